//! A small fake node registry for the integration tests, so that graph behaviour is tested without
//! the real effects crate:
//! - `Source`: outputs `a: f32`, `b: vec3`; one pass.
//! - `Blur`: input `x: f32`, output `y: f32`, params `mu` (> 0) and `taps` (int 1..=16); two passes
//!   (`h` writes a temporary, `v` reads it and writes `y`).
//! - `Sink` (a sink): inputs `color: f32`, optional `aux: vec3`; no passes of its own.
//! - `Grade` / `Mix`: input `x: f32`, output `y: f32`, one pass in stage `ImageFilter` / `Compose`
//!   (an image-space filter, and a composition that may follow one).
//! - `Lazy` / `Twice` / `WrongFormat`: broken kinds, to test that `expand` catches contract violations.
#![allow(dead_code)]

use std::path::Path;
use std::sync::Arc;

use wedge_graph::*;

pub struct Source;
impl NodeKind for Source {
    fn kind(&self) -> &'static str {
        "Source"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        vec![]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![PortDecl::new("a", Format::F32, "scalar"), PortDecl::new("b", Format::Vec3, "vector")]
    }
    fn params(&self) -> Vec<ParamDecl> {
        vec![ParamDecl::choice("mode", "fast", &["fast", "slow"], "how")]
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        let a = ctx.buffer("a", Format::F32);
        let b = ctx.buffer("b", Format::Vec3);
        ctx.pass("gen", "test.gen", Stage::Sample).write("a", a).write("b", b).finish();
        ctx.output("a", a);
        ctx.output("b", b);
        Ok(())
    }
}

pub struct Blur;
impl NodeKind for Blur {
    fn kind(&self) -> &'static str {
        "Blur"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        vec![PortDecl::new("x", Format::F32, "input")]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![PortDecl::new("y", Format::F32, "blurred")]
    }
    fn params(&self) -> Vec<ParamDecl> {
        vec![
            ParamDecl::positive("mu", 1.0, 100.0, "filter width"),
            ParamDecl::int("taps", 3, 1, 16, "taps"),
            ParamDecl::boolean("wide", false, "wide"),
            ParamDecl::colour("tint", [1.0, 1.0, 1.0], 1.0, "albedo-like colour"),
        ]
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        let x = ctx.required("x")?;
        let t = ctx.buffer("tmp", Format::F32);
        let y = ctx.buffer("y", Format::F32);
        ctx.pass("h", "test.blur_h", Stage::Filter)
            .read("x", x)
            .write("out", t)
            .node_params(&["mu"])
            .reference(Reference::Bypass { input: "x" })
            .finish();
        ctx.pass("v", "test.blur_v", Stage::Filter)
            .read("x", t)
            .write("out", y)
            .node_params(&["mu", "taps"])
            .reference(Reference::Bypass { input: "x" })
            .finish();
        ctx.output("y", y);
        Ok(())
    }
}

pub struct Sink;
impl NodeKind for Sink {
    fn kind(&self) -> &'static str {
        "Sink"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        vec![PortDecl::new("color", Format::F32, "shown"), PortDecl::optional("aux", Format::Vec3, "extra")]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![]
    }
    fn params(&self) -> Vec<ParamDecl> {
        vec![]
    }
    fn is_sink(&self) -> bool {
        true
    }
    fn expand(&self, _ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        Ok(())
    }
}

/// One pass of `stage` reading input `x` into output `y`.
fn one_pass(ctx: &mut ExpandCtx<'_>, stage: Stage) -> Result<(), GraphError> {
    let x = ctx.required("x")?;
    let y = ctx.buffer("y", Format::F32);
    ctx.pass("p", "test.p", stage).read("x", x).write("out", y).finish();
    ctx.output("y", y);
    Ok(())
}

macro_rules! one_pass_kind {
    ($name:ident, $stage:expr) => {
        pub struct $name;
        impl NodeKind for $name {
            fn kind(&self) -> &'static str {
                stringify!($name)
            }
            fn inputs(&self) -> Vec<PortDecl> {
                vec![PortDecl::new("x", Format::F32, "input")]
            }
            fn outputs(&self) -> Vec<PortDecl> {
                vec![PortDecl::new("y", Format::F32, "output")]
            }
            fn params(&self) -> Vec<ParamDecl> {
                vec![]
            }
            fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
                one_pass(ctx, $stage)
            }
        }
    };
}
one_pass_kind!(Grade, Stage::ImageFilter);
one_pass_kind!(Mix, Stage::Compose);

