//! GPU parity: the wgpu backend against the CPU backend, on whatever adapter wgpu finds (Mesa's
//! lavapipe on machines without a GPU; `scripts/test.sh` installs it where it can).
//!
//! Without an adapter these tests print why they were skipped and pass — except under `CI=true`,
//! where a missing adapter is a failure (CI must exercise the GPU path).
//!
//! - every pass of every pipeline in `pipelines/` at 64×48 (`run_parity`'s tolerances),
//! - end to end: `render --backend wgpu` vs `--backend cpu` on every pipeline, relMSE ≤ 1e-4,
//! - the RNG: a tiny WGSL kernel writes `hash4`/`uniform`/`cmj`/`permute` for 65 536 inputs, compared
//!   with `backends/src/rng.rs` bit for bit,
//! - heavy sampling runs in chunks (lavapipe's 65,535-iteration loop limit): equal to the CPU,
//!   independent of the chunk size, and loops cut without chunking are counted, not silent,
//! - the GPU buffer pool: physical allocations == the schedule's `slot_formats.len()`, and a kept
//!   backend's later runs write into those buffers (no allocation, the same bits),
//! - bands: with the binding limit lowered so every pass is split into bands of rows, every pipeline
//!   gives the same outputs and ray counts, bit for bit, as one dispatch per pass,
//! - the watertight triangle test (`shaders/bvh.wgsl`) on rays aimed exactly at shared vertices and
//!   edges: no ray leaks between triangles on either backend, and hits agree bit for bit,
//! - screen-space rays (`shaders/screen_trace.wgsl`) on the mixed-reality real layer: the GPU's
//!   hierarchical march equals its linear one bit for bit, and both the CPU's (≤ 1% may differ).

mod common;
use common::gpu_or_skip;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use wedge::backends::cpu::CpuBackend;
use wedge::backends::gpu::GpuBackend;
use wedge::backends::parity::run_parity;
use wedge::backends::{
    rng, BackendError, Binding, BufferData, Job, Kernel, KernelClass, KernelCtx, Silent, Uniforms, WgslSource,
};
use wedge::graph::{Format, ParamValue};
use wedge::{Overrides, Session};

fn small(w: u32, h: u32) -> Overrides {
    Overrides { width: Some(w), height: Some(h), ..Default::default() }
}

fn job(s: &Session) -> Job<'_> {
    s.job(s.seed, 0, &Silent)
}

fn pipelines() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines");
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("pipelines/")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .collect();
    v.sort();
    v
}

/// The `chess` board (a high-contrast checker at a grazing angle) is where secondary rays are most
/// sensitive to round-off (docs/DESIGN-NOTES.md, "Parity tolerances for sampling passes"): the
/// indirect pipeline must still pass there, within the perturbed allowance.
#[test]
fn parity_on_the_chess_board() {
    let Some(mut gpu) = gpu_or_skip("parity_on_the_chess_board") else { return };
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines/shadows_indirect.ron");
    let ov = Overrides { scene: Some("chess".into()), ..small(96, 72) };
    let session = Session::open(Some(&path), &ov).expect("chess session");
    let report = run_parity(&job(&session), &mut gpu).expect("parity runs");
    println!("{}", report.table());
    assert!(report.ok(), "parity on chess (table above)");
    let perturbed: usize = report.rows.iter().map(|r| r.perturbed).sum();
    assert!(report.rows.iter().all(|r| r.over <= 1), "no more than one pixel per output beyond the perturbed bound");
    println!("perturbed pixels over all outputs: {perturbed}");
}

