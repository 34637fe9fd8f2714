//! The `Indirect` node: its ports, light terms and parameters, and the passes it adds — on its own
//! (the shared sampler's centre path, statistics, bandwidth, rates, the sampler's adaptive paths,
//! a separable filter per component, compose) or as a factoring node's component.

use wedge_backends::kernels::indirect::ComposeIo;
use wedge_backends::kernels::neighbourhood_others::OthersIo;
use wedge_backends::KernelParams;
use wedge_graph::{
    Component, CountRequest, ExpandCtx, Format, GraphError, NodeKind, ParamDecl, ParamValue, Part, PerPrimary,
    PortDecl, Reference, SamplerPass, SamplerRequest, Stage, Statistic,
};

use super::kernels::{BandwidthIo, NearestIo, RateParams, RatesIo};
use crate::filtering::{self, Separable};
use crate::sampler::centre_path;

pub struct Indirect;

/// Under a factoring node (thesis Ch. 5, App. B; [`wedge_graph::factoring`]): indirect light as one
/// factored component with two parts — diffuse (`k = k_d`) and glossy (`k = k_s`, E the lobe-weighted
/// incident radiance; eq. 5.21 keeps them apart) — which the factoring node renders
/// ([`wedge_graph::NodeKind::expand_component`]). Its rates read the first pass's reflector depths;
/// `Ω_v^max` is the diffuse receiver's 2.8 (Ch. 4, eq. 4.18) for both parts: a reading — the thesis
/// gives one `Ω_v^max` per pixel and glossy receivers would take `4.27 + 0.15 m`, which the per-pixel
/// rate kernels do not see. The Ch. 4 parameters (`mu`, `alpha`, rays and filter settings) do not
/// apply; `bounces` and `brdf` set the sampler's hemisphere estimator.
///
/// Ambient occlusion (`mode: "ao"`) is one part, `occlusion`, with texture 1 (`paths.trace` under
/// `ao`: `L = E` = the occluded fraction, so it always factors): the factoring node filters it in
/// world space with the indirect component's width and counts (its occluders are reflectors at the
/// same depths), then blurs it through the lens or over the shutter — the AO image a camera with
/// that lens or shutter would see. Its terms say it is not light, so the factoring node adds no
/// emission to it ([`crate::factored::seen_directly`]).
fn expand_factored(ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
    let (settings, parts) = sampled_component(ctx, true);
    // The statistic reads the first pass: ask for the estimator now (the factoring node asks again
    // with the component; identical requests merge).
    let mut request = SamplerRequest::new().estimator("hemisphere");
    for (n, v) in &settings {
        request = request.setting(n, v.clone());
    }
    ctx.sampler(request)?;
    let statistic = reflectors(ctx, SamplerPass::First)?;
    ctx.component(&Component {
        name: "indirect",
        estimator: "hemisphere",
        settings,
        statistic: ("reflectors", Statistic::Buffer(statistic)),
        rate_params: vec![],
        max_radius: None,
        parts,
    })
}

/// The hemisphere estimator's settings and the component's parts: AO's one part `occlusion`, or
/// the diffuse part and, where `glossy`, the glossy one. `ao` is stated either way, so that radiance
/// and AO on one sampler conflict (named) rather than one silently becoming the other.
fn sampled_component(ctx: &ExpandCtx<'_>, glossy: bool) -> (Vec<(&'static str, ParamValue)>, Vec<Part>) {
    let ao = matches!(ctx.param("mode"), ParamValue::Str(m) if m == "ao");
    let settings = vec![
        ("bounces", ctx.param("bounces").clone()),
        ("brdf", ctx.param("brdf").clone()),
        ("ao", ParamValue::Bool(ao)),
        ("max_distance", ctx.param("max_distance").clone()),
    ];
    let diffuse = |name| Part { name, radiance: "l_diffuse", texture: "k_diffuse", irradiance: "e_diffuse" };
    let glossy_part = Part { name: "glossy", radiance: "l_glossy", texture: "k_glossy", irradiance: "e_glossy" };
    let parts = match (ao, glossy) {
        (true, _) => vec![diffuse("occlusion")],
        (false, true) => vec![diffuse("diffuse"), glossy_part],
        (false, false) => vec![diffuse("diffuse")],
    };
    (settings, parts)
}

/// The reflector depths (`z_min, z_max`, hits, rays) a pixel's rates and width read: its own first
/// pass's (`statistics: "own"`, the thesis), or its eight neighbours' (`"neighbours"`,
/// `neighbourhood.others`), which leaves the pixel's own samples out so that its count and width do
/// not depend on the values its estimate reuses. That correlation is a bias where a first pass
/// often sees no reflector: ambient occlusion under a factoring node lost 11% of its mean on the
/// `motion` scene with its own statistics — the pixels whose first rays hit were filtered widely
/// into zeros, the ones that saw nothing kept their zero (docs/DESIGN-NOTES.md "Ambient occlusion under a lens or shutter").
fn reflectors(ctx: &mut ExpandCtx<'_>, pass: SamplerPass) -> Result<wedge_graph::BufferId, GraphError> {
    let own = ctx.sampler_output(pass, "depth")?;
    if !matches!(ctx.param("statistics"), ParamValue::Str(m) if m == "neighbours") {
        return Ok(own);
    }
    let position = ctx.sampler_output(pass, "position")?;
    let others = ctx.buffer("depth_neighbours", Format::Vec4);
    OthersIo { value: own, position, out: others }
        .bind(ctx.pass("statistics", "neighbourhood.others", Stage::Bandwidth))
        .finish();
    Ok(others)
}

