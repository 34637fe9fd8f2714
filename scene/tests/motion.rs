//! Scene motion (issue 13): rigid motion over the shutter, its velocity and swept bounds, moving
//! instances traced against brute force over their triangles moved to world space, static scenes
//! unchanged at every time, `set_motion`, moving lights, the `motion` built-in's blur lengths, and
//! glTF animations and RON motion blocks sampled at a shutter.

use std::path::{Path, PathBuf};

use wedge_scene::bvh::{closer, intersect_triangle, TriangleRecord};
use wedge_scene::*;

struct Rng(u64);
impl Rng {
    fn f(&mut self) -> f32 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
    /// Uniform in [lo, hi).
    fn r(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f()
    }
    fn v(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.r(lo, hi), self.r(lo, hi), self.r(lo, hi))
    }
    fn unit(&mut self) -> Vec3 {
        loop {
            let v = self.v(-1.0, 1.0);
            if v.length_squared() > 0.01 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }
    /// A motion with a rotation of up to `max_deg` over the shutter and translations within ±1.
    fn motion(&mut self, max_deg: f32) -> RigidMotion {
        let axis = self.unit();
        let a0 = self.r(-3.0, 3.0);
        let a1 = a0 + self.r(-max_deg, max_deg).to_radians();
        RigidMotion {
            pivot: self.v(-2.0, 2.0),
            translation: [self.v(-1.0, 1.0), self.v(-1.0, 1.0)],
            rotation: [Quat::from_axis_angle(axis, a0), Quat::from_axis_angle(axis, a1)],
        }
    }
}

#[test]
fn slerp_ends_are_exact_and_zero_motion_is_the_identity() {
    let mut rng = Rng(1);
    for _ in 0..200 {
        let m = rng.motion(179.0);
        let p = m.prepare();
        let (open, close) = (m.at(-1.0), m.at(1.0));
        assert_eq!(open.translation, m.translation[0]);
        assert_eq!(close.translation, m.translation[1]);
        assert_eq!(open.rotation, m.rotation[0], "unit to f32 precision: kept as given");
        // The short arc may store −q, the same rotation.
        assert!(close.rotation == m.rotation[1] || close.rotation == -m.rotation[1]);
        assert!(p.q[0].dot(p.q[1]) >= 0.0);
        // A point at the ends is where the end rotation puts it (to f32 rounding of the matrix).
        let x = rng.v(-3.0, 3.0);
        let want = m.pivot + m.translation[1] + m.rotation[1] * (x - m.pivot);
        assert!((close.point(x) - want).length() < 1e-5, "{} vs {want}", close.point(x));
        // Rest → world → rest round trip.
        let t = rng.r(-1.0, 1.0);
        let xf = m.at(t);
        assert!((xf.inverse_point(xf.point(x)) - x).length() < 1e-5);
    }
    // Zero motion: the identity bit for bit at every time; also for a pure translation's rotation.
    for t in [-1.0, -0.37, 0.0, 0.5, 1.0] {
        let x = Vec3::new(1.25, -7.5, 0.1);
        assert_eq!(RigidMotion::IDENTITY.at(t).point(x), x);
        assert_eq!(RigidMotion::IDENTITY.velocity(t, x), Vec3::ZERO);
        let slide = RigidMotion::translation(Vec3::ZERO, Vec3::X);
        assert_eq!(slide.at(t).vector(x), x);
        assert_eq!(slide.at(t).point(x), x + Vec3::X * ((t + 1.0) * 0.5));
    }
    assert!(RigidMotion::IDENTITY.is_static());
    assert!(!RigidMotion::translation(Vec3::ZERO, Vec3::X).is_static());
    assert!(RigidMotion::translation(Vec3::X, Vec3::X).is_still());
}

#[test]
fn slerp_turns_at_a_constant_rate_about_one_axis() {
    // 90° about z over the shutter: at t = 0 the point (1, 0, 0) about the origin is at 45°.
    let m = RigidMotion::rotation_about(Vec3::ZERO, Vec3::Z, 0.0, std::f32::consts::FRAC_PI_2);
    let h = std::f32::consts::FRAC_1_SQRT_2;
    for (t, want) in
        [(-1.0, Vec3::X), (-0.5, Vec3::new(0.9238795, 0.38268343, 0.0)), (0.0, Vec3::new(h, h, 0.0)), (1.0, Vec3::Y)]
    {
        let got = m.at(t).point(Vec3::X);
        assert!((got - want).length() < 2e-7, "t = {t}: {got} vs {want}");
    }
    // ω = axis · (quarter turn)/2 per unit t.
    let p = m.prepare();
    assert!((p.omega - Vec3::Z * std::f32::consts::FRAC_PI_4).length() < 1e-7);
}

