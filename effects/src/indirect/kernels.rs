//! The indirect-light kernels: `indirect.bandwidth` (β per component, eqs. 4.15–4.16) and
//! `indirect.rates` (n per component, eq. 4.21), both from the first pass's reflector depths;
//! CPU here, WGSL in `shaders/indirect_{bandwidth,rates}.wgsl`.

use wedge_backends::kernels::hemisphere::Lobe;
use wedge_backends::kernels::neighbourhood_others::SAME_OBJECT_NEIGHBOUR;
use wedge_backends::{BackendError, Kernel, KernelCtx, KernelParams, Reach, Uniforms, WgslSource};

use super::formulas::{component, nearest, Receiver, Settings};

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
        width_alpha: f32 = float(4.0, 0.0, 16.0, "α of eq. 4.15's pixel bound in the filter width alone (β ≥ 2/(μ·width_alpha) px; 0 = alpha, the thesis); the rates keep alpha. 4 since issue 34's matrix (1 kept β ≥ 2.2 px and lost to the unfiltered image at 48×36)"),
    }
}

/// The formulas' settings and whether glossy receivers are Blinn-Phong; `with_rates` = false for
/// the bandwidth pass (counts of 1: it computes no rates).
fn settings(ctx: &KernelCtx<'_>, with_rates: bool) -> Result<(RateParams, Settings, bool), BackendError> {
    let p = RateParams::read(ctx)?;
    let s = Settings {
        mu: p.mu,
        alpha: p.alpha,
        width_alpha: if p.width_alpha > 0.0 { p.width_alpha } else { p.alpha },
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

wedge_backends::kernel_bindings! {
    /// What an `indirect.bandwidth` pass binds: the first pass's depth statistics, the normal
    /// (`w` = pixel footprint), the specular G-buffer where glossy receivers are filtered, the
    /// neighbourhood's nearest reflector (`width_z_min: "nearest"`), and β per component (glossy only
    /// where bound) and in pixels.
    pub struct BandwidthIo / BandwidthData {
        read depth: [f32; 4], read normal: [f32; 4], read_opt specular: [f32; 4], read_opt nearest: f32,
        write beta_diffuse: f32, write_opt beta_glossy: f32, write filter_width: f32,
    }
}

wedge_backends::kernel_bindings! {
    /// What an `indirect.rates` pass binds: the inputs of [`BandwidthIo`], the samples per pixel
    /// per component (glossy only where bound) and their sum.
    pub struct RatesIo / RatesData {
        read depth: [f32; 4], read normal: [f32; 4], read_opt specular: [f32; 4], write rays_diffuse: u32,
        write_opt rays_glossy: u32, write rays_per_pixel: u32,
    }
}

impl Kernel for Bandwidth {
    wedge_backends::kernel_signature!(
        name: "indirect.bandwidth", class: Bandwidth, bindings: BandwidthIo, params: [RateParams]
    );
    /// WGSL mirror: `shaders/indirect_bandwidth.wgsl` with the formulas of `shaders/indirect_formulas.wgsl`.
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/indirect_bandwidth.wgsl"), uniforms)
                .with_include("indirect_formulas.wgsl", include_str!("../../../shaders/indirect_formulas.wgsl"))
                .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let io = BandwidthIo::read(ctx)?;
        let (depth, normal, spec) = (io.depth, io.normal, io.specular);
        let (_, s, blinn) = settings(ctx, false)?;
        let active = |i: usize| depth[i][3] > 0.0;
        let near = |i: usize| io.nearest.map_or(0.0, |z| z[i]);
        let beta = |r, i: usize| component(r, depth[i], near(i), normal[i][3], &s).beta;
        let beta_d: Vec<f32> =
            (0..ctx.pixels()).map(|i| if active(i) { beta(Receiver::Diffuse, i) } else { 0.0 }).collect();
        let px = beta_d.iter().zip(normal).map(|(b, n)| if *b > 0.0 { b / n[3] } else { 0.0 }).collect::<Vec<f32>>();
        if let Some(beta_glossy) = io.beta_glossy {
            let beta_g = (0..beta_d.len())
                .map(|i| match glossy_receiver(spec, i, blinn) {
                    Some(r) if active(i) => beta(r, i),
                    _ => 0.0,
                })
                .collect::<Vec<f32>>();
            beta_glossy.put(ctx, beta_g)?;
        }
        io.beta_diffuse.put(ctx, beta_d)?;
        io.filter_width.put(ctx, px)
    }
}

/// `indirect.rates`: samples per pixel per component from eq. 4.21, clamped to `[16, 100·max(μ,1)]`,
/// and their sum (the `rays_per_pixel` heatmap).
pub struct Rates;

impl Kernel for Rates {
    wedge_backends::kernel_signature!(
        name: "indirect.rates", class: Bandwidth, bindings: RatesIo, params: [RateParams]
    );
    /// WGSL mirror: `shaders/indirect_rates.wgsl` with the formulas of `shaders/indirect_formulas.wgsl`.
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/indirect_rates.wgsl"), uniforms)
                .with_include("indirect_formulas.wgsl", include_str!("../../../shaders/indirect_formulas.wgsl"))
                .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let io = RatesIo::read(ctx)?;
        let (depth, normal, spec) = (io.depth, io.normal, io.specular);
        let (p, s, blinn) = settings(ctx, true)?;
        let glossy_bound = io.rays_glossy.is_some();
        let cap = p.rays_cap.max(1);
        let per: Vec<(u32, u32)> = (0..ctx.pixels())
            .map(|i| {
                if depth[i][3] <= 0.0 {
                    return (0, 0);
                }
                // The rates do not read the width's nearest reflector (0 = none).
                let nd = component(Receiver::Diffuse, depth[i], 0.0, normal[i][3], &s).rays;
                let ng = match glossy_receiver(spec, i, blinn) {
                    Some(r) if glossy_bound => component(r, depth[i], 0.0, normal[i][3], &s).rays,
                    _ => 0,
                };
                (nd.min(cap), ng.min(cap))
            })
            .collect();
        if let Some(rays_glossy) = io.rays_glossy {
            rays_glossy.put(ctx, per.iter().map(|p| p.1).collect())?;
        }
        io.rays_per_pixel.put(ctx, per.iter().map(|p| p.0 + p.1).collect())?;
        io.rays_diffuse.put(ctx, per.iter().map(|p| p.0).collect())
    }
}

