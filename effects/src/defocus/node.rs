//! `Defocus`: thin-lens depth of field with factored axis-aligned filtering and two-level sampling
//! (thesis Ch. 5, `seeds/000_956e982470d7e5bf.txt` Sec. 5.2–5.8; `docs/EQUATIONS.md` "Defocus + factoring").
//!
//! The pipeline's factoring node ([`wedge_graph::factoring`]): with an aperture, every lighting
//! component node of the pipeline (SoftShadows: direct; Indirect: indirect; Environment: the map's
//! direct light) renders its component for it ([`super::component`]) and this node
//! 1. asks the shared sampler for the thin lens (`aperture_radius`, `focus_distance`, `lens`) and
//!    the thesis's first pass: `initial_paths` (4; the thesis's 16) paths through the pixel centre, one lens sample,
//!    one shadow ray and one indirect sample each, the centre-of-light form factor (so `k·E = L` where
//!    the scene factors; docs/EQUATIONS.md reading; `form_factor: "exact"` for an unbiased reference);
//! 2. computes `Ω_x^d` (5.7, 5.29) and `n_p` (5.24) from the first pass's circles of confusion
//!    (`defocus.rates`) and submits `n_p` paths for the second pass (3×3 max, `p²` rounding);
//! 3. sums its `direct`, `indirect` and `environment` inputs (each a component's eq. 5.32 term) and
//!    the emission of the primary hits (the map where lens rays miss), and filters the sum in screen
//!    space (eq. 5.33, `filter.defocus`);
//!    3b. with `screen_scale_wide` (not the thesis; off by default), filters it at that wider scale
//!    too and takes per pixel the filter of the smaller estimated squared error, the composed
//!    image's variance read from the narrower filter's residual (`kernels/risk.rs`; the port
//!    `filter_choice` says which);
//! 4. with `layers` (not the thesis; off by default), composites each pixel's blurred near layer over
//!    its far paths with the near layer's own filter (`defocus.layers`, `kernels/layers.rs`).
//!
//! **Lens.** `aperture_radius` and `focus_distance` (world units; focus along the optical axis)
//! come from the node's parameters, else from the pipeline's `camera:` block (its `aperture_radius`,
//! and its `focus_distance` or the distance to `look_at`). A scene file's camera aperture is not
//! read: a pipeline states its lens. Neither given: a validation error at the node.
//! `aperture_radius = 0` is a pinhole: the node does not factor, the component nodes render as
//! without it (Ch. 3/4 constants, which differ from Ch. 5's), and it only sums its inputs. Stated
//! under a `camera:` block that opens a lens it is refused: that lens would still reach every camera
//! path (`effects/src/plain_camera.rs`), two cameras in one pipeline.
//!
//! **Lens and shutter together.** On a scene that moves over the camera's shutter (`shutter:
//! "sample"`, the default) the node's paths sample the shutter too (camera setting `time`): each path
//! its own lens point and time. Ch. 5's widths stay as they are — the lens × shutter band is the
//! intersection of the two single-effect bands (docs/DEFOCUS-MOTION.md DM.4), so a filter that passes
//! the lens's band passes the product's — and the counts take the time factor of the speeds that shear
//! them (DM.8, DM.11, DM.12; `formulas::time_factor`), from the first pass's velocities. By default
//! no motion filter is applied: moving pixels are filtered as Ch. 5 filters them, never wider than
//! their band; `motion_filter: true` adds App. B's filters along the velocity inside the lens filter
//! (the cascade of DEFOCUS-MOTION.md Sec. 3; measured: less variance, more bias, no net gain yet).
//! `shutter: "frozen"` renders the scene at the shutter's centre (Ch. 5 alone).
//!
//! **Settings for the components** (what [`wedge_graph::NodeKind::factoring`] returns): `mu`,
//! `mode` (`consistent`, the default: no clamp, converges to Monte Carlo as μ → ∞; or `literal`,
//! eq. 5.29 as printed — above μ = 1 its clamped widths narrow the filters while the counts stop
//! growing, so the error rises with μ: DESIGN-NOTES "μ above 1: the clamp of eq. 5.29"), `factor` (false: the thesis's no-factoring ablation, Fig. 5.1(e): flags 0, combined
//! counts `n^c`, every pixel composes `L`), `max_primary`, `max_per_primary`, `max_radius`,
//! `separable`, `motion_filter`, `width_pixel_limit`, `screen_scale` (a factor on eq. 5.33's width,
//! the rates pass's) and `screen_scale_factored` (that factor where every component's first-pass
//! flag is set and no emitter is seen: `kernels/all_factored.rs`), `screen_scale_wide` (step 3b), `texture` (`weighted`, the default: a factored pixel's texture is
//! `L / Ē`, the paths' `k` weighted by the irradiance each brought — `formulas::weighted_texture`;
//! `mean`: the paths' mean `k̄`, eq. 5.32 as printed), and the camera settings `aperture_radius`, `focus_distance`, `lens` and (on a moving
//! scene) `time` (a node tracing its own camera rays, LightField, takes the same lens and shutter).

