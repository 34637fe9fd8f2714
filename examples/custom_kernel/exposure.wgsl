// example.exposure — out = value · 2^stops. The scale is computed on the CPU (`f32::powf`) and
// handed over in the uniform block, so both backends multiply by the same float: bit-identical.
#include "common.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    out_put(i, value_at(i) * params.scale);
}
