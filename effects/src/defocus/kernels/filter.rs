//! `filter.defocus` (thesis eq. 5.33): Defocus's filter of the composed radiance with the
//! screen-space, pixel-distance Gaussian `w_i(j) = exp(−16 |i − j|² Ω_x^d(i)²)` (`|i − j|` the
//! Euclidean pixel distance; σ = 0.177/Ω px), in the window and with the rejection of
//! [`wedge_backends::kernels::filter_window`]. No geometry test: defocus blur crosses object
//! boundaries. Pass-through pixels: width not finite or ≤ 0. Non-finite values are counted and
//! never spread, as in `filter.irradiance`. WGSL mirror: `shaders/filter_defocus.wgsl`.

use wedge_backends::kernels::count_non_finite;
use wedge_backends::kernels::filter_window::{gather, pair_weight, valid_width, Axis, AxisWindowParams, ScreenRadius};
use wedge_backends::{BackendError, Kernel, KernelCtx, KernelParams, WgslSource};

wedge_backends::kernel_bindings! {
    /// What a `filter.defocus` pass binds: the composed radiance, its width `Ω_x^d` (pixel⁻¹) and
    /// the filtered radiance.
    pub struct DefocusIo / DefocusData {
        read value: [f32; 3], read omega: f32, write out: [f32; 3],
    }
}

/// Eq. 5.33 at pixel `(x, y)`.
#[allow(clippy::too_many_arguments)]
pub fn defocus_pixel(
    x: i32,
    y: i32,
    width: i32,
    height: i32,
    max_radius: ScreenRadius,
    axis: Axis,
    value: &[[f32; 3]],
    omega: &[f32],
) -> [f32; 3] {
    let i = (y * width + x) as usize;
    let centre = value[i];
    let om = omega[i];
    if !valid_width(om) {
        return centre;
    }
    let gi2 = om * om;
    gather(x, y, width, height, axis.extent(max_radius.window(om)), value, |j, (dx, dy)| {
        pair_weight((dx * dx + dy * dy) as f32, gi2, omega[j] * omega[j])
    })
}

/// `filter.defocus`: eq. 5.33 on composed radiance.
pub struct DefocusFilter;

impl Kernel for DefocusFilter {
    wedge_backends::kernel_signature!(
        name: "filter.defocus", class: Filter, bindings: DefocusIo, params: [AxisWindowParams]
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/filter_defocus.wgsl"), |ctx| {
                Ok(AxisWindowParams::read(ctx)?.uniforms())
            })
            .with_include("filter_window.wgsl", include_str!("../../../../shaders/filter_window.wgsl"))
            .with_reach(|ctx| {
                let p = AxisWindowParams::read(ctx)?;
                Ok(p.axis.reach(p.max_radius))
            }),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let DefocusData { value, omega, out } = DefocusIo::read(ctx)?;
        let AxisWindowParams { max_radius: r, axis: a } = AxisWindowParams::read(ctx)?;
        count_non_finite(ctx, value);
        let (w, h) = (ctx.width as i32, ctx.height as i32);
        let filtered = ctx.map_pixels(false, |x, y| defocus_pixel(x as i32, y as i32, w, h, r, a, value, omega));
        out.put(ctx, filtered)
    }
}
