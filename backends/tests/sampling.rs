//! Chi-square tests of light sampling against its pdf (uniform in area, `1/A`), for rectangle and
//! triangle lights, with independent and stratified (CMJ) sample placement.

use glam::{Vec2, Vec3};
use statrs::distribution::{ChiSquared, ContinuousCDF};
use wedge_backends::rng::PixelRng;
use wedge_scene::{AreaLight, LightShape};

const BINS: usize = 16;

/// Bin samples by their (u, v) coordinates on the light's own parameterisation and return the
/// p-value of Pearson's chi-square against the expected counts.
fn chi_square_p(observed: &[f64], expected: &[f64]) -> f64 {
    let stat: f64 = observed.iter().zip(expected).map(|(o, e)| (o - e) * (o - e) / e).sum();
    let dof = (observed.len() - 1) as f64;
    1.0 - ChiSquared::new(dof).unwrap().cdf(stat)
}

fn rect() -> AreaLight {
    AreaLight {
        shape: LightShape::Rect {
            corner: Vec3::new(-0.5, 2.0, -0.25),
            edge_u: Vec3::new(1.0, 0.0, 0.0),
            edge_v: Vec3::new(0.0, 0.0, 0.5),
        },
        radiance: Vec3::ONE,
        two_sided: false,
    }
}

fn triangle() -> AreaLight {
    AreaLight {
        shape: LightShape::Triangle {
            v0: Vec3::new(0.0, 1.0, 0.0),
            v1: Vec3::new(1.0, 1.0, 0.0),
            v2: Vec3::new(0.2, 1.0, 0.7),
        },
        radiance: Vec3::ONE,
        two_sided: false,
    }
}

/// Draw `n` sample points per pixel stream over many pixels with the given placement.
fn points(light: &AreaLight, stratified: bool, per_pixel: u32, pixels: u32) -> Vec<Vec3> {
    let mut out = Vec::new();
    for p in 0..pixels {
        let rng = PixelRng::new(7, p, 0);
        for s in 0..per_pixel {
            let u = if stratified { rng.stratified2(s, per_pixel, 8) } else { rng.uniform2(s, 8) };
            out.push(light.sample_point(Vec2::from(u)));
        }
    }
    out
}

#[test]
fn rect_light_samples_follow_uniform_area_pdf() {
    let light = rect();
    for stratified in [false, true] {
        let pts = points(&light, stratified, 9, 20_000);
        let mut obs = vec![0.0; BINS * BINS];
        for p in &pts {
            // Rect parameterisation: corner (-0.5, ·, -0.25), sides 1 × 0.5.
            let u = ((p.x + 0.5) / 1.0).clamp(0.0, 0.999_999);
            let v = ((p.z + 0.25) / 0.5).clamp(0.0, 0.999_999);
            obs[(u * BINS as f32) as usize + BINS * (v * BINS as f32) as usize] += 1.0;
        }
        let exp = vec![pts.len() as f64 / (BINS * BINS) as f64; BINS * BINS];
        let p = chi_square_p(&obs, &exp);
        assert!(p > 1e-3, "stratified={stratified}: chi-square p = {p}");
    }
}

#[test]
fn triangle_light_samples_follow_uniform_area_pdf() {
    // Bin by the point's x, z on a grid over the bounding box; the expected count of a cell is the
    // area of its intersection with the triangle (computed by dense sub-cell quadrature) over the area.
    let light = triangle();
    let (v0, v1, v2) = (Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(0.2, 0.7));
    let inside = |q: Vec2| {
        let cross = |a: Vec2, b: Vec2, c: Vec2| (b - a).perp_dot(c - a);
        let (d0, d1, d2) = (cross(v0, v1, q), cross(v1, v2, q), cross(v2, v0, q));
        (d0 >= 0.0 && d1 >= 0.0 && d2 >= 0.0) || (d0 <= 0.0 && d1 <= 0.0 && d2 <= 0.0)
    };
    const G: usize = 8;
    let sub = 64;
    let mut frac = vec![0.0f64; G * G];
    for cy in 0..G {
        for cx in 0..G {
            let mut n = 0;
            for sy in 0..sub {
                for sx in 0..sub {
                    let q = Vec2::new(
                        (cx as f32 + (sx as f32 + 0.5) / sub as f32) / G as f32,
                        0.7 * (cy as f32 + (sy as f32 + 0.5) / sub as f32) / G as f32,
                    );
                    n += inside(q) as usize;
                }
            }
            frac[cx + G * cy] = n as f64 / (sub * sub) as f64;
        }
    }
    let total: f64 = frac.iter().sum();
    for stratified in [false, true] {
        let pts = points(&light, stratified, 16, 10_000);
        let mut obs = vec![0.0; G * G];
        for p in &pts {
            let cx = ((p.x / 1.0) * G as f32).clamp(0.0, G as f32 - 1e-3) as usize;
            let cy = ((p.z / 0.7) * G as f32).clamp(0.0, G as f32 - 1e-3) as usize;
            obs[cx + G * cy] += 1.0;
        }
        // Only cells the triangle covers substantially (partial-cell quadrature error stays tiny there).
        let keep: Vec<usize> = (0..G * G).filter(|&i| frac[i] > 0.05).collect();
        let n_keep: f64 = keep.iter().map(|&i| obs[i]).sum();
        let f_keep: f64 = keep.iter().map(|&i| frac[i]).sum();
        let o: Vec<f64> = keep.iter().map(|&i| obs[i]).collect();
        let e: Vec<f64> = keep.iter().map(|&i| n_keep * frac[i] / f_keep).collect();
        let p = chi_square_p(&o, &e);
        assert!(p > 1e-3, "stratified={stratified}: chi-square p = {p} (total coverage {total})");
    }
}
