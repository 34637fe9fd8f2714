//! `Indirect`: axis-aligned filtering of diffuse and glossy indirect light, multi-bounce, and the
//! ambient-occlusion variant (Mehta thesis Ch. 4, eqs. 4.15–4.21, App. A; `docs/EQUATIONS.md` "Indirect").
//!
//! Sampling is the shared sampler's ([`crate::sampler`], `docs/SAMPLER-STAGE.md` §4): the node asks
//! it for the `hemisphere` estimator with the Ch. 4 constants — one path through the pixel centre,
//! `initial_rays` (16) stratified hemisphere samples per component on it, `bounces`, `brdf`, and the
//! AO mode — and reads the first pass's first-hit distances `z_min, z_max` (`depth`). Its own passes:
//! `bandwidth` (β per component, eqs. 4.15–4.16, 4.18, A.3, A.5) → `rates` (n per component,
//! eq. 4.21), submitted as each component's samples over both passes (`PerPrimary::Spread` on the
//! sampler's `diffuse` and `glossy` channels: up to n, reusing the first 16, each component with its
//! own count, every sample weighing the same) → `filter_x`/`filter_y` per component on the sampler's
//! final `diffuse` / `glossy` estimates (the shared separable world-space Gaussian, full 3-D
//! distance, 10° normal test) → `compose` (k_d and k_s multiply after filtering).
//!
//! Readings taken (documented in the report and `docs/EQUATIONS.md`'s map):
//! - **Components**: the diffuse component (cosine sampling) and, on pixels whose `specular` input has
//!   `k_s > 0, m > 0`, the glossy component (Phong-lobe sampling) are each sampled with *their own*
//!   count from eq. 4.21 (own `Ω_h`, own `γ`) and filtered with their own β. `rays_per_pixel` is the
//!   sum of both counts (hemisphere rays, i.e. paths, per pixel).
//! - **Indirect only**: the primary hit's direct light is not included (lights enter only by
//!   next-event estimation at path vertices beyond the primary hit); pair the node with a direct-light
//!   node (`SoftShadows`, `MonteCarlo`) and an `Add`.
//! - `z_min` is clamped to at least `z_min_fraction` (2%) of the scene's largest dimension; `z_max` is
//!   kept ≥ the clamped `z_min`.
//! - **No reflector found**: a pixel whose first-pass rays all miss (AO: nothing within
//!   `max_distance`) takes `z_min = z_max =` the scene's largest dimension, the farthest any reflector
//!   can be: eqs. 4.15–4.21 then give a wide filter (usually the whole `max_radius` window) and about
//!   the initial count, and β still shrinks as `1/μ`, so μ → ∞ stays plain Monte Carlo. Leaving such
//!   pixels unfiltered instead keeps exactly the pixels whose 16 rays happened to miss at 0, a
//!   selection bias: on the open `curved` AO scene the image mean was 27% low. (`z_min = ∞`, i.e.
//!   `β = ∞`, removes that bias too but never converges as μ grows.)
//! - Rates are clamped to `[initial_rays, max_rays · max(μ, 1)]` (thesis: 16 and 100μ).
//! - **Whose statistics** (`statistics`): the thesis's `z_min, z_max` are the pixel's own first
//!   pass's, whose samples its estimate then reuses, so a pixel's count and width correlate with
//!   its own value (AO on `curved`: unfiltered mean −1.1%, filtered −3.3%). `"neighbours"` runs
//!   `neighbourhood.others` first (pass `statistics`): the means of the eight neighbours' `z_min`,
//!   `z_max` on the same object, the pixel's own left out (AO: −1.1% → +0.0% and −3.3% → −0.4%;
//!   indirect light: the same speedups; the default; `"own"` keeps the thesis's; docs/DESIGN-NOTES.md
//!   "AO: the mean and the pixel's own statistics"). Not used under a factoring node.

use std::f32::consts::FRAC_PI_2;
use std::sync::Arc;

