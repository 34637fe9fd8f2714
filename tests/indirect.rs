//! End-to-end checks of the Indirect node (Mehta thesis Ch. 4) and its path tracer:
//! - white furnace: a closed box whose walls emit L_e and reflect ρ gives the closed-form
//!   `L_e Σ_{i=0..k+1} ρ^i` with k indirect bounces, and `L_e/(1 − ρ)` within 1% at enough bounces;
//! - consistency: on `cornell`, the RMSE of the filtered indirect image against a high-spp reference
//!   falls as μ grows;
//! - the gain over plain Monte Carlo (independent and stratified) at equal hemisphere samples (paths)
//!   per pixel. These compare the **indirect component alone** (Indirect's `radiance` against a
//!   `MonteCarlo` with `direct: false, bounces: 1` — the same estimator, unfiltered, at a fixed count);
//! - the same image for one and two threads, and the unfiltered image as μ → ∞.

mod common;

use common::*;
use wedge::backends::RunResult;
use wedge::image::Image;
use wedge::outputs::buffer_to_image;
use wedge::Session;
use wedge_scene::{Camera, Material, Scene, TriangleShading, Vec2, Vec3};

const SCENE: &str = "builtin:cornell";

fn indirect_text(extra: &str) -> String {
    format!(
        r#"Pipeline(scene: "{SCENE}", width: 64, height: 48, seed: 3, nodes: [
    (name: "primary", kind: "Primary"),
    (name: "indirect", kind: "Indirect", params: {{"initial_rays": 16{extra}}},
     inputs: {{"position": "primary.position", "normal": "primary.normal",
               "albedo": "primary.albedo", "specular": "primary.specular"}}),
    (name: "out", kind: "Output", inputs: {{"color": "indirect.radiance", "unfiltered": "indirect.unfiltered",
               "rays_per_pixel": "indirect.rays_per_pixel"}}),
])"#
    )
}

fn monte_carlo_text(spp: u32, sampling: &str, bounces: u32, direct: bool) -> String {
    format!(
        r#"Pipeline(scene: "{SCENE}", width: 64, height: 48, seed: 5, nodes: [
    (name: "primary", kind: "Primary"),
    (name: "mc", kind: "MonteCarlo",
     params: {{"spp": {spp}, "sampling": "{sampling}", "light": -1, "bounces": {bounces}, "direct": {direct}}},
     inputs: {{"position": "primary.position", "normal": "primary.normal",
               "albedo": "primary.albedo", "emission": "primary.emission", "specular": "primary.specular"}}),
    (name: "out", kind: "Output", inputs: {{"color": "mc.radiance"}}),
])"#
    )
}

fn render(text: &str, w: u32, h: u32) -> (Image, RunResult, Session) {
    let s = session_from_text(text, &sized(w, h, None, &[]));
    let r = run(&s);
    (color(&s, &r), r, s)
}

/// Converged indirect-only reference (stratified, 2048 paths per pixel and component).
fn reference(w: u32, h: u32) -> Image {
    render(&monte_carlo_text(2048, "stratified", 1, false), w, h).0
}

fn cached_reference() -> &'static Image {
    static REF: std::sync::OnceLock<Image> = std::sync::OnceLock::new();
    REF.get_or_init(|| reference(QW_I, QH_I))
}

const QW_I: u32 = 96;
const QH_I: u32 = 72;

/// Paths per pixel: hemisphere rays of the primary hit, i.e. secondary rays with one bounce.
fn paths_per_pixel(r: &RunResult, w: u32, h: u32) -> f64 {
    r.rays.secondary_rays as f64 / (w as f64 * h as f64)
}

// ---------------------------------------------------------------------------------------------
// White furnace

