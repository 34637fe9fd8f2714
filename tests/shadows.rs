//! End-to-end checks of the SoftShadows node on the built-in `grids` scene (thesis Fig. 3.6):
//! consistency as μ grows, and the gain over independent and stratified Monte Carlo at equal rays.

mod common;

use common::*;
use wedge::graph::ParamValue;

/// Converged stratified references at the two test sizes (their own error is far below what the
/// tests compare: stratified light sampling converges faster than 1/sqrt(spp) on soft shadows).
fn reference() -> &'static wedge::image::Image {
    static REF: std::sync::OnceLock<wedge::image::Image> = std::sync::OnceLock::new();
    REF.get_or_init(|| monte_carlo(4096, "stratified").0)
}

fn quality_reference() -> &'static wedge::image::Image {
    static REF: std::sync::OnceLock<wedge::image::Image> = std::sync::OnceLock::new();
    REF.get_or_init(|| monte_carlo_at(2048, "stratified", QW, QH).0)
}

#[test]
fn error_falls_as_mu_grows() {
    let reference = reference();
    let mut last = f64::INFINITY;
    let mut errors = Vec::new();
    for mu in [1.0, 2.0, 4.0, 8.0] {
        let (img, run) = shadows(mu, &[]);
        let e = rmse(&img, reference);
        errors.push((mu, e, shadow_rpp(&run, W, H)));
        assert!(e < last, "RMSE must fall as mu grows: {errors:?}");
        last = e;
    }
    eprintln!("mu, RMSE, shadow rays/pixel: {errors:?}");
}

#[test]
fn beats_monte_carlo_at_equal_rays() {
    let reference = quality_reference();
    let (aaf, run) = shadows_at(&sized(QW, QH, None, &[]));
    let rpp = shadow_rpp(&run, QW, QH);
    let spp = rpp.round().max(1.0) as u32;
    let e_aaf = rmse(&aaf, reference);
    let (ind, ind_run) = monte_carlo_at(spp, "independent", QW, QH);
    let (strat, _) = monte_carlo_at(spp, "stratified", QW, QH);
    let e_ind = rmse(&ind, reference);
    let e_strat = rmse(&strat, reference);
    eprintln!(
        "avg shadow rays/pixel {rpp:.2} (MC at {spp}, {:.2}): RMSE AAF {e_aaf:.5}, independent {e_ind:.5} ({:.2}x), stratified {e_strat:.5} ({:.2}x)",
        shadow_rpp(&ind_run, QW, QH),
        e_ind / e_aaf,
        e_strat / e_aaf
    );
    assert!(e_ind >= 2.5 * e_aaf, "AAF must have >= 2.5x lower RMSE than independent MC: {e_aaf} vs {e_ind}");
    assert!(e_strat > e_aaf, "AAF must beat stratified MC at equal rays: {e_aaf} vs {e_strat}");
}

#[test]
fn same_image_for_one_and_two_threads() {
    let render = |threads| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| shadows(2.0, &[]).0)
    };
    let a = render(1);
    let b = render(2);
    assert_eq!(a.pixels.len(), (W * H) as usize);
    assert!(a.pixels.iter().zip(&b.pixels).all(|(x, y)| x.iter().zip(y).all(|(u, v)| u.to_bits() == v.to_bits())));
}

#[test]
fn huge_mu_gives_the_unfiltered_image() {
    // μ → ∞ shrinks every filter to one pixel: with the sampled irradiance the output equals the
    // adaptive-sampled input bit for bit. (The analytic default then gives each pixel its own ratio
    // estimate r(x)·E/U, consistent as the samples grow: `error_falls_as_mu_grows`.)
    let sampled = ("shadows", "irradiance", ParamValue::Str("sampled".into()));
    let s = wedge::Session::open(None, &overrides(Some(1e6), &[("shadows", "rays_cap", ParamValue::Int(16)), sampled]))
        .unwrap();
    let r = run(&s);
    let out = color(&s, &r);
    let unfiltered = wedge::outputs::buffer_to_image(r.output("unfiltered").unwrap(), W, H);
    assert_eq!(out, unfiltered);
}

