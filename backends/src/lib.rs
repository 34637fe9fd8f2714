//! # wedge-backends
//!
//! Where passes run. A [`Backend`] executes a [`wedge_graph::Schedule`] against a scene: each pass is
//! an instance of a registered [`Kernel`] with its bindings and parameter block. This crate holds
//! - the [`Kernel`] trait and [`KernelRegistry`] (open: user crates register their own),
//! - the counter-based sampler ([`rng`]) that both backends share bit for bit,
//! - the shared kernels every effect reuses ([`kernels`]): primary visibility, light sampling,
//!   neighbourhood fill, the separable world-space Gaussian filter, compose,
//! - the CPU backend ([`cpu::CpuBackend`], rayon), which pools buffers by lifetime,
//! - the wgpu backend (`gpu::GpuBackend`, WGSL compute; cargo feature `gpu`, on by default) and the
//!   pass-by-pass parity harness (`parity`) that checks it against the CPU backend.

// `!(x > 0.0)` is how the kernels reject NaN along with the values they exclude (a NaN compares
// false); clippy's `partial_cmp` rewrite would hide that.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod bindings;
pub mod buffer;
pub mod cpu;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod kernel;
pub mod kernels;
pub mod lone;
pub mod params;
#[cfg(feature = "gpu")]
pub mod parity;
pub mod partial;
pub mod rng;
pub mod sobol;
pub mod tiles;

use std::collections::BTreeMap;

pub use bindings::{Output, PutWith};
pub use buffer::{BufferData, Texel};
// For `record!` expansions in other crates.
pub use kernel::{
    Access, Binding, Counters, Kernel, KernelClass, KernelCtx, KernelRegistry, Progress, RayCounts, Reach, Silent,
    UniformType, Uniforms, WgslSource, Window,
};
pub use params::{AnyLight, KernelParams, LightIndex, ParamField, ParamSpec, ParamType, Sampling};
pub use partial::PartialRun;
#[doc(hidden)]
pub use wedge_graph as __graph;
use wedge_graph::{BufferId, ParamValue, Schedule};
use wedge_scene::Scene;

#[derive(Debug, thiserror::Error)]
pub enum BackendError {
    #[error("pass `{pass}`: {message}")]
    Kernel { pass: String, message: String },
    #[error("pass `{pass}` runs kernel `{kernel}`, which is not registered; registered kernels: {known}")]
    UnknownKernel { pass: String, kernel: String, known: String },
    #[error("pass `{pass}`: binding `{binding}` {message}")]
    Binding { pass: String, binding: String, message: String },
    /// A pass lacks a parameter its kernel declares ([`Kernel::params`]) or carries another type.
    #[error("pass `{pass}`: parameter `{param}`: {message}")]
    Param { pass: String, param: String, message: String },
    /// Passes that do not match their kernels' declared signatures, all of them.
    #[error("{} signature problem(s): passes do not match their kernel's bindings and parameters:\n  - {}\nfix the node's `expand` (binding names, read/write, formats, forwarded parameters) or the kernel's `bindings()` / `params()`", problems.len(), problems.join("\n  - "))]
    Signatures { problems: Vec<String> },
    #[error("{0}")]
    Other(String),
    /// The wgpu backend failed: no adapter, shader validation, device lost, out of memory, a limit.
    #[error("wgpu backend: {0}")]
    Gpu(String),
    /// A kernel's WGSL does not compile (found without a device: `gpu::validate`).
    #[error("{0}")]
    Wgsl(String),
}

/// What a run needs besides the schedule.
pub struct Job<'a> {
    pub schedule: &'a Schedule,
    pub scene: &'a Scene,
    pub kernels: &'a KernelRegistry,
    pub width: u32,
    pub height: u32,
    pub seed: u32,
    /// Frames run before this one in its sequence (0 for a single image and for the first frame of
    /// `render --frames` or `render --progressive`): the previous-frame buffers hold frame − 1's
    /// results when it is > 0. Kernels read it as `KernelCtx::frame` (CPU) and `frame.frame_index`
    /// (WGSL), e.g. a progressive filter that runs on a schedule of frames (PixelFilter, thesis
    /// seed 002 Sec. 3.3.3: frames 4, 8, 16, …).
    pub frame: u32,
    pub progress: &'a dyn Progress,
    /// Where `width × height` lies in the full image: [`Window::whole`] for a whole image, a tile's
    /// rectangle and apron for `--tile` (see [`crate::tiles`]).
    pub window: Window,
}

