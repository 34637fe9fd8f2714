//! The `Scene` type: flat triangle + BVH arrays, materials, textures, lights and camera.

use std::collections::HashMap;

use glam::{Vec2, Vec3};

use crate::bvh::{self, Bvh, Hit, TriangleRecord, MAX_REFERENCES, NO_LIGHT, STACK_SIZE};
use crate::limits::{MAX_COORDINATE, MAX_RADIANCE, MAX_TRIANGLES};
use crate::{AreaLight, Camera, LightShape, SceneError, Texture};

/// A surface material: Lambertian `base_color` (times the optional texture) is k_d; a Phong lobe
/// `specular` (k_s) with exponent `phong_exponent` (m; 0 means no glossy lobe); `emission` is emitted
/// radiance (non-zero makes the triangle part of an area light).
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    pub base_color: Vec3,
    pub base_color_texture: Option<u32>,
    pub emission: Vec3,
    pub specular: Vec3,
    pub phong_exponent: f32,
}

impl Material {
    /// A plain diffuse material.
    pub fn diffuse(name: &str, base_color: Vec3) -> Material {
        Material {
            name: name.to_string(),
            base_color,
            base_color_texture: None,
            emission: Vec3::ZERO,
            specular: Vec3::ZERO,
            phong_exponent: 0.0,
        }
    }
    /// A black emitter.
    pub fn emitter(name: &str, radiance: Vec3) -> Material {
        Material {
            emission: radiance,
            ..Material::diffuse(name, Vec3::ZERO)
        }
    }
    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }
}

/// Per-triangle shading data, in the same order as `Scene::triangles`: vertex normals, uvs, material
/// index and object id (the object id groups triangles of one mesh/primitive; used by filters to
/// detect object boundaries).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleShading {
    pub n: [Vec3; 3],
    pub uv: [Vec2; 3],
    pub material: u32,
    pub object: u32,
}

/// Shading information at a hit. Both normals face the incoming ray (dot(normal, dir) <= 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    pub position: Vec3,
    pub geometric_normal: Vec3,
    pub shading_normal: Vec3,
    pub uv: Vec2,
    pub material: u32,
    pub object: u32,
}

/// Axis-aligned box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    pub fn empty() -> Aabb {
        Aabb {
            min: Vec3::splat(f32::INFINITY),
            max: Vec3::splat(f32::NEG_INFINITY),
        }
    }
    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }
    pub fn centre(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }
    pub fn size(&self) -> Vec3 {
        self.max - self.min
    }
}

/// A ready-to-render scene. `triangles`, `shading` share the BVH's leaf order; `bvh[0]` is the root.
#[derive(Clone, Debug)]
pub struct Scene {
    pub name: String,
    pub triangles: Vec<TriangleRecord>,
    pub shading: Vec<TriangleShading>,
    /// The BVH over `triangles` (wide nodes and the triangle packs their leaves hold).
    pub bvh: Bvh,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub lights: Vec<AreaLight>,
    pub camera: Camera,
    pub bounds: Aabb,
    /// Problems the loader worked around (unknown `usemtl`, dropped zero-area or duplicate triangles…);
    /// the CLI prints them after the scene line.
    pub warnings: Vec<String>,
}

/// Where a scene came from, for error messages of `from_triangles` (built-ins have no file).
fn origin_path(name: &str) -> std::path::PathBuf {
    std::path::PathBuf::from(name)
}

