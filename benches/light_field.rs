//! Light-field reconstruction against axis-aligned filtering and plain Monte Carlo
//! (`cargo bench --bench light_field`; issue 17, seed 001): indirect light on `cornell` (the scene
//! of `indirect.ron` and `lightfield_indirect.ron`) and ambient occlusion on `curved` (`ao.ron`,
//! `lightfield_ao.ron`), each method rendering the indirect component alone (no direct-light node),
//! against one plain path-traced reference of it. Not a pass/fail test: it prints tables and writes
//! error-vs-time plots for docs/DESIGN-NOTES.md.
//!
//! - **LightField** at 1, 2, 4, 8, 16 input rays per pixel (`spp`) with `WEDGE_BENCH_RAYS` (64)
//!   reconstruction rays: relMSE, time per pass (sampling, the splat build, reconstruction).
//! - **Plain Monte Carlo at equal input rays** is the same run's `unfiltered` output (the plain
//!   estimate of the very rays the reconstruction used), so the two differ only in reconstruction.
//! - **Plain Monte Carlo at equal time**: the node's reference (`Session::reference`, stratified) at
//!   1, 2, 4, … paths per pixel, its log-log error-vs-time curve interpolated at each LightField
//!   time (the honest baseline: stratified, as `wedge bench`); and **at equal error**: the paths per
//!   pixel (and time) it needs for LightField's error (the paper: 8 input spp ≈ 512 spp, 18× faster).
//! - **AAF**: the `Indirect` node (Mehta Ch. 4) at μ = 0.5, 1, 2, 4 on the same scene.
//! - Memory per input sample (the stored record, its splat, its share of the tree).
//!
//! `WEDGE_BENCH_SIZE` (160x120), `WEDGE_BENCH_REF_SPP` (4096), `WEDGE_BENCH_RAYS` (64),
//! `WEDGE_BENCH_SCENE` (both cases on this scene instead), `WEDGE_BENCH_PLOT_DIR` (target/). Without `--bench` (`cargo test --all-targets`): a smoke run at
//! 32×24 that checks it works without paying for the numbers.

// The relMSE every progressive test and bench uses (tests/common/progressive.rs).
#[allow(dead_code)]
#[path = "../tests/common/progressive.rs"]
mod progressive;

use std::path::{Path, PathBuf};

use progressive::rel_mse;

use wedge::backends::cpu::CpuBackend;
use wedge::backends::{RunResult, Silent};
use wedge::bench::plots::{write_plot, Plot, Series, SeriesStyle};
use wedge::effects::light_field::{LIGHT_SAMPLE, SPLAT, SPLAT_NODE};
use wedge::graph::parse_pipeline;
use wedge::{Overrides, Session};

fn env_u32(k: &str, d: u32) -> u32 {
    std::env::var(k).ok().and_then(|v| v.parse().ok()).unwrap_or(d)
}

/// One effect on one scene: the pipeline text of each method's node (`NODE` and `PARAMS` filled in);
/// `inputs`: the AAF node's G-buffer inputs (LightField traces its own camera rays).
struct Case {
    name: &'static str,
    scene: &'static str,
    inputs: &'static str,
    lightfield: &'static str,
    aaf: &'static str,
}

const CASES: [Case; 2] = [
    Case {
        name: "indirect light",
        scene: "builtin:cornell",
        inputs: r#"{"position": "primary.position", "normal": "primary.normal", "albedo": "primary.albedo", "specular": "primary.specular"}"#,
        lightfield: r#"{"bounces": 1, "brdf": "phong"}"#,
        aaf: r#"{"alpha": 0.3, "bounces": 1, "brdf": "phong"}"#,
    },
    Case {
        name: "ambient occlusion",
        scene: "builtin:curved",
        inputs: r#"{"position": "primary.position", "normal": "primary.normal"}"#,
        lightfield: r#"{"mode": "ao", "max_distance": 0.0}"#,
        aaf: r#"{"mode": "ao", "max_distance": 0.0, "alpha": 0.3}"#,
    },
];

/// The case's scene, or `WEDGE_BENCH_SCENE` (e.g. `builtin:heavy`, whose 409,604 triangles make
/// paths expensive while the reconstruction's cost does not depend on the scene: the paper's point).
fn scene(case: &Case) -> String {
    std::env::var("WEDGE_BENCH_SCENE").unwrap_or_else(|_| case.scene.to_string())
}

