//! The `MixedReality` node end to end (thesis Ch. 6.3–6.5, Algorithm 1; `effects/src/mixed_reality/`,
//! `docs/DESIGN-NOTES.md` "Mixed reality"): with no virtual triangles, or none with influence, the
//! composite is the camera image bit for bit; the round trip against a full render of real + virtual scenes; convergence of the
//! filtered composite to the unfiltered one as μ grows; sequences (a real layer per frame, captured or
//! read from `{frame}` files, and temporal filtering); and bad input.

mod common;

use std::path::Path;

use common::*;
use wedge::backends::cpu::CpuBackend;
use wedge::backends::{RunResult, Silent};
use wedge::graph::parse_pipeline;
use wedge::image::Image;
use wedge::outputs::buffer_to_image;
use wedge::scene::RealLayer;
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
    let differ = out
        .pixels
        .iter()
        .zip(&cam.pixels)
        .filter(|(a, b)| a.iter().zip(b.iter()).any(|(x, y)| x.to_bits() != y.to_bits()))
        .count();
    println!("pixels that differ from L_cam: {differ} of {}", out.pixels.len());
    assert_eq!(differ, 0);
}

#[test]
fn an_empty_virtual_world_leaves_the_camera_image_exact_on_both_backends() {
    // No virtual triangles at all (`envmap_empty`: the camera and map, an empty BVH): every BVH ray
    // misses, E_RV = E_R sample by sample, and the composite is L_cam bit for bit — on the CPU and
    // on the wgpu backend (whose scene upload and traversal must accept zero triangles).
    let s = build(&mr("builtin:envmap_empty", "builtin:envmap_real", 16, "\"mu\": 1")).unwrap();
    assert_eq!(s.scene.triangle_count(), 0);
    let cam = camera_image(&s);
    let mut results = vec![("cpu", run_cpu(&s))];
    if let Some(mut gpu) = gpu_or_skip("an_empty_virtual_world_leaves_the_camera_image_exact_on_both_backends") {
        results.push(("wgpu", s.run(&mut gpu, &Silent).expect("wgpu run")));
    }
    for (backend, r) in &results {
        for name in ["color", "unfiltered"] {
            let differ = differing_pixels(&output(&s, r, name), &cam);
            println!("{backend} {name}: {differ} of {} pixels differ from L_cam", cam.pixels.len());
            assert_eq!(differ, 0, "{backend} {name}");
        }
    }
}

#[test]
fn the_round_trip_matches_a_render_of_both_worlds() {
    // Real = envmap without the torus, captured by wedge; virtual = the torus; the composite against
    // a render of the whole envmap scene, both at the same sample count.
    let spp = 256;
    let s = build(&mr("builtin:envmap_virtual", "builtin:envmap_real", spp, "\"primary\": 4, \"per_primary\": 16"))
        .unwrap();
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

/// A camera path for the 64×48 envmap scenes: frame 0 left of the default view, frame 1 at it.
const PATH: &str = "camera_path: [(frame: 0, position: (-0.3, 1.6, 3.4), look_at: (-0.3, 0.45, 0)), \
                    (frame: 1, position: (0, 1.6, 3.4), look_at: (0, 0.45, 0))],";

/// [`mr`] with extra top-level pipeline fields (a camera path).
fn mr_with(scene: &str, real_params: &str, params: &str, extra: &str) -> String {
    format!(
        r#"Pipeline(scene: "{scene}", width: {W}, height: {H}, seed: 3, {extra} nodes: [
            (name: "mr", kind: "MixedReality", params: {{{real_params}, {params}}}),
            (name: "out", kind: "Output", inputs: {{"color": "mr.radiance", "unfiltered": "mr.unfiltered"}}),
        ])"#
    )
}

/// Frames `first..=last` on the CPU, each with the previous frame's history; their composites.
fn frames(s: &mut Session, first: u32, last: u32) -> Result<Vec<Image>, String> {
    let (mut out, mut previous): (Vec<Image>, Option<RunResult>) = (Vec::new(), None);
    for f in first..=last {
        let r = s.run_frame(&mut CpuBackend::new(), &Silent, f, first, previous.as_ref()).map_err(|e| e.to_string())?;
        out.push(output(s, &r, "color"));
        previous = Some(r);
    }
    Ok(out)
}

fn differing_pixels(a: &Image, b: &Image) -> usize {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .filter(|(p, q)| p.iter().zip(q.iter()).any(|(x, y)| x.to_bits() != y.to_bits()))
        .count()
}

/// The real layer wedge captures of `envmap_real` from `camera` (a session of the still camera).
fn capture_from(camera: &str) -> (Session, Image) {
    let s = build(&mr_with(
        "builtin:envmap_far",
        r#""capture": "builtin:envmap_real", "capture_spp": 16"#,
        "\"mu\": 1",
        camera,
    ))
    .unwrap();
    let cam = camera_image(&s);
    (s, cam)
}

