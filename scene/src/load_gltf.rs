//! glTF 2.0 (.gltf/.glb), read from the `gltf` crate's JSON model without its validation or readers.
//!
//! The crate's `import` panics on hostile files (an out-of-range accessor index inside its own
//! validation, a `byteStride` smaller than an element, an index accessor of floats, texture coordinates
//! of `UNSIGNED_INT`), follows node cycles forever and reads any `uri` on disk. So this loader parses the
//! JSON with `Gltf::from_slice_without_validation` and does the rest itself: every index is looked up
//! with a bounds check, every accessor is checked (component type and type allowed for its semantic,
//! stride ≥ element size, `byteOffset + (count−1)·stride + element` inside the bufferView, the bufferView
//! inside its buffer, the buffer's data as long as its `byteLength`) before a byte is read, node graphs
//! must be trees (a cycle or a node with two parents is an error), instanced triangles are counted
//! against [`MAX_TRIANGLES`] before geometry is built, and `uri`s go through [`Resources`]. Every error
//! names the JSON path (`meshes[0].primitives[0].attributes.POSITION`).
//!
//! Materials: base colour factor × base-colour texture (sRGB, decoded to linear) is k_d, scaled by
//! (1 − metallic); emission = emissiveFactor × KHR_materials_emissive_strength; a Phong lobe is derived
//! from metallic-roughness: α = roughness², m = 2/α² − 2 (the Blinn-Phong exponent matching a GGX/Beckmann
//! roughness), k_s = mix(0.04, base colour, metallic); roughness 1 (m = 0) means no glossy lobe.
//! `doubleSided` emissive materials become two-sided lights. Camera: the first node (depth-first in the
//! default scene) with a perspective camera; otherwise none (the bounds are framed). Sparse accessors,
//! quantized positions (KHR_mesh_quantization) and non-triangle modes are not supported (the last are
//! skipped with a warning).

use std::collections::HashMap;
use std::path::Path;

use glam::{Mat3, Mat4, Quat, Vec2, Vec3};
use gltf::json;
use json::accessor::{ComponentType, GenericComponentType, Type};
use json::mesh::{Mode, Semantic};
use json::validation::Checked;

use crate::data::SceneData;
use crate::limits::{MAX_ACCESSOR_ELEMENTS, MAX_COORDINATE, MAX_RADIANCE, MAX_TRIANGLES};
use crate::motion::RigidMotion;
use crate::resource::{read_capped, Resources};
use crate::texture::decode_texture;
use crate::{Camera, Material, SceneError, Texture};

/// A `SceneError::Invalid` for this file.
fn bad(path: &Path, what: impl Into<String>, fix: impl Into<String>) -> SceneError {
    SceneError::invalid(path, what, fix)
}

/// `items[index]`, or an error naming the JSON path that holds the index.
fn get<'a, T>(path: &Path, items: &'a [T], index: usize, kind: &str, at: &str) -> Result<&'a T, SceneError> {
    items.get(index).ok_or_else(|| {
        bad(
            path,
            format!("{at} = {index} but the file has {} {kind}", items.len()),
            format!("point {at} at an existing entry of `{kind}`"),
        )
    })
}

/// Buffers decoded on first use (a file may declare buffers nothing reads).
struct Buffers<'a> {
    path: &'a Path,
    res: &'a Resources,
    blob: Option<Vec<u8>>,
    loaded: Vec<Option<Vec<u8>>>,
}

impl Buffers<'_> {
    fn get(&mut self, root: &json::Root, b: usize, at: &str) -> Result<&[u8], SceneError> {
        let buffer = get(self.path, &root.buffers, b, "buffers", at)?;
        if self.loaded[b].is_none() {
            let data = match &buffer.uri {
                None => self.blob.take().ok_or_else(|| {
                    bad(
                        self.path,
                        format!("buffers[{b}] has no uri and the file has no GLB binary chunk"),
                        "give the buffer a uri or export as .glb",
                    )
                })?,
                Some(uri) => read_uri(self.path, self.res, uri, &format!("buffers[{b}].uri"))?,
            };
            self.loaded[b] = Some(data);
        }
        let data = self.loaded[b].as_deref().unwrap_or_default();
        let declared = buffer.byte_length.0;
        if (data.len() as u64) < declared {
            return Err(bad(
                self.path,
                format!("buffers[{b}] declares byteLength {declared} but its data has {} bytes", data.len()),
                "re-export the file with its complete .bin (or fix byteLength)",
            ));
        }
        Ok(&data[..declared as usize])
    }
}

/// The bytes a `uri` names: a base64 `data:` URI, or a file relative to the glTF file (percent-decoded,
/// subject to the scene-directory rule).
fn read_uri(path: &Path, res: &Resources, uri: &str, at: &str) -> Result<Vec<u8>, SceneError> {
    let by = format!("{at} = \"{}\"", shorten(uri));
    if let Some(rest) = uri.strip_prefix("data:") {
        let Some((_, b64)) = rest.split_once(";base64,") else {
            return Err(bad(path, format!("{by} is a data URI without ;base64,"), "embed data as base64 data URIs"));
        };
        return base64::decode(b64)
            .map_err(|e| bad(path, format!("{by} is not valid base64 ({e})"), "re-export the file"));
    }
    let file = if let Some(rest) = uri.strip_prefix("file://").or_else(|| uri.strip_prefix("file:")) {
        rest.to_string()
    } else if uri.contains("://") {
        return Err(bad(
            path,
            format!("{by} uses a URI scheme other than data: or a file path"),
            "download the resource and refer to it by a relative path",
        ));
    } else {
        urlencoding::decode(uri)
            .map_err(|_| bad(path, format!("{by} has percent-escapes that are not UTF-8"), "fix the uri"))?
            .into_owned()
    };
    res.read_referenced(path, Path::new(&file), &by)
}

/// Long data URIs would drown the message.
fn shorten(uri: &str) -> String {
    match uri.char_indices().nth(60) {
        Some((i, _)) => format!("{}…", &uri[..i]),
        None => uri.to_string(),
    }
}

fn component_size(c: ComponentType) -> u64 {
    match c {
        ComponentType::I8 | ComponentType::U8 => 1,
        ComponentType::I16 | ComponentType::U16 => 2,
        ComponentType::U32 | ComponentType::F32 => 4,
    }
}

fn component_name(c: ComponentType) -> &'static str {
    match c {
        ComponentType::I8 => "BYTE",
        ComponentType::U8 => "UNSIGNED_BYTE",
        ComponentType::I16 => "SHORT",
        ComponentType::U16 => "UNSIGNED_SHORT",
        ComponentType::U32 => "UNSIGNED_INT",
        ComponentType::F32 => "FLOAT",
    }
}

