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
use crate::kernels::{all_positive_zero, count_non_finite, v3};
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

/// A pixel as the weights read it, prepared once per pass rather than per tap (each pixel is a
/// neighbour of up to 2R + 1 others in a separable pass, and would have its normal normalised and
/// its width divided as often): hit, lens-averaged position, unit normal (zero where none), and
/// `g² = (Ω/ℓ_p)²`. The same operations in the same order as per tap, so the same bits.
#[derive(Clone, Copy)]
pub struct Neighbour {
    hit: bool,
    position: Vec3,
    normal: Vec3,
    g2: f32,
}

/// Every pixel of the pass as a [`Neighbour`].
pub fn neighbours(position: &[[f32; 4]], normal: &[[f32; 4]], omega: &[f32], pixel_length: &[f32]) -> Vec<Neighbour> {
    (0..position.len())
        .map(|j| {
            let g = omega[j] / pixel_length[j];
            Neighbour {
                hit: is_hit(position[j]),
                position: v3(position[j]),
                normal: v3(normal[j]).normalize_or_zero(),
                g2: g * g,
            }
        })
        .collect()
}

/// Eq. 5.31 at pixel `(x, y)`, its neighbours prepared by [`neighbours`].
#[allow(clippy::too_many_arguments)]
pub fn irradiance_pixel(
    x: i32,
    y: i32,
    width: i32,
    height: i32,
    p: &IrradianceParams,
    value: &[[f32; 3]],
    (omega, pixel_length): (&[f32], &[f32]),
    prepared: &[Neighbour],
) -> [f32; 3] {
    let i = (y * width + x) as usize;
    let centre = value[i];
    let (om, ell, me) = (omega[i], pixel_length[i], prepared[i]);
    if !valid_width(om) || !valid_width(ell) || !me.hit || me.normal == Vec3::ZERO {
        return centre;
    }
    let extent = p.axis.extent(p.max_radius.window(om));
    gather(x, y, width, height, extent, value, |j, _| {
        let n = &prepared[j];
        if !n.hit || me.normal.dot(n.normal) < p.normal_cos {
            return None;
        }
        pair_weight((n.position - me.position).length_squared(), me.g2, n.g2)
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
        if all_positive_zero(value) {
            return io.out.put(ctx, value.to_vec());
        }
        let prepared = neighbours(position, normal, omega, pixel_length);
        let (w, h) = (ctx.width as i32, ctx.height as i32);
        let out = ctx.map_pixels(false, |x, y| {
            irradiance_pixel(x as i32, y as i32, w, h, &p, value, (omega, pixel_length), &prepared)
        });
        io.out.put(ctx, out)
    }
}