use wedge_backends::kernels::hemisphere::Lobe;
use wedge_backends::{
    BackendError, Binding, Kernel, KernelClass, KernelCtx, KernelParams, KernelRegistry, ParamSpec, WgslSource,
};
use wedge_graph::{
    Component, CountRequest, ExpandCtx, Format, GraphError, NodeKind, ParamDecl, ParamValue, Part, PerPrimary,
    PortDecl, Reference, SamplerPass, Stage, Statistic,
};

use crate::filtering::{self, Separable};
use crate::sampler::centre_path;

/// Receiver BRDF for the transfer-function bandlimit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Receiver {
    Diffuse,
    BlinnPhong(f32),
    Phong(f32),
}

/// Transfer-function bandlimit `Ω_h^max` capturing 99% of its energy (thesis eq. 4.18, A.3, A.5):
/// diffuse 2.8, Blinn-Phong `3.6 + 0.084 m`, Phong `4.27 + 0.15 m`.
pub fn transfer_bandlimit(r: Receiver) -> f32 {
    match r {
        Receiver::Diffuse => 2.8,
        Receiver::BlinnPhong(m) => 3.6 + 0.084 * m,
        Receiver::Phong(m) => 4.27 + 0.15 * m,
    }
}

/// `γ` of eq. 4.21: 0.4 for diffuse; `acos(c^{1/m})/(π/2)` with `c = 1/√2` for glossy receivers
/// (the fraction of the hemisphere's angular extent the lobe occupies at half power).
pub fn gamma(r: Receiver) -> f32 {
    match r {
        Receiver::Diffuse => 0.4,
        Receiver::BlinnPhong(m) | Receiver::Phong(m) => {
            let c = std::f32::consts::FRAC_1_SQRT_2;
            c.powf(1.0 / m.max(1e-6)).acos() / FRAC_PI_2
        }
    }
}

/// `z_min` clamped to at least `fraction` of the scene's largest dimension (thesis Sec. 4.5).
pub fn clamp_z_min(z_min: f32, extent: f32, fraction: f32) -> f32 {
    z_min.max(fraction * extent)
}

/// Filter bandwidth (world units⁻¹), thesis eq. 4.15: `Ω_x^r = μ · min(Ω_h/z_min, α/d)`.
pub fn filter_bandwidth(omega_h: f32, z_min: f32, d: f32, mu: f32, alpha: f32) -> f32 {
    mu * (omega_h / z_min).min(alpha / d)
}

/// Spatial std-dev (metres), thesis eq. 4.16: `β = 2/Ω_x^r`. As μ → ∞, β → 0: a one-pixel filter.
pub fn filter_beta(omega_x_r: f32) -> f32 {
    2.0 / omega_x_r
}

/// Samples per pixel (thesis eq. 4.21), before clamping:
/// `n = γ (μ Ω_h sqrt(A_p)/z_min + α)² Ω_h² (1 + μ z_max/z_min)²` with `A_p = d²`.
pub fn samples_per_pixel(gamma: f32, omega_h: f32, d: f32, z_min: f32, z_max: f32, mu: f32, alpha: f32) -> f32 {
    let first = mu * omega_h * d / z_min + alpha;
    let second = 1.0 + mu * z_max / z_min;
    gamma * first * first * omega_h * omega_h * second * second
}

/// Round eq. 4.21 up and clamp to `[initial, max · max(μ, 1)]` (thesis: 16 and 100μ).
pub fn clamp_rate(n: f32, mu: f32, initial: u32, max: u32) -> u32 {
    let hi = ((max as f32) * mu.max(1.0)).ceil().max(initial as f32) as u32;
    if n.is_finite() {
        (n.ceil().max(0.0) as u32).clamp(initial, hi)
    } else {
        hi
    }
}

/// What one pixel's formulas need, for one component.
#[derive(Clone, Copy, Debug)]
pub struct ComponentRate {
    pub beta: f32,
    pub rays: u32,
}

/// Formula settings read from a pass's parameter block.
#[derive(Clone, Copy, Debug)]
pub struct Settings {
    pub mu: f32,
    pub alpha: f32,
    pub z_fraction: f32,
    pub extent: f32,
    pub initial: u32,
    pub max: u32,
}

