//! Environment maps (issue 14, thesis Ch. 6): the lat-long convention, importance sampling against its
//! pdf (chi-square), the 4096-sample table as a quadrature (white furnace, sky irradiance vs a brute
//! force sum over texels), `B_e` of known spectra, the procedural maps, parameters and the scene's
//! background. Bad files are in `bad_input.rs`.

use std::f64::consts::PI;

use wedge_scene::environment::{bandwidth_99, luminance, TABLE_SIZE};
use wedge_scene::*;

/// splitmix64: deterministic uniforms for the tests.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn vec2(&mut self) -> Vec2 {
        Vec2::new(self.next() as f32, self.next() as f32)
    }
    fn dir(&mut self) -> Vec3 {
        let z = 1.0 - 2.0 * self.next();
        let phi = 2.0 * PI * self.next();
        let s = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, z as f32)
    }
}

fn constant(w: u32, value: f32) -> EnvironmentMap {
    EnvironmentMap::from_texels("constant", w, w / 2, vec![[value; 3]; (w * w / 2) as usize]).unwrap()
}

/// 32 × 16, dim sky (0.05) with five hot texels (100–5000) and one black row: a peaky distribution.
fn hot_texels() -> EnvironmentMap {
    let (w, h) = (32u32, 16u32);
    let mut t = vec![[0.05f32; 3]; (w * h) as usize];
    for (x, y, v) in [(3, 2, 5000.0), (17, 5, 800.0), (30, 9, 100.0), (0, 0, 300.0), (12, 15, 2000.0)] {
        t[(y * w + x) as usize] = [v, 0.5 * v, 0.25 * v];
    }
    for x in 0..w {
        t[(7 * w + x) as usize] = [0.0; 3];
    }
    EnvironmentMap::from_texels("hot", w, h, t).unwrap()
}

/// Irradiance on a plane with normal `n` by a sum over every texel (radiance × cos at the texel
/// centre × exact solid angle), subdivided `sub`² times per texel for the cosine.
fn brute_irradiance(env: &EnvironmentMap, n: Vec3, sub: usize) -> f64 {
    let (w, h) = (env.width() as usize, env.height() as usize);
    let mut e = 0.0f64;
    for k in 0..w * h {
        let l = env.texel_radiance(k);
        if l == Vec3::ZERO {
            continue;
        }
        let (x, y) = (k % w, k / w);
        let mut cos_sum = 0.0;
        // Equal-solid-angle sub-cells: uniform in cos θ and φ inside the texel.
        let (c0, c1) = ((PI * y as f64 / h as f64).cos(), (PI * (y + 1) as f64 / h as f64).cos());
        for sy in 0..sub {
            let c = c0 + (c1 - c0) * (sy as f64 + 0.5) / sub as f64;
            let v = c.clamp(-1.0, 1.0).acos() / PI;
            for sx in 0..sub {
                let u = (x as f64 + (sx as f64 + 0.5) / sub as f64) / w as f64;
                let d = env.direction_of(u as f32, v as f32);
                cos_sum += d.dot(n).max(0.0) as f64;
            }
        }
        e += luminance(l.to_array()) * cos_sum / (sub * sub) as f64 * env.texel_solid_angle(k);
    }
    e
}

/// The table's irradiance estimate: mean of lum(L)·max(cos, 0)/pdf over the 4096 entries.
fn table_irradiance(env: &EnvironmentMap, n: Vec3) -> f64 {
    let s: f64 = (0..TABLE_SIZE)
        .map(|i| {
            let t = env.table(i);
            luminance(t.radiance.to_array()) * t.dir.dot(n).max(0.0) as f64 / t.pdf as f64
        })
        .sum();
    s / TABLE_SIZE as f64
}

