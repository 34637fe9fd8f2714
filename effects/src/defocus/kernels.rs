//! The defocus kernels: `defocus.rates`, `defocus.flags` and `defocus.compose` (thesis Sec. 5.7–5.8),
//! CPU here and WGSL in `shaders/defocus_{rates,flags,compose}.wgsl`, all built on the formulas of
//! [`super::formulas`] (WGSL mirror: `shaders/defocus_formulas.wgsl`).
//!
//! Buffer conventions (per pixel; `w > 0` marks a statistic that exists):
//! - `lens` (vec4): `r_min`, `r_max` (|circle of confusion| in pixels over the pixel's lens samples,
//!   eq. 5.2), lens-averaged depth along the optical axis, and `w > 0` where some primary ray hit (a
//!   hit count, or `ℓ_p` as `paths.resolve`'s `defocus` output has it; 0: every primary ray missed).
//! - `occlusion` (vec4, optional): `d1`, `d2_min`, `d2_max` as `shadows.rs` defines them (slopes by
//!   eq. 5.17 / 3.4), `w > 0` when some shadow sample was occluded. Unbound: no occluders anywhere.
//! - `reflectors` (vec4, optional): `z_min`, `z_max` (distances to indirect reflectors), indirect
//!   samples that hit (`> 0`: the statistic exists), indirect samples — the layout `indirect.sample`
//!   and `paths.resolve` write as `depth`. Unbound: no reflector terms.
//! - `bandlimit` (f32, optional): the environment component's own spatial bandwidth `B` (1/m, Ch. 6's
//!   eqs. 6.13/6.17, as `environment.bandwidth` writes it), 0 where none. Unbound: no environment terms.
//! - `velocity`, `shadow_velocity` (vec4, optional): where the paths also sample the shutter, the
//!   sampler's image velocities (mean, per-axis range; px per half shutter) of the primary hits and of
//!   the occluded shadow samples; their fastest speeds add the time factors to the counts
//!   (`formulas::time_factor`). Unbound: still.
//! - `radiance`, `texture`, `irradiance` (vec3 rgb): one component's lens-integrated `L`, `k`, `E`
//!   (eqs. 5.9, 5.13, 5.14 direct; 5.21 indirect), as `paths.resolve` writes them.

pub mod filter;

use wedge_backends::{
    BackendError, Binding, Kernel, KernelClass, KernelCtx, KernelParams, LightIndex, ParamSpec, Uniforms, WgslSource,
};
use wedge_graph::Format;

use super::formulas::{self, Mode, PixelRates, PixelStats, RateParams};
use crate::motion::formulas::fastest_speed;
use crate::shadows::slopes;

/// Largest `max_primary` / `max_per_primary` a pass may ask for: 64² strata each, so a total
/// `p² s²` stays far inside `u32`.
pub const MAX_COUNT_CAP: i64 = 4096;

wedge_backends::kernel_params! {
    /// What every `defocus.rates` (and `motion.rates`) pass carries (`component::rate_settings`):
    /// the rate constants checked by [`rate_params`]; its optional settings are [`RateOptions`].
    pub struct RatesParams {
        mu: f32,
        mode: Mode,
        omega_pix: f32,
        omega_v: f32,
        max_primary: i32,
        max_per_primary: i32,
    }
}

wedge_backends::kernel_params! {
    /// The rate settings a pass may leave out, their defaults applied in [`rate_params`] (not
    /// uploaded as they are: the WGSL reads the values applied).
    pub struct RateOptions {
        pixel_scale: Option<f32>,
        light_half_width: Option<f32>,
        light: Option<LightIndex>,
        environment_per_primary: Option<f32>,
        width_pixel_limit: Option<bool>,
    }
}

wedge_backends::kernel_params! {
    /// `defocus.flags`'s threshold on `‖L − k E‖` (eq. 5.30), finite and ≥ 0.
    pub struct FlagsParams {
        threshold: f32,
    }
}

/// `defocus.flags`'s threshold, checked.
fn threshold(ctx: &KernelCtx<'_>) -> Result<f32, BackendError> {
    positive(ctx, "threshold", FlagsParams::read(ctx)?.threshold, true)
}

