//! `.ron` scene composition: meshes from files (placed with translate/scale/rotate_y), an optional
//! built-in to start from, explicit lights and an optional camera. Unknown fields are rejected so typos
//! fail loudly; errors carry ron's line:col. Paths are relative to the .ron file.
//!
//! ```ron
//! Scene(
//!   meshes: [ (path: "bunny.obj", translate: (0,0,0), scale: 1.0, rotate_y_deg: 0.0, material: None) ],
//!   builtin: None, // or Some("grids")
//!   lights: [ Rect(corner: (-0.5, 2, -0.5), edge_u: (1,0,0), edge_v: (0,0,1), radiance: (10,10,10)) ],
//!   camera: Some((position: (0,1,3), look_at: (0,0,0), up: (0,1,0), vfov_deg: 40)),
//! )
//! ```
//! Every field except `path`, the light geometry/radiance and the camera's position/look_at/vfov_deg
//! has a default. A `Rect` light becomes two emissive triangles (so primary rays see it), which
//! `Scene::from_triangles` merges back into one Rect `AreaLight`. Lights may set `two_sided: true`.
//! Mesh paths must stay under the scene file's directory (see [`crate::LoadOptions`]); the camera must
//! pass [`Camera::validate`].

use std::path::Path;

use glam::{Mat4, Quat, Vec3};
use serde::Deserialize;

use crate::data::SceneData;
use crate::resource::{read_capped, Resources};
use crate::{builtin, Camera, Material, Scene, SceneError};

type V3 = (f32, f32, f32);

fn v(t: V3) -> Vec3 {
    Vec3::new(t.0, t.1, t.2)
}
fn one() -> f32 {
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
    #[serde(default = "one")]
    scale: f32,
    #[serde(default)]
    rotate_y_deg: f32,
    /// Override every triangle's material with the named one (looked up in this mesh's materials first,
    /// then in everything loaded before it).
    #[serde(default)]
    material: Option<String>,
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
}

pub(crate) fn load_ron(path: &Path, res: &Resources) -> Result<Scene, SceneError> {
    let bytes = read_capped(path, None)?;
    let text = String::from_utf8(bytes).map_err(|e| {
        SceneError::invalid(
            path,
            format!(
                "not UTF-8 text (invalid byte at offset {})",
                e.utf8_error().valid_up_to()
            ),
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
    let mut d = match &file.builtin {
        Some(name) => builtin::builtin_data(name)
            .map_err(|e| SceneError::invalid(path, format!("{e}"), "use a known built-in name"))?,
        None => SceneData::default(),
    };
    for (i, m) in file.meshes.iter().enumerate() {
        let by = format!("meshes[{i}].path = \"{}\"", m.path);
        let mesh_path = res.resolve(path, Path::new(&m.path), &by)?;
        let mesh = crate::load_data(&mesh_path, res)?;
        if !(m.scale.is_finite()
            && m.scale != 0.0
            && m.rotate_y_deg.is_finite()
            && v(m.translate).is_finite())
        {
            return Err(SceneError::invalid(
                path,
                format!("mesh {i} ('{}') has an invalid transform", m.path),
                "use finite values and a non-zero scale",
            ));
        }
        let xf = Mat4::from_scale_rotation_translation(
            Vec3::splat(m.scale),
            Quat::from_rotation_y(m.rotate_y_deg.to_radians()),
            v(m.translate),
        );
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
                        format!(
                            "mesh {i} ('{}') asks for material '{name}' which is not defined",
                            m.path
                        ),
                        "use a material name from the mesh or an earlier mesh",
                    ));
                }
            }
        };
        d.append(mesh, xf, over);
    }
    for (i, l) in file.lights.iter().enumerate() {
        let o = d.new_object();
        match *l {
            LightEntry::Rect {
                corner,
                edge_u,
                edge_v,
                radiance,
                two_sided,
            } => {
                let (c, eu, ev) = (v(corner), v(edge_u), v(edge_v));
                check_light(path, i, eu.cross(ev), v(radiance))?;
                let m = d.add_material(
                    Material::emitter(&format!("light{i}"), v(radiance)),
                    two_sided,
                );
                d.quad(c, c + eu, c + eu + ev, c + ev, m, o);
            }
            LightEntry::Triangle {
                v0,
                v1,
                v2,
                radiance,
                two_sided,
            } => {
                check_light(path, i, (v(v1) - v(v0)).cross(v(v2) - v(v0)), v(radiance))?;
                let m = d.add_material(
                    Material::emitter(&format!("light{i}"), v(radiance)),
                    two_sided,
                );
                d.flat(v(v0), v(v1), v(v2), m, o);
            }
        }
    }
    if let Some(c) = &file.camera {
        let camera = Camera {
            position: v(c.position),
            look_at: v(c.look_at),
            up: v(c.up),
            vfov_deg: c.vfov_deg,
            aperture_radius: c.aperture_radius,
            focus_distance: c.focus_distance,
            shutter_open: 0.0,
            shutter_close: 0.0,
        };
        camera.validate().map_err(|what| {
            SceneError::invalid(path, format!("camera: {what}"), Camera::VALID_RULES)
        })?;
        d.camera = Some(camera);
    }
    let name = path.display().to_string();
    d.into_scene(&name)
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
