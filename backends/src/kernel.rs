//! Kernels: the unit of work a pass runs. A kernel declares its bindings (name, format, read or
//! write) and implements the per-pixel work on the CPU; the GPU backend adds a WGSL source for the
//! same name. The set is open: a user crate registers its own kernels next to wedge's.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use rayon::prelude::*;
use wedge_graph::{Format, ParamValue, Pass, Schedule};
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
    /// Whether the kernel draws random numbers. Such a kernel keys them by its pass's `stream`
    /// parameter, which the graph assigns to passes declared `.random()`; the signature check refuses
    /// a pass of this kernel that is not so declared (at `wedge graph` time, not when it runs).
    /// The parameters the kernel reads from its pass, by name and type — `P::specs()` of its
    /// [`crate::kernel_params!`] block. The schedule check refuses a pass that lacks one or carries
    /// another type (at `wedge graph` / session build, every problem at once). Default: none
    /// declared, nothing checked (a kernel still reading `ctx.f32_param("…")` by hand).
    fn params(&self) -> Vec<crate::params::ParamSpec> {
        Vec::new()
    }
    fn draws_random(&self) -> bool {
        false
    }
    /// Run over every pixel. Reads come from `ctx.read`, writes are handed back with `ctx.put`.
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError>;
    /// The WGSL implementation for the wgpu backend; `None` = CPU only (the wgpu backend then
    /// refuses the pass with a clear error), unless the kernel is a [`Kernel::host`] kernel.
    fn wgsl(&self) -> Option<WgslSource> {
        None
    }
    /// A host kernel runs its CPU implementation on every backend: structure builds over a pass's
    /// data (a tree over a node's stored samples), which GPU renderers build on the host as wedge
    /// builds the scene's BVH. The wgpu backend reads the pass's inputs back, runs [`Kernel::run_cpu`]
    /// and uploads its outputs; its time counts as the pass's. Parity is exact by construction, so
    /// what a host kernel builds must be what the GPU kernels downstream read.
    fn host(&self) -> bool {
        false
    }
    /// How far from its own pixel a pass of this kernel reads (see [`Reach`]). By default the reach
    /// its WGSL declares ([`WgslSource::reach`]), so a kernel says it once for both backends; a
    /// kernel without WGSL reads anywhere unless it overrides this.
    fn reach(&self, ctx: &KernelCtx<'_>) -> Result<Reach, BackendError> {
        match self.wgsl() {
            Some(src) => (src.reach)(ctx),
            None => Ok(Reach::Image),
        }
    }
}

/// The [`Kernel`] methods nearly every kernel writes alike — `name`, `class`, `bindings` from its
/// [`crate::kernel_bindings!`] block, `params` from its [`crate::kernel_params!`] blocks and, for a
/// sampler, `draws_random` — from one declaration inside the `impl` (`wgsl`, `run_cpu` and any
/// other method stay written by hand, and a kernel may still write all of them: `dyn Kernel` is
/// unchanged):
///
/// ```ignore
/// impl Kernel for Fog {
///     wedge::backends::kernel_signature!(name: "fog.apply", class: Compose, bindings: FogIo, params: [FogParams]);
///     fn wgsl(&self) -> Option<WgslSource> { .. }
///     fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> { .. }
/// }
/// ```
///
/// `class` is a [`KernelClass`] variant; `params: [A, B]` concatenates `A::specs()` and `B::specs()`
/// (a [`crate::KernelParams`] block's, or a type's own; leave it out for a kernel without parameters); `random: true` declares a kernel that draws random numbers.
#[macro_export]
macro_rules! kernel_signature {
    (
        name: $name:expr, class: $class:ident, bindings: $io:ty
        $(, params: [$($p:ty),* $(,)?])? $(, random: $random:expr)? $(,)?
    ) => {
        fn name(&self) -> &'static str {
            $name
        }
        fn class(&self) -> $crate::KernelClass {
            $crate::KernelClass::$class
        }
        fn bindings(&self) -> ::std::vec::Vec<$crate::Binding> {
            <$io>::bindings()
        }
        $(fn params(&self) -> ::std::vec::Vec<$crate::ParamSpec> {
            // A block's `KernelParams::specs`, or a type's own `specs()` (e.g. a shared settings struct).
            #[allow(unused_imports)]
            use $crate::KernelParams as _;
            [$(<$p>::specs()),*].concat()
        })?
        $(fn draws_random(&self) -> bool {
            $random
        })?
    };
}

