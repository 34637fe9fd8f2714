//! `motion`: the motion-blur test scene of issue 13, in the spirit of thesis Fig. B.1 (a moving
//! teapot, its shadow on a moving sphere, a static sphere's shadow on a moving textured plane, App. B).
//! Every element tests one case of the Motion node's analysis (App. B: texture filter (B.1) along the
//! primary hit's velocity, irradiance filter (B.2) along the shadow's):
//!
//! - **`ground`** (at rest): a mildly checkered 8 × 8 m floor. Static surfaces must stay sharp, and its
//!   pixels see static texture under (partly) moving shadows — (B.2) without (B.1).
//! - **`panel`** (translating in its own plane): a 2.4 × 1.5 m plate 2 cm above the floor with a
//!   texture of three frequencies (0.6 m checks, 15 cm checks, 3.75 cm checks ≈ 5 px), moving 0.2 m
//!   along x over the shutter (≈ 25 px): texture blur along one direction, the thesis's "moving
//!   textured plane".
//! - **`ball`** (translating): a 0.22 m sphere 0.33 m above the panel moving 0.25 m along −x and
//!   slightly up (≈ 30 px), casting its shadow on the moving panel: a moving occluder over a moving
//!   receiver (two velocities, the thesis's "shadow of the moving teapot on a moving sphere").
//! - **`bridge`** (at rest): a plank on two legs across the view, 0.45 m over the panel; its shadow falls
//!   across the moving panel: a static occluder's shadow on a moving surface ("shadow of a static
//!   sphere on a moving textured plane") — the shadow stays still while the texture under it moves,
//!   so texture and irradiance need different filters.
//! - **`spinner`** (rotating): a 0.4 m textured cube on the floor right of the panel turning 25° about
//!   its vertical axis (edges move ≈ 10 px): rotation, where velocity varies across one object.
//! - **`light`** (at rest): one 0.8 × 0.8 m rectangular area light 3 m up, facing down, out of view.
//! - **camera**: at (0, 2.2, 4.2) looking at (0, 0.35, 0), 45° vertical field of view; at 640 × 480 a
//!   pixel is ≈ 8 mm at the panel. Shutter (0, 1): the built-in's motions are given over the shutter
//!   directly (`t = −1` … `+1`); the two times only label it.
//!
//! Blur lengths (screen displacement of any vertex from `t = −1` to `+1`, 640 × 480) are 5–40 px for
//! every moving object and 0 for the static ones (`scene/tests/motion.rs`). About 4.2k triangles.

use std::f32::consts::PI;

use glam::{Mat4, Vec2, Vec3};

use super::mesh::{add_box, parametric, smooth_tri, sphere_normal};
use crate::data::SceneData;
use crate::motion::RigidMotion;
use crate::{Camera, Material, Texture};

/// The panel's translation over the shutter (from `−PANEL_SHIFT/2` to `+PANEL_SHIFT/2` along x).
pub const PANEL_SHIFT: Vec3 = Vec3::new(0.2, 0.0, 0.0);
/// The ball's displacement over the shutter.
pub const BALL_SHIFT: Vec3 = Vec3::new(-0.25, 0.04, 0.0);
/// The spinner's rotation over the shutter (radians, about +y through its centre).
pub const SPIN: f32 = 25.0 * PI / 180.0;

/// A `size`² texture of three checker frequencies (4, 16 and 64 checks per side) summed, so a filter
/// along the motion meets coarse and fine detail: values 0.25–0.9, tinted per frequency.
fn multi_frequency_texture(size: u32) -> Texture {
    let check = |x: u32, y: u32, n: u32| (((x * n / size) + (y * n / size)) & 1) as f32;
    let texels = (0..size * size)
        .map(|i| {
            let (x, y) = (i % size, i / size);
            let (a, b, c) = (check(x, y, 4), check(x, y, 16), check(x, y, 64));
            let v = 0.25 + 0.3 * a + 0.2 * b + 0.15 * c;
            [v, 0.9 * v + 0.05 * b, 0.8 * v + 0.1 * c]
        })
        .collect();
    Texture { width: size, height: size, texels }
}

/// An axis-aligned cube of half-size `half` about `centre` whose six faces each carry the whole
/// texture (uv 0..1), outward flat normals.
fn textured_cube(d: &mut SceneData, centre: Vec3, half: f32, material: u32, object: u32) {
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let n = Vec3::AXES[axis] * sign;
            let u = Vec3::AXES[(axis + 1) % 3] * half;
            let v = Vec3::AXES[(axis + 2) % 3] * half;
            let c = centre + n * half;
            let p = [c - u - v, c + u - v, c + u + v, c - u + v];
            let uv = [Vec2::new(0.0, 1.0), Vec2::new(1.0, 1.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 0.0)];
            for idx in [[0, 1, 2], [0, 2, 3]] {
                // `smooth_tri` winds each triangle to face its normal.
                smooth_tri(d, idx.map(|k| p[k]), [n; 3], idx.map(|k| uv[k]), material, object);
            }
        }
    }
}

