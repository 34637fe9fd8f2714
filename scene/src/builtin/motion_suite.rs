//! The motion scene suite (issue 35): eight small scenes, each moving rigidly over the camera's
//! shutter (0, 1), each stressing one part of App. B's analysis, none shaped after the `motion`
//! built-in. `wedge bench --suite` runs a Motion pipeline over them (`NodeKind::bench_suite`).
//!
//! Every scene has one square area light at rest, out of view (lights do not move: emitters are
//! static geometry), and a camera at rest (in-shutter camera motion is not modelled by the scene
//! format yet: a camera path moves between frames only):
//!
//! - `mo_fast_thin`: thin posts (6 cm) sweeping 0.4 m over the shutter across a fine checker floor —
//!   blur many times wider than the mover, the floor seen through it.
//! - `mo_rotating`: a spinning checkered sphere and a spinning box on a plain floor (velocity varies
//!   across the object and flips sign across its axis).
//! - `mo_shadow_caster`: a ball moving over a static fine checker: the shadow moves, the texture does
//!   not (the texture must stay sharp while the irradiance blurs).
//! - `mo_slow`: slow motion — objects moving 1–2 cm over the shutter (blur under two pixels): the
//!   filters must not lose to plain Monte Carlo where there is almost nothing to blur.
//! - `mo_sliding_wall`: a large textured wall sliding 6 cm sideways behind a static fence that shadows it
//!   (the texture moves, the shadow stays).
//! - `mo_approach`: objects moving toward the camera (radial image velocity, growing blur).
//! - `mo_crossing`: small cubes with different speeds and directions crossing one another.
//! - `mo_glossy`: a moving glossy sphere and box on a glossy floor (the glossy indirect component
//!   over the shutter).

use std::f32::consts::PI;

use glam::{Mat4, Quat, Vec3};

use super::mesh::{add_bar, add_box, add_ground, add_panel, add_sphere, add_square_light};
use super::phong;
use crate::data::SceneData;
use crate::motion::RigidMotion;
use crate::{Camera, Material, Texture};

/// A pinhole camera whose shutter is open over (0, 1), the interval the motions are given over.
fn shutter_camera(position: Vec3, look_at: Vec3, vfov_deg: f32) -> Camera {
    Camera { shutter_open: 0.0, shutter_close: 1.0, ..super::pinhole(position, look_at, vfov_deg) }
}

/// A move by `shift` over the shutter, centred on the rest pose (open at −shift/2, close at +shift/2).
fn sweep(shift: Vec3) -> RigidMotion {
    RigidMotion::translation(-0.5 * shift, 0.5 * shift)
}

/// A turn by `angle` radians about the vertical axis through `pivot`, centred on the rest pose.
fn spin(pivot: Vec3, angle: f32) -> RigidMotion {
    RigidMotion::rotation_about(pivot, Vec3::Y, -0.5 * angle, 0.5 * angle)
}

fn checker_material(d: &mut SceneData, name: &str, size: u32, checks: u32, tint: Vec3) -> u32 {
    d.textures.push(Texture::checker(size, checks, 0.15, 0.85));
    let t = d.textures.len() as u32 - 1;
    d.add_material(Material { base_color_texture: Some(t), ..Material::diffuse(name, tint) }, false)
}

pub(crate) fn mo_fast_thin() -> SceneData {
    let mut d = SceneData::default();
    let floor = checker_material(&mut d, "floor", 256, 32, Vec3::ONE);
    let o = d.new_named_object("floor");
    add_ground(&mut d, (-4.0, 4.0, -4.0, 3.0), 0.5, floor, o);
    let bars = d.add_material(Material::diffuse("bars", Vec3::new(0.8, 0.3, 0.2)), false);
    for k in 0..4 {
        let o = d.new_named_object("bar");
        let z = -0.8 + 0.5 * k as f32;
        add_bar(
            &mut d,
            Mat4::from_translation(Vec3::new(-0.3 + 0.2 * k as f32, 0.3 + 0.1 * k as f32, z)),
            Vec3::new(0.03, 0.3, 0.03),
            0.15,
            bars,
            o,
        );
        d.set_motion(o, sweep(Vec3::new(0.4, 0.0, 0.0)));
    }
    add_square_light(&mut d, 35.0, Vec3::new(0.0, 3.0, -0.5), 0.8);
    d.camera = Some(shutter_camera(Vec3::new(0.0, 1.5, 2.8), Vec3::new(0.0, 0.3, -0.4), 45.0));
    d
}

