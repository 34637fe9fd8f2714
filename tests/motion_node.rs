//! The `Motion` node end to end (thesis App. B; `effects/src/motion/`, `docs/DESIGN-NOTES.md`
//! "Motion"): no-op on a static scene and at a zero-length shutter, the oriented filter's profile,
//! the time-integrated reference against an analytic ramp, consistency with μ, the refusal of two
//! factoring nodes.

mod common;

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

use common::*;
use wedge::backends::lone::LonePass;
use wedge::backends::{BufferData, Texel};
use wedge::effects::motion::kernels::filter::MotionFilter;
use wedge::graph::{parse_pipeline, ParamValue};
use wedge::image::Image;
use wedge::{Overrides, Session};

/// `pipelines/motion.ron`'s graph on `scene` with `extra` top-level fields (camera, motion), the
/// Output fed by `color` (`motion.radiance` or `shadows.radiance`).
fn pipeline(scene: &str, extra: &str, motion_params: &str, color: &str) -> String {
    format!(
        r#"Pipeline(scene: "{scene}", width: 64, height: 48, seed: 3, {extra} nodes: [
            (name: "primary", kind: "Primary"),
            (name: "shadows", kind: "SoftShadows", params: {{"light": 0}},
             inputs: {{"position": "primary.position", "normal": "primary.normal", "albedo": "primary.albedo", "emission": "primary.emission"}}),
            (name: "motion", kind: "Motion", params: {{{motion_params}}}, inputs: {{"direct": "shadows.radiance"}}),
            (name: "out", kind: "Output", inputs: {{"color": "{color}", "rays_per_pixel": "motion.rays_per_pixel"}}),
        ])"#
    )
}

/// The `motion` built-in's camera as a pipeline camera block with `shutter`.
fn motion_camera(shutter: &str) -> String {
    format!("camera: Some((position: (0, 2.2, 4.2), look_at: (0, 0.35, 0), vfov_deg: 45, shutter: {shutter})),")
}

fn render(text: &str, ov: &Overrides) -> (Image, wedge::backends::RunResult) {
    let s = session_from_text(text, ov);
    let r = run(&s);
    (color(&s, &r), r)
}

fn reference(text: &str, spp: u32, ov: &Overrides) -> Image {
    let loaded = parse_pipeline(Path::new("test.ron"), text).expect("pipeline parses");
    let (nodes, kernels) = wedge::effects::builtin();
    let s = Session::build_reference(loaded, ov, nodes, kernels, spp, "stratified").expect("reference builds");
    let r = run(&s);
    color(&s, &r)
}

#[test]
fn a_static_scene_renders_as_without_the_motion_node() {
    // `grids` does not move: Motion does not factor, SoftShadows renders Ch. 3 and Motion passes its
    // one component through — the same image and rays as reading SoftShadows directly.
    let with = render(&pipeline("builtin:grids", "", "", "motion.radiance"), &Overrides::default());
    let without = render(&pipeline("builtin:grids", "", "", "shadows.radiance"), &Overrides::default());
    assert_eq!(rmse(&with.0, &without.0), 0.0);
    assert_eq!(with.1.rays, without.1.rays);
}

#[test]
fn a_zero_length_shutter_renders_as_without_the_motion_node() {
    // The `motion` built-in at a zero-length shutter: every object held at the shutter's centre, so
    // nothing blurs and Motion does not factor.
    let still = motion_camera("Some((0.5, 0.5))");
    let with = render(&pipeline("builtin:motion", &still, "", "motion.radiance"), &Overrides::default());
    let without = render(&pipeline("builtin:motion", &still, "", "shadows.radiance"), &Overrides::default());
    assert_eq!(rmse(&with.0, &without.0), 0.0);
    assert_eq!(with.1.rays, without.1.rays);
    // With its shutter the same scene factors: every pixel traces its first pass of 4 timed paths
    // (the Motion node's default `initial_paths`), then the B.3 counts.
    let moving =
        render(&pipeline("builtin:motion", &motion_camera("None"), "", "motion.radiance"), &Overrides::default());
    assert!(moving.1.rays.primary_rays > 4 * 64 * 48, "{:?} vs {:?}", moving.1.rays, with.1.rays);
    assert!(rmse(&moving.0, &with.0) > 0.0);
}

