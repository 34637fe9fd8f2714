// The window and rejection constants the factoring nodes' filters share (filter.irradiance, eq. 5.31;
// filter.defocus, eq. 5.33; filter.motion, eqs. B.1–B.2), their window, neighbour weight and weighted
// mean; mirrors the constants, `window_radius`, `Axis::extent`, `pair_weight` and `gather` of
// backends/src/kernels/filter_window.rs.
// Needs common.wgsl (`frame`), which both filters include first.

const FILTER_SHARPNESS: f32 = 16.0;
const REJECT_EXPONENT: f32 = 4.6051702;
const REJECT_RADIUS: f32 = 0.5364915;

fn valid_width(w: f32) -> bool {
    return w > 0.0 && is_finite(w);
}

// ceil(0.5365 / Ω), at most the cap (filter_window.rs window_radius).
fn window_radius(omega: f32, cap: i32) -> i32 {
    let r = REJECT_RADIUS / omega;
    if (!(r < f32(cap))) {
        return cap;
    }
    return max(i32(ceil(r)), 0);
}

// Half-extents (x, y) of the visited window: 2-D (axis -1), or one axis of it (0: x, 1: y)
// (filter_window.rs Axis::extent).
fn window_extent(omega: f32, cap: i32, axis: i32) -> vec2<i32> {
    let r = window_radius(omega, cap);
    if (axis == 0) {
        return vec2<i32>(r, 0);
    }
    if (axis == 1) {
        return vec2<i32>(0, r);
    }
    return vec2<i32>(r, r);
}

// Whether window pixel `p` lies in the frame (filter_window.rs gather).
fn in_frame(p: vec2<i32>) -> bool {
    return p.x >= 0 && p.y >= 0 && p.x < i32(frame.width) && p.y < i32(frame.height);
}

// The weight w_i(j) = exp(-16 d² g_i²) of neighbour j at squared distance `d2` (eqs. 5.31, 5.33;
// g = Ω, or Ω/ℓ_p for the irradiance filter), or 0 where j is rejected: outside i's truncated
// Gaussian (w_i(j) < 0.01) or i outside j's filter (w_j(i) < 0.01, thesis Sec. 5.8). Accepted
// weights are >= 0.01, so 0 marks a rejection (filter_window.rs pair_weight).
fn pair_weight(d2: f32, gi2: f32, gj2: f32) -> f32 {
    let e_i = FILTER_SHARPNESS * d2 * gi2;
    let e_j = FILTER_SHARPNESS * d2 * gj2;
    if (!(e_i <= REJECT_EXPONENT) || !(e_j <= REJECT_EXPONENT)) {
        return 0.0;
    }
    return exp(-e_i);
}

// The weighted mean, or the centre value where no neighbour had a weight (filter_window.rs gather).
fn weighted_mean(sum: vec3<f32>, wsum: f32, centre: vec3<f32>) -> vec3<f32> {
    if (wsum > 0.0) {
        return vec3<f32>(sum.x / wsum, sum.y / wsum, sum.z / wsum);
    }
    return centre;
}
