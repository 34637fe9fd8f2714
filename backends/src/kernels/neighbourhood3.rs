//! `neighbourhood.max3` and `neighbourhood.median3`: the 3×3 neighbourhood filters of thesis Ch. 5
//! (Sec. 5.8, step 2: "We run a 3×3 max-filter on the ray counts, and a median filter on the
//! factorization flags, to reduce noise and artifacts"; the median's size is unstated, 3×3 is the
//! reading taken in `docs/EQUATIONS.md`).
//!
//! Both read one `u32` per pixel (`value`) and write one (`out`). Pixels outside the image repeat the
//! nearest edge pixel (clamp to edge), so every pixel sees nine values: the median of 0/1 flags is
//! their majority, and the max is the same as ignoring outside pixels. Integer-only, so both backends
//! agree bit for bit. WGSL: `shaders/neighbourhood3.wgsl` (one shader, `params.op` picks the filter).

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

/// Largest of the 3×3 window (edges clamped).
pub fn max3(value: &[u32], width: u32, height: u32, x: u32, y: u32) -> u32 {
    window(value, width as i32, height as i32, x as i32, y as i32).into_iter().max().unwrap_or(0)
}

/// Median (5th smallest) of the 3×3 window (edges clamped).
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

fn run(ctx: &mut KernelCtx<'_>, f: fn(&[u32], u32, u32, u32, u32) -> u32) -> Result<(), BackendError> {
    let Neighbourhood3Data { value, out } = Neighbourhood3Io::read(ctx)?;
    let (w, h) = (ctx.width, ctx.height);
    let result = ctx.map_pixels(false, |x, y| f(value, w, h, x, y));
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
        run(ctx, max3)
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
        run(ctx, median3)
    }
}
