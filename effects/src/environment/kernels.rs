//! The environment kernels: `environment.curvature` (eq. 6.20) and `environment.bandwidth` (eqs.
//! 6.13, 6.17, 6.18 per pixel, the filter widths for the heatmaps and the adaptive look-ups), CPU
//! here and WGSL in `shaders/environment_{curvature,bandwidth}.wgsl`, both on the formulas of
//! [`super::formulas`] (WGSL mirror `shaders/environment_formulas.wgsl`).
//!
//! Buffer conventions (per pixel):
//! - `position` (vec4): world position, `w` = 1 + object id (0: no hit) — the sampler's `position`;
//!   `normal` (vec4): unit normal, `w` = the pixel's footprint in metres — the sampler's `normal`.
//! - `curvature` (vec2): `(|κ_X|, |κ_Y|)` in rad/m.
//! - `environment` (vec4): the sampler's `environment` — occluder term `cos²θ_occ/z`, mean Phong
//!   exponent, look-ups, occluded look-ups.
//! - `depth` (vec4, optional): the sampler's `depth` — `z_min`, `z_max`, indirect hits, rays.
//! - Bandwidths written (vec2 each, `(B_X, B_Y)` in 1/m, μ included): `direct_diffuse`,
//!   `direct_glossy`, `indirect_diffuse`, `indirect_glossy`; for the heatmaps (f32) `bandwidth` and
//!   `filter_width` (the mean over both axes of the direct light's `B` and its σ in pixels — glossy
//!   where the surface has a lobe, else diffuse), `bandlimit` (f32: the larger axis of that `B`, what a
//!   factoring node's rates read as the environment component's own bandwidth), and `rays` (u32) the
//!   look-ups the pixel takes: the adaptive count where `adaptive` ([`AdaptiveLookUps`]) applies to
//!   it, else `base`.

pub mod filter;

use wedge_backends::{BackendError, Kernel, KernelCtx, KernelParams, PutWith, Reach, Uniforms, WgslSource};
use wedge_graph::BufferId;

use wedge_backends::kernels::v3;

use super::formulas::{self, PixelStats};

/// `|κ|` along `axis` at pixel `(x, y)` (eq. 6.20): against the next pixel along the axis where it
/// shows the same object, else the previous one, else 0.
pub fn curvature_at(
    x: i32,
    y: i32,
    width: i32,
    height: i32,
    axis: usize,
    position: &[[f32; 4]],
    normal: &[[f32; 4]],
) -> f32 {
    let i = (y * width + x) as usize;
    if !(position[i][3] > 0.0) {
        return 0.0;
    }
    for step in [1, -1] {
        let (jx, jy) = if axis == 0 { (x + step, y) } else { (x, y + step) };
        if jx < 0 || jy < 0 || jx >= width || jy >= height {
            continue;
        }
        let j = (jy * width + jx) as usize;
        if position[j][3] == position[i][3] {
            return formulas::curvature(v3(normal[i]), v3(normal[j]), v3(position[i]), v3(position[j]));
        }
    }
    0.0
}

/// `environment.curvature`: `(|κ_X|, |κ_Y|)` per pixel, and optionally their mean (`magnitude`, for a
/// heatmap).
pub struct Curvature;

wedge_backends::kernel_bindings! {
    /// What an `environment.curvature` pass binds.
    pub struct CurvatureIo / CurvatureData {
        read position: [f32; 4], read normal: [f32; 4], write curvature: [f32; 2], write_opt magnitude: f32,
    }
}

impl Kernel for Curvature {
    wedge_backends::kernel_signature!(name: "environment.curvature", class: Bandwidth, bindings: CurvatureIo);
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/environment_curvature.wgsl"), |_| Ok(Uniforms::new()))
                .with_include("environment_formulas.wgsl", include_str!("../../../shaders/environment_formulas.wgsl"))
                // The pixels next to it, above and below included: bands carry one row either side.
                .with_reach(|_| Ok(Reach::Rows(1))),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let CurvatureData { position, normal, curvature, magnitude } = CurvatureIo::read(ctx)?;
        let (w, h) = (ctx.width as i32, ctx.height as i32);
        let kappa: Vec<[f32; 2]> = ctx.map_pixels(false, |x, y| {
            let (x, y) = (x as i32, y as i32);
            [0, 1].map(|axis| curvature_at(x, y, w, h, axis, position, normal))
        });
        magnitude.put_with(ctx, || kappa.iter().map(|k| 0.5 * (k[0] + k[1])).collect())?;
        curvature.put(ctx, kappa)
    }
}

