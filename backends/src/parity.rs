//! Pass-by-pass parity between the CPU and wgpu backends.
//!
//! The CPU backend runs the whole schedule, keeping every buffer (no pooling). For each pass the
//! wgpu backend then runs that pass **alone on the CPU's inputs** ([`GpuBackend::run_pass`]), so a
//! difference is always that pass's own, never inherited. Every output buffer is compared per
//! element and per pixel; [`Tolerance`] says what counts as agreeing:
//!
//! - **Bandwidth / filter / compose passes** (no rays): must agree to float round-off on every pixel:
//!   `|gpu − cpu| ≤ 1e-5·|cpu| + 1e-6`. The kernels mirror the Rust expression order, but WGSL does
//!   not require correctly rounded `exp`, `sqrt` or division (Vulkan allows several ulp) and may
//!   contract `a*b+c` into an fma; 1e-5 relative is ~80 ulp of headroom for sums of a few hundred
//!   such terms, and the absolute 1e-6 covers values that cancel to ~0.
//! - **Sampling passes** (rays): the same tolerance per pixel, with two allowances, counted and
//!   printed apart. (1) Up to 0.1% of pixels may differ by any amount (`over`): a ray that grazes a
//!   triangle edge or a BVH box may hit on one backend and miss on the other after a one-ulp
//!   difference, changing that pixel's estimate by a whole sample. (2) Up to 2% of pixels may differ
//!   by more than round-off but less than 1% relative (`perturbed`): a secondary ray at a grazing
//!   angle to a large plane moves its hit point by far more than the ulp that started it, so its
//!   depth, and the texel and Phong lobe it lands on, shift slightly (measured on the built-in `chess`
//!   board at 160×120: 0.23% of `indirect.sample` depth pixels at ≤ 1.3e-3 relative, 0.46% of glossy
//!   pixels at ≤ 6.2e-3; with the checker texture removed the radiance rows agree). `paths.trace`
//!   computes its primary hit on each backend (a kernel fed the CPU's G-buffer starts its secondary
//!   rays from the same bits), so its ulp differences start one vertex earlier: 0.99% of glossy pixels
//!   at ≤ 4.3e-3 on `shadows_indirect.ron` at 160×120, 1.2% at 96×72, and the Defocus pipeline 1.24%
//!   at 96×72 before Ch. 4 moved onto the sampler (docs/DESIGN-NOTES.md "Parity tolerances"); 2% is
//!   that with headroom. A wrong kernel changes most pixels or changes them by more than 1%, which
//!   neither allowance admits.
//! - **Integer outputs** (rays per pixel): exact, except a difference of one where `ceil` of a float
//!   input sits on a rounding boundary; those are counted as `boundary` and allowed up to 0.1% of
//!   pixels in every class (a rate computed from the same inputs may round differently after a few ulp).
//!
//! Every allowance is rounded up (`ceil`), so a small image still allows one pixel rather than none.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::fmt::Write as _;

use wedge_graph::BufferId;

use crate::buffer::BufferData;
use crate::cpu::run_pass;
use crate::gpu::GpuBackend;
use crate::kernel::{Counters, KernelClass};
use crate::{BackendError, Job};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tolerance {
    pub rel: f32,
    pub abs: f32,
    /// Share of pixels allowed over tolerance by any amount.
    pub max_share: f64,
    /// Relative difference below which a pixel over tolerance counts as `perturbed`, not `over`.
    pub perturbed_rel: f32,
    /// Share of pixels allowed to be perturbed (over tolerance, within `perturbed_rel`).
    pub perturbed_share: f64,
}

/// Share of integer pixels allowed off by exactly one (rounding boundary), in every class.
pub const BOUNDARY_SHARE: f64 = 1e-3;

impl Tolerance {
    pub fn for_class(class: KernelClass) -> Tolerance {
        match class {
            KernelClass::Sampling => {
                Tolerance { rel: 1e-5, abs: 1e-6, max_share: 1e-3, perturbed_rel: 1e-2, perturbed_share: 2e-2 }
            }
            _ => Tolerance { rel: 1e-5, abs: 1e-6, max_share: 0.0, perturbed_rel: 0.0, perturbed_share: 0.0 },
        }
    }
    /// The same per-pixel test with the relative bound raised to `perturbed_rel`.
    fn loose(self) -> Tolerance {
        Tolerance { rel: self.rel.max(self.perturbed_rel), ..self }
    }
}

/// Pixels allowed for a share of an image: rounded up, so a share above zero allows at least one.
pub fn allowed_pixels(share: f64, pixels: usize) -> usize {
    (share * pixels as f64).ceil() as usize
}