/// Velocity against a central difference of positions, in f64 over f32 positions: h = 1e-3 gives a
/// truncation error of h²/6·|x'''| (≤ 1e-6 here) and a rounding error of ~|x|·6e-8/h ≤ 4e-4.
#[test]
fn velocity_is_the_time_derivative_of_position() {
    let mut rng = Rng(2);
    let h = 1e-3f32;
    for case in 0..500 {
        let m = rng.motion(if case % 5 == 0 { 0.001 } else { 170.0 });
        let t = rng.r(-0.99, 0.99);
        let x_rest = rng.v(-3.0, 3.0);
        let at = |t: f32| m.at(t).point(x_rest).as_dvec3();
        let fd = (at(t + h) - at(t - h)) / (2.0 * h as f64);
        let v = m.velocity(t, m.at(t).point(x_rest)).as_dvec3();
        let err = (fd - v).length();
        assert!(
            err < 1e-3 + 1e-3 * v.length(),
            "case {case}: t = {t}, velocity {v} vs finite difference {fd} (error {err})"
        );
    }
}

#[test]
fn swept_bounds_contain_every_transformed_point() {
    let mut rng = Rng(3);
    for case in 0..200 {
        let m = rng.motion(if case % 3 == 0 { 180.0 } else { 60.0 });
        let points: Vec<Vec3> = (0..20).map(|_| rng.v(-1.5, 1.5)).collect();
        let swept = m.swept_bounds(&points);
        for _ in 0..500 {
            let t = rng.r(-1.0, 1.0);
            let xf = m.at(t);
            for &x in &points {
                let w = xf.point(x);
                assert!(swept.contains(w), "case {case}: {w} at t = {t} outside {:?}", swept);
            }
        }
        // And the box of the rest points at the ends (the cheap necessary condition).
        for t in [-1.0, 1.0] {
            let xf = m.at(t);
            assert!(points.iter().all(|&x| swept.contains(xf.point(x))));
        }
    }
    // A pure translation's swept box is the two end boxes' union, padded by 1e-5 of the magnitude.
    let m = RigidMotion::translation(Vec3::ZERO, Vec3::new(1.0, 0.0, 0.0));
    let b = m.swept_box(&Aabb { min: Vec3::ZERO, max: Vec3::ONE });
    assert!((b.min - Vec3::ZERO).abs().max_element() < 1e-4, "{b:?}");
    assert!((b.max - Vec3::new(2.0, 1.0, 1.0)).abs().max_element() < 1e-4, "{b:?}");
}

fn shading(object: u32) -> TriangleShading {
    TriangleShading { n: [Vec3::Y; 3], uv: [Vec2::ZERO; 3], material: 0, object }
}

/// A soup: a static ground (object 0) plus `movers` clusters of small random triangles, each its own
/// object with a random motion (object k + 1).
fn soup(rng: &mut Rng, movers: usize, per: usize) -> Scene {
    let mut tris = Vec::new();
    let g = 6.0;
    for (a, b, c) in [
        (Vec3::new(-g, 0.0, g), Vec3::new(g, 0.0, g), Vec3::new(g, 0.0, -g)),
        (Vec3::new(-g, 0.0, g), Vec3::new(g, 0.0, -g), Vec3::new(-g, 0.0, -g)),
    ] {
        tris.push((a, b, c, shading(0)));
    }
    let mut objects = vec![SceneObject::named("ground")];
    for k in 0..movers {
        // Above the ground even after moving (translations within ±1, clusters within ±0.9).
        let centre = Vec3::new(rng.r(-2.0, 2.0), rng.r(2.2, 4.0), rng.r(-2.0, 2.0));
        for _ in 0..per {
            let a = centre + rng.v(-0.6, 0.6);
            tris.push((a, a + rng.v(-0.3, 0.3), a + rng.v(-0.3, 0.3), shading(k as u32 + 1)));
        }
        let mut m = rng.motion(120.0);
        m.pivot = centre;
        objects.push(SceneObject { motion: Some(m), ..SceneObject::named(format!("mover{k}")) });
    }
    Scene::from_objects(
        "soup",
        tris,
        vec![Material::diffuse("grey", Vec3::splat(0.5))],
        vec![],
        Camera::default(),
        objects,
    )
    .expect("soup scene")
}

/// Every triangle of `scene` where it is at `t`, in world space (static ones as stored).
fn world_triangles(scene: &Scene, t: f32) -> Vec<TriangleRecord> {
    scene
        .triangles
        .iter()
        .zip(&scene.shading)
        .map(|(r, s)| match scene.instance_of(s.object) {
            None => *r,
            Some(inst) => {
                let xf = inst.prepared.at(t);
                let v = r.vertices().map(|p| xf.point(p));
                TriangleRecord::new(v[0], v[1], v[2], r.material, r.source)
            }
        })
        .collect()
}

/// Closest hit over `tris` by brute force: (triangle, t, smallest barycentric weight).
fn brute(tris: &[TriangleRecord], o: Vec3, d: Vec3, tmax: f32) -> Option<(u32, f32, f32)> {
    let mut best: Option<(u32, f32, f32)> = None;
    for (i, tri) in tris.iter().enumerate() {
        if let Some((t, b1, b2)) = intersect_triangle(tri, o, d, 0.0, tmax) {
            let (tb, ib) = best.map_or((tmax, 0), |b| (b.1, b.0));
            if closer(t, i as u32, tb, ib) {
                best = Some((i as u32, t, b1.min(b2).min(1.0 - b1 - b2)));
            }
        }
    }
    best
}

