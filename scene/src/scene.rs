//! The `Scene` type: flat triangle + BVH arrays, materials, textures, lights, camera, and the named
//! objects whose motion over the shutter the scene traces ([`Scene::at`]).
//!
//! **Motion (issue 13): two levels.** Triangles of objects at rest keep the one static tree they had
//! before motion existed (node 0 on: static scenes trace bit for bit as before). Each group of moving
//! objects that share one [`RigidMotion`] is an [`Instance`]: its own wide tree over its triangles
//! *as stored* (the rest pose), in the same `bvh.nodes`/`bvh.packs` arrays after the static tree
//! (child references absolute, [`Bvh::pack_into`]), its triangles after the static ones in
//! `triangles`. A ray at time `t` is traced through the static tree, then through every instance
//! whose swept box (its bounds over the whole shutter) it enters, moved into the instance's rest
//! space by the inverse rigid transform at `t`; the instances it enters are found through a
//! top-level wide tree over their swept boxes ([`Scene::instance_root`], nearest box first, boxes
//! beyond the best hit so far skipped). A rigid map keeps the ray parameter (the direction
//! keeps its length), and triangle indices are global, so [`bvh::closer`]'s rule still picks the one
//! closest hit over all trees ([`bvh::traverse_from`] starts from the best hit so far).
//!
//! Why not one motion BVH that interpolates vertices: rotation is not linear in vertex positions, so
//! a tree over interpolated boxes would need the rotation's swept boxes at every node anyway. Cost and
//! limits are measured in DESIGN-NOTES "Scene motion".

use std::collections::HashMap;

use glam::{Vec2, Vec3};

use crate::bvh::{self, Bvh, Hit, TriangleRecord, WideNode, MAX_REFERENCES, NO_LIGHT, STACK_SIZE};
use crate::limits::{MAX_COORDINATE, MAX_RADIANCE, MAX_TRIANGLES};
use crate::motion::{PreparedMotion, RigidMotion};
use crate::{AreaLight, Camera, EnvironmentMap, LightShape, RealLayer, SceneError, Texture};

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
        Material { emission: radiance, ..Material::diffuse(name, Vec3::ZERO) }
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
        Aabb { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) }
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
    /// The smallest box holding both.
    pub fn union(&self, other: &Aabb) -> Aabb {
        Aabb { min: self.min.min(other.min), max: self.max.max(other.max) }
    }
    /// Whether `p` lies inside (boundary included).
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
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
    /// In a sequence of frames, the camera of the frame before this one (a temporal filter
    /// reprojects into it); `None` for a single image and the first frame.
    pub previous_camera: Option<Camera>,
    /// Bounds of the triangles at rest and of every instance over the whole shutter.
    pub bounds: Aabb,
    /// Problems the loader worked around (unknown `usemtl`, dropped zero-area or duplicate triangles…);
    /// the CLI prints them after the scene line.
    pub warnings: Vec<String>,
    /// Named groups of triangles, indexed by [`TriangleShading::object`] (one per mesh primitive, OBJ
    /// object or built-in part), with their motion.
    pub objects: Vec<SceneObject>,
    /// Moving groups of triangles, each with its own tree (see the module doc). Empty for a static scene.
    pub instances: Vec<Instance>,
    /// Root (in `bvh.nodes`, after the instances' trees) of the top-level tree over the instances'
    /// swept boxes ([`bvh::build::build_boxes`]: its leaves name instances, `leaf_ref(k, 1)` for
    /// `instances[k]`); 0 and unused when there are no instances.
    pub instance_root: u32,
    /// Per light (index into `lights`): the object whose triangles form it; the light moves with it
    /// ([`SceneAt::light`]).
    pub light_object: Vec<u32>,
    /// Distant lighting from every direction (thesis Ch. 6), or none. Not part of `bounds`: it is at
    /// infinity. Set with [`Scene::set_environment`]; camera rays that miss see it
    /// ([`Scene::background`]).
    pub environment: Option<EnvironmentMap>,
    /// The captured real world of a mixed-reality render (thesis Ch. 6.1–6.5, issue 15): per pixel of
    /// the camera image `L_cam`, world position and coverage, normal and albedo. Not geometry: no ray
    /// the BVH traces hits it (screen-space rays march it). Set with [`Scene::set_real`].
    pub real: Option<RealLayer>,
}

