//! The shared sampler mechanism (`wedge_graph::sampler`) with a test sampler kind and test nodes, so
//! it is tested without wedge's kernels: requests merged and shared, conflicts named, counts
//! combined, passes emitted once (and not at all when no node asks), the reference roles.

mod common;

use std::sync::Arc;

use common::{parse, Sink};
use wedge_graph::*;

/// A sampler with a first pass writing the `First` handles, a counts pass over every request, one
/// per-primary pass per estimator asked for, and an adaptive pass writing the `Final` handles.
struct TestSampler;

impl SamplerKind for TestSampler {
    fn name(&self) -> &'static str {
        "test"
    }
    fn estimators(&self) -> Vec<&'static str> {
        vec!["light", "hemisphere"]
    }
    fn channels(&self) -> Vec<(&'static str, &'static str)> {
        vec![("light", "light"), ("hemisphere", "hemisphere"), ("glossy", "hemisphere")]
    }
    fn settings(&self) -> Vec<&'static str> {
        vec!["light", "paths"]
    }
    fn merge(&self, setting: &str) -> SettingMerge {
        match setting {
            "paths" => SettingMerge::Max,
            _ => SettingMerge::Equal { why: "shadow rays go to one light" },
        }
    }
    fn outputs(&self) -> Vec<(&'static str, Format)> {
        vec![("estimate", Format::F32), ("stats", Format::Vec4)]
    }
    fn emit(&self, ctx: &mut ExpandCtx<'_>, plan: &SamplerPlan) -> Result<(), GraphError> {
        let record = ctx.buffer("record", Format::Vec4);
        let mut b = ctx.pass("first", "test.trace", Stage::Sample).write("record", record);
        for ((pass, name), id) in &plan.handles {
            if *pass == SamplerPass::First {
                b = b.write(name, *id);
            }
        }
        let paths = plan.setting("paths").cloned().unwrap_or(ParamValue::Int(1));
        b.param("count", paths).random().reference(Reference::Continued).finish();

        let counts = ctx.buffer("counts", Format::U32);
        let mut b = ctx.pass("counts", "test.max", Stage::Counts).write("out", counts).reference(Reference::Count);
        for (k, (_, r)) in plan.requests.iter().enumerate() {
            b = b.read_opt(&format!("request{k}"), r.paths).int(&format!("unit{k}"), i64::from(r.paths_unit));
        }
        b.finish();
        let mut per: Vec<(String, BufferId)> = Vec::new();
        for e in &plan.estimators {
            let id = ctx.buffer(&format!("per_{e}"), Format::U32);
            ctx.pass(&format!("per_{e}"), FILL_CONSTANT, Stage::Counts)
                .write("out", id)
                .int("value", 1)
                .reference(Reference::CountPerPrimary)
                .finish();
            per.push((e.clone(), id));
        }
        let last = ctx.buffer("final_record", Format::Vec4);
        let mut b = ctx.pass("adaptive", "test.trace", Stage::Adaptive).read("previous", record).read("counts", counts);
        for (e, id) in &per {
            b = b.read(e, *id);
        }
        b = b.write("record", last);
        for ((pass, name), id) in &plan.handles {
            if *pass == SamplerPass::Final {
                b = b.write(name, *id);
            }
        }
        b.int("count", 0).random_continuing("first").reference(Reference::Sample).finish();
        Ok(())
    }
}

/// Asks the sampler for the `light` estimator of light `light`, reads the first pass's `stats`,
/// writes a count request in `Stage::Bandwidth` and outputs the final `estimate` (composed).
struct Shadowy;

impl NodeKind for Shadowy {
    fn kind(&self) -> &'static str {
        "Shadowy"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        vec![]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![PortDecl::new("y", Format::F32, "composed final estimate")]
    }
    fn params(&self) -> Vec<ParamDecl> {
        vec![
            ParamDecl::int("light", 0, 0, 8, "light"),
            ParamDecl::int("paths", 1, 1, 16, "first-pass paths"),
            ParamDecl::choice("estimator", "light", &["light", "hemisphere", "lens"], "estimator to ask for"),
            ParamDecl::choice(
                "counts",
                "constant",
                &["constant", "spread", "spread0"],
                "9 per path, or a spread of `rays` (unit 9, or 0)",
            ),
            ParamDecl::choice(
                "key",
                "estimator",
                &["estimator", "glossy"],
                "the count request names the estimator, or channel `glossy`",
            ),
        ]
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        let ParamValue::Str(estimator) = ctx.param("estimator").clone() else { unreachable!() };
        let light = ctx.param("light").clone();
        ctx.sampler(
            SamplerRequest::new()
                .estimator(&estimator)
                .setting("light", light)
                .setting("paths", ctx.param("paths").clone()),
        )?;
        let stats = ctx.sampler_output(SamplerPass::First, "stats")?;
        let rays = ctx.buffer("rays", Format::U32);
        ctx.pass("rates", "test.rates", Stage::Bandwidth).read("stats", stats).write("rays", rays).finish();
        let key = match ctx.param("key") {
            ParamValue::Str(k) if k == "glossy" => "glossy".to_string(),
            _ => estimator.clone(),
        };
        let per = match ctx.param("counts") {
            ParamValue::Str(c) if c == "spread" => PerPrimary::Spread { total: rays, unit: 9 },
            ParamValue::Str(c) if c == "spread0" => PerPrimary::Spread { total: rays, unit: 0 },
            _ => PerPrimary::Constant(9),
        };
        ctx.sampler_counts(CountRequest {
            paths: Some(rays),
            paths_unit: 9,
            per_primary: vec![(key, per)],
            max3: false,
            beyond_first: false,
        })?;
        let estimate = ctx.sampler_output(SamplerPass::Final, "estimate")?;
        let y = ctx.buffer("y", Format::F32);
        ctx.pass("compose", "test.compose", Stage::Compose).read("x", estimate).write("y", y).finish();
        ctx.output("y", y);
        Ok(())
    }
}

