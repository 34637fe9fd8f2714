//! A session: a validated pipeline, its schedule and its loaded scene, with the command-line
//! overrides applied — everything `wedge render`, `reference`, `graph` and the tests share.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::{Quat, Vec3};
use wedge_backends::{Backend, BackendError, Job, KernelRegistry, Progress, RunResult, SinkNode};
use wedge_graph::SceneRequest;
use wedge_graph::{
    expand, parse_pipeline, schedule, validate, BufferBytes, GraphError, LoadedPipeline, NodeRegistry, ParamValue,
    Schedule, ValidatedPipeline,
};
use wedge_scene::motion::RigidMotion;
use wedge_scene::{Camera, ConfinedTo, Confinement, Scene, SceneError, SceneSource};

/// The default pipeline, compiled in so `wedge render` works from any directory.
pub const DEFAULT_PIPELINE: &str = include_str!("../pipelines/shadows.ron");
pub const DEFAULT_PIPELINE_NAME: &str = "pipelines/shadows.ron";

#[derive(Debug, thiserror::Error)]
pub enum WedgeError {
    #[error(transparent)]
    Graph(#[from] GraphError),
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Backend(#[from] BackendError),
    #[error(transparent)]
    Image(#[from] crate::image::ImageError),
    #[error(transparent)]
    Metrics(#[from] crate::metrics::MetricsError),
    #[error("{0}")]
    Usage(String),
}

/// Values given on the command line that replace the pipeline's.
#[derive(Clone, Debug, Default)]
pub struct Overrides {
    /// `builtin:NAME`, a built-in name, or a scene file path (relative to the working directory).
    pub scene: Option<String>,
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub seed: Option<u32>,
    /// Sets `mu` on every node that declares it.
    pub mu: Option<f64>,
    /// `(node, parameter, value)`: set one node's parameter (checked against its declaration).
    pub params: Vec<(String, String, ParamValue)>,
    /// Let the pipeline name files outside its own directory (its scene, environment map, real-layer
    /// maps, captured scene: [`pipeline_file`]) and the scene file read buffers, textures and meshes
    /// outside its own (`--allow-outside-dir`).
    pub allow_outside_dir: bool,
    /// Open the scene without a mixed-reality real layer: neither its maps are read nor its
    /// `capture` rendered. For `wedge export-scene` ([`crate::export`]), which does not export it; a
    /// session opened so cannot run a MixedReality node.
    pub without_real_layer: bool,
    /// The frame the session opens at (the first of `render --frames`; default 0): the camera path's
    /// position there, and the mixed-reality real layer of that frame.
    pub frame: Option<u32>,
    /// Render without the pipeline's filters at the same rays (`render --unfiltered`,
    /// [`wedge_graph::unfiltered`]): the baseline each filter must beat.
    pub unfiltered: bool,
    /// The scene's own camera (position, look-at, up, field of view, and its lens where it has one)
    /// instead of the view the pipeline's `camera:` block states; the block's shutter is kept, and
    /// its lens for a pinhole scene; a `camera_path` does not move it. `bench --suite` sets it: each
    /// suite scene is framed by its own camera, whatever camera the pipeline was written for.
    pub scene_camera: bool,
}

/// One `--set NODE.PARAM=VALUE` as an override of [`Overrides::params`]: the value is an integer,
/// a number, a bool, three numbers (`0.5,0.6,0.7` or `(0.5,0.6,0.7)`: a colour or vector) or else a
/// string, as written (checked against the parameter's declaration when a session applies it).
/// Public so that the fuzz target `set` parses exactly what the CLI does.
pub fn parse_set(s: &str) -> Result<(String, String, ParamValue), WedgeError> {
    let usage = || WedgeError::Usage(format!("--set {s:?}: expected NODE.PARAM=VALUE, e.g. shadows.mu=4"));
    let (lhs, value) = s.split_once('=').ok_or_else(usage)?;
    let (node, param) = lhs.split_once('.').ok_or_else(usage)?;
    let v = if let Ok(i) = value.parse::<i64>() {
        ParamValue::Int(i)
    } else if let Ok(f) = value.parse::<f64>() {
        ParamValue::Float(f)
    } else if let Ok(b) = value.parse::<bool>() {
        ParamValue::Bool(b)
    } else if let Some(v) = parse_vec3(value) {
        ParamValue::Vec3(v)
    } else {
        ParamValue::Str(value.to_string())
    };
    Ok((node.to_string(), param.to_string(), v))
}

/// `a,b,c` or `(a, b, c)`: three numbers, else `None`.
fn parse_vec3(value: &str) -> Option<[f64; 3]> {
    let inner = value.trim();
    let inner = inner.strip_prefix('(').and_then(|s| s.strip_suffix(')')).unwrap_or(inner);
    let parts: Vec<f64> = inner.split(',').map(|p| p.trim().parse::<f64>()).collect::<Result<_, _>>().ok()?;
    <[f64; 3]>::try_from(parts).ok()
}

pub struct Session {
    pub pipeline: ValidatedPipeline,
    pub schedule: Schedule,
    pub scene: Scene,
    pub nodes: NodeRegistry,
    pub kernels: KernelRegistry,
    pub width: u32,
    pub height: u32,
    pub seed: u32,
    /// The frame the session opened at (`Overrides::frame`, default 0): its camera and real layer
    /// are that frame's.
    pub frame: u32,
    /// `Overrides::allow_outside_dir`: the files of later frames' real layers follow it too.
    pub allow_outside_dir: bool,
}

/// The wgpu backend with the limits `--gpu-limits` names (None: the library's default, which reads
/// `WEDGE_WGPU_LIMITS`). Shared by `render`, `parity` and `view`.
pub fn open_gpu(limits: Option<&str>) -> Result<wedge_backends::gpu::GpuBackend, WedgeError> {
    use wedge_backends::gpu::{GpuBackend, LimitsChoice};
    Ok(match limits {
        None => GpuBackend::new()?,
        Some("webgpu") => GpuBackend::open(LimitsChoice::WebGpuDefault)?,
        Some(_) => GpuBackend::open(LimitsChoice::Adapter)?,
    })
}

/// Read a pipeline file, or the built-in default when `path` is `None`.
pub fn load_pipeline_or_default(path: Option<&Path>) -> Result<LoadedPipeline, GraphError> {
    match path {
        Some(p) => wedge_graph::load_pipeline(p),
        None => parse_pipeline(Path::new(DEFAULT_PIPELINE_NAME), DEFAULT_PIPELINE),
    }
}

/// The node kinds and kernels a session knows: wedge's own ([`Registries::builtin`]) plus whatever
/// a user crate adds. Every command of the CLI ([`crate::cli::main`]) opens its sessions with the
/// registries it is given, so a user's binary runs their nodes under every subcommand.
#[derive(Clone)]
pub struct Registries {
    pub nodes: NodeRegistry,
    pub kernels: KernelRegistry,
}

impl Registries {
    /// Everything wedge ships ([`wedge_effects::builtin`]).
    pub fn builtin() -> Registries {
        let (nodes, kernels) = wedge_effects::builtin();
        Registries { nodes, kernels }
    }
    /// These registries plus a node kind.
    pub fn with_node(mut self, kind: impl wedge_graph::NodeKind + 'static) -> Registries {
        self.nodes.register(std::sync::Arc::new(kind));
        self
    }
    /// These registries plus a kernel (both backends' implementations are the kernel's own).
    pub fn with_kernel(mut self, kernel: impl wedge_backends::Kernel + 'static) -> Registries {
        self.kernels.register(std::sync::Arc::new(kernel));
        self
    }
}

impl std::fmt::Debug for Registries {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Registries").finish_non_exhaustive()
    }
}

impl Default for Registries {
    fn default() -> Registries {
        Registries::builtin()
    }
}

impl Session {
    /// Load `path` (or the default pipeline) with wedge's own nodes and kernels.
    pub fn open(path: Option<&Path>, ov: &Overrides) -> Result<Session, WedgeError> {
        Session::open_with(&Registries::builtin(), path, ov)
    }

    /// [`Session::open`] with the caller's registries (a user crate's nodes and kernels).
    pub fn open_with(registries: &Registries, path: Option<&Path>, ov: &Overrides) -> Result<Session, WedgeError> {
        let Registries { nodes, kernels } = registries.clone();
        Session::build(load_pipeline_or_default(path)?, ov, nodes, kernels)
    }

    /// The registries this session was built with: sessions derived from it (a reference, a
    /// bench's other seeds) know the same nodes.
    pub fn registries(&self) -> Registries {
        Registries { nodes: self.nodes.clone(), kernels: self.kernels.clone() }
    }

    /// The plain Monte Carlo reference of the pipeline at `path` (or the default): the pipeline's own
    /// graph, transformed by [`wedge_graph::reference()`] — filters bypassed, per-pixel counts set to
    /// `spp`, every sampling pass at `spp` samples (per light, per component) placed by `sampling`
    /// (`stratified`: jointly stratified; `independent`). Same scene, camera, size, seed and
    /// `--set` overrides as a render.
    pub fn reference(path: Option<&Path>, spp: u32, sampling: &str, ov: &Overrides) -> Result<Session, WedgeError> {
        Session::reference_with(&Registries::builtin(), path, spp, sampling, ov)
    }

    /// [`Session::reference`] with the caller's registries.
    pub fn reference_with(
        registries: &Registries,
        path: Option<&Path>,
        spp: u32,
        sampling: &str,
        ov: &Overrides,
    ) -> Result<Session, WedgeError> {
        let Registries { nodes, kernels } = registries.clone();
        Session::build_reference(load_pipeline_or_default(path)?, ov, nodes, kernels, spp, sampling)
    }

    /// [`Session::reference`] with the caller's registries: a user crate's nodes get a reference from
    /// their declarations alone (stages, `random`, reference roles).
    pub fn build_reference(
        loaded: LoadedPipeline,
        ov: &Overrides,
        nodes: NodeRegistry,
        kernels: KernelRegistry,
        spp: u32,
        sampling: &str,
    ) -> Result<Session, WedgeError> {
        Session::build_with(loaded, ov, nodes, kernels, Some((spp, sampling)))
    }

    /// The general constructor: a user crate passes registries extended with its own nodes/kernels.
    pub fn build(
        loaded: LoadedPipeline,
        ov: &Overrides,
        nodes: NodeRegistry,
        kernels: KernelRegistry,
    ) -> Result<Session, WedgeError> {
        Session::build_with(loaded, ov, nodes, kernels, None)
    }

    /// A render, or with `reference = Some((spp, sampling))` the pipeline's reference.
    fn build_with(
        mut loaded: LoadedPipeline,
        ov: &Overrides,
        nodes: NodeRegistry,
        kernels: KernelRegistry,
        reference: Option<(u32, &str)>,
    ) -> Result<Session, WedgeError> {
        let p = &mut loaded.pipeline;
        if let Some(w) = ov.width {
            p.width = w;
        }
        if let Some(h) = ov.height {
            p.height = h;
        }
        if let Some(s) = ov.seed {
            p.seed = s;
        }
        check_pixel_count(ov, p.width, p.height)?;
        let mut pipeline = validate(&loaded, &nodes)?;
        apply_param_overrides(&mut pipeline, ov)?;
        // The scene before the graph: which node factors may depend on it (a Motion node on a static
        // scene does not).
        // Every refusal comes before a node's scene request is served (an environment map read, a real
        // layer captured at `capture_spp`), from the facts `wedge graph` decides with.
        let frame = ov.frame.unwrap_or(0);
        let mut scene = load_scene_at(&loaded, &pipeline, ov, frame)?;
        if ov.scene_camera {
            // The graph decides with the camera the render sees (a block's lens without a factoring
            // node is the plain Monte Carlo lens: `CameraSettings::of_block`).
            let block = pipeline.pipeline.camera.take();
            pipeline.pipeline.camera = block.map(|c| spec_of_camera(&scene.camera, c.shutter));
        }
        pipeline.update_factoring(Some(decision_facts(&scene, &pipeline)))?;
        let mut expansion = expand(&pipeline)?;
        apply_scene_requests(&mut scene, &pipeline, frame, ov)?;
        if let Some((spp, sampling)) = reference {
            expansion = wedge_graph::reference(expansion, spp, sampling)?;
        } else if ov.unfiltered {
            expansion = wedge_graph::unfiltered(expansion)?;
        }
        let schedule = schedule(expansion)?;
        kernels.check_schedule(&schedule)?;
        let (width, height, seed) = (pipeline.pipeline.width, pipeline.pipeline.height, pipeline.pipeline.seed);
        // Every pass's WGSL parsed and validated here, on any backend: a typo in a kernel's shader
        // is found by a CPU render and a CPU-only CI, at its file and line (backends gpu/validate.rs).
        let job = Job {
            schedule: &schedule,
            scene: &scene,
            kernels: &kernels,
            width,
            height,
            seed,
            frame,
            progress: &wedge_backends::Silent,
            window: wedge_backends::Window::whole(width, height),
        };
        wedge_backends::gpu::validate::check_job(&job)?;
        let allow_outside_dir = ov.allow_outside_dir;
        Ok(Session { pipeline, schedule, scene, nodes, kernels, width, height, seed, frame, allow_outside_dir })
    }

    pub fn run(&self, backend: &mut dyn Backend, progress: &dyn Progress) -> Result<RunResult, WedgeError> {
        self.run_with(backend, progress, self.seed, 0, &BTreeMap::new())
    }

    /// The camera of frame `frame` of a sequence: the pipeline's `camera_path` (position and look-at
    /// interpolated linearly between its keys, held before the first and after the last) over the
    /// session's camera (field of view, lens, shutter, up); without a path, the session's camera.
    pub fn camera_at(&self, frame: u32) -> Camera {
        let mut cam = self.scene.camera;
        if let Some((position, look_at)) = path_at(&self.pipeline.pipeline.camera_path, frame) {
            cam.position = position;
            cam.look_at = look_at;
        }
        cam
    }

    /// Run frame `frame` of a sequence that started at `first`: the scene seen by
    /// [`Session::camera_at`]`(frame)`, the camera of frame − 1 as the scene's previous camera (none
    /// for the first frame), the seed offset by the frame (each frame's noise is its own), and the
    /// previous-frame buffers ([`wedge_graph::Schedule::history`]) from `previous`, the run of the frame
    /// before (zeros without one), with `Job::frame` = `frame − first`. The session's camera is
    /// restored afterwards.
    pub fn run_frame(
        &mut self,
        backend: &mut dyn Backend,
        progress: &dyn Progress,
        frame: u32,
        first: u32,
        previous: Option<&RunResult>,
    ) -> Result<RunResult, WedgeError> {
        let empty = BTreeMap::new();
        let history = previous.map_or(&empty, |r| &r.history);
        self.at_frame(frame, first, |s, seed, index| s.run_with(backend, progress, seed, index, history))
    }

    /// `wedge parity`: every pass of the session's image (frame 0) run on the CPU and alone on `gpu`
    /// with the same inputs, compared pass by pass.
    pub fn parity(
        &self,
        gpu: &mut wedge_backends::gpu::GpuBackend,
    ) -> Result<wedge_backends::parity::ParityReport, WedgeError> {
        Ok(wedge_backends::parity::run_parity(&self.job(self.seed, 0, &wedge_backends::Silent), gpu)?)
    }

    /// Write `run` into `dir` as `wedge render` does (`stem`.exr/.png, the unfiltered image, every
    /// heatmap and statistic the pipeline's Output names), all or nothing ([`crate::staging`]).
    pub fn write_outputs(
        &self,
        dir: &Path,
        stem: &str,
        run: &RunResult,
    ) -> Result<crate::outputs::WrittenRun, WedgeError> {
        Ok(crate::outputs::write_run(dir, stem, run, self.width, self.height)?)
    }

    /// `wedge parity --frames`: frame `frame` of a sequence that started at `first`, set up as
    /// [`Session::run_frame`] sets it up, each pass run on the CPU and alone on the GPU with the same
    /// inputs, the previous-frame buffers from `previous` (the CPU's run of the frame before) on both.
    pub fn parity_frame(
        &mut self,
        gpu: &mut wedge_backends::gpu::GpuBackend,
        frame: u32,
        first: u32,
        previous: Option<&RunResult>,
    ) -> Result<wedge_backends::parity::ParityReport, WedgeError> {
        let empty = BTreeMap::new();
        let history = previous.map_or(&empty, |r| &r.history);
        self.at_frame(frame, first, |s, seed, index| {
            let job = s.job(seed, index, &wedge_backends::Silent);
            Ok(wedge_backends::parity::run_parity_with_history(&job, gpu, history)?)
        })
    }

    /// Run `f` on the scene of frame `frame` of a sequence that started at `first` (its camera, the
    /// camera before it as the previous camera, its real layer) with the frame's seed and index (see
    /// [`Session::run_frame`]); the session's camera and real layer are restored afterwards.
    fn at_frame<T>(
        &mut self,
        frame: u32,
        first: u32,
        f: impl FnOnce(&Session, u32, u32) -> Result<T, WedgeError>,
    ) -> Result<T, WedgeError> {
        let base = self.scene.camera;
        let camera = self.camera_at(frame);
        let previous_camera = (frame > first).then(|| self.camera_at(frame - 1));
        // A mixed-reality real layer belongs to one camera: each frame gets its own (`frame_real_layer`).
        let real = self.frame_real_layer(frame, &camera)?.map(|layer| self.scene.real.replace(layer));
        self.scene.camera = camera;
        self.scene.previous_camera = previous_camera;
        let result = f(self, self.seed.wrapping_add(frame), frame.saturating_sub(first));
        self.scene.camera = base;
        self.scene.previous_camera = None;
        if let Some(layer) = real {
            self.scene.real = layer;
        }
        result
    }

    /// The real layer of frame `frame` seen by `camera`, where it is not the session's own: a
    /// `capture` is rendered from the frame's camera (cached per camera, see [`crate::capture`]); maps
    /// whose file names hold `{frame}` are read for the frame; one photograph (no `{frame}`) serves
    /// only the camera it was taken from — a camera path that moves away from it is an error, not a
    /// composite of the wrong view. `None`: the session's layer is the frame's (or there is none).
    fn frame_real_layer(&self, frame: u32, camera: &Camera) -> Result<Option<wedge_scene::RealLayer>, WedgeError> {
        let Some((node, request)) = real_layer_request(&self.pipeline) else {
            return Ok(None);
        };
        let SceneRequest::RealLayer { camera_image, position_map, normal_map, albedo_map, capture, .. } = &request
        else {
            return Ok(None);
        };
        // The frame the session opened at already has its layer (read or captured at build).
        if frame == self.frame && *camera == self.scene.camera {
            return Ok(None);
        }
        let per_frame = [camera_image, position_map, normal_map, albedo_map].iter().any(|p| p.contains("{frame"));
        if capture.is_empty() && !per_frame {
            if *camera != self.scene.camera {
                return Err(WedgeError::Usage(format!(
                    "{}: node `{}`: frame {frame}'s camera differs from the one the real maps were taken with, and the \
                     maps are one photograph: give one set of maps per frame with `{{frame}}` in the file names (e.g. \
                     \"camera_image\": \"cam_{{frame:04}}.exr\"), or drop the camera path",
                    node.location, node.name
                )));
            }
            return Ok(None);
        }
        if capture.is_empty() || *camera != self.scene.camera {
            let at = RealLayerAt {
                camera,
                environment: self.scene.environment.as_ref(),
                frame,
                allow_outside_dir: self.allow_outside_dir,
            };
            return load_real_layer(&self.pipeline, node, request, &at).map(Some);
        }
        Ok(None)
    }

    /// Run frame `frame` (0, 1, 2, …) of a progressive render (`render --progressive`): the session's
    /// camera held still, the seed offset by the frame (each frame adds new samples), and the
    /// previous-frame buffers from `previous`, the run of frame − 1 (zeros without one), so a node
    /// that accumulates over frames (PixelFilter) continues its statistics. Frame 0 with no
    /// `previous` is the single image [`Session::run`] renders.
    pub fn run_progressive_frame(
        &self,
        backend: &mut dyn Backend,
        progress: &dyn Progress,
        frame: u32,
        previous: Option<&RunResult>,
    ) -> Result<RunResult, WedgeError> {
        let empty = BTreeMap::new();
        let history = previous.map_or(&empty, |r| &r.history);
        self.run_with(backend, progress, self.seed.wrapping_add(frame), frame, history)
    }

    /// The job of this session's schedule on its scene, with `seed` and frame index `frame`.
    pub fn job<'a>(&'a self, seed: u32, frame: u32, progress: &'a dyn Progress) -> Job<'a> {
        Job {
            schedule: &self.schedule,
            scene: &self.scene,
            kernels: &self.kernels,
            width: self.width,
            height: self.height,
            seed,
            frame,
            progress,
            window: wedge_backends::Window::whole(self.width, self.height),
        }
    }

    /// Run only `window` of this session's image (`render --tile`, [`crate::tiles`]): buffers of
    /// `width × height` at the window's place in the full image, whose camera rays and random
    /// numbers they use. A single image (no sequence, no history).
    pub fn run_window(
        &self,
        backend: &mut dyn Backend,
        progress: &dyn Progress,
        window: wedge_backends::Window,
        (width, height): (u32, u32),
    ) -> Result<RunResult, WedgeError> {
        let job = Job { width, height, window, ..self.job(self.seed, 0, progress) };
        self.run_job(backend, &job, &BTreeMap::new())
    }

    /// [`Session::run_window`] at frame `frame` of a sequence that started at `first`, set up as
    /// [`Session::run_frame`] sets it up, with no history (`render --tile` with `--frames`).
    pub fn run_window_frame(
        &mut self,
        backend: &mut dyn Backend,
        progress: &dyn Progress,
        window: wedge_backends::Window,
        (width, height): (u32, u32),
        frame: u32,
        first: u32,
    ) -> Result<RunResult, WedgeError> {
        self.at_frame(frame, first, |s, seed, index| {
            let job = Job { width, height, window, ..s.job(seed, index, progress) };
            s.run_job(backend, &job, &BTreeMap::new())
        })
    }

    fn run_with(
        &self,
        backend: &mut dyn Backend,
        progress: &dyn Progress,
        seed: u32,
        frame: u32,
        history: &BTreeMap<wedge_graph::BufferId, wedge_backends::BufferData>,
    ) -> Result<RunResult, WedgeError> {
        self.run_job(backend, &self.job(seed, frame, progress), history)
    }

    fn run_job(
        &self,
        backend: &mut dyn Backend,
        job: &Job<'_>,
        history: &BTreeMap<wedge_graph::BufferId, wedge_backends::BufferData>,
    ) -> Result<RunResult, WedgeError> {
        let mut run = backend.run_frame(job, history)?;
        run.sinks = self.sink_nodes();
        Ok(run)
    }

    /// The pipeline's sinks, so whoever writes the outputs knows each one's kind and parameters.
    fn sink_nodes(&self) -> BTreeMap<String, SinkNode> {
        self.pipeline
            .nodes
            .iter()
            .filter(|n| n.kind.is_sink())
            .map(|n| (n.name.clone(), SinkNode { kind: n.kind.kind().to_string(), params: n.params.clone() }))
            .collect()
    }

    /// Peak memory of running this session in `mode` (see [`MemoryEstimate`]).
    pub fn memory_estimate(&self, mode: RunMode) -> MemoryEstimate {
        self.memory_estimate_at(mode, (self.width, self.height))
    }

    /// [`Session::memory_estimate`] for buffers of `width × height` pixels: a tile with its apron
    /// (`render --tile`).
    pub fn memory_estimate_at(&self, mode: RunMode, (width, height): (u32, u32)) -> MemoryEstimate {
        let b = self.schedule.buffer_bytes(width, height);
        let scene = scene_bytes(&self.scene);
        let pixels = u64::from(width) * u64::from(height);
        match mode {
            RunMode::Cpu => MemoryEstimate {
                buffers: self.schedule.peak_bytes(width, height),
                scene,
                images: pixels.saturating_mul(OUTPUT_BYTES_PER_PIXEL),
            },
            // The pool lives on the device, the sink copies and images on the host; a software
            // adapter (lavapipe) takes both from the same RAM, so both count. The scene is uploaded.
            RunMode::Gpu => MemoryEstimate {
                buffers: self.schedule.peak_bytes(width, height),
                scene: scene.saturating_mul(2),
                images: pixels.saturating_mul(OUTPUT_BYTES_PER_PIXEL),
            },
            RunMode::Parity => {
                MemoryEstimate { buffers: parity_buffer_bytes(&b), scene: scene.saturating_mul(2), images: 0 }
            }
        }
    }
}

impl Session {
    /// Peak memory of a sequence (`render --frames`, `--progressive`) in `mode`: one frame's run as
    /// [`Session::memory_estimate`], plus the previous frame's run that the next frame reads its history
    /// from (its sink copies and previous-frame buffers), plus the frame being streamed out (its image,
    /// sRGB bytes and GIF frame). Frames are written as they come (`crate::outputs::SequenceWriter`), so
    /// this does not grow with the number of frames.
    pub fn sequence_memory_estimate(&self, mode: RunMode) -> MemoryEstimate {
        let single = self.memory_estimate(mode);
        let b = self.schedule.buffer_bytes(self.width, self.height);
        let pixels = u64::from(self.width) * u64::from(self.height);
        MemoryEstimate {
            buffers: single.buffers.saturating_add(b.sinks).saturating_add(b.history),
            scene: single.scene,
            images: single.images.saturating_add(pixels.saturating_mul(SEQUENCE_FRAME_BYTES_PER_PIXEL)),
        }
    }
}

/// Bytes per pixel a sequence holds for the frame being written besides [`OUTPUT_BYTES_PER_PIXEL`]:
/// the frame's `[f32; 3]` image and the GIF encoder's RGB copy and palette indices.
const SEQUENCE_FRAME_BYTES_PER_PIXEL: u64 = 12 + 3 + 1;

/// Buffer bytes of `wedge parity`: every CPU buffer kept (no pooling), plus one pass's bindings on
/// the device and the read-back copies of its outputs on the host.
pub fn parity_buffer_bytes(b: &BufferBytes) -> u64 {
    b.unpooled.saturating_add(b.pass_bindings).saturating_add(b.pass_outputs)
}

/// How a session is run, for [`Session::memory_estimate`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RunMode {
    /// `render`/`reference` on the CPU backend.
    Cpu,
    /// `render --backend wgpu`.
    Gpu,
    /// `wedge parity`: CPU and GPU copies of the buffers.
    Parity,
}

/// Bytes per pixel of writing the outputs: one image as `[f32; 3]` plus its 8-bit PNG encoding
/// (the images are written one after the other).
const OUTPUT_BYTES_PER_PIXEL: u64 = 12 + 3;

/// Estimated peak bytes of a run, by what holds them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MemoryEstimate {
    /// The schedule's buffers ([`Schedule::buffer_bytes`]).
    pub buffers: u64,
    /// Triangles, shading, BVH, materials, textures, lights (times two where a device copy exists).
    pub scene: u64,
    /// Converting and encoding the output images.
    pub images: u64,
}

impl MemoryEstimate {
    pub fn total(&self) -> u64 {
        self.buffers.saturating_add(self.scene).saturating_add(self.images)
    }