wedge_backends::param_choice! {
    /// Where the look-ups follow the filter width ([`formulas::look_ups`], an extension): nowhere (the
    /// thesis's fixed count), at glossy receivers only (the default: their filters are the narrow
    /// ones, and measured on the environment suite the diffuse receivers' extra look-ups went to
    /// error that is not the light's — docs/RESULTS.md), or at every receiver. WGSL: 0, 1, 2.
    pub enum AdaptiveLookUps { Off = "off", Glossy = "glossy", All = "all" }
}

impl AdaptiveLookUps {
    /// Whether a receiver of mean Phong exponent `exponent` (0: diffuse) takes the adaptive count.
    pub fn applies(self, exponent: f32) -> bool {
        match self {
            AdaptiveLookUps::Off => false,
            AdaptiveLookUps::Glossy => exponent > 0.0,
            AdaptiveLookUps::All => true,
        }
    }
}

wedge_backends::kernel_params! {
    /// The parameters of `environment.bandwidth` (WGSL: `params.NAME`), checked by [`bandwidth_params`].
    pub struct BandwidthParams {
        mu: f32,
        /// `B_e` in cycles per radian: the node's value, or the scene map's (Sec. 6.7: 99% energy).
        b_e: f32,
        max_radius: f32,
        /// Adaptive look-ups: where (`adaptive`), `base` (the fixed count), `sigma_ref`, `max`
        /// ([`formulas::look_ups`]).
        adaptive: AdaptiveLookUps,
        base: u32,
        sigma_ref: f32,
        max_rays: u32,
        /// The μ the filters of this pass's bandwidths will be narrowed by after it, which the
        /// adaptive count follows: 1 where `mu` is the node's own; a factoring node's μ where the
        /// pass runs at μ = 1 as its statistic ([`pixel_outputs`]).
        count_mu: f32,
    }
}

/// The pass's [`BandwidthParams`], checked, with `b_e` = -1 resolved to the scene map's.
fn bandwidth_params(ctx: &KernelCtx<'_>) -> Result<BandwidthParams, BackendError> {
    let p = BandwidthParams::read(ctx)?;
    let finite = |name: &str, v: f32, min: f32| -> Result<f32, BackendError> {
        if v.is_finite() && v >= min {
            Ok(v)
        } else {
            Err(ctx.err(format!("`{name}` = {v}; it must be a finite number >= {min}")))
        }
    };
    let count = |name: &str, c: u32| -> Result<u32, BackendError> {
        if c >= 1 {
            Ok(c)
        } else {
            Err(ctx.err(format!("`{name}` = {c}; it must be a count >= 1")))
        }
    };
    // A μ scales bandwidths: finite and > 0.
    let positive = |name: &str, v: f32| -> Result<f32, BackendError> {
        match finite(name, v, 0.0)? {
            v if v > 0.0 => Ok(v),
            v => Err(ctx.err(format!("`{name}` = {v}; it must be > 0"))),
        }
    };
    let mu = positive("mu", p.mu)?;
    // `b_e` = -1 (its declaration's special value; validation admits no other negative): the scene map's B_e.
    let b_e = match p.b_e {
        v if v >= 0.0 && v.is_finite() => v,
        _ => ctx.scene.environment.as_ref().map(|e| e.bandwidth()).ok_or_else(|| {
            ctx.err(format!("B_e comes from the scene's environment map, but scene `{}` has none", ctx.scene.name))
        })?,
    };
    Ok(BandwidthParams {
        mu,
        b_e,
        adaptive: p.adaptive,
        max_radius: finite("max_radius", p.max_radius, 0.0)?,
        base: count("base", p.base)?,
        sigma_ref: finite("sigma_ref", p.sigma_ref, 0.0)?,
        max_rays: count("max_rays", p.max_rays)?,
        count_mu: positive("count_mu", p.count_mu)?,
    })
}

/// One pixel's statistics from the input buffers.
pub fn pixel_stats(curvature: [f32; 2], environment: [f32; 4], depth: Option<[f32; 4]>) -> PixelStats {
    let z_min = match depth {
        Some(d) if d[2] > 0.0 => d[0],
        _ => 0.0,
    };
    PixelStats { kappa: curvature, occluder: environment[0], exponent: environment[1], z_min }
}

/// What `environment.bandwidth` writes for one pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelBandwidths {
    pub b: formulas::Bandwidths,
    /// Mean of the shown direct part's `(B_X, B_Y)` and of its σ in pixels.
    pub bandwidth: f32,
    /// The larger axis of the shown direct part's bandwidth: a factoring node's environment
    /// statistic (one isotropic width per pixel; the larger axis is the conservative one).
    pub bandlimit: f32,
    pub filter_width: f32,
    pub rays: u32,
}

