//! `suite_textured`: high-contrast textures under soft shadows — texture must survive the filter.
//!
//! - **Ground**: a black-and-white checker (albedo 0.08 / 0.85) of 6.25 cm squares (≈ 10 px at
//!   640 × 480), 10 × 9 m. SoftShadows and Indirect filter the irradiance and multiply the albedo
//!   after filtering, so the checks must stay as sharp as in the reference even where the filter is
//!   tens of pixels wide; any leak of albedo into the filtered signal shows as blurred check edges.
//! - **Back wall**: a coarser checker (25 cm squares, 0.25 / 0.75), 1.6 m behind the occluders,
//!   receiving the torus's shadow on a vertical surface.
//! - **Occluders**: one grid of 3 cm bars at a 20 cm pitch, 0.6 m up (shadow stripes crossing the
//!   checks at another frequency), a torus standing on the ground, and a textured box (the ground's
//!   checker on its faces).
//! - **Light**: 0.6 × 0.6 m, 2.5 m up, out of view.
//! - **Camera**: at (0, 1.8, 3) looking at (0, 0.35, −0.2), 45° vertical field of view.

use glam::{Mat4, Quat, Vec3};

use super::mesh::{add_bar, add_ground, add_panel, add_square_light, add_torus};
use super::pinhole;
use crate::data::SceneData;
use crate::{Material, Texture};

pub(crate) fn textured() -> SceneData {
    let mut d = SceneData::default();
    // 256 texels, 32 checks per uv unit; uv = 0.5 per metre: 2 m per uv unit → 6.25 cm squares.
    d.textures.push(Texture::checker(256, 32, 0.08, 0.85));
    d.textures.push(Texture::checker(64, 8, 0.25, 0.75));
    let fine =
        d.add_material(Material { base_color_texture: Some(0), ..Material::diffuse("ground", Vec3::ONE) }, false);
    let coarse = d.add_material(
        Material { base_color_texture: Some(1), ..Material::diffuse("wall", Vec3::new(0.9, 0.85, 0.75)) },
        false,
    );
    let o = d.new_named_object("ground");
    add_ground(&mut d, (-5.0, 5.0, -1.8, 3.0), 0.5, fine, o);
    let o = d.new_named_object("wall");
    let (x0, x1, z, top) = (-5.0f32, 5.0f32, -1.8f32, 4.0f32);
    add_panel(
        &mut d,
        [Vec3::new(x0, 0.0, z), Vec3::new(x1, 0.0, z), Vec3::new(x1, top, z), Vec3::new(x0, top, z)],
        Vec3::Z,
        0.5,
        coarse,
        o,
    );
    let bars = d.add_material(Material::diffuse("bars", Vec3::splat(0.5)), false);
    let o = d.new_named_object("bars");
    let rot = Quat::from_rotation_y(20f32.to_radians());
    for k in 0..7 {
        let off = (k as f32 - 3.0) * 0.2;
        let xf = Mat4::from_rotation_translation(rot, Vec3::new(-0.35, 0.6, 0.1) + rot * Vec3::new(0.0, 0.0, off));
        add_bar(&mut d, xf, Vec3::new(0.6, 0.015, 0.015), 0.15, bars, o);
    }
    let torus = d.add_material(Material::diffuse("torus", Vec3::new(0.75, 0.55, 0.3)), false);
    let o = d.new_named_object("torus");
    // Standing on edge (axis along z): its lowest point touches the ground.
    let xf = Mat4::from_rotation_translation(
        Quat::from_rotation_x(std::f32::consts::FRAC_PI_2),
        Vec3::new(0.85, 0.42, -0.4),
    );
    add_torus(&mut d, xf, 0.32, 0.1, torus, o);
    let o = d.new_named_object("box");
    let boxed = Mat4::from_rotation_translation(Quat::from_rotation_y(0.5), Vec3::new(-0.9, 0.2, -0.6));
    let c = |x: f32, y: f32, z: f32| boxed.transform_point3(Vec3::new(x, y, z) * 0.2);
    let n = |v: Vec3| boxed.transform_vector3(v);
    // Five visible faces (the bottom rests on the ground), counter-clockwise seen from outside.
    for (p, normal) in [
        ([c(-1., 1., 1.), c(1., 1., 1.), c(1., 1., -1.), c(-1., 1., -1.)], n(Vec3::Y)),
        ([c(-1., -1., 1.), c(1., -1., 1.), c(1., 1., 1.), c(-1., 1., 1.)], n(Vec3::Z)),
        ([c(1., -1., -1.), c(-1., -1., -1.), c(-1., 1., -1.), c(1., 1., -1.)], n(-Vec3::Z)),
        ([c(1., -1., 1.), c(1., -1., -1.), c(1., 1., -1.), c(1., 1., 1.)], n(Vec3::X)),
        ([c(-1., -1., -1.), c(-1., -1., 1.), c(-1., 1., 1.), c(-1., 1., -1.)], n(-Vec3::X)),
    ] {
        add_panel(&mut d, p, normal, 0.5, fine, o);
    }
    let side = 0.6;
    add_square_light(&mut d, 45.0, Vec3::new(0.0, 2.5, -0.4), side);
    d.camera = Some(pinhole(Vec3::new(0.0, 1.8, 3.0), Vec3::new(0.0, 0.35, -0.2), 45.0));
    d
}
