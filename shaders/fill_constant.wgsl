// fill.constant — out = value at every pixel (a reference's sample count); mirrors
// backends/src/kernels/constant.rs.
#include "common.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    out_put(pixel_index(gid), params.value);
}
