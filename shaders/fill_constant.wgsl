// fill.constant (u32) and fill.constant_f32 — out = value at every pixel (a reference's sample count, a zero width); mirrors
// backends/src/kernels/constant.rs.
#include "common.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    out_put(pixel_index(gid), params.value);
}
