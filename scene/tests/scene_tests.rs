//! Numeric tests of wedge-scene: traversal vs brute force, light formulas vs Monte Carlo and closed
//! forms, loaders (glTF, OBJ/MTL, RON) on files written here, and error paths.

use std::path::PathBuf;
use std::time::Instant;

use wedge_scene::bvh::{intersect_triangle, stack_need, tree_depth, STACK_SIZE};
use wedge_scene::*;

/// SplitMix64: tiny deterministic RNG so the tests need no extra crates.
struct Rng(u64);
impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn f(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    fn f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn v2(&mut self) -> Vec2 {
        Vec2::new(self.f(), self.f())
    }
    fn dir(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(self.f(), self.f(), self.f()) * 2.0 - Vec3::ONE;
            if v.length_squared() > 1e-4 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("wedge-scene-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn brute_closest(s: &Scene, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<(u32, f32)> {
    let mut best = None;
    let mut tb = tmax;
    for (i, t) in s.triangles.iter().enumerate() {
        if let Some((t, _, _)) = intersect_triangle(t, o, d, tmin, tb) {
            tb = t;
            best = Some((i as u32, t));
        }
    }
    best
}

fn check_traversal(name: &str) {
    let s = load(&SceneSource::Builtin(name.into())).unwrap();
    assert!(stack_need(&s.bvh.nodes) <= STACK_SIZE);
    let mut rng = Rng(42);
    let (lo, hi) = (s.bounds.min - Vec3::splat(0.5), s.bounds.max + Vec3::splat(0.5));
    let (mut hits, mut ties, mut anyhit_checks) = (0, 0, 0);
    for k in 0..10_000 {
        // Half the rays from the camera through random pixels (the realistic case), half arbitrary.
        let (o, d) = if k % 2 == 0 {
            s.camera.generate_ray(rng.f() * 640.0, rng.f() * 480.0, 640, 480, rng.v2())
        } else {
            (lo + (hi - lo) * Vec3::new(rng.f(), rng.f(), rng.f()), rng.dir())
        };
        let got = s.intersect(o, d, 1e-4, f32::INFINITY);
        let want = brute_closest(&s, o, d, 1e-4, f32::INFINITY);
        match (got, want) {
            (None, None) => {}
            (Some(h), Some((tri, t))) => {
                hits += 1;
                // The closest-hit rule (smallest t, then lowest index) makes the answer exact whatever
                // order the traversal visits triangles in: same triangle, same t bits.
                assert_eq!((h.triangle, h.t.to_bits()), (tri, t.to_bits()), "{name} ray {k}");
                let sibling = s.triangles.iter().enumerate().any(|(i, tr)| {
                    i as u32 != tri && intersect_triangle(tr, o, d, 1e-4, f32::INFINITY).is_some_and(|x| x.0 == t)
                });
                ties += sibling as u32;
            }
            (g, w) => panic!("{name} ray {k}: traversal {g:?} vs brute force {w:?}"),
        }
        // Any-hit over a random sub-interval.
        let tmax = rng.f() * s.extent();
        let occ = s.occluded(o, d, 1e-4, tmax);
        // Anything in (tmin, tmax) ⇔ the closest hit in (tmin, ∞) is before tmax.
        let want_occ = want.is_some_and(|(_, t)| t < tmax);
        assert_eq!(occ, want_occ, "{name} ray {k}: occluded mismatch (tmax {tmax})");
        anyhit_checks += 1;
    }
    println!(
        "{name}: {} tris, {hits} hits ({ties} at a shared edge or vertex: equal t), {anyhit_checks} any-hit checks",
        s.triangle_count()
    );
    assert!(hits > 3000, "too few hits to be a meaningful test: {hits}");
}

#[test]
fn traversal_matches_brute_force_grids() {
    check_traversal("grids");
}

#[test]
fn traversal_matches_brute_force_curved() {
    check_traversal("curved");
}

/// MC estimate of unoccluded irradiance: E = ∫ L cosθ_p cosθ_l / r² dA, sampling the light uniformly.
fn mc_irradiance(l: &AreaLight, p: Vec3, n: Vec3, samples: usize, seed: u64) -> f64 {
    let mut rng = Rng(seed);
    let ln = l.normal();
    let mut sum = 0.0f64;
    for _ in 0..samples {
        let q = l.sample_point(rng.v2());
        let w = q - p;
        let r2 = w.length_squared() as f64;
        let w = w.normalize();
        let cos_p = n.dot(w).max(0.0) as f64;
        let cl = -ln.dot(w);
        let cos_l = if l.two_sided { cl.abs() } else { cl.max(0.0) } as f64;
        sum += cos_p * cos_l / r2;
    }
    sum / samples as f64 * l.area() as f64 * l.radiance.x as f64
}

#[test]
fn irradiance_matches_monte_carlo() {
    let rect = AreaLight {
        shape: LightShape::Rect {
            corner: Vec3::new(-0.5, 2.0, -0.3),
            edge_u: Vec3::new(1.0, 0.0, 0.0),
            edge_v: Vec3::new(0.0, 0.0, 0.6),
        },
        radiance: Vec3::splat(10.0),
        two_sided: false,
    };
    assert!(rect.normal().abs_diff_eq(Vec3::NEG_Y, 1e-6));
    let tri = AreaLight {
        shape: LightShape::Triangle {
            v0: Vec3::new(-0.4, 1.5, 0.2),
            v1: Vec3::new(0.6, 1.7, 0.1),
            v2: Vec3::new(0.1, 1.6, -0.7),
        },
        radiance: Vec3::splat(5.0),
        two_sided: false,
    };
    // The triangle's winding must face down for these receivers; flip it if needed.
    let tri = if tri.normal().y > 0.0 {
        if let LightShape::Triangle { v0, v1, v2 } = tri.shape {
            AreaLight { shape: LightShape::Triangle { v0, v1: v2, v2: v1 }, ..tri }
        } else {
            unreachable!()
        }
    } else {
        tri
    };
    let points = [
        (Vec3::ZERO, Vec3::Y),
        (Vec3::new(0.7, 0.0, 0.4), Vec3::Y),
        (Vec3::new(-0.5, 0.3, -0.2), Vec3::new(0.3, 1.0, 0.2).normalize()),
        (Vec3::new(1.2, 0.5, 0.0), Vec3::new(-0.6, 1.0, 0.0).normalize()),
        // Lights straddling the tangent plane (a vertical face under the light, a face tilted past
        // the light's edge): the closed form clips the polygon to the part above the horizon.
        (Vec3::new(0.1, 1.0, 0.0), Vec3::X),
        (Vec3::new(0.0, 1.2, 0.1), Vec3::new(1.0, 0.3, -0.4).normalize()),
    ];
    for (li, l) in [rect, tri].iter().enumerate() {
        for (pi, (p, n)) in points.iter().enumerate() {
            let exact = l.irradiance_unoccluded(*p, *n).x as f64;
            let mc = mc_irradiance(l, *p, *n, 1_000_000, 7 + pi as u64);
            let rel = (exact - mc).abs() / mc;
            println!("light {li} point {pi}: closed form {exact:.6}, MC {mc:.6}, rel {rel:.2e}");
            assert!(exact > 0.0 && rel < 0.01, "light {li} point {pi}: {exact} vs MC {mc}");
        }
    }
    // One-sided light seen from behind: zero; two-sided: same as from the front by symmetry.
    let above = Vec3::new(0.0, 4.0, 0.0);
    assert_eq!(rect.irradiance_unoccluded(above, Vec3::NEG_Y), Vec3::ZERO);
    let two = AreaLight { two_sided: true, ..rect };
    let back = two.irradiance_unoccluded(above, Vec3::NEG_Y).x;
    let front = two.irradiance_unoccluded(Vec3::ZERO, Vec3::Y).x;
    assert!((back - front).abs() / front < 1e-4, "{back} vs {front}");
}

#[test]
fn irradiance_on_axis_square_is_analytic() {
    for (w, h, radiance) in [(1.0f64, 3.0f64, 10.0f32), (0.5, 0.4, 2.0), (2.0, 1.0, 1.0)] {
        let wf = w as f32;
        let l = AreaLight {
            shape: LightShape::Rect {
                corner: Vec3::new(-wf / 2.0, h as f32, -wf / 2.0),
                edge_u: Vec3::X * wf,
                edge_v: Vec3::Z * wf,
            },
            radiance: Vec3::splat(radiance),
            two_sided: false,
        };
        // Differential area to a parallel coaxial square of side w at height h:
        // E = 4 L X/√(1+X²) atan(X/√(1+X²)), X = (w/2)/h.
        let x = w / 2.0 / h;
        let s = (1.0 + x * x).sqrt();
        let analytic = 4.0 * radiance as f64 * x / s * (x / s).atan();
        let got = l.irradiance_unoccluded(Vec3::ZERO, Vec3::Y).x as f64;
        let rel = (got - analytic).abs() / analytic;
        println!("square {w} at {h}: {got} vs analytic {analytic} (rel {rel:.1e})");
        assert!(rel < 1e-3);
    }
}

#[test]
fn sigma_rect_and_triangle() {
    let rect = AreaLight {
        shape: LightShape::Rect { corner: Vec3::ZERO, edge_u: Vec3::X * 0.8, edge_v: Vec3::Z * 0.5 },
        radiance: Vec3::ONE,
        two_sided: false,
    };
    assert!((rect.sigma() - 0.8 / 12f32.sqrt()).abs() < 1e-6);
    // Triangle: compare with the largest eigenvalue of the sample covariance (power iteration).
    let (a, b, c) = (Vec3::new(0.0, 1.0, 0.0), Vec3::new(1.2, 1.0, 0.1), Vec3::new(0.3, 1.3, 0.9));
    let tri = AreaLight { shape: LightShape::Triangle { v0: a, v1: b, v2: c }, radiance: Vec3::ONE, two_sided: false };
    let mut rng = Rng(3);
    let n = 400_000;
    let pts: Vec<glam::DVec3> = (0..n).map(|_| tri.sample_point(rng.v2()).as_dvec3()).collect();
    let mean = pts.iter().copied().sum::<glam::DVec3>() / n as f64;
    let mut cov = glam::DMat3::ZERO;
    for p in &pts {
        let d = *p - mean;
        cov += glam::DMat3::from_cols(d * d.x, d * d.y, d * d.z);
    }
    cov *= 1.0 / n as f64;
    let mut v = glam::DVec3::ONE;
    for _ in 0..200 {
        v = (cov * v).normalize();
    }
    let lambda = v.dot(cov * v);
    let rel = (tri.sigma() as f64 - lambda.sqrt()).abs() / lambda.sqrt();
    println!("triangle sigma {} vs sampled {}", tri.sigma(), lambda.sqrt());
    assert!(rel < 0.01);
    // Centroid and area sanity.
    assert!((tri.centre() - (a + b + c) / 3.0).length() < 1e-6);
    assert!((mean.as_vec3() - tri.centre()).length() < 5e-3);
    let _ = rng.f64();
}

#[test]
fn texture_sample_at_texel_centres() {
    let (w, h) = (5u32, 3u32);
    let texels: Vec<[f32; 3]> = (0..w * h).map(|i| [i as f32, (i * 2) as f32, 0.5]).collect();
    let t = Texture { width: w, height: h, texels: texels.clone() };
    for y in 0..h {
        for x in 0..w {
            let uv = Vec2::new((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
            let got = t.sample(uv);
            assert!(got.abs_diff_eq(Vec3::from(texels[(y * w + x) as usize]), 1e-4), "({x},{y}): {got}");
            // Repeat wrapping: one period away gives the same value.
            assert!(t.sample(uv + Vec2::new(1.0, -2.0)).abs_diff_eq(got, 1e-3));
        }
    }
    // Halfway between texel (0,0) and (1,0): the average.
    let mid = t.sample(Vec2::new(1.0 / w as f32, 0.5 / h as f32));
    assert!(mid.abs_diff_eq(Vec3::new(0.5, 1.0, 0.5), 1e-4));
    // Wrap across the left edge: halfway between texel (w-1,0) and (0,0).
    let wrap = t.sample(Vec2::new(0.0, 0.5 / h as f32));
    assert!(wrap.abs_diff_eq(Vec3::new(2.0, 4.0, 0.5), 1e-4), "{wrap}");
}

#[test]
fn camera_rays() {
    let cam = Camera {
        position: Vec3::new(0.0, 1.0, 5.0),
        look_at: Vec3::new(0.0, 1.0, 0.0),
        up: Vec3::Y,
        vfov_deg: 90.0,
        aperture_radius: 0.0,
        focus_distance: 0.0,
        shutter_open: 0.0,
        shutter_close: 0.0,
    };
    let (o, d) = cam.generate_ray(50.0, 25.0, 100, 50, Vec2::ZERO);
    assert_eq!(o, cam.position);
    assert!(d.abs_diff_eq(Vec3::NEG_Z, 1e-6));
    // Top edge centre at vfov 90: 45° up. Right edge: 45° * aspect in tan.
    let (_, d) = cam.generate_ray(50.0, 0.0, 100, 50, Vec2::ZERO);
    assert!(d.abs_diff_eq(Vec3::new(0.0, 1.0, -1.0).normalize(), 1e-6));
    let (_, d) = cam.generate_ray(100.0, 25.0, 100, 50, Vec2::ZERO);
    assert!(d.abs_diff_eq(Vec3::new(2.0, 0.0, -1.0).normalize(), 1e-6));
    // Thin lens: all lens samples of a pixel meet on the focal plane.
    let lens = Camera { aperture_radius: 0.2, focus_distance: 3.0, ..cam };
    for u in [Vec2::new(0.1, 0.9), Vec2::new(0.7, 0.3), Vec2::new(0.5, 0.5)] {
        let (o, d) = lens.generate_ray(70.0, 10.0, 100, 50, u);
        assert!((o - cam.position).length() <= 0.2 + 1e-5);
        let (_, d0) = cam.generate_ray(70.0, 10.0, 100, 50, u);
        let target = cam.position + d0 * (3.0 / d0.dot(Vec3::NEG_Z));
        let t = (target.z - o.z) / d.z;
        assert!((o + d * t).abs_diff_eq(target, 1e-4));
    }
}

#[test]
fn builtins_load_and_are_sane() {
    assert_eq!(
        builtin_names(),
        &[
            "grids",
            "curved",
            "heavy",
            "cornell",
            "chess",
            "spheres",
            "motion",
            "envmap",
            "envmap_light",
            "envmap_real",
            "envmap_virtual",
            "envmap_far",
            "envmap_empty",
            "suite_slats",
            "suite_grate",
            "suite_contact",
            "suite_near_light",
            "suite_textured",
            "suite_glossy",
            "suite_room",
            "dof_foreground",
            "dof_background",
            "dof_receding",
            "dof_bokeh",
            "dof_thin",
            "dof_glossy",
            "dof_wide",
            "dof_tiny",
            "dof_room",
            "mo_fast_thin",
            "mo_rotating",
            "mo_shadow_caster",
            "mo_slow",
            "mo_sliding_wall",
            "mo_approach",
            "mo_crossing",
            "mo_glossy",
            "env_sun",
            "env_overcast",
            "env_glossy",
            "env_courtyard",
            "env_sunset",
            "env_slats",
            "env_studio",
            "env_curved"
        ]
    );
    // The defocus suite: every scene states a lens and has one area light (the component nodes'
    // `light: 0`), and is described.
    for (name, _) in wedge_scene::builtin::DEFOCUS_SUITE {
        let s = load(&SceneSource::Builtin((*name).into())).unwrap();
        assert!(s.camera.aperture_radius > 0.0 && s.camera.focus_distance > 0.0, "{name}: no lens");
        assert_eq!(s.lights.len(), 1, "{name}");
        assert!(s.triangle_count() > 0, "{name}");
    }
    // The motion suite: every scene moves over an open shutter, with one light at rest.
    for (name, _) in wedge_scene::builtin::MOTION_SUITE {
        let s = load(&SceneSource::Builtin((*name).into())).unwrap();
        assert!(s.camera.shutter_close > s.camera.shutter_open, "{name}: no shutter");
        assert!(s.has_motion(), "{name}: nothing moves");
        assert_eq!(s.lights.len(), 1, "{name}");
    }
    // The environment suite: every scene is lit by its own map alone (no area light, nothing emits),
    // and the maps differ where the scenes say (a sun's B_e far above overcast's).
    let mut bandwidths = std::collections::BTreeMap::new();
    for (name, _) in wedge_scene::builtin::ENVIRONMENT_SUITE {
        let s = load(&SceneSource::Builtin((*name).into())).unwrap();
        let env = s.environment.as_ref().unwrap_or_else(|| panic!("{name}: no environment map"));
        assert!(s.lights.is_empty() && s.triangle_count() > 0, "{name}");
        bandwidths.insert(env.name().to_string(), env.bandwidth());
    }
    assert_eq!(bandwidths.len(), 5, "{bandwidths:?}");
    assert!(bandwidths["builtin:sun"] > 2.0 * bandwidths["builtin:overcast"], "{bandwidths:?}");
    for (name, side) in [("grids", 0.6f32), ("curved", 1.0)] {
        let s = load(&SceneSource::Builtin(name.into())).unwrap();
        assert_eq!(s.lights.len(), 1, "{name}");
        let l = &s.lights[0];
        assert!(matches!(l.shape, LightShape::Rect { .. }), "{name}: {:?}", l.shape);
        assert!((l.area() - side * side).abs() < 1e-5 && l.normal().abs_diff_eq(Vec3::NEG_Y, 1e-6));
        assert!((l.sigma() - side / 12f32.sqrt()).abs() < 1e-6);
        let e = l.irradiance_unoccluded(Vec3::ZERO, Vec3::Y).x;
        assert!(e > 0.5 && e < 3.0, "{name}: ground irradiance {e}");
        // Both light triangles map to light 0, nothing else does.
        let lit: Vec<u32> = (0..s.triangle_count() as u32).filter(|&t| s.light_of_triangle(t).is_some()).collect();
        assert_eq!(lit.len(), 2);
        // The light is not in view; most camera rays hit something.
        let (w, h) = (64, 48);
        let mut hit = 0;
        for y in 0..h {
            for x in 0..w {
                let (o, d) = s.camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5, w, h, Vec2::ZERO);
                if let Some(hh) = s.intersect(o, d, 0.0, f32::INFINITY) {
                    hit += 1;
                    assert!(s.light_of_triangle(hh.triangle).is_none(), "{name}: light visible at ({x},{y})");
                    let sp = s.surface(&hh, o, d);
                    assert!(sp.geometric_normal.dot(d) <= 0.0 && sp.shading_normal.dot(d) <= 1e-6);
                    let a = s.albedo(&sp);
                    assert!(a.min_element() >= 0.0 && a.max_element() <= 1.0);
                }
            }
        }
        assert!(hit as f32 > 0.9 * (w * h) as f32, "{name}: only {hit} hits");
    }
    // The grids ground is checker-textured with mild contrast.
    let g = load(&SceneSource::Builtin("grids".into())).unwrap();
    assert_eq!(g.textures.len(), 1);
    let (o, d) = g.camera.generate_ray(320.0, 400.0, 640, 480, Vec2::ZERO);
    let sp = g.surface(&g.intersect(o, d, 0.0, f32::INFINITY).unwrap(), o, d);
    let a = g.albedo(&sp).x;
    assert!((0.549..=0.751).contains(&a), "{a}");
    assert!(matches!(load(&SceneSource::Builtin("nope".into())), Err(SceneError::UnknownBuiltin { .. })));
}

/// The scene suite (issue 16): every member is a built-in with a description, loads, is small, has
/// one rectangular light out of view (but in `cornell`) and a camera that sees geometry in nearly every pixel, and shows
/// mostly lit surfaces with penumbrae in view (pixels that see part of the light).
#[test]
fn suite_scenes_load_and_are_sane() {
    use wedge_scene::builtin::{describe, suite_names, SUITE};
    assert!(SUITE.len() >= 8, "issue 16 asks for at least eight scenes");
    let mut names: Vec<&str> = suite_names().collect();
    names.sort_unstable();
    names.dedup();
    assert_eq!(names.len(), SUITE.len(), "suite names are unique");
    for (name, text) in SUITE {
        assert!(builtin_names().contains(name), "{name} is a built-in");
        assert_eq!(describe(name), Some(*text));
        assert!(text.len() > 40 && text.ends_with('.'), "{name}: a sentence or two: {text:?}");
        let s = load(&SceneSource::Builtin(name.to_string())).unwrap();
        // New suite scenes: a few thousand triangles; `curved` (a finely tessellated ground) has 59k.
        let cap = if name.starts_with("suite_") { 10_000 } else { 60_000 };
        assert!(s.triangle_count() < cap, "{name}: {} triangles; keep suite scenes small", s.triangle_count());
        assert_eq!(s.lights.len(), 1, "{name}");
        let l = &s.lights[0];
        assert!(matches!(l.shape, LightShape::Rect { .. }), "{name}: {:?}", l.shape);
        assert!(l.normal().y < -0.99, "{name}: the light faces down");
        let (w, h) = (64u32, 48u32);
        let (mut hit, mut lit, mut penumbra, mut umbra) = (0u32, 0u32, 0u32, 0u32);
        for y in 0..h {
            for x in 0..w {
                let (o, d) = s.camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5, w, h, Vec2::ZERO);
                let Some(hh) = s.intersect(o, d, 0.0, f32::INFINITY) else { continue };
                hit += 1;
                if s.light_of_triangle(hh.triangle).is_some() {
                    // Only the thesis's Cornell box shows its light (as in its figures).
                    assert_eq!(*name, "cornell", "{name}: light visible at ({x},{y})");
                    continue;
                }
                let sp = s.surface(&hh, o, d);
                let a = s.albedo(&sp);
                assert!(a.min_element() >= 0.0 && a.max_element() <= 1.0, "{name}: albedo {a}");
                let p = sp.position + sp.geometric_normal * 1e-3;
                // 4×4 stratified points on the light: how many does this point see?
                let seen = (0..16)
                    .filter(|k| {
                        let u = Vec2::new((k % 4) as f32 + 0.5, (k / 4) as f32 + 0.5) / 4.0;
                        let q = l.sample_point(u);
                        let to = q - p;
                        to.dot(sp.geometric_normal) > 0.0
                            && !s.occluded(p, to.normalize(), 0.0, to.length() * (1.0 - 1e-4))
                    })
                    .count();
                match seen {
                    16 => lit += 1,
                    0 => umbra += 1,
                    _ => penumbra += 1,
                }
            }
        }
        let px = (w * h) as f32;
        // The new scenes fill the frame; `cornell` is a box in the dark (75% of the frame).
        let min_hit = if name.starts_with("suite_") { 0.97 } else { 0.7 };
        assert!(hit as f32 >= min_hit * px, "{name}: only {hit} of {px} camera rays hit geometry");
        assert!((lit + penumbra) as f32 > 0.5 * px, "{name}: only {} pixels see the light", lit + penumbra);
        assert!(penumbra as f32 > 0.03 * px, "{name}: only {penumbra} penumbra pixels (shadows in view?)");
        println!(
            "{name}: {} triangles, hit {hit}, lit {lit}, penumbra {penumbra}, umbra {umbra} of {px}",
            s.triangle_count()
        );
    }
}

#[test]
fn heavy_build_timing() {
    let t0 = Instant::now();
    let s = load(&SceneSource::Builtin("heavy".into())).unwrap();
    let total = t0.elapsed();
    println!(
        "heavy: {} triangles, {} nodes, depth {}, load+build {:?}",
        s.triangle_count(),
        s.bvh.nodes.len(),
        tree_depth(&s.bvh.nodes),
        total
    );
    assert!(s.triangle_count() >= 100_000);
    // Time from_triangles alone on the same triangles.
    let tris: Vec<_> = s
        .triangles
        .iter()
        .zip(&s.shading)
        .map(|(t, sh)| {
            let v = t.vertices();
            (v[0], v[1], v[2], *sh)
        })
        .collect();
    let t0 = Instant::now();
    let s2 = Scene::from_triangles("heavy", tris, s.materials.clone(), s.textures.clone(), s.camera).unwrap();
    println!("heavy: Scene::from_triangles {:?}", t0.elapsed());
    assert_eq!(s2.lights.len(), 1);
    // Throughput smoke: a few thousand camera rays.
    let t0 = Instant::now();
    let mut n = 0;
    for y in 0..60 {
        for x in 0..80 {
            let (o, d) = s.camera.generate_ray(x as f32 * 8.0, y as f32 * 8.0, 640, 480, Vec2::ZERO);
            n += s.intersect(o, d, 0.0, f32::INFINITY).is_some() as u32;
        }
    }
    println!("heavy: 4800 primary rays in {:?} ({n} hits)", t0.elapsed());
}

/// `spheres` is issue 12's benchmark scene: its triangle count is the issue's, it has one rectangular
/// light out of view, and the camera sees spheres, ground and sky (so primary rays exercise hits on
/// both and misses) — the properties the Embree comparison in `benches/throughput.rs` relies on.
#[test]
fn spheres_scene_matches_issue_12() {
    let t0 = Instant::now();
    let s = load(&SceneSource::Builtin("spheres".into())).unwrap();
    println!("spheres: {} triangles, load+build {:?}", s.triangle_count(), t0.elapsed());
    // No spatial splits in the default build, so one record per input triangle.
    assert_eq!(s.triangle_count(), 409_604);
    assert_eq!(s.lights.len(), 1);
    let l = &s.lights[0];
    assert!(matches!(l.shape, LightShape::Rect { .. }), "{:?}", l.shape);
    assert!((l.area() - 9.0).abs() < 1e-4 && l.normal().abs_diff_eq(Vec3::NEG_Y, 1e-6));
    let ground = s.materials.iter().position(|m| m.name == "ground").unwrap() as u32;
    let (w, h) = (80, 60);
    let (mut sphere, mut floor, mut sky) = (0, 0, 0);
    for y in 0..h {
        for x in 0..w {
            let (o, d) = s.camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5, w, h, Vec2::ZERO);
            match s.intersect(o, d, 0.0, f32::INFINITY) {
                None => sky += 1,
                Some(hit) => {
                    assert!(s.light_of_triangle(hit.triangle).is_none(), "light visible at ({x},{y})");
                    if s.triangles[hit.triangle as usize].material == ground {
                        floor += 1
                    } else {
                        sphere += 1
                    }
                }
            }
        }
    }
    println!("spheres: {sphere} sphere, {floor} ground, {sky} sky of {} camera rays", w * h);
    let n = (w * h) as f32;
    for (what, k) in [("sphere", sphere), ("ground", floor), ("sky", sky)] {
        assert!(k as f32 > 0.1 * n, "only {k} {what} pixels");
    }
}

#[test]
fn gltf_two_triangles_emissive_quad_and_camera() {
    let dir = temp_dir("gltf");
    // Ground: two triangles (non-indexed). Light: an indexed quad at y = 2 facing down.
    let ground: [[f32; 3]; 6] =
        [[-1., 0., 1.], [1., 0., 1.], [1., 0., -1.], [-1., 0., 1.], [1., 0., -1.], [-1., 0., -1.]];
    let light: [[f32; 3]; 4] = [[-0.25, 2., -0.25], [0.25, 2., -0.25], [0.25, 2., 0.25], [-0.25, 2., 0.25]];
    let idx: [u16; 6] = [0, 1, 2, 0, 2, 3];
    let mut buf: Vec<u8> = Vec::new();
    buf.extend_from_slice(bytemuck::cast_slice(&ground));
    buf.extend_from_slice(bytemuck::cast_slice(&light));
    buf.extend_from_slice(bytemuck::cast_slice(&idx));
    let json = format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "scene": 0,
  "scenes": [{{"nodes": [0, 1, 2]}}],
  "nodes": [
    {{"mesh": 0}},
    {{"mesh": 1}},
    {{"camera": 0, "translation": [0, 1, 5]}}
  ],
  "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.7, "znear": 0.1}}}}],
  "meshes": [
    {{"primitives": [{{"attributes": {{"POSITION": 0}}, "material": 0}}]}},
    {{"primitives": [{{"attributes": {{"POSITION": 1}}, "indices": 2, "material": 1}}]}}
  ],
  "materials": [
    {{"name": "grey", "pbrMetallicRoughness": {{"baseColorFactor": [0.5, 0.5, 0.5, 1]}}}},
    {{"name": "lamp", "emissiveFactor": [1, 0.5, 0.25]}}
  ],
  "buffers": [{{"byteLength": {len}, "uri": "data:application/octet-stream;base64,{b64}"}}],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 72}},
    {{"buffer": 0, "byteOffset": 72, "byteLength": 48}},
    {{"buffer": 0, "byteOffset": 120, "byteLength": 12}}
  ],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 6, "type": "VEC3", "min": [-1, 0, -1], "max": [1, 0, 1]}},
    {{"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-0.25, 2, -0.25], "max": [0.25, 2, 0.25]}},
    {{"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}}
  ]
}}"#,
        len = buf.len(),
        b64 = base64::encode(&buf)
    );
    let path = dir.join("tiny.gltf");
    std::fs::write(&path, json).unwrap();
    let s = load(&SceneSource::File(path.clone())).unwrap();
    assert_eq!(s.triangle_count(), 4);
    assert_eq!(s.materials.len(), 2);
    assert_eq!(s.materials[0].name, "grey");
    assert_eq!(s.lights.len(), 1, "{:?}", s.lights);
    let l = s.lights[0];
    assert!(matches!(l.shape, LightShape::Rect { .. }));
    assert!((l.area() - 0.25).abs() < 1e-6);
    assert!(l.radiance.abs_diff_eq(Vec3::new(1.0, 0.5, 0.25), 1e-6));
    // Winding (0,1,2) with those positions gives normal -Y: the light faces the ground.
    assert!(l.normal().abs_diff_eq(Vec3::NEG_Y, 1e-6));
    assert!(s.camera.position.abs_diff_eq(Vec3::new(0.0, 1.0, 5.0), 1e-6));
    assert!((s.camera.vfov_deg - 0.7f32.to_degrees()).abs() < 1e-4);
    assert!((s.camera.look_at - s.camera.position).normalize().abs_diff_eq(Vec3::NEG_Z, 1e-6));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Writes an OBJ (textured ground quad + emissive quad), its MTL and a 2×2 PNG.