/// [`formulas::pixel_bandwidths`] with the heatmap values and the adaptive count, for a pixel of
/// footprint `footprint` (0: no surface).
pub fn pixel_outputs(s: &PixelStats, footprint: f32, k: &BandwidthParams) -> PixelBandwidths {
    let b = formulas::pixel_bandwidths(s, k.b_e, k.mu, formulas::window_bandwidth(footprint, k.max_radius));
    let shown = if s.exponent > 0.0 { b.direct_glossy } else { b.direct_diffuse };
    let sigma = shown.map(|bx| formulas::sigma_pixels(bx, footprint, k.max_radius));
    // The widths the count follows: those of the bandwidths times `count_mu` (the same as `sigma`
    // where it is 1), so under a factoring node the count grows with the node's μ as its filters
    // narrow, as the node's own count does with its own μ.
    let sigma_count = shown.map(|bx| formulas::sigma_pixels(bx * k.count_mu, footprint, k.max_radius));
    PixelBandwidths {
        b,
        bandwidth: 0.5 * (shown[0] + shown[1]),
        bandlimit: shown[0].max(shown[1]),
        filter_width: 0.5 * (sigma[0] + sigma[1]),
        rays: if k.adaptive.applies(s.exponent) {
            formulas::look_ups(k.base, sigma_count, k.sigma_ref, k.max_rays)
        } else {
            k.base
        },
    }
}

wedge_backends::kernel_bindings! {
    /// What an `environment.bandwidth` pass binds: the curvature, the environment statistics, the
    /// normal (`w` = pixel footprint), the hit depths (indirect light); each output optional (a pass
    /// binds the bandwidths of the parts it filters and the heatmaps it shows).
    pub struct BandwidthIo / BandwidthData {
        read curvature: [f32; 2],
        read environment: [f32; 4],
        read normal: [f32; 4],
        read_opt depth: [f32; 4],
        write_opt direct_diffuse: [f32; 2],
        write_opt direct_glossy: [f32; 2],
        write_opt indirect_diffuse: [f32; 2],
        write_opt indirect_glossy: [f32; 2],
        write_opt bandwidth: f32,
        write_opt bandlimit: f32,
        write_opt filter_width: f32,
        write_opt rays: u32,
    }
}

impl BandwidthIo {
    /// The inputs with no output bound yet (a pass names the outputs it wants).
    pub fn inputs(curvature: BufferId, environment: BufferId, normal: BufferId, depth: Option<BufferId>) -> Self {
        BandwidthIo {
            curvature,
            environment,
            normal,
            depth,
            direct_diffuse: None,
            direct_glossy: None,
            indirect_diffuse: None,
            indirect_glossy: None,
            bandwidth: None,
            bandlimit: None,
            filter_width: None,
            rays: None,
        }
    }
}

/// `environment.bandwidth`: the bandwidths of eqs. 6.13, 6.17 and 6.18 per pixel (every output
/// optional; see the module doc).
pub struct Bandwidth;

impl Kernel for Bandwidth {
    wedge_backends::kernel_signature!(
        name: "environment.bandwidth", class: Bandwidth, bindings: BandwidthIo, params: [BandwidthParams]
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/environment_bandwidth.wgsl"), |ctx| {
                Ok(bandwidth_params(ctx)?.uniforms())
            })
            .with_include("environment_formulas.wgsl", include_str!("../../../shaders/environment_formulas.wgsl"))
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let k = bandwidth_params(ctx)?;
        let io = BandwidthIo::read(ctx)?;
        let (curvature, environment, normal, depth) = (io.curvature, io.environment, io.normal, io.depth);
        let out: Vec<PixelBandwidths> = ctx.map_pixels(false, |x, y| {
            let i = (y * ctx.width + x) as usize;
            let s = pixel_stats(curvature[i], environment[i], depth.map(|d| d[i]));
            pixel_outputs(&s, normal[i][3], &k)
        });
        let vec2 = |f: fn(&formulas::Bandwidths) -> [f32; 2]| out.iter().map(|o| f(&o.b)).collect::<Vec<[f32; 2]>>();
        io.direct_diffuse.put_with(ctx, || vec2(|b| b.direct_diffuse))?;
        io.direct_glossy.put_with(ctx, || vec2(|b| b.direct_glossy))?;
        io.indirect_diffuse.put_with(ctx, || vec2(|b| b.indirect_diffuse))?;
        io.indirect_glossy.put_with(ctx, || vec2(|b| b.indirect_glossy))?;
        io.bandwidth.put_with(ctx, || out.iter().map(|o| o.bandwidth).collect())?;
        io.bandlimit.put_with(ctx, || out.iter().map(|o| o.bandlimit).collect())?;
        io.filter_width.put_with(ctx, || out.iter().map(|o| o.filter_width).collect())?;
        io.rays.put_with(ctx, || out.iter().map(|o| o.rays).collect())
    }
}
