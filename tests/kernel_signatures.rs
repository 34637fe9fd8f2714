//! A node's passes are checked against their kernels' declared bindings when the session is built
//! (before the scene is traced or any buffer allocated), and every mismatch is reported at once.

use std::path::Path;
use std::sync::Arc;

use wedge::graph::{ExpandCtx, Format, GraphError, NodeKind, ParamDecl, PortDecl};

/// Runs `compose.modulate` (reads `value: vec4`, optional `albedo`/`emission: vec3`, writes
/// `out: vec3`) with three mistakes: `value` bound to a vec3 buffer, an undeclared `tint` read, and a
/// second pass that never binds the required `out`.
struct Miswired;

impl NodeKind for Miswired {
    fn kind(&self) -> &'static str {
        "Miswired"
    }
    fn doc(&self) -> &'static str {
        "a node whose passes do not match compose.modulate's signature"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        vec![PortDecl::new("albedo", Format::Vec3, "albedo"), PortDecl::new("position", Format::Vec4, "position")]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![PortDecl::new("color", Format::Vec3, "colour"), PortDecl::new("extra", Format::Vec3, "colour")]
    }
    fn params(&self) -> Vec<ParamDecl> {
        Vec::new()
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        let albedo = ctx.required("albedo")?;
        let out = ctx.buffer("color", Format::Vec3);
        ctx.pass("wrong", "compose.modulate", wedge::graph::Stage::Compose)
            .read("value", albedo)
            .read("tint", albedo)
            .write("out", out)
            .finish();
        let position = ctx.required("position")?;
        let other = ctx.buffer("extra", Format::Vec3);
        ctx.pass("fill", "compose.modulate", wedge::graph::Stage::Compose)
            .read("value", position)
            .write("spare", other)
            .finish();
        ctx.output("color", out);
        ctx.output("extra", other);
        Ok(())
    }
}

const PIPELINE: &str = r#"Pipeline(
    scene: "builtin:grids", width: 16, height: 12, seed: 1,
    nodes: [
        (name: "primary", kind: "Primary"),
        (name: "bad", kind: "Miswired", inputs: {"albedo": "primary.albedo", "position": "primary.position"}),
        (name: "out", kind: "Output", inputs: {"color": "bad.color", "unfiltered": "bad.extra"}),
    ],
)"#;

#[test]
fn every_binding_mismatch_is_reported_before_anything_runs() {
    let (mut nodes, kernels) = wedge::effects::builtin();
    nodes.register(Arc::new(Miswired));
    let loaded = wedge::graph::parse_pipeline(Path::new("miswired.ron"), PIPELINE).unwrap();
    let err = match wedge::Session::build(loaded, &Default::default(), nodes, kernels) {
        Ok(_) => panic!("a miswired node built a session"),
        Err(e) => e.to_string(),
    };
    println!("{err}");
    for line in [
        "4 signature problem(s): passes do not match their kernel's bindings and parameters",
        "pass `bad.wrong`: binding `value` is bound to a vec3<f32> buffer but the kernel declares vec4<f32>",
        "pass `bad.wrong`: binding `tint` is not declared by kernel `compose.modulate` as a Read",
        "pass `bad.fill`: binding `spare` is not declared by kernel `compose.modulate` as a Write",
        "pass `bad.fill`: binding `out` is required by kernel `compose.modulate` but not bound",
    ] {
        assert!(err.contains(line), "missing {line:?} in\n{err}");
    }
    assert!(err.contains("fix the node's `expand`"), "{err}");
}

/// A kernel that draws random numbers keys them by the pass's graph-assigned stream: a pass of it
/// not declared `.random()` is a signature problem, found before it runs.
#[test]
fn a_random_kernel_needs_a_pass_declared_random() {
    let (_, kernels) = wedge::effects::builtin();
    let schedule = wedge::graph::Schedule {
        passes: Vec::new(),
        buffers: Vec::new(),
        lifetimes: Vec::new(),
        slots: Vec::new(),
        slot_formats: Vec::new(),
        slot_layers: Vec::new(),
        sink_inputs: Vec::new(),
        history: Vec::new(),
        culled: Vec::new(),
    };
    let mut pass = wedge::graph::Pass::new("shadows.sample", "shadows", "direct.light", wedge::graph::Stage::Sample);
    let problems: Vec<String> = kernels.pass_problems(&schedule, &pass).iter().map(|e| e.to_string()).collect();
    assert!(problems.iter().any(|p| p.contains("declare the pass `.random()`")), "{problems:?}");
    pass.random = true;
    let problems: Vec<String> = kernels.pass_problems(&schedule, &pass).iter().map(|e| e.to_string()).collect();
    assert!(!problems.iter().any(|p| p.contains(".random()")), "{problems:?}");
}