/// β and n for one component at one pixel from its first-pass statistics `depth` (z_min, z_max,
/// hits, traced) and footprint `d`.
/// Pixels whose first-pass rays all missed take `z_min = z_max = extent`, the farthest a reflector
/// can be (see the module docs).
pub fn component(r: Receiver, depth: [f32; 4], d: f32, s: &Settings) -> ComponentRate {
    let (z_min, z_max) = if depth[2] > 0.0 { (depth[0], depth[1]) } else { (s.extent, s.extent) };
    let z_min = clamp_z_min(z_min, s.extent, s.z_fraction);
    let z_max = z_max.max(z_min);
    let omega_h = transfer_bandlimit(r);
    let beta = filter_beta(filter_bandwidth(omega_h, z_min, d.max(1e-12), s.mu, s.alpha));
    let n = samples_per_pixel(gamma(r), omega_h, d, z_min, z_max, s.mu, s.alpha);
    ComponentRate { beta, rays: clamp_rate(n, s.mu, s.initial, s.max) }
}

pub struct Indirect;

/// Under a factoring node (thesis Ch. 5, App. B; [`wedge_graph::factoring`]): indirect light as one
/// factored component with two parts — diffuse (`k = k_d`) and glossy (`k = k_s`, E the lobe-weighted
/// incident radiance; eq. 5.21 keeps them apart) — which the factoring node renders
/// ([`wedge_graph::NodeKind::expand_component`]). Its rates read the first pass's reflector depths;
/// `Ω_v^max` is the diffuse receiver's 2.8 (Ch. 4, eq. 4.18) for both parts: a reading — the thesis
/// gives one `Ω_v^max` per pixel and glossy receivers would take `4.27 + 0.15 m`, which the per-pixel
/// rate kernels do not see. The Ch. 4 parameters (`mu`, `alpha`, rays and filter settings) do not
/// apply; `bounces` and `brdf` set the sampler's hemisphere estimator. AO is not a factored
/// component: refused.
fn expand_factored(ctx: &mut ExpandCtx<'_>, f: &wedge_graph::Factoring) -> Result<(), GraphError> {
    if matches!(ctx.param("mode"), ParamValue::Str(m) if m == "ao") {
        return Err(GraphError::Expand {
            node: ctx.node().into(),
            message: format!(
                "ambient occlusion (`mode: \"ao\"`) is not a lighting component `{}` ({}) can factor; use `mode: \"radiance\"` \
                 or a pipeline without {} (docs/NODES.md \"Composing effects\": what is refused, and why)",
                f.node, f.kind, f.kind
            ),
        });
    }
    let settings = vec![("bounces", ctx.param("bounces").clone()), ("brdf", ctx.param("brdf").clone())];
    ctx.component(&Component {
        name: "indirect",
        estimator: "hemisphere",
        settings,
        statistic: ("reflectors", Statistic::Sampler("depth")),
        rate_params: vec![],
        parts: vec![
            Part { name: "diffuse", radiance: "l_diffuse", texture: "k_diffuse", irradiance: "e_diffuse" },
            Part { name: "glossy", radiance: "l_glossy", texture: "k_glossy", irradiance: "e_glossy" },
        ],
    })
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
                "z_min, z_max for eqs. 4.15–4.21 from the pixel's own first pass (thesis), or from its eight neighbours' (leaves its own samples out: no correlation between a pixel's estimate and its count or width; not with factoring)",
            ),
        ])
        .chain(filtering::params())
        .collect()
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        if let Some(f) = ctx.factoring() {
            return expand_factored(ctx, f);
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
            ctx.pass("statistics", "neighbourhood.others", Stage::Bandwidth)
                .read("value", own_depth)
                .read("position", position)
                .write("out", others)
                .finish();
            others
        } else {
            own_depth
        };

        let beta_d = ctx.buffer("beta_diffuse", Format::F32);
        let beta_g = ctx.buffer("beta_glossy", Format::F32);
        let width_px = ctx.buffer("filter_width", Format::F32);
        let mut pass = ctx
            .pass("bandwidth", "indirect.bandwidth", Stage::Bandwidth)
            .read("depth", depth)
            .read("normal", normal)
            .read_opt("specular", specular)
            .write("beta_diffuse", beta_d)
            .write("filter_width", width_px);
        if glossy {
            pass = pass.write("beta_glossy", beta_g);
        }
        pass.node_params(RateParams::names()).finish();

        let rays_d = ctx.buffer("rays_diffuse", Format::U32);
        let rays_g = ctx.buffer("rays_glossy", Format::U32);
        let rays = ctx.buffer("rays_per_pixel", Format::U32);
        let mut pass = ctx
            .pass("rates", "indirect.rates", Stage::Bandwidth)
            .read("depth", depth)
            .read("normal", normal)
            .read_opt("specular", specular)
            .write("rays_diffuse", rays_d)
            .write("rays_per_pixel", rays);
        if glossy {
            pass = pass.write("rays_glossy", rays_g);
        }
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
            ctx.pass(pass, "indirect.compose", Stage::Compose)
                .read("diffuse", d)
                .read_opt("glossy", g)
                .read_opt("albedo", albedo)
                .read_opt("specular", specular)
                .write("out", out)
                .finish();
            ctx.output(port, out);
        }
        ctx.output("filter_width", width_px);
        ctx.output("rays_per_pixel", rays);
        Ok(())
    }
}

