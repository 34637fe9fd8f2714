//! The environment scene suite (issue 35): eight small scenes lit by an environment map alone (no
//! area light), each stressing one part of Ch. 6's analysis (eq. 6.13: `B_e`, the occluder
//! distance, the curvature κ; eq. 6.17: the BRDF bandwidth `B_ρ`), none shaped after `envmap`.
//! `wedge bench --suite` runs an Environment pipeline over them (`NodeKind::bench_suite`). Each
//! scene names its map ([`map_of`]), attached when the scene is loaded, as `envmap` attaches `sky`:
//!
//! - `env_sun`: a sphere, a box and a post on a plain ground under `builtin:sun` (a 0.5° sun):
//!   high-frequency shadows, `B_e` far above `sky`'s.
//! - `env_overcast`: the same objects under `builtin:overcast`: the smoothest light (wide filters
//!   must win, and contact shadows must stay).
//! - `env_glossy`: glossy receivers — a Phong floor (m = 32) and spheres of exponent 8, 64 and 256
//!   under `builtin:sky` (the `B_ρ` terms; reflections of the sun and windows).
//! - `env_courtyard`: an enclosed courtyard (3 m walls around a 4 × 4 m yard, open to the sky)
//!   under `builtin:sun`, seen from inside: most of the sky occluded, a sunlit wall and floor strip,
//!   the rest lit by the sky through the opening and by bounces.
//! - `env_sunset`: posts on a fine checker under `builtin:sunset` (sun 6° up): long thin shadows
//!   across texture — shadow and texture frequencies meet.
//! - `env_slats`: a pergola of thin slats under `builtin:sun`: stripes of sun and shade (thin
//!   occluders at a distance, the occluder-distance term).
//! - `env_studio`: a product shot — a glossy torus and a sphere on a sweep under `builtin:studio`
//!   (soft boxes: mid-frequency light, glossy highlights).
//! - `env_curved`: small bumps and spheres of high curvature on a plain ground under
//!   `builtin:overcast` (the curvature term κ of eq. 6.20 dominates where occlusion does not).

use glam::{Mat4, Quat, Vec3};

use super::mesh::{add_bar, add_box, add_ground, add_panel, add_sphere, add_torus};
use super::{phong, pinhole};
use crate::data::SceneData;
use crate::{Material, Texture};

/// The map each suite scene is lit by (`builtin:NAME`); `None` for any other name.
pub(crate) fn map_of(name: &str) -> Option<&'static str> {
    Some(match name {
        "env_sun" | "env_courtyard" | "env_slats" => "builtin:sun",
        "env_overcast" | "env_curved" => "builtin:overcast",
        "env_glossy" => "builtin:sky",
        "env_sunset" => "builtin:sunset",
        "env_studio" => "builtin:studio",
        _ => return None,
    })
}

/// A plain ground, 40 m across (its far edge well beyond the view, so the map shows above it).
fn ground(d: &mut SceneData, albedo: Vec3) {
    let m = d.add_material(Material::diffuse("ground", albedo), false);
    let o = d.new_named_object("ground");
    add_ground(d, (-20.0, 20.0, -20.0, 20.0), 0.5, m, o);
}

/// A sphere, a box and a thin post: the objects `env_sun` and `env_overcast` share.
fn objects(d: &mut SceneData) {
    let m = d.add_material(Material::diffuse("sphere", Vec3::new(0.7, 0.6, 0.5)), false);
    let o = d.new_named_object("sphere");
    add_sphere(d, Vec3::new(-0.7, 0.4, 0.0), 0.4, 48, 96, m, o);
    let m = d.add_material(Material::diffuse("box", Vec3::new(0.35, 0.5, 0.7)), false);
    let o = d.new_named_object("box");
    add_box(
        d,
        Mat4::from_rotation_translation(Quat::from_rotation_y(0.5), Vec3::new(0.5, 0.3, -0.3)),
        Vec3::new(0.3, 0.3, 0.3),
        m,
        o,
    );
    let m = d.add_material(Material::diffuse("post", Vec3::new(0.8, 0.8, 0.75)), false);
    let o = d.new_named_object("post");
    add_bar(d, Mat4::from_translation(Vec3::new(0.05, 0.6, 0.5)), Vec3::new(0.03, 0.6, 0.03), 0.2, m, o);
}