#[test]
fn temporal_filtering_damps_the_flicker_of_a_still_camera() {
    // The same camera and photograph every frame, each frame with its own noise: the frame-to-frame
    // difference of the composite is the flicker of the virtual torus and its shadow.
    let flicker = |temporal: bool| {
        let mut s =
            build(&mr("builtin:envmap_virtual", "builtin:envmap_real", 16, &format!("\"temporal\": {temporal}")))
                .unwrap();
        let f = frames(&mut s, 0, 4).unwrap();
        f.windows(2).map(|w| rmse(&w[0], &w[1])).sum::<f64>() / 4.0
    };
    let (off, on) = (flicker(false), flicker(true));
    println!("frame-to-frame RMSE of the composite: spatial only {off:.4e}, temporal {on:.4e} ({:.2}x)", off / on);
    assert!(on < 0.85 * off, "{on} vs {off}");
}

#[test]
fn each_frame_of_a_moving_camera_composites_into_its_own_capture() {
    // With no virtual influence (`envmap_far`) the composite is the camera image bit for bit — so
    // frame by frame it shows which real layer the frame used: the capture from that frame's camera,
    // with temporal filtering on (E_R and E_RV take the same history, their ratio stays 1).
    let mut s = build(&mr_with(
        "builtin:envmap_far",
        r#""capture": "builtin:envmap_real", "capture_spp": 16"#,
        "\"mu\": 1, \"temporal\": true",
        PATH,
    ))
    .unwrap();
    let out = frames(&mut s, 0, 1).unwrap();
    let (_, cam0) = capture_from("camera: Some((position: (-0.3, 1.6, 3.4), look_at: (-0.3, 0.45, 0), vfov_deg: 40)),");
    let (_, cam1) = capture_from("camera: Some((position: (0, 1.6, 3.4), look_at: (0, 0.45, 0), vfov_deg: 40)),");
    let (d0, d1, moved) =
        (differing_pixels(&out[0], &cam0), differing_pixels(&out[1], &cam1), differing_pixels(&cam0, &cam1));
    println!("pixels differing from the frame's own capture: frame 0 {d0}, frame 1 {d1} (the two captures differ in {moved})");
    assert_eq!((d0, d1), (0, 0));
    // The camera translates (same direction): the sky, at infinity, is the same in both; the ground
    // and sphere move.
    assert!(moved > (W * H / 4) as usize, "{moved}");
    // The session's own layer is back after the frames (a later `run` renders the opened frame).
    assert_eq!(differing_pixels(&camera_image(&s), &cam0), 0);
}

#[test]
fn per_frame_maps_are_read_from_frame_numbered_files() {
    // A "photographed" sequence: the two frames' captures written as EXR files named with the frame
    // number, read back by `{frame:04}` in the node's file names.
    let dir = tempfile::tempdir().unwrap();
    let cameras = [
        "camera: Some((position: (-0.3, 1.6, 3.4), look_at: (-0.3, 0.45, 0), vfov_deg: 40)),",
        "camera: Some((position: (0, 1.6, 3.4), look_at: (0, 0.45, 0), vfov_deg: 40)),",
    ];
    let mut expected = Vec::new();
    for (frame, camera) in cameras.iter().enumerate() {
        let (s, cam) = capture_from(camera);
        let layer: &RealLayer = s.scene.real.as_ref().unwrap();
        let rgb = |m: &[[f32; 3]]| Image { width: W, height: H, pixels: m.to_vec() };
        let name = |what: &str| dir.path().join(format!("{what}_{frame:04}.exr"));
        wedge::image::write_exr(&name("camera"), &rgb(layer.camera_map())).unwrap();
        wedge::image::write_exr_rgba(&name("position"), W, H, layer.position_map()).unwrap();
        wedge::image::write_exr(&name("normal"), &rgb(layer.normal_map())).unwrap();
        wedge::image::write_exr(&name("albedo"), &rgb(layer.albedo_map())).unwrap();
        expected.push(cam);
    }
    let maps = r#""camera_image": "camera_{frame:04}.exr", "position_map": "position_{frame:04}.exr", "normal_map": "normal_{frame:04}.exr", "albedo_map": "albedo_{frame:04}.exr""#;
    let text = mr_with("builtin:envmap_far", maps, "\"mu\": 1, \"temporal\": true", PATH);
    let loaded = parse_pipeline(&dir.path().join("seq.ron"), &text).unwrap();
    let (nodes, kernels) = wedge::effects::builtin();
    let mut s = Session::build(loaded, &Overrides::default(), nodes, kernels).unwrap();
    // The opened frame's maps were read when the session was built; its run does not read them
    // again (removed here, frame 0 still renders).
    for what in ["camera", "position", "normal", "albedo"] {
        std::fs::remove_file(dir.path().join(format!("{what}_0000.exr"))).unwrap();
    }
    let out = frames(&mut s, 0, 1).unwrap();
    let (d0, d1) = (differing_pixels(&out[0], &expected[0]), differing_pixels(&out[1], &expected[1]));
    println!("pixels differing from the frame's file: frame 0 {d0}, frame 1 {d1}");
    assert_eq!((d0, d1), (0, 0));
    // A sequence that opens at frame 1 reads frame 1's files first; frame 2 has none: the error names it.
    let loaded = parse_pipeline(&dir.path().join("seq.ron"), &text).unwrap();
    let (nodes, kernels) = wedge::effects::builtin();
    let mut s = Session::build(loaded, &Overrides { frame: Some(1), ..Overrides::default() }, nodes, kernels).unwrap();
    assert_eq!(differing_pixels(&camera_image(&s), &expected[1]), 0);
    let e = frames(&mut s, 1, 2).expect_err("frame 2 has no files");
    println!("{e}");
    assert!(e.contains("camera_0002.exr"), "{e}");
}

