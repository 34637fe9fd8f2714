//! `wedge bench --quick` end to end on the soft-shadow pipeline: CSV rows and columns, report,
//! plots and crops, and the reference cache on a second run.

use std::path::{Path, PathBuf};

use wedge::bench::report::CSV_COLUMNS;
use wedge::bench::{run, BenchOptions, BenchResult, Method, Role};

fn options(out: &Path) -> BenchOptions {
    let pipeline = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("pipelines/shadows.ron");
    BenchOptions { quick: true, ..BenchOptions::new(pipeline, out) }
}

fn decode_png(path: &Path) -> (u32, u32) {
    let img = ::image::ImageReader::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .with_guessed_format()
        .unwrap()
        .decode()
        .unwrap_or_else(|e| panic!("{} does not decode: {e}", path.display()));
    assert_eq!(::image::ImageFormat::from_path(path).unwrap(), ::image::ImageFormat::Png);
    (img.width(), img.height())
}

fn check_csv(r: &BenchResult) {
    let text = std::fs::read_to_string(&r.csv).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header, CSV_COLUMNS);
    let rows: Vec<Vec<String>> = lines.map(|l| l.split(',').map(str::to_string).collect()).collect();
    // Quick: mu 1 and 2 (2 is the file's), two seeds each; 3 spp per baseline; one equal-time run.
    assert_eq!(rows.len(), 2 * 2 + 3 + 3 + 1, "{text}");
    assert_eq!(rows.len(), r.runs.len());
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let count =
        |method: &str, role: &str| rows.iter().filter(|x| x[col("method")] == method && x[col("role")] == role).count();
    assert_eq!(count("pipeline", "sweep"), 2);
    assert_eq!(count("pipeline", "seed2"), 2);
    assert_eq!(count("independent", "curve"), 3);
    assert_eq!(count("stratified", "curve"), 3);
    assert_eq!(count("stratified", "equal-time"), 1);
    let finite = |row: &Vec<String>, name: &str| {
        let v: f64 = row[col(name)].parse().unwrap_or_else(|_| panic!("{name} = {:?} in {row:?}", row[col(name)]));
        assert!(v.is_finite(), "{name} = {v} in {row:?}");
        v
    };
    for row in &rows {
        assert_eq!(row.len(), header.len());
        for name in [
            "rays_per_pixel",
            "shadow_rays_per_pixel",
            "time_total_s",
            "time_sampling_s",
            "rmse",
            "rel_mse",
            "psnr_db",
            "smape",
            "flip",
        ] {
            finite(row, name);
        }
        assert!(finite(row, "rmse") > 0.0);
        let flip = finite(row, "flip");
        assert!((0.0..1.0).contains(&flip));
        assert!(finite(row, "rays_per_pixel") >= 1.0);
    }
    for row in rows.iter().filter(|x| x[col("role")] == "sweep") {
        for name in
            ["variance", "bias2", "filter_overhead", "speedup_rays_vs_independent", "speedup_rays_vs_stratified"]
        {
            assert!(finite(row, name) >= 0.0, "{name}");
        }
        // By time: a number, or empty where our error lies beyond the baseline's three runs and
        // their wall-clock times give no falling error-vs-time fit to extrapolate (a loaded machine
        // can time 2 spp below 1 spp: curves.rs `cost_for_error`); the ray counts above never vary.
        for name in ["speedup_time_vs_independent", "speedup_time_vs_stratified"] {
            assert!(row[col(name)].is_empty() || finite(row, name) >= 0.0, "{name}");
        }
        assert!(["true", "false"].contains(&row[col("extrapolated_vs_independent")].as_str()));
    }
    let primary: Vec<&Vec<String>> = rows.iter().filter(|x| x[col("primary")] == "true").collect();
    assert_eq!(primary.len(), 1);
    assert_eq!(primary[0][col("mu")], "2");
    // Monte Carlo rays: one primary ray plus spp shadow rays per pixel (for lit, visible pixels).
    for row in rows.iter().filter(|x| x[col("role")] == "curve") {
        let spp: f64 = row[col("spp")].parse().unwrap();
        let shadow = finite(row, "shadow_rays_per_pixel");
        assert!(shadow <= spp + 1e-9 && shadow > 0.5 * spp, "{row:?}");
    }
}