wedge_backends::kernel_params! {
    /// The parameters of eqs. 4.15–4.21 as `indirect.bandwidth` and `indirect.rates` read them
    /// (CPU: typed; WGSL: `params.NAME`, `brdf` 0 = Phong, 1 = Blinn-Phong, plus the scene's
    /// `extent`). `mu` and `brdf` are declared by the shared definitions (`crate::params`), the
    /// rest here; the node forwards all of them to both passes.
    pub struct RateParams {
        mu: f32,
        brdf: Lobe,
        alpha: f32 = positive(0.3, 1.0, "α = Ω_x^max · d ∈ (0, 1] (eq. 4.15)"),
        initial_rays: u32 = int(16, 1, 4096, "first-pass hemisphere rays per component (thesis: 16, stratified)"),
        max_rays: u32 = int(100, 1, 1 << 20, "cap on rays per pixel per component, scaled by max(μ, 1) (thesis: 100μ)"),
        rays_cap: u32 = int(1 << 20, 1, 1 << 20, "absolute cap on rays per pixel per component, applied last (tests, previews)"),
        z_min_fraction: f32 = float(0.02, 0.0, 1.0, "z_min is clamped to at least this fraction of the scene's largest dimension"),
    }
}

/// The formulas' settings and whether glossy receivers are Blinn-Phong; `with_rates` = false for
/// the bandwidth pass (counts of 1: it computes no rates).
fn settings(ctx: &KernelCtx<'_>, with_rates: bool) -> Result<(RateParams, Settings, bool), BackendError> {
    let p = RateParams::read(ctx)?;
    let s = Settings {
        mu: p.mu,
        alpha: p.alpha,
        z_fraction: p.z_min_fraction,
        extent: ctx.scene.extent(),
        initial: if with_rates { p.initial_rays.max(1) } else { 1 },
        max: if with_rates { p.max_rays.max(1) } else { 1 },
    };
    let blinn = p.brdf == Lobe::BlinnPhong;
    Ok((p, s, blinn))
}

/// The WGSL parameter block of both formula passes.
fn uniforms(ctx: &KernelCtx<'_>) -> Result<wedge_backends::Uniforms, BackendError> {
    Ok(RateParams::read(ctx)?.uniforms().f32("extent", ctx.scene.extent()))
}

/// The glossy receiver at a pixel, if it has a glossy lobe.
fn glossy_receiver(spec: Option<&[[f32; 4]]>, i: usize, blinn: bool) -> Option<Receiver> {
    let s = spec?[i];
    let m = s[3];
    (m > 0.0 && s[0].max(s[1]).max(s[2]) > 0.0).then_some(if blinn {
        Receiver::BlinnPhong(m)
    } else {
        Receiver::Phong(m)
    })
}

/// `indirect.bandwidth`: β (metres) per component and the diffuse β in pixels for the heatmap.
pub struct Bandwidth;

