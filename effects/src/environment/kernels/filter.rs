//! The separable filter of thesis Ch. 6 (Sec. 6.7, eqs. 6.21–6.26) on one irradiance, with temporal
//! filtering across the frames of a sequence.
//!
//! - `filter.environment` (eqs. 6.21–6.23): one image axis (`axis` 0 = x, 1 = y) of the Gaussian
//!   `w = exp(−2 B̄² ‖p − p'‖²)` on world positions, `B̄² = ½(B²(i) + B²(j))` the mean of the two
//!   pixels' squared bandwidths along that axis (`bandwidth` holds `(B_X, B_Y)` in 1/m: "since the
//!   bandwidth estimates are also noisy"), over `|k| ≤ max_radius` pixels (the thesis: a 30 × 30
//!   window). Neighbours on another object or the background, whose normals differ by more than the
//!   normal test allows (10°, wedge's convention for every world-space filter), or whose values are not
//!   finite are not used. A pixel with no hit, or whose bandwidth is negative or not finite (a node's
//!   "do not filter"), passes through, and is no neighbour of another. A bandwidth of 0 (a flat, unoccluded receiver: eq. 6.13 gives
//!   `B_x = 0`) is the widest filter the window allows, not none.
//! - `filter.environment_history` (eqs. 6.24–6.25): the previous frame's unfiltered irradiance,
//!   reprojected: for pixel `(x, y)` with world position `p`, `(x', y')` is the previous frame's pixel
//!   whose position is closest to `p` (searched over the 3 × 3 pixels around `p`'s projection by the
//!   previous camera, `Scene::previous_camera`), and the output is the x filter of the previous raw
//!   irradiance around `(x', y')` with weights `exp(−2 B̄² ‖p − p'(x' + i, y')‖²)` measured from the
//!   *current* `p` (eq. 6.25: "the center of the kernel is offset to (x', y')"), `w` = 1 where the
//!   nearest previous neighbour weighs (exponent ≤ [`MAX_WEIGHT_EXPONENT`]), else 0 (no previous
//!   frame, off screen, disoccluded, too far from every neighbour to weigh, or moved
//!   more than `max_motion` pixels: a bound the thesis does not have, which keeps the rows the pass
//!   reads local so it splits into bands like every other filter).
//! - The y pass of `filter.environment` with `previous` bound joins it (eq. 6.26, whose printed form
//!   is garbled — docs/EQUATIONS.md: the previous-frame term uses w′): reading taken, the previous frame's
//!   x-filtered value at each `(x, y + j)` enters the y sum with the same spatial weight as the current
//!   one, `Ē = Σ_j w_j (E_X + v'_j E'_X)(x, y+j) / Σ_j w_j (1 + v'_j)`, `v'_j` its validity. Both sit at
//!   the current pixels' positions by construction, so the spatial weight is theirs.
//!
//! - Weights of both kernels are taken relative to the nearest used neighbour's ([`RelativeWeights`]):
//!   the same normalised average, with no weight left to underflow into the subnormals on which the
//!   CPU (keeps them) and GPUs (flush them) disagree.
//!
//! - `bandwidth.max` ([`BandwidthMax`]): two parts' bandwidths merged for one filter (MixedReality).
//!
//! WGSL mirrors: `shaders/filter_environment.wgsl`, `shaders/filter_environment_history.wgsl` and
//! `shaders/bandwidth_max.wgsl`, term by term in the same order.
//! Non-finite values are never used as neighbours; each pixel whose own value is non-finite is
//! counted once in `non_finite_samples` (in the x and history passes; the y pass sees x outputs).

use glam::{Vec2, Vec3};
use rayon::prelude::*;
use wedge_scene::Camera;

use wedge_backends::kernels::filter_window::{Line, WindowRadius};
use wedge_backends::kernels::paths::camera_uniforms;
use wedge_backends::kernels::{count_non_finite, is_finite3, v3};
use wedge_backends::{BackendError, Kernel, KernelCtx, KernelParams, Reach, Uniforms, WgslSource};

/// Largest `max_radius` a pass may ask for.
pub const MAX_RADIUS_LIMIT: u32 = 64;
/// Largest `max_motion` a history pass may ask for.
pub const MAX_MOTION_LIMIT: i64 = 4096;