pub(crate) fn mo_rotating() -> SceneData {
    let mut d = SceneData::default();
    let floor = d.add_material(Material::diffuse("floor", Vec3::new(0.7, 0.68, 0.62)), false);
    let o = d.new_named_object("floor");
    add_ground(&mut d, (-4.0, 4.0, -4.0, 3.0), 0.5, floor, o);
    let ball = checker_material(&mut d, "ball", 128, 16, Vec3::new(0.9, 0.8, 0.6));
    let o = d.new_named_object("spinning ball");
    let centre = Vec3::new(-0.45, 0.4, -0.3);
    add_sphere(&mut d, centre, 0.4, 32, 64, ball, o);
    d.set_motion(o, spin(centre, 0.6));
    let boxed = d.add_material(Material::diffuse("box", Vec3::new(0.25, 0.45, 0.75)), false);
    let o = d.new_named_object("spinning box");
    let pivot = Vec3::new(0.6, 0.3, 0.0);
    add_box(&mut d, Mat4::from_translation(pivot), Vec3::new(0.35, 0.3, 0.12), boxed, o);
    d.set_motion(o, spin(pivot, 1.2));
    add_square_light(&mut d, 35.0, Vec3::new(0.3, 3.0, 0.3), 0.8);
    d.camera = Some(shutter_camera(Vec3::new(0.0, 1.4, 2.6), Vec3::new(0.0, 0.35, -0.2), 45.0));
    d
}

pub(crate) fn mo_shadow_caster() -> SceneData {
    let mut d = SceneData::default();
    let floor = checker_material(&mut d, "floor", 256, 64, Vec3::ONE);
    let o = d.new_named_object("floor");
    add_ground(&mut d, (-4.0, 4.0, -4.0, 3.0), 0.5, floor, o);
    let ball = d.add_material(Material::diffuse("ball", Vec3::new(0.7, 0.7, 0.72)), false);
    let o = d.new_named_object("ball");
    add_sphere(&mut d, Vec3::new(0.0, 0.6, -0.2), 0.2, 24, 48, ball, o);
    d.set_motion(o, sweep(Vec3::new(0.6, 0.0, 0.0)));
    add_square_light(&mut d, 40.0, Vec3::new(-0.3, 2.6, -0.2), 0.6);
    d.camera = Some(shutter_camera(Vec3::new(0.0, 1.8, 2.2), Vec3::new(0.0, 0.1, -0.3), 45.0));
    d
}

pub(crate) fn mo_slow() -> SceneData {
    let mut d = SceneData::default();
    let floor = checker_material(&mut d, "floor", 128, 16, Vec3::new(0.9, 0.85, 0.8));
    let o = d.new_named_object("floor");
    add_ground(&mut d, (-4.0, 4.0, -4.0, 3.0), 0.5, floor, o);
    let red = d.add_material(Material::diffuse("box", Vec3::new(0.75, 0.25, 0.2)), false);
    let o = d.new_named_object("box");
    add_box(
        &mut d,
        Mat4::from_rotation_translation(Quat::from_rotation_y(0.5), Vec3::new(-0.5, 0.25, -0.3)),
        Vec3::splat(0.25),
        red,
        o,
    );
    d.set_motion(o, sweep(Vec3::new(0.015, 0.0, 0.0)));
    let blue = d.add_material(Material::diffuse("ball", Vec3::new(0.2, 0.35, 0.7)), false);
    let o = d.new_named_object("ball");
    add_sphere(&mut d, Vec3::new(0.5, 0.3, 0.0), 0.3, 24, 48, blue, o);
    d.set_motion(o, sweep(Vec3::new(0.0, 0.0, 0.02)));
    let bars = d.add_material(Material::diffuse("bars", Vec3::splat(0.5)), false);
    let o = d.new_named_object("bars");
    for k in 0..4 {
        add_bar(
            &mut d,
            Mat4::from_translation(Vec3::new(0.0, 0.8, -0.6 + 0.2 * k as f32)),
            Vec3::new(1.0, 0.012, 0.012),
            0.15,
            bars,
            o,
        );
    }
    d.set_motion(o, sweep(Vec3::new(0.01, 0.0, 0.0)));
    add_square_light(&mut d, 40.0, Vec3::new(0.0, 2.8, -0.3), 0.7);
    d.camera = Some(shutter_camera(Vec3::new(0.0, 1.6, 2.6), Vec3::new(0.0, 0.3, -0.3), 45.0));
    d
}