#[test]
fn analytic_irradiance_is_exact_where_nothing_occludes() {
    // A ground lit by a 1 m light 2 m up, nothing in between: every shadow ray is unblocked, so the
    // ratio E/U is exactly 1 and each pixel is albedo · r(x) with r the closed-form irradiance — no
    // noise at 8 rays per pixel, where stratified Monte Carlo still has the geometry term's variance
    // (the unoccluded error that dominated `suite_contact`, `suite_glossy`, `cornell`, `suite_room`).
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("ground.obj"), "v -5 0 -5\nv 5 0 -5\nv 5 0 5\nv -5 0 5\nf 1 3 2\nf 1 4 3\n")
        .unwrap();
    let scene = dir.path().join("lit.ron");
    std::fs::write(
        &scene,
        r#"Scene(meshes: [(path: "ground.obj")],
            lights: [Rect(corner: (-0.5, 2, -0.5), edge_u: (1, 0, 0), edge_v: (0, 0, 1), radiance: (10, 10, 10))],
            camera: Some((position: (0, 1.5, 3), look_at: (0, 0, 0), vfov_deg: 40)))"#,
    )
    .unwrap();
    let ov = || wedge::Overrides { scene: Some(scene.display().to_string()), ..sized(64, 48, None, &[]) };
    let s = wedge::Session::open(None, &ov()).unwrap();
    let r = run(&s);
    let out = color(&s, &r);
    let light = s.scene.lights[0];
    let (mut worst, mut lit) = (0.0f64, 0);
    for y in 0..48 {
        for x in 0..64 {
            let (o, d) = s.scene.camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5, 64, 48, glam::Vec2::splat(0.5));
            let Some(hit) = s.scene.intersect(o, d, 0.0, f32::INFINITY) else { continue };
            let p = o + d * hit.t;
            let expected = 0.8 * light.irradiance_unoccluded(p, glam::Vec3::Y).x as f64 / std::f64::consts::PI;
            let got = out.pixels[(y * 64 + x) as usize][0] as f64;
            worst = worst.max((got - expected).abs() / expected);
            lit += 1;
        }
    }
    let rays = shadow_rpp(&r, 64, 48);
    let mc = wedge::Session::reference(None, rays.round() as u32, "stratified", &ov()).unwrap();
    let mc_img = color(&mc, &run(&mc));
    let mc_err =
        rmse(&mc_img, &out) / (out.luminance().iter().map(|&v| v as f64).sum::<f64>() / out.pixels.len() as f64);
    println!("{lit} lit pixels at {rays:.1} rays/px: largest relative error {worst:.2e}; stratified MC at equal rays {mc_err:.2e} (relative RMSE)");
    assert!(lit > 64 * 48 / 2);
    assert!(worst < 1e-4, "{worst}");
    assert!(mc_err > 100.0 * worst, "{mc_err} vs {worst}");
}

/// Issue 38 §2: a CPU backend kept across frames recycles its pool — the in-place G-buffer pass
/// allocates nothing on a second frame — and renders what a fresh backend per frame renders.
#[test]
fn persistent_cpu_backend_reuses_its_pool() {
    use wedge::backends::cpu::CpuBackend;
    use wedge::backends::Silent;
    let ov = sized(32, 24, None, &[]);
    let gbuffer = session_from_text(
        r#"Pipeline(scene: "builtin:grids", width: 32, height: 24, seed: 1, nodes: [
            (name: "primary", kind: "Primary"),
            (name: "out", kind: "Output", inputs: {"color": "primary.albedo"}),
        ])"#,
        &ov,
    );
    let mut backend = CpuBackend::new();
    let first = gbuffer.run(&mut backend, &Silent).expect("first frame");
    let second = gbuffer.run(&mut backend, &Silent).expect("second frame");
    assert!(first.allocations > 0, "a first frame allocates its buffers");
    assert_eq!(second.allocations, 0, "a second frame of in-place kernels allocates nothing");
    assert_eq!(first.outputs, second.outputs);
    // The default pipeline over frames (kernels writing in place and others): the same images as a
    // fresh backend, with fewer buffers allocated after the first frame.
    let mut session = wedge::Session::open(None, &ov).expect("default pipeline");
    let (mut kept, mut fresh, mut backend) = (None, None, CpuBackend::new());
    for frame in 0..3 {
        let a = session.run_frame(&mut backend, &Silent, frame, 0, kept.as_ref()).expect("kept backend");
        let b = session.run_frame(&mut CpuBackend::new(), &Silent, frame, 0, fresh.as_ref()).expect("fresh");
        assert_eq!(a.outputs, b.outputs, "frame {frame}");
        if frame > 0 {
            assert!(a.allocations < b.allocations, "frame {frame}: {} vs {}", a.allocations, b.allocations);
        }
        (kept, fresh) = (Some(a), Some(b));
    }
}
