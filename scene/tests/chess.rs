//! The built-in `chess` scene (thesis Ch. 5's CHESS in spirit, issue 11 §2): what the defocus
//! pipelines rely on, asserted in numbers — one rectangular light, a high-contrast checker texture seen
//! over a wide range of depths, pieces in front of, at and beyond the recommended focus distance with
//! circles of confusion in the documented ranges, diffuse and glossy materials, a BVH that agrees with
//! brute force, outward-facing piece geometry, and a triangle count within budget.

use std::collections::BTreeMap;

use wedge_scene::builtin::chess::{
    APERTURE_RADIUS, CAMERA_POSITION, CAMERA_VFOV_DEG, FOCUS_DISTANCE, SQUARE, TEXELS_PER_SQUARE,
};
use wedge_scene::bvh::{intersect_triangle, stack_need, STACK_SIZE};
use wedge_scene::*;

fn chess() -> Scene {
    load(&SceneSource::Builtin("chess".into())).expect("built-in chess loads")
}

/// Depth along the camera's view axis (what the thin lens's focus distance measures).
fn depth(s: &Scene, p: Vec3) -> f32 {
    let (_, _, forward) = s.camera.basis();
    (p - s.camera.position).dot(forward)
}

/// Circle-of-confusion radius in pixels for a point at axis depth `z` (thesis eq. 5.2,
/// r = (aW/S)(f/z − 1) with the image measured vertically: S = 2 f tan(fov/2) is the height of the focal
/// plane in view and W = `height` pixels).
fn coc_pixels(z: f32, height: u32) -> f32 {
    let plane_height = 2.0 * FOCUS_DISTANCE * (CAMERA_VFOV_DEG.to_radians() * 0.5).tan();
    APERTURE_RADIUS * height as f32 / plane_height * (FOCUS_DISTANCE / z - 1.0).abs()
}

/// Per piece (object id): the centroid of its vertices and its material, for objects whose material
/// is named `piece ...`.
fn pieces(s: &Scene) -> BTreeMap<u32, (Vec3, u32)> {
    let mut acc: BTreeMap<u32, (Vec3, u32, u32)> = BTreeMap::new();
    for (t, sh) in s.triangles.iter().zip(&s.shading) {
        if !s.materials[sh.material as usize].name.starts_with("piece") {
            continue;
        }
        let v0 = Vec3::from(t.v0);
        let c = (3.0 * v0 + t.e1() + t.e2()) / 3.0;
        let e = acc.entry(sh.object).or_insert((Vec3::ZERO, 0, sh.material));
        e.0 += c;
        e.1 += 1;
        assert_eq!(e.2, sh.material, "one material per piece");
    }
    acc.into_iter().map(|(o, (sum, n, m))| (o, (sum / n as f32, m))).collect()
}

/// First hit of the pinhole ray through the centre of pixel (x, y) of a `w`×`h` image.
fn trace_pixel(s: &Scene, x: u32, y: u32, w: u32, h: u32) -> Option<(Hit, SurfacePoint, Vec3)> {
    let (o, d) = s.camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5, w, h, Vec2::ZERO);
    let hit = s.intersect(o, d, 1e-4, f32::INFINITY)?;
    let sp = s.surface(&hit, o, d);
    Some((hit, sp, d))
}

#[test]
fn loads_with_one_rect_light_out_of_view_and_a_pinhole_camera_focused_at_the_recommended_distance() {
    let s = chess();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!(s.lights.len(), 1);
    let l = &s.lights[0];
    assert!(matches!(l.shape, LightShape::Rect { .. }), "{:?}", l.shape);
    assert!((l.area() - 0.81).abs() < 1e-4, "area {}", l.area());
    assert!(l.normal().abs_diff_eq(-Vec3::Y, 1e-6), "faces down: {}", l.normal());
    assert!(l.radiance.min_element() > 0.0 && !l.two_sided);
    // Out of view: every corner of the light projects above the top of the image.
    let (_, up, forward) = s.camera.basis();
    let tan_half = (s.camera.vfov_deg.to_radians() * 0.5).tan();
    for v in l.vertices() {
        let r = v - s.camera.position;
        assert!(r.dot(up) / r.dot(forward).max(1e-6) > tan_half || r.dot(forward) <= 0.0, "{v}");
    }
    // Pinhole by default (pipelines without a Defocus node render it sharp), focused at the recommendation.
    let c = s.camera;
    assert!(c.validate().is_ok());
    assert_eq!(c.aperture_radius, 0.0);
    assert_eq!(c.position, CAMERA_POSITION);
    assert_eq!(c.vfov_deg, CAMERA_VFOV_DEG);
    assert!((c.effective_focus_distance() - FOCUS_DISTANCE).abs() < 1e-6);
    assert!(((c.look_at - c.position).length() - FOCUS_DISTANCE).abs() < 1e-5);
}

