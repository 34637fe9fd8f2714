//! The two image filters of thesis Ch. 5 (Sec. 5.8, steps 3–4). The reference is 2-D (`axis = -1`,
//! the default): the rejection of neighbour `j` uses `j`'s own width, so no X/Y split is exact. A pass
//! with `axis = 0` or `1` runs the same weights along one image axis only; an X pass followed by a Y
//! pass is the separable approximation, O(R) instead of O(R²) taps per pixel, validated against the
//! 2-D filter in `tests/defocus_filters.rs` (see there for the measured difference).
//!
//! - `filter.irradiance` (eq. 5.31) filters factored irradiance `E` with
//!   `w_i(j) = exp(−16 ‖λ(i) − λ(j)‖² (Ω(i)/ℓ_p(i))²)` on lens-averaged world positions `λ`, with
//!   `Ω = Ω_x^s` (direct) or `Ω_x^i` (indirect) and `ℓ_p` converting it to metres. Neighbours whose
//!   (lens-averaged, normalised) normals differ by more than the normal test allows (thesis: 10°) are
//!   not used.
//! - `filter.defocus` (eq. 5.33) filters the composed radiance with the screen-space, pixel-distance
//!   Gaussian `w_i(j) = exp(−16 |i − j|² Ω_x^d(i)²)` (`|i − j|` the Euclidean pixel distance; σ =
//!   0.177/Ω px). No geometry test: defocus blur crosses object boundaries.
//!
//! In both, neighbour `j` is rejected when `w_j(i) < 0.01` — `i` outside `j`'s own filter (thesis:
//! "mitigates errors due to noisy estimation of filter radii, and prevents bleeding of sharp regions
//! into blurry regions"). Both tests are made on the exponent, `16 d² (Ω/ℓ)² > ln 100`, which is the
//! same condition without rounding `exp` (so the backends take identical decisions).
//!
//! Window: pixel `i` uses the neighbours with `w_i(j) ≥ 0.01` — its Gaussian truncated at the same
//! threshold as the rejection, i.e. within `0.5365/Ω(i)` pixels — inside a square of half-width
//! `ceil(0.5365/Ω(i))` capped at the pass's `max_radius` (at most 64; 16 suggested: 33×33 = 1089
//! taps per pixel in 2-D, short fixed loops for GL/lavapipe). For the irradiance filter the pixel bound assumes
//! `‖λ(i) − λ(j)‖ ≥ ℓ_p(i) |i − j|` (true on a surface facing the camera; slanted surfaces are
//! farther apart). A cap that binds (`Ω < 0.5365/max_radius`: circles of confusion above ~30 px at
//! the default) truncates the Gaussian there.
//!
//! Pass-through pixels (output = input): width not finite or ≤ 0, and for the irradiance filter
//! `ℓ_p` not finite or ≤ 0, no hit (`position.w ≤ 0`) or a zero normal. Non-finite values are never
//! used as neighbours; each pixel whose own value is non-finite is counted once in
//! `non_finite_samples`, and gets its neighbours' average if it has any (else it keeps its value: it is
//! never spread). Values are rgb (`vec3`), as `paths.resolve` writes `E` and compose writes radiance.

use glam::Vec3;
use wedge_graph::Format;

use crate::kernel::{Binding, Kernel, KernelClass, KernelCtx, Reach, Uniforms, WgslSource};
use crate::kernels::{count_non_finite, is_finite3, v3};
use crate::BackendError;

/// The constant 16 of eqs. 5.31 and 5.33.
pub const FILTER_SHARPNESS: f32 = 16.0;
/// Neighbour rejection threshold `w_j(i) < 0.01` (Sec. 5.8).
pub const REJECT_WEIGHT: f32 = 0.01;
/// `ln(1/REJECT_WEIGHT)`: the exponent at which a weight reaches the threshold.
pub const REJECT_EXPONENT: f32 = 4.605_170_2;
/// `sqrt(ln 100 / 16)`: the pixel distance at which `exp(−16 d² Ω²) = 0.01` for `Ω = 1`.
pub const REJECT_RADIUS: f32 = 0.536_491_5;
/// Largest `max_radius` a pass may ask for.
pub const MAX_RADIUS_LIMIT: i64 = 64;

/// Half-width in pixels of the square window for width `omega`: `ceil(0.5365/Ω)`, at most `cap`.
pub fn window_radius(omega: f32, cap: i32) -> i32 {
    let r = REJECT_RADIUS / omega;
    if r.is_nan() || r >= cap as f32 {
        cap
    } else {
        (r.ceil() as i32).max(0)
    }
}

/// Whether a weight exponent `16 d² (Ω/ℓ)²` keeps the weight at or above 0.01 (false for NaN).
fn within_filter(exponent: f32) -> bool {
    exponent <= REJECT_EXPONENT
}

