//! The image filters of thesis App. B (motion blur, `seeds/000_956e982470d7e5bf.txt` Appendix B):
//!
//! - `filter.motion`: a 1-D Gaussian in image space **oriented along a velocity** (eqs. B.1, B.2:
//!   "these filters are 1-D Gaussians in image space, oriented in the direction of the velocity v").
//!   Pixel `i` with velocity `v_i` (pixels per half shutter) and width `Ω_i` (pixel⁻¹, μ-scaled)
//!   averages the pixels met at unit steps along `v̂_i`, `j(k) = ⌊i + ½ + k v̂_i⌋` for `|k| ≤ R`, with
//!   the weight of the Ch. 5 filters `exp(−16 k² Ω_i²)` and their rejection (neighbour `j` is dropped
//!   when `exp(−16 k² Ω_j²) < 0.01`, `i` outside `j`'s own filter: [`wedge_backends::kernels::filter_window`]). A
//!   neighbour is also dropped when it has no filter of its own (`Ω_j` not a valid width: a static
//!   or a multi-velocity pixel — so sharp regions never bleed into blurred ones) or moves with another
//!   velocity ([`same_velocity`]). Pixels without a valid width are passed through: the node writes
//!   none where `v = 0`, since eq. B.1 alone would still blur at `Ω_pix^max` (docs/EQUATIONS.md reading).
//!   The thesis applies it to texture (`v_p`, B.1) and to direct irradiance (`v_s`, B.2) separately.
//! - `filter.radiance3`: the "small 3×3 pixel-wide filter" App. B applies to the radiance of pixels
//!   that see two or more velocities (not factored), at pixels whose `mask` is set (elsewhere the
//!   value passes through): a 1-2-1 tent over the 3×3 neighbourhood of the finite values (the thesis),
//!   or, with `velocity` bound, a 1-2-1 filter over the pixel and its two neighbours along its mean
//!   velocity that are masked too. Why the second: such pixels sit on motion-blurred silhouettes,
//!   smooth along the motion but sharp across it (a static edge behind a moving object), and the 3×3
//!   tent mixes across those edges; measured on `motion` in DESIGN-NOTES, section Motion.
//!
//! Window: `R = ⌈0.5365/Ω_i⌉` (where the weight reaches 0.01), capped at `max_radius` (≤ 64). Non-finite
//! values are never used as neighbours; each pixel whose own value is non-finite is counted once in
//! `non_finite_samples` and gets its neighbours' average if it has any (never spread). WGSL mirrors:
//! `shaders/filter_motion.wgsl`, `shaders/filter_radiance3.wgsl`, term by term in the same order.

use glam::Vec2;

use wedge_backends::kernels::filter_window::{pair_weight, valid_width, window_radius, WindowParams};
use wedge_backends::kernels::{all_positive_zero, count_non_finite, is_finite3};
use wedge_backends::{BackendError, Kernel, KernelCtx, KernelParams, Reach, Uniforms, WgslSource};

/// Two velocities (pixels per half shutter) are the same motion when they differ by at most
/// `VELOCITY_TOLERANCE_PX + VELOCITY_TOLERANCE_REL · max(|a|, |b|)`: half a pixel of blur length
/// apart, or a quarter of the faster one (a rotating object's velocity varies across a pixel's
/// footprint over the shutter; a reading — the thesis counts "distinct velocities" without a rule).
pub const VELOCITY_TOLERANCE_PX: f32 = 0.5;
pub const VELOCITY_TOLERANCE_REL: f32 = 0.25;

/// The tolerance for velocities of magnitude up to `speed` (WGSL: `shaders/velocity.wgsl`, which
/// repeats the two constants).
pub fn velocity_tolerance(speed: f32) -> f32 {
    VELOCITY_TOLERANCE_PX + VELOCITY_TOLERANCE_REL * speed
}

/// Whether `a` and `b` are the same motion (see [`VELOCITY_TOLERANCE_PX`]); false for NaN.
pub fn same_velocity(a: [f32; 2], b: [f32; 2]) -> bool {
    let (a, b) = (Vec2::from(a), Vec2::from(b));
    let tol = velocity_tolerance(a.length().max(b.length()));
    (a - b).length_squared() <= tol * tol
}

/// The unit direction of `v`, or `None` for a zero or non-finite velocity.
fn direction(v: [f32; 2]) -> Option<[f32; 2]> {
    let len = (v[0] * v[0] + v[1] * v[1]).sqrt();
    (len > 0.0 && len.is_finite()).then(|| [v[0] / len, v[1] / len])
}