use std::collections::BTreeMap;

use wedge_graph::factoring::{CameraSettings, FactoringInputs, Refusal, Settings};
use wedge_graph::{
    BufferId, CameraSpec, Component, CountRequest, ExpandCtx, Factoring, Format, GraphError, NodeKind, ParamDecl,
    ParamValue, PassBuilder, PortDecl, Reference, SamplerPass, SamplerRequest, Stage, FILL_CONSTANT,
};

use super::component::rate_settings;
use super::kernels::all_factored::AllFactoredIo;
use super::kernels::filter::DefocusIo;
use super::kernels::layers::LayersIo;
use super::kernels::risk::{RiskChoiceIo, RiskSelectIo, RiskTermsIo};
use super::kernels::RatesIo;
use crate::factored::{components, filter_chain, pass_through, sum};
use wedge_backends::kernels::constant::FillU32Io;

pub struct Defocus;

/// The thin lens a Defocus node uses: its parameters, else the pipeline's camera block.
fn lens(params: &BTreeMap<String, ParamValue>, camera: Option<&CameraSpec>) -> Result<(f64, f64), Refusal> {
    let number = |name: &str| params.get(name).and_then(ParamValue::as_f64);
    let aperture = number("aperture_radius").or_else(|| camera.map(|c| f64::from(c.aperture_radius)));
    let Some(aperture) = aperture else {
        return Err(Refusal {
            message: "has no lens: neither its parameters nor the pipeline's `camera:` block give an aperture".into(),
            help: "add `\"aperture_radius\": 0.05, \"focus_distance\": 2.6` (world units) to its params, or a \
                   `camera: Some((position: .., look_at: .., vfov_deg: .., aperture_radius: 0.05, focus_distance: \
                   Some(2.6)))` block to the pipeline"
                .into(),
        });
    };
    let focus = number("focus_distance").or_else(|| {
        camera.map(|c| match c.focus_distance {
            Some(f) => f64::from(f),
            None => {
                let d = [c.look_at.0 - c.position.0, c.look_at.1 - c.position.1, c.look_at.2 - c.position.2];
                f64::from((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt())
            }
        })
    });
    let Some(focus) = focus else {
        return Err(Refusal {
            message: "has an aperture but no focus distance".into(),
            help: "add `\"focus_distance\": 2.6` (world units, along the view direction) to its params".into(),
        });
    };
    if !(aperture.is_finite() && aperture >= 0.0) {
        return Err(Refusal {
            message: format!("aperture_radius = {aperture} (from the camera block) is not a finite number >= 0"),
            help: "give the camera block an aperture_radius >= 0 (0 = pinhole)".into(),
        });
    }
    if !(focus.is_finite() && focus > 0.0) {
        return Err(Refusal {
            message: format!("focus_distance = {focus} (from the camera block) is not a finite number > 0"),
            help: "give the camera block a focus_distance > 0, or move look_at away from position".into(),
        });
    }
    Ok((aperture, focus))
}

/// A node that states `aperture_radius: 0` (a pinhole) under a camera block that opens a lens: the
/// block's lens would still reach every camera path (plain Monte Carlo through it, since this node
/// then filters nothing), so the pipeline would say two cameras. Refused, naming both.
fn refuse_a_second_lens(params: &BTreeMap<String, ParamValue>, camera: Option<&CameraSpec>) -> Result<(), Refusal> {
    let block = camera.map_or(0.0, |c| c.aperture_radius);
    if params.contains_key("aperture_radius") && block > 0.0 {
        return Err(Refusal {
            message: format!(
                "states aperture_radius = 0 (a pinhole) while the pipeline's `camera:` block opens aperture_radius = \
                 {block}: a pipeline has one camera"
            ),
            help: "remove the node's aperture_radius to blur the block's lens, or set the block's aperture_radius: 0 \
                   for a pinhole"
                .into(),
        });
    }
    Ok(())
}

/// Whether `screen_scale_wide` asks for a second, wider filter: a factor below `screen_scale`
/// (default 1). At or above it there is no wider filter to choose, and eq. 5.33 at `screen_scale`
/// alone is what renders (`--set defocus.screen_scale_wide=1` is the thesis's single filter).
fn wide_filter(params: &BTreeMap<String, ParamValue>) -> bool {
    let number = |name: &str| params.get(name).and_then(ParamValue::as_f64);
    number("screen_scale_wide").is_some_and(|wide| wide < number("screen_scale").unwrap_or(1.0))
}

impl NodeKind for Defocus {
    fn kind(&self) -> &'static str {
        "Defocus"
    }
    fn doc(&self) -> &'static str {
        "Thin-lens depth of field with factored irradiance filtering and two-level sampling (Mehta thesis Ch. 5)"
    }
    fn bench_suite(&self) -> Option<&'static str> {
        Some("defocus")
    }
    fn inputs(&self) -> Vec<PortDecl> {
        crate::light_terms::component_inputs()
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![
            PortDecl::new("radiance", Format::Vec3, "Σ components + emission, defocus-filtered (eq. 5.33)"),
            PortDecl::new("unfiltered", Format::Vec3, "the same sum before the defocus filter (components filtered)"),
            PortDecl::new("filter_width", Format::F32, "defocus filter std-dev in pixels, 1/(√32 Ω_x^d) (0 = pinhole)"),
            PortDecl::new(
                "rays_per_pixel",
                Format::U32,
                "primary rays per pixel asked for the second pass, n_p (eq. 5.24)",
            ),
            PortDecl::new(
                "filter_choice",
                Format::U32,
                "which screen filter a pixel took: 1 the wider (screen_scale_wide, by estimated risk), 0 eq. 5.33 at screen_scale",
            ),
        ]
    }
    /// Its components, and (where it factors) what its camera rays see directly, added once here.
    fn terms(&self, port: &str, q: &wedge_graph::TermQuery<'_>) -> Option<wedge_graph::Terms> {
        matches!(port, "radiance" | "unfiltered").then(|| crate::light_terms::factoring_sum(q))
    }
    fn params(&self) -> Vec<ParamDecl> {
        vec![
            ParamDecl::float("aperture_radius", 0.05, 0.0, 1e6, "thin-lens aperture radius, world units (0 = pinhole); default: the camera block's").optional(),
            ParamDecl::positive("focus_distance", 2.6, 1e9, "distance of the plane in focus along the view direction, world units; default: the camera block's").optional(),
            ParamDecl::choice("lens", "disk", &["disk", "gaussian"], "aperture weight: uniform disk (pbrt, Mitsuba) or the thesis's Gaussian exp(-|u|²/2)"),
            crate::params::mu(1.0, "μ: scales every Ch. 5 bandwidth (eq. 5.29); larger = narrower filters, more rays"),
            crate::params::mode(),
            crate::params::form_factor("light_centre", "light-centre form factor f_c in L, k and E (the thesis's reading: k·E = L where the scene factors), or the per-sample geometry term (unbiased; for comparisons with other renderers)"),
            ParamDecl::choice("texture", "weighted", &["weighted", "mean"], "a factored pixel's texture: weighted by the irradiance each path brought, L / Ē (the default since issue 35's defocus suites: it keeps the covariance of texture and light over the lens — a blurred highlight's paths bring both — and equals k̄ where k is constant), or the paths' mean k̄ (the thesis, eq. 5.32's k E); docs/DESIGN-NOTES.md \"The irradiance-weighted texture\""),
            ParamDecl::boolean("factor", true, "factor L into texture × irradiance (eq. 5.30); false = the thesis's no-factoring ablation"),
            ParamDecl::int("initial_paths", 4, 1, 4096, "first-pass paths per pixel, one lens, shadow and indirect sample each: 4 since issue 35's defocus suite (the thesis's 16 spent 48 rays per pixel before any rate was known; docs/DESIGN-NOTES.md \"Four first-pass paths under a lens\")"),
            crate::params::max_primary(),
            ParamDecl::int("max_primary_moving", 256, 1, 4096, "where the paths sample the shutter: the cap on a moving pixel's primary rays — max_primary's strata per side times the time factor's 1 + |v| Ω, at most this — so max_primary binds the lens's share and a mover keeps the paths the shutter asks for; absent: max_primary everywhere (docs/DESIGN-NOTES.md \"Defocus's primary-ray cap under a moving shutter\")").optional(),
            ParamDecl::int("max_per_primary", 1, 1, 4096, "cap on secondary rays per primary ray (rounded down to a square; scaled by max(μ, 1)² in consistent mode): 1 since issue 35's defocus suite (4 = 2×2 strata, the earlier default), see docs/DESIGN-NOTES.md \"The defocus suite\""),
            ParamDecl::int("max_shadow_per_primary", 1, 1, 4096, "cap on shadow rays per primary ray, as max_per_primary (1 = its default; docs/DESIGN-NOTES.md \"Shadow rays per primary under Motion\")"),
            ParamDecl::int("max_radius", 16, 1, 64, "largest filter half-width in pixels (eqs. 5.31, 5.33)"),
            ParamDecl::boolean("layers", false, "composite the near layer — the paths in front of the focal plane blurred over more than 2 px — over the rest of a pixel where the rest is much sharper, with the near layer's own filter (a blurred foreground over a sharp background: its lens noise filtered away; docs/DESIGN-NOTES.md \"The near layer\"); false: eq. 5.33 alone, the thesis"),
            ParamDecl::boolean("separable", true, "x then y filter passes (O(R) taps) instead of the 2-D reference (O(R²))"),
            ParamDecl::choice(
                "shutter",
                "sample",
                &["sample", "frozen"],
                "where the scene moves over the camera's shutter: sample it too (each path its own time; counts take the time factor, docs/DEFOCUS-MOTION.md), or freeze the scene at the shutter's centre (Ch. 5 alone)",
            ),
            ParamDecl::boolean("width_pixel_limit", false, "cap the screen-space filter's width at the pixel limit Ω_pix^max as eq. 5.7 does (the thesis: every in-focus pixel gets a σ = 0.35 px blur, a bias at sharp edges and highlights); false: the lens term alone, μ Ω_u^max / r_min, so in-focus pixels stay sharp. The counts are the same either way (DESIGN-NOTES \"The filters against their own rays\")"),
            ParamDecl::positive("screen_scale", 1.0, 1e3, "factor on eq. 5.33's screen-space bandwidth, μ Ω_u^max / r_min (not on the counts, the irradiance filters or the near layer's): below 1 a wider lens filter — the variance of a blurred texture where the first pass's paths already exceed eq. 5.24's count — at the cost of bias at bright out-of-focus highlights; 1 = the thesis. Still ∝ μ, so consistent as μ grows (docs/DESIGN-NOTES.md \"The screen filter's scale\")"),
            ParamDecl::positive("screen_scale_factored", 1.0, 1e3, "screen_scale where the pixel's whole radiance factors — every lighting component's first-pass flag set (eq. 5.30) and no emitter seen: a diffuse texture under smooth light, whose blurred edges are ramps a wider Gaussian barely changes, where a glossy highlight or an emitter blurs into a disc whose sharp rim it would ; absent: screen_scale everywhere, the thesis with screen_scale 1. Still ∝ μ, so consistent as μ grows. Measured at (screen_scale 1, 0.7): every Defocus goal of the suite met, but 11% lost on held-out chess and cornell, so no shipped pipeline sets it (docs/DESIGN-NOTES.md \"The screen filter's scale, per pixel\")").optional(),
            ParamDecl::positive("screen_scale_wide", 0.6, 1e3, "a second, wider screen filter — eq. 5.33's width times this factor, below screen_scale (at or above it: no second filter, screen_scale's alone) — and per pixel the one of the two with the smaller estimated squared error: the bias the wider adds (from the difference of the two filtered images) against the variance it removes (from the composed image's variance, estimated from what the narrower filter removes: the pixels' noise is independent, the narrower filter unbiased), summed over 7×7 pixels (kernels/risk.rs; docs/DESIGN-NOTES.md \"The risk-based width, shipped\"); absent: screen_scale's filter alone, the thesis with screen_scale 1. Both widths ∝ μ, so consistent as μ grows").optional(),
            ParamDecl::boolean("motion_filter", false, "with the shutter sampled: App. B's filters along the velocity inside the lens filter (texture along the primary hit's, direct irradiance along the shadow's; docs/DEFOCUS-MOTION.md Sec. 3); false = Ch. 5's filters only (measured better so far: DESIGN-NOTES \"Lens and shutter together\")"),
        ]
    }
    fn factoring(
        &self,
        params: &BTreeMap<String, ParamValue>,
        inputs: &FactoringInputs<'_>,
    ) -> Result<Option<Settings>, Refusal> {
        let (aperture, focus) = lens(params, inputs.camera)?;
        if aperture == 0.0 {
            refuse_a_second_lens(params, inputs.camera)?;
            return Ok(None);
        }
        let mut s: Settings = [
            "mu",
            "mode",
            "factor",
            "max_primary",
            "max_primary_moving",
            "max_per_primary",
            "max_shadow_per_primary",
            "max_radius",
            "separable",
            "lens",
            "initial_paths",
            "motion_filter",
            "width_pixel_limit",
            "screen_scale",
            "screen_scale_factored",
            "screen_scale_wide",
            "texture",
        ]
        .into_iter()
        .filter(|n| *n != "screen_scale_wide" || wide_filter(params))
        .filter_map(|n| params.get(n).map(|v| (n.to_string(), v.clone())))
        .collect();
        s.insert("aperture_radius".into(), ParamValue::Float(aperture));
        s.insert("focus_distance".into(), ParamValue::Float(focus));
        // Lens and shutter together where the scene moves (docs/DEFOCUS-MOTION.md): the camera
        // setting of a factoring node whose paths sample the shutter.
        let sample_shutter = params.get("shutter") != Some(&ParamValue::Str("frozen".into()));
        if sample_shutter && inputs.scene.is_some_and(|f| f.motion) {
            s.insert(CameraSettings::TIME.into(), ParamValue::Bool(true));
        }
        Ok(Some(s))
    }
    fn expand_component(&self, ctx: &mut ExpandCtx<'_>, f: &Factoring, c: &Component) -> Result<(), GraphError> {
        super::component::expand(ctx, f, c)
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        let components = components(ctx)?;
        let Some(f) = ctx.factoring().filter(|f| f.node == ctx.node()) else {
            // A pinhole: the components rendered as without a Defocus node; only their sum here.
            pass_through(ctx, &components);
            let choice = narrow_everywhere(ctx);
            ctx.output("filter_choice", choice);
            return Ok(());
        };

        // 1. The thin lens and the thesis's first pass (Sec. 5.8 step 1); shutter times too where
        // the scene moves.
        let time = f.bool(CameraSettings::TIME) == Some(true);
        let mut request = SamplerRequest::new()
            .setting("paths", ctx.param("initial_paths").clone())
            .setting("shadow_per_primary", ParamValue::Int(1))
            .setting("indirect_per_primary", ParamValue::Int(1))
            .setting("jitter", ParamValue::Bool(false))
            .setting("sampling", ParamValue::Str("stratified".into()))
            .setting("form_factor", ctx.param("form_factor").clone())
            .setting("lens", ctx.param("lens").clone());
        for n in ["aperture_radius", "focus_distance"] {
            request = request.setting(n, f.setting(n).expect("a factoring Defocus has a lens").clone());
        }
        if time {
            request = request.estimator("time");
        }
        ctx.sampler(request)?;

        // 2. Ω_x^d and n_p (eqs. 5.7, 5.24, 5.29; with the shutter, DM.8's time factor).
        let lens = ctx.sampler_output(SamplerPass::First, "defocus")?;
        let velocity = if time { Some(ctx.sampler_output(SamplerPass::First, "velocity")?) } else { None };
        let (omega, pixel_length, n_primary, sigma) = (
            ctx.buffer("omega_defocus", Format::F32),
            ctx.buffer("pixel_length", Format::F32),
            ctx.buffer("rays_per_pixel", Format::U32),
            ctx.buffer("filter_width", Format::F32),
        );
        // The risk-based width's wider filter takes its width from this pass (step 3b).
        let omega_wide = f.setting("screen_scale_wide").map(|_| ctx.buffer("omega_wide", Format::F32));
        let io = RatesIo {
            velocity,
            omega_defocus: Some(omega),
            omega_defocus_wide: omega_wide,
            n_primary: Some(n_primary),
            sigma_defocus: Some(sigma),
            flag: factored_pixels(ctx, f)?,
            ..RatesIo::new(lens, pixel_length)
        };
        let b = io.bind(ctx.pass("rates", "defocus.rates", Stage::Bandwidth));
        with_rate_settings(b, f, &["screen_scale", "screen_scale_factored", "screen_scale_wide"]).finish();
        ctx.sampler_counts(CountRequest {
            paths: Some(n_primary),
            paths_unit: 1,
            per_primary: vec![],
            max3: true,
            beyond_first: true,
        })?;

        // 3. Σ components + emission (eq. 5.32), then the screen-space defocus filter (eq. 5.33).
        let emission = crate::factored::seen_directly(ctx, SamplerPass::Final)?;
        let composed = sum(ctx, "compose", &components, emission);
        let value = screen_filter(ctx, "filter", composed, omega);
        let (value, choice) = match omega_wide {
            Some(omega_wide) => risk_width(ctx, RiskWidth { composed, narrow: value, omega, omega_wide }),
            None => (value, narrow_everywhere(ctx)),
        };
        ctx.output("filter_choice", choice);
        let value =
            if ctx.param("layers") == &ParamValue::Bool(true) { near_layer(ctx, f, composed, value)? } else { value };
        ctx.output("radiance", value);
        ctx.output("unfiltered", composed);
        ctx.output("filter_width", sigma);
        ctx.output("rays_per_pixel", n_primary);
        Ok(())
    }
}