fn registry(with_sampler: bool) -> NodeRegistry {
    let mut r = common::registry();
    r.register(Arc::new(Shadowy)).register(Arc::new(Sink));
    if with_sampler {
        r.register_sampler(Arc::new(TestSampler));
    }
    r
}

fn expansion(nodes: &[&str], with_sampler: bool) -> Result<Expansion, GraphError> {
    let v = validate(&parse(&common::pipeline(nodes)), &registry(with_sampler)).unwrap_or_else(|e| panic!("{e}"));
    expand(&v)
}

fn pass<'a>(e: &'a Expansion, name: &str) -> &'a Pass {
    e.passes.iter().find(|p| p.name == name).unwrap_or_else(|| panic!("no pass {name}"))
}

const TWO_LIGHTS_SINK: &str = r#"(name: "out", kind: "Sink", inputs: {"color": "a.y"})"#;

#[test]
fn two_nodes_share_one_sampler_and_both_requests_reach_its_counts() {
    let e = expansion(
        &[
            r#"(name: "a", kind: "Shadowy", params: {"light": 1})"#,
            r#"(name: "b", kind: "Shadowy", params: {"light": 1})"#,
            r#"(name: "out", kind: "Sink", inputs: {"color": "a.y"})"#,
        ],
        true,
    )
    .unwrap();
    let sampler: Vec<&str> = e.passes.iter().filter(|p| p.node == SAMPLER_NODE).map(|p| p.name.as_str()).collect();
    assert_eq!(sampler, ["sampler.first", "sampler.counts", "sampler.per_light", "sampler.adaptive"]);
    // Both nodes read the same handles.
    let (ra, rb) = (pass(&e, "a.rates"), pass(&e, "b.rates"));
    assert_eq!(ra.read("stats"), rb.read("stats"));
    assert_eq!(pass(&e, "a.compose").read("x"), pass(&e, "b.compose").read("x"));
    assert_eq!(e.buffer(ra.read("stats").unwrap()).name, "sampler.first_stats");
    // The counts pass reads both requests; the adaptive pass continues the first pass's stream.
    let counts = pass(&e, "sampler.counts");
    assert_eq!(counts.read("request0"), ra.write("rays"));
    assert_eq!(counts.read("request1"), rb.write("rays"));
    assert_eq!(counts.params["unit0"], ParamValue::Int(9));
    let (first, adaptive) = (pass(&e, "sampler.first"), pass(&e, "sampler.adaptive"));
    assert_eq!(first.params["stream"], ParamValue::Int(i64::from(stream_id("sampler.first"))));
    assert_eq!(adaptive.params["stream"], first.params["stream"]);
    assert_eq!(adaptive.continues.as_deref(), Some("sampler.first"));
    // The shared stream is not a collision, and stages are in order.
    let s = schedule(e).unwrap();
    let names: Vec<&str> = s.passes.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(
        names,
        ["sampler.first", "a.rates", "b.rates", "sampler.counts", "sampler.per_light", "sampler.adaptive", "a.compose"]
    );
}

#[test]
fn conflicting_settings_are_an_error_naming_both_nodes() {
    let err = expansion(
        &[
            r#"(name: "a", kind: "Shadowy", params: {"light": 1})"#,
            r#"(name: "b", kind: "Shadowy", params: {"light": 2})"#,
            TWO_LIGHTS_SINK,
        ],
        true,
    )
    .unwrap_err()
    .to_string();
    assert!(
        err.contains("node `b`")
            && err
                .contains("needs the shared sampler's `light` = 2, but node `a` needs 1: shadow rays go to one light"),
        "{err}"
    );
}

