//! Issue 34 §2 for the shared sampler's component nodes: a pipeline whose `camera:` block opens a
//! lens (or a shutter, on a moving scene) and has no Defocus or Motion node renders the plain Monte
//! Carlo image through that camera — SoftShadows, Indirect (radiance and AO) and Environment trace
//! `camera_paths` jittered paths through it and add their parts' `L`, unfiltered
//! (`effects/src/plain_camera.rs`). Held to numbers against an independent tracer (MonteCarlo's
//! camera paths through the same block), and to parity on both backends.

mod common;

use common::cameras::{OpenCamera, CAMERAS};
use common::progressive::{mean, rmse};
use common::*;
use wedge::backends::BufferData;

/// SoftShadows (with the G-buffer's emission) + Indirect (glossy where `specular` is wired) through
/// `camera`, `paths` camera paths per pixel.
fn components(c: &OpenCamera, camera: &str, paths: u32) -> String {
    format!(
        "Pipeline(scene: \"builtin:{}\", width: {}, height: {}, seed: 1,\n camera: Some(({camera})),\n nodes: [\n \
         (name: \"primary\", kind: \"Primary\"),\n \
         (name: \"shadows\", kind: \"SoftShadows\", params: {{\"camera_paths\": {paths}}}, inputs: {{\"position\": \"primary.position\", \"normal\": \"primary.normal\", \"albedo\": \"primary.albedo\", \"emission\": \"primary.emission\"}}),\n \
         (name: \"ind\", kind: \"Indirect\", params: {{\"camera_paths\": {paths}}}, inputs: {{\"position\": \"primary.position\", \"normal\": \"primary.normal\", \"albedo\": \"primary.albedo\", \"specular\": \"primary.specular\"}}),\n \
         (name: \"sum\", kind: \"Add\", inputs: {{\"a\": \"shadows.radiance\", \"b\": \"ind.radiance\"}}),\n \
         (name: \"out\", kind: \"Output\", inputs: {{\"color\": \"sum.radiance\"}}),\n])\n",
        c.scene, c.size.0, c.size.1
    )
}

/// MonteCarlo's own camera paths (`spp`, `bounces`) through `camera`: the independent tracer.
fn path_traced(scene: &str, size: (u32, u32), camera: &str, spp: u32, bounces: u32) -> String {
    format!(
        "Pipeline(scene: \"builtin:{scene}\", width: {}, height: {}, seed: 2,\n camera: Some(({camera})),\n nodes: [\n \
         (name: \"primary\", kind: \"Primary\"),\n \
         (name: \"mc\", kind: \"MonteCarlo\", params: {{\"spp\": {spp}, \"bounces\": {bounces}}}, inputs: {{\"position\": \"primary.position\", \"normal\": \"primary.normal\"}}),\n \
         (name: \"out\", kind: \"Output\", inputs: {{\"color\": \"mc.radiance\"}}),\n])\n",
        size.0, size.1
    )
}

fn color(text: &str, size: (u32, u32)) -> BufferData {
    run(&session_from_text(text, &sized(size.0, size.1, None, &[]))).output("color").expect("color").clone()
}

