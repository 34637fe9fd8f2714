// light_field_common.wgsl — what light_field.sample and light_field.reconstruct share: how a ray
// leaves a primary hit (the lobe mixture, eq. 3's weight f cos/pdf) and the sample flags; mirrors
// effects/src/light_field/ (kernels/mod.rs leave, formulas.rs kappa and ao_occluded, records.rs
// SAMPLE_*). The including kernel's Params must have `lobe`, `ao` and `max_distance`.
#include "common.wgsl"
#include "rng.wgsl"
#include "hemisphere.wgsl"
#include "lobe_mixture.wgsl"

const SAMPLE_NONE: u32 = 0u;
const SAMPLE_HIT: u32 = 1u;
const SAMPLE_ESCAPED: u32 = 2u;

struct Leave {
    wi: vec3<f32>,
    weight: vec3<f32>, // f cos/pdf (1 for AO; 0 below the surface or for a black one)
}

// Sample `s` of `count` leaving the primary hit x (normal n, k_d, k_s, m, toward the eye wo), its
// 2-D number stratified over the samples or independent.
fn lf_leave(n: vec3<f32>, kd: vec3<f32>, ks: vec3<f32>, m: f32, wo: vec3<f32>, key: u32, s: u32, count: u32, stratified: bool) -> Leave {
    var u = rng_uniform2(key, s, DIM_BSDF);
    if (stratified) {
        u = rng_stratified2(key, s, max(count, 1u), DIM_BSDF);
    }
    let choice = rng_uniform(key, s, LOBE_SELECT);
    let ao = params.ao != 0u;
    var mix = LobeMixture(false, 0.0, false);
    if (!ao) {
        mix = lobe_mixture(kd, ks, m);
    }
    if (!mix.some) {
        return Leave(sample_diffuse(n, u), select(vec3<f32>(0.0), vec3<f32>(1.0), ao));
    }
    let wi = lobe_sample(params.lobe, m, n, wo, mix, u, choice);
    let cos_i = dot3(wi, n);
    if (cos_i <= 0.0) {
        return Leave(wi, vec3<f32>(0.0));
    }
    let v = lobe_eval(params.lobe, kd, ks, m, mix, n, wo, wi, cos_i);
    if (v.pdf > 0.0) {
        return Leave(wi, v.f * (cos_i / v.pdf));
    }
    return Leave(wi, vec3<f32>(0.0));
}

fn lf_ao_occluded(t: f32) -> bool {
    return params.max_distance <= 0.0 || t <= params.max_distance;
}