wedge_backends::kernel_bindings! {
    /// What an `indirect.nearest` pass binds: the first pass's depth statistics, the position (`w` =
    /// object) and the nearest reflector per pixel.
    pub struct NearestIo / NearestData {
        read depth: [f32; 4], read position: [f32; 4], write nearest: f32,
    }
}

/// `indirect.nearest` (`width_z_min: "nearest"`): per pixel, the nearest reflector its eight
/// neighbours' first passes saw on its object ([`nearest`]), for the width of eq. 4.15.
pub struct Nearest;

impl Kernel for Nearest {
    wedge_backends::kernel_signature!(name: "indirect.nearest", class: Bandwidth, bindings: NearestIo);
    /// WGSL mirror: `shaders/indirect_nearest.wgsl`.
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/indirect_nearest.wgsl"), |_| Ok(Uniforms::new()))
                .with_include(SAME_OBJECT_NEIGHBOUR.0, SAME_OBJECT_NEIGHBOUR.1)
                .with_reach(|_| Ok(Reach::Rows(1))),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let io = NearestIo::read(ctx)?;
        let (w, h) = (ctx.width as i32, ctx.height as i32);
        let out = ctx.map_pixels(false, |x, y| nearest(io.depth, io.position, w, h, x as i32, y as i32));
        io.nearest.put(ctx, out)
    }
}