/// Comparison of one output buffer of one pass.
#[derive(Clone, Debug)]
pub struct BufferParity {
    pub pass: String,
    pub kernel: String,
    pub binding: String,
    pub class: KernelClass,
    pub pixels: usize,
    pub max_abs: f64,
    pub max_rel: f64,
    /// Pixels with a component over tolerance (floats; beyond `perturbed_rel` where the class has
    /// a perturbed allowance) or off by more than one (integers).
    pub over: usize,
    /// Float pixels over tolerance but within `perturbed_rel` (sampling passes; see the module doc).
    pub perturbed: usize,
    /// Integer pixels off by exactly one (rounding boundary).
    pub boundary: usize,
    pub tolerance: Tolerance,
    /// Device time of the pass (timestamp queries where supported, else wall clock).
    pub gpu_seconds: f64,
    pub ok: bool,
}

#[derive(Clone, Debug, Default)]
pub struct ParityReport {
    pub rows: Vec<BufferParity>,
    pub adapter: String,
    /// Passes in which the GPU driver stopped shader loops early ([`crate::RayCounts::cut_loops`]).
    pub cut_loops: Vec<(String, u64)>,
}

impl ParityReport {
    pub fn ok(&self) -> bool {
        self.rows.iter().all(|r| r.ok)
    }
    /// The table `wedge parity` prints.
    pub fn table(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "adapter: {}", self.adapter);
        let _ = writeln!(
            s,
            "{:<30} {:<18} {:<15} {:>10} {:>10} {:>7} {:>9} {:>6} {:>13} {:>9}  result",
            "pass", "kernel", "output", "max abs", "max rel", "over", "perturbed", "bound", "allowed", "gpu ms"
        );
        for r in &self.rows {
            let allowed = format!(
                "{}/{}",
                allowed_pixels(r.tolerance.max_share, r.pixels),
                allowed_pixels(r.tolerance.perturbed_share, r.pixels)
            );
            let _ = writeln!(
                s,
                "{:<30} {:<18} {:<15} {:>10.3e} {:>10.3e} {:>7} {:>9} {:>6} {:>13} {:>9.3}  {}",
                r.pass,
                r.kernel,
                r.binding,
                r.max_abs,
                r.max_rel,
                r.over,
                r.perturbed,
                r.boundary,
                allowed,
                r.gpu_seconds * 1e3,
                if r.ok { "ok" } else { "MISMATCH" }
            );
        }
        let t = Tolerance::for_class(KernelClass::Sampling);
        let _ = writeln!(
            s,
            "tolerance per pixel: |gpu-cpu| <= {:e}*|cpu| + {:e} on every component; sampling passes may exceed it on \
             <= {}% of pixels by any amount (over: rays that graze an edge) and on <= {}% by under {}% relative (perturbed: \
             grazing secondary rays); allowed = over/perturbed pixels; integers exact except off-by-one at rounding \
             boundaries (<= 0.1%)",
            t.rel,
            t.abs,
            t.max_share * 100.0,
            t.perturbed_share * 100.0,
            t.perturbed_rel * 100.0
        );
        for (pass, n) in &self.cut_loops {
            let _ = writeln!(
                s,
                "note: in `{pass}` the driver stopped {n} shader loops before they finished (lavapipe ends a loop after \
                 65,535 iterations), so the GPU skipped work there; lighter settings (mu, bounces, max_rays) avoid it"
            );
        }
        let _ = writeln!(s, "{}", if self.ok() { "parity: ok" } else { "parity: MISMATCH" });
        s
    }
}

/// Compare one output buffer.
pub fn compare(cpu: &BufferData, gpu: &BufferData, tol: Tolerance) -> (f64, f64, usize, usize) {
    let n = cpu.len().min(gpu.len());
    let comps = cpu.format().components();
    let (mut max_abs, mut max_rel, mut over, mut boundary) = (0f64, 0f64, 0usize, 0usize);
    if cpu.len() != gpu.len() || cpu.format() != gpu.format() {
        return (f64::INFINITY, f64::INFINITY, cpu.len().max(gpu.len()), 0);
    }
    if let (BufferData::U32(a), BufferData::U32(b)) = (cpu, gpu) {
        for i in 0..n {
            let d = a[i].abs_diff(b[i]);
            max_abs = max_abs.max(d as f64);
            if a[i] > 0 {
                max_rel = max_rel.max(d as f64 / a[i] as f64);
            }
            match d {
                0 => {}
                1 => boundary += 1,
                _ => over += 1,
            }
        }
        return (max_abs, max_rel, over, boundary);
    }
    for i in 0..n {
        let mut bad = false;
        for c in 0..comps {
            let (x, y) = (cpu.component(i, c), gpu.component(i, c));
            if x.is_nan() && y.is_nan() || x == y {
                continue;
            }
            let d = (x as f64 - y as f64).abs();
            if d.is_nan() {
                bad = true;
                max_abs = f64::INFINITY;
                continue;
            }
            max_abs = max_abs.max(d);
            if x != 0.0 {
                max_rel = max_rel.max(d / (x as f64).abs());
            }
            if d > tol.rel as f64 * (x as f64).abs() + tol.abs as f64 {
                bad = true;
            }
        }
        over += bad as usize;
    }
    (max_abs, max_rel, over, boundary)
}

