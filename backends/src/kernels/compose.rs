//! `compose.modulate`: `out = value.rgb · albedo + emission`. Textures multiply *after* filtering
//! (thesis eq. 3.1: `h(x) = r(x) ∫ f l`, with texture in `r`), so the filter never blurs texture detail.

use wedge_graph::Format;

use crate::kernel::{Binding, Kernel, KernelClass, KernelCtx, Uniforms, WgslSource};
use crate::BackendError;

pub struct Modulate;

impl Kernel for Modulate {
    fn name(&self) -> &'static str {
        "compose.modulate"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Compose
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("value", Format::Vec4),
            Binding::read_opt("albedo", Format::Vec3),
            Binding::read_opt("emission", Format::Vec3),
            Binding::write("out", Format::Vec3),
        ]
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/compose_modulate.wgsl"), |_| Ok(Uniforms::new()))
                .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let value = ctx.read::<[f32; 4]>("value")?;
        let albedo = ctx.read_opt::<[f32; 3]>("albedo")?;
        let emission = ctx.read_opt::<[f32; 3]>("emission")?;
        let out = (0..ctx.pixels())
            .map(|i| {
                let a = albedo.map_or([1.0; 3], |a| a[i]);
                let e = emission.map_or([0.0; 3], |e| e[i]);
                std::array::from_fn(|c| value[i][c] * a[c] + e[c])
            })
            .collect::<Vec<[f32; 3]>>();
        ctx.put("out", out)
    }
}