pub(crate) fn mo_sliding_wall() -> SceneData {
    let mut d = SceneData::default();
    let floor = d.add_material(Material::diffuse("floor", Vec3::splat(0.6)), false);
    let o = d.new_named_object("floor");
    add_ground(&mut d, (-5.0, 5.0, -3.0, 3.0), 0.5, floor, o);
    let wall = checker_material(&mut d, "wall", 256, 32, Vec3::new(0.9, 0.8, 0.7));
    let o = d.new_named_object("sliding wall");
    let v = Vec3::new;
    add_panel(
        &mut d,
        [v(-4.0, 0.0, -1.5), v(4.0, 0.0, -1.5), v(4.0, 2.5, -1.5), v(-4.0, 2.5, -1.5)],
        Vec3::Z,
        0.5,
        wall,
        o,
    );
    d.set_motion(o, sweep(Vec3::new(0.06, 0.0, 0.0)));
    let fence = d.add_material(Material::diffuse("fence", Vec3::new(0.45, 0.35, 0.25)), false);
    let o = d.new_named_object("fence");
    for k in 0..8 {
        add_bar(
            &mut d,
            Mat4::from_translation(v(-1.4 + 0.4 * k as f32, 0.6, -0.6)),
            v(0.025, 0.6, 0.025),
            0.15,
            fence,
            o,
        );
    }
    add_bar(&mut d, Mat4::from_translation(v(0.0, 1.0, -0.6)), v(1.6, 0.025, 0.025), 0.15, fence, o);
    add_square_light(&mut d, 35.0, Vec3::new(0.0, 2.8, 1.2), 0.9);
    d.camera = Some(shutter_camera(Vec3::new(0.0, 1.1, 2.8), Vec3::new(0.0, 0.9, -1.5), 45.0));
    d
}

pub(crate) fn mo_approach() -> SceneData {
    let mut d = SceneData::default();
    let floor = checker_material(&mut d, "floor", 128, 16, Vec3::new(0.85, 0.85, 0.9));
    let o = d.new_named_object("floor");
    add_ground(&mut d, (-4.0, 4.0, -6.0, 3.0), 0.5, floor, o);
    let colours = [Vec3::new(0.8, 0.3, 0.2), Vec3::new(0.3, 0.7, 0.3), Vec3::new(0.25, 0.35, 0.8)];
    for (k, x) in [-0.7f32, 0.0, 0.7].into_iter().enumerate() {
        let m = d.add_material(Material::diffuse("mover", colours[k]), false);
        let o = d.new_named_object("mover");
        let z = -1.5 + 0.6 * k as f32;
        if k == 1 {
            add_sphere(&mut d, Vec3::new(x, 0.25, z), 0.25, 24, 48, m, o);
        } else {
            add_box(&mut d, Mat4::from_translation(Vec3::new(x, 0.25, z)), Vec3::splat(0.25), m, o);
        }
        // Toward the camera (+z), faster for the nearer ones.
        d.set_motion(o, sweep(Vec3::new(0.0, 0.0, 0.3 + 0.2 * k as f32)));
    }
    add_square_light(&mut d, 40.0, Vec3::new(0.0, 3.0, -1.0), 0.9);
    d.camera = Some(shutter_camera(Vec3::new(0.0, 1.0, 2.5), Vec3::new(0.0, 0.3, -1.5), 45.0));
    d
}