wedge_backends::kernel_params! {
    /// What a `filter.environment` pass carries (the node's `PartFilter` sets them): `axis` 0 = x,
    /// 1 = y (checked, [`FilterParams::read_checked`]); `max_radius` clamped to `0..=MAX_RADIUS_LIMIT` as read.
    pub struct FilterParams {
        axis: u32,
        max_radius: WindowRadius<MAX_RADIUS_LIMIT>,
        normal_cos: f32,
    }
}

wedge_backends::kernel_params! {
    /// What a `filter.environment_history` pass carries: the filter's (its `axis` is 0, eq. 6.24)
    /// and `max_motion`, clamped to `0..=MAX_MOTION_LIMIT` ([`HistoryParams::read_checked`]).
    pub struct HistoryParams {
        axis: u32,
        max_radius: WindowRadius<MAX_RADIUS_LIMIT>,
        normal_cos: f32,
        /// The most pixels (along either axis) a point may have moved since the previous frame and
        /// still find its history; farther is "no history", as for a disocclusion. It bounds the
        /// rows the pass reads (`Reach::Rows(max_motion + 1)`), so the pass splits into bands of
        /// rows on devices with small bindings.
        max_motion: i32,
    }
}

/// One pixel as a neighbour in a pass, gathered once per pass ([`neighbours`]): a pixel sits in up
/// to 2R + 1 windows, and each read four buffers and normalised its normal per tap (the CPU time of
/// Environment's filter, issue 35 §4). The same operations on the same values, so the same bits (the
/// WGSL reads the buffers per tap, as before).
#[derive(Clone, Copy)]
pub struct Neighbour {
    position: Vec3,
    /// The object id (`position.w`), NaN where the pixel is nobody's neighbour (the filter: its value
    /// is not finite, or its bandwidth is negative or NaN; the history: its value is not finite): NaN
    /// equals no id.
    object: f32,
    /// The unit normal (zero where none).
    normal: Vec3,
    /// Its squared bandwidth `B²` along the pass's axis.
    b2: f32,
}

/// Every pixel as a neighbour along `axis`; `usable(j)` says whether pixel `j` may be one at all.
pub fn neighbours(
    position: &[[f32; 4]],
    normal: &[[f32; 4]],
    bandwidth: &[[f32; 2]],
    axis: usize,
    usable: impl Fn(usize) -> bool + Sync,
) -> Vec<Neighbour> {
    (0..position.len())
        .into_par_iter()
        .map(|j| {
            let b = bandwidth[j][axis];
            Neighbour {
                position: v3(position[j]),
                object: if usable(j) { position[j][3] } else { f32::NAN },
                normal: v3(normal[j]).normalize_or_zero(),
                b2: b * b,
            }
        })
        .collect()
}

/// The taps of one pixel's window: each one's weight exponent in tap order, NaN for a neighbour not
/// used (NaN weighs nothing and is never the nearest, [`RelativeWeights`]), and the nearest used
/// one's exponent: the weights need it before any is summed. No branch per tap.
struct UsedTaps {
    window: Line,
    exponent: [f32; 2 * MAX_RADIUS_LIMIT as usize + 1],
    nearest: f32,
}

impl UsedTaps {
    /// The taps of pixel `i` (position `xi`, object `oi`, unit normal `ni`, squared bandwidth `b2i`)
    /// at indices `j` in tap order: neighbour `j` is used where it is on the same object with a
    /// normal within `normal_cos`, and weighs `exp(−2 B̄² d²)`, `B̄² = ½(B²(i) + B²(j))` (eq. 6.22).
    fn gather(
        window: Line,
        neighbours: &[Neighbour],
        (xi, oi, ni, b2i): (Vec3, f32, Vec3, f32),
        normal_cos: f32,
    ) -> UsedTaps {
        let mut exponent = [0.0; 2 * MAX_RADIUS_LIMIT as usize + 1];
        let mut nearest = f32::INFINITY;
        for (e, (_, nb)) in exponent.iter_mut().zip(window.taps(neighbours)) {
            let used = nb.object == oi && ni.dot(nb.normal) >= normal_cos;
            let d2 = (nb.position - xi).length_squared();
            let a = if used { 2.0 * (0.5 * (b2i + nb.b2)) * d2 } else { f32::NAN };
            // `a < nearest` rather than `f32::min`: NaN never becomes the minimum, as in the WGSL.
            nearest = if a < nearest { a } else { nearest };
            *e = a;
        }
        UsedTaps { window, exponent, nearest }
    }

