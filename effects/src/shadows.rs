//! `SoftShadows`: axis-aligned filtering of area-light soft shadows (Mehta thesis Ch. 3,
//! `seeds/000_956e982470d7e5bf.txt`; `docs/EQUATIONS.md` "SoftShadows").
//!
//! Sampling is the shared sampler's ([`crate::sampler`], `docs/SAMPLER-STAGE.md` §4): the node asks
//! it for the `light` estimator with the Ch. 3 constants — one primary path per pixel through the
//! centre (`n_p = 1`), `initial_rays` (8; the thesis's 9 = 3×3 is not a stratified prefix of the
//! sampler's base-2 sequence; measured in docs/SAMPLER-STAGE.md §4) stratified light samples on it, `light`, `form_factor` —
//! and reads the first pass's occluder statistics `d1, d2_min, d2_max`. Its own passes:
//! `fill` (unoccluded pixels take their neighbours' averages within 5 pixels, Sec. 3.6)
//! → `bandwidth` (β, eq. 3.13) → `rates` (n, eq. 3.21, capped at `max_rays · max(μ, 1)²`: 64 at
//! μ = 2, see [`rays_cap`]), submitted to the sampler as `n` shadow rays
//! over both passes (`PerPrimary::Spread`: the sampler traces the `n − initial_rays` left on paths of
//! about `initial_rays` through the pixel centre, continuing the first pass's stratified light
//! samples; with a fixed camera ray its record weighs every shadow ray the same) → `visibility`
//! (the pair ΣE, ΣU: the sampler's final direct estimate and the same samples unshadowed) →
//! `filter_x` → `filter_y` (separable world-space Gaussian in the light's plane, eq. 3.12, 10° normal
//! test, mutual reach) → `shade` (eq. 3.1's `r(x)` — the closed-form unoccluded irradiance — times
//! the filtered ratio ΣE/ΣU) → `compose` (albedo after filtering). With `irradiance: "sampled"` the
//! filters take E itself and there is no `visibility`/`shade`. Pixels with no occluder statistics,
//! own or neighbours', are not filtered (analytic: their own E/U, exactly 1 where no ray was
//! blocked). docs/DESIGN-NOTES.md "SoftShadows after the suite".

use std::sync::Arc;

use wedge_backends::{BackendError, Binding, Kernel, KernelClass, KernelCtx, KernelRegistry, Uniforms, WgslSource};
use wedge_graph::{
    Component, CountRequest, ExpandCtx, Format, GraphError, NodeKind, ParamDecl, ParamValue, Part, PerPrimary,
    PortDecl, Reference, SamplerPass, Stage, Statistic,
};

use crate::filtering::{self, Separable};
use crate::sampler::centre_path;

/// Slopes of the occlusion spectrum's double wedge (thesis eq. 3.4):
/// `s_min = d1/d2_max − 1`, `s_max = d1/d2_min − 1`.
pub fn slopes(d1: f32, d2_min: f32, d2_max: f32) -> (f32, f32) {
    (d1 / d2_max - 1.0, d1 / d2_min - 1.0)
}

/// Filter std-dev β in metres (thesis eq. 3.13):
/// `β = (1/k)(1/μ) max[σ s_min, 1/Ω_x^max]` with `Ω_x^max = α/d` (eq. 3.6, conservative choice).
/// As μ → ∞, β → 0: the filter shrinks to the pixel itself and the result converges to Monte Carlo.
pub fn filter_beta(sigma: f32, s_min: f32, d: f32, mu: f32, alpha: f32, k: f32) -> f32 {
    (sigma * s_min).max(d / alpha) / (k * mu)
}

