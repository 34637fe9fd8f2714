//! The defocus scene suite (issue 35): nine small scenes, each with its own thin lens in its camera
//! (`aperture_radius`, `focus_distance`), each stressing one part of Ch. 5's analysis, none shaped
//! after `chess`. `wedge bench --suite` runs a Defocus pipeline over them and sets each scene's lens
//! on the pipeline's Defocus node (a pipeline states its lens; the suite's scenes state theirs).
//!
//! Every scene has one square area light out of view (the component nodes' `light: 0`), a textured
//! ground, and geometry at depths on both sides of the focus distance; what differs is where the
//! circle of confusion is large and what it blurs:
//!
//! - `dof_foreground`: posts and a lattice 0.7–1.1 m from the lens, far out of focus, over a sharp
//!   fine-checkered wall and floor 4–5 m away (blur in front of texture: the foreground's wide filter
//!   must not take the wall's texture with it).
//! - `dof_background`: a sharp subject (boxes, a sphere) at 1.6 m in front of a fine checker wall 6 m
//!   away, far out of focus (the subject's edges against a blurred background).
//! - `dof_receding`: a checker floor from under the camera to 20 m seen at a grazing angle, focus at
//!   3 m (the circle of confusion sweeps from huge to zero to large along every column).
//! - `dof_bokeh`: small bright white beads 4–6 m behind a sharp subject, against a dark wall (small
//!   high-contrast features blurred into discs: variance where a few lens samples find them).
//! - `dof_thin`: thin rods tilted in depth, crossing the focal plane, over a textured floor (in-focus
//!   and out-of-focus parts of one thin occluder, and their shadows).
//! - `dof_glossy`: glossy (Phong) floor and spheres at several depths (the glossy indirect component
//!   through the lens).
//! - `dof_wide`: a large aperture (0.15 m) over boxes and spheres from 1.4 to 7 m (circles of
//!   confusion of tens of pixels: the widest filters and the most primary rays).
//! - `dof_tiny`: a tiny aperture (3 mm) — almost a pinhole, circles under a pixel nearly everywhere;
//!   the factored filter must not lose to plain Monte Carlo when there is almost nothing to blur.
//! - `dof_room`: `suite_room` through a lens focused on the table (the thesis's ROOM-like scene,
//!   Ch. 5's 4× claim).

use glam::{Mat4, Quat, Vec3};

use super::mesh::{add_bar, add_box, add_ground, add_panel, add_sphere, add_square_light};
use super::phong;
use crate::data::SceneData;
use crate::{Camera, Material, Texture};

/// A camera with a thin lens: `aperture_radius` and `focus_distance` in metres.
fn lens_camera(position: Vec3, look_at: Vec3, vfov_deg: f32, aperture_radius: f32, focus_distance: f32) -> Camera {
    Camera { aperture_radius, focus_distance, ..super::pinhole(position, look_at, vfov_deg) }
}

/// A textured material from texture `texture` tinted by `tint`.
fn textured(d: &mut SceneData, name: &str, texture: u32, tint: Vec3) -> u32 {
    d.add_material(Material { base_color_texture: Some(texture), ..Material::diffuse(name, tint) }, false)
}

/// A vertical wall facing +z at depth `z`, from x0 to x1 and height 0 to `top`.
fn wall(d: &mut SceneData, (x0, x1, z, top): (f32, f32, f32, f32), uv_per_metre: f32, material: u32, name: &str) {
    let o = d.new_named_object(name);
    let v = Vec3::new;
    add_panel(d, [v(x0, 0.0, z), v(x1, 0.0, z), v(x1, top, z), v(x0, top, z)], Vec3::Z, uv_per_metre, material, o);
}