    /// Each used tap's index and weight, the nearest weighing 1; `None` when no tap weighs
    /// ([`RelativeWeights::from_nearest`]).
    fn weighted(&self) -> Option<impl Iterator<Item = (usize, f32)> + '_> {
        let weights = RelativeWeights::from_nearest(self.nearest)?;
        let taps = self.exponent[..self.window.len].iter().enumerate();
        Some(taps.filter_map(move |(t, &a)| Some((self.window.index(t), weights.weight(a)?))))
    }
}

/// The largest weight exponent `a` (weight `exp(−a)`) that still weighs: `exp(−87) ≈ 1.6e−38` is just
/// above f32's smallest normal number (1.2e−38). Past it a weight would be subnormal or 0, and
/// subnormals are where backends part: the CPU keeps them, GPUs (lavapipe among them) flush them to
/// 0 — which decided whether a pixel had any history at all (issue 33: GPU and CPU temporal frames
/// differing by up to 0.26 at a few pixels). Passed to the WGSL mirrors as the uniform
/// `max_weight_exponent`, so both sides cut at this one value.
pub const MAX_WEIGHT_EXPONENT: f32 = 87.0;

/// Gaussian weights `exp(−a)` of a normalised average, taken relative to the nearest neighbour's
/// (`exp(−(a − a_min))`, the same average since the scale cancels): the nearest neighbour weighs 1
/// and no weight underflows because the pixel is far from all of them. A neighbour whose relative
/// exponent exceeds [`MAX_WEIGHT_EXPONENT`], or is not a number, gets no weight on any backend.
struct RelativeWeights {
    a_min: f32,
}

impl RelativeWeights {
    /// From every used neighbour's exponent; `None` when there is none, or the nearest is so far that
    /// its absolute weight would be below [`MAX_WEIGHT_EXPONENT`]'s (the pixel has no neighbour).
    #[cfg(test)]
    fn new(exponents: impl Iterator<Item = f32>) -> Option<RelativeWeights> {
        // `a < a_min` rather than `f32::min`: NaN never becomes the minimum, as in the WGSL mirror.
        Self::from_nearest(exponents.fold(f32::INFINITY, |m, a| if a < m { a } else { m }))
    }

    /// From the nearest used neighbour's exponent (∞ where there is none).
    fn from_nearest(a_min: f32) -> Option<RelativeWeights> {
        (a_min <= MAX_WEIGHT_EXPONENT).then_some(RelativeWeights { a_min })
    }

    /// The weight of exponent `a`, or `None` for no weight.
    fn weight(&self, a: f32) -> Option<f32> {
        let relative = a - self.a_min;
        (relative <= MAX_WEIGHT_EXPONENT).then(|| (-relative).exp())
    }
}

/// Eqs. 6.21–6.23 (and 6.26 with `previous`) at pixel `(x, y)`; `neighbours` the pass's
/// ([`neighbours`]: a neighbour's value finite, its bandwidth along the axis ≥ 0).
#[allow(clippy::too_many_arguments)]
pub fn filter_pixel(
    x: i32,
    y: i32,
    width: i32,
    height: i32,
    p: &FilterParams,
    value: &[[f32; 3]],
    position: &[[f32; 4]],
    bandwidth: &[[f32; 2]],
    neighbours: &[Neighbour],
    previous: Option<&[[f32; 4]]>,
) -> [f32; 3] {
    let (i, axis) = ((y * width + x) as usize, p.axis as usize);
    let centre = value[i];
    let bi = bandwidth[i];
    if !(position[i][3] > 0.0 && bi[axis] >= 0.0 && bi[axis].is_finite()) {
        return centre;
    }
    let me = (neighbours[i].position, position[i][3], neighbours[i].normal, bi[axis] * bi[axis]);
    let taps = Line::along(x, y, (width, height), axis, p.max_radius.get());
    let used = UsedTaps::gather(taps, neighbours, me, p.normal_cos);
    let Some(weighted) = used.weighted() else {
        return centre;
    };
    let mut sum = [0.0f32; 3];
    let mut wsum = 0.0f32;
    for (j, w) in weighted {
        let v = value[j];
        for c in 0..3 {
            sum[c] += w * v[c];
        }
        wsum += w;
        if let Some(prev) = previous {
            let e = prev[j];
            if e[3] > 0.0 && is_finite3([e[0], e[1], e[2]]) {
                for c in 0..3 {
                    sum[c] += w * e[c];
                }
                wsum += w;
            }
        }
    }
    // The nearest neighbour's weight is 1: `wsum ≥ 1`.
    [sum[0] / wsum, sum[1] / wsum, sum[2] / wsum]
}

