//! # wedge-scene
//!
//! Scenes for wedge's sample-and-filter renderer: everything a pass needs to trace rays and shade hits,
//! laid out so the CPU reference and the GPU kernels read the same arrays.
//!
//! - **Geometry**: world-space triangles ([`TriangleRecord`]: `v0, v1, v2` for the watertight test of
//!   Woop, Benthin and Wald 2013) in BVH leaf order, plus per-triangle shading data
//!   ([`TriangleShading`]) in the same order.
//! - **BVH**: built once per scene with obvhs (PLOC, `fast_build`), collapsed to 8-wide 256-byte
//!   [`WideNode`]s. [`Scene::intersect`] / [`Scene::occluded`] traverse it with a SIMD slab test per node
//!   ([`bvh`]); the WGSL kernel traverses the same nodes, and the closest hit is defined so that any
//!   traversal order gives the same one (CPU and GPU agree); obvhs's own traversal is not used.
//! - **Lights**: emissive triangles become [`AreaLight`]s; a pair forming a parallelogram merges into one
//!   rectangle (the thesis's soft-shadow case). Each light provides uniform sampling, its footprint σ for
//!   the filter bandwidth, and exact unoccluded irradiance (useful for shadow-ratio shading and tests).
//! - **Materials/textures**: Lambertian base colour (optionally textured, linear RGB), Phong k_s/m, emission.
//! - **Motion** ([`motion`], issue 13): named objects ([`Scene::objects`]) may move rigidly over the
//!   shutter ([`RigidMotion`], `t ∈ [−1, 1]`); moving groups are instances with their own trees after the
//!   static one, and [`Scene::at`] gives rays, surfaces, lights and velocities at any time ([`SceneAt`];
//!   the time-less queries mean `t = 0`). glTF animations are sampled at the camera's shutter, `.ron`
//!   meshes take a `motion` block, [`Scene::set_motion`] moves any object by name.
//! - **Environment** ([`environment`], issue 14): a lat-long [`EnvironmentMap`] (EXR, HDR, or the
//!   procedural `builtin:sky`/`builtin:studio`) lights the scene from infinity
//!   ([`Scene::set_environment`], [`Scene::background`] for rays that miss): piecewise-constant radiance,
//!   importance sampling with its pdf, the thesis's 4096-sample table, and its bandwidth `B_e`.
//! - **Real layer** ([`real_layer`], issue 15): for mixed reality, the captured real world per pixel of
//!   a camera image — the image `L_cam`, world position with coverage, normal, diffuse albedo
//!   ([`RealLayer`], [`Scene::set_real`]), from EXR/PNG files or a wedge render's AOVs.
//! - **Sources** ([`load`]): built-ins (`grids`, `curved`, `heavy`, `cornell`, `chess`, `spheres`, `motion`, `envmap`, `envmap_real`, `envmap_virtual`, `envmap_far`, the scene suite `suite_*`, see [`builtin`]), glTF, OBJ/MTL, and a
//!   `.ron` composition file ([`compose`]). Bad input yields a [`SceneError`] naming the file, the problem
//!   (with the glTF JSON path or OBJ line where there is one) and the fix — never a panic, a hang or an
//!   unbounded allocation: inputs are validated before use and sizes are capped ([`limits`]). Files a
//!   scene references must lie under the scene file's directory unless [`LoadOptions`] allows more
//!   ([`Confinement`]: the rule a pipeline's files follow too).
//!   Recoverable oddities (unknown `usemtl`, dropped degenerate triangles) become [`Scene::warnings`].
//!
//! Conventions: right-handed, y up, metres; image y points down; textures have v = 0 at the top row.

pub mod builtin;
pub mod bvh;
pub mod camera;
pub mod compose;
mod data;
pub mod environment;
pub mod error;
pub mod light;
pub mod load_gltf;
pub mod load_obj;
pub mod motion;
pub mod real_layer;
mod resource;
pub mod scene;
pub mod texture;

use std::path::{Path, PathBuf};

pub use glam::{Quat, Vec2, Vec3};

pub use bvh::{Hit, TriangleRecord, WideNode, NO_LIGHT};
pub use camera::{Camera, CameraRays, LensRay, LensShape};
pub use environment::{EnvSample, EnvironmentMap};
pub use error::SceneError;
pub use light::{AreaLight, LightShape, PreparedLight};
pub use motion::{PreparedMotion, RigidMotion, RigidTransform};
pub use real_layer::{RealAlbedo, RealLayer};
pub use resource::{ConfinedTo, Confinement};
pub use scene::{Aabb, Instance, Material, Scene, SceneAt, SceneObject, SurfacePoint, TriangleShading};
pub use texture::Texture;

