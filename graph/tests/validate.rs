//! Validation: every diagnostic kind at the exact offending token, many problems in one report,
//! parse errors with ron's positions, cycles, and the validated result.

mod common;

use std::path::Path;

use common::*;
use wedge_graph::*;

const SRC: &str = r#"(name: "src", kind: "Source")"#;
const BLUR: &str = r#"(name: "blur", kind: "Blur", inputs: {"x": "src.a"})"#;
const OUT: &str = r#"(name: "out", kind: "Sink", inputs: {"color": "blur.y"})"#;

/// Exactly one diagnostic, of `kind`, at `line:col` of test.ron; returns it.
fn single(text: &str, kind: DiagnosticKind, line: usize, col: usize) -> Diagnostic {
    let d = diagnostics(text);
    assert_eq!(d.len(), 1, "expected one diagnostic, got {d:#?}");
    let d = d.into_iter().next().unwrap();
    assert_eq!(d.kind, kind, "{d}");
    assert_eq!((d.location.line, d.location.col), (line, col), "{d}");
    assert_eq!(d.location.file, Path::new("test.ron"));
    assert!(!d.help.is_empty());
    d
}

#[test]
fn valid_pipeline_is_ordered_and_filled() {
    // Written out of order: the consumer before its producers.
    let text = pipeline(&[OUT, BLUR, SRC]);
    let v = validate(&parse(&text), &registry()).unwrap();
    let names: Vec<&str> = v.nodes.iter().map(|n| n.name.as_str()).collect();
    assert_eq!(names, ["src", "blur", "out"]);
    let blur = v.node("blur").unwrap();
    assert_eq!(blur.params["mu"], ParamValue::Float(1.0));
    assert_eq!(blur.params["taps"], ParamValue::Int(3));
    assert_eq!(blur.inputs["x"], ("src".to_string(), "a".to_string()));
    assert_eq!((blur.location.line, blur.location.col), (5, 16));
    assert_eq!(v.base_dir(), Path::new("."));
}

#[test]
fn ties_in_file_order() {
    let a = r#"(name: "a", kind: "Blur", inputs: {"x": "src.a"})"#;
    let b = r#"(name: "b", kind: "Blur", inputs: {"x": "src.a"})"#;
    let out = r#"(name: "out", kind: "Sink", inputs: {"color": "a.y"})"#;
    let v = validate(&parse(&pipeline(&[b, out, a, SRC])), &registry()).unwrap();
    let names: Vec<&str> = v.nodes.iter().map(|n| n.name.as_str()).collect();
    assert_eq!(names, ["src", "b", "a", "out"]);
}

#[test]
fn unknown_node_kind() {
    let bad = r#"(name: "blur", kind: "Blurr", inputs: {"x": "src.a"})"#;
    let d = single(&pipeline(&[SRC, bad, OUT]), DiagnosticKind::UnknownNodeKind, 5, 30);
    assert!(d.help.contains("did you mean `Blur`"), "{d}");
    // Every registered kind is listed, the closest first.
    let list = d.help.split("registered kinds: ").nth(1).unwrap();
    assert!(list.starts_with("Blur,"), "{d}");
    for k in ["Source", "Sink", "Lazy", "Twice", "WrongFormat"] {
        assert!(list.contains(k), "{d}");
    }
    let shown = d.to_string();
    assert!(shown.starts_with("test.ron:5:30: error[unknown-node-kind]: "), "{shown}");
    assert!(shown.contains("\n  help: did you mean"), "{shown}");
}

#[test]
fn duplicate_node() {
    let d = single(&pipeline(&[SRC, BLUR, BLUR, OUT]), DiagnosticKind::DuplicateNode, 6, 16);
    assert!(d.message.contains("5:16"), "{d}");
}

#[test]
fn unknown_input_port() {
    let bad = r#"(name: "blur", kind: "Blur", inputs: {"x": "src.a", "z": "src.a"})"#;
    let d = single(&pipeline(&[SRC, bad, OUT]), DiagnosticKind::UnknownInputPort, 5, 61);
    assert!(d.help.contains("x: f32"), "{d}");
}

#[test]
fn unknown_output_port() {
    let bad = r#"(name: "out", kind: "Sink", inputs: {"color": "blur.q"})"#;
    let d = single(&pipeline(&[SRC, BLUR, bad]), DiagnosticKind::UnknownOutputPort, 6, 55);
    assert!(d.help.contains("y: f32"), "{d}");
}