/// Moving instances at random times: the traced hit is brute force's over the triangles moved to world
/// space at that time. The two compute the triangle test in different frames (rest space with a moved
/// ray vs world space with moved vertices), so they agree to rounding, not bit for bit: the same
/// triangle with `t` within 2e-5 relative plus 1e-5 absolute (moving a ray's origin rounds it by a
/// few ulps of the coordinates, ~1e-6 m here, which dominates for hits close to the origin), except
/// at near-ties (two triangles within 1e-4 in `t`) and grazing edges (a barycentric weight below
/// 1e-4), at most 0.2% of rays.
#[test]
fn moving_instances_trace_like_brute_force_over_moved_triangles() {
    let mut rng = Rng(4);
    let scene = soup(&mut rng, 6, 150);
    assert!(scene.has_motion());
    assert_eq!(scene.instances.len(), 6);
    let (mut rays, mut hits, mut disagree) = (0usize, 0usize, 0usize);
    for _ in 0..40 {
        let t = rng.r(-1.0, 1.0);
        let at = scene.at(t);
        let world = world_triangles(&scene, t);
        for _ in 0..100 {
            let o = rng.v(-4.0, 4.0) + Vec3::new(0.0, 6.0, 0.0);
            let target = rng.v(-3.0, 3.0) + Vec3::Y * 1.5;
            let d = (target - o).normalize();
            rays += 1;
            let got = at.intersect(o, d, 0.0, f32::INFINITY);
            let want = brute(&world, o, d, f32::INFINITY);
            assert_eq!(at.occluded(o, d, 0.0, f32::INFINITY), got.is_some());
            match (got, want) {
                (Some(g), Some((i, tw, _))) if g.triangle == i => {
                    hits += 1;
                    assert!((g.t - tw).abs() <= 2e-5 * tw + 1e-5, "t {} vs {tw}", g.t);
                }
                (None, None) => {}
                (g, w) => {
                    disagree += 1;
                    let tg = g.map_or(f32::INFINITY, |h| h.t);
                    let tw = w.map_or(f32::INFINITY, |h| h.1);
                    let near_tie = (tg - tw).abs() <= 1e-4 * tg.min(tw) + 1e-5;
                    let edge_g = g.is_some_and(|h| h.b1.min(h.b2).min(1.0 - h.b1 - h.b2) < 1e-4);
                    let edge_w = w.is_some_and(|h| h.2 < 1e-4);
                    assert!(near_tie || edge_g || edge_w, "{g:?} vs {w:?}");
                }
            }
        }
    }
    println!("{rays} rays: {hits} hits on the same triangle, {disagree} near-ties or grazing edges");
    assert!(hits > rays / 4, "too few hits to test anything: {hits} of {rays}");
    assert!(disagree * 500 <= rays, "{disagree} of {rays} rays disagree");
}

/// Many instances: the top-level tree over their swept boxes names every instance once, inside its
/// boxes, and tracing through it gives bit for bit what testing every instance's swept box in turn
/// gives (the linear loop it replaced: `traverse_from` over all of them after the static tree).
#[test]
fn the_top_level_tree_finds_what_a_loop_over_all_instances_finds() {
    use wedge_scene::bvh::{self, child_ref, Child};
    let mut rng = Rng(14);
    let scene = soup(&mut rng, 300, 6);
    assert_eq!(scene.instances.len(), 300);
    let mut seen = vec![0; scene.instances.len()];
    let mut todo = vec![(scene.instance_root, None::<Aabb>)];
    while let Some((node, parent)) = todo.pop() {
        let n = &scene.bvh.nodes[node as usize];
        for slot in (0..bvh::WIDTH).filter(|&s| n.used(s)) {
            let b = Aabb {
                min: Vec3::new(n.bounds[0][slot], n.bounds[2][slot], n.bounds[4][slot]),
                max: Vec3::new(n.bounds[1][slot], n.bounds[3][slot], n.bounds[5][slot]),
            };
            if let Some(p) = parent {
                assert!(p.contains(b.min) && p.contains(b.max));
            }
            match child_ref(n.child[slot]) {
                Child::Node(j) => todo.push((j, Some(b))),
                Child::Leaf { first, count } => {
                    assert_eq!(count, 1);
                    let inst = &scene.instances[first as usize];
                    assert_eq!((inst.swept_bounds.min, inst.swept_bounds.max), (b.min, b.max));
                    seen[first as usize] += 1;
                }
            }
        }
    }
    assert!(seen.iter().all(|&c| c == 1), "every instance in one leaf");
    let (mut rays, mut hits) = (0, 0);
    for _ in 0..20 {
        let t = rng.r(-1.0, 1.0);
        let at = scene.at(t);
        for _ in 0..200 {
            let o = rng.v(-4.0, 4.0) + Vec3::new(0.0, 6.0, 0.0);
            let d = (rng.v(-3.0, 3.0) + Vec3::Y * 2.5 - o).normalize();
            let tmax = if rays % 3 == 0 { rng.r(2.0, 8.0) } else { f32::INFINITY };
            let mut want = bvh::traverse(&scene.bvh, o, d, 0.0, tmax, false);
            let mut occluded = want.is_some();
            for inst in &scene.instances {
                let xf = inst.prepared.at(t);
                let (ro, rd) = (xf.inverse_point(o), xf.inverse_vector(d));
                let root = inst.root;
                if let Some(h) = bvh::traverse_from(&scene.bvh, root, ro, rd, 0.0, tmax, false, want.as_ref()) {
                    want = Some(h);
                }
                occluded |= bvh::traverse_from(&scene.bvh, root, ro, rd, 0.0, tmax, true, None).is_some();
            }
            let got = at.intersect(o, d, 0.0, tmax);
            assert_eq!(
                got.map(|h| (h.triangle, h.t.to_bits(), h.b1.to_bits(), h.b2.to_bits())),
                want.map(|h| (h.triangle, h.t.to_bits(), h.b1.to_bits(), h.b2.to_bits())),
                "ray {rays} at t = {t}"
            );
            assert_eq!(at.occluded(o, d, 0.0, tmax), occluded, "ray {rays}: any-hit");
            rays += 1;
            hits +=
                got.is_some_and(|h| scene.instance_of(scene.shading[h.triangle as usize].object).is_some()) as usize;
        }
    }
    println!("{rays} rays, {hits} hit a moving instance");
    assert!(hits > rays / 4, "{hits} of {rays} rays hit an instance");
}

