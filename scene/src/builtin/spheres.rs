//! `spheres`: the ray-tracing benchmark scene of issue 12 — a 20×20 field of UV spheres on a ground
//! plane under one rectangular area light, 409,604 triangles, so traversal speed can be compared with
//! Embree on the scene the issue measured (`cargo bench --bench throughput`).
//!
//! - **Spheres**: [`GRID`]² = 400 UV spheres of radius [`RADIUS`] = 0.4 m resting on the ground, centres
//!   [`SPACING`] = 1 m apart on a square grid centred on the origin (x, z ∈ ±9.5 m). Each has
//!   [`STACKS`] = 17 stacks × [`SLICES`] = 32 slices: 2·32·17 cells' triangles less the 2·32
//!   zero-area ones at the poles (dropped by the mesh generator; the bottom pole is snapped to exactly
//!   −y so they are) = 1,024 triangles, 409,600 in all. Eight diffuse albedos alternate so images show
//!   the field's structure; every sphere is its own object.
//! - **Ground**: a diffuse 40 × 40 m square (two triangles) at y = 0, large enough that the camera sees
//!   ground past the field and then sky.
//! - **Light**: one 3 × 3 m rectangle 13 m above the centre of the field, facing down (two emissive
//!   triangles → one `Rect` light), just out of view.
//! - **Camera**: at (0, 14, 22) looking at (0, 0, −1) with a 50° vertical fov: the whole field at a
//!   moderate angle (≈ 31° down), ground around it and some sky above the far ground edge, so primary
//!   rays hit spheres, ground and nothing.
//!
//! Total: 409,600 + 2 + 2 = 409,604 triangles, as in the issue (asserted by `scene/tests/scene_tests.rs`).

use glam::Vec3;

use super::mesh::add_square_light;
use super::mesh::{parametric, sphere_normal};
use crate::data::SceneData;
use crate::{Camera, Material};

/// Spheres per side of the square field.
pub const GRID: u32 = 20;
/// Sphere radius (metres).
pub const RADIUS: f32 = 0.4;
/// Distance between neighbouring sphere centres (metres).
pub const SPACING: f32 = 1.0;
/// Latitude bands per sphere.
pub const STACKS: u32 = 17;
/// Longitude segments per sphere; with [`STACKS`], 2·SLICES·(STACKS − 1) = 1,024 triangles a sphere.
pub const SLICES: u32 = 32;
/// Half the side of the square ground (metres).
const GROUND_HALF: f32 = 20.0;

pub(crate) fn spheres() -> SceneData {
    let mut d = SceneData::default();
    let ground = d.add_material(Material::diffuse("ground", Vec3::splat(0.6)), false);
    let o = d.new_object();
    let g = GROUND_HALF;
    // Counter-clockwise seen from above, so the flat normal points up.
    d.quad(Vec3::new(-g, 0.0, g), Vec3::new(g, 0.0, g), Vec3::new(g, 0.0, -g), Vec3::new(-g, 0.0, -g), ground, o);
    let materials: Vec<u32> = (0..8)
        .map(|k| {
            let t = k as f32 / 7.0;
            d.add_material(
                Material::diffuse(&format!("sphere{k}"), Vec3::new(0.25 + 0.5 * t, 0.45, 0.75 - 0.5 * t)),
                false,
            )
        })
        .collect();
    let half = (GRID - 1) as f32 * 0.5;
    for j in 0..GRID {
        for i in 0..GRID {
            let centre = Vec3::new((i as f32 - half) * SPACING, RADIUS, (j as f32 - half) * SPACING);
            let m = materials[((i + 3 * j) % 8) as usize];
            let o = d.new_object();
            // `add_sphere` with the bottom pole snapped to exactly −y: its sin π ≠ 0 left 312
            // sliver triangles at the bottom poles (409,916 in all); snapped, both poles' triangles
            // have zero area and are dropped, so every sphere has exactly 1,024 (the count).
            // The other built-ins keep `add_sphere` unchanged so their images do not move.
            parametric(&mut d, SLICES, STACKS, m, o, |u, v| {
                let n = if v == 1.0 { Vec3::NEG_Y } else { sphere_normal(u, v) };
                (centre + RADIUS * n, n)
            });
        }
    }
    // 13 m up keeps it just above the top of the frame (the camera is 14 m up, pitched ≈ 31°);
    // radiance 25 gives ≈ 1.3 irradiance at the field's centre (L·A/h²).
    add_square_light(&mut d, 25.0, Vec3::new(0.0, 13.0, 0.0), 3.0);
    d.camera = Some(Camera {
        position: Vec3::new(0.0, 14.0, 22.0),
        look_at: Vec3::new(0.0, 0.0, -1.0),
        up: Vec3::Y,
        vfov_deg: 50.0,
        aperture_radius: 0.0,
        focus_distance: 0.0,
        shutter_open: 0.0,
        shutter_close: 0.0,
    });
    d
}