#[test]
fn bad_reference() {
    let bad = r#"(name: "out", kind: "Sink", inputs: {"color": "blur"})"#;
    let d = single(&pipeline(&[SRC, BLUR, bad]), DiagnosticKind::BadReference, 6, 55);
    assert!(d.help.contains("<node>.<output port>"), "{d}");
}

#[test]
fn unknown_node() {
    let bad = r#"(name: "out", kind: "Sink", inputs: {"color": "blurry.y"})"#;
    let d = single(&pipeline(&[SRC, BLUR, bad]), DiagnosticKind::UnknownNode, 6, 55);
    assert!(d.help.contains("did you mean `blur`"), "{d}");
}

#[test]
fn missing_producer() {
    let bad = r#"(name: "out", kind: "Sink")"#;
    let d = single(&pipeline(&[SRC, BLUR, bad]), DiagnosticKind::MissingProducer, 6, 16);
    assert!(d.message.contains("color"), "{d}");
    // The help names the outputs that could be connected.
    assert!(d.help.contains("\"src.a\"") && d.help.contains("\"blur.y\""), "{d}");
    assert!(!d.help.contains("src.b"), "{d}");
}

#[test]
fn optional_input_may_be_left_unconnected_or_connected() {
    let with_aux = r#"(name: "out", kind: "Sink", inputs: {"color": "blur.y", "aux": "src.b"})"#;
    let (_, s) = compile_text(&pipeline(&[SRC, BLUR, with_aux]));
    assert!(s.sink("out", "aux").is_some());
    let (_, s) = compile_text(&pipeline(&[SRC, BLUR, OUT]));
    assert!(s.sink("out", "aux").is_none());
}

#[test]
fn two_producers() {
    let bad = r#"(name: "out", kind: "Sink", inputs: {"color": "blur.y", "color": "src.a"})"#;
    single(&pipeline(&[SRC, BLUR, bad]), DiagnosticKind::TwoProducers, 6, 65);
}

#[test]
fn format_conflict() {
    let bad = r#"(name: "out", kind: "Sink", inputs: {"color": "src.b"})"#;
    let d = single(&pipeline(&[SRC, BLUR, bad]), DiagnosticKind::FormatConflict, 6, 55);
    assert!(d.message.contains("f32") && d.message.contains("vec3<f32>"), "{d}");
    assert!(d.help.contains("src.a"), "{d}");
}

#[test]
fn cycle_of_two() {
    let b1 = r#"(name: "b1", kind: "Blur", inputs: {"x": "b2.y"})"#;
    let b2 = r#"(name: "b2", kind: "Blur", inputs: {"x": "b1.y"})"#;
    let out = r#"(name: "out", kind: "Sink", inputs: {"color": "b2.y"})"#;
    let d = single(&pipeline(&[SRC, b1, b2, out]), DiagnosticKind::Cycle, 5, 16);
    assert!(d.message.contains("b1.y -> b2.x, b2.y -> b1.x"), "{d}");
}

#[test]
fn cycle_of_three_is_reported_once_with_full_path() {
    let c = r#"(name: "c", kind: "Blur", inputs: {"x": "b.y"})"#;
    let a = r#"(name: "a", kind: "Blur", inputs: {"x": "c.y"})"#;
    let b = r#"(name: "b", kind: "Blur", inputs: {"x": "a.y"})"#;
    let out = r#"(name: "out", kind: "Sink", inputs: {"color": "a.y"})"#;
    // `c` is the first node of the cycle in the file: line 5.
    let d = single(&pipeline(&[SRC, c, a, b, out]), DiagnosticKind::Cycle, 5, 16);
    assert!(d.message.contains("c.y -> a.x, a.y -> b.x, b.y -> c.x"), "{d}");
}

#[test]
fn self_loop_is_a_cycle() {
    let b = r#"(name: "b", kind: "Blur", inputs: {"x": "b.y"})"#;
    let out = r#"(name: "out", kind: "Sink", inputs: {"color": "b.y"})"#;
    let d = single(&pipeline(&[b, out]), DiagnosticKind::Cycle, 4, 16);
    assert!(d.message.contains("b.y -> b.x"), "{d}");
}