#[test]
fn parity_every_pass_of_every_pipeline() {
    let Some(mut gpu) = gpu_or_skip("parity_every_pass_of_every_pipeline") else { return };
    let mut failures = Vec::new();
    for path in pipelines() {
        let session = Session::open(Some(&path), &small(64, 48)).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        // Kernels without WGSL are reported by `every_scheduled_kernel_has_wgsl`; compare the rest.
        let missing = kernels_without_wgsl(&session);
        if !missing.is_empty() {
            println!("{}: NOT COMPARED — kernel(s) without WGSL: {}", path.display(), missing.join(", "));
            continue;
        }
        match run_parity(&job(&session), &mut gpu) {
            Ok(report) => {
                println!("{}\n{}", path.display(), report.table());
                if !report.ok() {
                    failures.push(format!("{}: parity mismatch (table above)", path.display()));
                }
            }
            Err(e) => failures.push(format!("{}: {e}", path.display())),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The references of every pipeline (`Session::reference`: constant counts from `fill.constant`,
/// first passes at zero samples, filters bypassed) agree pass by pass too.
#[test]
fn parity_of_every_pipeline_reference() {
    let Some(mut gpu) = gpu_or_skip("parity_of_every_pipeline_reference") else { return };
    let mut failures = Vec::new();
    for path in pipelines() {
        let session = Session::reference(Some(&path), 8, "stratified", &small(32, 24)).unwrap();
        // A pipeline with per-pixel counts (an adaptive node) gets constant counts in its reference;
        // fixed-rate pipelines (MixedReality's 4 × 4) have none to fill.
        let render = Session::open(Some(&path), &small(32, 24)).unwrap();
        if render.schedule.passes.iter().any(|p| p.reference == wedge::graph::Reference::Count) {
            assert!(session.schedule.passes.iter().any(|p| p.kernel == "fill.constant"), "{}", path.display());
        }
        match run_parity(&job(&session), &mut gpu) {
            Ok(report) => {
                println!("{} (reference)\n{}", path.display(), report.table());
                if !report.ok() {
                    failures.push(format!("{}: reference parity mismatch (table above)", path.display()));
                }
            }
            Err(e) => failures.push(format!("{}: {e}", path.display())),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

fn kernels_without_wgsl(s: &Session) -> Vec<String> {
    let mut v: Vec<String> = s
        .schedule
        .passes
        .iter()
        // A host kernel (a structure build, `Kernel::host`) runs its CPU code on every backend.
        .filter(|p| s.kernels.get(&p.kernel).is_none_or(|k| k.wgsl().is_none() && !k.host()))
        .map(|p| p.kernel.clone())
        .collect();
    v.sort();
    v.dedup();
    v
}

/// Every kernel a shipped pipeline schedules must have a WGSL implementation (no GPU needed).
#[test]
fn every_scheduled_kernel_has_wgsl() {
    let mut gaps = Vec::new();
    for path in pipelines() {
        let session = Session::open(Some(&path), &small(8, 6)).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let missing = kernels_without_wgsl(&session);
        if !missing.is_empty() {
            gaps.push(format!("{}: {}", path.display(), missing.join(", ")));
        }
    }
    assert!(
        gaps.is_empty(),
        "kernels without a WGSL implementation (the wgpu backend cannot run them):\n{}",
        gaps.join("\n")
    );
}

fn rel_mse(test: &BufferData, reference: &BufferData) -> f64 {
    let (mut s, mut n) = (0f64, 0usize);
    for i in 0..reference.len() {
        for c in 0..reference.format().components() {
            let (x, r) = (test.component(i, c) as f64, reference.component(i, c) as f64);
            if x.is_finite() && r.is_finite() {
                s += (x - r) * (x - r) / (r * r + 0.01);
                n += 1;
            }
        }
    }
    s / n.max(1) as f64
}

#[test]
fn end_to_end_render_matches_cpu() {
    let Some(mut gpu) = gpu_or_skip("end_to_end_render_matches_cpu") else { return };
    // shadows.ron at 80×60 (the issue's check), every other pipeline at 48×36.
    for path in pipelines() {
        let size = if path.ends_with("shadows.ron") { small(80, 60) } else { small(48, 36) };
        let session = Session::open(Some(&path), &size).unwrap();
        let cpu = session.run(&mut CpuBackend::new(), &Silent).unwrap();
        let wgpu = session.run(&mut gpu, &Silent).unwrap();
        assert_eq!(cpu.outputs.len(), wgpu.outputs.len());
        for (key, reference) in &cpu.outputs {
            let test = &wgpu.outputs[key];
            let e = rel_mse(test, reference);
            println!("{}: {key:?}: relMSE {e:.3e}", path.display());
            assert!(e <= 1e-4, "{}: {key:?}: relMSE {e} > 1e-4", path.display());
        }
        assert_eq!(cpu.rays, wgpu.rays, "{}: ray counters differ", path.display());
        for t in &wgpu.timings {
            println!("{:<30} {:<20} {:>9.3} ms", t.pass, t.kernel, t.seconds * 1e3);
        }
    }
}

/// Counts the kernels a run said it compiled (`Progress::compiling`).
#[derive(Default)]
struct CompileCount(std::sync::atomic::AtomicUsize);
impl wedge::backends::Progress for CompileCount {
    fn compiling(&self, _kernel: &str) {
        self.0.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
    }
}

/// Backends opened with the same APIs and limits share one device and the kernels compiled on it
/// (backends/src/gpu/device.rs): after one backend has run a pipeline, a second one opened later
/// compiles none of its kernels and gives the same bits.
#[test]
fn a_second_backend_finds_the_kernels_compiled() {
    let Some(mut first) = gpu_or_skip("a_second_backend_finds_the_kernels_compiled") else { return };
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines/shadows.ron");
    let session = Session::open(Some(&path), &small(16, 12)).unwrap();
    let a = session.run(&mut first, &Silent).unwrap();
    let Some(mut second) = gpu_or_skip("a_second_backend_finds_the_kernels_compiled") else { return };
    let count = CompileCount::default();
    let b = session.run(&mut second, &count).unwrap();
    assert_eq!(count.0.load(std::sync::atomic::Ordering::SeqCst), 0, "the second backend compiled kernels");
    assert_same_bits(&path, "second backend", &a, &b);
}

#[test]
fn gpu_pool_allocates_one_buffer_per_slot() {
    let Some(mut gpu) = gpu_or_skip("gpu_pool_allocates_one_buffer_per_slot") else { return };
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines/shadows.ron");
    let session = Session::open(Some(&path), &small(32, 24)).unwrap();
    let run = session.run(&mut gpu, &Silent).unwrap();
    let logical = session.schedule.lifetimes.iter().filter(|l| l.is_some()).count();
    println!("physical {} (slots {}), logical {logical}", run.allocations, session.schedule.slot_formats.len());
    assert_eq!(run.allocations, session.schedule.slot_formats.len());
    assert!(run.allocations < logical, "pooling saved nothing: {} physical for {logical} logical", run.allocations);
}

/// Issue 38 §2: a kept `GpuBackend` writes a whole run into the previous run's pool buffers — a
/// second run (a frame with previous-frame buffers too) allocates nothing and gives the first run's
/// outputs bit for bit; a run at another image size allocates its slots afresh and still matches.
#[test]
fn gpu_pool_persists_across_runs() {
    let Some(mut gpu) = gpu_or_skip("gpu_pool_persists_across_runs") else { return };
    let open = |name: &str, w, h| {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines").join(name);
        Session::open(Some(&path), &small(w, h)).unwrap()
    };
    let bytes = |r: &wedge::backends::RunResult| -> Vec<Vec<u8>> {
        r.outputs.values().chain(r.history.values()).map(|d| d.as_bytes().to_vec()).collect()
    };
    let mut session = open("environment_temporal.ron", 32, 24);
    assert!(!session.schedule.history.is_empty(), "the test wants previous-frame buffers");
    let slots = session.schedule.slot_formats.len();
    let first = session.run_frame(&mut gpu, &Silent, 0, 0, None).unwrap();
    let scratch = gpu.scratch_buffers_created();
    let again = session.run_frame(&mut gpu, &Silent, 0, 0, None).unwrap();
    let next = session.run_frame(&mut gpu, &Silent, 1, 0, Some(&first)).unwrap();
    assert_eq!(first.allocations, slots);
    // Counter blocks and read-back staging are kept too (at 32×24 every read-back is small enough).
    assert_eq!(gpu.scratch_buffers_created(), scratch, "later runs create no scratch buffers");
    assert_eq!((again.allocations, next.allocations), (0, 0), "a kept backend's later runs allocate nothing");
    assert_eq!(bytes(&first), bytes(&again), "a run into reused buffers differs from the first");
    let fresh = session.run_frame(&mut GpuBackend::new().unwrap(), &Silent, 1, 0, Some(&first)).unwrap();
    assert_eq!(bytes(&next), bytes(&fresh), "frame 1 on reused buffers differs from a fresh backend's");
    let other = open("shadows.ron", 40, 30);
    let run = other.run(&mut gpu, &Silent).unwrap();
    assert_eq!(run.allocations, other.schedule.slot_formats.len(), "another size allocates its slots");
    let cpu = other.run(&mut CpuBackend::new(), &Silent).unwrap();
    for (key, reference) in &cpu.outputs {
        assert!(rel_mse(&run.outputs[key], reference) <= 1e-4, "{key:?} at 40×30 after 32×24");
    }
}

/// The band path (what runs when an image's buffers exceed the device's binding limit, e.g. 4K+
/// `vec4` on 128 MiB), forced at 64×48 by lowering the limit to 20 rows of `vec4`: every pass of every
/// pipeline runs as 2–4 bands, and the result must equal the unsplit run exactly (same shader, same
/// inputs per pixel). Filter radii are capped at 4 so a y-filter band (±4 rows) fits the limit.
#[test]
fn bands_give_the_same_outputs_as_one_dispatch() {
    let Some(mut whole) = gpu_or_skip("bands_give_the_same_outputs_as_one_dispatch") else { return };
    let Some(mut banded) = gpu_or_skip("bands_give_the_same_outputs_as_one_dispatch") else { return };
    // 16×48 (a quarter of 64×48's pixels): the check is bit for bit, so any size with several bands
    // per pass will do, and every pipeline runs twice here (kernel time on lavapipe grows with the
    // pixels; CI time). Narrow, so that the sampler's record row (the limit below) is well under a
    // vec3 or vec4 image.
    let (w, h) = (16u32, 48u32);
    // 10 rows of vec4, or one row of the sampler's record where that is larger (its passes then run
    // a row per band).
    let record_row = (wedge::backends::kernels::paths::PATH_RECORD.words() * 4) as u64 * w as u64;
    banded.set_binding_limit((10 * w as u64 * 16).max(record_row));
    for path in pipelines() {
        let probe = Session::open(Some(&path), &small(w, h)).unwrap();
        let mut ov = small(w, h);
        for node in &probe.pipeline.nodes {
            if node.params.contains_key("max_radius") {
                ov.params.push((node.name.clone(), "max_radius".into(), wedge::graph::ParamValue::Int(2)));
            }
            // The history pass reads max_motion + 1 rows either side.
            if node.params.contains_key("max_motion") {
                ov.params.push((node.name.clone(), "max_motion".into(), wedge::graph::ParamValue::Int(2)));
            }
            // PixelFilter's window reaches ceil(3 sigma_s) rows either side.
            if node.params.contains_key("sigma_s") {
                ov.params.push((node.name.clone(), "sigma_s".into(), wedge::graph::ParamValue::Float(0.6)));
            }
        }
        let session = Session::open(Some(&path), &ov).unwrap();
        let a = session.run(&mut whole, &Silent).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        if session.schedule.buffers.iter().any(|b| b.layers > 1) {
            // Per-sample buffers (LightField) are never split into bands of rows: a pass binding
            // them over the limit fails, naming itself (docs/BACKENDS.md).
            let e = session.run(&mut banded, &Silent).expect_err("banded per-sample buffers");
            assert!(e.to_string().contains("light_field."), "{}: {e}", path.display());
            continue;
        }
        let b = session.run(&mut banded, &Silent).unwrap_or_else(|e| panic!("{}: banded: {e}", path.display()));
        for (key, x) in &a.outputs {
            let y = &b.outputs[key];
            let differ = (0..x.len())
                .filter(|&i| {
                    (0..x.format().components()).any(|c| x.component(i, c).to_bits() != y.component(i, c).to_bits())
                })
                .count();
            println!("{}: {key:?}: {differ} of {} pixels differ", path.display(), x.len());
            assert_eq!(differ, 0, "{}: {key:?} differs between banded and whole dispatches", path.display());
        }
        assert_eq!(a.rays, b.rays, "{}: ray counts differ", path.display());
        assert!(whole.last_bands.iter().all(|(_, n)| *n == 1));
        // Passes whose every buffer fits the limit whole (u32 counts and flags, vec2 bandwidths:
        // 3 and 6 KiB at 16×48) need no bands.
        let limit = (10 * w as u64 * 16).max(record_row);
        let fits = |id: &wedge::graph::BufferId| {
            (session.schedule.buffers[id.0].format.components() as u64 * 4) * (w * h) as u64 <= limit
        };
        let u32_only: std::collections::HashSet<&str> = session
            .schedule
            .passes
            .iter()
            .filter(|p| p.reads.iter().chain(&p.writes).all(|(_, id)| fits(id)))
            .map(|p| p.name.as_str())
            .collect();
        let fewest =
            banded.last_bands.iter().filter(|(p, _)| !u32_only.contains(p.as_str())).map(|(_, n)| *n).min().unwrap();
        println!("{}: bands per pass {:?}", path.display(), banded.last_bands);
        assert!(fewest >= 2, "{}: every pass should have been split: {:?}", path.display(), banded.last_bands);
    }
}

/// Outputs and ray counts of two runs of one session must agree bit for bit.
fn assert_same_bits(path: &Path, what: &str, a: &wedge::backends::RunResult, b: &wedge::backends::RunResult) {
    for (key, x) in &a.outputs {
        let y = &b.outputs[key];
        let differ = (0..x.len())
            .filter(|&i| {
                (0..x.format().components()).any(|c| x.component(i, c).to_bits() != y.component(i, c).to_bits())
            })
            .count();
        println!("{}: {what}: {key:?}: {differ} of {} pixels differ", path.display(), x.len());
        assert_eq!(differ, 0, "{}: {key:?} differs ({what})", path.display());
    }
    assert_eq!(a.rays, b.rays, "{}: ray counts differ ({what})", path.display());
}

/// The packed binding plan (what runs where a kernel's buffers exceed the device's storage buffers
/// per stage, e.g. `indirect.sample` on WebGPU's 8) forced on every pass of every pipeline, alone
/// and together with bands: the same outputs and ray counts, bit for bit, as one binding per buffer.
#[test]
fn packed_bindings_give_the_same_outputs_as_direct_bindings() {
    use wedge::backends::gpu::shaders::BindingPlan;
    let Some(mut direct) = gpu_or_skip("packed_bindings_give_the_same_outputs_as_direct_bindings") else { return };
    let Some(mut packed) = gpu_or_skip("packed_bindings_give_the_same_outputs_as_direct_bindings") else { return };
    let Some(mut packed_bands) = gpu_or_skip("packed_bindings_give_the_same_outputs_as_direct_bindings") else {
        return;
    };
    // 32×24 (a quarter of 64×48's pixels): the check is bit for bit, and every pipeline runs three
    // times here (CI time).
    let (w, h) = (32u32, 24u32);
    packed.force_packed(true);
    packed_bands.force_packed(true);
    // The largest packed buffer (indirect.sample's inputs: 4+4+4+1+1+4+4 floats per pixel) in
    // bands of about 8 rows.
    packed_bands.set_binding_limit(8 * w as u64 * 22 * 4);
    for path in pipelines() {
        let probe = Session::open(Some(&path), &small(w, h)).unwrap();
        let mut ov = small(w, h);
        for node in &probe.pipeline.nodes {
            if node.params.contains_key("max_radius") {
                ov.params.push((node.name.clone(), "max_radius".into(), wedge::graph::ParamValue::Int(2)));
            }
            // The history pass reads max_motion + 1 rows either side.
            if node.params.contains_key("max_motion") {
                ov.params.push((node.name.clone(), "max_motion".into(), wedge::graph::ParamValue::Int(2)));
            }
            // PixelFilter's window reaches ceil(3 sigma_s) rows either side.
            if node.params.contains_key("sigma_s") {
                ov.params.push((node.name.clone(), "sigma_s".into(), wedge::graph::ParamValue::Float(0.6)));
            }
        }
        let session = Session::open(Some(&path), &ov).unwrap();
        let a = session.run(&mut direct, &Silent).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        if session.schedule.buffers.iter().any(|b| b.layers > 1) {
            // Per-sample buffers (LightField) bind directly only: forced packing is refused with
            // an error that says so (their kernels fit WebGPU's 8 storage buffers unpacked).
            let e = session.run(&mut packed, &Silent).expect_err("packed per-sample buffers");
            assert!(e.to_string().contains("per-sample buffers"), "{}: {e}", path.display());
            continue;
        }
        let b = session.run(&mut packed, &Silent).unwrap_or_else(|e| panic!("{}: packed: {e}", path.display()));
        let c =
            session.run(&mut packed_bands, &Silent).unwrap_or_else(|e| panic!("{}: packed bands: {e}", path.display()));
        assert!(direct.last_plans.iter().all(|(_, p)| *p == BindingPlan::Direct), "{:?}", direct.last_plans);
        assert!(packed.last_plans.iter().all(|(_, p)| *p == BindingPlan::Packed), "{:?}", packed.last_plans);
        println!("{}: packed bands per pass {:?}", path.display(), packed_bands.last_bands);
        assert!(packed_bands.last_bands.iter().any(|(_, n)| *n >= 2), "{}: nothing was split", path.display());
        assert_same_bits(&path, "packed", &a, &b);
        assert_same_bits(&path, "packed in bands", &a, &c);
    }
}

/// A device opened with wgpu's `Limits::default()` (WebGPU: 8 storage buffers per stage, 128 MiB
/// bindings): every pass of every pipeline agrees with the CPU, end to end too, and kernels over
/// 8 storage buffers (indirect.sample) run packed.
#[test]
fn parity_with_webgpu_default_limits() {
    use wedge::backends::gpu::{shaders::BindingPlan, LimitsChoice};
    let mut gpu = match GpuBackend::open(LimitsChoice::WebGpuDefault) {
        Ok(g) => g,
        Err(e) => {
            assert!(
                !std::env::var("CI").is_ok_and(|v| v == "true"),
                "CI=true and no wgpu device with default limits: {e}"
            );
            eprintln!("parity_with_webgpu_default_limits: SKIPPED — {e}");
            return;
        }
    };
    assert_eq!(gpu.limits().max_storage_buffers_per_shader_stage, 8);
    let mut failures = Vec::new();
    for path in pipelines() {
        let session = Session::open(Some(&path), &small(48, 36)).unwrap();
        match run_parity(&job(&session), &mut gpu) {
            Ok(report) => {
                println!("{} (Limits::default)\n{}", path.display(), report.table());
                if !report.ok() {
                    failures.push(format!("{}: parity mismatch (table above)", path.display()));
                }
            }
            Err(e) => failures.push(format!("{}: {e}", path.display())),
        }
        let cpu = session.run(&mut CpuBackend::new(), &Silent).unwrap();
        let wgpu = session.run(&mut gpu, &Silent).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        for (key, reference) in &cpu.outputs {
            let e = rel_mse(&wgpu.outputs[key], reference);
            println!("{}: {key:?}: relMSE {e:.3e}", path.display());
            assert!(e <= 1e-4, "{}: {key:?}: relMSE {e} > 1e-4", path.display());
        }
        assert_eq!(cpu.rays, wgpu.rays, "{}: ray counters differ", path.display());
        println!("{}: plans {:?}", path.display(), gpu.last_plans);
        for (pass, plan) in &gpu.last_plans {
            let kernel = &session.schedule.passes.iter().find(|p| &p.name == pass).unwrap().kernel;
            if kernel == "indirect.sample" {
                assert_eq!(*plan, BindingPlan::Packed, "{pass}");
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The GL backend (what wgpu picks without Vulkan; `WGPU_BACKEND=gl`), headless through EGL on
/// Mesa's llvmpipe: every pass of every pipeline agrees with the CPU, and its limits are reported.
/// Skipped with the reason printed when no GL adapter exists, except under CI=true.
#[test]
fn parity_on_the_gl_backend() {
    use wedge::backends::gpu::LimitsChoice;
    let mut gpu = match GpuBackend::open_on(Some(wedge::backends::gpu::Backends::GL), LimitsChoice::Adapter) {
        Ok(g) => g,
        Err(e) => {
            assert!(!std::env::var("CI").is_ok_and(|v| v == "true"), "CI=true and no GL adapter: {e}");
            eprintln!("parity_on_the_gl_backend: SKIPPED — no GL adapter (install libegl1 libgl1-mesa-dri): {e}");
            return;
        }
    };
    let l = gpu.limits();
    println!(
        "GL adapter {}: storage buffers per stage {}, storage binding {} B, workgroup storage {} B, invocations per workgroup {}",
        gpu.adapter_description(),
        l.max_storage_buffers_per_shader_stage,
        l.max_storage_buffer_binding_size,
        l.max_compute_workgroup_storage_size,
        l.max_compute_invocations_per_workgroup
    );
    assert!(gpu.adapter_description().contains("Gl"), "{}", gpu.adapter_description());
    let mut failures = Vec::new();
    for path in pipelines() {
        // 48×36, not 32×24: at 768 pixels the sampling passes' 0.1% allowance (one grazing ray that
        // hits on one backend and misses on the other, see backends/src/parity.rs) rounds down to
        // zero pixels; with the graph-hashed streams one such pixel of `indirect.sample_initial`'s
        // depth differs by 1.3e-5 relative on llvmpipe's GL.
        let session = Session::open(Some(&path), &small(48, 36)).unwrap();
        match run_parity(&job(&session), &mut gpu) {
            Ok(report) => {
                println!("{} (GL)\n{}", path.display(), report.table());
                if !report.ok() {
                    failures.push(format!("{}: parity mismatch on GL (table above)", path.display()));
                }
            }
            Err(e) => failures.push(format!("{}: {e}", path.display())),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A test-only kernel whose WGSL writes `hash4`, `uniform`, `cmj`, `permute` and `substream` outputs
/// for many inputs (one per pixel; sub-stream indices up to 299, past the 64 lights where packed
/// streams collided); the Rust side recomputes them with `wedge::backends::rng`.
struct RngProbe;

const RNG_PROBE_WGSL: &str = r#"
#include "rng.wgsl"
@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) { return; }
    let i = pixel_index(gid);
    let h = hash4(i, i * 2654435761u, frame.seed, i ^ 0xdeadbeefu);
    hash_put(i, h);
    uniform_put(i, rng_uniform(rng_key(frame.seed, i, 3u), i % 97u, DIM_LIGHT));
    let n = 1u + (i % 401u);
    cmj_put(i, cmj(h % n, n, hash4(i, 17u, 0u, 0u)));
    perm_put(i, permute(i % n, n, h));
    substream_put(i, rng_substream(h, i % 300u));
}
"#;

impl Kernel for RngProbe {
    fn name(&self) -> &'static str {
        "test.rng_probe"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Compose
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::write("hash", Format::U32),
            Binding::write("uniform", Format::F32),
            Binding::write("cmj", Format::Vec2),
            Binding::write("perm", Format::U32),
            Binding::write("substream", Format::U32),
        ]
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let seed = ctx.seed;
        let n = ctx.pixels() as u32;
        let hash: Vec<u32> = (0..n).map(|i| rng::hash4(i, i.wrapping_mul(2654435761), seed, i ^ 0xdead_beef)).collect();
        let uniform: Vec<f32> =
            (0..n).map(|i| rng::PixelRng::new(seed, i, 3).uniform(i % 97, rng::dim::LIGHT)).collect();
        let cmj: Vec<[f32; 2]> = (0..n)
            .map(|i| {
                let m = 1 + i % 401;
                rng::cmj(hash[i as usize] % m, m, rng::hash4(i, 17, 0, 0))
            })
            .collect();
        let perm: Vec<u32> = (0..n)
            .map(|i| {
                let m = 1 + i % 401;
                rng::permute(i % m, m, hash[i as usize])
            })
            .collect();
        let substream: Vec<u32> = (0..n).map(|i| rng::substream(hash[i as usize], i % 300)).collect();
        ctx.put("substream", substream)?;
        ctx.put("hash", hash)?;
        ctx.put("uniform", uniform)?;
        ctx.put("cmj", cmj)?;
        ctx.put("perm", perm)
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(WgslSource::new(RNG_PROBE_WGSL, |_| Ok(Uniforms::new())))
    }
}

#[test]
fn rng_wgsl_is_bit_exact() {
    let Some(mut gpu) = gpu_or_skip("rng_wgsl_is_bit_exact") else { return };
    let scene = wedge::scene::load(&wedge::scene::SceneSource::Builtin("grids".into())).unwrap();
    let (w, h, seed) = (256u32, 256u32, 12345u32);
    let out = gpu.run_kernel(Arc::new(RngProbe), &scene, w, h, seed, BTreeMap::new(), &BTreeMap::new()).unwrap();
    let (mut hash, mut uniform, mut cmj, mut perm, mut sub) = (0, 0, 0, 0, 0);
    let BufferData::U32(gs) = &out["substream"] else { panic!("unexpected format") };
    let (BufferData::U32(gh), BufferData::F32(gu), BufferData::Vec2(gc), BufferData::U32(gp)) =
        (&out["hash"], &out["uniform"], &out["cmj"], &out["perm"])
    else {
        panic!("unexpected formats")
    };
    for i in 0..w * h {
        let k = i as usize;
        let hs = rng::hash4(i, i.wrapping_mul(2654435761), seed, i ^ 0xdead_beef);
        let m = 1 + i % 401;
        hash += (gh[k] != hs) as usize;
        uniform +=
            (gu[k].to_bits() != rng::PixelRng::new(seed, i, 3).uniform(i % 97, rng::dim::LIGHT).to_bits()) as usize;
        let c = rng::cmj(hs % m, m, rng::hash4(i, 17, 0, 0));
        cmj += (gc[k][0].to_bits() != c[0].to_bits() || gc[k][1].to_bits() != c[1].to_bits()) as usize;
        perm += (gp[k] != rng::permute(i % m, m, hs)) as usize;
        sub += (gs[k] != rng::substream(hs, i % 300)) as usize;
    }
    println!("mismatches of {}: hash4 {hash}, uniform {uniform}, cmj {cmj}, permute {perm}, substream {sub}", w * h);
    assert_eq!((hash, uniform, cmj, perm, sub), (0, 0, 0, 0, 0));
}

/// Pixels where `a` and `b` differ in any component's bits.
fn differing_pixels(a: &BufferData, b: &BufferData) -> usize {
    (0..a.len())
        .filter(|&i| (0..a.format().components()).any(|c| a.component(i, c).to_bits() != b.component(i, c).to_bits()))
        .count()
}

/// Every output of a GPU run within relMSE 1e-4 of the CPU run's (printed).
fn assert_outputs_match(cpu: &wedge::backends::RunResult, gpu: &wedge::backends::RunResult) {
    for (key, reference) in &cpu.outputs {
        let e = rel_mse(&gpu.outputs[key], reference);
        println!("{key:?}: relMSE vs CPU {e:.3e}");
        assert!(e <= 1e-4, "{key:?}: relMSE {e} > 1e-4");
    }
}

/// Heavy sampling on lavapipe, which ends a shader loop after 65,535 iterations (`indirect.ron` at
/// μ 4 with 4 bounces, 16×12): sampling passes run in chunks of samples per dispatch, so
/// - by default no loop is cut and the render equals the CPU's (relMSE ≤ 1e-4, same ray counts);
/// - the result does not depend on the chunk size, bit for bit (raw sums carried between chunks);
/// - with chunking off, the cut loops are counted (`RayCounts::cut_loops`), never silent.
#[test]
fn heavy_sampling_is_chunked_and_cut_loops_are_counted() {
    let Some(mut gpu) = gpu_or_skip("heavy_sampling_is_chunked_and_cut_loops_are_counted") else { return };
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines/indirect.ron");
    let heavy = vec![
        ("indirect".to_string(), "mu".to_string(), wedge::graph::ParamValue::Float(4.0)),
        ("indirect".to_string(), "bounces".to_string(), wedge::graph::ParamValue::Int(4)),
    ];
    let session = Session::open(Some(&path), &Overrides { params: heavy, ..small(16, 12) }).unwrap();
    let cpu = session.run(&mut CpuBackend::new(), &Silent).unwrap();
    let chunked = session.run(&mut gpu, &Silent).unwrap();
    println!("default chunking: cut loops {}", chunked.rays.cut_loops);
    assert_eq!(chunked.rays.cut_loops, 0);
    assert_eq!(cpu.rays, chunked.rays, "ray counters differ");
    assert_outputs_match(&cpu, &chunked);
    gpu.set_samples_per_dispatch(5);
    let small_chunks = session.run(&mut gpu, &Silent).unwrap();
    for (key, a) in &chunked.outputs {
        let b = &small_chunks.outputs[key];
        let differ = differing_pixels(a, b);
        assert_eq!(differ, 0, "{key:?}: 5 samples per dispatch differs from the default in {differ} pixels");
    }
    gpu.set_samples_per_dispatch(u32::MAX);
    let unchunked = session.run(&mut gpu, &Silent).unwrap();
    println!("one dispatch per pass: cut loops {} ({})", unchunked.rays.cut_loops, gpu.adapter_description());
    if gpu.is_software() {
        assert!(unchunked.rays.cut_loops > 0, "lavapipe's loop limit should have been hit and counted");
    }
}

/// `mr.sample` (mixed reality) is chunked by primary sample: a pixel resumes from the raw sums its
/// outputs hold between chunks, so any chunk size gives the same image bit for bit, no loop is cut,
/// and the counts are the CPU's.
#[test]
fn mixed_reality_sampling_is_chunked_bit_for_bit() {
    let Some(mut gpu) = gpu_or_skip("mixed_reality_sampling_is_chunked_bit_for_bit") else { return };
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines/mixed_reality.ron");
    let params = vec![
        ("mr".to_string(), "primary".to_string(), wedge::graph::ParamValue::Int(40)),
        ("mr".to_string(), "capture_spp".to_string(), wedge::graph::ParamValue::Int(16)),
    ];
    let session = Session::open(Some(&path), &Overrides { params, ..small(16, 12) }).unwrap();
    let cpu = session.run(&mut CpuBackend::new(), &Silent).unwrap();
    let chunked = session.run(&mut gpu, &Silent).unwrap();
    println!("default chunking: cut loops {}", chunked.rays.cut_loops);
    assert_eq!(chunked.rays.cut_loops, 0);
    assert_eq!(cpu.rays, chunked.rays, "ray counters differ");
    assert_outputs_match(&cpu, &chunked);
    gpu.set_samples_per_dispatch(3);
    let small_chunks = session.run(&mut gpu, &Silent).unwrap();
    gpu.set_samples_per_dispatch(u32::MAX);
    let one = session.run(&mut gpu, &Silent).unwrap();
    println!("one dispatch per pass: cut loops {} ({})", one.rays.cut_loops, gpu.adapter_description());
    // Where the driver cuts the single dispatch's loops (lavapipe) the cut is counted, not silent;
    // elsewhere one dispatch is the same image.
    let mut compared = vec![("3 samples per dispatch", &small_chunks)];
    if gpu.is_software() {
        assert!(one.rays.cut_loops > 0, "lavapipe's loop limit should have been hit and counted");
    } else {
        compared.push(("one dispatch", &one));
    }
    for (key, a) in &chunked.outputs {
        for (what, run) in &compared {
            let b = &run.outputs[key];
            let differ = differing_pixels(a, b);
            assert_eq!(differ, 0, "{key:?}: {what} differs from the default chunks in {differ} pixels");
        }
    }
    assert_eq!(small_chunks.rays, chunked.rays);
}

/// `light_field.sample` is chunked over its paths (a reference traces thousands per pixel: unchunked,
/// lavapipe cut 656 loops of a 1024-path reference of `lightfield_indirect.ron` at 32×24): any chunk
/// size gives the same samples, primary hits and estimate bit for bit (`lightfield_motion.ron`, 8
/// timed paths per pixel, in chunks of 3), and a 1024-path reference is the CPU's with no loop cut.
#[test]
fn light_field_sampling_is_chunked_bit_for_bit() {
    let Some(mut gpu) = gpu_or_skip("light_field_sampling_is_chunked_bit_for_bit") else { return };
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines");
    let session = Session::open(Some(&dir.join("lightfield_motion.ron")), &small(16, 12)).unwrap();
    gpu.set_samples_per_dispatch(3);
    let three = session.run(&mut gpu, &Silent).unwrap();
    gpu.set_samples_per_dispatch(u32::MAX);
    let one = session.run(&mut gpu, &Silent).unwrap();
    assert_eq!(one.rays.cut_loops, 0);
    for (key, a) in &one.outputs {
        let b = &three.outputs[key];
        let differ = differing_pixels(a, b);
        assert_eq!(differ, 0, "{key:?}: 3 paths per dispatch differs from one dispatch in {differ} pixels");
    }
    assert_eq!(three.rays, one.rays);
    gpu.set_samples_per_dispatch(16);
    let reference =
        Session::reference(Some(&dir.join("lightfield_indirect.ron")), 1024, "stratified", &small(16, 12)).unwrap();
    let cpu = reference.run(&mut CpuBackend::new(), &Silent).unwrap();
    let chunked = reference.run(&mut gpu, &Silent).unwrap();
    println!("1024-path reference: cut loops {}", chunked.rays.cut_loops);
    assert_eq!(chunked.rays.cut_loops, 0);
    assert_eq!(cpu.rays, chunked.rays, "ray counters differ");
    assert_outputs_match(&cpu, &chunked);
}

/// A kernel that does not declare how far it reads (the RNG probe keeps the default `Reach::Image`)
/// is never split: over the binding limit it is an error that says why and what to do.
#[test]
fn kernel_without_declared_reach_is_not_split() {
    let Some(mut gpu) = gpu_or_skip("kernel_without_declared_reach_is_not_split") else { return };
    gpu.set_binding_limit(1024);
    let scene = wedge::scene::load(&wedge::scene::SceneSource::Builtin("grids".into())).unwrap();
    let e = gpu
        .run_kernel(Arc::new(RngProbe), &scene, 64, 64, 1, BTreeMap::new(), &BTreeMap::new())
        .unwrap_err()
        .to_string();
    println!("{e}");
    assert!(e.contains("test.rng_probe") && e.contains("Reach::Image") && e.contains("--backend cpu"), "{e}");
}

/// The `Params` struct is generated from the fields `WgslSource::uniforms` returns; a kernel whose
/// fields change with the pass's parameters is refused with a message saying so.
#[test]
fn params_fields_must_not_depend_on_parameters() {
    let Some(mut gpu) = gpu_or_skip("params_fields_must_not_depend_on_parameters") else { return };
    struct Shifty;
    impl Kernel for Shifty {
        fn name(&self) -> &'static str {
            "test.shifty"
        }
        fn class(&self) -> KernelClass {
            KernelClass::Compose
        }
        fn bindings(&self) -> Vec<Binding> {
            vec![Binding::write("out", Format::F32)]
        }
        fn run_cpu(&self, _: &mut KernelCtx<'_>) -> Result<(), BackendError> {
            Ok(())
        }
        fn wgsl(&self) -> Option<WgslSource> {
            let src = "@compute @workgroup_size(8, 8)\nfn main(@builtin(global_invocation_id) gid: vec3<u32>) {\n    if (pixel_of(gid)) { out_put(pixel_index(gid), 1.0); }\n}\n";
            Some(WgslSource::new(src, |ctx| {
                Ok(if ctx.params.contains_key("wide") {
                    Uniforms::new().vec3("a", [1.0; 3])
                } else {
                    Uniforms::new().f32("a", 1.0)
                })
            }))
        }
    }
    let scene = wedge::scene::load(&wedge::scene::SceneSource::Builtin("grids".into())).unwrap();
    let out = gpu.run_kernel(Arc::new(Shifty), &scene, 8, 8, 1, BTreeMap::new(), &BTreeMap::new()).unwrap();
    assert_eq!(out["out"], BufferData::F32(vec![1.0; 64]));
    let wide = BTreeMap::from([("wide".to_string(), wedge::graph::ParamValue::Bool(true))]);
    let e = gpu.run_kernel(Arc::new(Shifty), &scene, 8, 8, 1, wide, &BTreeMap::new()).unwrap_err().to_string();
    println!("{e}");
    assert!(e.contains("test.shifty") && e.contains("must not depend on the pass's parameters"), "{e}");
}

#[test]
fn kernel_without_wgsl_is_a_clear_error() {
    let Some(mut gpu) = gpu_or_skip("kernel_without_wgsl_is_a_clear_error") else { return };
    struct CpuOnly;
    impl Kernel for CpuOnly {
        fn name(&self) -> &'static str {
            "test.cpu_only"
        }
        fn class(&self) -> KernelClass {
            KernelClass::Compose
        }
        fn bindings(&self) -> Vec<Binding> {
            vec![Binding::write("out", Format::F32)]
        }
        fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
            let n = ctx.pixels();
            ctx.put("out", vec![0f32; n])
        }
    }
    let scene = wedge::scene::load(&wedge::scene::SceneSource::Builtin("grids".into())).unwrap();
    let e = gpu.run_kernel(Arc::new(CpuOnly), &scene, 8, 8, 1, BTreeMap::new(), &BTreeMap::new()).unwrap_err();
    assert!(e.to_string().contains("no WGSL implementation"), "{e}");

    // A shader that does not validate is an error naming the kernel, not a panic.
    struct Broken;
    impl Kernel for Broken {
        fn name(&self) -> &'static str {
            "test.broken"
        }
        fn class(&self) -> KernelClass {
            KernelClass::Compose
        }
        fn bindings(&self) -> Vec<Binding> {
            vec![Binding::write("out", Format::F32)]
        }
        fn run_cpu(&self, _: &mut KernelCtx<'_>) -> Result<(), BackendError> {
            Ok(())
        }
        fn wgsl(&self) -> Option<WgslSource> {
            Some(WgslSource::new("fn main( { this is not wgsl", |_| Ok(Uniforms::new())))
        }
    }
    let e = gpu.run_kernel(Arc::new(Broken), &scene, 8, 8, 1, BTreeMap::new(), &BTreeMap::new()).unwrap_err();
    println!("{e}");
    assert!(e.to_string().contains("test.broken"), "{e}");
}

/// `--gpu-limits webgpu` opens the device with WebGPU's default limits from the command line: the
/// render says which passes were bound packed (paths.resolve declares 21 buffers against 8)
/// and `wedge parity` still passes.
#[test]
fn cli_gpu_limits_webgpu_packs_and_keeps_parity() {
    if gpu_or_skip("cli_gpu_limits_webgpu_packs_and_keeps_parity").is_none() {
        return;
    }
    let out = tempfile::tempdir().unwrap();
    let wedge = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_wedge"))
            .args(args)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap()
    };
    let o = wedge(&[
        "render",
        "pipelines/indirect.ron",
        "--backend",
        "wgpu",
        "--gpu-limits",
        "webgpu",
        "--width",
        "16",
        "--height",
        "12",
        "--out",
        out.path().to_str().unwrap(),
    ]);
    let text = String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{text}");
    // paths.trace declares 7 buffers (a record to continue, 5 counts, the record) besides the scene
    // and the counters; paths.resolve 30.
    assert!(
        text.contains(
            "passes bound packed (more buffers than the device's 8 storage buffers per stage): sampler.first, \
             sampler.resolve_first, sampler.adaptive, sampler.resolve_final"
        ),
        "{text}"
    );
    let o = wedge(&["parity", "pipelines/indirect.ron", "--gpu-limits", "webgpu", "--width", "16", "--height", "12"]);
    let text = String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && text.contains("parity: ok"), "{text}");
}

/// The `motion` scene through an existing pipeline on the GPU (its instances traced by the WGSL at
/// `scene_time` 0): every pass of `shadows.ron` within `run_parity`'s tolerances, on the default
/// adapter and, where there is one, GL. 32×24 keeps it to seconds on lavapipe.
#[test]
fn parity_on_the_motion_scene() {
    let ov = Overrides { width: Some(32), height: Some(24), scene: Some("motion".into()), ..Default::default() };
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines/shadows.ron");
    let session = Session::open(Some(&path), &ov).unwrap();
    assert!(session.scene.has_motion());
    let mut backends = Vec::new();
    if let Some(gpu) = gpu_or_skip("parity_on_the_motion_scene") {
        backends.push(gpu);
    }
    use wedge::backends::gpu::LimitsChoice;
    match GpuBackend::open_on(Some(wedge::backends::gpu::Backends::GL), LimitsChoice::Adapter) {
        Ok(g) => backends.push(g),
        Err(e) => eprintln!("parity_on_the_motion_scene: GL SKIPPED — {e}"),
    }
    for mut gpu in backends {
        let report = run_parity(&job(&session), &mut gpu).unwrap();
        println!("motion on {}\n{}", gpu.adapter_description(), report.table());
        assert!(report.ok(), "parity mismatch on `motion` ({})", gpu.adapter_description());
    }
}

/// Traces the scene at a per-pixel time (`scene_time`): closest hit, its surface and velocity, light 0
/// where it is at that time, and a shadow ray toward it — `SceneAt` on the CPU, the WGSL mirror on
/// the GPU, from the same rays (input buffers).
struct MotionProbe;

const MOTION_PROBE_WGSL: &str = r#"
#include "bvh.wgsl"
@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) { return; }
    let i = pixel_index(gid);
    scene_time = time_at(i);
    let o = origin_at(i);
    let d = dir_at(i);
    let l = scene_light_at(0u);
    light_put(i, l.p0.xyz);
    let h = scene_intersect(o, d, 0.0, inf());
    if (!h.hit) {
        triangle_put(i, 0xffffffffu);
        return;
    }
    triangle_put(i, h.triangle);
    distance_put(i, h.t);
    let sp = surface(h.triangle, h.b1, h.b2, d);
    position_put(i, sp.position);
    normal_put(i, sp.shading_normal);
    velocity_put(i, object_velocity(sp.object, sp.position));
    let x = sp.position + sp.geometric_normal * 1e-3;
    let seg = l.centre_sigma.xyz - x;
    let len = length3(seg);
    occluded_put(i, select(0u, 1u, scene_occluded(x, seg / len, 0.0, len * 0.999)));
}
"#;

impl Kernel for MotionProbe {
    fn name(&self) -> &'static str {
        "test.motion_probe"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Sampling
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("origin", Format::Vec3),
            Binding::read("dir", Format::Vec3),
            Binding::read("time", Format::F32),
            Binding::write("triangle", Format::U32),
            Binding::write("distance", Format::F32),
            Binding::write("position", Format::Vec3),
            Binding::write("normal", Format::Vec3),
            Binding::write("velocity", Format::Vec3),
            Binding::write("light", Format::Vec3),
            Binding::write("occluded", Format::U32),
        ]
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let (origin, dir, time) =
            (ctx.read::<[f32; 3]>("origin")?, ctx.read::<[f32; 3]>("dir")?, ctx.read::<f32>("time")?);
        let n = ctx.pixels();
        let (mut triangle, mut distance) = (vec![u32::MAX; n], vec![0.0f32; n]);
        let (mut position, mut normal, mut velocity, mut light) =
            (vec![[0.0f32; 3]; n], vec![[0.0f32; 3]; n], vec![[0.0f32; 3]; n], vec![[0.0f32; 3]; n]);
        let mut occluded = vec![0u32; n];
        for i in 0..n {
            let at = ctx.scene.at(time[i]);
            let (o, d) = (glam::Vec3::from(origin[i]), glam::Vec3::from(dir[i]));
            let l = at.light(0);
            light[i] = l.vertices()[0].to_array();
            let Some(h) = at.intersect(o, d, 0.0, f32::INFINITY) else { continue };
            triangle[i] = h.triangle;
            distance[i] = h.t;
            let sp = at.surface(&h, o, d);
            position[i] = sp.position.to_array();
            normal[i] = sp.shading_normal.to_array();
            velocity[i] = at.velocity(&sp).to_array();
            let x = sp.position + sp.geometric_normal * 1e-3;
            let seg = l.centre() - x;
            let len = seg.length();
            occluded[i] = at.occluded(x, seg / len, 0.0, len * 0.999) as u32;
        }
        ctx.put("triangle", triangle)?;
        ctx.put("distance", distance)?;
        ctx.put("position", position)?;
        ctx.put("normal", normal)?;
        ctx.put("velocity", velocity)?;
        ctx.put("light", light)?;
        ctx.put("occluded", occluded)
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(WgslSource::new(MOTION_PROBE_WGSL, |_| Ok(Uniforms::new())).with_scene())
    }
}

