// pixel_filter.accumulate — the running statistics: the previous frame's (history) combined with this
// frame's paths (Stats::combine); mirrors effects/src/pixel_filter/kernels/sample.rs (Accumulate).
#include "common.wgsl"
#include "pixel_filter_formulas.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    var prev = PfStats(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, 0.0);
    if (previous_lv_bound() && previous_hv_bound()) {
        prev = pf_stats(previous_lv_at(i), previous_hv_at(i));
    }
    let st = pf_combine(prev, pf_stats(sample_lv_at(i), sample_hv_at(i)));
    lv_put(i, vec4<f32>(st.lv, st.n));
    hv_put(i, vec4<f32>(st.u, st.m2));
}