/// A user's kernel whose WGSL has a typo (`scael` for `scale`): a session built for the CPU backend
/// refuses it — no device needed — at the kernel's own line, not the composed shader's.
struct Typo;

impl wedge::backends::Kernel for Typo {
    fn name(&self) -> &'static str {
        "user.typo"
    }
    fn class(&self) -> wedge::backends::KernelClass {
        wedge::backends::KernelClass::Compose
    }
    fn bindings(&self) -> Vec<wedge::backends::Binding> {
        vec![
            wedge::backends::Binding::read("value", Format::Vec4),
            wedge::backends::Binding::write("out", Format::Vec3),
        ]
    }
    fn run_cpu(&self, ctx: &mut wedge::backends::KernelCtx<'_>) -> Result<(), wedge::backends::BackendError> {
        let v = ctx.read::<[f32; 4]>("value")?;
        let out = v.iter().map(|p| [p[0], p[1], p[2]]).collect::<Vec<[f32; 3]>>();
        ctx.put("out", out)
    }
    fn wgsl(&self) -> Option<wedge::backends::WgslSource> {
        const SOURCE: &str = "#include \"common.wgsl\"\n@compute @workgroup_size(8, 8)\nfn main(@builtin(global_invocation_id) gid: vec3<u32>) {\n    if (!pixel_of(gid)) {\n        return;\n    }\n    let i = pixel_index(gid);\n    out_put(i, value_at(i).xyz * params.scael);\n}\n";
        Some(
            wedge::backends::WgslSource::new(SOURCE, |_| Ok(wedge::backends::Uniforms::new().f32("scale", 1.0)))
                .per_pixel(),
        )
    }
}

struct UsesTypo;

impl NodeKind for UsesTypo {
    fn kind(&self) -> &'static str {
        "UsesTypo"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        vec![PortDecl::new("position", Format::Vec4, "position")]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![PortDecl::new("color", Format::Vec3, "colour")]
    }
    fn params(&self) -> Vec<ParamDecl> {
        Vec::new()
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        let position = ctx.required("position")?;
        let out = ctx.buffer("color", Format::Vec3);
        ctx.pass("apply", "user.typo", wedge::graph::Stage::ImageFilter)
            .read("value", position)
            .write("out", out)
            .finish();
        ctx.output("color", out);
        Ok(())
    }
}

#[test]
fn a_wgsl_typo_is_refused_at_its_line_without_a_device() {
    let registries = wedge::Registries::builtin().with_node(UsesTypo).with_kernel(Typo);
    let text = r#"Pipeline(scene: "builtin:grids", width: 8, height: 6, seed: 1, nodes: [
        (name: "primary", kind: "Primary"),
        (name: "typo", kind: "UsesTypo", inputs: {"position": "primary.position"}),
        (name: "out", kind: "Output", inputs: {"color": "typo.color"}),
    ])"#;
    let loaded = wedge::graph::parse_pipeline(Path::new("typo.ron"), text).unwrap();
    let wedge::Registries { nodes, kernels } = registries;
    let err = match wedge::Session::build(loaded, &Default::default(), nodes, kernels) {
        Ok(_) => panic!("a kernel with a WGSL typo built a session"),
        Err(e) => e.to_string(),
    };
    // Line 8 of the kernel's own source, with the line quoted.
    assert!(err.contains("kernel `user.typo` (pass `typo.apply`): user.typo:8:"), "{err}");
    assert!(err.contains("params.scael"), "{err}");
}

/// A node kind that reads a parameter it does not declare (`density`, declared as `dens`).
struct ReadsUndeclared;

impl NodeKind for ReadsUndeclared {
    fn kind(&self) -> &'static str {
        "ReadsUndeclared"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        vec![PortDecl::new("color", Format::Vec3, "colour")]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![PortDecl::new("color", Format::Vec3, "colour")]
    }
    fn params(&self) -> Vec<ParamDecl> {
        vec![ParamDecl::float("dens", 1.0, 0.0, 10.0, "density")]
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        let _ = ctx.param("density").as_f64();
        let color = ctx.required("color")?;
        ctx.output("color", color);
        Ok(())
    }
}