pub(crate) fn dof_foreground() -> SceneData {
    let mut d = SceneData::default();
    d.textures.push(Texture::checker(256, 32, 0.1, 0.8));
    let fine = textured(&mut d, "checker", 0, Vec3::ONE);
    let o = d.new_named_object("floor");
    add_ground(&mut d, (-6.0, 6.0, -2.0, 4.0), 0.5, fine, o);
    wall(&mut d, (-6.0, 6.0, -2.0, 4.0), 0.5, fine, "wall");
    let wood = d.add_material(Material::diffuse("posts", Vec3::new(0.6, 0.4, 0.25)), false);
    let o = d.new_named_object("posts");
    for k in 0..5 {
        let x = -0.8 + 0.4 * k as f32;
        add_bar(
            &mut d,
            Mat4::from_translation(Vec3::new(x, 0.6, 2.2 - 0.1 * k as f32)),
            Vec3::new(0.03, 0.6, 0.03),
            0.15,
            wood,
            o,
        );
    }
    let lattice = d.add_material(Material::diffuse("lattice", Vec3::splat(0.7)), false);
    let o = d.new_named_object("lattice");
    for k in 0..4 {
        let y = 0.9 + 0.12 * k as f32;
        add_bar(&mut d, Mat4::from_translation(Vec3::new(0.0, y, 2.0)), Vec3::new(0.9, 0.012, 0.012), 0.15, lattice, o);
    }
    let red = d.add_material(Material::diffuse("box", Vec3::new(0.7, 0.2, 0.15)), false);
    let o = d.new_named_object("box");
    add_box(
        &mut d,
        Mat4::from_rotation_translation(Quat::from_rotation_y(0.4), Vec3::new(0.6, 0.3, -1.0)),
        Vec3::new(0.3, 0.3, 0.3),
        red,
        o,
    );
    add_square_light(&mut d, 30.0, Vec3::new(0.0, 3.2, 0.5), 0.8);
    d.camera = Some(lens_camera(Vec3::new(0.0, 1.0, 3.0), Vec3::new(0.0, 0.8, -2.0), 45.0, 0.04, 4.6));
    d
}

pub(crate) fn dof_background() -> SceneData {
    let mut d = SceneData::default();
    d.textures.push(Texture::checker(256, 64, 0.15, 0.85));
    d.textures.push(Texture::checker(64, 8, 0.3, 0.6));
    let fine = textured(&mut d, "wall", 0, Vec3::new(0.9, 0.85, 0.8));
    let floor = textured(&mut d, "floor", 1, Vec3::new(0.8, 0.75, 0.7));
    let o = d.new_named_object("floor");
    add_ground(&mut d, (-8.0, 8.0, -5.0, 3.0), 0.5, floor, o);
    wall(&mut d, (-8.0, 8.0, -5.0, 6.0), 0.5, fine, "wall");
    let blue = d.add_material(Material::diffuse("sphere", Vec3::new(0.2, 0.3, 0.7)), false);
    let o = d.new_named_object("sphere");
    add_sphere(&mut d, Vec3::new(-0.25, 0.25, 0.4), 0.25, 24, 48, blue, o);
    let white = d.add_material(Material::diffuse("boxes", Vec3::splat(0.8)), false);
    let o = d.new_named_object("boxes");
    add_box(
        &mut d,
        Mat4::from_rotation_translation(Quat::from_rotation_y(0.3), Vec3::new(0.35, 0.2, 0.3)),
        Vec3::new(0.2, 0.2, 0.2),
        white,
        o,
    );
    add_box(
        &mut d,
        Mat4::from_rotation_translation(Quat::from_rotation_y(-0.5), Vec3::new(0.3, 0.5, 0.3)),
        Vec3::new(0.1, 0.1, 0.1),
        blue,
        o,
    );
    add_square_light(&mut d, 25.0, Vec3::new(0.5, 3.5, -1.5), 1.5);
    d.camera = Some(lens_camera(Vec3::new(0.0, 0.6, 2.0), Vec3::new(0.0, 0.45, 0.3), 40.0, 0.05, 1.7));
    d
}

pub(crate) fn dof_receding() -> SceneData {
    let mut d = SceneData::default();
    d.textures.push(Texture::checker(256, 32, 0.1, 0.85));
    let fine = textured(&mut d, "floor", 0, Vec3::ONE);
    let o = d.new_named_object("floor");
    add_ground(&mut d, (-4.0, 4.0, -20.0, 3.0), 1.0, fine, o);
    let bars = d.add_material(Material::diffuse("bars", Vec3::splat(0.55)), false);
    let o = d.new_named_object("bars");
    for k in 0..6 {
        let z = 1.2 - 2.2 * k as f32;
        add_bar(&mut d, Mat4::from_translation(Vec3::new(0.6, 0.35, z)), Vec3::new(0.02, 0.35, 0.02), 0.15, bars, o);
        add_bar(
            &mut d,
            Mat4::from_translation(Vec3::new(-0.9, 0.25, z - 1.0)),
            Vec3::new(0.4, 0.02, 0.02),
            0.15,
            bars,
            o,
        );
    }
    add_square_light(&mut d, 60.0, Vec3::new(0.0, 3.5, -3.0), 1.0);
    d.camera = Some(lens_camera(Vec3::new(0.0, 0.8, 3.0), Vec3::new(0.0, 0.2, -3.0), 40.0, 0.04, 3.0));
    d
}

