//! `.ron` scene composition: meshes from files (placed with translate/scale/rotate_y, optionally
//! moving over the shutter), an optional built-in to start from, explicit lights and an optional
//! camera with a shutter. Unknown fields are rejected so typos fail loudly; errors carry ron's
//! line:col. Paths are relative to the .ron file.
//!
//! ```ron
//! Scene(
//!   meshes: [ (path: "bunny.obj", translate: (0,0,0), scale: 1.0, rotate_y_deg: 0.0, material: None,
//!              motion: Some((translation: ((0,0,0), (0.2,0,0)), axis: (0,1,0), rotate_deg: (0, 15)))) ],
//!   builtin: None, // or Some("grids")
//!   lights: [ Rect(corner: (-0.5, 2, -0.5), edge_u: (1,0,0), edge_v: (0,0,1), radiance: (10,10,10)) ],
//!   camera: Some((position: (0,1,3), look_at: (0,0,0), up: (0,1,0), vfov_deg: 40, shutter: (0, 0.02))),
//! )
//! ```
//! Every field except `path`, the light geometry/radiance and the camera's position/look_at/vfov_deg
//! has a default. A `Rect` light becomes two emissive triangles (so primary rays see it), which
//! `Scene::from_triangles` merges back into one Rect `AreaLight`. Lights may set `two_sided: true`.
//! Mesh paths must stay under the scene file's directory (see [`crate::LoadOptions`]); the camera must
//! pass [`Camera::validate`].
//!
//! **Motion.** A mesh's `motion` moves it rigidly over the shutter, in world space after its
//! placement: `translation: (at open, at close)` (default none), a rotation about `axis` (default y)
//! through `pivot` (default: the mesh's `translate`) from `rotate_deg.0` to `rotate_deg.1` degrees
//! (at most 180 apart; default no rotation) — see [`crate::motion`]. The camera's `shutter: (open,
//! close)` (default (0, 0)) is the time interval glTF meshes' animations are sampled at (a mesh may
//! have animations or a `motion` block, not both); a shutter given by the caller
//! ([`crate::load_with_shutter`], e.g. a pipeline's camera) replaces it.

use std::path::Path;

use glam::{Mat4, Quat, Vec3};
use serde::Deserialize;

use crate::data::SceneData;
use crate::motion::RigidMotion;
use crate::resource::{read_capped, Resources};
use crate::{builtin, Camera, Material, Scene, SceneError};

type V3 = (f32, f32, f32);

fn v(t: V3) -> Vec3 {
    Vec3::new(t.0, t.1, t.2)
}
fn one() -> f64 {
    1.0
}
fn y_up() -> V3 {
    (0.0, 1.0, 0.0)
}