/// A kernel's WGSL implementation (see `shaders/common.wgsl` for the binding convention; the
/// backend generates the kernel's bindings — `NAME_at`/`NAME_put`/`NAME_bound` per
/// `Kernel::bindings()` entry — and its `Params` struct, so the WGSL declares neither):
/// - `source`: the kernel's WGSL with an entry point `main`, `@workgroup_size(8, 8)`, one invocation
///   per pixel. Lines `#include "NAME.wgsl"` are replaced by that file — one of wedge's shared files
///   in `shaders/` (`common`, `rng`, `sampling`, `scene`, `bvh`, `camera`, `sobol`) or one of `includes` — each file at
///   most once (later includes of the same name are dropped), so shared code is never copied.
/// - `uniforms`: the pass's parameter block as named, typed fields ([`Uniforms`]) — the same
///   parameter parsing the CPU path uses (`KernelCtx::f32_param` …); it sees size, seed, scene and
///   params, not buffers. The backend generates `struct Params` and `params` (group 0, binding 1)
///   from it, so the kernel's WGSL only reads `params.NAME`.
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
    /// With `chunked`: the most samples per pixel one dispatch may take, below the backend's own
    /// bound (a kernel whose every sample runs long inner loops, e.g. a tree walk per ray).
    pub max_chunk: u32,
}

/// How far from its own pixel a kernel reads per-pixel buffers (see [`WgslSource::reach`]): ONE
/// declaration per kernel that both backends use — the wgpu backend to split an image into bands
/// of rows (`gpu/bands.rs`), and tiles (`--tile`, [`crate::tiles`]) on either backend to size the
/// apron a tile computes around its rectangle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reach {
    /// Only its own pixel: any band of rows works.
    Pixel,
    /// Pixels up to `n` rows above or below its own and up to `n` columns left or right of it: a
    /// square window of radius `n` (neighbourhood filters, the vertical pass of a separable filter).
    Rows(u32),
    /// Pixels up to `n` columns left or right of its own, in its own row only (the horizontal pass
    /// of a separable filter): any band of rows works, a tile needs `n` columns of apron.
    Cols(u32),
    /// Anywhere in the image (reductions, gathers): never split, never tiled.
    Image,
}

impl Reach {
    /// Rows above or below a pixel that it reads (`None`: anywhere).
    pub fn rows(self) -> Option<u32> {
        match self {
            Reach::Pixel | Reach::Cols(_) => Some(0),
            Reach::Rows(n) => Some(n),
            Reach::Image => None,
        }
    }
    /// Distance in pixels, along either axis, of the farthest pixel it reads (`None`: anywhere).
    pub fn radius(self) -> Option<u32> {
        match self {
            Reach::Pixel => Some(0),
            Reach::Rows(n) | Reach::Cols(n) => Some(n),
            Reach::Image => None,
        }
    }
}

/// The rectangle of the full image a job computes: its buffers are the rectangle's size
/// (`KernelCtx::width × height`), at `(x0, y0)` in an image of `full_width × full_height`. Camera
/// rays and random numbers use the full image's coordinates ([`KernelCtx::global_xy`],
/// [`KernelCtx::pixel_id`]), so a rectangle computes exactly what the whole image computes there.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Window {
    pub x0: u32,
    pub y0: u32,
    pub full_width: u32,
    pub full_height: u32,
}

impl Window {
    /// The whole `width × height` image (what every job without `--tile` computes).
    pub fn whole(width: u32, height: u32) -> Window {
        Window { x0: 0, y0: 0, full_width: width, full_height: height }
    }
    /// The full image's size: what camera rays and pixel footprints are computed for.
    pub fn full_size(&self) -> (u32, u32) {
        (self.full_width, self.full_height)
    }
    /// Pixel `(x, y)` of the window in the full image's coordinates.
    pub fn global_xy(&self, x: u32, y: u32) -> (u32, u32) {
        (x + self.x0, y + self.y0)
    }
    /// The full image's index of the window's pixel `(x, y)`: what random numbers are keyed by
    /// ([`crate::rng::PixelRng::new`]), so a tile draws the numbers the whole image draws there.
    pub fn pixel_id(&self, x: u32, y: u32) -> u32 {
        let (gx, gy) = self.global_xy(x, y);
        gy * self.full_width + gx
    }
}

