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
    let term = defocus_compose_term(radiance_at(i), texture_at(i), irradiance_at(i), flag_at(i) != 0u);
    if (previous_bound()) {
        let p = previous_at(i);
        out_put(i, vec3<f32>(p.x + term.x, p.y + term.y, p.z + term.z));
    } else {
        out_put(i, term);
    }
}