fn type_components(t: Type) -> u64 {
    match t {
        Type::Scalar => 1,
        Type::Vec2 => 2,
        Type::Vec3 => 3,
        Type::Vec4 | Type::Mat2 => 4,
        Type::Mat3 => 9,
        Type::Mat4 => 16,
    }
}

fn type_name(t: Type) -> &'static str {
    match t {
        Type::Scalar => "SCALAR",
        Type::Vec2 => "VEC2",
        Type::Vec3 => "VEC3",
        Type::Vec4 => "VEC4",
        Type::Mat2 => "MAT2",
        Type::Mat3 => "MAT3",
        Type::Mat4 => "MAT4",
    }
}

/// What a semantic may be stored as (the glTF 2.0 spec's table, without KHR_mesh_quantization).
struct Layout {
    ty: Type,
    /// Allowed component types, each with whether it must be `normalized`.
    components: &'static [(ComponentType, bool)],
}

const POSITION: Layout = Layout { ty: Type::Vec3, components: &[(ComponentType::F32, false)] };
const NORMAL: Layout = POSITION;
const TEXCOORD: Layout = Layout {
    ty: Type::Vec2,
    components: &[(ComponentType::F32, false), (ComponentType::U8, true), (ComponentType::U16, true)],
};
const INDICES: Layout = Layout {
    ty: Type::Scalar,
    components: &[(ComponentType::U8, false), (ComponentType::U16, false), (ComponentType::U32, false)],
};

/// One component as f32 (normalized integers mapped to 0..1). Only layouts above reach it, so signed
/// integers never do.
fn decode_f32(comp: ComponentType, b: &[u8], normalized: bool) -> f32 {
    match comp {
        ComponentType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        ComponentType::U16 if normalized => u16::from_le_bytes([b[0], b[1]]) as f32 / 65535.0,
        ComponentType::U8 if normalized => b[0] as f32 / 255.0,
        _ => decode_u32(comp, b, normalized) as f32,
    }
}

/// One unsigned integer component (indices).
fn decode_u32(comp: ComponentType, b: &[u8], _normalized: bool) -> u32 {
    match comp {
        ComponentType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        ComponentType::U16 => u16::from_le_bytes([b[0], b[1]]) as u32,
        ComponentType::U8 => b[0] as u32,
        _ => 0,
    }
}

/// Read accessor `index` (referenced at JSON path `at`) as `layout` says, after checking every bound;
/// `decode` turns one component's little-endian bytes into a value.
fn read_accessor<T: Default + Clone>(
    path: &Path,
    root: &json::Root,
    buffers: &mut Buffers,
    index: usize,
    at: &str,
    layout: &Layout,
    decode: fn(ComponentType, &[u8], bool) -> T,
) -> Result<Vec<T>, SceneError> {
    let acc = get(path, &root.accessors, index, "accessors", at)?;
    let here = format!("accessors[{index}] (used as {at})");
    let (Checked::Valid(ty), Checked::Valid(GenericComponentType(comp))) = (&acc.type_, &acc.component_type) else {
        return Err(bad(path, format!("{here} has an unknown type or componentType"), "re-export the file"));
    };
    let (ty, comp) = (*ty, *comp);
    let allowed = layout.components.iter().find(|(c, _)| *c == comp);
    if ty != layout.ty || allowed.is_none() {
        let names: Vec<_> = layout.components.iter().map(|(c, _)| component_name(*c)).collect();
        return Err(bad(
            path,
            format!(
                "{here} is {} {}, but {at} must be {} of {}",
                type_name(ty),
                component_name(comp),
                type_name(layout.ty),
                names.join(" or ")
            ),
            "re-export the mesh with a standard vertex layout",
        ));
    }
    if allowed.is_some_and(|(_, must_normalize)| *must_normalize && !acc.normalized) {
        return Err(bad(
            path,
            format!("{here} is {} but not normalized", component_name(comp)),
            "set \"normalized\": true or store FLOAT",
        ));
    }
    if acc.sparse.is_some() {
        return Err(bad(
            path,
            format!("{here} is a sparse accessor, which wedge does not read"),
            "export without sparse accessors",
        ));
    }
    let count = acc.count.0;
    if count == 0 {
        return Err(bad(path, format!("{here} has count 0"), "remove the empty primitive or fix the count"));
    }
    if count > MAX_ACCESSOR_ELEMENTS {
        return Err(bad(
            path,
            format!("{here} has count {count}, more than the limit of {MAX_ACCESSOR_ELEMENTS}"),
            "split the mesh",
        ));
    }
    let comps = type_components(ty);
    let size = component_size(comp);
    let elem = comps * size;
    let Some(view_index) = acc.buffer_view.map(|v| v.value()) else {
        // The spec: an accessor without a bufferView (and not sparse) is all zeros.
        return Ok(vec![T::default(); (count * comps) as usize]);
    };
    let view_at = format!("accessors[{index}].bufferView");
    let view = get(path, &root.buffer_views, view_index, "bufferViews", &view_at)?;
    let stride = view.byte_stride.map(|s| s.0 as u64).unwrap_or(elem);
    if stride < elem {
        return Err(bad(
            path,
            format!(
                "bufferViews[{view_index}].byteStride is {stride} but {here} has {elem}-byte elements ({} {})",
                type_name(ty),
                component_name(comp)
            ),
            format!("set byteStride to at least {elem} (or remove it for tightly packed data)"),
        ));
    }
    let offset = acc.byte_offset.map(|o| o.0).unwrap_or(0);
    let need = (count - 1).checked_mul(stride).and_then(|x| x.checked_add(offset)).and_then(|x| x.checked_add(elem));
    let view_len = view.byte_length.0;
    if need.is_none_or(|n| n > view_len) {
        return Err(bad(
            path,
            format!(
                "{here} needs {} bytes (byteOffset {offset} + {count} elements × stride {stride}) but bufferViews[{view_index}] has byteLength {view_len}",
                need.map_or("more than 2^64".to_string(), |n| n.to_string())
            ),
            "fix the accessor's count/byteOffset or the bufferView's byteLength (re-export the file)",
        ));
    }
    let buffer_index = view.buffer.value();
    let view_offset = view.byte_offset.map(|o| o.0).unwrap_or(0);
    let buffer_len =
        get(path, &root.buffers, buffer_index, "buffers", &format!("bufferViews[{view_index}].buffer"))?.byte_length.0;
    if view_offset.checked_add(view_len).is_none_or(|end| end > buffer_len) {
        return Err(bad(
            path,
            format!("bufferViews[{view_index}] (byteOffset {view_offset} + byteLength {view_len}) runs past buffers[{buffer_index}].byteLength {buffer_len}"),
            "fix the bufferView or re-export the file",
        ));
    }
    let data = buffers.get(root, buffer_index, &format!("bufferViews[{view_index}].buffer"))?;
    // All bounds are checked above, so these slices are in range (`get` would only hide a bug).
    let bytes = &data[(view_offset + offset) as usize..(view_offset + view_len) as usize];
    let mut out = Vec::with_capacity((count * comps) as usize);
    for i in 0..count {
        let base = (i * stride) as usize;
        for c in 0..comps {
            let at = base + (c * size) as usize;
            out.push(decode(comp, &bytes[at..at + size as usize], acc.normalized));
        }
    }
    Ok(out)
}