#[test]
fn the_oriented_filter_blurs_along_the_velocity_only() {
    // A 64×16 image f(x, y) = g(x)·h(y) — vertical stripes of period 8 times a vertical ramp — moving
    // along +x at 12 px per half shutter, Ω = 1/12 (eq. B.1 at μ = 1). Each output pixel averages
    // only its own row: the column profile keeps h exactly (ratios between rows unchanged), while
    // the row profile is the Gaussian exp(−16 k² Ω²) (σ = 12/√32 ≈ 2.1 px) smoothing of g.
    let (w, h) = (64u32, 16u32);
    let g = |x: i32| if (x / 4) % 2 == 0 { 1.0f32 } else { 0.25 };
    let hy = |y: u32| 0.5 + y as f32 / 16.0;
    let value: Vec<[f32; 3]> = (0..w * h).map(|i| [g((i % w) as i32) * hy(i / w); 3]).collect();
    let omega = 1.0 / 12.0;
    let motion = vec![[12.0f32, 0.0, omega, 0.0]; (w * h) as usize];
    let inputs: BTreeMap<&str, BufferData> =
        [("value", BufferData::Vec3(value)), ("motion", BufferData::Vec4(motion))].into_iter().collect();
    let params = [("max_radius".to_string(), ParamValue::Int(32))].into_iter().collect();
    let pass = LonePass::new(Arc::new(MotionFilter), params, &inputs).expect("filter binds");
    let scene = wedge::scene::load(&wedge::scene::SceneSource::Builtin("grids".into())).expect("scene");
    let (out, _) = pass.run_cpu(&scene, w, h, 1).expect("filter runs");
    let out = <[f32; 3] as Texel>::slice(&out["out"]).expect("vec3").to_vec();
    // Column profiles: exactly h(y) up to rounding, at every x.
    for x in 0..w {
        for y in 1..h {
            let (a, b) = (out[(y * w + x) as usize][0], out[(w + x) as usize][0]);
            let want = hy(y) / hy(1);
            assert!((a / b - want).abs() < 1e-5, "column {x}, row {y}: ratio {} vs {want}", a / b);
        }
    }
    // Row profile (row 0, away from the borders): the Gaussian-weighted mean of g along x.
    let r = wedge::backends::kernels::filter_window::window_radius(omega, 32);
    for x in 24..40 {
        let (mut s, mut ws) = (0.0f64, 0.0f64);
        for k in -r..=r {
            // Taps below the 0.01 weight of the Ch. 5 filters are not used.
            let e = 16.0 * (k * k) as f64 * (omega as f64).powi(2);
            if e > 100f64.ln() {
                continue;
            }
            s += (-e).exp() * g(x + k) as f64;
            ws += (-e).exp();
        }
        let want = s / ws * hy(0) as f64;
        let got = out[x as usize][0] as f64;
        assert!((got - want).abs() < 1e-5, "x {x}: {got} vs {want}");
    }
    // The stripes are smoothed: the fundamental of a period-8 square wave keeps exp(−2π²σ²/8²) ≈ 0.26
    // of its amplitude under σ ≈ 2.1 px, so the contrast along the row drops from 0.75 to about 0.22.
    let row: Vec<f32> = (16..48).map(|x| out[x][0] / hy(0)).collect();
    let contrast = row.iter().cloned().fold(f32::MIN, f32::max) - row.iter().cloned().fold(f32::MAX, f32::min);
    assert!(contrast > 0.15 && contrast < 0.3, "row contrast {contrast}");
}

