//! Tiles: the apron a rectangle of the image must compute around itself so that its own pixels are
//! exactly the whole image's, derived from the schedule. Every pass declares how far it reads
//! ([`Kernel::reach`], the same declaration the wgpu backend splits bands by); a pixel of a pass's
//! output needs its inputs within that reach, so the apron of a chain is the sum of its reaches
//! (statistics → rates → adaptive sampling → filters), and the apron of a schedule the longest chain.
//! A pass that reads anywhere ([`Reach::Image`]) makes the schedule refuse tiles, naming it.

use crate::kernel::{Counters, Kernel, KernelCtx, Window};
use crate::{BackendError, Job};

/// Pixels of apron every tile of `job`'s schedule needs on each side (clipped to the image by the
/// caller), or why the schedule cannot be tiled: the first pass (in running order) that reads
/// anywhere in the image, with its node and kernel.
pub fn apron(job: &Job<'_>) -> Result<u32, BackendError> {
    let schedule = job.schedule;
    let reaches = pass_reaches(job)?;
    // need[b]: how far around a tile's pixels buffer b must be correct. Walking the passes backwards,
    // a pass's inputs must be correct its reach further out than the farthest of its outputs.
    let mut need = vec![0u64; schedule.buffers.len()];
    for (pass, reach) in schedule.passes.iter().zip(&reaches).rev() {
        let out = pass.writes.iter().map(|(_, id)| need[id.0]).max().unwrap_or(0);
        for (_, id) in &pass.reads {
            need[id.0] = need[id.0].max(out + u64::from(*reach));
        }
    }
    let apron = need.into_iter().max().unwrap_or(0);
    Ok(u32::try_from(apron).unwrap_or(u32::MAX))
}

/// Each pass's reach radius, in running order; the first pass that reads anywhere is an error.
fn pass_reaches(job: &Job<'_>) -> Result<Vec<u32>, BackendError> {
    let counters = Counters::default();
    job.schedule
        .passes
        .iter()
        .map(|pass| {
            let kernel = job.kernels.get(&pass.kernel).ok_or_else(|| BackendError::UnknownKernel {
                pass: pass.name.clone(),
                kernel: pass.kernel.clone(),
                known: job.kernels.names().collect::<Vec<_>>().join(", "),
            })?;
            let ctx = KernelCtx::for_pass(job, pass, &counters, Default::default(), Default::default());
            radius(kernel.as_ref(), &ctx, &pass.node)
        })
        .collect()
}

/// `kernel`'s reach radius for the pass in `ctx`, or the refusal naming its node.
fn radius(kernel: &dyn Kernel, ctx: &KernelCtx<'_>, node: &str) -> Result<u32, BackendError> {
    kernel.reach(ctx)?.radius().ok_or_else(|| BackendError::Kernel {
        pass: ctx.pass.to_string(),
        message: format!(
            "node `{node}` cannot be tiled: its kernel `{}` reads anywhere in the image (Reach::Image), so a tile \
             would not compute what the whole image computes; render this pipeline whole (without --tile)",
            kernel.name()
        ),
    })
}

/// `window` grown by `apron` pixels on every side, clipped to the full image: the rectangle a tile
/// computes (`x0, y0, width, height` in the full image).
pub fn grow(rect: (u32, u32, u32, u32), apron: u32, full: (u32, u32)) -> (u32, u32, u32, u32) {
    let (x, y, w, h) = rect;
    let x0 = x.saturating_sub(apron);
    let y0 = y.saturating_sub(apron);
    let x1 = x.saturating_add(w).saturating_add(apron).min(full.0);
    let y1 = y.saturating_add(h).saturating_add(apron).min(full.1);
    (x0, y0, x1 - x0, y1 - y0)
}

/// The [`Window`] of a grown rectangle in a `full` image.
pub fn window_of(grown: (u32, u32, u32, u32), full: (u32, u32)) -> Window {
    Window { x0: grown.0, y0: grown.1, full_width: full.0, full_height: full.1 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::Reach;

    #[test]
    fn grow_clips_to_the_image() {
        assert_eq!(grow((0, 0, 32, 24), 5, (64, 48)), (0, 0, 37, 29));
        assert_eq!(grow((32, 24, 32, 24), 5, (64, 48)), (27, 19, 37, 29));
        assert_eq!(grow((10, 10, 4, 4), 100, (64, 48)), (0, 0, 64, 48));
    }

    #[test]
    fn reach_radius_and_rows() {
        assert_eq!(Reach::Cols(3).radius(), Some(3));
        assert_eq!(Reach::Cols(3).rows(), Some(0));
        assert_eq!(Reach::Rows(2).radius(), Some(2));
        assert_eq!(Reach::Image.radius(), None);
    }
}