/// Read a float attribute and refuse NaN/inf (which would render black or NaN).
fn read_floats(
    path: &Path,
    root: &json::Root,
    buffers: &mut Buffers,
    index: usize,
    at: &str,
    layout: &Layout,
) -> Result<Vec<f32>, SceneError> {
    let values = read_accessor(path, root, buffers, index, at, layout, decode_f32)?;
    let n = type_components(layout.ty) as usize;
    if let Some(k) = values.iter().position(|v| !v.is_finite()) {
        return Err(bad(
            path,
            format!("{at}: element {} (accessors[{index}]) is NaN or infinite", k / n),
            "fix the mesh data",
        ));
    }
    Ok(values)
}

/// A primitive's data as read from the file (before the node transform).
struct Primitive {
    positions: Vec<Vec3>,
    normals: Option<Vec<Vec3>>,
    uvs: Option<Vec<Vec2>>,
    indices: Vec<u32>,
    material: Option<usize>,
}

/// Read and check one triangle primitive.
fn read_primitive(
    path: &Path,
    root: &json::Root,
    buffers: &mut Buffers,
    mesh: usize,
    p: usize,
    texcoord_set: &dyn Fn(Option<usize>) -> u32,
) -> Result<Primitive, SceneError> {
    let prim = &root.meshes[mesh].primitives[p];
    let at = format!("meshes[{mesh}].primitives[{p}]");
    let attribute = |s: Semantic| prim.attributes.get(&Checked::Valid(s)).map(|i| i.value());
    let Some(pos_index) = attribute(Semantic::Positions) else {
        return Err(bad(path, format!("{at} has no POSITION attribute"), "export positions"));
    };
    let pos_at = format!("{at}.attributes.POSITION");
    let positions: Vec<Vec3> = read_floats(path, root, buffers, pos_index, &pos_at, &POSITION)?
        .chunks_exact(3)
        .map(|c| Vec3::new(c[0], c[1], c[2]))
        .collect();
    let n = positions.len();
    let check_count = |what: &str, len: usize| {
        if len == n {
            Ok(())
        } else {
            Err(bad(
                path,
                format!("{at}.attributes.{what} has {len} elements but POSITION has {n}"),
                "re-export the mesh",
            ))
        }
    };
    let normals = match attribute(Semantic::Normals) {
        Some(i) => {
            let v: Vec<Vec3> = read_floats(path, root, buffers, i, &format!("{at}.attributes.NORMAL"), &NORMAL)?
                .chunks_exact(3)
                .map(|c| Vec3::new(c[0], c[1], c[2]))
                .collect();
            check_count("NORMAL", v.len())?;
            Some(v)
        }
        None => None,
    };
    let material = prim.material.map(|m| m.value());
    let set = texcoord_set(material);
    let uvs = match attribute(Semantic::TexCoords(set)) {
        Some(i) => {
            let name = format!("TEXCOORD_{set}");
            let v: Vec<Vec2> = read_floats(path, root, buffers, i, &format!("{at}.attributes.{name}"), &TEXCOORD)?
                .chunks_exact(2)
                .map(|c| Vec2::new(c[0], c[1]))
                .collect();
            check_count(&name, v.len())?;
            Some(v)
        }
        None => None,
    };
    let indices: Vec<u32> = match prim.indices.map(|i| i.value()) {
        Some(i) => {
            let idx_at = format!("{at}.indices");
            let raw = read_accessor(path, root, buffers, i, &idx_at, &INDICES, decode_u32)?;
            if !raw.len().is_multiple_of(3) {
                return Err(bad(
                    path,
                    format!("{idx_at}: {} indices is not a multiple of 3", raw.len()),
                    "export triangle lists (mode 4) with whole triangles",
                ));
            }
            if let Some(k) = raw.iter().position(|&v| v as usize >= n) {
                return Err(bad(
                    path,
                    format!("{idx_at}: index {} at position {k} is out of range (POSITION has {n} vertices)", raw[k]),
                    "fix the index data or re-export the mesh",
                ));
            }
            raw
        }
        None => {
            if !n.is_multiple_of(3) {
                return Err(bad(
                    path,
                    format!("{pos_at} has {n} vertices, not a multiple of 3 (the primitive has no indices)"),
                    "export whole triangles",
                ));
            }
            (0..n as u32).collect()
        }
    };
    Ok(Primitive { positions, normals, uvs, indices, material })
}

/// A node's local transform (matrix, or translation·rotation·scale), refusing non-finite values.
fn local_transform(path: &Path, node: &json::Node, n: usize) -> Result<Mat4, SceneError> {
    local_transform_at(path, node, n, [None, None, None])
}

/// [`local_transform`] with animated values (`[translation, rotation, scale]`, each `None` where no
/// channel targets it) in place of the node's own.
fn local_transform_at(
    path: &Path,
    node: &json::Node,
    n: usize,
    animated: [Option<[f32; 4]>; 3],
) -> Result<Mat4, SceneError> {
    let finite = |what: &str, v: &[f32]| {
        if v.iter().all(|x| x.is_finite()) {
            Ok(())
        } else {
            Err(bad(path, format!("nodes[{n}].{what} {v:?} is not finite"), "use finite transform values"))
        }
    };
    if let Some(m) = &node.matrix {
        finite("matrix", m)?;
        return Ok(Mat4::from_cols_array(m));
    }
    let xyz = |v: [f32; 4]| [v[0], v[1], v[2]];
    let t = animated[0].map(xyz).unwrap_or(node.translation.unwrap_or([0.0; 3]));
    let r = animated[1].unwrap_or(node.rotation.as_ref().map(|q| q.0).unwrap_or([0.0, 0.0, 0.0, 1.0]));
    let s = animated[2].map(xyz).unwrap_or(node.scale.unwrap_or([1.0; 3]));
    finite("translation", &t)?;
    finite("rotation", &r)?;
    finite("scale", &s)?;
    let q = Quat::from_array(r);
    let len = q.length();
    if !(len.is_finite() && len > 1e-6) {
        return Err(bad(path, format!("nodes[{n}].rotation {r:?} is not a rotation"), "use a unit quaternion"));
    }
    let q = q / len;
    Ok(Mat4::from_scale_rotation_translation(Vec3::from(s), q, Vec3::from(t)))
}

