//! The per-pixel passes around the filter: `pixel_filter.width` (the adaptive spatial width,
//! eqs. 3.15–3.17) and `pixel_filter.blend` (eqs. 3.1, 3.10–3.13, the spike clamp of eq. 3.18).

use glam::Vec3;
use wedge_backends::{BackendError, Kernel, KernelCtx, KernelParams, Uniforms, WgslSource};

use super::ThresholdParams;

use crate::pixel_filter::formulas::{adaptive_sigma, blend_factor, luminance, spike_clamp, FILTERED};

// ---------------------------------------------------------------------------------------------
// pixel_filter.width
// ---------------------------------------------------------------------------------------------

/// `pixel_filter.width`: the per-pixel spatial σ of the adaptive filter (eqs. 3.15–3.17) from the
/// last filter pass's filtered variance and background; before any filter pass, the guide σ̄(n).
pub struct AdaptiveWidth;

wedge_backends::kernel_params! {
    /// The adaptive width's parameters (with [`ThresholdParams`]): the user's widest σ (declared
    /// with the filter's, `FilterParams`) and the bound `c` of eq. 3.16.
    pub struct WidthParams {
        sigma_s: f32,
        adaptive_c: f32 = float(4.0, 1.0, 1e3, "the adaptive width stays within [guide/c, c guide] (eq. 3.16)"),
    }
}

fn width_params(ctx: &KernelCtx<'_>) -> Result<(f32, f32, f32), BackendError> {
    let (w, t) = (WidthParams::read(ctx)?, ThresholdParams::read(ctx)?);
    Ok((w.sigma_s, w.adaptive_c, t.t))
}

/// One pixel of [`AdaptiveWidth`].
pub fn width_pixel(lv: [f32; 4], filtered: [f32; 4], variance: [f32; 4], sigma_s: f32, c: f32, t: f32) -> f32 {
    let n = lv[3];
    if variance[3] != FILTERED {
        return (sigma_s / n.max(1.0).sqrt()).min(sigma_s);
    }
    let lb = luminance(Vec3::new(filtered[0] + lv[0], filtered[1] + lv[1], filtered[2] + lv[2]));
    adaptive_sigma(variance[0], n, lb, t, sigma_s, c)
}

wedge_backends::kernel_bindings! {
    /// What a `pixel_filter.width` pass binds.
    pub struct WidthIo / WidthData {
        read lv: [f32; 4],
        read_opt previous_filtered: [f32; 4],
        read_opt previous_variance: [f32; 4],
        write sigma: f32,
    }
}

impl Kernel for AdaptiveWidth {
    wedge_backends::kernel_signature!(
        name: "pixel_filter.width", class: Bandwidth, bindings: WidthIo, params: [ThresholdParams, WidthParams]
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/pixel_filter_width.wgsl"), |ctx| {
                let (sigma_s, c, t) = width_params(ctx)?;
                Ok(Uniforms::new().f32("sigma_s", sigma_s).f32("adaptive_c", c).f32("t", t))
            })
            .with_include("pixel_filter_formulas.wgsl", include_str!("../../../../shaders/pixel_filter_formulas.wgsl"))
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let (sigma_s, c, t) = width_params(ctx)?;
        let WidthData { lv, previous_filtered: pf, previous_variance: pv, sigma } = WidthIo::read(ctx)?;
        let at = |b: Option<&[[f32; 4]]>, i: usize| b.map_or([0.0; 4], |b| b[i]);
        let out: Vec<f32> =
            (0..ctx.pixels()).map(|i| width_pixel(lv[i], at(pf, i), at(pv, i), sigma_s, c, t)).collect();
        sigma.put(ctx, out)
    }
}

// ---------------------------------------------------------------------------------------------
// pixel_filter.blend
// ---------------------------------------------------------------------------------------------

/// `pixel_filter.blend`: `L = L_lv + s·L_u + (1 − s)·L_f` (eq. 3.1) with `s` from
/// [`blend_factor`]; `unfiltered` = `L_lv + L_u`, the plain progressive accumulation; `blend` = s.
pub struct Blend;