pub(crate) fn env_sun() -> SceneData {
    let mut d = SceneData::default();
    ground(&mut d, Vec3::splat(0.6));
    objects(&mut d);
    d.camera = Some(pinhole(Vec3::new(0.0, 1.5, 3.2), Vec3::new(0.0, 0.35, 0.0), 42.0));
    d
}

pub(crate) fn env_overcast() -> SceneData {
    let mut d = env_sun();
    d.camera = Some(pinhole(Vec3::new(0.3, 1.3, 3.0), Vec3::new(0.0, 0.35, 0.0), 42.0));
    d
}

pub(crate) fn env_glossy() -> SceneData {
    let mut d = SceneData::default();
    let floor = d.add_material(phong("floor", Vec3::splat(0.3), 0.4, 32.0), false);
    let o = d.new_named_object("glossy floor");
    add_ground(&mut d, (-20.0, 20.0, -20.0, 20.0), 0.5, floor, o);
    for (k, m) in [8.0f32, 64.0, 256.0].into_iter().enumerate() {
        let mat = d.add_material(phong("sphere", Vec3::new(0.15, 0.2, 0.3), 0.6, m), false);
        let o = d.new_named_object("glossy sphere");
        add_sphere(&mut d, Vec3::new(-0.9 + 0.9 * k as f32, 0.35, -0.2 * k as f32), 0.35, 48, 96, mat, o);
    }
    d.camera = Some(pinhole(Vec3::new(0.0, 1.2, 3.0), Vec3::new(0.0, 0.3, -0.2), 40.0));
    d
}

pub(crate) fn env_courtyard() -> SceneData {
    let mut d = SceneData::default();
    ground(&mut d, Vec3::splat(0.55));
    let wall = d.add_material(Material::diffuse("wall", Vec3::new(0.75, 0.7, 0.62)), false);
    let (h, s) = (3.0f32, 2.0f32);
    let walls = [
        ([Vec3::new(-s, 0.0, -s), Vec3::new(s, 0.0, -s), Vec3::new(s, h, -s), Vec3::new(-s, h, -s)], Vec3::Z),
        ([Vec3::new(-s, 0.0, s), Vec3::new(-s, 0.0, -s), Vec3::new(-s, h, -s), Vec3::new(-s, h, s)], Vec3::X),
        ([Vec3::new(s, 0.0, -s), Vec3::new(s, 0.0, s), Vec3::new(s, h, s), Vec3::new(s, h, -s)], -Vec3::X),
        ([Vec3::new(s, 0.0, s), Vec3::new(-s, 0.0, s), Vec3::new(-s, h, s), Vec3::new(s, h, s)], -Vec3::Z),
    ];
    for (p, n) in walls {
        let o = d.new_named_object("wall");
        add_panel(&mut d, p, n, 0.5, wall, o);
    }
    let m = d.add_material(Material::diffuse("bench", Vec3::new(0.5, 0.35, 0.25)), false);
    let o = d.new_named_object("bench");
    add_box(&mut d, Mat4::from_translation(Vec3::new(0.2, 0.25, -0.8)), Vec3::new(0.7, 0.25, 0.25), m, o);
    // From the shaded side toward the sunlit wall (the sun is behind the camera, over the −z wall).
    d.camera = Some(pinhole(Vec3::new(-1.5, 1.6, -1.6), Vec3::new(0.6, 0.9, 1.2), 60.0));
    d
}

