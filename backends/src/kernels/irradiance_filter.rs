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
use crate::kernels::filter_window::{gather_taps, pair_weight, valid_width, Axis, ScreenRadius};
use crate::kernels::{all_positive_zero, count_non_finite, is_finite3, v3};
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

/// A pixel as its neighbours' weights read it, prepared once per pass rather than per tap (each
/// pixel is a neighbour of up to 2R + 1 others in a separable pass, and would have its normal
/// normalised, its width divided and its value tested as often): lens-averaged position, unit
/// normal (zero where none), its value, and `g² = (Ω/ℓ_p)²` — NaN where the pixel is nobody's
/// neighbour (no hit, or a non-finite value), which the rejection test refuses as it refuses any
/// NaN exponent. One test per tap instead of three, the same decisions and the same operations in
/// the same order as per tap: the same bits.
#[derive(Clone, Copy)]
pub struct Neighbour {
    position: Vec3,
    g2: f32,
    normal: Vec3,
    value: [f32; 3],
}

/// Every pixel of the pass as a [`Neighbour`].
pub fn neighbours(d: &IrradianceData<'_>) -> Vec<Neighbour> {
    (0..d.position.len())
        .map(|j| {
            let g = d.omega[j] / d.pixel_length[j];
            let usable = is_hit(d.position[j]) && is_finite3(d.value[j]);
            Neighbour {
                position: v3(d.position[j]),
                g2: if usable { g * g } else { f32::NAN },
                normal: v3(d.normal[j]).normalize_or_zero(),
                value: d.value[j],
            }
        })
        .collect()
}

/// Eq. 5.31 at pixel `(x, y)`, its neighbours prepared by [`neighbours`].
pub fn irradiance_pixel(
    (x, y): (i32, i32),
    (width, height): (i32, i32),
    p: &IrradianceParams,
    d: &IrradianceData<'_>,
    prepared: &[Neighbour],
) -> [f32; 3] {
    let i = (y * width + x) as usize;
    let centre = d.value[i];
    let (om, ell, me) = (d.omega[i], d.pixel_length[i], prepared[i]);
    if !valid_width(om) || !valid_width(ell) || !is_hit(d.position[i]) || me.normal == Vec3::ZERO {
        return centre;
    }
    // The pixel's own `g²` (its record's is NaN where its value is not finite: it still gathers).
    let g = om / ell;
    let gi2 = g * g;
    let extent = p.axis.extent(p.max_radius.window(om));
    let tap = |_, n: &Neighbour, _| {
        if me.normal.dot(n.normal) < p.normal_cos {
            return None;
        }
        pair_weight((n.position - me.position).length_squared(), gi2, n.g2).map(|w| (w, n.value))
    };
    gather_taps(x, y, width, height, extent, prepared, tap).unwrap_or(centre)
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
        let p = IrradianceParams::read(ctx)?;
        count_non_finite(ctx, io.value);
        if all_positive_zero(io.value) {
            return io.out.put(ctx, io.value.to_vec());
        }
        let prepared = neighbours(&io);
        let size = (ctx.width as i32, ctx.height as i32);
        let out = ctx.map_pixels(false, |x, y| irradiance_pixel((x as i32, y as i32), size, &p, &io, &prepared));
        io.out.put(ctx, out)
    }
}
