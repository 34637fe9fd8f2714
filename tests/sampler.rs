//! The shared sampler on wedge's own kernels (`effects/src/sampler.rs`, `docs/SAMPLER-STAGE.md` §4),
//! through the default `SoftShadows` pipeline: the adaptive pass traces eq. 3.21's rays as paths of
//! `initial_rays` shadow rays, its reference converges to `direct.light`'s Monte Carlo with the same
//! form factor (the `exact` option of `paths.trace` included), and a pipeline without a node asking
//! for it runs none of its passes.

mod common;

use common::*;
use wedge::graph::ParamValue;
use wedge::{Overrides, Session};

const SW: u32 = 48;
const SH: u32 = 36;

/// `MonteCarlo` (`direct.light`) of the default pipeline's scene and light at `spp`.
fn direct_light_mc(spp: u32, form_factor: &str) -> wedge::image::Image {
    let text = format!(
        r#"Pipeline(scene: "builtin:grids", width: {SW}, height: {SH}, seed: 5, nodes: [
            (name: "primary", kind: "Primary"),
            (name: "mc", kind: "MonteCarlo", params: {{"spp": {spp}, "light": 0, "form_factor": "{form_factor}"}},
             inputs: {{"position": "primary.position", "normal": "primary.normal", "albedo": "primary.albedo", "emission": "primary.emission"}}),
            (name: "out", kind: "Output", inputs: {{"color": "mc.radiance"}}),
        ])"#
    );
    let s = session_from_text(&text, &Overrides::default());
    let r = run(&s);
    color(&s, &r)
}

fn sampler_reference(spp: u32, form_factor: &str) -> wedge::image::Image {
    let ov = sized(SW, SH, None, &[("shadows", "form_factor", ParamValue::Str(form_factor.into()))]);
    let s = Session::reference(None, spp, "stratified", &ov).unwrap();
    let r = run(&s);
    color(&s, &r)
}

#[test]
fn reference_matches_direct_light_for_both_form_factors() {
    // Same estimator, two samplers (Sobol' paths vs direct.light's stratified samples): at 1024
    // samples both are within noise of each other; the two form factors differ by more (f_c is the
    // thesis's light-centre approximation), so each option really reaches paths.trace.
    let mut d = Vec::new();
    for ff in ["exact", "light_centre"] {
        let (a, b) = (sampler_reference(1024, ff), direct_light_mc(1024, ff));
        d.push(rmse(&a, &b));
    }
    let across = rmse(&sampler_reference(1024, "exact"), &direct_light_mc(1024, "light_centre"));
    eprintln!("RMSE sampler vs direct.light: exact {:.6}, light_centre {:.6}; exact vs light_centre {across:.6}", d[0], d[1]);
    assert!(d[0] < 1.5e-3 && d[1] < 1.5e-3, "{d:?}");
    assert!(across > 3.0 * d[0].max(d[1]), "{across} vs {d:?}");
}

#[test]
fn shadow_rays_are_traced_in_paths_of_initial_rays() {
    let s = Session::open(None, &sized(SW, SH, None, &[])).unwrap();
    let r = run(&s);
    let wedge::backends::BufferData::U32(n) = r.output("rays_per_pixel").unwrap() else { panic!("rays_per_pixel is u32") };
    // SoftShadows' default `initial_rays`: the shadow rays of one path.
    const PER_PATH: u32 = 8;
    // ceil(n / 8) sampler paths per pixel (1 in the first pass), all through the pixel centre of a
    // pinhole camera: the sampler traces that camera ray once per pixel and pass, so the primary
    // rays are one G-buffer ray, one first-pass ray, and one adaptive-pass ray where it adds paths.
    let paths: u64 = n.iter().map(|&n| u64::from(n.div_ceil(PER_PATH).max(1))).sum();
    assert!(n.iter().all(|&n| (PER_PATH..=400).contains(&n)));
    let adaptive_pixels = n.iter().filter(|&&n| n.div_ceil(PER_PATH) > 1).count() as u64;
    assert_eq!(r.rays.primary_rays, 2 * u64::from(SW * SH) + adaptive_pixels);
    // Every path that hits carries exactly 8 shadow rays; background paths carry none.
    let per_path = u64::from(PER_PATH);
    assert_eq!(r.rays.shadow_rays % per_path, 0);
    assert!(r.rays.shadow_rays <= per_path * paths && r.rays.shadow_rays >= per_path * paths / 2, "{:?}", r.rays);
    assert_eq!(r.rays.secondary_rays, 0, "no node asked for the hemisphere estimator");
}

#[test]
fn a_pipeline_without_sampler_users_runs_none_of_its_passes() {
    let path = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("pipelines/indirect.ron");
    let s = Session::open(Some(&path), &sized(16, 12, None, &[])).unwrap();
    assert!(s.schedule.passes.iter().all(|p| !p.name.starts_with("sampler.")), "{}", s.schedule.table());
}
