//! The fuzz targets: each takes arbitrary bytes, feeds them to one of wedge's input readers the way
//! the `wedge` CLI would, and returns the reader's error text (`Err`) or `Ok(())`. A target must
//! never panic, hang or exhaust memory; the driver treats each of those as a crasher. The `Err`
//! text doubles as a cheap novelty signal for the driver (a new kind of error keeps the input).
//!
//! File-based readers get their input written to a per-thread temporary directory (`scene.gltf`,
//! `scene.glb`, `scene.obj` + `scene.mtl`, `image.exr`), next to fixed companions that seed inputs
//! may reference: `buffer.bin` (glTF buffer data) and `tex.png` (a 2×2 texture).

use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use wedge_graph::NodeRegistry;
use wedge_scene::SceneSource;

/// A fuzz target: its name (as given on the command line), the function, and the file extension
/// used for its crasher files.
#[derive(Clone, Copy)]
pub struct Target {
    pub name: &'static str,
    pub run: fn(&[u8]) -> Result<(), String>,
    pub ext: &'static str,
    /// Whether inputs are text (token-level mutations apply) or binary.
    pub text: bool,
}

/// Every target, in the order `--all` runs them.
pub const TARGETS: &[Target] = &[
    Target { name: "pipeline", run: pipeline, ext: "ron", text: true },
    Target { name: "gltf", run: gltf, ext: "gltf", text: true },
    Target { name: "glb", run: glb, ext: "glb", text: false },
    Target { name: "obj", run: obj, ext: "obj", text: true },
    Target { name: "exr", run: exr, ext: "exr", text: false },
    Target { name: "camera_path", run: camera_path, ext: "ron", text: true },
    Target { name: "set", run: set, ext: "txt", text: true },
];

/// The target called `name`.
pub fn by_name(name: &str) -> Option<Target> {
    TARGETS.iter().copied().find(|t| t.name == name)
}

/// Separates the OBJ part of an `obj` input from the MTL written beside it.
pub const MTL_MARKER: &[u8] = b"\n#--- scene.mtl ---\n";

fn registry() -> &'static NodeRegistry {
    static REGISTRY: OnceLock<NodeRegistry> = OnceLock::new();
    REGISTRY.get_or_init(|| wedge_effects::builtin().0)
}

/// Pipeline text → parse → validate (wedge's built-in nodes) → expand → schedule, as `wedge render`
/// does before loading the scene. Invalid UTF-8 is replaced rather than rejected so mutations keep
/// exercising the parser.
pub fn pipeline(data: &[u8]) -> Result<(), String> {
    let text = String::from_utf8_lossy(data);
    let path = Path::new("fuzz.ron");
    let run = || -> Result<(), wedge_graph::GraphError> {
        let loaded = wedge_graph::parse_pipeline(path, &text)?;
        let validated = wedge_graph::validate(&loaded, registry())?;
        let expansion = wedge_graph::expand(&validated)?;
        let schedule = wedge_graph::schedule(expansion)?;
        // What `wedge graph` prints, so the formatting is exercised too.
        std::hint::black_box(format!("{schedule:?}"));
        Ok(())
    };
    run().map_err(|e| e.to_string())
}

/// Pipeline text with a `camera_path` → parse → validate. Where validation accepts the path, every
/// camera along it must pass the camera rules the validator holds a `camera:` block to (the view
/// rules; `up` only where a camera block gives it, as validation does) at a sampled set of frames —
/// the keys, their neighbours, the midpoints and fractions between them, and the far ends — each
/// camera interpolated by [`wedge_graph::camera_path_at`], the renderer's function. A violation
/// panics: the validator let a path through that renders a degenerate camera.
pub fn camera_path(data: &[u8]) -> Result<(), String> {
    let text = String::from_utf8_lossy(data);
    let loaded = wedge_graph::parse_pipeline(Path::new("fuzz.ron"), &text).map_err(|e| e.to_string())?;
    let validated = wedge_graph::validate(&loaded, registry()).map_err(|e| e.to_string())?;
    let keys = &validated.pipeline.camera_path;
    let (camera, check_up) = match &validated.pipeline.camera {
        Some(c) => (c.clone(), true),
        None => (
            wedge_graph::CameraSpec {
                position: (0.0, 0.0, 1.0),
                look_at: (0.0, 0.0, 0.0),
                up: (0.0, 1.0, 0.0),
                vfov_deg: 45.0,
                aperture_radius: 0.0,
                focus_distance: None,
                shutter: None,
            },
            false,
        ),
    };
    for frame in sampled_frames(keys) {
        let Some((position, look_at)) = wedge_graph::camera_path_at(keys, frame) else { continue };
        let cam = wedge_graph::CameraSpec { position, look_at, ..camera.clone() };
        let broken: Vec<_> = cam
            .problems()
            .into_iter()
            .filter(|p| matches!(p.field, "position" | "look_at") || (check_up && p.field == "up"))
            .collect();
        assert!(
            broken.is_empty(),
            "validation accepted a camera path whose frame {frame} breaks a camera rule: {}",
            broken[0].message
        );
    }
    Ok(())
}

/// Frames to check along a path: each key and its neighbours, and 1/8 steps between two keys.
fn sampled_frames(keys: &[wedge_graph::CameraKey]) -> Vec<u32> {
    let mut frames = vec![0, u32::MAX];
    for k in keys {
        frames.extend([k.frame.saturating_sub(1), k.frame, k.frame.saturating_add(1)]);
    }
    for w in keys.windows(2) {
        let (a, b) = (u64::from(w[0].frame), u64::from(w[1].frame));
        frames.extend((1..8u64).map(|i| (a + (b.saturating_sub(a)) * i / 8) as u32));
    }
    frames
}

