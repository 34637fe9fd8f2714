//! `Motion`: motion blur with factored axis-aligned filtering and two-level sampling (thesis App. B,
//! `seeds/000_956e982470d7e5bf.txt` Appendix B; `docs/EQUATIONS.md` "Motion").
//!
//! The pipeline's factoring node ([`wedge_graph::factoring`]) when the scene moves over the shutter
//! (a static scene, or a zero-length shutter: the node does not factor, the component nodes render
//! as without it — Ch. 3/4 — and it only sums its inputs, so the image is the same as without it).
//! Factoring, it
//! 1. asks the shared sampler for shutter times (estimator `time`) and App. B's first pass:
//!    `initial_paths` paths through the pixel centre (the thesis: 9; default 4, measured), each at its
//!    own time with one shadow ray and one indirect sample, the centre-of-light form factor (so
//!    `k·E = L` where the scene factors);
//! 2. from the first pass's velocities (`velocity`, `shadow_velocity`) computes the texture width
//!    `Ω_{x,p}^m` (B.1) and `n_p` (B.3; `multi_paths` where the pixel sees two or more velocities —
//!    the thesis: 64, default 16, measured) with `motion.rates`, and submits `n_p` paths for the
//!    second pass (3×3 max, `p²` rounding);
//! 3. sums its `direct`, `indirect` and `environment` inputs (each a component's factored term) and
//!    the emission of the primary hits (the map where camera rays miss), and filters the sum at the pixels whose final paths saw two or more
//!    velocities (`motion.flags`, `filter.radiance3`) where `multi_filter` asks: `none` (the default)
//!    keeps the `multi_paths` estimate — measured better on every scene of the motion suite, and
//!    consistent (a fixed filter does not narrow as μ grows; DESIGN-NOTES "The filters against their
//!    own rays"); `velocity` averages such a pixel with its two neighbours along its velocity that see
//!    several velocities too; `tent` is the thesis's 3×3 filter, which mixes across the sharp edges of
//!    blurred silhouettes (measured: DESIGN-NOTES "Motion").
//!
//! **Components** ([`Motion::expand_component`]): each lighting component node (SoftShadows, Indirect,
//! Environment) renders for it: `motion.rates` gives its irradiance width (direct: eq. 5.18 without the
//! lens term, and B.2 along the shadow's velocity; indirect: eq. 5.22 without the lens term;
//! environment: Ch. 6's bandwidth as 5.18's light term) and its count (5.25 with the shadow's
//! velocity; 5.26 without the time factor; the environment's 5.24 factors × look-ups per primary ray); per part the irradiance `E` is filtered
//! (`filter.irradiance`, then for direct light `filter.motion` along `v_s`), the texture `k` is filtered
//! along `v_p` (`filter.motion`, B.1: App. B filters texture and irradiance independently, "since a
//! moving surface may receive shadows that are not motion-blurred"), and the term is `k̃ Ẽ` where the
//! pixel has one velocity, else the path-averaged `L`.
//!
//! **Time** is a sample dimension of the shared sampler: `t ∈ [−1, 1]` over the shutter, stratified
//! (progressive Owen-scrambled Sobol', paired with the light and hemisphere samples by their own
//! scrambles). The scene's motion (per object, rigid) comes from the scene (glTF animations, a RON scene
//! file's `motion`, the built-in `motion` scene) or the pipeline's `motion` block; the shutter from the
//! camera.
//!
//! Settings for the components (the factoring contract): `mu`, `mode` (`consistent`, the default:
//! converges to Monte Carlo as μ → ∞; or `literal`, eq. 5.29 as printed, whose error rises above
//! μ = 1: DESIGN-NOTES "μ above 1: the clamp of eq. 5.29"), `max_primary`, `max_per_primary`,
//! `max_radius`, `multi_paths`, and the camera setting `time = true` (its paths sample the shutter:
//! a node tracing its own camera rays, LightField, samples it too).

use std::collections::BTreeMap;