/// `SceneAt` against its WGSL mirror at times all over the shutter (the pipelines only trace t = 0):
/// on `motion` with its light made to move too (so `scene_light_at` and moving emitters are covered),
/// camera rays at per-pixel times including −1, 0 and 1. Bit for bit where the GPU does not fuse
/// multiply-adds (lavapipe); otherwise hits agree on ≥ 99.9% of rays and values within 1e-5.
#[test]
fn scene_motion_wgsl_matches_scene_at() {
    let mut scene = wedge::scene::load(&wedge::scene::SceneSource::Builtin("motion".into())).unwrap();
    let swing = wedge::scene::RigidMotion {
        pivot: glam::Vec3::new(-0.2, 3.0, 0.1),
        translation: [glam::Vec3::new(-0.3, 0.0, 0.0), glam::Vec3::new(0.3, 0.1, 0.0)],
        rotation: [glam::Quat::from_rotation_z(-0.3), glam::Quat::from_rotation_z(0.2)],
    };
    scene.set_motion("light", swing).unwrap();
    motion_probe_matches("scene_motion_wgsl_matches_scene_at", &scene);
}

/// The same probe on `spheres` with 120 of its spheres moving (a translation and a turn each, their
/// own instances): the top-level tree over the instances' swept boxes (several levels deep) is walked
/// the same way on both backends.
#[test]
fn many_moving_instances_wgsl_match_scene_at() {
    use wedge::scene::{RigidMotion, Scene, SceneObject};
    let still = wedge::scene::load(&wedge::scene::SceneSource::Builtin("spheres".into())).unwrap();
    let tris: Vec<_> = (0..still.triangles.len())
        .map(|i| {
            let v = still.triangles[i].vertices();
            (v[0], v[1], v[2], still.shading[i])
        })
        .collect();
    let objects: Vec<SceneObject> = still
        .objects
        .iter()
        .enumerate()
        .map(|(k, o)| SceneObject {
            motion: (k % 3 == 1 && k <= 360).then(|| RigidMotion {
                pivot: glam::Vec3::ZERO,
                translation: [glam::Vec3::ZERO, glam::Vec3::new(0.05, 0.02 * (k % 5) as f32, -0.03)],
                rotation: [glam::Quat::IDENTITY, glam::Quat::from_rotation_y(0.002 * k as f32)],
            }),
            ..SceneObject::named(o.name.clone())
        })
        .collect();
    let scene = Scene::from_objects(
        "spheres, 120 moving",
        tris,
        still.materials.clone(),
        still.textures.clone(),
        still.camera,
        objects,
    )
    .unwrap();
    assert_eq!(scene.instances.len(), 120);
    motion_probe_matches("many_moving_instances_wgsl_match_scene_at", &scene);
}

