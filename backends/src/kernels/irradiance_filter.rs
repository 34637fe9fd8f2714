//! `filter.irradiance` (thesis eq. 5.31): the factoring nodes' filter of factored irradiance `E`
//! with `w_i(j) = exp(−16 ‖λ(i) − λ(j)‖² (Ω(i)/ℓ_p(i))²)` on lens-averaged world positions `λ`, with
//! `Ω = Ω_x^s` (direct) or `Ω_x^i` (indirect) and `ℓ_p` converting it to metres, in the window and
//! with the rejection of [`super::filter_window`]. Neighbours whose (lens-averaged, normalised)
//! normals differ by more than the normal test allows (thesis: 10°) are not used. The pixel bound of
//! the window assumes `‖λ(i) − λ(j)‖ ≥ ℓ_p(i) |i − j|` (true on a surface facing the camera; slanted
//! surfaces are farther apart).
//!
//! Pass-through pixels (output = input): width not finite or ≤ 0, `ℓ_p` not finite or ≤ 0, no hit
//! (`position.w ≤ 0`) or a zero normal. Non-finite values are never used as neighbours; each pixel
//! whose own value is non-finite is counted once in `non_finite_samples`, and gets its neighbours'
//! average if it has any (else it keeps its value: it is never spread). Values are rgb (`vec3`), as
//! `paths.resolve` writes `E`. WGSL mirror: `shaders/filter_irradiance.wgsl`.

use glam::Vec3;

use crate::kernel::{Kernel, KernelCtx, WgslSource};
use crate::kernels::filter_window::{gather, pair_weight, valid_width, Axis, ScreenRadius};
use crate::kernels::{count_non_finite, v3};
use crate::params::KernelParams;
use crate::BackendError;

crate::kernel_params! {
    /// What a `filter.irradiance` pass carries: the window's cap (clamped as read), the cosine of
    /// the normal test and the optional [`Axis`] (absent = 2-D).
    pub struct IrradianceParams {
        max_radius: ScreenRadius,
        normal_cos: f32,
        axis: Axis,
    }
}

crate::kernel_bindings! {
    /// What a `filter.irradiance` pass binds: `E` (rgb), the lens-averaged G-buffer, the width
    /// `Ω` (pixel⁻¹) and `ℓ_p` converting it to metres.
    pub struct IrradianceIo / IrradianceData {
        read value: [f32; 3], read position: [f32; 4], read normal: [f32; 4], read omega: f32, read pixel_length: f32,
        write out: [f32; 3],
    }
}

/// Eq. 5.31 at pixel `(x, y)`.
#[allow(clippy::too_many_arguments)]
pub fn irradiance_pixel(
    x: i32,
    y: i32,
    width: i32,
    height: i32,
    p: &IrradianceParams,
    value: &[[f32; 3]],
    position: &[[f32; 4]],
    normal: &[[f32; 4]],
    omega: &[f32],
    pixel_length: &[f32],
) -> [f32; 3] {
    let i = (y * width + x) as usize;
    let centre = value[i];
    let (om, ell) = (omega[i], pixel_length[i]);
    if !valid_width(om) || !valid_width(ell) || !is_hit(position[i]) {
        return centre;
    }
    let ni = v3(normal[i]).normalize_or_zero();
    if ni == Vec3::ZERO {
        return centre;
    }
    let gi = om / ell;
    let gi2 = gi * gi;
    let xi = v3(position[i]);
    let extent = p.axis.extent(p.max_radius.window(om));
    gather(x, y, width, height, extent, value, |j, _| {
        if !is_hit(position[j]) || ni.dot(v3(normal[j]).normalize_or_zero()) < p.normal_cos {
            return None;
        }
        let gj = omega[j] / pixel_length[j];
        pair_weight((v3(position[j]) - xi).length_squared(), gi2, gj * gj)
    })
}

/// Whether a pixel's primary rays hit geometry (`position.w > 0`; false for NaN).
fn is_hit(position: [f32; 4]) -> bool {
    position[3] > 0.0
}

/// `filter.irradiance`: eq. 5.31 on factored irradiance.
pub struct IrradianceFilter;

impl Kernel for IrradianceFilter {
    crate::kernel_signature!(
        name: "filter.irradiance", class: Filter, bindings: IrradianceIo, params: [IrradianceParams]
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/filter_irradiance.wgsl"), |ctx| {
                Ok(IrradianceParams::read(ctx)?.uniforms())
            })
            .with_include("filter_window.wgsl", include_str!("../../../shaders/filter_window.wgsl"))
            .with_reach(|ctx| {
                let p = IrradianceParams::read(ctx)?;
                Ok(p.axis.reach(p.max_radius))
            }),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let io = IrradianceIo::read(ctx)?;
        let IrradianceData { value, position, normal, omega, pixel_length, .. } = io;
        let p = IrradianceParams::read(ctx)?;
        count_non_finite(ctx, value);
        let (w, h) = (ctx.width as i32, ctx.height as i32);
        let out = ctx.map_pixels(false, |x, y| {
            irradiance_pixel(x as i32, y as i32, w, h, &p, value, position, normal, omega, pixel_length)
        });
        io.out.put(ctx, out)
    }
}
