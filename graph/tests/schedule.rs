//! Expansion and scheduling: culling, order, lifetimes, the pool plan, printing, and the checks on
//! node kinds that break their declared contract.

mod common;

use common::*;
use wedge_graph::*;

const SRC: &str = r#"(name: "src", kind: "Source")"#;

fn blur(name: &str, from: &str) -> String {
    format!(r#"(name: "{name}", kind: "Blur", inputs: {{"x": "{from}"}})"#)
}

fn sink(from: &str) -> String {
    format!(r#"(name: "out", kind: "Sink", inputs: {{"color": "{from}"}})"#)
}

fn pass_names(s: &Schedule) -> Vec<&str> {
    s.passes.iter().map(|p| p.name.as_str()).collect()
}

fn buffer(s: &Schedule, name: &str) -> BufferId {
    BufferId(s.buffers.iter().position(|b| b.name == name).unwrap_or_else(|| panic!("no buffer {name}")))
}

#[test]
fn chain_order_and_lifetimes() {
    // Source -> Blur -> Blur -> Sink.
    let text = pipeline(&[SRC, &blur("b1", "src.a"), &blur("b2", "b1.y"), &sink("b2.y")]);
    let (_, s) = compile_text(&text);
    assert_eq!(pass_names(&s), ["src.gen", "b1.h", "b1.v", "b2.h", "b2.v"]);
    assert!(s.culled.is_empty());
    let life = |n: &str| s.lifetimes[buffer(&s, n).0].unwrap();
    assert_eq!(life("src.a"), Lifetime { first: 0, last: 1 });
    // src.b is written but nobody reads it: it lives only during its writer.
    assert_eq!(life("src.b"), Lifetime { first: 0, last: 0 });
    assert_eq!(life("b1.tmp"), Lifetime { first: 1, last: 2 });
    assert_eq!(life("b1.y"), Lifetime { first: 2, last: 3 });
    assert_eq!(life("b2.tmp"), Lifetime { first: 3, last: 4 });
    // The sink input lives to the end.
    assert_eq!(life("b2.y"), Lifetime { first: 4, last: 4 });
    assert_eq!(s.sink("out", "color"), Some(buffer(&s, "b2.y")));
    assert_eq!(s.sink("out", "aux"), None);
    // Pass parameters carry the node's validated parameters.
    assert_eq!(s.passes[2].params["taps"], ParamValue::Int(3));
}

#[test]
fn sink_input_read_early_lives_to_the_end() {
    // The sink shows src.a, which is also read by the first pass of the blur chain.
    let text = pipeline(&[
        SRC,
        &blur("b1", "src.a"),
        r#"(name: "out", kind: "Sink", inputs: {"color": "src.a"})"#,
        r#"(name: "out2", kind: "Sink", inputs: {"color": "b1.y"})"#,
    ]);
    let (_, s) = compile_text(&text);
    assert_eq!(s.lifetimes[buffer(&s, "src.a").0], Some(Lifetime { first: 0, last: 2 }));
}

#[test]
fn schedule_respects_dependencies() {
    // Nodes written in reverse; two branches joined at the sink through `aux`-free wiring.
    let text = pipeline(&[&sink("b3.y"), &blur("b3", "b2.y"), &blur("b2", "b1.y"), &blur("b1", "src.a"), SRC]);
    let (_, s) = compile_text(&text);
    let pos = |name: &str| s.passes.iter().position(|p| p.name == name).unwrap();
    for (i, p) in s.passes.iter().enumerate() {
        for (_, id) in &p.reads {
            let writer = s.passes.iter().position(|q| q.writes.iter().any(|(_, w)| w == id)).unwrap();
            assert!(writer < i, "{} reads a buffer written later", p.name);
        }
    }
    assert!(pos("src.gen") < pos("b1.h") && pos("b1.v") < pos("b2.h") && pos("b2.v") < pos("b3.h"));
}

#[test]
fn unread_blur_is_culled() {
    let text = pipeline(&[SRC, &blur("used", "src.a"), &blur("debug", "src.a"), &sink("used.y")]);
    let (_, s) = compile_text(&text);
    assert_eq!(s.culled, ["debug.h", "debug.v"]);
    assert_eq!(pass_names(&s), ["src.gen", "used.h", "used.v"]);
    assert_eq!(s.lifetimes[buffer(&s, "debug.tmp").0], None);
    assert_eq!(s.slots[buffer(&s, "debug.y").0], None);
    assert!(s.table().contains("culled (2): debug.h, debug.v"), "{}", s.table());
}

#[test]
fn pool_plan_of_four_blurs_shares_slots_without_overlap() {
    let text = pipeline(&[
        SRC,
        &blur("b1", "src.a"),
        &blur("b2", "b1.y"),
        &blur("b3", "b2.y"),
        &blur("b4", "b3.y"),
        &sink("b4.y"),
    ]);
    let (_, s) = compile_text(&text);
    let live: Vec<BufferId> = s.live_buffers().collect();
    assert_eq!(live.len(), 10); // src.a, src.b, 4 × (tmp, y)
    let f32_buffers = live.iter().filter(|b| s.buffers[b.0].format == Format::F32).count();
    assert_eq!(f32_buffers, 9);
    // A chain needs only two f32 slots at a time (the one being read and the one being written),
    // plus one vec3 slot.
    assert_eq!(s.physical_allocations(), 3);
    assert!(s.physical_allocations() < live.len());
    for (i, a) in live.iter().enumerate() {
        let (la, sa) = (s.lifetimes[a.0].unwrap(), s.slots[a.0].unwrap());
        assert_eq!(s.slot_formats[sa], s.buffers[a.0].format);
        for b in &live[i + 1..] {
            let (lb, sb) = (s.lifetimes[b.0].unwrap(), s.slots[b.0].unwrap());
            if la.overlaps(&lb) {
                assert_ne!(sa, sb, "{} and {} overlap but share slot {sa}", s.buffers[a.0].name, s.buffers[b.0].name);
            }
        }
    }
    // A pass never reads and writes the same slot.
    for p in &s.passes {
        for (_, r) in &p.reads {
            for (_, w) in &p.writes {
                assert_ne!(s.slots[r.0], s.slots[w.0], "{}", p.name);
            }
        }
    }
}

#[test]
fn table_and_dot_show_every_scheduled_pass() {
    let text = pipeline(&[SRC, &blur("b1", "src.a"), &blur("dbg", "src.a"), &sink("b1.y")]);
    let (_, s) = compile_text(&text);
    let dot = s.to_dot();
    assert!(dot.starts_with("digraph"));
    assert!(dot.trim_end().ends_with('}'));
    for p in &s.passes {
        assert!(
            dot.contains(&format!("label=\"{}\\n{}\\n[{}]\"", p.name, p.kernel, p.stage)),
            "{} missing:\n{dot}",
            p.name
        );
    }
    assert!(dot.contains("shape=box") && dot.contains("shape=ellipse"));
    assert!(dot.contains("b1.tmp\\nf32"), "{dot}");
    assert!(!dot.contains("dbg.h"), "culled passes are not drawn:\n{dot}");
    let table = s.table();
    for p in &s.passes {
        assert!(table.contains(&p.name) && table.contains(&p.kernel), "{table}");
    }
    assert!(table.contains("x=src.a") && table.contains("out=b1.tmp"), "{table}");
    assert!(table.contains("0..=1"), "{table}");
}

fn expand_err(nodes: &[&str]) -> (String, String) {
    let v = validate(&parse(&pipeline(nodes)), &registry()).unwrap_or_else(|e| panic!("{e}"));
    match expand(&v).as_ref().map_err(GraphError::unlocated) {
        Err(GraphError::Expand { node, message }) => (node.clone(), message.clone()),
        Err(e) => panic!("expected an expand error, got {e}"),
        Ok(_) => panic!("expected an expand error"),
    }
}

#[test]
fn broken_node_kinds_are_caught_at_expansion() {
    let (node, message) = expand_err(&[r#"(name: "l", kind: "Lazy")"#, &sink("l.y")]);
    assert_eq!(node, "l");
    assert!(message.contains("did not bind") && message.contains("`y`"), "{message}");

    let (node, message) = expand_err(&[r#"(name: "t", kind: "Twice")"#, &sink("t.y")]);
    assert_eq!(node, "t");
    assert!(message.contains("t.p1") && message.contains("t.p2"), "{message}");

    let (node, message) = expand_err(&[r#"(name: "w", kind: "WrongFormat")"#, &sink("w.y")]);
    assert_eq!(node, "w");
    assert!(message.contains("vec3<f32>"), "{message}");
}

#[test]
fn reading_an_unwritten_buffer_is_an_error() {
    let mut e = Expansion::default();
    e.buffers.push(BufferInfo::new("n.orphan", Format::F32));
    e.buffers.push(BufferInfo::new("n.y", Format::F32));
    e.passes.push(Pass {
        name: "n.p".into(),
        node: "n".into(),
        kernel: "k".into(),
        reads: vec![("x".into(), BufferId(0))],
        writes: vec![("out".into(), BufferId(1))],
        params: Default::default(),
        stage: Stage::Sample,
        random: false,
        reference: Reference::Keep,
        continues: None,
    });
    e.sink_inputs.push(("out".into(), "color".into(), BufferId(1)));
    match schedule(e) {
        Err(GraphError::Expand { node, message }) => {
            assert_eq!(node, "n");
            assert!(message.contains("n.orphan"), "{message}");
        }
        other => panic!("expected an error, got {:?}", other.map(|_| ())),
    }
}

/// A node that averages its input with that buffer's previous frame: `x` and `x@previous_frame` →
/// `y`, plus an unread side buffer whose previous frame it asks for but never reads.
struct Temporal;
impl NodeKind for Temporal {
    fn kind(&self) -> &'static str {
        "Temporal"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        vec![PortDecl::new("x", Format::F32, "")]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![PortDecl::new("y", Format::F32, "")]
    }
    fn params(&self) -> Vec<ParamDecl> {
        vec![]
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        let x = ctx.required("x")?;
        let side = ctx.buffer("side", Format::F32);
        ctx.pass("side", "side", Stage::Sample).write("out", side).finish();
        let _unused = ctx.previous_frame(side);
        let prev = ctx.previous_frame(x);
        assert_eq!(ctx.previous_frame(x), prev, "one buffer per source");
        let y = ctx.buffer("y", Format::F32);
        ctx.pass("mix", "mix", Stage::Filter).read("a", x).read("b", prev).write("out", y).finish();
        ctx.output("y", y);
        Ok(())
    }
}

#[test]
fn previous_frame_buffers_are_inputs_that_keep_their_sources() {
    let mut reg = registry();
    reg.register(std::sync::Arc::new(Temporal));
    let text = pipeline(&[SRC, r#"(name: "t", kind: "Temporal", inputs: {"x": "src.a"})"#, &sink("t.y")]);
    let v = validate(&parse(&text), &reg).unwrap_or_else(|e| panic!("{e}"));
    let s = schedule(expand(&v).unwrap()).unwrap_or_else(|e| panic!("{e}"));
    // Only the read one is scheduled; the side pass that feeds nothing is culled.
    assert_eq!(s.history.len(), 1, "{:?}", s.history);
    let h = s.history[0];
    assert_eq!(s.buffers[h.buffer.0].name, "src.a@previous_frame");
    assert_eq!(h.source, buffer(&s, "src.a"));
    assert!(s.culled.contains(&"t.side".to_string()), "{:?}", s.culled);
    // It exists from before the first pass to its reader; its source lives to the end of the run.
    let end = s.passes.len() - 1;
    let mix = s.passes.iter().position(|p| p.name == "t.mix").unwrap();
    assert_eq!(s.lifetimes[h.buffer.0], Some(Lifetime { first: 0, last: mix }));
    assert_eq!(s.lifetimes[h.source.0].unwrap().last, end);
    // It has storage of its own.
    let slot = s.slots[h.buffer.0].unwrap();
    assert!(s
        .slots
        .iter()
        .enumerate()
        .all(|(b, sl)| b == h.buffer.0 || *sl != Some(slot) || s.lifetimes[b].unwrap().first > mix));
}

fn pass(name: &str, reads: &[(&str, usize)], writes: &[(&str, usize)]) -> Pass {
    Pass {
        name: name.into(),
        node: "n".into(),
        kernel: "k".into(),
        reads: reads.iter().map(|(b, i)| (b.to_string(), BufferId(*i))).collect(),
        writes: writes.iter().map(|(b, i)| (b.to_string(), BufferId(*i))).collect(),
        params: Default::default(),
        stage: Stage::Sample,
        random: false,
        reference: Reference::Keep,
        continues: None,
    }
}

/// Per-sample buffers (`layers` elements per pixel): the pool shares a slot only between buffers of
/// the same format *and* layers, the memory estimate counts every layer, and a sink refuses one.
#[test]
fn per_sample_buffers_pool_by_layers_and_are_never_sinks() {
    let mut e = Expansion::default();
    e.buffers.push(BufferInfo { layers: 8, ..BufferInfo::new("n.samples", Format::Vec4) });
    e.buffers.push(BufferInfo::new("n.a", Format::Vec4));
    e.buffers.push(BufferInfo { layers: 4, ..BufferInfo::new("n.more", Format::Vec4) });
    e.buffers.push(BufferInfo::new("n.out", Format::Vec4));
    // samples → a; (samples dead) more → out: `more` may not take the 8-layer slot.
    e.passes.push(pass("n.p1", &[], &[("s", 0)]));
    e.passes.push(pass("n.p2", &[("s", 0)], &[("a", 1)]));
    e.passes.push(pass("n.p3", &[("a", 1)], &[("m", 2)]));
    e.passes.push(pass("n.p4", &[("m", 2)], &[("o", 3)]));
    e.sink_inputs.push(("out".into(), "color".into(), BufferId(3)));
    let s = schedule(e.clone()).unwrap();
    let slot = |b: usize| s.slots[b].unwrap();
    assert_ne!(slot(0), slot(2), "8 and 4 layers never share");
    assert_eq!(s.slot_layers[slot(0)], 8);
    assert_eq!(s.slot_layers[slot(2)], 4);
    // 8 + 4 layers and two images of vec4 at 2×2 pixels: 16 bytes each.
    let pooled: u64 = (0..s.slot_formats.len()).map(|k| 4 * 16 * u64::from(s.slot_layers[k])).sum();
    assert_eq!(s.buffer_bytes(2, 2).pool, pooled);
    assert!(s.table().contains("vec4<f32> × 8 per pixel"), "{}", s.table());

    e.sink_inputs[0].2 = BufferId(2);
    e.passes.pop();
    match schedule(e) {
        Err(GraphError::Expand { message, .. }) => assert!(message.contains("per-sample buffer"), "{message}"),
        other => panic!("expected an error, got {:?}", other.map(|_| ())),
    }
}

#[test]
fn a_change_marks_its_passes_and_everything_downstream_of_them() {
    let chain = |taps: &str| {
        let b2 = format!(r#"(name: "b2", kind: "Blur", params: {{"taps": {taps}}}, inputs: {{"x": "b1.y"}})"#);
        compile_text(&pipeline(&[SRC, &blur("b1", "src.a"), &b2, &sink("b2.y")])).1
    };
    let (old, new) = (chain("3"), chain("5"));
    assert_eq!(pass_names(&new), ["src.gen", "b1.h", "b1.v", "b2.h", "b2.v"]);
    // b2's `taps` changed: only b2.v reads it (b2.h's parameters are unchanged), so it alone runs
    // again; src, b1 and b2.h keep what they wrote.
    assert_eq!(new.changed_since(&old), [false, false, false, false, true]);
    assert_eq!(new.changed_since(&new), [false; 5]);
    // b1's passes, and b2's, which read what b1 writes.
    assert_eq!(new.downstream_of_node("b1"), [false, true, true, true, true]);
}
