//! Hardening (issue 10): parse errors that name the real mistake and its fix, size limits checked
//! before parsing and expansion, and camera sanity with the camera field's position. The inputs
//! under `tests/data/bad/pipeline/` are shared with the CLI-level regression tests.

mod common;

use std::path::{Path, PathBuf};

use common::*;
use wedge_graph::*;

fn bad(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/bad/pipeline").join(name)
}

/// Load `tests/data/bad/pipeline/<name>`, expecting a parse error: (line, col, message, help).
fn parse_error_of(name: &str) -> (usize, usize, String, String) {
    match load_pipeline(&bad(name)) {
        Err(GraphError::Parse { location, message, help }) => {
            assert!(location.file.ends_with(name), "{}", location.file.display());
            (location.line, location.col, message, help)
        }
        Err(e) => panic!("expected a parse error, got {e}"),
        Ok(_) => panic!("expected a parse error for {name}"),
    }
}

#[test]
fn byte_order_mark_is_skipped() {
    let loaded = load_pipeline(&bad("bom_ok.ron")).unwrap();
    assert_eq!(loaded.pipeline.width, 64);
    assert_eq!(loaded.pipeline.nodes.len(), 2);
    // Positions count from the first character after the mark.
    assert_eq!(loaded.node_location(0).line, 5);
}

#[test]
fn fractional_number_where_a_whole_number_is_wanted() {
    let (line, col, message, help) = parse_error_of("fractional_width.ron");
    assert_eq!((line, col), (3, 12), "{message}");
    assert!(message.contains("`width` must be a whole number") && message.contains("64.5"), "{message}");
    assert!(help.contains("`width: 64`"), "{help}");
    assert!(!message.contains("comma"), "{message}");
}

#[test]
fn negative_and_too_large_integers() {
    let (line, col, message, help) = parse_error_of("negative_seed.ron");
    assert_eq!((line, col), (5, 11), "{message}");
    assert!(message.contains("`seed` cannot be negative") && message.contains("-1"), "{message}");
    assert!(help.contains("0 to 4294967295"), "{help}");

    let text = pipeline(&[]).replace("width: 64", "width: 4294967296");
    let Err(GraphError::Parse { location, message, .. }) = parse_pipeline(Path::new("t.ron"), &text) else {
        panic!("expected a parse error");
    };
    assert_eq!((location.line, location.col), (2, 36));
    assert!(message.contains("`4294967296` is too large for `width`"), "{message}");
}

#[test]
fn quoted_number_asks_to_remove_the_quotes() {
    let (line, col, message, help) = parse_error_of("quoted_height.ron");
    assert_eq!((line, col), (4, 13), "{message}");
    assert!(message.contains("`height` expects a whole number") && message.contains("\"48\""), "{message}");
    assert!(help.contains("remove the quotes") && help.contains("`height: 480`"), "{help}");
}

#[test]
fn missing_closing_paren_names_the_open_bracket() {
    let (line, _, message, help) = parse_error_of("unclosed.ron");
    assert_eq!(line, 7, "{message}");
    assert!(message.contains("the `(` opened at 1:9 is closed"), "{message}");
    assert!(help.contains("add the missing `)`"), "{help}");
}

#[test]
fn wrong_camera_syntax_shows_the_form() {
    let text =
        pipeline(&[]).replace("nodes:", "camera: (position: (0, 1, 2), look_at: (0, 0, 0), vfov_deg: 45),\n    nodes:");
    let Err(GraphError::Parse { location, message, help }) = parse_pipeline(Path::new("t.ron"), &text) else {
        panic!("expected a parse error");
    };
    assert_eq!((location.line, location.col), (3, 13), "{message}");
    assert!(message.contains("`camera` expects `Some(…)` or `None`"), "{message}");
    assert!(help.contains("camera: Some(("), "{help}");
}