fn text(case: &Case, kind: &str, params: &str, inputs: &str) -> String {
    format!(
        r#"Pipeline(scene: "{}", width: 32, height: 24, seed: 1, nodes: [
    (name: "primary", kind: "Primary"),
    (name: "x", kind: "{kind}", params: {params}, inputs: {}),
    (name: "out", kind: "Output", inputs: {{"color": "x.radiance", "unfiltered": "x.unfiltered"}}),
])"#,
        scene(case),
        inputs
    )
}

fn session(text: &str, ov: &Overrides, reference: Option<u32>) -> Session {
    let loaded = parse_pipeline(Path::new("bench.ron"), text).expect("pipeline parses");
    let (nodes, kernels) = wedge::effects::builtin();
    match reference {
        Some(spp) => Session::build_reference(loaded, ov, nodes, kernels, spp, "stratified").expect("reference builds"),
        None => Session::build(loaded, ov, nodes, kernels).expect("session builds"),
    }
}

fn pass_seconds(run: &RunResult, pass: &str) -> f64 {
    run.timings.iter().filter(|t| t.pass == pass).map(|t| t.seconds).sum()
}

/// A log-log curve of points `(x, y)` (sorted by `x`) interpolated at `x` (None outside it).
fn at_time(curve: &[(f64, f64)], x: f64) -> Option<f64> {
    curve.windows(2).find(|w| w[0].0 <= x && x <= w[1].0).map(|w| {
        let f = (x.ln() - w[0].0.ln()) / (w[1].0.ln() - w[0].0.ln()).max(1e-12);
        (w[0].1.ln() + f * (w[1].1.ln() - w[0].1.ln())).exp()
    })
}

/// Where a decreasing log-log curve `(x, error)` reaches `error`: its `x` (None outside it).
fn for_error(curve: &[(f64, f64)], error: f64) -> Option<f64> {
    let flipped: Vec<(f64, f64)> = curve.iter().rev().map(|&(x, e)| (e, x)).collect();
    at_time(&flipped, error)
}

