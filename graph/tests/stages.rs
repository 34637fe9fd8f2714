//! Stages, graph-assigned streams and the reference transform, on hand-built expansions (the
//! effects' own graphs are tested in the workspace's `tests/reference.rs` and `tests/streams.rs`).

use std::collections::BTreeMap;

use wedge_graph::*;

/// A small expansion builder: buffers by name, passes with reads/writes by buffer name.
#[derive(Default)]
struct Build {
    e: Expansion,
}

impl Build {
    fn buf(&mut self, name: &str, format: Format) -> BufferId {
        self.e.buffers.push(BufferInfo::new(name, format));
        BufferId(self.e.buffers.len() - 1)
    }
    fn id(&self, name: &str) -> BufferId {
        self.e.find_buffer(name).unwrap_or_else(|| panic!("no buffer {name}"))
    }
    fn pass(&mut self, name: &str, stage: Stage, reads: &[(&str, &str)], writes: &[(&str, &str)]) -> &mut Pass {
        let node = name.split('.').next().unwrap();
        let mut p = Pass::new(name, node, &format!("k.{}", name.split('.').nth(1).unwrap()), stage);
        p.reads = reads.iter().map(|(b, n)| (b.to_string(), self.id(n))).collect();
        p.writes = writes.iter().map(|(b, n)| (b.to_string(), self.id(n))).collect();
        self.e.passes.push(p);
        self.e.passes.last_mut().unwrap()
    }
    fn sink(&mut self, port: &str, buffer: &str) {
        let id = self.id(buffer);
        self.e.sink_inputs.push(("out".into(), port.into(), id));
    }
}

fn names(s: &Schedule) -> Vec<&str> {
    s.passes.iter().map(|p| p.name.as_str()).collect()
}

#[test]
fn passes_run_by_stage_then_in_expansion_order() {
    // Expanded in the "wrong" order: a compose pass first, then two independent sample passes.
    let mut b = Build::default();
    for n in ["a.value", "b.value", "c.out"] {
        b.buf(n, Format::F32);
    }
    b.pass("c.compose", Stage::Compose, &[("x", "a.value"), ("y", "b.value")], &[("out", "c.out")]);
    b.pass("b.sample", Stage::Sample, &[], &[("out", "b.value")]);
    b.pass("a.sample", Stage::Sample, &[], &[("out", "a.value")]);
    b.sink("color", "c.out");
    let s = schedule(b.e).unwrap();
    assert_eq!(names(&s), ["b.sample", "a.sample", "c.compose"]);
    let table = s.table();
    assert!(table.contains("stage") && table.contains("compose       c.compose"), "{table}");
}

#[test]
fn stages_order_unrelated_branches() {
    // Two chains Sample → Filter, expanded chain by chain: both samples run before either filter.
    let mut b = Build::default();
    for n in ["a.s", "a.f", "b.s", "b.f"] {
        b.buf(n, Format::F32);
    }
    b.pass("a.sample", Stage::Sample, &[], &[("out", "a.s")]);
    b.pass("a.filter", Stage::Filter, &[("x", "a.s")], &[("out", "a.f")]);
    b.pass("b.sample", Stage::Sample, &[], &[("out", "b.s")]);
    b.pass("b.filter", Stage::Filter, &[("x", "b.s")], &[("out", "b.f")]);
    b.sink("color", "a.f");
    b.sink("aux", "b.f");
    let s = schedule(b.e).unwrap();
    assert_eq!(names(&s), ["a.sample", "b.sample", "a.filter", "b.filter"]);
}

#[test]
fn reading_a_later_stage_is_an_error_naming_both_passes() {
    let mut b = Build::default();
    b.buf("f.out", Format::F32);
    b.buf("s.out", Format::F32);
    b.pass("f.filter", Stage::Filter, &[], &[("out", "f.out")]);
    b.pass("s.sample", Stage::Sample, &[("x", "f.out")], &[("out", "s.out")]);
    // Culled or not, the declaration is wrong: no sink at all.
    match schedule(b.e) {
        Err(GraphError::Expand { node, message }) => {
            assert_eq!(node, "s");
            for needle in ["`s.sample` (stage sample)", "`f.filter`", "later stage filter"] {
                assert!(message.contains(needle), "{needle:?} in {message}");
            }
        }
        other => panic!("expected a stage error, got {:?}", other.map(|_| ())),
    }
}

#[test]
fn random_passes_get_hashed_streams_and_collisions_are_errors() {
    let mut b = Build::default();
    b.buf("a.out", Format::F32);
    b.buf("b.out", Format::F32);
    b.pass("a.sample", Stage::Sample, &[], &[("out", "a.out")]).random = true;
    b.pass("b.sample", Stage::Sample, &[], &[("out", "b.out")]).random = true;
    // Hand-set streams the way a careless tool might: the same number twice.
    for p in &mut b.e.passes {
        p.params.insert("stream".into(), ParamValue::Int(7));
    }
    b.sink("color", "a.out");
    match schedule(b.e) {
        Err(GraphError::Expand { message, .. }) => {
            assert!(message.contains("`a.sample` and `b.sample`") && message.contains("0x00000007"), "{message}");
        }
        other => panic!("expected a stream collision, got {:?}", other.map(|_| ())),
    }
}