/// A number parameter that must be finite and above (or, with `zero_ok`, at least) 0.
fn positive(ctx: &KernelCtx<'_>, name: &str, v: f32, zero_ok: bool) -> Result<f32, BackendError> {
    if v.is_finite() && (v > 0.0 || (zero_ok && v == 0.0)) {
        return Ok(v);
    }
    Err(BackendError::Kernel {
        pass: ctx.pass.to_string(),
        message: format!(
            "parameter `{name}` = {v}; it must be a finite number {}",
            if zero_ok { ">= 0" } else { "> 0" }
        ),
    })
}

/// A count cap as the pass applies it: as given in `literal` mode; in `consistent` mode scaled by
/// `max(μ, 1)²` (counts grow about as μ² per factor), so the caps do not stop the convergence to
/// Monte Carlo that the mode is for (up to [`MAX_COUNT_CAP`]). Ch. 4 scales its cap the same way
/// (100μ rays).
pub fn scaled_cap(cap: i32, mu: f32, mode: Mode) -> u32 {
    let cap = i64::from(cap).clamp(1, MAX_COUNT_CAP);
    let scaled = match mode {
        Mode::Literal => cap as f64,
        Mode::Consistent => cap as f64 * f64::from(mu.max(1.0)).powi(2),
    };
    scaled.min(MAX_COUNT_CAP as f64) as u32
}

/// The pass's rate constants from its parameter block. `pixel_scale` (m) defaults to the scene
/// camera's at the image height; `light_half_width` (ℓ_I) to the half-width of area light `light`
/// where that is given, else 0 (no light term: no area light, or a point light).
pub fn rate_params(ctx: &KernelCtx<'_>) -> Result<RateParams, BackendError> {
    let o = RateOptions::read(ctx)?;
    let pixel_scale = match o.pixel_scale {
        Some(v) => positive(ctx, "pixel_scale", v, false)?,
        None => formulas::pixel_scale(ctx.scene.camera.vfov_deg, ctx.full_size().1),
    };
    let light_half_width = match (o.light_half_width, o.light) {
        (Some(v), _) => positive(ctx, "light_half_width", v, true)?,
        (None, Some(light)) => formulas::light_half_width(&ctx.scene.lights[light.0]),
        (None, None) => 0.0,
    };
    let p = RatesParams::read(ctx)?;
    let (mu, mode) = (positive(ctx, "mu", p.mu, false)?, p.mode);
    // Look-ups per primary ray of an environment component (absent: 1, no environment component).
    let environment_per_primary = match o.environment_per_primary {
        Some(v) => positive(ctx, "environment_per_primary", v, false)?,
        None => 1.0,
    };
    Ok(RateParams {
        mu,
        mode,
        omega_pix: positive(ctx, "omega_pix", p.omega_pix, false)?,
        pixel_scale,
        light_half_width,
        omega_v: positive(ctx, "omega_v", p.omega_v, false)?,
        max_primary: scaled_cap(p.max_primary, mu, mode),
        max_per_primary: scaled_cap(p.max_per_primary, mu, mode),
        environment_per_primary,
        // Absent (a component's rates, which write no screen width): the thesis's.
        width_pixel_limit: o.width_pixel_limit.unwrap_or(true),
    })
}

/// The optional statistics of a pixel beside its `lens`: where each is unbound, `None`.
#[derive(Clone, Copy, Debug, Default)]
pub struct OptionalStats {
    pub occlusion: Option<[f32; 4]>,
    pub reflectors: Option<[f32; 4]>,
    pub bandlimit: Option<f32>,
    pub velocity: Option<[f32; 4]>,
    pub shadow_velocity: Option<[f32; 4]>,
}