impl Scene {
    /// Build from loose world-space triangles. Builds the BVH with obvhs, reorders the triangles to
    /// the BVH's leaf order and flattens the nodes. Emissive triangles become area lights: two emissive
    /// triangles of the same material that share an edge and together form a planar parallelogram are
    /// merged into one `Rect` light; the rest become `Triangle` lights. Lights are one-sided, emitting
    /// toward the triangle's winding normal ((v1-v0)×(v2-v0)); loaders set `two_sided` afterwards
    /// where the file says so (glTF `doubleSided`, RON `two_sided`).
    pub fn from_triangles(
        name: &str,
        tris: Vec<(Vec3, Vec3, Vec3, TriangleShading)>,
        materials: Vec<Material>,
        textures: Vec<Texture>,
        camera: Camera,
    ) -> Result<Scene, SceneError> {
        let path = origin_path(name);
        if tris.is_empty() {
            return Err(SceneError::invalid(
                &path,
                "the scene has no triangles",
                "add geometry (meshes or a built-in)",
            ));
        }
        if tris.len() > MAX_TRIANGLES {
            return Err(SceneError::invalid(
                &path,
                format!(
                    "{} triangles, more than the limit of {MAX_TRIANGLES}",
                    tris.len()
                ),
                "decimate the meshes or split the scene",
            ));
        }
        for (i, m) in materials.iter().enumerate() {
            check_material(&path, i, m, textures.len())?;
        }
        let mut bounds = Aabb::empty();
        for (i, (a, b, c, s)) in tris.iter().enumerate() {
            if !(a.is_finite() && b.is_finite() && c.is_finite()) {
                return Err(SceneError::invalid(
                    &path,
                    format!("triangle {i} has a non-finite (NaN or infinite) vertex"),
                    "fix or remove the broken geometry",
                ));
            }
            let far = a.abs().max(b.abs()).max(c.abs()).max_element();
            if far > MAX_COORDINATE {
                return Err(SceneError::invalid(
                    &path,
                    format!("triangle {i} has a vertex {far:e} m from the origin, beyond the limit of {MAX_COORDINATE:e} m"),
                    "check the units and the transforms' scale/translation",
                ));
            }
            if s.material as usize >= materials.len() {
                return Err(SceneError::invalid(
                    &path,
                    format!(
                        "triangle {i} uses material {} but there are {}",
                        s.material,
                        materials.len()
                    ),
                    "give every triangle a valid material index",
                ));
            }
            bounds.grow(*a);
            bounds.grow(*b);
            bounds.grow(*c);
        }

        // Zero-area triangles can never be hit and exact duplicates add nothing but BVH work (and a
        // million copies of one triangle is a pathological builder input), so both are dropped here,
        // counted into a warning. `kept[k]` is the input index of the k-th kept triangle.
        let (kept, warnings) = drop_degenerate_and_duplicates(name, &tris);
        if kept.is_empty() {
            return Err(SceneError::invalid(
                &path,
                format!("all {} triangles have zero area", tris.len()),
                "add geometry with non-degenerate triangles",
            ));
        }
        let tris: Vec<_> = kept.iter().map(|&i| tris[i as usize]).collect();

        // Lights first, in input order (so light indices do not depend on the BVH).
        let (lights, input_light) = extract_lights(&tris, &materials, bounds.size().max_element());

        let positions: Vec<[Vec3; 3]> = tris.iter().map(|t| [t.0, t.1, t.2]).collect();
        let built = bvh::build(&positions);
        if built.stack_need > STACK_SIZE || built.order.len() > MAX_REFERENCES {
            return Err(SceneError::invalid(
                &path,
                format!(
                    "the BVH needs {} traversal stack entries (the traversal has {STACK_SIZE}) for {} triangle references",
                    built.stack_need,
                    built.order.len()
                ),
                "this geometry is pathological for the builder; simplify or split it",
            ));
        }
        // Spatial pre-splits reference a triangle from several leaves, so the order may be longer than
        // the input (each reference gets its own full copy of the triangle); never shorter.
        if built.order.len() < tris.len() {
            return Err(SceneError::invalid(
                &path,
                "BVH builder returned a different primitive count",
                "report this as a bug",
            ));
        }
        let mut triangles = Vec::with_capacity(tris.len());
        let mut shading = Vec::with_capacity(tris.len());
        for &src in &built.order {
            let (a, b, c, s) = tris[src as usize];
            let mut rec = TriangleRecord::new(a, b, c, s.material, kept[src as usize]);
            rec.light = input_light[src as usize];
            triangles.push(rec);
            shading.push(s);
        }
        let bvh = Bvh::pack(built.nodes, &triangles);
        Ok(Scene {
            name: name.to_string(),
            triangles,
            shading,
            bvh,
            materials,
            textures,
            lights,
            camera,
            bounds,
            warnings,
        })
    }