#[test]
fn instances_swept_boxes_hold_their_triangles_at_every_time() {
    let mut rng = Rng(5);
    let scene = soup(&mut rng, 4, 50);
    let motion = load(&SceneSource::Builtin("motion".into())).unwrap();
    for scene in [&scene, &motion] {
        for inst in &scene.instances {
            let tris = &scene.triangles[inst.first as usize..(inst.first + inst.count) as usize];
            for _ in 0..200 {
                let xf = inst.prepared.at(rng.r(-1.0, 1.0));
                for r in tris {
                    for p in r.vertices() {
                        assert!(inst.rest_bounds.contains(p));
                        assert!(inst.swept_bounds.contains(xf.point(p)));
                    }
                }
            }
        }
    }
}

/// Rays through every 7th pixel of the scene's camera plus bounce-like rays from the hits.
fn probe_rays(scene: &Scene) -> Vec<(Vec3, Vec3)> {
    let mut rays = Vec::new();
    let (w, h) = (160, 120);
    for y in (0..h).step_by(7) {
        for x in (0..w).step_by(7) {
            let (o, d) = scene.camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5, w, h, Vec2::ZERO);
            rays.push((o, d));
            if let Some(hit) = scene.intersect(o, d, 0.0, f32::INFINITY) {
                let sp = scene.surface(&hit, o, d);
                let p = sp.position + sp.shading_normal * 1e-3;
                rays.push((p, (sp.shading_normal + Vec3::new(0.3, 0.2, -0.1)).normalize()));
            }
        }
    }
    rays
}

#[test]
fn static_scenes_trace_the_same_at_every_time() {
    for name in ["grids", "cornell", "chess"] {
        let scene = load(&SceneSource::Builtin(name.into())).unwrap();
        assert!(!scene.has_motion(), "{name}");
        assert!(scene.instances.is_empty());
        let rays = probe_rays(&scene);
        for t in [-1.0, -0.5, 0.25, 1.0] {
            let at = scene.at(t);
            assert_eq!(at.time(), t);
            for &(o, d) in &rays {
                let a = scene.intersect(o, d, 0.0, f32::INFINITY);
                let b = at.intersect(o, d, 0.0, f32::INFINITY);
                let bits = |h: Option<Hit>| h.map(|h| (h.triangle, h.t.to_bits(), h.b1.to_bits(), h.b2.to_bits()));
                assert_eq!(bits(a), bits(b), "{name} t = {t}");
                assert_eq!(scene.occluded(o, d, 0.0, 5.0), at.occluded(o, d, 0.0, 5.0));
                if let Some(hit) = a {
                    let (s0, s1) = (scene.surface(&hit, o, d), at.surface(&hit, o, d));
                    assert_eq!(s0, s1);
                    assert_eq!(at.velocity(&s1), Vec3::ZERO);
                }
            }
            for i in 0..scene.lights.len() {
                assert_eq!(at.light(i), scene.lights[i]);
            }
        }
    }
}