pub(crate) fn dof_bokeh() -> SceneData {
    let mut d = SceneData::default();
    let dark = d.add_material(Material::diffuse("dark", Vec3::splat(0.04)), false);
    let o = d.new_named_object("floor");
    add_ground(&mut d, (-8.0, 8.0, -7.0, 3.0), 0.5, dark, o);
    wall(&mut d, (-8.0, 8.0, -7.0, 5.0), 0.5, dark, "wall");
    let white = d.add_material(Material::diffuse("beads", Vec3::splat(0.95)), false);
    let o = d.new_named_object("beads");
    // A deterministic scatter of 5 cm beads 4-6 m behind the subject, on thin stands.
    for k in 0..24 {
        let f = k as f32;
        let x = -2.4 + 0.2 * f + 0.13 * (f * 2.3).sin();
        let z = -4.0 - 2.0 * (0.5 + 0.5 * (f * 1.7).sin());
        let y = 0.4 + 1.2 * (0.5 + 0.5 * (f * 0.9).cos());
        add_sphere(&mut d, Vec3::new(x, y, z), 0.05, 8, 16, white, o);
    }
    d.textures.push(Texture::checker(64, 8, 0.2, 0.8));
    let subject = textured(&mut d, "subject", 0, Vec3::new(0.8, 0.6, 0.4));
    let o = d.new_named_object("subject");
    add_box(
        &mut d,
        Mat4::from_rotation_translation(Quat::from_rotation_y(0.6), Vec3::new(0.0, 0.3, 0.0)),
        Vec3::new(0.25, 0.3, 0.25),
        subject,
        o,
    );
    add_square_light(&mut d, 60.0, Vec3::new(0.0, 3.5, -2.0), 1.2);
    d.camera = Some(lens_camera(Vec3::new(0.0, 0.9, 1.8), Vec3::new(0.0, 0.5, -2.0), 40.0, 0.05, 1.75));
    d
}

pub(crate) fn dof_thin() -> SceneData {
    let mut d = SceneData::default();
    d.textures.push(Texture::checker(128, 16, 0.2, 0.8));
    let floor = textured(&mut d, "floor", 0, Vec3::new(0.85, 0.8, 0.75));
    let o = d.new_named_object("floor");
    add_ground(&mut d, (-5.0, 5.0, -6.0, 3.0), 0.5, floor, o);
    let rods = d.add_material(Material::diffuse("rods", Vec3::new(0.7, 0.65, 0.6)), false);
    let o = d.new_named_object("rods");
    // Rods 2.4 m long tilted in depth (from ~1 m to ~5 m from the lens) 0.3-1.2 m above the floor.
    for k in 0..7 {
        let x = -0.9 + 0.3 * k as f32;
        let y = 0.3 + 0.15 * k as f32;
        let xf = Mat4::from_rotation_translation(
            Quat::from_rotation_y(0.25 * (k as f32 - 3.0) / 3.0),
            Vec3::new(x, y, -0.5),
        );
        add_bar(&mut d, xf, Vec3::new(0.012, 0.012, 2.0), 0.15, rods, o);
    }
    add_square_light(&mut d, 40.0, Vec3::new(0.0, 3.0, -1.0), 0.8);
    d.camera = Some(lens_camera(Vec3::new(0.0, 1.4, 2.8), Vec3::new(0.0, 0.4, -1.5), 45.0, 0.05, 3.4));
    d
}

pub(crate) fn dof_glossy() -> SceneData {
    let mut d = SceneData::default();
    let floor = d.add_material(phong("floor", Vec3::new(0.3, 0.3, 0.32), 0.4, 50.0), false);
    let o = d.new_named_object("floor");
    add_ground(&mut d, (-5.0, 5.0, -6.0, 3.0), 0.5, floor, o);
    d.textures.push(Texture::checker(64, 8, 0.3, 0.75));
    let back = textured(&mut d, "wall", 0, Vec3::new(0.85, 0.8, 0.7));
    wall(&mut d, (-5.0, 5.0, -6.0, 4.0), 0.5, back, "wall");
    for (k, (x, z, r, m)) in
        [(-0.7f32, 1.0f32, 0.25f32, 30.0f32), (0.2, -0.5, 0.35, 80.0), (0.9, -2.5, 0.4, 15.0), (-1.2, -3.5, 0.5, 60.0)]
            .into_iter()
            .enumerate()
    {
        let kd = [
            Vec3::new(0.6, 0.15, 0.1),
            Vec3::new(0.1, 0.2, 0.5),
            Vec3::new(0.2, 0.45, 0.15),
            Vec3::new(0.5, 0.45, 0.1),
        ][k];
        let mat = d.add_material(phong("sphere", kd, 0.5, m), false);
        let o = d.new_named_object("sphere");
        add_sphere(&mut d, Vec3::new(x, r, z), r, 24, 48, mat, o);
    }
    add_square_light(&mut d, 25.0, Vec3::new(0.0, 2.8, -1.0), 1.0);
    d.camera = Some(lens_camera(Vec3::new(0.0, 0.9, 3.0), Vec3::new(0.0, 0.3, -1.0), 45.0, 0.05, 3.6));
    d
}