/// Samples per pixel (thesis eq. 3.21), including the initial ones:
/// `n(μ) = 4(1 + μ s_max/s_min)² (μ (2/s_min) sqrt(A_p/A_l) + α/(1 + s_min))²`,
/// with `A_p = d²` and `A_l = (2σ)²` (Sec. 3.5.1). Returns `f32::INFINITY` when `s_min ≤ 0`
/// (occluder on the receiver), which the caller clamps to the maximum count.
pub fn samples_per_pixel(s_min: f32, s_max: f32, d: f32, sigma: f32, mu: f32, alpha: f32) -> f32 {
    if s_min <= 0.0 || !s_min.is_finite() {
        return f32::INFINITY;
    }
    let a_p = d * d;
    let a_l = (2.0 * sigma) * (2.0 * sigma);
    let first = 1.0 + mu * s_max / s_min;
    let second = mu * (2.0 / s_min) * (a_p / a_l).sqrt() + alpha / (1.0 + s_min);
    4.0 * first * first * second * second
}

pub struct SoftShadows;

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
    /// the diffuse lobe; as a factoring node's component the glossy lobe toward the light centre
    /// too, eq. 5.20); without a factoring node also the wired `emission` (a factoring node adds
    /// emission once itself).
    fn terms(&self, port: &str, q: &wedge_graph::TermQuery<'_>) -> Option<wedge_graph::Terms> {
        use crate::light_terms::lobes;
        let light = u32::try_from(q.int("light")?).ok()?;
        let lobes = if q.factored() { lobes::TOWARD_LIGHT_CENTRE } else { lobes::DIFFUSE };
        let term =
            wedge_graph::Term::new(wedge_graph::TermKind::DirectArea, q.sampler_view()).light(light).detail(lobes);
        let direct = wedge_graph::Terms::new().with(term);
        matches!(port, "radiance" | "unfiltered").then(|| {
            if q.factored() {
                direct
            } else {
                direct.plus(q.input("emission"))
            }
        })
    }
    fn params(&self) -> Vec<ParamDecl> {
        vec![
            crate::params::mu(2.0, "μ: scales the filter bandwidth; larger = narrower filter, more rays (eq. 3.21)"),
            ParamDecl::positive("alpha", 1.0, 1.0, "α = Ω_g^max/Ω_pix^max ∈ (0, 1] (eq. 3.5); 1 is conservative"),
            ParamDecl::positive("k", 3.0, 100.0, "k: Gaussian spread correction in eq. 3.13"),
            ParamDecl::int("light", 0, 0, 1 << 16, "index of the area light whose shadows this node filters"),
            ParamDecl::int("initial_rays", 8, 1, 4096, "first-pass light samples (thesis: 9 = 3×3; 8 is the stratified prefix of the sampler's base-2 sequence nearest it)"),
            ParamDecl::int(
                "max_rays",
                16,
                1,
                1 << 20,
                "cap on eq. 3.21's rays per pixel, scaled by max(μ, 1)² (64 at the default μ = 2) so μ → ∞ stays Monte Carlo; before rounding up to whole multiples of initial_rays",
            ),
            ParamDecl::int("rays_cap", 1 << 20, 1, 1 << 20, "absolute cap on rays per pixel, applied after the μ-scaled max_rays (tests, previews)"),
            ParamDecl::int("fill_radius", 5, 0, 64, "radius (pixels) for averaging d1, d2 into unoccluded pixels"),
            ParamDecl::choice(
                "form_factor",
                "exact",
                &["exact", "light_centre"],
                "per-sample geometry term (unbiased), or the thesis's light-centre approximation r(x)",
            ),
            ParamDecl::choice(
                "irradiance",
                "analytic",
                &["analytic", "sampled"],
                "filter the visibility E/U and multiply by the closed-form unoccluded irradiance (eq. 3.1's r(x) exact), or filter the sampled E itself",
            ),
        ]
        .into_iter()
        .chain(filtering::params())
        .collect()
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        if ctx.factoring().is_some() {
            return expand_factored(ctx);
        }
        let position = ctx.required("position")?;
        let normal = ctx.required("normal")?;
        let (albedo, emission) = (ctx.input("albedo"), ctx.input("emission"));
        let light = ctx.param("light").clone();
        let fill_radius = ctx.param("fill_radius").clone();

        // The shared sampler's first pass: n_p = 1 path through the pixel centre with `initial_rays`
        // stratified light samples (Ch. 3's first pass); its occluder statistics feed eq. 3.13/3.21.
        let (first, per_path) = centre_path(ctx.node(), "light", "shadow_per_primary", ctx.param("initial_rays"))?;
        ctx.sampler(first.setting("light", light.clone()).setting("form_factor", ctx.param("form_factor").clone()))?;
        let occlusion = ctx.sampler_output(SamplerPass::First, "occlusion")?;

        let filled = ctx.buffer("occlusion_filled", Format::Vec4);
        ctx.pass("fill", "neighbourhood.fill", Stage::Bandwidth)
            .read("value", occlusion)
            .read("position", position)
            .write("out", filled)
            .param("radius", fill_radius)
            .finish();

        let beta = ctx.buffer("beta", Format::F32);
        let width_px = ctx.buffer("filter_width", Format::F32);
        ctx.pass("bandwidth", "shadows.bandwidth", Stage::Bandwidth)
            .read("occlusion", filled)
            .read("normal", normal)
            .write("beta", beta)
            .write("filter_width", width_px)
            .node_params(&["mu", "alpha", "k", "light"])
            .finish();

        let rays = ctx.buffer("rays_per_pixel", Format::U32);
        ctx.pass("rates", "shadows.rates", Stage::Bandwidth)
            .read("occlusion", filled)
            .read("normal", normal)
            .write("rays_per_pixel", rays)
            .node_params(&["mu", "alpha", "light", "initial_rays", "max_rays", "rays_cap"])
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
            ctx.pass("visibility", "shadows.visibility", Stage::Filter)
                .read("direct", noisy)
                .read("unshadowed", unshadowed)
                .write("out", pair)
                .reference(Reference::Bypass { input: "direct" })
                .finish();
            let pair = filtering::separable(ctx, "", pair, &filter);
            let shaded = ctx.buffer("shaded", Format::Vec4);
            ctx.pass("shade", "shadows.shade", Stage::Filter)
                .read("direct", noisy)
                .read("visibility", pair)
                .read("position", position)
                .read("normal", normal)
                .write("out", shaded)
                .param("light", light.clone())
                .reference(Reference::Bypass { input: "direct" })
                .finish();
            shaded
        } else {
            filtering::separable(ctx, "", noisy, &filter)
        };

        for (pass, value, port) in [("compose", filtered, "radiance"), ("compose_unfiltered", noisy, "unfiltered")] {
            let out = ctx.buffer(port, Format::Vec3);
            ctx.pass(pass, "compose.modulate", Stage::Compose)
                .read("value", value)
                .read_opt("albedo", albedo)
                .read_opt("emission", emission)
                .write("out", out)
                .finish();
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
/// added there). The Ch. 3 parameters (`mu`, `alpha`, `k`, `initial_rays`, `max_rays`, `fill_radius`,
/// `form_factor`) do not apply: the factoring node's settings do; `position`, `normal`, `albedo` and
/// `emission` inputs are not read (the sampler's path-averaged values are).
fn expand_factored(ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
    let light = ctx.param("light").clone();
    ctx.component(&Component {
        name: "direct",
        estimator: "light",
        settings: vec![("light", light.clone())],
        statistic: ("occlusion", Statistic::Sampler("occlusion")),
        rate_params: vec![("light", light)],
        parts: vec![Part { name: "direct", radiance: "l_direct", texture: "k_direct", irradiance: "e_direct" }],
    })
}

/// Per-pixel inputs of the formulas, read from the filled occluder statistics.
struct PixelStats {
    filterable: bool,
    s_min: f32,
    s_max: f32,
    d: f32,
}

fn pixel_stats(occ: [f32; 4], normal: [f32; 4]) -> PixelStats {
    let (s_min, s_max) = slopes(occ[0], occ[1], occ[2]);
    PixelStats { filterable: occ[3] > 0.0, s_min, s_max, d: normal[3] }
}

/// `shadows.bandwidth`: β (metres) and β in pixels for the heatmap.
pub struct Bandwidth;

impl Kernel for Bandwidth {
    fn name(&self) -> &'static str {
        "shadows.bandwidth"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Bandwidth
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("occlusion", Format::Vec4),
            Binding::read("normal", Format::Vec4),
            Binding::write("beta", Format::F32),
            Binding::write("filter_width", Format::F32),
        ]
    }
    /// WGSL mirror: `shaders/shadows_bandwidth.wgsl` with the formulas of `shaders/shadows_formulas.wgsl`.
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../shaders/shadows_bandwidth.wgsl"), |ctx| {
                let sigma = ctx.scene.lights[ctx.light_param("light")?].sigma();
                Ok(Uniforms::new()
                    .f32("mu", ctx.f32_param("mu")?)
                    .f32("alpha", ctx.f32_param("alpha")?)
                    .f32("k", ctx.f32_param("k")?)
                    .f32("sigma", sigma))
            })
            .with_include("shadows_formulas.wgsl", include_str!("../../shaders/shadows_formulas.wgsl"))
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let occ = ctx.read::<[f32; 4]>("occlusion")?;
        let normal = ctx.read::<[f32; 4]>("normal")?;
        let (mu, alpha, k) = (ctx.f32_param("mu")?, ctx.f32_param("alpha")?, ctx.f32_param("k")?);
        let sigma = ctx.scene.lights[ctx.light_param("light")?].sigma();
        let beta: Vec<f32> = (0..ctx.pixels())
            .map(|i| {
                let p = pixel_stats(occ[i], normal[i]);
                if p.filterable {
                    filter_beta(sigma, p.s_min, p.d, mu, alpha, k)
                } else {
                    0.0
                }
            })
            .collect();
        let px = beta.iter().zip(normal).map(|(b, n)| if *b > 0.0 { b / n[3] } else { 0.0 }).collect::<Vec<f32>>();
        ctx.put("beta", beta)?;
        ctx.put("filter_width", px)
    }
}