/// The weight `w_i(j) = exp(−16 d² g_i²)` of neighbour `j` at squared distance `d2` (eqs. 5.31,
/// 5.33; `g = Ω`, or `Ω/ℓ_p` for the irradiance filter), or `None` where `j` is rejected: outside
/// `i`'s truncated Gaussian (`w_i(j) < 0.01`) or `i` outside `j`'s filter (`w_j(i) < 0.01`, thesis
/// Sec. 5.8). WGSL: `pair_weight` in filter_ch5_window.wgsl (0 for a rejection).
pub(crate) fn pair_weight(d2: f32, gi2: f32, gj2: f32) -> Option<f32> {
    let e_i = FILTER_SHARPNESS * d2 * gi2;
    let e_j = FILTER_SHARPNESS * d2 * gj2;
    (within_filter(e_i) && within_filter(e_j)).then(|| (-e_i).exp())
}

/// Whether a pixel's primary rays hit geometry (`position.w > 0`; false for NaN).
fn is_hit(position: [f32; 4]) -> bool {
    position[3] > 0.0
}

fn valid_width(w: f32) -> bool {
    w > 0.0 && w.is_finite()
}

/// Which neighbours a pass visits: the 2-D window, or one axis of it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    Both,
    X,
    Y,
}

impl Axis {
    /// The pass parameter: -1 (or absent) 2-D, 0 along x, 1 along y.
    pub fn from_param(v: i64) -> Option<Axis> {
        match v {
            -1 => Some(Axis::Both),
            0 => Some(Axis::X),
            1 => Some(Axis::Y),
            _ => None,
        }
    }
    pub fn code(self) -> i32 {
        match self {
            Axis::Both => -1,
            Axis::X => 0,
            Axis::Y => 1,
        }
    }
    /// Half-widths `(rx, ry)` of the visited window for radius `r`.
    pub fn extent(self, r: i32) -> (i32, i32) {
        match self {
            Axis::Both => (r, r),
            Axis::X => (r, 0),
            Axis::Y => (0, r),
        }
    }
}

/// Parameters of one irradiance filter pass.
#[derive(Clone, Copy, Debug)]
pub struct IrradianceParams {
    pub max_radius: i32,
    pub normal_cos: f32,
    pub axis: Axis,
}

/// Eq. 5.31 at pixel `(x, y)`.
#[allow(clippy::too_many_arguments)]
pub fn irradiance_pixel(
    x: i32,
    y: i32,
    width: i32,
    height: i32,
    p: &IrradianceParams,
    value: &[[f32; 3]],
    position: &[[f32; 4]],
    normal: &[[f32; 4]],
    omega: &[f32],
    pixel_length: &[f32],
) -> [f32; 3] {
    let i = (y * width + x) as usize;
    let centre = value[i];
    let (om, ell) = (omega[i], pixel_length[i]);
    if !valid_width(om) || !valid_width(ell) || !is_hit(position[i]) {
        return centre;
    }
    let ni = v3(normal[i]).normalize_or_zero();
    if ni == Vec3::ZERO {
        return centre;
    }
    let gi = om / ell;
    let gi2 = gi * gi;
    let xi = v3(position[i]);
    let extent = p.axis.extent(window_radius(om, p.max_radius));
    gather(x, y, width, height, extent, value, |j, _| {
        if !is_hit(position[j]) || ni.dot(v3(normal[j]).normalize_or_zero()) < p.normal_cos {
            return None;
        }
        let gj = omega[j] / pixel_length[j];
        pair_weight((v3(position[j]) - xi).length_squared(), gi2, gj * gj)
    })
}

/// The weighted mean over the window of half-extents `(rx, ry)` around `(x, y)` of the finite
/// values whose neighbour test `weight(j, (dx, dy))` gives a weight; the centre value where none
/// does. Both Ch. 5 filters are this loop with their own weights (WGSL: the same order of terms).
fn gather(
    x: i32,
    y: i32,
    width: i32,
    height: i32,
    (rx, ry): (i32, i32),
    value: &[[f32; 3]],
    weight: impl Fn(usize, (i32, i32)) -> Option<f32>,
) -> [f32; 3] {
    let mut sum = [0.0f32; 3];
    let mut wsum = 0.0f32;
    for dy in -ry..=ry {
        for dx in -rx..=rx {
            let (jx, jy) = (x + dx, y + dy);
            if jx < 0 || jy < 0 || jx >= width || jy >= height {
                continue;
            }
            let j = (jy * width + jx) as usize;
            let v = value[j];
            if !is_finite3(v) {
                continue;
            }
            let Some(w) = weight(j, (dx, dy)) else { continue };
            for c in 0..3 {
                sum[c] += w * v[c];
            }
            wsum += w;
        }
    }
    if wsum > 0.0 {
        [sum[0] / wsum, sum[1] / wsum, sum[2] / wsum]
    } else {
        value[(y * width + x) as usize]
    }
}