/// A camera's projection of a world point to pixel coordinates (continuous, (0,0) the top-left
/// corner), or `None` behind it: the inverse of [`Camera::ray`]'s pinhole mapping.
pub fn project(cam: &Camera, p: Vec3, width: u32, height: u32) -> Option<Vec2> {
    let (right, up, forward) = cam.basis();
    let d = p - cam.position;
    let z = d.dot(forward);
    if !(z > 0.0) {
        return None;
    }
    let (w, h) = (width.max(1) as f32, height.max(1) as f32);
    let tan_half = (cam.vfov_deg.to_radians() * 0.5).tan();
    let sx = d.dot(right) / z;
    let sy = d.dot(up) / z;
    Some(Vec2::new((sx / (tan_half * (w / h)) + 1.0) * 0.5 * w, (1.0 - sy / tan_half) * 0.5 * h))
}

/// Eqs. 6.24–6.25 at pixel `(x, y)`: the previous frame's raw irradiance x-filtered around the
/// previous pixel closest to this pixel's position, weights from this pixel's position (rgb, valid);
/// `normal` this frame's unit normals, `previous` the previous frame's pixels as neighbours along x
/// ([`neighbours`]: a neighbour's value finite).
#[allow(clippy::too_many_arguments)]
pub fn history_pixel(
    x: i32,
    y: i32,
    width: i32,
    height: i32,
    p: &HistoryParams,
    previous_camera: Option<&Camera>,
    position: &[[f32; 4]],
    normal: &[Vec3],
    bandwidth: &[[f32; 2]],
    prev_value: &[[f32; 3]],
    prev_position: &[[f32; 4]],
    previous: &[Neighbour],
) -> [f32; 4] {
    let i = (y * width + x) as usize;
    let none = [0.0; 4];
    let Some(cam) = previous_camera else { return none };
    // A pixel the y pass lets through (no hit, "do not filter") never reads its history.
    if !(position[i][3] > 0.0 && bandwidth[i][0] >= 0.0 && bandwidth[i][0].is_finite()) {
        return none;
    }
    let xi = v3(position[i]);
    let ni = normal[i];
    let Some(q) = project(cam, xi, width as u32, height as u32) else { return none };
    // Off the previous frame (or not a number): that frame did not see this point, and the nearest
    // edge pixel is another point of the surface.
    if !(q.x >= 0.0 && q.x < width as f32 && q.y >= 0.0 && q.y < height as f32) {
        return none;
    }
    let (qx, qy) = (q.x.floor() as i64, q.y.floor() as i64);
    // Moved farther than `max_motion` pixels: no history (see [`HistoryParams::max_motion`]).
    if (qx - x as i64).abs() > p.max_motion as i64 || (qy - y as i64).abs() > p.max_motion as i64 {
        return none;
    }
    // The previous pixel with the closest world position (same object), around the projection.
    let mut best: Option<(f32, i32, i32)> = None;
    for dy in -1..=1i64 {
        for dx in -1..=1i64 {
            let (sx, sy) = (qx + dx, qy + dy);
            if sx < 0 || sy < 0 || sx >= width as i64 || sy >= height as i64 {
                continue;
            }
            let j = (sy * width as i64 + sx) as usize;
            if prev_position[j][3] != position[i][3] {
                continue;
            }
            let d2 = (v3(prev_position[j]) - xi).length_squared();
            if best.is_none_or(|(b, _, _)| d2 < b) {
                best = Some((d2, sx as i32, sy as i32));
            }
        }
    }
    let Some((_, px, py)) = best else { return none };
    let bi = bandwidth[i][0];
    let taps = Line::along(px, py, (width, height), 0, p.max_radius.get());
    let used = UsedTaps::gather(taps, previous, (xi, position[i][3], ni, bi * bi), p.normal_cos);
    // No neighbour near enough to weigh anything: no history (as when there is no neighbour).
    let Some(weighted) = used.weighted() else {
        return none;
    };
    let mut sum = [0.0f32; 3];
    let mut wsum = 0.0f32;
    for (j, w) in weighted {
        let v = prev_value[j];
        for c in 0..3 {
            sum[c] += w * v[c];
        }
        wsum += w;
    }
    [sum[0] / wsum, sum[1] / wsum, sum[2] / wsum, 1.0]
}

