//! `suite_slats`: thin occluders at several heights, open scene (the scene of issue 16's report).
//!
//! - **Slats**: three layers of parallel 5 cm × 2 cm slats along x, at 0.3, 0.65 and 1.1 m, with
//!   pitches of 15, 19 and 24 cm and staggered so their shadows interleave. Under the 0.6 m light
//!   2.2 m up their penumbrae are 0.6·h/(2.2 − h) ≈ 9, 25 and 60 cm wide: the lowest layer's shadows
//!   are crisp stripes, the highest layer's nearly washed out, and most ground pixels see occluders
//!   at two or three depths (the spread `s_max/s_min` of eq. 3.21).
//! - **Sphere**: 0.35 m radius resting on the ground right of the slats: a curved occluder, its
//!   contact shadow and attached shadow.
//! - **Ground**: a plain diffuse 12 × 10 m plane (albedo 0.7), nothing around it: an open scene,
//!   where most indirect paths leave the scene.
//! - **Light**: 0.6 × 0.6 m, 2.2 m up, 0.6 m behind the slats (seen from the camera), so the shadows
//!   fall toward the camera; out of view.
//! - **Camera**: at (0, 2, 3.2) looking at (0, 0.2, 0.3), 45° vertical field of view.

use glam::{Mat4, Vec3};

use super::mesh::{add_bar, add_ground, add_sphere, add_square_light};
use super::pinhole;
use crate::data::SceneData;
use crate::Material;

pub(crate) fn slats() -> SceneData {
    let mut d = SceneData::default();
    let ground = d.add_material(Material::diffuse("ground", Vec3::splat(0.7)), false);
    let o = d.new_named_object("ground");
    add_ground(&mut d, (-9.0, 9.0, -16.0, 4.0), 0.5, ground, o);
    let wood = d.add_material(Material::diffuse("slats", Vec3::new(0.55, 0.45, 0.35)), false);
    // (height, pitch, count, z offset of the layer's centre)
    for (layer, (height, pitch, count, z_off)) in
        [(0.3f32, 0.15f32, 7i32, 0.35f32), (0.65, 0.19, 6, 0.2), (1.1, 0.24, 5, 0.05)].into_iter().enumerate()
    {
        let o = d.new_named_object(format!("slats{layer}"));
        for k in 0..count {
            let z = z_off + (k as f32 - 0.5 * (count - 1) as f32) * pitch;
            let xf = Mat4::from_translation(Vec3::new(-0.35, height, z));
            add_bar(&mut d, xf, Vec3::new(0.8, 0.01, 0.025), 0.4, wood, o);
        }
    }
    let red = d.add_material(Material::diffuse("sphere", Vec3::new(0.7, 0.3, 0.25)), false);
    let o = d.new_named_object("sphere");
    add_sphere(&mut d, Vec3::new(1.05, 0.35, 0.55), 0.35, 24, 48, red, o);
    let side = 0.6;
    add_square_light(&mut d, 35.0, Vec3::new(-0.3, 2.2, -0.6), side);
    d.camera = Some(pinhole(Vec3::new(0.0, 2.0, 3.2), Vec3::new(0.0, 0.2, 0.3), 45.0));
    d
}
