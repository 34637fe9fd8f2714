//! Partial re-runs on the wgpu backend (issue 38, `wedge view`): after a parameter change, a first
//! frame that runs only the passes `Schedule::changed_since` marks, the others' buffers kept on the
//! device from the run before, equals a whole (pooled) run with the new value bit for bit — with
//! random passes among those re-run (same seed and frame as the whole run), with passes split into
//! bands of rows and chunks of samples, and with per-sample buffers and a host pass. On the CPU
//! backend the same contract is tested through the viewer (tests/view.rs).

use std::path::{Path, PathBuf};

use wedge::backends::gpu::GpuBackend;
use wedge::backends::Silent;
use wedge::graph::ParamValue;
use wedge::{Overrides, Session};

const W: u32 = 32;
const H: u32 = 24;

fn shadows() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines/shadows.ron")
}

/// The wgpu backend, or `None` (with a note) where there is none; under `CI=true` its absence fails.
fn gpu_or_skip(test: &str) -> Option<GpuBackend> {
    match GpuBackend::new() {
        Ok(gpu) => Some(gpu),
        Err(e) if std::env::var("CI").is_ok_and(|v| v == "true") => panic!("{test}: CI=true and no wgpu backend: {e}"),
        Err(e) => {
            eprintln!("{test}: SKIPPED — the wgpu backend is unavailable: {e}");
            None
        }
    }
}

/// shadows.ron at W×H with `max_radius` capped (so a filter's band fits a small binding limit) and
/// the changes `set` (node, parameter, value) and `mu`.
fn session(set: &[(&str, &str, ParamValue)], mu: Option<f64>) -> Session {
    let mut ov = Overrides { width: Some(W), height: Some(H), mu, ..Default::default() };
    ov.params = set.iter().map(|(n, p, v)| (n.to_string(), p.to_string(), v.clone())).collect();
    Session::open(Some(&shadows()), &ov).expect("shadows.ron opens")
}

