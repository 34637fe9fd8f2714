// indirect.bandwidth — β (metres) per component and the diffuse β in pixels; mirrors
// effects/src/indirect/kernels.rs `Bandwidth` with the formulas of indirect_formulas.wgsl.
#include "common.wgsl"
#include "indirect_formulas.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    // The bandwidth pass reads no rate settings: initial = max = 1 as on the CPU.
    let s = indirect_settings(1u, 1u);
    let dp = depth_at(i);
    let d = normal_at(i).w;
    // The neighbourhood's nearest reflector (`width_z_min: "nearest"`); unbound reads as 0 = none.
    let near = nearest_at(i);
    let has_stats = dp.w > 0.0;
    var bd = 0.0;
    if (has_stats) {
        bd = indirect_component(Receiver(RECEIVER_DIFFUSE, 0.0), dp, near, d, s).beta;
    }
    beta_diffuse_put(i, bd);
    filter_width_put(i, select(0.0, bd / d, bd > 0.0));
    if (beta_glossy_bound()) {
        var bg = 0.0;
        if (has_stats && specular_bound()) {
            let sp = specular_at(i);
            if (indirect_has_glossy(sp)) {
                let r = Receiver(select(RECEIVER_PHONG, RECEIVER_BLINN_PHONG, params.brdf != 0u), sp.w);
                bg = indirect_component(r, dp, near, d, s).beta;
            }
        }
        beta_glossy_put(i, bg);
    }
}