    /// Refuse the run when the estimate exceeds `limit` (bytes); `limit_source` says where the
    /// limit came from (`--memory-limit`, or the default's derivation) for the message.
    pub fn check(&self, limit: u64, limit_source: &str) -> Result<(), WedgeError> {
        if self.total() <= limit {
            return Ok(());
        }
        Err(WedgeError::Usage(format!(
            "this run needs an estimated {} ({} buffers + {} scene + {} output images), more than the memory \
             limit of {} ({limit_source}); lower --width/--height, or raise the limit with --memory-limit SIZE \
             (e.g. --memory-limit 16G) if the machine has the memory",
            format_bytes(self.total()),
            format_bytes(self.buffers),
            format_bytes(self.scene),
            format_bytes(self.images),
            format_bytes(limit)
        )))
    }
}

/// Position and look-at of a camera path at `frame` (see [`Session::camera_at`]); `None` without keys.
/// The interpolation is the graph's ([`wedge_graph::camera_path_at`]), the one its validation checks.
pub fn path_at(keys: &[wedge_graph::CameraKey], frame: u32) -> Option<(Vec3, Vec3)> {
    let v = |t: (f32, f32, f32)| Vec3::new(t.0, t.1, t.2);
    wedge_graph::camera_path_at(keys, frame).map(|(position, look_at)| (v(position), v(look_at)))
}

/// The scene a render of `pipeline` sees at `frame`, before the nodes' scene requests (environment
/// map, real layer): its geometry and lights, the pipeline's camera block and motion, the frame's
/// camera on the path, motion held still under a zero-length shutter.
fn load_scene_at(
    loaded: &LoadedPipeline,
    pipeline: &ValidatedPipeline,
    ov: &Overrides,
    frame: u32,
) -> Result<Scene, WedgeError> {
    let source = scene_source(pipeline, ov.scene.as_deref());
    // A scene file the pipeline names is confined to the pipeline's directory; one given on the
    // command line (`--scene PATH`) is not: the user chose it, as they chose the pipeline file, and
    // it is relative to the working directory, not to the pipeline.
    if let (SceneSource::File(_), None) = (&source, &ov.scene) {
        let at = loaded.scene_location();
        let entry = format!("line {}: scene = {:?}", at.line, pipeline.pipeline.scene);
        pipeline_file(&pipeline.path, &pipeline.pipeline.scene, &entry, ov.allow_outside_dir)?;
    }
    let scene_opts = wedge_scene::LoadOptions { allow_outside_dir: ov.allow_outside_dir };
    // The pipeline's shutter (if it gives one) is when a scene file's animations are sampled.
    let shutter = pipeline.pipeline.camera.as_ref().and_then(|c| c.shutter);
    let mut scene = wedge_scene::load_with_shutter(&source, &scene_opts, shutter)?;
    match &pipeline.pipeline.camera {
        Some(c) if ov.scene_camera => scene.camera = camera_from_spec(&scene_view(c, &scene.camera), &scene.camera),
        Some(c) => scene.camera = camera_from_spec(c, &scene.camera),
        None => {}
    }
    apply_motion(&mut scene, pipeline)?;
    // Without a camera block (or with `scene_camera`) the scene's camera gives the path its `up`:
    // check the path's view against it now (validation checked it against the block's).
    if pipeline.pipeline.camera.is_none() || ov.scene_camera {
        let up = scene.camera.up;
        wedge_graph::check_camera_path(loaded, (up.x, up.y, up.z))?;
    }
    // A pipeline with a camera path renders its frame 0 (or `ov.frame`) as a single image; before
    // the scene requests, so a real layer is captured from that frame's camera. Not where the scene
    // frames itself (`scene_camera`): a path written for the pipeline's scene would move it away.
    let path = if ov.scene_camera { None } else { path_at(&pipeline.pipeline.camera_path, frame) };
    if let Some((position, look_at)) = path {
        scene.camera.position = position;
        scene.camera.look_at = look_at;
    }
    if shutter.is_some_and(|(open, close)| open == close) {
        freeze_motion(&mut scene)?;
    }
    Ok(scene)
}

/// The scene facts a render of `loaded` decides with, for `wedge graph` (issue 34 §4: `graph` and
/// `render` make the same decision): the scene loaded as a render loads it, before any environment
/// map is read or real layer captured. Refusals that need no scene come first, from [`validate`].
pub fn graph_scene_facts(
    loaded: &LoadedPipeline,
    pipeline: &ValidatedPipeline,
    ov: &Overrides,
) -> Result<wedge_graph::SceneFacts, WedgeError> {
    let scene = load_scene_at(loaded, pipeline, ov, ov.frame.unwrap_or(0))?;
    Ok(decision_facts(&scene, pipeline))
}

/// [`scene_facts`] of the scene before the nodes' scene requests are served, a node's request for an
/// environment map counting as the environment it will light the scene with.
fn decision_facts(scene: &Scene, pipeline: &ValidatedPipeline) -> wedge_graph::SceneFacts {
    let mut facts = scene_facts(scene);
    facts.environment |= pipeline.nodes.iter().any(|n| {
        n.kind
            .scene_requests(&n.params)
            .iter()
            .any(|r| matches!(r, SceneRequest::Environment { map, .. } if !map.is_empty()))
    });
    facts
}

/// What factoring decisions and the light-term warnings may know of a loaded scene
/// ([`wedge_graph::SceneFacts`]): something moves over the shutter (an object whose motion has
/// different poses at its two ends), its area lights, its environment map.
pub fn scene_facts(scene: &Scene) -> wedge_graph::SceneFacts {
    let moves = scene.objects.iter().any(|o| o.motion.is_some_and(|m| !m.is_still()));
    wedge_graph::SceneFacts {
        motion: moves,
        area_lights: u32::try_from(scene.lights.len()).unwrap_or(u32::MAX),
        environment: scene.environment.is_some(),
    }
}

/// A zero-length shutter sees one instant: every moving object is held where it is at the shutter's
/// centre (`t = 0`, where renders without motion blur see it), so nothing blurs whatever the scene's
/// motion is given as — a glTF animation is sampled at the one time anyway; motion given over the
/// shutter (built-ins, `.ron` scenes, a pipeline's `motion` block) would otherwise still move.
fn freeze_motion(scene: &mut Scene) -> Result<(), WedgeError> {
    let moving: Vec<(String, RigidMotion)> =
        scene.objects.iter().filter_map(|o| o.motion.filter(|m| !m.is_still()).map(|m| (o.name.clone(), m))).collect();
    for (name, m) in moving {
        let mid = m.translation[0].lerp(m.translation[1], 0.5);
        let q = m.rotation[0].slerp(m.rotation[1], 0.5);
        scene.set_motion(&name, RigidMotion { pivot: m.pivot, translation: [mid; 2], rotation: [q; 2] })?;
    }
    Ok(())
}

/// The rigid motion a pipeline's `motion` entry gives its object ([`wedge_graph::MotionSpec`]: the
/// displacement and rotation over the whole shutter, centred on the pose in the scene file): keys at
/// `∓translate/2` and `∓rotate_deg/2` about `pivot` (default: the centre of the object's bounding box).
pub fn motion_from_spec(scene: &Scene, m: &wedge_graph::MotionSpec) -> RigidMotion {
    let v = |t: (f32, f32, f32)| Vec3::new(t.0, t.1, t.2);
    let pivot = m.pivot.map(v).unwrap_or_else(|| {
        let mut b = wedge_scene::Aabb::empty();
        for (tri, sh) in scene.triangles.iter().zip(&scene.shading) {
            if scene.objects.get(sh.object as usize).is_some_and(|o| o.name == m.object) {
                tri.vertices().into_iter().for_each(|p| b.grow(p));
            }
        }
        if b.min.x <= b.max.x {
            b.centre()
        } else {
            Vec3::ZERO
        }
    });
    let (axis, half) = (v(m.axis).normalize_or_zero(), 0.5 * m.rotate_deg.to_radians());
    let half_turn = |a: f32| if axis == Vec3::ZERO { Quat::IDENTITY } else { Quat::from_axis_angle(axis, a) };
    RigidMotion {
        pivot,
        translation: [v(m.translate) * -0.5, v(m.translate) * 0.5],
        rotation: [half_turn(-half), half_turn(half)],
    }
}

/// Apply the pipeline's `motion` entries to the loaded scene; an entry the scene cannot take (no such
/// object, a light split between objects) is an error naming the pipeline file and the entry.
fn apply_motion(scene: &mut Scene, pipeline: &ValidatedPipeline) -> Result<(), WedgeError> {
    for m in &pipeline.pipeline.motion {
        let motion = motion_from_spec(scene, m);
        scene.set_motion(&m.object, motion).map_err(|e| {
            WedgeError::Usage(format!("{}: the `motion` entry for `{}`: {e}", pipeline.path.display(), m.object))
        })?;
    }
    Ok(())
}

/// Apply what the pipeline's nodes ask of the scene ([`SceneRequest`]): an environment map, read
/// relative to the pipeline file (or the scene's own, scaled and turned), and a mixed-reality real
/// layer (unless `ov.without_real_layer`). One of each kind per scene: nodes that ask for different
/// ones are refused, naming both. Files are confined to the pipeline's directory ([`pipeline_file`]).
fn apply_scene_requests(
    scene: &mut Scene,
    pipeline: &ValidatedPipeline,
    frame: u32,
    ov: &Overrides,
) -> Result<(), WedgeError> {
    type Asked<'p> = Option<(&'p wedge_graph::ValidatedNode, SceneRequest)>;
    let (mut environment, mut real): (Asked<'_>, Asked<'_>) = (None, None);
    for node in &pipeline.nodes {
        for request in node.kind.scene_requests(&node.params) {
            let (slot, what) = match request {
                SceneRequest::Environment { .. } => (
                    &mut environment,
                    "one scene has one environment: give both nodes the same map, scale and rotation_deg",
                ),
                SceneRequest::RealLayer { .. } => {
                    (&mut real, "one scene has one real layer: give both nodes the same inputs")
                }
            };
            match slot {
                Some((first, wanted)) if *wanted != request => {
                    return Err(WedgeError::Usage(format!(
                        "{}: node `{}` asks the scene for {request:?}, but node `{}` (at {}) for {wanted:?}; {what}",
                        node.location, node.name, first.name, first.location
                    )));
                }
                Some(_) => {}
                None => *slot = Some((node, request)),
            }
        }
    }
    if let Some((node, SceneRequest::Environment { map, scale, rotation_deg, param })) = environment {
        let requested = EnvironmentRequest { map: &map, scale, rotation_deg, param };
        apply_environment(scene, pipeline, node, &requested, ov.allow_outside_dir)?;
    }
    if let Some((node, request)) = real.filter(|_| !ov.without_real_layer) {
        let at = RealLayerAt {
            camera: &scene.camera,
            environment: scene.environment.as_ref(),
            frame,
            allow_outside_dir: ov.allow_outside_dir,
        };
        let layer = load_real_layer(pipeline, node, request, &at)?;
        scene.set_real(Some(layer));
    }
    Ok(())
}