#[test]
fn one_photograph_refuses_a_moving_camera() {
    let dir = tempfile::tempdir().unwrap();
    let (s, cam) = capture_from("camera: Some((position: (-0.3, 1.6, 3.4), look_at: (-0.3, 0.45, 0), vfov_deg: 40)),");
    let layer = s.scene.real.as_ref().unwrap();
    let rgb = |m: &[[f32; 3]]| Image { width: W, height: H, pixels: m.to_vec() };
    wedge::image::write_exr(&dir.path().join("c.exr"), &cam).unwrap();
    wedge::image::write_exr_rgba(&dir.path().join("p.exr"), W, H, layer.position_map()).unwrap();
    wedge::image::write_exr(&dir.path().join("n.exr"), &rgb(layer.normal_map())).unwrap();
    let text = mr_with(
        "builtin:envmap_far",
        r#""camera_image": "c.exr", "position_map": "p.exr", "normal_map": "n.exr""#,
        "\"mu\": 1",
        PATH,
    );
    let loaded = parse_pipeline(&dir.path().join("one.ron"), &text).unwrap();
    let (nodes, kernels) = wedge::effects::builtin();
    let mut s = Session::build(loaded, &Overrides::default(), nodes, kernels).unwrap();
    let e = frames(&mut s, 0, 1).expect_err("frame 1 moved away from the photograph");
    println!("{e}");
    assert!(e.contains("frame 1") && e.contains("{frame:04}"), "{e}");
}

#[test]
fn a_moving_camera_leaves_no_ghost_of_the_virtual_object() {
    // The torus moves across the image between frames 0 and 1 (the camera moves 0.3 m): the history
    // pass must find the same world points, so frame 1 with temporal filtering is no further from the
    // converged composite than frame 1 without it.
    let run = |temporal: bool| {
        let text = mr_with(
            "builtin:envmap_virtual",
            r#""capture": "builtin:envmap_real", "capture_spp": 16"#,
            &format!("\"temporal\": {temporal}"),
            PATH,
        );
        frames(&mut build(&text).unwrap(), 0, 1).unwrap().pop().unwrap()
    };
    let (temporal, spatial) = (run(true), run(false));
    let still = "camera: Some((position: (0, 1.6, 3.4), look_at: (0, 0.45, 0), vfov_deg: 40)),";
    let converged = build(&mr_with(
        "builtin:envmap_virtual",
        r#""capture": "builtin:envmap_real", "capture_spp": 16"#,
        "\"per_primary\": 256",
        still,
    ))
    .unwrap();
    let truth = output(&converged, &run_cpu(&converged), "unfiltered");
    let (et, es) = (rmse(&temporal, &truth), rmse(&spatial, &truth));
    println!("frame 1 RMSE against the converged composite: temporal {et:.4e}, spatial {es:.4e}");
    assert!(et <= 1.05 * es, "temporal {et} vs spatial {es}");
}

#[test]
fn a_captured_scene_without_a_map_of_its_own_is_lit_by_the_nodes_map() {
    // Issue 33: `builtin:cornell` has no environment map; the node's `map` lights the capture, as the
    // README says capture accepts any scene (this failed with "scene `cornell` has none").
    let s = build(&mr("builtin:envmap_virtual", "builtin:cornell", 4, r#""map": "builtin:sky""#))
        .unwrap_or_else(|e| panic!("{e}"));
    let lit = mean(&camera_image(&s));
    assert!(lit.is_finite() && lit > 0.0, "the capture under builtin:sky is black: {lit}");
}
