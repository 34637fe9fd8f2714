// shadows.visibility — the pair (ΣE, ΣU) the filter averages for the ratio estimate of visibility;
// mirrors effects/src/shadows/kernels.rs `Visibility`.
#include "common.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let e = direct_at(i);
    let u = unshadowed_at(i);
    out_put(i, vec4<f32>(e.x + e.y + e.z, u.x + u.y + u.z, 0.0, e.w));
}
