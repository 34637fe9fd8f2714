//! `chess`: a built-in scene in the spirit of the thesis's CHESS (Mehta, Ch. 5, Fig. 5.1), the test
//! scene for defocus blur combined with soft shadows and indirect light.
//!
//! - **Ground**: a checkerboard of [`SQUARE`] = 20 cm squares (dark 0.1, light 0.9, tinted warm) covering
//!   12 × 11 m, seen at a grazing angle (the camera is 0.9 m up, pitched 18° down) so one high-contrast
//!   texture spans every depth from the bottom of the frame (≈ 1.55 m) to the back wall (≈ 10.7 m): in
//!   focus a square is ≈ 16 px wide at 160×120 and shows texture the filters must keep; out of focus it is
//!   the detail defocus must blur away.
//! - **Pieces**: nine turned (lathe) pieces — pawns, rooks, bishops, a queen and kings, 0.28–0.55 m
//!   tall — on square centres at depths along the camera axis of 1.66–1.82 m (in front of focus),
//!   2.57–2.61 m (at focus) and 3.75–5.46 m (beyond). Ivory pieces are diffuse; ebony pieces are glossy (Phong
//!   k_s = 0.45, m = 40) and one lacquered ivory rook is mildly glossy (k_s = 0.3, m = 12), so direct and
//!   indirect glossy terms both appear (thesis eq. 5.20 folds the Phong factor into k). Materials of
//!   pieces are named `piece ...`.
//! - **Light**: one 0.9 × 0.9 m rectangle 1.7 m up, about 2 m left of the focus group at its depth,
//!   facing down and out of view; it lights the faces the camera sees from the side, and the pieces'
//!   soft shadows fall sideways across the board.
//! - **Back wall**: a diffuse grey wall closing the far end, so the top of the frame is lit surface
//!   rather than black, and indirect light has something to bounce from.
//! - **Camera**: [`CAMERA_POSITION`] (0, 0.9, 3.2), looking down the −z axis pitched [`CAMERA_PITCH_DEG`]
//!   = 18° down, vertical fov [`CAMERA_VFOV_DEG`] = 32°, `look_at` on the axis at [`FOCUS_DISTANCE`]. The
//!   scene's camera is a pinhole (`aperture_radius` 0, so pipelines without a Defocus node render it
//!   sharp); its `focus_distance` is [`FOCUS_DISTANCE`].
//!
//! **Recommended lens** for defocus pipelines (`pipelines/defocus*.ron`): `focus_distance` =
//! [`FOCUS_DISTANCE`] = 2.6 m (the focus group: king, queen, rook), `aperture_radius` =
//! [`APERTURE_RADIUS`] = 0.05 m. In a pipeline's camera block:
//! `camera: Some((position: (0.0, 0.9, 3.2), look_at: (0.0, 0.0966, 0.7273), up: (0.0, 1.0, 0.0), vfov_deg:
//! 32.0, aperture_radius: 0.05, focus_distance: Some(2.6)))`. The circle of confusion (thesis eq. 5.2, radius in
//! pixels `r = A·H/(2 f tan(fov/2)) · |f/z − 1|` for aperture radius A, image height H, focus f, axis
//! depth z; 12.7 px · |f/z − 1| at 640×480) is then below 0.25 px on the focus group, 7–9 px on the near
//! pieces, about 5–8.5 px on the far pieces and ≈ 12 px at the back of the board (a quarter of that at
//! 160×120) — `scene/tests/chess.rs` asserts these ranges.
//!
//! 17.4k triangles (the thesis's CHESS has 21k), so it renders in about a second at 320×240.

use glam::{Mat4, Vec2, Vec3};

use super::mesh::{add_box, add_rect_light, lathe, smooth_tri};
use crate::data::SceneData;
use crate::{Camera, Material, Texture};

/// Recommended distance to the focal plane along the view direction (metres): the depth of the focus
/// group (white king, black queen, white rook).
pub const FOCUS_DISTANCE: f32 = 2.6;
/// Recommended thin-lens aperture radius (metres); see the module doc for the circles of confusion.
pub const APERTURE_RADIUS: f32 = 0.05;
/// Side of one checkerboard square (metres).
pub const SQUARE: f32 = 0.2;
/// Texels per checkerboard square in the ground texture (the texture is 16 squares across, so the
/// checker period is twice this); 16 keeps bilinear lookup's one-texel transition sharp.
pub const TEXELS_PER_SQUARE: u32 = 16;
/// Camera position (metres).
pub const CAMERA_POSITION: Vec3 = Vec3::new(0.0, 0.9, 3.2);
/// Camera pitch below the horizon (degrees).
pub const CAMERA_PITCH_DEG: f32 = 18.0;
/// Camera vertical field of view (degrees).
pub const CAMERA_VFOV_DEG: f32 = 32.0;

/// Squares per texture side: the texture repeats every 16 squares, so its edge never shows.
const SQUARES_PER_TEXTURE: u32 = 16;
/// Scale applied to the piece profiles below (written at 1:1 in metres): 1.25 makes the king 0.55 m
/// tall on 0.2 m squares, about a Staunton set's proportions given these slimmer profiles.
const PIECE_SCALE: f32 = 1.25;
/// Points around the axis of each turned piece.
const SLICES: u32 = 48;

