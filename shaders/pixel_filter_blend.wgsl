// pixel_filter.blend — L = L_lv + s L_u + (1 - s) L_f (seed 002 eq. 3.1) with s from eqs. 3.10-3.13
// and the optional spike clamp (eq. 3.18); mirrors effects/src/pixel_filter/kernels/blend.rs (blend_pixel).
#include "common.wgsl"
#include "pixel_filter_formulas.wgsl"

fn pf_perceived(v: f32, lb: f32) -> f32 {
    if (!(v > 0.0)) {
        return 0.0;
    }
    if (lb > 0.0) {
        return v / (lb * lb);
    }
    return inf();
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let lv = lv_at(i);
    let hv = hv_at(i);
    let filt = filtered_at(i);
    let v = variance_at(i);
    let n = lv.w;
    let unfiltered = lv.xyz + hv.xyz;
    unfiltered_put(i, unfiltered);
    if (!(n > 0.0) || v.w != PF_FILTERED) {
        radiance_put(i, unfiltered);
        blend_put(i, 1.0);
        return;
    }
    let lf = filt.xyz;
    let lb = pf_luminance(lf + lv.xyz);
    let s = pf_blend_factor(pf_perceived(v.x / n, lb), pf_perceived(filt.w, lb), params.t);
    if (s >= 1.0) {
        radiance_put(i, unfiltered);
        blend_put(i, 1.0);
        return;
    }
    var lu = hv.xyz;
    if (params.spike_c > 0.0) {
        lu = pf_spike_clamp(lu, lf, params.spike_c);
    }
    radiance_put(i, lv.xyz + (lu * s + lf * (1.0 - s)));
    blend_put(i, s);
}
