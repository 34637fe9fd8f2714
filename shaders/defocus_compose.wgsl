// defocus.compose — one component of eq. 5.32 added to the running sum; mirrors
// effects/src/defocus/kernels.rs `Compose`.
#include "common.wgsl"
#include "defocus_formulas.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let l = radiance_at(i);
    let term = defocus_compose_term(l.xyz, texture_at(i).xyz, irradiance_at(i).xyz, flag_at(i) != 0u);
    if (previous_bound()) {
        let p = previous_at(i);
        out_put(i, vec4<f32>(p.x + term.x, p.y + term.y, p.z + term.z, p.w));
    } else {
        out_put(i, vec4<f32>(term, l.w));
    }
}
