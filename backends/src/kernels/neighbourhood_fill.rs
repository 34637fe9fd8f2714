//! `neighbourhood.fill`: give pixels with no statistic of their own the average of their
//! neighbours' within a radius (thesis Sec. 3.6: unoccluded pixels take the averages of `d1`, `d2`
//! within a 5-pixel radius). Only neighbours on the same object (position `w`) count, as in the
//! filter: otherwise a bar's edge takes the ground's occluder distances. Input `value.w > 0` marks a
//! pixel that has its own statistic; output `w` is 1 for own, 2 for filled from neighbours, 0 for
//! neither (such pixels are not filtered).

use crate::kernel::{Kernel, KernelCtx, Reach, WgslSource};
use crate::kernels::filter_window::ScreenRadius;
use crate::params::KernelParams;
use crate::BackendError;

pub struct FillInvalid;

crate::kernel_params! {
    /// The neighbourhood's radius in pixels, clamped to `0..=64` when read (the filters' cap).
    pub struct FillParams {
        radius: ScreenRadius,
    }
}

crate::kernel_bindings! {
    /// What a `neighbourhood.fill` pass binds: the first pass's statistics (`w` > 0 where valid),
    /// the G-buffer position (same object test) and the filled statistics.
    pub struct FillIo / FillData {
        read value: [f32; 4], read position: [f32; 4], write out: [f32; 4],
    }
}

impl Kernel for FillInvalid {
    crate::kernel_signature!(name: "neighbourhood.fill", class: Bandwidth, bindings: FillIo, params: [FillParams]);
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/neighbourhood_fill.wgsl"), |ctx| {
                Ok(FillParams::read(ctx)?.uniforms())
            })
            .with_reach(|ctx| Ok(Reach::Rows(FillParams::read(ctx)?.radius.get() as u32))),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let FillData { value, position, out } = FillIo::read(ctx)?;
        let radius = FillParams::read(ctx)?.radius.get();
        let size = (ctx.width as i32, ctx.height as i32);
        // Per pixel, the object a neighbour must match: its own where it has a statistic, else NaN
        // (equal to nothing) — one test and one 4-byte read per tap instead of two tests on two
        // `vec4`s, the same decisions.
        let key: Vec<f32> = value.iter().zip(position).map(|(v, p)| if v[3] > 0.0 { p[3] } else { f32::NAN }).collect();
        let rows = disk_rows(radius);
        let filled = ctx.map_pixels(false, |x, y| fill_pixel((x as i32, y as i32), size, &rows, value, position, &key));
        out.put(ctx, filled)
    }
}

/// Half-width of each row `dy = −r..=r` of the disk of radius `r`: the `dx` with `dx² + dy² ≤ r²`.
fn disk_rows(r: i32) -> Vec<i32> {
    (-r..=r).map(|dy| (0..=r).take_while(|dx| dx * dx + dy * dy <= r * r).last().unwrap_or(0)).collect()
}

/// Pixel `(x, y)`'s output: its own statistic, or the mean of those on its object within the disk
/// (rows `rows`, [`disk_rows`]), visited in the WGSL mirror's order, row by row, so the sums agree
/// (here each row is clipped to the image once; the mirror tests each tap).
fn fill_pixel(
    (x, y): (i32, i32),
    (w, h): (i32, i32),
    rows: &[i32],
    value: &[[f32; 4]],
    position: &[[f32; 4]],
    key: &[f32],
) -> [f32; 4] {
    let i = (y * w + x) as usize;
    let v = value[i];
    if v[3] > 0.0 {
        return [v[0], v[1], v[2], 1.0];
    }
    let object = position[i][3];
    if object == 0.0 {
        return [0.0; 4];
    }
    let r = (rows.len() / 2) as i32;
    let mut sum = [0.0f32; 3];
    let mut n = 0u32;
    for (dy, &half) in (-r..).zip(rows) {
        let ny = y + dy;
        if ny < 0 || ny >= h {
            continue;
        }
        let (x0, x1) = ((x - half).max(0), (x + half).min(w - 1));
        let row = (ny * w) as usize;
        for j in row + x0 as usize..=row + x1 as usize {
            // Same object only, as the filter (a bar must not take the ground's d1, d2).
            if key[j] == object {
                for c in 0..3 {
                    sum[c] += value[j][c];
                }
                n += 1;
            }
        }
    }
    if n == 0 {
        [0.0; 4]
    } else {
        [sum[0] / n as f32, sum[1] / n as f32, sum[2] / n as f32, 2.0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disk_rows_hold_the_taps_of_the_disk() {
        for r in 0..=ScreenRadius::LIMIT as i32 {
            let rows = disk_rows(r);
            for dy in -r..=r {
                let taps: Vec<i32> = (-r..=r).filter(|dx| dx * dx + dy * dy <= r * r).collect();
                let half = rows[(dy + r) as usize];
                assert_eq!(taps, (-half..=half).collect::<Vec<_>>(), "r {r} dy {dy}");
            }
        }
    }
}
