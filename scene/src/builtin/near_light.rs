//! `suite_near_light`: occluders close to the light, mixed with occluders close to the receiver.
//!
//! - **Louvre**: eight 4 cm slats at a 6 cm pitch, 0.2 m below the 0.8 m light (2.6 m up), under
//!   its left half (two thirds of which they block): to the ground, an occluder at 2.4 m has `s = d1/d2 − 1 ≈ 0.08`, so its shadow
//!   is spread over metres (a smooth dimming), yet eq. 3.21 asks for many samples (`n ∝ 1/s_min²`)
//!   and eq. 3.13's `σ s_min` gives a wide filter — the rate and width formulas at their far end.
//! - **Table**: a 1.0 × 0.6 m top at 0.75 m on four 4 cm legs, and a 0.35 m box on the ground beside
//!   it: pixels in the table's shadow see occluders at 0.75 m and 2.4 m together (`s_max/s_min`
//!   large), the legs and the box give contact shadows.
//! - **Ground**: plain diffuse 10 × 9 m (albedo 0.7).
//! - **Light**: 0.8 × 0.8 m, 2.6 m up, out of view.
//! - **Camera**: at (0, 1.7, 3) looking at (0, 0.15, 0), 45° vertical field of view.

use glam::{Mat4, Quat, Vec3};

use super::mesh::{add_bar, add_box, add_ground, add_square_light};
use super::pinhole;
use crate::data::SceneData;
use crate::Material;

pub(crate) fn near_light() -> SceneData {
    let mut d = SceneData::default();
    let ground = d.add_material(Material::diffuse("ground", Vec3::splat(0.7)), false);
    let o = d.new_named_object("ground");
    add_ground(&mut d, (-8.0, 8.0, -16.0, 3.0), 0.5, ground, o);
    let louvre = d.add_material(Material::diffuse("louvre", Vec3::splat(0.5)), false);
    let o = d.new_named_object("louvre");
    for k in 0..8 {
        // Slats along z, centred from x = −0.4 to 0.02 (the light spans x ∈ [−0.4, 0.4]).
        let x = -0.4 + 0.06 * k as f32;
        add_bar(&mut d, Mat4::from_translation(Vec3::new(x, 2.4, -0.3)), Vec3::new(0.02, 0.005, 0.6), 0.3, louvre, o);
    }
    let wood = d.add_material(Material::diffuse("table", Vec3::new(0.6, 0.45, 0.32)), false);
    let o = d.new_named_object("table");
    let (tx, tz) = (0.15f32, -0.1f32);
    add_box(&mut d, Mat4::from_translation(Vec3::new(tx, 0.73, tz)), Vec3::new(0.5, 0.02, 0.3), wood, o);
    for (sx, sz) in [(-1.0f32, -1.0f32), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
        let leg = Vec3::new(tx + sx * 0.45, 0.355, tz + sz * 0.25);
        add_box(&mut d, Mat4::from_translation(leg), Vec3::new(0.02, 0.355, 0.02), wood, o);
    }
    let grey = d.add_material(Material::diffuse("box", Vec3::new(0.5, 0.55, 0.65)), false);
    let o = d.new_named_object("box");
    let xf = Mat4::from_rotation_translation(Quat::from_rotation_y(0.4), Vec3::new(1.0, 0.175, 0.45));
    add_box(&mut d, xf, Vec3::splat(0.175), grey, o);
    let side = 0.8;
    add_square_light(&mut d, 30.0, Vec3::new(0.0, 2.6, -0.3), side);
    d.camera = Some(pinhole(Vec3::new(0.0, 1.7, 3.0), Vec3::new(0.0, 0.15, 0.0), 45.0));
    d
}