#[test]
fn surfaces_of_moving_triangles_are_where_the_motion_puts_them() {
    let mut rng = Rng(6);
    let scene = soup(&mut rng, 3, 40);
    for _ in 0..30 {
        let t = rng.r(-1.0, 1.0);
        let at = scene.at(t);
        let world = world_triangles(&scene, t);
        for inst in &scene.instances {
            let k = inst.first as usize + (rng.f() * inst.count as f32) as usize % inst.count as usize;
            let w = world[k].vertices();
            let target = (w[0] + w[1] + w[2]) / 3.0;
            let o = target + Vec3::new(0.1, 3.0, 0.2);
            let d = (target - o).normalize();
            let Some(hit) = at.intersect(o, d, 0.0, f32::INFINITY) else {
                panic!("the ray aimed at a moving triangle's centroid misses");
            };
            let sp = at.surface(&hit, o, d);
            let on_ray = o + d * hit.t;
            assert!((sp.position - on_ray).length() < 1e-4, "{} vs {on_ray}", sp.position);
            assert!(sp.geometric_normal.dot(d) <= 1e-6);
            let n = world[hit.triangle as usize].vertices();
            let flat = (n[1] - n[0]).cross(n[2] - n[0]).normalize();
            assert!(sp.geometric_normal.dot(flat).abs() > 0.9999);
            let v = at.velocity(&sp);
            let obj = scene.shading[hit.triangle as usize].object;
            let m = scene.objects[obj as usize].motion.expect("a moving triangle is hit");
            assert_eq!(v, m.prepare().velocity(t, sp.position));
        }
    }
}

#[test]
fn set_motion_moves_objects_by_name_and_back() {
    let mut rng = Rng(7);
    let mut scene = soup(&mut rng, 0, 0);
    let before = scene.clone();
    // Add a named box-like cluster by rebuilding from triangles with names.
    let mut tris: Vec<_> = Vec::new();
    for (i, r) in before.triangles.iter().enumerate() {
        let v = r.vertices();
        tris.push((v[0], v[1], v[2], before.shading[i]));
    }
    for _ in 0..30 {
        let a = Vec3::new(0.0, 1.0, 0.0) + rng.v(-0.3, 0.3);
        tris.push((a, a + rng.v(-0.2, 0.2), a + rng.v(-0.2, 0.2), shading(1)));
    }
    let objects = vec![SceneObject::named("ground"), SceneObject::named("crate")];
    scene = Scene::from_objects("named", tris, before.materials.clone(), vec![], Camera::default(), objects).unwrap();
    // Origins on a 1/1024 grid, so moving them by 3 m and back is exact.
    let rays: Vec<(Vec3, Vec3)> = (0..400)
        .map(|_| {
            let o = (rng.v(-1.0, 1.0) * 1024.0).round() / 1024.0 + Vec3::Y * 4.0;
            (o, (rng.v(-0.5, 0.5) + Vec3::Y - o).normalize())
        })
        .collect();
    let hits = |s: &Scene, t: f32| -> Vec<Option<u32>> {
        rays.iter()
            .map(|&(o, d)| s.at(t).intersect(o, d, 0.0, f32::INFINITY).map(|h| s.triangles[h.triangle as usize].source))
            .collect()
    };
    let still = hits(&scene, 0.0);
    assert!(!scene.has_motion());

    let e = scene.set_motion("barrel", RigidMotion::translation(Vec3::ZERO, Vec3::X)).unwrap_err().to_string();
    assert!(e.contains("no object is called 'barrel'") && e.contains("ground, crate"), "{e}");
    let bad = RigidMotion { rotation: [Quat::from_xyzw(0.0, 0.0, 0.0, 2.0), Quat::IDENTITY], ..RigidMotion::IDENTITY };
    let e = scene.set_motion("crate", bad).unwrap_err().to_string();
    assert!(e.contains("not a unit quaternion"), "{e}");

    // Moved 3 m along x: at every time the crate is hit where a translated copy would be.
    scene.set_motion("crate", RigidMotion::translation(Vec3::X * 3.0, Vec3::X * 3.0)).unwrap();
    assert!(scene.has_motion());
    assert_eq!(scene.objects[1].instance, Some(0));
    let moved = hits(&scene, 0.3);
    assert_ne!(moved, still);
    for (k, &(o, d)) in rays.iter().enumerate() {
        let shifted = scene.at(0.3).intersect(o + Vec3::X * 3.0, d, 0.0, f32::INFINITY);
        let src = shifted.map(|h| scene.triangles[h.triangle as usize].source);
        if still[k].is_some_and(|s| s >= 2) {
            assert_eq!(src, still[k], "ray {k}");
        }
    }
    // Back at rest: the static tree again, the same hits bit for bit as before.
    scene.set_motion("crate", RigidMotion::IDENTITY).unwrap();
    assert!(!scene.has_motion());
    assert_eq!(hits(&scene, 0.7), still);
}

