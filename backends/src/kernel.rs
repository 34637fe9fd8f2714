//! Kernels: the unit of work a pass runs. A kernel declares its bindings (name, format, read or
//! write) and implements the per-pixel work on the CPU; the GPU backend adds a WGSL source for the
//! same name. The set is open: a user crate registers its own kernels next to wedge's.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use rayon::prelude::*;
use wedge_graph::{Format, ParamValue};
use wedge_scene::Scene;

use crate::buffer::{BufferData, Texel};
use crate::BackendError;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    Read,
    Write,
}

/// One buffer a kernel touches.
#[derive(Clone, Debug)]
pub struct Binding {
    pub name: &'static str,
    pub format: Format,
    pub access: Access,
    /// May be left unbound by a pass (the kernel then skips that work).
    pub optional: bool,
}

impl Binding {
    pub const fn read(name: &'static str, format: Format) -> Self {
        Binding { name, format, access: Access::Read, optional: false }
    }
    pub const fn read_opt(name: &'static str, format: Format) -> Self {
        Binding { name, format, access: Access::Read, optional: true }
    }
    pub const fn write(name: &'static str, format: Format) -> Self {
        Binding { name, format, access: Access::Write, optional: false }
    }
    pub const fn write_opt(name: &'static str, format: Format) -> Self {
        Binding { name, format, access: Access::Write, optional: true }
    }
}

/// Whether a kernel traces rays (its time counts as sampling) or only reads and writes buffers
/// (bandwidth, rates, filters, compose: the overhead the thesis keeps around 5%).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum KernelClass {
    Sampling,
    Bandwidth,
    Filter,
    Compose,
}

pub trait Kernel: Send + Sync {
    fn name(&self) -> &'static str;
    fn class(&self) -> KernelClass;
    fn bindings(&self) -> Vec<Binding>;
    /// Run over every pixel. Reads come from `ctx.read`, writes are handed back with `ctx.put`.
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError>;
    /// The WGSL implementation for the wgpu backend; `None` = CPU only (the wgpu backend then
    /// refuses the pass with a clear error).
    fn wgsl(&self) -> Option<WgslSource> {
        None
    }
}