/// A change: what it is, the parameters it sets and its `--mu`.
type Change = (&'static str, Vec<(&'static str, &'static str, ParamValue)>, Option<f64>);

fn changes() -> Vec<Change> {
    vec![
        ("shadows.k = 2 (filters only)", vec![("shadows", "k", ParamValue::Float(2.0))], None),
        ("shadows.max_rays = 8 (the adaptive sampling pass)", vec![("shadows", "max_rays", ParamValue::Int(8))], None),
        ("--mu 1.5 (rates, adaptive sampling, filters)", vec![], Some(1.5)),
    ]
}

/// For each change: keep a first frame's buffers on the device, rebuild with the change, re-run
/// only the changed passes and compare with a whole run of the changed session; report the counts.
fn partial_equals_whole(gpu: &mut GpuBackend, what: &str, changes: Vec<Change>) {
    let before = session(&[], None);
    let (first, kept) = before.run_partial_frame(gpu, &Silent, 0, &Default::default(), None).expect("first frame");
    assert!(wedge::backends::gpu::kept_bytes(&kept) > 0);
    let mut random_rerun = false;
    for (change, set, mu) in changes {
        let after = session(&set, mu);
        let rerun = after.schedule.changed_since(&before.schedule);
        let (partial, _) = after.run_partial_frame(gpu, &Silent, 0, &kept, Some(&rerun)).expect("partial re-run");
        let whole = after.run_progressive_frame(gpu, &Silent, 0, None).expect("whole run");
        let total = after.schedule.passes.len();
        eprintln!("{what}: {change}: {} of {total} passes re-run", partial.timings.len());
        assert!(partial.timings.len() < total, "{what}: {change}: every pass re-ran");
        assert_eq!(partial.outputs, whole.outputs, "{what}: {change}: the partial re-run differs from a whole run");
        assert_ne!(whole.outputs, first.outputs, "{what}: {change} changed nothing (the test would prove nothing)");
        random_rerun |=
            partial.timings.iter().any(|t| after.schedule.passes.iter().any(|p| p.name == t.pass && p.random));
    }
    assert!(random_rerun, "{what}: no change re-ran a random pass");
}

#[test]
fn a_wgpu_partial_rerun_equals_a_whole_run_bit_for_bit() {
    let Some(mut gpu) = gpu_or_skip("a_wgpu_partial_rerun_equals_a_whole_run_bit_for_bit") else { return };
    partial_equals_whole(&mut gpu, "one dispatch per pass", changes());
    // Chunks of 2 samples per pixel, and bands of rows: every sampling pass binds a path record
    // per pixel, so a limit of 8 records' rows splits the image into 3 bands.
    gpu.set_samples_per_dispatch(2);
    let record_row = (wedge::backends::kernels::paths::PATH_RECORD.words() * 4) as u64 * u64::from(W);
    gpu.set_binding_limit(8 * record_row);
    partial_equals_whole(&mut gpu, "chunks and bands", changes().split_off(2));
    assert!(gpu.last_bands.iter().any(|(_, n)| *n > 1), "no pass ran in bands: {:?}", gpu.last_bands);
}

/// A skipped pass whose outputs were not kept (or were kept at another size) is refused, naming
/// the pass and the buffer, so the caller can run in full; nothing panics.
#[test]
fn a_partial_rerun_without_the_kept_buffers_is_refused() {
    let Some(mut gpu) = gpu_or_skip("a_partial_rerun_without_the_kept_buffers_is_refused") else { return };
    let s = session(&[], None);
    let mut rerun = vec![true; s.schedule.passes.len()];
    rerun[0] = false;
    let Err(e) = s.run_partial_frame(&mut gpu, &Silent, 0, &Default::default(), Some(&rerun)) else {
        panic!("wgpu: a skipped pass without kept buffers ran");
    };
    let first = &s.schedule.passes[0].name;
    assert!(e.to_string().contains(&format!("pass `{first}` is skipped but no `")), "{e}");
    let mut cpu = wedge::backends::cpu::CpuBackend::new();
    let Err(e) = s.run_partial_frame(&mut cpu, &Silent, 0, &Default::default(), Some(&rerun)) else {
        panic!("cpu: a skipped pass without kept buffers ran");
    };
    assert!(e.to_string().contains(&format!("pass `{first}` is skipped but no `")), "{e}");
}

/// Per-sample buffers and a host pass (LightField's splat build, run on the CPU inside a wgpu run):
/// `rays` re-runs the reconstruction alone, `max_distance` everything from the samples on (the
/// host pass among them); both equal a whole run bit for bit.
#[test]
fn a_wgpu_partial_rerun_keeps_per_sample_buffers_and_runs_host_passes() {
    let Some(mut gpu) = gpu_or_skip("a_wgpu_partial_rerun_keeps_per_sample_buffers_and_runs_host_passes") else {
        return;
    };
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines/lightfield_ao.ron");
    let open = |set: Option<(&str, ParamValue)>| {
        let params = set.map(|(p, v)| ("ao".to_string(), p.to_string(), v)).into_iter().collect();
        let ov = Overrides { width: Some(24), height: Some(16), params, ..Default::default() };
        Session::open(Some(&path), &ov).expect("lightfield_ao.ron opens")
    };
    let before = open(None);
    let (first, kept) = before.run_partial_frame(&mut gpu, &Silent, 0, &Default::default(), None).expect("first frame");
    for (param, value, runs) in [("rays", ParamValue::Int(32), 1), ("max_distance", ParamValue::Float(0.5), 4)] {
        let after = open(Some((param, value)));
        let rerun = after.schedule.changed_since(&before.schedule);
        let (partial, _) = after.run_partial_frame(&mut gpu, &Silent, 0, &kept, Some(&rerun)).expect("partial");
        let whole = after.run_progressive_frame(&mut gpu, &Silent, 0, None).expect("whole run");
        assert_eq!(partial.timings.len(), runs, "ao.{param}: {:?}", partial.timings);
        assert_eq!(partial.outputs, whole.outputs, "ao.{param}: the partial re-run differs from a whole run");
        assert_ne!(whole.outputs, first.outputs, "ao.{param} changed nothing");
    }
}
