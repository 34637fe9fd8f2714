//! Camera paths (issue 33): every camera along a path is held to the rules a `camera:` block is,
//! checked at validation (before any scene is loaded or frame rendered), with the keys' lines.

mod common;

use common::*;
use wedge_graph::*;

/// A pipeline with `camera` (a `camera:` line or "") and the path `keys` (frame, position, look_at).
fn with_path(camera: &str, keys: &[(u32, &str, &str)]) -> String {
    let mut s =
        format!("Pipeline(\n    scene: \"builtin:grids\", width: 64, height: 32,\n    {camera}\n    camera_path: [\n");
    for (frame, position, look_at) in keys {
        s.push_str(&format!("        (frame: {frame}, position: {position}, look_at: {look_at}),\n"));
    }
    s.push_str("    ],\n    nodes: [\n        (name: \"src\", kind: \"Source\"),\n        (name: \"out\", kind: \"Sink\", inputs: {\"color\": \"src.a\"}),\n    ],\n)\n");
    s
}

const CAMERA: &str = "camera: Some((position: (0, 1, 3), look_at: (0, 1, 0), vfov_deg: 45)),";

#[test]
fn keys_swapping_position_and_look_at_are_refused_at_the_frame_they_meet() {
    // 0..10: the camera reaches its target at frame 5 exactly.
    let d = diagnostics(&with_path(CAMERA, &[(0, "(0, 1, 3)", "(0, 1, 0)"), (10, "(0, 1, 0)", "(0, 1, 3)")]));
    assert_eq!(d.len(), 1, "{d:#?}");
    assert_eq!((d[0].kind, d[0].location.line), (DiagnosticKind::BadCamera, 5));
    assert_eq!(
        d[0].message,
        "camera path between key 1 (frame 0, line 5) and key 2 (frame 10, line 6): the camera at frame 5 breaks a camera rule: camera `look_at` [0.0, 1.0, 1.5] equals `position`, so there is no view direction"
    );
    assert!(d[0].help.contains("change one key's `look_at`"), "{}", d[0].help);
    // 0..9: it passes through between frames 4 and 5, refused too (without a camera block as well).
    for camera in [CAMERA, ""] {
        let d = diagnostics(&with_path(camera, &[(0, "(0, 1, 3)", "(0, 1, 0)"), (9, "(0, 1, 0)", "(0, 1, 3)")]));
        assert_eq!(d.len(), 1, "{d:#?}");
        assert!(d[0].message.contains("at frame 4.5 (between frames 4 and 5)"), "{}", d[0].message);
    }
}

#[test]
fn a_view_along_up_between_keys_is_refused_with_a_camera_block() {
    // Over the top of the target: frame 5 looks straight down along the block's `up` (0, 1, 0).
    let text = with_path(CAMERA, &[(0, "(0, 2, 1)", "(0, 1, 0)"), (10, "(0, 2, -1)", "(0, 1, 0)")]);
    let d = diagnostics(&text);
    assert_eq!(d.len(), 1, "{d:#?}");
    assert!(
        d[0].message.contains("the camera at frame 5 breaks a camera rule: camera `up` [0.0, 1.0, 0.0] is parallel"),
        "{}",
        d[0].message
    );
    assert!(d[0].help.contains("add a key in between"), "{}", d[0].help);
    // Without a block the scene's camera decides `up`: checked when a session has loaded it.
    let text = with_path("", &[(0, "(0, 2, 1)", "(0, 1, 0)"), (10, "(0, 2, -1)", "(0, 1, 0)")]);
    let loaded = parse(&text);
    assert!(validate(&loaded, &registry()).is_ok());
    let Err(GraphError::Invalid(d)) = check_camera_path(&loaded, (0.0, 1.0, 0.0)) else {
        panic!("a view along up passed")
    };
    assert_eq!((d.len(), d[0].location.line), (1, 5), "{d:#?}");
    assert!(check_camera_path(&loaded, (1.0, 0.0, 0.0)).is_ok());
}

#[test]
fn ordinary_paths_pass_and_the_renderer_interpolates_the_same_way() {
    let keys = [
        (0, "(-0.8, 1.6, 3.3)", "(0, 0.45, 0)"),
        (23, "(0.8, 1.6, 3.3)", "(0, 0.45, 0)"),
        (4000000000, "(3, 1, -3)", "(0, 0.45, 0)"),
    ];
    let loaded = parse(&with_path(CAMERA, &keys));
    assert!(validate(&loaded, &registry()).is_ok());
    let path = &loaded.pipeline.camera_path;
    assert_eq!(camera_path_at(path, 0), Some(((-0.8, 1.6, 3.3), (0.0, 0.45, 0.0))));
    let (p, _) = camera_path_at(path, 23).unwrap();
    assert_eq!(p, (0.8, 1.6, 3.3));
    assert_eq!(camera_path_at(path, u32::MAX).unwrap().0, (3.0, 1.0, -3.0));
}