/// Direct light, emission and one bounce through the lens (over the shutter): the image's terms say
/// so, its mean is the path tracer's within 1%, and it is closer to the path tracer through the
/// camera than to the one through the closed camera (a pinhole at the shutter's centre).
#[test]
fn component_nodes_render_the_plain_monte_carlo_image_through_the_camera_block() {
    // 64×48: at 32×24 the emitter's few pixels alone move the image mean by about 1% at these paths.
    let size = (64, 48);
    for c in &CAMERAS {
        let s = session_from_text(&components(c, c.open, 512), &sized(size.0, size.1, None, &[]));
        let terms = s.pipeline.terms.of("sum", "radiance").expect("declared").to_string();
        assert!(
            terms.contains("emission") && terms.contains("indirect(1 bounce") && terms.ends_with(c.view),
            "{terms}"
        );
        let image = run(&s).output("color").expect("color").clone();
        let truth = color(&path_traced(c.scene, size, c.open, 2048, 1), size);
        let closed = color(&path_traced(c.scene, size, c.closed, 2048, 1), size);
        let (to_open, to_closed) = (rmse(&image, &truth), rmse(&image, &closed));
        println!(
            "{}: mean {:.5} vs the path tracer's {:.5}; RMSE {to_open:.4} to it, {to_closed:.4} to the closed camera's",
            c.what,
            mean(&image),
            mean(&truth)
        );
        assert!(
            (mean(&image) / mean(&truth) - 1.0).abs() < 0.01,
            "{}: means {} vs {}",
            c.what,
            mean(&image),
            mean(&truth)
        );
        assert!(to_open < 0.6 * to_closed, "{}: RMSE {to_open} to the open camera, {to_closed} to the closed", c.what);
        // More camera paths, closer to the path tracer: the image converges, it is not filtered.
        let fewer = color(&components(c, c.open, 16), size);
        assert!(
            rmse(&fewer, &truth) > 1.5 * to_open,
            "{}: 16 paths {} vs 512 paths {to_open}",
            c.what,
            rmse(&fewer, &truth)
        );
    }
}

/// A lens on the environment-lit scene.
const ENV_CAMERA: &str = "position: (0.0, 1.0, 3.5), look_at: (0.0, 0.5, 0.0), vfov_deg: 40.0, aperture_radius: 0.1";

/// An Environment node alone through [`ENV_CAMERA`], `paths` camera paths per pixel.
fn environment(paths: u32) -> String {
    format!(
        "Pipeline(scene: \"builtin:envmap\", width: 32, height: 24, seed: 1,\n camera: Some(({ENV_CAMERA})),\n nodes: [\n \
         (name: \"env\", kind: \"Environment\", params: {{\"map\": \"builtin:sky\", \"camera_paths\": {paths}}}),\n \
         (name: \"out\", kind: \"Output\", inputs: {{\"color\": \"env.radiance\", \"filter_width\": \"env.bandwidth\"}}),\n])\n"
    )
}

/// The environment's direct light through the lens on the environment-lit scene, with what camera
/// rays see directly (the map where they miss): the path tracer's image of the same terms.
#[test]
fn the_environment_renders_through_the_camera_blocks_lens() {
    let (camera, size, text) = (ENV_CAMERA, (32, 24), environment(512));
    let s = session_from_text(&text, &sized(size.0, size.1, None, &[]));
    let terms = s.pipeline.terms.of("env", "radiance").expect("declared").to_string();
    assert_eq!(terms, "emission + background + direct(environment), through the lens");
    let image = run(&s).output("color").expect("color").clone();
    let truth = color(&path_traced("envmap", size, camera, 1024, 0), size);
    println!("environment: mean {:.5} vs the path tracer's {:.5}", mean(&image), mean(&truth));
    assert!((mean(&image) / mean(&truth) - 1.0).abs() < 0.01, "means {} vs {}", mean(&image), mean(&truth));
    // What the node would filter with a temporal history is refused, not ignored.
    let temporal = text.replace("\"camera_paths\": 512", "\"temporal\": true");
    let err = build_text(&temporal, &sized(size.0, size.1, None, &[]), None).err().expect("refused");
    assert!(err.contains("`temporal: true` does not apply through the `camera:` block's lens"), "{err}");
}

