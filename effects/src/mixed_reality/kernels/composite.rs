//! `mr.composite`: differential compositing (eq. 6.2, [`crate::mixed_reality::formulas::composite`])
//! per pixel; WGSL `shaders/mr_composite.wgsl`.

use glam::Vec3;
use wedge_backends::{BackendError, Kernel, KernelCtx, PutWith, Uniforms, WgslSource};

use super::CompositeIo;
use crate::mixed_reality::formulas::composite;

/// `mr.composite`: eq. 6.2 per pixel from the six (filtered) irradiances, `texture` and the real
/// layer's `L_cam`; optionally `reconstruction` = `k_R E_R` (the real albedo times the real
/// irradiance), which should reproduce `L_cam` on real surfaces when the inputs agree with each other
/// (map scale, registration): a check of the capture, not part of eq. 6.2.
pub struct MrComposite;

impl Kernel for MrComposite {
    wedge_backends::kernel_signature!(name: "mr.composite", class: Compose, bindings: CompositeIo);
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/mr_composite.wgsl"), |_| Ok(Uniforms::new()))
                .with_scene()
                .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let layer = ctx.scene.real.as_ref().ok_or_else(|| BackendError::Kernel {
            pass: ctx.pass.into(),
            message: "the scene has no real layer".into(),
        })?;
        let (width, window) = (ctx.width, ctx.window);
        let io = CompositeIo::read(ctx)?;
        let (texture, e) = (io.texture, [io.e_r_dir, io.e_r_ind, io.e_rv_dir, io.e_rv_ind, io.e_v_dir, io.e_v_ind]);
        let out = ctx.map_pixels(false, |x, y| {
            let i = (y * width + x) as usize;
            let (gx, gy) = window.global_xy(x, y);
            composite([e[0][i], e[1][i], e[2][i], e[3][i], e[4][i], e[5][i]], texture[i], layer.camera(gx, gy))
        });
        io.reconstruction.put_with(ctx, || {
            (0..out.len())
                .map(|i| {
                    let (x, y) = window.global_xy(i as u32 % width, i as u32 / width);
                    let e_r = Vec3::from(e[0][i]) + Vec3::from(e[1][i]);
                    (layer.albedo(x, y) * e_r).to_array()
                })
                .collect::<Vec<_>>()
        })?;
        io.mask.put_with(ctx, || texture.iter().map(|t| t[3]).collect())?;
        io.out.put(ctx, out)
    }
}
