//! `Add`: the sum of two radiance images — e.g. `SoftShadows` (direct) + `Indirect` (the rest), so
//! the graph, not a node, composes separately filtered light paths.

use std::sync::Arc;

use wedge_backends::{BackendError, Binding, Kernel, KernelClass, KernelCtx, KernelRegistry, Uniforms, WgslSource};
use wedge_graph::{Accepts, ExpandCtx, Format, GraphError, NodeKind, ParamDecl, PortDecl, Stage, TermQuery, Terms};

pub struct Add;

impl NodeKind for Add {
    fn kind(&self) -> &'static str {
        "Add"
    }
    fn doc(&self) -> &'static str {
        "Sum of two radiance images (a + b)"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        vec![
            PortDecl::new("a", Format::Vec3, "first radiance").accepts(Accepts::ANY),
            PortDecl::new("b", Format::Vec3, "second radiance").accepts(Accepts::ANY),
        ]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![PortDecl::new("radiance", Format::Vec3, "a + b")]
    }
    fn params(&self) -> Vec<ParamDecl> {
        vec![]
    }
    /// The union of its operands' terms: a term in both is a double count, refused by the validator.
    fn terms(&self, _port: &str, q: &TermQuery<'_>) -> Option<Terms> {
        Some(q.sum(&["a", "b"]))
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        let a = ctx.required("a")?;
        let b = ctx.required("b")?;
        let out = ctx.buffer("radiance", Format::Vec3);
        ctx.pass("add", "compose.add", Stage::Compose).read("a", a).read("b", b).write("out", out).finish();
        ctx.output("radiance", out);
        Ok(())
    }
}

/// `compose.add`: `out = a + b` per pixel and channel.
pub struct ComposeAdd;

impl Kernel for ComposeAdd {
    fn name(&self) -> &'static str {
        "compose.add"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Compose
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![Binding::read("a", Format::Vec3), Binding::read("b", Format::Vec3), Binding::write("out", Format::Vec3)]
    }
    /// WGSL mirror: `shaders/compose_add.wgsl`.
    fn wgsl(&self) -> Option<WgslSource> {
        Some(WgslSource::new(include_str!("../../shaders/compose_add.wgsl"), |_| Ok(Uniforms::new())).per_pixel())
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let a = ctx.read::<[f32; 3]>("a")?;
        let b = ctx.read::<[f32; 3]>("b")?;
        let out: Vec<[f32; 3]> = a.iter().zip(b).map(|(x, y)| std::array::from_fn(|c| x[c] + y[c])).collect();
        ctx.put("out", out)
    }
}

pub fn register_kernels(reg: &mut KernelRegistry) {
    reg.register(Arc::new(ComposeAdd));
}
