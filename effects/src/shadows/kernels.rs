//! The soft-shadow kernels (thesis Sec. 3.4–3.6): `shadows.bandwidth` (β, eq. 3.13),
//! `shadows.rates` (n, eq. 3.21), `shadows.visibility` (the pair ΣE, ΣU) and `shadows.shade`
//! (`r(x)` times the filtered visibility); CPU here, WGSL in `shaders/shadows_*.wgsl`.

use wedge_backends::{BackendError, Kernel, KernelCtx, KernelParams, LightIndex, Uniforms, WgslSource};

use super::formulas::{filter_beta, rays_cap, samples_per_pixel, slopes, whole_multiples};

wedge_backends::kernel_params! {
    /// Eq. 3.13's parameters as `shadows.bandwidth` reads them (WGSL: `params.NAME`, plus the light's
    /// `sigma`). `mu` is the shared declaration (`crate::params::mu`), the rest are declared here.
    pub struct BandwidthParams {
        mu: f32,
        alpha: f32 = positive(1.0, 1.0, "α = Ω_g^max/Ω_pix^max ∈ (0, 1] (eq. 3.5); 1 is conservative"),
        k: f32 = positive(3.0, 100.0, "k: Gaussian spread correction in eq. 3.13"),
        light: LightIndex = int(0, 0, 1 << 16, "index of the area light whose shadows this node filters"),
    }
}

wedge_backends::kernel_params! {
    /// Eq. 3.21's parameters as `shadows.rates` reads them (WGSL: `params.NAME`, plus the light's
    /// `sigma` and the applied `cap`); `mu`, `alpha` and `light` are declared with [`BandwidthParams`].
    pub struct RateParams {
        mu: f32,
        alpha: f32,
        light: LightIndex,
        initial_rays: u32 = int(8, 1, 4096, "first-pass light samples (thesis: 9 = 3×3; 8 is the stratified prefix of the sampler's base-2 sequence nearest it)"),
        max_rays: u32 = int(
            16,
            1,
            1 << 20,
            "cap on eq. 3.21's rays per pixel, scaled by max(μ, 1)² (64 at the default μ = 2) so μ → ∞ stays Monte Carlo; before rounding up to whole multiples of initial_rays",
        ),
        rays_cap: u32 = int(1 << 20, 1, 1 << 20, "absolute cap on rays per pixel, applied after the μ-scaled max_rays (tests, previews)"),
    }
}

wedge_backends::kernel_params! {
    /// `shadows.shade`'s one parameter, set by the node from its own.
    pub struct ShadeParams {
        light: LightIndex,
    }
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

wedge_backends::kernel_bindings! {
    /// What a `shadows.bandwidth` pass binds: the filled first-pass occluder statistics, the normal
    /// (`w` = pixel footprint), β in metres and in pixels.
    pub struct BandwidthIo / BandwidthData {
        read occlusion: [f32; 4], read normal: [f32; 4], write beta: f32, write filter_width: f32,
    }
}

wedge_backends::kernel_bindings! {
    /// What a `shadows.rates` pass binds: the statistics of [`BandwidthIo`] and the rays per pixel.
    pub struct RatesIo / RatesData {
        read occlusion: [f32; 4], read normal: [f32; 4], write rays_per_pixel: u32,
    }
}

wedge_backends::kernel_bindings! {
    /// What a `shadows.visibility` pass binds: the shadowed and unshadowed estimates, the pair.
    pub struct VisibilityIo / VisibilityData {
        read direct: [f32; 4], read unshadowed: [f32; 4], write out: [f32; 4],
    }
}

wedge_backends::kernel_bindings! {
    /// What a `shadows.shade` pass binds: the estimate, the filtered pair, the G-buffer, the shade.
    pub struct ShadeIo / ShadeData {
        read direct: [f32; 4], read visibility: [f32; 4], read position: [f32; 4], read normal: [f32; 4],
        write out: [f32; 4],
    }
}

/// `shadows.bandwidth`: β (metres) and β in pixels for the heatmap.
pub struct Bandwidth;

impl Kernel for Bandwidth {
    wedge_backends::kernel_signature!(
        name: "shadows.bandwidth", class: Bandwidth, bindings: BandwidthIo, params: [BandwidthParams]
    );
    /// WGSL mirror: `shaders/shadows_bandwidth.wgsl` with the formulas of `shaders/shadows_formulas.wgsl`.
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/shadows_bandwidth.wgsl"), |ctx| {
                let p = BandwidthParams::read(ctx)?;
                Ok(p.uniforms().f32("sigma", ctx.scene.lights[p.light.0].sigma()))
            })
            .with_include("shadows_formulas.wgsl", include_str!("../../../shaders/shadows_formulas.wgsl"))
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let BandwidthData { occlusion: occ, normal, beta: beta_out, filter_width } = BandwidthIo::read(ctx)?;
        let BandwidthParams { mu, alpha, k, light } = BandwidthParams::read(ctx)?;
        let sigma = ctx.scene.lights[light.0].sigma();
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
        beta_out.put(ctx, beta)?;
        filter_width.put(ctx, px)
    }
}