fn main() {
    let smoke = !std::env::args().any(|a| a == "--bench");
    let (w, h) = progressive::bench_size(smoke);
    let ref_spp = if smoke { 64 } else { env_u32("WEDGE_BENCH_REF_SPP", 4096) };
    let rays = if smoke { 8 } else { env_u32("WEDGE_BENCH_RAYS", 64) };
    let lf_spp: &[u32] = if smoke { &[2] } else { &[1, 2, 4, 8, 16] };
    let mus: &[f64] = if smoke { &[1.0] } else { &[0.5, 1.0, 2.0, 4.0] };
    let plot_dir = PathBuf::from(std::env::var("WEDGE_BENCH_PLOT_DIR").unwrap_or_else(|_| "target".into()));
    let ov = Overrides { width: Some(w), height: Some(h), ..Default::default() };
    let per_sample = LIGHT_SAMPLE.words() + SPLAT.words() + 2 * SPLAT_NODE.words();
    println!(
        "memory per input sample: at most {per_sample} floats ({} B): the record, its splat, two tree nodes",
        4 * per_sample
    );

    for case in &CASES {
        let lf = |spp: u32| {
            text(
                case,
                "LightField",
                &case.lightfield.replacen('{', &format!("{{\"spp\": {spp}, \"rays\": {rays}, "), 1),
                "{}",
            )
        };
        let start = std::time::Instant::now();
        let reference =
            session(&lf(1), &ov, Some(ref_spp)).run(&mut CpuBackend::new(), &Silent).expect("reference runs");
        let r = reference.output("color").expect("color").clone();
        println!(
            "\n## {} on {} {w}x{h} (reference: {ref_spp} paths/px, {:.1} s)\n",
            case.name,
            scene(case),
            start.elapsed().as_secs_f64()
        );

        // Plain Monte Carlo: the same estimator at 1, 2, 4, … paths per pixel.
        let (mut mc, mut mc_spp, mut mc_time_of_spp) = (Vec::new(), Vec::new(), Vec::new());
        let mut n = 1u32;
        println!("| plain MC paths/px | time (s) | relMSE |\n|---|---|---|");
        while n <= ref_spp / 4 {
            let run = session(&lf(1), &ov, Some(n)).run(&mut CpuBackend::new(), &Silent).expect("MC runs");
            let (t, e) = (run.total_seconds(), rel_mse(run.output("color").expect("color"), &r));
            println!("| {n} | {t:.3} | {e:.5} |");
            mc.push((t, e));
            mc_spp.push((f64::from(n), e));
            mc_time_of_spp.push((f64::from(n), t));
            if smoke && n >= 4 {
                break;
            }
            n *= 2;
        }

        println!("\n| LightField spp | time (s) | sample | splats | reconstruct | relMSE | MC relMSE, equal rays | gain | MC relMSE, equal time | gain | MC paths/px, equal error | MC time / LightField time, equal error |");
        println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
        let mut points = Vec::new();
        for &spp in lf_spp {
            let run = session(&lf(spp), &ov, None).run(&mut CpuBackend::new(), &Silent).expect("LightField runs");
            let t = run.total_seconds();
            let e = rel_mse(run.output("color").expect("color"), &r);
            let e_rays = rel_mse(run.output("unfiltered").expect("unfiltered"), &r);
            let e_time = at_time(&mc, t);
            let spp_equal = for_error(&mc_spp, e);
            let time_equal = spp_equal.and_then(|n| at_time(&mc_time_of_spp, n));
            println!(
                "| {spp} | {t:.3} | {:.3} | {:.3} | {:.3} | {e:.5} | {e_rays:.5} | {:.1}× | {} | {} | {} | {} |",
                pass_seconds(&run, "x.sample"),
                pass_seconds(&run, "x.splats"),
                pass_seconds(&run, "x.reconstruct"),
                e_rays / e,
                e_time.map_or("—".into(), |m| format!("{m:.5}")),
                e_time.map_or("—".into(), |m| format!("{:.2}×", m / e)),
                spp_equal.map_or("beyond the curve".into(), |n| format!("{n:.0}")),
                time_equal.map_or("—".into(), |m| format!("{:.2}×", m / t)),
            );
            points.push((t, e));
        }

        println!("\n| AAF (Indirect) mu | time (s) | relMSE | MC relMSE, equal time | gain |\n|---|---|---|---|---|");
        let mut aaf_points = Vec::new();
        for &mu in mus {
            let params = case.aaf.replacen('{', &format!("{{\"mu\": {mu}, "), 1);
            let run = session(&text(case, "Indirect", &params, case.inputs), &ov, None)
                .run(&mut CpuBackend::new(), &Silent)
                .expect("AAF runs");
            let (t, e) = (run.total_seconds(), rel_mse(run.output("color").expect("color"), &r));
            let e_time = at_time(&mc, t);
            println!(
                "| {mu} | {t:.3} | {e:.5} | {} | {} |",
                e_time.map_or("—".into(), |m| format!("{m:.5}")),
                e_time.map_or("—".into(), |m| format!("{:.2}×", m / e))
            );
            aaf_points.push((t, e));
        }

        let series = vec![
            Series {
                label: "plain Monte Carlo (stratified)".into(),
                color: [128, 128, 128],
                style: SeriesStyle::LinePoints,
                points: mc,
            },
            Series {
                label: format!("LightField, {rays} reconstruction rays, spp 1-16"),
                color: [214, 39, 40],
                style: SeriesStyle::LinePoints,
                points,
            },
            Series {
                label: "AAF (Indirect), mu 0.5-4".into(),
                color: [31, 119, 180],
                style: SeriesStyle::LinePoints,
                points: aaf_points,
            },
        ];
        let scene_name = scene(case).trim_start_matches("builtin:").to_string();
        let file = plot_dir.join(format!("light_field_{}_{scene_name}.png", case.name.replace(' ', "_")));
        let plot = Plot {
            title: format!("{} on {} {w}x{h}: relMSE vs time", case.name, scene(case)),
            x_label: "seconds (CPU, passes)".into(),
            y_label: "relMSE vs reference".into(),
            series,
        };
        write_plot(&file, &plot).expect("plot written");
        println!("\nwrote {}", file.display());
    }
}