use wedge_backends::kernels::constant::FillVec4Io;
use wedge_graph::factoring::{CameraSettings, FactoringInputs, Refusal, Settings};
use wedge_graph::{
    BufferId, Component, CountRequest, ExpandCtx, Factoring, Format, GraphError, NodeKind, ParamDecl, ParamValue,
    PerPrimary, PortDecl, Reference, SamplerPass, SamplerRequest, Stage,
};

use super::formulas::{MULTI_VELOCITY_PATHS, OMEGA_T_MAX};
use super::kernels::filter::{MotionFilterIo, Radiance3Io};
use super::kernels::{FlagsIo, RatesIo};
use crate::defocus::component::rate_settings;
use crate::defocus::kernels::{RateComponent, Statistic};
use crate::factored::{compose_component, sum, IrradianceFilter, PartTerms};

pub struct Motion;

/// The settings `motion.rates` takes from the factoring node.
pub(crate) fn motion_rate_settings(f: &Factoring) -> Vec<(&'static str, ParamValue)> {
    let mut s = rate_settings(f);
    s.push(("multi_paths", f.setting("multi_paths").cloned().unwrap_or(ParamValue::Int(MULTI_VELOCITY_PATHS))));
    s.push(("omega_t", f.setting("omega_t").cloned().unwrap_or(ParamValue::Float(f64::from(OMEGA_T_MAX)))));
    s
}

/// `filter.motion` on `value` along `motion` (a `motion.rates` velocity/width buffer), named `name`;
/// a reference bypasses it.
pub(crate) fn motion_filter(
    ctx: &mut ExpandCtx<'_>,
    name: &str,
    value: BufferId,
    motion: BufferId,
    radius: &ParamValue,
) -> BufferId {
    let out = ctx.buffer(name, Format::Vec3);
    MotionFilterIo { value, motion, out }
        .bind(ctx.pass(name, "filter.motion", Stage::Filter))
        .param("max_radius", radius.clone())
        .reference(Reference::Bypass { input: "value" })
        .finish();
    out
}

