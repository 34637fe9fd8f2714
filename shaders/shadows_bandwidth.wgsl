// shadows.bandwidth — β (metres) and β in pixels; mirrors effects/src/shadows/kernels.rs `Bandwidth`.
#include "common.wgsl"
#include "shadows_formulas.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let occ = occlusion_at(i);
    let d = normal_at(i).w;
    var b = 0.0;
    if (occ.w > 0.0) {
        let s = shadows_slopes(occ.x, occ.y, occ.z);
        b = shadows_filter_beta(params.sigma, s.x, d, params.mu, params.alpha, params.k);
    }
    beta_put(i, b);
    filter_width_put(i, select(0.0, b / d, b > 0.0));
}