impl WgslSource {
    pub fn new(
        source: impl Into<std::borrow::Cow<'static, str>>,
        uniforms: fn(&KernelCtx<'_>) -> Result<Uniforms, BackendError>,
    ) -> Self {
        WgslSource {
            source: source.into(),
            includes: Vec::new(),
            uniforms,
            scene: false,
            reach: |_| Ok(Reach::Image),
            chunked: false,
            max_chunk: u32::MAX,
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
    /// [`WgslSource::chunked`] with at most `n` samples per pixel per dispatch: drivers that cap a
    /// loop's iterations (lavapipe) count an inner loop's iterations over the whole invocation, so
    /// a kernel that walks a tree per sample keeps its chunks short.
    pub fn chunked_by(mut self, n: u32) -> Self {
        self.chunked = true;
        self.max_chunk = n.max(1);
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

/// Type of one field of a kernel's `Params` uniform block.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum UniformType {
    F32,
    U32,
    I32,
    Vec2,
    Vec3,
    Vec4,
}

impl UniformType {
    pub fn wgsl(self) -> &'static str {
        match self {
            UniformType::F32 => "f32",
            UniformType::U32 => "u32",
            UniformType::I32 => "i32",
            UniformType::Vec2 => "vec2<f32>",
            UniformType::Vec3 => "vec3<f32>",
            UniformType::Vec4 => "vec4<f32>",
        }
    }
    /// Alignment in 4-byte words under WGSL's uniform layout rules.
    fn align_words(self) -> usize {
        match self {
            UniformType::Vec2 => 2,
            UniformType::Vec3 | UniformType::Vec4 => 4,
            _ => 1,
        }
    }
}

/// A kernel's `Params` uniform block as named, typed fields: ONE declaration that yields both the
/// WGSL struct ([`Uniforms::wgsl_struct`], which the backend prepends to the kernel's WGSL, so
/// kernels never declare `Params` themselves) and its bytes laid out by WGSL's rules
/// ([`Uniforms::words`]: a `vec3` takes 16-byte alignment and the scalar after it fills its fourth
/// word). The fields must not depend on the pass's parameters (only their values may); the
/// backend checks that every pass of a kernel yields the same field list.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Uniforms {
    fields: Vec<(&'static str, UniformType, Vec<u32>)>,
}

impl Uniforms {
    pub fn new() -> Self {
        Uniforms::default()
    }
    fn field(mut self, name: &'static str, ty: UniformType, words: Vec<u32>) -> Self {
        self.fields.push((name, ty, words));
        self
    }
    pub fn f32(self, name: &'static str, v: f32) -> Self {
        self.field(name, UniformType::F32, vec![v.to_bits()])
    }
    pub fn u32(self, name: &'static str, v: u32) -> Self {
        self.field(name, UniformType::U32, vec![v])
    }
    pub fn i32(self, name: &'static str, v: i32) -> Self {
        self.field(name, UniformType::I32, vec![v as u32])
    }
    /// A flag, as `u32` 0 or 1 (WGSL uniforms cannot hold `bool`).
    pub fn bool(self, name: &'static str, v: bool) -> Self {
        self.u32(name, v as u32)
    }
    pub fn vec2(self, name: &'static str, v: [f32; 2]) -> Self {
        self.field(name, UniformType::Vec2, v.iter().map(|x| x.to_bits()).collect())
    }
    pub fn vec3(self, name: &'static str, v: [f32; 3]) -> Self {
        self.field(name, UniformType::Vec3, v.iter().map(|x| x.to_bits()).collect())
    }
    pub fn vec4(self, name: &'static str, v: [f32; 4]) -> Self {
        self.field(name, UniformType::Vec4, v.iter().map(|x| x.to_bits()).collect())
    }
    /// Field names and types, in declaration order.
    pub fn layout(&self) -> Vec<(&'static str, UniformType)> {
        self.fields.iter().map(|(n, t, _)| (*n, *t)).collect()
    }
    /// The block's 4-byte words as WGSL lays out [`Uniforms::wgsl_struct`] (padding as zeros),
    /// padded to a multiple of 16 bytes (at least 16).
    pub fn words(&self) -> Vec<u32> {
        let mut out = Vec::new();
        for (_, ty, words) in &self.fields {
            while !out.len().is_multiple_of(ty.align_words()) {
                out.push(0);
            }
            out.extend_from_slice(words);
        }
        while out.is_empty() || !out.len().is_multiple_of(4) {
            out.push(0);
        }
        out
    }
    /// `struct Params { … }` and its `var<uniform>` (group 0, binding 1). A block without fields
    /// gets one unused word (WGSL structs cannot be empty). Names must be WGSL identifiers.
    pub fn wgsl_struct(&self) -> Result<String, String> {
        let mut s = String::from("struct Params {\n");
        for (name, ty, _) in &self.fields {
            let valid = name.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
                && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
            if !valid {
                return Err(format!(
                    "uniform field `{name}` is not a WGSL identifier (a letter, then letters, digits or `_`)"
                ));
            }
            s.push_str(&format!("    {name}: {},\n", ty.wgsl()));
        }
        if self.fields.is_empty() {
            s.push_str("    _unused: u32,\n");
        }
        s.push_str("}\n@group(0) @binding(1) var<uniform> params: Params;\n");
        Ok(s)
    }
}

#[cfg(test)]
mod uniform_tests {
    use super::*;

    #[test]
    fn words_follow_wgsl_layout_and_struct_matches() {
        let u = Uniforms::new()
            .f32("a", 1.0)
            .vec3("c", [2.0, 3.0, 4.0])
            .u32("n", 7)
            .vec2("uv", [5.0, 6.0])
            .bool("on", true);
        let w = u.words();
        // a @0, pad to 4, c @4..7, n @7 (fills the vec3's fourth word), uv @8..10, on @10, pad to 12.
        assert_eq!(
            w,
            vec![
                1f32.to_bits(),
                0,
                0,
                0,
                2f32.to_bits(),
                3f32.to_bits(),
                4f32.to_bits(),
                7,
                5f32.to_bits(),
                6f32.to_bits(),
                1,
                0
            ]
        );
        let s = u.wgsl_struct().unwrap();
        assert!(s.contains("a: f32,\n    c: vec3<f32>,\n    n: u32,\n    uv: vec2<f32>,\n    on: u32,"), "{s}");
        assert_eq!(Uniforms::new().words(), vec![0; 4]);
        assert!(Uniforms::new().wgsl_struct().unwrap().contains("_unused: u32"));
        assert!(Uniforms::new().f32("bad name", 0.0).wgsl_struct().unwrap_err().contains("bad name"));
    }
}

/// Kernels by name.
#[derive(Clone, Default)]
pub struct KernelRegistry {
    kernels: BTreeMap<&'static str, Arc<dyn Kernel>>,
}

impl KernelRegistry {
    /// Check a pass against its kernel's signature (its first problem; see [`Self::pass_problems`]).
    pub fn check_pass(&self, schedule: &Schedule, pass: &Pass) -> Result<(), BackendError> {
        self.pass_problems(schedule, pass).into_iter().next().map_or(Ok(()), Err)
    }

    /// Everything wrong with a pass against its kernel's signature: the kernel is not registered, a
    /// bound buffer is not declared by the kernel with that access, or has another format, or a
    /// required binding is not bound.
    pub fn pass_problems(&self, schedule: &Schedule, pass: &Pass) -> Vec<BackendError> {
        let Some(kernel) = self.get(&pass.kernel) else {
            return vec![BackendError::UnknownKernel {
                pass: pass.name.clone(),
                kernel: pass.kernel.clone(),
                known: self.names().collect::<Vec<_>>().join(", "),
            }];
        };
        let decls = kernel.bindings();
        let berr = |binding: &str, message: String| BackendError::Binding {
            pass: pass.name.clone(),
            binding: binding.to_string(),
            message,
        };
        let mut problems = Vec::new();
        if kernel.draws_random() && !pass.random {
            problems.push(berr(
                "stream",
                format!(
                    "kernel `{}` draws random numbers: declare the pass `.random()` so the graph assigns its stream",
                    pass.kernel
                ),
            ));
        }
        for (list, access) in [(&pass.reads, Access::Read), (&pass.writes, Access::Write)] {
            for (name, id) in list {
                match decls.iter().find(|d| d.name == name && d.access == access) {
                    None => problems
                        .push(berr(name, format!("is not declared by kernel `{}` as a {access:?}", pass.kernel))),
                    Some(d) => {
                        let f = schedule.buffers[id.0].format;
                        if f != d.format {
                            // Struct formats are compared by name and fields; say which field differs.
                            let why = match (f.layout(), d.format.layout()) {
                                (Some(a), Some(b)) => a.difference(b).map(|w| format!(" ({w})")).unwrap_or_default(),
                                _ => String::new(),
                            };
                            problems.push(berr(
                                name,
                                format!("is bound to a {f} buffer but the kernel declares {}{why}", d.format),
                            ));
                        }
                    }
                }
            }
        }
        for spec in kernel.params() {
            let problem = match pass.params.get(spec.name) {
                None if spec.optional => continue,
                None => {
                    "the pass does not carry it: forward it from the node (`.node_params(..)`) or set it (`.param(..)`)"
                        .to_string()
                }
                Some(v) if !spec.ty.accepts(v) => format!("the pass carries {v}"),
                Some(_) => continue,
            };
            problems.push(BackendError::Param {
                pass: pass.name.clone(),
                param: spec.name.to_string(),
                message: format!("kernel `{}` reads it as {}; {problem}", pass.kernel, spec.ty.describe()),
            });
        }
        for d in decls.iter().filter(|d| !d.optional) {
            let bound = match d.access {
                Access::Read => pass.read(d.name).is_some(),
                Access::Write => pass.write(d.name).is_some(),
            };
            if !bound {
                problems.push(berr(d.name, format!("is required by kernel `{}` but not bound", pass.kernel)));
            }
        }
        problems
    }

    /// Check every pass of a schedule against its kernel's signature before anything runs, so a
    /// node that binds a kernel wrongly (a user's node, say) fails at `wedge graph` / session time
    /// with every problem listed, not at the first pass that reaches the backend.
    pub fn check_schedule(&self, schedule: &Schedule) -> Result<(), BackendError> {
        let problems: Vec<String> =
            schedule.passes.iter().flat_map(|p| self.pass_problems(schedule, p)).map(|e| e.to_string()).collect();
        if problems.is_empty() {
            Ok(())
        } else {
            Err(BackendError::Signatures { problems })
        }
    }
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

/// Progress of long passes (rows done) and of compiling GPU kernels (kernels done), shown by the
/// CLI as a progress bar.
pub trait Progress: Send + Sync {
    fn begin(&self, _pass: &str, _rows: u64) {}
    fn advance(&self, _rows: u64) {}
    fn end(&self) {}
    /// The GPU backend is about to compile `kernels` pipelines, before a run's first pass
    /// (`software`: on a CPU emulation such as lavapipe, where a cold shader cache takes minutes);
    /// then [`Progress::compiling`] and `advance(1)` per kernel, and [`Progress::end`].
    fn begin_compile(&self, _kernels: u64, _software: bool) {}
    /// The kernel now being compiled.
    fn compiling(&self, _kernel: &str) {}
    /// Pass `pass` of the job's schedule has run (every pass, in schedule order, on every backend):
    /// what a task's progress lines count (`wedge::progress::TaskProgress`).
    fn pass_done(&self, _pass: &str) {}
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
    /// The job's frame index in its sequence ([`crate::Job::frame`]; 0 for a single image).
    pub frame: u32,
    pub scene: &'a Scene,
    pub pass: &'a str,
    pub params: &'a BTreeMap<String, ParamValue>,
    pub counters: &'a Counters,
    pub progress: &'a dyn Progress,
    pub(crate) reads: BTreeMap<String, &'a BufferData>,
    pub(crate) writes: BTreeMap<String, Option<BufferData>>,
    /// Elements per pixel of each bound binding that is not an image ([`wedge_graph::BufferInfo::layers`]);
    /// absent = 1.
    pub(crate) layers: BTreeMap<String, u32>,
    /// Where this job's `width × height` lies in the full image ([`Window`]).
    pub window: Window,
    /// Storage of a persistent pool the pass may write its outputs into ([`Recycled`]).
    pub(crate) recycled: Recycled,
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
        let window = Window::whole(width, height);
        KernelCtx {
            width,
            height,
            seed,
            frame: 0,
            scene,
            pass,
            params,
            counters,
            progress,
            reads,
            writes,
            layers: BTreeMap::new(),
            window,
            recycled: Recycled::default(),
        }
    }

    /// The same context with the pass's bindings' elements per pixel (from the schedule's buffers);
    /// every backend sets it, so `put` checks lengths and kernels read [`KernelCtx::layers`].
    pub fn with_layers(mut self, pass: &Pass, buffers: &[wedge_graph::BufferInfo]) -> Self {
        for (name, id) in pass.reads.iter().chain(&pass.writes) {
            if let Some(b) = buffers.get(id.0).filter(|b| b.layers != 1) {
                self.layers.insert(name.clone(), b.layers);
            }
        }
        self
    }

    /// Elements per pixel of a bound binding (1 for an image): a per-sample buffer holds pixel `p`'s
    /// records at `p·layers .. (p + 1)·layers`.
    pub fn layers(&self, binding: &str) -> u32 {
        self.layers.get(binding).copied().unwrap_or(1)
    }

    /// The same context at frame `frame` of a sequence ([`crate::Job::frame`]).
    pub fn with_frame(mut self, frame: u32) -> Self {
        self.frame = frame;
        self
    }

    /// The same context computing `window` of the full image ([`Window`]; its size is the context's).
    pub fn with_window(mut self, window: Window) -> Self {
        self.window = window;
        self
    }

    /// The context of `pass` in `job` — size, seed, frame, window, scene, parameters, progress and
    /// its bindings' elements per pixel — with `reads` and `writes` bound (empty where nothing runs:
    /// a pass's uniforms, its reach). The one place every backend and every look at a pass build it.
    pub fn for_pass(
        job: &crate::Job<'a>,
        pass: &'a Pass,
        counters: &'a Counters,
        reads: BTreeMap<String, &'a BufferData>,
        writes: BTreeMap<String, Option<BufferData>>,
    ) -> Self {
        KernelCtx::new(
            job.width,
            job.height,
            job.seed,
            job.scene,
            &pass.name,
            &pass.params,
            counters,
            job.progress,
            reads,
            writes,
        )
        .with_frame(job.frame)
        .with_window(job.window)
        .with_layers(pass, &job.schedule.buffers)
    }

    pub fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// The full image's size ([`Window::full_size`]): what camera rays and pixel footprints use.
    pub fn full_size(&self) -> (u32, u32) {
        self.window.full_size()
    }

    /// An error of this pass (`BackendError::Kernel` naming it), for a kernel's own checks.
    pub fn err(&self, message: String) -> BackendError {
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
        let expected = self.pixels() * self.layers(binding) as usize;
        if data.len() != expected {
            return Err(self.err(format!("wrote {} elements to `{binding}`, expected {expected}", data.len())));
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
    /// Three numbers ([`wedge_graph::ParamDecl::colour`] / `vec3`), as f32 — for `Uniforms::vec3`
    /// and the CPU kernel alike.
    pub fn vec3_param(&self, name: &str) -> Result<[f32; 3], BackendError> {
        match self.params.get(name) {
            Some(ParamValue::Vec3(v)) => Ok(v.map(|x| x as f32)),
            other => Err(self.err(format!("parameter `{name}` must be three numbers, found {other:?}"))),
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
    pub fn bool_param(&self, name: &str) -> Result<bool, BackendError> {
        match self.params.get(name) {
            Some(ParamValue::Bool(v)) => Ok(*v),
            other => Err(self.err(format!("parameter `{name}` must be true or false, found {other:?}"))),
        }
    }
    pub fn light_param(&self, name: &str) -> Result<usize, BackendError> {
        self.check_light(name, self.int_param(name)?)
    }
    /// Light index `i` (parameter `name`) checked against the scene: a scene with no area light,
    /// or fewer than `i + 1`, is refused with the fix.
    pub fn check_light(&self, name: &str, i: i64) -> Result<usize, BackendError> {
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

    /// Evaluate `f(x, y)` for every pixel in parallel. The result depends only on `f`, never on
    /// the thread count. Progress is reported per row when `report` is set.
    ///
    /// One indexed parallel iterator over the pixels in row order: rayon collects it straight into
    /// the output, splitting the range as its threads need — no vector per row, and no copy when
    /// rows are joined (which a filter pass of a few taps per pixel paid as much as for its taps).
    pub fn map_pixels<T: Send>(&self, report: bool, f: impl Fn(u32, u32) -> T + Sync) -> Vec<T> {
        let w = self.width as usize;
        if report {
            self.progress.begin(self.pass, self.height as u64);
        }
        let out: Vec<T> = (0..w * self.height as usize)
            .into_par_iter()
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let value = f(x as u32, y as u32);
                if report && x + 1 == w {
                    self.progress.advance(1);
                }
                value
            })
            .collect();
        if report {
            self.progress.end();
        }
        out
    }
}

/// Storage a backend's persistent pool offers a pass for its outputs (issue 38 §2): per write binding,
/// what its pool slot held before — a buffer whose lifetime ended earlier in the frame, or the slot's
/// buffer of the previous frame. Same format and length while the schedule's slot plan is unchanged.
#[derive(Default)]
pub struct Recycled {
    spare: BTreeMap<String, BufferData>,
    /// Write bindings whose output went into spare storage: no fresh allocation.
    reused: std::collections::BTreeSet<String>,
}

/// Writing outputs in place into recycled storage, beside [`KernelCtx::put`] with a fresh `Vec`.
impl<'a> KernelCtx<'a> {
    /// The same context offering `spare` (write binding → storage) for its outputs.
    pub fn with_recycled(mut self, spare: BTreeMap<String, BufferData>) -> Self {
        self.recycled.spare = spare;
        self
    }

    /// Storage for write binding `binding` (its full length), to fill in place and hand back with
    /// [`KernelCtx::put`]: the recycled buffer when one of type `T` and the right length was offered
    /// (its contents are stale — the kernel writes every element), else a fresh zeroed one.
    pub fn output_vec<T: Texel>(&mut self, binding: &str) -> Result<Vec<T>, BackendError> {
        if !self.writes.contains_key(binding) {
            return Err(self.err(format!("writes `{binding}`, which is not bound")));
        }
        let len = self.pixels() * self.layers(binding) as usize;
        if let Some(Ok(v)) = self.recycled.spare.remove(binding).map(T::unwrap) {
            if v.len() == len {
                // A record type's `unwrap` keeps the words' allocation too (`buffer::recast`).
                self.recycled.reused.insert(binding.to_string());
                return Ok(v);
            }
        }
        Ok(T::zeroed(len))
    }

    /// [`KernelCtx::output_vec`] for an optional write: `None` when the pass left it unbound.
    pub fn output_vec_opt<T: Texel>(&mut self, binding: &str) -> Result<Option<Vec<T>>, BackendError> {
        if self.writes.contains_key(binding) {
            self.output_vec(binding).map(Some)
        } else {
            Ok(None)
        }
    }

    /// Whether the output of `binding` was written into recycled storage (not freshly allocated).
    pub fn reused(&self, binding: &str) -> bool {
        self.recycled.reused.contains(binding)
    }
}

/// The rows (`row` elements each) of an optional output to zip beside a required one's
/// `par_chunks_mut(row)`: `Some(row)` where the output is bound, `None` for each of `rows` where not.
pub fn optional_rows<T: Send>(
    out: Option<&mut Vec<T>>,
    row: usize,
    rows: usize,
) -> impl IndexedParallelIterator<Item = Option<&mut [T]>> {
    match out {
        Some(o) => rayon::iter::Either::Left(o.par_chunks_mut(row.max(1)).map(Some)),
        None => rayon::iter::Either::Right((0..rows).into_par_iter().map(|_| None)),
    }
}
