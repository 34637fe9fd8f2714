//! Issue 37's per-task parts, through the binary: progress lines (one per 10% of a task's work,
//! human or JSON, never changing the image), frame shards (`--frames A..B --shard I/N`, each frame
//! byte-identical to an unsharded `--frames A..B`, history pipelines by chunks with a warm-up or
//! refused) and tiles of frames (`--tile` with `--frames`, merged per frame).

mod common;

use std::fs;
use std::path::Path;
use std::process::Output;

use common::cli::{pipeline, refused, temp_dir, wedge};

fn ok(o: &Output) -> (String, String) {
    let (out, err) = (String::from_utf8_lossy(&o.stdout).into_owned(), String::from_utf8_lossy(&o.stderr).into_owned());
    assert!(o.status.success(), "failed: {out}{err}");
    (out, err)
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn same_bytes(a: &Path, b: &Path) {
    let (x, y) = (
        fs::read(a).unwrap_or_else(|e| panic!("{}: {e}", a.display())),
        fs::read(b).unwrap_or_else(|e| panic!("{}: {e}", b.display())),
    );
    assert!(x == y, "{} and {} differ", a.display(), b.display());
}

const SMALL: [&str; 4] = ["--width", "48", "--height", "36"];

/// The percents of the progress lines in `stderr`: monotone, each a multiple of 10, ending at 100.
fn percents(stderr: &str, json: bool) -> Vec<u64> {
    let p: Vec<u64> = if json {
        stderr
            .lines()
            .filter(|l| l.starts_with('{'))
            .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap_or_else(|e| panic!("`{l}` is not JSON: {e}")))
            .map(|v| v["percent"].as_u64().unwrap_or_else(|| panic!("no percent in {v}")))
            .collect()
    } else {
        stderr
            .lines()
            .filter_map(|l| l.strip_prefix("progress: "))
            .map(|l| l.split('%').next().unwrap().parse().unwrap())
            .collect()
    };
    assert!(!p.is_empty() && p.len() <= 10, "{p:?} in {stderr}");
    assert!(p.windows(2).all(|w| w[0] < w[1]) && p.iter().all(|x| x % 10 == 0), "not monotone tenths: {p:?}");
    assert_eq!(p.last(), Some(&100), "{stderr}");
    p
}

#[test]
fn progress_lines_for_every_kind_of_task_and_the_same_image() {
    let d = temp_dir("frames_farm", "progress");
    let shadows = pipeline("shadows.ron");
    // A plain render: human lines; the image is the same with JSON lines and with none.
    let (_, err) = ok(&wedge(&[&["render", &shadows], &SMALL[..], &["--out", "human"]].concat(), &d));
    assert_eq!(percents(&err, false).len(), 10, "shadows.ron has more than 10 passes: one line per tenth: {err}");
    let (_, err) =
        ok(&wedge(&[&["render", &shadows], &SMALL[..], &["--progress", "json", "--out", "json"]].concat(), &d));
    percents(&err, true);
    let first: serde_json::Value = serde_json::from_str(err.lines().find(|l| l.starts_with('{')).unwrap()).unwrap();
    assert_eq!(
        (first["task"].as_str(), first["tile"].is_null(), first["frame"].is_null()),
        (Some("render"), true, true),
        "{first}"
    );
    let (_, err) =
        ok(&wedge(&[&["render", &shadows], &SMALL[..], &["--progress", "none", "--out", "none"]].concat(), &d));
    assert!(!err.contains("progress:") && !err.contains("\"percent\""), "{err}");
    for out in ["json", "none"] {
        same_bytes(&d.join("human/render.exr"), &d.join(out).join("render.exr"));
    }
    // A tile: the lines name it.
    let (_, err) = ok(&wedge(
        &[&["render", &shadows], &SMALL[..], &["--tile", "2/4", "--progress", "json", "--out", "t"]].concat(),
        &d,
    ));
    percents(&err, true);
    assert!(err.contains("\"tile\":\"2/4\"") && err.contains("\"task\":\"tile\""), "{err}");
    // Frames: the frame of each line, in order.
    let (_, err) = ok(&wedge(&[&["render", &shadows], &SMALL[..], &["--frames", "3..5", "--out", "f"]].concat(), &d));
    percents(&err, false);
    assert!(err.contains("progress: 10% frame 3") && err.contains("progress: 100% frame 5"), "{err}");
    // A progressive render: its frames.
    let (_, err) = ok(&wedge(
        &[&["render", &pipeline("progressive_pixel.ron")], &SMALL[..], &["--progressive", "3", "--out", "p"]].concat(),
        &d,
    ));
    percents(&err, false);
    assert!(err.contains("progress: 100% frame 2"), "{err}");
    // An auto-tiled render (the whole image over --memory-limit): tile numbers of the grid.
    let base = ["--width", "192", "--height", "144", "--set", "shadows.max_radius=4", "--set", "shadows.fill_radius=2"];
    let (out, err) =
        ok(&wedge(&[&["render", &shadows], &base[..], &["--memory-limit", "24M", "--out", "a"]].concat(), &d));
    assert!(out.contains("rendered as"), "{out}");
    percents(&err, false);
    assert!(err.contains("progress: 100% tile "), "{err}");
}