/// An `axis` other than 0 (x) or 1 (y) is an error.
fn check_axis(ctx: &KernelCtx<'_>, axis: u32) -> Result<(), BackendError> {
    match axis {
        0 | 1 => Ok(()),
        _ => Err(ctx.err(format!("`axis` = {axis}; use 0 (x) or 1 (y)"))),
    }
}

impl FilterParams {
    /// The pass's block, `axis` checked.
    pub fn read_checked(ctx: &KernelCtx<'_>) -> Result<Self, BackendError> {
        let p = Self::read(ctx)?;
        check_axis(ctx, p.axis)?;
        Ok(p)
    }
}

impl HistoryParams {
    /// The pass's block, `axis` checked, `max_motion` clamped.
    pub fn read_checked(ctx: &KernelCtx<'_>) -> Result<Self, BackendError> {
        let p = Self::read(ctx)?;
        check_axis(ctx, p.axis)?;
        Ok(Self { max_motion: p.max_motion.clamp(0, MAX_MOTION_LIMIT as i32), ..p })
    }
}

wedge_backends::kernel_bindings! {
    /// What a `filter.environment` pass binds.
    pub struct EnvironmentFilterIo / EnvironmentFilterData {
        read value: [f32; 3], read position: [f32; 4], read normal: [f32; 4], read bandwidth: [f32; 2],
        /// The previous frame's x-filtered irradiance at each pixel (`filter.environment_history`):
        /// joins the y pass (eq. 6.26).
        read_opt previous: [f32; 4],
        write out: [f32; 3],
    }
}

wedge_backends::kernel_bindings! {
    /// What a `filter.environment_history` pass binds: this frame's G-buffer and bandwidths, the
    /// previous frame's irradiance, G-buffer and bandwidths, and the reprojected, x-filtered history.
    pub struct HistoryIo / HistoryData {
        read position: [f32; 4], read normal: [f32; 4], read bandwidth: [f32; 2], read previous_value: [f32; 3],
        read previous_position: [f32; 4], read previous_normal: [f32; 4], read previous_bandwidth: [f32; 2],
        write out: [f32; 4],
    }
}

wedge_backends::kernel_bindings! {
    /// What a `bandwidth.max` pass binds.
    pub struct BandwidthMaxIo / BandwidthMaxData {
        read a: [f32; 2], read b: [f32; 2], write out: [f32; 2],
    }
}

/// `filter.environment`: one axis of eqs. 6.21–6.23 (and 6.26 with `previous`).
pub struct EnvironmentFilter;

impl Kernel for EnvironmentFilter {
    wedge_backends::kernel_signature!(
        name: "filter.environment", class: Filter, bindings: EnvironmentFilterIo, params: [FilterParams]
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/filter_environment.wgsl"), |ctx| {
                Ok(FilterParams::read_checked(ctx)?.uniforms().f32("max_weight_exponent", MAX_WEIGHT_EXPONENT))
            })
            .with_reach(|ctx| {
                let p = FilterParams::read_checked(ctx)?;
                Ok(if p.axis == 0 {
                    Reach::Cols(p.max_radius.get() as u32)
                } else {
                    Reach::Rows(p.max_radius.get() as u32)
                })
            }),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let p = FilterParams::read_checked(ctx)?;
        let EnvironmentFilterData { value, position, normal, bandwidth, previous, out } =
            EnvironmentFilterIo::read(ctx)?;
        if p.axis == 0 {
            count_non_finite(ctx, value);
        }
        let (w, h, axis) = (ctx.width as i32, ctx.height as i32, p.axis as usize);
        let usable = |j: usize| is_finite3(value[j]) && bandwidth[j][axis] >= 0.0;
        let neighbours = neighbours(position, normal, bandwidth, axis, usable);
        let filtered = ctx.map_pixels(false, |x, y| {
            filter_pixel(x as i32, y as i32, w, h, &p, value, position, bandwidth, &neighbours, previous)
        });
        out.put(ctx, filtered)
    }
}

/// `filter.environment_history`: eqs. 6.24–6.25 (see the module doc).
pub struct EnvironmentHistory;