#[test]
fn column_at_u_half_faces_minus_z_and_u_three_quarters_plus_x() {
    let (w, h) = (64u32, 32u32);
    let column = |c: u32| {
        let mut t = vec![[0.0f32; 3]; (w * h) as usize];
        for y in 0..h {
            t[(y * w + c) as usize] = [1.0; 3];
        }
        EnvironmentMap::from_texels("column", w, h, t).unwrap()
    };
    let half = column(w / 2);
    let e = |env: &EnvironmentMap, n: Vec3| (brute_irradiance(env, n, 4), table_irradiance(env, n));
    let (minus_z, plus_z) = (e(&half, -Vec3::Z), e(&half, Vec3::Z));
    println!("u = 0.5 column: E(−Z) = {minus_z:?}, E(+Z) = {plus_z:?}");
    assert!(minus_z.0 > 0.05 && minus_z.1 > 0.05, "{minus_z:?}");
    assert_eq!(plus_z, (0.0, 0.0));
    // u = 0.75 faces +X.
    let q = column(3 * w / 4);
    assert!(e(&q, Vec3::X).0 > 0.05 && e(&q, -Vec3::X).0 == 0.0);
    // rotation_deg = 90 turns the −Z column toward −X (right-hand rule about +Y).
    let turned = column(w / 2).with_params(1.0, 90.0).unwrap();
    assert!(e(&turned, -Vec3::X).0 > 0.05 && e(&turned, Vec3::X).0 == 0.0 && e(&turned, -Vec3::Z).0 < 0.01);
    // Directions of named texels.
    let env = constant(64, 1.0);
    assert!(env.direction_of(0.5, 0.5).distance(-Vec3::Z) < 1e-6);
    assert!(env.direction_of(0.75, 0.5).distance(Vec3::X) < 1e-6);
    assert!(env.direction_of(0.25, 0.5).distance(-Vec3::X) < 1e-6);
    assert!(env.direction_of(0.0, 0.5).distance(Vec3::Z) < 1e-6);
    assert!(env.direction_of(0.3, 0.0).distance(Vec3::Y) < 1e-6);
    assert_eq!(env.texel_of(Vec3::Y).1, 0);
    assert_eq!(env.texel_of(-Vec3::Y).1, 31);
    assert_eq!(env.texel_of(Vec3::new(-0.01, 0.5, -1.0)), (31, 11));
    assert_eq!(env.texel_of(Vec3::new(0.01, 0.5, -1.0)), (32, 11));
}

/// `texel_of` (comparisons against boundary tables) against floor(uv · size) from atan2/acos: equal
/// except for directions within rounding of a boundary; at several rotations.
#[test]
fn texel_lookup_matches_atan2_acos_away_from_boundaries() {
    let mut rng = Rng(7);
    for rot in [0.0f32, 90.0, 33.3, -170.0, 725.0] {
        let env = EnvironmentMap::builtin("sky").unwrap().with_params(1.0, rot).unwrap();
        let (w, h) = (env.width() as f32, env.height() as f32);
        let (mut same, mut near, n) = (0, 0, 200_000);
        for _ in 0..n {
            let d = rng.dir() * (0.5 + rng.next() as f32);
            let uv = env.uv_of(d);
            let expect = (((uv.x * w) as u32).min(w as u32 - 1), ((uv.y * h) as u32).min(h as u32 - 1));
            let got = env.texel_of(d);
            if got == expect {
                same += 1;
            } else {
                let fx = (uv.x * w).fract().min(1.0 - (uv.x * w).fract());
                let fy = (uv.y * h).fract().min(1.0 - (uv.y * h).fract());
                assert!(fx < 1e-3 || fy < 1e-3, "rot {rot}: {d} uv {uv} expected {expect:?} got {got:?}");
                near += 1;
            }
        }
        println!("rotation {rot}: {same} of {n} equal, {near} differ within 1e-3 texel of a boundary");
        assert!(near * 10_000 <= n, "{near}");
    }
}