#[test]
fn lights_on_moving_objects_move_with_them() {
    let lamp = Material::emitter("lamp", Vec3::splat(5.0));
    let grey = Material::diffuse("grey", Vec3::splat(0.5));
    let q = [Vec3::new(0.0, 2.0, 0.0), Vec3::new(1.0, 2.0, 0.0), Vec3::new(1.0, 2.0, 1.0), Vec3::new(0.0, 2.0, 1.0)];
    let s = |material, object| TriangleShading { material, ..shading(object) };
    let tris = vec![
        (Vec3::new(-5.0, 0.0, 5.0), Vec3::new(5.0, 0.0, 5.0), Vec3::new(0.0, 0.0, -5.0), s(1, 0)),
        (q[0], q[1], q[2], s(0, 1)),
        (q[0], q[2], q[3], s(0, 1)),
    ];
    let motion = RigidMotion {
        pivot: Vec3::new(0.5, 2.0, 0.5),
        translation: [Vec3::ZERO, Vec3::new(0.0, 0.0, 2.0)],
        rotation: [Quat::IDENTITY, Quat::from_rotation_y(0.5)],
    };
    let objects = vec![SceneObject::named("floor"), SceneObject { motion: Some(motion), ..SceneObject::named("lamp") }];
    let scene = Scene::from_objects("lamp", tris, vec![lamp, grey], vec![], Camera::default(), objects).unwrap();
    assert_eq!(scene.lights.len(), 1, "the quad is still one rect light");
    assert_eq!(scene.light_object, vec![1]);
    for t in [-1.0f32, 0.0, 0.6, 1.0] {
        let at = scene.at(t);
        let l = at.light(0);
        let xf = motion.at(t);
        let rest = scene.lights[0];
        for (moved, stored) in l.vertices().iter().zip(rest.vertices()) {
            assert!((*moved - xf.point(stored)).length() < 1e-5);
        }
        // The light's centre, seen from below, is the light's own surface at that time.
        let c = l.centre();
        let o = c - Vec3::Y;
        let hit = at.intersect(o, Vec3::Y, 0.0, f32::INFINITY).expect("light hit");
        assert!((hit.t - 1.0).abs() < 1e-5);
        assert_eq!(scene.light_of_triangle(hit.triangle), Some(0));
        assert!((l.normal() - Vec3::NEG_Y).length() < 1e-5);
    }
}

#[test]
fn the_motion_builtin_blurs_5_to_40_pixels_and_keeps_static_parts_still() {
    let scene = load(&SceneSource::Builtin("motion".into())).unwrap();
    assert!(builtin_names().contains(&"motion"));
    assert!(scene.triangle_count() < 20_000, "{}", scene.triangle_count());
    assert!(scene.has_motion());
    assert_eq!(scene.lights.len(), 1);
    let names: Vec<&str> = scene.objects.iter().map(|o| o.name.as_str()).collect();
    for n in ["ground", "panel", "ball", "bridge", "spinner", "light"] {
        assert!(names.contains(&n), "{names:?}");
    }
    let cam = scene.camera;
    assert!(cam.validate().is_ok() && cam.shutter_open < cam.shutter_close);
    // Project to 640×480 pixels.
    let (w, h) = (640.0f32, 480.0f32);
    let (right, up, forward) = cam.basis();
    let tan_half = (cam.vfov_deg.to_radians() * 0.5).tan();
    let project = |p: Vec3| {
        let v = p - cam.position;
        let z = v.dot(forward);
        let sx = v.dot(right) / (z * tan_half * w / h);
        let sy = v.dot(up) / (z * tan_half);
        Vec2::new((sx + 1.0) * 0.5 * w, (1.0 - sy) * 0.5 * h)
    };
    for (k, o) in scene.objects.iter().enumerate() {
        let mut longest = 0.0f32;
        for (r, s) in scene.triangles.iter().zip(&scene.shading) {
            if s.object as usize != k {
                continue;
            }
            for p in r.vertices() {
                let (a, b) = match scene.instance_of(k as u32) {
                    None => (p, p),
                    Some(i) => (i.prepared.at(-1.0).point(p), i.prepared.at(1.0).point(p)),
                };
                longest = longest.max((project(a) - project(b)).length());
            }
        }
        println!("{}: blur {longest:.1} px", o.name);
        match o.name.as_str() {
            "ground" | "bridge" | "light" => assert_eq!(longest, 0.0, "{}", o.name),
            _ => assert!((5.0..=40.0).contains(&longest), "{}: {longest} px", o.name),
        }
    }
    // The panel moves 0.2 m along x over the shutter: 0.1 per unit t everywhere on it.
    let at = scene.at(0.3);
    let panel = names.iter().position(|&n| n == "panel").unwrap() as u32;
    let o = Vec3::new(0.2, 2.0, 0.3);
    let hit = at.intersect(o, Vec3::NEG_Y, 0.0, f32::INFINITY).unwrap();
    let sp = at.surface(&hit, o, Vec3::NEG_Y);
    assert_eq!(sp.object, panel);
    assert!((at.velocity(&sp) - Vec3::new(0.1, 0.0, 0.0)).length() < 1e-6);
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("wedge-motion-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn le(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// An animated glTF: a 1 m triangle in node 0 ("spin") under a parent node 1 ("carrier"). The
/// parent translates LINEARly (keyframes 0 s → (0,0,0), 1 s → (2,0,0)); the child rotates about y in
/// STEP (0 s → 0°, 0.5 s → 90°) or LINEAR (0 s → 0°, 1 s → 90°).
pub fn animated_gltf(rotation_interpolation: &str) -> String {
    let tri = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    let times = [0.0f32, 1.0];
    let step_times = [0.0f32, 0.5];
    let tr = [0.0f32, 0.0, 0.0, 2.0, 0.0, 0.0];
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let rot = [0.0f32, 0.0, 0.0, 1.0, 0.0, s, 0.0, s];
    let mut buf = le(&tri); // 0..36
    buf.extend(le(&times)); // 36..44
    buf.extend(le(&step_times)); // 44..52
    buf.extend(le(&tr)); // 52..76
    buf.extend(le(&rot)); // 76..108
    let rot_input = if rotation_interpolation == "STEP" { 2 } else { 1 };
    format!(
        r#"{{"asset":{{"version":"2.0"}},
"buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{}"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":8}},
  {{"buffer":0,"byteOffset":44,"byteLength":8}},{{"buffer":0,"byteOffset":52,"byteLength":24}},{{"buffer":0,"byteOffset":76,"byteLength":32}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}},
  {{"bufferView":1,"componentType":5126,"count":2,"type":"SCALAR"}},
  {{"bufferView":2,"componentType":5126,"count":2,"type":"SCALAR"}},
  {{"bufferView":3,"componentType":5126,"count":2,"type":"VEC3"}},
  {{"bufferView":4,"componentType":5126,"count":2,"type":"VEC4"}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
"nodes":[{{"name":"spin","mesh":0}},{{"name":"carrier","children":[0]}}],
"scenes":[{{"nodes":[1]}}],"scene":0,
"animations":[{{"channels":[{{"sampler":0,"target":{{"node":1,"path":"translation"}}}},{{"sampler":1,"target":{{"node":0,"path":"rotation"}}}}],
  "samplers":[{{"input":1,"output":3,"interpolation":"LINEAR"}},{{"input":{rot_input},"output":4,"interpolation":"{rotation_interpolation}"}}]}}]}}"#,
        buf.len(),
        base64_encode(&buf)
    )
}

