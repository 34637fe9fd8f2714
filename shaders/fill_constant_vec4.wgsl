// fill.constant_vec4 — out = (value, value, value, value) at every pixel; mirrors
// backends/src/kernels/constant.rs FillConstantVec4.
#include "common.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    out_put(pixel_index(gid), vec4<f32>(params.value));
}