/// `shadows.rates`: total shadow rays per pixel from eq. 3.21, clamped to `[initial, max]`.
pub struct Rates;

/// `n` rounded up to a multiple of `initial` (the first pass's light samples): the sampler's base-2
/// sequence is stratified in blocks of powers of 2, so a pixel's shadow rays stay whole blocks of 8.
/// Measured on `shadows.ron` (160×120, seeds 1–3): RMSE 2% lower than exact counts at 1.1% more rays
/// (docs/SAMPLER-STAGE.md "Samples, not paths").
pub fn whole_multiples(n: u32, initial: u32) -> u32 {
    let initial = initial.max(1);
    n.div_ceil(initial).saturating_mul(initial)
}

/// The cap on eq. 3.21's count as the pass applies it: `max_rays · max(μ, 1)²`, then at most
/// `rays_cap` (an absolute ceiling, as Indirect's), and at least `initial`.
/// Eq. 3.21 grows as `(1 + μ s_max/s_min)²`: under several occluder layers (s_max/s_min large) it
/// asks for hundreds of rays that buy little once β is set by `s_min`, and a low cap spends them
/// where they help (`suite_slats`, 320×240: 1.19× → 2.52× vs stratified MC with 64 instead of 400,
/// docs/DESIGN-NOTES.md "The cap on eq. 3.21's count"). Scaling with μ² keeps it consistent: as μ
/// grows the cap recedes and the counts converge to eq. 3.21's, i.e. to Monte Carlo.
pub fn rays_cap(max_rays: i64, mu: f32, absolute: i64, initial: u32) -> u32 {
    let scaled = max_rays.max(1) as f64 * f64::from(mu.max(1.0)).powi(2);
    (scaled.min(absolute.max(1) as f64).min(f64::from(u32::MAX)) as u32).max(initial)
}

