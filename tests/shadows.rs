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
        let (img, run) = shadows(mu, &[("shadows", "max_rays", ParamValue::Int(4096))]);
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
    // μ → ∞ shrinks every filter to one pixel: the output equals the adaptive-sampled input.
    let s = wedge::Session::open(None, &overrides(Some(1e6), &[("shadows", "max_rays", ParamValue::Int(16))])).unwrap();
    let r = run(&s);
    let out = color(&s, &r);
    let unfiltered = wedge::outputs::buffer_to_image(r.output("unfiltered").unwrap(), W, H);
    assert_eq!(out, unfiltered);
}
