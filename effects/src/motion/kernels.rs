//! The motion kernels: `motion.rates` (App. B widths and counts per pixel) and `motion.flags` (one
//! velocity or several), CPU here and WGSL in `shaders/motion_{rates,flags}.wgsl`, both on the
//! formulas of [`super::formulas`] (WGSL mirror `shaders/motion_formulas.wgsl`).
//!
//! Buffer conventions (per pixel):
//! - `velocity` (vec4): mean image-space velocity of the primary hits (pixels per half shutter) and its
//!   per-axis range over the pixel's paths (misses count as 0) — the path sampler's `velocity`.
//! - `shadow_velocity` (vec4, optional): the same for the shadows of the occluded shadow samples.
//! - `depth` (vec4): the sampler's `defocus` output; `z` the mean depth along the optical axis, `w > 0`
//!   where some primary ray hit.
//! - `occlusion`, `reflectors` (vec4, optional): as `defocus.rates` reads them.
//! - Filter inputs written for `filter.motion`: `texture_motion`, `shadow_motion` (vec4: the velocity
//!   to filter along, its μ-scaled width Ω — 0 where the pixel is not filtered — and σ in pixels).

pub mod filter;

use wedge_backends::{BackendError, Kernel, KernelCtx, KernelParams, PutWith, Uniforms, WgslSource};
use wedge_graph::BufferId;

use super::formulas::{self, MotionParams, MotionRates, MotionStats};
use crate::defocus::kernels::{
    component_uniform, rate_component, rate_params, sigma_px, RateComponent, RateOptions, RatesParams, Statistic,
};
use crate::shadows::slopes;

/// The filter's σ in pixels (`1/(√32 Ω)`, Ch. 5's Gaussian), 0 where it does not filter (Ω = 0).
pub fn sigma_or_zero(omega: f32) -> f32 {
    if omega > 0.0 {
        sigma_px(omega)
    } else {
        0.0
    }
}

wedge_backends::kernel_params! {
    /// What a `motion.rates` pass carries besides the Ch. 5 rate constants ([`RatesParams`]):
    /// `multi_paths` (a count ≥ 1) and `omega_t` (finite, > 0), checked by [`motion_params`].
    pub struct MotionRatesParams {
        multi_paths: u32,
        omega_t: f32,
    }
}

fn motion_params(ctx: &KernelCtx<'_>) -> Result<MotionParams, BackendError> {
    let k = rate_params(ctx)?;
    let MotionRatesParams { multi_paths, omega_t } = MotionRatesParams::read(ctx)?;
    if multi_paths < 1 {
        return Err(ctx.err(format!("`multi_paths` = {multi_paths}; it must be a count >= 1")));
    }
    if !(omega_t.is_finite() && omega_t > 0.0) {
        return Err(ctx.err(format!("`omega_t` = {omega_t}; it must be a finite number > 0")));
    }
    Ok(MotionParams {
        mu: k.mu,
        mode: k.mode,
        omega_pix: k.omega_pix,
        omega_t,
        pixel_scale: k.pixel_scale,
        light_half_width: k.light_half_width,
        omega_v: k.omega_v,
        max_primary: k.max_primary,
        max_per_primary: k.max_per_primary,
        max_shadow_per_primary: k.max_shadow_per_primary,
        multi_paths,
        environment_per_primary: k.environment_per_primary,
    })
}

/// One pixel's statistics from the input buffers (an unbound `shadow_velocity` means no shadow motion
/// statistics: the shadow is not tested for a second velocity).
pub fn motion_stats(
    velocity: [f32; 4],
    shadow_velocity: Option<[f32; 4]>,
    depth: [f32; 4],
    occlusion: Option<[f32; 4]>,
    reflectors: Option<[f32; 4]>,
    bandlimit: Option<f32>,
) -> MotionStats {
    let occluded_any = occlusion.is_some_and(|o| o[3] > 0.0);
    let (s_min, s_max) = match occlusion {
        Some(o) if occluded_any => slopes(o[0], o[1], o[2]),
        _ => (0.0, 0.0),
    };
    let (z_min, z_max) = match reflectors {
        Some(z) if z[2] > 0.0 => (z[0], z[1]),
        _ => (0.0, 0.0),
    };
    let sv = shadow_velocity.unwrap_or_default();
    MotionStats {
        v_p: [velocity[0], velocity[1]],
        v_p_spread: [velocity[2], velocity[3]],
        v_s: [sv[0], sv[1]],
        v_s_spread: [sv[2], sv[3]],
        occluded: occluded_any && shadow_velocity.is_some(),
        hit: depth[3] > 0.0,
        depth: depth[2],
        s_min,
        s_max,
        z_min,
        z_max,
        bandlimit: crate::defocus::formulas::bandlimit_of(bandlimit),
    }
}