/// `(initial_rays, cap)` from the pass's parameters.
fn count_bounds(ctx: &KernelCtx<'_>) -> Result<(u32, u32), BackendError> {
    let initial = ctx.int_param("initial_rays")?.max(1) as u32;
    let cap = rays_cap(ctx.int_param("max_rays")?, ctx.f32_param("mu")?, ctx.int_param("rays_cap")?, initial);
    Ok((initial, cap))
}

impl Kernel for Rates {
    fn name(&self) -> &'static str {
        "shadows.rates"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Bandwidth
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("occlusion", Format::Vec4),
            Binding::read("normal", Format::Vec4),
            Binding::write("rays_per_pixel", Format::U32),
        ]
    }
    /// WGSL mirror: `shaders/shadows_rates.wgsl` with the formulas of `shaders/shadows_formulas.wgsl`.
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../shaders/shadows_rates.wgsl"), |ctx| {
                let (initial, max) = count_bounds(ctx)?;
                let sigma = ctx.scene.lights[ctx.light_param("light")?].sigma();
                Ok(Uniforms::new()
                    .f32("mu", ctx.f32_param("mu")?)
                    .f32("alpha", ctx.f32_param("alpha")?)
                    .f32("sigma", sigma)
                    .u32("initial", initial)
                    .u32("max_rays", max))
            })
            .with_include("shadows_formulas.wgsl", include_str!("../../shaders/shadows_formulas.wgsl"))
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let occ = ctx.read::<[f32; 4]>("occlusion")?;
        let normal = ctx.read::<[f32; 4]>("normal")?;
        let (mu, alpha) = (ctx.f32_param("mu")?, ctx.f32_param("alpha")?);
        let (initial, max) = count_bounds(ctx)?;
        let sigma = ctx.scene.lights[ctx.light_param("light")?].sigma();
        let n: Vec<u32> = (0..ctx.pixels())
            .map(|i| {
                let p = pixel_stats(occ[i], normal[i]);
                if !p.filterable {
                    return initial;
                }
                let n = samples_per_pixel(p.s_min, p.s_max, p.d, sigma, mu, alpha);
                let n = if n.is_finite() { (n.ceil() as u32).clamp(initial, max) } else { max };
                whole_multiples(n, initial)
            })
            .collect();
        ctx.put("rays_per_pixel", n)
    }
}