/// Chi-square statistic of observed vs expected counts (bins with expectation < 5 pooled) and its
/// degrees of freedom.
fn chi_square(observed: &[f64], expected: &[f64]) -> (f64, usize) {
    let (mut chi, mut dof) = (0.0, 0usize);
    let (mut po, mut pe) = (0.0, 0.0);
    for (&o, &e) in observed.iter().zip(expected) {
        if e < 5.0 {
            assert!(e > 0.0 || o == 0.0, "a sample fell where the pdf is zero");
            po += o;
            pe += e;
            continue;
        }
        chi += (o - e) * (o - e) / e;
        dof += 1;
    }
    if pe >= 5.0 {
        chi += (po - pe) * (po - pe) / pe;
        dof += 1;
    }
    (chi, dof.saturating_sub(1))
}

/// Upper critical value of χ²(dof) at p = 1e-4 (Wilson–Hilferty, z = 3.72).
fn chi_critical(dof: usize) -> f64 {
    let k = dof as f64;
    let z = 3.72;
    k * (1.0 - 2.0 / (9.0 * k) + z * (2.0 / (9.0 * k)).sqrt()).powi(3)
}

#[test]
fn sampling_passes_chi_square_against_pdf() {
    // Hot texels: the bins are the texels, whose probabilities are pdf × solid angle exactly.
    let env = hot_texels();
    let n = 400_000;
    let mut rng = Rng(11);
    let texels = (env.width() * env.height()) as usize;
    let mut observed = vec![0.0; texels];
    for _ in 0..n {
        let s = env.sample(rng.vec2());
        observed[s.texel as usize] += 1.0;
        assert!(s.pdf > 0.0);
    }
    let expected: Vec<f64> =
        (0..texels).map(|k| n as f64 * env.texel_pdf(k) as f64 * env.texel_solid_angle(k)).collect();
    let (chi, dof) = chi_square(&observed, &expected);
    println!("hot texels: chi² = {chi:.1}, dof {dof}, critical (p = 1e-4) {:.1}", chi_critical(dof));
    assert!(chi < chi_critical(dof));

    // The sky, rotated, binned on a 24 × 12 grid of the world sphere, equal steps of y and of the
    // azimuth ψ = atan2(−x, z) offset by 0.1 rad, so the bins do not line up with texel columns and
    // the within-texel placement is tested too. Texels and bins are rectangles in (y, ψ), where
    // dω = dy dψ and the pdf is constant per texel, so the expected counts are exact overlaps.
    let env = EnvironmentMap::builtin("sky").unwrap().with_params(2.0, 21.0).unwrap();
    let (bx, by) = (24usize, 12usize);
    let offset = 0.1f64;
    let tau = 2.0 * PI;
    let bin_of = |d: Vec3| {
        let psi = ((-d.x as f64).atan2(d.z as f64) - offset).rem_euclid(tau);
        let x = ((psi / tau * bx as f64) as usize).min(bx - 1);
        let y = (((1.0 - d.y as f64) * 0.5 * by as f64) as usize).min(by - 1);
        y * bx + x
    };
    let mut observed = vec![0.0; bx * by];
    for _ in 0..n {
        observed[bin_of(env.sample(rng.vec2()).dir)] += 1.0;
    }
    let mut expected = vec![0.0; bx * by];
    let (w, h) = (env.width() as usize, env.height() as usize);
    let rot = (env.rotation_deg() as f64).to_radians();
    let overlap = |a0: f64, a1: f64, b0: f64, b1: f64| (a1.min(b1) - a0.max(b0)).max(0.0);
    for k in 0..w * h {
        let (i, j) = (k % w, k / w);
        let p = env.texel_pdf(k) as f64;
        if p == 0.0 {
            continue;
        }
        let (y0, y1) = ((PI * (j + 1) as f64 / h as f64).cos(), (PI * j as f64 / h as f64).cos());
        // The texel's world azimuths, relative to the bins' origin, in [0, 2π) (maybe wrapping).
        let p0 = (tau * i as f64 / w as f64 - rot - offset).rem_euclid(tau);
        let p1 = p0 + tau / w as f64;
        for (b, e) in expected.iter_mut().enumerate() {
            let (x, y) = (b % bx, b / bx);
            let (by1, by0) = (1.0 - 2.0 * y as f64 / by as f64, 1.0 - 2.0 * (y + 1) as f64 / by as f64);
            let dy = overlap(y0, y1, by0, by1);
            if dy == 0.0 {
                continue;
            }
            let (bx0, bx1) = (tau * x as f64 / bx as f64, tau * (x + 1) as f64 / bx as f64);
            let dpsi = overlap(p0, p1, bx0, bx1) + overlap(p0 - tau, p1 - tau, bx0, bx1);
            *e += n as f64 * p * dy * dpsi;
        }
    }
    let (chi, dof) = chi_square(&observed, &expected);
    println!("sky: chi² = {chi:.1}, dof {dof}, critical (p = 1e-4) {:.1}", chi_critical(dof));
    assert!(chi < chi_critical(dof));
}