/// Time spent in one pass, and what it counted (rays traced, non-finite samples excluded), so a
/// NaN or infinity can be traced to the pass that met it.
#[derive(Clone, Debug)]
pub struct PassTiming {
    pub pass: String,
    pub kernel: String,
    pub class: KernelClass,
    pub seconds: f64,
    pub counts: RayCounts,
}

/// A sink node of a run: its kind and its (validated) parameters, which say how its inputs are to be
/// written (a `Heatmap`'s scale and unit).
#[derive(Clone, Debug, PartialEq)]
pub struct SinkNode {
    pub kind: String,
    pub params: BTreeMap<String, ParamValue>,
}

/// What a run hands back: the buffers bound to sink inputs, per-pass times and counters.
#[derive(Debug)]
pub struct RunResult {
    /// `(sink node, input port)` → contents.
    pub outputs: BTreeMap<(String, String), BufferData>,
    /// Sink node name → its kind and parameters. A backend runs a schedule, which has no node
    /// parameters, and leaves this empty; `wedge::Session::run`, which holds the pipeline, fills it.
    pub sinks: BTreeMap<String, SinkNode>,
    pub timings: Vec<PassTiming>,
    pub rays: RayCounts,
    /// Physical buffers allocated (after pooling by lifetime).
    pub allocations: usize,
    /// For each previous-frame buffer of the schedule, its source's contents at the end of this run:
    /// what the next frame's [`Backend::run_frame`] takes as `history`.
    pub history: BTreeMap<BufferId, BufferData>,
}

impl RunResult {
    /// Output bound to input `port` of the (first) sink, whatever the sink node is called.
    pub fn output(&self, port: &str) -> Option<&BufferData> {
        self.outputs.iter().find(|((_, p), _)| p == port).map(|(_, b)| b)
    }
    pub fn seconds(&self, class: KernelClass) -> f64 {
        // fold from +0.0: an empty f64 `sum()` is -0.0, which prints as "-0.0 ms".
        self.timings.iter().filter(|t| t.class == class).fold(0.0, |a, t| a + t.seconds)
    }
    pub fn total_seconds(&self) -> f64 {
        self.timings.iter().fold(0.0, |a, t| a + t.seconds)
    }
}

pub trait Backend {
    fn name(&self) -> &'static str;
    /// Run one frame of a sequence: `history` fills the schedule's previous-frame buffers
    /// ([`wedge_graph::Schedule::history`], keyed by those buffers; a missing one is all zeros, as in
    /// a first frame), and the result hands back each one's source for the next frame
    /// ([`RunResult::history`]).
    fn run_frame(&mut self, job: &Job<'_>, history: &BTreeMap<BufferId, BufferData>)
        -> Result<RunResult, BackendError>;
    /// Run one image (a first frame: every previous-frame buffer is zeros).
    fn run(&mut self, job: &Job<'_>) -> Result<RunResult, BackendError> {
        self.run_frame(job, &BTreeMap::new())
    }
}

/// The contents of a schedule's previous-frame buffer `h` for a run: given in `history`, else zeros.
pub fn history_input(job: &Job<'_>, history: &BTreeMap<BufferId, BufferData>, h: &wedge_graph::History) -> BufferData {
    let info = &job.schedule.buffers[h.buffer.0];
    let elements = job.width as usize * job.height as usize * info.layers as usize;
    match history.get(&h.buffer) {
        Some(d) if d.len() == elements && d.format() == info.format => d.clone(),
        _ => BufferData::zeroed(info.format, elements),
    }
}

/// wedge's own shared kernels.
pub fn register_shared_kernels(reg: &mut KernelRegistry) {
    kernels::register(reg);
}