impl NodeKind for Indirect {
    fn kind(&self) -> &'static str {
        "Indirect"
    }
    fn doc(&self) -> &'static str {
        "Axis-aligned filtering of diffuse and glossy indirect light (path traced, multi-bounce) or ambient occlusion (Mehta thesis Ch. 4)"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        vec![
            PortDecl::new("position", Format::Vec4, "from Primary"),
            PortDecl::new("normal", Format::Vec4, "from Primary (w = pixel footprint d)"),
            PortDecl::optional("albedo", Format::Vec3, "k_d, multiplied after filtering; white if absent"),
            PortDecl::optional(
                "specular",
                Format::Vec4,
                "k_s and Phong exponent (w) from Primary; no glossy component if absent",
            ),
        ]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![
            PortDecl::new(
                "radiance",
                Format::Vec3,
                "filtered indirect light (k_d diffuse + k_s glossy); AO mode: the filtered unoccluded fraction",
            ),
            PortDecl::new("unfiltered", Format::Vec3, "the adaptive-sampled estimate before filtering"),
            PortDecl::new("filter_width", Format::F32, "diffuse filter std-dev β in pixels (0 = not filtered)"),
            PortDecl::new(
                "rays_per_pixel",
                Format::U32,
                "hemisphere samples (paths) per pixel, both components and passes (eq. 4.21)",
            ),
        ]
    }
    /// Indirect light (diffuse, and glossy where `specular` is wired) or ambient occlusion, through
    /// the shared sampler's camera.
    fn terms(&self, port: &str, q: &wedge_graph::TermQuery<'_>) -> Option<wedge_graph::Terms> {
        let lobes = if q.is_connected("specular") { "diffuse+glossy" } else { "diffuse" };
        matches!(port, "radiance" | "unfiltered")
            .then(|| crate::light_terms::indirect_or_ao(q, q.sampler_view(), lobes))
    }
    fn params(&self) -> Vec<ParamDecl> {
        vec![
            crate::params::mu(0.9, "μ: scales the filter bandwidth (eq. 4.15); larger = narrower filter, more rays (eq. 4.21)"),
            crate::params::brdf("glossy lobe of k_s, m: Phong (A.5) or Blinn-Phong (4.18, A.3)"),
        ]
        .into_iter()
        .chain(RateParams::decls())
        .chain([
            ParamDecl::int("bounces", 1, 1, 64, "path vertices beyond the primary hit with next-event estimation (1 = one-bounce indirect)"),
            ParamDecl::choice("mode", "radiance", &["radiance", "ao"], "indirect radiance, or ambient occlusion (a hit reflector returns 1)"),
            ParamDecl::float("max_distance", 0.0, 0.0, 1e9, "AO: hits farther than this are misses (0 = no limit)"),
            ParamDecl::choice(
                "statistics",
                "neighbours",
                &["own", "neighbours"],
                "z_min, z_max for eqs. 4.15–4.21 from the pixel's own first pass (thesis), or from its eight neighbours' (leaves its own samples out: no correlation between a pixel's estimate and its count or width; also the indirect or AO component's statistic under a factoring node)",
            ),
            ParamDecl::choice(
                "width_z_min",
                "nearest",
                &["statistics", "nearest"],
                "z_min of the filter width (eq. 4.15): the nearest reflector the eight neighbours' first passes saw, unclamped (narrower where reflectors are near), or the rates' statistics, clamped (thesis); the rates are unchanged; not with factoring",
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
            // The glossy part where `specular` is wired, as its terms say; the sampler traces no
            // glossy samples otherwise (the pinhole node's rule).
            let (mut settings, parts) = sampled_component(ctx, ctx.input("specular").is_some());
            settings.push(("glossy", ParamValue::Bool(parts.len() == 2)));
            let c = crate::plain_camera::PlainComponent {
                estimator: "hemisphere",
                settings,
                parts: &parts,
                emission: false,
            };
            return crate::plain_camera::expand(ctx, &c);
        }
        let position = ctx.required("position")?;
        let normal = ctx.required("normal")?;
        let ao = matches!(ctx.param("mode"), ParamValue::Str(m) if m == "ao");
        let albedo = if ao { None } else { ctx.input("albedo") };
        let specular = if ao { None } else { ctx.input("specular") };
        let glossy = specular.is_some();
        // The shared sampler's first pass: one path through the pixel centre with `initial_rays`
        // stratified hemisphere samples per part (Ch. 4's first pass); its first-hit distances
        // `z_min, z_max` feed eqs. 4.15–4.21.
        let (first, per_path) =
            centre_path(ctx.node(), "hemisphere", "indirect_per_primary", ctx.param("initial_rays"))?;
        ctx.sampler(
            first
                .setting("bounces", ctx.param("bounces").clone())
                .setting("brdf", ctx.param("brdf").clone())
                .setting("ao", ParamValue::Bool(ao))
                .setting("glossy", ParamValue::Bool(glossy))
                .setting("max_distance", ctx.param("max_distance").clone()),
        )?;
        let own_depth = ctx.sampler_output(SamplerPass::First, "depth")?;
        // `statistics: "neighbours"`: each pixel's z_min, z_max from its eight neighbours' first
        // passes, so its count and width do not depend on the samples its estimate reuses.
        let depth = if matches!(ctx.param("statistics"), ParamValue::Str(m) if m == "neighbours") {
            let others = ctx.buffer("depth_neighbours", Format::Vec4);
            let io = OthersIo { value: own_depth, position, out: others };
            io.bind(ctx.pass("statistics", "neighbourhood.others", Stage::Bandwidth)).finish();
            others
        } else {
            own_depth
        };

        // `width_z_min: "nearest"`: the width's z_min from the neighbourhood's nearest reflector.
        let nearest = matches!(ctx.param("width_z_min"), ParamValue::Str(m) if m == "nearest").then(|| {
            let nearest = ctx.buffer("nearest", Format::F32);
            let io = NearestIo { depth: own_depth, position, nearest };
            io.bind(ctx.pass("nearest", "indirect.nearest", Stage::Bandwidth)).finish();
            nearest
        });
        let beta_d = ctx.buffer("beta_diffuse", Format::F32);
        let beta_g = ctx.buffer("beta_glossy", Format::F32);
        let width_px = ctx.buffer("filter_width", Format::F32);
        let io = BandwidthIo {
            depth,
            normal,
            specular,
            nearest,
            beta_diffuse: beta_d,
            beta_glossy: glossy.then_some(beta_g),
            filter_width: width_px,
        };
        let pass = io.bind(ctx.pass("bandwidth", "indirect.bandwidth", Stage::Bandwidth));
        pass.node_params(RateParams::names()).finish();

        let rays_d = ctx.buffer("rays_diffuse", Format::U32);
        let rays_g = ctx.buffer("rays_glossy", Format::U32);
        let rays = ctx.buffer("rays_per_pixel", Format::U32);
        let io = RatesIo {
            depth,
            normal,
            specular,
            rays_diffuse: rays_d,
            rays_glossy: glossy.then_some(rays_g),
            rays_per_pixel: rays,
        };
        let pass = io.bind(ctx.pass("rates", "indirect.rates", Stage::Bandwidth));
        pass.node_params(RateParams::names()).reference(Reference::Count).finish();

        // eq. 4.21's n per part over both passes, exactly: the sampler traces the rest on paths of
        // about `initial_rays` (the camera ray is fixed, so every sample of a part weighs the same).
        let mut per_primary = vec![("diffuse".to_string(), PerPrimary::Spread { total: rays_d, unit: per_path })];
        if glossy {
            per_primary.push(("glossy".to_string(), PerPrimary::Spread { total: rays_g, unit: per_path }));
        }
        ctx.sampler_counts(CountRequest { paths: None, paths_unit: 1, per_primary, max3: false, beyond_first: false })?;
        // The sampler's final estimates per part: mean E (k_d, k_s left out), w = samples.
        let noisy_d = ctx.sampler_output(SamplerPass::Final, "diffuse")?;
        let noisy_g = if glossy { Some(ctx.sampler_output(SamplerPass::Final, "glossy")?) } else { None };

        // Full 3-D distances (Ch. 4 has no light plane); each component with its own β.
        let filter = |ctx: &mut ExpandCtx<'_>, prefix: &str, value, bandwidth| {
            filtering::separable(ctx, prefix, value, &Separable { position, normal, bandwidth, plane_light: None })
        };
        let filtered_d = filter(ctx, "diffuse_", noisy_d, beta_d);
        let filtered_g = noisy_g.map(|g| filter(ctx, "glossy_", g, beta_g));

        for (pass, d, g, port) in
            [("compose", filtered_d, filtered_g, "radiance"), ("compose_unfiltered", noisy_d, noisy_g, "unfiltered")]
        {
            let out = ctx.buffer(port, Format::Vec3);
            let io = ComposeIo { diffuse: d, glossy: g, direct: None, albedo, specular, emission: None, out };
            io.bind(ctx.pass(pass, "indirect.compose", Stage::Compose)).finish();
            ctx.output(port, out);
        }
        ctx.output("filter_width", width_px);
        ctx.output("rays_per_pixel", rays);
        Ok(())
    }
}
