//! `Environment`: image-based lighting with axis-aligned filtering, and filtering across frames
//! (thesis Ch. 6, `seeds/000_956e982470d7e5bf.txt` Sec. 6.5–6.7; `docs/EQUATIONS.md` "Environment").
//!
//! The node
//! 1. asks the scene for its environment map ([`SceneRequest::Environment`]: `map`, `scale`,
//!    `rotation_deg`; no `map` = the scene's own) and the shared sampler for the `environment`
//!    estimator: `primary` paths per pixel (jittered where more than one) with `per_primary` table
//!    look-ups each — Algorithm 1's 4 × 4 = 16 by default — and, with `indirect`, the `hemisphere`
//!    estimator (`indirect_per_primary` one-bounce samples per path, whose reflectors the environment
//!    lights by next-event estimation);
//! 2. computes the screen-space curvature (eq. 6.20, `environment.curvature`) and per pixel the
//!    bandwidths of the environment's direct light (eq. 6.13 diffuse, 6.17 Phong with `B_ρ(m)`) and of
//!    the indirect light (6.18), times μ (`environment.bandwidth`); where `adaptive` applies (glossy
//!    receivers by default, [`AdaptiveLookUps`]), submits the look-ups its filters need
//!    ([`super::formulas::look_ups`], an extension);
//! 3. filters each irradiance — environment diffuse and glossy, indirect diffuse and glossy — with
//!    the separable Gaussian of eqs. 6.21–6.23 (`filter.environment`); with `temporal`, the previous
//!    frame's unfiltered irradiance, reprojected (`filter.environment_history`, eqs. 6.24–6.25), joins
//!    the y pass (6.26) through the frame history (`ExpandCtx::previous_frame`);
//! 4. composes `Σ k Ē` (+ the primary hits' emission and the environment seen where camera rays miss,
//!    with `emission`), each part's `k Ē` where eq. 5.30's test says the pixel's primary rays factor
//!    (a pixel whose jittered rays see two textures keeps its Monte Carlo `L`), as Ch. 5 composes.
//!
//! Ch. 6 has no μ and no adaptive rates; both are documented extensions here (μ = 1 and
//! `adaptive: "off"` are the thesis).
//!
//! **Under a factoring node** (Defocus, Motion: [`wedge_graph::factoring`]) the environment's direct
//! light is one factored component ([`expand_factored`]), as SoftShadows' direct light is: Ch. 6's
//! bandwidth (steps 1–2, on the factoring node's first pass, at μ = 1) is the component's own
//! bandlimit, which the factoring node's rates turn into its irradiance width and look-ups (the lens
//! or velocity terms added: `crate::defocus::formulas::omega_environment`). Where `adaptive` applies
//! (glossy receivers by default) the node also asks the sampler for the paths its own rule gives at
//! the factoring node's μ — Ch. 5's rates give a pixel in focus one path, whose single position
//! cannot resolve a glossy reflection of the map (docs/DESIGN-NOTES.md "Glossy receivers under a
//! factoring node", and "The glossy count follows the factoring node's μ").

use std::collections::BTreeMap;

use wedge_graph::{
    BufferId, Component, CountRequest, ExpandCtx, Factoring, Format, GraphError, NodeKind, ParamDecl, ParamValue, Part,
    PerPrimary, PortDecl, Reference, SamplerPass, SamplerRequest, SceneRequest, Stage, Statistic,
};

use super::kernels::filter::{EnvironmentFilterIo, HistoryIo};
use super::kernels::{AdaptiveLookUps, BandwidthIo, CurvatureIo};
use crate::factored::{compose_component, factor_flags, PartTerms};
use wedge_backends::kernels::constant::FillF32Io;
use wedge_backends::kernels::environment::GlossySampling;

pub struct Environment;

/// A filtered part: the sampler's `L, k, E` names, the bandwidth output of `environment.bandwidth`
/// filtering it, and whether its light depends on the view direction (glossy: then it keeps no
/// temporal history, [`PartFilter`]).
struct FilteredPart {
    part: Part,
    bandwidth: &'static str,
    view_dependent: bool,
}

