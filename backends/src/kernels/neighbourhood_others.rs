//! `neighbourhood.others`: a pixel's first-pass distance statistics taken from its eight
//! neighbours on the same object, leaving its own samples out.
//!
//! Why: a node whose rates and filter width come from a pixel's own first-pass samples, and whose
//! estimate reuses those samples, correlates the estimate with its own weight. For ambient
//! occlusion (Ch. 4's `z_min`, `z_max`) a first pass that happened to hit something near gives the
//! pixel a higher value, a narrower filter and more rays, which dilute the lucky value: the
//! unfiltered image is biased low (−1.1% on `curved`), and a filter that weighs neighbours by their
//! own width carries that correlation into the mean (docs/DESIGN-NOTES.md "AO: the mean"). With the
//! statistics from the neighbours only, a pixel's count and width are independent of its own samples.
//!
//! Layout (the Indirect first pass's `depth`): `x` a minimum, `y` a maximum (both valid where
//! `z > 0`), `z` a count (hits), `w > 0` marks a pixel with samples. Output: `x`, `y` = the means of
//! the neighbours' `x`, `y` over those with `z > 0` (each neighbour's is the same statistic of as
//! many rays as the pixel's own, so the rates keep their scale; the min over all eight would be
//! the statistic of 8× the rays, measured: +50% rays on `curved`), `z` = the sum of their `z`, `w` =
//! the pixel's own. Only neighbours with `w > 0` on the pixel's object (position `w`) count; a pixel
//! with none keeps its own statistics. Sums in a fixed order: both backends agree bit for bit.
//! WGSL: `shaders/neighbourhood_others.wgsl`.

use rayon::prelude::*;

use crate::kernel::{Kernel, KernelCtx, Reach, Uniforms, WgslSource};
use crate::BackendError;

/// `neighbourhood.others` (module doc).
pub struct Others;

/// A pixel's eight neighbours `(dx, dy)` in their fixed order (rows, then columns; the pixel itself
/// left out): the order every sum over them takes, here and in the WGSL's loops.
const NEIGHBOURS: [(i32, i32); 8] = [(-1, -1), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1), (1, 1)];

/// The indices of pixel `(x, y)`'s eight neighbours inside the `w × h` image that lie on its object
/// (position `w`), in the order of [`NEIGHBOURS`]: the neighbourhood `others` and the Indirect
/// node's `nearest` read (WGSL: `same_object_neighbour` in common.wgsl).
pub fn same_object_neighbours(
    position: &[[f32; 4]],
    w: i32,
    h: i32,
    x: i32,
    y: i32,
) -> impl Iterator<Item = usize> + '_ {
    let object = position[(y * w + x) as usize][3];
    NEIGHBOURS
        .into_iter()
        .map(move |(dx, dy)| (x + dx, y + dy))
        .filter(move |&(nx, ny)| nx >= 0 && ny >= 0 && nx < w && ny < h)
        .map(move |(nx, ny)| (ny * w + nx) as usize)
        .filter(move |&j| position[j][3] == object)
}

/// The WGSL mirror of [`same_object_neighbours`] (name, source), for `WgslSource::with_include`.
pub const SAME_OBJECT_NEIGHBOUR: (&str, &str) =
    ("same_object_neighbour.wgsl", include_str!("../../../shaders/same_object_neighbour.wgsl"));

/// The statistics of pixel `(x, y)` from its neighbours (module doc).
pub fn others(value: &[[f32; 4]], position: &[[f32; 4]], w: i32, h: i32, x: i32, y: i32) -> [f32; 4] {
    let i = (y * w + x) as usize;
    let mut sums = OthersSums::default();
    if value[i][3] > 0.0 {
        for j in same_object_neighbours(position, w, h, x, y) {
            sums.add(value[j]);
        }
    }
    sums.statistics(value[i])
}

/// The sums [`others`] takes over a pixel's neighbours, in their fixed order.
#[derive(Default)]
struct OthersSums {
    min_sum: f32,
    max_sum: f32,
    hits: f32,
    /// Neighbours with samples (`w > 0`).
    n: u32,
    /// Of those, the ones with hits (`z > 0`).
    with_hits: u32,
}

impl OthersSums {
    /// Add one neighbour on the pixel's object (one without samples adds nothing).
    #[inline(always)]
    fn add(&mut self, v: [f32; 4]) {
        if v[3] > 0.0 {
            self.n += 1;
            if v[2] > 0.0 {
                self.min_sum += v[0];
                self.max_sum += v[1];
                self.hits += v[2];
                self.with_hits += 1;
            }
        }
    }

    /// The pixel's output from its own statistics `own` and these sums (module doc).
    fn statistics(&self, own: [f32; 4]) -> [f32; 4] {
        if !(own[3] > 0.0) || self.n == 0 {
            own
        } else if self.hits > 0.0 {
            [self.min_sum / self.with_hits as f32, self.max_sum / self.with_hits as f32, self.hits, own[3]]
        } else {
            [0.0, 0.0, 0.0, own[3]]
        }
    }
}