/// Declares output `y` but never binds it.
pub struct Lazy;
impl NodeKind for Lazy {
    fn kind(&self) -> &'static str {
        "Lazy"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        vec![]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![PortDecl::new("y", Format::F32, "")]
    }
    fn params(&self) -> Vec<ParamDecl> {
        vec![]
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        let y = ctx.buffer("y", Format::F32);
        ctx.pass("p", "test.p", Stage::Sample).write("out", y).finish();
        Ok(())
    }
}

/// Writes its output buffer from two passes.
pub struct Twice;
impl NodeKind for Twice {
    fn kind(&self) -> &'static str {
        "Twice"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        vec![]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![PortDecl::new("y", Format::F32, "")]
    }
    fn params(&self) -> Vec<ParamDecl> {
        vec![]
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        let y = ctx.buffer("y", Format::F32);
        ctx.pass("p1", "test.p", Stage::Sample).write("out", y).finish();
        ctx.pass("p2", "test.p", Stage::Sample).write("out", y).finish();
        ctx.output("y", y);
        Ok(())
    }
}

/// Binds its f32 output to a vec3 buffer.
pub struct WrongFormat;
impl NodeKind for WrongFormat {
    fn kind(&self) -> &'static str {
        "WrongFormat"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        vec![]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![PortDecl::new("y", Format::F32, "")]
    }
    fn params(&self) -> Vec<ParamDecl> {
        vec![]
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        let y = ctx.buffer("y", Format::Vec3);
        ctx.pass("p", "test.p", Stage::Sample).write("out", y).finish();
        ctx.output("y", y);
        Ok(())
    }
}

pub fn registry() -> NodeRegistry {
    let mut r = NodeRegistry::new();
    r.register(Arc::new(Source))
        .register(Arc::new(Blur))
        .register(Arc::new(Sink))
        .register(Arc::new(Grade))
        .register(Arc::new(Mix))
        .register(Arc::new(Lazy))
        .register(Arc::new(Twice))
        .register(Arc::new(WrongFormat));
    r
}

/// A pipeline file with the standard header; node `k` is on line `4 + k`, starting at column 9:
///
/// ```text
/// 1 Pipeline(
/// 2     scene: "builtin:grids", width: 64, height: 32,
/// 3     nodes: [
/// 4         <node 0>,
/// ...
/// ```
pub fn pipeline(nodes: &[&str]) -> String {
    pipeline_sized(64, 32, nodes)
}

pub fn pipeline_sized(width: u32, height: u32, nodes: &[&str]) -> String {
    let mut s = format!("Pipeline(\n    scene: \"builtin:grids\", width: {width}, height: {height},\n    nodes: [\n");
    for n in nodes {
        s.push_str("        ");
        s.push_str(n);
        s.push_str(",\n");
    }
    s.push_str("    ],\n)\n");
    s
}

pub fn parse(text: &str) -> LoadedPipeline {
    parse_pipeline(Path::new("test.ron"), text).unwrap_or_else(|e| panic!("parse failed: {e}"))
}

/// Validate, expecting failure; the diagnostics.
pub fn diagnostics(text: &str) -> Vec<Diagnostic> {
    match validate(&parse(text), &registry()) {
        Err(GraphError::Invalid(d)) => d,
        Err(e) => panic!("expected GraphError::Invalid, got {e}"),
        Ok(_) => panic!("expected validation to fail:\n{text}"),
    }
}

/// Validate, expand and schedule, expecting success.
pub fn compile_text(text: &str) -> (ValidatedPipeline, Schedule) {
    let v = validate(&parse(text), &registry()).unwrap_or_else(|e| panic!("{e}"));
    let e = expand(&v).unwrap_or_else(|e| panic!("{e}"));
    let s = schedule(e).unwrap_or_else(|e| panic!("{e}"));
    (v, s)
}
