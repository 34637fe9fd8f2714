//! glTF 2.0 (.gltf/.glb) via the `gltf` crate (buffers and images imported, data URIs included).
//!
//! Materials: base colour factor × base-colour texture (sRGB, decoded to linear) is k_d, scaled by
//! (1 − metallic); emission = emissiveFactor × KHR_materials_emissive_strength; a Phong lobe is derived
//! from metallic-roughness: α = roughness², m = 2/α² − 2 (the Blinn-Phong exponent matching a GGX/Beckmann
//! roughness), k_s = mix(0.04, base colour, metallic); roughness 1 (m = 0) means no glossy lobe.
//! `doubleSided` emissive materials become two-sided lights. Camera: the first node (depth-first in the
//! default scene) with a perspective camera; otherwise none (the bounds are framed).

use std::collections::HashMap;
use std::path::Path;

use glam::{Mat4, Vec2, Vec3};

use crate::data::SceneData;
use crate::{Camera, Material, SceneError, Texture};

pub(crate) fn load_gltf(path: &Path) -> Result<SceneData, SceneError> {
    if !path.is_file() {
        return Err(SceneError::io(
            path,
            std::io::Error::new(std::io::ErrorKind::NotFound, "file not found"),
        ));
    }
    let (doc, buffers, images) = gltf::import(path).map_err(|e| {
        SceneError::invalid(
            path,
            format!("not a valid glTF file ({e})"),
            "re-export it as glTF 2.0 with embedded or adjacent buffers/images",
        )
    })?;
    let mut d = SceneData::default();

    // Materials in document order; a default one is appended for primitives without a material.
    let mut image_to_texture: HashMap<usize, u32> = HashMap::new();
    for m in doc.materials() {
        let pbr = m.pbr_metallic_roughness();
        let bc = pbr.base_color_factor();
        let base = Vec3::new(bc[0], bc[1], bc[2]).max(Vec3::ZERO);
        let metallic = pbr.metallic_factor().clamp(0.0, 1.0);
        let roughness = pbr.roughness_factor().clamp(0.0, 1.0);
        let base_color_texture = match pbr.base_color_texture() {
            Some(info) => {
                let img = info.texture().source().index();
                let t = match image_to_texture.get(&img) {
                    Some(&t) => t,
                    None => {
                        let data = images.get(img).ok_or_else(|| {
                            SceneError::invalid(
                                path,
                                format!("image {img} is missing"),
                                "fix the file's images",
                            )
                        })?;
                        d.textures.push(texture_from_gltf(data, path, img)?);
                        let t = (d.textures.len() - 1) as u32;
                        image_to_texture.insert(img, t);
                        t
                    }
                };
                Some(t)
            }
            None => None,
        };
        let e = m.emissive_factor();
        let emission =
            Vec3::new(e[0], e[1], e[2]).max(Vec3::ZERO) * m.emissive_strength().unwrap_or(1.0);
        let alpha = (roughness * roughness).max(1e-3);
        let m_exp = (2.0 / (alpha * alpha) - 2.0).clamp(0.0, 1e4);
        let specular = if m_exp > 0.0 {
            Vec3::splat(0.04).lerp(base, metallic)
        } else {
            Vec3::ZERO
        };
        d.add_material(
            Material {
                name: m
                    .name()
                    .map(str::to_string)
                    .unwrap_or_else(|| format!("material{}", m.index().unwrap_or(0))),
                base_color: base * (1.0 - metallic),
                base_color_texture,
                emission,
                specular,
                phong_exponent: m_exp,
            },
            m.double_sided(),
        );
    }
    let mut default_material: Option<u32> = None;

    let scene = doc.default_scene().or_else(|| doc.scenes().next());
    let Some(scene) = scene else {
        return Err(SceneError::invalid(
            path,
            "the file has no scene",
            "export at least one scene with meshes",
        ));
    };
    let mut camera_node: Option<(Mat4, f32)> = None;
    let mut todo: Vec<(gltf::Node, Mat4)> = scene.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
    todo.reverse(); // depth-first in document order
    while let Some((node, parent)) = todo.pop() {
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        if camera_node.is_none() {
            if let Some(cam) = node.camera() {
                if let gltf::camera::Projection::Perspective(p) = cam.projection() {
                    camera_node = Some((world, p.yfov()));
                }
            }
        }
        if let Some(mesh) = node.mesh() {
            let normal_m = world.inverse().transpose();
            for prim in mesh.primitives() {
                if prim.mode() != gltf::mesh::Mode::Triangles {
                    continue; // points/lines/strips are not rendered
                }
                let object = d.new_object();
                let material = match prim.material().index() {
                    Some(i) if i < d.materials.len() => i as u32,
                    Some(i) => {
                        return Err(SceneError::invalid(
                            path,
                            format!("primitive uses material {i} which does not exist"),
                            "fix the file's materials",
                        ))
                    }
                    None => *default_material.get_or_insert_with(|| {
                        d.add_material(Material::diffuse("default", Vec3::splat(0.8)), false)
                    }),
                };
                let reader = prim.reader(|b| buffers.get(b.index()).map(|x| &x.0[..]));
                let Some(positions) = reader.read_positions() else {
                    return Err(SceneError::invalid(
                        path,
                        format!(
                            "mesh '{}' has a primitive without positions",
                            mesh.name().unwrap_or("?")
                        ),
                        "export positions",
                    ));
                };
                let positions: Vec<Vec3> = positions
                    .map(|p| world.transform_point3(Vec3::from(p)))
                    .collect();
                let normals: Option<Vec<Vec3>> = reader.read_normals().map(|it| {
                    it.map(|n| {
                        normal_m
                            .transform_vector3(Vec3::from(n))
                            .normalize_or_zero()
                    })
                    .collect()
                });
                let uvs: Option<Vec<Vec2>> = reader
                    .read_tex_coords(0)
                    .map(|it| it.into_f32().map(Vec2::from).collect());
                let indices: Vec<u32> = match reader.read_indices() {
                    Some(it) => it.into_u32().collect(),
                    None => (0..positions.len() as u32).collect(),
                };
                for tri in indices.chunks_exact(3) {
                    let tri = [tri[0], tri[1], tri[2]];
                    let mut p = [Vec3::ZERO; 3];
                    for k in 0..3 {
                        p[k] = *positions.get(tri[k] as usize).ok_or_else(|| {
                            SceneError::invalid(
                                path,
                                format!(
                                    "index {} out of range ({} vertices)",
                                    tri[k],
                                    positions.len()
                                ),
                                "fix the index accessor",
                            )
                        })?;
                    }
                    if !(p[0].is_finite() && p[1].is_finite() && p[2].is_finite()) {
                        return Err(SceneError::invalid(
                            path,
                            "a vertex position is NaN or infinite",
                            "fix the mesh",
                        ));
                    }
                    let flat = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
                    let n = match &normals {
                        Some(ns) => tri.map(|i| {
                            ns.get(i as usize)
                                .copied()
                                .filter(|n| *n != Vec3::ZERO && n.is_finite())
                                .unwrap_or(flat)
                        }),
                        None => [flat; 3],
                    };
                    let uv = match &uvs {
                        Some(uv) => tri.map(|i| uv.get(i as usize).copied().unwrap_or(Vec2::ZERO)),
                        None => [Vec2::ZERO; 3],
                    };
                    d.push(p, n, uv, material, object);
                }
            }
        }
        let kids: Vec<_> = node.children().map(|c| (c, world)).collect();
        todo.extend(kids.into_iter().rev());
    }
    if d.tris.is_empty() {
        return Err(SceneError::invalid(
            path,
            "no triangles in the default scene",
            "export triangle meshes",
        ));
    }
    if let Some((world, yfov)) = camera_node {
        let position = world.transform_point3(Vec3::ZERO);
        let forward = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
        let up = world.transform_vector3(Vec3::Y).normalize_or_zero();
        // Aim at the bounds' centre depth along the view direction (glTF gives no focus distance).
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for t in &d.tris {
            for q in [t.0, t.1, t.2] {
                lo = lo.min(q);
                hi = hi.max(q);
            }
        }
        let dist = ((lo + hi) * 0.5 - position).dot(forward).max(1e-2);
        if forward != Vec3::ZERO && position.is_finite() {
            d.camera = Some(Camera {
                position,
                look_at: position + forward * dist,
                up: if up == Vec3::ZERO { Vec3::Y } else { up },
                vfov_deg: yfov.to_degrees(),
                aperture_radius: 0.0,
                focus_distance: dist,
            });
        }
    }
    Ok(d)
}

fn texture_from_gltf(
    data: &gltf::image::Data,
    path: &Path,
    index: usize,
) -> Result<Texture, SceneError> {
    use gltf::image::Format;
    let channels = match data.format {
        Format::R8 => 1,
        Format::R8G8 => 2,
        Format::R8G8B8 => 3,
        Format::R8G8B8A8 => 4,
        other => {
            return Err(SceneError::invalid(
                path,
                format!(
                    "image {index} has pixel format {other:?}, only 8-bit images are supported"
                ),
                "convert the texture to 8-bit PNG or JPEG",
            ))
        }
    };
    Texture::from_srgb8(data.width, data.height, channels, &data.pixels).ok_or_else(|| {
        SceneError::invalid(
            path,
            format!("image {index} is empty or truncated"),
            "re-export the texture",
        )
    })
}
