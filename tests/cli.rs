//! The `wedge` command line as a user meets it: outputs written, schedules printed, and every bad
//! input answered with a clear error (file, position, fix) and a non-zero exit — never a panic.

use std::path::Path;
use std::process::{Command, Output};

fn wedge(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_wedge")).args(args).current_dir(cwd).output().expect("wedge runs")
}

fn text(o: &Output) -> (String, String) {
    (String::from_utf8_lossy(&o.stdout).into_owned(), String::from_utf8_lossy(&o.stderr).into_owned())
}

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn fails_cleanly(o: &Output, needles: &[&str]) {
    let (out, err) = text(o);
    assert!(!o.status.success(), "should fail: {out}{err}");
    assert!(!err.contains("panicked"), "must not panic: {err}");
    for n in needles {
        assert!(err.contains(n), "stderr should mention {n:?}: {err}");
    }
}

#[test]
fn render_writes_image_unfiltered_and_heatmaps() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = wedge(&["render", "--width", "64", "--height", "48", "--out", out.to_str().unwrap()], dir.path());
    let (stdout, stderr) = text(&o);
    assert!(o.status.success(), "{stdout}{stderr}");
    assert!(stdout.contains("rays per pixel"), "{stdout}");
    assert!(stdout.contains("shadows.filter_x"), "per-pass times: {stdout}");
    for f in ["render.exr", "render.png", "unfiltered.exr", "unfiltered.png", "filter_width.png", "rays_per_pixel.png"]
    {
        let p = out.join(f);
        assert!(p.metadata().map(|m| m.len() > 0).unwrap_or(false), "missing {f}");
    }
    let img = wedge::image::read_exr(&out.join("render.exr")).unwrap();
    assert_eq!((img.width, img.height), (64, 48));
    // Reference of the same scene, then compare: the same file against itself is exact.
    let o = wedge(
        &["reference", "--spp", "16", "--width", "64", "--height", "48", "--out", out.to_str().unwrap()],
        dir.path(),
    );
    assert!(o.status.success(), "{:?}", text(&o));
    let r = out.join("reference.exr");
    let o = wedge(
        &["compare", r.to_str().unwrap(), r.to_str().unwrap(), "--heatmap", out.join("e.png").to_str().unwrap()],
        dir.path(),
    );
    let (stdout, _) = text(&o);
    assert!(o.status.success());
    assert!(stdout.contains("RMSE    0.000000"), "{stdout}");
    assert!(stdout.contains("PSNR    inf"), "{stdout}");
}

#[test]
fn graph_prints_schedule_and_dot() {
    let o = wedge(&["graph", "pipelines/shadows.ron"], repo());
    let (stdout, stderr) = text(&o);
    assert!(o.status.success(), "{stderr}");
    // SoftShadows samples through the shared sampler (node `sampler`, SAMPLER-STAGE.md §4).
    for pass in [
        "primary.gbuffer",
        "sampler.first",
        "shadows.bandwidth",
        "shadows.rates",
        "sampler.counts_paths",
        "sampler.adaptive",
        "shadows.filter_x",
        "shadows.filter_y",
        "shadows.compose",
    ] {
        assert!(stdout.contains(pass), "{pass} missing from\n{stdout}");
    }
    // The stage column, and random passes marked.
    assert!(stdout.contains("stage") && stdout.contains("(random)"), "{stdout}");
    for (stage, pass) in [
        ("sample", "sampler.first"),
        ("bandwidth", "shadows.rates"),
        ("counts", "sampler.counts_paths"),
        ("adaptive", "sampler.adaptive"),
        ("filter", "shadows.filter_y"),
        ("compose", "shadows.compose"),
    ] {
        assert!(stdout.lines().any(|l| l.contains(&format!("{stage:12}  {pass} "))), "{stage} {pass} in\n{stdout}");
    }
    let o = wedge(&["graph", "pipelines/shadows.ron", "--dot"], repo());
    let (stdout, _) = text(&o);
    assert!(stdout.trim_start().starts_with("digraph"), "{stdout}");
}

#[test]
fn reference_takes_set_overrides() {
    // The reference is the pipeline's own graph, so any node parameter can be set (the old
    // template knew only a fixed list of the Indirect node's).
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let args = [
        "reference",
        "pipelines/indirect.ron",
        "--set",
        "indirect.bounces=3",
        "--spp",
        "2",
        "--width",
        "16",
        "--height",
        "12",
    ];
    let o = wedge(&[&args[..], &["--out", out.to_str().unwrap()]].concat(), repo());
    let (stdout, stderr) = text(&o);
    assert!(o.status.success(), "{stdout}{stderr}");
    assert!(out.join("reference.exr").exists());
    assert!(!stdout.contains("filter.gaussian") && stdout.contains("fill.constant"), "{stdout}");
}