/// The camera diagnostics of a pipeline file: (line, col, message).
fn camera_problems(name: &str) -> Vec<(usize, usize, String)> {
    let loaded = load_pipeline(&bad(name)).unwrap();
    match validate(&loaded, &registry()) {
        Err(GraphError::Invalid(d)) => d
            .into_iter()
            .filter(|d| d.kind == DiagnosticKind::BadCamera)
            .map(|d| {
                assert!(!d.help.is_empty());
                assert_eq!(d.to_string().matches("error[bad-camera]").count(), 1);
                (d.location.line, d.location.col, d.message)
            })
            .collect(),
        Err(e) => panic!("{e}"),
        Ok(_) => Vec::new(),
    }
}

#[test]
fn degenerate_camera_is_refused_at_its_fields() {
    let p = camera_problems("camera_degenerate.ron");
    assert_eq!(p.len(), 2, "{p:#?}");
    assert_eq!((p[0].0, p[0].1), (7, 18));
    assert!(p[0].2.contains("equals `position`"), "{}", p[0].2);
    assert_eq!((p[1].0, p[1].1), (8, 19));
    assert!(p[1].2.contains("vfov_deg` = 180"), "{}", p[1].2);

    let p = camera_problems("camera_nan.ron");
    let at: Vec<(usize, usize)> = p.iter().map(|x| (x.0, x.1)).collect();
    assert_eq!(at, [(6, 19), (8, 13), (10, 26), (11, 25)], "{p:#?}");
    assert!(p[0].2.contains("`position`") && p[0].2.contains("NaN"), "{}", p[0].2);
    assert!(p[1].2.contains("`up` is (0, 0, 0)"), "{}", p[1].2);
    assert!(p[2].2.contains("aperture_radius` = -1"), "{}", p[2].2);
    assert!(p[3].2.contains("focus_distance` = 0"), "{}", p[3].2);

    let p = camera_problems("camera_up_parallel.ron");
    assert_eq!(p.len(), 1, "{p:#?}");
    assert_eq!((p[0].0, p[0].1), (5, 13), "the default `up` is not written: point at the camera");
    assert!(p[0].2.contains("parallel to the view direction"), "{}", p[0].2);
}

#[test]
fn camera_rules_accept_ordinary_cameras() {
    let cam = |position, look_at, up, vfov_deg| CameraSpec {
        position,
        look_at,
        up,
        vfov_deg,
        aperture_radius: 0.0,
        focus_distance: None,
        shutter: None,
    };
    assert!(cam((0.0, 1.0, 4.0), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0), 45.0).problems().is_empty());
    // Straight down with a tilted up is fine; huge but finite coordinates are fine.
    assert!(cam((0.0, 5.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, -1.0), 179.0).problems().is_empty());
    assert!(cam((3e38, 0.0, 0.0), (-3e38, 0.0, 0.0), (0.0, 1.0, 0.0), 0.5).problems().is_empty());
    let p = cam((0.0, 0.0, 0.0), (0.0, 0.0, -1.0), (0.0, 1.0, 0.0), 0.0).problems();
    assert_eq!(p.len(), 1);
    assert_eq!(p[0].field, "vfov_deg");
    let p = cam((0.0, 0.0, 0.0), (0.0, 0.0, -1.0), (0.0, 0.0, f32::INFINITY), 45.0).problems();
    assert_eq!(p.iter().map(|x| x.field).collect::<Vec<_>>(), ["up"]);
}