/// One pixel's statistics from the input buffers.
pub fn pixel_stats(lens: [f32; 4], o: OptionalStats) -> PixelStats {
    let OptionalStats { occlusion, reflectors, bandlimit, velocity, shadow_velocity } = o;
    let (s_min, s_max) = match occlusion {
        Some(o) if o[3] > 0.0 => slopes(o[0], o[1], o[2]),
        _ => (0.0, 0.0),
    };
    let (z_min, z_max) = match reflectors {
        Some(z) if z[2] > 0.0 => (z[0], z[1]),
        _ => (0.0, 0.0),
    };
    let bandlimit = formulas::bandlimit_of(bandlimit);
    // Speeds for the counts where the paths sample the shutter; the shadow's only where occluded.
    let occluded = occlusion.is_some_and(|o| o[3] > 0.0);
    let v_p = velocity.map_or(0.0, fastest_speed);
    let v_s = shadow_velocity.filter(|_| occluded).map_or(0.0, fastest_speed);
    PixelStats {
        r_min: lens[0],
        r_max: lens[1],
        depth: lens[2],
        hit: lens[3] > 0.0,
        s_min,
        s_max,
        z_min,
        z_max,
        bandlimit,
        v_p,
        v_s,
    }
}

/// `defocus.rates`: per pixel the μ-scaled widths `Ω_x^d`, `Ω_x^s`, `Ω_x^i` (eqs. 5.7, 5.18, 5.22,
/// 5.29), `ℓ_p`, and the rounded counts `n_p`, `n_dir^{f|c}`, `n_ind^{f|c}` (eqs. 5.24–5.28). The
/// defocus, direct and indirect outputs are optional (a component node binds only its own; the
/// Defocus node only the defocus ones).
/// With a (median-filtered) factoring flag bound (`flag_direct`, `flag_indirect`; eq. 5.30),
/// `n_direct` / `n_indirect` is the count the pixel takes: `^f` where the flag is set, else `^c`
/// (Sec. 5.7); unbound, the pixel is combined (`^c`). `sigma_*` are the widths as the filters'
/// Gaussian standard deviation in pixels, `1/(√32 Ω)` (eqs. 5.31, 5.33), for heatmaps.
pub struct Rates;

/// A width `Ω` (pixel⁻¹) as the standard deviation in pixels of the Ch. 5 filters' Gaussian
/// `exp(−16 d² Ω²)`: `σ = 1/(√32 Ω)`.
/// (`√32` written out, as `shaders/defocus_formulas.wgsl` does, so both backends divide by the same
/// number.)
pub fn sigma_px(omega: f32) -> f32 {
    1.0 / (5.656_854 * omega)
}

