// hemisphere.wgsl — hemisphere and glossy-lobe sampling with the matching pdfs and BRDF values;
// mirrors backends/src/kernels/hemisphere.rs operation by operation (Frame, cosine_hemisphere,
// power_cosine, reflect, glossy_brdf, glossy_pdf, sample_glossy, sample_diffuse).
// Lobe: LOBE_PHONG or LOBE_BLINN_PHONG (hemisphere::Lobe).
#include "common.wgsl"
#include "sampling.wgsl"

const LOBE_PHONG: u32 = 0u;
const LOBE_BLINN_PHONG: u32 = 1u;

const TAU_F32: f32 = 6.28318530717958647692;
const FRAC_1_PI_F32: f32 = 0.318309886183790671538;

// glam Vec3::max_element: `if a > b { a } else { b }`, nested as max(x, max(y, z)).
fn max_element3(v: vec3<f32>) -> f32 {
    let yz = select(v.z, v.y, v.y > v.z);
    return select(yz, v.x, v.x > yz);
}

// hemisphere::Frame (Duff et al. 2017).
struct OrthoFrame {
    t: vec3<f32>,
    b: vec3<f32>,
    n: vec3<f32>,
}

fn ortho_frame(n: vec3<f32>) -> OrthoFrame {
    // 1.0f32.copysign(n.z)
    let sign = select(1.0, -1.0, (bitcast<u32>(n.z) & 0x80000000u) != 0u);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bb = vec3<f32>(b, sign + n.y * n.y * a, -n.y);
    return OrthoFrame(t, bb, n);
}

fn frame_to_world(f: OrthoFrame, v: vec3<f32>) -> vec3<f32> {
    return f.t * v.x + f.b * v.y + f.n * v.z;
}

fn cosine_hemisphere(u: vec2<f32>) -> vec3<f32> {
    let cos_t = sqrt(rmax(1.0 - u.x, 0.0));
    let sin_t = sqrt(rmax(u.x, 0.0));
    let phi = TAU_F32 * u.y;
    return vec3<f32>(sin_t * cos(phi), sin_t * sin(phi), cos_t);
}

fn power_cosine(u: vec2<f32>, m: f32) -> vec3<f32> {
    let cos_a = pow(rmax(u.x, 0.0), 1.0 / (m + 1.0));
    let sin_a = sqrt(rmax(1.0 - cos_a * cos_a, 0.0));
    let phi = TAU_F32 * u.y;
    return vec3<f32>(sin_a * cos(phi), sin_a * sin(phi), cos_a);
}

fn power_cosine_pdf(cos_a: f32, m: f32) -> f32 {
    if (cos_a <= 0.0) {
        return 0.0;
    }
    return (m + 1.0) / TAU_F32 * pow(cos_a, m);
}

// Mirror direction of `wo` about unit `n`.
fn reflect_about(wo: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return 2.0 * dot3(wo, n) * n - wo;
}

// Glossy BRDF value without k_s.
fn glossy_brdf(lobe: u32, m: f32, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    if (lobe == LOBE_PHONG) {
        let c = dot3(reflect_about(wo, n), wi);
        if (c <= 0.0) {
            return 0.0;
        }
        return (m + 2.0) / TAU_F32 * pow(c, m);
    }
    let h = normalize_or_zero3(wo + wi);
    let c = dot3(h, n);
    if (c <= 0.0) {
        return 0.0;
    }
    return (m + 2.0) / (8.0 * PI_F32) * pow(c, m);
}

// Solid-angle pdf of sampling `wi` with sample_glossy.
fn glossy_pdf(lobe: u32, m: f32, n: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    if (lobe == LOBE_PHONG) {
        return power_cosine_pdf(dot3(reflect_about(wo, n), wi), m);
    }
    let h = normalize_or_zero3(wo + wi);
    let oh = dot3(wo, h);
    if (oh <= 0.0) {
        return 0.0;
    }
    return power_cosine_pdf(dot3(h, n), m) / (4.0 * oh);
}

struct GlossySample {
    wi: vec3<f32>,
    // f cos θ_i / pdf without k_s; 0 below the surface.
    weight: f32,
}

fn sample_glossy(lobe: u32, m: f32, n: vec3<f32>, wo: vec3<f32>, u: vec2<f32>) -> GlossySample {
    if (lobe == LOBE_PHONG) {
        let r = reflect_about(wo, n);
        let wi = normalize3(frame_to_world(ortho_frame(r), power_cosine(u, m)));
        let cos_i = dot3(wi, n);
        var w = 0.0;
        if (cos_i > 0.0) {
            w = (m + 2.0) / (m + 1.0) * cos_i;
        }
        return GlossySample(wi, w);
    }
    let h = normalize3(frame_to_world(ortho_frame(n), power_cosine(u, m)));
    let oh = dot3(wo, h);
    let wi = normalize3(2.0 * oh * h - wo);
    let cos_i = dot3(wi, n);
    var w = 0.0;
    if (cos_i > 0.0 && oh > 0.0) {
        w = (m + 2.0) / (m + 1.0) * oh * cos_i;
    }
    return GlossySample(wi, w);
}

// Cosine-hemisphere direction around `n` (weight 1 for the Lambertian BRDF).
fn sample_diffuse(n: vec3<f32>, u: vec2<f32>) -> vec3<f32> {
    return normalize3(frame_to_world(ortho_frame(n), cosine_hemisphere(u)));
}
