// environment_light.wgsl — environment lighting as the path sampler and the indirect paths see it;
// mirrors backends/src/kernels/environment.rs (stratified_entry, uniform_entry, environment_event)
// and Vertex::brdf (backends/src/kernels/indirect.rs) with the same look-ups and operation order.
// Needs scene.wgsl (env_table) and, for environment_query, the including kernel's Params `eps` and
// `lobe`.
#include "common.wgsl"
#include "rng.wgsl"
#include "hemisphere.wgsl"

// Entry (shift XOR q) mod 4096: a pixel's q-th stratified look-up.
fn env_stratified_entry(shift: u32, q: u32) -> u32 {
    return (shift ^ q) & (ENV_TABLE_SIZE - 1u);
}

// The entry a uniform u in [0, 1) picks: floor(u · 4096) (exact in f32).
fn env_uniform_entry(u: f32) -> u32 {
    return min(u32(u * f32(ENV_TABLE_SIZE)), ENV_TABLE_SIZE - 1u);
}

// k_d/π + k_s ρ_s for light arriving along wi.
fn surface_brdf(kd: vec3<f32>, ks: vec3<f32>, m: f32, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    var f = kd * FRAC_1_PI_F32;
    if (m > 0.0 && max_element3(ks) > 0.0) {
        f = f + ks * glossy_brdf(params.lobe, m, n, wo, wi);
    }
    return f;
}

// A shadow ray a next event asks for (`wanted`: from `origin` along `dir` up to `tmax`) and what the
// event brings when nothing blocks it: `total`, and `glossy`, the part through the glossy lobe.
// The caller traces it (indirect_path.wgsl `next_events`: one traversal call site for all events).
struct ShadowQuery {
    wanted: bool,
    origin: vec3<f32>,
    dir: vec3<f32>,
    tmax: f32,
    total: vec3<f32>,
    glossy: vec3<f32>,
}

fn no_shadow_query() -> ShadowQuery {
    return ShadowQuery(false, vec3<f32>(0.0), vec3<f32>(0.0), 0.0, vec3<f32>(0.0), vec3<f32>(0.0));
}

// Next-event estimation of the environment at a path vertex: one table look-up (DIM_ENVIRONMENT of
// the bounce), a shadow ray to infinity, L f cos / pdf; no ray without a map (indirect.rs
// environment_event).
fn environment_query(y: vec3<f32>, n: vec3<f32>, wo: vec3<f32>, kd: vec3<f32>, ks: vec3<f32>, m: f32, key: u32, sample: u32,
        bounce: u32) -> ShadowQuery {
    if (!env_present()) {
        return no_shadow_query();
    }
    let e = env_table(env_uniform_entry(rng_uniform(key, sample, DIM_ENVIRONMENT + bounce * DIM_BOUNCE_STRIDE)));
    let c = dot3(n, e.dir);
    if (!(c > 0.0 && e.pdf > 0.0)) {
        return no_shadow_query();
    }
    let value = e.radiance * surface_brdf(kd, ks, m, n, wo, e.dir) * (c / e.pdf);
    return ShadowQuery(true, y + n * params.eps, e.dir, inf(), value, vec3<f32>(0.0));
}
