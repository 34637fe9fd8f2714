//! The `SoftShadows` node: its ports, light terms and parameters, and the passes it adds — on its
//! own (the shared sampler's centre path, fill, bandwidth, rates, the sampler's adaptive paths, the
//! separable filter, shade and compose) or as a factoring node's component.

use wedge_graph::{
    BufferId, Component, CountRequest, ExpandCtx, Format, GraphError, NodeKind, ParamDecl, ParamValue, Part,
    PerPrimary, PortDecl, Reference, SamplerPass, SamplerRequest, Stage, Statistic,
};

use wedge_backends::kernels::compose::ModulateIo;
use wedge_backends::kernels::neighbourhood_fill::FillIo;
use wedge_backends::KernelParams;

use super::kernels::{BandwidthIo, BandwidthParams, RateParams, RatesIo, ShadeIo, VisibilityIo};
use crate::filtering::{self, Separable};
use crate::plain_camera::PlainComponent;
use crate::sampler::centre_path;

pub struct SoftShadows;

/// The direct component's one factored part on the shared sampler (eqs. 5.9–5.14).
const DIRECT_PART: Part = Part { name: "direct", radiance: "l_direct", texture: "k_direct", irradiance: "e_direct" };

impl NodeKind for SoftShadows {
    fn kind(&self) -> &'static str {
        "SoftShadows"
    }
    fn doc(&self) -> &'static str {
        "Axis-aligned filtering of area-light soft shadows with adaptive sampling (Mehta thesis Ch. 3)"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        vec![
            PortDecl::new("position", Format::Vec4, "from Primary"),
            PortDecl::new("normal", Format::Vec4, "from Primary (w = pixel footprint d)"),
            PortDecl::optional("albedo", Format::Vec3, "texture, multiplied after filtering; white if absent"),
            PortDecl::optional("emission", Format::Vec3, "added after filtering")
                .accepts(crate::light_terms::EMISSION_INPUT),
        ]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![
            PortDecl::new("radiance", Format::Vec3, "filtered direct light × albedo + emission"),
            PortDecl::new("unfiltered", Format::Vec3, "the adaptive-sampled estimate before filtering"),
            PortDecl::new("filter_width", Format::F32, "filter std-dev β in pixels (0 = not filtered)"),
            PortDecl::new(
                "rays_per_pixel",
                Format::U32,
                "shadow rays per pixel, both passes (eq. 3.21; traced in paths of initial_rays, rounded up)",
            ),
        ]
    }
    /// Direct light of its one area light, through the shared sampler's camera (times the albedo:
    /// the diffuse lobe; as a factoring node's component, or through the camera block's lens or
    /// shutter, the sampler's `L` with the glossy lobe toward the light centre too, eq. 5.20);
    /// without a factoring node also the emission where `emission` is wired — the wired image
    /// through a pinhole, what the sampler's camera rays see through the block's lens or shutter
    /// (a factoring node adds emission once itself).
    fn terms(&self, port: &str, q: &wedge_graph::TermQuery<'_>) -> Option<wedge_graph::Terms> {
        use crate::light_terms::{lobes, seen_directly};
        let light = u32::try_from(q.int("light")?).ok()?;
        let sampled = q.factored() || q.plain_camera();
        let lobes = if sampled { lobes::TOWARD_LIGHT_CENTRE } else { lobes::DIFFUSE };
        let term =
            wedge_graph::Term::new(wedge_graph::TermKind::DirectArea, q.sampler_view()).light(light).detail(lobes);
        let direct = wedge_graph::Terms::new().with(term);
        matches!(port, "radiance" | "unfiltered").then(|| match (q.factored(), q.plain_camera()) {
            (true, _) => direct,
            (false, true) if q.is_connected("emission") => direct.plus(Some(&seen_directly(q.sampler_view()))),
            (false, true) => direct,
            (false, false) => direct.plus(q.input("emission")),
        })
    }
    fn params(&self) -> Vec<ParamDecl> {
        std::iter::once(crate::params::mu(
            2.0,
            "μ: scales the filter bandwidth; larger = narrower filter, more rays (eq. 3.21)",
        ))
        .chain(BandwidthParams::decls())
        .chain(RateParams::decls())
        .chain([
            ParamDecl::int("fill_radius", 5, 0, 64, "radius (pixels) for averaging d1, d2 into unoccluded pixels (also under a factoring node; 0 there: the thesis's Ch. 5, own statistics only)"),
            crate::params::form_factor("exact", "per-sample geometry term (unbiased), or the thesis's light-centre approximation r(x)"),
            ParamDecl::choice(
                "irradiance",
                "analytic",
                &["analytic", "sampled"],
                "filter the visibility E/U and multiply by the closed-form unoccluded irradiance (eq. 3.1's r(x) exact), or filter the sampled E itself",
            ),
        ])
        .chain(filtering::params())
        .chain([crate::plain_camera::paths_param()])
        .collect()
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        if ctx.factoring().is_some() {
            return expand_factored(ctx);
        }
        if ctx.plain_camera() {
            let settings =
                vec![("light", ctx.param("light").clone()), ("form_factor", ctx.param("form_factor").clone())];
            let emission = ctx.input("emission").is_some();
            let c = PlainComponent { estimator: "light", settings, parts: &[DIRECT_PART], emission };
            return crate::plain_camera::expand(ctx, &c);
        }
        let position = ctx.required("position")?;
        let normal = ctx.required("normal")?;
        let (albedo, emission) = (ctx.input("albedo"), ctx.input("emission"));
        let light = ctx.param("light").clone();

        // The shared sampler's first pass: n_p = 1 path through the pixel centre with `initial_rays`
        // stratified light samples (Ch. 3's first pass); its occluder statistics feed eq. 3.13/3.21.
        let (first, per_path) = centre_path(ctx.node(), "light", "shadow_per_primary", ctx.param("initial_rays"))?;
        ctx.sampler(first.setting("light", light.clone()).setting("form_factor", ctx.param("form_factor").clone()))?;
        let occlusion = ctx.sampler_output(SamplerPass::First, "occlusion")?;
        let filled = fill(ctx, occlusion, position);

        let beta = ctx.buffer("beta", Format::F32);
        let width_px = ctx.buffer("filter_width", Format::F32);
        BandwidthIo { occlusion: filled, normal, beta, filter_width: width_px }
            .bind(ctx.pass("bandwidth", "shadows.bandwidth", Stage::Bandwidth))
            .node_params(BandwidthParams::names())
            .finish();

        let rays = ctx.buffer("rays_per_pixel", Format::U32);
        RatesIo { occlusion: filled, normal, rays_per_pixel: rays }
            .bind(ctx.pass("rates", "shadows.rates", Stage::Bandwidth))
            .node_params(RateParams::names())
            .reference(Reference::Count)
            .finish();

        // eq. 3.21's n shadow rays per pixel over both passes, exactly: the sampler traces the rest on
        // paths of about `initial_rays` (the camera ray is fixed, so every shadow ray weighs the same).
        ctx.sampler_counts(CountRequest {
            paths: None,
            paths_unit: 1,
            per_primary: vec![("light".into(), PerPrimary::Spread { total: rays, unit: per_path })],
            max3: false,
            beyond_first: false,
        })?;
        // The sampler's final direct estimate: mean E (unit albedo), w = shadow rays.
        let noisy = ctx.sampler_output(SamplerPass::Final, "direct")?;

        // Distances in the plane parallel to the light (eq. 3.12).
        let filter = Separable { position, normal, bandwidth: beta, plane_light: Some(light.clone()) };
        let filtered = if matches!(ctx.param("irradiance"), ParamValue::Str(m) if m == "analytic") {
            // Eq. 3.1/3.10: h(x) = r(x) · (filtered visibility). The visibility is the ratio
            // estimate E/U over the same samples (U: each counted as unblocked), filtered as the
            // pair (ΣE, ΣU) so a neighbour weighs by its unshadowed light; r(x) is the closed-form
            // unoccluded irradiance. Both passes are reconstruction (`Bypass` to E): a reference
            // stays plain Monte Carlo.
            let unshadowed = ctx.sampler_output(SamplerPass::Final, "direct_unshadowed")?;
            let pair = ctx.buffer("visibility", Format::Vec4);
            VisibilityIo { direct: noisy, unshadowed, out: pair }
                .bind(ctx.pass("visibility", "shadows.visibility", Stage::Filter))
                .reference(Reference::Bypass { input: "direct" })
                .finish();
            let pair = filtering::separable(ctx, "", pair, &filter);
            let shaded = ctx.buffer("shaded", Format::Vec4);
            ShadeIo { direct: noisy, visibility: pair, position, normal, out: shaded }
                .bind(ctx.pass("shade", "shadows.shade", Stage::Filter))
                .param("light", light.clone())
                .reference(Reference::Bypass { input: "direct" })
                .finish();
            shaded
        } else {
            filtering::separable(ctx, "", noisy, &filter)
        };

        for (pass, value, port) in [("compose", filtered, "radiance"), ("compose_unfiltered", noisy, "unfiltered")] {
            let out = ctx.buffer(port, Format::Vec3);
            let io = ModulateIo { value, albedo, emission, out };
            io.bind(ctx.pass(pass, "compose.modulate", Stage::Compose)).finish();
            ctx.output(port, out);
        }
        ctx.output("filter_width", width_px);
        ctx.output("rays_per_pixel", rays);
        Ok(())
    }
}