#[test]
fn pdf_integrates_to_one_and_sample_round_trips() {
    for env in
        [hot_texels(), EnvironmentMap::builtin("sky").unwrap().with_params(3.0, 47.0).unwrap(), constant(16, 0.0)]
    {
        let texels = (env.width() * env.height()) as usize;
        let exact: f64 = (0..texels).map(|k| env.texel_pdf(k) as f64 * env.texel_solid_angle(k)).sum();
        // ∫ pdf dω through pdf(dir) on a 2048 × 1024 equal-area grid of cell centres (uniform in y and
        // in azimuth; deterministic, so the sun's spike does not make it noisy).
        let (gx, gy) = (2048usize, 1024usize);
        let mut grid = 0.0f64;
        for y in 0..gy {
            let z = 1.0 - 2.0 * (y as f64 + 0.5) / gy as f64;
            let s = (1.0 - z * z).sqrt();
            for x in 0..gx {
                let phi = 2.0 * PI * (x as f64 + 0.5) / gx as f64;
                grid += env.pdf(Vec3::new((s * phi.cos()) as f32, z as f32, (s * phi.sin()) as f32)) as f64;
            }
        }
        let grid = grid * 4.0 * PI / (gx * gy) as f64;
        println!("{}: Σ pdf·Ω = {exact:.9}, ∫ pdf dω on a 2048 × 1024 grid = {grid:.5}", env.name());
        assert!((exact - 1.0).abs() < 1e-5, "{exact}");
        assert!((grid - 1.0).abs() < 0.01, "{grid}");
        let mut rng = Rng(3);
        let (mut same, m) = (0, 100_000);
        for _ in 0..m {
            let s = env.sample(rng.vec2());
            assert!((s.dir.length() - 1.0).abs() < 1e-5);
            if env.pdf(s.dir) == s.pdf && env.radiance(s.dir) == s.radiance {
                same += 1;
            }
        }
        println!("{}: {same} of {m} samples read back the same pdf and radiance", env.name());
        assert!(same * 1000 >= m * 999, "{same}");
    }
}

#[test]
fn zero_luminance_texels_are_never_sampled() {
    let env = hot_texels();
    let mut rng = Rng(5);
    for _ in 0..100_000 {
        let s = env.sample(rng.vec2());
        assert_ne!(s.texel / env.width(), 7, "row 7 is black");
        assert!(s.radiance.max_element() > 0.0);
    }
    for i in 0..TABLE_SIZE {
        assert!(env.table(i).radiance.max_element() > 0.0);
    }
}

/// White furnace: for a constant map L the table's irradiance estimate is πL for every normal.
#[test]
fn table_white_furnace() {
    let env = constant(512, 0.7);
    let mut worst = 0.0f64;
    for n in [
        Vec3::Y,
        -Vec3::Y,
        Vec3::X,
        -Vec3::Z,
        Vec3::new(0.3, 0.8, -0.5).normalize(),
        Vec3::new(-0.9, -0.1, 0.4).normalize(),
    ] {
        let e = table_irradiance(&env, n);
        let rel = (e / (PI * 0.7) - 1.0).abs();
        println!("furnace n = {n}: table E = {e:.6}, πL = {:.6}, relative error {rel:.2e}", PI * 0.7);
        worst = worst.max(rel);
    }
    assert!(worst < 2e-3, "{worst}");
}

