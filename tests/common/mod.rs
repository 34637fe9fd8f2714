//! Shared helpers for wedge's integration tests: run pipelines at small sizes, compare images.
#![allow(dead_code)]

pub mod cameras;
pub mod cli;
pub mod progressive;

use std::path::Path;

use wedge::backends::cpu::CpuBackend;
use wedge::backends::gpu::GpuBackend;
use wedge::backends::{RunResult, Silent};
use wedge::graph::{parse_pipeline, ParamValue};
use wedge::image::Image;
use wedge::outputs::buffer_to_image;
use wedge::{Overrides, Session};

/// Small size for tests that only need the method's behaviour (cheap).
pub const W: u32 = 128;
pub const H: u32 = 96;

/// The quality comparisons need filters wider than a pixel: at 128×96 a `grids` penumbra spans a
/// few pixels and β (≈ penumbra/20, eq. 3.13 with k = 3, μ = 2) stays below one, so those tests
/// run at 320×240.
pub const QW: u32 = 320;
pub const QH: u32 = 240;

pub fn overrides(mu: Option<f64>, params: &[(&str, &str, ParamValue)]) -> Overrides {
    sized(W, H, mu, params)
}

pub fn sized(w: u32, h: u32, mu: Option<f64>, params: &[(&str, &str, ParamValue)]) -> Overrides {
    Overrides {
        width: Some(w),
        height: Some(h),
        mu,
        params: params.iter().map(|(n, p, v)| (n.to_string(), p.to_string(), v.clone())).collect(),
        ..Default::default()
    }
}

pub fn session_from_text(text: &str, ov: &Overrides) -> Session {
    let loaded = parse_pipeline(Path::new("test.ron"), text).expect("pipeline parses");
    let (nodes, kernels) = wedge::effects::builtin();
    Session::build(loaded, ov, nodes, kernels).expect("session builds")
}

/// The session of pipeline `text` at `ov` — with `reference = Some(spp)` its stratified reference
/// at `spp` samples — or the error that refused it, as the user reads it.
pub fn build_text(text: &str, ov: &Overrides, reference: Option<u32>) -> Result<Session, String> {
    let loaded = parse_pipeline(Path::new("test.ron"), text).map_err(|e| e.to_string())?;
    let (nodes, kernels) = wedge::effects::builtin();
    match reference {
        None => Session::build(loaded, ov, nodes, kernels),
        Some(spp) => Session::build_reference(loaded, ov, nodes, kernels, spp, "stratified"),
    }
    .map_err(|e| e.to_string())
}

/// The mean over pixels of the mean of an image's three channels.
pub fn image_mean(image: &Image) -> f64 {
    image.pixels.iter().map(|p| f64::from(p[0] + p[1] + p[2]) / 3.0).sum::<f64>() / image.pixels.len() as f64
}

pub fn run(session: &Session) -> RunResult {
    session.run(&mut CpuBackend::new(), &Silent).expect("run succeeds")
}

pub fn color(session: &Session, run: &RunResult) -> Image {
    buffer_to_image(run.output("color").expect("color output"), session.width, session.height)
}

/// The default soft-shadow pipeline at `ov`'s size with μ and extra parameters.
pub fn shadows_at(ov: &Overrides) -> (Image, RunResult) {
    let s = Session::open(None, ov).expect("default pipeline");
    let r = run(&s);
    (color(&s, &r), r)
}

pub fn shadows(mu: f64, params: &[(&str, &str, ParamValue)]) -> (Image, RunResult) {
    shadows_at(&overrides(Some(mu), params))
}

/// Monte Carlo of the default pipeline's scene at `spp` light samples per pixel.
pub fn monte_carlo_at(spp: u32, sampling: &str, w: u32, h: u32) -> (Image, RunResult) {
    let s = Session::reference(None, spp, sampling, &sized(w, h, None, &[])).expect("reference");
    let r = run(&s);
    (color(&s, &r), r)
}

pub fn monte_carlo(spp: u32, sampling: &str) -> (Image, RunResult) {
    monte_carlo_at(spp, sampling, W, H)
}

pub fn rmse(a: &Image, b: &Image) -> f64 {
    wedge::metrics::compare(a, b).expect("same size").rmse
}

/// Mean shadow rays per pixel of a run.
pub fn shadow_rpp(r: &RunResult, w: u32, h: u32) -> f64 {
    r.rays.shadow_rays as f64 / (w as f64 * h as f64)
}

/// The GPU backend, or `None` (with the reason printed) when there is no adapter — except under
/// `CI=true`, where a missing adapter fails the test (parity must run on every CI run).
pub fn gpu_or_skip(test: &str) -> Option<GpuBackend> {
    match GpuBackend::new() {
        Ok(g) => {
            eprintln!("{test}: wgpu adapter {}", g.adapter_description());
            Some(g)
        }
        Err(e) => {
            if std::env::var("CI").is_ok_and(|v| v == "true") {
                panic!("{test}: CI=true and the wgpu backend is unavailable: {e}");
            }
            eprintln!("{test}: SKIPPED — the wgpu backend is unavailable: {e}");
            None
        }
    }
}
