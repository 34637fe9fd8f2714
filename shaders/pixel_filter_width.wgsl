// pixel_filter.width — the adaptive spatial sigma (seed 002 Sec. 3.6.3, eqs. 3.15-3.17); mirrors
// effects/src/pixel_filter/kernels/blend.rs (width_pixel).
#include "common.wgsl"
#include "pixel_filter_formulas.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let lv = lv_at(i);
    let n = lv.w;
    let f = previous_filtered_at(i);
    let v = previous_variance_at(i);
    if (v.w != PF_FILTERED) {
        sigma_put(i, rmin(params.sigma_s / sqrt(rmax(n, 1.0)), params.sigma_s));
        return;
    }
    let lb = pf_luminance(vec3<f32>(f.x + lv.x, f.y + lv.y, f.z + lv.z));
    sigma_put(i, pf_adaptive_sigma(v.x, n, lb, params.t, params.sigma_s, params.adaptive_c));
}
