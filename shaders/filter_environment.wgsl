// filter.environment — thesis eqs. 6.21–6.23: one image axis of the world-space Gaussian
// exp(−2 B̄² ‖p − p'‖²) with B̄² the mean of the two pixels' squared bandwidths along the axis; with
// `previous` bound, the y pass joins the previous frame's x-filtered irradiance (eq. 6.26 as read in
// backends/src/kernels/filter_ch6.rs). Mirrors filter_ch6.rs (filter_pixel) term by term and in the
// same order.
#include "common.wgsl"

fn mean_b2(bi: vec2<f32>, bj: vec2<f32>, axis: u32) -> f32 {
    return 0.5 * (bi[axis] * bi[axis] + bj[axis] * bj[axis]);
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
    let xi = pi.xyz;
    var sum = vec3<f32>(0.0);
    var wsum = 0.0;
    for (var k = -params.max_radius; k <= params.max_radius; k = k + 1) {
        var p = vec2<i32>(xy.x + k, xy.y);
        if (params.axis == 1u) {
            p = vec2<i32>(xy.x, xy.y + k);
        }
        if (p.x < 0 || p.y < 0 || p.x >= i32(frame.width) || p.y >= i32(frame.height)) {
            continue;
        }
        let j = index_at(p.x, p.y);
        let v = value_at(j);
        let pj = position_at(j);
        let bj = bandwidth_at(j);
        if (!is_finite3(v) || !(bj[params.axis] >= 0.0) || !(pj.w == pi.w)
            || !(dot3(ni, normalize_or_zero3(normal_at(j).xyz)) >= params.normal_cos)) {
            continue;
        }
        let d = pj.xyz - xi;
        let d2 = dot3(d, d);
        let w = exp(-2.0 * mean_b2(bi, bj, params.axis) * d2);
        sum = sum + w * v;
        wsum = wsum + w;
        if (previous_bound()) {
            let e = previous_at(j);
            if (e.w > 0.0 && is_finite3(e.xyz)) {
                sum = sum + w * e.xyz;
                wsum = wsum + w;
            }
        }
    }
    if (wsum > 0.0) {
        out_put(i, vec3<f32>(sum.x / wsum, sum.y / wsum, sum.z / wsum));
    } else {
        out_put(i, centre);
    }
}