/// The node that asks for the real layer, and its request (the first: [`apply_scene_requests`] has
/// checked that every node asks for the same one).
fn real_layer_request(pipeline: &ValidatedPipeline) -> Option<(&wedge_graph::ValidatedNode, SceneRequest)> {
    pipeline.nodes.iter().find_map(|node| {
        node.kind
            .scene_requests(&node.params)
            .into_iter()
            .find(|r| matches!(r, SceneRequest::RealLayer { .. }))
            .map(|r| (node, r))
    })
}

/// What a node's [`SceneRequest::Environment`] asks for.
struct EnvironmentRequest<'a> {
    /// A file relative to the pipeline, `builtin:NAME`, or empty: the scene's own map.
    map: &'a str,
    scale: f64,
    rotation_deg: f64,
    /// The node's parameter that names the map, for messages.
    param: &'a str,
}

fn apply_environment(
    scene: &mut Scene,
    pipeline: &ValidatedPipeline,
    node: &wedge_graph::ValidatedNode,
    request: &EnvironmentRequest<'_>,
    allow_outside_dir: bool,
) -> Result<(), WedgeError> {
    let EnvironmentRequest { map, scale, rotation_deg, param } = *request;
    let at =
        |e: String| WedgeError::Usage(format!("{}: node `{}`, parameter `{param}`: {e}", node.location, node.name));
    let (base, scale, rotation_deg) = if map.is_empty() {
        // The scene's own map, with the node's scale and rotation on top of its own.
        let own = scene.environment.clone().ok_or_else(|| {
            at(format!(
                "no map given and scene `{}` has none — give `{param}` an EXR or .hdr file (relative to the pipeline \
                 file) or builtin:sky, or use a scene with a map (e.g. --scene envmap)",
                scene.name
            ))
        })?;
        let (s, r) = (own.scale() as f64 * scale, own.rotation_deg() as f64 + rotation_deg);
        (own, s, r)
    } else {
        let spec = if map.starts_with("builtin:") {
            map.to_string()
        } else {
            pipeline_file(&pipeline.path, map, &node_entry(node, param, map), allow_outside_dir)?.display().to_string()
        };
        (wedge_scene::EnvironmentMap::open(&spec).map_err(|e| at(e.to_string()))?, scale, rotation_deg)
    };
    scene.set_environment(Some(base.with_params(scale as f32, rotation_deg as f32).map_err(|e| at(e.to_string()))?));
    Ok(())
}

