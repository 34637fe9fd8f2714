//! Hemisphere and lobe sampling for the indirect-light path tracer (thesis Ch. 4: "stratified and
//! importance sampled" hemisphere rays), with the matching pdfs and BRDF values.
//!
//! Directions are in a local frame with `z` along the lobe axis (the normal for the cosine
//! hemisphere and the Blinn-Phong half vector, the mirror direction for the Phong lobe); [`Frame`]
//! maps them to world space. All maps take `u ∈ [0,1)²`, so stratified `u` gives stratified
//! directions.
//!
//! BRDFs (k_d, k_s left out: textures multiply after filtering, thesis Sec. 4.5):
//! - Lambertian `1/π`, sampled with pdf `cos θ/π` → weight `f cos θ / pdf = 1`.
//! - Normalised Phong `(m+2)/(2π) cos^m α` (α between `ω_i` and the mirror direction of `ω_o`),
//!   sampled with pdf `(m+1)/(2π) cos^m α` → weight `(m+2)/(m+1) cos θ_i` (0 below the surface).
//! - Normalised Blinn-Phong `(m+2)/(8π) cos^m θ_h`, half vector sampled with pdf
//!   `(m+1)/(2π) cos^m θ_h`, so `pdf(ω_i) = (m+1) cos^m θ_h / (8π (ω_o·h))` → weight
//!   `(m+2)/(m+1) (ω_o·h) cos θ_i`.

use std::f32::consts::{PI, TAU};

use glam::{Vec2, Vec3};

crate::param_choice! {
    /// Glossy lobe model of a material's `k_s, m`: the `brdf` parameter of every node that traces
    /// glossy paths (declared once: `wedge_effects::params::brdf`). WGSL: 0 = Phong, 1 = Blinn-Phong.
    pub enum Lobe {
        Phong = "phong",
        BlinnPhong = "blinn_phong",
    }
}

/// Orthonormal frame around a unit vector (Duff et al. 2017, branchless).
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub t: Vec3,
    pub b: Vec3,
    pub n: Vec3,
}

impl Frame {
    pub fn new(n: Vec3) -> Frame {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let t = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let bb = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { t, b: bb, n }
    }
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.t * v.x + self.b * v.y + self.n * v.z
    }
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }
}

/// Cosine-weighted hemisphere around +z: `cos θ = sqrt(1 − u.x)`, `φ = 2π u.y` (pdf `cos θ/π`).
#[inline]
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let cos_t = (1.0 - u.x).max(0.0).sqrt();
    let sin_t = u.x.max(0.0).sqrt();
    let phi = TAU * u.y;
    Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t)
}

/// Power-cosine lobe around +z: `cos α = u.x^{1/(m+1)}`, `φ = 2π u.y` (pdf `(m+1)/(2π) cos^m α`).
/// Used for the Phong lobe (axis = mirror direction) and the Blinn-Phong half vector (axis = normal).
#[inline]
pub fn power_cosine(u: Vec2, m: f32) -> Vec3 {
    let cos_a = u.x.max(0.0).powf(1.0 / (m + 1.0));
    let sin_a = (1.0 - cos_a * cos_a).max(0.0).sqrt();
    let phi = TAU * u.y;
    Vec3::new(sin_a * phi.cos(), sin_a * phi.sin(), cos_a)
}

#[inline]
pub fn power_cosine_pdf(cos_a: f32, m: f32) -> f32 {
    if cos_a <= 0.0 {
        0.0
    } else {
        (m + 1.0) / TAU * cos_a.powf(m)
    }
}

/// Mirror direction of `wo` (pointing away from the surface) about unit `n`.
#[inline]
pub fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    2.0 * wo.dot(n) * n - wo
}