const DIRECT_PARTS: [FilteredPart; 2] = [
    FilteredPart {
        part: Part {
            name: "env_diffuse",
            radiance: "l_env_diffuse",
            texture: "k_env_diffuse",
            irradiance: "e_env_diffuse",
        },
        bandwidth: "direct_diffuse",
        view_dependent: false,
    },
    FilteredPart {
        part: Part {
            name: "env_glossy",
            radiance: "l_env_glossy",
            texture: "k_env_glossy",
            irradiance: "e_env_glossy",
        },
        bandwidth: "direct_glossy",
        view_dependent: true,
    },
];

const INDIRECT_PARTS: [FilteredPart; 2] = [
    FilteredPart {
        part: Part { name: "indirect_diffuse", radiance: "l_diffuse", texture: "k_diffuse", irradiance: "e_diffuse" },
        bandwidth: "indirect_diffuse",
        view_dependent: false,
    },
    FilteredPart {
        part: Part { name: "indirect_glossy", radiance: "l_glossy", texture: "k_glossy", irradiance: "e_glossy" },
        bandwidth: "indirect_glossy",
        view_dependent: true,
    },
];

/// The normal test of the filters: neighbours whose normals differ by more are not averaged.
pub(crate) const NORMAL_DEG: f64 = 10.0;

/// The map a node lit by an environment declares (`map`, `scale`, `rotation_deg`), shared by every
/// such node so that the same names mean the same thing; [`environment_request`] asks the scene for it.
pub(crate) fn map_params() -> [ParamDecl; 3] {
    [
        ParamDecl::path("map", "", "lat-long environment map: .exr or .hdr, relative to the pipeline file, or builtin:sky / studio / sun / overcast / sunset; empty = the scene's own"),
        ParamDecl::positive("scale", 1.0, 1e9, "multiplies the map's radiance"),
        ParamDecl::float("rotation_deg", 0.0, -3600.0, 3600.0, "turns the map about +Y (right-hand rule, degrees)"),
    ]
}

/// A string parameter's value (`""` where absent).
pub(crate) fn str_param(params: &BTreeMap<String, ParamValue>, name: &str) -> String {
    match params.get(name) {
        Some(ParamValue::Str(s)) => s.clone(),
        _ => String::new(),
    }
}

/// The environment [`map_params`] describe, as a scene request.
pub(crate) fn environment_request(params: &BTreeMap<String, ParamValue>) -> SceneRequest {
    let f = |n: &str| params.get(n).and_then(ParamValue::as_f64).unwrap_or(0.0);
    SceneRequest::Environment {
        map: str_param(params, "map"),
        scale: f("scale"),
        rotation_deg: f("rotation_deg"),
        param: "map",
    }
}

fn count(ctx: &ExpandCtx<'_>, name: &str) -> i64 {
    match ctx.param(name) {
        ParamValue::Int(v) => *v,
        other => unreachable!("`{name}` is declared an integer, found {other}"),
    }
}