/// The inside of a 2 m cube whose six walls all emit `le` (one-sided, inward) and reflect `rho`;
/// the camera sits at the centre.
fn furnace_scene(le: f32, rho: f32) -> Scene {
    let m = Material { emission: Vec3::splat(le), ..Material::diffuse("wall", Vec3::splat(rho)) };
    let mut tris = Vec::new();
    let c = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    // For each axis and side, a quad wound so its normal points inward.
    for axis in 0..3 {
        for side in [-1.0f32, 1.0] {
            let inward = -side;
            let p = |a: f32, b: f32| {
                let mut v = [0.0; 3];
                v[axis] = side;
                v[(axis + 1) % 3] = a;
                v[(axis + 2) % 3] = b;
                c(v[0], v[1], v[2])
            };
            let q = [p(-1.0, -1.0), p(1.0, -1.0), p(1.0, 1.0), p(-1.0, 1.0)];
            let mut n = [0.0; 3];
            n[axis] = inward;
            let n = Vec3::from(n);
            let (a, b, cc, d) = if (q[1] - q[0]).cross(q[2] - q[0]).dot(n) > 0.0 {
                (q[0], q[1], q[2], q[3])
            } else {
                (q[0], q[3], q[2], q[1])
            };
            let object = (axis * 2) as u32 + (side > 0.0) as u32;
            let sh = TriangleShading { n: [n; 3], uv: [Vec2::ZERO; 3], material: 0, object };
            tris.push((a, b, cc, sh));
            tris.push((a, cc, d, sh));
        }
    }
    let camera = Camera {
        position: Vec3::new(0.1, -0.05, 0.2),
        look_at: Vec3::new(0.3, 0.1, -1.0),
        up: Vec3::Y,
        vfov_deg: 70.0,
        aperture_radius: 0.0,
        focus_distance: 1.0,
        shutter_open: 0.0,
        shutter_close: 0.0,
    };
    Scene::from_triangles("furnace", tris, vec![m], vec![], camera).expect("furnace scene")
}

fn furnace_mean(text: &str, scene: &Scene) -> f64 {
    let mut s = session_from_text(text, &sized(32, 32, None, &[]));
    s.scene = scene.clone();
    let r = run(&s);
    assert_eq!(r.rays.non_finite_samples, 0);
    image_mean(&color(&s, &r))
}

fn furnace_mc(spp: u32, bounces: u32, direct: bool) -> String {
    monte_carlo_text(spp, "independent", bounces, direct).replace("builtin:cornell", "builtin:grids")
}