#[test]
fn unknown_param() {
    let bad = r#"(name: "blur", kind: "Blur", params: {"sigma": 2.0}, inputs: {"x": "src.a"})"#;
    let d = single(&pipeline(&[SRC, bad, OUT]), DiagnosticKind::UnknownParam, 5, 47);
    assert!(d.help.contains("mu: number in (0, 100]"), "{d}");
}

#[test]
fn duplicate_param() {
    let bad = r#"(name: "blur", kind: "Blur", params: {"mu": 2.0, "mu": 3.0}, inputs: {"x": "src.a"})"#;
    single(&pipeline(&[SRC, bad, OUT]), DiagnosticKind::DuplicateParam, 5, 58);
}

#[test]
fn param_type() {
    let bad = r#"(name: "blur", kind: "Blur", params: {"mu": "wide", "taps": 2.5, "wide": 1}, inputs: {"x": "src.a"})"#;
    let d = diagnostics(&pipeline(&[SRC, bad, OUT]));
    let got: Vec<(DiagnosticKind, usize, usize)> =
        d.iter().map(|d| (d.kind, d.location.line, d.location.col)).collect();
    assert_eq!(
        got,
        [(DiagnosticKind::ParamType, 5, 47), (DiagnosticKind::ParamType, 5, 61), (DiagnosticKind::ParamType, 5, 74)]
    );
    assert!(d[0].help.contains("expected a number"), "{}", d[0]);
    assert!(d[1].help.contains("expected an integer"), "{}", d[1]);
}

#[test]
fn param_out_of_range() {
    let bad = r#"(name: "blur", kind: "Blur", params: {"taps": 17, "mu": 0.0}, inputs: {"x": "src.a"})"#;
    let d = diagnostics(&pipeline(&[SRC, bad, OUT]));
    let got: Vec<(DiagnosticKind, usize, usize)> =
        d.iter().map(|d| (d.kind, d.location.line, d.location.col)).collect();
    assert_eq!(got, [(DiagnosticKind::ParamOutOfRange, 5, 47), (DiagnosticKind::ParamOutOfRange, 5, 59)]);
    assert!(d[0].help.contains("1 <= taps <= 16"), "{}", d[0]);
    assert!(d[1].help.contains("0 < mu"), "{}", d[1]);
}

