//! References from the same graph (`wedge_graph::reference`, `Session::reference`): every shipped
//! pipeline's reference is its own graph with the filters bypassed, the counts constant and every
//! sampling pass at the reference's count; `--set` overrides reach it; a stratified reference is N
//! jointly stratified samples drawn by one pass.

mod common;

use std::path::PathBuf;

use common::*;
use wedge::graph::{ParamValue, Stage, FILL_CONSTANT};
use wedge::Session;

fn pipelines() -> Vec<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("pipelines");
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "ron"))
        .collect();
    v.sort();
    assert!(v.len() >= 4, "{v:?}");
    v
}

#[test]
fn every_pipeline_reference_is_its_graph_without_filters() {
    for path in pipelines() {
        let s = Session::reference(Some(&path), 64, "independent", &sized(16, 12, None, &[])).unwrap();
        let name = path.display();
        assert!(
            s.schedule.passes.iter().all(|p| p.stage != Stage::Filter),
            "{name}: a filter ran\n{}",
            s.schedule.table()
        );
        for p in &s.schedule.passes {
            if p.random {
                let count = &p.params["count"];
                assert!(
                    *count == ParamValue::Int(64)
                        || (*count == ParamValue::Int(0)
                            && (p.name.ends_with("sample_initial") || p.name == "sampler.first")),
                    "{name}: {} count {count:?}",
                    p.name
                );
                assert_eq!(p.params["sampling"], ParamValue::Str("independent".into()), "{name}: {}", p.name);
            }
            if p.kernel == FILL_CONSTANT {
                // The shared sampler's paths and every channel's samples over them are N in a
                // reference: N paths, one shadow ray / hemisphere sample each (SAMPLER-STAGE.md §4).
                // Ch. 5's factoring flags are 0 (`Reference::Fill(0)`): a reference composes L; so is
                // Defocus's risk-based choice of screen filter (both filters are bypassed).
                let decision = p.name.ends_with("_flag") || p.name.ends_with(".risk_choice");
                let want = if decision { 0 } else { 64 };
                assert_eq!(p.params["value"], ParamValue::Int(want), "{name}: {}", p.name);
            }
        }
        let adaptive = s.schedule.passes.iter().any(|p| p.stage == Stage::Adaptive);
        let fills = s.schedule.passes.iter().filter(|p| p.kernel == FILL_CONSTANT).count();
        assert_eq!(adaptive, fills > 0, "{name}: adaptive passes read constant counts");
        let ports: Vec<&str> = s.schedule.sink_inputs.iter().map(|(_, p, _)| p.as_str()).collect();
        assert!(
            ports.contains(&"color") && !ports.contains(&"filter_width") && !ports.contains(&"rays_per_pixel"),
            "{name}: {ports:?}"
        );
        // Nothing only the filters needed is left: no bandwidth kernel runs.
        assert!(s.schedule.passes.iter().all(|p| !p.kernel.ends_with(".bandwidth")), "{name}\n{}", s.schedule.table());
    }
}

#[test]
fn a_stratified_reference_draws_all_n_samples_in_one_pass() {
    // grids has one area light: N shadow rays per covered pixel, all from the shared sampler's
    // adaptive pass (N paths of one shadow ray; the first pass takes none), so the pattern spans
    // all N (not 9 + a separate N − 9).
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("pipelines/shadows.ron");
    let ov = sized(32, 24, None, &[]);
    let rays = |spp: u32| {
        let s = Session::reference(Some(&path), spp, "stratified", &ov).unwrap();
        let first = s.schedule.passes.iter().find(|p| p.name == "sampler.first").unwrap();
        assert_eq!(first.params["count"], ParamValue::Int(0));
        run(&s).rays.shadow_rays
    };
    let one = rays(1);
    assert!(one > 0);
    assert_eq!(rays(37), 37 * one);
}

