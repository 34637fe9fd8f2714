// indirect.rates — samples per pixel per component (eq. 4.21) clamped to [initial, max·max(μ,1)]
// and to `rays_cap`, and their sum; mirrors effects/src/indirect/kernels.rs `Rates` with the formulas of
// indirect_formulas.wgsl.
#include "common.wgsl"
#include "indirect_formulas.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let s = indirect_settings(params.initial_rays, params.max_rays);
    let dp = depth_at(i);
    var nd = 0u;
    var ng = 0u;
    if (dp.w > 0.0) {
        let d = normal_at(i).w;
        nd = indirect_component(Receiver(RECEIVER_DIFFUSE, 0.0), dp, 0.0, d, s).rays;
        if (specular_bound() && rays_glossy_bound()) {
            let sp = specular_at(i);
            if (indirect_has_glossy(sp)) {
                let r = Receiver(select(RECEIVER_PHONG, RECEIVER_BLINN_PHONG, params.brdf != 0u), sp.w);
                ng = indirect_component(r, dp, 0.0, d, s).rays;
            }
        }
        nd = min(nd, params.rays_cap);
        ng = min(ng, params.rays_cap);
    }
    rays_diffuse_put(i, nd);
    if (rays_glossy_bound()) {
        rays_glossy_put(i, ng);
    }
    rays_per_pixel_put(i, nd + ng);
}