impl NodeKind for Environment {
    fn kind(&self) -> &'static str {
        "Environment"
    }
    fn doc(&self) -> &'static str {
        "Environment-map lighting with axis-aligned filtering and optional temporal filtering (Mehta thesis Ch. 6)"
    }
    fn bench_suite(&self) -> Option<&'static str> {
        Some("environment")
    }
    fn inputs(&self) -> Vec<PortDecl> {
        Vec::new()
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![
            PortDecl::new(
                "radiance",
                Format::Vec3,
                "Σ k·Ē over the filtered parts (+ emission and the visible environment, with `emission`)",
            ),
            PortDecl::new("unfiltered", Format::Vec3, "the same sum of the parts' Monte Carlo L"),
            PortDecl::new(
                "filter_width",
                Format::F32,
                "σ of the direct light's filter in pixels, mean of x and y (thesis Fig. 6.7(b))",
            ),
            PortDecl::new(
                "bandwidth",
                Format::F32,
                "B_x of the direct light (eq. 6.13/6.17, μ included), mean of x and y, 1/m",
            ),
            PortDecl::new("curvature", Format::F32, "screen-space curvature |κ| (eq. 6.20), mean of x and y, rad/m"),
            PortDecl::new(
                "rays_per_pixel",
                Format::U32,
                "environment look-ups per pixel asked for (`primary` × `per_primary` where `adaptive` does not apply)",
            ),
        ]
    }
    /// Direct environment light (and one-bounce indirect with `indirect`; what camera rays see
    /// directly with `emission`), through the shared sampler's camera.
    /// Under a factoring node: the direct environment light alone (the factoring node adds what camera
    /// rays see directly).
    fn terms(&self, port: &str, q: &wedge_graph::TermQuery<'_>) -> Option<wedge_graph::Terms> {
        use wedge_graph::{Term, TermKind, Terms};
        let v = q.sampler_view();
        let mut t = Terms::new().with(Term::new(TermKind::DirectEnvironment, v));
        if q.factored() {
            return matches!(port, "radiance" | "unfiltered").then_some(t);
        }
        if q.flag("indirect") {
            t = t.with(Term::new(TermKind::Indirect, v).detail("1 bounce"));
        }
        if q.flag("emission") {
            t = t.plus(Some(&crate::light_terms::seen_directly(v)));
        }
        matches!(port, "radiance" | "unfiltered").then_some(t)
    }
    fn params(&self) -> Vec<ParamDecl> {
        let mut params = map_params().to_vec();
        params.extend([
            ParamDecl::float("b_e", -1.0, 0.0, 1e4, "B_e in cycles per radian; -1 = the map's 99%-energy bandwidth (Sec. 6.7)").or_special(-1.0, "automatic: the map's 99%-energy bandwidth"),
            crate::params::mu(1.0, "μ (an extension; the thesis has none): scales every bandwidth; larger = narrower filters"),
            ParamDecl::int("primary", 4, 1, 256, "primary rays per pixel, jittered where more than one (Algorithm 1: 4)"),
            ParamDecl::int("per_primary", 4, 1, 4096, "environment look-ups per primary ray (Algorithm 1: 4)"),
            ParamDecl::boolean("indirect", false, "also sample and filter one-bounce indirect light (eq. 6.18)"),
            ParamDecl::int("indirect_per_primary", 4, 1, 4096, "one-bounce indirect samples per primary ray, with `indirect`"),
            ParamDecl::boolean("temporal", false, "join the previous frame's reprojected irradiance in the y pass (eqs. 6.24-6.26)"),
            ParamDecl::int("max_radius", 8, 1, 64, "filter half-width and widest σ in pixels (15: the thesis's 30 × 30 window; 8 measured better, docs/RESULTS.md); under a factoring node, the cap of its component's irradiance filter where below the factoring node's"),
            ParamDecl::int("max_motion", 32, 0, 4096, "with `temporal`: pixels a point may move between frames and keep its history (bounds the rows the history pass reads)"),
            ParamDecl::float("occluder_threshold", 0.1, 0.0, 1e6, "occluded look-ups dimmer than this × the map's mean radiance do not set the occluder term (Sec. 6.7: 0.1)"),
            ParamDecl::choice("adaptive", "glossy", AdaptiveLookUps::OPTIONS, "more look-ups where the filter is narrower than `sigma_ref` pixels (an extension): at glossy receivers, every receiver, or off (the thesis's fixed count)"),
            ParamDecl::positive("sigma_ref", 1.0, 64.0, "with `adaptive`: the filter width (px) below which look-ups grow as σ_ref²/(σ_x σ_y)"),
            ParamDecl::int("max_rays", 256, 1, 1 << 20, "with `adaptive`: the most look-ups per pixel"),
            ParamDecl::choice("glossy_sampling", "mis", GlossySampling::OPTIONS, "the light at glossy receivers: mis (the default since issue 35), each look-up paired with a direction drawn from the receiver's lobe, the two combined by multiple importance sampling (one more shadow ray per look-up at glossy receivers), or table: look-ups into the map's table alone (the thesis: directions drawn by the map's luminance; a sharp lobe catches few); docs/DESIGN-NOTES.md \"Glossy receivers: the lobe and the map\""),
            ParamDecl::boolean("emission", true, "add the primary hits' emission and the environment where camera rays miss (false where another node adds it)"),
            crate::plain_camera::paths_param(),
        ]);
        params
    }
    fn scene_requests(&self, params: &BTreeMap<String, ParamValue>) -> Vec<SceneRequest> {
        vec![environment_request(params)]
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        if let Some(f) = ctx.factoring() {
            return expand_factored(ctx, f);
        }
        if ctx.plain_camera() {
            return expand_plain(ctx);
        }
        let (primary, per_primary) = (count(ctx, "primary"), count(ctx, "per_primary"));
        let indirect = ctx.param("indirect").as_bool() == Some(true);
        let temporal = ctx.param("temporal").as_bool() == Some(true);
        // Counts submitted wherever the look-ups may follow the filters (a scene with no glossy
        // receiver adds no path under "glossy").
        let adaptive = adapts(ctx);

        // 1. The sampler: Algorithm 1's primary rays and look-ups (and one-bounce indirect samples).
        let mut request = SamplerRequest::new()
            .estimator("environment")
            .setting("paths", ParamValue::Int(primary))
            .setting("environment_per_primary", ParamValue::Int(per_primary))
            .setting("jitter", ParamValue::Bool(primary > 1))
            .setting("sampling", ParamValue::Str("stratified".into()))
            .setting("occluder_threshold", ctx.param("occluder_threshold").clone())
            .setting("environment_glossy", ctx.param("glossy_sampling").clone());
        if indirect {
            request = request
                .estimator("hemisphere")
                .setting("indirect_per_primary", ctx.param("indirect_per_primary").clone());
        }
        ctx.sampler(request)?;

        // 2. Curvature (6.20) and bandwidths (6.13, 6.17, 6.18) from the first pass.
        let position = ctx.sampler_output(SamplerPass::First, "position")?;
        let normal = ctx.sampler_output(SamplerPass::First, "normal")?;
        let stats = ctx.sampler_output(SamplerPass::First, "environment")?;
        let depth = if indirect { Some(ctx.sampler_output(SamplerPass::First, "depth")?) } else { None };
        let (curvature, magnitude) = curvature_pass(ctx, position, normal);
        let parts: Vec<&FilteredPart> =
            DIRECT_PARTS.iter().chain(if indirect { &INDIRECT_PARTS[..] } else { &[] }).collect();
        let bandwidths: Vec<BufferId> =
            parts.iter().map(|p| ctx.buffer(&format!("bandwidth_{}", p.bandwidth), Format::Vec2)).collect();
        let (bandwidth, width, rays) = (
            ctx.buffer("bandwidth", Format::F32),
            ctx.buffer("filter_width", Format::F32),
            ctx.buffer("rays_per_pixel", Format::U32),
        );
        // The parts' bandwidths in `DIRECT_PARTS`, `INDIRECT_PARTS` order (the indirect ones where sampled).
        let part = |i: usize| bandwidths.get(i).copied();
        let io = BandwidthIo {
            direct_diffuse: part(0),
            direct_glossy: part(1),
            indirect_diffuse: part(2),
            indirect_glossy: part(3),
            bandwidth: Some(bandwidth),
            filter_width: Some(width),
            rays: Some(rays),
            ..BandwidthIo::inputs(curvature, stats, normal, depth)
        };
        io.bind(ctx.pass("bandwidth", "environment.bandwidth", Stage::Bandwidth))
            .node_params(&["b_e", "mu", "adaptive", "max_radius", "sigma_ref", "max_rays"])
            .int("base", primary * per_primary)
            .float("count_mu", 1.0)
            .reference(if adaptive { Reference::Count } else { Reference::Keep })
            .finish();
        if adaptive {
            // Look-ups over both passes, `per_primary` per path: the sampler adds paths.
            let mut per_path = vec![("environment".to_string(), PerPrimary::Constant(per_primary as u32))];
            if indirect {
                per_path.push(("hemisphere".into(), PerPrimary::Constant(count(ctx, "indirect_per_primary") as u32)));
            }
            ctx.sampler_counts(CountRequest {
                paths: Some(rays),
                paths_unit: per_primary as u32,
                per_primary: per_path,
                max3: false,
                beyond_first: false,
            })?;
        }

        // 3. Per part: the separable filter (6.21–6.23), the previous frame joining its y pass
        // (6.24–6.26) with `temporal`; 4. composed k·Ē where the pixel factors (eq. 5.30) — the
        // paths' mean k: the irradiance-weighted one Defocus takes measured the same here
        // (docs/DESIGN-NOTES.md "The irradiance-weighted texture").
        let position = ctx.sampler_output(SamplerPass::Final, "position")?;
        let normal = ctx.sampler_output(SamplerPass::Final, "normal")?;
        let mut filter = PartFilter {
            position,
            normal,
            max_radius: ctx.param("max_radius").clone(),
            max_motion: ctx.param("max_motion").clone(),
            normal_cos: ParamValue::Float(NORMAL_DEG.to_radians().cos()),
            temporal,
        };
        let mut terms = Vec::new();
        for (FilteredPart { part, view_dependent, .. }, bw) in parts.iter().zip(&bandwidths) {
            // Eq. 5.30 without Ch. 5's median: a pixel whose rays all see one surface factors exactly
            // (E is averaged over the hits: `PathRecord::w_env_missed`), so the raw test is not noisy
            // and a median would only turn pixels that see two surfaces to k·Ē.
            let flag = factor_flags(
                ctx,
                &format!("{}_flag", part.name),
                part,
                (SamplerPass::Final, Stage::Factor),
                true,
                false,
                Reference::Fill(0),
            )?;
            let e = ctx.sampler_output(SamplerPass::Final, part.irradiance)?;
            // A glossy part's irradiance depends on the direction it is seen from, which the history
            // pass does not know (it matches world positions): under a moving camera the previous
            // frame's glossy light is another reflection. Only the diffuse parts join the history.
            filter.temporal = temporal && !view_dependent;
            let e = filter.apply(ctx, part.name, e, *bw);
            let (l, k) = (
                ctx.sampler_output(SamplerPass::Final, part.radiance)?,
                ctx.sampler_output(SamplerPass::Final, part.texture)?,
            );
            terms.push((part, PartTerms { l, k, e, flag }));
        }
        let emission = if ctx.param("emission").as_bool() == Some(true) {
            Some(ctx.sampler_output(SamplerPass::Final, "emission")?)
        } else {
            None
        };
        compose_component(ctx, &terms, emission, width, rays);
        ctx.output("bandwidth", bandwidth);
        ctx.output("curvature", magnitude);
        Ok(())
    }
}