/// Run every pass of `job` on the CPU, then each pass alone on the GPU with the CPU's inputs, and
/// compare every output.
pub fn run_parity(job: &Job<'_>, gpu: &mut GpuBackend) -> Result<ParityReport, BackendError> {
    run_parity_with_history(job, gpu, &BTreeMap::new())
}

/// [`run_parity`] for a later frame of a sequence: the previous-frame buffers hold `history` (a
/// CPU run's [`crate::RunResult::history`]; missing ones are zeros) on both backends, and `job.frame`
/// says which frame it is (kernels on a schedule of frames, e.g. a progressive filter).
pub fn run_parity_with_history(
    job: &Job<'_>,
    gpu: &mut GpuBackend,
    history: &BTreeMap<BufferId, BufferData>,
) -> Result<ParityReport, BackendError> {
    let counters = Counters::default();
    let mut held: BTreeMap<BufferId, BufferData> = BTreeMap::new();
    // Previous-frame buffers (zeros in a first frame): both backends get the same inputs.
    for h in &job.schedule.history {
        held.insert(h.buffer, crate::history_input(job, history, h));
    }
    let mut report = ParityReport { adapter: gpu.adapter_description(), ..Default::default() };
    for pass in &job.schedule.passes {
        let kernel = job.kernels.get(&pass.kernel).ok_or_else(|| BackendError::UnknownKernel {
            pass: pass.name.clone(),
            kernel: pass.kernel.clone(),
            known: job.kernels.names().collect::<Vec<_>>().join(", "),
        })?;
        let class = kernel.class();
        let inputs: BTreeMap<BufferId, &BufferData> =
            pass.reads.iter().filter_map(|(_, id)| held.get(id).map(|b| (*id, b))).collect();
        let cpu_out = run_pass(job, pass, &inputs, &counters)?;
        let (gpu_out, time, gpu_rays) = gpu.run_pass(job, pass, &inputs)?;
        if gpu_rays.cut_loops > 0 {
            report.cut_loops.push((pass.name.clone(), gpu_rays.cut_loops));
        }
        let tol = Tolerance::for_class(class);
        for (binding, cpu_buf) in &cpu_out {
            let gpu_buf = gpu_out.get(binding).ok_or_else(|| BackendError::Binding {
                pass: pass.name.clone(),
                binding: binding.clone(),
                message: "the wgpu backend returned no data for it".into(),
            })?;
            // Struct buffers are compared field by field (one row each, `binding.field`), so float
            // fields get the float tolerance and counts the integer rule.
            let fields: Vec<(String, Cow<'_, BufferData>, Cow<'_, BufferData>)> = match cpu_buf.format().layout() {
                Some(layout) if cpu_buf.format() == gpu_buf.format() => layout
                    .fields
                    .iter()
                    .filter_map(|f| {
                        Some((
                            format!("{binding}.{}", f.name),
                            Cow::Owned(cpu_buf.field(f.name)?),
                            Cow::Owned(gpu_buf.field(f.name)?),
                        ))
                    })
                    .collect(),
                _ => vec![(binding.clone(), Cow::Borrowed(cpu_buf), Cow::Borrowed(gpu_buf))],
            };
            for (binding, cpu_buf, gpu_buf) in &fields {
                let (max_abs, max_rel, over_tight, boundary) = compare(cpu_buf, gpu_buf, tol);
                let pixels = cpu_buf.len();
                let is_int = matches!(**cpu_buf, BufferData::U32(_));
                // Pixels beyond the perturbed bound are `over`; the rest over tolerance are `perturbed`.
                let over = if is_int || tol.perturbed_share == 0.0 {
                    over_tight
                } else {
                    compare(cpu_buf, gpu_buf, tol.loose()).2
                };
                let perturbed = over_tight - over;
                let ok = if is_int {
                    over == 0 && boundary <= allowed_pixels(BOUNDARY_SHARE, pixels)
                } else {
                    over <= allowed_pixels(tol.max_share, pixels)
                        && perturbed <= allowed_pixels(tol.perturbed_share, pixels)
                };
                report.rows.push(BufferParity {
                    pass: pass.name.clone(),
                    kernel: pass.kernel.clone(),
                    binding: binding.clone(),
                    class,
                    pixels,
                    max_abs,
                    max_rel,
                    over,
                    perturbed,
                    boundary,
                    tolerance: tol,
                    gpu_seconds: time.seconds,
                    ok,
                });
            }
        }
        for (binding, data) in cpu_out {
            let id = pass.write(&binding).expect("bound");
            held.insert(id, data);
        }
    }
    Ok(report)
}