/// [`MotionProbe`] on the CPU and every GPU backend here, at per-pixel times over the shutter.
fn motion_probe_matches(test: &str, scene: &wedge::scene::Scene) {
    let (w, h) = (96u32, 72u32);
    let (mut origin, mut dir, mut time) = (Vec::new(), Vec::new(), Vec::new());
    for y in 0..h {
        for x in 0..w {
            let (o, d) = scene.camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5, w, h, glam::Vec2::ZERO);
            origin.push(o.to_array());
            dir.push(d.to_array());
            let k = (x * 7 + y * 13) % 41;
            time.push(-1.0 + 2.0 * k as f32 / 40.0);
        }
    }
    let inputs: BTreeMap<String, BufferData> = [
        ("origin".to_string(), BufferData::Vec3(origin)),
        ("dir".to_string(), BufferData::Vec3(dir)),
        ("time".to_string(), BufferData::F32(time)),
    ]
    .into_iter()
    .collect();
    let lone = wedge::backends::lone::LonePass::new(Arc::new(MotionProbe), BTreeMap::new(), &inputs).unwrap();
    let (cpu, _) = lone.run_cpu(scene, w, h, 1).unwrap();
    let BufferData::U32(ct) = &cpu["triangle"] else { panic!() };
    assert!(ct.iter().filter(|&&t| t != u32::MAX).count() > (w * h / 2) as usize);
    let mut backends = Vec::new();
    if let Some(gpu) = gpu_or_skip(test) {
        backends.push(gpu);
    }
    use wedge::backends::gpu::LimitsChoice;
    match GpuBackend::open_on(Some(wedge::backends::gpu::Backends::GL), LimitsChoice::Adapter) {
        Ok(g) => backends.push(g),
        Err(e) => eprintln!("{test}: GL SKIPPED — {e}"),
    }
    for mut gpu in backends {
        let gpu_out = gpu.run_kernel(Arc::new(MotionProbe), scene, w, h, 1, BTreeMap::new(), &inputs).unwrap();
        let BufferData::U32(gt) = &gpu_out["triangle"] else { panic!() };
        let n = (w * h) as usize;
        let (mut same_hit, mut bits, mut worst) = (0usize, 0usize, 0.0f32);
        for i in 0..n {
            if gt[i] != ct[i] {
                continue;
            }
            same_hit += 1;
            if ct[i] == u32::MAX {
                bits += 1;
                continue;
            }
            let mut exact = true;
            for name in ["distance", "position", "normal", "velocity", "light"] {
                for c in 0..cpu[name].format().components() {
                    let (a, b) = (cpu[name].component(i, c), gpu_out[name].component(i, c));
                    exact &= a.to_bits() == b.to_bits();
                    worst = worst.max((a - b).abs() / (1.0 + a.abs()));
                }
            }
            let BufferData::U32(go) = &gpu_out["occluded"] else { panic!() };
            let BufferData::U32(co) = &cpu["occluded"] else { panic!() };
            exact &= go[i] == co[i];
            bits += exact as usize;
        }
        println!(
            "{}: {same_hit} of {n} rays hit the same triangle, {bits} bit for bit in every output; largest difference {worst:.2e} (relative to 1 + |value|)",
            gpu.adapter_description()
        );
        assert!(same_hit * 1000 >= n * 999, "{same_hit} of {n}");
        assert!(worst <= 1e-5, "{worst}");
    }
}