/// The screen-space curvature of eq. 6.20 (`environment.curvature`, pass `curvature`) from
/// `position` and `normal`: per axis (`curvature_xy`) and its magnitude for the heatmap (`curvature`).
pub(crate) fn curvature_pass(ctx: &mut ExpandCtx<'_>, position: BufferId, normal: BufferId) -> (BufferId, BufferId) {
    let (curvature, magnitude) = (ctx.buffer("curvature_xy", Format::Vec2), ctx.buffer("curvature", Format::F32));
    let io = CurvatureIo { position, normal, curvature, magnitude: Some(magnitude) };
    io.bind(ctx.pass("curvature", "environment.curvature", Stage::Bandwidth)).finish();
    (curvature, magnitude)
}

/// Whether the node's look-ups may follow its filters anywhere (`adaptive` other than `"off"`).
fn adapts(ctx: &ExpandCtx<'_>) -> bool {
    !matches!(ctx.param("adaptive"), ParamValue::Str(s) if s == AdaptiveLookUps::Off.as_str())
}

/// The parameters that have no meaning for a factored component, with why: refused at any value but
/// their default, so nothing a pipeline states is silently ignored.
const NOT_FACTORED: [(&str, &str); 2] = [
    ("indirect", "the indirect light is the Indirect node's component: wire an Indirect node's radiance to the factoring node's `indirect`"),
    ("temporal", "the factoring node's paths are not reprojected across frames"),
];