/// Every frame of `--frames A..B` rendered as `n` shards into one directory has the bytes of the
/// unsharded sequence's frame.
fn shards_equal_whole(pipeline: &str, (a, b): (u32, u32), n: u32, mode: &str, d: &Path) -> Vec<String> {
    let range = format!("{a}..{b}");
    ok(&wedge(&[&["render", pipeline], &SMALL[..], &["--frames", &range, "--out", "whole"]].concat(), d));
    let mut logs = Vec::new();
    for i in 0..n {
        let shard = format!("{i}/{n}");
        let (out, err) = ok(&wedge(
            &[
                &["render", pipeline],
                &SMALL[..],
                &["--frames", &range, "--shard", &shard, "--shard-mode", mode, "--out", "shards"],
            ]
            .concat(),
            d,
        ));
        logs.push(format!("{out}{err}"));
    }
    for f in a..=b {
        same_bytes(&d.join(format!("whole/frame_{f:04}.exr")), &d.join(format!("shards/frame_{f:04}.exr")));
        same_bytes(&d.join(format!("whole/frame_{f:04}.png")), &d.join(format!("shards/frame_{f:04}.png")));
    }
    // Shards write their frames only: the preview and the last frame's outputs are the sequence's.
    let names: Vec<String> = fs::read_dir(d.join("shards"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(names.iter().all(|f| f.starts_with("frame_")), "{names:?}");
    assert_eq!(names.len() as u32, 2 * (b - a + 1), "{names:?}");
    logs
}

#[test]
fn frame_shards_are_the_unsharded_frames() {
    let d = temp_dir("frames_farm", "stride");
    let logs = shards_equal_whole(&pipeline("shadows.ron"), (2, 6), 2, "stride", &d);
    assert!(
        logs[1].contains("wrote shards/frame_0003.exr") && logs[1].contains("wrote shards/frame_0005.exr"),
        "{}",
        logs[1]
    );
    let d = temp_dir("frames_farm", "chunks");
    shards_equal_whole(&pipeline("shadows.ron"), (0, 4), 3, "chunks", &d);
}

#[test]
fn history_pipelines_shard_by_chunks_with_a_warm_up() {
    let temporal = pipeline("environment_temporal.ron");
    let d = temp_dir("frames_farm", "history");
    let logs = shards_equal_whole(&temporal, (0, 4), 2, "chunks", &d);
    // Shard 1 holds frames 2..4 and renders 0..1 first, unwritten.
    assert!(
        logs[1].contains("warming up the frame history on frames 0..1") && logs[1].contains("2 warm-up frame(s)"),
        "{}",
        logs[1]
    );
    assert!(
        !logs[1].contains("frame_0000") && !logs[1].contains("frame_0001"),
        "warm-up frames are not written: {}",
        logs[1]
    );
    let o = wedge(
        &[&["render", &temporal], &SMALL[..], &["--frames", "0..4", "--shard", "0/2", "--out", "x"]].concat(),
        &d,
    );
    refused(&o, &["--shard 0/2", "keeps frame history", "--shard-mode chunks"]);
    let o =
        wedge(&[&["render", &temporal], &SMALL[..], &["--frames", "0..1", "--tile", "0/2", "--out", "x"]].concat(), &d);
    refused(&o, &["--tile with --frames", "keeps frame history"]);
}

#[test]
fn bad_shards_are_refused_by_flag() {
    let d = temp_dir("frames_farm", "bad");
    let shadows = pipeline("shadows.ron");
    refused(
        &wedge(&["render", &shadows, "--frames", "0..1", "--shard", "0/3", "--out", "x"], &d),
        &["--shard 0/3", "2 frame(s)", "at most 2 shards"],
    );
    refused(&wedge(&["render", &shadows, "--frames", "0..3", "--shard", "2/2"], &d), &["--shard", "does not exist"]);
    refused(&wedge(&["render", &shadows, "--shard", "0/2"], &d), &["--frames"]);
    refused(&wedge(&["render", &shadows, "--progress", "loud"], &d), &["--progress"]);
    refused(&wedge(&["render", &shadows, "--frames", "0..3", "--shard-mode", "chunks"], &d), &["--shard"]);
    assert!(!d.join("x").exists(), "nothing written");
}

/// `--tile I/N --frames A..B`: tile I of each frame into OUT/frame_FFFF/, which `wedge merge` turns
/// into that frame's image, byte-identical to the unsharded sequence's frame.
#[test]
fn tiles_of_frames_merge_into_the_frames() {
    let d = temp_dir("frames_farm", "tiled_frames");
    let shadows = pipeline("shadows.ron");
    let size = ["--width", "160", "--height", "120", "--set", "shadows.max_radius=8"];
    ok(&wedge(&[&["render", &shadows], &size[..], &["--frames", "1..2", "--out", "whole"]].concat(), &d));
    for t in 0..4 {
        let tile = format!("{t}/4");
        ok(&wedge(
            &[&["render", &shadows], &size[..], &["--frames", "1..2", "--tile", &tile, "--out", "tiles"]].concat(),
            &d,
        ));
    }
    for f in 1..=2 {
        let frame = format!("frame_{f:04}");
        ok(&wedge(&["merge", s(&d.join("tiles").join(&frame)), "--out", s(&d.join("merged").join(&frame))], &d));
        same_bytes(&d.join(format!("whole/{frame}.exr")), &d.join(format!("merged/{frame}/render.exr")));
    }
    // Tiles of two frames do not merge into one image.
    fs::copy(d.join("tiles/frame_0001/tile_0000_of_0004.exr"), d.join("tiles/frame_0002/tile_0000_of_0004.exr"))
        .unwrap();
    refused(
        &wedge(&["merge", s(&d.join("tiles/frame_0002")), "--out", s(&d.join("bad"))], &d),
        &["do not belong", "frame 1", "frame 2"],
    );
}