/// Lines of `--set NODE.PARAM=VALUE` (at most 8) parsed as the CLI does ([`wedge::session::parse_set`])
/// and applied to a small pipeline (a SoftShadows node on `builtin:cornell`) by building its session.
/// Each must give an error or a value its parameter's declaration accepts.
pub fn set(data: &[u8]) -> Result<(), String> {
    const PIPELINE: &str = r#"Pipeline(scene: "builtin:cornell", width: 8, height: 6, nodes: [
        (name: "primary", kind: "Primary"),
        (name: "shadows", kind: "SoftShadows", inputs: {"position": "primary.position", "normal": "primary.normal", "albedo": "primary.albedo", "emission": "primary.emission"}),
        (name: "out", kind: "Output", inputs: {"color": "shadows.radiance"}),
    ])"#;
    let text = String::from_utf8_lossy(data);
    let params = text
        .lines()
        .take(8)
        .map(wedge::session::parse_set)
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| e.to_string())?;
    let loaded = wedge_graph::parse_pipeline(Path::new("fuzz.ron"), PIPELINE).map_err(|e| e.to_string())?;
    let (nodes, kernels) = wedge_effects::builtin();
    let ov = wedge::Overrides { params: params.clone(), ..Default::default() };
    let session = wedge::Session::build(loaded, &ov, nodes, kernels).map_err(|e| e.to_string())?;
    for (node, name, _) in &params {
        let n = session
            .pipeline
            .node(node)
            .unwrap_or_else(|| panic!("--set {node}.{name} was accepted but there is no node `{node}`"));
        let decl = n
            .kind
            .params()
            .into_iter()
            .find(|d| d.name == name)
            .unwrap_or_else(|| panic!("--set {node}.{name} was accepted but `{node}` declares no `{name}`"));
        let value = n
            .params
            .get(name)
            .unwrap_or_else(|| panic!("--set {node}.{name} was accepted but the node has no value for it"));
        assert!(decl.check(value).is_ok(), "--set {node}.{name} left the value {value}, which its declaration refuses");
    }
    Ok(())
}

/// A `.gltf` scene file.
pub fn gltf(data: &[u8]) -> Result<(), String> {
    load_scene("scene.gltf", data)
}

/// A `.glb` scene file.
pub fn glb(data: &[u8]) -> Result<(), String> {
    load_scene("scene.glb", data)
}

/// An OBJ file and, after [`MTL_MARKER`], the `scene.mtl` beside it (empty if there is no marker).
pub fn obj(data: &[u8]) -> Result<(), String> {
    let (obj, mtl) = match find(data, MTL_MARKER) {
        Some(i) => (&data[..i], &data[i + MTL_MARKER.len()..]),
        None => (data, &[][..]),
    };
    write_file("scene.mtl", mtl);
    load_scene("scene.obj", obj)
}

/// An EXR image read with `wedge::image::read_exr`, the reader behind `wedge compare`.
pub fn exr(data: &[u8]) -> Result<(), String> {
    let path = write_file("image.exr", data);
    wedge::image::read_exr(&path)
        .map(|img| {
            std::hint::black_box(img.pixels.len());
        })
        .map_err(|e| e.to_string())
}

/// The shutter scene files are loaded at (as a pipeline camera with a shutter would), so glTF
/// animations become motion and reach the motion code (rigidity checks, instances, swept bounds).
pub const SHUTTER: (f32, f32) = (0.25, 0.75);

fn load_scene(name: &str, data: &[u8]) -> Result<(), String> {
    let path = write_file(name, data);
    let opts = wedge_scene::LoadOptions::default();
    wedge_scene::load_with_shutter(&SceneSource::File(path), &opts, Some(SHUTTER))
        .map(|scene| {
            std::hint::black_box(scene.triangle_count());
            // Trace one ray at a time of the shutter through any moving instance.
            let c = scene.bounds.centre();
            let hit = scene.at(0.3).intersect(c + wedge_scene::Vec3::Y, -wedge_scene::Vec3::Y, 0.0, f32::INFINITY);
            std::hint::black_box(hit);
        })
        .map_err(|e| e.to_string())
}

fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

thread_local! {
    static DIR: RefCell<Option<tempfile::TempDir>> = const { RefCell::new(None) };
}

/// The per-thread scratch directory, created with its companion files on first use.
pub fn scratch_dir() -> PathBuf {
    DIR.with(|d| {
        let mut d = d.borrow_mut();
        if d.is_none() {
            let dir = tempfile::Builder::new()
                .prefix("wedge-fuzz-")
                .tempdir()
                .expect("cannot create a temporary directory for fuzz inputs");
            std::fs::write(dir.path().join("buffer.bin"), crate::seeds::gltf_buffer())
                .expect("cannot write fuzz companion file");
            std::fs::write(dir.path().join("tex.png"), crate::seeds::tiny_png())
                .expect("cannot write fuzz companion file");
            *d = Some(dir);
        }
        d.as_ref().unwrap().path().to_path_buf()
    })
}

fn write_file(name: &str, data: &[u8]) -> PathBuf {
    let path = scratch_dir().join(name);
    std::fs::write(&path, data).expect("cannot write a fuzz input to the temporary directory");
    path
}