/// Under a factoring node (thesis Ch. 5, App. B; [`wedge_graph::factoring`]): the environment's
/// direct light as one factored component with two parts — diffuse and glossy, as Ch. 6 keeps them
/// — which the factoring node renders ([`wedge_graph::NodeKind::expand_component`]). Its statistic is
/// Ch. 6's bandwidth of the direct light (eqs. 6.13/6.17 from the curvature 6.20, the occluder term
/// and `B_e`; the glossy part's where the receiver is glossy, the larger axis) on the factoring
/// node's first pass, at μ = 1 (the factoring node's μ scales the widths it derives); its look-ups
/// per primary ray are `per_primary`. Where `adaptive` applies, its paths are at least
/// `look_ups / per_primary` (the node's rule, `primary × per_primary` look-ups grown as σ_ref² / σ²,
/// with σ at the factoring node's μ). `max_radius` caps the component's irradiance filter where it is
/// below the factoring node's ([`Component::irradiance_radius`]). `mu` and `emission` do not apply (the
/// factoring node's μ, and the emission it adds once); `indirect` and `temporal` are refused ([`NOT_FACTORED`]).
fn expand_factored(ctx: &mut ExpandCtx<'_>, f: &Factoring) -> Result<(), GraphError> {
    refuse_not_factored(ctx, &format!("under the factoring node `{}` ({})", f.node, f.kind))?;
    let settings = sampled_settings(ctx);
    let mut request = SamplerRequest::new().estimator("environment");
    for (n, v) in &settings {
        request = request.setting(n, v.clone());
    }
    ctx.sampler(request)?;
    let bandlimit = first_pass_bandlimit(ctx, f)?;
    ctx.component(&Component {
        name: "environment",
        estimator: "environment",
        settings,
        statistic: ("bandlimit", Statistic::Buffer(bandlimit)),
        rate_params: vec![("environment_per_primary", ctx.param("per_primary").clone())],
        parts: DIRECT_PARTS.iter().map(|p| p.part.clone()).collect(),
        // Its own window (8 px, measured better than the thesis's 15 alone: docs/RESULTS.md "The
        // Environment filter's window") caps the factoring node's for its irradiance.
        max_radius: match ctx.param("max_radius") {
            ParamValue::Int(r) => Some(*r),
            _ => None,
        },
    })
}