/// A kernel's WGSL implementation (see `shaders/common.wgsl` for the binding convention):
/// - `source`: the kernel's WGSL with an entry point `main`, `@workgroup_size(8, 8)`, one invocation
///   per pixel. Lines `#include "NAME.wgsl"` are replaced by that file — one of wedge's shared files
///   in `shaders/` (`common`, `rng`, `sampling`, `scene`, `bvh`) or one of `includes` — each file at
///   most once (later includes of the same name are dropped), so shared code is never copied.
/// - `uniforms`: packs the pass's parameter block into the kernel's `Params` uniform (group 0,
///   binding 1) as 4-byte words in declaration order — the same parameter parsing the CPU path
///   uses (`KernelCtx::f32_param` …); it sees size, seed, scene and params, not buffers.
/// - `scene`: whether the kernel reads the scene (group 2: BVH, triangles, materials, lights).
/// - `reach`: how far from its own pixel the WGSL reads per-pixel buffers, given the pass's
///   parameters ([`Reach`]). The backend splits an image whose buffers exceed the device's binding
///   limit into bands of rows only for kernels that say how far they read; the default is
///   [`Reach::Image`] (never split), so a kernel that does not declare it fails clearly on such an
///   image instead of reading outside its band.
/// - `chunked`: the kernel's sample loop takes only the pass's sample indices
///   `[frame.chunk_begin, frame.chunk_end)` and, when `chunk_begin > 0`, continues from the partial
///   result in its own outputs (see `shaders/common.wgsl`). The backend then runs long sampling
///   passes as several dispatches ([`WgslSource::chunked`]).
#[derive(Clone)]
pub struct WgslSource {
    pub source: std::borrow::Cow<'static, str>,
    pub includes: Vec<(&'static str, std::borrow::Cow<'static, str>)>,
    pub uniforms: fn(&KernelCtx<'_>) -> Result<Uniforms, BackendError>,
    pub scene: bool,
    pub reach: fn(&KernelCtx<'_>) -> Result<Reach, BackendError>,
    pub chunked: bool,
}

/// How far from its own pixel a kernel reads per-pixel buffers (see [`WgslSource::reach`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reach {
    /// Only its own pixel: any band of rows works.
    Pixel,
    /// Pixels up to `n` rows above or below its own (neighbourhood filters, separable passes).
    Rows(u32),
    /// Anywhere in the image (reductions, gathers): never split.
    Image,
}

impl WgslSource {
    pub fn new(source: impl Into<std::borrow::Cow<'static, str>>, uniforms: fn(&KernelCtx<'_>) -> Result<Uniforms, BackendError>) -> Self {
        WgslSource {
            source: source.into(),
            includes: Vec::new(),
            uniforms,
            scene: false,
            reach: |_| Ok(Reach::Image),
            chunked: false,
        }
    }
    /// The kernel reads only its own pixel of every per-pixel buffer.
    pub fn per_pixel(mut self) -> Self {
        self.reach = |_| Ok(Reach::Pixel);
        self
    }
    /// The kernel's sample loop can be split over several dispatches (see the struct docs): the
    /// wgpu backend then bounds the samples per pixel of one dispatch, which keeps each shader
    /// invocation short (drivers that cap loop iterations, like lavapipe, or GPU watchdogs).
    pub fn chunked(mut self) -> Self {
        self.chunked = true;
        self
    }
    /// How far the kernel reads, from the pass's parameters (e.g. a filter's radius and axis).
    pub fn with_reach(mut self, reach: fn(&KernelCtx<'_>) -> Result<Reach, BackendError>) -> Self {
        self.reach = reach;
        self
    }
    /// Make `name` available to `#include` (e.g. an effect's formula file).
    pub fn with_include(mut self, name: &'static str, text: impl Into<std::borrow::Cow<'static, str>>) -> Self {
        self.includes.push((name, text.into()));
        self
    }
    /// The kernel reads the scene (group 2).
    pub fn with_scene(mut self) -> Self {
        self.scene = true;
        self
    }
}

/// The words of a kernel's `Params` uniform block, in WGSL declaration order. Only 4-byte scalars
/// and `vec4`s keep this layout trivial: a `vec3` must be followed by one scalar (use [`Uniforms::vec3`]
/// with a fourth value). The backend pads the block to 16 bytes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Uniforms(pub Vec<u32>);

impl Uniforms {
    pub fn new() -> Self {
        Uniforms(Vec::new())
    }
    pub fn f32(mut self, v: f32) -> Self {
        self.0.push(v.to_bits());
        self
    }
    pub fn u32(mut self, v: u32) -> Self {
        self.0.push(v);
        self
    }
    pub fn i32(mut self, v: i32) -> Self {
        self.0.push(v as u32);
        self
    }
    /// A `vec4<f32>` made of `xyz` and `w`.
    pub fn vec3(self, xyz: [f32; 3], w: f32) -> Self {
        self.f32(xyz[0]).f32(xyz[1]).f32(xyz[2]).f32(w)
    }
    /// Pad with zero words up to a multiple of four (a 16-byte boundary).
    pub fn align16(mut self) -> Self {
        while !self.0.len().is_multiple_of(4) {
            self.0.push(0);
        }
        self
    }
}

/// Kernels by name.
#[derive(Clone, Default)]
pub struct KernelRegistry {
    kernels: BTreeMap<&'static str, Arc<dyn Kernel>>,
}

impl KernelRegistry {
    pub fn new() -> Self {
        Self::default()
    }
    /// A later registration under the same name replaces the earlier one.
    pub fn register(&mut self, k: Arc<dyn Kernel>) -> &mut Self {
        self.kernels.insert(k.name(), k);
        self
    }
    pub fn get(&self, name: &str) -> Option<&Arc<dyn Kernel>> {
        self.kernels.get(name)
    }
    pub fn names(&self) -> impl Iterator<Item = &'static str> + '_ {
        self.kernels.keys().copied()
    }
}

/// Counters a run accumulates (integer sums, so they are identical for any thread count).
#[derive(Debug, Default)]
pub struct Counters {
    pub primary_rays: AtomicU64,
    pub shadow_rays: AtomicU64,
    pub secondary_rays: AtomicU64,
    /// Samples whose value was NaN or infinite: excluded from every estimate, never spread.
    pub non_finite_samples: AtomicU64,
}

impl Counters {
    pub fn add(counter: &AtomicU64, n: u64) {
        if n > 0 {
            counter.fetch_add(n, Ordering::Relaxed);
        }
    }
    pub fn snapshot(&self) -> RayCounts {
        RayCounts {
            primary_rays: self.primary_rays.load(Ordering::Relaxed),
            shadow_rays: self.shadow_rays.load(Ordering::Relaxed),
            secondary_rays: self.secondary_rays.load(Ordering::Relaxed),
            non_finite_samples: self.non_finite_samples.load(Ordering::Relaxed),
            cut_loops: 0,
        }
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounts {
    pub primary_rays: u64,
    pub shadow_rays: u64,
    pub secondary_rays: u64,
    pub non_finite_samples: u64,
    /// GPU only: shader loops the driver stopped before they finished (lavapipe ends a loop after
    /// 65,535 iterations): traversals that report a miss and sample loops that took fewer samples.
    /// Non-zero means the image lacks work; the CPU backend never cuts a loop.
    pub cut_loops: u64,
}

impl RayCounts {
    pub fn total_rays(&self) -> u64 {
        self.primary_rays + self.shadow_rays + self.secondary_rays
    }
    pub fn add(&mut self, other: &RayCounts) {
        self.primary_rays += other.primary_rays;
        self.shadow_rays += other.shadow_rays;
        self.secondary_rays += other.secondary_rays;
        self.non_finite_samples += other.non_finite_samples;
        self.cut_loops += other.cut_loops;
    }
}

/// Progress of long passes (rows done), shown by the CLI as a progress bar.
pub trait Progress: Send + Sync {
    fn begin(&self, _pass: &str, _rows: u64) {}
    fn advance(&self, _rows: u64) {}
    fn end(&self) {}
}

/// No progress display.
pub struct Silent;
impl Progress for Silent {}

/// Everything one pass sees while it runs: size, seed, scene, its parameter block, the buffers it
/// declared (reads borrowed, writes owned until handed back), counters and progress.
pub struct KernelCtx<'a> {
    pub width: u32,
    pub height: u32,
    pub seed: u32,
    pub scene: &'a Scene,
    pub pass: &'a str,
    pub params: &'a BTreeMap<String, ParamValue>,
    pub counters: &'a Counters,
    pub progress: &'a dyn Progress,
    pub(crate) reads: BTreeMap<String, &'a BufferData>,
    pub(crate) writes: BTreeMap<String, Option<BufferData>>,
}

impl<'a> KernelCtx<'a> {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        width: u32,
        height: u32,
        seed: u32,
        scene: &'a Scene,
        pass: &'a str,
        params: &'a BTreeMap<String, ParamValue>,
        counters: &'a Counters,
        progress: &'a dyn Progress,
        reads: BTreeMap<String, &'a BufferData>,
        writes: BTreeMap<String, Option<BufferData>>,
    ) -> Self {
        KernelCtx { width, height, seed, scene, pass, params, counters, progress, reads, writes }
    }