/// Row `y` of the pass: [`others`] for each pixel, the interior read through fixed index offsets
/// (from [`NEIGHBOURS`], so the same neighbours in the same order: the same bits) and the two edge
/// pixels, like every pixel of the first and last rows, through [`others`] itself.
fn others_row(value: &[[f32; 4]], position: &[[f32; 4]], w: i32, h: i32, y: i32, out: &mut [[f32; 4]]) {
    let edge = |x: i32| others(value, position, w, h, x, y);
    if y == 0 || y == h - 1 || w < 3 {
        out.iter_mut().enumerate().for_each(|(x, o)| *o = edge(x as i32));
        return;
    }
    let wu = w as usize;
    let offsets = NEIGHBOURS.map(|(dx, dy)| dy as isize * wu as isize + dx as isize);
    let row = y as usize * wu;
    for (x, o) in out.iter_mut().enumerate().take(wu - 1).skip(1) {
        let i = row + x;
        let mut sums = OthersSums::default();
        if value[i][3] > 0.0 {
            let object = position[i][3];
            for offset in offsets {
                let j = i.wrapping_add_signed(offset);
                if position[j][3] == object {
                    sums.add(value[j]);
                }
            }
        }
        *o = sums.statistics(value[i]);
    }
    out[0] = edge(0);
    out[wu - 1] = edge(w - 1);
}

crate::kernel_bindings! {
    /// What a `neighbourhood.others` pass binds: each pixel's own statistics, the G-buffer
    /// position and the eight neighbours' statistics.
    pub struct OthersIo / OthersData {
        read value: [f32; 4], read position: [f32; 4], write out: [f32; 4],
    }
}

impl Kernel for Others {
    crate::kernel_signature!(name: "neighbourhood.others", class: Bandwidth, bindings: OthersIo);
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/neighbourhood_others.wgsl"), |_| Ok(Uniforms::new()))
                .with_include(SAME_OBJECT_NEIGHBOUR.0, SAME_OBJECT_NEIGHBOUR.1)
                .with_reach(|_| Ok(Reach::Rows(1))),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let OthersData { value, position, out } = OthersIo::read(ctx)?;
        let (w, h) = (ctx.width as i32, ctx.height as i32);
        let mut gathered = out.storage(ctx)?;
        gathered
            // (`max(1)`: chunks of an empty image's empty buffer.)
            .par_chunks_mut((w as usize).max(1))
            .enumerate()
            .for_each(|(y, row)| others_row(value, position, w, h, y as i32, row));
        out.put(ctx, gathered)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pixel_takes_its_neighbours_statistics_not_its_own() {
        // 3×3 image on one object; the centre saw a near hit (0.1) that no neighbour saw.
        let mut value = vec![[1.0, 2.0, 4.0, 16.0]; 9];
        value[4] = [0.1, 3.0, 9.0, 16.0];
        value[0] = [0.5, 1.0, 2.0, 16.0];
        value[8] = [0.0, 0.0, 0.0, 16.0]; // no hits: does not enter min/max
        let position = vec![[0.0, 0.0, 0.0, 1.0]; 9];
        // Seven neighbours with hits: means (0.5 + 6·1)/7, (1 + 6·2)/7; hits 2 + 6·4.
        let c = others(&value, &position, 3, 3, 1, 1);
        assert_eq!(c[2..], [26.0, 16.0]);
        assert!((c[0] - 6.5 / 7.0).abs() < 1e-6 && (c[1] - 13.0 / 7.0).abs() < 1e-6, "{c:?}");
        // A corner pixel sees the centre's near hit among its three neighbours: (0.1 + 1 + 1)/3.
        assert!((others(&value, &position, 3, 3, 0, 0)[0] - 2.1 / 3.0).abs() < 1e-6);
        // Another object's pixels do not count; with no neighbour left the pixel keeps its own.
        let mut position = position;
        for (k, p) in position.iter_mut().enumerate() {
            p[3] = if k == 4 { 2.0 } else { 1.0 };
        }
        assert_eq!(others(&value, &position, 3, 3, 1, 1), value[4]);
        // Neighbours with samples but no hits: no hits.
        let value = vec![[0.0, 0.0, 0.0, 16.0]; 9];
        let position = vec![[0.0, 0.0, 0.0, 1.0]; 9];
        assert_eq!(others(&value, &position, 3, 3, 1, 1), [0.0, 0.0, 0.0, 16.0]);
    }

    /// The pass's rows (fixed offsets in the interior) give [`others`]' bits at every pixel: three
    /// objects, pixels without samples, neighbours without hits, and images one or two pixels thin.
    #[test]
    fn the_rows_are_the_per_pixel_statistics() {
        for (w, h) in [(13, 9), (1, 5), (2, 2), (7, 1)] {
            let n = (w * h) as usize;
            let hash = |k: usize, salt: u32| ((k as u32).wrapping_mul(2_654_435_761) ^ salt).wrapping_mul(40_503) >> 16;
            let value: Vec<[f32; 4]> = (0..n)
                .map(|k| {
                    let r = hash(k, 7) as f32 / 65_536.0;
                    let hits = if hash(k, 3) % 4 == 0 { 0.0 } else { (hash(k, 5) % 9) as f32 };
                    let samples = if hash(k, 11) % 5 == 0 { 0.0 } else { 16.0 };
                    [r, r + 0.5, hits, samples]
                })
                .collect();
            let position: Vec<[f32; 4]> = (0..n).map(|k| [0.0, 0.0, 0.0, (hash(k, 13) % 3) as f32]).collect();
            for y in 0..h {
                let mut row = vec![[0.0; 4]; w as usize];
                others_row(&value, &position, w, h, y, &mut row);
                for (x, got) in row.iter().enumerate() {
                    let want = others(&value, &position, w, h, x as i32, y);
                    assert_eq!(got.map(f32::to_bits), want.map(f32::to_bits), "({x}, {y}) of {w}x{h}");
                }
            }
        }
    }
}