/// The table's irradiance for the sky against a brute-force sum over every texel, a few normals.
#[test]
fn table_quadrature_of_the_sky() {
    let env = EnvironmentMap::builtin("sky").unwrap();
    let normals = [
        Vec3::Y,
        -Vec3::Z,
        Vec3::X,
        -Vec3::X,
        Vec3::Z,
        Vec3::new(0.4, 0.6, -0.7).normalize(),
        Vec3::new(0.0, -1.0, 0.0),
    ];
    let pairs: Vec<(f64, f64)> =
        normals.iter().map(|&n| (brute_irradiance(&env, n, 4), table_irradiance(&env, n))).collect();
    let e_max = pairs.iter().map(|p| p.0).fold(0.0, f64::max);
    let (mut sq, mut worst_rel, mut worst_abs) = (0.0, 0.0f64, 0.0f64);
    for (n, &(exact, table)) in normals.iter().zip(&pairs) {
        let rel = (table - exact).abs() / exact;
        let of_max = (table - exact).abs() / e_max;
        println!("sky n = {n}: brute force E = {exact:.5}, table E = {table:.5}, error {rel:.2e} of E, {of_max:.2e} of the largest E");
        sq += of_max * of_max;
        worst_abs = worst_abs.max(of_max);
        if n.y >= 0.0 {
            worst_rel = worst_rel.max(rel);
        }
    }
    println!(
        "sky: RMS error {:.2e} of the largest irradiance, worst {worst_abs:.2e}; worst relative error {worst_rel:.2e} on normals not facing the ground",
        (sq / normals.len() as f64).sqrt()
    );
    assert!(worst_abs < 3e-3, "{worst_abs}");
    assert!(worst_rel < 1e-2, "{worst_rel}");
}

#[test]
fn bandwidth_of_known_spectra() {
    let (w, h) = (256usize, 128usize);
    // A sinusoid of 8 cycles around the horizon: 8/(2π) cycles per radian.
    let around: Vec<f32> =
        (0..w * h).map(|k| 1.0 + 0.5 * (2.0 * PI * 8.0 * ((k % w) as f64 + 0.5) / w as f64).cos() as f32).collect();
    let b = bandwidth_99(&around, w, h);
    println!("8 cycles around: B_e = {b} (expected {})", 8.0 / (2.0 * PI));
    assert!((b as f64 - 8.0 / (2.0 * PI)).abs() < 1e-4);
    // 5 cycles from zenith to nadir (period H rows): 5/π cycles per radian.
    let down: Vec<f32> =
        (0..w * h).map(|k| 2.0 + (2.0 * PI * 5.0 * ((k / w) as f64 + 0.5) / h as f64).sin() as f32).collect();
    let b = bandwidth_99(&down, w, h);
    println!("5 cycles down: B_e = {b} (expected {})", 5.0 / PI);
    assert!((b as f64 - 5.0 / PI).abs() < 1e-4);
    // Both: the larger radius sqrt((8/2π)² + (5/π)²) if the diagonal term is the product.
    assert_eq!(constant(256, 3.0).bandwidth(), 0.0);
    // Through the map: the same as the free function on its luminance; independent of the parameters.
    let env =
        EnvironmentMap::from_texels("around", w as u32, h as u32, around.iter().map(|&v| [v; 3]).collect()).unwrap();
    assert!((env.bandwidth() as f64 - 8.0 / (2.0 * PI)).abs() < 1e-4);
    assert_eq!(env.clone().with_params(5.0, 30.0).unwrap().bandwidth(), env.bandwidth());
    let sky = EnvironmentMap::builtin("sky").unwrap();
    let studio = EnvironmentMap::builtin("studio").unwrap();
    println!("B_e: sky {} cycles/rad, studio {} cycles/rad", sky.bandwidth(), studio.bandwidth());
    assert!(sky.bandwidth() > 0.5 && sky.bandwidth().is_finite());
}