/// Where to get a scene: a built-in by name, or a file (format chosen by extension).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SceneSource {
    Builtin(String),
    File(PathBuf),
}

/// Size and value caps applied while loading, so no input can exhaust memory or overflow f32 maths.
pub mod limits {
    /// Most triangles a scene may have (after glTF instancing), checked before geometry is allocated.
    pub const MAX_TRIANGLES: usize = 1 << 26;
    /// Most elements (vertices, indices) one glTF accessor may hold.
    pub const MAX_ACCESSOR_ELEMENTS: u64 = 1 << 26;
    /// Largest texture (width × height); 8192 × 8192. Checked from the image header before decoding.
    pub const MAX_TEXTURE_PIXELS: u64 = 1 << 26;
    /// Largest texture side.
    pub const MAX_TEXTURE_SIDE: u32 = 16384;
    /// Largest file (scene, buffer, texture) read.
    pub const MAX_FILE_BYTES: u64 = 4 << 30;
    /// Largest |coordinate| of a vertex after all transforms (metres). Beyond it edge cross products
    /// and ray distances overflow f32.
    pub const MAX_COORDINATE: f32 = 1e8;
    /// Largest emitted radiance channel; sums of many samples of it must stay finite in f32.
    pub const MAX_RADIANCE: f32 = 1e12;
}

/// How a scene file may reach other files.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// Allow buffers, images, material libraries, textures and meshes outside the directory of the
    /// scene file (after following symlinks; `--allow-outside-dir`, which lifts a pipeline's
    /// confinement to its directory too, see [`Confinement`]). Off by default: a scene must not read
    /// arbitrary files.
    pub allow_outside_dir: bool,
}

/// Load a scene with default [`LoadOptions`]: built-in by name, or `.gltf`/`.glb`, `.obj` (+MTL) or
/// `.ron` by extension.
pub fn load(source: &SceneSource) -> Result<Scene, SceneError> {
    load_with(source, &LoadOptions::default())
}

/// [`load`] with explicit options.
pub fn load_with(source: &SceneSource, opts: &LoadOptions) -> Result<Scene, SceneError> {
    load_with_shutter(source, opts, None)
}

/// [`load_with`] for a camera whose shutter is `shutter` = (open, close) in the scene's time unit
/// (e.g. a pipeline's camera, which replaces the scene's): glTF animations are sampled at these two
/// times (they become `t = −1` and `t = +1`), and the scene camera's `shutter_open`/`shutter_close`
/// are set to them. `None` keeps the file's own shutter (a `.ron` scene's `shutter`; 0, 0 for glTF).
/// Built-ins define their motion over the shutter directly; only their camera's fields change.
pub fn load_with_shutter(
    source: &SceneSource,
    opts: &LoadOptions,
    shutter: Option<(f32, f32)>,
) -> Result<Scene, SceneError> {
    if let Some((open, close)) = shutter {
        if !(open.is_finite() && close.is_finite() && open <= close) {
            let name = match source {
                SceneSource::Builtin(name) => PathBuf::from(format!("builtin:{name}")),
                SceneSource::File(path) => path.clone(),
            };
            return Err(SceneError::Invalid {
                path: name,
                what: format!("the shutter ({open}, {close}) is not an interval"),
                fix: "give finite shutter times with open <= close".into(),
            });
        }
    }
    let mut scene = match source {
        SceneSource::Builtin(name) => builtin::builtin(name)?,
        SceneSource::File(path) => {
            let mut res = resource::Resources::for_scene(path, opts)?;
            res.shutter = shutter;
            if ext(path).as_deref() == Some("ron") {
                compose::load_ron(path, &res)?
            } else {
                let name = path.display().to_string();
                load_data(path, &res)?.into_scene(&name)?
            }
        }
    };
    if let Some((open, close)) = shutter {
        scene.camera.shutter_open = open;
        scene.camera.shutter_close = close;
    }
    Ok(scene)
}

/// Names accepted by `SceneSource::Builtin`.
pub fn builtin_names() -> &'static [&'static str] {
    builtin::NAMES
}

fn ext(path: &Path) -> Option<String> {
    path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase())
}

/// Load a mesh file into loose triangles (used by `load` and by `.ron` composition).
pub(crate) fn load_data(path: &Path, res: &resource::Resources) -> Result<data::SceneData, SceneError> {
    match ext(path).as_deref() {
        Some("gltf") | Some("glb") => load_gltf::load_gltf(path, res),
        Some("obj") => load_obj::load_obj(path, res),
        _ => Err(SceneError::UnsupportedFormat { path: path.to_path_buf() }),
    }
}