#[test]
fn quick_bench_writes_everything_and_caches_the_reference() {
    let dir = tempfile::tempdir().unwrap();
    let first = run(&options(dir.path())).expect("bench runs");
    assert!(!first.reference.from_cache);
    assert_eq!((first.width, first.height), (128, 96));
    assert_eq!(first.reference.spp, 512);
    assert!(first.reference.noise_rmse > 0.0 && first.reference.noise_rmse.is_finite());
    check_csv(&first);

    // The primary run's numbers are consistent with their definitions.
    let p = first.primary().unwrap();
    let bv = p.bias_variance.unwrap();
    assert!((bv.mse - p.metrics.rmse.powi(2)).abs() < 1e-15);
    assert!(bv.variance > 0.0 && bv.bias2 >= 0.0);
    for m in [Method::Independent, Method::Stratified] {
        let s = p.speedup(m).unwrap();
        let needed = s.rays_needed.unwrap().cost;
        assert!((s.rays - needed / p.rays.total).abs() < 1e-9 * s.rays);
    }
    // Stratified beats independent at equal spp on this scene (except at noise level).
    let ind: Vec<f64> = first.curve_runs(Method::Independent).map(|r| r.metrics.rmse).collect();
    let strat: Vec<f64> = first.curve_runs(Method::Stratified).map(|r| r.metrics.rmse).collect();
    assert!(ind.iter().zip(&strat).all(|(i, s)| s < i), "{ind:?} {strat:?}");
    assert!(first.runs.iter().any(|r| r.role == Role::EqualTime));

    // Report: every method, the goals with PASS/MISS, links to plots and crops.
    let report = std::fs::read_to_string(&first.report).unwrap();
    for needle in [
        "independent MC",
        "stratified MC",
        "ours",
        "reference",
        "equal-RMSE speedup vs independent MC",
        "equal-RMSE speedup vs stratified MC",
        "filter overhead",
        "error_vs_rays.png",
        "error_vs_time.png",
        "images/crop_ours.png",
        "pipeline/filter_width.png",
        "pipeline/rays_per_pixel.png",
    ] {
        assert!(report.contains(needle), "report lacks {needle:?}:\n{report}");
    }
    assert!(report.contains("PASS") || report.contains("MISS"));
    assert_eq!(first.goals.len(), 3);
    for g in first.goals.iter().filter(|g| !g.pass) {
        assert!(!g.note.is_empty(), "a miss names its cause: {g:?}");
    }
    for p in &first.plots {
        assert_eq!(decode_png(p), (wedge::bench::plots::PLOT_WIDTH, wedge::bench::plots::PLOT_HEIGHT));
    }
    assert_eq!(first.plots.len(), 2);
    for i in &first.images {
        decode_png(i);
    }
    for name in ["crop_input.png", "crop_ours.png", "crop_equal_time_mc.png", "crop_reference.png"] {
        // Centre quarter (64×48) enlarged 4×.
        assert_eq!(decode_png(&dir.path().join("images").join(name)), (256, 192));
    }
    for name in ["filter_width.png", "rays_per_pixel.png", "render.exr"] {
        assert!(dir.path().join("pipeline").join(name).exists(), "{name}");
    }

    // Second run: the reference comes from the cache, bit for bit.
    let second = run(&options(dir.path())).expect("second bench runs");
    assert!(second.reference.from_cache);
    assert_eq!(second.reference.key, first.reference.key);
    assert_eq!(second.reference.noise_rmse, first.reference.noise_rmse);
    assert!(
        second.reference.obtain_seconds * 5.0 < first.reference.obtain_seconds,
        "cache load {:.3} s vs render {:.3} s",
        second.reference.obtain_seconds,
        first.reference.obtain_seconds
    );
    assert!(second.seconds < first.seconds, "{} vs {}", second.seconds, first.seconds);
    let rmses =
        |r: &BenchResult| r.runs.iter().filter(|x| x.role == Role::Sweep).map(|x| x.metrics.rmse).collect::<Vec<_>>();
    assert_eq!(rmses(&second), rmses(&first));
    let report = std::fs::read_to_string(&second.report).unwrap();
    assert!(report.contains("loaded from the cache"));
}