/// `shadows.visibility`: the pair the filter averages for the ratio estimate of visibility —
/// `(ΣE, ΣU)` over the colour channels (one light: E and U share its colour, so any positive
/// channel weighting gives the same ratio), `w` = the estimate's samples.
pub struct Visibility;

impl Kernel for Visibility {
    fn name(&self) -> &'static str {
        "shadows.visibility"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Filter
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("direct", Format::Vec4),
            Binding::read("unshadowed", Format::Vec4),
            Binding::write("out", Format::Vec4),
        ]
    }
    /// WGSL mirror: `shaders/shadows_visibility.wgsl`.
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../shaders/shadows_visibility.wgsl"), |_| Ok(Uniforms::new())).per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let e = ctx.read::<[f32; 4]>("direct")?;
        let u = ctx.read::<[f32; 4]>("unshadowed")?;
        let out: Vec<[f32; 4]> =
            e.iter().zip(u).map(|(e, u)| [e[0] + e[1] + e[2], u[0] + u[1] + u[2], 0.0, e[3]]).collect();
        ctx.put("out", out)
    }
}

/// `shadows.shade`: `r(x) · V`, the closed-form unoccluded irradiance of light `light` at the pixel
/// ([`wedge_scene::AreaLight::irradiance_unoccluded`], over π: unit-albedo radiance) times the
/// filtered visibility `ΣE/ΣU` (1 where no sample saw the light: nothing says it is blocked);
/// background pixels keep `direct`. `w` = the estimate's samples.
pub struct Shade;