/// The seed of every `capture`.
const CAPTURE_SEED: u32 = 0x5eed_ca97;

/// A file the pipeline at `pipeline_path` names (its scene, an environment map, a real-layer map, a
/// captured scene), resolved relative to the pipeline file's directory and confined to it unless
/// `allow_outside` (`--allow-outside-dir`), by the rule a scene's own files follow
/// ([`wedge_scene::Confinement`], symlinks followed): the canonical path. `entry` says where in the
/// pipeline it is named (`line 12: node `env`, parameter `map` = "../sky.exr"`), for the refusal.
/// `builtin:` names are not files: the callers keep them away from here.
pub fn pipeline_file(
    pipeline_path: &Path,
    reference: &str,
    entry: &str,
    allow_outside: bool,
) -> Result<PathBuf, SceneError> {
    let confinement = Confinement::of_file(pipeline_path, ConfinedTo::Pipeline, allow_outside)?;
    confinement.resolve(pipeline_path, Path::new(reference), entry)
}

/// Where a node names a file, for [`pipeline_file`]: `line N: node `NAME`, parameter `PARAM` = "VALUE"`.
fn node_entry(node: &wedge_graph::ValidatedNode, param: &str, value: &str) -> String {
    format!("line {}: node `{}`, parameter `{param}` = {value:?}", node.location.line, node.name)
}