/// `wedge bench --suite` in small: two suite scenes at 48×36, few samples. Every scene gets its own
/// bench directory; the table has one row per scene with finite numbers, the median and the worst
/// follow from the rows; CSV, JSON and chart are written; `--scene` with `--suite` is refused.
#[test]
fn suite_smoke_two_scenes() {
    use wedge::bench::suite::{column_medians, median, run_suite, worst_row, SUITE_COLUMNS};
    let dir = tempfile::tempdir().unwrap();
    let opts = BenchOptions {
        width: Some(48),
        height: Some(36),
        reference_spp: Some(64),
        mu_values: Some(vec![2.0]),
        baseline_spp: Some(vec![2, 8, 32]),
        ..options(dir.path())
    };
    let scenes = ["builtin:suite_contact".to_string(), "builtin:suite_slats".to_string()];
    let r = run_suite(&opts, &scenes).expect("suite runs");
    assert_eq!(r.rows.len(), 2);
    assert_eq!((r.width, r.height), (48, 36));
    for (row, name) in r.rows.iter().zip(["suite_contact", "suite_slats"]) {
        assert_eq!(row.scene, name);
        assert_eq!(row.description, wedge::scene::builtin::describe(name).unwrap());
        assert_eq!(row.mu, Some(2.0));
        for (what, v) in [
            ("rays", row.rays_per_pixel),
            ("rmse", row.rmse),
            ("vs independent", row.speedup_vs_independent),
            ("vs stratified", row.speedup_vs_stratified),
            ("variance", row.variance),
            ("bias2", row.bias2),
            ("overhead", row.filter_overhead),
            ("mean offset", row.mean_offset),
        ] {
            assert!(v.is_finite(), "{name}: {what} = {v}");
        }
        assert!(row.rays_per_pixel >= 1.0 && row.rmse > 0.0 && row.speedup_vs_stratified > 0.0);
        assert!(row.mean_offset.abs() < 0.5, "{name}: mean offset {}", row.mean_offset);
        let scene_dir = dir.path().join(name);
        for f in ["report.md", "bench.csv", "error_vs_rays.png", "pipeline/filter_width.png"] {
            assert!(scene_dir.join(f).exists(), "{name}/{f}");
        }
    }
    // One reference cache for the whole suite, one entry per scene.
    assert!(dir.path().join(".cache").is_dir());
    // Median and worst as defined.
    let m = median(r.rows.iter().map(|x| x.speedup_vs_stratified));
    assert_eq!(r.median.speedup_vs_stratified, m);
    assert_eq!(m, 0.5 * (r.rows[0].speedup_vs_stratified + r.rows[1].speedup_vs_stratified));
    assert_eq!(column_medians(&r.rows).rays_per_pixel, 0.5 * (r.rows[0].rays_per_pixel + r.rows[1].rays_per_pixel));
    let worst = worst_row(&r.rows).unwrap();
    assert_eq!(r.worst, Some(worst));
    assert!(r.rows.iter().all(|x| x.speedup_vs_stratified >= r.rows[worst].speedup_vs_stratified));
    // Files: table with both rows, median and worst; CSV; JSON; chart.
    let md = std::fs::read_to_string(&r.table).unwrap();
    for needle in [
        "[suite_contact](suite_contact/report.md)",
        "[suite_slats](suite_slats/report.md)",
        "| **median** |",
        "| **worst: ",
        "suite_speedup.png",
    ] {
        assert!(md.contains(needle), "suite.md lacks {needle:?}:\n{md}");
    }
    let csv = std::fs::read_to_string(&r.csv).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next().unwrap().split(',').collect::<Vec<_>>(), SUITE_COLUMNS);
    assert_eq!(lines.count(), 2);
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&r.json).unwrap()).unwrap();
    assert_eq!(json["rows"].as_array().unwrap().len(), 2);
    assert_eq!(json["rows"][1]["scene"], "suite_slats");
    let (w, h) = decode_png(&r.plot);
    assert_eq!(w, wedge::bench::plots::PLOT_WIDTH);
    assert!(h >= wedge::bench::plots::PLOT_HEIGHT);

    let refused =
        run_suite(&BenchOptions { scene: Some("builtin:grids".into()), ..opts.clone() }, &scenes).unwrap_err();
    assert!(refused.to_string().contains("--scene"), "{refused}");
}