/// Sample (continued) → rates (count) → adaptive sample → two filters → compose, plus a bandwidth
/// diagnostic wired to the sink: the shape of SoftShadows.
fn effect_like() -> Expansion {
    let mut b = Build::default();
    b.buf("e.initial", Format::Vec4);
    b.buf("e.width", Format::F32);
    b.buf("e.rays", Format::U32);
    b.buf("e.noisy", Format::Vec4);
    b.buf("e.fx", Format::Vec4);
    b.buf("e.fy", Format::Vec4);
    b.buf("e.radiance", Format::Vec3);
    let first = b.pass("e.sample_initial", Stage::Sample, &[], &[("estimate", "e.initial")]);
    first.random = true;
    first.reference = Reference::Continued;
    first.params.insert("count".into(), ParamValue::Int(9));
    b.pass("e.bandwidth", Stage::Bandwidth, &[("stats", "e.initial")], &[("filter_width", "e.width")]);
    b.pass("e.rates", Stage::Bandwidth, &[("stats", "e.initial")], &[("rays_per_pixel", "e.rays")]).reference =
        Reference::Count;
    let adaptive = b.pass(
        "e.sample_adaptive",
        Stage::Adaptive,
        &[("rays_per_pixel", "e.rays"), ("previous", "e.initial")],
        &[("estimate", "e.noisy")],
    );
    adaptive.random = true;
    adaptive.reference = Reference::Sample;
    adaptive.params.insert("count".into(), ParamValue::Int(0));
    for (name, from, to) in [("e.filter_x", "e.noisy", "e.fx"), ("e.filter_y", "e.fx", "e.fy")] {
        b.pass(name, Stage::Filter, &[("value", from), ("bandwidth", "e.width")], &[("out", to)]).reference =
            Reference::Bypass { input: "value" };
    }
    b.pass("e.compose", Stage::Compose, &[("value", "e.fy")], &[("out", "e.radiance")]);
    b.sink("color", "e.radiance");
    b.sink("filter_width", "e.width");
    b.sink("rays_per_pixel", "e.rays");
    for p in &mut b.e.passes {
        if p.random {
            p.params.insert("stream".into(), ParamValue::Int(i64::from(stream_id(&p.name))));
        }
    }
    b.e
}

#[test]
fn reference_bypasses_filters_fills_counts_and_resets_sampling() {
    let e = effect_like();
    let noisy = e.find_buffer("e.noisy").unwrap();
    let s = schedule(reference(e, 256, "independent").unwrap()).unwrap();
    assert_eq!(names(&s), ["e.sample_initial", "e.rates", "e.sample_adaptive", "e.compose"]);
    assert_eq!(s.culled, ["e.bandwidth"], "only the filters needed the bandwidth");
    let p = |n: &str| s.passes.iter().find(|p| p.name == n).unwrap();
    let params = |n: &str| -> &BTreeMap<String, ParamValue> { &p(n).params };
    assert_eq!(params("e.sample_initial")["count"], ParamValue::Int(0));
    assert_eq!(params("e.sample_adaptive")["count"], ParamValue::Int(256));
    for n in ["e.sample_initial", "e.sample_adaptive"] {
        assert_eq!(params(n)["sampling"], ParamValue::Str("independent".into()));
        assert_eq!(params(n)["stream"], ParamValue::Int(i64::from(stream_id(n))), "streams are kept");
    }
    assert_eq!(p("e.rates").kernel, FILL_CONSTANT);
    assert_eq!(params("e.rates")["value"], ParamValue::Int(256));
    assert!(p("e.rates").reads.is_empty());
    assert_eq!(p("e.compose").read("value"), Some(noisy), "compose reads the unfiltered estimate");
    let sinks: Vec<&str> = s.sink_inputs.iter().map(|(_, port, _)| port.as_str()).collect();
    assert_eq!(sinks, ["color"], "filter widths and counts are not part of a reference");
}

#[test]
fn reference_refuses_undeclared_roles_and_bad_settings() {
    let mut e = effect_like();
    for p in &mut e.passes {
        if p.name == "e.sample_adaptive" || p.name == "e.filter_y" {
            p.reference = Reference::Keep;
        }
    }
    match reference(e, 16, "stratified") {
        Err(GraphError::Expand { message, .. }) => {
            assert!(message.contains("`e.sample_adaptive` draws random numbers"), "{message}");
            assert!(message.contains("filter pass `e.filter_y` must declare"), "{message}");
        }
        other => panic!("expected role errors, got {:?}", other.map(|_| ())),
    }
    for (spp, sampling) in [(0, "stratified"), (16, "sobol")] {
        assert!(reference(effect_like(), spp, sampling).is_err(), "{spp} {sampling}");
    }
}

#[test]
fn a_hand_picked_stream_is_an_error() {
    let mut b = Build::default();
    b.buf("a.out", Format::F32);
    b.pass("a.sample", Stage::Sample, &[], &[("out", "a.out")]).params.insert("stream".into(), ParamValue::Int(1));
    b.sink("color", "a.out");
    match schedule(b.e) {
        Err(GraphError::Expand { message, .. }) => {
            assert!(message.contains("`a.sample` sets `stream` by hand"), "{message}")
        }
        other => panic!("expected an error, got {:?}", other.map(|_| ())),
    }
}