/// Whose real layer [`load_real_layer`] reads or captures: frame `frame` seen by `camera` under
/// `environment`, its files confined to the pipeline's directory unless `allow_outside_dir`.
struct RealLayerAt<'a> {
    camera: &'a Camera,
    environment: Option<&'a wedge_scene::EnvironmentMap>,
    frame: u32,
    allow_outside_dir: bool,
}

/// The mixed-reality real layer a node asks for, for frame `at.frame` seen by `at.camera`: its maps
/// read relative to the pipeline file (`{frame}` in a file name replaced by the frame number, see
/// [`frame_path`]), or a scene captured by wedge from the camera under `at.environment`
/// ([`crate::capture`]); files confined as [`pipeline_file`] says; it must have the image's size.
fn load_real_layer(
    pipeline: &ValidatedPipeline,
    node: &wedge_graph::ValidatedNode,
    request: SceneRequest,
    at_frame: &RealLayerAt<'_>,
) -> Result<wedge_scene::RealLayer, WedgeError> {
    let &RealLayerAt { camera, environment, frame, allow_outside_dir } = at_frame;
    let SceneRequest::RealLayer { camera_image, position_map, normal_map, albedo_map, albedo, capture, capture_spp } =
        request
    else {
        unreachable!("load_real_layer is given RealLayer requests only");
    };
    let at = |e: String| WedgeError::Usage(format!("{}: node `{}`: {e}", node.location, node.name));
    let (width, height) = (pipeline.pipeline.width, pipeline.pipeline.height);
    let maps = [("camera_image", &camera_image), ("position_map", &position_map), ("normal_map", &normal_map)];
    let layer = if !capture.is_empty() {
        let given: Vec<&str> =
            maps.iter().chain([&("albedo_map", &albedo_map)]).filter(|(_, v)| !v.is_empty()).map(|(n, _)| *n).collect();
        if !given.is_empty() {
            return Err(at(format!("give either `capture` or the maps, not both (also given: {})", given.join(", "))));
        }
        let scene = if capture.starts_with("builtin:") {
            capture.clone()
        } else {
            pipeline_file(&pipeline.path, &capture, &node_entry(node, "capture", &capture), allow_outside_dir)?
                .display()
                .to_string()
        };
        crate::capture::capture_real_layer(&crate::capture::Capture {
            spec: &scene,
            base_dir: &pipeline.base_dir(),
            allow_outside_dir,
            camera: *camera,
            environment: environment.cloned(),
            width,
            height,
            spp: capture_spp.clamp(1, u32::MAX as i64) as u32,
            // A photograph is an input, the same whatever seed renders the virtual objects into it
            // (a bench averaging seeds must not average photographs).
            seed: CAPTURE_SEED,
        })
        .map_err(|e| at(format!("parameter `capture`: {e}")))?
    } else {
        let missing: Vec<&str> = maps.iter().filter(|(_, v)| v.is_empty()).map(|(n, _)| *n).collect();
        if !missing.is_empty() {
            return Err(at(format!(
                "the real world is missing: set {} (EXR/PNG files relative to the pipeline file; `wedge render --aov \
                 position,normal,albedo` writes them for any scene), or `capture` a scene instead",
                missing.join(", ")
            )));
        }
        let file = |param: &str, template: &str| -> Result<PathBuf, WedgeError> {
            let name = frame_path(template, frame).map_err(|e| at(format!("parameter `{param}`: {e}")))?;
            let entry = if name == template {
                node_entry(node, param, template)
            } else {
                format!("{} (frame {frame}: {name:?})", node_entry(node, param, template))
            };
            Ok(pipeline_file(&pipeline.path, &name, &entry, allow_outside_dir)?)
        };
        // The camera image first: a missing frame is named by it.
        let (image, position, normal) = (
            file("camera_image", &camera_image)?,
            file("position_map", &position_map)?,
            file("normal_map", &normal_map)?,
        );
        let albedo = if albedo_map.is_empty() {
            wedge_scene::RealAlbedo::Constant([albedo as f32; 3])
        } else {
            wedge_scene::RealAlbedo::Map(file("albedo_map", &albedo_map)?)
        };
        wedge_scene::RealLayer::open(&image, &position, &normal, albedo).map_err(|e| at(e.to_string()))?
    };
    if (layer.width(), layer.height()) != (width, height) {
        return Err(at(format!(
            "the real layer is {}x{} but the pipeline renders {width}x{height}: set `width: {}, height: {}` (or --width/--height) \
             to the capture's size",
            layer.width(),
            layer.height(),
            layer.width(),
            layer.height()
        )));
    }
    Ok(layer)
}