/// With `screen_scale_factored`: the pixels whose whole radiance factors — every component's
/// first-pass flag set (eq. 5.30; the flags the components published, `component.rs`) and, where
/// the node's radiance holds emission, no emitter seen by the first pass's camera paths — ANDed by
/// `defocus.all_factored` (passes `factored`, `factored_1`, …), for `defocus.rates` to widen eq.
/// 5.33's filter there. `None` (every pixel takes `screen_scale`) without the option.
fn factored_pixels(ctx: &mut ExpandCtx<'_>, f: &Factoring) -> Result<Option<BufferId>, GraphError> {
    if f.setting("screen_scale_factored").is_none() {
        return Ok(None);
    }
    let mut emission = crate::factored::seen_directly(ctx, SamplerPass::First)?;
    let mut previous = None;
    for (k, flag) in ctx.factoring_flags().into_iter().enumerate() {
        let name = if k == 0 { "factored".to_string() } else { format!("factored_{k}") };
        let out = ctx.buffer(&name, Format::U32);
        AllFactoredIo { flag, previous, emission: emission.take(), out }
            .bind(ctx.pass(&name, "defocus.all_factored", Stage::Bandwidth))
            .finish();
        previous = Some(out);
    }
    Ok(previous)
}

/// The node's own `defocus.rates` parameters: the rate settings, `width_pixel_limit` and the
/// settings named in `scales` where given.
fn with_rate_settings<'c, 'a>(mut b: PassBuilder<'c, 'a>, f: &Factoring, scales: &[&str]) -> PassBuilder<'c, 'a> {
    for (n, v) in rate_settings(f) {
        b = b.param(n, v);
    }
    for name in ["width_pixel_limit"].iter().chain(scales) {
        if let Some(v) = f.setting(name) {
            b = b.param(name, v.clone());
        }
    }
    b
}

