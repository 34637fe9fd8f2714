//! Wavefront OBJ + MTL via `tobj`. MTL keys used: Kd (base colour), map_Kd (base-colour texture, sRGB),
//! Ke (emission), Ks (k_s), Ns (Phong exponent). OBJ has no camera (the caller frames the bounds).
//! OBJ's `vt` has v = 0 at the image's bottom row; textures here use v = 0 at the top (glTF), so we store
//! `1 - v`.
//!
//! We read the files ourselves and hand tobj the bytes, so a missing or unreadable `.obj`/`.mtl`/texture
//! is an IO error naming that file and who referenced it (tobj only says "open file failed"), and
//! `mtllib`/`map_Kd` paths go through the scene-directory check of [`crate::resource`]. A cheap pre-scan
//! of the text bounds the triangle count before tobj allocates and finds `usemtl` names the libraries do
//! not define (a warning: those faces get the default material).

use std::cell::RefCell;
use std::collections::HashMap;
use std::io::Cursor;
use std::path::Path;

use glam::{Vec2, Vec3};

use crate::data::SceneData;
use crate::limits::MAX_TRIANGLES;
use crate::resource::{read_capped, Resources};
use crate::texture::decode_texture;
use crate::{Material, SceneError};

/// What the pre-scan learns from the OBJ text without parsing it fully.
struct Prescan {
    /// Upper bound of the triangles a fan triangulation of the `f` lines yields.
    triangles: u64,
    /// `usemtl` names with the 1-based line of their first use.
    usemtl: Vec<(String, usize)>,
}

fn prescan(bytes: &[u8]) -> Prescan {
    let mut scan = Prescan { triangles: 0, usemtl: Vec::new() };
    for (i, line) in bytes.split(|&b| b == b'\n').enumerate() {
        let line = String::from_utf8_lossy(line);
        let mut words = line.split_whitespace();
        match words.next() {
            Some("f") => scan.triangles += words.count().saturating_sub(2) as u64,
            Some("usemtl") => {
                let name = line.trim().split_once(' ').map(|x| x.1.trim()).unwrap_or("").to_string();
                if !scan.usemtl.iter().any(|(n, _)| *n == name) {
                    scan.usemtl.push((name, i + 1));
                }
            }
            _ => {}
        }
    }
    scan
}