#[test]
fn oversized_file_is_refused_before_parsing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("huge.ron");
    // A valid-looking pipeline padded with a comment to just over the limit.
    let mut text = pipeline(&[r#"(name: "src", kind: "Source")"#]);
    text.push_str("//");
    text.push_str(&"x".repeat(wedge_graph::pipeline::MAX_PIPELINE_BYTES));
    std::fs::write(&path, &text).unwrap();
    for result in [load_pipeline(&path), parse_pipeline(&path, &text)] {
        match result {
            Err(e @ GraphError::TooLarge { .. }) => {
                let s = e.to_string();
                assert!(s.contains("huge.ron:1:1") && s.contains("limit of 1048576 bytes"), "{s}");
            }
            Err(e) => panic!("expected TooLarge, got {e}"),
            Ok(_) => panic!("expected TooLarge"),
        }
    }
    // A device that never ends is read only up to the limit.
    if Path::new("/dev/zero").exists() {
        assert!(matches!(load_pipeline(Path::new("/dev/zero")), Err(GraphError::TooLarge { .. })));
    }
}

#[test]
fn too_many_nodes_or_long_names_are_refused_after_parsing() {
    let node = r#"(name: "n", kind: "Source")"#;
    let nodes = vec![node; wedge_graph::pipeline::MAX_NODES + 1];
    match parse_pipeline(Path::new("t.ron"), &pipeline(&nodes)) {
        Err(e @ GraphError::TooLarge { .. }) => {
            let s = e.to_string();
            assert!(s.starts_with("t.ron:3:5:"), "{s}");
            assert!(s.contains("1025 nodes, more than the limit of 1024"), "{s}");
        }
        other => panic!("expected TooLarge, got {:?}", other.map(|_| ())),
    }

    let long = format!(r#"(name: "{}", kind: "Source")"#, "a".repeat(300));
    match parse_pipeline(Path::new("t.ron"), &pipeline(&[&long])) {
        Err(e @ GraphError::TooLarge { .. }) => {
            let s = e.to_string();
            assert!(s.starts_with("t.ron:4:16:"), "{s}");
            assert!(s.contains("the node name is 300 characters long, more than the limit of 256"), "{s}");
        }
        other => panic!("expected TooLarge, got {:?}", other.map(|_| ())),
    }
}

#[test]
fn a_badly_broken_pipeline_reports_a_bounded_number_of_problems() {
    // 1000 nodes, each referring to a node that does not exist: a suggestion per problem is
    // computed over all node names, so the report is capped (and so is the time it takes).
    let nodes: Vec<String> =
        (0..1000).map(|i| format!(r#"(name: "blur{i}", kind: "Blur", inputs: {{"x": "nowhere{i}.a"}})"#)).collect();
    let refs: Vec<&str> = nodes.iter().map(String::as_str).collect();
    let start = std::time::Instant::now();
    let d = diagnostics(&pipeline(&refs));
    assert_eq!(d.len(), MAX_DIAGNOSTICS);
    assert!(start.elapsed().as_secs_f64() < 2.0, "{:?}", start.elapsed());
    let text = GraphError::Invalid(d).to_string();
    assert!(text.contains("the first 100; fix these and run again"), "{}", &text[..200]);
    // Help lines list at most 20 names.
    assert!(text.contains(", … (980 more)"), "{}", &text[..2000]);
}

#[test]
fn a_runaway_string_is_quoted_short() {
    // An unterminated string where a number goes: the message quotes only its start.
    let text = pipeline(&[]).replace("height: 32", &format!("height: \"{}", "x".repeat(500)));
    let Err(GraphError::Parse { message, .. }) = parse_pipeline(Path::new("t.ron"), &text) else {
        panic!("expected a parse error");
    };
    assert!(message.len() < 150, "{message}");
    assert!(message.contains("`height` expects a whole number") && message.contains('…'), "{message}");
}

#[test]
fn the_largest_allowed_pipeline_compiles_quickly() {
    // MAX_NODES nodes in one chain (1 source, blurs, 1 sink): validation, expansion and scheduling
    // stay fast at the limit.
    let n = wedge_graph::pipeline::MAX_NODES;
    let mut nodes = vec![r#"(name: "b0", kind: "Source")"#.to_string()];
    for i in 1..n - 1 {
        let from = if i == 1 { "b0.a".to_string() } else { format!("b{}.y", i - 1) };
        nodes.push(format!(r#"(name: "b{i}", kind: "Blur", inputs: {{"x": "{from}"}})"#));
    }
    nodes.push(format!(r#"(name: "out", kind: "Sink", inputs: {{"color": "b{}.y"}})"#, n - 2));
    let refs: Vec<&str> = nodes.iter().map(String::as_str).collect();
    let text = pipeline(&refs);
    let start = std::time::Instant::now();
    let (v, s) = compile_text(&text);
    assert_eq!(v.nodes.len(), n);
    assert_eq!(s.passes.len(), 1 + 2 * (n - 2));
    assert!(start.elapsed().as_secs_f64() < 3.0, "{:?}", start.elapsed());
}

#[test]
fn node_names_must_be_referable_and_messages_stay_printable() {
    let text = pipeline(&[
        r#"(name: "a.b", kind: "Source")"#,
        "(name: \"bad\\nname\", kind: \"Nope\")",
        r#"(name: "out", kind: "Sink", inputs: {"color": "a.b.a"})"#,
    ]);
    let d = diagnostics(&text);
    let bad: Vec<&Diagnostic> = d.iter().filter(|d| d.kind == DiagnosticKind::BadName).collect();
    assert_eq!(bad.len(), 2, "{d:#?}");
    assert_eq!((bad[0].location.line, bad[0].location.col), (4, 16));
    assert!(bad[0].message.contains("`a.b` cannot be used in references"), "{}", bad[0]);
    // The newline in the name is shown as an escape, in every diagnostic that prints it.
    for x in &d {
        assert!(!x.message.contains('\n') && !x.help.contains('\n'), "{x}");
    }
    assert!(bad[1].message.contains(r"bad\u{a}name"), "{}", bad[1]);
}

#[test]
fn motion_entries_are_checked_at_their_fields() {
    // Line 3: two entries for one object, the second rotating half a turn; line 5: a bad shutter.
    let text = pipeline(&[]).replace(
        "    nodes:",
        "    motion: [(object: \"ball\", translate: (0.3, 0, 0)),\n        (object: \"ball\", rotate_deg: 200.0, axis: (0, 0, 0))],\n    \
         camera: Some((position: (0, 1, 4), look_at: (0, 0, 0), vfov_deg: 45, shutter: Some((1.0, 0.5)))),\n    nodes:",
    );
    let d = diagnostics(&text);
    let at = |kind: DiagnosticKind| -> Vec<(usize, usize, String)> {
        d.iter().filter(|x| x.kind == kind).map(|x| (x.location.line, x.location.col, x.message.clone())).collect()
    };
    let motion = at(DiagnosticKind::BadMotion);
    assert_eq!(motion.len(), 3, "{motion:#?}");
    assert!(motion.iter().any(|(l, c, m)| (*l, *c) == (4, 38) && m.contains("not an angle below 180")), "{motion:#?}");
    assert!(motion.iter().any(|(l, c, m)| (*l, *c) == (4, 51) && m.contains("not a direction")), "{motion:#?}");
    assert!(motion.iter().any(|(l, c, m)| (*l, *c) == (4, 18) && m.contains("two motion entries")), "{motion:#?}");
    let camera = at(DiagnosticKind::BadCamera);
    assert_eq!(camera.len(), 1, "{camera:#?}");
    assert!(camera[0].2.contains("not an interval"), "{camera:#?}");
    // A well-formed block validates.
    let nodes = [r#"(name: "src", kind: "Source")"#, r#"(name: "out", kind: "Sink", inputs: {"color": "src.a"})"#];
    let ok = pipeline(&nodes)
        .replace("    nodes:", "    motion: [(object: \"ball\", translate: (0.3, 0, 0), rotate_deg: 30)],\n    nodes:");
    if let Err(e) = validate(&parse(&ok), &registry()) {
        panic!("{e}");
    }
}