/// Settings of the blend: threshold `t`, and the spike clamp's `c` (eq. 3.18; 0 = off).
#[derive(Clone, Copy, Debug)]
pub struct BlendParams {
    pub t: f32,
    pub spike_c: f32,
}

wedge_backends::kernel_params! {
    /// The spike clamp of eq. 3.18 (with [`ThresholdParams`], the blend's parameters).
    pub struct SpikeParams {
        spike_clamp: bool = boolean(false, "clamp L_u to [L_f/c, c L_f] while blending (eq. 3.18)"),
        spike_c: f32 = float(2.0, 1.0, 1e6, "the spike clamp's factor c"),
    }
}

fn blend_params(ctx: &KernelCtx<'_>) -> Result<BlendParams, BackendError> {
    let (t, spike) = (ThresholdParams::read(ctx)?, SpikeParams::read(ctx)?);
    Ok(BlendParams { t: t.t, spike_c: if spike.spike_clamp { spike.spike_c } else { 0.0 } })
}

/// One pixel of [`Blend`]: (radiance, unfiltered, s).
pub fn blend_pixel(
    lv: [f32; 4],
    hv: [f32; 4],
    filtered: [f32; 4],
    variance: [f32; 4],
    b: BlendParams,
) -> (Vec3, Vec3, f32) {
    let v3 = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]);
    let (llv, lu, lf) = (v3(lv), v3(hv), v3(filtered));
    let n = lv[3];
    let unfiltered = llv + lu;
    if !(n > 0.0) || variance[3] != FILTERED {
        return (unfiltered, unfiltered, 1.0);
    }
    // Eq. 3.10: the background radiance; eq. 3.4: perceived variances. The unfiltered buffer's
    // variance is the filtered per-path variance over the current n (Sec. 3.3.2); the filtered
    // buffer's was fixed at its filter pass.
    let lb = luminance(lf + llv);
    let (u_abs, f_abs) = (variance[0] / n, filtered[3]);
    let perceived = |v: f32| {
        if !(v > 0.0) {
            0.0
        } else if lb > 0.0 {
            v / (lb * lb)
        } else {
            f32::INFINITY
        }
    };
    let s = blend_factor(perceived(u_abs), perceived(f_abs), b.t);
    if s >= 1.0 {
        // Converged: the plain accumulation, bit for bit (no clamp: consistency, see DESIGN-NOTES).
        return (unfiltered, unfiltered, 1.0);
    }
    let lu = if b.spike_c > 0.0 { spike_clamp(lu, lf, b.spike_c) } else { lu };
    (llv + (lu * s + lf * (1.0 - s)), unfiltered, s)
}

wedge_backends::kernel_bindings! {
    /// What a `pixel_filter.blend` pass binds.
    pub struct BlendIo / BlendData {
        read lv: [f32; 4],
        read hv: [f32; 4],
        read filtered: [f32; 4],
        read variance: [f32; 4],
        write radiance: [f32; 3],
        write unfiltered: [f32; 3],
        write blend: f32,
    }
}

impl Kernel for Blend {
    wedge_backends::kernel_signature!(
        name: "pixel_filter.blend", class: Compose, bindings: BlendIo, params: [ThresholdParams, SpikeParams]
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/pixel_filter_blend.wgsl"), |ctx| {
                let b = blend_params(ctx)?;
                Ok(Uniforms::new().f32("t", b.t).f32("spike_c", b.spike_c))
            })
            .with_include("pixel_filter_formulas.wgsl", include_str!("../../../../shaders/pixel_filter_formulas.wgsl"))
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let b = blend_params(ctx)?;
        let BlendData { lv, hv, filtered, variance, radiance, unfiltered, blend } = BlendIo::read(ctx)?;
        let out: Vec<(Vec3, Vec3, f32)> =
            (0..ctx.pixels()).map(|i| blend_pixel(lv[i], hv[i], filtered[i], variance[i], b)).collect();
        radiance.put(ctx, out.iter().map(|o| o.0.to_array()).collect())?;
        unfiltered.put(ctx, out.iter().map(|o| o.1.to_array()).collect())?;
        blend.put(ctx, out.iter().map(|o| o.2).collect())
    }
}
