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

use wedge_graph::ParamValue;

use crate::kernel::{KernelCtx, Reach, Uniforms};
use crate::kernels::is_finite3;
use crate::params::{ParamField, ParamType};
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
pub const MAX_RADIUS_LIMIT: u32 = 64;

/// Half-width in pixels of the square window for width `omega`: `ceil(0.5365/Ω)`, at most `cap`.
pub fn window_radius(omega: f32, cap: i32) -> i32 {
    let r = REJECT_RADIUS / omega;
    if r.is_nan() || r >= cap as f32 {
        cap
    } else {
        (r.ceil() as i32).max(0)
    }
}

/// The weight exponent `16 d² g²` of a squared distance `d2` under a width² `g2` — the one
/// expression [`pair_weight`], [`accepts`] and [`CentreWeights`] share, so their bits agree.
#[inline(always)]
pub fn exponent(d2: f32, g2: f32) -> f32 {
    FILTER_SHARPNESS * d2 * g2
}

/// Whether a weight exponent `16 d² (Ω/ℓ)²` keeps the weight at or above 0.01 (false for NaN).
#[inline(always)]
pub fn within_filter(exponent: f32) -> bool {
    exponent <= REJECT_EXPONENT
}

/// The weight `w_i(j) = exp(−16 d² g_i²)` of neighbour `j` at squared distance `d2` (eqs. 5.31,
/// 5.33; `g = Ω`, or `Ω/ℓ_p` for the irradiance filter), or `None` where `j` is rejected: outside
/// `i`'s truncated Gaussian (`w_i(j) < 0.01`) or `i` outside `j`'s filter (`w_j(i) < 0.01`, thesis
/// Sec. 5.8). WGSL: `pair_weight` in filter_window.wgsl (0 for a rejection).
pub fn pair_weight(d2: f32, gi2: f32, gj2: f32) -> Option<f32> {
    let e_i = exponent(d2, gi2);
    (within_filter(e_i) && accepts(d2, gj2)).then(|| (-e_i).exp())
}

/// Whether neighbour `j` of width² `gj2` keeps a pixel at squared distance `d2` inside its own
/// filter (`w_j(i) ≥ 0.01`): [`pair_weight`]'s second test.
fn accepts(d2: f32, gj2: f32) -> bool {
    within_filter(exponent(d2, gj2))
}

/// One centre pixel's `w_i(j)` for every integer squared distance of its 2-D window, each computed
/// once — a window of half-width `R` has `(R+1)(R+2)/2` distinct `dx² + dy²` up to symmetry against
/// `(2R+1)²` taps, and `exp` is most of a 2-D tap's cost. [`CentreWeights::pair`] is [`pair_weight`]
/// bit for bit (the same `f32` exponent, the same `exp`), so a 2-D pass that uses it keeps its bytes.
pub struct CentreWeights {
    /// `w_i` at `d² = index`, 0 where `i`'s truncated Gaussian rejects it (a kept weight is ≥ 0.01).
    table: Vec<f32>,
}

impl CentreWeights {
    /// The table of a centre of width² `gi2` over a square window of half-width `radius`.
    pub fn new(gi2: f32, radius: i32) -> Self {
        let r = radius.max(0) as usize;
        let mut table = vec![0.0f32; 2 * r * r + 1];
        for a in 0..=r {
            for b in 0..=a {
                let d2 = a * a + b * b;
                let e_i = exponent(d2 as f32, gi2);
                table[d2] = if within_filter(e_i) { (-e_i).exp() } else { 0.0 };
            }
        }
        CentreWeights { table }
    }

