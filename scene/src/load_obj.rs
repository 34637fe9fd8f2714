//! Wavefront OBJ + MTL via `tobj`. MTL keys used: Kd (base colour), map_Kd (base-colour texture, sRGB),
//! Ke (emission), Ks (k_s), Ns (Phong exponent). OBJ has no camera (the caller frames the bounds).
//! OBJ's `vt` has v = 0 at the image's bottom row; textures here use v = 0 at the top (glTF), so we store
//! `1 - v`.

use std::collections::HashMap;
use std::path::Path;

use glam::{Vec2, Vec3};

use crate::data::SceneData;
use crate::{Material, SceneError, Texture};

pub(crate) fn load_obj(path: &Path) -> Result<SceneData, SceneError> {
    if !path.is_file() {
        return Err(SceneError::io(
            path,
            std::io::Error::new(std::io::ErrorKind::NotFound, "file not found"),
        ));
    }
    let opts = tobj::LoadOptions {
        single_index: false,
        triangulate: true,
        ..Default::default()
    };
    let (models, mats) = tobj::load_obj(path, &opts).map_err(|e| {
        SceneError::invalid(
            path,
            format!("not a valid OBJ file ({e})"),
            "export the mesh again as Wavefront OBJ",
        )
    })?;
    let mats = mats.map_err(|e| {
        SceneError::invalid(
            path,
            format!("its material library could not be loaded ({e})"),
            "put the .mtl next to the .obj or remove the mtllib line",
        )
    })?;
    let dir = path.parent().unwrap_or(Path::new("."));

    let mut d = SceneData::default();
    let mut tex_cache: HashMap<String, u32> = HashMap::new();
    for m in &mats {
        let base_color_texture = match &m.diffuse_texture {
            Some(name) if !name.trim().is_empty() => Some(load_texture_cached(
                &mut d,
                &mut tex_cache,
                dir,
                name.trim(),
                path,
            )?),
            _ => None,
        };
        let v3 = |a: Option<[f32; 3]>, def: Vec3| {
            a.map(Vec3::from)
                .filter(|v| v.is_finite())
                .unwrap_or(def)
                .max(Vec3::ZERO)
        };
        let specular = v3(m.specular, Vec3::ZERO);
        let ns = m
            .shininess
            .filter(|s| s.is_finite() && *s > 0.0)
            .unwrap_or(0.0);
        d.add_material(
            Material {
                name: m.name.clone(),
                base_color: v3(m.diffuse, Vec3::splat(0.8)),
                base_color_texture,
                emission: v3(m.emissive, Vec3::ZERO),
                specular: if ns > 0.0 { specular } else { Vec3::ZERO },
                phong_exponent: if specular.max_element() > 0.0 {
                    ns
                } else {
                    0.0
                },
            },
            false,
        );
    }
    let mut default_material = None;

    for model in &models {
        let mesh = &model.mesh;
        let object = d.new_object();
        let material = match mesh.material_id {
            Some(id) if id < mats.len() => id as u32,
            Some(id) => {
                return Err(SceneError::invalid(
                    path,
                    format!(
                        "object '{}' uses material {id} but the library has {}",
                        model.name,
                        mats.len()
                    ),
                    "fix the usemtl/mtllib lines",
                ))
            }
            None => *default_material.get_or_insert_with(|| {
                d.add_material(Material::diffuse("default", Vec3::splat(0.8)), false)
            }),
        };
        let pos = |i: u32| -> Result<Vec3, SceneError> {
            let i = i as usize * 3;
            let p = mesh
                .positions
                .get(i..i + 3)
                .map(|s| Vec3::new(s[0], s[1], s[2]));
            match p {
                Some(p) if p.is_finite() => Ok(p),
                Some(_) => Err(SceneError::invalid(
                    path,
                    format!("object '{}' has a NaN or infinite vertex", model.name),
                    "fix the v lines",
                )),
                None => Err(SceneError::invalid(
                    path,
                    format!("object '{}' has a face index out of range", model.name),
                    "fix the f lines",
                )),
            }
        };
        if mesh.indices.len() % 3 != 0 {
            return Err(SceneError::invalid(
                path,
                format!("object '{}' has a non-triangle face", model.name),
                "triangulate the mesh",
            ));
        }
        for (f, tri) in mesh.indices.chunks_exact(3).enumerate() {
            let p = [pos(tri[0])?, pos(tri[1])?, pos(tri[2])?];
            let flat = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
            let mut n = [flat; 3];
            if !mesh.normal_indices.is_empty() {
                for (k, nk) in n.iter_mut().enumerate() {
                    let ni = *mesh.normal_indices.get(f * 3 + k).unwrap_or(&u32::MAX) as usize * 3;
                    if let Some(s) = mesh.normals.get(ni..ni + 3) {
                        let v = Vec3::new(s[0], s[1], s[2]).normalize_or_zero();
                        if v != Vec3::ZERO && v.is_finite() {
                            *nk = v;
                        }
                    }
                }
            }
            let mut uv = [Vec2::ZERO; 3];
            if !mesh.texcoord_indices.is_empty() {
                for (k, uvk) in uv.iter_mut().enumerate() {
                    let ti =
                        *mesh.texcoord_indices.get(f * 3 + k).unwrap_or(&u32::MAX) as usize * 2;
                    if let Some(s) = mesh.texcoords.get(ti..ti + 2) {
                        *uvk = Vec2::new(s[0], 1.0 - s[1]); // OBJ v=0 is the bottom row
                    }
                }
            }
            d.push(p, n, uv, material, object);
        }
    }
    if d.tris.is_empty() {
        return Err(SceneError::invalid(
            path,
            "no triangles found",
            "check that the file is a Wavefront OBJ with f (face) lines",
        ));
    }
    Ok(d)
}

fn load_texture_cached(
    d: &mut SceneData,
    cache: &mut HashMap<String, u32>,
    dir: &Path,
    name: &str,
    obj: &Path,
) -> Result<u32, SceneError> {
    if let Some(&i) = cache.get(name) {
        return Ok(i);
    }
    let tex = load_texture_file(&dir.join(name), obj)?;
    d.textures.push(tex);
    let i = (d.textures.len() - 1) as u32;
    cache.insert(name.to_string(), i);
    Ok(i)
}

/// Decode an image file (PNG/JPEG) as an sRGB base-colour texture.
pub(crate) fn load_texture_file(file: &Path, referenced_by: &Path) -> Result<Texture, SceneError> {
    let img = image::open(file).map_err(|e| {
        SceneError::invalid(
            file,
            format!(
                "texture referenced by {} could not be loaded ({e})",
                referenced_by.display()
            ),
            "put the image next to the scene file (PNG or JPEG) or fix the path",
        )
    })?;
    Texture::from_image(&img)
        .ok_or_else(|| SceneError::invalid(file, "texture is empty", "use a non-empty image"))
}