impl Kernel for Bandwidth {
    fn name(&self) -> &'static str {
        "indirect.bandwidth"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Bandwidth
    }
    fn params(&self) -> Vec<ParamSpec> {
        RateParams::specs()
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("depth", Format::Vec4),
            Binding::read("normal", Format::Vec4),
            Binding::read_opt("specular", Format::Vec4),
            Binding::write("beta_diffuse", Format::F32),
            Binding::write_opt("beta_glossy", Format::F32),
            Binding::write("filter_width", Format::F32),
        ]
    }
    /// WGSL mirror: `shaders/indirect_bandwidth.wgsl` with the formulas of `shaders/indirect_formulas.wgsl`.
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../shaders/indirect_bandwidth.wgsl"), uniforms)
                .with_include("indirect_formulas.wgsl", include_str!("../../shaders/indirect_formulas.wgsl"))
                .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let depth = ctx.read::<[f32; 4]>("depth")?;
        let normal = ctx.read::<[f32; 4]>("normal")?;
        let spec = ctx.read_opt::<[f32; 4]>("specular")?;
        let (_, s, blinn) = settings(ctx, false)?;
        let active = |i: usize| depth[i][3] > 0.0;
        let beta_d: Vec<f32> = (0..ctx.pixels())
            .map(|i| if active(i) { component(Receiver::Diffuse, depth[i], normal[i][3], &s).beta } else { 0.0 })
            .collect();
        let px = beta_d.iter().zip(normal).map(|(b, n)| if *b > 0.0 { b / n[3] } else { 0.0 }).collect::<Vec<f32>>();
        ctx.put_opt("beta_glossy", || {
            (0..beta_d.len())
                .map(|i| match glossy_receiver(spec, i, blinn) {
                    Some(r) if active(i) => component(r, depth[i], normal[i][3], &s).beta,
                    _ => 0.0,
                })
                .collect::<Vec<f32>>()
        })?;
        ctx.put("beta_diffuse", beta_d)?;
        ctx.put("filter_width", px)
    }
}

/// `indirect.rates`: samples per pixel per component from eq. 4.21, clamped to `[16, 100·max(μ,1)]`,
/// and their sum (the `rays_per_pixel` heatmap).
pub struct Rates;

impl Kernel for Rates {
    fn name(&self) -> &'static str {
        "indirect.rates"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Bandwidth
    }
    fn params(&self) -> Vec<ParamSpec> {
        RateParams::specs()
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("depth", Format::Vec4),
            Binding::read("normal", Format::Vec4),
            Binding::read_opt("specular", Format::Vec4),
            Binding::write("rays_diffuse", Format::U32),
            Binding::write_opt("rays_glossy", Format::U32),
            Binding::write("rays_per_pixel", Format::U32),
        ]
    }
    /// WGSL mirror: `shaders/indirect_rates.wgsl` with the formulas of `shaders/indirect_formulas.wgsl`.
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../shaders/indirect_rates.wgsl"), uniforms)
                .with_include("indirect_formulas.wgsl", include_str!("../../shaders/indirect_formulas.wgsl"))
                .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let depth = ctx.read::<[f32; 4]>("depth")?;
        let normal = ctx.read::<[f32; 4]>("normal")?;
        let spec = ctx.read_opt::<[f32; 4]>("specular")?;
        let (p, s, blinn) = settings(ctx, true)?;
        let glossy_bound = ctx.is_bound("rays_glossy");
        let cap = p.rays_cap.max(1);
        let per: Vec<(u32, u32)> = (0..ctx.pixels())
            .map(|i| {
                if depth[i][3] <= 0.0 {
                    return (0, 0);
                }
                let nd = component(Receiver::Diffuse, depth[i], normal[i][3], &s).rays;
                let ng = match glossy_receiver(spec, i, blinn) {
                    Some(r) if glossy_bound => component(r, depth[i], normal[i][3], &s).rays,
                    _ => 0,
                };
                (nd.min(cap), ng.min(cap))
            })
            .collect();
        ctx.put_opt("rays_glossy", || per.iter().map(|p| p.1).collect::<Vec<u32>>())?;
        ctx.put("rays_per_pixel", per.iter().map(|p| p.0 + p.1).collect::<Vec<u32>>())?;
        ctx.put("rays_diffuse", per.iter().map(|p| p.0).collect::<Vec<u32>>())
    }
}

