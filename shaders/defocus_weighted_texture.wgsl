// defocus.weighted_texture — a factored part's texture weighted by the irradiance each path brought,
// L / Ē per channel (else the paths' mean k); mirrors effects/src/defocus/kernels.rs `WeightedTexture`.
#include "common.wgsl"
#include "defocus_formulas.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    out_put(i, defocus_weighted_texture(radiance_at(i), texture_at(i), irradiance_at(i)));
}