pub(crate) fn dof_wide() -> SceneData {
    let mut d = SceneData::default();
    d.textures.push(Texture::checker(128, 16, 0.15, 0.8));
    let floor = textured(&mut d, "floor", 0, Vec3::new(0.9, 0.85, 0.8));
    let o = d.new_named_object("floor");
    add_ground(&mut d, (-6.0, 6.0, -9.0, 3.0), 0.5, floor, o);
    let colours = [Vec3::new(0.7, 0.25, 0.2), Vec3::new(0.25, 0.6, 0.3), Vec3::new(0.25, 0.3, 0.7), Vec3::splat(0.8)];
    for k in 0..6 {
        let z = 1.2 - 1.2 * k as f32;
        let x = if k % 2 == 0 { -0.5 } else { 0.5 };
        let mat = d.add_material(Material::diffuse("object", colours[k % 4]), false);
        let o = d.new_named_object("object");
        if k % 3 == 0 {
            add_sphere(&mut d, Vec3::new(x, 0.3, z), 0.3, 24, 48, mat, o);
        } else {
            add_box(
                &mut d,
                Mat4::from_rotation_translation(Quat::from_rotation_y(0.5 * k as f32), Vec3::new(x, 0.3, z)),
                Vec3::splat(0.3),
                mat,
                o,
            );
        }
    }
    add_square_light(&mut d, 40.0, Vec3::new(0.0, 3.5, -2.0), 1.2);
    d.camera = Some(lens_camera(Vec3::new(0.0, 1.1, 2.6), Vec3::new(0.0, 0.3, -2.0), 45.0, 0.15, 3.6));
    d
}

pub(crate) fn dof_tiny() -> SceneData {
    let mut d = SceneData::default();
    d.textures.push(Texture::checker(128, 32, 0.2, 0.8));
    let top = textured(&mut d, "table", 0, Vec3::new(0.8, 0.7, 0.55));
    let o = d.new_named_object("table");
    add_ground(&mut d, (-3.0, 3.0, -4.0, 2.0), 0.5, top, o);
    let mats = [Vec3::new(0.75, 0.3, 0.2), Vec3::new(0.2, 0.5, 0.7), Vec3::splat(0.85)];
    for (k, p) in
        [Vec3::new(-0.5, 0.15, 0.0), Vec3::new(0.1, 0.2, -0.6), Vec3::new(0.6, 0.1, 0.3)].into_iter().enumerate()
    {
        let mat = d.add_material(Material::diffuse("object", mats[k]), false);
        let o = d.new_named_object("object");
        add_box(
            &mut d,
            Mat4::from_rotation_translation(Quat::from_rotation_y(0.7 * k as f32), p),
            Vec3::splat(p.y),
            mat,
            o,
        );
    }
    let bars = d.add_material(Material::diffuse("bars", Vec3::splat(0.5)), false);
    let o = d.new_named_object("bars");
    for k in 0..5 {
        add_bar(
            &mut d,
            Mat4::from_translation(Vec3::new(0.0, 0.55, -0.8 + 0.25 * k as f32)),
            Vec3::new(1.2, 0.015, 0.015),
            0.15,
            bars,
            o,
        );
    }
    add_square_light(&mut d, 40.0, Vec3::new(0.0, 2.5, -0.3), 0.7);
    d.camera = Some(lens_camera(Vec3::new(0.0, 1.5, 2.2), Vec3::new(0.0, 0.2, -0.4), 45.0, 0.003, 2.9));
    d
}

pub(crate) fn dof_room() -> SceneData {
    let mut d = super::room::room();
    let camera =
        d.camera.take().unwrap_or_else(|| super::pinhole(Vec3::new(0.3, 1.6, 1.6), Vec3::new(-0.2, 0.55, -1.0), 55.0));
    // Focused on the sphere on the table (2.4 m away along the view axis), the bench in front and
    // the cabinet behind out of focus.
    d.camera = Some(Camera { aperture_radius: 0.04, focus_distance: 2.4, ..camera });
    d
}
