// compose.add — out = a + b per pixel and channel; mirrors effects/src/add.rs.
// vec3 buffers are packed f32 arrays (3 floats per pixel).
#include "common.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    out_put(i, a_at(i) + b_at(i));
}