/// A file name of a frame sequence: `{frame}` replaced by the frame number, `{frame:0N}` by the
/// number zero-padded to N digits (as `wedge render --frames` names its `frame_NNNN` outputs); a
/// name without either is returned as it is. A malformed placeholder is an error naming the fix.
pub fn frame_path(template: &str, frame: u32) -> Result<String, String> {
    let mut out = String::with_capacity(template.len());
    let mut rest = template;
    while let Some(start) = rest.find("{frame") {
        out.push_str(&rest[..start]);
        let after = &rest[start + "{frame".len()..];
        let end = after
            .find('}')
            .ok_or_else(|| format!("`{template}`: `{{frame` is not closed; write `{{frame}}` or `{{frame:04}}`"))?;
        let spec = &after[..end];
        let digits = match spec.strip_prefix(":0") {
            None if spec.is_empty() => 0,
            Some(n) => n.parse::<usize>().ok().filter(|n| (1..=9).contains(n)).ok_or_else(|| {
                format!("`{template}`: `{{frame{spec}}}` is not a frame placeholder; write `{{frame}}` or `{{frame:0N}}` with N from 1 to 9")
            })?,
            None => return Err(format!("`{template}`: `{{frame{spec}}}` is not a frame placeholder; write `{{frame}}` or `{{frame:0N}}`, e.g. `{{frame:04}}`")),
        };
        out.push_str(&format!("{frame:0digits$}"));
        rest = &after[end + 1..];
    }
    out.push_str(rest);
    Ok(out)
}

/// Bytes the loaded scene's arrays take.
pub fn scene_bytes(scene: &Scene) -> u64 {
    fn of<T>(v: &[T]) -> u64 {
        std::mem::size_of_val(v) as u64
    }
    let texels: u64 = scene.textures.iter().map(|t| of(&t.texels)).sum();
    // Moving instances (their trees are in `bvh`), objects (one instance index each on the GPU) and
    // the lights' objects.
    let motion = of(&scene.instances) + of(&scene.objects) + of(&scene.light_object);
    // The environment map: texels, CDFs, boundary tables and the 4096-sample table (about 20 bytes
    // per texel on the CPU; the GPU copy, 16 per texel, is covered by the estimate's doubling).
    let environment = scene.environment.as_ref().map_or(0, |e| e.bytes());
    // A mixed-reality real layer: 52 bytes per camera pixel on the CPU (the GPU's 64, as above).
    let real = scene.real.as_ref().map_or(0, |r| r.bytes());
    of(&scene.triangles)
        + of(&scene.shading)
        + scene.bvh.bytes() as u64
        + of(&scene.materials)
        + of(&scene.lights)
        + texels
        + motion
        + environment
        + real
}

/// The default memory limit: 3/4 of the memory the kernel reports available (`MemAvailable` of
/// /proc/meminfo), leaving room for the rest of the system. `None` where it cannot be read.
pub fn default_memory_limit() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let kib: u64 =
        text.lines().find_map(|l| l.strip_prefix("MemAvailable:"))?.trim().strip_suffix("kB")?.trim().parse().ok()?;
    Some(kib.saturating_mul(1024) / 4 * 3)
}

/// The memory budget and where it comes from: `--memory-limit` (`flag`), else 3/4 of the
/// available memory ([`default_memory_limit`]), else none.
pub fn memory_budget(flag: Option<u64>) -> Option<(u64, String)> {
    match flag {
        Some(l) => Some((l, "--memory-limit".into())),
        None => default_memory_limit().map(|l| (l, "default: 3/4 of the available memory".into())),
    }
}

/// Parse a size: bytes (`1048576`), or a number with a binary suffix `K`, `M`, `G`, `T`
/// (optionally followed by `B` or `iB`; `1.5G` allowed). For `--memory-limit`.
pub fn parse_size(s: &str) -> Result<u64, String> {
    let t = s.trim();
    if t.starts_with('-') {
        return Err(format!("`{s}` is negative; a size must be positive, e.g. 512M, 8G or 1073741824"));
    }
    let split = t.find(|c: char| !(c.is_ascii_digit() || c == '.')).unwrap_or(t.len());
    let (number, unit) = t.split_at(split);
    let shift = match unit.trim().to_ascii_uppercase().trim_end_matches("IB").trim_end_matches('B') {
        "" => 0,
        "K" => 10,
        "M" => 20,
        "G" => 30,
        "T" => 40,
        _ => {
            return Err(format!("`{s}` has an unknown unit; write bytes or a number with K, M, G or T (e.g. 512M, 8G)"))
        }
    };
    let n: f64 = number.parse().map_err(|_| format!("`{s}` is not a size; write e.g. 512M, 8G or 1073741824"))?;
    let bytes = n * (1u64 << shift) as f64;
    if !(1.0..1.8e19).contains(&bytes) {
        return Err(format!("`{s}` is outside 1 byte ..= 16E; write e.g. 512M or 8G"));
    }
    Ok(bytes as u64)
}

/// `1536` → `1.5 KiB`; binary units, three significant digits.
pub fn format_bytes(bytes: u64) -> String {
    const UNITS: [&str; 6] = ["B", "KiB", "MiB", "GiB", "TiB", "PiB"];
    let mut v = bytes as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{bytes} B")
    } else {
        format!("{v:.1} {}", UNITS[u])
    }
}