/// Glossy BRDF value (without k_s).
#[inline]
pub fn glossy_brdf(lobe: Lobe, m: f32, n: Vec3, wo: Vec3, wi: Vec3) -> f32 {
    match lobe {
        Lobe::Phong => {
            let c = reflect(wo, n).dot(wi);
            if c <= 0.0 {
                0.0
            } else {
                (m + 2.0) / TAU * c.powf(m)
            }
        }
        Lobe::BlinnPhong => {
            let h = (wo + wi).normalize_or_zero();
            let c = h.dot(n);
            if c <= 0.0 {
                0.0
            } else {
                (m + 2.0) / (8.0 * PI) * c.powf(m)
            }
        }
    }
}

/// Pdf (solid angle) of sampling `wi` with [`sample_glossy`].
#[inline]
pub fn glossy_pdf(lobe: Lobe, m: f32, n: Vec3, wo: Vec3, wi: Vec3) -> f32 {
    match lobe {
        Lobe::Phong => power_cosine_pdf(reflect(wo, n).dot(wi), m),
        Lobe::BlinnPhong => {
            let h = (wo + wi).normalize_or_zero();
            let oh = wo.dot(h);
            if oh <= 0.0 {
                return 0.0;
            }
            power_cosine_pdf(h.dot(n), m) / (4.0 * oh)
        }
    }
}

/// Sample the glossy lobe at a surface with unit normal `n` seen from `wo`. Returns the direction
/// and the weight `f cos θ_i / pdf` (without k_s; 0 when the direction falls below the surface).
#[inline]
pub fn sample_glossy(lobe: Lobe, m: f32, n: Vec3, wo: Vec3, u: Vec2) -> (Vec3, f32) {
    match lobe {
        Lobe::Phong => {
            let r = reflect(wo, n);
            let wi = Frame::new(r).to_world(power_cosine(u, m)).normalize();
            let cos_i = wi.dot(n);
            (wi, if cos_i > 0.0 { (m + 2.0) / (m + 1.0) * cos_i } else { 0.0 })
        }
        Lobe::BlinnPhong => {
            let h = Frame::new(n).to_world(power_cosine(u, m)).normalize();
            let oh = wo.dot(h);
            let wi = (2.0 * oh * h - wo).normalize();
            let cos_i = wi.dot(n);
            let w = if cos_i > 0.0 && oh > 0.0 { (m + 2.0) / (m + 1.0) * oh * cos_i } else { 0.0 };
            (wi, w)
        }
    }
}

/// Sample the cosine hemisphere around `n`: direction (weight is 1 for the Lambertian BRDF).
#[inline]
pub fn sample_diffuse(n: Vec3, u: Vec2) -> Vec3 {
    Frame::new(n).to_world(cosine_hemisphere(u)).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_is_orthonormal() {
        for n in
            [Vec3::Z, -Vec3::Z, Vec3::X, Vec3::new(0.3, -0.5, 0.8).normalize(), Vec3::new(0.0, -1e-7, -1.0).normalize()]
        {
            let f = Frame::new(n);
            assert!(f.t.dot(f.b).abs() < 1e-5 && f.t.dot(n).abs() < 1e-5 && f.b.dot(n).abs() < 1e-5);
            assert!((f.t.length() - 1.0).abs() < 1e-5 && (f.b.length() - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn glossy_weights_match_brdf_over_pdf() {
        let n = Vec3::Y;
        let wo = Vec3::new(0.4, 0.8, 0.2).normalize();
        for lobe in [Lobe::Phong, Lobe::BlinnPhong] {
            for k in 0..50 {
                let u = Vec2::new((k as f32 + 0.5) / 50.0, (k * 7 % 50) as f32 / 50.0);
                let (wi, w) = sample_glossy(lobe, 15.0, n, wo, u);
                if w > 0.0 {
                    let expect = glossy_brdf(lobe, 15.0, n, wo, wi) * wi.dot(n) / glossy_pdf(lobe, 15.0, n, wo, wi);
                    assert!((w - expect).abs() < 1e-3 * expect.max(1.0), "{lobe:?} {w} vs {expect}");
                }
            }
        }
    }
}