/// Pixel `k` steps from `(x, y)` along the unit direction `d`: `⌊x + ½ + k·d⌋` per axis.
fn step(x: i32, y: i32, k: i32, d: [f32; 2]) -> (i32, i32) {
    let kf = k as f32;
    ((x as f32 + 0.5 + kf * d[0]).floor() as i32, (y as f32 + 0.5 + kf * d[1]).floor() as i32)
}

/// `filter.motion` at pixel `(x, y)`; `motion[i]` = (v_x, v_y, Ω, unused).
pub fn motion_pixel(
    x: i32,
    y: i32,
    width: i32,
    height: i32,
    max_radius: i32,
    value: &[[f32; 3]],
    motion: &[[f32; 4]],
) -> [f32; 3] {
    let i = (y * width + x) as usize;
    let centre = value[i];
    let (vi, om) = ([motion[i][0], motion[i][1]], motion[i][2]);
    let Some(d) = direction(vi).filter(|_| valid_width(om)) else {
        return centre;
    };
    let gi2 = om * om;
    let r = window_radius(om, max_radius);
    let mut sum = [0.0f32; 3];
    let mut wsum = 0.0f32;
    for k in -r..=r {
        let (jx, jy) = step(x, y, k, d);
        if jx < 0 || jy < 0 || jx >= width || jy >= height {
            continue;
        }
        let j = (jy * width + jx) as usize;
        let v = value[j];
        let (vj, oj) = ([motion[j][0], motion[j][1]], motion[j][2]);
        if !is_finite3(v) || !valid_width(oj) || !same_velocity(vi, vj) {
            continue;
        }
        let Some(w) = pair_weight((k * k) as f32, gi2, oj * oj) else { continue };
        for c in 0..3 {
            sum[c] += w * v[c];
        }
        wsum += w;
    }
    if wsum > 0.0 {
        [sum[0] / wsum, sum[1] / wsum, sum[2] / wsum]
    } else {
        centre
    }
}

/// `filter.radiance3` at pixel `(x, y)`: the 3×3 tent, or with `velocity` the 1-2-1 filter along it.
pub fn radiance3_pixel(
    x: i32,
    y: i32,
    width: i32,
    height: i32,
    value: &[[f32; 3]],
    mask: &[u32],
    velocity: Option<&[[f32; 4]]>,
) -> [f32; 3] {
    let i = (y * width + x) as usize;
    if mask[i] == 0 {
        return value[i];
    }
    let mut sum = [0.0f32; 3];
    let mut wsum = 0.0f32;
    let mut tap = |jx: i32, jy: i32, w: f32, masked_only: bool| {
        if jx < 0 || jy < 0 || jx >= width || jy >= height {
            return;
        }
        let j = (jy * width + jx) as usize;
        let v = value[j];
        if !is_finite3(v) || (masked_only && mask[j] == 0) {
            return;
        }
        for c in 0..3 {
            sum[c] += w * v[c];
        }
        wsum += w;
    };
    match velocity {
        None => {
            for dy in -1..=1i32 {
                for dx in -1..=1i32 {
                    tap(x + dx, y + dy, ((2 - dx.abs()) * (2 - dy.abs())) as f32, false);
                }
            }
        }
        Some(v) => {
            tap(x, y, 2.0, false);
            if let Some(d) = direction([v[i][0], v[i][1]]) {
                for k in [-1, 1] {
                    let (jx, jy) = step(x, y, k, d);
                    tap(jx, jy, 1.0, true);
                }
            }
        }
    }
    if wsum > 0.0 {
        [sum[0] / wsum, sum[1] / wsum, sum[2] / wsum]
    } else {
        value[i]
    }
}

wedge_backends::kernel_bindings! {
    /// What a `filter.motion` pass binds: the radiance, the motion (direction and width) and the
    /// filtered radiance.
    pub struct MotionFilterIo / MotionFilterData {
        read value: [f32; 3], read motion: [f32; 4], write out: [f32; 3],
    }
}

wedge_backends::kernel_bindings! {
    /// What a `filter.radiance3` pass binds.
    pub struct Radiance3Io / Radiance3Data {
        read value: [f32; 3], read mask: u32,
        /// A velocity per pixel (x, y used): filter along it instead of over 3×3.
        read_opt velocity: [f32; 4],
        write out: [f32; 3],
    }
}

/// `filter.motion`: the oriented 1-D Gaussian of eqs. B.1 / B.2 (module doc).
pub struct MotionFilter;

