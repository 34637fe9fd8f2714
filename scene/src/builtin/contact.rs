//! `suite_contact`: contact shadows under a large light.
//!
//! - **Objects resting on the ground**: a 0.5 m cube turned 20°, a 0.3 m sphere touching the ground
//!   at one point, a cylinder (r 0.12 m, 0.9 m long) lying on its side, a 1.17 m plank leaning from the
//!   ground onto the cube, and two small 6 cm cubes. Where an occluder meets its receiver the
//!   occluder distance goes to 0: `s_min → 0`, the penumbra narrows to a line, eq. 3.21 asks for
//!   unbounded samples (capped by `max_rays`) and the filter must shrink to nothing there, while a
//!   few centimetres away the same shadow is wide and soft.
//! - **Light**: a large 1.6 × 1.6 m square only 2 m up (solid angle ≈ 0.5 sr at the ground): wide
//!   penumbrae everywhere except at the contacts; out of view.
//! - **Ground**: plain diffuse 10 × 9 m (albedo 0.7).
//! - **Camera**: at (0, 1.5, 2.6) looking at (0, 0.15, 0), 45° vertical field of view.

use glam::{Mat3, Mat4, Quat, Vec3};

use super::mesh::{add_box, add_cylinder, add_ground, add_sphere, add_square_light};
use super::pinhole;
use crate::data::SceneData;
use crate::Material;

pub(crate) fn contact() -> SceneData {
    let mut d = SceneData::default();
    let ground = d.add_material(Material::diffuse("ground", Vec3::splat(0.7)), false);
    let o = d.new_named_object("ground");
    add_ground(&mut d, (-8.0, 8.0, -16.0, 3.0), 0.5, ground, o);
    let grey = d.add_material(Material::diffuse("cube", Vec3::new(0.55, 0.55, 0.6)), false);
    let o = d.new_named_object("cube");
    let cube_yaw = Quat::from_rotation_y(20f32.to_radians());
    let cube_centre = Vec3::new(-0.75, 0.25, -0.2);
    add_box(&mut d, Mat4::from_rotation_translation(cube_yaw, cube_centre), Vec3::splat(0.25), grey, o);
    // The plank: 1.17 m × 0.22 m × 2 cm, its foot on the ground 1 m in front of the cube, leaning on
    // the top edge of the cube's front face (27° up).
    let wood = d.add_material(Material::diffuse("plank", Vec3::new(0.6, 0.45, 0.3)), false);
    let o = d.new_named_object("plank");
    let top = cube_centre + cube_yaw * Vec3::new(0.0, 0.25, 0.25);
    let foot = top + cube_yaw * Vec3::new(0.0, 0.0, 1.0);
    let foot = Vec3::new(foot.x, 0.0, foot.z);
    let along = (top - foot).normalize();
    let across = cube_yaw * Vec3::X;
    let up = across.cross(along).normalize(); // the plank's upward face normal (y > 0)
                                              // 5 cm past the edge, so the plank rests on the cube's top rather than ending on the edge.
    let half_len = 0.5 * (top - foot).length() + 0.025;
    let centre = 0.5 * (top + foot) + along * 0.025 + up * 0.01;
    let xf = Mat4::from_mat3_translation(Mat3::from_cols(across, up, across.cross(up)), centre);
    add_box(&mut d, xf, Vec3::new(0.11, 0.01, half_len), wood, o);
    let blue = d.add_material(Material::diffuse("sphere", Vec3::new(0.3, 0.4, 0.7)), false);
    let o = d.new_named_object("sphere");
    add_sphere(&mut d, Vec3::new(0.3, 0.3, 0.25), 0.3, 24, 48, blue, o);
    let green = d.add_material(Material::diffuse("cylinder", Vec3::new(0.35, 0.6, 0.3)), false);
    let o = d.new_named_object("cylinder");
    let lying = Quat::from_rotation_y(-35f32.to_radians()) * Quat::from_rotation_z(std::f32::consts::FRAC_PI_2);
    add_cylinder(&mut d, Mat4::from_rotation_translation(lying, Vec3::new(1.05, 0.12, -0.35)), 0.12, 0.9, 48, green, o);
    let o = d.new_named_object("small cubes");
    for (x, z, yaw) in [(0.05f32, 0.95f32, 10f32), (0.4, 0.8, 40.0)] {
        let xf = Mat4::from_rotation_translation(Quat::from_rotation_y(yaw.to_radians()), Vec3::new(x, 0.03, z));
        add_box(&mut d, xf, Vec3::splat(0.03), grey, o);
    }
    let side = 1.6;
    add_square_light(&mut d, 5.0, Vec3::new(0.0, 2.0, -0.5), side);
    d.camera = Some(pinhole(Vec3::new(0.0, 1.5, 2.6), Vec3::new(0.0, 0.15, 0.0), 45.0));
    d
}