/// Width and height given on the command line are checked here, where the pipeline's other side is
/// known, so the message blames the flags rather than a line of the pipeline file.
fn check_pixel_count(ov: &Overrides, width: u32, height: u32) -> Result<(), WedgeError> {
    let pixels = u64::from(width) * u64::from(height);
    if (ov.width.is_none() && ov.height.is_none()) || pixels <= wedge_graph::MAX_PIXELS {
        return Ok(());
    }
    let side = |flag: &str, given: Option<u32>, v: u32| match given {
        Some(_) => format!("--{flag} {v}"),
        None => format!("the pipeline's {flag} {v}"),
    };
    Err(WedgeError::Usage(format!(
        "{} × {} = {pixels} pixels is more than the limit of {} (2^26); lower --width/--height",
        side("width", ov.width, width),
        side("height", ov.height, height),
        wedge_graph::MAX_PIXELS
    )))
}

/// Apply `--mu` and per-node parameter overrides, checked against each node's declarations.
fn apply_param_overrides(p: &mut ValidatedPipeline, ov: &Overrides) -> Result<(), WedgeError> {
    let mut sets: Vec<(Option<&str>, &str, ParamValue)> = Vec::new();
    if let Some(mu) = ov.mu {
        sets.push((None, "mu", ParamValue::Float(mu)));
    }
    for (node, name, v) in &ov.params {
        sets.push((Some(node.as_str()), name.as_str(), v.clone()));
    }
    for (node, name, value) in sets {
        // The flag as the user wrote it, to blame it in a message.
        let flag = node.map_or_else(|| "--mu".to_string(), |n| format!("--set {n}.{name}"));
        if let Some(want) = node.filter(|want| p.node(want).is_none()) {
            return Err(unknown_node(p, &flag, want));
        }
        let mut applied = false;
        for n in p.nodes.iter_mut().filter(|n| node.is_none_or(|want| n.name == want)) {
            if let Some(decl) = n.kind.params().into_iter().find(|d| d.name == name) {
                // `--set` names its node; `--mu` reaches every node with a `mu`, so say which one.
                let whose = if node.is_some() { String::new() } else { format!(" for node `{}`", n.name) };
                let v = decl.check(&value).map_err(|e| WedgeError::Usage(format!("{flag}{whose}: {e}")))?;
                n.params.insert(name.to_string(), v);
                applied = true;
            }
        }
        if !applied {
            return Err(unknown_param(p, &flag, node, name));
        }
    }
    Ok(())
}

/// `--set NODE.…` naming no node of `p`: the closest name and the list.
fn unknown_node(p: &ValidatedPipeline, flag: &str, want: &str) -> WedgeError {
    let names: Vec<&str> = p.nodes.iter().map(|n| n.name.as_str()).collect();
    WedgeError::Usage(format!(
        "{flag}: node `{want}` does not exist in {}; {}its nodes are: {}",
        p.path.display(),
        wedge_graph::suggestion(want, names.iter().copied()),
        names.join(", ")
    ))
}

/// A parameter that `node` (or, for `--mu`, every node) does not declare: the closest name and the
/// node's parameters.
fn unknown_param(p: &ValidatedPipeline, flag: &str, node: Option<&str>, name: &str) -> WedgeError {
    WedgeError::Usage(match node.and_then(|want| p.node(want)) {
        Some(n) => {
            let params = n.kind.params();
            let names: Vec<&str> = params.iter().map(|d| d.name).collect();
            format!(
                "{flag}: node `{}` (kind {}) has no parameter `{name}`; {}its parameters are: {}",
                n.name,
                n.kind.kind(),
                wedge_graph::suggestion(name, names.iter().copied()),
                names.join(", ")
            )
        }
        None => format!("{flag}: no node in {} declares parameter `{name}`", p.path.display()),
    })
}

/// `builtin:NAME` or a built-in's bare name → built-in; anything else is a file path. Pipeline scene
/// paths are relative to the pipeline file, command-line ones to the working directory.
pub fn scene_source(p: &ValidatedPipeline, cli: Option<&str>) -> SceneSource {
    let (spec, base) = match cli {
        Some(s) => (s.to_string(), PathBuf::from(".")),
        None => (p.pipeline.scene.clone(), p.base_dir()),
    };
    if let Some(name) = spec.strip_prefix("builtin:") {
        return SceneSource::Builtin(name.to_string());
    }
    if cli.is_some() && wedge_scene::builtin_names().contains(&spec.as_str()) {
        return SceneSource::Builtin(spec);
    }
    SceneSource::File(base.join(spec))
}

/// The pipeline's camera block over the scene's camera `scene` (which keeps its shutter where the
/// block gives none).
pub fn camera_from_spec(c: &wedge_graph::CameraSpec, scene: &Camera) -> Camera {
    let v = |t: (f32, f32, f32)| glam::Vec3::new(t.0, t.1, t.2);
    let position = v(c.position);
    let look_at = v(c.look_at);
    Camera {
        position,
        look_at,
        up: v(c.up),
        vfov_deg: c.vfov_deg,
        aperture_radius: c.aperture_radius,
        focus_distance: c.focus_distance.unwrap_or((look_at - position).length()),
        shutter_open: c.shutter.map_or(scene.shutter_open, |s| s.0),
        shutter_close: c.shutter.map_or(scene.shutter_close, |s| s.1),
    }
}

/// The block `c` with the view of the scene's camera `scene` ([`Overrides::scene_camera`]): its
/// position, look-at, up and field of view; its lens where it has one (a suite scene states its
/// lens), else the block's; the block's shutter.
fn scene_view(c: &wedge_graph::CameraSpec, scene: &Camera) -> wedge_graph::CameraSpec {
    let own = spec_of_camera(scene, c.shutter);
    if scene.aperture_radius > 0.0 {
        return own;
    }
    wedge_graph::CameraSpec { aperture_radius: c.aperture_radius, focus_distance: c.focus_distance, ..own }
}

/// `camera` as a pipeline's `camera:` block with `shutter` (the inverse of [`camera_from_spec`]).
fn spec_of_camera(camera: &Camera, shutter: Option<(f32, f32)>) -> wedge_graph::CameraSpec {
    let t = |v: glam::Vec3| (v.x, v.y, v.z);
    wedge_graph::CameraSpec {
        position: t(camera.position),
        look_at: t(camera.look_at),
        up: t(camera.up),
        vfov_deg: camera.vfov_deg,
        aperture_radius: camera.aperture_radius,
        focus_distance: Some(camera.effective_focus_distance()),
        shutter,
    }
}

/// Re-running only what a change touches (issue 38, `wedge view`).
impl Session {
    /// Frame `frame` of a progressive render ([`Session::run_progressive_frame`], no history) on
    /// `backend` (the CPU's or the wgpu one), running only the passes `rerun` marks (all when it is
    /// `None`) and taking the others' outputs from `kept`, an earlier such run's buffers of the same
    /// scene, camera, size, seed and frame ([`wedge_graph::Schedule::changed_since`] says which
    /// passes that leaves to run). The image is the whole run's bit for bit; the run's buffers come
    /// back for the next change.
    pub fn run_partial_frame<B: wedge_backends::PartialRun>(
        &self,
        backend: &mut B,
        progress: &dyn Progress,
        frame: u32,
        kept: &B::Kept,
        rerun: Option<&[bool]>,
    ) -> Result<(RunResult, B::Kept), WedgeError> {
        let job = self.job(self.seed.wrapping_add(frame), frame, progress);
        let (mut run, buffers) = backend.run_partial(&job, &BTreeMap::new(), kept, rerun.unwrap_or(&[]))?;
        run.sinks = self.sink_nodes();
        Ok((run, buffers))
    }

