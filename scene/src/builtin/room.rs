//! `suite_room`: a closed room seen from inside — every path stays in the scene.
//!
//! - **Room**: 4 × 2.6 × 3.8 m, six walls facing in (white walls and ceiling, one terracotta wall on
//!   the left, a mildly checkered floor): no ray escapes, so indirect light is a large part of every
//!   pixel (the shadowed floor under the table is lit only by bounces) and it comes from every
//!   direction, including from walls at grazing distance (small `z_min`, wide indirect bandwidth).
//! - **Furniture**: a table (1.2 × 0.7 m top at 0.74 m, four 5 cm legs), a sphere on it, a 1.0 m
//!   cabinet against the back wall and a low bench: contact shadows, thin legs and occluders at
//!   several heights under one small light.
//! - **Light**: a 0.5 × 0.5 m ceiling panel (1 cm below the ceiling) above the table, out of view.
//! - **Camera**: inside, at (0.3, 1.6, 1.6) looking at (−0.2, 0.55, −1), 55° vertical field of view.

use glam::{Mat4, Quat, Vec3};

use super::mesh::{add_box, add_panel, add_sphere, add_square_light};
use super::pinhole;
use crate::data::SceneData;
use crate::{Material, Texture};

pub(crate) fn room() -> SceneData {
    let mut d = SceneData::default();
    d.textures.push(Texture::checker(64, 8, 0.35, 0.5));
    let white = d.add_material(Material::diffuse("walls", Vec3::splat(0.75)), false);
    let terracotta = d.add_material(Material::diffuse("left wall", Vec3::new(0.7, 0.35, 0.22)), false);
    let floor = d.add_material(
        Material { base_color_texture: Some(0), ..Material::diffuse("floor", Vec3::new(1.0, 0.85, 0.7)) },
        false,
    );
    let (x0, x1, y1, z0, z1) = (-2.0f32, 2.0f32, 2.6f32, -2.0f32, 1.8f32);
    let v = Vec3::new;
    // (corners, inward normal, material); uv 0.5 per metre (8 checks per uv unit: 25 cm on the floor).
    let walls = [
        ([v(x0, 0.0, z1), v(x1, 0.0, z1), v(x1, 0.0, z0), v(x0, 0.0, z0)], Vec3::Y, floor, "floor"),
        ([v(x0, y1, z0), v(x1, y1, z0), v(x1, y1, z1), v(x0, y1, z1)], -Vec3::Y, white, "ceiling"),
        ([v(x0, 0.0, z0), v(x1, 0.0, z0), v(x1, y1, z0), v(x0, y1, z0)], Vec3::Z, white, "back wall"),
        ([v(x1, 0.0, z1), v(x0, 0.0, z1), v(x0, y1, z1), v(x1, y1, z1)], -Vec3::Z, white, "front wall"),
        ([v(x0, 0.0, z1), v(x0, 0.0, z0), v(x0, y1, z0), v(x0, y1, z1)], Vec3::X, terracotta, "left wall"),
        ([v(x1, 0.0, z0), v(x1, 0.0, z1), v(x1, y1, z1), v(x1, y1, z0)], -Vec3::X, white, "right wall"),
    ];
    for (p, n, m, name) in walls {
        let o = d.new_named_object(name);
        add_panel(&mut d, p, n, 0.5, m, o);
    }
    let wood = d.add_material(Material::diffuse("wood", Vec3::new(0.55, 0.38, 0.24)), false);
    let o = d.new_named_object("table");
    let (tx, tz) = (-0.2f32, -0.6f32);
    add_box(&mut d, Mat4::from_translation(v(tx, 0.72, tz)), v(0.6, 0.02, 0.35), wood, o);
    for (sx, sz) in [(-1.0f32, -1.0f32), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
        add_box(
            &mut d,
            Mat4::from_translation(v(tx + sx * 0.53, 0.35, tz + sz * 0.29)),
            v(0.025, 0.35, 0.025),
            wood,
            o,
        );
    }
    let blue = d.add_material(Material::diffuse("sphere", Vec3::new(0.25, 0.35, 0.65)), false);
    let o = d.new_named_object("sphere");
    add_sphere(&mut d, v(tx + 0.25, 0.74 + 0.15, tz + 0.05), 0.15, 24, 48, blue, o);
    let cabinet = d.add_material(Material::diffuse("cabinet", Vec3::new(0.8, 0.78, 0.7)), false);
    let o = d.new_named_object("cabinet");
    add_box(&mut d, Mat4::from_translation(v(1.3, 0.5, -1.75)), v(0.45, 0.5, 0.25), cabinet, o);
    let o = d.new_named_object("bench");
    let xf = Mat4::from_rotation_translation(Quat::from_rotation_y(0.15), v(-1.3, 0.22, 0.2));
    add_box(&mut d, xf, v(0.2, 0.22, 0.55), wood, o);
    let side = 0.5;
    add_square_light(&mut d, 40.0, Vec3::new(tx, y1 - 0.01, tz), side);
    d.camera = Some(pinhole(v(0.3, 1.6, 1.6), v(-0.2, 0.55, -1.0), 55.0));
    d
}