impl Kernel for MotionFilter {
    wedge_backends::kernel_signature!(
        name: "filter.motion", class: Filter, bindings: MotionFilterIo, params: [WindowParams]
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/filter_motion.wgsl"), |ctx| {
                Ok(WindowParams::read(ctx)?.uniforms())
            })
            .with_include("filter_window.wgsl", include_str!("../../../../shaders/filter_window.wgsl"))
            .with_include("velocity.wgsl", include_str!("../../../../shaders/velocity.wgsl"))
            .with_reach(|ctx| Ok(Reach::Rows(WindowParams::read(ctx)?.max_radius.get() as u32))),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let MotionFilterData { value, motion, out } = MotionFilterIo::read(ctx)?;
        let r = WindowParams::read(ctx)?.max_radius.get();
        count_non_finite(ctx, value);
        if all_positive_zero(value) {
            return out.put(ctx, value.to_vec());
        }
        let (w, h) = (ctx.width as i32, ctx.height as i32);
        let filtered = ctx.map_pixels(false, |x, y| motion_pixel(x as i32, y as i32, w, h, r, value, motion));
        out.put(ctx, filtered)
    }
}

/// `filter.radiance3`: the 3×3 radiance filter of App. B at masked (multi-velocity) pixels.
pub struct Radiance3Filter;

impl Kernel for Radiance3Filter {
    wedge_backends::kernel_signature!(name: "filter.radiance3", class: Filter, bindings: Radiance3Io);
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/filter_radiance3.wgsl"), |_| Ok(Uniforms::new()))
                .with_include("velocity.wgsl", include_str!("../../../../shaders/velocity.wgsl"))
                .with_reach(|_| Ok(Reach::Rows(1))),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let Radiance3Data { value, mask, velocity, out } = Radiance3Io::read(ctx)?;
        count_non_finite(ctx, value);
        let (w, h) = (ctx.width as i32, ctx.height as i32);
        let filtered = ctx.map_pixels(false, |x, y| radiance3_pixel(x as i32, y as i32, w, h, value, mask, velocity));
        out.put(ctx, filtered)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn velocities_match_within_the_tolerance() {
        assert!(same_velocity([10.0, 0.0], [10.4, 0.0]));
        assert!(same_velocity([10.0, 0.0], [12.9, 0.0])); // 0.5 + 0.25·12.9 = 3.73
        assert!(!same_velocity([10.0, 0.0], [14.5, 0.0])); // 0.5 + 0.25·14.5 = 4.125 < 4.5
        assert!(!same_velocity([0.0, 0.0], [0.7, 0.0])); // 0.5 + 0.25·0.7 = 0.675
        assert!(!same_velocity([f32::NAN, 0.0], [0.0, 0.0]));
    }

    #[test]
    fn a_horizontal_motion_filters_along_its_row_only() {
        // 9×3 image; the middle row moves along +x; a vertical stripe pattern everywhere.
        let (w, h) = (9, 3);
        let value: Vec<[f32; 3]> = (0..w * h).map(|i| [(i % w) as f32, (i / w) as f32 * 100.0, 0.0]).collect();
        let mut motion = vec![[0.0f32; 4]; (w * h) as usize];
        for x in 0..w {
            motion[(w + x) as usize] = [4.0, 0.0, 0.25, 0.0];
        }
        let out = motion_pixel(4, 1, w, h, 16, &value, &motion);
        // Only row 1 contributes (the y channel is 100 there), symmetric about x = 4.
        assert!((out[1] - 100.0).abs() < 1e-4);
        assert!((out[0] - 4.0).abs() < 1e-5);
        // A static pixel is not filtered.
        assert_eq!(motion_pixel(4, 0, w, h, 16, &value, &motion), value[4]);
    }

    #[test]
    fn the_tent_filter_only_touches_masked_pixels() {
        let value: Vec<[f32; 3]> = (0..9).map(|i| [i as f32; 3]).collect();
        let mut mask = vec![0u32; 9];
        mask[4] = 1;
        assert_eq!(radiance3_pixel(0, 0, 3, 3, &value, &mask, None), value[0]);
        assert_eq!(radiance3_pixel(1, 1, 3, 3, &value, &mask, None), [4.0; 3]);
        // Along a horizontal velocity, only masked neighbours: pixel 3 is not masked, 5 is.
        mask[5] = 1;
        let v = vec![[2.0f32, 0.0, 0.0, 0.0]; 9];
        assert_eq!(radiance3_pixel(1, 1, 3, 3, &value, &mask, Some(&v)), [(2.0 * 4.0 + 5.0) / 3.0; 3]);
    }
}