    /// Closest hit with tmin < t < tmax, ties to the lower triangle index (own traversal over `self.bvh`,
    /// see [`crate::bvh::traverse`]).
    pub fn intersect(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
        bvh::traverse(&self.bvh, origin, dir, tmin, tmax, false)
    }

    /// Whether anything is hit with tmin < t < tmax (shadow rays; stops at the first hit).
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> bool {
        bvh::traverse(&self.bvh, origin, dir, tmin, tmax, true).is_some()
    }

    /// Interpolated attributes at a hit. The position is interpolated from the vertices (more precise
    /// than origin + t·dir). Shading normals that are missing/degenerate fall back to the geometric one.
    pub fn surface(&self, hit: &Hit, origin: Vec3, dir: Vec3) -> SurfacePoint {
        let _ = origin;
        let tri = &self.triangles[hit.triangle as usize];
        let sh = &self.shading[hit.triangle as usize];
        let (b0, b1, b2) = (1.0 - hit.b1 - hit.b2, hit.b1, hit.b2);
        let e1 = Vec3::from(tri.e1);
        let e2 = Vec3::from(tri.e2);
        let position = Vec3::from(tri.v0) + b1 * e1 + b2 * e2;
        let mut ng = e1.cross(e2).normalize_or_zero();
        if ng == Vec3::ZERO {
            ng = -dir.normalize_or_zero();
        }
        if ng.dot(dir) > 0.0 {
            ng = -ng;
        }
        let mut ns = (b0 * sh.n[0] + b1 * sh.n[1] + b2 * sh.n[2]).normalize_or_zero();
        if ns == Vec3::ZERO || !ns.is_finite() {
            ns = ng;
        }
        if ns.dot(ng) < 0.0 {
            ns = -ns;
        }
        SurfacePoint {
            position,
            geometric_normal: ng,
            shading_normal: ns,
            uv: b0 * sh.uv[0] + b1 * sh.uv[1] + b2 * sh.uv[2],
            material: sh.material,
            object: sh.object,
        }
    }

    /// k_d = base_color × texture(uv).
    pub fn albedo(&self, sp: &SurfacePoint) -> Vec3 {
        let m = &self.materials[sp.material as usize];
        match m.base_color_texture {
            Some(t) => m.base_color * self.textures[t as usize].sample(sp.uv),
            None => m.base_color,
        }
    }

    /// Emitted radiance of the material. Seen from either side (primary visibility of a light is not
    /// culled by its winding); light *transport* uses `lights`, which respects `two_sided`.
    pub fn emission(&self, sp: &SurfacePoint) -> Vec3 {
        self.materials[sp.material as usize].emission
    }

    /// Index of the light whose surface triangle `triangle` (an index into `self.triangles`) belongs to.
    pub fn light_of_triangle(&self, triangle: u32) -> Option<u32> {
        match self.triangles.get(triangle as usize)?.light {
            NO_LIGHT => None,
            l => Some(l),
        }
    }

    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Largest dimension of `bounds`.
    pub fn extent(&self) -> f32 {
        self.bounds.size().max_element()
    }

    /// Mark every light made of triangles with one of the given materials as two-sided (loaders use this
    /// for glTF `doubleSided` and RON `two_sided`).
    pub(crate) fn set_two_sided_by_material(&mut self, two_sided: &[bool]) {
        for t in &self.triangles {
            if t.light != NO_LIGHT && two_sided.get(t.material as usize).copied().unwrap_or(false) {
                self.lights[t.light as usize].two_sided = true;
            }
        }
    }
}

