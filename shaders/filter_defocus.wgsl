// filter.defocus — thesis eq. 5.33: screen-space pixel-distance Gaussian on composed radiance, 2-D,
// with the w_j(i) < 0.01 rejection; mirrors effects/src/defocus/kernels/filter.rs (defocus_pixel) term
// by term and in the same order.
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
    if (!valid_width(om)) {
        out_put(i, centre);
        return;
    }
    let gi2 = om * om;
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
            let v = value_at(j);
            if (!is_finite3(v)) {
                continue;
            }
            let oj = omega_at(j);
            let w = pair_weight(f32(dx * dx + dy * dy), gi2, oj * oj);
            if (w > 0.0) {
                sum = sum + w * v;
                wsum = wsum + w;
            }
        }
    }
    out_put(i, weighted_mean(sum, wsum, centre));
}
