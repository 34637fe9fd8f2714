// compose.modulate — out = value.rgb · albedo + emission (albedo/emission optional);
// mirrors backends/src/kernels/compose.rs. vec3 buffers are packed f32 arrays.
#include "common.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    var a = vec3<f32>(1.0);
    if (albedo_bound()) {
        a = albedo_at(i);
    }
    var e = vec3<f32>(0.0);
    if (emission_bound()) {
        e = emission_at(i);
    }
    let o = value_at(i).xyz * a + e;
    out_put(i, o);
}