/// A mesh instance found while walking the node tree.
struct Instance {
    node: usize,
    mesh: usize,
    /// World transform at shutter open (the triangles' rest pose).
    world: Mat4,
    /// World transform at shutter close, and the pivot of its motion: the origin (at open) of the
    /// nearest animated node at or above it. Equal to `world` when nothing above it moves.
    world_close: Mat4,
    pivot: Vec3,
}

/// A material's values, with glTF JSON paths on the refusals.
fn material(path: &Path, i: usize, m: &json::Material) -> Result<(Material, bool), SceneError> {
    let at = format!("materials[{i}]");
    let pbr = &m.pbr_metallic_roughness;
    let bc = pbr.base_color_factor.0;
    let metallic = pbr.metallic_factor.0;
    let roughness = pbr.roughness_factor.0;
    let e = m.emissive_factor.0;
    let strength =
        m.extensions.as_ref().and_then(|x| x.emissive_strength.as_ref()).map(|s| s.emissive_strength.0).unwrap_or(1.0);
    let checks: [(&str, &[f32]); 5] = [
        ("pbrMetallicRoughness.baseColorFactor", &bc),
        ("pbrMetallicRoughness.metallicFactor", &[metallic]),
        ("pbrMetallicRoughness.roughnessFactor", &[roughness]),
        ("emissiveFactor", &e),
        ("extensions.KHR_materials_emissive_strength.emissiveStrength", &[strength]),
    ];
    for (field, v) in checks {
        if v.iter().any(|x| !x.is_finite() || *x < 0.0) {
            return Err(bad(path, format!("{at}.{field} is {v:?}"), "use finite, non-negative values"));
        }
    }
    let emission = Vec3::from(e) * strength;
    // Both factors are finite and non-negative here, so the product is never NaN; overflow gives inf.
    if emission.max_element() > MAX_RADIANCE {
        return Err(bad(
            path,
            format!("{at}: emissiveFactor {e:?} × emissiveStrength {strength} = {emission}, more than the limit of {MAX_RADIANCE:e}"),
            "lower KHR_materials_emissive_strength.emissiveStrength (radiance in W/(sr·m²))",
        ));
    }
    let base = Vec3::new(bc[0], bc[1], bc[2]);
    let metallic = metallic.clamp(0.0, 1.0);
    let roughness = roughness.clamp(0.0, 1.0);
    let alpha = (roughness * roughness).max(1e-3);
    let m_exp = (2.0 / (alpha * alpha) - 2.0).clamp(0.0, 1e4);
    let specular = if m_exp > 0.0 { Vec3::splat(0.04).lerp(base, metallic) } else { Vec3::ZERO };
    Ok((
        Material {
            name: m.name.clone().unwrap_or_else(|| format!("material{i}")),
            base_color: base * (1.0 - metallic),
            base_color_texture: None,
            emission,
            specular,
            phong_exponent: m_exp,
        },
        m.double_sided,
    ))
}

/// Decode `images[img]` (from its bufferView or uri).
fn image(
    path: &Path,
    res: &Resources,
    root: &json::Root,
    buffers: &mut Buffers,
    img: usize,
    at: &str,
) -> Result<Texture, SceneError> {
    let image = get(path, &root.images, img, "images", at)?;
    let bytes = match (&image.buffer_view, &image.uri) {
        (Some(v), _) => {
            let v = v.value();
            let view_at = format!("images[{img}].bufferView");
            let view = get(path, &root.buffer_views, v, "bufferViews", &view_at)?;
            let (off, len) = (view.byte_offset.map(|o| o.0).unwrap_or(0), view.byte_length.0);
            let data = buffers.get(root, view.buffer.value(), &format!("bufferViews[{v}].buffer"))?;
            match off.checked_add(len) {
                Some(end) if end <= data.len() as u64 => data[off as usize..end as usize].to_vec(),
                _ => {
                    return Err(bad(
                        path,
                        format!("bufferViews[{v}] (for images[{img}]) runs past its buffer"),
                        "re-export the file",
                    ));
                }
            }
        }
        (None, Some(uri)) => read_uri(path, res, uri, &format!("images[{img}].uri"))?,
        (None, None) => {
            return Err(bad(path, format!("images[{img}] has neither uri nor bufferView"), "re-export the file"))
        }
    };
    decode_texture(&bytes, path, &format!("images[{img}]"))
}

pub(crate) fn load_gltf(path: &Path, res: &Resources) -> Result<SceneData, SceneError> {
    let bytes = read_capped(path, None)?;
    let gltf = gltf::Gltf::from_slice_without_validation(&bytes).map_err(|e| {
        bad(path, format!("not a valid glTF file ({e})"), "re-export it as glTF 2.0 (.gltf JSON or .glb)")
    })?;
    drop(bytes);
    let blob = gltf.blob;
    let root = gltf.document.into_json();
    let mut buffers = Buffers { path, res, blob, loaded: vec![None; root.buffers.len()] };
    let mut d = SceneData::default();
    add_materials(path, res, &root, &mut buffers, &mut d)?;
    let (scene_index, scene_at) = match root.scene {
        Some(s) => (s.value(), "scene".to_string()),
        None => (0, "scenes".to_string()),
    };
    if root.scenes.is_empty() {
        return Err(bad(path, "the file has no scene", "export at least one scene with meshes"));
    }
    let scene = get(path, &root.scenes, scene_index, "scenes", &scene_at)?;
    // Animations are sampled at the shutter's two ends (the camera's `shutter_open`/`shutter_close`;
    // 0 and 0 unless the caller gives a shutter): each node's world transform at both times.
    let shutter = res.shutter.unwrap_or((0.0, 0.0));
    let animations = read_animations(path, &root, &mut buffers, &mut d.warnings)?;
    if animations.channels > 0 && shutter.0 == shutter.1 {
        d.warnings.push(format!(
            "{}: {} animation channel(s) are sampled at time {} only (the shutter is empty), so nothing moves — give the camera a shutter (RON scene file `shutter`, or the pipeline's camera) to render motion blur",
            path.display(),
            animations.channels,
            shutter.0
        ));
    }
    let walk = walk_nodes(path, &root, (scene_index, scene), &animations, shutter, &mut d.warnings)?;
    add_instances(path, &root, &mut buffers, &walk.instances, &mut d)?;
    if d.tris.is_empty() {
        return Err(bad(path, "no triangles in the default scene", "export triangle meshes"));
    }
    if let Some((n, world, yfov)) = walk.camera {
        d.camera = Some(node_camera(path, n, world, yfov, shutter, &d)?);
    }
    Ok(d)
}

