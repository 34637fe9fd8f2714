//! The wgpu backend: every pass runs as a WGSL compute shader (one invocation per pixel, 8×8
//! workgroups) on whatever adapter wgpu finds — a GPU, or Mesa's software Vulkan (lavapipe).
//!
//! - **Device**: the adapter's own limits are requested (larger bindings than wgpu's defaults), or
//!   wgpu's `Limits::default()` ([`LimitsChoice::WebGpuDefault`], what any WebGPU device offers);
//!   any wgpu API may be used ([`GpuBackend::open_on`]; the GL backend runs headless through EGL).
//!   `TIMESTAMP_QUERY` is enabled where offered and then each pass is timed on the device (on
//!   lavapipe these are CPU-emulation times, not GPU times). One device per (APIs, limits) per
//!   process, shared with the kernels compiled on it by every backend opened so, but on GL ([`device`]).
//! - **Generated WGSL**: a kernel's bindings (group 1) and `Params` struct are generated from its
//!   Rust declaration ([`shaders::binding_header`], [`crate::kernel::Uniforms`]); the kernel only
//!   calls `NAME_at`/`NAME_put`/`NAME_bound` and reads `params.NAME`.
//! - **Binding plans**: per dispatch, one storage binding per declared buffer
//!   ([`shaders::BindingPlan::Direct`]) when `1 (counters) + scene + bindings` fits the device's
//!   `max_storage_buffers_per_shader_stage`; else [`shaders::BindingPlan::Packed`]: all inputs in
//!   one storage buffer, all outputs in another, filled and emptied with `copy_buffer_to_buffer`
//!   around each band's dispatch. Same bits either way ([`GpuBackend::force_packed`] for tests).
//! - **Buffers**: per-pixel buffers follow the schedule's pool plan: one `wgpu::Buffer` per
//!   physical slot (`Schedule::slot_formats`), created on first use, so a first run allocates
//!   exactly `slot_formats.len()` of them ([`RunResult::allocations`]); the backend keeps them, and
//!   the next whole run (a frame of `--frames`, a progressive round) writes into those of the same
//!   size, allocating none. Layout per format: f32, vec2, vec4 and u32 are WGSL arrays of that
//!   type; **vec3 buffers are packed `array<f32>` (3 floats per pixel)**, the same bytes as the
//!   CPU's `Vec<[f32; 3]>`, so upload/readback is a plain copy and no 16-byte padding is stored.
//! - **Bands**: a pass whose per-pixel bindings would exceed the device's storage-binding limit
//!   (e.g. `vec4` from 4096×2160 on, against 128 MiB; packed: the packed buffer's bytes per pixel)
//!   is dispatched as bands of rows, each binding only its rows plus the rows its kernel reads
//!   around them ([`bands`]); kernels see the band in `Frame` and
//!   index through `pixel_index`/`index_at` (shaders/common.wgsl), so the result is the same image.
//! - **Scene**: uploaded once per distinct scene as ONE storage buffer holding all its arrays plus a
//!   uniform of their offsets and the instance count ([`scene`]); kernels that declare `scene` see it
//!   in bind group 2.
//! - **Errors**: no adapter, WGSL/naga validation, out of memory, a device loss, a buffer over the
//!   device's `max_buffer_size`, a scene over the binding limit, a kernel over the storage buffers
//!   per stage even packed, a pass too large for the limit that cannot be split (a kernel reading
//!   the whole image, or a band too narrow for its reach), a kernel without WGSL — all become [`BackendError::Gpu`] with what to do; nothing panics
//!   (wgpu's default panicking error handler is replaced). Shader loops the driver cuts short are
//!   counted (`RayCounts::cut_loops`), not silent.
//! - **Chunks**: a sampling kernel that declares `WgslSource::chunked` runs as dispatches of at most
//!   `samples_per_dispatch` samples per pixel (16 on software adapters, whose loops stop after
//!   65,535 iterations; 64 on GPUs) until no pixel has samples left; the image does not depend on it.

pub mod bands;
mod device;
mod dispatch;
pub mod run;
pub mod scene;
pub mod shaders;
pub mod validate;

/// Which graphics APIs [`GpuBackend::open_on`] may use (wgpu's set: `Backends::GL`, `Backends::VULKAN`, …).
pub use wgpu::Backends;

pub use run::{kept_bytes, DeviceBuffer, KeptBuffers};

use std::collections::{BTreeMap, HashMap};
use std::hash::{Hash, Hasher};
use std::sync::{mpsc, Arc, Mutex};
use std::time::Instant;

use wedge_graph::{BufferId, Format, Pass};
use wgpu::util::DeviceExt;

use crate::buffer::BufferData;
use crate::cpu::check_bindings;
use crate::kernel::{Access, Binding, Counters, Kernel, KernelCtx, Progress, Reach};
use crate::{BackendError, Job, RayCounts};

