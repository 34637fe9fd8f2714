//! A kernel and an effect node defined outside wedge: `Exposure` scales a colour by `2^stops`.
//! The kernel has both implementations — Rust for the CPU backend, `exposure.wgsl` for wgpu — and is
//! registered next to wedge's own with `wedge::effects::builtin()` + `register`.

use std::sync::Arc;

use wedge::backends::{BackendError, Binding, Kernel, KernelClass, KernelCtx, KernelRegistry, Uniforms, WgslSource};
use wedge::graph::{ExpandCtx, Format, GraphError, NodeKind, NodeRegistry, ParamDecl, PortDecl, Stage};

pub struct ExposureKernel;

fn scale(ctx: &KernelCtx<'_>) -> Result<f32, BackendError> {
    Ok(2f32.powf(ctx.f32_param("stops")?))
}

impl Kernel for ExposureKernel {
    fn name(&self) -> &'static str {
        "example.exposure"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Compose
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![Binding::read("value", Format::Vec3), Binding::write("out", Format::Vec3)]
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let s = scale(ctx)?;
        let value = ctx.read::<[f32; 3]>("value")?;
        let out = value.iter().map(|v| v.map(|c| c * s)).collect::<Vec<[f32; 3]>>();
        ctx.put("out", out)
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(WgslSource::new(include_str!("../exposure.wgsl"), |ctx| Ok(Uniforms::new().f32("scale", scale(ctx)?))).per_pixel())
    }
}

pub struct Exposure;

impl NodeKind for Exposure {
    fn kind(&self) -> &'static str {
        "Exposure"
    }
    fn doc(&self) -> &'static str {
        "Scale a colour by 2^stops (example of a user-defined node and kernel)"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        vec![PortDecl::new("color", Format::Vec3, "linear radiance")]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![PortDecl::new("color", Format::Vec3, "radiance × 2^stops")]
    }
    fn params(&self) -> Vec<ParamDecl> {
        vec![ParamDecl::float("stops", 0.0, -20.0, 20.0, "exposure change in stops")]
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        let input = ctx.required("color")?;
        let stops = ctx.param("stops").clone();
        let out = ctx.buffer("color", Format::Vec3);
        ctx.pass("scale", "example.exposure", Stage::ImageFilter).read("value", input).write("out", out).param("stops", stops).finish();
        ctx.output("color", out);
        Ok(())
    }
}

/// wedge's registries plus this crate's node and kernel.
pub fn registries() -> (NodeRegistry, KernelRegistry) {
    let (mut nodes, mut kernels) = wedge::effects::builtin();
    nodes.register(Arc::new(Exposure));
    kernels.register(Arc::new(ExposureKernel));
    (nodes, kernels)
}

fn pipeline_path() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("pipeline.ron")
}

/// The example pipeline, opened with the extended registries.
pub fn session(ov: &wedge::Overrides) -> Result<wedge::Session, wedge::WedgeError> {
    let loaded = wedge::graph::load_pipeline(&pipeline_path())?;
    let (nodes, kernels) = registries();
    wedge::Session::build(loaded, ov, nodes, kernels)
}

/// The example pipeline's Monte Carlo reference: `Exposure` declares only its stage (an image-space
/// pass, kept in a reference), so the reference needs no code of this crate's own.
pub fn reference(ov: &wedge::Overrides, spp: u32, sampling: &str) -> Result<wedge::Session, wedge::WedgeError> {
    let loaded = wedge::graph::load_pipeline(&pipeline_path())?;
    let (nodes, kernels) = registries();
    wedge::Session::build_reference(loaded, ov, nodes, kernels, spp, sampling)
}