/// Whether a material's numbers are usable: finite, non-negative colours, emission at most
/// [`MAX_RADIANCE`] (larger sums overflow to inf and NaN pixels), a finite Phong exponent, a valid
/// texture index. One check for every loader; loaders with a more precise location (a glTF JSON path)
/// check their raw values first.
fn check_material(
    path: &std::path::Path,
    i: usize,
    m: &Material,
    textures: usize,
) -> Result<(), SceneError> {
    let what = |field: &str, v: String| format!("material {i} ('{}') has {field} {v}", m.name);
    for (field, v) in [
        ("base colour", m.base_color),
        ("specular", m.specular),
        ("emission", m.emission),
    ] {
        if !v.is_finite() || v.min_element() < 0.0 {
            return Err(SceneError::invalid(
                path,
                what(field, v.to_string()),
                "use finite, non-negative values",
            ));
        }
    }
    if m.emission.max_element() > MAX_RADIANCE {
        return Err(SceneError::invalid(
            path,
            what("emission", m.emission.to_string()),
            format!(
                "keep emitted radiance at most {MAX_RADIANCE:e} per channel (scale the light down)"
            ),
        ));
    }
    if !(m.phong_exponent.is_finite() && m.phong_exponent >= 0.0) {
        return Err(SceneError::invalid(
            path,
            what("Phong exponent", m.phong_exponent.to_string()),
            "use a finite exponent >= 0",
        ));
    }
    if let Some(t) = m.base_color_texture {
        if t as usize >= textures {
            return Err(SceneError::invalid(
                path,
                format!(
                    "material {i} ('{}') uses texture {t} but there are {textures}",
                    m.name
                ),
                "give every material a valid texture index",
            ));
        }
    }
    Ok(())
}

/// Indices of the triangles worth building a BVH over: zero-area ones (cross product of the edges is
/// zero) and exact copies of an earlier triangle (same three vertices bit for bit, in the same cyclic
/// order) are left out. Returns the kept input indices and one warning per kind of drop.
fn drop_degenerate_and_duplicates(
    name: &str,
    tris: &[(Vec3, Vec3, Vec3, TriangleShading)],
) -> (Vec<u32>, Vec<String>) {
    let key = |v: Vec3| v.to_array().map(|c| if c == 0.0 { 0 } else { c.to_bits() }); // -0 == +0
    let mut seen: std::collections::HashSet<[[u32; 3]; 3]> =
        std::collections::HashSet::with_capacity(tris.len());
    let (mut zero_area, mut duplicates) = (0usize, 0usize);
    let mut kept = Vec::with_capacity(tris.len());
    for (i, (a, b, c, _)) in tris.iter().enumerate() {
        if (*b - *a).cross(*c - *a).length_squared() == 0.0 {
            zero_area += 1;
            continue;
        }
        // Same vertices in the same cyclic order (same winding): rotate the smallest first. Opposite
        // windings are kept — back-to-back faces (e.g. the shared cap between two boxes) are legitimate.
        let mut k = [key(*a), key(*b), key(*c)];
        let first = (0..3).min_by_key(|&i| k[i]).unwrap_or(0);
        k.rotate_left(first);
        if !seen.insert(k) {
            duplicates += 1;
            continue;
        }
        kept.push(i as u32);
    }
    let mut warnings = Vec::new();
    if zero_area > 0 {
        warnings.push(format!(
            "{name}: dropped {zero_area} zero-area triangle(s) of {} (they cannot be hit) — remove them in the modelling tool",
            tris.len()
        ));
    }
    if duplicates > 0 {
        warnings.push(format!(
            "{name}: dropped {duplicates} exact duplicate triangle(s) of {} — remove the copies in the modelling tool",
            tris.len()
        ));
    }
    (kept, warnings)
}