/// [`NOT_FACTORED`] at any value but its default, refused: the node renders `under` (e.g. "under
/// the factoring node `dof` (Defocus)") as a component on the shared sampler's paths.
fn refuse_not_factored(ctx: &ExpandCtx<'_>, under: &str) -> Result<(), GraphError> {
    let declared = Environment.params();
    for (name, why) in NOT_FACTORED {
        let default = declared.iter().find(|d| d.name == name).map(|d| d.default_value());
        let value = ctx.param(name);
        if default.as_ref() != Some(value) {
            return Err(GraphError::Expand {
                node: ctx.node().into(),
                message: format!(
                    "`{name}: {value}` does not apply {under}: {why}; remove it (docs/NODES.md \"Composing effects\")"
                ),
            });
        }
    }
    Ok(())
}

/// The environment estimator's settings as a component samples it: one look-up per path, as Ch. 5
/// takes one shadow ray and one indirect sample.
fn sampled_settings(ctx: &ExpandCtx<'_>) -> Vec<(&'static str, ParamValue)> {
    vec![
        ("environment_per_primary", ParamValue::Int(1)),
        ("occluder_threshold", ctx.param("occluder_threshold").clone()),
        ("environment_glossy", ctx.param("glossy_sampling").clone()),
    ]
}

/// Through the `camera:` block's lens or shutter with no factoring node: the plain Monte Carlo
/// image of the map's direct light ([`crate::plain_camera`]), with what camera rays see directly
/// where `emission`; `bandwidth` and `curvature` are 0 (nothing is filtered).
fn expand_plain(ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
    refuse_not_factored(ctx, "through the `camera:` block's lens or shutter without a Defocus or Motion node")?;
    let parts: Vec<Part> = DIRECT_PARTS.iter().map(|p| p.part.clone()).collect();
    let emission = ctx.param("emission").as_bool() == Some(true);
    let c = crate::plain_camera::PlainComponent {
        estimator: "environment",
        settings: sampled_settings(ctx),
        parts: &parts,
        emission,
    };
    crate::plain_camera::expand(ctx, &c)?;
    for port in ["bandwidth", "curvature"] {
        let zero = ctx.buffer(port, Format::F32);
        FillF32Io { out: zero }.bind(ctx.pass(port, "fill.constant_f32", Stage::Compose)).float("value", 0.0).finish();
        ctx.output(port, zero);
    }
    Ok(())
}

