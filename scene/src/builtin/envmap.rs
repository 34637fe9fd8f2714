//! `envmap` (and `envmap_light`): the environment-lighting test scene of issue 14, in the spirit of
//! thesis Fig. 6.7 ("a diffuse and a phong (exponent 64) object on a diffuse plane" under an outdoor
//! environment map, direct light only). Every part tests one term of the Ch. 6 analysis:
//!
//! - **`sky`**: lit only by `builtin:sky` (no area light): its sun (1.5° radius, 4000× the sky) casts
//!   sharp shadows whose bandwidth is bounded by `B_e` and the occluder distance (eq. 6.13, the
//!   `cos²θ_occ/z · B_e` term); the sky, clouds and two bright "windows" give soft, low-frequency light
//!   from every side, and the dark ground lights the undersides.
//! - **`ground`**: a 40 × 40 m diffuse plane (albedo 0.6): flat, so the curvature term κ of eq. 6.13 is
//!   zero and only occlusion sets the bandwidth; it receives both objects' shadows and contact shadows
//!   where they touch it (z → 0). It ends 20 m behind the objects, so camera rays above its far edge
//!   (about the top 13% of the image) miss everything and show the map (`Scene::background`).
//! - **`sphere`** (diffuse, 0.5 m radius, resting on the plane): constant positive curvature (κ = 2/m,
//!   eq. 6.20) and an attached shadow line (terminator) from the sun.
//! - **`torus`** (Phong k_s 0.5, m = 64, k_d 0.2; tilted 25° about x, resting on the plane): glossy
//!   reflections of the sun and windows (the `B_ρ` terms of eq. 6.17, B_ρ(64) ≈ 10), curvature varying
//!   in sign across the surface (inner side saddle-shaped), and self-shadowing through the hole.
//! - **camera**: at (0, 1.6, 3.4) looking at (0, 0.45, 0), 40° vertical field of view: both objects, their
//!   shadows toward the camera (the sun is behind them, a little left, 35° up), and a strip of the map
//!   above the plane's far edge.
//!
//! `envmap_light` adds one 0.5 × 0.5 m rectangular area light 2.5 m up (radiance 20), for pipelines that
//! compose area-light SoftShadows with the environment.
//!
//! `envmap_far` is `envmap_virtual` with the torus 1 km below the ground (a virtual object without
//! influence: the mixed-reality composite must equal the photograph bit for bit).
//!
//! `envmap_real` and `envmap_virtual` split `envmap` for the mixed-reality round trip (issue 15):
//! `envmap_real` is the ground and the sphere (the "real" world whose render and position, normal and
//! albedo AOVs stand in for a capture), `envmap_virtual` the torus alone (the object inserted into
//! it). Same camera, same map; their union is exactly `envmap`'s triangles and materials.
//!
//! The map is attached to the scene (`Scene::environment`), `scale` 1, `rotation_deg` 0.

use glam::{Mat4, Quat, Vec3};

use super::mesh::{add_ground, add_sphere, add_square_light, add_torus};
use crate::data::SceneData;
use crate::{Camera, Material};

/// Where the sphere and torus rest, and their sizes.
pub const SPHERE_CENTRE: Vec3 = Vec3::new(-0.65, 0.5, 0.0);
pub const SPHERE_RADIUS: f32 = 0.5;
pub const TORUS_CENTRE: Vec3 = Vec3::new(0.75, 0.0, 0.15);
pub const TORUS_MAJOR: f32 = 0.42;
pub const TORUS_MINOR: f32 = 0.16;
/// The torus's tilt about x (radians).
pub const TORUS_TILT: f32 = 25.0 * std::f32::consts::PI / 180.0;
/// The environment the built-in carries.
pub const MAP: &str = "builtin:sky";

/// Which parts of the scene to build.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Parts {
    /// The ground and the sphere (`envmap_real`).
    pub real: bool,
    /// The torus (`envmap_virtual`).
    pub virtual_objects: bool,
    /// The area light (`envmap_light`).
    pub light: bool,
    /// The torus moved 1 km below the ground (`envmap_far`): a virtual object no camera ray, shadow
    /// ray or reflection of the real scene reaches — mixed reality must leave the photograph as it is.
    pub far: bool,
}

/// The scene's geometry and camera; `with_light` adds the area light (`envmap_light`).
pub(crate) fn envmap(with_light: bool) -> SceneData {
    envmap_parts(Parts { real: true, virtual_objects: true, light: with_light, far: false })
}

/// `envmap`'s parts (in `envmap`'s order, so the parts' triangles and materials are `envmap`'s).
pub(crate) fn envmap_parts(parts: Parts) -> SceneData {
    let mut d = SceneData::default();
    if parts.real {
        add_real(&mut d);
    }
    if parts.virtual_objects {
        add_torus_part(&mut d, if parts.far { Vec3::new(0.0, -1000.0, 0.0) } else { Vec3::ZERO });
    }
    if parts.light {
        add_square_light(&mut d, 20.0, Vec3::new(0.0, 2.5, 0.0), 0.5);
    }
    d.camera = Some(Camera {
        position: Vec3::new(0.0, 1.6, 3.4),
        look_at: Vec3::new(0.0, 0.45, 0.0),
        up: Vec3::Y,
        vfov_deg: 40.0,
        aperture_radius: 0.0,
        focus_distance: 0.0,
        shutter_open: 0.0,
        shutter_close: 0.0,
    });
    d
}

/// The ground plane and the sphere.
fn add_real(d: &mut SceneData) {
    let ground = d.add_material(Material::diffuse("ground", Vec3::splat(0.6)), false);
    let o = d.new_named_object("ground");
    add_ground(d, (-20.0, 20.0, -20.0, 20.0), 0.5, ground, o);
    let diffuse = d.add_material(Material::diffuse("sphere", Vec3::new(0.7, 0.62, 0.5)), false);
    let o = d.new_named_object("sphere");
    add_sphere(d, SPHERE_CENTRE, SPHERE_RADIUS, 64, 128, diffuse, o);
}

/// The tilted Phong torus, moved by `offset`.
fn add_torus_part(d: &mut SceneData, offset: Vec3) {
    let glossy = d.add_material(
        Material {
            specular: Vec3::splat(0.5),
            phong_exponent: 64.0,
            ..Material::diffuse("torus", Vec3::new(0.12, 0.18, 0.35))
        },
        false,
    );
    let o = d.new_named_object("torus");
    // Tilted about x, then lifted so its lowest point touches the plane: the lowest point of a torus
    // tilted by t is (R sin t + r) below its centre.
    let lift = TORUS_MAJOR * TORUS_TILT.sin() + TORUS_MINOR;
    let xf = Mat4::from_rotation_translation(Quat::from_rotation_x(TORUS_TILT), TORUS_CENTRE + Vec3::Y * lift + offset);
    add_torus(d, xf, TORUS_MAJOR, TORUS_MINOR, glossy, o);
}