/// Eq. 5.33 at pixel `(x, y)`.
#[allow(clippy::too_many_arguments)]
pub fn defocus_pixel(
    x: i32,
    y: i32,
    width: i32,
    height: i32,
    max_radius: i32,
    axis: Axis,
    value: &[[f32; 3]],
    omega: &[f32],
) -> [f32; 3] {
    let i = (y * width + x) as usize;
    let centre = value[i];
    let om = omega[i];
    if !valid_width(om) {
        return centre;
    }
    let gi2 = om * om;
    gather(x, y, width, height, axis.extent(window_radius(om, max_radius)), value, |j, (dx, dy)| {
        pair_weight((dx * dx + dy * dy) as f32, gi2, omega[j] * omega[j])
    })
}

/// The `max_radius` parameter clamped to `0..=MAX_RADIUS_LIMIT` (shared by `filter.motion`).
pub(crate) fn max_radius(ctx: &KernelCtx<'_>) -> Result<i32, BackendError> {
    Ok(ctx.int_param("max_radius")?.clamp(0, MAX_RADIUS_LIMIT) as i32)
}

/// The `axis` parameter: absent or -1 = 2-D, 0 = x, 1 = y.
fn axis(ctx: &KernelCtx<'_>) -> Result<Axis, BackendError> {
    if !ctx.params.contains_key("axis") {
        return Ok(Axis::Both);
    }
    let v = ctx.int_param("axis")?;
    Axis::from_param(v).ok_or_else(|| BackendError::Kernel {
        pass: ctx.pass.to_string(),
        message: format!("`axis` = {v}; use -1 (2-D), 0 (x) or 1 (y)"),
    })
}

/// The x pass stays in its row; the 2-D and y passes read `max_radius` rows away.
fn reach(ctx: &KernelCtx<'_>) -> Result<Reach, BackendError> {
    Ok(match axis(ctx)? {
        Axis::X => Reach::Cols(max_radius(ctx)? as u32),
        _ => Reach::Rows(max_radius(ctx)? as u32),
    })
}

/// `filter.irradiance`: eq. 5.31 on factored irradiance.
pub struct IrradianceFilter;

impl Kernel for IrradianceFilter {
    fn name(&self) -> &'static str {
        "filter.irradiance"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Filter
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("value", Format::Vec3),
            Binding::read("position", Format::Vec4),
            Binding::read("normal", Format::Vec4),
            Binding::read("omega", Format::F32),
            Binding::read("pixel_length", Format::F32),
            Binding::write("out", Format::Vec3),
        ]
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/filter_irradiance.wgsl"), |ctx| {
                Ok(Uniforms::new()
                    .i32("max_radius", max_radius(ctx)?)
                    .i32("axis", axis(ctx)?.code())
                    .f32("normal_cos", ctx.f32_param("normal_cos")?))
            })
            .with_include("filter_ch5_window.wgsl", include_str!("../../../shaders/filter_ch5_window.wgsl"))
            .with_reach(reach),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let value = ctx.read::<[f32; 3]>("value")?;
        let position = ctx.read::<[f32; 4]>("position")?;
        let normal = ctx.read::<[f32; 4]>("normal")?;
        let omega = ctx.read::<f32>("omega")?;
        let pixel_length = ctx.read::<f32>("pixel_length")?;
        let p = IrradianceParams {
            max_radius: max_radius(ctx)?,
            normal_cos: ctx.f32_param("normal_cos")?,
            axis: axis(ctx)?,
        };
        count_non_finite(ctx, value);
        let (w, h) = (ctx.width as i32, ctx.height as i32);
        let out = ctx.map_pixels(false, |x, y| {
            irradiance_pixel(x as i32, y as i32, w, h, &p, value, position, normal, omega, pixel_length)
        });
        ctx.put("out", out)
    }
}

/// `filter.defocus`: eq. 5.33 on composed radiance.
pub struct DefocusFilter;

impl Kernel for DefocusFilter {
    fn name(&self) -> &'static str {
        "filter.defocus"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Filter
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("value", Format::Vec3),
            Binding::read("omega", Format::F32),
            Binding::write("out", Format::Vec3),
        ]
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/filter_defocus.wgsl"), |ctx| {
                Ok(Uniforms::new().i32("max_radius", max_radius(ctx)?).i32("axis", axis(ctx)?.code()))
            })
            .with_include("filter_ch5_window.wgsl", include_str!("../../../shaders/filter_ch5_window.wgsl"))
            .with_reach(reach),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let value = ctx.read::<[f32; 3]>("value")?;
        let omega = ctx.read::<f32>("omega")?;
        let (r, a) = (max_radius(ctx)?, axis(ctx)?);
        count_non_finite(ctx, value);
        let (w, h) = (ctx.width as i32, ctx.height as i32);
        let out = ctx.map_pixels(false, |x, y| defocus_pixel(x as i32, y as i32, w, h, r, a, value, omega));
        ctx.put("out", out)
    }
}