wedge_backends::kernel_bindings! {
    /// What a `motion.rates` pass binds. The Motion node's own pass (and a Defocus component's
    /// filter widths along the velocities) reads the velocities and depth and writes the primary
    /// outputs; a lighting component's pass reads its [`Statistic`] too and writes its width and
    /// count as `omega`, `n`, `sigma` for the [`RateComponent`] its `component` parameter names
    /// (fixed names, as `defocus.rates`: [`crate::defocus::kernels::RatesIo`]).
    pub struct RatesIo / RatesData {
        read velocity: [f32; 4],
        read depth: [f32; 4],
        read_opt shadow_velocity: [f32; 4],
        read_opt occlusion: [f32; 4],
        read_opt reflectors: [f32; 4],
        read_opt bandlimit: f32,
        write_opt pixel_length: f32,
        write_opt omega: f32,
        write_opt n: u32,
        write_opt sigma: f32,
        write_opt texture_motion: [f32; 4],
        write_opt shadow_motion: [f32; 4],
        write_opt n_primary: u32,
        write_opt sigma_texture: f32,
    }
}

impl RatesIo {
    /// The velocities and depth, with the first-pass statistic `s`; no output bound (a pass names
    /// the outputs it wants with `..`).
    pub fn inputs(velocity: BufferId, depth: BufferId, shadow_velocity: Option<BufferId>, s: Statistic) -> RatesIo {
        let (occlusion, reflectors, bandlimit) = (s.occlusion, s.reflectors, s.bandlimit);
        RatesIo { shadow_velocity, occlusion, reflectors, bandlimit, ..RatesIo::new(velocity, depth) }
    }
}

/// A component's width and count among a pixel's motion rates, the component a constant where it is
/// inlined (so that the others' are not computed: `rate_rows`).
#[inline(always)]
fn pick(c: RateComponent, r: &MotionRates) -> (f32, u32) {
    match c {
        RateComponent::Direct => (r.omega_direct, r.n_direct),
        RateComponent::Indirect => (r.omega_indirect, r.n_indirect),
        RateComponent::Environment => (r.omega_environment, r.n_environment),
    }
}

/// `motion.rates`: per pixel the App. B widths and rounded counts ([`formulas::pixel_rates`]); every
/// output is optional ([`RatesIo`]: the Motion node binds the primary ones, each component its own).
pub struct Rates;

impl Kernel for Rates {
    wedge_backends::kernel_signature!(
        name: "motion.rates", class: Bandwidth, bindings: RatesIo, params: [RatesParams, RateOptions, MotionRatesParams]
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/motion_rates.wgsl"), |ctx| {
                let k = motion_params(ctx)?;
                use crate::defocus::formulas::strata_cap;
                Ok(RatesParams::read(ctx)?
                    .uniforms()
                    .f32("omega_t", k.omega_t)
                    .f32("pixel_scale", k.pixel_scale)
                    .f32("light_half_width", k.light_half_width)
                    .u32("max_p", strata_cap(k.max_primary))
                    .u32("max_s", strata_cap(k.max_per_primary))
                    .u32("max_s_shadow", strata_cap(k.max_shadow_per_primary))
                    .u32("multi_paths", k.multi_paths)
                    .f32("environment_per_primary", k.environment_per_primary)
                    .u32("component", component_uniform(ctx)?))
            })
            .with_include("shadows_formulas.wgsl", include_str!("../../../shaders/shadows_formulas.wgsl"))
            .with_include("defocus_formulas.wgsl", include_str!("../../../shaders/defocus_formulas.wgsl"))
            .with_include("velocity.wgsl", include_str!("../../../shaders/velocity.wgsl"))
            .with_include("motion_formulas.wgsl", include_str!("../../../shaders/motion_formulas.wgsl"))
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let k = motion_params(ctx)?;
        let io = RatesIo::read(ctx)?;
        let component = rate_component(ctx, io.omega.is_some() || io.n.is_some() || io.sigma.is_some())?;
        let shadow = io.shadow_velocity;
        // One loop per component, its choice a constant in each: the rates no output reads are never
        // computed.
        let rows = match component {
            None => rate_rows(ctx, &io, &k, |_| (0.0, 0)),
            // Literal components in the closures (a captured one is data, not a constant).
            Some(RateComponent::Direct) => rate_rows(ctx, &io, &k, |r| pick(RateComponent::Direct, r)),
            Some(RateComponent::Indirect) => rate_rows(ctx, &io, &k, |r| pick(RateComponent::Indirect, r)),
            Some(RateComponent::Environment) => rate_rows(ctx, &io, &k, |r| pick(RateComponent::Environment, r)),
        };
        let column = |f: &dyn Fn(&Row) -> f32| rows.iter().map(f).collect::<Vec<f32>>();
        io.texture_motion.put_with(ctx, || {
            rows.iter().map(|r| [r.v_p[0], r.v_p[1], r.omega_texture, sigma_or_zero(r.omega_texture)]).collect()
        })?;
        // The shadow's mean velocity as the sampler gave it (zero where unbound).
        io.shadow_motion.put_with(ctx, || {
            rows.iter()
                .enumerate()
                .map(|(i, r)| {
                    let v = shadow.map_or([0.0; 4], |s| s[i]);
                    [v[0], v[1], r.omega_shadow, sigma_or_zero(r.omega_shadow)]
                })
                .collect()
        })?;
        io.n_primary.put_with(ctx, || rows.iter().map(|r| r.n_primary).collect())?;
        io.pixel_length.put_with(ctx, || column(&|r| r.pixel_length))?;
        io.sigma_texture.put_with(ctx, || column(&|r| sigma_or_zero(r.omega_texture)))?;
        if component.is_none() {
            return Ok(());
        }
        io.omega.put_with(ctx, || column(&|r| r.omega))?;
        io.n.put_with(ctx, || rows.iter().map(|r| r.n).collect())?;
        io.sigma.put_with(ctx, || column(&|r| sigma_or_zero(r.omega)))
    }
}