#[derive(Clone, Copy)]
enum Piece {
    Pawn,
    Rook,
    Bishop,
    Queen,
    King,
}

/// The base every piece stands on: a disk of radius `r` with a rounded rim, then a waist of radius
/// `waist` at 5 cm. (radius, height) points from the axis outward and up, as [`lathe`] expects.
fn base(r: f32, waist: f32) -> Vec<Vec2> {
    vec![
        Vec2::new(0.0, 0.0),
        Vec2::new(r, 0.0),
        Vec2::new(r, 0.016),
        Vec2::new(r * 0.95, 0.022),
        Vec2::new(r * 0.86, 0.026),
        Vec2::new(r * 0.86, 0.034),
        Vec2::new(r * 0.78, 0.04),
        Vec2::new(waist, 0.05),
    ]
}

/// Points of a circular arc of radius `r` about (0, `cy`) from `from_deg` up to the top of the axis
/// (90°), `steps` segments.
fn cap(cy: f32, r: f32, from_deg: f32, steps: u32) -> impl Iterator<Item = Vec2> {
    (0..=steps).map(move |k| {
        let a = (from_deg + (90.0 - from_deg) * k as f32 / steps as f32).to_radians();
        if k == steps {
            Vec2::new(0.0, cy + r) // exactly on the axis, so the solid closes
        } else {
            Vec2::new(r * a.cos(), cy + r * a.sin())
        }
    })
}

/// The lathe profile of a piece, in metres, from the axis at the bottom to the axis at the top.
fn profile(piece: Piece) -> Vec<Vec2> {
    let p = |r: f32, y: f32| Vec2::new(r, y);
    let mut v;
    match piece {
        Piece::Pawn => {
            v = base(0.058, 0.04);
            v.extend([p(0.032, 0.07), p(0.026, 0.1), p(0.023, 0.125), p(0.04, 0.132), p(0.04, 0.14), p(0.022, 0.146)]);
            v.extend(cap(0.182, 0.04, -64.0, 10));
        }
        Piece::Rook => {
            v = base(0.064, 0.046);
            v.extend([
                p(0.042, 0.09),
                p(0.038, 0.15),
                p(0.037, 0.19),
                p(0.05, 0.205),
                p(0.052, 0.27),
                p(0.036, 0.27),
                p(0.036, 0.248),
                p(0.0, 0.248),
            ]);
        }
        Piece::Bishop => {
            v = base(0.062, 0.042);
            v.extend([p(0.033, 0.09), p(0.026, 0.15), p(0.023, 0.2), p(0.042, 0.21), p(0.042, 0.218), p(0.026, 0.225)]);
            v.extend([p(0.032, 0.236), p(0.038, 0.256), p(0.037, 0.28), p(0.03, 0.3), p(0.018, 0.314), p(0.011, 0.32)]);
            v.extend(cap(0.33, 0.012, -55.0, 6));
        }
        Piece::Queen => {
            v = base(0.068, 0.046);
            v.extend([p(0.036, 0.1), p(0.029, 0.17), p(0.026, 0.25), p(0.046, 0.26), p(0.046, 0.268), p(0.03, 0.276)]);
            v.extend([p(0.034, 0.3), p(0.046, 0.34), p(0.041, 0.348), p(0.02, 0.352)]);
            v.extend(cap(0.372, 0.02, -60.0, 8));
        }
        Piece::King => {
            v = base(0.07, 0.048);
            v.extend([p(0.037, 0.1), p(0.03, 0.18), p(0.027, 0.27), p(0.048, 0.28), p(0.048, 0.288), p(0.031, 0.296)]);
            v.extend([p(0.036, 0.32), p(0.046, 0.36), p(0.04, 0.37), p(0.0, 0.372)]);
        }
    }
    v
}

/// One piece standing on the centre of square (`col`, `row`) (square (i, j) spans x ∈ [i, i+1]·SQUARE,
/// z ∈ [j, j+1]·SQUARE), turned `yaw` radians about its axis (only the king's cross shows it).
fn add_piece(d: &mut SceneData, piece: Piece, col: i32, row: i32, yaw: f32, material: u32) {
    let o = d.new_object();
    let at = Vec3::new((col as f32 + 0.5) * SQUARE, 0.0, (row as f32 + 0.5) * SQUARE);
    let xf = Mat4::from_translation(at) * Mat4::from_rotation_y(yaw) * Mat4::from_scale(Vec3::splat(PIECE_SCALE));
    lathe(d, xf, &profile(piece), SLICES, material, o);
    if let Piece::King = piece {
        // The cross: an upright bar through the top and a crossbar, overlapping the crown slightly.
        add_box(
            d,
            xf * Mat4::from_translation(Vec3::new(0.0, 0.402, 0.0)),
            Vec3::new(0.009, 0.034, 0.009),
            material,
            o,
        );
        add_box(d, xf * Mat4::from_translation(Vec3::new(0.0, 0.41, 0.0)), Vec3::new(0.026, 0.009, 0.009), material, o);
    }
}