/// The defocus suite (issue 35) in small: a pipeline with a lens picks it; each scene's lens is set
/// on the Defocus node (the scene's, not the pipeline's 5 cm); the report splits the error by pixel
/// class (focus, texture) with shares summing to one, and writes the bias² and variance maps.
#[test]
fn defocus_suite_smoke_sets_each_scenes_lens_and_splits_the_error() {
    use wedge::bench::suite::{family_of, family_scenes, lens_params, run_suite};
    use wedge::graph::ParamValue;
    use wedge::scene::builtin::SuiteFamily;
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let reg = wedge::Registries::builtin().nodes;
    let pipeline = root.join("pipelines/defocus_shadows_indirect.ron");
    assert_eq!(family_of(&reg, &pipeline).unwrap(), SuiteFamily::Defocus);
    assert_eq!(family_of(&reg, &root.join("pipelines/shadows.ron")).unwrap(), SuiteFamily::Shadows);
    assert_eq!(family_of(&reg, &root.join("pipelines/motion_shadows_indirect.ron")).unwrap(), SuiteFamily::Motion);
    assert!(
        lens_params(&reg, &root.join("pipelines/motion.ron"), "builtin:dof_tiny").unwrap().is_empty(),
        "Motion takes no lens"
    );
    let scenes = family_scenes(SuiteFamily::Defocus);
    assert!(scenes.len() >= 8, "{scenes:?}");
    for s in &scenes {
        let name = s.strip_prefix("builtin:").unwrap();
        assert!(wedge::scene::builtin::describe(name).is_some(), "{name} has no description");
    }
    let lens = lens_params(&reg, &pipeline, "builtin:dof_tiny").unwrap();
    assert_eq!(
        lens,
        vec![
            ("defocus".to_string(), "aperture_radius".to_string(), ParamValue::Float(f64::from(0.003f32))),
            ("defocus".to_string(), "focus_distance".to_string(), ParamValue::Float(f64::from(2.9f32))),
        ]
    );
    assert!(lens_params(&reg, &pipeline, "builtin:grids").unwrap().is_empty(), "a pinhole scene sets no lens");

    let dir = tempfile::tempdir().unwrap();
    let opts = tiny_suite(pipeline, dir.path());
    let r = run_suite(&opts, &["builtin:dof_foreground".to_string()]).expect("defocus suite runs");
    assert_eq!(r.family, SuiteFamily::Defocus);
    let row = &r.rows[0];
    assert!(row.rmse.is_finite() && row.rays_per_pixel > 1.0);
    assert!(row.error_home.contains("focus") && row.error_home.contains('%'), "{}", row.error_home);
    let report = std::fs::read_to_string(dir.path().join("dof_foreground/report.md")).unwrap();
    for needle in [
        "Where the error lives",
        "| focus | out of focus |",
        "| texture | texture edge |",
        "error_bias2.png",
        "error_variance.png",
    ] {
        assert!(report.contains(needle), "report lacks {needle:?}:\n{report}");
    }
    let md = std::fs::read_to_string(&r.table).unwrap();
    assert!(md.contains("Issue 35's goals"), "{md}");
}

