// filter.radiance3 — thesis App. B: a 1-2-1 tent over the 3×3 neighbourhood of the finite radiance
// values at pixels whose `mask` is set (multi-velocity pixels); mirrors
// backends/src/kernels/filter_motion.rs (radiance3_pixel) term by term and in the same order.
#include "common.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let centre = value_at(i);
    if (!is_finite3(centre)) {
        atomicAdd(&counters[COUNTER_NON_FINITE], 1u);
    }
    if (mask_at(i) == 0u) {
        out_put(i, centre);
        return;
    }
    let xy = vec2<i32>(pixel_xy(gid));
    var sum = vec3<f32>(0.0);
    var wsum = 0.0;
    for (var dy = -1; dy <= 1; dy = dy + 1) {
        for (var dx = -1; dx <= 1; dx = dx + 1) {
            let p = xy + vec2<i32>(dx, dy);
            if (p.x < 0 || p.y < 0 || p.x >= i32(frame.width) || p.y >= i32(frame.height)) {
                continue;
            }
            let v = value_at(index_at(p.x, p.y));
            if (!is_finite3(v)) {
                continue;
            }
            let w = f32((2 - abs(dx)) * (2 - abs(dy)));
            sum = sum + w * v;
            wsum = wsum + w;
        }
    }
    if (wsum > 0.0) {
        out_put(i, vec3<f32>(sum.x / wsum, sum.y / wsum, sum.z / wsum));
    } else {
        out_put(i, centre);
    }
}
