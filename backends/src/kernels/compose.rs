//! `compose.modulate`: `out = value.rgb · albedo + emission`. Textures multiply *after* filtering
//! (thesis eq. 3.1: `h(x) = r(x) ∫ f l`, with texture in `r`), so the filter never blurs texture detail.

use crate::kernel::{Kernel, KernelCtx, Uniforms, WgslSource};
use crate::BackendError;

crate::kernel_bindings! {
    /// What a `compose.modulate` pass binds: the filtered value (rgb of a `vec4` estimate), the
    /// albedo it is multiplied by and the emission added (each optional: 1 and 0 without).
    pub struct ModulateIo / ModulateData {
        read value: [f32; 4], read_opt albedo: [f32; 3], read_opt emission: [f32; 3], write out: [f32; 3],
    }
}

pub struct Modulate;

impl Kernel for Modulate {
    crate::kernel_signature!(name: "compose.modulate", class: Compose, bindings: ModulateIo);
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/compose_modulate.wgsl"), |_| Ok(Uniforms::new()))
                .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let ModulateData { value, albedo, emission, out } = ModulateIo::read(ctx)?;
        let composed = (0..ctx.pixels())
            .map(|i| {
                let a = albedo.map_or([1.0; 3], |a| a[i]);
                let e = emission.map_or([0.0; 3], |e| e[i]);
                std::array::from_fn(|c| value[i][c] * a[c] + e[c])
            })
            .collect::<Vec<[f32; 3]>>();
        out.put(ctx, composed)
    }
}