/// Issue 34 §4: settings the sampler kind declares negotiable are merged by its rule, in either
/// order, never refused.
#[test]
fn negotiable_settings_take_the_kinds_rule() {
    for (a, b) in [(1, 4), (4, 1)] {
        let e = expansion(
            &[
                &format!(r#"(name: "a", kind: "Shadowy", params: {{"paths": {a}}})"#),
                &format!(r#"(name: "b", kind: "Shadowy", params: {{"paths": {b}}})"#),
                TWO_LIGHTS_SINK,
            ],
            true,
        )
        .unwrap();
        assert_eq!(pass(&e, "sampler.first").params["count"], ParamValue::Int(4), "paths {a} and {b}");
    }
    assert_eq!(
        SettingMerge::Any.merge(&ParamValue::Bool(false), &ParamValue::Bool(true)),
        Some(ParamValue::Bool(true))
    );
    assert_eq!(SettingMerge::Max.merge(&ParamValue::Int(2), &ParamValue::Float(3.0)), None, "kinds differ");
    assert_eq!(SettingMerge::Equal { why: "" }.merge(&ParamValue::Int(2), &ParamValue::Int(3)), None);
}

#[test]
fn estimators_merge_and_unknown_ones_are_errors() {
    let e = expansion(
        &[
            r#"(name: "a", kind: "Shadowy")"#,
            r#"(name: "b", kind: "Shadowy", params: {"estimator": "hemisphere"})"#,
            TWO_LIGHTS_SINK,
        ],
        true,
    )
    .unwrap();
    let adaptive = pass(&e, "sampler.adaptive");
    assert!(adaptive.read("light").is_some() && adaptive.read("hemisphere").is_some());
    let err = expansion(&[r#"(name: "a", kind: "Shadowy", params: {"estimator": "lens"})"#, TWO_LIGHTS_SINK], true)
        .unwrap_err()
        .to_string();
    assert!(err.contains("node `a`") && err.contains("estimator `lens`") && err.contains("light, hemisphere"), "{err}");
}

#[test]
fn no_node_asking_means_no_sampler_passes() {
    let e = expansion(
        &[r#"(name: "s", kind: "Source")"#, r#"(name: "out", kind: "Sink", inputs: {"color": "s.a"})"#],
        true,
    )
    .unwrap();
    assert!(e.passes.iter().all(|p| p.node != SAMPLER_NODE), "{:?}", e.passes);
    assert!(e.buffers.iter().all(|b| !b.name.starts_with("sampler.")));
}

#[test]
fn asking_without_a_registered_sampler_or_under_its_name_is_an_error() {
    let err = expansion(&[r#"(name: "a", kind: "Shadowy")"#, TWO_LIGHTS_SINK], false).unwrap_err().to_string();
    assert!(err.contains("node `a`") && err.contains("no sampler kind is registered"), "{err}");
    let err =
        expansion(&[r#"(name: "a", kind: "Shadowy")"#, r#"(name: "sampler", kind: "Source")"#, TWO_LIGHTS_SINK], true)
            .unwrap_err()
            .to_string();
    assert!(err.contains("node `sampler`") && err.contains("`a`") && err.contains("rename this node"), "{err}");
}

#[test]
fn reference_is_n_jointly_stratified_paths_of_one_secondary_each() {
    let e = expansion(&[r#"(name: "a", kind: "Shadowy")"#, TWO_LIGHTS_SINK], true).unwrap();
    let r = reference(e, 37, "stratified").unwrap();
    assert_eq!(pass(&r, "sampler.first").params["count"], ParamValue::Int(0));
    assert_eq!(pass(&r, "sampler.adaptive").params["count"], ParamValue::Int(37));
    let counts = pass(&r, "sampler.counts");
    assert_eq!((counts.kernel.as_str(), &counts.params["value"]), (FILL_CONSTANT, &ParamValue::Int(37)));
    assert!(counts.reads.is_empty());
    assert_eq!(pass(&r, "sampler.per_light").params["value"], ParamValue::Int(1));
    // The node's rate pass is no longer needed: culled by the scheduler.
    let s = schedule(r).unwrap();
    let names: Vec<&str> = s.passes.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names, ["sampler.first", "sampler.counts", "sampler.per_light", "sampler.adaptive", "a.compose"]);
}

#[test]
fn count_requests_may_name_a_channel_of_an_asked_estimator_and_a_spread_needs_a_unit() {
    // `glossy` is a channel of `hemisphere`: fine where a node asked for `hemisphere`, an error naming
    // the estimator where none did.
    let ok = [
        r#"(name: "a", kind: "Shadowy", params: {"estimator": "hemisphere", "key": "glossy", "counts": "spread"})"#,
        TWO_LIGHTS_SINK,
    ];
    expansion(&ok, true).unwrap();
    let err = expansion(&[r#"(name: "a", kind: "Shadowy", params: {"key": "glossy"})"#, TWO_LIGHTS_SINK], true)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("node `a`") && err.contains("estimator `hemisphere`") && err.contains("no node asked"),
        "{err}"
    );
    let err = expansion(&[r#"(name: "a", kind: "Shadowy", params: {"counts": "spread0"})"#, TWO_LIGHTS_SINK], true)
        .unwrap_err()
        .to_string();
    assert!(err.contains("node `a`") && err.contains("`light`") && err.contains("`unit` must be at least 1"), "{err}");
}