pub(crate) fn load_obj(path: &Path, res: &Resources) -> Result<SceneData, SceneError> {
    let bytes = read_capped(path, None)?;
    let scan = prescan(&bytes);
    if scan.triangles > MAX_TRIANGLES as u64 {
        return Err(SceneError::invalid(
            path,
            format!("its faces make {} triangles, more than the limit of {MAX_TRIANGLES}", scan.triangles),
            "decimate the mesh or split the scene",
        ));
    }
    let obj = parse(path, res, &bytes)?;
    let mut d = SceneData::default();
    warn_undefined_usemtl(&mut d, path, &scan, &obj);
    add_materials(&mut d, path, res, &obj)?;
    let mut default_material = None;
    for model in &obj.models {
        add_model(&mut d, path, model, obj.materials.len(), &mut default_material)?;
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

/// What tobj read from the OBJ text and its material libraries.
struct Parsed {
    models: Vec<tobj::Model>,
    materials: Vec<tobj::Material>,
    /// The `mtllib` names in the order tobj asked for them (warnings and errors name them).
    libraries: Vec<String>,
}

/// Parse the OBJ text with tobj, triangulated; each `mtllib` library is read through `res` (the
/// scene-directory check) and its colour lines checked before tobj sees it.
fn parse(path: &Path, res: &Resources, bytes: &[u8]) -> Result<Parsed, SceneError> {
    let opts = tobj::LoadOptions { single_index: false, triangulate: true, ..Default::default() };
    // tobj's material callback can only return tobj's error enum, so keep our (more precise) error here.
    let mtl_error: RefCell<Option<SceneError>> = RefCell::new(None);
    let mtl_names: RefCell<Vec<String>> = RefCell::new(Vec::new());
    let material_loader = |mtl: &Path| -> tobj::MTLLoadResult {
        let by = format!("mtllib {}", mtl.display());
        mtl_names.borrow_mut().push(mtl.display().to_string());
        let mtl_path = crate::resource::parent_dir(path).join(mtl);
        let loaded = res.read_referenced(path, mtl, &by).and_then(|b| {
            check_mtl_colours(&mtl_path, &b)?;
            tobj::load_mtl_buf(&mut Cursor::new(b)).map_err(|e| {
                SceneError::invalid(
                    &mtl_path,
                    format!("not a valid MTL material library ({e}; referenced by {} {by})", path.display()),
                    "fix or re-export the .mtl file",
                )
            })
        });
        loaded.map_err(|e| {
            mtl_error.borrow_mut().get_or_insert(e);
            tobj::LoadError::OpenFileFailed
        })
    };
    let (models, mats) = tobj::load_obj_buf(&mut Cursor::new(bytes), &opts, material_loader).map_err(|e| {
        SceneError::invalid(
            path,
            format!("not a valid OBJ file ({e})"),
            "fix the v/vt/vn/f lines (Wavefront OBJ text, 1-based or negative indices)",
        )
    })?;
    if let Some(e) = mtl_error.into_inner() {
        return Err(e);
    }
    // Only a library-loader failure (reported above) makes tobj return an error here.
    let materials = mats.unwrap_or_default();
    Ok(Parsed { models, materials, libraries: mtl_names.into_inner() })
}

/// A warning for each `usemtl` name the libraries do not define (tobj gives those faces no material,
/// so they get the default one), with the line of its first use.
fn warn_undefined_usemtl(d: &mut SceneData, path: &Path, scan: &Prescan, obj: &Parsed) {
    for (name, line) in &scan.usemtl {
        if !obj.materials.iter().any(|m| &m.name == name) {
            let libs = &obj.libraries;
            let libs = if libs.is_empty() { "no mtllib line".to_string() } else { libs.join(", ") };
            d.warnings.push(format!(
                "{}:{line}: usemtl '{name}' is not defined in the material library ({libs}); its faces use \
                 the default grey material — define it in the .mtl or fix the name",
                path.display()
            ));
        }
    }
}

/// The libraries' materials in tobj's order, so tobj's material id `i` is material `i` here; each
/// `map_Kd` texture is decoded once, however many materials name it.
fn add_materials(d: &mut SceneData, path: &Path, res: &Resources, obj: &Parsed) -> Result<(), SceneError> {
    let mut tex_cache: HashMap<String, u32> = HashMap::new();
    for m in &obj.materials {
        let base_color_texture = match &m.diffuse_texture {
            Some(name) if !name.trim().is_empty() => {
                Some(load_texture_cached(d, &mut tex_cache, res, path, &m.name, name.trim())?)
            }
            _ => None,
        };
        let material = material(path, m, &obj.libraries.join(", "), base_color_texture)?;
        d.add_material(material, false);
    }
    Ok(())
}

/// Material `m` of the libraries `mtl_file`: Kd, Ke, Ks clamped to >= 0, and a Phong lobe only
/// where both Ks and Ns are positive. NaN/inf in a library is refused (it would render black or
/// NaN); the .mtl path is named.
fn material(
    path: &Path,
    m: &tobj::Material,
    mtl_file: &str,
    base_color_texture: Option<u32>,
) -> Result<Material, SceneError> {
    let v3 = |a: Option<[f32; 3]>, key: &str, def: Vec3| -> Result<Vec3, SceneError> {
        match a.map(Vec3::from) {
            Some(v) if !v.is_finite() => Err(SceneError::invalid(
                path,
                format!("material '{}' in {mtl_file} has {key} {v}", m.name),
                format!("use finite, non-negative {key} values"),
            )),
            v => Ok(v.unwrap_or(def).max(Vec3::ZERO)),
        }
    };
    let specular = v3(m.specular, "Ks", Vec3::ZERO)?;
    if m.shininess.is_some_and(|s| !s.is_finite()) {
        return Err(SceneError::invalid(
            path,
            format!("material '{}' in {mtl_file} has a non-finite Ns", m.name),
            "use a finite Phong exponent Ns >= 0",
        ));
    }
    let ns = m.shininess.filter(|s| *s > 0.0).unwrap_or(0.0);
    Ok(Material {
        name: m.name.clone(),
        base_color: v3(m.diffuse, "Kd", Vec3::splat(0.8))?,
        base_color_texture,
        emission: v3(m.emissive, "Ke", Vec3::ZERO)?,
        specular: if ns > 0.0 { specular } else { Vec3::ZERO },
        phong_exponent: if specular.max_element() > 0.0 { ns } else { 0.0 },
    })
}

/// One `o`/`g` model as an object with its triangles, after checking its material id (the default
/// grey material, added on first use, where it has none), its vn/vt values and its triangulation.
fn add_model(
    d: &mut SceneData,
    path: &Path,
    model: &tobj::Model,
    materials: usize,
    default_material: &mut Option<u32>,
) -> Result<(), SceneError> {
    let mesh = &model.mesh;
    // Named after its `o`/`g` line, so `Scene::set_motion` can name it (tobj's "unnamed_object"
    // when there is none).
    let object = if model.name.is_empty() { d.new_object() } else { d.new_named_object(model.name.clone()) };
    let material = match mesh.material_id {
        Some(id) if id < materials => id as u32,
        Some(id) => {
            return Err(SceneError::invalid(
                path,
                format!("object '{}' uses material {id} but the library has {}", model.name, materials),
                "fix the usemtl/mtllib lines",
            ))
        }
        None => *default_material
            .get_or_insert_with(|| d.add_material(Material::diffuse("default", Vec3::splat(0.8)), false)),
    };
    if !(mesh.normals.iter().all(|x| x.is_finite()) && mesh.texcoords.iter().all(|x| x.is_finite())) {
        return Err(SceneError::invalid(
            path,
            format!("object '{}' has a NaN or infinite normal (vn) or texture coordinate (vt)", model.name),
            "fix the vn/vt lines",
        ));
    }
    if !mesh.indices.len().is_multiple_of(3) {
        return Err(SceneError::invalid(
            path,
            format!("object '{}' has a non-triangle face", model.name),
            "triangulate the mesh",
        ));
    }
    for (f, tri) in mesh.indices.chunks_exact(3).enumerate() {
        let (p, n, uv) = face(path, model, f, tri)?;
        d.push(p, n, uv, material, object);
    }
    Ok(())
}

/// A triangle's positions, normals and texture coordinates, as [`SceneData::push`] takes them.
type Face = ([Vec3; 3], [Vec3; 3], [Vec2; 3]);

/// Face `f` of `model` (`tri` = its position indices): positions, normals (the flat one where the
/// file gives none or a zero one) and texture coordinates (v flipped: OBJ's v = 0 is the bottom row).
fn face(path: &Path, model: &tobj::Model, f: usize, tri: &[u32]) -> Result<Face, SceneError> {
    let mesh = &model.mesh;
    let p = [vertex(path, model, tri[0])?, vertex(path, model, tri[1])?, vertex(path, model, tri[2])?];
    let flat = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
    let mut n = [flat; 3];
    // tobj checks v indices but not vt/vn ones: an out-of-range one is an error, not a default.
    let out_of_range = |what: &str| {
        SceneError::invalid(
            path,
            format!("object '{}' face {f} has a {what} index beyond the {what} lines", model.name),
            format!("fix the f lines' {what} indices"),
        )
    };
    for (k, nk) in n.iter_mut().enumerate() {
        if let Some(&ni) = mesh.normal_indices.get(f * 3 + k) {
            let ni = ni as usize * 3;
            let s = mesh.normals.get(ni..ni + 3).ok_or_else(|| out_of_range("vn"))?;
            let v = Vec3::new(s[0], s[1], s[2]).normalize_or_zero();
            if v != Vec3::ZERO {
                *nk = v;
            }
        }
    }
    let mut uv = [Vec2::ZERO; 3];
    for (k, uvk) in uv.iter_mut().enumerate() {
        if let Some(&ti) = mesh.texcoord_indices.get(f * 3 + k) {
            let ti = ti as usize * 2;
            let s = mesh.texcoords.get(ti..ti + 2).ok_or_else(|| out_of_range("vt"))?;
            *uvk = Vec2::new(s[0], 1.0 - s[1]); // OBJ v=0 is the bottom row
        }
    }
    Ok((p, n, uv))
}

/// Position `i` of `model`, refused if NaN/inf or out of range.
fn vertex(path: &Path, model: &tobj::Model, i: u32) -> Result<Vec3, SceneError> {
    let i = i as usize * 3;
    let p = model.mesh.positions.get(i..i + 3).map(|s| Vec3::new(s[0], s[1], s[2]));
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
}

fn load_texture_cached(
    d: &mut SceneData,
    cache: &mut HashMap<String, u32>,
    res: &Resources,
    obj: &Path,
    material: &str,
    name: &str,
) -> Result<u32, SceneError> {
    if let Some(&i) = cache.get(name) {
        return Ok(i);
    }
    let by = format!("material '{material}' map_Kd {name}");
    let bytes = res.read_referenced(obj, Path::new(name), &by)?;
    let file = crate::resource::parent_dir(obj).join(name);
    let tex = decode_texture(&bytes, &file, &format!("the texture ({} {by})", obj.display()))?;
    d.textures.push(tex);
    let i = (d.textures.len() - 1) as u32;
    cache.insert(name.to_string(), i);
    Ok(i)
}

/// tobj 4.0 panics (an `unwrap` in its `parse_float3`) on a colour line with fewer than three
/// numbers, e.g. `Ks 0.2` (found by fuzzing), so such lines are refused here first, by line number.
fn check_mtl_colours(mtl: &Path, bytes: &[u8]) -> Result<(), SceneError> {
    for (n, line) in String::from_utf8_lossy(bytes).lines().enumerate() {
        let mut words = line.split_whitespace();
        let Some(key @ ("Ka" | "Kd" | "Ks" | "Ke")) = words.next() else { continue };
        let given = words.count();
        if given < 3 {
            return Err(SceneError::invalid(
                mtl,
                format!("line {}: `{key}` has {given} value(s) but needs three (r g b)", n + 1),
                format!("write the colour as `{key} r g b`, e.g. `{key} 0.2 0.2 0.2`"),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::prescan;

    #[test]
    fn prescan_bounds_triangles_and_lists_usemtl_lines() {
        let scan = prescan(b"v 0 0 0\nf 1 2 3\nusemtl a\nf 1 2 3 4 5\r\nusemtl b\nusemtl a\nf 1 2\n");
        // 1 + 3 (fan of a pentagon) + 0 (a two-vertex face makes none).
        assert_eq!(scan.triangles, 4);
        assert_eq!(scan.usemtl, vec![("a".to_string(), 3), ("b".to_string(), 5)]);
    }
}
