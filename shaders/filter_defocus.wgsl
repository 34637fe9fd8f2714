// filter.defocus — thesis eq. 5.33: screen-space pixel-distance Gaussian on composed radiance, 2-D,
// with the w_j(i) < 0.01 rejection; mirrors backends/src/kernels/filter_ch5.rs (defocus_pixel) term
// by term and in the same order.
#include "common.wgsl"
#include "filter_ch5_window.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let width = i32(frame.width);
    let height = i32(frame.height);
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
    let extent = window_extent(om, params.max_radius, params.axis);
    let rx = extent.x;
    let ry = extent.y;
    var sum = vec3<f32>(0.0);
    var wsum = 0.0;
    for (var dy = -ry; dy <= ry; dy = dy + 1) {
        for (var dx = -rx; dx <= rx; dx = dx + 1) {
            let jx = xy.x + dx;
            let jy = xy.y + dy;
            if (jx < 0 || jy < 0 || jx >= width || jy >= height) {
                continue;
            }
            let j = index_at(jx, jy);
            let v = value_at(j);
            if (!is_finite3(v)) {
                continue;
            }
            let d2 = f32(dx * dx + dy * dy);
            let e_i = FILTER_SHARPNESS * d2 * gi2;
            if (!(e_i <= REJECT_EXPONENT)) {
                continue;
            }
            let oj = omega_at(j);
            let e_j = FILTER_SHARPNESS * d2 * (oj * oj);
            if (!(e_j <= REJECT_EXPONENT)) {
                continue;
            }
            let w = exp(-e_i);
            sum = sum + w * v;
            wsum = wsum + w;
        }
    }
    out_put(i, weighted_mean(sum, wsum, centre));
}
