// filter.environment_history — thesis eqs. 6.24–6.25: the previous frame's raw irradiance, x-filtered
// around the previous pixel whose world position is closest to this pixel's (searched over the 3×3
// pixels around its projection by the previous camera), weights measured from this pixel's position;
// w = 1 where any previous neighbour had a weight. Mirrors effects/src/environment/kernels/filter.rs
// (history_pixel, project) term by term and in the same order.
#include "common.wgsl"
#include "camera.wgsl"

// An exponent no used neighbour has: never the smallest, always past max_weight_exponent. (Not
// 1.0 / 0.0: a constant division by zero is a shader-creation error in WGSL.)
const NOT_USED: f32 = 3.0e38;

// filter.rs history_pixel's `term`: the previous pixel (jx, row)'s weight exponent 2 B̄² d²
// measured from this pixel's position, NOT_USED where it is off the image, not finite or on
// another surface.
fn previous_exponent(jx: i32, row: i32, pi: vec4<f32>, ni: vec3<f32>, bi: vec2<f32>) -> f32 {
    if (jx < 0 || jx >= i32(frame.width)) {
        return NOT_USED;
    }
    let j = index_at(jx, row);
    let pj = previous_position_at(j);
    if (!is_finite3(previous_value_at(j)) || !(pj.w == pi.w)
        || !(dot3(ni, normalize_or_zero3(previous_normal_at(j).xyz)) >= params.normal_cos)) {
        return NOT_USED;
    }
    let dd = pj.xyz - pi.xyz;
    let bj = previous_bandwidth_at(j);
    return 2.0 * (0.5 * (bi.x * bi.x + bj.x * bj.x)) * dot3(dd, dd);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let xy = vec2<i32>(pixel_xy(gid));
    let none = vec4<f32>(0.0);
    let pi = position_at(i);
    // A pixel the y pass lets through (no hit, "do not filter") never reads its history.
    let b0 = bandwidth_at(i).x;
    if (params.history == 0u || !(pi.w > 0.0) || !(b0 >= 0.0 && is_finite(b0))) {
        out_put(i, none);
        return;
    }
    let xi = pi.xyz;
    let ni = normalize_or_zero3(normal_at(i).xyz);
    // filter.rs `project`: the previous camera's pixel coordinates of xi.
    let d = xi - params.cam_position;
    let z = dot3(d, params.cam_forward);
    if (!(z > 0.0)) {
        out_put(i, none);
        return;
    }
    let w = f32(max(frame.width, 1u));
    let h = f32(max(frame.height, 1u));
    let sx = dot3(d, params.cam_right) / z;
    let sy = dot3(d, params.cam_up) / z;
    let qx = (sx / (params.cam_tan_half * (w / h)) + 1.0) * 0.5 * w;
    let qy = (1.0 - sy / params.cam_tan_half) * 0.5 * h;
    // Off the previous frame (or not a number): that frame did not see this point.
    if (!(qx >= 0.0 && qx < w && qy >= 0.0 && qy < h)) {
        out_put(i, none);
        return;
    }
    let fx = i32(floor(qx));
    let fy = i32(floor(qy));
    // Moved farther than max_motion pixels: no history (filter.rs HistoryParams::max_motion).
    if (abs(fx - xy.x) > params.max_motion || abs(fy - xy.y) > params.max_motion) {
        out_put(i, none);
        return;
    }
    var found = false;
    var best_d2 = 0.0;
    var bx = 0;
    var by = 0;
    for (var dy = -1; dy <= 1; dy = dy + 1) {
        for (var dx = -1; dx <= 1; dx = dx + 1) {
            let sxp = fx + dx;
            let syp = fy + dy;
            if (sxp < 0 || syp < 0 || sxp >= i32(frame.width) || syp >= i32(frame.height)) {
                continue;
            }
            let pj = previous_position_at(index_at(sxp, syp));
            if (!(pj.w == pi.w)) {
                continue;
            }
            let dd = pj.xyz - xi;
            let d2 = dot3(dd, dd);
            if (!found || d2 < best_d2) {
                found = true;
                best_d2 = d2;
                bx = sxp;
                by = syp;
            }
        }
    }
    if (!found) {
        out_put(i, none);
        return;
    }
    let bi = bandwidth_at(i);
    // filter.rs RelativeWeights: weights relative to the nearest neighbour's, cut at
    // params.max_weight_exponent, so no weight is subnormal (flushed here, kept on the CPU) and
    // whether a pixel has history is decided alike on both backends.
    var a_min = NOT_USED;
    for (var k = -params.max_radius; k <= params.max_radius; k = k + 1) {
        let a = previous_exponent(bx + k, by, pi, ni, bi);
        if (a < a_min) {
            a_min = a;
        }
    }
    if (!(a_min <= params.max_weight_exponent)) {
        out_put(i, none);
        return;
    }
    var sum = vec3<f32>(0.0);
    var wsum = 0.0;
    for (var k = -params.max_radius; k <= params.max_radius; k = k + 1) {
        let relative = previous_exponent(bx + k, by, pi, ni, bi) - a_min;
        if (!(relative <= params.max_weight_exponent)) {
            continue;
        }
        let wt = exp(-relative);
        sum = sum + wt * previous_value_at(index_at(bx + k, by));
        wsum = wsum + wt;
    }
    out_put(i, vec4<f32>(sum.x / wsum, sum.y / wsum, sum.z / wsum, 1.0));
}