/// Every pixel's [`Row`] of a `motion.rates` pass, `chosen` giving the component's width and count.
/// Per pixel only what the outputs need (a full stats-and-rates record is ~130 bytes, and writing
/// and re-reading it per column cost more than the formulas).
fn rate_rows(
    ctx: &KernelCtx<'_>,
    io: &RatesData<'_>,
    k: &MotionParams,
    chosen: impl Fn(&MotionRates) -> (f32, u32) + Sync,
) -> Vec<Row> {
    let at = |b: Option<&[[f32; 4]]>, i: usize| b.map(|b| b[i]);
    ctx.map_pixels(false, |x, y| {
        let i = (y * ctx.width + x) as usize;
        let s = motion_stats(
            io.velocity[i],
            at(io.shadow_velocity, i),
            io.depth[i],
            at(io.occlusion, i),
            at(io.reflectors, i),
            io.bandlimit.map(|b| b[i]),
        );
        Row::of(&s, &formulas::pixel_rates(&s, k), &chosen)
    })
}

/// One pixel of a `motion.rates` pass: the columns it may write, and no more.
struct Row {
    v_p: [f32; 2],
    omega_texture: f32,
    omega_shadow: f32,
    pixel_length: f32,
    n_primary: u32,
    /// The pass's component's width and count (0 where it sizes none).
    omega: f32,
    n: u32,
}

impl Row {
    fn of(s: &MotionStats, r: &MotionRates, chosen: impl Fn(&MotionRates) -> (f32, u32)) -> Row {
        let (omega, n) = chosen(r);
        Row {
            v_p: s.v_p,
            omega_texture: r.omega_texture,
            omega_shadow: r.omega_shadow,
            pixel_length: r.pixel_length,
            n_primary: r.n_primary,
            omega,
            n,
        }
    }
}

wedge_backends::kernel_bindings! {
    /// What a `motion.flags` pass binds: the final paths' velocities (the shadow's and the occlusion
    /// for direct light) and either flag (each optional: a pass computes only what is bound).
    pub struct FlagsIo / FlagsData {
        read velocity: [f32; 4], read_opt shadow_velocity: [f32; 4], read_opt occlusion: [f32; 4],
        write_opt flag: u32, write_opt multi: u32,
    }
}

/// `motion.flags`: `flag` 1 where the pixel's paths saw one velocity (App. B factors it), else 0;
/// `multi` the opposite (the pixels App. B filters over 3×3). Both optional.
pub struct Flags;

impl Kernel for Flags {
    wedge_backends::kernel_signature!(name: "motion.flags", class: Bandwidth, bindings: FlagsIo);
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/motion_flags.wgsl"), |_| Ok(Uniforms::new()))
                .with_include("defocus_formulas.wgsl", include_str!("../../../shaders/defocus_formulas.wgsl"))
                .with_include("velocity.wgsl", include_str!("../../../shaders/velocity.wgsl"))
                .with_include("motion_formulas.wgsl", include_str!("../../../shaders/motion_formulas.wgsl"))
                .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let FlagsData { velocity, shadow_velocity: shadow, occlusion, flag, multi } = FlagsIo::read(ctx)?;
        let single: Vec<bool> = ctx.map_pixels(false, |x, y| {
            let i = (y * ctx.width + x) as usize;
            motion_stats(velocity[i], shadow.map(|s| s[i]), [0.0; 4], occlusion.map(|o| o[i]), None, None).single()
        });
        flag.put_with(ctx, || single.iter().map(|&s| s as u32).collect())?;
        multi.put_with(ctx, || single.iter().map(|&s| !s as u32).collect())
    }
}