/// Eq. 5.33 on `value` at width `omega` (`filter.defocus`, passes `<name>_x`, `<name>_y` where the
/// node is `separable`), in the node's window.
fn screen_filter(ctx: &mut ExpandCtx<'_>, name: &str, value: BufferId, omega: BufferId) -> BufferId {
    let separable = ctx.param("separable") == &ParamValue::Bool(true);
    let radius = ctx.param("max_radius").clone();
    filter_chain(
        ctx,
        name,
        "filter.defocus",
        Stage::ImageFilter,
        value,
        |b, value, out| DefocusIo { value, omega, out }.bind(b),
        &[("max_radius", radius)],
        separable,
    )
}

/// The node's `filter_choice` without `screen_scale_wide`: 0 (eq. 5.33 at `screen_scale`) everywhere
/// (`fill.constant`; culled unless a heatmap reads it).
fn narrow_everywhere(ctx: &mut ExpandCtx<'_>) -> BufferId {
    let out = ctx.buffer("filter_choice", Format::U32);
    FillU32Io { out }.bind(ctx.pass("filter_choice", FILL_CONSTANT, Stage::ImageFilter)).int("value", 0).finish();
    out
}

/// What the risk-based width ([`risk_width`]) takes from the node's expansion: eq. 5.32's sum, eq.
/// 5.33 of it at `screen_scale` and that width, and the width at `screen_scale_wide` (the node's
/// rates pass writes both).
struct RiskWidth {
    composed: BufferId,
    narrow: BufferId,
    omega: BufferId,
    omega_wide: BufferId,
}