/// The environment map's WGSL mirror (`shaders/environment.wgsl`): per pixel a direction in, and
/// `env_texel`, `env_radiance`, `env_pdf`, `scene_background` and table entry `pixel % 4096` out —
/// `EnvironmentMap::texel_of`, `radiance`, `pdf`, `Scene::background` and `table` on the CPU.
struct EnvProbe;

const ENV_PROBE_WGSL: &str = r#"
#include "scene.wgsl"
@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) { return; }
    let i = pixel_index(gid);
    let d = dir_at(i);
    var texel = 0xffffffffu;
    if (env_present()) {
        texel = env_texel(d);
    }
    env_texel_out_put(i, texel);
    radiance_put(i, env_radiance(d));
    pdf_put(i, env_pdf(d));
    background_put(i, scene_background(d));
    let s = env_table(i);
    table_dir_put(i, s.dir);
    table_radiance_put(i, s.radiance);
    table_pdf_put(i, s.pdf);
    table_texel_put(i, s.texel);
}
"#;

impl Kernel for EnvProbe {
    fn name(&self) -> &'static str {
        "test.env_probe"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Sampling
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("dir", Format::Vec3),
            Binding::write("env_texel_out", Format::U32),
            Binding::write("radiance", Format::Vec3),
            Binding::write("pdf", Format::F32),
            Binding::write("background", Format::Vec3),
            Binding::write("table_dir", Format::Vec3),
            Binding::write("table_radiance", Format::Vec3),
            Binding::write("table_pdf", Format::F32),
            Binding::write("table_texel", Format::U32),
        ]
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let dir = ctx.read::<[f32; 3]>("dir")?;
        let scene = ctx.scene;
        let n = ctx.pixels();
        let (mut texel, mut radiance, mut pdf, mut background) =
            (vec![u32::MAX; n], vec![[0.0f32; 3]; n], vec![0.0f32; n], vec![[0.0f32; 3]; n]);
        let (mut tdir, mut trad, mut tpdf, mut ttex) =
            (vec![[0.0f32; 3]; n], vec![[0.0f32; 3]; n], vec![0.0f32; n], vec![0u32; n]);
        for i in 0..n {
            let d = glam::Vec3::from(dir[i]);
            background[i] = scene.background(d).to_array();
            let Some(env) = &scene.environment else { continue };
            let (c, r) = env.texel_of(d);
            texel[i] = r * env.width() + c;
            radiance[i] = env.radiance(d).to_array();
            pdf[i] = env.pdf(d);
            let s = env.table(i);
            (tdir[i], trad[i], tpdf[i], ttex[i]) = (s.dir.to_array(), s.radiance.to_array(), s.pdf, s.texel);
        }
        ctx.put("env_texel_out", texel)?;
        ctx.put("radiance", radiance)?;
        ctx.put("pdf", pdf)?;
        ctx.put("background", background)?;
        ctx.put("table_dir", tdir)?;
        ctx.put("table_radiance", trad)?;
        ctx.put("table_pdf", tpdf)?;
        ctx.put("table_texel", ttex)
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(WgslSource::new(ENV_PROBE_WGSL, |_| Ok(Uniforms::new())).with_scene())
    }
}