    pub fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }

    fn err(&self, message: String) -> BackendError {
        BackendError::Kernel { pass: self.pass.to_string(), message }
    }

    /// A bound input, viewed as `T`.
    pub fn read<T: Texel>(&self, binding: &str) -> Result<&'a [T], BackendError> {
        let b = self.reads.get(binding).ok_or_else(|| self.err(format!("reads `{binding}`, which is not bound")))?;
        T::slice(b).ok_or_else(|| self.err(format!("`{binding}` is {}, not {}", b.format(), T::FORMAT)))
    }
    /// An optional input: `None` when the pass left it unbound.
    pub fn read_opt<T: Texel>(&self, binding: &str) -> Result<Option<&'a [T]>, BackendError> {
        if self.reads.contains_key(binding) {
            self.read(binding).map(Some)
        } else {
            Ok(None)
        }
    }
    pub fn is_bound(&self, binding: &str) -> bool {
        self.reads.contains_key(binding) || self.writes.contains_key(binding)
    }
    /// Hand back the contents of a write binding. Writing one that the pass did not bind is an error
    /// (a pass can only touch what it declared); an unbound *optional* write is skipped silently by
    /// checking [`KernelCtx::is_bound`] first.
    pub fn put<T: Texel>(&mut self, binding: &str, data: Vec<T>) -> Result<(), BackendError> {
        if data.len() != self.pixels() {
            return Err(self.err(format!("wrote {} elements to `{binding}`, expected {}", data.len(), self.pixels())));
        }
        match self.writes.get_mut(binding) {
            Some(slot) => {
                *slot = Some(T::wrap(data));
                Ok(())
            }
            None => Err(self.err(format!("writes `{binding}`, which is not bound"))),
        }
    }
    pub fn put_opt<T: Texel>(&mut self, binding: &str, data: impl FnOnce() -> Vec<T>) -> Result<(), BackendError> {
        if self.writes.contains_key(binding) {
            self.put(binding, data())
        } else {
            Ok(())
        }
    }

    pub fn f32_param(&self, name: &str) -> Result<f32, BackendError> {
        match self.params.get(name) {
            Some(ParamValue::Float(v)) => Ok(*v as f32),
            Some(ParamValue::Int(v)) => Ok(*v as f32),
            other => Err(self.err(format!("parameter `{name}` must be a number, found {other:?}"))),
        }
    }
    pub fn int_param(&self, name: &str) -> Result<i64, BackendError> {
        match self.params.get(name) {
            Some(ParamValue::Int(v)) => Ok(*v),
            other => Err(self.err(format!("parameter `{name}` must be an integer, found {other:?}"))),
        }
    }
    pub fn str_param(&self, name: &str) -> Result<&'a str, BackendError> {
        match self.params.get(name) {
            Some(ParamValue::Str(v)) => Ok(v.as_str()),
            other => Err(self.err(format!("parameter `{name}` must be a string, found {other:?}"))),
        }
    }
    /// The `sampling` parameter every sampling kernel takes: `true` for `"stratified"` (correlated
    /// multi-jitter), `false` for `"independent"`.
    pub fn stratified_param(&self) -> Result<bool, BackendError> {
        match self.str_param("sampling")? {
            "stratified" => Ok(true),
            "independent" => Ok(false),
            other => Err(self.err(format!("unknown sampling `{other}`; use stratified or independent"))),
        }
    }
    pub fn bool_param(&self, name: &str) -> Result<bool, BackendError> {
        match self.params.get(name) {
            Some(ParamValue::Bool(v)) => Ok(*v),
            other => Err(self.err(format!("parameter `{name}` must be true or false, found {other:?}"))),
        }
    }
    pub fn light_param(&self, name: &str) -> Result<usize, BackendError> {
        let i = self.int_param(name)?;
        if self.scene.lights.is_empty() {
            return Err(self.err(format!(
                "`{name}` = {i} but scene `{}` has no area light (no emissive triangles) — add an emissive \
                 material (glTF emissiveFactor, MTL Ke, a `lights` entry in a .ron scene) or use a scene with \
                 a light, e.g. --scene grids",
                self.scene.name
            )));
        }
        if i < 0 || i as usize >= self.scene.lights.len() {
            return Err(self.err(format!(
                "`{name}` = {i} but the scene has {} area light(s); pick 0..{}",
                self.scene.lights.len(),
                self.scene.lights.len().saturating_sub(1)
            )));
        }
        Ok(i as usize)
    }

    /// Evaluate `f(x, y)` for every pixel in parallel (rows across threads). The result depends
    /// only on `f`, never on the thread count. Progress is reported per row when `report` is set.
    pub fn map_pixels<T: Send>(&self, report: bool, f: impl Fn(u32, u32) -> T + Sync) -> Vec<T> {
        let w = self.width;
        if report {
            self.progress.begin(self.pass, self.height as u64);
        }
        let rows: Vec<Vec<T>> = (0..self.height)
            .into_par_iter()
            .map(|y| {
                let row = (0..w).map(|x| f(x, y)).collect();
                if report {
                    self.progress.advance(1);
                }
                row
            })
            .collect();
        if report {
            self.progress.end();
        }
        rows.into_iter().flatten().collect()
    }
}