#[test]
fn procedural_sky_has_a_sun_thousands_of_times_the_sky() {
    let sky = EnvironmentMap::open("builtin:sky").unwrap();
    let again = EnvironmentMap::open("builtin:sky").unwrap();
    assert_eq!((sky.width(), sky.height()), (512, 256));
    assert_eq!(again.texels(), sky.texels());
    let sun = environment::sky_sun_direction();
    let zenith = sky.radiance(Vec3::Y);
    let sun_l = sky.radiance(sun);
    let ground = sky.radiance(-Vec3::Y);
    println!("sun {sun_l}, zenith {zenith}, ground {ground}");
    assert!(sun_l.x > 1000.0 * zenith.x);
    assert!(ground.max_element() < zenith.min_element());
    // Most of the table looks at the sun (it holds most of the light) but not all of it.
    let at_sun = (0..TABLE_SIZE).filter(|&i| sky.table(i).dir.dot(sun) > 0.999).count();
    println!("table entries within 2.6° of the sun: {at_sun} of {TABLE_SIZE}");
    assert!(at_sun > TABLE_SIZE / 4 && at_sun < TABLE_SIZE * 9 / 10);
    let studio = EnvironmentMap::open("builtin:studio").unwrap();
    assert_eq!((studio.width(), studio.height()), (256, 128));
    let e = EnvironmentMap::open("builtin:nope").unwrap_err().to_string();
    assert!(e.contains("builtin:nope") && e.contains("builtin:sky"), "{e}");
}

#[test]
fn scale_and_rotation_are_checked_and_applied() {
    let sky = EnvironmentMap::builtin("sky").unwrap();
    for (scale, rot) in [
        (0.0, 0.0),
        (-1.0, 0.0),
        (f32::NAN, 0.0),
        (f32::INFINITY, 0.0),
        (1e12, 0.0),
        (1.0, f32::NAN),
        (1.0, f32::INFINITY),
    ] {
        let e = sky.clone().with_params(scale, rot).unwrap_err().to_string();
        assert!(e.contains("builtin:sky"), "{e}");
    }
    let doubled = sky.clone().with_params(2.0, 0.0).unwrap();
    let d = Vec3::new(0.3, 0.5, -0.2);
    assert_eq!(doubled.radiance(d), sky.radiance(d) * 2.0);
    assert_eq!(doubled.pdf(d), sky.pdf(d));
    assert_eq!(doubled.table(17).radiance, sky.table(17).radiance * 2.0);
    assert_eq!(doubled.table(17).dir, sky.table(17).dir);
    // Rotating by 90° moves what was at −Z to −X; the same texel, the same pdf.
    let turned = sky.clone().with_params(1.0, 90.0).unwrap();
    let r = glam::Quat::from_rotation_y(90f32.to_radians());
    let mut rng = Rng(9);
    let mut same = 0;
    for _ in 0..10_000 {
        let d = rng.dir();
        same += (turned.texel_of(r * d) == sky.texel_of(d)) as usize;
    }
    assert!(same >= 9_990, "{same}");
    for i in (0..TABLE_SIZE).step_by(97) {
        assert!((turned.table(i).dir - r * sky.table(i).dir).length() < 1e-5);
        assert_eq!(turned.table(i).texel, sky.table(i).texel);
    }
}

#[test]
fn scene_background_is_the_map_and_bounds_ignore_it() {
    let mut scene = load(&SceneSource::Builtin("grids".into())).unwrap();
    let bounds = scene.bounds;
    let d = Vec3::new(0.2, 0.9, -0.3);
    assert_eq!(scene.background(d), Vec3::ZERO);
    let sky = EnvironmentMap::builtin("sky").unwrap();
    scene.set_environment(Some(sky.clone()));
    assert_eq!(scene.background(d), sky.radiance(d));
    assert_eq!(scene.bounds, bounds);
    scene.set_environment(None);
    assert!(scene.environment.is_none());
}

