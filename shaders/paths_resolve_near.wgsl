// paths.resolve_near — a PathRecord's near layer; mirrors backends/src/kernels/paths.rs (resolve_near).
#include "common.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let r = record_at(i);
    let w = r.weight;
    var m = vec3<f32>(0.0);
    var coverage = 0.0;
    if (w > 0.0) {
        m = r.l_near / w;
        coverage = r.w_near / w;
    }
    near_put(i, vec4<f32>(m, coverage));
    near_coc_put(i, vec4<f32>(r.r_near, 0.0, 0.0, 0.0));
}