/// Turn emissive triangles into lights. Returns the lights and, per input triangle, its light index.
fn extract_lights(
    tris: &[(Vec3, Vec3, Vec3, TriangleShading)],
    materials: &[Material],
    extent: f32,
) -> (Vec<AreaLight>, Vec<u32>) {
    let mut light_of = vec![NO_LIGHT; tris.len()];
    let emissive: Vec<usize> = (0..tris.len())
        .filter(|&i| materials[tris[i].3.material as usize].is_emissive())
        .filter(|&i| {
            (tris[i].1 - tris[i].0)
                .cross(tris[i].2 - tris[i].0)
                .length_squared()
                > 0.0
        })
        .collect();
    if emissive.is_empty() {
        return (Vec::new(), light_of);
    }
    // Find edge-sharing pairs through a map keyed by the edge's two vertices (exact bits: vertices of a
    // shared edge are normally bit-identical copies; near-misses just stay two triangle lights).
    let key = |v: Vec3| v.to_array().map(|c| if c == 0.0 { 0 } else { c.to_bits() });
    let mut edges: HashMap<([u32; 3], [u32; 3]), Vec<usize>> = HashMap::new();
    for &i in &emissive {
        let v = [tris[i].0, tris[i].1, tris[i].2];
        for k in 0..3 {
            let (a, b) = (key(v[k]), key(v[(k + 1) % 3]));
            let e = if a <= b { (a, b) } else { (b, a) };
            edges.entry(e).or_default().push(i);
        }
    }
    let tol = 1e-5 * extent.max(1e-6);
    let mut lights = Vec::new();
    for &i in &emissive {
        if light_of[i] != NO_LIGHT {
            continue;
        }
        let v = [tris[i].0, tris[i].1, tris[i].2];
        let mut merged = None;
        'edges: for k in 0..3 {
            let (a, b) = (key(v[k]), key(v[(k + 1) % 3]));
            let e = if a <= b { (a, b) } else { (b, a) };
            for &j in edges.get(&e).map(|v| v.as_slice()).unwrap_or(&[]) {
                if j == i || light_of[j] != NO_LIGHT {
                    continue;
                }
                if let Some(rect) = parallelogram(&tris[i], &tris[j], materials, tol) {
                    merged = Some((j, rect));
                    break 'edges;
                }
            }
        }
        let radiance = materials[tris[i].3.material as usize].emission;
        let index = lights.len() as u32;
        light_of[i] = index;
        let shape = match merged {
            Some((j, rect)) => {
                light_of[j] = index;
                rect
            }
            None => LightShape::Triangle {
                v0: v[0],
                v1: v[1],
                v2: v[2],
            },
        };
        lights.push(AreaLight {
            shape,
            radiance,
            two_sided: false,
        });
    }
    (lights, light_of)
}

/// If triangles `t` and `u` have the same material, the same facing, share an edge and their union is a
/// planar parallelogram, return it as a Rect whose `edge_u × edge_v` points the way `t` faces.
fn parallelogram(
    t: &(Vec3, Vec3, Vec3, TriangleShading),
    u: &(Vec3, Vec3, Vec3, TriangleShading),
    materials: &[Material],
    tol: f32,
) -> Option<LightShape> {
    if materials[t.3.material as usize].emission != materials[u.3.material as usize].emission {
        return None;
    }
    let a = [t.0, t.1, t.2];
    let b = [u.0, u.1, u.2];
    let na = (a[1] - a[0]).cross(a[2] - a[0]).normalize();
    let nb = (b[1] - b[0]).cross(b[2] - b[0]).normalize();
    if na.dot(nb) < 0.9999 {
        return None;
    }
    // The vertex of each triangle not on the shared edge.
    let close = |p: Vec3, q: Vec3| (p - q).abs().max_element() <= tol;
    let oa = (0..3).find(|&k| !b.iter().any(|&q| close(a[k], q)))?;
    let ob = (0..3).find(|&k| !a.iter().any(|&q| close(b[k], q)))?;
    let shared: Vec<Vec3> = (0..3).filter(|&k| k != oa).map(|k| a[k]).collect();
    if shared.len() != 2 {
        return None;
    }
    let (p, q) = (shared[0], shared[1]);
    // Parallelogram ⇔ the diagonals bisect each other: a[oa] + b[ob] = p + q.
    if !close(a[oa] + b[ob], p + q) {
        return None;
    }
    let corner = a[oa];
    let (mut eu, mut ev) = (p - corner, q - corner);
    if eu.cross(ev).dot(na) < 0.0 {
        std::mem::swap(&mut eu, &mut ev);
    }
    Some(LightShape::Rect {
        corner,
        edge_u: eu,
        edge_v: ev,
    })
}