/// The suite a pipeline gets is the first that fits, its factoring node's first: `motion_environment.ron`
/// (Environment first in its file) the motion suite — on the environment suite's static scenes Motion
/// factors nothing, and the bench would measure its Environment node alone; `defocus_environment.ron`
/// would be the defocus suite, but its map-less scenes leave its Environment node without a map, so
/// the environment suite. A pipeline that cannot render some of the scenes is refused before the
/// first renders, every such scene named, and nothing is written (`environment_shadows.ron`'s
/// SoftShadows on the map-lit environment scenes; no suite fits it).
#[test]
fn the_suite_is_the_first_that_fits_and_every_scene_is_checked_first() {
    use wedge::bench::suite::{candidate_families, family_scenes, run_suite, suite_for};
    use wedge::scene::builtin::SuiteFamily;
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let reg = wedge::Registries::builtin().nodes;
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("suite");
    for (pipeline, candidates, runs) in [
        ("motion_environment.ron", vec![SuiteFamily::Motion, SuiteFamily::Environment], Some(SuiteFamily::Motion)),
        (
            "defocus_environment.ron",
            vec![SuiteFamily::Defocus, SuiteFamily::Environment],
            Some(SuiteFamily::Environment),
        ),
        ("environment_temporal.ron", vec![SuiteFamily::Environment], Some(SuiteFamily::Environment)),
        ("environment_shadows.ron", vec![SuiteFamily::Environment], None),
    ] {
        let path = root.join("pipelines").join(pipeline);
        let mut expected = candidates.clone();
        expected.push(SuiteFamily::Shadows);
        assert_eq!(candidate_families(&reg, &path).unwrap(), expected, "{pipeline}");
        let chosen = suite_for(&tiny_suite(path, &out));
        match runs {
            Some(f) => assert_eq!(chosen.unwrap(), (f, family_scenes(f)), "{pipeline}"),
            None => {
                let err = chosen.unwrap_err().to_string();
                assert!(err.contains("no suite fits (tried the environment, shadows suites)"), "{err}");
            }
        }
    }
    let opts = tiny_suite(root.join("pipelines/environment_shadows.ron"), &out);
    let scenes = family_scenes(SuiteFamily::Environment);
    let err = run_suite(&opts, &scenes).unwrap_err().to_string();
    assert!(err.contains(&format!("cannot render {} of the suite's {} scenes", scenes.len(), scenes.len())), "{err}");
    for s in &scenes {
        assert!(err.contains(&format!("scene `{}`", s.strip_prefix("builtin:").unwrap())), "{s}: {err}");
    }
    assert!(err.contains("error[missing-light]") && err.contains("--suite-scenes"), "{err}");
    assert!(!out.exists(), "nothing written");
}

/// A suite bench at its smallest (the CI smoke size of a family's suite): 40×30, reference 32 spp,
/// μ 1, baselines at 2 and 8 spp.
fn tiny_suite(pipeline: PathBuf, out: &Path) -> BenchOptions {
    BenchOptions {
        width: Some(40),
        height: Some(30),
        reference_spp: Some(32),
        mu_values: Some(vec![1.0]),
        baseline_spp: Some(vec![2, 8]),
        ..BenchOptions { quick: true, ..BenchOptions::new(pipeline, out) }
    }
}

/// The motion suite (issue 35) in small: the report splits the error of a scene with movers into
/// moving and static pixels (and texture), where the Motion node samples the shutter.
#[test]
fn motion_suite_smoke_splits_the_error_into_moving_and_static_pixels() {
    use wedge::bench::suite::run_suite;
    use wedge::scene::builtin::SuiteFamily;
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    let opts = tiny_suite(root.join("pipelines/motion_shadows_indirect.ron"), dir.path());
    let r = run_suite(&opts, &["builtin:mo_fast_thin".to_string()]).expect("motion suite runs");
    assert_eq!(r.family, SuiteFamily::Motion);
    let report = std::fs::read_to_string(dir.path().join("mo_fast_thin/report.md")).unwrap();
    for needle in ["| motion | static |", "| motion | moving |", "| texture | flat |", "moving = the surface blurs"] {
        assert!(report.contains(needle), "report lacks {needle:?}:\n{report}");
    }
}