/// The materials in document order, so material i is SceneData material i; their base-colour
/// textures decoded on first use (each image once).
fn add_materials(
    path: &Path,
    res: &Resources,
    root: &json::Root,
    buffers: &mut Buffers,
    d: &mut SceneData,
) -> Result<(), SceneError> {
    let mut image_to_texture: HashMap<usize, u32> = HashMap::new();
    for (i, m) in root.materials.iter().enumerate() {
        let (mut mat, two_sided) = material(path, i, m)?;
        if let Some(info) = &m.pbr_metallic_roughness.base_color_texture {
            let tex_at = format!("materials[{i}].pbrMetallicRoughness.baseColorTexture.index");
            let texture = get(path, &root.textures, info.index.value(), "textures", &tex_at)?;
            let img = texture.source.value();
            let t = match image_to_texture.get(&img) {
                Some(&t) => t,
                None => {
                    let src_at = format!("textures[{}].source", info.index.value());
                    d.textures.push(image(path, res, root, buffers, img, &src_at)?);
                    let t = (d.textures.len() - 1) as u32;
                    image_to_texture.insert(img, t);
                    t
                }
            };
            mat.base_color_texture = Some(t);
        }
        d.add_material(mat, two_sided);
    }
    Ok(())
}

/// What the walk of the default scene's node tree found: the mesh instances with their world
/// transforms, and the first perspective camera (node, world transform, vertical field of view).
struct Walk {
    instances: Vec<Instance>,
    camera: Option<(usize, Mat4, f32)>,
}

/// Walk the default scene's (`scene_index`) node tree once: each node at most once (a second visit is a cycle or a
/// node with two parents, both invalid glTF), so the walk is linear in the node count; each node's
/// world transform at shutter open and close; triangles counted before any is read (a small file
/// can instance a mesh millions of times).
fn walk_nodes(
    path: &Path,
    root: &json::Root,
    (scene_index, scene): (usize, &json::Scene),
    animations: &Animations,
    shutter: (f32, f32),
    warnings: &mut Vec<String>,
) -> Result<Walk, SceneError> {
    let mut visited = vec![false; root.nodes.len()];
    // (node, parent's world at open and at close, the pivot of the nearest animated ancestor, path)
    let mut todo: Vec<(usize, Mat4, Mat4, Option<Vec3>, String)> = scene
        .nodes
        .iter()
        .enumerate()
        .rev()
        .map(|(k, n)| (n.value(), Mat4::IDENTITY, Mat4::IDENTITY, None, format!("scenes[{scene_index}].nodes[{k}]")))
        .collect();
    let mut walk = Walk { instances: Vec::new(), camera: None };
    let mut triangles: u64 = 0;
    let mut warned_modes = false;
    while let Some((n, parent, parent_close, pivot, at)) = todo.pop() {
        let node = get(path, &root.nodes, n, "nodes", &at)?;
        if visited[n] {
            return Err(bad(
                path,
                format!("{at} = {n} reaches nodes[{n}] a second time (a cycle in the node hierarchy, or a node with two parents)"),
                "make the node hierarchy a tree: every node at most one parent, no node its own ancestor",
            ));
        }
        visited[n] = true;
        let (world, world_close, pivot) = match animations.of_node(n) {
            None => {
                let local = local_transform(path, node, n)?;
                (parent * local, parent_close * local, pivot)
            }
            Some(tracks) => {
                let open = local_transform_at(path, node, n, animations.sample(path, tracks, shutter.0)?)?;
                let close = local_transform_at(path, node, n, animations.sample(path, tracks, shutter.1)?)?;
                let world = parent * open;
                (world, parent_close * close, Some(world.w_axis.truncate()))
            }
        };
        if !(world.is_finite() && world_close.is_finite()) {
            return Err(bad(
                path,
                format!("nodes[{n}]: its transform combined with its parents' overflows"),
                "check the scale/matrix of this node and its parents",
            ));
        }
        if let (None, Some(c)) = (&walk.camera, node.camera) {
            walk.camera = camera_of_node(path, root, n, c.value(), (world, world_close), warnings)?;
        }
        if let Some(m) = node.mesh {
            let mesh_index = m.value();
            triangles = count_triangles(path, root, n, mesh_index, triangles, (warnings, &mut warned_modes))?;
            walk.instances.push(Instance {
                node: n,
                mesh: mesh_index,
                world,
                world_close,
                pivot: pivot.unwrap_or(Vec3::ZERO),
            });
        }
        if let Some(children) = &node.children {
            for (k, c) in children.iter().enumerate().rev() {
                todo.push((c.value(), world, world_close, pivot, format!("nodes[{n}].children[{k}]")));
            }
        }
    }
    Ok(walk)
}

/// Node `n`'s camera `c`, checked: `(n, world at shutter open, yfov)` for a perspective one, `None`
/// for an orthographic one; a camera that moves over the shutter is warned about (it stays at open).
fn camera_of_node(
    path: &Path,
    root: &json::Root,
    n: usize,
    c: usize,
    (world, world_close): (Mat4, Mat4),
    warnings: &mut Vec<String>,
) -> Result<Option<(usize, Mat4, f32)>, SceneError> {
    let cam = get(path, &root.cameras, c, "cameras", &format!("nodes[{n}].camera"))?;
    let Some(p) = &cam.perspective else { return Ok(None) };
    if !(p.yfov.is_finite() && p.yfov > 0.0 && p.yfov < std::f32::consts::PI) {
        return Err(bad(
            path,
            format!("cameras[{c}].perspective.yfov is {} radians", p.yfov),
            "use a vertical field of view with 0 < yfov < π (radians)",
        ));
    }
    if let Some(a) = p.aspect_ratio {
        if !(a.is_finite() && a > 0.0) {
            return Err(bad(
                path,
                format!("cameras[{c}].perspective.aspectRatio is {a}"),
                "use a finite aspect ratio > 0 or leave it out",
            ));
        }
    }
    if world_close != world {
        warnings.push(format!(
            "{}: the camera of nodes[{n}] moves over the shutter; wedge blurs object motion only, so the camera stays where it is at shutter open",
            path.display()
        ));
    }
    Ok(Some((n, world, p.yfov)))
}

