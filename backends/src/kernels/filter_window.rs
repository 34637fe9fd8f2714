//! The screen-space window the factoring nodes' filters share (thesis Sec. 5.8, steps 3–4; App. B):
//! `filter.irradiance` (eq. 5.31, [`super::irradiance_filter`]), Defocus's `filter.defocus` (eq.
//! 5.33) and Motion's `filter.motion` (eqs. B.1, B.2) weigh neighbour `j` of pixel `i` by
//! `w_i(j) = exp(−16 d² g_i²)` (`d` a distance, `g` a width) and reject it when `w_j(i) < 0.01` —
//! `i` outside `j`'s own filter (thesis: "mitigates errors due to noisy estimation of filter radii,
//! and prevents bleeding of sharp regions into blurry regions"). Both tests are made on the exponent,
//! `16 d² g² > ln 100`, which is the same condition without rounding `exp` (so the backends take
//! identical decisions).
//!
//! Window: pixel `i` uses the neighbours with `w_i(j) ≥ 0.01` — its Gaussian truncated at the same
//! threshold as the rejection, i.e. within `0.5365/Ω(i)` pixels — inside a square of half-width
//! `ceil(0.5365/Ω(i))` capped at the pass's `max_radius` (at most 64; 16 suggested: 33×33 = 1089
//! taps per pixel in 2-D, short fixed loops for GL/lavapipe). A cap that binds (`Ω < 0.5365/max_radius`:
//! circles of confusion above ~30 px at the default) truncates the Gaussian there.
//!
//! The reference is 2-D (`axis = -1`, the default): the rejection of neighbour `j` uses `j`'s own
//! width, so no X/Y split is exact. A pass with `axis = 0` or `1` runs the same weights along one
//! image axis only; an X pass followed by a Y pass is the separable approximation, O(R) instead of
//! O(R²) taps per pixel, validated against the 2-D filter in `tests/defocus_filters.rs` (see there
//! for the measured difference). WGSL mirror: `shaders/filter_window.wgsl`.

use crate::kernel::{KernelCtx, Reach};
use crate::kernels::is_finite3;
use crate::params::KernelParams;
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
/// Sec. 5.8). WGSL: `pair_weight` in filter_window.wgsl (0 for a rejection).
pub fn pair_weight(d2: f32, gi2: f32, gj2: f32) -> Option<f32> {
    let e_i = FILTER_SHARPNESS * d2 * gi2;
    let e_j = FILTER_SHARPNESS * d2 * gj2;
    (within_filter(e_i) && within_filter(e_j)).then(|| (-e_i).exp())
}

/// Whether `w` is a width a pixel filters with (finite and > 0).
pub fn valid_width(w: f32) -> bool {
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

/// The weighted mean over the window of half-extents `(rx, ry)` around `(x, y)` of the finite
/// values whose neighbour test `weight(j, (dx, dy))` gives a weight; the centre value where none
/// does. The irradiance and defocus filters are this loop with their own weights (WGSL: the same order of terms).
pub fn gather(
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

crate::kernel_params! {
    /// The window's cap, as `filter.defocus` and `filter.motion` read it (`filter.irradiance`'s block
    /// adds its normal test): clamped to `0..=MAX_RADIUS_LIMIT` ([`WindowParams::read_clamped`]).
    pub struct WindowParams {
        max_radius: i32,
    }
}

impl WindowParams {
    /// The pass's block, `max_radius` clamped ([`clamp_radius`]).
    pub fn read_clamped(ctx: &KernelCtx<'_>) -> Result<Self, BackendError> {
        Ok(Self { max_radius: clamp_radius(Self::read(ctx)?.max_radius) })
    }
}

/// A pass's `max_radius` clamped to `0..=MAX_RADIUS_LIMIT`.
pub fn clamp_radius(r: i32) -> i32 {
    r.clamp(0, MAX_RADIUS_LIMIT as i32)
}

/// The `max_radius` parameter clamped to `0..=MAX_RADIUS_LIMIT`.
pub fn max_radius(ctx: &KernelCtx<'_>) -> Result<i32, BackendError> {
    Ok(WindowParams::read_clamped(ctx)?.max_radius)
}

/// The `axis` parameter: absent or -1 = 2-D, 0 = x, 1 = y. Read by name, not declared in the
/// kernels' blocks: it is optional (absent = the 2-D reference filter), which a block's field is not.
pub fn axis(ctx: &KernelCtx<'_>) -> Result<Axis, BackendError> {
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
pub fn reach(ctx: &KernelCtx<'_>) -> Result<Reach, BackendError> {
    Ok(match axis(ctx)? {
        Axis::X => Reach::Cols(max_radius(ctx)? as u32),
        _ => Reach::Rows(max_radius(ctx)? as u32),
    })
}