#[test]
fn white_furnace() {
    let (le, rho) = (1.0f32, 0.5f32);
    let scene = furnace_scene(le, rho);
    assert_eq!(scene.lights.len(), 6, "each wall is one rectangular light");
    let closed = |k: u32| (0..=k + 1).map(|i| (le * rho.powi(i as i32)) as f64).sum::<f64>();
    // Indirect alone after k bounces: L_e Σ_{i=2..k+1} ρ^i (the primary hit's emission and direct light excluded).
    // 1024 independent paths per pixel: the image mean's own noise is ~0.3% (at 96 the seed-to-seed
    // spread was 1.5%, so a 1% bound passed or failed with the random streams, not the estimator).
    for k in [1u32, 2, 3] {
        let got = furnace_mean(&furnace_mc(1024, k, false), &scene);
        let want = closed(k) - (le + le * rho) as f64;
        eprintln!("furnace indirect, {k} bounce(s): {got:.5} vs closed form {want:.5}");
        assert!((got / want - 1.0).abs() < 0.01, "{k} bounces: {got} vs {want}");
    }
    // Full estimate (emission + direct + 10 indirect bounces) → L_e/(1 − ρ) = 2 within 1%.
    let got = furnace_mean(&furnace_mc(64, 10, true), &scene);
    let limit = le as f64 / (1.0 - rho as f64);
    eprintln!("furnace full, 10 bounces: {got:.5} vs L_e/(1-ρ) = {limit}");
    assert!((got / limit - 1.0).abs() < 0.01, "{got} vs {limit}");
    // The Indirect node (first pass + filter) keeps the one-bounce mean. At its default counts the
    // image mean's own noise is ~2% in this furnace (more than the bound), so the first pass takes
    // 2048 paths per pixel (noise ~0.3%) and the filter is what is tested.
    let text = indirect_text(r#", "bounces": 1, "max_rays": 2048"#)
        .replace(r#""initial_rays": 16"#, r#""initial_rays": 2048"#)
        .replace("builtin:cornell", "builtin:grids");
    let got = furnace_mean(&text, &scene);
    let want = closed(1) - (le + le * rho) as f64;
    eprintln!("furnace, Indirect node, 1 bounce: {got:.5} vs {want:.5}");
    assert!((got / want - 1.0).abs() < 0.01, "{got} vs {want}");
}

// ---------------------------------------------------------------------------------------------
// Consistency and baselines on `cornell`

/// The default width (`width_z_min: "nearest"`, `width_alpha` 4) and the thesis's (`"statistics"`,
/// α): both consistent.
#[test]
fn error_falls_as_mu_grows() {
    error_falls_as_mu_grows_with("");
}

#[test]
fn error_falls_as_mu_grows_with_the_thesis_width() {
    error_falls_as_mu_grows_with(r#", "width_z_min": "statistics", "width_alpha": 0.0"#);
}

fn error_falls_as_mu_grows_with(width: &str) {
    let reference = cached_reference();
    let mut rows = Vec::new();
    let mut last = f64::INFINITY;
    for mu in [0.5, 1.0, 2.0, 4.0] {
        let (img, run, _) = render(&indirect_text(&format!(r#", "mu": {mu:?}{width}"#)), QW_I, QH_I);
        let e = rmse(&img, reference);
        rows.push((mu, e, paths_per_pixel(&run, QW_I, QH_I)));
        eprintln!("mu {mu}: RMSE {e:.5}, paths/pixel {:.1}", paths_per_pixel(&run, QW_I, QH_I));
        assert!(e < last, "RMSE must fall as mu grows: {rows:?}");
        last = e;
    }
}

/// RMSE of AAF (default settings), independent and stratified MC at equal paths per pixel, against
/// a 1024-path stratified reference, indirect component only, at `w`×`h`.
fn baselines(w: u32, h: u32) -> (f64, f64, f64) {
    let reference = render(&monte_carlo_text(1024, "stratified", 1, false), w, h).0;
    let (aaf, run, s) = render(&indirect_text(""), w, h);
    let unfiltered = buffer_to_image(run.output("unfiltered").unwrap(), s.width, s.height);
    let aaf_paths = run.rays.secondary_rays as f64;
    // Paths one MC sample per component costs (diffuse everywhere + glossy on glossy pixels).
    let (_, one, _) = render(&monte_carlo_text(1, "independent", 1, false), w, h);
    let spp = (aaf_paths / one.rays.secondary_rays as f64).round().max(1.0) as u32;
    let (ind, ind_run, _) = render(&monte_carlo_text(spp, "independent", 1, false), w, h);
    let (strat, _, _) = render(&monte_carlo_text(spp, "stratified", 1, false), w, h);
    let (e_aaf, e_ind, e_strat) = (rmse(&aaf, &reference), rmse(&ind, &reference), rmse(&strat, &reference));
    eprintln!(
        "indirect only, {w}x{h}: AAF paths/pixel {:.2} (MC at {spp} per component: {:.2}); RMSE AAF {e_aaf:.5} \
         (unfiltered {:.5}), independent {e_ind:.5} ({:.2}x), stratified {e_strat:.5} ({:.2}x)",
        paths_per_pixel(&run, w, h),
        paths_per_pixel(&ind_run, w, h),
        rmse(&unfiltered, &reference),
        e_ind / e_aaf,
        e_strat / e_aaf
    );
    (e_aaf, e_ind, e_strat)
}

/// At 160×120 (measured 1.46x vs independent, 1.11x vs stratified at ~46 paths/pixel).
#[test]
fn beats_monte_carlo_at_equal_paths() {
    let (e_aaf, e_ind, e_strat) = baselines(160, 120);
    assert!(e_strat > e_aaf, "AAF must beat stratified MC at equal paths: {e_aaf} vs {e_strat}");
    assert!(e_ind > e_aaf, "AAF must beat independent MC at equal paths: {e_aaf} vs {e_ind}");
}

/// The issue's goal at the thesis's default settings (μ 0.9, α 0.3, γ 0.4 / per exponent, 16 initial
/// rays, clamp [16, 100μ]): ≥ 2× lower RMSE than independent MC and lower than stratified MC at equal
/// paths per pixel. Measured 2.35× / 1.69× at 640×480 (34.5 paths/px). At 320×240 it is 1.88× /
/// 1.38×: 96% of the AAF error there is bias, from filters that are wide in pixels at low resolution
/// (the α/d floor β ≥ 2d/(μα) ≈ 7.4 px and z-limited widths up to the 64-px window), so the goal is
/// checked at a resolution like the thesis's, where the pixel footprint d is small. ≈ 2 min.
#[test]
fn two_times_better_than_independent_monte_carlo() {
    let (e_aaf, e_ind, e_strat) = baselines(640, 480);
    assert!(e_ind >= 2.0 * e_aaf, "AAF must have >= 2x lower RMSE than independent MC: {e_aaf} vs {e_ind}");
    assert!(e_strat > e_aaf, "AAF must beat stratified MC at equal paths: {e_aaf} vs {e_strat}");
}

#[test]
fn same_image_for_one_and_two_threads() {
    let render_with = |threads| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| render(&indirect_text(r#", "bounces": 2"#), 48, 36).0)
    };
    let a = render_with(1);
    let b = render_with(2);
    assert!(a.pixels.iter().zip(&b.pixels).all(|(x, y)| x.iter().zip(y).all(|(u, v)| u.to_bits() == v.to_bits())));
}

#[test]
fn huge_mu_gives_the_unfiltered_image() {
    let (img, run, s) = render(&indirect_text(r#", "mu": 1e6, "rays_cap": 16"#), 48, 36);
    let unfiltered = buffer_to_image(run.output("unfiltered").unwrap(), s.width, s.height);
    assert_eq!(img, unfiltered);
}

#[test]
fn ao_is_a_fraction_and_reference_follows_the_node() {
    // The AO pipeline as shipped, and its reference (Session::reference takes mode and
    // max_distance from the Indirect node): both in [0, 1], close in the mean.
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines/ao.ron");
    let ov = sized(160, 120, None, &[]);
    let s = Session::open(Some(&path), &ov).unwrap();
    let r = run(&s);
    let ao = color(&s, &r);
    let s_ref = Session::reference(Some(&path), 256, "stratified", &ov).unwrap();
    let r_ref = run(&s_ref);
    let reference = color(&s_ref, &r_ref);
    assert!(ao.pixels.iter().all(|p| p.iter().all(|c| (0.0..=1.0).contains(c))));
    let (a, b) = (image_mean(&ao), image_mean(&reference));
    let un = buffer_to_image(r.output("unfiltered").unwrap(), s.width, s.height);
    let (e, e_un) = (rmse(&ao, &reference), rmse(&un, &reference));
    eprintln!(
        "AO mean {a:.4} (unfiltered {:.4}), reference {b:.4}, RMSE {e:.4} (unfiltered {e_un:.4})",
        image_mean(&un)
    );
    // The unfiltered estimate's mean over seeds matches the reference's. The fixed-count estimator
    // is unbiased. The adaptive one with the thesis's own-pixel statistics (Ch. 4: the first pass's
    // 16 samples are kept and decide the count) is low by ~1.5% here: a pixel whose 16 rays all
    // missed keeps its 0 at ~16 samples, while one that hit gets many more that dilute its hits
    // (seeds 1–5 at 160×120: −1.5% / −1.6%; fixed count +0.1% / +0.3%; docs/SAMPLER-STAGE.md
    // "Samples, not paths"). The node's default takes each pixel's z_min, z_max from its
    // neighbours (`statistics: "neighbours"`), so its count no longer depends on its own samples
    // and the adaptive estimate is unbiased too. One seed's mean carries ~0.6% of noise, so the mean is
    // taken over four seeds.
    let unfiltered_mean = |extra: &[(&str, &str, wedge::graph::ParamValue)]| {
        let runs: Vec<f64> = (1..=4)
            .map(|seed| {
                let mut ov = sized(160, 120, None, extra);
                ov.seed = Some(seed);
                let s = Session::open(Some(&path), &ov).unwrap();
                let r = run(&s);
                image_mean(&buffer_to_image(r.output("unfiltered").unwrap(), s.width, s.height))
            })
            .collect();
        runs.iter().sum::<f64>() / runs.len() as f64
    };
    use wedge::graph::ParamValue;
    let (adaptive, own, fixed) = (
        unfiltered_mean(&[]),
        unfiltered_mean(&[("ao", "statistics", ParamValue::Str("own".into()))]),
        unfiltered_mean(&[("ao", "rays_cap", ParamValue::Int(16))]),
    );
    eprintln!(
        "unfiltered mean over seeds 1-4: adaptive {adaptive:.5} (own statistics {own:.5}), fixed count {fixed:.5}, reference {b:.5}"
    );
    assert!((fixed - b).abs() < 0.01 * b, "fixed-count unfiltered {fixed} vs {b}");
    assert!((adaptive - b).abs() < 0.01 * b, "adaptive unfiltered (neighbours' statistics) {adaptive} vs {b}");
    assert!(own < 0.995 * b && own > 0.98 * b, "adaptive unfiltered (own statistics) {own} vs {b}: the known −1.5%");
    // Filtering must help: measured RMSE 0.0162 vs 0.0474 unfiltered at 160×120.
    assert!(e < 0.5 * e_un, "filtered RMSE {e} vs unfiltered {e_un}");
    // Issue 16's goal, the filtered mean within 2% of the reference (measured −0.4%). History of
    // this bound: ~15% high with the thesis's reach (wide filters over-count the bright AO halo
    // beside the objects), −3.3% with mutual reach and own statistics (the correlation above,
    // carried into the filter's weights), −0.4% now (docs/DESIGN-NOTES.md "AO: the mean and the
    // pixel's own statistics").
    assert!((a - b).abs() < 0.02 * b, "filtered mean {a} vs reference {b}");
}
