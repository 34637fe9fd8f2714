// indirect.compose — out = diffuse·k_d + glossy·k_s + direct·k_d + emission (every input but
// `diffuse` optional: k_d white, k_s zero when absent); mirrors backends/src/kernels/indirect.rs.
// vec3 buffers are packed f32 arrays.
#include "common.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    var kd = vec3<f32>(1.0);
    if (albedo_bound()) {
        kd = albedo_at(i);
    }
    var ks = vec3<f32>(0.0);
    if (specular_bound()) {
        ks = specular_at(i).xyz;
    }
    var v = diffuse_at(i).xyz * kd;
    if (glossy_bound()) {
        v = v + glossy_at(i).xyz * ks;
    }
    if (direct_bound()) {
        v = v + direct_at(i).xyz * kd;
    }
    if (emission_bound()) {
        v = v + emission_at(i);
    }
    out_put(i, v);
}