/// `triangles` plus the triangles node `n` instances of mesh `mesh_index` (its triangle-list
/// primitives, counted from their accessors before anything is read), refused past
/// [`MAX_TRIANGLES`]; primitives of other modes are skipped with one warning per file.
fn count_triangles(
    path: &Path,
    root: &json::Root,
    n: usize,
    mesh_index: usize,
    mut triangles: u64,
    (warnings, warned_modes): (&mut Vec<String>, &mut bool),
) -> Result<u64, SceneError> {
    let mesh = get(path, &root.meshes, mesh_index, "meshes", &format!("nodes[{n}].mesh"))?;
    for (p, prim) in mesh.primitives.iter().enumerate() {
        let pat = format!("meshes[{mesh_index}].primitives[{p}]");
        match prim.mode {
            Checked::Valid(Mode::Triangles) => {}
            Checked::Valid(_) => {
                if !*warned_modes {
                    warnings.push(format!(
                        "{}: {pat} is not a triangle list (mode 4); primitives of other modes are skipped",
                        path.display()
                    ));
                    *warned_modes = true;
                }
                continue;
            }
            Checked::Invalid => {
                return Err(bad(path, format!("{pat}.mode is not a glTF primitive mode"), "use mode 4 (triangles)"))
            }
        }
        let counted = match (prim.indices, prim.attributes.get(&Checked::Valid(Semantic::Positions))) {
            (Some(i), _) => get(path, &root.accessors, i.value(), "accessors", &format!("{pat}.indices"))?.count.0,
            (None, Some(i)) => {
                get(path, &root.accessors, i.value(), "accessors", &format!("{pat}.attributes.POSITION"))?.count.0
            }
            (None, None) => 0,
        };
        triangles = triangles.saturating_add(counted / 3);
        if triangles > MAX_TRIANGLES as u64 {
            return Err(bad(
                path,
                format!("the default scene instances more than {MAX_TRIANGLES} triangles (limit reached at nodes[{n}] → {pat})"),
                "reduce the instancing or split the scene",
            ));
        }
    }
    Ok(triangles)
}

/// The instances' triangles in world space, one object per instanced primitive (with its motion
/// over the shutter): each primitive read and checked once however often it is instanced; a
/// primitive without a material gets one shared diffuse default.
fn add_instances(
    path: &Path,
    root: &json::Root,
    buffers: &mut Buffers,
    instances: &[Instance],
    d: &mut SceneData,
) -> Result<(), SceneError> {
    let texcoord_set = |material: Option<usize>| -> u32 {
        material
            .and_then(|m| root.materials.get(m))
            .and_then(|m| m.pbr_metallic_roughness.base_color_texture.as_ref())
            .map(|t| t.tex_coord)
            .unwrap_or(0)
    };
    let mut read: HashMap<(usize, usize), Primitive> = HashMap::new();
    let mut default_material: Option<u32> = None;
    for inst in instances {
        let motion = if inst.world_close == inst.world { None } else { Some(node_motion(path, inst)?) };
        let name = root.nodes[inst.node]
            .name
            .clone()
            .or_else(|| root.meshes[inst.mesh].name.clone())
            .unwrap_or_else(|| format!("nodes[{}]", inst.node));
        for (p, prim) in root.meshes[inst.mesh].primitives.iter().enumerate() {
            if prim.mode != Checked::Valid(Mode::Triangles) {
                continue;
            }
            let data = match read.entry((inst.mesh, p)) {
                std::collections::hash_map::Entry::Occupied(e) => e.into_mut(),
                std::collections::hash_map::Entry::Vacant(e) => {
                    e.insert(read_primitive(path, root, buffers, inst.mesh, p, &texcoord_set)?)
                }
            };
            let material = match data.material {
                Some(i) if i < d.materials.len() => i as u32,
                Some(i) => {
                    return Err(bad(
                        path,
                        format!(
                            "meshes[{}].primitives[{p}].material = {i} but the file has {} materials",
                            inst.mesh,
                            d.materials.len()
                        ),
                        "point the primitive at an existing material",
                    ))
                }
                None => *default_material
                    .get_or_insert_with(|| d.add_material(Material::diffuse("default", Vec3::splat(0.8)), false)),
            };
            let object = d.new_named_object(name.clone());
            if let Some(m) = motion {
                d.set_motion(object, m);
            }
            push_triangles(path, inst, data, material, object, d)?;
        }
    }
    Ok(())
}

/// One instanced primitive's triangles, transformed to world space (normals by the inverse
/// transpose, the flat normal where a vertex normal degenerates); a vertex beyond
/// ±[`MAX_COORDINATE`] or not finite is refused.
fn push_triangles(
    path: &Path,
    inst: &Instance,
    data: &Primitive,
    material: u32,
    object: u32,
    d: &mut SceneData,
) -> Result<(), SceneError> {
    let normal_m = inst.world.inverse().transpose();
    for tri in data.indices.chunks_exact(3) {
        let tri = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
        let p = tri.map(|i| inst.world.transform_point3(data.positions[i]));
        if let Some(q) = p.iter().find(|q| !(q.is_finite() && q.abs().max_element() <= MAX_COORDINATE)) {
            return Err(bad(
                path,
                format!(
                    "nodes[{}] places meshes[{}] vertices at {q} (beyond ±{MAX_COORDINATE:e} m or not finite)",
                    inst.node, inst.mesh
                ),
                "check the scale/translation of this node and its parents (units are metres)",
            ));
        }
        let flat = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
        let n = match &data.normals {
            Some(ns) => tri.map(|i| {
                let n = normal_m.transform_vector3(ns[i]).normalize_or_zero();
                if n == Vec3::ZERO || !n.is_finite() {
                    flat
                } else {
                    n
                }
            }),
            None => [flat; 3],
        };
        let uv = match &data.uvs {
            Some(uv) => tri.map(|i| uv[i]),
            None => [Vec2::ZERO; 3],
        };
        d.push(p, n, uv, material, object);
    }
    Ok(())
}

/// The camera of node `n` (world transform `world`, vertical field of view `yfov`), aimed at the
/// scene bounds' centre depth along its view direction (glTF gives no focus distance), with the
/// shutter; a degenerate transform is refused.
fn node_camera(
    path: &Path,
    n: usize,
    world: Mat4,
    yfov: f32,
    shutter: (f32, f32),
    d: &SceneData,
) -> Result<Camera, SceneError> {
    let position = world.transform_point3(Vec3::ZERO);
    let forward = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
    let up = world.transform_vector3(Vec3::Y).normalize_or_zero();
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for t in &d.tris {
        for q in [t.0, t.1, t.2] {
            lo = lo.min(q);
            hi = hi.max(q);
        }
    }
    let dist = ((lo + hi) * 0.5 - position).dot(forward).max(1e-2);
    let cam = Camera {
        position,
        look_at: position + forward * dist,
        up,
        vfov_deg: yfov.to_degrees(),
        aperture_radius: 0.0,
        focus_distance: dist,
        shutter_open: shutter.0,
        shutter_close: shutter.1,
    };
    cam.validate().map_err(|what| {
        bad(
            path,
            format!("the camera of nodes[{n}]: {what} (its transform is degenerate)"),
            "give the camera node an invertible transform without zero scale",
        )
    })?;
    Ok(cam)
}

