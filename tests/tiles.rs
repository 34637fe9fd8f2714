//! Tiles (`render --tile I/N`) and `wedge merge`: a merged render.exr is byte-identical to a
//! single-process render; merge refuses missing, extra and mismatched tiles by name; every shipped
//! pipeline either tiles exactly or is refused with the node that reads the whole image.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use wedge::backends::cpu::CpuBackend;
use wedge::backends::Silent;
use wedge::graph::ParamValue;
use wedge::{Overrides, Session};

fn wedge(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_wedge")).args(args).current_dir(repo()).output().expect("wedge runs")
}

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn ok(o: &Output) -> String {
    let (out, err) = (String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    assert!(o.status.success(), "failed: {out}{err}");
    out.into_owned()
}

/// stderr of a clean refusal (exit 1, or 2 for a flag clap refuses; no panic) holding every needle.
fn refused(o: &Output, needles: &[&str]) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(matches!(o.status.code(), Some(1 | 2)), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    for n in needles {
        assert!(err.contains(n), "`{n}` not in: {err}");
    }
    err
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The apron `render --tile` reports.
fn apron(stdout: &str) -> u32 {
    let after = stdout.split("apron ").nth(1).unwrap_or_else(|| panic!("no apron in {stdout}"));
    after.split(' ').next().unwrap().parse().unwrap()
}

/// Render `pipeline` (with `extra` flags) whole into `dir/whole` and as `n` tiles into
/// `dir/tiles`, merge into `dir/merged`; the paths of the two render.exr files. The apron must be
/// smaller than the tiles' share of the image, or the test would compare whole images.
fn whole_and_merged(
    pipeline: &str,
    backend: &str,
    (w, h): (u32, u32),
    n: u32,
    extra: &[&str],
    dir: &Path,
) -> (PathBuf, PathBuf) {
    let size = [w.to_string(), h.to_string()];
    let common = [&["--width", &size[0], "--height", &size[1], "--backend", backend][..], extra].concat();
    let whole = dir.join("whole");
    ok(&wedge(&[&["render", pipeline], &common[..], &["--out", s(&whole)]].concat()));
    let tiles = dir.join("tiles");
    for i in 0..n {
        let tile = format!("{i}/{n}");
        let out = ok(&wedge(&[&["render", pipeline], &common[..], &["--tile", &tile, "--out", s(&tiles)]].concat()));
        assert!(apron(&out) < w.min(h) / 2, "the apron covers the image: {out}");
    }
    let merged = dir.join("merged");
    let out = ok(&wedge(&["merge", s(&tiles), "--out", s(&merged)]));
    assert!(out.contains("render.exr"), "{out}");
    (whole.join("render.exr"), merged.join("render.exr"))
}

fn assert_same_bytes(a: &Path, b: &Path) {
    let (x, y) = (std::fs::read(a).unwrap(), std::fs::read(b).unwrap());
    assert!(x == y, "{} and {} differ", a.display(), b.display());
}

#[test]
fn merged_shadows_is_byte_identical() {
    let dir = tempfile::tempdir().unwrap();
    let (whole, merged) = whole_and_merged(
        "pipelines/shadows.ron",
        "cpu",
        (64, 48),
        4,
        &["--set", "shadows.max_radius=4", "--set", "shadows.fill_radius=2"],
        dir.path(),
    );
    assert_same_bytes(&whole, &merged);
    let (w, m) = (whole.with_file_name("unfiltered.exr"), merged.with_file_name("unfiltered.exr"));
    assert_same_bytes(&w, &m);
}

#[test]
fn merged_defocus_is_byte_identical() {
    let dir = tempfile::tempdir().unwrap();
    let (whole, merged) =
        // 96×72: the near layer's pass (`layers`) reads max_radius rows past eq. 5.33's, an apron of
        // 26 px, more than half of 48 rows.
        whole_and_merged("pipelines/defocus.ron", "cpu", (96, 72), 4, &["--set", "defocus.max_radius=4"], dir.path());
    assert_same_bytes(&whole, &merged);
}

#[test]
fn merged_indirect_is_byte_identical() {
    let dir = tempfile::tempdir().unwrap();
    let (whole, merged) =
        whole_and_merged("pipelines/indirect.ron", "cpu", (64, 48), 4, &["--set", "indirect.max_radius=4"], dir.path());
    assert_same_bytes(&whole, &merged);
}

/// The wgpu backend honours tiles too (tiny: lavapipe is slow). Skipped without an adapter, except
/// under CI=true, where that fails (as tests/parity.rs does).
#[test]
fn merged_shadows_on_wgpu_is_byte_identical() {
    if let Err(e) = wedge::backends::gpu::GpuBackend::new() {
        assert!(std::env::var("CI").map_or(true, |v| v != "true"), "CI=true and no wgpu adapter: {e}");
        eprintln!("merged_shadows_on_wgpu_is_byte_identical: SKIPPED — no wgpu adapter: {e}");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let sets = ["--set", "shadows.max_radius=4", "--set", "shadows.fill_radius=2"];
    let (whole, merged) = whole_and_merged("pipelines/shadows.ron", "wgpu", (48, 36), 4, &sets, dir.path());
    assert_same_bytes(&whole, &merged);
}

#[test]
fn tile_grid_and_odd_sizes_merge_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let tiles = dir.path().join("tiles");
    for i in 0..3 {
        ok(&wedge(&[
            "render",
            "--width",
            "37",
            "--height",
            "23",
            "--tile",
            &format!("{i}/3"),
            "--tile-grid",
            "3x1",
            "--out",
            s(&tiles),
        ]));
    }
    let whole = dir.path().join("whole");
    ok(&wedge(&["render", "--width", "37", "--height", "23", "--out", s(&whole)]));
    ok(&wedge(&["merge", s(&tiles), "--out", s(&dir.path().join("m"))]));
    assert_same_bytes(&whole.join("render.exr"), &dir.path().join("m/render.exr"));
}

#[test]
fn merge_names_missing_extra_and_mismatched_tiles() {
    let dir = tempfile::tempdir().unwrap();
    let tiles = dir.path().join("tiles");
    let render = |i: u32, seed: &str, out: &Path| {
        ok(&wedge(&[
            "render",
            "--width",
            "32",
            "--height",
            "24",
            "--seed",
            seed,
            "--tile",
            &format!("{i}/4"),
            "--out",
            s(out),
        ]))
    };
    for i in [0, 1, 3] {
        render(i, "1", &tiles);
    }
    let out = dir.path().join("merged");
    refused(&wedge(&["merge", s(&tiles), "--out", s(&out)]), &["missing", "2/4"]);
    assert!(!out.join("render.exr").exists(), "nothing is written from an incomplete set");
    // Tile 2 from another seed: named as not belonging.
    let other = dir.path().join("other");
    render(2, "2", &other);
    std::fs::copy(other.join("tile_0002_of_0004.exr"), tiles.join("tile_0002_of_0004.exr")).unwrap();
    refused(&wedge(&["merge", s(&tiles), "--out", s(&out)]), &["tile_0002_of_0004.exr", "seed 2", "do not belong"]);
    // Tile 2 from another pipeline (a parameter changed by --set): not belonging either.
    let changed = dir.path().join("changed");
    ok(&wedge(&[
        "render",
        "--width",
        "32",
        "--height",
        "24",
        "--seed",
        "1",
        "--set",
        "shadows.mu=3",
        "--tile",
        "2/4",
        "--out",
        s(&changed),
    ]));
    std::fs::copy(changed.join("tile_0002_of_0004.exr"), tiles.join("tile_0002_of_0004.exr")).unwrap();
    refused(&wedge(&["merge", s(&tiles), "--out", s(&out)]), &["tile_0002_of_0004.exr", "seed 1", "do not belong"]);
    // The right tile 2, plus a copy of tile 1 under another name: an extra tile.
    render(2, "1", &tiles);
    std::fs::copy(tiles.join("tile_0001_of_0004.exr"), tiles.join("copy.exr")).unwrap();
    refused(&wedge(&["merge", s(&tiles), "--out", s(&out)]), &["extra", "tile 1 appears 2 times", "copy.exr"]);
    std::fs::remove_file(tiles.join("copy.exr")).unwrap();
    ok(&wedge(&["merge", s(&tiles), "--out", s(&out)]));
    // A file that is not a tile.
    std::fs::write(tiles.join("junk.exr"), b"not an exr").unwrap();
    refused(&wedge(&["merge", s(&tiles), "--out", s(&out)]), &["junk.exr", "not a wedge tile"]);
}

#[test]
fn bad_tile_flags_are_refused() {
    refused(&wedge(&["render", "--tile", "4/4"]), &["numbered from 0"]);
    refused(&wedge(&["render", "--tile", "0/4", "--tile-grid", "3x1"]), &["disagree"]);
    refused(&wedge(&["render", "--width", "2", "--height", "2", "--tile", "0/9"]), &["does not fit"]);
    refused(&wedge(&["render", "--tile", "0/2", "--progressive", "2"]), &["cannot be used with"]);
    let dir = tempfile::tempdir().unwrap();
    refused(&wedge(&["merge", s(dir.path()), "--out", s(&dir.path().join("o"))]), &["no tile files"]);
}

/// The light field's splat tree reads every sample of the image: tiling is refused, naming the node.
#[test]
fn a_whole_image_pass_refuses_tiles() {
    let dir = tempfile::tempdir().unwrap();
    refused(
        &wedge(&[
            "render",
            "pipelines/lightfield_ao.ron",
            "--width",
            "16",
            "--height",
            "12",
            "--tile",
            "0/4",
            "--out",
            s(dir.path()),
        ]),
        &["cannot be tiled", "Reach::Image", "node `"],
    );
}

/// Radius parameters lowered (`max_radius` 2, …) so that a tile's apron is smaller than the image
/// at the tiny size of [`every_shipped_pipeline_tiles_exactly_or_is_refused`]: with the defaults
/// (up to 64 px per filter pass) every tile of a 48x36 image would compute the whole image.
fn small_reach(path: &Path, ov: &Overrides) -> Overrides {
    let session = Session::open(Some(path), ov).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut params = Vec::new();
    for node in &session.pipeline.nodes {
        for (name, value) in [
            ("max_radius", ParamValue::Int(2)),
            ("max_motion", ParamValue::Int(1)),
            ("fill_radius", ParamValue::Int(1)),
            ("sigma_s", ParamValue::Float(0.7)),
        ] {
            if node.params.contains_key(name) {
                params.push((node.name.clone(), name.to_string(), value));
            }
        }
    }
    Overrides { params, ..ov.clone() }
}

/// Every shipped pipeline, at 48x36 in 4 tiles on the CPU (radius parameters lowered so that the
/// apron is smaller than a tile's share of the image): each tile's pixels are the whole image's
/// bits, or the pipeline is refused with the reason (a pass that reads the whole image).
#[test]
fn every_shipped_pipeline_tiles_exactly_or_is_refused() {
    let mut report = Vec::new();
    let mut paths: Vec<PathBuf> =
        std::fs::read_dir(repo().join("pipelines")).unwrap().map(|e| e.unwrap().path()).collect();
    paths.sort();
    let (w, h) = (48, 36);
    for path in paths.iter().filter(|p| p.extension().is_some_and(|x| x == "ron")) {
        let ov = small_reach(path, &Overrides { width: Some(w), height: Some(h), ..Overrides::default() });
        let session = Session::open(Some(path), &ov).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let whole = session.run(&mut CpuBackend::new(), &Silent).unwrap();
        let grid = wedge::tiles::Grid::near_square(4, (w, h));
        let mut verdict = "tiles exactly".to_string();
        for i in 0..4 {
            match wedge::tiles::render_tile(&session, &mut CpuBackend::new(), &Silent, i, grid) {
                Err(e) => {
                    let e = e.to_string();
                    assert!(e.contains("cannot be tiled") && e.contains("node `"), "{}: {e}", path.display());
                    verdict = format!("refused: {e}");
                    break;
                }
                Ok(tile) => {
                    let r = tile.header.rect;
                    verdict = format!("tiles exactly (apron {} px)", tile.header.apron);
                    for (port, img) in &tile.images {
                        let full = wedge::outputs::buffer_to_image(whole.output(port).unwrap(), w, h);
                        for y in 0..r.h {
                            for x in 0..r.w {
                                let a = img.pixels[(y * r.w + x) as usize].map(f32::to_bits);
                                let b = full.pixels[((r.y + y) * w + r.x + x) as usize].map(f32::to_bits);
                                assert_eq!(
                                    a,
                                    b,
                                    "{}: tile {i} `{port}` differs at ({}, {})",
                                    path.display(),
                                    r.x + x,
                                    r.y + y
                                );
                            }
                        }
                    }
                }
            }
        }
        report.push(format!("{}: {verdict}", path.file_name().unwrap().to_string_lossy()));
    }
    eprintln!("{}", report.join("\n"));
}

/// `wedge farm slurm --dry-run`: an array of one task per tile reading SLURM_ARRAY_TASK_ID, the
/// render flags passed on, and a merge job chained with afterok; nothing is submitted.
#[test]
fn farm_slurm_dry_run_prints_the_array_and_the_merge() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("farm");
    let o = wedge(&[
        "farm",
        "slurm",
        "pipelines/shadows.ron",
        "--tiles",
        "4",
        "--width",
        "160",
        "--height",
        "120",
        "--seed",
        "7",
        "--set",
        "shadows.mu=3",
        "--partition",
        "gpu",
        "--time",
        "00:10:00",
        "--dry-run",
        "--out",
        s(&out),
    ]);
    let text = ok(&o);
    for needle in [
        "#SBATCH --array=0-3",
        "#SBATCH --partition=gpu",
        "#SBATCH --time=00:10:00",
        "--tile \"${SLURM_ARRAY_TASK_ID}/4\"",
        "'--width' '160' '--height' '120'",
        "'--seed' '7'",
        "'--set' 'shadows.mu=3'",
        "merge '",
        "sbatch --parsable --dependency=afterok:${jobid%%;*}",
    ] {
        assert!(text.contains(needle), "`{needle}` not in:\n{text}");
    }
    assert!(!out.exists(), "--dry-run writes nothing");
    // Refused before anything is written: a pipeline that cannot be tiled, an unsafe directive.
    refused(
        &wedge(&["farm", "slurm", "pipelines/lightfield_ao.ron", "--tiles", "4", "--dry-run"]),
        &["cannot be tiled", "node `ao`"],
    );
    refused(
        &wedge(&["farm", "slurm", "pipelines/shadows.ron", "--tiles", "4", "--time", "1 --x", "--dry-run"]),
        &["--time"],
    );
}

/// `--memory-limit` applies to the tile with its apron, not to the whole image: a limit the whole
/// 640x480 render exceeds lets one of its 4 tiles run.
#[test]
fn memory_limit_counts_the_tile_not_the_image() {
    let dir = tempfile::tempdir().unwrap();
    let size = ["--width", "640", "--height", "480", "--memory-limit", "300M"];
    ok(&wedge(&[&["render"], &size[..], &["--tile", "3/4", "--out", s(dir.path())]].concat()));
    assert!(dir.path().join("tile_0003_of_0004.exr").is_file());
}

/// `render` of an image whose whole run does not fit `--memory-limit` picks the fewest tiles that
/// fit and renders them in sequence in one process: the same render.exr and unfiltered.exr bytes as
/// the whole image rendered without the limit. A limit no grid meets is refused with the reason.
#[test]
fn a_render_over_the_memory_limit_runs_as_tiles_with_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let base = ["--width", "192", "--height", "144", "--set", "shadows.max_radius=4", "--set", "shadows.fill_radius=2"];
    let (whole, tiled) = (dir.path().join("whole"), dir.path().join("tiled"));
    ok(&wedge(&[&["render"], &base[..], &["--out", s(&whole)]].concat()));
    let out = wedge(&[&["render"], &base[..], &["--memory-limit", "24M", "--out", s(&tiled)]].concat());
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    let text = ok(&out);
    assert!(err.contains("does not fit the memory limit") && text.contains("rendered as"), "{err}{text}");
    for name in ["render.exr", "unfiltered.exr"] {
        assert_same_bytes(&whole.join(name), &tiled.join(name));
    }
    let small = [&["render"], &base[..], &["--memory-limit", "1M", "--out", s(&tiled)]].concat();
    refused(&wedge(&small), &["memory limit", "rendering it in tiles does not help", "apron of"]);
}
