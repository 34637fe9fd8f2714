//! A node and kernel written outside wedge: `Fog` attenuates a radiance image by the distance from
//! the camera to the surface each pixel sees and adds a fog colour, `out = fog + (color − fog)·T`
//! with `T = exp(−density·distance)` (Beer–Lambert with constant in-scattered radiance; `T = 0`
//! where no surface is seen). The kernel has both implementations — Rust here for the CPU backend,
//! `fog.wgsl` for wgpu — and [`registries`] adds both to wedge's own.

use wedge::backends::{BackendError, Kernel, KernelCtx, KernelParams, WgslSource};
use wedge::graph::{ExpandCtx, Format, GraphError, NodeKind, ParamDecl, PortDecl, Stage};
use wedge::Registries;

/// wedge's nodes and kernels plus Fog's: what `wedge-fog` runs every command with.
pub fn registries() -> Registries {
    Registries::builtin().with_node(Fog).with_kernel(FogKernel)
}

wedge::backends::kernel_params! {
    /// Fog's parameters, declared once: the node's declarations, its forwarding, the kernel's typed
    /// read and the WGSL `params` block all come from here.
    pub struct FogParams {
        density: f32 = float(0.1, 0.0, 1e3, "extinction per metre"),
        colour: [f32; 3] = colour([0.5, 0.5, 0.5], 1e6, "fog radiance (linear RGB)"),
    }
}

wedge::backends::kernel_bindings! {
    /// Fog's bindings, declared once: the kernel's `bindings()`, its typed reads and write, and the
    /// node's `FogIo { .. }.bind(pass)` all come from here.
    pub struct FogIo / FogData {
        read color: [f32; 3], read position: [f32; 4], write out: [f32; 3],
    }
}

pub struct FogKernel;

impl Kernel for FogKernel {
    wedge::backends::kernel_signature!(name: "fog.apply", class: Compose, bindings: FogIo, params: [FogParams]);
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let (p, eye, io) = (FogParams::read(ctx)?, eye(ctx), FogIo::read(ctx)?);
        let image = io.color.iter().zip(io.position).map(|(c, x)| fogged(&p, eye, *c, *x)).collect();
        io.out.put(ctx, image)
    }
    fn wgsl(&self) -> Option<WgslSource> {
        let uniforms = |ctx: &KernelCtx<'_>| Ok(FogParams::read(ctx)?.uniforms().vec3("eye", eye(ctx)));
        Some(WgslSource::new(include_str!("../fog.wgsl"), uniforms).per_pixel())
    }
}

/// Where distances are measured from: the camera.
fn eye(ctx: &KernelCtx<'_>) -> [f32; 3] {
    ctx.scene.camera.position.to_array()
}

/// One pixel: `colour + (c − colour)·T`, the formula `fog.wgsl` computes.
fn fogged(p: &FogParams, eye: [f32; 3], c: [f32; 3], x: [f32; 4]) -> [f32; 3] {
    let t = if x[3] > 0.0 {
        let d = [x[0] - eye[0], x[1] - eye[1], x[2] - eye[2]];
        (-p.density * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()).exp()
    } else {
        0.0
    };
    std::array::from_fn(|i| p.colour[i] + (c[i] - p.colour[i]) * t)
}

pub struct Fog;

impl NodeKind for Fog {
    fn kind(&self) -> &'static str {
        "Fog"
    }
    fn doc(&self) -> &'static str {
        "Homogeneous fog: the colour attenuated by exp(-density·distance) towards a constant fog colour"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        vec![
            PortDecl::new("color", Format::Vec3, "linear radiance"),
            PortDecl::new("position", Format::Vec4, "world position; w > 0 where a surface is seen (Primary.position)"),
        ]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![PortDecl::new("color", Format::Vec3, "radiance seen through the fog")]
    }
    fn params(&self) -> Vec<ParamDecl> {
        FogParams::decls()
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        let (color, position) = (ctx.required("color")?, ctx.required("position")?);
        let out = ctx.buffer("color", Format::Vec3);
        let pass = ctx.pass("apply", "fog.apply", Stage::ImageFilter);
        FogIo { color, position, out }.bind(pass).node_params(FogParams::names()).finish();
        ctx.output("color", out);
        Ok(())
    }
}
