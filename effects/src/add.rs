//! `Add`: the sum of two radiance images — e.g. `SoftShadows` (direct) + `Indirect` (the rest), so
//! the graph, not a node, composes separately filtered light paths.

use std::sync::Arc;

use wedge_backends::{BackendError, Kernel, KernelCtx, KernelRegistry, Uniforms, WgslSource};
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
        AddIo { a, b, out }.bind(ctx.pass("add", "compose.add", Stage::Compose)).finish();
        ctx.output("radiance", out);
        Ok(())
    }
}

wedge_backends::kernel_bindings! {
    /// What a `compose.add` pass binds.
    pub struct AddIo / AddData {
        read a: [f32; 3], read b: [f32; 3], write out: [f32; 3],
    }
}

/// `compose.add`: `out = a + b` per pixel and channel.
pub struct ComposeAdd;

impl Kernel for ComposeAdd {
    wedge_backends::kernel_signature!(name: "compose.add", class: Compose, bindings: AddIo);
    /// WGSL mirror: `shaders/compose_add.wgsl`.
    fn wgsl(&self) -> Option<WgslSource> {
        Some(WgslSource::new(include_str!("../../shaders/compose_add.wgsl"), |_| Ok(Uniforms::new())).per_pixel())
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let AddData { a, b, out } = AddIo::read(ctx)?;
        out.put(ctx, a.iter().zip(b).map(|(x, y)| std::array::from_fn(|c| x[c] + y[c])).collect())
    }
}

pub fn register_kernels(reg: &mut KernelRegistry) {
    reg.register(Arc::new(ComposeAdd));
}
