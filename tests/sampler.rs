//! The shared sampler on wedge's own kernels (`effects/src/sampler.rs`, `docs/SAMPLER-STAGE.md` §4),
//! through the default `SoftShadows` pipeline: the adaptive pass traces eq. 3.21's rays as paths of
//! `initial_rays` shadow rays, its reference converges to `direct.light`'s Monte Carlo with the same
//! form factor (the `exact` option of `paths.trace` included), SoftShadows and Indirect sharing it
//! each get exactly their own counts, and a pipeline without a node asking for it runs none of its
//! passes.

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
    eprintln!(
        "RMSE sampler vs direct.light: exact {:.6}, light_centre {:.6}; exact vs light_centre {across:.6}",
        d[0], d[1]
    );
    assert!(d[0] < 1.5e-3 && d[1] < 1.5e-3, "{d:?}");
    assert!(across > 3.0 * d[0].max(d[1]), "{across} vs {d:?}");
}

#[test]
fn shadow_rays_are_traced_in_paths_of_initial_rays() {
    let s = Session::open(None, &sized(SW, SH, None, &[])).unwrap();
    let r = run(&s);
    let wedge::backends::BufferData::U32(n) = r.output("rays_per_pixel").unwrap() else {
        panic!("rays_per_pixel is u32")
    };
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
    // Plain Monte Carlo baselines keep their own kernels.
    let text = r#"Pipeline(scene: "builtin:cornell", width: 16, height: 12, seed: 1, nodes: [
        (name: "primary", kind: "Primary"),
        (name: "mc", kind: "MonteCarlo", params: {"spp": 4, "light": -1, "bounces": 1},
         inputs: {"position": "primary.position", "normal": "primary.normal", "albedo": "primary.albedo", "emission": "primary.emission"}),
        (name: "out", kind: "Output", inputs: {"color": "mc.radiance"}),
    ])"#;
    let s = session_from_text(text, &Overrides::default());
    assert!(s.schedule.passes.iter().all(|p| !p.name.starts_with("sampler.")), "{}", s.schedule.table());
}

/// SoftShadows and/or Indirect (Ch. 3, Ch. 4) on `cornell`, sharing the sampler when both are in.
fn chapters_3_and_4(shadows: bool, indirect: bool) -> String {
    let mut nodes = vec![r#"(name: "primary", kind: "Primary")"#.to_string()];
    let g = r#""position": "primary.position", "normal": "primary.normal", "albedo": "primary.albedo""#;
    if shadows {
        nodes.push(format!(
            r#"(name: "shadows", kind: "SoftShadows", params: {{"mu": 2.0, "light": 0}}, inputs: {{{g}, "emission": "primary.emission"}})"#
        ));
        nodes.push(r#"(name: "shadow_rays", kind: "Heatmap", inputs: {"count": "shadows.rays_per_pixel"})"#.into());
    }
    if indirect {
        nodes.push(format!(
            r#"(name: "indirect", kind: "Indirect", params: {{"bounces": 1}}, inputs: {{{g}, "specular": "primary.specular"}})"#
        ));
        nodes.push(r#"(name: "indirect_rays", kind: "Heatmap", inputs: {"count": "indirect.rays_per_pixel"})"#.into());
    }
    let color = match (shadows, indirect) {
        (true, true) => {
            nodes.push(
                r#"(name: "sum", kind: "Add", inputs: {"a": "shadows.radiance", "b": "indirect.radiance"})"#.into(),
            );
            "sum.radiance"
        }
        (true, false) => "shadows.radiance",
        _ => "indirect.radiance",
    };
    let mut sinks = format!(r#""color": "{color}""#);
    if shadows && indirect {
        sinks += r#", "unfiltered": "shadows.radiance", "rays_per_pixel": "indirect.rays_per_pixel""#;
    }
    nodes.push(format!(r#"(name: "out", kind: "Output", inputs: {{{sinks}}})"#));
    format!(r#"Pipeline(scene: "builtin:cornell", width: {SW}, height: {SH}, seed: 7, nodes: [{}])"#, nodes.join(",\n"))
}

#[test]
fn two_nodes_on_the_sampler_trace_exactly_their_own_counts() {
    // One pipeline with both nodes and one with each alone: the shared sampler splits each count
    // channel's total over the pixel's paths (SAMPLER-STAGE.md "Samples, not paths"), so the
    // shadow rays and hemisphere rays of the pair are exactly the sums of the single-node runs'
    // (the rates come from the same first pass; the samples continue the same sequences) — counts
    // do not multiply — and SoftShadows' image is the same up to float regrouping (its samples are
    // summed per path, and the pair splits them over more paths).
    let go = |shadows, indirect| {
        let s = session_from_text(&chapters_3_and_4(shadows, indirect), &Overrides::default());
        let r = run(&s);
        (r, s)
    };
    let (both, s_both) = go(true, true);
    let (alone_s, s_s) = go(true, false);
    let (alone_i, _) = go(false, true);
    assert_eq!(both.rays.shadow_rays, alone_s.rays.shadow_rays + alone_i.rays.shadow_rays, "{:?}", both.rays);
    assert_eq!(both.rays.secondary_rays, alone_i.rays.secondary_rays, "{:?}", both.rays);
    assert!(
        alone_i.rays.secondary_rays > 16 * u64::from(SW * SH) / 2,
        "Indirect traced its hemisphere rays: {:?}",
        alone_i.rays
    );
    let counts = |r: &wedge::backends::RunResult, sink: &str| match &r.outputs[&(sink.to_string(), "count".to_string())]
    {
        wedge::backends::BufferData::U32(v) => v.clone(),
        _ => panic!("{sink} is a u32 count"),
    };
    assert_eq!(counts(&both, "shadow_rays"), counts(&alone_s, "shadow_rays"));
    assert_eq!(counts(&both, "indirect_rays"), counts(&alone_i, "indirect_rays"));
    let shadows_in_both =
        wedge::outputs::buffer_to_image(both.output("unfiltered").unwrap(), s_both.width, s_both.height);
    let alone = color(&s_s, &alone_s);
    let worst = shadows_in_both
        .pixels
        .iter()
        .zip(&alone.pixels)
        .flat_map(|(a, b)| a.iter().zip(b))
        .map(|(a, b)| (a - b).abs() / b.abs().max(1e-3))
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-4, "largest relative difference {worst}");
}
