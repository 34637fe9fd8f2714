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
use wedge_scene::Camera;

use wedge_backends::kernels::filter_window::WindowRadius;
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

/// Whether neighbour `j` (position `pj`, unit normal `nj`) may be averaged into pixel `i`.
fn compatible(pi: [f32; 4], ni: Vec3, pj: [f32; 4], nj: Vec3, normal_cos: f32) -> bool {
    pj[3] == pi[3] && ni.dot(nj) >= normal_cos
}

/// Every pixel's unit normal (zero where none), once per pass rather than per tap: a pixel is a
/// neighbour of up to 2R + 1 others, each of which normalised its normal twice. The same operation,
/// so the same bits (the WGSL normalises per tap, as before).
pub fn unit_normals(normal: &[[f32; 4]]) -> Vec<Vec3> {
    normal.iter().map(|n| v3(*n).normalize_or_zero()).collect()
}

/// The used taps of one pixel's window, `(neighbour index, weight exponent)` in tap order, found
/// once: the weights need the nearest one's exponent before any is summed ([`RelativeWeights`]).
struct UsedTaps {
    taps: [(usize, f32); 2 * MAX_RADIUS_LIMIT as usize + 1],
    len: usize,
}

impl UsedTaps {
    fn new(found: impl Iterator<Item = (usize, f32)>) -> UsedTaps {
        let mut used = UsedTaps { taps: [(0, 0.0); 2 * MAX_RADIUS_LIMIT as usize + 1], len: 0 };
        for t in found {
            used.taps[used.len] = t;
            used.len += 1;
        }
        used
    }

    fn get(&self) -> &[(usize, f32)] {
        &self.taps[..self.len]
    }

    /// Their weights relative to the nearest ([`RelativeWeights::new`]).
    fn weights(&self) -> Option<RelativeWeights> {
        RelativeWeights::new(self.get().iter().map(|t| t.1))
    }
}

/// The mean squared bandwidth `B̄²` of two pixels along `axis`.
fn mean_b2(bi: [f32; 2], bj: [f32; 2], axis: usize) -> f32 {
    0.5 * (bi[axis] * bi[axis] + bj[axis] * bj[axis])
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
    fn new(exponents: impl Iterator<Item = f32>) -> Option<RelativeWeights> {
        // `a < a_min` rather than `f32::min`: NaN never becomes the minimum, as in the WGSL mirror.
        let a_min = exponents.fold(f32::INFINITY, |m, a| if a < m { a } else { m });
        (a_min <= MAX_WEIGHT_EXPONENT).then_some(RelativeWeights { a_min })
    }

    /// The weight of exponent `a`, or `None` for no weight.
    fn weight(&self, a: f32) -> Option<f32> {
        let relative = a - self.a_min;
        (relative <= MAX_WEIGHT_EXPONENT).then(|| (-relative).exp())
    }
}

/// Eqs. 6.21–6.23 (and 6.26 with `previous`) at pixel `(x, y)`; `normal` the pass's unit normals
/// ([`unit_normals`]).
#[allow(clippy::too_many_arguments)]
pub fn filter_pixel(
    x: i32,
    y: i32,
    width: i32,
    height: i32,
    p: &FilterParams,
    value: &[[f32; 3]],
    position: &[[f32; 4]],
    normal: &[Vec3],
    bandwidth: &[[f32; 2]],
    previous: Option<&[[f32; 4]]>,
) -> [f32; 3] {
    let (i, axis) = ((y * width + x) as usize, p.axis as usize);
    let centre = value[i];
    let bi = bandwidth[i];
    if !(position[i][3] > 0.0 && bi[axis] >= 0.0 && bi[axis].is_finite()) {
        return centre;
    }
    let ni = normal[i];
    let xi = v3(position[i]);
    // Neighbour `k`'s index and weight exponent `2 B̄² d²`, or `None` where it is not used.
    let term = |k: i32| -> Option<(usize, f32)> {
        let (jx, jy) = if axis == 0 { (x + k, y) } else { (x, y + k) };
        if jx < 0 || jy < 0 || jx >= width || jy >= height {
            return None;
        }
        let j = (jy * width + jx) as usize;
        let bj = bandwidth[j];
        if !is_finite3(value[j])
            || !(bj[axis] >= 0.0)
            || !compatible(position[i], ni, position[j], normal[j], p.normal_cos)
        {
            return None;
        }
        let d2 = (v3(position[j]) - xi).length_squared();
        Some((j, 2.0 * mean_b2(bi, bj, axis) * d2))
    };
    let used = UsedTaps::new(p.max_radius.taps().filter_map(term));
    let Some(weights) = used.weights() else {
        return centre;
    };
    let mut sum = [0.0f32; 3];
    let mut wsum = 0.0f32;
    for &(j, a) in used.get() {
        let Some(w) = weights.weight(a) else { continue };
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
/// `normal` and `prev_normal` unit normals ([`unit_normals`]).
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
    prev_normal: &[Vec3],
    prev_bandwidth: &[[f32; 2]],
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
    let bi = bandwidth[i];
    // Previous neighbour `k`'s index and weight exponent `2 B̄² d²`, or `None` where it is not used.
    let term = |k: i32| -> Option<(usize, f32)> {
        let jx = px + k;
        if jx < 0 || jx >= width {
            return None;
        }
        let j = (py * width + jx) as usize;
        if !is_finite3(prev_value[j]) || !compatible(position[i], ni, prev_position[j], prev_normal[j], p.normal_cos) {
            return None;
        }
        let d2 = (v3(prev_position[j]) - xi).length_squared();
        Some((j, 2.0 * mean_b2(bi, prev_bandwidth[j], 0) * d2))
    };
    // No neighbour near enough to weigh anything: no history (as when there is no neighbour).
    let used = UsedTaps::new(p.max_radius.taps().filter_map(term));
    let Some(weights) = used.weights() else {
        return none;
    };
    let mut sum = [0.0f32; 3];
    let mut wsum = 0.0f32;
    for &(j, a) in used.get() {
        let Some(w) = weights.weight(a) else { continue };
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
        let (w, h) = (ctx.width as i32, ctx.height as i32);
        let normal = unit_normals(normal);
        let filtered = ctx.map_pixels(false, |x, y| {
            filter_pixel(x as i32, y as i32, w, h, &p, value, position, &normal, bandwidth, previous)
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
        let (position, normal, bandwidth) = (io.position, unit_normals(io.normal), io.bandwidth);
        let (pv, pp, pb) = (io.previous_value, io.previous_position, io.previous_bandwidth);
        let pn = unit_normals(io.previous_normal);
        let cam = ctx.scene.previous_camera;
        let (w, h) = (ctx.width as i32, ctx.height as i32);
        let history = ctx.map_pixels(false, |x, y| {
            history_pixel(x as i32, y as i32, w, h, &p, cam.as_ref(), position, &normal, bandwidth, pv, pp, &pn, pb)
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