    /// [`pair_weight`]`(dx² + dy², gi2, gj2)` for a tap `(dx, dy)` of the window.
    pub fn pair(&self, (dx, dy): (i32, i32), gj2: f32) -> Option<f32> {
        let d2 = dx * dx + dy * dy;
        let w = self.table[d2 as usize];
        (w > 0.0 && accepts(d2 as f32, gj2)).then_some(w)
    }
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
/// does. The defocus filter is this loop with its own weights (WGSL: the same order of terms).
pub fn gather(
    x: i32,
    y: i32,
    width: i32,
    height: i32,
    extent: (i32, i32),
    value: &[[f32; 3]],
    weight: impl Fn(usize, (i32, i32)) -> Option<f32>,
) -> [f32; 3] {
    let tap = |j: usize, v: &[f32; 3], d: (i32, i32)| {
        if !is_finite3(*v) {
            return None;
        }
        weight(j, d).map(|w| (w, *v))
    };
    gather_taps(x, y, width, height, extent, value, tap).unwrap_or(value[(y * width + x) as usize])
}

/// The loop under [`gather`], over any per-pixel records: `tap(j, &records[j], (dx, dy))` gives
/// a neighbour's weight and value or `None` (not used); the weighted mean of the used ones in row
/// order, `None` where no weight was positive. The window is clipped to the image once and each of
/// its rows walked as a slice, rather than each tap tested and indexed: the same taps in the same
/// order (`filter.irradiance` hands it records that fold its per-tap tests into one, [`super::irradiance_filter`]).
pub fn gather_taps<T, const N: usize>(
    x: i32,
    y: i32,
    width: i32,
    height: i32,
    (rx, ry): (i32, i32),
    records: &[T],
    tap: impl Fn(usize, &T, (i32, i32)) -> Option<(f32, [f32; N])>,
) -> Option<[f32; N]> {
    let mut sum = [0.0f32; N];
    let mut wsum = 0.0f32;
    let (dy0, dy1) = ((-ry).max(-y), ry.min(height - 1 - y));
    let (dx0, dx1) = ((-rx).max(-x), rx.min(width - 1 - x));
    let mut add = |j: usize, r: &T, d: (i32, i32)| {
        if let Some((w, v)) = tap(j, r, d) {
            for c in 0..N {
                sum[c] += w * v[c];
            }
            wsum += w;
        }
    };
    if dx0 == dx1 {
        // One column (a y pass): a strided walk, not one slice per row.
        let column = Line::along(x + dx0, y, (width, height), 1, ry);
        for ((j, r), dy) in column.taps(records).zip(dy0..=dy1) {
            add(j, r, (dx0, dy));
        }
    } else {
        for dy in dy0..=dy1 {
            let first = ((y + dy) * width + x + dx0) as usize;
            let row = &records[first..=first + (dx1 - dx0) as usize];
            for (k, r) in row.iter().enumerate() {
                add(first + k, r, (dx0 + k as i32, dy));
            }
        }
    }
    (wsum > 0.0).then(|| sum.map(|s| s / wsum))
}

/// Pixel `(x, y)`'s 1-D window of half-width `radius` along one image axis (0: x, 1: y), clipped to
/// the image: `len` pixels from index `first`, `stride` apart, in tap order — a column's walk in
/// [`gather_taps`], and the Environment filter's separable passes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Line {
    pub first: usize,
    pub stride: usize,
    pub len: usize,
}

impl Line {
    pub fn along(x: i32, y: i32, (width, height): (i32, i32), axis: usize, radius: i32) -> Line {
        let (at, extent, stride) = if axis == 0 { (x, width, 1) } else { (y, height, width) };
        let (lo, hi) = ((-radius).max(-at), radius.min(extent - 1 - at));
        Line {
            first: (y * width + x + lo * stride) as usize,
            stride: stride as usize,
            len: (hi - lo + 1).max(0) as usize,
        }
    }
    /// Index of tap `t`.
    pub fn index(&self, t: usize) -> usize {
        self.first + t * self.stride
    }
    /// Each tap's index and record, in tap order.
    pub fn taps<'a, T>(&self, records: &'a [T]) -> impl Iterator<Item = (usize, &'a T)> + 'a {
        let Line { first, stride, len } = *self;
        records[first..].iter().step_by(stride).take(len).enumerate().map(move |(t, r)| (first + t * stride, r))
    }
}

crate::kernel_params! {
    /// The window's cap, as `filter.motion` reads it (clamped to `0..=MAX_RADIUS_LIMIT` as read).
    pub struct WindowParams {
        max_radius: ScreenRadius,
    }
}

crate::kernel_params! {
    /// The window's cap and the pass's [`Axis`], as `filter.defocus` reads them (`filter.irradiance`'s
    /// block adds its normal test).
    pub struct AxisWindowParams {
        max_radius: ScreenRadius,
        axis: Axis,
    }
}

/// The `axis` parameter: absent or -1 = 2-D, 0 = x, 1 = y; another value is refused with the fix.
/// Optional (absent = the 2-D reference filter); an `i32` in WGSL ([`Axis::code`]).
impl ParamField for Axis {
    const TYPE: ParamType = ParamType::Integer;
    const OPTIONAL: bool = true;
    fn read(ctx: &KernelCtx<'_>, name: &str) -> Result<Self, BackendError> {
        if !ctx.params.contains_key(name) {
            return Ok(Axis::Both);
        }
        let v = ctx.int_param(name)?;
        Axis::from_param(v).ok_or_else(|| ctx.err(format!("`{name}` = {v}; use -1 (2-D), 0 (x) or 1 (y)")))
    }
    fn uniform(&self, u: Uniforms, name: &'static str) -> Uniforms {
        u.i32(name, self.code())
    }
}

