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
    Target {
        name: "pipeline",
        run: pipeline,
        ext: "ron",
        text: true,
    },
    Target {
        name: "gltf",
        run: gltf,
        ext: "gltf",
        text: true,
    },
    Target {
        name: "glb",
        run: glb,
        ext: "glb",
        text: false,
    },
    Target {
        name: "obj",
        run: obj,
        ext: "obj",
        text: true,
    },
    Target {
        name: "exr",
        run: exr,
        ext: "exr",
        text: false,
    },
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