/// Step 3b of the module doc, with `screen_scale_wide` (`kernels/risk.rs`): the composed image
/// filtered at eq. 5.33's width at the wider scale (`filter_wide`; the rates pass's
/// `omega_defocus_wide`, on which `screen_scale_factored` does not act), and per pixel the filter of
/// the smaller estimated error (`risk_terms`, `risk_choice`, `risk_select`; a reference bypasses
/// them, as it does both filters). Returns the image and the choice (1 = wide), the node's
/// `filter_choice`.
fn risk_width(ctx: &mut ExpandCtx<'_>, w: RiskWidth) -> (BufferId, BufferId) {
    let omega_wide = w.omega_wide;
    let wide = screen_filter(ctx, "filter_wide", w.composed, omega_wide);
    let radius = ctx.param("max_radius").clone();
    let (bias, noise) = (ctx.buffer("risk_bias", Format::F32), ctx.buffer("risk_noise", Format::F32));
    RiskTermsIo { value: w.composed, narrow: w.narrow, wide, omega: w.omega, omega_wide, bias, noise }
        .bind(ctx.pass("risk_terms", "defocus.risk_terms", Stage::ImageFilter))
        .param("max_radius", radius)
        .finish();
    // A reference takes the narrow filter (bypassed too): 0 everywhere.
    let choice = ctx.buffer("risk_choice", Format::U32);
    RiskChoiceIo { bias, noise, choice }
        .bind(ctx.pass("risk_choice", "defocus.risk_choice", Stage::ImageFilter))
        .reference(Reference::Fill(0))
        .finish();
    let out = ctx.buffer("risk", Format::Vec3);
    RiskSelectIo { choice, narrow: w.narrow, wide, out }
        .bind(ctx.pass("risk_select", "defocus.risk_select", Stage::ImageFilter))
        .reference(Reference::Bypass { input: "narrow" })
        .finish();
    (out, choice)
}

/// Step 4 of the module doc, with `layers`: the near layer composited over the rest after eq. 5.33
/// (`defocus.layers`, `kernels/layers.rs`), at the node's μ and window cap; a reference bypasses it.
fn near_layer(
    ctx: &mut ExpandCtx<'_>,
    f: &Factoring,
    composed: BufferId,
    filtered: BufferId,
) -> Result<BufferId, GraphError> {
    let near = ctx.sampler_output(SamplerPass::Final, "near")?;
    let near_coc = ctx.sampler_output(SamplerPass::Final, "near_coc")?;
    let lens = ctx.sampler_output(SamplerPass::Final, "defocus")?;
    // The μ the rates and eq. 5.33's widths were computed with (`component::rate_settings`).
    let mu = f.setting("mu").cloned().unwrap_or_else(|| ctx.param("mu").clone());
    let max_radius = ctx.param("max_radius").clone();
    let out = ctx.buffer("layered", Format::Vec3);
    LayersIo { composed, filtered, near, near_coc, lens, out }
        .bind(ctx.pass("layers", "defocus.layers", Stage::ImageFilter))
        .param("mu", mu)
        .param("max_radius", max_radius)
        .reference(Reference::Bypass { input: "filtered" })
        .finish();
    Ok(out)
}