    /// Peak memory of `wedge view` in `mode`: a frame's run as [`Session::memory_estimate`], plus
    /// what a partial re-run keeps across frames when `keep` is set: a first frame's buffers, every
    /// one of the schedule unpooled, and beside them the next change's re-run writing new ones (at
    /// most as many again) until it replaces them. On the CPU the backend's persistent pool is the
    /// run's pool, already counted; on the wgpu backend the kept buffers are device memory, counted
    /// as the pool is (a software adapter takes it from the same RAM).
    pub fn view_memory_estimate(&self, mode: RunMode, keep: bool) -> MemoryEstimate {
        let run = self.memory_estimate(mode);
        let kept =
            if keep { self.schedule.buffer_bytes(self.width, self.height).unpooled.saturating_mul(2) } else { 0 };
        MemoryEstimate { buffers: run.buffers.saturating_add(kept), ..run }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_reads_three_numbers_as_a_colour_and_anything_else_as_before() {
        let value = |s: &str| parse_set(s).unwrap().2;
        assert_eq!(value("fog.colour=0.5,0.6,0.7"), ParamValue::Vec3([0.5, 0.6, 0.7]));
        assert_eq!(value("fog.colour=(1, 0, 2e-1)"), ParamValue::Vec3([1.0, 0.0, 0.2]));
        assert_eq!(value("fog.colour=0.5,0.6"), ParamValue::Str("0.5,0.6".into()));
        assert_eq!(value("shadows.mu=2"), ParamValue::Int(2));
        assert_eq!(value("env.map=builtin:sky"), ParamValue::Str("builtin:sky".into()));
    }

    #[test]
    fn frame_placeholders_are_replaced_and_malformed_ones_named() {
        assert_eq!(frame_path("cam_{frame:04}.exr", 7).unwrap(), "cam_0007.exr");
        assert_eq!(frame_path("f{frame}/p_{frame:02}.exr", 123).unwrap(), "f123/p_123.exr");
        assert_eq!(frame_path("still.exr", 9).unwrap(), "still.exr");
        for bad in
            ["cam_{frame.exr", "cam_{frame:4}.exr", "cam_{frame:0}.exr", "cam_{frame:0x}.exr", "cam_{frames}.exr"]
        {
            let e = frame_path(bad, 1).unwrap_err();
            assert!(e.contains(bad) && e.contains("{frame:0"), "{bad}: {e}");
        }
    }

    #[test]
    fn shadows_estimate_at_640x480_equals_the_hand_count() {
        let ov = Overrides { width: Some(640), height: Some(480), ..Overrides::default() };
        let s = Session::open(None, &ov).unwrap();
        let px = 640 * 480u64;
        // From `wedge graph pipelines/shadows.ron` (SoftShadows on the shared sampler, analytic
        // irradiance): 17 slots = 5 vec4 (16 B) + 4 vec3 (12 B) + 6 scalar (4 B) + 2 PathRecord
        // (109 words, 436 B, the near layer's 5 included) = 1024 B/px; the largest pass output is
        // one record (436 B/px); sinks filter_width, rays_per_pixel (4 B) + radiance, unfiltered
        // (12 B) = 32 B/px; all 23 buffers unpooled (11 vec4, 4 vec3, 6 scalar, 2 records) = 1120
        // B/px; the widest pass binds two records and two u32 counts (sampler.adaptive) = 880 B/px.
        let b = s.schedule.buffer_bytes(640, 480);
        assert_eq!(
            b,
            BufferBytes {
                pool: 1024 * px,
                pass_outputs: 436 * px,
                sinks: 32 * px,
                unpooled: 1120 * px,
                pass_bindings: 880 * px,
                history: 0
            }
        );
        assert_eq!(s.schedule.peak_bytes(640, 480), 1492 * px);
        assert_eq!(s.schedule.peak_bytes(640, 480), 458_342_400);
        let cpu = s.memory_estimate(RunMode::Cpu);
        assert_eq!(cpu.buffers, 1492 * px);
        assert_eq!(cpu.images, 15 * px);
        assert_eq!(cpu.scene, scene_bytes(&s.scene));
        assert!(cpu.scene > 7660 * 32, "grids has 7660 triangles: {}", cpu.scene);
        assert_eq!(s.memory_estimate(RunMode::Gpu).scene, 2 * cpu.scene);
        assert_eq!(s.memory_estimate(RunMode::Parity).buffers, (1120 + 436 + 880) * px);
    }

    /// A sequence holds one frame's run, the previous run (sinks + history) and the frame being
    /// written: environment_temporal.ron has history, and its estimate does not depend on a frame count.
    #[test]
    fn sequence_estimate_adds_the_previous_run_and_one_streamed_frame() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines/environment_temporal.ron");
        let ov = Overrides { width: Some(64), height: Some(48), ..Overrides::default() };
        let s = Session::open(Some(&path), &ov).unwrap();
        let b = s.schedule.buffer_bytes(64, 48);
        assert!(b.history > 0, "environment_temporal.ron keeps previous-frame buffers");
        let (one, seq) = (s.memory_estimate(RunMode::Cpu), s.sequence_memory_estimate(RunMode::Cpu));
        assert_eq!(seq.buffers, one.buffers + b.sinks + b.history);
        assert_eq!(seq.images, one.images + 16 * 64 * 48);
        assert_eq!(seq.scene, one.scene);
    }

    /// The environment map's arrays count: `envmap` carries `builtin:sky` (512 × 256 texels, ≥ 20 bytes
    /// each on the CPU: RGB and a CDF entry).
    #[test]
    fn scene_bytes_count_the_environment_map() {
        let mut scene = wedge_scene::load(&SceneSource::Builtin("envmap".into())).unwrap();
        let env = scene.environment.clone().unwrap();
        let with = scene_bytes(&scene);
        scene.set_environment(None);
        assert_eq!(with - scene_bytes(&scene), env.bytes());
        assert!(env.bytes() >= 20 * 512 * 256, "{}", env.bytes());
    }

    #[test]
    fn over_budget_names_estimate_limit_and_fix() {
        let e = MemoryEstimate { buffers: 3 << 30, scene: 1 << 20, images: 0 };
        assert!(e.check(4 << 30, "--memory-limit").is_ok());
        let msg = e.check(1 << 30, "--memory-limit").unwrap_err().to_string();
        for needle in ["3.0 GiB", "1.0 GiB (--memory-limit)", "--width/--height", "--memory-limit SIZE"] {
            assert!(msg.contains(needle), "{needle:?} in {msg}");
        }
    }

    #[test]
    fn sizes_parse_with_binary_units() {
        assert_eq!(parse_size("1048576"), Ok(1 << 20));
        assert_eq!(parse_size("512M"), Ok(512 << 20));
        assert_eq!(parse_size("8G"), Ok(8 << 30));
        assert_eq!(parse_size("8GiB"), Ok(8 << 30));
        assert_eq!(parse_size("1.5k"), Ok(1536));
        assert_eq!(parse_size("2TB"), Ok(2 << 40));
        for bad in ["", "G", "-1", "0", "8X", "1e3", "nan", "99999999999T"] {
            assert!(parse_size(bad).is_err(), "{bad:?}");
        }
        for negative in ["-5M", " -1", "-0.5G"] {
            let e = parse_size(negative).unwrap_err();
            assert!(e.contains("is negative; a size must be positive") && !e.contains("unit"), "{negative:?}: {e}");
        }
        assert_eq!(format_bytes(512), "512 B");
        assert_eq!(format_bytes(1536), "1.5 KiB");
        assert_eq!(format_bytes(74_956_800), "71.5 MiB");
    }

    #[test]
    fn default_limit_is_three_quarters_of_available_memory() {
        if let Ok(text) = std::fs::read_to_string("/proc/meminfo") {
            assert!(text.contains("MemAvailable"));
            let kib: u64 = text
                .lines()
                .find_map(|l| l.strip_prefix("MemAvailable:"))
                .and_then(|v| v.split_whitespace().next())
                .and_then(|v| v.parse().ok())
                .unwrap();
            // Memory moves between the two reads: allow 64 MiB of drift.
            let expected = kib * 1024 / 4 * 3;
            let limit = default_memory_limit().expect("readable on Linux");
            assert!(limit.abs_diff(expected) < 64 << 20, "{limit} vs {expected}");
        }
    }

    #[test]
    fn too_many_pixels_from_the_flags_blame_the_flags() {
        let ov = Overrides { width: Some(16384), ..Overrides::default() };
        let ov_both = Overrides { height: Some(16384), ..ov.clone() };
        let msg = Session::open(None, &ov_both).err().unwrap().to_string();
        assert!(msg.contains("--width 16384 × --height 16384") && msg.contains("2^26"), "{msg}");
        let text = DEFAULT_PIPELINE.replace("height: 480", "height: 16384");
        let loaded = parse_pipeline(Path::new("p.ron"), &text).unwrap();
        let (nodes, kernels) = wedge_effects::builtin();
        let msg = Session::build(loaded, &ov, nodes, kernels).err().unwrap().to_string();
        assert!(msg.contains("--width 16384 × the pipeline's height 16384"), "{msg}");
    }

    /// `wedge view` keeps a first frame's buffers (every one unpooled) and, during a change's first
    /// frame, the re-run's new ones beside them: two unpooled sets on top of a run; none without keeping.
    #[test]
    fn view_estimate_adds_two_unpooled_sets_when_keeping() {
        let ov = Overrides { width: Some(64), height: Some(48), ..Overrides::default() };
        let s = Session::open(None, &ov).unwrap();
        let unpooled = s.schedule.buffer_bytes(64, 48).unpooled;
        for mode in [RunMode::Cpu, RunMode::Gpu] {
            let run = s.memory_estimate(mode);
            assert_eq!(s.view_memory_estimate(mode, false), run);
            assert_eq!(
                s.view_memory_estimate(mode, true),
                MemoryEstimate { buffers: run.buffers + 2 * unpooled, ..run }
            );
        }
    }
}