/// Ch. 6's bandwidth of the direct light per pixel on the first pass (1/m, μ = 1), the larger of
/// its axes; at least the widest filter the factoring node's `max_radius` holds (the window floor
/// that keeps μ consistent: [`super::formulas::window_bandwidth`]). Binds the node's `bandwidth` and
/// `curvature` heatmap ports from the same passes; where `adaptive` applies, the same pass writes
/// the node's look-up count and the node asks the sampler for its paths.
fn first_pass_bandlimit(ctx: &mut ExpandCtx<'_>, f: &Factoring) -> Result<BufferId, GraphError> {
    let position = ctx.sampler_output(SamplerPass::First, "position")?;
    let normal = ctx.sampler_output(SamplerPass::First, "normal")?;
    let stats = ctx.sampler_output(SamplerPass::First, "environment")?;
    let (curvature, magnitude) = curvature_pass(ctx, position, normal);
    let (bandlimit, bandwidth) = (ctx.buffer("bandlimit", Format::F32), ctx.buffer("bandwidth", Format::F32));
    let rays = adapts(ctx).then(|| ctx.buffer("look_ups", Format::U32));
    let io = BandwidthIo {
        bandlimit: Some(bandlimit),
        bandwidth: Some(bandwidth),
        rays,
        ..BandwidthIo::inputs(curvature, stats, normal, None)
    };
    let per_primary = count(ctx, "per_primary");
    let base = count(ctx, "primary") * per_primary;
    io.bind(ctx.pass("bandwidth", "environment.bandwidth", Stage::Bandwidth))
        .node_params(&["b_e", "adaptive", "sigma_ref", "max_rays"])
        .float("mu", 1.0)
        .param("count_mu", f.setting("mu").cloned().unwrap_or(ParamValue::Float(1.0)))
        .param("max_radius", f.setting("max_radius").cloned().unwrap_or(ParamValue::Int(16)))
        .int("base", base)
        .reference(Reference::Keep)
        .finish();
    // Where `adaptive` applies, paths of `per_primary` look-ups each until the pixel has Algorithm 1's
    // look-ups grown as its filter narrows — the node's own rule, with the widths at the factoring
    // node's μ (`count_mu`), so the count grows as that μ narrows the filters: a glossy receiver in
    // focus or still, which the factoring node's rates give one path, gets the paths its glossy
    // reflection needs at every μ.
    if let Some(rays) = rays {
        ctx.sampler_counts(CountRequest {
            paths: Some(rays),
            paths_unit: per_primary as u32,
            per_primary: vec![],
            max3: false,
            beyond_first: false,
        })?;
    }
    ctx.output("bandwidth", bandwidth);
    ctx.output("curvature", magnitude);
    Ok(bandlimit)
}

/// The Ch. 6 filter of one irradiance as the node runs it (the MixedReality node filters its
/// irradiances with it too).
pub(crate) struct PartFilter {
    pub position: BufferId,
    pub normal: BufferId,
    pub max_radius: ParamValue,
    pub max_motion: ParamValue,
    pub normal_cos: ParamValue,
    pub temporal: bool,
}

impl PartFilter {
    /// `filter.environment` along x then y on `e` with `bandwidth`, passes `<name>_x`, `<name>_y`;
    /// with `temporal`, `filter.environment_history` (`<name>_history`) on the previous frame's `e`,
    /// positions, normals and bandwidths joins the y pass. A reference bypasses the filters (and the
    /// history pass, which then feeds nothing, is culled).
    pub fn apply(&self, ctx: &mut ExpandCtx<'_>, name: &str, e: BufferId, bandwidth: BufferId) -> BufferId {
        let history = self.temporal.then(|| {
            let out = ctx.buffer(&format!("{name}_history"), Format::Vec4);
            let previous = [e, self.position, self.normal, bandwidth].map(|b| ctx.previous_frame(b));
            let io = HistoryIo {
                position: self.position,
                normal: self.normal,
                bandwidth,
                previous_value: previous[0],
                previous_position: previous[1],
                previous_normal: previous[2],
                previous_bandwidth: previous[3],
                out,
            };
            io.bind(ctx.pass(&format!("{name}_history"), "filter.environment_history", Stage::Factor))
                // Eq. 6.24 filters the previous frame along x.
                .int("axis", 0)
                .param("max_radius", self.max_radius.clone())
                .param("max_motion", self.max_motion.clone())
                .param("normal_cos", self.normal_cos.clone())
                .finish();
            out
        });
        let mut value = e;
        for (axis, suffix) in [(0, "x"), (1, "y")] {
            let local = format!("{name}_{suffix}");
            let out = ctx.buffer(&local, Format::Vec3);
            let (position, normal, previous) = (self.position, self.normal, if axis == 1 { history } else { None });
            EnvironmentFilterIo { value, position, normal, bandwidth, previous, out }
                .bind(ctx.pass(&local, "filter.environment", Stage::Filter))
                .int("axis", axis)
                .param("max_radius", self.max_radius.clone())
                .param("normal_cos", self.normal_cos.clone())
                .reference(Reference::Bypass { input: "value" })
                .finish();
            value = out;
        }
        value
    }
}