#[test]
fn bad_inputs_fail_with_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Unknown node kind, with file:line:col.
    std::fs::write(
        d.join("bad.ron"),
        "Pipeline(scene: \"builtin:grids\", width: 8, height: 8,\n  nodes: [\n    (name: \"p\", kind: \"Primery\"),\n    (name: \"o\", kind: \"Output\", inputs: {\"color\": \"p.position\"}),\n  ],\n)\n",
    )
    .unwrap();
    fails_cleanly(&wedge(&["render", "bad.ron"], d), &["bad.ron:3:", "Primary"]);
    // Unknown field.
    std::fs::write(
        d.join("field.ron"),
        "Pipeline(scene: \"builtin:grids\", width: 8, height: 8, colour: 1, nodes: [])\n",
    )
    .unwrap();
    fails_cleanly(&wedge(&["graph", "field.ron"], d), &["field.ron:1:", "colour"]);
    // Missing pipeline, scene, EXR.
    fails_cleanly(&wedge(&["render", "nope.ron"], d), &["nope.ron"]);
    fails_cleanly(&wedge(&["render", "--scene", "missing.obj", "--width", "8", "--height", "8"], d), &["missing.obj"]);
    std::fs::write(d.join("fake.exr"), "not an exr").unwrap();
    fails_cleanly(&wedge(&["compare", "fake.exr", "fake.exr"], d), &["fake.exr"]);
    // Absurd sizes and parameters.
    fails_cleanly(&wedge(&["render", "--width", "0"], d), &["width"]);
    fails_cleanly(&wedge(&["render", "--width", "100000", "--height", "100000"], d), &["width"]);
    fails_cleanly(&wedge(&["render", "--mu", "0", "--width", "8", "--height", "8"], d), &["mu"]);
    fails_cleanly(&wedge(&["render", "--set", "shadows.nope=1", "--width", "8", "--height", "8"], d), &["nope"]);
    fails_cleanly(&wedge(&["render", "--set", "shadows.light=7", "--width", "8", "--height", "8"], d), &["light"]);
    // Nothing was written by the failed runs.
    assert!(!d.join("out").exists());
}

/// `render --aov position,normal,albedo` writes the maps a mixed-reality real layer reads, and they
/// load as one with the render as its camera image: the AOVs are the G-buffer's (bit for bit against
/// `wedge::aov::Aovs::render` in-process), misses are uncovered with zeros, normals unit, the ground's
/// albedo its material's. `--aov albedo` writes only that map; with `--frames` one per frame
/// (`aov_albedo_NNNN.exr`, a photographed sequence's maps) and the last frame's unnumbered.
#[test]
fn render_aov_maps_load_as_a_real_layer() {
    use wedge::scene::{RealAlbedo, RealLayer};
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let (w, h) = (64u32, 48u32);
    let o = wedge(
        &[
            "render",
            "pipelines/environment.ron",
            "--scene",
            "envmap_real",
            "--width",
            "64",
            "--height",
            "48",
            "--out",
            out.to_str().unwrap(),
            "--aov",
            "position,normal,albedo",
        ],
        repo(),
    );
    let (stdout, stderr) = text(&o);
    assert!(o.status.success(), "{stdout}{stderr}");
    assert!(stdout.contains("AOVs aov_position, aov_normal, aov_albedo in"), "{stdout}");
    let layer = RealLayer::open(
        &out.join("render.exr"),
        &out.join("aov_position.exr"),
        &out.join("aov_normal.exr"),
        RealAlbedo::Map(out.join("aov_albedo.exr")),
    )
    .unwrap();
    assert_eq!((layer.width(), layer.height()), (w, h));
    let scene = wedge::scene::load(&wedge::scene::SceneSource::Builtin("envmap_real".into())).unwrap();
    let aovs = wedge::aov::Aovs::render(&scene, w, h).unwrap();
    assert_eq!(layer.position_map(), &aovs.position[..]);
    assert_eq!(layer.albedo_map(), &aovs.albedo[..]);
    for (k, (n, p)) in layer.normal_map().iter().zip(layer.position_map()).enumerate() {
        let len = wedge::scene::Vec3::from(*n).length();
        if p[3] == 1.0 {
            assert!((len - 1.0).abs() < 1e-5, "pixel {k}: |n| = {len}");
            assert!(n.iter().zip(&aovs.normal[k]).all(|(a, b)| (a - b).abs() < 1e-6), "pixel {k}: renormalised only");
        } else {
            assert_eq!((*n, *p, layer.albedo_map()[k]), ([0.0; 3], [0.0; 4], [0.0; 3]));
        }
    }
    // The top row sees the sky above the ground's far edge; the bottom row's centre sees the ground.
    assert!(!layer.covered(w / 2, 0));
    assert!(layer.covered(w / 2, h - 1));
    assert_eq!(layer.albedo(w / 2, h - 1).to_array(), [0.6; 3]);
    assert_eq!(layer.normal(w / 2, h - 1).to_array(), [0.0, 1.0, 0.0]);

    let only = dir.path().join("only");
    let o = wedge(
        &[
            "render",
            "--width",
            "32",
            "--height",
            "24",
            "--frames",
            "0..1",
            "--out",
            only.to_str().unwrap(),
            "--aov",
            "albedo",
        ],
        repo(),
    );
    assert!(o.status.success(), "{:?}", text(&o));
    assert!(only.join("aov_albedo.exr").is_file());
    assert!(only.join("aov_albedo_0000.exr").is_file() && only.join("aov_albedo_0001.exr").is_file());
    assert!(!only.join("aov_position.exr").exists() && !only.join("aov_normal.exr").exists());
    assert!(!only.join("aov_position_0000.exr").exists());
    let img = wedge::image::read_exr(&only.join("aov_albedo.exr")).unwrap();
    assert_eq!((img.width, img.height), (32, 24));
}