#[test]
fn set_overrides_reach_the_reference() {
    // `wedge reference --set indirect.bounces=3 pipelines/indirect.ron`: the template could not.
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("pipelines/indirect.ron");
    let secondary = |bounces: i64| {
        let ov = sized(16, 12, None, &[("indirect", "bounces", ParamValue::Int(bounces))]);
        let s = Session::reference(Some(&path), 4, "stratified", &ov).unwrap();
        let p = s.schedule.passes.iter().find(|p| p.name == "sampler.adaptive").unwrap();
        assert_eq!(p.params["bounces"], ParamValue::Int(bounces));
        run(&s).rays.secondary_rays
    };
    let (one, three) = (secondary(1), secondary(3));
    assert!(three > 2 * one, "3 bounces trace more: {one} vs {three}");
}

#[test]
fn stratified_reference_beats_independent_at_equal_samples() {
    // Same estimator, same count: stratification must lower the error against a converged reference.
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("pipelines/shadows.ron");
    let ov = sized(48, 36, None, &[]);
    let image = |spp, sampling: &str, seed| {
        let s = Session::reference(Some(&path), spp, sampling, &wedge::Overrides { seed: Some(seed), ..ov.clone() })
            .unwrap();
        let r = run(&s);
        color(&s, &r)
    };
    let converged = image(2048, "stratified", 7);
    let (strat, ind) = (rmse(&image(64, "stratified", 1), &converged), rmse(&image(64, "independent", 1), &converged));
    assert!(strat < 0.7 * ind, "stratified {strat} vs independent {ind}");
}

/// An adaptive Environment node's bandwidth pass writes its look-up counts beside its filter widths:
/// its reference fills the counts with N and keeps the pass for its other outputs, and is the same
/// plain Monte Carlo image as the non-adaptive node's (the counts were all that differed).
#[test]
fn a_count_pass_with_other_outputs_keeps_them_and_its_reference_is_plain_mc() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("pipelines/environment.ron");
    let image = |adaptive: &str| {
        let ov = sized(24, 18, None, &[("env", "adaptive", ParamValue::Str(adaptive.into()))]);
        // This failed with "count or fill pass `env.bandwidth` writes `bandwidth` as f32".
        let s = Session::reference(Some(&path), 8, "stratified", &ov).unwrap();
        run(&s).output("color").cloned().expect("a colour output")
    };
    let fixed = image("off");
    assert_eq!(image("all"), fixed);
    assert_eq!(image("glossy"), fixed);
}

/// `render --unfiltered` (`wedge_graph::unfiltered`): every shipped pipeline without its filter
/// passes and with every other pass as the render has it (sampling passes at their counts, count and
/// decision passes) — only what a filter alone read may be culled (PixelFilter's `range` pass); on `shadows.ron`, whose node hands
/// out its pre-filter image, the two agree bit for bit.
#[test]
fn unfiltered_is_the_render_without_its_filter_passes() {
    use wedge::graph::Reference;
    let passes = |s: &Session| -> Vec<(String, String)> {
        s.schedule.passes.iter().map(|p| (p.name.clone(), format!("{:?}", p.params))).collect()
    };
    for path in pipelines() {
        let ov = sized(16, 12, None, &[]);
        let render = Session::open(Some(&path), &ov).unwrap();
        let bare = Session::open(Some(&path), &wedge::Overrides { unfiltered: true, ..ov }).unwrap();
        let name = path.display();
        let (all, without) = (passes(&render), passes(&bare));
        assert!(
            bare.schedule.passes.iter().all(|p| !matches!(p.reference, Reference::Bypass { .. })),
            "{name}: a filter ran\n{}",
            bare.schedule.table()
        );
        assert!(without.iter().all(|p| all.contains(p)), "{name}: a pass changed\n{without:?}\nvs {all:?}");
        assert!(bare.schedule.passes.iter().any(|p| p.random), "{name}: nothing samples");
    }
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("pipelines/shadows.ron");
    let ov = sized(32, 24, None, &[]);
    let render = Session::open(Some(&path), &ov).unwrap();
    let bare = Session::open(Some(&path), &wedge::Overrides { unfiltered: true, ..ov }).unwrap();
    let unfiltered = wedge::outputs::buffer_to_image(run(&render).output("unfiltered").unwrap(), 32, 24);
    assert_eq!(unfiltered.pixels, color(&bare, &run(&bare)).pixels, "shadows.ron");
}