impl NodeKind for Motion {
    fn kind(&self) -> &'static str {
        "Motion"
    }
    fn doc(&self) -> &'static str {
        "Motion blur with factored texture/irradiance filters along the velocity and two-level sampling (Mehta thesis App. B)"
    }
    fn bench_suite(&self) -> Option<&'static str> {
        Some("motion")
    }
    fn inputs(&self) -> Vec<PortDecl> {
        crate::light_terms::component_inputs()
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![
            PortDecl::new("radiance", Format::Vec3, "Σ components + emission, 3×3-filtered where a pixel sees two or more velocities"),
            PortDecl::new("unfiltered", Format::Vec3, "the same sum before the 3×3 filter (components filtered)"),
            PortDecl::new("filter_width", Format::F32, "texture filter std-dev in pixels along the velocity, 1/(√32 Ω_{x,p}^m) (0 = not filtered)"),
            PortDecl::new("rays_per_pixel", Format::U32, "primary rays per pixel asked for the second pass, n_p (eq. B.3; 64 at multi-velocity pixels)"),
            PortDecl::new("velocity", Format::Vec4, "image-space velocity of the primary hits (px per half shutter), its texture width Ω and σ"),
            PortDecl::new("shadow_velocity", Format::Vec4, "image-space velocity of the shadows (px per half shutter), the width Ω of the filter along it (eq. B.2) and σ"),
        ]
    }
    /// Its components, and (where it factors) what its camera rays see directly, added once here.
    fn terms(&self, port: &str, q: &wedge_graph::TermQuery<'_>) -> Option<wedge_graph::Terms> {
        matches!(port, "radiance" | "unfiltered").then(|| crate::light_terms::factoring_sum(q))
    }
    fn params(&self) -> Vec<ParamDecl> {
        vec![
            crate::params::mu(1.0, "μ: scales every App. B bandwidth (eq. 5.29); larger = narrower filters, more rays"),
            ParamDecl::positive("omega_t", OMEGA_T_MAX as f64, 1e6, "Ω_t^max, the shutter's bandlimit over t ∈ [−1, 1] (eqs. B.1–B.3; 1 = docs/EQUATIONS.md's reading)"),
            crate::params::mode(),
            crate::params::form_factor("light_centre", "light-centre form factor f_c in L, k and E (k·E = L where the scene factors), or the per-sample geometry term"),
            ParamDecl::int("initial_paths", 4, 1, 4096, "first-pass paths per pixel, one time, shadow and indirect sample each (thesis App. B: 9; 4 measured better, DESIGN-NOTES \"Motion\")"),
            crate::params::max_primary(),
            ParamDecl::int("max_per_primary", 1, 1, 4096, "cap on hemisphere and environment samples per primary ray (rounded down to a square; scaled by max(μ, 1)² in consistent mode): 1 since issue 35's motion suite (4 = 2×2 strata, the earlier default), see docs/DESIGN-NOTES.md \"Shadow rays per primary under Motion\""),
            ParamDecl::int("max_shadow_per_primary", 4, 1, 4096, "cap on shadow rays per primary ray, as max_per_primary: 4 (2×2 strata), the light's variance in penumbrae is what they reduce"),
            ParamDecl::int("multi_paths", MULTI_VELOCITY_PATHS, 1, 4096, "primary rays at pixels that see two or more velocities (thesis: 64; 16 measured better, DESIGN-NOTES \"Motion\")"),
            ParamDecl::int("max_radius", 32, 1, 64, "largest filter half-width in pixels (filter.motion, filter.irradiance)"),
            ParamDecl::choice(
                "multi_filter",
                "none",
                &["none", "velocity", "tent"],
                "radiance filter at multi-velocity pixels: none (the default since the motion suite: a fixed filter does not shrink as μ grows, and it raised the error on every unseen scene), 1-2-1 along the velocity over such pixels, or the thesis's 3×3 tent",
            ),
        ]
    }
    fn factoring(
        &self,
        params: &BTreeMap<String, ParamValue>,
        inputs: &FactoringInputs<'_>,
    ) -> Result<Option<Settings>, Refusal> {
        if inputs.scene.is_some_and(|s| !s.motion) {
            return Ok(None);
        }
        let mut s: Settings = [
            "mu",
            "mode",
            "omega_t",
            "max_primary",
            "max_per_primary",
            "max_shadow_per_primary",
            "max_radius",
            "multi_paths",
            "initial_paths",
            "form_factor",
        ]
        .into_iter()
        .filter_map(|n| params.get(n).map(|v| (n.to_string(), v.clone())))
        .collect();
        // The camera setting of a factoring node whose paths sample the shutter.
        s.insert(CameraSettings::TIME.into(), ParamValue::Bool(true));
        Ok(Some(s))
    }
    fn expand_component(&self, ctx: &mut ExpandCtx<'_>, f: &Factoring, c: &Component) -> Result<(), GraphError> {
        expand_component(ctx, f, c)
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        let components = crate::factored::components(ctx)?;
        let Some(f) = ctx.factoring().filter(|f| f.node == ctx.node()) else {
            // A static scene: the components rendered as without a Motion node; only their sum
            // here, and no velocity.
            crate::factored::pass_through(ctx, &components);
            let still = ctx.buffer("velocity", Format::Vec4);
            FillVec4Io { out: still }
                .bind(ctx.pass("velocity", "fill.constant_vec4", Stage::Compose))
                .float("value", 0.0)
                .finish();
            ctx.output("velocity", still);
            ctx.output("shadow_velocity", still);
            return Ok(());
        };

        // 1. Shutter times and App. B's first pass.
        ctx.sampler(
            SamplerRequest::new()
                .estimator("time")
                .setting("paths", ctx.param("initial_paths").clone())
                .setting("shadow_per_primary", ParamValue::Int(1))
                .setting("indirect_per_primary", ParamValue::Int(1))
                .setting("jitter", ParamValue::Bool(false))
                .setting("sampling", ParamValue::Str("stratified".into()))
                .setting("form_factor", ctx.param("form_factor").clone()),
        )?;

        // 2. Ω_{x,p}^m and n_p (eqs. B.1, B.3); the shadows' filter (B.2) for the heatmap.
        let velocity = ctx.sampler_output(SamplerPass::First, "velocity")?;
        let depth = ctx.sampler_output(SamplerPass::First, "defocus")?;
        let shadow_velocity = ctx.sampler_output(SamplerPass::First, "shadow_velocity")?;
        let occlusion = ctx.sampler_output(SamplerPass::First, "occlusion")?;
        let (texture_motion, shadow_motion, n_primary, sigma) = (
            ctx.buffer("velocity", Format::Vec4),
            ctx.buffer("shadow_velocity", Format::Vec4),
            ctx.buffer("rays_per_pixel", Format::U32),
            ctx.buffer("filter_width", Format::F32),
        );
        let io = RatesIo {
            shadow_velocity: Some(shadow_velocity),
            occlusion: Some(occlusion),
            texture_motion: Some(texture_motion),
            shadow_motion: Some(shadow_motion),
            n_primary: Some(n_primary),
            sigma_texture: Some(sigma),
            ..RatesIo::new(velocity, depth)
        };
        let mut b = io.bind(ctx.pass("rates", "motion.rates", Stage::Bandwidth));
        for (n, v) in motion_rate_settings(f) {
            b = b.param(n, v);
        }
        b.finish();
        ctx.sampler_counts(CountRequest {
            paths: Some(n_primary),
            paths_unit: 1,
            per_primary: vec![],
            max3: true,
            beyond_first: true,
        })?;

        // 3. Σ components + emission, then the 3×3 filter at multi-velocity pixels (App. B).
        let emission = crate::factored::seen_directly(ctx, SamplerPass::Final)?;
        let composed = sum(ctx, "compose", &components, emission);
        let final_velocity = ctx.sampler_output(SamplerPass::Final, "velocity")?;
        let multi = ctx.buffer("multi", Format::U32);
        let io = FlagsIo {
            velocity: final_velocity,
            shadow_velocity: None,
            occlusion: None,
            flag: None,
            multi: Some(multi),
        };
        io.bind(ctx.pass("multi", "motion.flags", Stage::Factor)).reference(Reference::Fill(0)).finish();
        let radiance = match ctx.param("multi_filter").clone() {
            ParamValue::Str(f) if f == "none" => composed,
            f => {
                let along = (f == ParamValue::Str("velocity".into())).then_some(final_velocity);
                let out = ctx.buffer("radiance", Format::Vec3);
                Radiance3Io { value: composed, mask: multi, velocity: along, out }
                    .bind(ctx.pass("filter", "filter.radiance3", Stage::ImageFilter))
                    .reference(Reference::Bypass { input: "value" })
                    .finish();
                out
            }
        };
        ctx.output("radiance", radiance);
        ctx.output("unfiltered", composed);
        ctx.output("filter_width", sigma);
        ctx.output("rays_per_pixel", n_primary);
        ctx.output("velocity", texture_motion);
        ctx.output("shadow_velocity", shadow_motion);
        Ok(())
    }
}