pub(crate) fn mo_crossing() -> SceneData {
    let mut d = SceneData::default();
    let floor = checker_material(&mut d, "floor", 128, 16, Vec3::new(0.8, 0.8, 0.75));
    let o = d.new_named_object("floor");
    add_ground(&mut d, (-4.0, 4.0, -4.0, 3.0), 0.5, floor, o);
    let colours =
        [Vec3::new(0.85, 0.3, 0.2), Vec3::new(0.2, 0.6, 0.3), Vec3::new(0.2, 0.3, 0.8), Vec3::new(0.85, 0.75, 0.2)];
    for k in 0..12 {
        let f = k as f32;
        let m = d.add_material(Material::diffuse("cube", colours[k % 4]), false);
        let o = d.new_named_object("cube");
        let p = Vec3::new(-0.9 + 0.16 * f, 0.08 + 0.05 * (f * 1.3).sin().abs(), -0.6 + 0.25 * (f * 2.1).sin());
        add_box(&mut d, Mat4::from_rotation_translation(Quat::from_rotation_y(0.3 * f), p), Vec3::splat(0.08), m, o);
        let angle = f * 2.4;
        let speed = 0.1 + 0.35 * (0.5 + 0.5 * (f * 0.7).cos());
        d.set_motion(o, sweep(Vec3::new(angle.cos(), 0.0, angle.sin()) * speed));
    }
    add_square_light(&mut d, 40.0, Vec3::new(0.0, 2.6, -0.2), 0.7);
    d.camera = Some(shutter_camera(Vec3::new(0.0, 1.7, 1.9), Vec3::new(0.0, 0.1, -0.3), 45.0));
    d
}

pub(crate) fn mo_glossy() -> SceneData {
    let mut d = SceneData::default();
    let floor = d.add_material(phong("floor", Vec3::new(0.3, 0.3, 0.32), 0.4, 40.0), false);
    let o = d.new_named_object("floor");
    add_ground(&mut d, (-4.0, 4.0, -4.0, 3.0), 0.5, floor, o);
    let wall = checker_material(&mut d, "wall", 64, 8, Vec3::new(0.85, 0.8, 0.7));
    let o = d.new_named_object("wall");
    let v = Vec3::new;
    add_panel(
        &mut d,
        [v(-4.0, 0.0, -2.0), v(4.0, 0.0, -2.0), v(4.0, 3.0, -2.0), v(-4.0, 3.0, -2.0)],
        Vec3::Z,
        0.5,
        wall,
        o,
    );
    let ball = d.add_material(phong("ball", Vec3::new(0.6, 0.15, 0.1), 0.5, 60.0), false);
    let o = d.new_named_object("ball");
    add_sphere(&mut d, Vec3::new(-0.4, 0.3, -0.3), 0.3, 24, 48, ball, o);
    d.set_motion(o, sweep(Vec3::new(0.35, 0.0, 0.1)));
    let boxed = d.add_material(phong("box", Vec3::new(0.15, 0.25, 0.5), 0.4, 25.0), false);
    let o = d.new_named_object("box");
    let pivot = Vec3::new(0.6, 0.25, -0.6);
    add_box(&mut d, Mat4::from_translation(pivot), Vec3::new(0.2, 0.25, 0.2), boxed, o);
    d.set_motion(o, spin(pivot, PI / 6.0));
    add_square_light(&mut d, 25.0, Vec3::new(0.0, 2.7, -0.5), 1.0);
    d.camera = Some(shutter_camera(Vec3::new(0.0, 1.0, 2.6), Vec3::new(0.0, 0.3, -0.5), 45.0));
    d
}