/// A scene of two quads seen head on (written to `dir`): an emissive backdrop (radiance 1) at z = 0,
/// and a black bar of width 0.2 m at z = 0.5 m in front of it; the camera at z = 3 looks down −z.
fn bar_scene(dir: &Path) -> std::path::PathBuf {
    std::fs::write(dir.join("bar.mtl"), "newmtl backdrop\nKd 0 0 0\nKe 1 1 1\nnewmtl black\nKd 0 0 0\n").unwrap();
    std::fs::write(
        dir.join("bar.obj"),
        "mtllib bar.mtl\n\
         o backdrop\nusemtl backdrop\nv -2 -2 0\nv 2 -2 0\nv 2 2 0\nv -2 2 0\nf 1 2 3\nf 1 3 4\n\
         o bar\nusemtl black\nv -0.1 -1 0.5\nv 0.1 -1 0.5\nv 0.1 1 0.5\nv -0.1 1 0.5\nf 5 6 7\nf 5 7 8\n",
    )
    .unwrap();
    dir.join("bar.obj")
}

#[test]
fn the_reference_of_a_moving_bar_is_the_analytic_coverage_ramp() {
    // The bar moves 0.6 m along x over the shutter (from −0.3 to +0.3 about its file pose): a pixel
    // whose centre ray meets the bar's plane at x sees the backdrop for the fraction of the shutter
    // the bar does not cover x — a trapezoid in x, computed here exactly, which the time-integrated
    // reference (jointly stratified times, pixel centres) must match.
    let dir = tempfile::tempdir().unwrap();
    let obj = bar_scene(dir.path());
    let text = pipeline(
        &obj.display().to_string(),
        "camera: Some((position: (0, 0, 3), look_at: (0, 0, 0), vfov_deg: 40)),\n\
         motion: [(object: \"bar\", translate: (0.6, 0, 0))],",
        "",
        "motion.radiance",
    );
    let (w, h) = (64u32, 48u32);
    // The text's scene lies in a temp dir, outside the directory of its nominal path `test.ron`.
    let img = reference(&text, 256, &Overrides { allow_outside_dir: true, ..sized(w, h, None, &[]) });
    let (tan_half, z_cam, z_bar) = ((20f64).to_radians().tan(), 3.0f64, 0.5f64);
    let (half_width, shift) = (0.1f64, 0.6f64);
    let y = h / 2;
    let mut worst = 0.0f64;
    for x in 0..w {
        // The centre ray of pixel x meets the bar's plane at world x_p.
        let sx = (2.0 * (x as f64 + 0.5) / w as f64 - 1.0) * tan_half * (w as f64 / h as f64);
        let xp = sx * (z_cam - z_bar);
        // The bar's centre runs from −shift/2 to +shift/2 linearly over the shutter: it covers x_p
        // while |x_p − c| ≤ half_width, for an interval of centres of length ≤ 2·half_width.
        let (lo, hi) = ((xp - half_width).max(-shift / 2.0), (xp + half_width).min(shift / 2.0));
        let covered = ((hi - lo) / shift).max(0.0);
        let want = 1.0 - covered;
        let got = img.get(x, y)[0] as f64;
        worst = worst.max((got - want).abs());
    }
    // 256 stratified times per pixel resolve the coverage to about 1/256 (a 1-D (0,1)-sequence).
    assert!(worst < 0.01, "largest difference from the analytic ramp: {worst}");
}

