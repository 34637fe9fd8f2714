//! A node and kernel written outside wedge: `Fog` attenuates a radiance image by the distance from
//! the camera to the surface each pixel sees and adds a fog colour, `out = fog + (color − fog)·T`
//! with `T = exp(−density·distance)` (Beer–Lambert with constant in-scattered radiance; `T = 0`
//! where no surface is seen). The kernel has both implementations — Rust here for the CPU backend,
//! `fog.wgsl` for wgpu — and [`registries`] adds both to wedge's own.

use wedge::backends::{BackendError, Binding, Kernel, KernelClass, KernelCtx, Uniforms, WgslSource};
use wedge::graph::{ExpandCtx, Format, GraphError, NodeKind, ParamDecl, PortDecl, Stage};
use wedge::Registries;

/// wedge's nodes and kernels plus Fog's: what `wedge-fog` runs every command with.
pub fn registries() -> Registries {
    Registries::builtin().with_node(Fog).with_kernel(FogKernel)
}

/// The fog's parameters as the kernel uses them (one read of the pass's parameters for both backends).
struct FogParams {
    density: f32,
    colour: [f32; 3],
    eye: [f32; 3],
}

fn fog_params(ctx: &KernelCtx<'_>) -> Result<FogParams, BackendError> {
    Ok(FogParams { density: ctx.f32_param("density")?, colour: ctx.vec3_param("colour")?, eye: ctx.scene.camera.position.to_array() })
}

pub struct FogKernel;

impl Kernel for FogKernel {
    fn name(&self) -> &'static str {
        "fog.apply"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Compose
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![Binding::read("color", Format::Vec3), Binding::read("position", Format::Vec4), Binding::write("out", Format::Vec3)]
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let p = fog_params(ctx)?;
        let (color, position) = (ctx.read::<[f32; 3]>("color")?, ctx.read::<[f32; 4]>("position")?);
        let out = color.iter().zip(position).map(|(c, x)| fogged(&p, *c, *x)).collect();
        ctx.put("out", out)
    }
    fn wgsl(&self) -> Option<WgslSource> {
        let uniforms = |ctx: &KernelCtx<'_>| {
            let p = fog_params(ctx)?;
            Ok(Uniforms::new().vec3("eye", p.eye).vec3("colour", p.colour).f32("density", p.density))
        };
        Some(WgslSource::new(include_str!("../fog.wgsl"), uniforms).per_pixel())
    }
}

/// One pixel: `colour + (c − colour)·T`, the formula `fog.wgsl` computes.
fn fogged(p: &FogParams, c: [f32; 3], x: [f32; 4]) -> [f32; 3] {
    let t = if x[3] > 0.0 {
        let d = [x[0] - p.eye[0], x[1] - p.eye[1], x[2] - p.eye[2]];
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
        vec![
            ParamDecl::float("density", 0.1, 0.0, 1e3, "extinction per metre"),
            ParamDecl::colour("colour", [0.5, 0.5, 0.5], 1e6, "fog radiance (linear RGB)"),
        ]
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        let (color, position) = (ctx.required("color")?, ctx.required("position")?);
        let out = ctx.buffer("color", Format::Vec3);
        let pass = ctx.pass("apply", "fog.apply", Stage::ImageFilter).read("color", color).read("position", position);
        pass.write("out", out).node_params(&["density", "colour"]).finish();
        ctx.output("color", out);
        Ok(())
    }
}
