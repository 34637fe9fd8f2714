//! `neighbourhood.max3` and `neighbourhood.median3`: the 3×3 neighbourhood filters of thesis Ch. 5
//! (Sec. 5.8, step 2: "We run a 3×3 max-filter on the ray counts, and a median filter on the
//! factorization flags, to reduce noise and artifacts"; the median's size is unstated, 3×3 is the
//! reading taken in `docs/EQUATIONS.md`).
//!
//! Both read one `u32` per pixel (`value`) and write one (`out`). Pixels outside the image repeat the
//! nearest edge pixel (clamp to edge), so every pixel sees nine values: the median of 0/1 flags is
//! their majority, and the max is the same as ignoring outside pixels. Integer-only, so both backends
//! agree bit for bit. WGSL: `shaders/neighbourhood3.wgsl` (one shader, `params.op` picks the filter).

use rayon::prelude::*;

use crate::kernel::{Kernel, KernelCtx, Reach, Uniforms, WgslSource};
use crate::BackendError;

/// The nine values around `(x, y)`, edges clamped, row by row.
fn window(value: &[u32], w: i32, h: i32, x: i32, y: i32) -> [u32; 9] {
    let mut v = [0u32; 9];
    let mut k = 0;
    for dy in -1..=1 {
        for dx in -1..=1 {
            let nx = (x + dx).clamp(0, w - 1);
            let ny = (y + dy).clamp(0, h - 1);
            v[k] = value[(ny * w + nx) as usize];
            k += 1;
        }
    }
    v
}

/// Largest of the 3×3 window (edges clamped): the pass's reference, pixel by pixel.
pub fn max3(value: &[u32], width: u32, height: u32, x: u32, y: u32) -> u32 {
    window(value, width as i32, height as i32, x as i32, y as i32).into_iter().max().unwrap_or(0)
}

/// Median (5th smallest) of the 3×3 window (edges clamped): the pass's reference, pixel by pixel.
pub fn median3(value: &[u32], width: u32, height: u32, x: u32, y: u32) -> u32 {
    let mut v = window(value, width as i32, height as i32, x as i32, y as i32);
    v.sort_unstable();
    v[4]
}

fn wgsl_with_op(op: u32) -> WgslSource {
    let uniforms: fn(&KernelCtx<'_>) -> Result<Uniforms, BackendError> = match op {
        0 => |_| Ok(Uniforms::new().u32("op", 0)),
        _ => |_| Ok(Uniforms::new().u32("op", 1)),
    };
    WgslSource::new(include_str!("../../../shaders/neighbourhood3.wgsl"), uniforms).with_reach(|_| Ok(Reach::Rows(1)))
}

crate::kernel_bindings! {
    /// What a `neighbourhood.max3` / `neighbourhood.median3` pass binds.
    pub struct Neighbourhood3Io / Neighbourhood3Data {
        read value: u32, write out: u32,
    }
}

/// Which 3×3 filter a pass runs, row by row: each row's three source rows (edges clamped) are
/// reduced per column first (max; or sorted into low, middle, high), then across the three columns
/// (edges clamped). The same values as [`max3`] and [`median3`] pixel by pixel, without gathering
/// and sorting nine values per pixel.
#[derive(Clone, Copy)]
enum Op {
    Max,
    Median,
}

/// Row `y` of `op` over the `w`-wide image `value` of `h` rows, into `out`.
fn filter_row(op: Op, value: &[u32], w: usize, h: usize, y: usize, out: &mut [u32]) {
    let row = |r: usize| &value[r * w..(r + 1) * w];
    let (above, here, below) = (row(y.saturating_sub(1)), row(y), row((y + 1).min(h - 1)));
    // The columns either side of `x`, clamped to the image.
    let sides = |x: usize| (x.saturating_sub(1), (x + 1).min(w - 1));
    match op {
        Op::Max => {
            let column: Vec<u32> = (0..w).map(|x| above[x].max(here[x]).max(below[x])).collect();
            for (x, o) in out.iter_mut().enumerate() {
                let (l, r) = sides(x);
                *o = column[l].max(column[x]).max(column[r]);
            }
        }
        Op::Median => {
            // The median of nine is the median of (the largest low, the median middle, the
            // smallest high) of its three sorted columns (Paeth, Graphics Gems I).
            let column: Vec<[u32; 3]> = (0..w).map(|x| sort3(above[x], here[x], below[x])).collect();
            for (x, o) in out.iter_mut().enumerate() {
                let (l, r) = sides(x);
                let (a, b, c) = (column[l], column[x], column[r]);
                let low = a[0].max(b[0]).max(c[0]);
                let high = a[2].min(b[2]).min(c[2]);
                *o = sort3(low, sort3(a[1], b[1], c[1])[1], high)[1];
            }
        }
    }
}

/// `a`, `b`, `c` in ascending order.
#[inline(always)]
fn sort3(a: u32, b: u32, c: u32) -> [u32; 3] {
    let (a, b) = (a.min(b), a.max(b));
    let (b, c) = (b.min(c), b.max(c));
    let (a, b) = (a.min(b), a.max(b));
    [a, b, c]
}

fn run(ctx: &mut KernelCtx<'_>, op: Op) -> Result<(), BackendError> {
    let Neighbourhood3Data { value, out } = Neighbourhood3Io::read(ctx)?;
    let (w, h) = (ctx.width as usize, ctx.height as usize);
    let mut result = out.storage(ctx)?;
    // (`max(1)`: chunks of an empty image's empty buffer.)
    result.par_chunks_mut(w.max(1)).enumerate().for_each(|(y, row)| filter_row(op, value, w, h, y, row));
    out.put(ctx, result)
}

/// `neighbourhood.max3`: 3×3 max on per-pixel ray counts (thesis Sec. 5.8, step 2).
pub struct Max3;

impl Kernel for Max3 {
    crate::kernel_signature!(name: "neighbourhood.max3", class: Bandwidth, bindings: Neighbourhood3Io);
    fn wgsl(&self) -> Option<WgslSource> {
        Some(wgsl_with_op(0))
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        run(ctx, Op::Max)
    }
}

/// `neighbourhood.median3`: 3×3 median on per-pixel flags (thesis Sec. 5.8, step 2).
pub struct Median3;

impl Kernel for Median3 {
    crate::kernel_signature!(name: "neighbourhood.median3", class: Bandwidth, bindings: Neighbourhood3Io);
    fn wgsl(&self) -> Option<WgslSource> {
        Some(wgsl_with_op(1))
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        run(ctx, Op::Median)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every row of both passes gives the per-pixel window's max and median: random values, every
    /// 0/1 window (the flags' case), and images one or two pixels thin (where the clamps overlap).
    #[test]
    fn the_rows_are_the_per_pixel_windows() {
        let mut state = 0x9e37_79b9u32;
        let mut next = |range: u32| {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state % range
        };
        for (w, h, range) in [(11, 7, 1000), (11, 7, 2), (1, 6, 5), (2, 2, 3), (9, 1, 4), (3, 3, 2)] {
            for _ in 0..200 {
                let value: Vec<u32> = (0..w * h).map(|_| next(range)).collect();
                for y in 0..h {
                    for (op, reference) in
                        [(Op::Max, max3 as fn(&[u32], u32, u32, u32, u32) -> u32), (Op::Median, median3)]
                    {
                        let mut row = vec![0; w];
                        filter_row(op, &value, w, h, y, &mut row);
                        for (x, got) in row.into_iter().enumerate() {
                            assert_eq!(got, reference(&value, w as u32, h as u32, x as u32, y as u32), "({x}, {y})");
                        }
                    }
                }
            }
        }
    }
}