/// What to tell a user when there is no adapter at all.
pub const INSTALL_HINT: &str = "no GPU adapter was found. Without a GPU, install Mesa's software Vulkan driver \
(lavapipe): `apt-get install mesa-vulkan-drivers libvulkan1` (Debian/Ubuntu; `dnf install mesa-vulkan-drivers` on \
Fedora), or run with `--backend cpu`";

const WORKGROUP: u32 = 8;
/// Bytes of one counter block: `array<atomic<u32>, 8>` in shaders/common.wgsl.
const COUNTER_BLOCK: u64 = 32;
/// Samples per pixel per dispatch of chunked sampling kernels on a CPU-emulated adapter: lavapipe
/// ends a shader loop after 65,535 iterations, and 16 samples (each a few rays of up to a few
/// hundred traversal steps) stay well under that.
const SOFTWARE_SAMPLES_PER_DISPATCH: u32 = 16;
/// ... and on a GPU: short enough that one dispatch stays far from OS watchdogs (about 2 s on
/// Windows) at large sizes, long enough that the per-dispatch sync costs nothing.
const GPU_SAMPLES_PER_DISPATCH: u32 = 64;

fn gpu_err(msg: impl Into<String>) -> BackendError {
    BackendError::Gpu(msg.into())
}

/// A compiled kernel: pipeline plus the layouts its bind groups are made against.
struct KernelPipeline {
    pipeline: wgpu::ComputePipeline,
    g0: wgpu::BindGroupLayout,
    g1: wgpu::BindGroupLayout,
    g2: Option<wgpu::BindGroupLayout>,
}

/// Entries of the GPU traversal's private stack for `scene`: its trees' need
/// ([`wedge_scene::Scene::traversal_stack_need`]) rounded up to a power of two, at least 16 and at
/// most the builder's bound [`wedge_scene::bvh::STACK_SIZE`]. The stack arrays are most of what
/// lavapipe's LLVM spends compiling the path tracer (issue 33: 128 entries where typical scenes need
/// 20–40); powers of two keep the number of shader variants, each compiled and cached once, small.
pub fn traversal_stack_entries(scene: &wedge_scene::Scene) -> u32 {
    let bound = wedge_scene::bvh::STACK_SIZE;
    scene.traversal_stack_need().next_power_of_two().clamp(16, bound) as u32
}

/// A kernel's shader text as this device builds it (generated header included), its binding plan,
/// and the key its compiled pipeline is cached under.
struct PipelineSource {
    key: u64,
    name: &'static str,
    text: String,
    src: crate::kernel::WgslSource,
    plan: shaders::BindingPlan,
    bindings: Vec<Binding>,
}

/// The scene as bound in group 2: every array in one storage buffer, their offsets in a uniform.
struct SceneBuffers {
    hash: u64,
    data: wgpu::Buffer,
    layout: wgpu::Buffer,
}

/// Which limits to ask the adapter for ([`GpuBackend::open`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LimitsChoice {
    /// Everything the adapter offers (the default: larger bindings, more storage buffers).
    Adapter,
    /// wgpu's `Limits::default()` (WebGPU's: 8 storage buffers per stage, 4 bind groups, 128 MiB
    /// bindings), to check that every kernel runs on any WebGPU device.
    WebGpuDefault,
}

/// Time of one dispatch: device timestamps where supported, else wall clock around submit + wait.
#[derive(Clone, Copy, Debug)]
pub struct DispatchTime {
    pub seconds: f64,
    pub from_timestamps: bool,
}

/// The size of the device buffer [`GpuBackend::storage`] makes for `bytes`: at least 16, a multiple of 4.
fn storage_size(bytes: u64) -> u64 {
    bytes.max(16).div_ceil(4) * 4
}