/// Under a factoring node (thesis Ch. 5, App. B; [`wedge_graph::factoring`]): the direct light of
/// area light `light` as one factored component, which the factoring node renders
/// ([`wedge_graph::NodeKind::expand_component`]: SepDir flags, the irradiance filter width and counts
/// of its chapter, the composed term `radiance` carries to it; albedo is the factored `k`, emission is
/// added there). Of the Ch. 3 parameters only `fill_radius` applies ([`filled_occluders`]); `mu`,
/// `alpha`, `k`, `initial_rays`, `max_rays` and `form_factor` do not: the factoring node's settings
/// do; `position`, `normal`, `albedo` and `emission` inputs are not read (the sampler's
/// path-averaged values are).
fn expand_factored(ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
    let light = ctx.param("light").clone();
    let settings = vec![("light", light.clone())];
    // The statistic reads the first pass: ask for the estimator now (the factoring node asks again
    // with the component; identical requests merge).
    ctx.sampler(SamplerRequest::new().estimator("light").setting("light", light.clone()))?;
    let statistic = filled_occluders(ctx)?;
    ctx.component(&Component {
        name: "direct",
        estimator: "light",
        settings,
        statistic: ("occlusion", statistic),
        rate_params: vec![("light", light)],
        max_radius: None,
        parts: vec![DIRECT_PART],
    })
}

