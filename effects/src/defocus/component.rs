//! One lighting component under a factoring Defocus node (thesis Sec. 5.5–5.8): the passes a
//! component node (SoftShadows: direct; Indirect: diffuse and glossy; Environment: the map's diffuse
//! and glossy direct light) gets when the pipeline's
//! factoring node ([`wedge_graph::factoring`]) is a Defocus node — [`super::Defocus`]'s
//! `NodeKind::expand_component` calls [`expand`] with the [`Component`] the node declared.
//!
//! Per component, on the shared sampler's records:
//! 1. `Stage::Bandwidth`: SepDir / SepInd on the first pass's `L, k, E` (eq. 5.30, `defocus.flags`),
//!    3×3 median (`neighbourhood.median3`), then `defocus.rates` for this component's width
//!    (5.18 / 5.22 / `formulas::omega_environment`) and count — `n^f` where the flag is set, else
//!    `n^c` (5.25–5.28, `formulas::environment_rate`) — submitted to the sampler as a total over
//!    the adaptive pass's `n_p` paths (`PerPrimary::Total`, 3×3 max; the factoring node asks for
//!    the paths).
//!    Without factoring (the ablation, `factor: false`) the flag is 0 everywhere: `n^c`.
//! 2. `Stage::Factor`: the flags again on the final `L, k, E`, median (a reference fills 0: it
//!    composes `L`).
//! 3. `Stage::Filter`: `filter.irradiance` (5.31) on each part's `E` with this component's width.
//! 4. `Stage::Compose`: `defocus.compose` (5.32) per part, summed — with the irradiance-weighted
//!    texture `L / Ē` (`defocus.weighted_texture`; the node's `texture`, default `weighted`), which
//!    `motion_filter` then filters along the velocity: the component's term, which the
//!    node outputs for the Defocus node to sum and blur (5.33) ([`crate::factored`], shared with
//!    the Motion node).

use wedge_graph::factoring::CameraSettings;
use wedge_graph::{
    BufferId, Component, CountRequest, ExpandCtx, Factoring, Format, GraphError, ParamValue, PerPrimary, Reference,
    SamplerPass, SamplerRequest, Stage,
};

use crate::factored::{compose_component, factor_flags, IrradianceFilter, PartTerms};

use super::formulas::OMEGA_PIX_MAX;
use super::kernels::{RateComponent, RatesIo, Statistic, WeightedTextureIo};
use crate::motion::kernels::RatesIo as MotionRatesIo;
use crate::motion::node::{motion_filter, motion_rate_settings};

/// The factoring node's rate settings forwarded into `defocus.rates`, with `Ω_pix^max` and the
/// diffuse receiver's `Ω_v^max` (a component may override it in its `rate_params`).
pub fn rate_settings(f: &Factoring) -> Vec<(&'static str, ParamValue)> {
    let omega_v = crate::indirect::formulas::transfer_bandlimit(crate::indirect::formulas::Receiver::Diffuse);
    ["mu", "mode", "max_primary", "max_primary_moving", "max_per_primary", "max_shadow_per_primary"]
        .into_iter()
        .filter_map(|n| f.setting(n).map(|v| (n, v.clone())))
        .chain([
            ("omega_pix", ParamValue::Float(f64::from(OMEGA_PIX_MAX))),
            ("omega_v", ParamValue::Float(f64::from(omega_v))),
        ])
        .collect()
}

/// App. B's filter widths along the velocities from the first pass (`motion.rates`, pass
/// `<component>_motion`): the texture's along the primary hit's velocity (B.1) and, for direct light,
/// the irradiance's along the shadow's (B.2); width 0 where a pixel sees several velocities.
fn velocity_widths(
    ctx: &mut ExpandCtx<'_>,
    f: &Factoring,
    c: &Component,
    velocity: BufferId,
    shadow_velocity: Option<BufferId>,
) -> Result<(BufferId, Option<BufferId>), GraphError> {
    let direct = c.name == "direct";
    let depth = ctx.sampler_output(SamplerPass::First, "defocus")?;
    let occlusion = if direct { Some(ctx.sampler_output(SamplerPass::First, "occlusion")?) } else { None };
    let texture_motion = ctx.buffer(&format!("{}_texture_motion", c.name), Format::Vec4);
    let shadow_motion = direct.then(|| ctx.buffer(&format!("{}_shadow_motion", c.name), Format::Vec4));
    let io = MotionRatesIo {
        shadow_velocity: shadow_velocity.filter(|_| direct),
        occlusion,
        texture_motion: Some(texture_motion),
        shadow_motion,
        ..MotionRatesIo::new(velocity, depth)
    };
    let mut b = io.bind(ctx.pass(&format!("{}_motion", c.name), "motion.rates", Stage::Bandwidth));
    for (n, v) in motion_rate_settings(f) {
        b = b.param(n, v);
    }
    b.finish();
    Ok((texture_motion, shadow_motion))
}

