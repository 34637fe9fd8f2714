// indirect.nearest — the nearest reflector the eight neighbours' first passes saw on the pixel's
// object (0 = none); mirrors effects/src/indirect/formulas.rs `nearest`.
#include "common.wgsl"
#include "same_object_neighbour.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    if (!(depth_at(i).w > 0.0)) {
        nearest_put(i, 0.0);
        return;
    }
    let xy = vec2<i32>(pixel_xy(gid));
    var z = 3.0e38;
    var found = false;
    for (var dy = -1; dy <= 1; dy = dy + 1) {
        for (var dx = -1; dx <= 1; dx = dx + 1) {
            let j = same_object_neighbour(i, xy, dx, dy);
            if (j < 0) {
                continue;
            }
            let v = depth_at(u32(j));
            if (v.w > 0.0 && v.z > 0.0) {
                z = min(z, v.x);
                found = true;
            }
        }
    }
    nearest_put(i, select(0.0, z, found));
}