#[test]
fn triangle_count_is_within_budget_and_the_scene_is_deterministic() {
    let (a, b) = (chess(), chess());
    let n = a.triangle_count();
    assert!((10_000..=50_000).contains(&n), "{n} triangles");
    assert_eq!(a.triangles, b.triangles);
    assert_eq!(a.shading, b.shading);
    assert_eq!(a.bvh, b.bvh);
}

#[test]
fn bvh_traversal_matches_brute_force_on_camera_and_shadow_rays() {
    let s = chess();
    assert!(stack_need(&s.bvh.nodes) <= STACK_SIZE);
    let (w, h) = (64u32, 48u32);
    let mut hits = 0;
    let mut checked_shadow = 0;
    for y in 0..h {
        for x in 0..w {
            let (o, d) = s.camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5, w, h, Vec2::ZERO);
            let brute = s
                .triangles
                .iter()
                .enumerate()
                .filter_map(|(i, t)| intersect_triangle(t, o, d, 1e-4, f32::INFINITY).map(|r| (i as u32, r.0)))
                .min_by(|a, b| a.1.total_cmp(&b.1));
            let bvh = s.intersect(o, d, 1e-4, f32::INFINITY);
            match (brute, bvh) {
                (None, None) => {}
                (Some((_, tb)), Some(hit)) => {
                    hits += 1;
                    assert!((tb - hit.t).abs() <= 1e-5 * tb.max(1.0), "pixel ({x},{y}): {tb} vs {}", hit.t);
                    // A shadow ray toward the light's centre: occlusion agrees with brute force.
                    let p = o + d * hit.t;
                    let to = s.lights[0].centre() - p;
                    let (dist, dir) = (to.length(), to.normalize());
                    let start = p + s.surface(&hit, o, d).geometric_normal * 1e-4;
                    let brute_occluded = s.triangles.iter().any(|t| {
                        t.light == NO_LIGHT && intersect_triangle(t, start, dir, 1e-4, dist * 0.999).is_some()
                    });
                    let occluded = s
                        .intersect(start, dir, 1e-4, dist * 0.999)
                        .is_some_and(|h| s.triangles[h.triangle as usize].light == NO_LIGHT);
                    assert_eq!(brute_occluded, occluded, "shadow ray from pixel ({x},{y})");
                    checked_shadow += occluded as u32;
                }
                (a, b) => panic!("pixel ({x},{y}): brute force {a:?}, BVH {b:?}"),
            }
        }
    }
    // The ground and wall fill the frame; some of the board lies in the pieces' shadows.
    assert_eq!(hits, w * h);
    assert!(checked_shadow > 100, "{checked_shadow} shadowed pixels");
}