/// Add the component's passes (see the module doc) and bind the node's ports `radiance` (the
/// composed term), `unfiltered` (Σ L), `filter_width` (the irradiance filter's σ in pixels) and
/// `rays_per_pixel` (the component's secondary samples per pixel as the rates ask).
pub fn expand(ctx: &mut ExpandCtx<'_>, f: &Factoring, c: &Component) -> Result<(), GraphError> {
    let mut request = SamplerRequest::new().estimator(c.estimator);
    for (n, v) in &c.settings {
        request = request.setting(n, v.clone());
    }
    ctx.sampler(request)?;
    let factor = f.bool("factor").unwrap_or(true);
    let radius = f.setting("max_radius").cloned().unwrap_or(ParamValue::Int(16));
    let separable = f.bool("separable").unwrap_or(true);
    let weighted = f.setting("texture").and_then(ParamValue::as_str) == Some("weighted");
    let first = &c.parts[0];

    // 1. Counts from the first pass.
    let lens = ctx.sampler_output(SamplerPass::First, "defocus")?;
    let (statistic, component) = (Statistic::of(ctx, c)?, RateComponent::of(ctx, c)?);
    // Where the paths sample the shutter too, the speeds that add the counts' time factors.
    let (velocity, shadow_velocity) = if f.bool(CameraSettings::TIME) == Some(true) {
        (
            Some(ctx.sampler_output(SamplerPass::First, "velocity")?),
            Some(ctx.sampler_output(SamplerPass::First, "shadow_velocity")?),
        )
    } else {
        (None, None)
    };
    let flag_first = factor_flags(
        ctx,
        &format!("{}_flag_first", c.name),
        first,
        (SamplerPass::First, Stage::Bandwidth),
        factor,
        true,
        Reference::Keep,
    )?;
    // For the factoring node's screen filter (`screen_scale_factored`, node.rs `factored_pixels`).
    ctx.publish_factoring_flag(flag_first)?;
    let (omega, pixel_length) = (
        ctx.buffer(&format!("{}_omega", c.name), Format::F32),
        ctx.buffer(&format!("{}_pixel_length", c.name), Format::F32),
    );
    let (count, sigma) = (
        ctx.buffer(&format!("{}_rays_per_pixel", c.name), Format::U32),
        ctx.buffer(&format!("{}_sigma", c.name), Format::F32),
    );
    let io = RatesIo {
        occlusion: statistic.occlusion,
        reflectors: statistic.reflectors,
        bandlimit: statistic.bandlimit,
        velocity,
        shadow_velocity,
        flag: Some(flag_first),
        omega: Some(omega),
        n: Some(count),
        sigma: Some(sigma),
        ..RatesIo::new(lens, pixel_length)
    };
    let mut b =
        io.bind(ctx.pass(&format!("{}_rates", c.name), "defocus.rates", Stage::Bandwidth)).reference(Reference::Keep);
    for (n, v) in rate_settings(f).into_iter().chain(c.rate_params.iter().cloned()).chain([component.param()]) {
        b = b.param(n, v);
    }
    b.finish();
    // Secondary samples only: the factoring node asks for the n_p paths they are spread over.
    ctx.sampler_counts(CountRequest {
        paths: None,
        paths_unit: 1,
        per_primary: vec![(c.estimator.into(), PerPrimary::Total(count))],
        max3: true,
        beyond_first: true,
    })?;

    // 2–4. Per part: final flags, irradiance filter; composed and summed over parts.
    let position = ctx.sampler_output(SamplerPass::Final, "position")?;
    let normal = ctx.sampler_output(SamplerPass::Final, "normal")?;
    let along = match velocity {
        Some(v) if f.bool("motion_filter") == Some(true) => Some(velocity_widths(ctx, f, c, v, shadow_velocity)?),
        _ => None,
    };
    let mut terms = Vec::new();
    for part in &c.parts {
        let flag = factor_flags(
            ctx,
            &format!("{}_flag", part.name),
            part,
            (SamplerPass::Final, Stage::Factor),
            factor,
            true,
            Reference::Fill(0),
        )?;
        let e_raw = ctx.sampler_output(SamplerPass::Final, part.irradiance)?;
        let max_radius = c.irradiance_radius(&radius);
        let filter = IrradianceFilter { position, normal, omega, pixel_length, max_radius, separable };
        let mut e = filter.apply(ctx, &format!("{}_filter", part.name), e_raw);
        let l = ctx.sampler_output(SamplerPass::Final, part.radiance)?;
        let k = ctx.sampler_output(SamplerPass::Final, part.texture)?;
        let mut k = part_texture(ctx, &format!("{}_texture", part.name), weighted, l, k, e_raw);
        // With the shutter and `motion_filter`: App. B's filters along the velocity inside the lens
        // filter (docs/DEFOCUS-MOTION.md Sec. 3) — texture along the primary hit's (B.1), direct
        // irradiance along the shadow's (B.2); each skips pixels that see several velocities.
        if let Some((texture_motion, shadow_motion)) = along {
            if let Some(s) = shadow_motion {
                e = motion_filter(ctx, &format!("{}_filter_shadow", part.name), e, s, &radius);
            }
            k = motion_filter(ctx, &format!("{}_filter_texture", part.name), k, texture_motion, &radius);
        }
        terms.push((part, PartTerms { l, k, e, flag }));
    }
    compose_component(ctx, &terms, None, sigma, count);
    Ok(())
}

/// A part's texture for the compose: the paths' mean `k`, or (`weighted`) the texture weighted by
/// the irradiance each path brought, `L / Ē` with `Ē` the unfiltered `e_raw`
/// (`defocus.weighted_texture`, pass `<name>`; docs/DESIGN-NOTES.md "The irradiance-weighted
/// texture").
fn part_texture(
    ctx: &mut ExpandCtx<'_>,
    name: &str,
    weighted: bool,
    l: BufferId,
    k: BufferId,
    e_raw: BufferId,
) -> BufferId {
    if !weighted {
        return k;
    }
    let out = ctx.buffer(name, Format::Vec3);
    WeightedTextureIo { radiance: l, texture: k, irradiance: e_raw, out }
        // Before the filters: `motion_filter` filters it along the velocity.
        .bind(ctx.pass(name, "defocus.weighted_texture", Stage::Factor))
        .finish();
    out
}