fn base64_encode(b: &[u8]) -> String {
    const T: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for c in b.chunks(3) {
        let n = (c[0] as u32) << 16 | (*c.get(1).unwrap_or(&0) as u32) << 8 | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            if k <= c.len() {
                out.push(T[(n >> (18 - 6 * k)) as usize & 63] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// The world vertices of object `k` at shutter time `t`.
fn vertices_at(scene: &Scene, object: u32, t: f32) -> Vec<Vec3> {
    let xf = scene.instance_of(object).map(|i| i.prepared.at(t));
    scene
        .triangles
        .iter()
        .zip(&scene.shading)
        .filter(|(_, s)| s.object == object)
        .flat_map(|(r, _)| r.vertices())
        .map(|p| xf.map_or(p, |x| x.point(p)))
        .collect()
}

fn close_to(a: &[Vec3], b: &[Vec3]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (*x - *y).length() < 1e-5)
}

#[test]
fn gltf_animations_are_sampled_at_the_shutter() {
    let dir = temp_dir("gltf");
    let opts = LoadOptions::default();
    let y90 = |p: Vec3| Vec3::new(p.z, p.y, -p.x); // +90° about y
    let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
    for interp in ["LINEAR", "STEP"] {
        let path = write(&dir, &format!("anim_{interp}.gltf"), &animated_gltf(interp));
        let src = SceneSource::File(path.clone());
        // Without a shutter: sampled at time 0 only, nothing moves, a warning says why.
        let still = load(&src).unwrap();
        assert!(!still.has_motion());
        assert!(still.warnings.iter().any(|w| w.contains("shutter is empty")), "{:?}", still.warnings);
        assert_eq!(still.objects[0].name, "spin");

        // Shutter (0.25, 0.75): the carrier is at x = 0.5 and 1.5; the spin at 22.5° and 67.5°
        // (LINEAR) or 0° and 90° (STEP: the 0.5 s key holds from then on).
        let scene = load_with_shutter(&src, &opts, Some((0.25, 0.75))).unwrap();
        assert_eq!((scene.camera.shutter_open, scene.camera.shutter_close), (0.25, 0.75));
        assert!(scene.has_motion());
        let deg = |d: f32| Quat::from_rotation_y(d.to_radians());
        let (rot_open, rot_close) = match interp {
            "STEP" => (deg(0.0), deg(90.0)),
            _ => (deg(22.5), deg(67.5)),
        };
        let open: Vec<Vec3> = tri.iter().map(|&p| rot_open * p + Vec3::X * 0.5).collect();
        let close: Vec<Vec3> = tri.iter().map(|&p| rot_close * p + Vec3::X * 1.5).collect();
        let (got_open, got_close) = (vertices_at(&scene, 0, -1.0), vertices_at(&scene, 0, 1.0));
        assert!(close_to(&got_open, &open), "{interp} open: {got_open:?} vs {open:?}");
        assert!(close_to(&got_close, &close), "{interp} close: {got_close:?} vs {close:?}");
        // Pivot: the animated child's origin at open, (0.5, 0, 0); it travels straight.
        let m = scene.objects[0].motion.unwrap();
        assert!((m.pivot - Vec3::X * 0.5).length() < 1e-6);
        let mid = scene.instance_of(0).unwrap().prepared.at(0.0).point(m.pivot);
        assert!((mid - Vec3::X * 1.0).length() < 1e-6);
    }
    // Before the first and after the last keyframe the values hold.
    let path = write(&dir, "hold.gltf", &animated_gltf("LINEAR"));
    let scene = load_with_shutter(&SceneSource::File(path), &opts, Some((5.0, 9.0))).unwrap();
    assert!(!scene.has_motion());
    let want: Vec<Vec3> = tri.iter().map(|&p| y90(p) + Vec3::X * 2.0).collect();
    assert!(close_to(&vertices_at(&scene, 0, 0.0), &want));
    // A shutter that is not an interval is refused.
    let e = load_with_shutter(&SceneSource::Builtin("grids".into()), &opts, Some((1.0, 0.0))).unwrap_err();
    assert!(e.to_string().contains("not an interval"), "{e}");
}

#[test]
fn ron_motion_blocks_and_camera_shutters() {
    let dir = temp_dir("ron");
    std::fs::write(dir.join("anim.gltf"), animated_gltf("LINEAR")).unwrap();
    std::fs::write(dir.join("tri.obj"), "o wedge\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let scene_file = write(
        &dir,
        "s.ron",
        r#"Scene(
  meshes: [
    (path: "tri.obj", translate: (0, 0, -2),
     motion: Some((translation: ((0, 0, 0), (0.4, 0, 0)), rotate_deg: (0, 90)))),
    (path: "anim.gltf"),
  ],
  camera: Some((position: (0, 1, 4), look_at: (0, 0, 0), vfov_deg: 40, shutter: (0.0, 1.0))),
)"#,
    );
    let scene = load(&SceneSource::File(scene_file.clone())).unwrap();
    assert_eq!((scene.camera.shutter_open, scene.camera.shutter_close), (0.0, 1.0));
    let names: Vec<&str> = scene.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["wedge", "spin"]);
    // The OBJ triangle turns 90° about y through its placed origin (0, 0, −2) and moves 0.4 m.
    let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
    let close: Vec<Vec3> = tri.iter().map(|&p| Vec3::new(p.z, p.y, -p.x) + Vec3::new(0.4, 0.0, -2.0)).collect();
    assert!(close_to(&vertices_at(&scene, 0, 1.0), &close), "{:?}", vertices_at(&scene, 0, 1.0));
    // The glTF's animation sampled at the RON camera's shutter: carrier from x = 0 to 2.
    let open: Vec<Vec3> = tri.to_vec();
    assert!(close_to(&vertices_at(&scene, 1, -1.0), &open));
    // An animated glTF placed by a similarity (scale 2, 90° about y, moved): its motion is carried
    // along, so at both ends the triangles are the placement of the file's own poses.
    let placed = write(
        &dir,
        "placed.ron",
        r#"Scene(meshes: [(path: "anim.gltf", translate: (1, 0, -1), scale: 2.0, rotate_y_deg: 90)],
  camera: Some((position: (0, 1, 4), look_at: (0, 0, 0), vfov_deg: 40, shutter: (0.0, 1.0))))"#,
    );
    let s3 = load(&SceneSource::File(placed)).unwrap();
    let place = |p: Vec3| Quat::from_rotation_y(std::f32::consts::FRAC_PI_2) * (p * 2.0) + Vec3::new(1.0, 0.0, -1.0);
    let pose_close: Vec<Vec3> =
        tri.iter().map(|&p| place(Quat::from_rotation_y(std::f32::consts::FRAC_PI_2) * p + Vec3::X * 2.0)).collect();
    let pose_open: Vec<Vec3> = tri.iter().map(|&p| place(p)).collect();
    assert!(close_to(&vertices_at(&s3, 0, -1.0), &pose_open), "{:?}", vertices_at(&s3, 0, -1.0));
    assert!(close_to(&vertices_at(&s3, 0, 1.0), &pose_close), "{:?}", vertices_at(&s3, 0, 1.0));
    // A shutter from the caller (a pipeline camera) wins over the file's.
    let s2 = load_with_shutter(&SceneSource::File(scene_file), &LoadOptions::default(), Some((0.5, 0.5))).unwrap();
    assert!(s2.instance_of(1).is_none(), "the glTF does not move over an empty shutter");
    assert!(s2.instance_of(0).is_some(), "the RON motion block does not depend on the shutter");
}
