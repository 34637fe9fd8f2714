//! Loader-side scene description: loose triangles plus what `Scene::from_triangles` needs. Loaders and
//! built-ins produce this so the RON composer can merge several sources before one BVH build.

use glam::{Mat3, Mat4, Quat, Vec2, Vec3};

use crate::motion::RigidMotion;
use crate::{Camera, Material, Scene, SceneError, SceneObject, Texture, TriangleShading};

#[derive(Clone, Debug, Default)]
pub(crate) struct SceneData {
    pub tris: Vec<(Vec3, Vec3, Vec3, TriangleShading)>,
    pub materials: Vec<Material>,
    /// Per material: emits from both sides (glTF `doubleSided`, RON `two_sided`).
    pub two_sided: Vec<bool>,
    pub textures: Vec<Texture>,
    pub camera: Option<Camera>,
    /// Per object id: its name and motion (`Scene::objects`); the next free id is its length.
    pub objects: Vec<SceneObject>,
    /// Things the loader accepted but the user should know about (become `Scene::warnings`).
    pub warnings: Vec<String>,
}

impl SceneData {
    pub fn add_material(&mut self, m: Material, two_sided: bool) -> u32 {
        self.materials.push(m);
        self.two_sided.push(two_sided);
        (self.materials.len() - 1) as u32
    }

    /// One triangle with per-vertex normals and uvs (every loader's common path).
    pub fn push(&mut self, p: [Vec3; 3], n: [Vec3; 3], uv: [Vec2; 3], material: u32, object: u32) {
        self.tris.push((p[0], p[1], p[2], TriangleShading { n, uv, material, object }));
    }

    /// A new object at rest named `object<id>`.
    pub fn new_object(&mut self) -> u32 {
        let id = self.objects.len();
        self.new_named_object(format!("object{id}"))
    }

    /// A new object at rest called `name`.
    pub fn new_named_object(&mut self, name: impl Into<String>) -> u32 {
        self.objects.push(SceneObject::named(name));
        (self.objects.len() - 1) as u32
    }

    /// Give object `object` a motion over the shutter (its triangles are stored in the rest pose).
    pub fn set_motion(&mut self, object: u32, motion: RigidMotion) {
        if let Some(o) = self.objects.get_mut(object as usize) {
            o.motion = Some(motion);
        }
    }

    /// Whether any object has a motion.
    pub fn has_motion(&self) -> bool {
        self.objects.iter().any(|o| o.motion.is_some())
    }

    /// A triangle with flat normals and zero uvs.
    pub fn flat(&mut self, a: Vec3, b: Vec3, c: Vec3, material: u32, object: u32) {
        let n = (b - a).cross(c - a).normalize_or_zero();
        self.tris.push((a, b, c, TriangleShading { n: [n; 3], uv: [Vec2::ZERO; 3], material, object }));
    }

    /// A quad a-b-c-d (counter-clockwise around its front) as two flat triangles sharing the a-c diagonal.
    pub fn quad(&mut self, a: Vec3, b: Vec3, c: Vec3, d: Vec3, material: u32, object: u32) {
        self.flat(a, b, c, material, object);
        self.flat(a, c, d, material, object);
    }

    /// Append another description (materials/textures/objects renumbered); its camera is ignored.
    /// `transform` must be a similarity (uniform scale, rotation, translation: what `.ron` placement
    /// makes) when `other` has motion: its motions are carried into the new frame
    /// ([`similarity_motion`]).
    pub fn append(&mut self, other: SceneData, transform: Mat4, material_override: Option<u32>) {
        let mat_off = self.materials.len() as u32;
        let tex_off = self.textures.len() as u32;
        let obj_off = self.objects.len() as u32;
        let normal_m = transform.inverse().transpose();
        for (a, b, c, mut s) in other.tris {
            s.material = material_override.unwrap_or(s.material + mat_off);
            s.object += obj_off;
            s.n = s.n.map(|n| normal_m.transform_vector3(n).normalize_or_zero());
            self.tris.push((
                transform.transform_point3(a),
                transform.transform_point3(b),
                transform.transform_point3(c),
                s,
            ));
        }
        for mut m in other.materials {
            m.base_color_texture = m.base_color_texture.map(|t| t + tex_off);
            self.materials.push(m);
        }
        self.two_sided.extend(other.two_sided);
        self.textures.extend(other.textures);
        let objects = other.objects.into_iter().map(|mut o| {
            o.motion = o.motion.map(|m| similarity_motion(&m, transform));
            o
        });
        self.objects.extend(objects);
        self.warnings.extend(other.warnings);
    }

    pub fn into_scene(self, name: &str) -> Result<Scene, SceneError> {
        // An empty world is a scene (mixed reality with no virtual objects), but only with a camera:
        // there is nothing to frame one around, and an empty file without one is a mistake.
        if self.tris.is_empty() && self.camera.is_none() {
            return Err(SceneError::invalid(
                std::path::Path::new(name),
                "the scene has no triangles and no camera",
                "add meshes, a built-in or lights; an intentionally empty world (e.g. mixed reality with no virtual objects) needs a `camera`",
            ));
        }
        let mut bounds = crate::Aabb::empty();
        for t in &self.tris {
            for p in [t.0, t.1, t.2] {
                if p.is_finite() {
                    bounds.grow(p);
                }
            }
        }
        let camera = self.camera.unwrap_or_else(|| {
            if bounds.min.is_finite() {
                Camera::framing(bounds.min, bounds.max)
            } else {
                Camera::default()
            }
        });
        let two_sided = self.two_sided;
        let mut scene = Scene::from_objects(name, self.tris, self.materials, self.textures, camera, self.objects)?;
        scene.set_two_sided_by_material(&two_sided);
        // Loader warnings first (they are about the files), then the builder's (dropped triangles).
        let mut warnings = self.warnings;
        warnings.append(&mut scene.warnings);
        scene.warnings = warnings;
        Ok(scene)
    }
}

/// A motion of points in some frame carried into the frame `x' = X·x` of a similarity `X` (uniform
/// scale `s`, possibly negative, rotation `Q`, translation): `X(p + T + R(x − p)) = X(p) + sQT +
/// (QRQ⁻¹)(X(x) − X(p))`, so the pivot maps through `X`, translations scale and rotate, and rotations
/// are conjugated by `Q`.
pub(crate) fn similarity_motion(m: &RigidMotion, transform: Mat4) -> RigidMotion {
    let linear = Mat3::from_mat4(transform);
    let scale = linear.determinant().cbrt();
    let q = if scale != 0.0 && scale.is_finite() {
        Quat::from_mat3(&(linear * (1.0 / scale))).normalize()
    } else {
        Quat::IDENTITY
    };
    RigidMotion {
        pivot: transform.transform_point3(m.pivot),
        translation: m.translation.map(|t| linear * t),
        rotation: m.rotation.map(|r| (q * r * q.conjugate()).normalize()),
    }
}
