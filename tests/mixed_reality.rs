//! The `MixedReality` node end to end (thesis Ch. 6.3–6.5, Algorithm 1; `effects/src/mixed_reality.rs`,
//! `docs/DESIGN-NOTES.md` "Mixed reality"): without virtual influence the composite is the camera image
//! bit for bit; the round trip against a full render of real + virtual scenes; convergence of the
//! filtered composite to the unfiltered one as μ grows; the screen-space tracer against the BVH; and
//! bad input.

mod common;

use std::path::Path;

use common::*;
use wedge::backends::cpu::CpuBackend;
use wedge::backends::{RunResult, Silent};
use wedge::graph::parse_pipeline;
use wedge::image::Image;
use wedge::outputs::buffer_to_image;
use wedge::{Overrides, Session};

const W: u32 = 64;
const H: u32 = 48;

fn build(text: &str) -> Result<Session, String> {
    let loaded = parse_pipeline(Path::new("test.ron"), text).map_err(|e| e.to_string())?;
    let (nodes, kernels) = wedge::effects::builtin();
    Session::build(loaded, &Overrides::default(), nodes, kernels).map_err(|e| e.to_string())
}

fn run_cpu(s: &Session) -> RunResult {
    s.run(&mut CpuBackend::new(), &Silent).expect("run")
}

fn output(s: &Session, r: &RunResult, name: &str) -> Image {
    buffer_to_image(r.output(name).expect("output"), s.width, s.height)
}

/// A MixedReality pipeline: virtual scene `scene`, the real world captured from `real` at `spp`.
fn mr(scene: &str, real: &str, spp: u32, params: &str) -> String {
    format!(
        r#"Pipeline(scene: "{scene}", width: {W}, height: {H}, seed: 3, nodes: [
            (name: "mr", kind: "MixedReality", params: {{"capture": "{real}", "capture_spp": {spp}, {params}}}),
            (name: "out", kind: "Output", inputs: {{"color": "mr.radiance", "unfiltered": "mr.unfiltered"}}),
        ])"#
    )
}

fn mean(img: &Image) -> f64 {
    img.luminance().iter().map(|&v| v as f64).sum::<f64>() / img.luminance().len() as f64
}

/// The camera image of the session's real layer, as an image.
fn camera_image(s: &Session) -> Image {
    let layer = s.scene.real.as_ref().expect("a real layer");
    Image::from_fn(s.width, s.height, |x, y| layer.camera(x, y).to_array())
}

#[test]
fn a_virtual_object_without_influence_leaves_the_camera_image_exact() {
    // The virtual torus far below the ground (`envmap_far`): no camera ray, shadow ray or
    // reflection reaches it, so E_RV = E_R sample by sample, the filters see equal inputs, the ratio
    // is exactly 1 and every pixel keeps L_cam bit for bit.
    let s = build(&mr("builtin:envmap_far", "builtin:envmap_real", 16, "\"mu\": 1")).unwrap();
    let r = run_cpu(&s);
    let (out, cam) = (output(&s, &r, "color"), camera_image(&s));
    let differ = out.pixels.iter().zip(&cam.pixels).filter(|(a, b)| a.iter().zip(b.iter()).any(|(x, y)| x.to_bits() != y.to_bits())).count();
    println!("pixels that differ from L_cam: {differ} of {}", out.pixels.len());
    assert_eq!(differ, 0);
}

#[test]
fn the_round_trip_matches_a_render_of_both_worlds() {
    // Real = envmap without the torus, captured by wedge; virtual = the torus; the composite against
    // a render of the whole envmap scene, both at the same sample count.
    let spp = 256;
    let s = build(&mr("builtin:envmap_virtual", "builtin:envmap_real", spp, "\"primary\": 4, \"per_primary\": 16")).unwrap();
    let r = run_cpu(&s);
    let composite = output(&s, &r, "unfiltered");
    let full = format!(
        r#"Pipeline(scene: "builtin:envmap", width: {W}, height: {H}, seed: 3, nodes: [
            (name: "env", kind: "Environment", params: {{"indirect": true}}),
            (name: "out", kind: "Output", inputs: {{"color": "env.radiance"}}),
        ])"#
    );
    let loaded = parse_pipeline(Path::new("full.ron"), &full).unwrap();
    let (nodes, kernels) = wedge::effects::builtin();
    let f = Session::build_reference(loaded, &Overrides::default(), nodes, kernels, spp, "stratified").unwrap();
    let truth = output(&f, &run_cpu(&f), "color");
    let rel = rmse(&composite, &truth) / mean(&truth);
    println!("composite mean {:.4} vs full render {:.4}; RMSE / mean {rel:.4}", mean(&composite), mean(&truth));
    assert!((mean(&composite) / mean(&truth) - 1.0).abs() < 0.03, "{} vs {}", mean(&composite), mean(&truth));
    assert!(rel < 0.25, "{rel}");
}

#[test]
fn filtered_converges_to_unfiltered_as_mu_grows() {
    let mut last = f64::INFINITY;
    for mu in [1.0, 30.0, 1e4] {
        let s = build(&mr("builtin:envmap_virtual", "builtin:envmap_real", 16, &format!("\"mu\": {mu}"))).unwrap();
        let r = run_cpu(&s);
        let e = rmse(&output(&s, &r, "color"), &output(&s, &r, "unfiltered"));
        println!("mu {mu}: RMSE(filtered, unfiltered) {e:.4e}");
        assert!(e < last, "mu {mu}: {e} >= {last}");
        last = e;
    }
    assert!(last < 1e-3, "{last}");
}

#[test]
fn bad_inputs_are_clear_errors() {
    let none = r#"Pipeline(scene: "builtin:envmap_virtual", width: 64, height: 48, nodes: [
        (name: "mr", kind: "MixedReality", params: {"position_map": "p.exr"}),
        (name: "out", kind: "Output", inputs: {"color": "mr.radiance"}),
    ])"#;
    let e = build(none).err().expect("refused");
    println!("{e}");
    assert!(e.contains("camera_image") && e.contains("normal_map") && e.contains("capture"), "{e}");
    let both = r#"Pipeline(scene: "builtin:envmap_virtual", width: 64, height: 48, nodes: [
        (name: "mr", kind: "MixedReality", params: {"capture": "builtin:envmap_real", "camera_image": "c.exr"}),
        (name: "out", kind: "Output", inputs: {"color": "mr.radiance"}),
    ])"#;
    let e = build(both).err().expect("refused");
    println!("{e}");
    assert!(e.contains("either `capture` or the maps") && e.contains("camera_image"), "{e}");
    let missing = r#"Pipeline(scene: "builtin:envmap_virtual", width: 64, height: 48, nodes: [
        (name: "mr", kind: "MixedReality", params: {"camera_image": "nope.exr", "position_map": "p.exr", "normal_map": "n.exr"}),
        (name: "out", kind: "Output", inputs: {"color": "mr.radiance"}),
    ])"#;
    let e = build(missing).err().expect("refused");
    println!("{e}");
    assert!(e.contains("nope.exr"), "{e}");
}
