//! `suite_grate`: fine, regular occluders under a small light — shadows of high spatial frequency.
//!
//! - **Fine grate**: a 1.2 × 1.2 m grid of 1.2 cm bars at a 6 cm pitch, 0.25 m over the ground, on
//!   four legs (x bars below z bars: no coplanar faces). Under the 0.15 m light its penumbrae are
//!   0.15·0.25/2.15 ≈ 1.7 cm, a quarter of the pitch: a sharp, high-frequency grid of shadow whose
//!   occlusion spectrum reaches far beyond what a wide filter may blur (eq. 3.13's `σ s_min` term).
//! - **Coarse grate**: 2 cm bars at a 15 cm pitch, 0.8 m up, turned 30°: penumbrae ≈ 7.5 cm, half its
//!   pitch, overlapping the fine grate's shadow in moiré-like patterns.
//! - **Ground**: plain diffuse 10 × 9 m (albedo 0.65).
//! - **Light**: a small 0.15 × 0.15 m square 2.4 m up, slightly behind the grates; out of view.
//! - **Camera**: at (0, 1.7, 2.4) looking at (0, 0, −0.05), 45° vertical field of view.

use glam::{Mat4, Quat, Vec3};

use super::mesh::{add_bar, add_box, add_ground, add_square_light};
use super::pinhole;
use crate::data::SceneData;
use crate::Material;

/// A square grid of bars of `bar` m side, `count` per direction at `pitch`, centred at `centre` (x bars
/// at the centre's height, z bars one bar higher) and turned by `yaw` radians about y.
struct Grid {
    centre: Vec3,
    yaw: f32,
    count: i32,
    pitch: f32,
    bar: f32,
}

fn add_grid(d: &mut SceneData, g: Grid, material: u32, object: u32) {
    let rot = Quat::from_rotation_y(g.yaw);
    let half_len = 0.5 * g.pitch * (g.count - 1) as f32 + g.bar;
    let bar = g.bar;
    for k in 0..g.count {
        let off = (k as f32 - 0.5 * (g.count - 1) as f32) * g.pitch;
        let xbar = Mat4::from_rotation_translation(rot, g.centre + rot * Vec3::new(0.0, 0.5 * bar, off));
        add_bar(d, xbar, Vec3::new(half_len, 0.5 * bar, 0.5 * bar), 0.15, material, object);
        let zbar = Mat4::from_rotation_translation(rot, g.centre + rot * Vec3::new(off, 1.5 * bar, 0.0));
        add_bar(d, zbar, Vec3::new(0.5 * bar, 0.5 * bar, half_len), 0.15, material, object);
    }
}

pub(crate) fn grate() -> SceneData {
    let mut d = SceneData::default();
    let ground = d.add_material(Material::diffuse("ground", Vec3::splat(0.65)), false);
    let o = d.new_named_object("ground");
    add_ground(&mut d, (-8.0, 8.0, -16.0, 3.0), 0.5, ground, o);
    let metal = d.add_material(Material::diffuse("grate", Vec3::new(0.35, 0.37, 0.4)), false);
    let o = d.new_named_object("fine grate");
    add_grid(
        &mut d,
        Grid { centre: Vec3::new(0.0, 0.25, 0.0), yaw: 0.0, count: 21, pitch: 0.06, bar: 0.012 },
        metal,
        o,
    );
    for (x, z) in [(-0.6f32, -0.6f32), (0.6, -0.6), (0.6, 0.6), (-0.6, 0.6)] {
        add_box(&mut d, Mat4::from_translation(Vec3::new(x, 0.125, z)), Vec3::new(0.01, 0.125, 0.01), metal, o);
    }
    let paint = d.add_material(Material::diffuse("coarse grate", Vec3::new(0.6, 0.5, 0.3)), false);
    let o = d.new_named_object("coarse grate");
    add_grid(
        &mut d,
        Grid { centre: Vec3::new(0.1, 0.8, -0.1), yaw: 30f32.to_radians(), count: 8, pitch: 0.15, bar: 0.02 },
        paint,
        o,
    );
    let side = 0.15;
    add_square_light(&mut d, 640.0, Vec3::new(0.0, 2.4, -0.4), side);
    d.camera = Some(pinhole(Vec3::new(0.0, 1.7, 2.4), Vec3::new(0.0, 0.0, -0.05), 45.0));
    d
}