/// The motion of a mesh instance over the shutter, from its world transforms at open (`W_o`, where its
/// triangles are stored) and close (`W_c`): `D = W_c·W_o⁻¹` must be rigid (a rotation `R` and a
/// translation); it becomes a [`RigidMotion`] about the instance's pivot `p` (the origin of the
/// nearest animated node at or above it, so every mesh under one animated node shares one motion)
/// from the identity to `(T = D(p) − p, R)`. In between, the pivot moves on the straight line and the
/// rotation is slerped: a child of a rotating parent follows the chord of its arc, not the arc.
fn node_motion(path: &Path, inst: &Instance) -> Result<RigidMotion, SceneError> {
    let open = Mat3::from_mat4(inst.world);
    let close = Mat3::from_mat4(inst.world_close);
    let (n, mesh) = (inst.node, inst.mesh);
    let det = open.determinant();
    if !(det.is_finite() && det != 0.0 && open.inverse().is_finite()) {
        return Err(bad(
            path,
            format!("nodes[{n}] (meshes[{mesh}]) is animated but has zero scale at shutter open"),
            "give the node and its parents a non-zero scale",
        ));
    }
    let r = close * open.inverse();
    let err = (r * r.transpose() - Mat3::IDENTITY).to_cols_array().iter().fold(0.0f32, |m, x| m.max(x.abs()));
    if !(err <= 1e-3 && r.determinant() > 0.0) {
        return Err(bad(
            path,
            format!(
                "nodes[{n}] (meshes[{mesh}]): its transform at shutter close is not a rigid motion of the one at shutter open (a scale changes over the shutter, or a rotation is animated under a non-uniformly scaled parent; deviation from a rotation {err:.3})"
            ),
            "animate only translation and rotation over the shutter (constant scale), with uniform scales above animated rotations",
        ));
    }
    let q = Quat::from_mat3(&r).normalize();
    let p = inst.pivot;
    let moved = inst.world_close.transform_point3(inst.world.inverse().transform_point3(p));
    let motion = RigidMotion { pivot: p, translation: [Vec3::ZERO, moved - p], rotation: [Quat::IDENTITY, q] };
    motion.validate().map_err(|what| {
        bad(
            path,
            format!("nodes[{n}] (meshes[{mesh}]): its motion over the shutter: {what}"),
            "check the node's animation values",
        )
    })?;
    Ok(motion)
}

/// Keyframe times: SCALAR FLOAT.
const ANIM_TIMES: Layout = Layout { ty: Type::Scalar, components: &[(ComponentType::F32, false)] };
/// Translation and scale keyframes: VEC3 FLOAT.
const ANIM_VEC3: Layout = POSITION;
/// Rotation keyframes: VEC4 FLOAT (the normalized-integer forms of the spec are refused).
const ANIM_VEC4: Layout = Layout { ty: Type::Vec4, components: &[(ComponentType::F32, false)] };

/// One checked animation channel (its sampler's keyframes).
struct Track {
    times: Vec<f32>,
    /// Per keyframe its value (VEC3 padded with 0); CUBICSPLINE: in-tangent, value, out-tangent.
    values: Vec<[f32; 4]>,
    interpolation: json::animation::Interpolation,
    rotation: bool,
    /// The channel's JSON path (`animations[a].channels[c]`), for errors found when it is sampled.
    at: String,
}

impl Track {
    /// The value at time `tau`: held before the first and after the last keyframe, STEP holds each
    /// keyframe, LINEAR lerps (slerps rotations, short arc), CUBICSPLINE is the spec's Hermite spline
    /// (rotations renormalised).
    fn sample(&self, tau: f32) -> [f32; 4] {
        use json::animation::Interpolation::*;
        let cubic = self.interpolation == CubicSpline;
        let value = |k: usize| {
            if cubic {
                self.values[3 * k + 1]
            } else {
                self.values[k]
            }
        };
        let last = self.times.len() - 1;
        // NaN (not reachable: shutters are checked) holds the first keyframe. Times are finite
        // (checked when read), so the comparisons below are total.
        if tau.is_nan() || tau <= self.times[0] {
            return value(0);
        }
        if tau >= self.times[last] {
            return value(last);
        }
        let k = self.times.partition_point(|&x| x <= tau) - 1;
        let (t0, t1) = (self.times[k], self.times[k + 1]);
        let u = (tau - t0) / (t1 - t0);
        let v4 = |a: [f32; 4]| glam::Vec4::from_array(a);
        match self.interpolation {
            Step => value(k),
            Linear if self.rotation => {
                Quat::from_array(value(k)).normalize().slerp(Quat::from_array(value(k + 1)).normalize(), u).to_array()
            }
            Linear => v4(value(k)).lerp(v4(value(k + 1)), u).to_array(),
            CubicSpline => {
                let td = t1 - t0;
                let (p0, m0) = (v4(self.values[3 * k + 1]), v4(self.values[3 * k + 2]) * td);
                let (p1, m1) = (v4(self.values[3 * k + 4]), v4(self.values[3 * k + 3]) * td);
                let (u2, u3) = (u * u, u * u * u);
                let v = p0 * (2.0 * u3 - 3.0 * u2 + 1.0)
                    + m0 * (u3 - 2.0 * u2 + u)
                    + p1 * (-2.0 * u3 + 3.0 * u2)
                    + m1 * (u3 - u2);
                if self.rotation {
                    v.normalize_or_zero().to_array()
                } else {
                    v.to_array()
                }
            }
        }
    }
}

/// Every animation's channels, checked; per node the tracks of its translation, rotation and scale.
struct Animations {
    tracks: Vec<Track>,
    per_node: HashMap<usize, [Option<usize>; 3]>,
    /// Channels read (weights channels excluded).
    channels: usize,
}

impl Animations {
    fn of_node(&self, n: usize) -> Option<&[Option<usize>; 3]> {
        self.per_node.get(&n)
    }