pub(crate) fn motion() -> SceneData {
    let mut d = SceneData::default();

    // Ground, at rest: 25 cm checks, mild contrast.
    d.textures.push(Texture::checker(64, 8, 0.5, 0.7));
    let ground_mat =
        d.add_material(Material { base_color_texture: Some(0), ..Material::diffuse("ground", Vec3::ONE) }, false);
    let ground = d.new_named_object("ground");
    let g = 4.0f32;
    let corners = [Vec3::new(-g, 0.0, g), Vec3::new(g, 0.0, g), Vec3::new(g, 0.0, -g), Vec3::new(-g, 0.0, -g)];
    let uv = corners.map(|p| Vec2::new(p.x, p.z) * 0.5);
    for idx in [[0, 1, 2], [0, 2, 3]] {
        smooth_tri(&mut d, idx.map(|k| corners[k]), [Vec3::Y; 3], idx.map(|k| uv[k]), ground_mat, ground);
    }

    // Panel, translating along x in its own plane.
    d.textures.push(multi_frequency_texture(256));
    let panel_mat =
        d.add_material(Material { base_color_texture: Some(1), ..Material::diffuse("panel", Vec3::ONE) }, false);
    let panel = d.new_named_object("panel");
    let (x0, x1, z0, z1, y) = (-1.3f32, 1.1f32, -0.6f32, 0.9f32, 0.02f32);
    let p = [Vec3::new(x0, y, z1), Vec3::new(x1, y, z1), Vec3::new(x1, y, z0), Vec3::new(x0, y, z0)];
    // One texture repeat over the panel's width (2.4 m): 0.6 m, 15 cm and 3.75 cm checks.
    let uv = p.map(|q| Vec2::new(q.x - x0, q.z - z0) / (x1 - x0));
    for idx in [[0, 1, 2], [0, 2, 3]] {
        smooth_tri(&mut d, idx.map(|k| p[k]), [Vec3::Y; 3], idx.map(|k| uv[k]), panel_mat, panel);
    }
    d.set_motion(panel, RigidMotion::translation(-0.5 * PANEL_SHIFT, 0.5 * PANEL_SHIFT));

    // Ball, moving over the panel (its shadow falls on the panel).
    let ball_mat = d.add_material(Material::diffuse("ball", Vec3::new(0.75, 0.3, 0.2)), false);
    let ball = d.new_named_object("ball");
    let (centre, r) = (Vec3::new(0.45, 0.55, 0.15), 0.22f32);
    parametric(&mut d, 64, 32, ball_mat, ball, |u, v| {
        // The bottom pole snapped to −y so its triangles have exactly zero area (see `sphere_normal`).
        let n = if v == 1.0 { Vec3::NEG_Y } else { sphere_normal(u, v) };
        (centre + r * n, n)
    });
    d.set_motion(ball, RigidMotion::translation(-0.5 * BALL_SHIFT, 0.5 * BALL_SHIFT));

    // Bridge, at rest: a 30 cm plank across the view 0.45 m over the panel, on legs outside the
    // panel's reach; under the light its shadow has a 12 cm umbra between 17 cm penumbrae.
    let bridge_mat = d.add_material(Material::diffuse("bridge", Vec3::splat(0.55)), false);
    let bridge = d.new_named_object("bridge");
    let (bz, bar_y, t) = (-0.1f32, 0.45f32, 0.04f32);
    let (xa, xb) = (x0 - 0.25, x1 + 0.25);
    add_box(
        &mut d,
        Mat4::from_translation(Vec3::new(0.5 * (xa + xb), bar_y, bz)),
        Vec3::new(0.5 * (xb - xa) + t, 0.02, 0.15),
        bridge_mat,
        bridge,
    );
    for x in [xa, xb] {
        add_box(
            &mut d,
            Mat4::from_translation(Vec3::new(x, 0.5 * (bar_y - t), bz)),
            Vec3::new(t, 0.5 * (bar_y - t), t),
            bridge_mat,
            bridge,
        );
    }

    // Spinner, rotating about its vertical axis on the floor behind the panel.
    d.textures.push(Texture::checker(64, 4, 0.2, 0.85));
    let spinner_mat = d.add_material(
        Material { base_color_texture: Some(2), ..Material::diffuse("spinner", Vec3::new(0.4, 0.55, 0.9)) },
        false,
    );
    let spinner = d.new_named_object("spinner");
    let spin_centre = Vec3::new(1.8, 0.2, -1.0);
    textured_cube(&mut d, spin_centre, 0.2, spinner_mat, spinner);
    d.set_motion(spinner, RigidMotion::rotation_about(spin_centre, Vec3::Y, -0.5 * SPIN, 0.5 * SPIN));

    // Light, at rest: 0.8 m square 3 m up, emitting downward (edge_u × edge_v = −y).
    let light_mat = d.add_material(Material::emitter("light", Vec3::splat(45.0)), false);
    let light = d.new_named_object("light");
    let corner = Vec3::new(-0.6, 3.0, -0.3);
    let (eu, ev) = (Vec3::X * 0.8, Vec3::Z * 0.8);
    d.quad(corner, corner + eu, corner + eu + ev, corner + ev, light_mat, light);

    d.camera = Some(Camera {
        position: Vec3::new(0.0, 2.2, 4.2),
        look_at: Vec3::new(0.0, 0.35, 0.0),
        up: Vec3::Y,
        vfov_deg: 45.0,
        aperture_radius: 0.0,
        focus_distance: 0.0,
        shutter_open: 0.0,
        shutter_close: 1.0,
    });
    d
}