/// The environment suite (issue 35) in small: an Environment pipeline picks it, every scene is
/// described, and a scene runs under its own map (the sun's, not the pipeline's).
#[test]
fn environment_suite_smoke_runs_each_scene_under_its_own_map() {
    use wedge::bench::suite::{family_of, family_scenes, run_suite};
    use wedge::scene::builtin::SuiteFamily;
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let reg = wedge::Registries::builtin().nodes;
    let pipeline = root.join("pipelines/environment.ron");
    assert_eq!(family_of(&reg, &pipeline).unwrap(), SuiteFamily::Environment);
    let scenes = family_scenes(SuiteFamily::Environment);
    assert!(scenes.len() >= 8, "{scenes:?}");
    for s in &scenes {
        assert!(
            wedge::scene::builtin::describe(s.strip_prefix("builtin:").unwrap()).is_some(),
            "{s} has no description"
        );
    }
    let dir = tempfile::tempdir().unwrap();
    let opts = tiny_suite(pipeline, dir.path());
    let r = run_suite(&opts, &["builtin:env_sun".to_string()]).expect("environment suite runs");
    assert_eq!(r.family, SuiteFamily::Environment);
    assert!(r.rows[0].rmse.is_finite() && r.rows[0].rays_per_pixel > 1.0);
    let report = std::fs::read_to_string(dir.path().join("env_sun/report.md")).unwrap();
    assert!(report.contains("builtin:sun") || report.contains("env_sun"), "{report}");
    let md = std::fs::read_to_string(&r.table).unwrap();
    assert!(md.contains("Environment pipelines"), "{md}");
}

/// `BenchOptions.scene` (`wedge bench --scene`) benches another scene than the pipeline's.
#[test]
fn bench_on_another_scene() {
    let dir = tempfile::tempdir().unwrap();
    let opts = BenchOptions {
        scene: Some("builtin:suite_grate".into()),
        width: Some(40),
        height: Some(30),
        reference_spp: Some(32),
        mu_values: Some(vec![2.0]),
        baseline_spp: Some(vec![2, 8]),
        ..options(dir.path())
    };
    let r = run(&opts).expect("bench on suite_grate");
    assert_eq!(r.scene, "suite_grate");
    let report = std::fs::read_to_string(&r.report).unwrap();
    assert!(report.contains("Scene `suite_grate`"), "{report}");
}

/// `--compare`: a second pipeline for the same effect (LightField beside Indirect) is measured on
/// the bench's scene and reference, with its own speedups, rows and plot series.
#[test]
fn compared_pipelines_share_the_tables() {
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let opts = BenchOptions {
        width: Some(32),
        height: Some(24),
        reference_spp: Some(32),
        mu_values: Some(vec![1.0]),
        baseline_spp: Some(vec![2, 8]),
        compare: vec![root.join("pipelines/lightfield_indirect.ron")],
        ..BenchOptions::new(root.join("pipelines/indirect.ron"), dir.path())
    };
    let r = run(&opts).expect("bench with a compared pipeline");
    let compared: Vec<_> = r.runs.iter().filter(|x| x.method == Method::Compared).collect();
    assert_eq!(compared.len(), 2, "one sweep run and its second seed");
    let sweep = compared.iter().find(|x| x.role == Role::Sweep).unwrap();
    assert_eq!(sweep.compared.as_deref(), Some("lightfield_indirect"));
    assert_eq!(sweep.speedups.len(), 2, "against both baselines");
    assert!(sweep.metrics.rmse.is_finite() && sweep.bias_variance.is_some());
    let report = std::fs::read_to_string(&r.report).unwrap();
    assert!(report.contains("| lightfield_indirect |"), "{report}");
    let csv = std::fs::read_to_string(&r.csv).unwrap();
    assert!(csv.lines().any(|l| l.starts_with("compared,sweep,lightfield_indirect")), "{csv}");
}

