// radiance_filter.compose — this frame's direct + filtered indirect light accumulated over frames, or
// the plain accumulation once a pixel is in the correction phase (`switch_mode`, seed 002 Sec. 4.4.1);
// mirrors effects/src/radiance_filter/formulas.rs (compose_pixel).
#include "common.wgsl"
#include "radiance_filter_formulas.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let slv = sample_lv_at(i);
    let f = filtered_at(i);
    let unfiltered = lv_at(i).xyz + hv_at(i).xyz;
    var previous = vec4<f32>(0.0);
    if (previous_accumulated_bound()) {
        previous = previous_accumulated_at(i);
    }
    var previous_phase = 0.0;
    if (previous_phase_bound()) {
        previous_phase = previous_phase_at(i);
    }
    let own_only = f.w != RF_FILTERED;
    var indirect = f.xyz;
    if (own_only) {
        indirect = own_at(i).xyz;
    }
    let x = slv.xyz + indirect;
    let b = slv.w;
    var acc = previous;
    if (b > 0.0) {
        let n = previous.w + b;
        acc = vec4<f32>(previous.xyz + (x - previous.xyz) * (b / n), n);
    }
    var now = 0.0;
    if (own_only) {
        now = 1.0;
    }
    var phase = now;
    // correction: 0 = accumulate, 1 = switch (the options' order, `Correction`).
    if (params.correction != 0u) {
        phase = rmax(previous_phase, now);
    }
    var radiance = acc.xyz;
    if (params.correction != 0u && phase >= 1.0) {
        radiance = unfiltered;
    }
    accumulated_put(i, acc);
    radiance_put(i, radiance);
    unfiltered_put(i, unfiltered);
    phase_put(i, phase);
}
