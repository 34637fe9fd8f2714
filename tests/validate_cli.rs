//! Issue 33, silently wrong inputs and misleading messages, at the command line: camera paths are
//! held to the camera rules before anything renders, parameter values mean what they say, and a
//! pixel-accumulating node over a moving camera is warned about (a wiring against the stage order:
//! `graph/tests/validate.rs`; an `Add` after Defocus, which now runs after it:
//! `tests/composition.rs`). Inputs are written by each test to a temporary directory.

mod common;

use std::fs;
use std::path::PathBuf;
use std::process::Output;

use common::cli::wedge;

fn temp_dir(name: &str) -> PathBuf {
    common::cli::temp_dir("validate-cli", name)
}

/// Assert exit `code`, no panic, and every fragment in stderr; returns stderr.
fn stderr_of(o: &Output, code: i32, needles: &[&str]) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(code), "exit code; stderr: {err}");
    assert!(!err.contains("panicked"), "must not panic: {err}");
    for n in needles {
        assert!(err.contains(n), "stderr should mention {n:?}: {err}");
    }
    err
}

/// An Environment pipeline on `builtin:envmap` with `camera` (a line or "") and the path `keys`.
fn env_path(camera: &str, keys: &str, params: &str) -> String {
    format!(
        "Pipeline(\n    scene: \"builtin:envmap\", width: 16, height: 12,\n    {camera}\n    camera_path: [\n{keys}    ],\n    nodes: [\n        (name: \"env\", kind: \"Environment\", params: {{{params}}}),\n        (name: \"out\", kind: \"Output\", inputs: {{\"color\": \"env.radiance\"}}),\n    ],\n)\n"
    )
}

const SWAP: &str = "        (frame: 0, position: (0, 1, 3), look_at: (0, 1, 0)),\n        (frame: 9, position: (0, 1, 0), look_at: (0, 1, 3)),\n";
const OVER_THE_TOP: &str = "        (frame: 0, position: (0, 2, 1), look_at: (0, 1, 0)),\n        (frame: 10, position: (0, 2, -1), look_at: (0, 1, 0)),\n";

#[test]
fn camera_paths_through_their_target_or_along_up_are_refused_before_rendering() {
    let dir = temp_dir("path");
    fs::write(dir.join("swap.ron"), env_path("", SWAP, "")).unwrap();
    for args in [&["graph", "swap.ron"][..], &["render", "swap.ron", "--out", "o", "--frames", "0..9"]] {
        stderr_of(&wedge(args, &dir), 1, &[
            "swap.ron:5:17: error[bad-camera]: camera path between key 1 (frame 0, line 5) and key 2 (frame 9, line 6)",
            "at frame 4.5 (between frames 4 and 5)",
            "equals `position`",
        ]);
    }
    assert!(!dir.join("o").exists(), "nothing rendered");
    // Looking straight down along the scene camera's `up` at frame 5: no camera block, so the
    // scene decides `up`; refused once it is loaded, still before any frame.
    fs::write(dir.join("top.ron"), env_path("", OVER_THE_TOP, "")).unwrap();
    stderr_of(
        &wedge(&["render", "top.ron", "--out", "o", "--frames", "0..1"], &dir),
        1,
        &[
            "top.ron:5:17: error[bad-camera]",
            "the camera at frame 5 breaks a camera rule: camera `up` [0.0, 1.0, 0.0] is parallel to the view direction",
            "add a key in between",
        ],
    );
    assert!(!dir.join("o").exists(), "nothing rendered");
}

#[test]
fn parameter_values_mean_what_they_say() {
    let dir = temp_dir("params");
    let still = "        (frame: 0, position: (0, 1, 3), look_at: (0, 1, 0)),\n";
    fs::write(dir.join("b_e.ron"), env_path("", still, r#""b_e": -0.5"#)).unwrap();
    stderr_of(&wedge(&["graph", "b_e.ron"], &dir), 1, &[
        "b_e.ron:8:53: error[param-out-of-range]",
        "b_e = -0.5 is out of range; it must be -1 (automatic: the map's 99%-energy bandwidth) or satisfy 0 <= b_e <= 10000",
    ]);
    fs::write(dir.join("scale.ron"), env_path("", still, r#""scale": 1e-300"#)).unwrap();
    stderr_of(&wedge(&["graph", "scale.ron"], &dir), 1, &[
        "scale.ron:8:53",
        "scale = 1e-300 is 0 in single precision (f32), which the kernels compute in; write a value of magnitude at least 1.1754944e-38",
    ]);
    // The same through `--set`, blamed on the value.
    fs::write(dir.join("ok.ron"), env_path("", still, "")).unwrap();
    stderr_of(
        &wedge(&["render", "ok.ron", "--out", "o", "--set", "env.mu=1e-300"], &dir),
        1,
        &["--set env.mu: mu = 1e-300 is 0 in single precision (f32)"],
    );
    assert!(!dir.join("o").exists(), "nothing rendered");
    let pf = "Pipeline(scene: \"builtin:cornell\", width: 16, height: 12, nodes: [\n    (name: \"pf\", kind: \"PixelFilter\", params: {\"sigma_c\": 1e-300}),\n    (name: \"out\", kind: \"Output\", inputs: {\"color\": \"pf.radiance\"}),\n])\n";
    fs::write(dir.join("sigma.ron"), pf).unwrap();
    stderr_of(&wedge(&["graph", "sigma.ron"], &dir), 1, &["sigma.ron:2:", "sigma_c = 1e-300 is 0 in single precision"]);
}

#[test]
fn a_pixel_filter_over_a_moving_camera_is_warned_about_once() {
    let dir = temp_dir("pixel");
    let text = r#"Pipeline(scene: "builtin:cornell", width: 8, height: 6,
    camera_path: [
        (frame: 0, position: (0, 1, 3.5), look_at: (0, 1, 0)),
        (frame: 2, position: (0.5, 1, 3.5), look_at: (0, 1, 0)),
    ],
    nodes: [
        (name: "pf", kind: "PixelFilter"),
        (name: "out", kind: "Output", inputs: {"color": "pf.radiance"}),
    ],
)
"#;
    fs::write(dir.join("pf.ron"), text).unwrap();
    let err = stderr_of(&wedge(&["render", "pf.ron", "--out", "o", "--frames", "0..1"], &dir), 0, &[
        "warning: pf.ron:7:16: node `pf` (PixelFilter) averages its progressive path-traced radiance",
        "over frames 0..1 pixel by pixel, but the camera moves along the pipeline's `camera_path` (keys at frames 0..2)",
    ]);
    assert_eq!(err.matches("smeared light").count(), 1, "{err}");
    // After the last key the camera holds still: no warning.
    let err = stderr_of(&wedge(&["render", "pf.ron", "--out", "o2", "--frames", "3..4"], &dir), 0, &[]);
    assert!(!err.contains("warning: pf.ron"), "{err}");
}
