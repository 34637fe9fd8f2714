//! Per-frame GPU/CPU parity of every temporal pipeline — every `pipelines/*.ron` whose schedule
//! carries buffers from one frame to the next — over the first frames of a `render --frames`
//! sequence (issue 33: `environment_temporal.ron` frame 2 differed at 5 of 768 pixels by up to 0.26,
//! because history weights underflowed to subnormals the CPU kept and lavapipe flushed; see
//! `effects/src/environment/kernels/filter.rs`, `RelativeWeights`).
//!
//! Two checks per frame:
//! - `Session::parity_frame` (what `wedge parity --frames` runs): each pass on both backends with the
//!   same inputs, the previous-frame buffers from the CPU's run of the frame before — the strict
//!   per-pass tolerances of `wedge parity`;
//! - the two sequences run independently, each backend on its own history, as a user's
//!   `render --frames` on either backend: every output of every frame within the sampling passes'
//!   tolerance (a grazing ray may differ at 0.1% of pixels; 2% may be perturbed by under 1%).

mod common;

use std::path::{Path, PathBuf};

use common::gpu_or_skip;
use wedge::backends::cpu::CpuBackend;
use wedge::backends::parity::{allowed_pixels, compare, Tolerance};
use wedge::backends::{KernelClass, RunResult, Silent};
use wedge::{Overrides, Session};

/// Frames checked per pipeline: frame 2 was the first to differ in the report.
const FRAMES: u32 = 4;

/// The temporal pipelines, found by their schedules rather than listed, so a new one is checked too.
fn temporal_pipelines(ov: &Overrides) -> Vec<(PathBuf, Session)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines");
    let mut paths: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .collect();
    paths.sort();
    paths
        .into_iter()
        .filter_map(|p| {
            let s = Session::open(Some(&p), ov).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            (!s.schedule.history.is_empty()).then_some((p, s))
        })
        .collect()
}

/// Every output of `gpu` within the sampling tolerance of `cpu`'s; returns the largest difference.
fn sequences_agree(name: &str, frame: u32, cpu: &RunResult, gpu: &RunResult) -> f64 {
    let tol = Tolerance::for_class(KernelClass::Sampling);
    let mut worst = 0.0f64;
    for (key, c) in &cpu.outputs {
        let g =
            gpu.outputs.get(key).unwrap_or_else(|| panic!("{name} frame {frame}: the GPU run has no output {key:?}"));
        let (max_abs, _, over_strict, _) = compare(c, g, tol);
        let (_, _, over_loose, _) = compare(c, g, Tolerance { rel: tol.perturbed_rel, ..tol });
        let (over, perturbed) = (allowed_pixels(tol.max_share, c.len()), allowed_pixels(tol.perturbed_share, c.len()));
        assert!(
            over_loose <= over && over_strict <= over + perturbed,
            "{name} frame {frame} output {key:?}: {over_loose} pixel(s) off by more than 1% (allowed {over}), {over_strict} over \
             the strict tolerance (allowed {}); largest difference {max_abs:e}",
            over + perturbed
        );
        worst = worst.max(max_abs);
    }
    worst
}

#[test]
fn every_temporal_pipeline_agrees_frame_by_frame_with_history() {
    let Some(mut gpu) = gpu_or_skip("every_temporal_pipeline_agrees_frame_by_frame_with_history") else { return };
    let ov = Overrides { width: Some(32), height: Some(24), ..Default::default() };
    let pipelines = temporal_pipelines(&ov);
    let names: Vec<String> =
        pipelines.iter().map(|(p, _)| p.file_name().unwrap().to_string_lossy().into_owned()).collect();
    assert!(names.contains(&"environment_temporal.ron".to_string()), "{names:?}");
    for (path, mut session) in pipelines {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let (mut cpu_previous, mut gpu_previous): (Option<RunResult>, Option<RunResult>) = (None, None);
        for frame in 0..FRAMES {
            let report = session.parity_frame(&mut gpu, frame, 0, cpu_previous.as_ref()).unwrap();
            assert!(report.ok(), "{name} frame {frame}, each pass with the CPU's history:\n{}", report.table());
            let c = session.run_frame(&mut CpuBackend::new(), &Silent, frame, 0, cpu_previous.as_ref()).unwrap();
            let g = session.run_frame(&mut gpu, &Silent, frame, 0, gpu_previous.as_ref()).unwrap();
            let worst = sequences_agree(&name, frame, &c, &g);
            println!("{name} frame {frame}: per-pass parity ok; sequences' largest output difference {worst:e}");
            (cpu_previous, gpu_previous) = (Some(c), Some(g));
        }
    }
}

/// `wedge parity --frames A..B` checks each frame with history and prints a table per frame.
#[test]
fn parity_frames_on_the_command_line() {
    if gpu_or_skip("parity_frames_on_the_command_line").is_none() {
        return;
    }
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_wedge"))
        .args(["parity", "pipelines/environment_temporal.ron", "--width", "16", "--height", "12", "--frames", "2..3"])
        .current_dir(repo)
        .output()
        .unwrap();
    let (out, err) = (String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    assert!(o.status.success(), "{out}{err}");
    assert!(out.contains("frame 2\n") && out.contains("frame 3\n") && !out.contains("frame 1\n"), "{out}");
    assert_eq!(out.matches("parity: ok").count(), 2, "{out}");
    assert!(out.contains("filter.environment_history"), "{out}");
}