impl Kernel for EnvironmentHistory {
    wedge_backends::kernel_signature!(
        name: "filter.environment_history", class: Filter, bindings: HistoryIo, params: [HistoryParams]
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/filter_environment_history.wgsl"), |ctx| {
                let p = HistoryParams::read_checked(ctx)?;
                let (cam, present) = match ctx.scene.previous_camera {
                    Some(c) => (c, 1u32),
                    None => (ctx.scene.camera, 0u32),
                };
                let u = p.uniforms().u32("history", present).f32("max_weight_exponent", MAX_WEIGHT_EXPONENT);
                Ok(camera_uniforms(u, &cam, wedge_scene::LensShape::Disk))
            })
            .with_include("camera.wgsl", include_str!("../../../../shaders/camera.wgsl"))
            .with_reach(|ctx| Ok(Reach::Rows(HistoryParams::read_checked(ctx)?.max_motion as u32 + 1))),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let p = HistoryParams::read_checked(ctx)?;
        let io = HistoryIo::read(ctx)?;
        let (position, bandwidth, pv, pp) = (io.position, io.bandwidth, io.previous_value, io.previous_position);
        let normal: Vec<Vec3> = io.normal.iter().map(|n| v3(*n).normalize_or_zero()).collect();
        let previous = neighbours(pp, io.previous_normal, io.previous_bandwidth, 0, |j| is_finite3(pv[j]));
        let cam = ctx.scene.previous_camera;
        let (w, h) = (ctx.width as i32, ctx.height as i32);
        let history = ctx.map_pixels(false, |x, y| {
            history_pixel(x as i32, y as i32, w, h, &p, cam.as_ref(), position, &normal, bandwidth, pv, pp, &previous)
        });
        io.out.put(ctx, history)
    }
}

/// `bandwidth.max`: per pixel and axis the larger of two Ch. 6 bandwidths `a`, `b` (vec2, 1/m), a
/// negative one ("do not filter" for that part) counting as absent; negative where both are. For an
/// irradiance that mixes two parts (a surface's diffuse and glossy light in one value): the larger
/// bandwidth is the narrower filter, which keeps both parts' detail.
/// MixedReality's (its virtual objects' irradiance mixes the parts); it lives beside the filter it
/// feeds, whose passes MixedReality reuses by kernel name.
pub struct BandwidthMax;

/// The larger of two bandwidths (see [`BandwidthMax`]).
pub fn bandwidth_max(a: [f32; 2], b: [f32; 2]) -> [f32; 2] {
    let one = |x: f32, y: f32| match (x >= 0.0, y >= 0.0) {
        (true, true) => x.max(y),
        (true, false) => x,
        (false, true) => y,
        (false, false) => x.min(y),
    };
    [one(a[0], b[0]), one(a[1], b[1])]
}

impl Kernel for BandwidthMax {
    wedge_backends::kernel_signature!(name: "bandwidth.max", class: Bandwidth, bindings: BandwidthMaxIo);
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/bandwidth_max.wgsl"), |_| Ok(Uniforms::new()))
                .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let BandwidthMaxData { a, b, out } = BandwidthMaxIo::read(ctx)?;
        let larger: Vec<[f32; 2]> = a.iter().zip(b).map(|(a, b)| bandwidth_max(*a, *b)).collect();
        out.put(ctx, larger)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Far neighbours keep their relative weights (the old `exp(−a)` would have been subnormal or 0,
    /// backend-dependent), a pixel whose nearest neighbour is past the cut has none, and NaN weighs
    /// nothing.
    #[test]
    fn weights_are_relative_to_the_nearest_neighbour_and_cut_alike() {
        let w = RelativeWeights::new([95.0f32, 90.0, f32::NAN].into_iter());
        assert!(w.is_none(), "nearest exponent 90 > {MAX_WEIGHT_EXPONENT}: no neighbour weighs");
        let w = RelativeWeights::new([86.0f32, 100.0, f32::NAN, 200.0].into_iter()).unwrap();
        assert_eq!(w.weight(86.0), Some(1.0));
        assert_eq!(w.weight(100.0), Some((-14.0f32).exp()));
        assert_eq!(w.weight(f32::NAN), None);
        assert_eq!(w.weight(200.0), None, "114 past the nearest: cut on every backend, not left to flush");
        assert!(RelativeWeights::new(std::iter::empty()).is_none());
    }
}