impl Kernel for Shade {
    fn name(&self) -> &'static str {
        "shadows.shade"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Filter
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("direct", Format::Vec4),
            Binding::read("visibility", Format::Vec4),
            Binding::read("position", Format::Vec4),
            Binding::read("normal", Format::Vec4),
            Binding::write("out", Format::Vec4),
        ]
    }
    /// WGSL mirror: `shaders/shadows_shade.wgsl` (the polygon formula term by term).
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../shaders/shadows_shade.wgsl"), |ctx| {
                let light = ctx.scene.at(0.0).light(ctx.light_param("light")?);
                let (v, count) = light.corners();
                // The side test's vector, as `irradiance_unoccluded` takes it.
                let cross = light.normal();
                let four = |p: glam::Vec3| [p.x, p.y, p.z, 0.0];
                Ok(Uniforms::new()
                    .vec4("v0", four(v[0]))
                    .vec4("v1", four(v[1]))
                    .vec4("v2", four(v[2]))
                    .vec4("v3", four(v[3]))
                    .vec4("radiance", four(light.radiance))
                    .vec4("cross", four(cross))
                    .u32("count", count as u32)
                    .u32("two_sided", light.two_sided as u32))
            })
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let direct = ctx.read::<[f32; 4]>("direct")?;
        let vis = ctx.read::<[f32; 4]>("visibility")?;
        let position = ctx.read::<[f32; 4]>("position")?;
        let normal = ctx.read::<[f32; 4]>("normal")?;
        // A Ch. 3 kernel: the light at the shutter's centre, as the sampler's shadow rays see it.
        let light = ctx.scene.at(0.0).light(ctx.light_param("light")?);
        let out: Vec<[f32; 4]> = (0..ctx.pixels())
            .map(|i| {
                if position[i][3] == 0.0 {
                    return direct[i];
                }
                let (x, n) = (glam::Vec3::from_slice(&position[i][..3]), glam::Vec3::from_slice(&normal[i][..3]));
                let v = if vis[i][1] > 0.0 { vis[i][0] / vis[i][1] } else { 1.0 };
                let e = light.irradiance_unoccluded(x, n) / std::f32::consts::PI * v;
                [e.x, e.y, e.z, direct[i][3]]
            })
            .collect();
        ctx.put("out", out)
    }
}