/// A named group of triangles (`TriangleShading::object` is its index in `Scene::objects`).
#[derive(Clone, Debug, PartialEq)]
pub struct SceneObject {
    /// From the file where it has one (glTF node or mesh name, OBJ `o`/`g`), else `object<i>`; not
    /// necessarily unique ([`Scene::set_motion`] moves every object of a name).
    pub name: String,
    /// Its motion over the shutter; `None` = at rest. A motion that moves nothing
    /// ([`RigidMotion::is_static`]) is stored as `None`.
    pub motion: Option<RigidMotion>,
    /// The instance that holds its triangles while it moves (set by the scene; `None` at rest).
    pub instance: Option<u32>,
}

impl SceneObject {
    /// An object at rest.
    pub fn named(name: impl Into<String>) -> SceneObject {
        SceneObject { name: name.into(), motion: None, instance: None }
    }
}

/// A moving group of triangles: the objects that share one motion.
#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    /// Root of its tree in `Scene::bvh.nodes`.
    pub root: u32,
    /// Its triangles are `Scene::triangles[first..first + count]`, stored in the rest pose.
    pub first: u32,
    pub count: u32,
    pub motion: RigidMotion,
    /// `motion`, ready to evaluate (what the GPU receives too).
    pub prepared: PreparedMotion,
    /// Bounds of its triangles as stored.
    pub rest_bounds: Aabb,
    /// Conservative bounds over the whole shutter ([`RigidMotion::swept_bounds`]).
    pub swept_bounds: Aabb,
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
    /// where the file says so (glTF `doubleSided`, RON `two_sided`). Every object is at rest and
    /// named `object<i>`; [`Scene::from_objects`] names them and gives them motion.
    pub fn from_triangles(
        name: &str,
        tris: Vec<(Vec3, Vec3, Vec3, TriangleShading)>,
        materials: Vec<Material>,
        textures: Vec<Texture>,
        camera: Camera,
    ) -> Result<Scene, SceneError> {
        Scene::from_objects(name, tris, materials, textures, camera, Vec::new())
    }

    /// [`Scene::from_triangles`] with the objects' names and motions (`objects[i]` describes the
    /// triangles whose `TriangleShading::object` is `i`; objects beyond the list are at rest and
    /// named `object<i>`). Triangles are given in their rest pose. Two emissive triangles merge into
    /// one light only if their objects move alike.
    pub fn from_objects(
        name: &str,
        tris: Vec<(Vec3, Vec3, Vec3, TriangleShading)>,
        materials: Vec<Material>,
        textures: Vec<Texture>,
        camera: Camera,
        objects: Vec<SceneObject>,
    ) -> Result<Scene, SceneError> {
        // A scene may have no triangles at all: mixed reality's empty virtual world (issue 15), or
        // a scene lit and seen only through its environment map. Its trees are one empty root that
        // every ray misses. (The mesh loaders still refuse a *file* without faces: that is an export
        // mistake, not an empty world.)
        let path = origin_path(name);
        if tris.len() > MAX_TRIANGLES {
            return Err(SceneError::invalid(
                &path,
                format!("{} triangles, more than the limit of {MAX_TRIANGLES}", tris.len()),
                "decimate the meshes or split the scene",
            ));
        }
        for (i, m) in materials.iter().enumerate() {
            check_material(&path, i, m, textures.len())?;
        }
        let objects = complete_objects(&path, objects, &tris)?;
        let moves = |o: u32| objects[o as usize].motion.is_some();
        // The bounds of what is at rest (moving objects add their swept boxes once built), and of
        // everything as given (the scale of the light-merging tolerance).
        let mut bounds = Aabb::empty();
        let mut given = Aabb::empty();
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
                    format!(
                        "triangle {i} has a vertex {far:e} m from the origin, beyond the limit of {MAX_COORDINATE:e} m"
                    ),
                    "check the units and the transforms' scale/translation",
                ));
            }
            if s.material as usize >= materials.len() {
                return Err(SceneError::invalid(
                    &path,
                    format!("triangle {i} uses material {} but there are {}", s.material, materials.len()),
                    "give every triangle a valid material index",
                ));
            }
            for v in [a, b, c] {
                given.grow(*v);
                if !moves(s.object) {
                    bounds.grow(*v);
                }
            }
        }

        // Zero-area triangles can never be hit and exact duplicates add nothing but BVH work (and a
        // million copies of one triangle is a pathological builder input), so both are dropped here,
        // counted into a warning. `kept[k]` is the input index of the k-th kept triangle.
        let (kept, warnings) = drop_degenerate_and_duplicates(name, &tris);
        if kept.is_empty() && !tris.is_empty() {
            return Err(SceneError::invalid(
                &path,
                format!("all {} triangles have zero area", tris.len()),
                "add geometry with non-degenerate triangles",
            ));
        }
        let tris: Vec<_> = kept.iter().map(|&i| tris[i as usize]).collect();

        // Lights first, in input order (so light indices do not depend on the BVH).
        let (lights, input_light, light_object) =
            extract_lights(&tris, &materials, given.size().max_element(), &objects);

        let mut records = Vec::with_capacity(tris.len());
        let mut shading = Vec::with_capacity(tris.len());
        let mut positions = Vec::with_capacity(tris.len());
        for (k, &(a, b, c, s)) in tris.iter().enumerate() {
            let mut rec = TriangleRecord::new(a, b, c, s.material, kept[k]);
            rec.light = input_light[k];
            records.push(rec);
            shading.push(s);
            positions.push([a, b, c]);
        }
        drop(tris);
        let built = assemble(&path, &records, &shading, &positions, objects)?;
        bounds = built.bounds.union(&bounds);
        Ok(Scene {
            name: name.to_string(),
            triangles: built.triangles,
            shading: built.shading,
            bvh: built.bvh,
            materials,
            textures,
            lights,
            camera,
            previous_camera: None,
            bounds,
            warnings,
            objects: built.objects,
            instances: built.instances,
            instance_root: built.instance_root,
            light_object,
            environment: None,
            real: None,
        })
    }

    /// Stack entries a traversal of this scene's trees can need: the most of the static tree's
    /// (node 0) and every instance tree's ([`bvh::build::stack_need`]); at most [`STACK_SIZE`], which
    /// the build keeps every tree within. The GPU traversal sizes its private stack by it.
    pub fn traversal_stack_need(&self) -> usize {
        let need = bvh::build::stack_needs(&self.bvh.nodes);
        let roots = std::iter::once(0).chain(self.instances.iter().map(|i| i.root as usize));
        roots.filter_map(|r| need.get(r).copied()).max().unwrap_or(0)
    }

    /// Light the scene with `map` from infinity (or remove it with `None`). The bounds, the trees and
    /// the area lights do not change.
    pub fn set_environment(&mut self, map: Option<EnvironmentMap>) {
        self.environment = map;
    }

    /// Give the scene a captured real world (or remove it with `None`) for mixed reality. The triangles,
    /// bounds, lights and environment do not change.
    pub fn set_real(&mut self, layer: Option<RealLayer>) {
        self.real = layer;
    }

    /// What a ray leaving the scene in direction `dir` sees: the environment's radiance
    /// ([`EnvironmentMap::radiance`]), black without one. WGSL `scene_background` is the same.
    pub fn background(&self, dir: Vec3) -> Vec3 {
        match &self.environment {
            Some(env) => env.radiance(dir),
            None => Vec3::ZERO,
        }
    }

    /// The scene at time `t ∈ [−1, 1]` of the shutter (−1 open, +1 close, 0 its centre): rays,
    /// surfaces, lights and velocities with every object where it is at `t`.
    pub fn at(&self, t: f32) -> SceneAt<'_> {
        SceneAt { scene: self, t }
    }

    /// Whether anything moves (some object has a motion, so the scene has instances).
    pub fn has_motion(&self) -> bool {
        !self.instances.is_empty()
    }

    /// Give every object called `object` the motion `motion` (a motion that moves nothing puts them
    /// back at rest) and rebuild the trees; lights on them follow. For motion a scene file cannot
    /// carry (OBJ), e.g. from a pipeline file. Errors: no object of that name (the message lists the
    /// names there are), an invalid motion, or a light whose two triangles belong to objects that
    /// would then move differently.
    pub fn set_motion(&mut self, object: &str, motion: RigidMotion) -> Result<(), SceneError> {
        let path = origin_path(&self.name);
        let ids: Vec<usize> = (0..self.objects.len()).filter(|&k| self.objects[k].name == object).collect();
        if ids.is_empty() {
            let mut names: Vec<&str> = self.objects.iter().map(|o| o.name.as_str()).collect();
            names.dedup();
            let shown = names.len().min(20);
            return Err(SceneError::invalid(
                &path,
                format!("no object is called '{object}'"),
                format!(
                    "name one of the scene's objects: {}{}",
                    names[..shown].join(", "),
                    if names.len() > shown { ", …" } else { "" }
                ),
            ));
        }
        motion.validate().map_err(|what| {
            SceneError::invalid(
                &path,
                format!("the motion given to object '{object}': {what}"),
                "use finite numbers and unit rotation quaternions",
            )
        })?;
        let mut objects = self.objects.clone();
        for &k in &ids {
            objects[k].motion = (!motion.is_static()).then_some(motion);
        }
        for (i, t) in self.triangles.iter().enumerate() {
            if t.light == NO_LIGHT {
                continue;
            }
            let (of_light, of_triangle) = (self.light_object[t.light as usize], self.shading[i].object);
            if objects[of_light as usize].motion != objects[of_triangle as usize].motion {
                return Err(SceneError::invalid(
                    &path,
                    format!(
                        "light {} is made of triangles of objects '{}' and '{}', which would move differently",
                        t.light, objects[of_light as usize].name, objects[of_triangle as usize].name
                    ),
                    "give both objects the same motion",
                ));
            }
        }
        // The triangles in their input order (`source`; spatial splits may store copies).
        let mut order: Vec<u32> = (0..self.triangles.len() as u32).collect();
        order.sort_by_key(|&i| self.triangles[i as usize].source);
        order.dedup_by_key(|i| self.triangles[*i as usize].source);
        let records: Vec<TriangleRecord> = order.iter().map(|&i| self.triangles[i as usize]).collect();
        let shading: Vec<TriangleShading> = order.iter().map(|&i| self.shading[i as usize]).collect();
        let positions: Vec<[Vec3; 3]> = records.iter().map(|r| r.vertices()).collect();
        let mut bounds = Aabb::empty();
        for (p, s) in positions.iter().zip(&shading) {
            if objects[s.object as usize].motion.is_none() {
                p.iter().for_each(|&v| bounds.grow(v));
            }
        }
        let built = assemble(&path, &records, &shading, &positions, objects)?;
        self.triangles = built.triangles;
        self.shading = built.shading;
        self.bvh = built.bvh;
        self.objects = built.objects;
        self.instances = built.instances;
        self.instance_root = built.instance_root;
        self.bounds = built.bounds.union(&bounds);
        Ok(())
    }

    /// Closest hit with tmin < t < tmax, ties to the lower triangle index (own traversal over `self.bvh`,
    /// see [`crate::bvh::traverse`]), at the shutter's centre (`t = 0`, [`Scene::at`]).
    pub fn intersect(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
        self.at(0.0).intersect(origin, dir, tmin, tmax)
    }

    /// Whether anything is hit with tmin < t < tmax (shadow rays; stops at the first hit), at `t = 0`.
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> bool {
        self.at(0.0).occluded(origin, dir, tmin, tmax)
    }

    /// Interpolated attributes at a hit, at `t = 0` (see [`SceneAt::surface`]).
    pub fn surface(&self, hit: &Hit, origin: Vec3, dir: Vec3) -> SurfacePoint {
        self.at(0.0).surface(hit, origin, dir)
    }

    /// [`Scene::surface`] of a triangle as stored (rest pose), `dir` given in the same space.
    fn surface_stored(&self, hit: &Hit, dir: Vec3) -> SurfacePoint {
        let tri = &self.triangles[hit.triangle as usize];
        let sh = &self.shading[hit.triangle as usize];
        let (b0, b1, b2) = (1.0 - hit.b1 - hit.b2, hit.b1, hit.b2);
        let (e1, e2) = (tri.e1(), tri.e2());
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

    /// The instance that moves `object`, if it moves.
    #[inline]
    pub fn instance_of(&self, object: u32) -> Option<&Instance> {
        if self.instances.is_empty() {
            return None;
        }
        let k = self.objects.get(object as usize)?.instance?;
        self.instances.get(k as usize)
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

    /// Largest dimension of `bounds`; 0 for a scene with no triangles (whose bounds are empty), so
    /// ray offsets scaled by it stay finite.
    pub fn extent(&self) -> f32 {
        self.bounds.size().max_element().max(0.0)
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

/// A [`Scene`] at one time of the shutter (`Scene::at`): the queries every kernel needs, with each
/// object where it is at that time. Just the scene and the time (make one per sample freely); an
/// instance's transform at that time is computed when a ray enters its swept box.
#[derive(Clone, Copy, Debug)]
pub struct SceneAt<'a> {
    scene: &'a Scene,
    t: f32,
}

impl<'a> SceneAt<'a> {
    /// The time, in [−1, 1].
    pub fn time(&self) -> f32 {
        self.t
    }

    pub fn scene(&self) -> &'a Scene {
        self.scene
    }

    /// Closest hit with tmin < t < tmax (ties to the lower triangle index, across all trees): the
    /// static tree, then every instance whose swept box the ray enters before the best hit so far,
    /// in its rest space (the ray moved by the inverse transform at this time; same ray parameter).
    #[inline]
    pub fn intersect(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
        let s = self.scene;
        if s.instances.is_empty() {
            return bvh::traverse::closest(&s.bvh, origin, dir, tmin, tmax);
        }
        let best = bvh::traverse::closest(&s.bvh, origin, dir, tmin, tmax);
        self.intersect_instances(best, origin, dir, tmin, tmax)
    }

    /// Whether anything is hit with tmin < t < tmax at this time (stops at the first hit).
    #[inline]
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> bool {
        let s = self.scene;
        if s.instances.is_empty() {
            return bvh::traverse::occluded(&s.bvh, origin, dir, tmin, tmax);
        }
        bvh::traverse::occluded(&s.bvh, origin, dir, tmin, tmax) || self.occluded_instances(origin, dir, tmin, tmax)
    }

    // Measured: with the `instances.is_empty()` test *after* the static traversal, the scene
    // pointer stayed live across the traversal loop and static scenes traced 13% slower (`grids`
    // primary rays, one thread, 15.4 → 13.4 Mrays/s); tested first, as above, they trace as fast
    // as before motion existed. The instance loops stay out of line so the static path's code
    // does not depend on them.

    /// [`SceneAt::intersect`]'s instances, after the static tree gave `best`: those whose swept box
    /// the ray enters before the best hit so far, found by walking the top-level tree.
    #[inline(never)]
    fn intersect_instances(&self, mut best: Option<Hit>, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
        let s = self.scene;
        let limit = best.map_or(tmax, |h| h.t);
        bvh::traverse::walk_leaves(&s.bvh, s.instance_root, origin, dir, tmin, limit, |k| {
            let inst = &s.instances[k as usize];
            let xf = inst.prepared.at(self.t);
            let (o, d) = (xf.inverse_point(origin), xf.inverse_vector(dir));
            if let Some(h) = bvh::traverse_from(&s.bvh, inst.root, o, d, tmin, tmax, false, best.as_ref()) {
                best = Some(h);
            }
            Some(best.map_or(tmax, |h| h.t))
        });
        best
    }

    /// [`SceneAt::occluded`]'s instances.
    #[inline(never)]
    fn occluded_instances(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> bool {
        let s = self.scene;
        let mut occluded = false;
        bvh::traverse::walk_leaves(&s.bvh, s.instance_root, origin, dir, tmin, tmax, |k| {
            let inst = &s.instances[k as usize];
            let xf = inst.prepared.at(self.t);
            let (o, d) = (xf.inverse_point(origin), xf.inverse_vector(dir));
            occluded = bvh::traverse_from(&s.bvh, inst.root, o, d, tmin, tmax, true, None).is_some();
            (!occluded).then_some(tmax)
        });
        occluded
    }

    /// Interpolated attributes at a hit of this time's ray (`dir` in world space), in world space at
    /// this time: a moving triangle's point and normals are computed as stored (rest pose, with `dir`
    /// moved there) and moved by the transform at this time (normals rotated). The position is
    /// interpolated from the vertices (more precise than origin + t·dir). Both normals face the
    /// incoming ray; shading normals that are missing/degenerate fall back to the geometric one.
    pub fn surface(&self, hit: &Hit, origin: Vec3, dir: Vec3) -> SurfacePoint {
        let _ = origin;
        let s = self.scene;
        let object = s.shading[hit.triangle as usize].object;
        let Some(inst) = s.instance_of(object) else {
            return s.surface_stored(hit, dir);
        };
        let xf = inst.prepared.at(self.t);
        let mut sp = s.surface_stored(hit, xf.inverse_vector(dir));
        sp.position = xf.point(sp.position);
        sp.geometric_normal = xf.vector(sp.geometric_normal);
        sp.shading_normal = xf.vector(sp.shading_normal);
        sp
    }

    /// Light `i` where it is at this time (a light on a moving object moves with it; `Scene::lights`
    /// keeps the rest pose).
    pub fn light(&self, i: usize) -> AreaLight {
        let s = self.scene;
        let light = s.lights[i];
        let Some(inst) = s.light_object.get(i).and_then(|&o| s.instance_of(o)) else {
            return light;
        };
        let xf = inst.prepared.at(self.t);
        let shape = match light.shape {
            LightShape::Rect { corner, edge_u, edge_v } => {
                LightShape::Rect { corner: xf.point(corner), edge_u: xf.vector(edge_u), edge_v: xf.vector(edge_v) }
            }
            LightShape::Triangle { v0, v1, v2 } => {
                LightShape::Triangle { v0: xf.point(v0), v1: xf.point(v1), v2: xf.point(v2) }
            }
        };
        AreaLight { shape, ..light }
    }

    /// World velocity `dx/dt` per unit `t` (per half shutter) of the surface point `sp` of this time
    /// (its object's motion at `sp.position`); zero at rest.
    pub fn velocity(&self, sp: &SurfacePoint) -> Vec3 {
        self.object_velocity(sp.object, sp.position)
    }

    /// World velocity per unit `t` of point `x` of object `object` at this time; zero at rest.
    pub fn object_velocity(&self, object: u32, x: Vec3) -> Vec3 {
        match self.scene.instance_of(object) {
            Some(inst) => inst.prepared.velocity(self.t, x),
            None => Vec3::ZERO,
        }
    }
}

/// `objects` extended to every object id the triangles use (`object<i>` at rest), motions checked,
/// motions that move nothing stored as `None`, instances cleared (the build sets them).
fn complete_objects(
    path: &std::path::Path,
    mut objects: Vec<SceneObject>,
    tris: &[(Vec3, Vec3, Vec3, TriangleShading)],
) -> Result<Vec<SceneObject>, SceneError> {
    let used = tris.iter().map(|t| t.3.object as usize + 1).max().unwrap_or(0);
    if used > objects.len() {
        let from = objects.len();
        objects.extend((from..used).map(|i| SceneObject::named(format!("object{i}"))));
    }
    for o in &mut objects {
        o.instance = None;
        if let Some(m) = &o.motion {
            m.validate().map_err(|what| {
                SceneError::invalid(
                    path,
                    format!("the motion of object '{}': {what}", o.name),
                    "use finite numbers and unit rotation quaternions",
                )
            })?;
            if m.is_static() {
                o.motion = None;
            }
        }
    }
    Ok(objects)
}

/// A motion's numbers as bits (a hash key: equal bits, same motion).
fn motion_bits(m: &RigidMotion) -> [u32; 17] {
    let mut k = [0u32; 17];
    let v = m
        .pivot
        .to_array()
        .into_iter()
        .chain(m.translation[0].to_array())
        .chain(m.translation[1].to_array())
        .chain(m.rotation[0].to_array())
        .chain(m.rotation[1].to_array());
    for (slot, x) in k.iter_mut().zip(v) {
        *slot = x.to_bits();
    }
    k
}

/// What [`assemble`] builds.
struct Assembled {
    triangles: Vec<TriangleRecord>,
    shading: Vec<TriangleShading>,
    bvh: Bvh,
    objects: Vec<SceneObject>,
    instances: Vec<Instance>,
    /// See [`Scene::instance_root`].
    instance_root: u32,
    /// The union of the instances' swept bounds.
    bounds: Aabb,
}

/// Build the trees over triangles given in input order (`records`, `shading` and the `positions` the
/// builder sees, index-aligned): one static tree over the objects at rest (node 0; an empty node if
/// none), then one per group of moving objects sharing a motion. Triangles are reordered to the
/// trees' leaf order, static ones first. With nothing moving this is exactly the single-tree build.
fn assemble(
    path: &std::path::Path,
    records: &[TriangleRecord],
    shading: &[TriangleShading],
    positions: &[[Vec3; 3]],
    mut objects: Vec<SceneObject>,
) -> Result<Assembled, SceneError> {
    // Groups of moving objects: one per distinct motion (objects moving alike share one tree),
    // found by the motion's bits so that many objects stay linear.
    let mut motions: Vec<RigidMotion> = Vec::new();
    let mut by_bits: HashMap<[u32; 17], u32> = HashMap::new();
    let mut group = vec![u32::MAX; objects.len()];
    for (k, o) in objects.iter().enumerate() {
        if let Some(m) = o.motion {
            group[k] = *by_bits.entry(motion_bits(&m)).or_insert_with(|| {
                motions.push(m);
                (motions.len() - 1) as u32
            });
        }
    }
    let group_of = |i: usize| group[shading[i].object as usize];
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); motions.len() + 1];
    if motions.is_empty() {
        members[0] = (0..records.len() as u32).collect();
    } else {
        for i in 0..records.len() {
            let g = group_of(i);
            members[if g == u32::MAX { 0 } else { g as usize + 1 }].push(i as u32);
        }
    }

    let mut triangles = Vec::with_capacity(records.len());
    let mut shading_out = Vec::with_capacity(records.len());
    let mut bvh = Bvh { nodes: Vec::new(), packs: Vec::with_capacity(records.len() / 2) };
    let mut instances = Vec::with_capacity(motions.len());
    let mut bounds = Aabb::empty();
    for (g, idx) in members.iter().enumerate() {
        if idx.is_empty() {
            if g == 0 {
                // Nothing at rest: an empty root (every slot culled) keeps node 0 the static tree.
                bvh.nodes.push(WideNode::empty());
            }
            continue;
        }
        let subset: Vec<[Vec3; 3]>;
        let input: &[[Vec3; 3]] = if idx.len() == records.len() {
            positions
        } else {
            subset = idx.iter().map(|&i| positions[i as usize]).collect();
            &subset
        };
        let built = bvh::build(input);
        if built.stack_need > STACK_SIZE || built.order.len() > MAX_REFERENCES {
            return Err(SceneError::invalid(
                path,
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
        if built.order.len() < input.len() {
            return Err(SceneError::invalid(
                path,
                "BVH builder returned a different primitive count",
                "report this as a bug",
            ));
        }
        let first = triangles.len();
        for &src in &built.order {
            let i = idx[src as usize] as usize;
            triangles.push(records[i]);
            shading_out.push(shading[i]);
        }
        if triangles.len() > MAX_REFERENCES {
            return Err(SceneError::invalid(
                path,
                format!("{} triangle references, more than the BVH can address ({MAX_REFERENCES})", triangles.len()),
                "decimate the meshes or split the scene",
            ));
        }
        let root = bvh.pack_into(built.nodes, &triangles[first..], first as u32);
        if g == 0 {
            continue;
        }
        let motion = motions[g - 1];
        // The vertices as traced (the given ones, bit for bit).
        let mut rest_bounds = Aabb::empty();
        let mut points = Vec::with_capacity(3 * (triangles.len() - first));
        for r in &triangles[first..] {
            for v in r.vertices() {
                rest_bounds.grow(v);
                points.push(v);
            }
        }
        let swept_bounds = motion.swept_bounds(&points);
        bounds = bounds.union(&swept_bounds);
        instances.push(Instance {
            root,
            first: first as u32,
            count: (triangles.len() - first) as u32,
            motion,
            prepared: motion.prepare(),
            rest_bounds,
            swept_bounds,
        });
    }
    for (k, o) in objects.iter_mut().enumerate() {
        o.instance = (group[k] != u32::MAX).then_some(group[k]);
    }
    let mut instance_root = 0;
    if !instances.is_empty() {
        let boxes: Vec<([f32; 3], [f32; 3])> =
            instances.iter().map(|i| (i.swept_bounds.min.to_array(), i.swept_bounds.max.to_array())).collect();
        let top = bvh::build::build_boxes(&boxes);
        if top.stack_need + 1 > bvh::build::TOP_STACK_SIZE {
            return Err(SceneError::invalid(
                path,
                format!(
                    "the tree over the {} moving instances needs {} stack entries (the walk has {})",
                    instances.len(),
                    top.stack_need + 1,
                    bvh::build::TOP_STACK_SIZE
                ),
                "give fewer groups of objects their own motion",
            ));
        }
        // Appended after the instances' trees: inner references shifted, leaves name instances.
        instance_root = bvh.nodes.len() as u32;
        for mut node in top.nodes {
            for slot in 0..bvh::WIDTH {
                if node.used(slot) && node.child[slot] & bvh::LEAF_BIT == 0 {
                    node.child[slot] += instance_root;
                }
            }
            bvh.nodes.push(node);
        }
    }
    Ok(Assembled { triangles, shading: shading_out, bvh, objects, instances, instance_root, bounds })
}

/// Whether a material's numbers are usable: finite, non-negative colours, emission at most
/// [`MAX_RADIANCE`] (larger sums overflow to inf and NaN pixels), a finite Phong exponent, a valid
/// texture index. One check for every loader; loaders with a more precise location (a glTF JSON path)
/// check their raw values first.
fn check_material(path: &std::path::Path, i: usize, m: &Material, textures: usize) -> Result<(), SceneError> {
    let what = |field: &str, v: String| format!("material {i} ('{}') has {field} {v}", m.name);
    for (field, v) in [("base colour", m.base_color), ("specular", m.specular), ("emission", m.emission)] {
        if !v.is_finite() || v.min_element() < 0.0 {
            return Err(SceneError::invalid(path, what(field, v.to_string()), "use finite, non-negative values"));
        }
    }
    if m.emission.max_element() > MAX_RADIANCE {
        return Err(SceneError::invalid(
            path,
            what("emission", m.emission.to_string()),
            format!("keep emitted radiance at most {MAX_RADIANCE:e} per channel (scale the light down)"),
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
                format!("material {i} ('{}') uses texture {t} but there are {textures}", m.name),
                "give every material a valid texture index",
            ));
        }
    }
    Ok(())
}

/// Indices of the triangles worth building a BVH over: zero-area ones (cross product of the edges is
/// zero) and exact copies of an earlier triangle (same three vertices bit for bit, in the same cyclic
/// order) are left out. Returns the kept input indices and one warning per kind of drop.
fn drop_degenerate_and_duplicates(name: &str, tris: &[(Vec3, Vec3, Vec3, TriangleShading)]) -> (Vec<u32>, Vec<String>) {
    let key = |v: Vec3| v.to_array().map(|c| if c == 0.0 { 0 } else { c.to_bits() }); // -0 == +0
    let mut seen: std::collections::HashSet<[[u32; 3]; 3]> = std::collections::HashSet::with_capacity(tris.len());
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

/// Turn emissive triangles into lights. Returns the lights, per input triangle its light index, and
/// per light the object of its (first) triangle. Two triangles merge only if their objects move
/// alike (a light moves with its object).
fn extract_lights(
    tris: &[(Vec3, Vec3, Vec3, TriangleShading)],
    materials: &[Material],
    extent: f32,
    objects: &[SceneObject],
) -> (Vec<AreaLight>, Vec<u32>, Vec<u32>) {
    let mut light_of = vec![NO_LIGHT; tris.len()];
    let mut light_object = Vec::new();
    let emissive: Vec<usize> = (0..tris.len())
        .filter(|&i| materials[tris[i].3.material as usize].is_emissive())
        .filter(|&i| (tris[i].1 - tris[i].0).cross(tris[i].2 - tris[i].0).length_squared() > 0.0)
        .collect();
    if emissive.is_empty() {
        return (Vec::new(), light_of, light_object);
    }
    let motion = |i: usize| &objects[tris[i].3.object as usize].motion;
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
                if j == i || light_of[j] != NO_LIGHT || motion(i) != motion(j) {
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
            None => LightShape::Triangle { v0: v[0], v1: v[1], v2: v[2] },
        };
        lights.push(AreaLight { shape, radiance, two_sided: false });
        light_object.push(tris[i].3.object);
    }
    (lights, light_of, light_object)
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
    Some(LightShape::Rect { corner, edge_u: eu, edge_v: ev })
}