pub(crate) fn env_sunset() -> SceneData {
    let mut d = SceneData::default();
    d.textures.push(Texture::checker(256, 64, 0.2, 0.8));
    let t = d.textures.len() as u32 - 1;
    let floor =
        d.add_material(Material { base_color_texture: Some(t), ..Material::diffuse("floor", Vec3::ONE) }, false);
    let o = d.new_named_object("checker ground");
    add_ground(&mut d, (-20.0, 20.0, -20.0, 20.0), 0.25, floor, o);
    let m = d.add_material(Material::diffuse("post", Vec3::new(0.6, 0.55, 0.5)), false);
    for k in 0..5 {
        let o = d.new_named_object("post");
        let x = -1.0 + 0.5 * k as f32;
        add_bar(
            &mut d,
            Mat4::from_translation(Vec3::new(x, 0.5, -1.0 - 0.3 * k as f32)),
            Vec3::new(0.04, 0.5, 0.04),
            0.2,
            m,
            o,
        );
    }
    d.camera = Some(pinhole(Vec3::new(0.0, 1.4, 3.0), Vec3::new(0.0, 0.2, -0.5), 45.0));
    d
}

pub(crate) fn env_slats() -> SceneData {
    let mut d = SceneData::default();
    ground(&mut d, Vec3::splat(0.65));
    let m = d.add_material(Material::diffuse("slat", Vec3::new(0.55, 0.4, 0.3)), false);
    for k in 0..14 {
        let o = d.new_named_object("slat");
        let z = -1.6 + 0.16 * k as f32;
        add_bar(&mut d, Mat4::from_translation(Vec3::new(0.0, 2.0, z)), Vec3::new(1.4, 0.03, 0.03), 0.2, m, o);
    }
    for (x, z) in [(-1.4, -1.6), (1.4, -1.6), (-1.4, 0.6), (1.4, 0.6)] {
        let o = d.new_named_object("column");
        add_bar(&mut d, Mat4::from_translation(Vec3::new(x, 1.0, z)), Vec3::new(0.05, 1.0, 0.05), 0.2, m, o);
    }
    d.camera = Some(pinhole(Vec3::new(0.0, 1.5, 3.4), Vec3::new(0.0, 0.3, -0.6), 50.0));
    d
}

pub(crate) fn env_studio() -> SceneData {
    let mut d = SceneData::default();
    let sweep = d.add_material(Material::diffuse("sweep", Vec3::splat(0.7)), false);
    let o = d.new_named_object("sweep floor");
    add_ground(&mut d, (-3.0, 3.0, -2.0, 3.0), 0.5, sweep, o);
    let o = d.new_named_object("sweep wall");
    let p =
        [Vec3::new(-3.0, 0.0, -2.0), Vec3::new(3.0, 0.0, -2.0), Vec3::new(3.0, 3.0, -2.0), Vec3::new(-3.0, 3.0, -2.0)];
    add_panel(&mut d, p, Vec3::Z, 0.5, sweep, o);
    let gold = d.add_material(phong("torus", Vec3::new(0.3, 0.22, 0.08), 0.6, 96.0), false);
    let o = d.new_named_object("torus");
    let xf = Mat4::from_rotation_translation(Quat::from_rotation_x(1.2), Vec3::new(0.35, 0.45, -0.4));
    add_torus(&mut d, xf, 0.35, 0.1, gold, o);
    let m = d.add_material(phong("sphere", Vec3::new(0.6, 0.1, 0.1), 0.3, 16.0), false);
    let o = d.new_named_object("sphere");
    add_sphere(&mut d, Vec3::new(-0.5, 0.3, -0.2), 0.3, 48, 96, m, o);
    d.camera = Some(pinhole(Vec3::new(0.0, 1.1, 2.6), Vec3::new(0.0, 0.35, -0.4), 38.0));
    d
}

pub(crate) fn env_curved() -> SceneData {
    let mut d = SceneData::default();
    ground(&mut d, Vec3::splat(0.6));
    let m = d.add_material(Material::diffuse("bumps", Vec3::new(0.75, 0.7, 0.65)), false);
    for i in 0..5 {
        for j in 0..4 {
            let o = d.new_named_object("bump");
            let r = 0.06 + 0.03 * ((i + j) % 3) as f32;
            add_sphere(&mut d, Vec3::new(-0.8 + 0.4 * i as f32, r * 0.6, -0.9 + 0.45 * j as f32), r, 16, 32, m, o);
        }
    }
    d.camera = Some(pinhole(Vec3::new(0.0, 1.2, 1.8), Vec3::new(0.0, 0.0, -0.3), 45.0));
    d
}