/// The expansion is refused naming the parameter and what is declared; nothing panics.
#[test]
fn reading_an_undeclared_parameter_is_an_error_not_a_panic() {
    let text = r#"Pipeline(scene: "builtin:grids", width: 8, height: 6, seed: 1, nodes: [
        (name: "primary", kind: "Primary"),
        (name: "user", kind: "ReadsUndeclared", inputs: {"color": "primary.albedo"}),
        (name: "out", kind: "Output", inputs: {"color": "user.color"}),
    ])"#;
    let loaded = wedge::graph::parse_pipeline(Path::new("undeclared.ron"), text).unwrap();
    let wedge::Registries { nodes, kernels } = wedge::Registries::builtin().with_node(ReadsUndeclared);
    let err = match wedge::Session::build(loaded, &Default::default(), nodes, kernels) {
        Ok(_) => panic!("a node reading an undeclared parameter expanded"),
        Err(e) => e.to_string(),
    };
    assert!(
        err.contains("`user`") && err.contains("undeclared parameter(s) `density`") && err.contains("declared: dens"),
        "{err}"
    );
}

wedge::backends::kernel_params! {
    /// What `user.scale` reads: one declared number and one the node sets.
    struct ScaleParams {
        scale: f32 = positive(1.0, 1e6, "multiplier"),
        tint: [f32; 3],
    }
}

/// A kernel with typed parameters ([`wedge::backends::kernel_params!`]).
struct Scale;

impl wedge::backends::Kernel for Scale {
    fn name(&self) -> &'static str {
        "user.scale"
    }
    fn class(&self) -> wedge::backends::KernelClass {
        wedge::backends::KernelClass::Compose
    }
    fn bindings(&self) -> Vec<wedge::backends::Binding> {
        vec![
            wedge::backends::Binding::read("value", Format::Vec4),
            wedge::backends::Binding::write("out", Format::Vec3),
        ]
    }
    fn params(&self) -> Vec<wedge::backends::ParamSpec> {
        use wedge::backends::KernelParams;
        ScaleParams::specs()
    }
    fn run_cpu(&self, _: &mut wedge::backends::KernelCtx<'_>) -> Result<(), wedge::backends::BackendError> {
        unreachable!("refused before it runs")
    }
}

/// Forwards `scale` as a string and never sets `tint`.
struct ForgetsTint;

impl NodeKind for ForgetsTint {
    fn kind(&self) -> &'static str {
        "ForgetsTint"
    }
    fn doc(&self) -> &'static str {
        "a node that does not give user.scale its parameters"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        vec![PortDecl::new("position", Format::Vec4, "position")]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![PortDecl::new("color", Format::Vec3, "colour")]
    }
    fn params(&self) -> Vec<ParamDecl> {
        Vec::new()
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        let position = ctx.required("position")?;
        let out = ctx.buffer("color", Format::Vec3);
        ctx.pass("apply", "user.scale", wedge::graph::Stage::Compose)
            .read("value", position)
            .write("out", out)
            .param("scale", wedge::graph::ParamValue::Str("big".into()))
            .finish();
        ctx.output("color", out);
        Ok(())
    }
}

/// A kernel's declared parameters are part of its signature: a pass without one, or with one of
/// another type, is refused when the session is built, with the fix.
#[test]
fn a_kernels_typed_parameters_are_checked_before_anything_runs() {
    let (mut nodes, mut kernels) = wedge::effects::builtin();
    nodes.register(Arc::new(ForgetsTint));
    kernels.register(Arc::new(Scale));
    let text = PIPELINE
        .replace(
            "\"Miswired\", inputs: {\"albedo\": \"primary.albedo\", \"position\": \"primary.position\"}",
            "\"ForgetsTint\", inputs: {\"position\": \"primary.position\"}",
        )
        .replace("\"unfiltered\": \"bad.extra\"", "\"unfiltered\": \"bad.color\"");
    let loaded = wedge::graph::parse_pipeline(Path::new("forgets.ron"), &text).unwrap();
    let err = match wedge::Session::build(loaded, &Default::default(), nodes, kernels) {
        Ok(_) => panic!("a pass without its kernel's parameters built a session"),
        Err(e) => e.to_string(),
    };
    for line in [
        "2 signature problem(s)",
        "pass `bad.apply`: parameter `scale`: kernel `user.scale` reads it as a number; the pass carries \"big\"",
        "pass `bad.apply`: parameter `tint`: kernel `user.scale` reads it as three numbers; the pass does not carry it: forward it from the node (`.node_params(..)`) or set it (`.param(..)`)",
    ] {
        assert!(err.contains(line), "missing {line:?} in\n{err}");
    }
}