impl Kernel for Rates {
    fn name(&self) -> &'static str {
        "defocus.rates"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Bandwidth
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("lens", Format::Vec4),
            Binding::read_opt("occlusion", Format::Vec4),
            Binding::read_opt("reflectors", Format::Vec4),
            Binding::read_opt("flag_direct", Format::U32),
            Binding::read_opt("flag_indirect", Format::U32),
            Binding::read_opt("bandlimit", Format::F32),
            Binding::read_opt("flag_environment", Format::U32),
            Binding::read_opt("velocity", Format::Vec4),
            Binding::read_opt("shadow_velocity", Format::Vec4),
            Binding::write_opt("omega_defocus", Format::F32),
            Binding::write("pixel_length", Format::F32),
            Binding::write_opt("n_primary", Format::U32),
            Binding::write_opt("omega_direct", Format::F32),
            Binding::write_opt("n_direct_factored", Format::U32),
            Binding::write_opt("n_direct_combined", Format::U32),
            Binding::write_opt("omega_indirect", Format::F32),
            Binding::write_opt("n_indirect_factored", Format::U32),
            Binding::write_opt("n_indirect_combined", Format::U32),
            Binding::write_opt("n_direct", Format::U32),
            Binding::write_opt("n_indirect", Format::U32),
            Binding::write_opt("omega_environment", Format::F32),
            Binding::write_opt("n_environment", Format::U32),
            Binding::write_opt("sigma_defocus", Format::F32),
            Binding::write_opt("sigma_direct", Format::F32),
            Binding::write_opt("sigma_indirect", Format::F32),
            Binding::write_opt("sigma_environment", Format::F32),
        ]
    }
    fn params(&self) -> Vec<ParamSpec> {
        [RatesParams::specs(), RateOptions::specs()].concat()
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/defocus_rates.wgsl"), |ctx| {
                let k = rate_params(ctx)?;
                Ok(RatesParams::read(ctx)?
                    .uniforms()
                    .f32("pixel_scale", k.pixel_scale)
                    .f32("light_half_width", k.light_half_width)
                    .u32("max_p", formulas::strata_cap(k.max_primary))
                    .u32("max_s", formulas::strata_cap(k.max_per_primary))
                    .f32("environment_per_primary", k.environment_per_primary)
                    .u32("width_pixel_limit", u32::from(k.width_pixel_limit)))
            })
            .with_include("defocus_formulas.wgsl", include_str!("../../../shaders/defocus_formulas.wgsl"))
            .with_include("shadows_formulas.wgsl", include_str!("../../../shaders/shadows_formulas.wgsl"))
            .with_include("velocity.wgsl", include_str!("../../../shaders/velocity.wgsl"))
            .with_include("motion_formulas.wgsl", include_str!("../../../shaders/motion_formulas.wgsl"))
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let k = rate_params(ctx)?;
        let lens = ctx.read::<[f32; 4]>("lens")?;
        let occlusion = ctx.read_opt::<[f32; 4]>("occlusion")?;
        let reflectors = ctx.read_opt::<[f32; 4]>("reflectors")?;
        let flag_direct = ctx.read_opt::<u32>("flag_direct")?;
        let flag_indirect = ctx.read_opt::<u32>("flag_indirect")?;
        let bandlimit = ctx.read_opt::<f32>("bandlimit")?;
        let flag_environment = ctx.read_opt::<u32>("flag_environment")?;
        let velocity = ctx.read_opt::<[f32; 4]>("velocity")?;
        let shadow_velocity = ctx.read_opt::<[f32; 4]>("shadow_velocity")?;
        let rates: Vec<PixelRates> = ctx.map_pixels(false, |x, y| {
            let i = (y * ctx.width + x) as usize;
            let at = |b: Option<&[[f32; 4]]>| b.map(|b| b[i]);
            let o = OptionalStats {
                occlusion: at(occlusion),
                reflectors: at(reflectors),
                bandlimit: bandlimit.map(|b| b[i]),
                velocity: at(velocity),
                shadow_velocity: at(shadow_velocity),
            };
            let s = pixel_stats(lens[i], o);
            formulas::pixel_rates(&s, &k)
        });
        let column = |f: fn(&PixelRates) -> f32| rates.iter().map(f).collect::<Vec<f32>>();
        let count = |f: fn(&PixelRates) -> u32| rates.iter().map(f).collect::<Vec<u32>>();
        ctx.put_opt("omega_defocus", || column(|r| r.omega_defocus))?;
        ctx.put("pixel_length", column(|r| r.pixel_length))?;
        ctx.put_opt("n_primary", || count(|r| r.n_primary))?;
        ctx.put_opt("omega_direct", || column(|r| r.omega_direct))?;
        ctx.put_opt("n_direct_factored", || count(|r| r.n_direct_factored))?;
        ctx.put_opt("n_direct_combined", || count(|r| r.n_direct_combined))?;
        ctx.put_opt("omega_indirect", || column(|r| r.omega_indirect))?;
        ctx.put_opt("n_indirect_factored", || count(|r| r.n_indirect_factored))?;
        ctx.put_opt("n_indirect_combined", || count(|r| r.n_indirect_combined))?;
        let pick = |flag: Option<&[u32]>, f: fn(&PixelRates) -> u32, c: fn(&PixelRates) -> u32| {
            rates
                .iter()
                .enumerate()
                .map(|(i, r)| if flag.is_some_and(|g| g[i] != 0) { f(r) } else { c(r) })
                .collect::<Vec<u32>>()
        };
        ctx.put_opt("n_direct", || pick(flag_direct, |r| r.n_direct_factored, |r| r.n_direct_combined))?;
        ctx.put_opt("n_indirect", || pick(flag_indirect, |r| r.n_indirect_factored, |r| r.n_indirect_combined))?;
        ctx.put_opt("omega_environment", || column(|r| r.omega_environment))?;
        ctx.put_opt("n_environment", || {
            pick(flag_environment, |r| r.n_environment_factored, |r| r.n_environment_combined)
        })?;
        ctx.put_opt("sigma_defocus", || column(|r| sigma_px(r.omega_defocus)))?;
        ctx.put_opt("sigma_direct", || column(|r| sigma_px(r.omega_direct)))?;
        ctx.put_opt("sigma_indirect", || column(|r| sigma_px(r.omega_indirect)))?;
        ctx.put_opt("sigma_environment", || column(|r| sigma_px(r.omega_environment)))
    }
}