pub struct GpuBackend {
    /// The process's device for this backend's (APIs, limits) choice, its queue and limits, and the
    /// kernels compiled on it by any backend ([`device`]).
    shared: Arc<device::SharedDevice>,
    /// Largest per-pixel storage binding one dispatch may use: the device's, or less (`set_binding_limit`).
    max_binding: u64,
    timestamps: Option<(wgpu::QuerySet, wgpu::Buffer)>,
    /// Entries of the BVH traversal's private stack in the scene kernels being built
    /// ([`traversal_stack_entries`] of the job's scene; set before a run's pipelines are built).
    stack_entries: u32,
    scene: Option<SceneBuffers>,
    /// Stand-ins for unbound optional bindings, one per binding index (never shared within a dispatch).
    dummies: Vec<wgpu::Buffer>,
    /// Per-pass device times of the last run (seconds, from timestamp queries); empty when unsupported.
    pub last_device_times: Vec<(String, f64)>,
    /// Per-pass number of bands (dispatches) of the last run: 1 unless a binding was over the limit.
    pub last_bands: Vec<(String, usize)>,
    /// Most samples per pixel one dispatch of a chunked sampling kernel takes (`set_samples_per_dispatch`).
    samples_per_dispatch: u32,
    /// Bind every pass's per-pixel buffers packed, even where they fit one per binding (`force_packed`).
    force_packed: bool,
    /// `Params` fields per kernel name, as its first pass gave them.
    uniform_layouts: HashMap<String, Vec<(&'static str, crate::kernel::UniformType)>>,
    /// Per-pass binding plan of the last run.
    pub last_plans: Vec<(String, shaders::BindingPlan)>,
    /// The pool slots' device buffers a whole run left, by slot: the next whole run writes into
    /// those whose size still fits instead of allocating (issue 38 §2, see `run.rs`).
    pool: Vec<Option<wgpu::Buffer>>,
    /// Small per-dispatch buffers (uniforms, counter blocks, read-back staging up to [`SCRATCH_MAX`]
    /// bytes) by role, index and size, kept for the next dispatch or run that needs the same (issue 38 §2).
    scratch: Mutex<Scratch>,
}

/// Largest scratch buffer kept between dispatches: counters and timestamps, not image read-backs
/// (kept, those would hold host-visible memory the size of an output for the backend's life).
const SCRATCH_MAX: u64 = 64 * 1024;

/// Distinct (role, size) scratch buffers kept at most; past it the cache starts over (a viewer
/// resizing through many sizes must not pile them up).
const SCRATCH_KEPT: usize = 64;

/// [`GpuBackend`]'s kept scratch buffers and how many were ever created.
#[derive(Default)]
struct Scratch {
    buffers: HashMap<(&'static str, u64, u64), wgpu::Buffer>,
    created: usize,
}

impl GpuBackend {
    /// Open the default adapter (high performance preference; `WGPU_BACKEND` etc. are honoured)
    /// with the adapter's own limits, or with wgpu's `Limits::default()` when the environment says
    /// `WEDGE_WGPU_LIMITS=default` (so `wedge render`/`parity` can check WebGPU portability).
    pub fn new() -> Result<GpuBackend, BackendError> {
        let choice = match std::env::var("WEDGE_WGPU_LIMITS") {
            Err(_) => LimitsChoice::Adapter,
            Ok(v) => match v.as_str() {
                "" | "adapter" => LimitsChoice::Adapter,
                "default" => LimitsChoice::WebGpuDefault,
                other => {
                    return Err(gpu_err(format!(
                        "environment variable WEDGE_WGPU_LIMITS is `{other}`; use `adapter` (the adapter's own limits, the \
                         default) or `default` (wgpu's Limits::default(), WebGPU's)"
                    )))
                }
            },
        };
        Self::open(choice)
    }

    /// Open the default adapter with the limits `choice` names.
    pub fn open(choice: LimitsChoice) -> Result<GpuBackend, BackendError> {
        Self::open_on(None, choice)
    }

    /// Open an adapter of one of `backends` (e.g. `wgpu::Backends::GL`; `None`: those
    /// `WGPU_BACKEND` names, else all) with the limits `choice` names. Backends opened with the same
    /// `backends` and `choice` share one device and the kernels compiled on it (but on GL; [`device`]).
    pub fn open_on(backends: Option<wgpu::Backends>, choice: LimitsChoice) -> Result<GpuBackend, BackendError> {
        let shared = device::shared(backends, choice)?;
        let (device, features) = (&shared.device, shared.features);
        let samples_per_dispatch = if shared.info.device_type == wgpu::DeviceType::Cpu {
            SOFTWARE_SAMPLES_PER_DISPATCH
        } else {
            GPU_SAMPLES_PER_DISPATCH
        };
        let timestamps = features.contains(wgpu::Features::TIMESTAMP_QUERY).then(|| {
            let qs = device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("wedge timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: 2,
            });
            let resolve = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("wedge timestamp resolve"),
                size: 16,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            (qs, resolve)
        });
        Ok(GpuBackend {
            max_binding: shared.limits.max_storage_buffer_binding_size,
            shared,
            timestamps,
            stack_entries: wedge_scene::bvh::STACK_SIZE as u32,
            scene: None,
            dummies: Vec::new(),
            last_device_times: Vec::new(),
            last_bands: Vec::new(),
            samples_per_dispatch,
            force_packed: false,
            uniform_layouts: HashMap::new(),
            last_plans: Vec::new(),
            pool: Vec::new(),
            scratch: Mutex::default(),
        })
    }