/// Directions for the environment probe: random over the sphere at random lengths, the map's texel
/// corners and edge midpoints (directions on row and column boundaries, where rounding would show),
/// the poles and the axes.
fn env_probe_dirs(env: &wedge::scene::EnvironmentMap, n: usize) -> Vec<[f32; 3]> {
    let mut state = 0x1234_5678_9abc_def0u64;
    let mut next = || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u32 << 24) as f32
    };
    let (w, h) = (env.width(), env.height());
    let mut dirs = vec![
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
        [0.0, 3.0, 0.0],
    ];
    while dirs.len() < n / 2 {
        let (u, v) = ((next() * w as f32).floor() / w as f32, (next() * h as f32).floor() / h as f32);
        let half = if next() < 0.5 { 0.5 / w as f32 } else { 0.0 };
        dirs.push(env.direction_of(u + half, v).to_array());
    }
    while dirs.len() < n {
        let z = 1.0 - 2.0 * next();
        let phi = std::f32::consts::TAU * next();
        let s = (1.0 - z * z).max(0.0).sqrt() * (0.25 + 4.0 * next());
        dirs.push([s * phi.cos(), z * s.max(0.25), s * phi.sin()]);
    }
    dirs
}

/// `env_texel`/`env_radiance`/`env_pdf`/`scene_background`/`env_table` against the CPU on `envmap`
/// (its sky rotated 33.3° and scaled 1.7), for 64k directions — half of them on texel boundaries —
/// and every table entry; and `grids` (no map: zeros). Bit for bit where the GPU does not fuse
/// `x·x + z·z` into a multiply-add (lavapipe, llvmpipe GL); the share of differing texels is printed
/// and must stay under 0.1% elsewhere, the table always bit for bit.
#[test]
fn environment_wgsl_matches_cpu() {
    let mut scene = wedge::scene::load(&wedge::scene::SceneSource::Builtin("envmap".into())).unwrap();
    let env = scene.environment.clone().unwrap().with_params(1.7, 33.3).unwrap();
    scene.set_environment(Some(env.clone()));
    let plain = wedge::scene::load(&wedge::scene::SceneSource::Builtin("grids".into())).unwrap();
    let (w, h) = (256u32, 256u32);
    let inputs: BTreeMap<String, BufferData> =
        [("dir".to_string(), BufferData::Vec3(env_probe_dirs(&env, (w * h) as usize)))].into_iter().collect();
    let mut backends = Vec::new();
    if let Some(gpu) = gpu_or_skip("environment_wgsl_matches_cpu") {
        backends.push(gpu);
    }
    use wedge::backends::gpu::LimitsChoice;
    match GpuBackend::open_on(Some(wedge::backends::gpu::Backends::GL), LimitsChoice::Adapter) {
        Ok(g) => backends.push(g),
        Err(e) => eprintln!("environment_wgsl_matches_cpu: GL SKIPPED — {e}"),
    }
    let lone = wedge::backends::lone::LonePass::new(Arc::new(EnvProbe), BTreeMap::new(), &inputs).unwrap();
    for mut gpu in backends {
        for s in [&scene, &plain] {
            let (cpu, _) = lone.run_cpu(s, w, h, 1).unwrap();
            let out = gpu.run_kernel(Arc::new(EnvProbe), s, w, h, 1, BTreeMap::new(), &inputs).unwrap();
            let n = (w * h) as usize;
            let (BufferData::U32(ct), BufferData::U32(gt)) = (&cpu["env_texel_out"], &out["env_texel_out"]) else {
                panic!()
            };
            let differ = (0..n).filter(|&i| ct[i] != gt[i]).count();
            let mut other = Vec::new();
            for name in ["radiance", "pdf", "background", "table_dir", "table_radiance", "table_pdf", "table_texel"] {
                let bad = (0..n)
                    .filter(|&i| ct[i] == gt[i] || name.starts_with("table"))
                    .filter(|&i| {
                        (0..cpu[name].format().components())
                            .any(|c| cpu[name].component(i, c).to_bits() != out[name].component(i, c).to_bits())
                    })
                    .count();
                other.push((name, bad));
            }
            println!("{} on `{}`: {differ} of {n} directions pick another texel; values differing in bits (same texel): {other:?}", gpu.adapter_description(), s.name);
            assert!(other.iter().all(|(_, bad)| *bad == 0), "{other:?}");
            assert!(differ * 1000 <= n, "{differ} of {n}");
            if s.environment.is_none() {
                assert!(ct.iter().all(|&t| t == u32::MAX) && gt.iter().all(|&t| t == u32::MAX));
            }
        }
    }
}

/// The real layer's WGSL accessors (`shaders/real_layer.wgsl`): per probe pixel `(x, y)` the layer's
/// pixel `(x − 8, y − 8)`, so a border of the probe reads outside the layer (zeros, not covered), and
/// `real_camera`, `real_position`, `real_normal`, `real_albedo`, `real_present` out — on the CPU
/// `RealLayer::index_of` and the maps.
struct RealProbe;

const REAL_PROBE_WGSL: &str = r#"
#include "scene.wgsl"
@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) { return; }
    let i = pixel_index(gid);
    let p = vec2<i32>(pixel_xy(gid)) - vec2<i32>(8, 8);
    camera_put(i, real_camera(p.x, p.y));
    position_put(i, real_position(p.x, p.y));
    normal_put(i, real_normal(p.x, p.y));
    albedo_put(i, real_albedo(p.x, p.y));
    present_put(i, select(0u, 1u, real_present()));
}
"#;

impl Kernel for RealProbe {
    fn name(&self) -> &'static str {
        "test.real_probe"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Sampling
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::write("camera", Format::Vec3),
            Binding::write("position", Format::Vec4),
            Binding::write("normal", Format::Vec3),
            Binding::write("albedo", Format::Vec3),
            Binding::write("present", Format::U32),
        ]
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let (w, n) = (ctx.width as i32, ctx.pixels());
        let real = ctx.scene.real.as_ref();
        let (mut camera, mut position, mut normal, mut albedo) =
            (vec![[0.0f32; 3]; n], vec![[0.0f32; 4]; n], vec![[0.0f32; 3]; n], vec![[0.0f32; 3]; n]);
        for i in 0..n {
            let (x, y) = (i as i32 % w - 8, i as i32 / w - 8);
            let Some(k) = real.and_then(|r| r.index_of(x, y)) else { continue };
            let r = real.unwrap();
            (camera[i], position[i], normal[i], albedo[i]) =
                (r.camera_map()[k], r.position_map()[k], r.normal_map()[k], r.albedo_map()[k]);
        }
        ctx.put("camera", camera)?;
        ctx.put("position", position)?;
        ctx.put("normal", normal)?;
        ctx.put("albedo", albedo)?;
        ctx.put("present", vec![real.is_some() as u32; n])
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(WgslSource::new(REAL_PROBE_WGSL, |_| Ok(Uniforms::new())).with_scene())
    }
}