/// The occluder statistics (`d1`, `d2_min`, `d2_max`, occluded rays) the component's width and
/// counts read: the first pass's, where a pixel's paths saw no occluder filled with the averages of
/// its neighbours' on the same object within `fill_radius` pixels — Ch. 3 Sec. 3.6's fill, as the
/// pinhole node does. Without it a penumbra pixel whose few first-pass paths all missed the occluder
/// has no light term, so eq. 5.18 gives it the narrowest filter (`Ω_pix^max`) and the mutual
/// rejection keeps its wider neighbours from reaching it (docs/DESIGN-NOTES.md "Occluders filled
/// under a factoring node"). `fill_radius: 0` reads the pixel's own statistics (the thesis's Ch. 5).
fn filled_occluders(ctx: &mut ExpandCtx<'_>) -> Result<Statistic, GraphError> {
    if matches!(ctx.param("fill_radius"), ParamValue::Int(0)) {
        return Ok(Statistic::Sampler("occlusion"));
    }
    let occlusion = ctx.sampler_output(SamplerPass::First, "occlusion")?;
    let position = ctx.sampler_output(SamplerPass::First, "position")?;
    Ok(Statistic::Buffer(fill(ctx, occlusion, position)))
}

/// Pass `fill` (`neighbourhood.fill`, radius `fill_radius`): the occluder statistics `occlusion`
/// with each pixel that has none given its neighbours' averages on the same object (`position.w`).
fn fill(ctx: &mut ExpandCtx<'_>, occlusion: BufferId, position: BufferId) -> BufferId {
    let (radius, out) = (ctx.param("fill_radius").clone(), ctx.buffer("occlusion_filled", Format::Vec4));
    FillIo { value: occlusion, position, out }
        .bind(ctx.pass("fill", "neighbourhood.fill", Stage::Bandwidth))
        .param("radius", radius)
        .finish();
    out
}