#[test]
fn consistent_mode_converges_to_the_reference_as_mu_grows() {
    // μ → ∞ in consistent mode: every filter shrinks below a pixel and counts grow (Ch. 5's mode,
    // App. B's widths): the error against the time-integrated reference falls.
    let text = pipeline("builtin:motion", "", r#""mode": "consistent""#, "motion.radiance");
    let ov = |mu: f64| sized(64, 48, Some(mu), &[]);
    let truth = reference(&text, 1024, &ov(1.0));
    let errors: Vec<f64> = [0.5, 2.0, 8.0].iter().map(|&mu| rmse(&render(&text, &ov(mu)).0, &truth)).collect();
    assert!(errors[0] > errors[1] && errors[1] > errors[2], "RMSE at μ 0.5, 2, 8: {errors:?}");
    // It is the default (issue 35): the same image without the mode written.
    let default = pipeline("builtin:motion", "", "", "motion.radiance");
    assert_eq!(rmse(&render(&default, &ov(2.0)).0, &truth), errors[1]);
}

/// Under a factoring node SoftShadows fills the first pass's occluder statistics into the pixels
/// whose paths saw no occluder (Ch. 3 Sec. 3.6's fill, `fill_radius`; docs/DESIGN-NOTES.md
/// "Occluders filled under a factoring node"): the component's rates read the filled buffer, and the
/// image is closer to the reference than with the pixels' own statistics (`fill_radius: 0`, the
/// thesis's Ch. 5 — no fill pass, the rates read the sampler's statistics as before).
#[test]
fn the_factored_shadows_fill_unoccluded_pixels_from_their_neighbours() {
    let filled = pipeline("builtin:mo_shadow_caster", "", "", "motion.radiance");
    let own = filled.replace(r#"{"light": 0}"#, r#"{"light": 0, "fill_radius": 0}"#);
    let rates_reads = |text: &str| {
        let s = session_from_text(text, &Overrides::default());
        let rates = s.schedule.passes.iter().find(|p| p.name == "shadows.direct_rates").expect("the component's rates");
        let occlusion = rates.reads.iter().find(|(b, _)| b == "occlusion").expect("occlusion bound").1;
        let fill = s.schedule.passes.iter().find(|p| p.name == "shadows.fill").map(|p| p.write("out").unwrap());
        (fill, occlusion)
    };
    let (fill, read) = rates_reads(&filled);
    assert_eq!(fill, Some(read), "the rates read the fill pass's output");
    assert_eq!(rates_reads(&own).0, None, "no fill pass at fill_radius 0");

    let ov = sized(160, 120, None, &[]);
    let truth = reference(&filled, 512, &ov);
    let (a, ra) = render(&filled, &ov);
    let (b, rb) = render(&own, &ov);
    let (e_filled, e_own) = (rmse(&a, &truth), rmse(&b, &truth));
    eprintln!(
        "RMSE filled {e_filled:.4e} ({} rays), own {e_own:.4e} ({} rays)",
        ra.rays.total_rays(),
        rb.rays.total_rays()
    );
    assert!(e_filled < 0.9 * e_own, "filled {e_filled} vs own {e_own}");
}

#[test]
fn motion_and_defocus_in_one_pipeline_are_refused_with_the_reason() {
    let text = r#"Pipeline(scene: "builtin:motion", width: 32, height: 24, nodes: [
        (name: "primary", kind: "Primary"),
        (name: "shadows", kind: "SoftShadows", params: {"light": 0},
         inputs: {"position": "primary.position", "normal": "primary.normal"}),
        (name: "defocus", kind: "Defocus", params: {"aperture_radius": 0.05, "focus_distance": 3.0}, inputs: {"direct": "shadows.radiance"}),
        (name: "motion", kind: "Motion", inputs: {"direct": "defocus.radiance"}),
        (name: "out", kind: "Output", inputs: {"color": "motion.radiance"}),
    ])"#;
    let loaded = parse_pipeline(Path::new("both.ron"), text).expect("pipeline parses");
    let (nodes, kernels) = wedge::effects::builtin();
    let err = match Session::build(loaded, &Overrides::default(), nodes, kernels) {
        Ok(_) => panic!("two factoring nodes must be refused"),
        Err(e) => e.to_string(),
    };
    assert!(err.contains("both factor") && err.contains("samples the camera's shutter too"), "{err}");
    assert!(err.contains("both.ron:6:"), "located at the second node: {err}");
}