pub fn register_kernels(reg: &mut KernelRegistry) {
    reg.register(Arc::new(Bandwidth));
    reg.register(Arc::new(Rates));
    reg.register(Arc::new(Visibility));
    reg.register(Arc::new(Shade));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slopes_eq_3_4() {
        // d1 = 3, occluders at 1 and 2 from the light: s_min = 3/2 − 1, s_max = 3/1 − 1.
        let (s_min, s_max) = slopes(3.0, 1.0, 2.0);
        assert!((s_min - 0.5).abs() < 1e-6);
        assert!((s_max - 2.0).abs() < 1e-6);
    }

    #[test]
    fn beta_eq_3_13_by_hand() {
        // σ = 0.3, s_min = 0.5, d = 0.01, μ = 2, α = 1, k = 3: max(0.15, 0.01)/6 = 0.025.
        let b = filter_beta(0.3, 0.5, 0.01, 2.0, 1.0, 3.0);
        assert!((b - 0.025).abs() < 1e-7, "{b}");
        // Pixel limit wins when σ s_min < d/α: max(0.003, 0.01)/(3·1) = 0.0033333.
        let b = filter_beta(0.3, 0.01, 0.01, 1.0, 1.0, 3.0);
        assert!((b - 0.01 / 3.0).abs() < 1e-7, "{b}");
        // α < 1 raises the pixel limit: d/α = 0.02.
        let b = filter_beta(0.0, 0.0, 0.01, 1.0, 0.5, 1.0);
        assert!((b - 0.02).abs() < 1e-7);
    }

    #[test]
    fn beta_shrinks_to_a_pixel_as_mu_grows() {
        // β scales as 1/μ; at μ = 1e6 it is far below a pixel (d = 0.01), so the Gaussian's weight
        // on the nearest neighbour, exp(−d²/(2β²)), underflows to 0: a one-pixel filter.
        let b = filter_beta(0.3, 0.5, 0.01, 1e6, 1.0, 3.0);
        assert!(b < 1e-6);
        assert_eq!((-(0.01f32 * 0.01) / (2.0 * b * b)).exp(), 0.0);
        assert!(
            (filter_beta(0.3, 0.5, 0.01, 4.0, 1.0, 3.0) * 2.0 - filter_beta(0.3, 0.5, 0.01, 2.0, 1.0, 3.0)).abs()
                < 1e-7
        );
    }

    #[test]
    fn samples_eq_3_21_by_hand() {
        // s_min = 0.5, s_max = 2, d = 0.01, σ = 0.1 (A_l = 0.04, sqrt(A_p/A_l) = 0.05), μ = 2, α = 1:
        // 4 (1 + 2·4)² (2·4·0.05 + 1/1.5)² = 4 · 81 · (0.4 + 0.666667)² = 368.64.
        let n = samples_per_pixel(0.5, 2.0, 0.01, 0.1, 2.0, 1.0);
        assert!((n - 368.64).abs() < 0.01, "{n}");
        // μ = 1: 4 (1 + 4)² (0.2 + 0.666667)² = 100 · 0.751111 = 75.1111.
        let n = samples_per_pixel(0.5, 2.0, 0.01, 0.1, 1.0, 1.0);
        assert!((n - 75.1111).abs() < 0.001, "{n}");
        // A single occluder depth (s_max = s_min) and a tiny pixel: 4·(1+μ)²·(α/(1+s))² → μ = 1: 16/2.25.
        let n = samples_per_pixel(0.5, 0.5, 0.0, 0.1, 1.0, 1.0);
        assert!((n - 16.0 / 2.25).abs() < 1e-4, "{n}");
        // Contact shadows (s_min → 0) need unbounded samples: the caller clamps.
        assert!(samples_per_pixel(0.0, 2.0, 0.01, 0.1, 2.0, 1.0).is_infinite());
    }

    #[test]
    fn samples_grow_quadratically_in_mu() {
        // Fig. 3.5(a): for large μ, n ∝ μ⁴ asymptotically only through both factors; check monotone growth.
        let mut last = 0.0;
        for mu in [0.5, 1.0, 2.0, 4.0, 8.0] {
            let n = samples_per_pixel(0.5, 2.0, 0.01, 0.1, mu, 1.0);
            assert!(n > last);
            last = n;
        }
    }

    #[test]
    fn rays_cap_scales_with_mu_squared() {
        // Default 16 → 64 at μ = 2; below μ = 1 it stays 16; never under the first pass; the
        // absolute cap wins last.
        let no_ceiling = i64::MAX;
        assert_eq!(rays_cap(16, 2.0, no_ceiling, 8), 64);
        assert_eq!(rays_cap(16, 0.5, no_ceiling, 8), 16);
        assert_eq!(rays_cap(16, 8.0, no_ceiling, 8), 1024);
        assert_eq!(rays_cap(2, 1.0, no_ceiling, 8), 8);
        assert_eq!(rays_cap(16, 1e6, no_ceiling, 8), u32::MAX);
        assert_eq!(rays_cap(16, 1e6, 100, 8), 100);
        assert_eq!(rays_cap(16, 1e6, 1, 8), 8);
        // The cap binds eq. 3.21's count at μ = 64 but recedes past it as μ grows (consistency).
        let n = samples_per_pixel(0.5, 2.0, 0.01, 0.1, 64.0, 1.0);
        assert!(f64::from(rays_cap(16, 64.0, no_ceiling, 8)) < f64::from(n));
        assert!(f64::from(rays_cap(16, 1e4, no_ceiling, 8)) > f64::from(n));
    }
}
