//! Chi-square goodness-of-fit of the hemisphere/lobe samplers against their pdfs: samples binned in
//! (cos θ, φ) around the lobe axis, expected counts from the pdf integrated over each bin; bins with an
//! expected count below 5 are pooled. Uniform numbers from the crate's counter-based RNG.

use glam::{Vec2, Vec3};
use statrs::distribution::{ChiSquared, ContinuousCDF};
use wedge_backends::kernels::hemisphere::{
    cosine_hemisphere, power_cosine, reflect, sample_diffuse, sample_glossy, Frame, Lobe,
};
use wedge_backends::rng::PixelRng;

const N: u32 = 200_000;
const COS_BINS: usize = 16;
const PHI_BINS: usize = 8;

/// Bin (cos θ, φ) of local directions; `cdf_cos(c)` = P(cos θ ≤ c) of the tested distribution
/// (φ uniform). Returns the p-value of the chi-square statistic.
fn chi_square(dirs: impl Iterator<Item = Vec3>, cdf_cos: impl Fn(f64) -> f64) -> f64 {
    let mut counts = vec![0f64; COS_BINS * PHI_BINS];
    let mut n = 0f64;
    for d in dirs {
        n += 1.0;
        let c = d.z.clamp(0.0, 1.0 - 1e-7) as f64;
        let phi = (d.y as f64).atan2(d.x as f64).rem_euclid(std::f64::consts::TAU);
        let ci = ((c * COS_BINS as f64) as usize).min(COS_BINS - 1);
        let pi = ((phi / std::f64::consts::TAU * PHI_BINS as f64) as usize).min(PHI_BINS - 1);
        counts[ci * PHI_BINS + pi] += 1.0;
    }
    let mut stat = 0.0;
    let mut dof = 0usize;
    let (mut pool_obs, mut pool_exp) = (0.0, 0.0);
    for ci in 0..COS_BINS {
        let p_cos = cdf_cos((ci + 1) as f64 / COS_BINS as f64) - cdf_cos(ci as f64 / COS_BINS as f64);
        for pi in 0..PHI_BINS {
            let expected = n * p_cos / PHI_BINS as f64;
            let observed = counts[ci * PHI_BINS + pi];
            if expected < 5.0 {
                pool_obs += observed;
                pool_exp += expected;
                continue;
            }
            stat += (observed - expected).powi(2) / expected;
            dof += 1;
        }
    }
    if pool_exp > 0.0 {
        stat += (pool_obs - pool_exp).powi(2) / pool_exp.max(1e-9);
        dof += 1;
    }
    let chi = ChiSquared::new((dof - 1) as f64).unwrap();
    1.0 - chi.cdf(stat)
}

fn uniforms(stream: u32) -> impl Iterator<Item = Vec2> {
    let rng = PixelRng::new(7, 11, stream);
    (0..N).map(move |s| Vec2::from(rng.uniform2(s, 0)))
}

#[test]
fn cosine_hemisphere_matches_its_pdf() {
    // pdf cos θ/π: P(cos θ ≤ c) = c².
    let p = chi_square(uniforms(1).map(cosine_hemisphere), |c| c * c);
    assert!(p > 1e-3, "p = {p}");
    // The world-space sampler around a tilted normal, binned in the normal's frame.
    let n = Vec3::new(0.3, -0.8, 0.5).normalize();
    let f = Frame::new(n);
    let p = chi_square(uniforms(2).map(|u| f.to_local(sample_diffuse(n, u))), |c| c * c);
    assert!(p > 1e-3, "world-space p = {p}");
}

#[test]
fn phong_lobe_matches_its_pdf() {
    for m in [1.0f32, 12.0, 20.0, 50.0] {
        // pdf (m+1)/(2π) cos^m α: P(cos α ≤ c) = c^{m+1}.
        let cdf = |c: f64| c.powf(m as f64 + 1.0);
        let p = chi_square(uniforms(3).map(|u| power_cosine(u, m)), cdf);
        assert!(p > 1e-3, "m = {m}: p = {p}");
        // World space: sample_glossy's Phong lobe, binned around the mirror direction of wo. Directions
        // below the surface still belong to the lobe (their weight is 0), so all are binned.
        let n = Vec3::Y;
        let wo = Vec3::new(0.2, 0.9, -0.3).normalize();
        let r = Frame::new(reflect(wo, n));
        let p = chi_square(uniforms(4).map(|u| r.to_local(sample_glossy(Lobe::Phong, m, n, wo, u).0)), cdf);
        assert!(p > 1e-3, "world-space m = {m}: p = {p}");
    }
}

#[test]
fn blinn_phong_half_vectors_match_their_pdf() {
    // The half vector h = normalize(wo + wi) of Blinn-Phong samples follows (m+1)/(2π) cos^m θ_h.
    let m = 12.0f32;
    let n = Vec3::new(0.0, 0.0, 1.0);
    let wo = Vec3::new(0.3, 0.1, 0.9).normalize();
    let p = chi_square(
        uniforms(5).map(|u| {
            let (wi, _) = sample_glossy(Lobe::BlinnPhong, m, n, wo, u);
            (wo + wi).normalize()
        }),
        |c| c.powf(m as f64 + 1.0),
    );
    assert!(p > 1e-3, "p = {p}");
}

#[test]
fn a_wrong_pdf_is_rejected() {
    // Power: cosine samples tested against the uniform-hemisphere cdf (P = c) must fail.
    let p = chi_square(uniforms(6).map(cosine_hemisphere), |c| c);
    assert!(p < 1e-6, "p = {p}");
}
