//! `suite_glossy`: glossy receivers — a Phong floor and Phong objects, seen at a low angle.
//!
//! - **Floor**: Phong (k_d 0.35, k_s 0.35, exponent 40), 10 × 6 m, receiving the objects' shadows;
//!   the camera looks along it at ≈ 20°, so glossy reflections of the bright wall and the objects
//!   stretch toward the camera. The glossy indirect component (thesis Ch. 4, `Ω_h` of the Phong lobe)
//!   needs its own, narrower filter; SoftShadows is diffuse-only (Ch. 3), so for it the floor is a
//!   k_d = 0.35 receiver and the scene tests shadows on a darker surface.
//! - **Objects**: a Phong sphere (exponent 80) resting on the floor, a glossy box (exponent 20) and a
//!   bright diffuse box (albedo 0.85) whose light the floor reflects.
//! - **Back wall**: diffuse, warm (0.8, 0.7, 0.55), 1.5 m behind the objects.
//! - **Light**: 0.9 × 0.9 m, 2.2 m up, out of view.
//! - **Camera**: at (0, 1.0, 3) looking at (0, 0.35, −0.3), 45° vertical field of view.

use glam::{Mat4, Quat, Vec3};

use super::mesh::{add_box, add_ground, add_panel, add_sphere, add_square_light};
use super::{phong, pinhole};
use crate::data::SceneData;
use crate::Material;

pub(crate) fn glossy() -> SceneData {
    let mut d = SceneData::default();
    let floor = d.add_material(phong("floor", Vec3::new(0.35, 0.33, 0.3), 0.35, 40.0), false);
    let o = d.new_named_object("floor");
    add_ground(&mut d, (-5.0, 5.0, -1.8, 4.2), 0.5, floor, o);
    let wall = d.add_material(Material::diffuse("wall", Vec3::new(0.8, 0.7, 0.55)), false);
    let o = d.new_named_object("wall");
    let (x0, x1, z, top) = (-5.0f32, 5.0f32, -1.8f32, 4.0f32);
    add_panel(
        &mut d,
        [Vec3::new(x0, 0.0, z), Vec3::new(x1, 0.0, z), Vec3::new(x1, top, z), Vec3::new(x0, top, z)],
        Vec3::Z,
        0.5,
        wall,
        o,
    );
    let sphere = d.add_material(phong("sphere", Vec3::new(0.12, 0.2, 0.45), 0.5, 80.0), false);
    let o = d.new_named_object("sphere");
    add_sphere(&mut d, Vec3::new(0.1, 0.35, 0.0), 0.35, 32, 64, sphere, o);
    let glossy_box = d.add_material(phong("glossy box", Vec3::new(0.45, 0.2, 0.15), 0.3, 20.0), false);
    let o = d.new_named_object("glossy box");
    let xf = Mat4::from_rotation_translation(Quat::from_rotation_y(0.6), Vec3::new(-0.85, 0.3, -0.5));
    add_box(&mut d, xf, Vec3::new(0.22, 0.3, 0.22), glossy_box, o);
    let white = d.add_material(Material::diffuse("white box", Vec3::splat(0.85)), false);
    let o = d.new_named_object("white box");
    let xf = Mat4::from_rotation_translation(Quat::from_rotation_y(-0.3), Vec3::new(1.0, 0.25, -0.7));
    add_box(&mut d, xf, Vec3::new(0.3, 0.25, 0.2), white, o);
    let side = 0.9;
    add_square_light(&mut d, 16.0, Vec3::new(0.0, 2.2, -0.3), side);
    d.camera = Some(pinhole(Vec3::new(0.0, 1.0, 3.0), Vec3::new(0.0, 0.35, -0.3), 45.0));
    d
}