#[derive(Deserialize, Debug)]
#[serde(rename = "Scene", deny_unknown_fields)]
struct SceneFile {
    #[serde(default)]
    meshes: Vec<MeshEntry>,
    #[serde(default)]
    builtin: Option<String>,
    #[serde(default)]
    lights: Vec<LightEntry>,
    #[serde(default)]
    camera: Option<CameraEntry>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct MeshEntry {
    path: String,
    #[serde(default)]
    translate: V3,
    /// Read as f64 so that a value f32 cannot hold (1e-300, 1e39) is reported as written.
    #[serde(default = "one")]
    scale: f64,
    #[serde(default)]
    rotate_y_deg: f32,
    /// Override every triangle's material with the named one (looked up in this mesh's materials first,
    /// then in everything loaded before it).
    #[serde(default)]
    material: Option<String>,
    /// Rigid motion over the shutter (see the module doc).
    #[serde(default)]
    motion: Option<MotionEntry>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct MotionEntry {
    /// World translation at shutter open and close.
    #[serde(default)]
    translation: (V3, V3),
    #[serde(default = "y_up")]
    axis: V3,
    /// Rotation about `axis` through `pivot` at shutter open and close, in degrees.
    #[serde(default)]
    rotate_deg: (f32, f32),
    /// Default: the mesh's `translate`.
    #[serde(default)]
    pivot: Option<V3>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
enum LightEntry {
    Rect {
        corner: V3,
        edge_u: V3,
        edge_v: V3,
        radiance: V3,
        #[serde(default)]
        two_sided: bool,
    },
    Triangle {
        v0: V3,
        v1: V3,
        v2: V3,
        radiance: V3,
        #[serde(default)]
        two_sided: bool,
    },
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct CameraEntry {
    position: V3,
    look_at: V3,
    #[serde(default = "y_up")]
    up: V3,
    vfov_deg: f32,
    #[serde(default)]
    aperture_radius: f32,
    /// 0 (default) = focus on look_at.
    #[serde(default)]
    focus_distance: f32,
    /// (open, close) in the scene's time unit; glTF animations are sampled at both.
    #[serde(default)]
    shutter: (f32, f32),
}

pub(crate) fn load_ron(path: &Path, res: &Resources) -> Result<Scene, SceneError> {
    let bytes = read_capped(path, None)?;
    let text = String::from_utf8(bytes).map_err(|e| {
        SceneError::invalid(
            path,
            format!("not UTF-8 text (invalid byte at offset {})", e.utf8_error().valid_up_to()),
            "save the scene file as UTF-8",
        )
    })?;
    let file: SceneFile = ron::from_str(&text).map_err(|e| {
        // SpannedError displays as "line:col: message".
        SceneError::invalid(
            path,
            format!("{e}"),
            "fix the scene file (see wedge-scene's compose module for the fields)",
        )
    })?;
    // The camera first: its shutter is when glTF meshes' animations are sampled.
    let camera = match &file.camera {
        None => None,
        Some(c) => {
            let camera = Camera {
                position: v(c.position),
                look_at: v(c.look_at),
                up: v(c.up),
                vfov_deg: c.vfov_deg,
                aperture_radius: c.aperture_radius,
                focus_distance: c.focus_distance,
                shutter_open: c.shutter.0,
                shutter_close: c.shutter.1,
            };
            camera
                .validate()
                .map_err(|what| SceneError::invalid(path, format!("camera: {what}"), Camera::VALID_RULES))?;
            Some(camera)
        }
    };
    let mut res = res.clone();
    res.shutter = res.shutter.or(camera.map(|c| (c.shutter_open, c.shutter_close)));
    let res = &res;
    let mut d = match &file.builtin {
        Some(name) => builtin::builtin_data(name)
            .map_err(|e| SceneError::invalid(path, format!("{e}"), "use a known built-in name"))?,
        None => SceneData::default(),
    };
    for (i, m) in file.meshes.iter().enumerate() {
        let by = format!("meshes[{i}].path = \"{}\"", m.path);
        let mesh_path = res.resolve(path, Path::new(&m.path), &by)?;
        check_mesh_format(path, i, &m.path, &mesh_path)?;
        let mesh = crate::load_data(&mesh_path, res)?;
        let scale = m.scale as f32;
        if !scale.is_normal() {
            // Positions are f32: a scale that is 0, subnormal or infinite there collapses or blows
            // up the mesh, whatever the file wrote.
            return Err(SceneError::invalid(
                path,
                format!(
                    "mesh {i} ('{}') has scale = {:e}, which is {} in single precision (f32, what positions are stored in)",
                    m.path,
                    m.scale,
                    if scale == 0.0 { "0" } else if scale.is_finite() { "subnormal" } else { "not a finite number" }
                ),
                format!("use a non-zero scale of magnitude between {:e} and {:e}", f32::MIN_POSITIVE, f32::MAX),
            ));
        }
        if !(m.rotate_y_deg.is_finite() && v(m.translate).is_finite()) {
            return Err(SceneError::invalid(
                path,
                format!("mesh {i} ('{}') has an invalid transform", m.path),
                "use finite values",
            ));
        }
        let xf = Mat4::from_scale_rotation_translation(
            Vec3::splat(scale),
            Quat::from_rotation_y(m.rotate_y_deg.to_radians()),
            v(m.translate),
        );
        let motion = match &m.motion {
            None => None,
            Some(entry) => {
                if mesh.has_motion() {
                    return Err(SceneError::invalid(
                        path,
                        format!("mesh {i} ('{}') has a motion block, and its file has animations that move it", m.path),
                        "use one of the two: remove the motion block, or the file's animations",
                    ));
                }
                Some(mesh_motion(path, i, m, entry)?)
            }
        };
        let first_object = d.objects.len();
        let over = match &m.material {
            None => None,
            Some(name) => {
                if let Some(k) = mesh.materials.iter().position(|x| &x.name == name) {
                    Some(d.materials.len() as u32 + k as u32)
                } else if let Some(k) = d.materials.iter().position(|x| &x.name == name) {
                    Some(k as u32)
                } else {
                    return Err(SceneError::invalid(
                        path,
                        format!("mesh {i} ('{}') asks for material '{name}' which is not defined", m.path),
                        "use a material name from the mesh or an earlier mesh",
                    ));
                }
            }
        };
        d.append(mesh, xf, over);
        if let Some(motion) = motion {
            // World space, so set after placement.
            for o in &mut d.objects[first_object..] {
                o.motion = Some(motion);
            }
        }
    }
    for (i, l) in file.lights.iter().enumerate() {
        let o = d.new_object();
        match *l {
            LightEntry::Rect { corner, edge_u, edge_v, radiance, two_sided } => {
                let (c, eu, ev) = (v(corner), v(edge_u), v(edge_v));
                check_light(path, i, eu.cross(ev), v(radiance))?;
                let m = d.add_material(Material::emitter(&format!("light{i}"), v(radiance)), two_sided);
                d.quad(c, c + eu, c + eu + ev, c + ev, m, o);
            }
            LightEntry::Triangle { v0, v1, v2, radiance, two_sided } => {
                check_light(path, i, (v(v1) - v(v0)).cross(v(v2) - v(v0)), v(radiance))?;
                let m = d.add_material(Material::emitter(&format!("light{i}"), v(radiance)), two_sided);
                d.flat(v(v0), v(v1), v(v2), m, o);
            }
        }
    }
    if camera.is_some() {
        d.camera = camera;
    }
    let name = path.display().to_string();
    d.into_scene(&name)
}

/// A mesh must be a file of triangles (.gltf, .glb, .obj). A `.ron` scene is not one: scenes do not
/// nest (and one naming itself would recurse), so it is refused here with what it is, rather than as
/// an "unsupported format" whose list of formats includes `.ron`.
fn check_mesh_format(path: &Path, i: usize, written: &str, resolved: &Path) -> Result<(), SceneError> {
    let ext = crate::ext(resolved);
    if matches!(ext.as_deref(), Some("gltf" | "glb" | "obj")) {
        return Ok(());
    }
    let name = |p: &Path| p.file_name().map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned());
    let what = if ext.as_deref() != Some("ron") {
        format!("meshes[{i}].path = \"{written}\" is not a mesh file")
    } else if std::fs::canonicalize(path).is_ok_and(|p| p == resolved) {
        format!("meshes[{i}].path = \"{written}\" includes this scene file itself ({} → {0}), an include cycle that would never end", name(path))
    } else {
        format!(
            "meshes[{i}].path = \"{written}\" includes another .ron scene ({} → {}); .ron scenes do not nest (so two that include each other cannot loop), and one cannot be a mesh of another",
            name(path),
            name(resolved)
        )
    };
    Err(SceneError::invalid(
        path,
        what,
        "name a .gltf, .glb or .obj file as the mesh (copy the other scene's `meshes` and `lights` into this file to combine them)",
    ))
}

fn check_light(path: &Path, i: usize, cross: Vec3, radiance: Vec3) -> Result<(), SceneError> {
    if !(cross.is_finite() && cross.length_squared() > 0.0) {
        return Err(SceneError::invalid(
            path,
            format!("light {i} has zero area or non-finite corners"),
            "give it two non-parallel, non-zero edges",
        ));
    }
    if !(radiance.is_finite() && radiance.min_element() >= 0.0 && radiance.max_element() > 0.0) {
        return Err(SceneError::invalid(
            path,
            format!("light {i} has radiance {radiance}"),
            "use finite, non-negative radiance with at least one positive channel",
        ));
    }
    Ok(())
}

/// A mesh's `motion` block as a [`RigidMotion`] in world space, checked.
fn mesh_motion(path: &Path, i: usize, m: &MeshEntry, e: &MotionEntry) -> Result<RigidMotion, SceneError> {
    let what = |w: String| {
        SceneError::invalid(
            path,
            format!("mesh {i} ('{}') motion: {w}", m.path),
            "use finite numbers, a non-zero axis and rotate_deg values at most 180 apart",
        )
    };
    let (r0, r1) = e.rotate_deg;
    if !(r0.is_finite() && r1.is_finite()) {
        return Err(what(format!("rotate_deg ({r0}, {r1}) is not finite")));
    }
    if (r1 - r0).abs() > 180.0 {
        return Err(what(format!(
            "rotate_deg ({r0}, {r1}) turns by more than 180° (rotation over the shutter takes the short way)"
        )));
    }
    let axis = v(e.axis);
    if r0 != r1 && axis.try_normalize().is_none() {
        return Err(what(format!("axis {axis} has no direction")));
    }
    let motion = RigidMotion {
        pivot: v(e.pivot.unwrap_or(m.translate)),
        translation: [v(e.translation.0), v(e.translation.1)],
        ..RigidMotion::rotation_about(Vec3::ZERO, axis, r0.to_radians(), r1.to_radians())
    };
    motion.validate().map_err(what)?;
    Ok(motion)
}
