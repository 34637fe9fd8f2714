//! A session: a validated pipeline, its schedule and its loaded scene, with the command-line
//! overrides applied — everything `wedge render`, `reference`, `graph` and the tests share.

use std::path::{Path, PathBuf};

use wedge_backends::{Backend, BackendError, Job, KernelRegistry, Progress, RunResult};
use wedge_graph::{
    expand, parse_pipeline, schedule, validate, GraphError, LoadedPipeline, NodeRegistry, ParamValue, Schedule,
    ValidatedPipeline,
};
use wedge_scene::{Camera, Scene, SceneError, SceneSource};

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
    /// Let the scene file read buffers/textures/meshes outside its own directory.
    pub allow_outside_scene_dir: bool,
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
}

/// Read a pipeline file, or the built-in default when `path` is `None`.
pub fn load_pipeline_or_default(path: Option<&Path>) -> Result<LoadedPipeline, GraphError> {
    match path {
        Some(p) => wedge_graph::load_pipeline(p),
        None => parse_pipeline(Path::new(DEFAULT_PIPELINE_NAME), DEFAULT_PIPELINE),
    }
}

impl Session {
    /// Load `path` (or the default pipeline) with wedge's own nodes and kernels.
    pub fn open(path: Option<&Path>, ov: &Overrides) -> Result<Session, WedgeError> {
        let (nodes, kernels) = wedge_effects::builtin();
        Session::build(load_pipeline_or_default(path)?, ov, nodes, kernels)
    }

    /// The plain stratified (or independent) Monte Carlo reference for the pipeline at `path`:
    /// same scene, camera, size and seed; every area light sampled `spp` times per pixel; no filter.
    pub fn reference(path: Option<&Path>, spp: u32, sampling: &str, ov: &Overrides) -> Result<Session, WedgeError> {
        let (nodes, kernels) = wedge_effects::builtin();
        let original = load_pipeline_or_default(path)?;
        let p = &original.pipeline;
        // A pipeline with an `Indirect` node gets a reference with the same indirect light: its
        // bounces, mode (radiance or AO), AO distance and glossy lobe, path-traced at `spp`.
        let validated = validate(&original, &nodes)?;
        let indirect = validated.nodes.iter().find(|n| n.kind.kind() == "Indirect").map(|n| IndirectSpec {
            bounces: match n.params.get("bounces") {
                Some(ParamValue::Int(b)) => *b,
                _ => 1,
            },
            ao: matches!(n.params.get("mode"), Some(ParamValue::Str(m)) if m == "ao"),
            max_distance: match n.params.get("max_distance") {
                Some(ParamValue::Float(d)) => *d,
                _ => 0.0,
            },
            brdf: match n.params.get("brdf") {
                Some(ParamValue::Str(b)) => b.clone(),
                _ => "phong".into(),
            },
        });
        let text = reference_pipeline_text(&p.scene, p.width, p.height, p.seed, spp, sampling, indirect.as_ref());
        let mut loaded = parse_pipeline(&original.path, &text)?;
        loaded.pipeline.camera = p.camera.clone();
        Session::build(loaded, ov, nodes, kernels)
    }

    /// The general constructor: a user crate passes registries extended with its own nodes/kernels.
    pub fn build(
        mut loaded: LoadedPipeline,
        ov: &Overrides,
        nodes: NodeRegistry,
        kernels: KernelRegistry,
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
        let mut pipeline = validate(&loaded, &nodes)?;
        apply_param_overrides(&mut pipeline, ov)?;
        let schedule = schedule(expand(&pipeline)?)?;
        let source = scene_source(&pipeline, ov.scene.as_deref());
        let scene_opts = wedge_scene::LoadOptions { allow_outside_scene_dir: ov.allow_outside_scene_dir };
        let mut scene = wedge_scene::load_with(&source, &scene_opts)?;
        if let Some(c) = &pipeline.pipeline.camera {
            scene.camera = camera_from_spec(c);
        }
        let (width, height, seed) = (pipeline.pipeline.width, pipeline.pipeline.height, pipeline.pipeline.seed);
        Ok(Session { pipeline, schedule, scene, nodes, kernels, width, height, seed })
    }

    pub fn run(&self, backend: &mut dyn Backend, progress: &dyn Progress) -> Result<RunResult, WedgeError> {
        let job = Job {
            schedule: &self.schedule,
            scene: &self.scene,
            kernels: &self.kernels,
            width: self.width,
            height: self.height,
            seed: self.seed,
            progress,
        };
        Ok(backend.run(&job)?)
    }
}

/// The indirect light a reference must include (from the pipeline's `Indirect` node).
struct IndirectSpec {
    bounces: i64,
    ao: bool,
    max_distance: f64,
    brdf: String,
}

fn reference_pipeline_text(
    scene: &str,
    width: u32,
    height: u32,
    seed: u32,
    spp: u32,
    sampling: &str,
    indirect: Option<&IndirectSpec>,
) -> String {
    let (extra_params, extra_inputs) = match indirect {
        None => (String::new(), String::new()),
        Some(i) => (
            format!(
                r#", "bounces": {}, "mode": {:?}, "max_distance": {:?}, "brdf": {:?}"#,
                i.bounces,
                if i.ao { "ao" } else { "radiance" },
                i.max_distance,
                i.brdf
            ),
            r#", "specular": "primary.specular""#.to_string(),
        ),
    };
    format!(
        r#"Pipeline(
    scene: {scene:?}, width: {width}, height: {height}, seed: {seed},
    nodes: [
        (name: "primary", kind: "Primary"),
        (name: "reference", kind: "MonteCarlo", params: {{"spp": {spp}, "sampling": {sampling:?}, "light": -1{extra_params}}},
         inputs: {{"position": "primary.position", "normal": "primary.normal",
                   "albedo": "primary.albedo", "emission": "primary.emission"{extra_inputs}}}),
        (name: "out", kind: "Output", inputs: {{"color": "reference.radiance"}}),
    ],
)"#
    )
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
        let mut applied = false;
        for n in p.nodes.iter_mut().filter(|n| node.is_none_or(|want| n.name == want)) {
            if let Some(decl) = n.kind.params().into_iter().find(|d| d.name == name) {
                let v = decl.check(&value).map_err(|e| WedgeError::Usage(format!("--{name} for node `{}`: {e}", n.name)))?;
                n.params.insert(name.to_string(), v);
                applied = true;
            }
        }
        if !applied {
            return Err(WedgeError::Usage(format!(
                "no node in {} declares parameter `{name}`{}",
                p.path.display(),
                node.map(|n| format!(" (looked in `{n}`)")).unwrap_or_default()
            )));
        }
    }
    Ok(())
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

pub fn camera_from_spec(c: &wedge_graph::CameraSpec) -> Camera {
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
    }
}
