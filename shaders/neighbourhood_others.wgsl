// neighbourhood.others — a pixel's first-pass statistics from its eight neighbours on the same
// object, its own samples left out; mirrors backends/src/kernels/neighbourhood_others.rs.
#include "common.wgsl"
#include "same_object_neighbour.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let xy = vec2<i32>(pixel_xy(gid));
    let own = value_at(i);
    if (!(own.w > 0.0)) {
        out_put(i, own);
        return;
    }
    var min_sum = 0.0;
    var max_sum = 0.0;
    var hits = 0.0;
    var n = 0u;
    var with_hits = 0u;
    for (var dy = -1; dy <= 1; dy = dy + 1) {
        for (var dx = -1; dx <= 1; dx = dx + 1) {
            let j = same_object_neighbour(i, xy, dx, dy);
            if (j < 0) {
                continue;
            }
            let v = value_at(u32(j));
            if (!(v.w > 0.0)) {
                continue;
            }
            n = n + 1u;
            if (v.z > 0.0) {
                min_sum = min_sum + v.x;
                max_sum = max_sum + v.y;
                hits = hits + v.z;
                with_hits = with_hits + 1u;
            }
        }
    }
    if (n == 0u) {
        out_put(i, own);
    } else if (hits > 0.0) {
        out_put(i, vec4<f32>(min_sum / f32(with_hits), max_sum / f32(with_hits), hits, own.w));
    } else {
        out_put(i, vec4<f32>(0.0, 0.0, 0.0, own.w));
    }
}
