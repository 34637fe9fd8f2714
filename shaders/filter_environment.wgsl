// filter.environment — thesis eqs. 6.21–6.23: one image axis of the world-space Gaussian
// exp(−2 B̄² ‖p − p'‖²) with B̄² the mean of the two pixels' squared bandwidths along the axis; with
// `previous` bound, the y pass joins the previous frame's x-filtered irradiance (eq. 6.26 as read in
// effects/src/environment/kernels/filter.rs). Mirrors that file's filter_pixel term by term and in
// the same order.
#include "common.wgsl"

fn mean_b2(bi: vec2<f32>, bj: vec2<f32>, axis: u32) -> f32 {
    return 0.5 * (bi[axis] * bi[axis] + bj[axis] * bj[axis]);
}

// An exponent no used neighbour has: never the smallest, always past max_weight_exponent. (Not
// 1.0 / 0.0: a constant division by zero is a shader-creation error in WGSL.)
const NOT_USED: f32 = 3.0e38;

// The pixel k steps from xy along the pass's axis (possibly off the image).
fn neighbour_xy(xy: vec2<i32>, k: i32) -> vec2<i32> {
    if (params.axis == 1u) {
        return vec2<i32>(xy.x, xy.y + k);
    }
    return vec2<i32>(xy.x + k, xy.y);
}

fn neighbour_index(xy: vec2<i32>, k: i32) -> u32 {
    let p = neighbour_xy(xy, k);
    return index_at(p.x, p.y);
}

// filter.rs filter_pixel's `term`: neighbour k's weight exponent 2 B̄² d², NOT_USED where it is
// off the image, not finite, "do not filter", or on another surface.
fn neighbour_exponent(xy: vec2<i32>, k: i32, pi: vec4<f32>, ni: vec3<f32>, bi: vec2<f32>) -> f32 {
    let p = neighbour_xy(xy, k);
    if (p.x < 0 || p.y < 0 || p.x >= i32(frame.width) || p.y >= i32(frame.height)) {
        return NOT_USED;
    }
    let j = index_at(p.x, p.y);
    let pj = position_at(j);
    let bj = bandwidth_at(j);
    if (!is_finite3(value_at(j)) || !(bj[params.axis] >= 0.0) || !(pj.w == pi.w)
        || !(dot3(ni, normalize_or_zero3(normal_at(j).xyz)) >= params.normal_cos)) {
        return NOT_USED;
    }
    let d = pj.xyz - pi.xyz;
    return 2.0 * mean_b2(bi, bj, params.axis) * dot3(d, d);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let xy = vec2<i32>(pixel_xy(gid));
    let centre = value_at(i);
    if (params.axis == 0u && !is_finite3(centre)) {
        atomicAdd(&counters[COUNTER_NON_FINITE], 1u);
    }
    let bi = bandwidth_at(i);
    let pi = position_at(i);
    if (!(pi.w > 0.0 && bi[params.axis] >= 0.0 && is_finite(bi[params.axis]))) {
        out_put(i, centre);
        return;
    }
    let ni = normalize_or_zero3(normal_at(i).xyz);
    // filter.rs RelativeWeights: weights relative to the nearest neighbour's, cut at
    // params.max_weight_exponent, so no weight is subnormal (flushed here, kept on the CPU).
    var a_min = NOT_USED;
    for (var k = -params.max_radius; k <= params.max_radius; k = k + 1) {
        let a = neighbour_exponent(xy, k, pi, ni, bi);
        if (a < a_min) {
            a_min = a;
        }
    }
    if (!(a_min <= params.max_weight_exponent)) {
        out_put(i, centre);
        return;
    }
    var sum = vec3<f32>(0.0);
    var wsum = 0.0;
    for (var k = -params.max_radius; k <= params.max_radius; k = k + 1) {
        let relative = neighbour_exponent(xy, k, pi, ni, bi) - a_min;
        if (!(relative <= params.max_weight_exponent)) {
            continue;
        }
        let w = exp(-relative);
        let j = neighbour_index(xy, k);
        sum = sum + w * value_at(j);
        wsum = wsum + w;
        if (previous_bound()) {
            let e = previous_at(j);
            if (e.w > 0.0 && is_finite3(e.xyz)) {
                sum = sum + w * e.xyz;
                wsum = wsum + w;
            }
        }
    }
    // The nearest neighbour's weight is 1: wsum >= 1.
    out_put(i, vec3<f32>(sum.x / wsum, sum.y / wsum, sum.z / wsum));
}