    /// Scratch buffers (uniforms, counter blocks, small read-back staging) created so far: a kept backend's
    /// later dispatches of the same sizes create none (`tests/parity.rs` `gpu_pool_persists_across_runs`).
    pub fn scratch_buffers_created(&self) -> usize {
        self.scratch.lock().unwrap_or_else(|e| e.into_inner()).created
    }

    /// The `role` buffer number `index` of `size` bytes an earlier dispatch left, else `make()`'s,
    /// kept for the next one when at most [`SCRATCH_MAX`] bytes. Callers are done with it before the
    /// next request (a dispatch waits for its submission), so one buffer per key is enough.
    fn scratch(
        &self,
        (role, index): (&'static str, u64),
        size: u64,
        make: impl FnOnce() -> Result<wgpu::Buffer, BackendError>,
    ) -> Result<wgpu::Buffer, BackendError> {
        let mut kept = self.scratch.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(b) = kept.buffers.get(&(role, index, size)) {
            return Ok(b.clone());
        }
        let b = make()?;
        kept.created += 1;
        if size <= SCRATCH_MAX {
            if kept.buffers.len() >= SCRATCH_KEPT {
                kept.buffers.clear();
            }
            kept.buffers.insert((role, index, size), b.clone());
        }
        Ok(b)
    }

    /// Forget the `role` buffer of `size` bytes (after an error left it in an unknown state).
    fn drop_scratch(&self, role: &'static str, size: u64) {
        self.scratch.lock().unwrap_or_else(|e| e.into_inner()).buffers.remove(&(role, 0, size));
    }

    /// A uniform buffer holding `data`: the kept `role` buffer number `index` of its size with
    /// `data` written into it (ordered before the next submission), else a new one.
    fn uniform_buffer(&self, role: &'static str, index: u64, data: &[u32]) -> Result<wgpu::Buffer, BackendError> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        if bytes.is_empty() {
            // (What `create_buffer_init` makes of no contents; nothing to keep.)
            return self.scoped(role, || {
                self.shared.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(role),
                    contents: bytes,
                    usage: wgpu::BufferUsages::UNIFORM,
                })
            });
        }
        let buf = self.scratch((role, index), bytes.len() as u64, || {
            self.scoped(role, || {
                self.shared.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(role),
                    size: bytes.len() as u64,
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            })
        })?;
        self.shared.queue.write_buffer(&buf, 0, bytes);
        Ok(buf)
    }

    /// `name (backend, device type)` of the adapter in use.
    pub fn adapter_description(&self) -> String {
        format!("{} ({:?}, {:?})", self.shared.info.name, self.shared.info.backend, self.shared.info.device_type)
    }
    /// Whether the adapter is a CPU emulation (lavapipe/llvmpipe): its timings say nothing about GPUs.
    pub fn is_software(&self) -> bool {
        self.shared.info.device_type == wgpu::DeviceType::Cpu
    }
    pub fn has_timestamps(&self) -> bool {
        self.timestamps.is_some()
    }
    pub fn limits(&self) -> &wgpu::Limits {
        &self.shared.limits
    }
    /// Chunked sampling kernels take at most `n` samples per pixel per dispatch (`u32::MAX`: one
    /// dispatch per pass). Results agree with any `n` to float round-off of the running mean.
    pub fn set_samples_per_dispatch(&mut self, n: u32) {
        self.samples_per_dispatch = n.max(1);
    }
    /// Bind at most `bytes` of each per-pixel buffer per dispatch (never more than the device
    /// allows), so passes over it run as bands of rows. For tests and users checking the band path
    /// at small sizes; the scene is still bound whole under the device's own limit.
    pub fn set_binding_limit(&mut self, bytes: u64) {
        self.max_binding = bytes.min(self.shared.limits.max_storage_buffer_binding_size).max(16);
    }

    /// Bind every pass's per-pixel buffers packed (two storage buffers) even where one binding per
    /// buffer fits the device: for tests of the packed plan, which must give the same bits.
    pub fn force_packed(&mut self, on: bool) {
        self.force_packed = on;
    }

    /// The binding plan for a kernel: one storage binding per declared buffer when
    /// `1 (counters) + scene + bindings` fits `max_storage_buffers_per_shader_stage`, else packed.
    fn binding_plan(
        &self,
        name: &str,
        bindings: &[crate::kernel::Binding],
        scene: bool,
    ) -> Result<shaders::BindingPlan, BackendError> {
        use shaders::BindingPlan;
        let limit = self.shared.limits.max_storage_buffers_per_shader_stage;
        let fixed = 1 + scene as u32;
        let needed = |plan| fixed + shaders::storage_bindings(bindings, plan);
        if !self.force_packed && needed(BindingPlan::Direct) <= limit {
            return Ok(BindingPlan::Direct);
        }
        if needed(BindingPlan::Packed) <= limit {
            return Ok(BindingPlan::Packed);
        }
        Err(gpu_err(format!(
            "kernel `{name}` needs {} storage buffers in one shader stage even with its buffers packed, over this \
             device's max_storage_buffers_per_shader_stage ({limit}, adapter `{}`); use --backend cpu",
            needed(BindingPlan::Packed),
            self.shared.info.name
        )))
    }

    /// Errors wgpu reported asynchronously (uncaptured or device lost) since the last check.
    fn check_async_errors(&self, what: &str) -> Result<(), BackendError> {
        let mut v = self.shared.errors.lock().map_err(|_| gpu_err("error log poisoned"))?;
        if v.is_empty() {
            return Ok(());
        }
        let all = v.drain(..).collect::<Vec<_>>().join("; ");
        Err(gpu_err(format!("{what}: {all}")))
    }

    /// Run `f` inside validation + out-of-memory error scopes and turn what they catch into errors.
    fn scoped<T>(&self, what: &str, f: impl FnOnce() -> T) -> Result<T, BackendError> {
        let oom = self.shared.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let val = self.shared.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let out = f();
        let v = pollster::block_on(val.pop());
        let o = pollster::block_on(oom.pop());
        if let Some(e) = v {
            return Err(gpu_err(format!("{what}: validation error: {e}")));
        }
        if let Some(e) = o {
            return Err(gpu_err(format!(
                "{what}: out of GPU memory ({e}); try a smaller --width/--height or a smaller scene"
            )));
        }
        self.check_async_errors(what)?;
        Ok(out)
    }

    fn wait(&self, what: &str) -> Result<(), BackendError> {
        self.shared
            .device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| gpu_err(format!("{what}: waiting for the device failed: {e}")))?;
        self.check_async_errors(what)
    }

    /// Check one buffer's size against the device's limit. (What one dispatch binds is limited
    /// separately: per-pixel buffers by bands, the scene in `scene_buffers`.)
    fn check_buffer_size(&self, what: &str, bytes: u64) -> Result<(), BackendError> {
        if bytes > self.shared.limits.max_buffer_size {
            return Err(gpu_err(format!(
                "{what} needs {bytes} bytes, over this device's max_buffer_size ({} bytes, adapter `{}`); \
                 render smaller (--width/--height), use a smaller scene, or use --backend cpu",
                self.shared.limits.max_buffer_size, self.shared.info.name
            )));
        }
        Ok(())
    }

    fn storage(&self, label: &str, bytes: u64) -> Result<wgpu::Buffer, BackendError> {
        self.check_buffer_size(label, bytes)?;
        let size = storage_size(bytes);
        self.scoped(&format!("allocating `{label}`"), || {
            self.shared.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        })
    }

    fn storage_init(&self, label: &str, bytes: &[u8]) -> Result<wgpu::Buffer, BackendError> {
        self.check_buffer_size(label, bytes.len() as u64)?;
        let mut data = bytes.to_vec();
        while data.len() < 16 || !data.len().is_multiple_of(4) {
            data.push(0);
        }
        self.scoped(&format!("uploading `{label}`"), || {
            self.shared.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: &data,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            })
        })
    }

    /// Copy a buffer back to the host (through a kept staging buffer where small, [`GpuBackend::scratch`]).
    fn read_bytes(&self, what: &str, buf: &wgpu::Buffer, bytes: u64) -> Result<Vec<u8>, BackendError> {
        let size = bytes.div_ceil(4) * 4;
        let read = self.read_staged(what, buf, bytes, size);
        if read.is_err() {
            self.drop_scratch("wedge readback", size.max(4));
        }
        read
    }

    fn read_staged(&self, what: &str, buf: &wgpu::Buffer, bytes: u64, size: u64) -> Result<Vec<u8>, BackendError> {
        let staging = self.scratch(("wedge readback", 0), size.max(4), || {
            self.scoped(what, || {
                self.shared.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("wedge readback"),
                    size: size.max(4),
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            })
        })?;
        self.scoped(what, || {
            let mut enc =
                self.shared.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("readback") });
            enc.copy_buffer_to_buffer(buf, 0, &staging, 0, size);
            self.shared.queue.submit([enc.finish()]);
        })?;
        let slice = staging.slice(..size);
        let (tx, rx) = mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.wait(what)?;
        rx.recv()
            .map_err(|_| gpu_err(format!("{what}: the read-back never completed")))?
            .map_err(|e| gpu_err(format!("{what}: mapping the read-back buffer failed: {e}")))?;
        let data = {
            let view = slice.get_mapped_range().map_err(|e| gpu_err(format!("{what}: {e}")))?;
            view[..bytes as usize].to_vec()
        };
        staging.unmap();
        Ok(data)
    }

    fn read_buffer(
        &self,
        what: &str,
        buf: &wgpu::Buffer,
        format: Format,
        pixels: usize,
    ) -> Result<BufferData, BackendError> {
        let bytes = self.read_bytes(what, buf, (pixels * format.components() * 4) as u64)?;
        Ok(from_bytes(format, &bytes))
    }

    fn scene_buffers(&mut self, scene: &wedge_scene::Scene) -> Result<(), BackendError> {
        let arrays = scene::scene_bytes(scene);
        let mut h = std::collections::hash_map::DefaultHasher::new();
        arrays.hash(&mut h);
        // The layout's other words too: a 640x480 and a 480x640 real layer can hold the same bytes.
        scene::layout(&[0; scene::ARRAY_COUNT], scene).hash(&mut h);
        let hash = h.finish();
        if self.scene.as_ref().is_some_and(|s| s.hash == hash) {
            return Ok(());
        }
        let (bytes, offsets) = scene::pack(&arrays);
        // The scene is bound whole (a ray may touch any node or triangle).
        let max_binding = self.shared.limits.max_storage_buffer_binding_size;
        if bytes.len() as u64 > max_binding {
            let sizes: Vec<String> =
                scene::SCENE_ARRAYS.iter().zip(&arrays).map(|(n, a)| format!("{n} {}", a.len())).collect();
            return Err(gpu_err(format!(
                "scene `{}` needs {} bytes ({}), over this device's max_storage_buffer_binding_size ({} bytes, \
                 adapter `{}`); use a smaller scene or --backend cpu",
                scene.name,
                bytes.len(),
                sizes.join(", "),
                max_binding,
                self.shared.info.name
            )));
        }
        let data = self.storage_init(&format!("scene `{}`", scene.name), &bytes)?;
        let layout = self.scoped("uploading the scene layout", || {
            self.shared.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("scene layout"),
                contents: bytemuck::cast_slice(&scene::layout(&offsets, scene)),
                usage: wgpu::BufferUsages::UNIFORM,
            })
        })?;
        self.scene = Some(SceneBuffers { hash, data, layout });
        Ok(())
    }

    fn dummy(&mut self, index: usize) -> Result<wgpu::Buffer, BackendError> {
        while self.dummies.len() <= index {
            let b = self.storage("unbound optional binding", 16)?;
            self.dummies.push(b);
        }
        Ok(self.dummies[index].clone())
    }

    fn wgsl_of(kernel: &dyn Kernel) -> Result<crate::kernel::WgslSource, BackendError> {
        kernel.wgsl().ok_or_else(|| {
            gpu_err(format!(
                "kernel `{}` has no WGSL implementation (Kernel::wgsl returns None); run this pipeline with --backend cpu, or give the kernel a WGSL source",
                kernel.name()
            ))
        })
    }

    /// The pass's `Params` block ([`crate::kernel::Uniforms`]), from the same `KernelCtx` accessors
    /// its CPU path uses.
    pub(crate) fn uniforms(
        job: &Job<'_>,
        pass: &Pass,
        src: &crate::kernel::WgslSource,
    ) -> Result<(crate::kernel::Uniforms, Reach), BackendError> {
        let cpu_counters = Counters::default();
        let ctx = KernelCtx::for_pass(job, pass, &cpu_counters, BTreeMap::new(), BTreeMap::new());
        Ok(((src.uniforms)(&ctx)?, (src.reach)(&ctx)?))
    }

    /// The compiled pipeline of a kernel under the binding plan this device needs for it, with its
    /// `Params` struct generated from `uniforms` (every pass of a kernel must give the same fields).
    fn pipeline(
        &mut self,
        kernel: &dyn Kernel,
        uniforms: &crate::kernel::Uniforms,
    ) -> Result<(Arc<KernelPipeline>, crate::kernel::WgslSource, shaders::BindingPlan), BackendError> {
        let source = self.pipeline_source(kernel, uniforms)?;
        let p = match self.shared.pipeline(source.key) {
            Some(p) => p,
            None => self.compile(&source)?,
        };
        Ok((p, source.src, source.plan))
    }

    /// Everything a kernel's pipeline is built from, and the key it is cached under.
    fn pipeline_source(
        &mut self,
        kernel: &dyn Kernel,
        uniforms: &crate::kernel::Uniforms,
    ) -> Result<PipelineSource, BackendError> {
        let name = kernel.name();
        let src = Self::wgsl_of(kernel)?;
        let bindings = kernel.bindings();
        let plan = self.binding_plan(name, &bindings, src.scene)?;
        let fields = uniforms.layout();
        match self.uniform_layouts.get(name) {
            Some(first) if *first != fields => {
                return Err(gpu_err(format!(
                    "kernel `{name}`: WgslSource::uniforms gave the fields {fields:?} for one pass and {first:?} for another; \
                     the Params fields must not depend on the pass's parameters (only their values may)"
                )))
            }
            Some(_) => {}
            None => {
                self.uniform_layouts.insert(name.to_string(), fields);
            }
        }
        let text = shaders::kernel_wgsl(name, &src, &bindings, uniforms, plan, self.stack_entries)?.text;
        let mut h = std::collections::hash_map::DefaultHasher::new();
        (name, &text, src.scene, plan).hash(&mut h);
        Ok(PipelineSource { key: h.finish(), name, text, src, plan, bindings })
    }

    /// Compile `source` into a pipeline (the expensive step: on a CPU emulation with a cold shader
    /// cache, minutes for the path tracer) and cache it under its key.
    fn compile(&mut self, source: &PipelineSource) -> Result<Arc<KernelPipeline>, BackendError> {
        let PipelineSource { key, name, text, src, plan, bindings } = source;
        let (key, name, plan) = (*key, *name, *plan);
        let storage = |binding: u32, read_only: bool| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let uniform = |binding: u32| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let what = format!("compiling kernel `{name}`");
        let p = self.scoped(&what, || {
            let module = self.shared.device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(name),
                source: wgpu::ShaderSource::Wgsl(text.clone().into()),
            });
            let g0 = self.shared.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("wedge frame"),
                entries: &[uniform(0), uniform(1), storage(2, false)],
            });
            let g1_entries: Vec<_> = match plan {
                shaders::BindingPlan::Direct => {
                    bindings.iter().enumerate().map(|(k, b)| storage(k as u32, b.access == Access::Read)).collect()
                }
                shaders::BindingPlan::Packed => {
                    let (_, inputs, outputs) = shaders::packed_layout(bindings);
                    let mut e = Vec::new();
                    if inputs > 0 {
                        e.push(storage(0, true));
                    }
                    if outputs > 0 {
                        e.push(storage(e.len() as u32, false));
                    }
                    e
                }
            };
            let g1 = self.shared.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("wedge buffers"),
                entries: &g1_entries,
            });
            let g2 = src.scene.then(|| {
                self.shared.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some("wedge scene"),
                    entries: &[storage(0, true), uniform(1)],
                })
            });
            let mut layouts = vec![Some(&g0), Some(&g1)];
            if let Some(g2) = &g2 {
                layouts.push(Some(g2));
            }
            let layout = self.shared.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(name),
                bind_group_layouts: &layouts,
                immediate_size: 0,
            });
            let pipeline = self.shared.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(name),
                layout: Some(&layout),
                module: &module,
                entry_point: Some("main"),
                compilation_options: Default::default(),
                cache: None,
            });
            KernelPipeline { pipeline, g0, g1, g2 }
        })?;
        let p = Arc::new(p);
        self.shared.keep_pipeline(key, p.clone());
        Ok(p)
    }

    fn kernels_ready(&mut self, job: &Job<'_>, passes: &[&Pass]) -> Result<bool, BackendError> {
        let mut scene = false;
        let mut missing: Vec<PipelineSource> = Vec::new();
        self.stack_entries = traversal_stack_entries(job.scene);
        for pass in passes {
            check_bindings(job, pass)?;
            let kernel = job.kernels.get(&pass.kernel).expect("checked").clone();
            if kernel.host() {
                continue;
            }
            let (uniforms, _) = Self::uniforms(job, pass, &Self::wgsl_of(kernel.as_ref())?)?;
            let source = self.pipeline_source(kernel.as_ref(), &uniforms)?;
            scene |= source.src.scene;
            if self.shared.pipeline(source.key).is_none() && !missing.iter().any(|m| m.key == source.key) {
                missing.push(source);
            }
        }
        self.compile_all(&missing, job.progress)?;
        Ok(scene)
    }

    /// Compile the pipelines a run lacks, before its first pass, saying so: with a cold shader cache a
    /// CPU emulation (lavapipe) takes minutes for the big kernels, which would otherwise look like a
    /// frozen terminal (issue 33).
    fn compile_all(&mut self, missing: &[PipelineSource], progress: &dyn Progress) -> Result<(), BackendError> {
        if missing.is_empty() {
            return Ok(());
        }
        progress.begin_compile(missing.len() as u64, self.is_software());
        for source in missing {
            progress.compiling(source.name);
            let compiled = self.compile(source);
            if compiled.is_err() {
                progress.end();
            }
            compiled?;
            progress.advance(1);
        }
        progress.end();
        Ok(())
    }

    /// Sum the per-band counter blocks of one dispatch in 64 bits; also returns the pixels that
    /// still have samples left (`COUNTER_REMAINING`, chunked sampling kernels).
    fn read_counters(&self, buf: &wgpu::Buffer, bands: usize, stride: u64) -> Result<(RayCounts, u64), BackendError> {
        let b = self.read_bytes("reading counters", buf, stride * bands as u64)?;
        let c: Vec<u32> = bytemuck::pod_collect_to_vec(&b);
        let words = (stride / 4) as usize;
        let sum = |k: usize| (0..bands).map(|n| c[n * words + k] as u64).sum::<u64>();
        let rays = RayCounts {
            primary_rays: sum(0),
            shadow_rays: sum(1),
            secondary_rays: sum(2),
            non_finite_samples: sum(3),
            cut_loops: sum(4),
        };
        Ok((rays, sum(5)))
    }

    /// Run one pass alone: upload `inputs`, dispatch, read every output back (by binding name),
    /// with the pass's time and counters. The parity harness feeds it the CPU backend's inputs.
    pub fn run_pass(
        &mut self,
        job: &Job<'_>,
        pass: &Pass,
        inputs: &BTreeMap<BufferId, &BufferData>,
    ) -> Result<(BTreeMap<String, BufferData>, DispatchTime, RayCounts), BackendError> {
        if self.kernels_ready(job, &[pass])? {
            self.scene_buffers(job.scene)?;
        }
        let kernel = job.kernels.get(&pass.kernel).expect("checked").clone();
        if kernel.host() {
            let (counters, start) = (Counters::default(), Instant::now());
            let out = crate::cpu::run_pass(job, pass, inputs, &counters)?;
            return Ok((
                out,
                DispatchTime { seconds: start.elapsed().as_secs_f64(), from_timestamps: false },
                counters.snapshot(),
            ));
        }
        let pixels = job.width as usize * job.height as usize;
        let elements = |id: BufferId| pixels * job.schedule.buffers.get(id.0).map_or(1, |b| b.layers as usize);
        let mut bufs = Vec::new();
        let mut outs = Vec::new();
        for b in kernel.bindings() {
            let buf = match b.access {
                Access::Read => match pass.read(b.name) {
                    Some(id) => {
                        let pixels = elements(id);
                        let data = inputs.get(&id).ok_or_else(|| BackendError::Binding {
                            pass: pass.name.clone(),
                            binding: b.name.to_string(),
                            message: format!("reads `{}`, which holds no data", job.schedule.buffers[id.0].name),
                        })?;
                        if data.len() != pixels || data.format() != b.format {
                            return Err(BackendError::Binding {
                                pass: pass.name.clone(),
                                binding: b.name.to_string(),
                                message: format!(
                                    "input is {} × {}, expected {pixels} × {}",
                                    data.len(),
                                    data.format(),
                                    b.format
                                ),
                            });
                        }
                        Some(self.storage_init(b.name, &to_bytes(data))?)
                    }
                    None => None,
                },
                Access::Write => match pass.write(b.name) {
                    Some(id) => {
                        let buf = self.storage(b.name, (elements(id) * b.format.components() * 4) as u64)?;
                        outs.push((b.name.to_string(), b.format, buf.clone(), elements(id)));
                        Some(buf)
                    }
                    None => None,
                },
            };
            bufs.push(buf);
        }
        let (time, rays, _, _) = self.dispatch(job, pass, &bufs)?;
        let mut out = BTreeMap::new();
        for (name, format, buf, elements) in outs {
            let data =
                self.read_buffer(&format!("reading `{}` of pass `{}`", name, pass.name), &buf, format, elements)?;
            out.insert(name, data);
        }
        Ok((out, time, rays))
    }
}

impl GpuBackend {
    /// Run one kernel outside any pipeline: `inputs` by binding name, `params` as its parameter block.
    /// Returns every bound write binding. For tests and user crates trying out a kernel's WGSL
    /// (e.g. the RNG bit-exactness test runs a tiny WGSL kernel through this).
    #[allow(clippy::too_many_arguments)]
    pub fn run_kernel(
        &mut self,
        kernel: Arc<dyn Kernel>,
        scene: &wedge_scene::Scene,
        width: u32,
        height: u32,
        seed: u32,
        params: BTreeMap<String, wedge_graph::ParamValue>,
        inputs: &BTreeMap<String, BufferData>,
    ) -> Result<BTreeMap<String, BufferData>, BackendError> {
        Ok(crate::lone::LonePass::new(kernel, params, inputs)?.run_gpu(self, scene, width, height, seed)?.0)
    }
}

/// The bytes of a per-pixel buffer as the GPU stores it (vec3 packed, see the module docs).
pub fn to_bytes(b: &BufferData) -> Vec<u8> {
    b.as_bytes().to_vec()
}

pub fn from_bytes(format: Format, bytes: &[u8]) -> BufferData {
    BufferData::from_bytes(format, bytes)
}