#[test]
fn ground_texture_is_a_high_contrast_checker_seen_over_a_wide_range_of_depths() {
    let s = chess();
    assert_eq!(s.textures.len(), 1);
    let t = &s.textures[0];
    // Checker period in texels: 2 squares of TEXELS_PER_SQUARE; contrast 0.1 vs 0.9 (9:1).
    assert_eq!(TEXELS_PER_SQUARE, 16);
    let row: Vec<f32> = (0..t.width as usize).map(|x| t.texels[x][0]).collect();
    let period = 2 * TEXELS_PER_SQUARE as usize;
    for (x, v) in row.iter().enumerate() {
        let expect = if (x / TEXELS_PER_SQUARE as usize).is_multiple_of(2) { 0.1 } else { 0.9 };
        assert_eq!(*v, expect, "texel {x}");
        assert_eq!(row[x], row[(x + period) % row.len()]);
    }
    // One square of the texture covers SQUARE metres of ground: sample at square centres.
    let board = s.materials.iter().position(|m| m.name == "board").unwrap() as u32;
    assert_eq!(s.materials[board as usize].base_color_texture, Some(0));

    // Down a column of a 160×120 image: the board is hit over depths from well in front of focus to far
    // beyond it, across many squares, and each hit's albedo is the checker of its square (dark where
    // column + row is even), so the texture's squares line up with the grid the pieces stand on.
    let (w, h) = (160u32, 120u32);
    let mut depths = Vec::new();
    let mut squares = std::collections::BTreeSet::new();
    let mut checked = 0;
    for y in 0..h {
        let Some((_, sp, _)) = trace_pixel(&s, w / 3, y, w, h) else {
            continue;
        };
        if sp.material != board {
            continue;
        }
        depths.push(depth(&s, sp.position));
        let cell = Vec2::new(sp.position.x, sp.position.z) / SQUARE;
        let (i, j) = (cell.x.floor() as i32, cell.y.floor() as i32);
        squares.insert((i, j));
        let inside = cell - cell.floor();
        if inside.min_element() > 0.1 && inside.max_element() < 0.9 {
            let bright = s.albedo(&sp).x > 0.5;
            assert_eq!(bright, (i + j).rem_euclid(2) == 1, "pixel row {y}, square ({i},{j})");
            checked += 1;
        }
    }
    let near = depths.iter().cloned().fold(f32::MAX, f32::min);
    let far = depths.iter().cloned().fold(0.0, f32::max);
    assert!(near < 0.65 * FOCUS_DISTANCE, "nearest board depth {near}");
    assert!(far > 3.0 * FOCUS_DISTANCE, "farthest board depth {far}");
    assert!(squares.len() >= 30, "{} squares down the column", squares.len());
    assert!(checked >= 40, "{checked} rows checked");
    // In focus a square spans several pixels across: detail the filters must keep.
    let px_per_square = SQUARE / (2.0 * FOCUS_DISTANCE * (CAMERA_VFOV_DEG.to_radians() * 0.5).tan() / h as f32);
    assert!((8.0..32.0).contains(&px_per_square), "{px_per_square} px per square at focus");
}

#[test]
fn pieces_stand_in_front_of_at_and_beyond_focus_with_the_documented_circles_of_confusion() {
    let s = chess();
    let p = pieces(&s);
    assert_eq!(p.len(), 9);
    let f = FOCUS_DISTANCE;
    let mut groups = [Vec::new(), Vec::new(), Vec::new()];
    for (centroid, _) in p.values() {
        let z = depth(&s, *centroid);
        let g = if z < 0.75 * f {
            0
        } else if (z / f - 1.0).abs() < 0.08 {
            1
        } else if z > 1.4 * f {
            2
        } else {
            panic!("piece at depth {z} is neither near, at nor beyond focus");
        };
        groups[g].push(z);
        // Every piece stands on the board, inside the 640×480 frame (its centroid projects inside).
        let (right, up, forward) = s.camera.basis();
        let r = *centroid - s.camera.position;
        let tan_half = (s.camera.vfov_deg.to_radians() * 0.5).tan();
        assert!((r.dot(up) / r.dot(forward)).abs() < tan_half, "{centroid}");
        assert!((r.dot(right) / r.dot(forward)).abs() < tan_half * 640.0 / 480.0, "{centroid}");
    }
    let [near, at, beyond] = groups.map(|mut g| {
        g.sort_by(f32::total_cmp);
        g
    });
    assert_eq!((near.len(), at.len(), beyond.len()), (2, 3, 4), "{near:?} {at:?} {beyond:?}");
    // Circles of confusion at 640×480 with the recommended aperture (module doc): sharp in focus,
    // several pixels in front and beyond.
    for z in &at {
        assert!(coc_pixels(*z, 480) < 0.25, "in focus at {z}: {} px", coc_pixels(*z, 480));
    }
    for (z, range) in near.iter().map(|z| (z, 6.5..9.5)).chain(beyond.iter().map(|z| (z, 4.5..9.0))) {
        let r = coc_pixels(*z, 480);
        assert!(range.contains(&r), "depth {z}: {r} px");
    }
    assert!(beyond[beyond.len() - 1] > 2.0 * f, "farthest piece {beyond:?}");
}

