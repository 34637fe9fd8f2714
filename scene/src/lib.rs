//! # wedge-scene
//!
//! Scenes for wedge's sample-and-filter renderer: everything a pass needs to trace rays and shade hits,
//! laid out so the CPU reference and the GPU kernels read the same arrays.
//!
//! - **Geometry**: world-space triangles ([`TriangleRecord`]: `v0, e1, e2` for Möller–Trumbore) in BVH
//!   leaf order, plus per-triangle shading data ([`TriangleShading`]) in the same order.
//! - **BVH**: built once per scene with obvhs (PLOC, `medium_build`), flattened to 32-byte [`BvhNode`]s.
//!   [`Scene::intersect`] / [`Scene::occluded`] traverse it with a plain fixed-stack loop ([`bvh`]) that
//!   the WGSL kernel mirrors, so CPU and GPU results agree; obvhs's own traversal is not used.
//! - **Lights**: emissive triangles become [`AreaLight`]s; a pair forming a parallelogram merges into one
//!   rectangle (the thesis's soft-shadow case). Each light provides uniform sampling, its footprint σ for
//!   the filter bandwidth, and exact unoccluded irradiance (useful for shadow-ratio shading and tests).
//! - **Materials/textures**: Lambertian base colour (optionally textured, linear RGB), Phong k_s/m, emission.
//! - **Sources** ([`load`]): built-ins (`grids`, `curved`, `heavy`, see [`builtin`]), glTF, OBJ/MTL, and a
//!   `.ron` composition file ([`compose`]). Bad input yields a [`SceneError`] naming the file, the problem
//!   and the fix — never a panic.
//!
//! Conventions: right-handed, y up, metres; image y points down; textures have v = 0 at the top row.

pub mod builtin;
pub mod bvh;
pub mod camera;
pub mod compose;
mod data;
pub mod error;
pub mod light;
pub mod load_gltf;
pub mod load_obj;
pub mod scene;
pub mod texture;

use std::path::{Path, PathBuf};

pub use glam::{Vec2, Vec3};

pub use bvh::{BvhNode, Hit, TriangleRecord, NO_LIGHT};
pub use camera::Camera;
pub use error::SceneError;
pub use light::{AreaLight, LightShape};
pub use scene::{Aabb, Material, Scene, SurfacePoint, TriangleShading};
pub use texture::Texture;

/// Where to get a scene: a built-in by name, or a file (format chosen by extension).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SceneSource {
    Builtin(String),
    File(PathBuf),
}

/// Load a scene: built-in by name, or `.gltf`/`.glb`, `.obj` (+MTL) or `.ron` by extension.
pub fn load(source: &SceneSource) -> Result<Scene, SceneError> {
    match source {
        SceneSource::Builtin(name) => builtin::builtin(name),
        SceneSource::File(path) => {
            if ext(path).as_deref() == Some("ron") {
                return compose::load_ron(path);
            }
            let name = path.display().to_string();
            load_data(path)?.into_scene(&name)
        }
    }
}

/// Names accepted by `SceneSource::Builtin`.
pub fn builtin_names() -> &'static [&'static str] {
    builtin::NAMES
}

fn ext(path: &Path) -> Option<String> {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
}

/// Load a mesh file into loose triangles (used by `load` and by `.ron` composition).
pub(crate) fn load_data(path: &Path) -> Result<data::SceneData, SceneError> {
    match ext(path).as_deref() {
        Some("gltf") | Some("glb") => load_gltf::load_gltf(path),
        Some("obj") => load_obj::load_obj(path),
        _ => Err(SceneError::UnsupportedFormat {
            path: path.to_path_buf(),
        }),
    }
}