/// `shadows.rates`: total shadow rays per pixel from eq. 3.21, clamped to `[initial, max]`.
pub struct Rates;

/// `(initial_rays, cap)` as the pass applies them: at least one first-pass ray, the cap of [`rays_cap`].
fn count_bounds(p: &RateParams) -> (u32, u32) {
    let initial = p.initial_rays.max(1);
    (initial, rays_cap(i64::from(p.max_rays), p.mu, i64::from(p.rays_cap), initial))
}

impl Kernel for Rates {
    wedge_backends::kernel_signature!(name: "shadows.rates", class: Bandwidth, bindings: RatesIo, params: [RateParams]);
    /// WGSL mirror: `shaders/shadows_rates.wgsl` with the formulas of `shaders/shadows_formulas.wgsl`.
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/shadows_rates.wgsl"), |ctx| {
                let p = RateParams::read(ctx)?;
                let (initial, cap) = count_bounds(&p);
                let sigma = ctx.scene.lights[p.light.0].sigma();
                Ok(p.uniforms().f32("sigma", sigma).u32("initial", initial).u32("cap", cap))
            })
            .with_include("shadows_formulas.wgsl", include_str!("../../../shaders/shadows_formulas.wgsl"))
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let RatesData { occlusion: occ, normal, rays_per_pixel } = RatesIo::read(ctx)?;
        let p = RateParams::read(ctx)?;
        let (mu, alpha) = (p.mu, p.alpha);
        let (initial, max) = count_bounds(&p);
        let sigma = ctx.scene.lights[p.light.0].sigma();
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
        rays_per_pixel.put(ctx, n)
    }
}

/// `shadows.visibility`: the pair the filter averages for the ratio estimate of visibility —
/// `(ΣE, ΣU)` over the colour channels (one light: E and U share its colour, so any positive
/// channel weighting gives the same ratio), `w` = the estimate's samples.
pub struct Visibility;

impl Kernel for Visibility {
    wedge_backends::kernel_signature!(name: "shadows.visibility", class: Filter, bindings: VisibilityIo);
    /// WGSL mirror: `shaders/shadows_visibility.wgsl`.
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/shadows_visibility.wgsl"), |_| Ok(Uniforms::new()))
                .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let VisibilityData { direct: e, unshadowed: u, out } = VisibilityIo::read(ctx)?;
        let pair: Vec<[f32; 4]> =
            e.iter().zip(u).map(|(e, u)| [e[0] + e[1] + e[2], u[0] + u[1] + u[2], 0.0, e[3]]).collect();
        out.put(ctx, pair)
    }
}

/// `shadows.shade`: `r(x) · V`, the closed-form unoccluded irradiance of light `light` at the pixel
/// ([`wedge_scene::AreaLight::irradiance_unoccluded`], over π: unit-albedo radiance) times the
/// filtered visibility `ΣE/ΣU` (1 where no sample saw the light: nothing says it is blocked);
/// background pixels keep `direct`. `w` = the estimate's samples.
pub struct Shade;

impl Kernel for Shade {
    wedge_backends::kernel_signature!(name: "shadows.shade", class: Filter, bindings: ShadeIo, params: [ShadeParams]);
    /// WGSL mirror: `shaders/shadows_shade.wgsl` (the polygon formula term by term).
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/shadows_shade.wgsl"), |ctx| {
                let light = ctx.scene.at(0.0).light(ShadeParams::read(ctx)?.light.0);
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
        let ShadeData { direct, visibility: vis, position, normal, out } = ShadeIo::read(ctx)?;
        // A Ch. 3 kernel: the light at the shutter's centre, as the sampler's shadow rays see it.
        let light = ctx.scene.at(0.0).light(ShadeParams::read(ctx)?.light.0);
        let shaded: Vec<[f32; 4]> = (0..ctx.pixels())
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
        out.put(ctx, shaded)
    }
}
