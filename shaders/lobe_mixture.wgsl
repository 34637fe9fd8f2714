// lobe_mixture.wgsl — the one-sample lobe mixture of a diffuse + glossy surface; mirrors
// backends/src/kernels/indirect.rs (weight_of, lobe_mixture, LobeMixture::sample / eval).
// Shared by indirect_path.wgsl, first_vertex.wgsl and radiance_filter.filter (which re-weights
// neighbours' directions under a pixel's own BRDF and pdf, seed 002 eq. 4.10).
#include "common.wgsl"
#include "hemisphere.wgsl"

// Dimension choosing the lobe at a path vertex (indirect.rs LOBE_SELECT).
const LOBE_SELECT: u32 = 14u;

// Relative weight of a lobe for lobe selection (mean of the rgb coefficients).
fn weight_of(c: vec3<f32>) -> f32 {
    return (c.x + c.y + c.z) / 3.0;
}

struct LobeMixture {
    some: bool,
    pd: f32,
    glossy: bool,
}

fn lobe_mixture(kd: vec3<f32>, ks: vec3<f32>, m: f32) -> LobeMixture {
    let is_glossy = m > 0.0 && max_element3(ks) > 0.0;
    let wd = rmax(weight_of(kd), 0.0);
    var ws = 0.0;
    if (is_glossy) {
        ws = rmax(weight_of(ks), 0.0);
    }
    if (!(wd + ws > 0.0)) {
        return LobeMixture(false, 0.0, false);
    }
    return LobeMixture(true, wd / (wd + ws), is_glossy);
}

// f = fd + g: the diffuse and glossy parts.
struct LobeValue {
    f: vec3<f32>,
    fd: vec3<f32>,
    g: vec3<f32>,
    pdf: f32,
}

// LobeMixture::sample: the diffuse lobe when `select` < pd, else the glossy one, from `u`.
fn lobe_sample(lobe: u32, m: f32, n: vec3<f32>, wo: vec3<f32>, mix: LobeMixture, u: vec2<f32>, select: f32) -> vec3<f32> {
    if (select < mix.pd) {
        return sample_diffuse(n, u);
    }
    return sample_glossy(lobe, m, n, wo, u).wi;
}

fn lobe_eval(lobe: u32, kd: vec3<f32>, ks: vec3<f32>, m: f32, mix: LobeMixture, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>,
    cos_i: f32) -> LobeValue {
    let fd = kd * FRAC_1_PI_F32;
    var f = fd;
    var g = vec3<f32>(0.0);
    var pdf = mix.pd * cos_i * FRAC_1_PI_F32;
    if (mix.glossy) {
        g = ks * glossy_brdf(lobe, m, n, wo, wi);
        f = f + g;
        pdf = pdf + (1.0 - mix.pd) * glossy_pdf(lobe, m, n, wo, wi);
    }
    return LobeValue(f, fd, g, pdf);
}