    /// Translation, rotation and scale of a node's tracks at `tau` (`None` where not animated). A
    /// rotation that is no rotation there — a CUBICSPLINE through unit keys may pass through the zero
    /// quaternion, which [`Track::sample`] cannot normalise — is refused naming the channel and time
    /// (the node's own `rotation` is not what is wrong).
    fn sample(&self, path: &Path, tracks: &[Option<usize>; 3], tau: f32) -> Result<[Option<[f32; 4]>; 3], SceneError> {
        let mut out = [None; 3];
        for (slot, t) in tracks.iter().enumerate() {
            let Some(track) = t.map(|i| &self.tracks[i]) else { continue };
            let value = track.sample(tau);
            if track.rotation && value == [0.0; 4] {
                let k = track.times.partition_point(|&x| x <= tau).saturating_sub(1);
                return Err(bad(
                    path,
                    format!(
                        "{}: the CUBICSPLINE rotation at time {tau} (between keyframes {k} and {}) is the zero \
                         quaternion, which is no rotation: the spline through the unit keyframes passes through 0 there",
                        track.at,
                        k + 1
                    ),
                    "change the keyframes' tangents so the spline stays away from zero (or use LINEAR, which slerps)",
                ));
            }
            out[slot] = Some(value);
        }
        Ok(out)
    }
}

/// Read and check every channel of every animation (all of them play at once). Each problem is an
/// error naming its JSON path: an out-of-range sampler, node or accessor index, an unknown target
/// path or interpolation, a node with a `matrix` (glTF forbids animating it), two channels on one
/// node property, keyframe times that are not finite and strictly increasing, an output count that
/// does not match the times (LINEAR/STEP one value per keyframe, CUBICSPLINE three), non-finite
/// values, rotations that are not unit quaternions. Morph-target weights are skipped with a warning.
fn read_animations(
    path: &Path,
    root: &json::Root,
    buffers: &mut Buffers,
    warnings: &mut Vec<String>,
) -> Result<Animations, SceneError> {
    use json::animation::{Interpolation, Property};
    let mut out = Animations { tracks: Vec::new(), per_node: HashMap::new(), channels: 0 };
    let mut owner: HashMap<(usize, usize), String> = HashMap::new();
    let mut warned_weights = false;
    for (a, anim) in root.animations.iter().enumerate() {
        for (c, channel) in anim.channels.iter().enumerate() {
            let at = format!("animations[{a}].channels[{c}]");
            let slot = match channel.target.path {
                Checked::Valid(Property::Translation) => 0,
                Checked::Valid(Property::Rotation) => 1,
                Checked::Valid(Property::Scale) => 2,
                Checked::Valid(Property::MorphTargetWeights) => {
                    if !warned_weights {
                        warnings.push(format!("{}: {at} animates morph-target weights, which wedge does not support; such channels are skipped", path.display()));
                        warned_weights = true;
                    }
                    continue;
                }
                Checked::Invalid => {
                    return Err(bad(
                        path,
                        format!("{at}.target.path is not \"translation\", \"rotation\", \"scale\" or \"weights\""),
                        "target one of the node properties glTF animates",
                    ))
                }
            };
            let property = ["translation", "rotation", "scale"][slot];
            let n = channel.target.node.value();
            let node = get(path, &root.nodes, n, "nodes", &format!("{at}.target.node"))?;
            if node.matrix.is_some() {
                return Err(bad(
                    path,
                    format!("{at} animates nodes[{n}].{property}, but nodes[{n}] has a matrix"),
                    "give the node translation/rotation/scale instead of a matrix (glTF does not allow animating a node with a matrix)",
                ));
            }
            if let Some(first) = owner.insert((n, slot), at.clone()) {
                return Err(bad(
                    path,
                    format!("{at} animates nodes[{n}].{property}, which {first} animates already"),
                    "keep one channel per node property (wedge plays every animation at once)",
                ));
            }
            let s = channel.sampler.value();
            let sampler =
                get(path, &anim.samplers, s, &format!("samplers in animations[{a}]"), &format!("{at}.sampler"))?;
            let sat = format!("animations[{a}].samplers[{s}]");
            let Checked::Valid(interpolation) = sampler.interpolation else {
                return Err(bad(
                    path,
                    format!("{sat}.interpolation is not LINEAR, STEP or CUBICSPLINE"),
                    "use one of the glTF interpolations",
                ));
            };
            let input = sampler.input.value();
            let times = read_floats(path, root, buffers, input, &format!("{sat}.input"), &ANIM_TIMES)?;
            if let Some(k) = (1..times.len()).find(|&k| times[k] <= times[k - 1]) {
                return Err(bad(
                    path,
                    format!(
                        "{sat}.input (accessors[{input}]): keyframe time {k} ({}) is not after time {} ({})",
                        times[k],
                        k - 1,
                        times[k - 1]
                    ),
                    "keyframe times must increase strictly (re-export the animation)",
                ));
            }
            let rotation = slot == 1;
            let (layout, comps) = if rotation { (&ANIM_VEC4, 4) } else { (&ANIM_VEC3, 3) };
            let output = sampler.output.value();
            let oat = format!("{sat}.output");
            let raw = read_floats(path, root, buffers, output, &oat, layout)?;
            let cubic = interpolation == Interpolation::CubicSpline;
            let per_key = if cubic { 3 } else { 1 };
            let count = raw.len() / comps;
            if count != per_key * times.len() {
                return Err(bad(
                    path,
                    format!(
                        "{oat} (accessors[{output}]) has {count} values but {sat}.input has {} keyframes ({} needs {})",
                        times.len(),
                        if cubic { "CUBICSPLINE" } else { "LINEAR/STEP" },
                        per_key * times.len()
                    ),
                    if cubic {
                        "give CUBICSPLINE three values per keyframe (in-tangent, value, out-tangent)"
                    } else {
                        "give one value per keyframe time"
                    },
                ));
            }
            let values: Vec<[f32; 4]> =
                raw.chunks_exact(comps).map(|v| [v[0], v[1], v[2], if comps == 4 { v[3] } else { 0.0 }]).collect();
            if rotation {
                for (k, q) in values.iter().enumerate().skip(per_key / 2).step_by(per_key) {
                    let len = Quat::from_array(*q).length();
                    if (len - 1.0).abs() > 1e-3 {
                        return Err(bad(
                            path,
                            format!(
                                "{oat} (accessors[{output}]): keyframe {} rotation {q:?} has length {len}, not a unit quaternion",
                                k / per_key
                            ),
                            "normalise the rotation keyframes (re-export the animation)",
                        ));
                    }
                }
            }
            out.tracks.push(Track { times, values, interpolation, rotation, at: at.clone() });
            out.per_node.entry(n).or_insert([None; 3])[slot] = Some(out.tracks.len() - 1);
            out.channels += 1;
        }
    }
    Ok(out)
}