pub fn register_kernels(reg: &mut KernelRegistry) {
    reg.register(Arc::new(Bandwidth));
    reg.register(Arc::new(Rates));
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol * b.abs().max(1e-6)
    }

    #[test]
    fn bandlimits_eq_4_18_a_3_a_5() {
        assert_eq!(transfer_bandlimit(Receiver::Diffuse), 2.8);
        // Blinn-Phong m = 12 (thesis Fig. 4.8): 3.6 + 1.008 = 4.608; m = 20: 5.28.
        assert!(close(transfer_bandlimit(Receiver::BlinnPhong(12.0)), 4.608, 1e-6));
        assert!(close(transfer_bandlimit(Receiver::BlinnPhong(20.0)), 5.28, 1e-6));
        // Phong m = 12: 4.27 + 1.8 = 6.07; m = 20: 7.27.
        assert!(close(transfer_bandlimit(Receiver::Phong(12.0)), 6.07, 1e-6));
        assert!(close(transfer_bandlimit(Receiver::Phong(20.0)), 7.27, 1e-6));
    }

    #[test]
    fn gamma_by_hand() {
        assert_eq!(gamma(Receiver::Diffuse), 0.4);
        // m = 1: acos(1/√2) = π/4 → 0.5. m = 12: acos(0.5^{1/24}) = acos(0.971532) = 0.239 → 0.15218.
        assert!(close(gamma(Receiver::Phong(1.0)), 0.5, 1e-5));
        assert!(close(gamma(Receiver::Phong(12.0)), 0.152_18, 1e-3), "{}", gamma(Receiver::Phong(12.0)));
        assert!(gamma(Receiver::BlinnPhong(50.0)) < gamma(Receiver::BlinnPhong(12.0)));
    }

    #[test]
    fn bandwidth_and_beta_eq_4_15_4_16_by_hand() {
        // Ω_h = 2.8, z_min = 0.5, d = 0.01, μ = 0.9, α = 0.3: min(5.6, 30) = 5.6 → Ω = 5.04, β = 0.396825.
        let w = filter_bandwidth(2.8, 0.5, 0.01, 0.9, 0.3);
        assert!(close(w, 5.04, 1e-6), "{w}");
        assert!(close(filter_beta(w), 2.0 / 5.04, 1e-6));
        // Pixel limit wins for a very near reflector: z_min = 0.05 → 56 vs α/d = 30 → Ω = 27, β = 0.074074.
        let w = filter_bandwidth(2.8, 0.05, 0.01, 0.9, 0.3);
        assert!(close(w, 27.0, 1e-6), "{w}");
        assert!(close(filter_beta(w), 0.074_074, 1e-4));
        // z_min clamp: 2% of a 5 m scene = 0.1 m.
        assert!(close(clamp_z_min(0.01, 5.0, 0.02), 0.1, 1e-6));
        assert_eq!(clamp_z_min(0.3, 5.0, 0.02), 0.3);
    }

    #[test]
    fn one_pixel_filter_as_mu_grows() {
        // μ = 1e6: β far below a pixel (d = 0.01): the nearest neighbour's weight underflows to 0.
        let b = filter_beta(filter_bandwidth(2.8, 0.5, 0.01, 1e6, 0.3));
        assert!(b < 1e-6, "{b}");
        assert_eq!((-(0.01f32 * 0.01) / (2.0 * b * b)).exp(), 0.0);
        // β ∝ 1/μ.
        let b1 = filter_beta(filter_bandwidth(2.8, 0.5, 0.01, 1.0, 0.3));
        let b2 = filter_beta(filter_bandwidth(2.8, 0.5, 0.01, 2.0, 0.3));
        assert!(close(b1, 2.0 * b2, 1e-6));
    }

    #[test]
    fn samples_eq_4_21_by_hand() {
        // Diffuse: γ = 0.4, Ω_h = 2.8, d = 0.01, z_min = 0.5, z_max = 2, μ = 0.9, α = 0.3:
        // (0.9·2.8·0.01/0.5 + 0.3)² = (0.0504 + 0.3)² = 0.12278; Ω_h² = 7.84; (1 + 0.9·4)² = 21.16.
        // n = 0.4 · 0.12278016 · 7.84 · 21.16 = 8.14766.
        let n = samples_per_pixel(0.4, 2.8, 0.01, 0.5, 2.0, 0.9, 0.3);
        assert!(close(n, 8.147_66, 1e-4), "{n}");
        assert_eq!(clamp_rate(n, 0.9, 16, 100), 16, "clamped up to the 16 initial rays");
        // z_max/z_min = 20: (1 + 18)² = 361 → n = 0.4 · 0.12278 · 7.84 · 361 = 139.0 → clamp at 100.
        let n = samples_per_pixel(0.4, 2.8, 0.01, 0.5, 10.0, 0.9, 0.3);
        assert!(close(n, 139.002, 1e-3), "{n}");
        assert_eq!(clamp_rate(n, 0.9, 16, 100), 100);
        // μ = 2 raises the cap to 200: n = 0.4 (0.112 + 0.3)² 7.84 (1 + 40)² = 0.4·0.169744·7.84·1681 = 894.8 → 200.
        let n = samples_per_pixel(0.4, 2.8, 0.01, 0.5, 10.0, 2.0, 0.3);
        assert!(close(n, 894.81, 1e-3), "{n}");
        assert_eq!(clamp_rate(n, 2.0, 16, 100), 200);
        // In range: z_max/z_min = 6 → (1 + 5.4)² = 40.96 → n = 0.4·0.12278·7.84·40.96 = 15.77 → 16;
        // z_max/z_min = 8 → (8.2)² = 67.24 → 25.89 → 26.
        let n = samples_per_pixel(0.4, 2.8, 0.01, 0.5, 4.0, 0.9, 0.3);
        assert!(close(n, 25.889, 1e-3), "{n}");
        assert_eq!(clamp_rate(n, 0.9, 16, 100), 26);
        // Glossy Phong m = 12: γ = 0.15218, Ω_h = 6.07; same geometry as the first case:
        // (0.9·6.07·0.02 + 0.3)² = (0.10926 + 0.3)² = 0.167494; n = 0.15218·0.167494·36.8449·21.16 = 19.873.
        let g = gamma(Receiver::Phong(12.0));
        let n = samples_per_pixel(g, 6.07, 0.01, 0.5, 2.0, 0.9, 0.3);
        assert!(close(n, 19.873, 2e-3), "{n}");
        assert_eq!(clamp_rate(f32::INFINITY, 0.5, 16, 100), 100);
    }

    #[test]
    fn component_uses_clamped_depths() {
        let s = Settings { mu: 0.9, alpha: 0.3, z_fraction: 0.02, extent: 5.0, initial: 16, max: 100 };
        // z_min = 0.01 clamps to 0.1: Ω = 0.9·min(28, 30) = 25.2 → β = 0.079365.
        let c = component(Receiver::Diffuse, [0.01, 0.5, 16.0, 16.0], 0.01, &s);
        assert!(close(c.beta, 2.0 / 25.2, 1e-5), "{}", c.beta);
        // No hits: z_min = z_max = extent = 5: Ω = 0.9·min(0.56, 30) = 0.504 → β = 3.968;
        // n = 0.4·(0.9·2.8·0.01/5 + 0.3)²·7.84·1.9² = 1.037 → the initial 16.
        let c = component(Receiver::Diffuse, [0.0, 0.0, 0.0, 16.0], 0.01, &s);
        assert!(close(c.beta, 2.0 / 0.504, 1e-5), "{}", c.beta);
        assert_eq!(c.rays, 16);
        // ... and still a one-pixel filter as μ → ∞ (consistency): β = 2/(1e6·0.56) ≪ d.
        let c = component(Receiver::Diffuse, [0.0, 0.0, 0.0, 16.0], 0.01, &Settings { mu: 1e6, ..s });
        assert!(c.beta < 0.01 / 100.0, "{}", c.beta);
    }
}