/// `--suite` frames each scene with the scene's own camera (`Overrides::scene_camera`): a pipeline
/// whose `camera:` block was written for another scene would otherwise see the suite scene from
/// there (`dof_room` came out black under `defocus_motion_shadows_indirect.ron`'s block). The
/// render, the graph's camera block and the reference all take the scene's view and lens; the
/// block's shutter stays.
#[test]
fn the_suite_frames_each_scene_with_its_own_camera() {
    use wedge::session::{Overrides, Session};
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let pipeline = root.join("pipelines/defocus_motion_shadows_indirect.ron");
    let scene = wedge::scene::load(&wedge::scene::SceneSource::Builtin("dof_room".into())).unwrap();
    let ov =
        Overrides { scene: Some("builtin:dof_room".into()), width: Some(8), height: Some(6), ..Default::default() };
    let own = Session::open(Some(&pipeline), &Overrides { scene_camera: true, ..ov.clone() }).unwrap();
    let cam = own.scene.camera;
    assert_eq!((cam.position, cam.look_at, cam.up), (scene.camera.position, scene.camera.look_at, scene.camera.up));
    assert_eq!((cam.vfov_deg, cam.aperture_radius), (scene.camera.vfov_deg, scene.camera.aperture_radius));
    let block = own.pipeline.pipeline.camera.as_ref().expect("the block stays, with the scene's view");
    assert_eq!(block.position, (cam.position.x, cam.position.y, cam.position.z));
    assert_eq!(block.aperture_radius, scene.camera.aperture_radius);
    assert_eq!(block.focus_distance, Some(scene.camera.effective_focus_distance()));
    // A scene without a lens keeps the pipeline's (the block's aperture 0.04), seen from its own view.
    let pinhole = wedge::scene::load(&wedge::scene::SceneSource::Builtin("grids".into())).unwrap();
    assert_eq!(pinhole.camera.aperture_radius, 0.0);
    let grids = Overrides { scene: Some("builtin:grids".into()), scene_camera: true, ..ov.clone() };
    let grids = Session::open(Some(&pipeline), &grids).unwrap();
    assert_eq!((grids.scene.camera.position, grids.scene.camera.aperture_radius), (pinhole.camera.position, 0.04));
    // Nor does a camera path written for the pipeline's scene move a suite scene's camera.
    let temporal = root.join("pipelines/environment_temporal.ron");
    let env = wedge::scene::load(&wedge::scene::SceneSource::Builtin("env_sun".into())).unwrap();
    let sun = Overrides { scene: Some("builtin:env_sun".into()), scene_camera: true, ..ov.clone() };
    let sun = Session::open(Some(&temporal), &sun).unwrap();
    assert_eq!((sun.scene.camera.position, sun.scene.camera.look_at), (env.camera.position, env.camera.look_at));
    // Without it, the pipeline's block frames the scene, as a render of the pipeline does.
    let theirs = Session::open(Some(&pipeline), &ov).unwrap();
    assert_eq!(theirs.scene.camera.position, glam::Vec3::new(0.0, 2.2, 4.2));
    // The suite sets it on every scene's bench.
    let dir = tempfile::tempdir().unwrap();
    wedge::bench::suite::run_suite(&tiny_suite(pipeline, dir.path()), &["builtin:dof_room".into()]).unwrap();
    let cached = std::fs::read_dir(dir.path().join(".cache")).unwrap().map(|e| e.unwrap().path());
    let exr = cached.into_iter().find(|p| p.extension().is_some_and(|e| e == "exr")).expect("a cached reference");
    let img = wedge::image::read_exr(&exr).unwrap();
    let mean = img.pixels.iter().flatten().map(|&v| f64::from(v)).sum::<f64>() / (3 * img.pixels.len()) as f64;
    assert!(mean > 0.05, "dof_room's reference is dark (mean {mean}): seen from the pipeline's camera");
}
