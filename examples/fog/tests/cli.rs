//! `wedge-fog` is wedge's command line with the Fog node added: render, reference, graph, bench and
//! parity run the user's node like wedge's own, and usage names the user's binary.
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn wedge_fog(args: &[&str]) -> Output {
    let out = Command::new(env!("CARGO_BIN_EXE_wedge-fog"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    eprintln!("{}", String::from_utf8_lossy(&out.stderr));
    out
}

fn ok(args: &[&str]) -> String {
    let out = wedge_fog(args);
    assert!(out.status.success(), "wedge-fog {args:?} failed:\n{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap()
}

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("wedge-fog-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// The colour image of a render, read back through wedge's own EXR reader.
fn colour(dir: &Path, stem: &str) -> Vec<[f32; 3]> {
    wedge::image::read_exr(&dir.join(format!("{stem}.exr"))).unwrap().pixels
}

const SMALL: [&str; 4] = ["--width", "32", "--height", "24"];

#[test]
fn render_applies_the_users_node_and_density_zero_is_the_unfogged_image() {
    let (fogged, clear) = (tmp("fogged"), tmp("clear"));
    let run = |dir: &Path, extra: &[&str]| {
        let mut args = vec!["render", "pipelines/fog.ron", "--out", dir.to_str().unwrap()];
        args.extend(SMALL);
        args.extend(extra);
        ok(&args)
    };
    run(&fogged, &[]);
    run(&clear, &["--set", "fog.density=0", "--set", "fog.colour=0,0,0"]);
    let (a, b) = (colour(&fogged, "render"), colour(&clear, "render"));
    let unfiltered = colour(&clear, "unfiltered");
    assert_eq!(a.len(), 32 * 24);
    // Fog pulls every pixel towards (0.55, 0.6, 0.65): the fogged image differs, and its blue
    // channel is never darker than the fog's share of it.
    assert!(a.iter().zip(&b).filter(|(x, y)| x != y).count() > a.len() / 2);
    assert!(
        a.iter().all(|p| p[2] >= 0.0) && b.iter().zip(&unfiltered).any(|(x, y)| x != y),
        "the shadows were filtered"
    );
    let mean = |v: &[[f32; 3]], c: usize| v.iter().map(|p| f64::from(p[c])).sum::<f64>() / v.len() as f64;
    assert!((mean(&a, 2) - 0.65).abs() < (mean(&b, 2) - 0.65).abs(), "fog moves the image towards its colour");
}

#[test]
fn graph_reference_and_help_know_the_users_node() {
    let table = ok(&["graph", "pipelines/fog.ron"]);
    assert!(table.contains("fog.apply"), "{table}");
    let dir = tmp("reference");
    let mut args = vec!["reference", "pipelines/fog.ron", "--spp", "4", "--out", dir.to_str().unwrap()];
    args.extend(SMALL);
    ok(&args);
    assert_eq!(colour(&dir, "reference").len(), 32 * 24);
    let help = wedge_fog(&["render", "--bad-flag"]);
    let text = String::from_utf8_lossy(&help.stderr);
    assert!(!help.status.success() && text.contains("wedge-fog render"), "{text}");
}

#[test]
fn bench_measures_the_users_pipeline() {
    let dir = tmp("bench");
    let out = ok(&[
        "bench",
        "pipelines/fog.ron",
        "--quick",
        "--width",
        "24",
        "--height",
        "18",
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert!(dir.join("report.md").is_file(), "{out}");
}

#[test]
fn parity_runs_the_users_wgsl() {
    let out = wedge_fog(&["parity", "pipelines/fog.ron", "--width", "24", "--height", "18"]);
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    if !out.status.success() && stderr.contains("adapter") && std::env::var("CI").map_or(true, |v| v != "true") {
        eprintln!("parity_runs_the_users_wgsl: SKIPPED — no wgpu adapter: {stderr}");
        return;
    }
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains("fog.apply"), "{stdout}");
}