/// The real layer reads the same bits on both backends: `envmap_real`'s own AOVs (`wedge render
/// --aov`) with a synthetic camera image as the layer, probed inside and 8 pixels beyond every edge,
/// and `grids` without a layer (zeros, `real_present()` false). Also the layer's GPU size in bytes.
#[test]
fn real_layer_wgsl_matches_cpu() {
    let mut scene = wedge::scene::load(&wedge::scene::SceneSource::Builtin("envmap_real".into())).unwrap();
    let (lw, lh) = (64u32, 48u32);
    let aovs = wedge::aov::Aovs::render(&scene, lw, lh).unwrap();
    let camera: Vec<[f32; 3]> = (0..lw * lh).map(|k| [k as f32 * 0.001, 1.0 / (1.0 + k as f32), 0.25]).collect();
    let layer = wedge::scene::RealLayer::from_maps(
        lw,
        lh,
        camera,
        aovs.position.clone(),
        aovs.normal.clone(),
        aovs.albedo.clone(),
    )
    .unwrap();
    assert!(layer.covered_count() > 0 && layer.covered_count() < (lw * lh) as usize, "the sky shows above the ground");
    assert_eq!(layer.position_map(), &aovs.position[..], "AOV positions load unchanged");
    scene.set_real(Some(layer));
    let plain = wedge::scene::load(&wedge::scene::SceneSource::Builtin("grids".into())).unwrap();
    let Some(mut gpu) = gpu_or_skip("real_layer_wgsl_matches_cpu") else { return };
    let (w, h) = (lw + 16, lh + 16);
    let inputs: BTreeMap<String, BufferData> = BTreeMap::new();
    let lone = wedge::backends::lone::LonePass::new(Arc::new(RealProbe), BTreeMap::new(), &inputs).unwrap();
    for s in [&scene, &plain] {
        let (cpu, _) = lone.run_cpu(s, w, h, 1).unwrap();
        let out = gpu.run_kernel(Arc::new(RealProbe), s, w, h, 1, BTreeMap::new(), &inputs).unwrap();
        let n = (w * h) as usize;
        for name in ["camera", "position", "normal", "albedo", "present"] {
            let comps = cpu[name].format().components();
            let bad = (0..n)
                .filter(|&i| {
                    (0..comps).any(|c| cpu[name].component(i, c).to_bits() != out[name].component(i, c).to_bits())
                })
                .count();
            assert_eq!(bad, 0, "`{name}` differs in {bad} of {n} pixels on `{}`", s.name);
        }
        let covered = (0..n).filter(|&i| out["position"].component(i, 3) == 1.0).count();
        println!("{} on `{}`: {n} probes bit for bit, {covered} covered", gpu.adapter_description(), s.name);
        assert_eq!(covered, s.real.as_ref().map_or(0, |r| r.covered_count()));
    }
}

/// The triangle test and traversal alone: per pixel a ray in, the closest hit (triangle, `t`, `b1`,
/// `b2`) and the any-hit answer out — `Scene::intersect`/`occluded` on the CPU, `scene_intersect`/
/// `scene_occluded` of `shaders/bvh.wgsl` on the GPU.
struct TriangleProbe;

const TRIANGLE_PROBE_WGSL: &str = r#"
#include "bvh.wgsl"
@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) { return; }
    let i = pixel_index(gid);
    let o = origin_at(i);
    let d = dir_at(i);
    occluded_put(i, select(0u, 1u, scene_occluded(o, d, 0.0, inf())));
    let h = scene_intersect(o, d, 0.0, inf());
    if (!h.hit) {
        triangle_put(i, 0xffffffffu);
        return;
    }
    triangle_put(i, h.triangle);
    distance_put(i, h.t);
    b1_put(i, h.b1);
    b2_put(i, h.b2);
}
"#;

impl Kernel for TriangleProbe {
    fn name(&self) -> &'static str {
        "test.triangle_probe"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Sampling
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("origin", Format::Vec3),
            Binding::read("dir", Format::Vec3),
            Binding::write("triangle", Format::U32),
            Binding::write("distance", Format::F32),
            Binding::write("b1", Format::F32),
            Binding::write("b2", Format::F32),
            Binding::write("occluded", Format::U32),
        ]
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let (origin, dir) = (ctx.read::<[f32; 3]>("origin")?, ctx.read::<[f32; 3]>("dir")?);
        let n = ctx.pixels();
        let (mut triangle, mut distance, mut b1, mut b2) =
            (vec![u32::MAX; n], vec![0.0f32; n], vec![0.0f32; n], vec![0.0f32; n]);
        let mut occluded = vec![0u32; n];
        for i in 0..n {
            let (o, d) = (glam::Vec3::from(origin[i]), glam::Vec3::from(dir[i]));
            occluded[i] = ctx.scene.occluded(o, d, 0.0, f32::INFINITY) as u32;
            let Some(h) = ctx.scene.intersect(o, d, 0.0, f32::INFINITY) else { continue };
            (triangle[i], distance[i], b1[i], b2[i]) = (h.triangle, h.t, h.b1, h.b2);
        }
        ctx.put("triangle", triangle)?;
        ctx.put("distance", distance)?;
        ctx.put("b1", b1)?;
        ctx.put("b2", b2)?;
        ctx.put("occluded", occluded)
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(WgslSource::new(TRIANGLE_PROBE_WGSL, |_| Ok(Uniforms::new())).with_scene())
    }
}

/// The watertight triangle test (Woop, Benthin and Wald 2013; `scene/src/bvh/triangle.rs`) against its
/// WGSL mirror on the rays where it matters: aimed exactly at the shared vertices and at points of the
/// shared edges of closed meshes (jittered UV spheres, from inside, near the origin and 1000 m out) and
/// of a fan (from above and below). Every ray must hit the mesh it was aimed at on both backends
/// (no leaks), with the same triangle; on a CPU-emulated adapter (lavapipe, llvmpipe GL: no fused
/// multiply-adds) `t`, `b1`, `b2` bit for bit. A GPU that fuses `a·b − c·d` into a multiply-add
/// rounds the edge functions differently, so elsewhere the hit must only agree on ≥ 99.9% of rays
/// (printed).
#[test]
fn watertight_triangle_wgsl_matches_cpu() {
    use glam::Vec3;
    use wedge::scene::{Material, Scene, TriangleShading};
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut tris = Vec::new();
    let (mut origin, mut dir, mut aimed_at) = (Vec::new(), Vec::new(), Vec::new());
    let mut ray = |o: Vec3, target: Vec3, scale: f32, object: u32| {
        origin.push(o.to_array());
        dir.push(((target - o) * scale).to_array());
        aimed_at.push(object);
    };
    let meshes: [(Vec3, f32, bool); 3] = [
        (Vec3::new(0.0, 1.0, 0.0), 1.0, true),
        (Vec3::new(1000.0, 37.0, -500.0), 1.0, true),
        (Vec3::new(-40.0, 3.0, 25.0), 2.0, false),
    ];
    for (object, &(c, r, closed)) in meshes.iter().enumerate() {
        let (slices, stacks) = (16usize, 8usize);
        let mut v = Vec::new();
        let mut f: Vec<[usize; 3]> = Vec::new();
        if closed {
            v.push(c + Vec3::Y * r);
            for i in 1..stacks {
                for j in 0..slices {
                    let (th, ph) = (
                        std::f32::consts::PI * i as f32 / stacks as f32,
                        std::f32::consts::TAU * j as f32 / slices as f32,
                    );
                    v.push(
                        c + Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin())
                            * (r * (1.0 + 0.05 * (next() - 0.5))),
                    );
                }
            }
            v.push(c - Vec3::Y * r);
            let at = |i: usize, j: usize| 1 + (i - 1) * slices + j % slices;
            for j in 0..slices {
                f.push([0, at(1, j + 1), at(1, j)]);
                f.push([v.len() - 1, at(stacks - 1, j), at(stacks - 1, j + 1)]);
                for i in 1..stacks - 1 {
                    f.push([at(i, j), at(i, j + 1), at(i + 1, j)]);
                    f.push([at(i, j + 1), at(i + 1, j + 1), at(i + 1, j)]);
                }
            }
        } else {
            v.push(c);
            for j in 0..slices {
                let ph = std::f32::consts::TAU * j as f32 / slices as f32;
                let (rr, h) = (r * (1.0 + 0.3 * (next() - 0.5)), r * 0.2 * (next() - 0.5));
                v.push(c + Vec3::new(ph.cos() * rr, h, ph.sin() * rr));
            }
            f = (0..slices).map(|j| [0, 1 + j, 1 + (j + 1) % slices]).collect();
        }
        let sh = TriangleShading { n: [Vec3::ZERO; 3], uv: [glam::Vec2::ZERO; 3], material: 0, object: object as u32 };
        tris.extend(f.iter().map(|t| (v[t[0]], v[t[1]], v[t[2]], sh)));
        // Targets: every (shared) vertex of a sphere, the fan's centre 64 times; four points on every
        // edge shared by two faces.
        let mut targets: Vec<Vec3> = if closed { v.clone() } else { vec![c; 64] };
        let mut edges = BTreeMap::new();
        for t in &f {
            for e in 0..3 {
                let (p, q) = (t[e], t[(e + 1) % 3]);
                *edges.entry((p.min(q), p.max(q))).or_insert(0) += 1;
            }
        }
        for (&(p, q), _) in edges.iter().filter(|(_, &n)| n == 2) {
            for _ in 0..4 {
                targets.push(v[p] + (v[q] - v[p]) * next());
            }
        }
        for target in targets {
            for _ in 0..4 {
                let o = if closed {
                    c + (Vec3::new(next(), next(), next()) - Vec3::splat(0.5)) * r
                } else {
                    let side = if next() < 0.5 { -1.0 } else { 1.0 };
                    c + Vec3::new(next() - 0.5, side * (0.5 + next()), next() - 0.5) * (2.0 * r)
                };
                ray(o, target, 0.5 + next(), object as u32);
            }
        }
    }
    let w = 128u32;
    let h = (origin.len() as u32).div_ceil(w);
    while origin.len() < (w * h) as usize {
        let k = origin.len() % aimed_at.len();
        let (o, d, a) = (origin[k], dir[k], aimed_at[k]);
        origin.push(o);
        dir.push(d);
        aimed_at.push(a);
    }
    let camera = wedge::scene::load(&wedge::scene::SceneSource::Builtin("grids".into())).unwrap().camera;
    let scene = Scene::from_triangles(
        "watertight probe",
        tris,
        vec![Material::diffuse("grey", Vec3::splat(0.5))],
        vec![],
        camera,
    )
    .unwrap();
    let inputs: BTreeMap<String, BufferData> =
        [("origin".to_string(), BufferData::Vec3(origin)), ("dir".to_string(), BufferData::Vec3(dir))]
            .into_iter()
            .collect();
    let n = (w * h) as usize;
    let lone = wedge::backends::lone::LonePass::new(Arc::new(TriangleProbe), BTreeMap::new(), &inputs).unwrap();
    let (cpu, _) = lone.run_cpu(&scene, w, h, 1).unwrap();
    // No leaks on the CPU: every ray hits (any-hit too) the mesh it was aimed at.
    let on_target = |out: &BTreeMap<String, BufferData>| {
        let (BufferData::U32(t), BufferData::U32(occ)) = (&out["triangle"], &out["occluded"]) else { panic!() };
        (0..n)
            .filter(|&i| t[i] != u32::MAX && scene.shading[t[i] as usize].object == aimed_at[i] && occ[i] == 1)
            .count()
    };
    assert_eq!(on_target(&cpu), n, "CPU: rays leaked between triangles");
    let mut backends = Vec::new();
    if let Some(gpu) = gpu_or_skip("watertight_triangle_wgsl_matches_cpu") {
        backends.push(gpu);
    }
    use wedge::backends::gpu::LimitsChoice;
    match GpuBackend::open_on(Some(wedge::backends::gpu::Backends::GL), LimitsChoice::Adapter) {
        Ok(g) => backends.push(g),
        Err(e) => eprintln!("watertight_triangle_wgsl_matches_cpu: GL SKIPPED — {e}"),
    }
    let BufferData::U32(ct) = &cpu["triangle"] else { panic!() };
    for mut gpu in backends {
        let out = gpu.run_kernel(Arc::new(TriangleProbe), &scene, w, h, 1, BTreeMap::new(), &inputs).unwrap();
        let BufferData::U32(gt) = &out["triangle"] else { panic!() };
        let same_hit = (0..n).filter(|&i| gt[i] == ct[i]).count();
        let bits = (0..n)
            .filter(|&i| {
                gt[i] == ct[i]
                    && ["distance", "b1", "b2", "occluded"]
                        .iter()
                        .all(|name| cpu[*name].component(i, 0).to_bits() == out[*name].component(i, 0).to_bits())
            })
            .count();
        let hits = on_target(&out);
        println!(
            "{}: {n} rays at shared vertices and edges, {hits} hit their mesh, {same_hit} the CPU's triangle, {bits} bit for bit (t, b1, b2, any-hit)",
            gpu.adapter_description()
        );
        if gpu.is_software() {
            assert_eq!((hits, same_hit, bits), (n, n, n), "{}", gpu.adapter_description());
        } else {
            assert!(same_hit * 1000 >= n * 999, "{same_hit} of {n}");
        }
    }
}