fn write_obj_fixture(dir: &std::path::Path) -> PathBuf {
    let img = image::RgbImage::from_fn(2, 2, |x, y| {
        if (x + y) % 2 == 0 {
            image::Rgb([255, 255, 255])
        } else {
            image::Rgb([188, 0, 0])
        }
    });
    img.save(dir.join("check.png")).unwrap();
    std::fs::write(
        dir.join("scene.mtl"),
        "newmtl floor\nKd 0.8 0.8 0.8\nKs 0.2 0.2 0.2\nNs 50\nmap_Kd check.png\n\nnewmtl lamp\nKd 0 0 0\nKe 4 4 4\n",
    )
    .unwrap();
    let obj = "mtllib scene.mtl\n\
o floor\nv -1 0 1\nv 1 0 1\nv 1 0 -1\nv -1 0 -1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 1 0\nusemtl floor\nf 1/1/1 2/2/1 3/3/1 4/4/1\n\
o lamp\nv -0.3 1.5 -0.3\nv 0.3 1.5 -0.3\nv 0.3 1.5 0.3\nv -0.3 1.5 0.3\nusemtl lamp\nf 5 6 7 8\n";
    let path = dir.join("scene.obj");
    std::fs::write(&path, obj).unwrap();
    path
}

#[test]
fn obj_mtl_with_texture() {
    let dir = temp_dir("obj");
    let path = write_obj_fixture(&dir);
    let s = load(&SceneSource::File(path)).unwrap();
    assert_eq!(s.triangle_count(), 4);
    assert_eq!(s.materials.len(), 2);
    let floor = s.materials.iter().find(|m| m.name == "floor").unwrap();
    assert!(floor.base_color.abs_diff_eq(Vec3::splat(0.8), 1e-6));
    assert!(floor.specular.abs_diff_eq(Vec3::splat(0.2), 1e-6) && floor.phong_exponent == 50.0);
    let t = &s.textures[floor.base_color_texture.unwrap() as usize];
    assert_eq!((t.width, t.height), (2, 2));
    // sRGB 188 → linear ≈ 0.5029; texel (1,0) is the red one; sampling its centre returns it.
    let red = t.sample(Vec2::new(0.75, 0.25));
    assert!(red.abs_diff_eq(Vec3::new(0.5029, 0.0, 0.0), 1e-3), "{red}");
    assert_eq!(s.lights.len(), 1);
    assert!(matches!(s.lights[0].shape, LightShape::Rect { .. }));
    assert!((s.lights[0].area() - 0.36).abs() < 1e-5);
    assert!(s.lights[0].radiance.abs_diff_eq(Vec3::splat(4.0), 1e-6));
    // OBJ v is flipped: vt (0,0) is the image's bottom-left, so uv (0,1) in our convention.
    let (o, d) = (Vec3::new(-0.99, 1.0, 0.99), Vec3::NEG_Y);
    let h = s.intersect(o, d, 0.0, f32::INFINITY).unwrap();
    let sp = s.surface(&h, o, d);
    assert!(sp.uv.abs_diff_eq(Vec2::new(0.005, 0.995), 1e-3), "{}", sp.uv);
    assert!(sp.shading_normal.abs_diff_eq(Vec3::Y, 1e-6));
    // Camera: OBJ has none, so the default framing looks at the bounds' centre.
    assert!(s.camera.look_at.abs_diff_eq(s.bounds.centre(), 1e-5));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn ron_composition() {
    let dir = temp_dir("ron");
    write_obj_fixture(&dir);
    let ron = r#"Scene(
  meshes: [ (path: "scene.obj", translate: (0, 1, 0), scale: 2.0, rotate_y_deg: 90.0, material: Some("floor")) ],
  builtin: Some("grids"),
  lights: [ Rect(corner: (-0.5, 4, -0.5), edge_u: (1,0,0), edge_v: (0,0,1), radiance: (10,10,10)),
            Triangle(v0: (0, 5, 0), v1: (1, 5, 0), v2: (0, 5, 1), radiance: (1, 2, 3), two_sided: true) ],
  camera: Some((position: (0,1,3), look_at: (0,0,0), up: (0,1,0), vfov_deg: 40)),
)"#;
    let path = dir.join("comp.ron");
    std::fs::write(&path, ron).unwrap();
    let s = load(&SceneSource::File(path)).unwrap();
    let grids = load(&SceneSource::Builtin("grids".into())).unwrap();
    // grids + 4 mesh triangles (lamp overridden to floor: not a light) + 2 + 1 light triangles.
    assert_eq!(s.triangle_count(), grids.triangle_count() + 4 + 3);
    assert_eq!(s.lights.len(), 3, "{:?}", s.lights);
    let rects = s.lights.iter().filter(|l| matches!(l.shape, LightShape::Rect { .. })).count();
    assert_eq!(rects, 2);
    assert!(s.lights.iter().any(|l| l.two_sided && matches!(l.shape, LightShape::Triangle { .. })));
    assert_eq!(s.camera.position, Vec3::new(0.0, 1.0, 3.0));
    assert_eq!(s.camera.vfov_deg, 40.0);
    // The scaled mesh spans 4 m, so the bounds still come from the grids ground (6 m).
    assert!((s.extent() - 6.0).abs() < 1e-3 || s.extent() > 6.0);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn errors_name_the_file_and_never_panic() {
    let dir = temp_dir("errors");
    // Missing file.
    let missing = dir.join("does_not_exist.obj");
    let e = load(&SceneSource::File(missing)).unwrap_err().to_string();
    assert!(e.contains("does_not_exist.obj"), "{e}");
    // Garbage OBJ.
    let garbage = dir.join("garbage.obj");
    std::fs::write(&garbage, b"\x00\x01hello world\nthis is not an obj\n\xff\xfe").unwrap();
    let e = load(&SceneSource::File(garbage)).unwrap_err().to_string();
    assert!(e.contains("garbage.obj") && e.contains('—'), "{e}");
    // NaN vertex and out-of-range face index.
    let nan = dir.join("nan.obj");
    std::fs::write(&nan, "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let e = load(&SceneSource::File(nan)).unwrap_err().to_string();
    assert!(e.contains("nan.obj"), "{e}");
    let oob = dir.join("oob.obj");
    std::fs::write(&oob, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n").unwrap();
    let e = load(&SceneSource::File(oob)).unwrap_err().to_string();
    assert!(e.contains("oob.obj"), "{e}");
    // Missing texture file.
    std::fs::write(dir.join("t.mtl"), "newmtl m\nKd 1 1 1\nmap_Kd nowhere.png\n").unwrap();
    let tex = dir.join("tex.obj");
    std::fs::write(&tex, "mtllib t.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl m\nf 1 2 3\n").unwrap();
    let e = load(&SceneSource::File(tex)).unwrap_err().to_string();
    assert!(e.contains("nowhere.png"), "{e}");
    // RON with an unknown field: file name and line:col.
    let ron = dir.join("bad.ron");
    std::fs::write(&ron, "Scene(\n  meshes: [],\n  lihgts: [],\n)\n").unwrap();
    let e = load(&SceneSource::File(ron)).unwrap_err().to_string();
    assert!(e.contains("bad.ron") && e.contains("3:"), "{e}");
    assert!(e.contains("lihgts"), "{e}");
    // Garbage glTF, unsupported extension, empty RON scene.
    let g = dir.join("bad.gltf");
    std::fs::write(&g, "{ not json").unwrap();
    assert!(load(&SceneSource::File(g)).unwrap_err().to_string().contains("bad.gltf"));
    let u = dir.join("x.fbx");
    std::fs::write(&u, "").unwrap();
    assert!(load(&SceneSource::File(u)).unwrap_err().to_string().contains("x.fbx"));
    let empty = dir.join("empty.ron");
    std::fs::write(&empty, "Scene()").unwrap();
    let e = load(&SceneSource::File(empty)).unwrap_err().to_string();
    assert!(e.contains("empty.ron") && e.contains("no triangles and no camera"), "{e}");
    // With a camera an empty world is a scene (mixed reality with no virtual objects): every ray
    // misses its empty tree.
    let world = dir.join("world.ron");
    std::fs::write(&world, "Scene(camera: Some((position: (0, 1, 3), look_at: (0, 0, 0), vfov_deg: 40)))").unwrap();
    let s = load(&SceneSource::File(world)).unwrap();
    assert_eq!((s.triangle_count(), s.lights.len(), s.extent()), (0, 0, 0.0));
    assert!(s.intersect(Vec3::new(0.0, 1.0, 3.0), Vec3::NEG_Z, 0.0, f32::INFINITY).is_none());
    assert!(!s.occluded(Vec3::ZERO, Vec3::Y, 0.0, 1e30));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Not a check: renders direct lighting (stratified shadow rays) of the built-ins to PNGs for a visual
/// sanity check. `cargo test --release -p wedge-scene -- --ignored --nocapture preview`.
#[test]
#[ignore]
fn preview_direct_lighting() {
    let out = std::env::temp_dir().join("wedge-scene-preview");
    std::fs::create_dir_all(&out).unwrap();
    for name in ["grids", "curved", "heavy"] {
        let s = load(&SceneSource::Builtin(name.into())).unwrap();
        let (w, h) = (320u32, 240u32);
        let img = image::RgbImage::from_fn(w, h, |x, y| {
            let (o, d) = s.camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5, w, h, Vec2::ZERO);
            let Some(hit) = s.intersect(o, d, 0.0, f32::INFINITY) else {
                return image::Rgb([0, 0, 40]);
            };
            let sp = s.surface(&hit, o, d);
            let mut c = s.emission(&sp);
            for (li, l) in s.lights.iter().enumerate() {
                let n = 8;
                let mut e = Vec3::ZERO;
                for i in 0..n * n {
                    let u = Vec2::new(((i % n) as f32 + 0.5) / n as f32, ((i / n) as f32 + 0.5) / n as f32);
                    let q = l.sample_point(u);
                    let to = q - sp.position;
                    let dist = to.length();
                    let wi = to / dist;
                    let cos_p = sp.shading_normal.dot(wi).max(0.0);
                    let cos_l = (-l.normal().dot(wi)).max(0.0);
                    if cos_p == 0.0 || cos_l == 0.0 {
                        continue;
                    }
                    let origin = sp.position + sp.geometric_normal * 1e-4;
                    let blocked = s
                        .intersect(origin, wi, 0.0, dist * (1.0 - 1e-4))
                        .is_some_and(|h| s.light_of_triangle(h.triangle) != Some(li as u32));
                    if !blocked {
                        e += l.radiance * cos_p * cos_l / (dist * dist) * l.area();
                    }
                }
                c += s.albedo(&sp) / std::f32::consts::PI * e / (n * n) as f32;
            }
            let g = c.to_array().map(|v| (v.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0) as u8);
            image::Rgb(g)
        });
        img.save(out.join(format!("{name}.png"))).unwrap();
    }
    println!("previews in {}", out.display());
}

#[test]
fn polygon_angle_matches_atan2() {
    // `light::angle` (the closed form's atan2 from + − × ÷, mirrored in WGSL) against f64 atan2 over
    // the upper half-plane, including tiny angles (distant lights) and the axes.
    let mut worst = 0.0f64;
    let mut rng = Rng(11);
    for k in 0..200_000 {
        let (y, x) = match k {
            0 => (0.0, 1.0),
            1 => (1.0, 0.0),
            2 => (0.0, -1.0),
            3 => (1e-8, 1.0),
            _ => {
                let u = rng.v2();
                let scale = 10f32.powf(u.x * 8.0 - 4.0);
                (u.y * scale, (rng.v2().x * 2.0 - 1.0) * 10f32.powf(rng.v2().y * 8.0 - 4.0))
            }
        };
        let exact = (y as f64).atan2(x as f64);
        let got = wedge_scene::light::angle(y, x) as f64;
        worst = worst.max((got - exact).abs() / exact.abs().max(1e-30));
    }
    println!("largest relative error of angle(): {worst:.2e}");
    assert!(worst < 1e-6, "{worst}");
}
