//! Progressive rendering's error against time (`cargo bench --bench progressive`; issue 18): the
//! pixel filter (brute force and separable, Schwenk Ch. 3) and the radiance filter (Ch. 4, with and
//! without its occlusion factor) against plain progressive accumulation, and the AAF pipeline
//! `shadows_indirect.ron` on the same scene — tables for docs/DESIGN-NOTES.md and a log-log plot of
//! relMSE against seconds. Not a pass/fail test: it prints numbers for humans to compare.
//!
//! - Reference: the pixel-filter pipeline's own (`Session::reference`, filters bypassed) at
//!   `WEDGE_BENCH_REF_SPP` (4096) paths per pixel; the radiance pipeline's reference is the same
//!   estimator (`camera_paths::first_vertex`, next-event estimation at every vertex, 3 bounces).
//! - Each progressive pipeline runs `WEDGE_BENCH_FRAMES` (256) frames on the CPU. "Plain" is
//!   progressive accumulation without the filter: the same run's `unfiltered` output, timed by its
//!   node's `sample` and `accumulate` passes only; the filtered image is timed by every pass. At the
//!   plain run's time after 1, 2, 4, … frames, the filtered image is the last one finished by then.
//! - AAF: one image per μ = 0.5, 1, 2, 4 (μ scales every node's), against its own reference at
//!   min(spp, 2048): it converges to a different image (diffuse-only direct light, two indirect
//!   bounces), so each method is measured against what it converges to.
//! - `WEDGE_BENCH_SCENE` (default: the pipelines' `cornell`), `WEDGE_BENCH_SIZE` (160x120),
//!   `WEDGE_BENCH_PLOT` (target/progressive_error_vs_time.png).
//! - Without `--bench` (`cargo test --all-targets`): a smoke run at 32×24, 8 frames.

// Shared with tests/pixel_filter.rs and tests/radiance_filter.rs (which use the rest of it).
#[allow(dead_code)]
#[path = "../tests/common/progressive.rs"]
mod progressive;

use std::path::{Path, PathBuf};

use progressive::{measure_curve, plot_curves, print_curve, rel_mse, rmse};
use wedge::backends::cpu::CpuBackend;
use wedge::backends::Silent;
use wedge::bench::plots::{Series, SeriesStyle};
use wedge::effects::pixel_filter::formulas::is_filter_frame;
use wedge::graph::ParamValue;
use wedge::{Overrides, Session};

fn pipeline(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines").join(name)
}

fn env_u32(k: &str, d: u32) -> u32 {
    std::env::var(k).ok().and_then(|v| v.parse().ok()).unwrap_or(d)
}

fn main() {
    // `cargo bench` passes `--bench`; `cargo test --all-targets` runs this binary without it: then a
    // smoke run (32×24, a 64-path reference, 8 frames, the plot under target/) checks that it works
    // without paying for the numbers.
    let smoke = !std::env::args().any(|a| a == "--bench");
    let (w, h) = progressive::bench_size(smoke);
    let (spp, frames) =
        if smoke { (64, 8) } else { (env_u32("WEDGE_BENCH_REF_SPP", 4096), env_u32("WEDGE_BENCH_FRAMES", 256)) };
    let scene = std::env::var("WEDGE_BENCH_SCENE").ok();
    let ov = |mu: Option<f64>, params: &[(&str, &str, ParamValue)]| Overrides {
        scene: scene.clone(),
        width: Some(w),
        height: Some(h),
        mu,
        params: params.iter().map(|(n, p, v)| (n.to_string(), p.to_string(), v.clone())).collect(),
        ..Default::default()
    };
    let start = std::time::Instant::now();
    let reference = Session::reference(Some(&pipeline("progressive_pixel.ron")), spp, "independent", &ov(None, &[]))
        .expect("reference");
    let scene_name = reference.scene.name.clone();
    let r = reference.run(&mut CpuBackend::new(), &Silent).expect("reference runs");
    let rc = r.output("color").expect("color").clone();
    println!("{scene_name} {w}x{h}: reference {spp} paths per pixel in {:.1} s", start.elapsed().as_secs_f64());

    let occlusion_off = [("rf", "occlusion", ParamValue::Bool(false))];
    // (label, pipeline, parameter overrides)
    type Run<'a> = (&'a str, &'a str, &'a [(&'a str, &'a str, ParamValue)]);
    let runs: [Run; 4] = [
        ("progressive_pixel.ron", "progressive_pixel.ron", &[]),
        ("progressive_pixel_fast.ron", "progressive_pixel_fast.ron", &[]),
        ("progressive_radiance.ron", "progressive_radiance.ron", &[]),
        ("progressive_radiance.ron, occlusion off", "progressive_radiance.ron", &occlusion_off),
    ];
    let mut curves = Vec::new();
    for (label, name, params) in runs {
        let s = Session::open(Some(&pipeline(name)), &ov(None, params)).expect("session");
        let node = s.pipeline.nodes[0].name.clone();
        let radiance = name == "progressive_radiance.ron";
        let c = measure_curve(&s, label, &node, frames, &rc, |f| radiance || is_filter_frame(f, 4, true));
        print_curve(&c);
        curves.push(c);
    }

    let aaf = pipeline("shadows_indirect.ron");
    let aaf_spp = spp.min(2048);
    let aaf_ref = Session::reference(Some(&aaf), aaf_spp, "stratified", &ov(None, &[])).expect("AAF reference");
    let ra = aaf_ref
        .run(&mut CpuBackend::new(), &Silent)
        .expect("AAF reference runs")
        .output("color")
        .expect("color")
        .clone();
    let mut points = Vec::new();
    println!("\nAAF shadows_indirect.ron (SoftShadows + Indirect), against its own {aaf_spp}-spp reference:");
    println!("| mu | time (s) | RMSE | relMSE |\n|---|---|---|---|");
    for mu in [0.5, 1.0, 2.0, 4.0] {
        let s = Session::open(Some(&aaf), &ov(Some(mu), &[])).expect("AAF session");
        let run = s.run(&mut CpuBackend::new(), &Silent).expect("AAF runs");
        let (t, c) = (run.total_seconds(), run.output("color").expect("color"));
        println!("| {mu} | {t:.3} | {:.4} | {:.5} |", rmse(c, &ra), rel_mse(c, &ra));
        points.push((t, rel_mse(c, &ra)));
    }
    let aaf_series = Series {
        label: "AAF shadows_indirect.ron, mu 0.5-4".into(),
        color: [0, 0, 0],
        style: SeriesStyle::LinePoints,
        points,
    };
    let out = std::env::var("WEDGE_BENCH_PLOT").unwrap_or_else(|_| "target/progressive_error_vs_time.png".into());
    plot_curves(
        Path::new(&out),
        &format!("{scene_name} {w}x{h}: relMSE vs time (reference {spp} paths/px)"),
        &curves,
        vec![aaf_series],
    );
}