/// A test-only kernel tracing one screen-space ray per pixel (the rays are inputs: origin and
/// direction) with both marches of `shaders/screen_trace.wgsl`, the hierarchical `screen_trace` and
/// the linear `screen_trace_linear`, writing (kind, t, x, y) of each; on the CPU the same with
/// `ScreenTracer::trace` and `::trace_linear` (`backends/src/kernels/screen_trace.rs`).
struct ScreenProbe;

const SCREEN_PROBE_WGSL: &str = r#"
#include "screen_trace.wgsl"
fn screen_probe_out(h: ScreenHit) -> vec4<f32> {
    return vec4<f32>(f32(h.kind), h.t, f32(h.x), f32(h.y));
}
@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) { return; }
    let i = pixel_index(gid);
    let o = origin_at(i).xyz;
    let d = dir_at(i).xyz;
    fast_put(i, screen_probe_out(screen_trace(o, d)));
    linear_put(i, screen_probe_out(screen_trace_linear(o, d)));
}
"#;

const SCREEN_PROBE_THICKNESS: f32 = 0.05;

fn screen_probe_max_steps(width: u32, height: u32) -> u32 {
    (width as f32).hypot(height as f32).ceil() as u32 + 1
}

fn screen_probe_row(h: wedge::backends::kernels::screen_trace::ScreenHit) -> [f32; 4] {
    use wedge::backends::kernels::screen_trace::ScreenHit;
    match h {
        ScreenHit::Miss => [0.0; 4],
        ScreenHit::Hit { t, x, y } => [1.0, t, x as f32, y as f32],
        ScreenHit::Offscreen => [2.0, 0.0, 0.0, 0.0],
    }
}

impl Kernel for ScreenProbe {
    fn name(&self) -> &'static str {
        "test.screen_probe"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Compose
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("origin", Format::Vec4),
            Binding::read("dir", Format::Vec4),
            Binding::write("fast", Format::Vec4),
            Binding::write("linear", Format::Vec4),
        ]
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        use wedge::backends::kernels::screen_trace::ScreenTracer;
        let layer = ctx.scene.real.as_ref().expect("a real layer");
        let t = ScreenTracer::new(
            layer,
            &ctx.scene.camera,
            SCREEN_PROBE_THICKNESS,
            screen_probe_max_steps(ctx.width, ctx.height),
        );
        let (origin, dir) = (ctx.read::<[f32; 4]>("origin")?, ctx.read::<[f32; 4]>("dir")?);
        let v3 = |a: [f32; 4]| wedge::scene::Vec3::new(a[0], a[1], a[2]);
        let fast = origin.iter().zip(dir).map(|(&o, &d)| screen_probe_row(t.trace(v3(o), v3(d)))).collect();
        let linear = origin.iter().zip(dir).map(|(&o, &d)| screen_probe_row(t.trace_linear(v3(o), v3(d)))).collect();
        ctx.put("fast", fast)?;
        ctx.put("linear", linear)
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(SCREEN_PROBE_WGSL, |ctx| {
                let u = Uniforms::new()
                    .f32("thickness", SCREEN_PROBE_THICKNESS)
                    .u32("max_steps", screen_probe_max_steps(ctx.width, ctx.height));
                Ok(wedge::backends::kernels::paths::camera_uniforms(
                    u,
                    &ctx.scene.camera,
                    wedge::scene::LensShape::Disk,
                ))
            })
            .with_include("screen_trace.wgsl", include_str!("../shaders/screen_trace.wgsl"))
            .with_scene()
            .per_pixel(),
        )
    }
}

/// The WGSL screen-space marches (`shaders/screen_trace.wgsl`) on the real layer of
/// `pipelines/mixed_reality.ron` (its depth pyramid uploaded with the layer): on the GPU the
/// hierarchical march gives exactly the linear one's answers (kind, t bit for bit, pixel), and both
/// agree with the CPU's on all but rays whose answer turns on float rounding (≤ 1%, counted).
/// Rays: from the real surfaces (offset along the normal as mr.sample does) and from anywhere in a
/// box around the view, in directions over the whole sphere.
#[test]
fn screen_trace_wgsl_hierarchical_equals_linear() {
    let Some(mut gpu) = gpu_or_skip("screen_trace_wgsl_hierarchical_equals_linear") else { return };
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines/mixed_reality.ron");
    let (w, h) = (96u32, 72u32);
    let spp = vec![("mr".to_string(), "capture_spp".to_string(), wedge::graph::ParamValue::Int(1))];
    let session = Session::open(Some(&path), &Overrides { params: spp, ..small(w, h) }).expect("mixed-reality session");
    let layer = session.scene.real.as_ref().expect("a real layer").clone();
    let cam = session.scene.camera;
    let (_, _, forward) = cam.basis();
    let (mut same_gpu, mut same_cpu, mut total, mut hits) = (0usize, 0usize, 0usize, 0usize);
    let mut differ_gpu = Vec::new();
    for batch in 0..3u32 {
        let mut k = 0u32;
        let mut next = || {
            k += 1;
            rng::to_unit(rng::hash4(batch, k, 0x5c7e, 11))
        };
        let (mut origin, mut dir) = (Vec::new(), Vec::new());
        for i in 0..w * h {
            let o = if i % 2 == 0 {
                let (x, y) = (((next() * w as f32) as u32).min(w - 1), ((next() * h as f32) as u32).min(h - 1));
                match layer.position(x, y) {
                    Some(p) => p + layer.normal(x, y) * 1e-3,
                    None => cam.position + forward * (0.5 + 20.0 * next()),
                }
            } else {
                cam.position + wedge::scene::Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 24.0 + forward * 8.0
            };
            let z = 2.0 * next() - 1.0;
            let phi = std::f32::consts::TAU * next();
            let r = (1.0 - z * z).max(0.0).sqrt();
            origin.push([o.x, o.y, o.z, 0.0]);
            dir.push([r * phi.cos(), r * phi.sin(), z, 0.0]);
        }
        let inputs: BTreeMap<String, BufferData> =
            [("origin".to_string(), BufferData::Vec4(origin)), ("dir".to_string(), BufferData::Vec4(dir))]
                .into_iter()
                .collect();
        let g = gpu
            .run_kernel(Arc::new(ScreenProbe), &session.scene, w, h, 1, BTreeMap::new(), &inputs)
            .expect("GPU probe");
        let c = wedge::backends::lone::LonePass::new(Arc::new(ScreenProbe), BTreeMap::new(), &inputs)
            .and_then(|p| p.run_cpu(&session.scene, w, h, 1))
            .expect("CPU probe")
            .0;
        let rows = |m: &BTreeMap<String, BufferData>, name: &str| match &m[name] {
            BufferData::Vec4(v) => v.clone(),
            _ => panic!("format"),
        };
        let (gf, gl, cf, cl) = (rows(&g, "fast"), rows(&g, "linear"), rows(&c, "fast"), rows(&c, "linear"));
        let bits = |a: [f32; 4]| a.map(f32::to_bits);
        for i in 0..gf.len() {
            total += 1;
            hits += (cl[i][0] == 1.0) as usize;
            assert_eq!(
                bits(cf[i]),
                bits(cl[i]),
                "CPU: hierarchical and linear differ (the unit tests should have caught it)"
            );
            if bits(gf[i]) == bits(gl[i]) {
                same_gpu += 1;
            } else if differ_gpu.len() < 10 {
                differ_gpu.push(format!(
                    "batch {batch} ray {i}: hierarchical {:?}, linear {:?}, CPU {:?}",
                    gf[i], gl[i], cl[i]
                ));
            }
            same_cpu += (bits(gl[i]) == bits(cl[i])) as usize;
        }
    }
    println!(
        "{total} rays ({hits} CPU hits): GPU hierarchical == GPU linear on {same_gpu}, GPU linear == CPU on {same_cpu} ({})",
        gpu.adapter_description()
    );
    assert_eq!(same_gpu, total, "the GPU's hierarchical march differs from its linear one:\n{}", differ_gpu.join("\n"));
    assert!(hits > total / 20, "too few hits to mean much");
    assert!(total - same_cpu <= total / 100, "{} of {total} rays differ between GPU and CPU", total - same_cpu);
}

/// Motion's filters at multi-velocity pixels (`filter.radiance3`), off by default since the motion
/// suite, still agree pass by pass where a pipeline asks for them.
#[test]
fn parity_of_the_multi_velocity_filters() {
    let Some(mut gpu) = gpu_or_skip("parity_of_the_multi_velocity_filters") else { return };
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines/motion_shadows_indirect.ron");
    for filter in ["velocity", "tent"] {
        let set = ("motion".to_string(), "multi_filter".to_string(), ParamValue::Str(filter.into()));
        let ov = Overrides { params: vec![set], ..small(64, 48) };
        let session = Session::open(Some(&path), &ov).unwrap();
        assert!(session.schedule.passes.iter().any(|p| p.kernel == "filter.radiance3"), "{filter}");
        let report = run_parity(&job(&session), &mut gpu).expect("parity runs");
        assert!(report.ok(), "multi_filter {filter}:\n{}", report.table());
    }
}