/// An axis-aligned rectangle as two smooth triangles with normal `n` and uv = (`uv_x`, `uv_y`) applied
/// to its corners (uv scales set the texture's repetition).
fn add_rect(d: &mut SceneData, p: [Vec3; 4], n: Vec3, uv: [Vec2; 4], material: u32) {
    let o = d.new_object();
    for idx in [[0, 1, 2], [0, 2, 3]] {
        smooth_tri(d, idx.map(|k| p[k]), [n; 3], idx.map(|k| uv[k]), material, o);
    }
}

pub(crate) fn chess() -> SceneData {
    let mut d = SceneData::default();
    // Board texture: 16×16 squares of 16 texels; dark 0.1 and light 0.9 (×tint) — the thesis's point is
    // a high-contrast texture whose detail must survive filtering in focus.
    let side = SQUARES_PER_TEXTURE * TEXELS_PER_SQUARE;
    d.textures.push(Texture::checker(side, SQUARES_PER_TEXTURE, 0.1, 0.9));
    let board = d.add_material(
        Material { base_color_texture: Some(0), ..Material::diffuse("board", Vec3::new(0.95, 0.85, 0.7)) },
        false,
    );
    // Ground: x ∈ [−6, 6] m, z ∈ [−8, 3] m (wide enough to fill the frame at the back wall); uv = position / (16 squares) so texel (0,0)'s square starts at
    // the origin and squares line up with the pieces' grid.
    let (x0, x1, z0, z1) = (-6.0f32, 6.0f32, -8.0f32, 3.0f32);
    let p = [Vec3::new(x0, 0.0, z1), Vec3::new(x1, 0.0, z1), Vec3::new(x1, 0.0, z0), Vec3::new(x0, 0.0, z0)];
    let per_metre = 1.0 / (SQUARES_PER_TEXTURE as f32 * SQUARE);
    add_rect(&mut d, p, Vec3::Y, p.map(|q| Vec2::new(q.x, q.z) * per_metre), board);
    let wall = d.add_material(Material::diffuse("back wall", Vec3::splat(0.5)), false);
    let h = 4.0;
    let p = [Vec3::new(x0, 0.0, z0), Vec3::new(x1, 0.0, z0), Vec3::new(x1, h, z0), Vec3::new(x0, h, z0)];
    add_rect(&mut d, p, Vec3::Z, p.map(|q| Vec2::new(q.x, q.y) / h), wall);

    let ivory = d.add_material(Material::diffuse("piece ivory", Vec3::new(0.78, 0.7, 0.56)), false);
    let lacquer = d.add_material(
        Material {
            specular: Vec3::splat(0.3),
            phong_exponent: 12.0,
            ..Material::diffuse("piece lacquered ivory", Vec3::new(0.62, 0.56, 0.45))
        },
        false,
    );
    let ebony = d.add_material(
        Material {
            specular: Vec3::splat(0.45),
            phong_exponent: 40.0,
            ..Material::diffuse("piece ebony", Vec3::new(0.06, 0.045, 0.04))
        },
        false,
    );
    use Piece::*;
    // (piece, column, row, yaw, material); depths along the camera axis in the module doc.
    let pieces = [
        // In front of focus.
        (Pawn, -2, 8, 0.0, ivory),
        (Bishop, 1, 7, 0.0, ebony),
        // At focus.
        (King, 0, 3, 0.3, ivory),
        (Queen, 2, 3, 0.0, ebony),
        (Rook, -3, 3, 0.0, lacquer),
        // Beyond focus.
        (Rook, 3, -3, 0.0, ebony),
        (Bishop, -4, -6, 0.0, ivory),
        (King, 0, -9, 0.6, ebony),
        (Pawn, 4, -12, 0.0, ivory),
    ];
    for (piece, col, row, yaw, m) in pieces {
        add_piece(&mut d, piece, col, row, yaw, m);
    }
    // 0.9 m square light 1.7 m up, 2 m left of the focus group at about its depth, so the faces the camera
    // sees are lit from the side and shadows fall sideways across the board where the camera sees them
    // (a light behind the pieces hides their shadows behind them); low enough that the pieces' sides
    // get light at a usable angle, above the camera so it stays out of view. eu × ev = −Y: emits downward.
    let side = 0.9;
    add_rect_light(&mut d, "light", Vec3::splat(30.0), Vec3::new(-2.5, 1.7, 0.3), Vec3::X * side, Vec3::Z * side);

    let pitch = CAMERA_PITCH_DEG.to_radians();
    let forward = Vec3::new(0.0, -pitch.sin(), -pitch.cos());
    d.camera = Some(Camera {
        position: CAMERA_POSITION,
        look_at: CAMERA_POSITION + forward * FOCUS_DISTANCE,
        up: Vec3::Y,
        vfov_deg: CAMERA_VFOV_DEG,
        aperture_radius: 0.0,
        focus_distance: FOCUS_DISTANCE,
        shutter_open: 0.0,
        shutter_close: 0.0,
    });
    d
}