#[test]
fn glossy_and_diffuse_pieces_both_present() {
    let s = chess();
    let p = pieces(&s);
    let (mut glossy, mut diffuse) = (0, 0);
    for (_, m) in p.values() {
        let m = &s.materials[*m as usize];
        assert!(m.base_color_texture.is_none() && !m.is_emissive(), "{}", m.name);
        // Energy conserving in every channel (k_d + k_s ≤ 1).
        assert!((m.base_color + m.specular).max_element() <= 1.0, "{}", m.name);
        if m.specular.max_element() > 0.0 {
            assert!(m.phong_exponent >= 10.0, "{}: m = {}", m.name, m.phong_exponent);
            glossy += 1;
        } else {
            diffuse += 1;
        }
    }
    assert!(glossy >= 3 && diffuse >= 3, "{glossy} glossy, {diffuse} diffuse");
}

#[test]
fn camera_rays_hit_the_outside_of_the_pieces() {
    // Lathe winding and normals: wherever a camera ray meets a piece, it meets a front face whose
    // stored (interpolated) normal also faces the camera; a flipped profile would fail here.
    let s = chess();
    let (w, h) = (160u32, 120u32);
    let mut piece_hits = 0;
    for y in 0..h {
        for x in 0..w {
            let Some((hit, sp, d)) = trace_pixel(&s, x, y, w, h) else {
                continue;
            };
            if !s.materials[sp.material as usize].name.starts_with("piece") {
                continue;
            }
            piece_hits += 1;
            let t = &s.triangles[hit.triangle as usize];
            let g = t.e1().cross(t.e2());
            assert!(g.dot(d) < 0.0, "pixel ({x},{y}) hit a back face");
            let sh = &s.shading[hit.triangle as usize];
            let n = (1.0 - hit.b1 - hit.b2) * sh.n[0] + hit.b1 * sh.n[1] + hit.b2 * sh.n[2];
            assert!(n.dot(g) > 0.0, "pixel ({x},{y}): shading normal disagrees with the face");
        }
    }
    assert!(piece_hits > 1500, "{piece_hits} piece pixels at 160x120");
}

#[test]
fn the_light_casts_soft_shadows_of_the_pieces_onto_the_board_in_view() {
    // Fraction of the light visible from each board pixel of an 80×60 image (8×8 stratified points on
    // the light): the pieces' shadows must show as penumbrae (partial visibility), and most of the board
    // is fully lit.
    let s = chess();
    let l = &s.lights[0];
    let (w, h) = (80u32, 60u32);
    let (mut lit, mut penumbra, mut board_pixels) = (0, 0, 0);
    for y in 0..h {
        for x in 0..w {
            let Some((hit, sp, d)) = trace_pixel(&s, x, y, w, h) else {
                continue;
            };
            if s.materials[sp.material as usize].name != "board" {
                continue;
            }
            board_pixels += 1;
            let o = s.camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5, w, h, Vec2::ZERO).0;
            let start = s.surface(&hit, o, d).position + sp.geometric_normal * 1e-4;
            let visible = (0..64)
                .filter(|k| {
                    let u = Vec2::new((k % 8) as f32 + 0.5, (k / 8) as f32 + 0.5) / 8.0;
                    let to = l.sample_point(u) - start;
                    !s.occluded(start, to.normalize(), 1e-4, to.length() * 0.999)
                })
                .count();
            if visible == 64 {
                lit += 1;
            } else if visible > 3 {
                penumbra += 1;
            }
        }
    }
    assert!(lit * 10 > board_pixels * 8, "{lit} of {board_pixels} board pixels fully lit");
    // Soft: penumbrae (4–63 of 64 points visible) outnumber umbrae (at most 3) several times over.
    let umbra = board_pixels - lit - penumbra;
    assert!(penumbra >= 300 && penumbra > 5 * umbra, "{penumbra} penumbra, {umbra} umbra pixels");
}