wedge_backends::kernel_bindings! {
    /// What a `defocus.flags` pass binds: a part's `L`, `k` and `E`, and its flag.
    pub struct FlagsIo / FlagsData {
        read radiance: [f32; 3], read texture: [f32; 3], read irradiance: [f32; 3], write flag: u32,
    }
}

wedge_backends::kernel_bindings! {
    /// What a `defocus.compose` pass binds: [`FlagsIo`]'s inputs, the flag, the running sum
    /// (optional: the first part starts at 0) and the new sum.
    pub struct ComposeIo / ComposeData {
        read radiance: [f32; 3], read texture: [f32; 3], read irradiance: [f32; 3], read flag: u32,
        read_opt previous: [f32; 3], write out: [f32; 3],
    }
}

/// `defocus.flags`: SepDir / SepInd for one component (eq. 5.30), 1 where `‖L − k E‖ < threshold`,
/// else 0 (also where any input is not finite). The 3×3 median (`neighbourhood.median3`) follows.
pub struct Flags;

impl Kernel for Flags {
    fn name(&self) -> &'static str {
        "defocus.flags"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Bandwidth
    }
    fn bindings(&self) -> Vec<Binding> {
        FlagsIo::bindings()
    }
    fn params(&self) -> Vec<ParamSpec> {
        FlagsParams::specs()
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/defocus_flags.wgsl"), |ctx| {
                Ok(FlagsParams { threshold: threshold(ctx)? }.uniforms())
            })
            .with_include("defocus_formulas.wgsl", include_str!("../../../shaders/defocus_formulas.wgsl"))
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let FlagsData { radiance: l, texture: k, irradiance: e, flag: out } = FlagsIo::read(ctx)?;
        let threshold = threshold(ctx)?;
        let flag: Vec<u32> = ctx.map_pixels(false, |x, y| {
            let i = (y * ctx.width + x) as usize;
            formulas::separable(l[i], k[i], e[i], threshold) as u32
        });
        out.put(ctx, flag)
    }
}

/// `defocus.compose`: one component of eq. 5.32 added to a running sum,
/// `out = previous + (flag ? k E : L)` with `E` the filtered irradiance and `flag` the (median-filtered)
/// SepDir / SepInd. One pass per component (direct; indirect diffuse; indirect glossy), each reading
/// the previous pass's `out` as `previous` (unbound for the first: the sum starts at 0). Non-finite
/// values pass through unchanged
/// to the defocus filter, which counts and excludes them (counting here too would count them twice).
pub struct Compose;

impl Kernel for Compose {
    fn name(&self) -> &'static str {
        "defocus.compose"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Compose
    }
    fn bindings(&self) -> Vec<Binding> {
        ComposeIo::bindings()
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/defocus_compose.wgsl"), |_| Ok(Uniforms::new()))
                .with_include("defocus_formulas.wgsl", include_str!("../../../shaders/defocus_formulas.wgsl"))
                .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let ComposeData { radiance: l, texture: k, irradiance: e, flag, previous, out } = ComposeIo::read(ctx)?;
        let sum: Vec<[f32; 3]> = ctx.map_pixels(false, |x, y| {
            let i = (y * ctx.width + x) as usize;
            let t = formulas::compose_term(l[i], k[i], e[i], flag[i] != 0);
            match previous {
                Some(p) => [p[i][0] + t[0], p[i][1] + t[1], p[i][2] + t[2]],
                None => t,
            }
        });
        out.put(ctx, sum)
    }
}