impl Axis {
    /// The name the kernels' blocks declare the field under (`AxisWindowParams::axis`, ...).
    pub const PARAM: &'static str = "axis";
    /// The pass parameter a node sets for this axis (the value [`Axis::from_param`] reads back).
    pub fn param(self) -> (&'static str, ParamValue) {
        (Self::PARAM, ParamValue::Int(self.code().into()))
    }
    /// How far a pass along this axis reads for cap `r`: the x pass stays in its row; the 2-D and y
    /// passes read `r` rows away.
    pub fn reach(self, r: ScreenRadius) -> Reach {
        match self {
            Axis::X => Reach::Cols(r.get() as u32),
            _ => Reach::Rows(r.get() as u32),
        }
    }
}

/// A filter window's cap in pixels (a pass's `max_radius`), clamped to `0..=LIMIT` as it is read
/// (a value outside `i32` is refused, as an `i32` field's). One type for every filter's cap, each
/// with its own limit: [`ScreenRadius`] (64) here, `filter.gaussian`'s 1024 (an axis-aligned filter
/// of 1-D taps), `filter.environment`'s 64. An `i32` in WGSL.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WindowRadius<const LIMIT: u32>(u32);

impl<const LIMIT: u32> WindowRadius<LIMIT> {
    /// Largest cap a pass may ask for.
    pub const LIMIT: u32 = LIMIT;
    /// `r` clamped to `0..=LIMIT`.
    pub fn clamped(r: i32) -> Self {
        Self(r.clamp(0, LIMIT as i32) as u32)
    }
    /// The cap in pixels.
    pub fn get(self) -> i32 {
        self.0 as i32
    }
    /// The offsets `-cap..=cap` of a 1-D window at the cap.
    pub fn taps(self) -> std::ops::RangeInclusive<i32> {
        -self.get()..=self.get()
    }
    /// Half-width of the screen-space window for width `omega` under this cap ([`window_radius`]).
    pub fn window(self, omega: f32) -> i32 {
        window_radius(omega, self.get())
    }
}

impl<const LIMIT: u32> ParamField for WindowRadius<LIMIT> {
    const TYPE: ParamType = ParamType::Integer;
    fn read(ctx: &KernelCtx<'_>, name: &str) -> Result<Self, BackendError> {
        i32::read(ctx, name).map(Self::clamped)
    }
    fn uniform(&self, u: Uniforms, name: &'static str) -> Uniforms {
        u.i32(name, self.get())
    }
}

/// The cap of the screen-space window of this module's filters.
pub type ScreenRadius = WindowRadius<MAX_RADIUS_LIMIT>;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::irradiance_filter::IrradianceParams;
    use crate::params::KernelParams;

    /// The table is `pair_weight` bit for bit at every tap of the window, rejections included —
    /// widths that bind the cap, that truncate inside it, zero, infinite and NaN.
    #[test]
    fn centre_weights_are_pair_weight_bit_for_bit() {
        let widths = [0.0f32, 0.01, 0.033, 0.1, 0.25, 0.7, 1.0, 3.0, f32::INFINITY, f32::NAN];
        for &gi in &widths {
            let radius = window_radius(gi, 16);
            let table = CentreWeights::new(gi * gi, radius);
            for &gj in &widths {
                for dy in -radius..=radius {
                    for dx in -radius..=radius {
                        let want = pair_weight((dx * dx + dy * dy) as f32, gi * gi, gj * gj);
                        let got = table.pair((dx, dy), gj * gj);
                        assert_eq!(want.map(f32::to_bits), got.map(f32::to_bits), "gi {gi} gj {gj} ({dx}, {dy})");
                    }
                }
            }
        }
    }

    #[test]
    fn the_blocks_declare_the_axis_the_nodes_set() {
        assert!(AxisWindowParams::names().contains(&Axis::PARAM));
        assert!(IrradianceParams::names().contains(&Axis::PARAM));
        for a in [Axis::Both, Axis::X, Axis::Y] {
            let ParamValue::Int(v) = a.param().1 else { unreachable!() };
            assert_eq!(Axis::from_param(v), Some(a));
        }
    }

    #[test]
    fn a_window_radius_clamps_to_its_limit() {
        assert_eq!(ScreenRadius::clamped(1000).get(), 64);
        assert_eq!(WindowRadius::<1024>::clamped(1000).get(), 1000);
        assert_eq!(ScreenRadius::clamped(-3).get(), 0);
        assert_eq!(ScreenRadius::clamped(16).window(0.5365 / 3.5), 4);
    }
}