/// `wedge bench --suite --quick` restricted to two scenes at a tiny size (the CI smoke of issue 16's
/// suite through the command line): a directory per scene, the table with both rows, the median and
/// the worst; and `--scene` benches another scene than the pipeline's.
#[test]
fn bench_suite_quick_and_bench_scene() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("suite");
    let pipeline = repo().join("pipelines/shadows.ron");
    let common = ["--quick", "--width", "32", "--height", "24", "--reference-spp", "32"];
    let mut args = vec![
        "bench",
        pipeline.to_str().unwrap(),
        "--suite",
        "--suite-scenes",
        "suite_grate,builtin:curved",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend(common);
    let o = wedge(&args, dir.path());
    let (stdout, stderr) = text(&o);
    assert!(o.status.success(), "{stdout}{stderr}");
    assert!(stdout.contains("suite of 2 scenes: median") && stdout.contains("worst: `"), "{stdout}");
    let md = std::fs::read_to_string(out.join("suite.md")).unwrap();
    for needle in [
        "[suite_grate](suite_grate/report.md)",
        "[curved](curved/report.md)",
        "| **median** |",
        "| **worst: ",
        "quick mode",
    ] {
        assert!(md.contains(needle), "suite.md lacks {needle:?}:\n{md}");
    }
    for f in ["suite.csv", "suite.json", "suite_speedup.png", "suite_grate/report.md", "curved/bench.csv"] {
        assert!(out.join(f).exists(), "{f}");
    }
    let one = dir.path().join("one");
    let mut args =
        vec!["bench", pipeline.to_str().unwrap(), "--scene", "suite_contact", "--out", one.to_str().unwrap()];
    args.extend(common);
    let o = wedge(&args, dir.path());
    assert!(o.status.success(), "{:?}", text(&o));
    let report = std::fs::read_to_string(one.join("report.md")).unwrap();
    assert!(report.contains("Scene `suite_contact`"), "{report}");
}

/// `--frames` is bounded (issue 33): a sequence is estimated as one frame's run plus the previous
/// frame's history and the frame being streamed out, whatever its length, so a limit a single frame
/// fits in but a sequence does not refuses the sequence up front, writing nothing; and a long
/// sequence's files are all there, with a preview of every frame.
#[test]
fn a_sequence_the_memory_limit_cannot_hold_is_refused_up_front() {
    let dir = tempfile::tempdir().unwrap();
    let pipeline = repo().join("pipelines/environment_temporal.ron");
    let size = ["--width", "320", "--height", "240"];
    let out = dir.path().join("seq");
    let mut args = vec![
        "render",
        pipeline.to_str().unwrap(),
        "--frames",
        "0..99999",
        "--memory-limit",
        "124M",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend(size);
    let o = wedge(&args, dir.path());
    fails_cleanly(&o, &["more than the memory limit of 124.0 MiB (--memory-limit)", "estimated 130.9 MiB"]);
    assert!(!out.exists(), "nothing written for a refused sequence");
    // The single-frame estimate of the same size is below the limit: the sequence's share is what refused it.
    let single = wedge::session::Session::open(
        Some(&pipeline),
        &wedge::session::Overrides { width: Some(320), height: Some(240), ..Default::default() },
    )
    .unwrap()
    .memory_estimate(wedge::session::RunMode::Cpu);
    assert!(single.total() < 124 << 20, "{single:?}");

    let many = dir.path().join("many");
    let o = wedge(
        &["render", "--width", "8", "--height", "6", "--frames", "0..39", "--out", many.to_str().unwrap()],
        repo(),
    );
    assert!(o.status.success(), "{:?}", text(&o));
    assert!((0..40)
        .all(|f| many.join(format!("frame_{f:04}.exr")).is_file() && many.join(format!("frame_{f:04}.png")).is_file()));
    let file = std::fs::File::open(many.join("preview.gif")).unwrap();
    let mut gif = gif::DecodeOptions::new().read_info(file).unwrap();
    let mut frames = 0;
    while gif.read_next_frame().unwrap().is_some() {
        frames += 1;
    }
    assert_eq!(frames, 40);
}