/// A colour is one parameter of three numbers: written `(r, g, b)` or `[r, g, b]`, each checked
/// against the range at the parameter's position; a single number is the wrong type; a list of
/// another length is refused where it is written.
#[test]
fn colour_params_are_three_numbers_checked_in_place() {
    for written in ["(0.5, 1, 0)", "[0.5, 1, 0]"] {
        let ok = format!(r#"(name: "blur", kind: "Blur", params: {{"tint": {written}}}, inputs: {{"x": "src.a"}})"#);
        let v = validate(&parse(&pipeline(&[SRC, &ok, OUT])), &registry()).unwrap();
        let blur = v.nodes.iter().find(|n| n.name == "blur").unwrap();
        assert_eq!(blur.params.get("tint"), Some(&ParamValue::Vec3([0.5, 1.0, 0.0])), "{written}");
    }
    let scalar = r#"(name: "blur", kind: "Blur", params: {"tint": 0.5}, inputs: {"x": "src.a"})"#;
    let d = single(&pipeline(&[SRC, scalar, OUT]), DiagnosticKind::ParamType, 5, 47);
    assert!(d.help.contains("a colour, three numbers `(r, g, b)`"), "{d}");
    let bright = r#"(name: "blur", kind: "Blur", params: {"tint": (0.5, 2, 0)}, inputs: {"x": "src.a"})"#;
    let d = single(&pipeline(&[SRC, bright, OUT]), DiagnosticKind::ParamOutOfRange, 5, 47);
    assert!(d.help.contains("its second number 2 is out of range; each must satisfy 0 <= x <= 1"), "{d}");
    let two = r#"(name: "blur", kind: "Blur", params: {"tint": (0.5, 2)}, inputs: {"x": "src.a"})"#;
    let (line, _, message, _) = parse_err(&pipeline(&[SRC, two, OUT]));
    assert_eq!(line, 5, "{message}");
    assert!(message.contains("three numbers (r, g, b), not 2"), "{message}");
}

#[test]
fn param_choice() {
    let ok = r#"(name: "src", kind: "Source", params: {"mode": "slow"})"#;
    let v = validate(&parse(&pipeline(&[ok, BLUR, OUT])), &registry()).unwrap();
    assert_eq!(v.node("src").unwrap().params["mode"], ParamValue::Str("slow".into()));
    let bad = r#"(name: "src", kind: "Source", params: {"mode": "medium"})"#;
    // `"mode"` at column 9 + 39.
    single(&pipeline(&[bad, BLUR, OUT]), DiagnosticKind::ParamOutOfRange, 4, 48);
}

#[test]
fn no_sink() {
    let d = single(&pipeline(&[SRC, BLUR]), DiagnosticKind::NoSink, 3, 5);
    assert!(d.help.contains("Sink"), "{d}");
}

#[test]
fn bad_size() {
    // Line 2 is `    scene: "builtin:grids", width: W, height: H,`; W starts at column 36.
    single(&pipeline_sized(0, 32, &[SRC, BLUR, OUT]), DiagnosticKind::BadSize, 2, 36);
    single(&pipeline_sized(64, 20000, &[SRC, BLUR, OUT]), DiagnosticKind::BadSize, 2, 48);
    // Both sides allowed, but 10^8 pixels > 2^26.
    let d = single(&pipeline_sized(10000, 10000, &[SRC, BLUR, OUT]), DiagnosticKind::BadSize, 2, 36);
    assert!(d.message.contains("100000000"), "{d}");
    // Exactly at the limits is fine.
    validate(&parse(&pipeline_sized(16384, 4096, &[SRC, BLUR, OUT])), &registry()).unwrap();
}

#[test]
fn three_mistakes_in_one_report_in_file_order() {
    let blur = r#"(name: "blur", kind: "Blur", params: {"mu": -1.0}, inputs: {"x": "src.a"})"#;
    let out = r#"(name: "out", kind: "Sink", inputs: {"color": "blur.y", "aux": "nowhere.b"})"#;
    let extra = r#"(name: "extra", kind: "Fog")"#;
    let text = pipeline(&[SRC, blur, out, extra]);
    let err = validate(&parse(&text), &registry()).unwrap_err();
    let GraphError::Invalid(d) = &err else { panic!("{err}") };
    let got: Vec<(DiagnosticKind, usize, usize)> =
        d.iter().map(|d| (d.kind, d.location.line, d.location.col)).collect();
    assert_eq!(
        got,
        [
            (DiagnosticKind::ParamOutOfRange, 5, 47),
            (DiagnosticKind::UnknownNode, 6, 72),
            (DiagnosticKind::UnknownNodeKind, 7, 31),
        ]
    );
    let shown = err.to_string();
    assert!(shown.starts_with("3 problem(s) in the pipeline:"), "{shown}");
    assert!(shown.contains("test.ron:6:72: error[unknown-node]"), "{shown}");
}

#[test]
fn comments_and_odd_layout_do_not_confuse_locations() {
    let text = "// header comment with ( [ { \"quotes\"\nPipeline(\n  /* nodes: [ */ scene: r#\"builtin:\"grids\"#,\n  width: 8, height: 8,\n  nodes: [\n    (name: \"src\", kind: \"Source\"), (name: \"out\",\n      kind: \"Snk\", // typo\n      inputs: {\"color\": \"src.a\"}),\n  ],\n)\n";
    let d = diagnostics(text);
    // The misspelt sink also leaves the pipeline without a sink, reported at the `nodes` key.
    let got: Vec<(DiagnosticKind, usize, usize)> =
        d.iter().map(|d| (d.kind, d.location.line, d.location.col)).collect();
    assert_eq!(got, [(DiagnosticKind::NoSink, 5, 3), (DiagnosticKind::UnknownNodeKind, 7, 13)]);
    assert!(d[1].help.starts_with("did you mean `Sink`?"), "{}", d[1]);
}

fn parse_err(text: &str) -> (usize, usize, String, String) {
    match parse_pipeline(Path::new("p.ron"), text) {
        Err(GraphError::Parse { location, message, help }) => {
            assert_eq!(location.file, Path::new("p.ron"));
            (location.line, location.col, message, help)
        }
        Err(e) => panic!("expected a parse error, got {e}"),
        Ok(_) => panic!("expected a parse error"),
    }
}

#[test]
fn unknown_field_at_top_level() {
    let text = "Pipeline(\n    scene: \"builtin:grids\", width: 64, height: 32,\n    frames: 3,\n    nodes: [],\n)\n";
    let (line, col, message, help) = parse_err(text);
    assert_eq!((line, col), (3, 5), "{message}");
    assert!(message.contains("frames"), "{message}");
    for f in ["scene", "width", "height", "seed", "camera", "nodes"] {
        assert!(help.contains(f), "{help}");
    }
}

#[test]
fn unknown_field_in_node() {
    let bad = r#"(name: "blur", kind: "Blur", input: {"x": "src.a"})"#;
    let (line, col, message, help) = parse_err(&pipeline(&[SRC, bad, OUT]));
    // `input` starts at column 9 + 29.
    assert_eq!((line, col), (5, 38), "{message}");
    assert!(help.contains("inputs") && help.contains("params"), "{help}");
}

#[test]
fn missing_field_and_syntax_errors() {
    let (line, _, message, help) = parse_err(&pipeline(&[r#"(kind: "Source")"#]));
    assert_eq!(line, 4, "{message}");
    assert!(message.contains("name") && help.contains("name"), "{message} / {help}");

    let (line, _, message, _) = parse_err("Pipeline(\n  scene: \"x\", width: 1 height: 2, nodes: [])");
    assert_eq!(line, 2, "{message}");

    let (line, _, message, _) = parse_err("Pipeline(\n  scene: \"x\", width: \"wide\", height: 2, nodes: [])");
    assert_eq!(line, 2, "{message}");
}

#[test]
fn load_pipeline_reads_files_and_names_missing_ones() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sub").join("p.ron");
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(&path, pipeline(&[SRC, BLUR, OUT])).unwrap();
    let loaded = load_pipeline(&path).unwrap();
    let v = validate(&loaded, &registry()).unwrap();
    assert_eq!(v.base_dir(), dir.path().join("sub"));
    assert_eq!(v.nodes[0].location.file, path);

    let (v2, sched) = compile(&path, &registry()).unwrap();
    assert_eq!(v2.nodes.len(), 3);
    assert_eq!(sched.passes.len(), 3);

    let missing = dir.path().join("missing.ron");
    match load_pipeline(&missing) {
        Err(e @ GraphError::Io { .. }) => assert!(e.to_string().contains("missing.ron"), "{e}"),
        other => panic!("expected Io error, got {:?}", other.map(|_| ())),
    }
}

/// Issue 34 §4: stage order follows the data after composition. A composition that reads an
/// image-space filter's output runs after it (in its stage), and so does what reads the composition.
#[test]
fn a_composition_after_an_image_space_filter_runs_after_it() {
    let grade = r#"(name: "grade", kind: "Grade", inputs: {"x": "src.a"})"#;
    let mix = r#"(name: "mix", kind: "Mix", inputs: {"x": "grade.y"})"#;
    let again = r#"(name: "again", kind: "Mix", inputs: {"x": "mix.y"})"#;
    let out = r#"(name: "out", kind: "Sink", inputs: {"color": "again.y"})"#;
    let (_, s) = compile_text(&pipeline(&[SRC, mix, grade, again, out]));
    let order: Vec<(&str, Stage)> = s.passes.iter().map(|p| (p.name.as_str(), p.stage)).collect();
    assert_eq!(
        order,
        [
            ("src.gen", Stage::Sample),
            ("grade.p", Stage::ImageFilter),
            ("mix.p", Stage::ImageFilter),
            ("again.p", Stage::ImageFilter)
        ]
    );
}

/// Before composition a stage keeps its place (the sampler's counts and the reference transform rely
/// on it): a world-space filter reading an image-space output is named at its node, with a fix.
#[test]
fn a_filter_reading_an_image_space_output_is_a_stage_order_error() {
    let grade = r#"(name: "grade", kind: "Grade", inputs: {"x": "src.a"})"#;
    let blur = r#"(name: "blur", kind: "Blur", inputs: {"x": "grade.y"})"#;
    let text = pipeline(&[SRC, grade, blur, OUT]);
    let v = validate(&parse(&text), &registry()).unwrap();
    let Err(GraphError::Invalid(d)) = expand(&v) else { panic!("expected a stage-order error") };
    assert_eq!(d.len(), 1, "{d:#?}");
    assert_eq!(d[0].kind, DiagnosticKind::StageOrder);
    assert_eq!((d[0].location.line, d[0].location.col), (6, 16), "{}", d[0]);
    assert!(
        d[0].message.contains("node `blur` (Blur) runs in stage filter, but its input `x` is `grade.y`"),
        "{}",
        d[0]
    );
    assert!(d[0].help.contains("combine before `grade` instead"), "{}", d[0]);
}