/// Ambient occlusion through the lens: its terms say it, and its image is the occlusion the
/// lens-averaged paths see — not the pinhole one.
#[test]
fn ambient_occlusion_renders_through_the_camera_blocks_lens() {
    let c = &CAMERAS[0];
    let text = |camera: &str| {
        components(c, camera, 64).replace(
            "(name: \"ind\", kind: \"Indirect\", params: {\"camera_paths\": 64}",
            "(name: \"ind\", kind: \"Indirect\", params: {\"camera_paths\": 64, \"mode\": \"ao\"}",
        )
    };
    let ao = |camera: &str| {
        text(camera).replace("\"color\": \"sum.radiance\"", "\"color\": \"ind.radiance\"").replace(
            "(name: \"sum\", kind: \"Add\", inputs: {\"a\": \"shadows.radiance\", \"b\": \"ind.radiance\"}),\n ",
            "",
        )
    };
    let s = session_from_text(&ao(c.open), &sized(c.size.0, c.size.1, None, &[]));
    let terms = s.pipeline.terms.of("ind", "radiance").expect("declared").to_string();
    assert_eq!(terms, "ambient occlusion, through the lens");
    let (open, closed) = (color(&ao(c.open), c.size), color(&ao(c.closed), c.size));
    assert!(rmse(&open, &closed) > 0.01, "the lens changed the occlusion by {}", rmse(&open, &closed));
}

/// `wedge graph` says the image is seen through the block's camera, with no warning that the lens
/// is not sampled, and notes the G-buffer's emission it does not add (its paths see their own).
#[test]
fn graph_states_the_plain_camera_without_warning() {
    for c in &CAMERAS {
        let dir = common::cli::temp_dir("plain-camera", c.what);
        std::fs::write(dir.join("p.ron"), components(c, c.open, 16)).unwrap();
        let o = common::cli::wedge(&["graph", "p.ron"], &dir);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let out = String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr);
        assert!(out.contains("out.color = sum.radiance: ") && out.contains(c.view), "{out}");
        assert!(!out.contains("is not sampled") && !out.contains("rendered at the shutter's centre"), "{out}");
        assert!(
            out.contains("input `emission` of node `shadows`") && out.contains("already holds that light"),
            "{out}"
        );
    }
}

/// The plain camera's paths are the same on both backends.
#[test]
fn the_plain_camera_passes_parity() {
    let Some(mut gpu) = gpu_or_skip("the_plain_camera_passes_parity") else { return };
    for c in &CAMERAS {
        let s = session_from_text(&components(c, c.open, 4), &sized(16, 12, None, &[]));
        let report = wedge::backends::parity::run_parity(&s.job(s.seed, 0, &wedge::backends::Silent), &mut gpu)
            .expect("parity runs");
        assert!(report.ok(), "{}:\n{}", c.what, report.table());
    }
    let s = session_from_text(&environment(4), &sized(16, 12, None, &[]));
    let report = wedge::backends::parity::run_parity(&s.job(s.seed, 0, &wedge::backends::Silent), &mut gpu)
        .expect("parity runs");
    assert!(report.ok(), "environment:\n{}", report.table());
}

/// Through the camera block the image is the same whatever the tiling or thread count: `render
/// --tile i/3` merged is the whole render's EXR byte for byte, and so is a one-thread render (the
/// lens and time samples are keyed by the global pixel, like every other draw).
#[test]
fn the_plain_camera_is_the_same_image_in_tiles_and_on_one_thread() {
    let c = &CAMERAS[0];
    let dir = common::cli::temp_dir("plain-camera", "tiles");
    std::fs::write(dir.join("p.ron"), components(c, c.open, 4)).unwrap();
    let run = |args: &[&str]| {
        let o = common::cli::wedge(args, &dir);
        assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
    };
    run(&["render", "p.ron", "--out", "whole"]);
    run(&["render", "p.ron", "--threads", "1", "--out", "one"]);
    for tile in ["0/3", "1/3", "2/3"] {
        run(&["render", "p.ron", "--tile", tile, "--out", "tiles"]);
    }
    run(&["merge", "tiles", "--out", "merged"]);
    let bytes = |d: &str| std::fs::read(dir.join(d).join("render.exr")).unwrap();
    assert!(bytes("whole") == bytes("merged"), "the merged tiles differ from the whole render");
    assert!(bytes("whole") == bytes("one"), "one thread differs from the default");
}
