// defocus.flags — SepDir / SepInd for one component (eq. 5.30); mirrors effects/src/defocus/kernels.rs
// `Flags`.
#include "common.wgsl"
#include "defocus_formulas.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let sep = defocus_separable(radiance_at(i), texture_at(i), irradiance_at(i), params.threshold);
    flag_put(i, select(0u, 1u, sep));
}
