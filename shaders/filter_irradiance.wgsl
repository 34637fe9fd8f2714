// filter.irradiance — thesis eq. 5.31 on factored irradiance, 2-D, with the 10° normal test and the
// w_j(i) < 0.01 rejection; mirrors backends/src/kernels/irradiance_filter.rs (irradiance_pixel) term by term
// and in the same order.
#include "common.wgsl"
#include "filter_window.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let xy = vec2<i32>(pixel_xy(gid));
    let centre = value_at(i);
    if (!is_finite3(centre)) {
        atomicAdd(&counters[COUNTER_NON_FINITE], 1u);
    }
    let om = omega_at(i);
    let ell = pixel_length_at(i);
    if (!valid_width(om) || !valid_width(ell) || !(position_at(i).w > 0.0)) {
        out_put(i, centre);
        return;
    }
    let ni = normalize_or_zero3(normal_at(i).xyz);
    if (is_zero3(ni)) {
        out_put(i, centre);
        return;
    }
    let gi = om / ell;
    let gi2 = gi * gi;
    let xi = position_at(i).xyz;
    let r = window_extent(om, params.max_radius, params.axis);
    var sum = vec3<f32>(0.0);
    var wsum = 0.0;
    for (var dy = -r.y; dy <= r.y; dy = dy + 1) {
        for (var dx = -r.x; dx <= r.x; dx = dx + 1) {
            let p = xy + vec2<i32>(dx, dy);
            if (!in_frame(p)) {
                continue;
            }
            let j = index_at(p.x, p.y);
            if (!(position_at(j).w > 0.0)) {
                continue;
            }
            let v = value_at(j);
            if (!is_finite3(v)) {
                continue;
            }
            if (dot3(ni, normalize_or_zero3(normal_at(j).xyz)) < params.normal_cos) {
                continue;
            }
            let d = position_at(j).xyz - xi;
            let gj = omega_at(j) / pixel_length_at(j);
            let w = pair_weight(dot3(d, d), gi2, gj * gj);
            if (w > 0.0) {
                sum = sum + w * v;
                wsum = wsum + w;
            }
        }
    }
    out_put(i, weighted_mean(sum, wsum, centre));
}