/// Timings of building the distribution, table and B_e (printed; `--nocapture`).
#[test]
fn build_timings() {
    // Generation + distribution + table + B_e of the built-ins (first use in this process only when
    // this test runs alone: `cargo test --release -p wedge-scene --test environment build_timings`).
    for name in ["sky", "studio"] {
        let t = std::time::Instant::now();
        let env = EnvironmentMap::builtin(name).unwrap();
        println!("builtin:{name} ({}x{}): {:?}", env.width(), env.height(), t.elapsed());
    }
    for (w, h) in [(512u32, 256u32), (2048, 1024)] {
        let texels: Vec<[f32; 3]> = (0..w * h).map(|k| [1.0 + (k % 7) as f32, 1.0, 0.5]).collect();
        let t = std::time::Instant::now();
        let env = EnvironmentMap::from_texels("timing", w, h, texels).unwrap();
        println!("{w}x{h}: distribution + table + B_e in {:?} ({} bytes)", t.elapsed(), env.bytes());
        let t = std::time::Instant::now();
        let _ = env.with_params(1.5, 30.0).unwrap();
        println!("{w}x{h}: new rotation + scale in {:?}", t.elapsed());
    }
}

#[test]
fn envmap_builtin_scene() {
    let scene = load(&SceneSource::Builtin("envmap".into())).unwrap();
    let env = scene.environment.as_ref().expect("envmap carries its map");
    assert_eq!(env.name(), "builtin:sky");
    assert!(scene.lights.is_empty(), "lit by the map only");
    let phong: Vec<f32> = scene.materials.iter().map(|m| m.phong_exponent).collect();
    assert!(phong.contains(&64.0) && phong.contains(&0.0), "{phong:?}");
    let names: Vec<&str> = scene.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["ground", "sphere", "torus"]);
    // Both objects rest on the plane (lowest vertex within a tessellation step of y = 0).
    for obj in 1..3u32 {
        let low = scene
            .triangles
            .iter()
            .zip(&scene.shading)
            .filter(|(_, s)| s.object == obj)
            .flat_map(|(t, _)| [t.v0[1], t.v1[1], t.v2[1]])
            .fold(f32::INFINITY, f32::min);
        assert!(low.abs() < 0.01, "object {obj}: lowest y {low}");
    }
    // Bounds hold the geometry only (the map is at infinity).
    assert!(scene.bounds.size().max_element() <= 40.0 + 1e-3);
    // Camera rays: most hit, the top rows see the map above the plane's far edge.
    let (w, h) = (64u32, 48u32);
    let (mut misses, mut top_misses) = (0, 0);
    for y in 0..h {
        for x in 0..w {
            let (o, d) = scene.camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5, w, h, Vec2::ZERO);
            if scene.intersect(o, d, 0.0, f32::INFINITY).is_none() {
                misses += 1;
                top_misses += (y < 4) as u32;
                assert!(scene.background(d).max_element() > 0.0);
            }
        }
    }
    println!("envmap: {misses} of {} camera rays miss (see the map), {top_misses} in the top 4 rows", w * h);
    assert!(misses > w * h / 20 && misses < w * h / 5);
    // The sun shadows: a point on the plane just beyond the sphere, away from the sun, cannot see it.
    let sun = environment::sky_sun_direction();
    let c = builtin::envmap::SPHERE_CENTRE;
    let behind = c - sun * (c.y / sun.y) + Vec3::Y * 1e-3;
    assert!(scene.occluded(behind, sun, 1e-4, f32::INFINITY));
    let lit = Vec3::new(-3.0, 1e-3, 2.0);
    assert!(!scene.occluded(lit, sun, 1e-4, f32::INFINITY));
    let with_light = load(&SceneSource::Builtin("envmap_light".into())).unwrap();
    assert_eq!(with_light.lights.len(), 1);
    assert!(with_light.environment.is_some());
}