/// The passes of one lighting component under a factoring Motion node (see the module doc).
fn expand_component(ctx: &mut ExpandCtx<'_>, f: &Factoring, c: &Component) -> Result<(), GraphError> {
    let mut request = SamplerRequest::new().estimator(c.estimator);
    for (n, v) in &c.settings {
        request = request.setting(n, v.clone());
    }
    ctx.sampler(request)?;
    let radius = f.setting("max_radius").cloned().unwrap_or(ParamValue::Int(32));
    let direct = c.name == "direct";

    // 1. Widths and counts from the first pass (the shadow's velocity only for direct light).
    let velocity = ctx.sampler_output(SamplerPass::First, "velocity")?;
    let depth = ctx.sampler_output(SamplerPass::First, "defocus")?;
    let (statistic, component) = (Statistic::of(ctx, c)?, RateComponent::of(ctx, c)?);
    let shadow_velocity = if direct { Some(ctx.sampler_output(SamplerPass::First, "shadow_velocity")?) } else { None };
    let name = c.name;
    let (omega, pixel_length, count, sigma, texture_motion) = (
        ctx.buffer(&format!("{name}_omega"), Format::F32),
        ctx.buffer(&format!("{name}_pixel_length"), Format::F32),
        ctx.buffer(&format!("{name}_rays_per_pixel"), Format::U32),
        ctx.buffer(&format!("{name}_sigma"), Format::F32),
        ctx.buffer(&format!("{name}_texture_motion"), Format::Vec4),
    );
    let shadow_motion = direct.then(|| ctx.buffer(&format!("{name}_shadow_motion"), Format::Vec4));
    let io = RatesIo {
        pixel_length: Some(pixel_length),
        omega: Some(omega),
        n: Some(count),
        sigma: Some(sigma),
        texture_motion: Some(texture_motion),
        shadow_motion,
        ..RatesIo::inputs(velocity, depth, shadow_velocity, statistic)
    };
    let mut b = io.bind(ctx.pass(&format!("{name}_rates"), "motion.rates", Stage::Bandwidth));
    for (n, v) in motion_rate_settings(f).into_iter().chain(c.rate_params.iter().cloned()).chain([component.param()]) {
        b = b.param(n, v);
    }
    b.finish();
    ctx.sampler_counts(CountRequest {
        paths: None,
        paths_unit: 1,
        per_primary: vec![(c.estimator.into(), PerPrimary::Total(count))],
        max3: true,
        beyond_first: true,
    })?;

    // 2. One velocity or several, on the final paths (a reference composes L everywhere).
    let final_velocity = ctx.sampler_output(SamplerPass::Final, "velocity")?;
    let (final_shadow, final_occlusion) = if direct {
        (
            Some(ctx.sampler_output(SamplerPass::Final, "shadow_velocity")?),
            Some(ctx.sampler_output(SamplerPass::Final, "occlusion")?),
        )
    } else {
        (None, None)
    };
    let flag = ctx.buffer(&format!("{name}_flag"), Format::U32);
    let io = FlagsIo {
        velocity: final_velocity,
        shadow_velocity: final_shadow,
        occlusion: final_occlusion,
        flag: Some(flag),
        multi: None,
    };
    io.bind(ctx.pass(&format!("{name}_flag"), "motion.flags", Stage::Factor)).reference(Reference::Fill(0)).finish();

    // 3–4. Per part: E filtered (5.18/5.22, then B.2 along the shadow), k filtered along v_p (B.1);
    // composed and summed over parts.
    let position = ctx.sampler_output(SamplerPass::Final, "position")?;
    let normal = ctx.sampler_output(SamplerPass::Final, "normal")?;
    let max_radius = c.irradiance_radius(&radius);
    let filter = IrradianceFilter { position, normal, omega, pixel_length, max_radius, separable: true };
    let mut terms = Vec::new();
    for part in &c.parts {
        let e = ctx.sampler_output(SamplerPass::Final, part.irradiance)?;
        let mut e = filter.apply(ctx, &format!("{}_filter", part.name), e);
        if let Some(s) = shadow_motion {
            e = motion_filter(ctx, &format!("{}_filter_shadow", part.name), e, s, &radius);
        }
        // The paths' mean `k`, not the irradiance-weighted one Defocus takes: `L / Ē` carries the
        // shadow's noise over the shutter into the texture filtered along v_p (measured worse on the
        // motion suite: docs/DESIGN-NOTES.md "The irradiance-weighted texture").
        let k = ctx.sampler_output(SamplerPass::Final, part.texture)?;
        let k = motion_filter(ctx, &format!("{}_filter_texture", part.name), k, texture_motion, &radius);
        let l = ctx.sampler_output(SamplerPass::Final, part.radiance)?;
        terms.push((part, PartTerms { l, k, e, flag }));
    }
    compose_component(ctx, &terms, None, sigma, count);
    Ok(())
}
