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

pub mod all_factored;
pub mod filter;
pub mod layers;
pub mod risk;

use wedge_backends::{BackendError, Kernel, KernelCtx, KernelParams, LightIndex, PutWith, Uniforms, WgslSource};
use wedge_graph::{BufferId, Component, ExpandCtx, GraphError, ParamValue};

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
        /// Cap on shadow rays per primary ray (direct light); absent: `max_per_primary`.
        max_shadow_per_primary: Option<i32>,
        /// Cap on a moving pixel's primary rays (`formulas::primary_cap`); absent: `max_primary`.
        max_primary_moving: Option<i32>,
        width_pixel_limit: Option<bool>,
        /// The Defocus node's `screen_scale`: eq. 5.33's width times it; absent: 1 (the thesis).
        screen_scale: Option<f32>,
        /// Its `screen_scale_factored`: the factor instead where the `flag` binding is set (on the
        /// node's own pass: `defocus.all_factored`'s pixels); absent: `screen_scale` everywhere.
        screen_scale_factored: Option<f32>,
        /// The Defocus node's `screen_scale_wide`: the factor of the `omega_defocus_wide` output (the
        /// risk-based width's wider filter, everywhere: `screen_scale_factored` does not apply to it);
        /// absent: `screen_scale`.
        screen_scale_wide: Option<f32>,
        component: Option<RateComponent>,
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

/// The factors on eq. 5.33's screen-space width (the Defocus node's `screen_scale`, and
/// `screen_scale_factored` where the `flag` binding is set), checked: finite numbers > 0; 1 where
/// the pass leaves `screen_scale` out, `screen_scale` where it leaves the others out.
fn screen_scales(ctx: &KernelCtx<'_>) -> Result<ScreenScales, BackendError> {
    let o = RateOptions::read(ctx)?;
    let other = o.screen_scale.map_or(Ok(1.0), |v| positive(ctx, "screen_scale", v, false))?;
    let factored = o.screen_scale_factored.map_or(Ok(other), |v| positive(ctx, "screen_scale_factored", v, false))?;
    let wide = o.screen_scale_wide.map_or(Ok(other), |v| positive(ctx, "screen_scale_wide", v, false))?;
    Ok(ScreenScales { factored, other, wide })
}

/// The factors of [`screen_scales`].
#[derive(Clone, Copy)]
struct ScreenScales {
    factored: f32,
    other: f32,
    /// `omega_defocus_wide`'s, on every pixel.
    wide: f32,
}

impl ScreenScales {
    fn at(self, flag_set: bool) -> f32 {
        if flag_set {
            self.factored
        } else {
            self.other
        }
    }
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
        max_primary_moving: scaled_cap(o.max_primary_moving.unwrap_or(p.max_primary), mu, mode),
        max_per_primary: scaled_cap(p.max_per_primary, mu, mode),
        max_shadow_per_primary: scaled_cap(o.max_shadow_per_primary.unwrap_or(p.max_per_primary), mu, mode),
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

wedge_backends::param_choice! {
    /// Which lighting component a rates pass sizes (`defocus.rates` and `motion.rates`' `component`
    /// parameter): its width and count are written as `omega`, `n`, `sigma` — fixed binding names,
    /// so one declaration ([`RatesIo`], `motion::kernels::RatesIo`) serves the factoring node's own
    /// pass and every component's (`docs/DESIGN-NOTES.md` "One rates kernel, fixed names").
    pub enum RateComponent {
        /// The light's occluder term (eqs. 5.18, 5.25, 5.26).
        Direct = "direct",
        /// The reflector-depth term (eqs. 5.22, 5.27, 5.28).
        Indirect = "indirect",
        /// The environment's Ch. 6 bandwidth (`formulas::omega_environment`).
        Environment = "environment",
    }
}

impl RateComponent {
    /// The component a [`Component`] node declares (its `name`), refused naming the node otherwise.
    pub fn of(ctx: &ExpandCtx<'_>, c: &Component) -> Result<RateComponent, GraphError> {
        RateComponent::parse(c.name).ok_or_else(|| GraphError::Expand {
            node: ctx.node().into(),
            message: format!(
                "lighting component `{}` has no rates: a factoring node sizes one of {:?}",
                c.name,
                RateComponent::OPTIONS
            ),
        })
    }
    /// The pass parameter that names it.
    pub fn param(self) -> (&'static str, ParamValue) {
        ("component", ParamValue::Str(self.as_str().into()))
    }
    /// Its width and the count a pixel takes (factored where `factors`, else combined) among the
    /// pixel's rates; inlined, so that a constant component leaves the others' rates unread.
    #[inline(always)]
    fn pick(self, r: &PixelRates, factors: bool) -> (f32, u32) {
        let (omega, factored, combined) = match self {
            RateComponent::Direct => (r.omega_direct, r.n_direct_factored, r.n_direct_combined),
            RateComponent::Indirect => (r.omega_indirect, r.n_indirect_factored, r.n_indirect_combined),
            RateComponent::Environment => (r.omega_environment, r.n_environment_factored, r.n_environment_combined),
        };
        (omega, if factors { factored } else { combined })
    }
}

/// A component's first-pass statistic where the rates kernels read it: [`Component::statistic`]
/// names the binding (`occlusion`, `reflectors` or `bandlimit`), the one place a binding is chosen
/// by name — the component node's declaration, checked here.
#[derive(Clone, Copy, Debug, Default)]
pub struct Statistic {
    pub occlusion: Option<BufferId>,
    pub reflectors: Option<BufferId>,
    pub bandlimit: Option<BufferId>,
}

impl Statistic {
    /// The component's statistic buffer in its binding; an unknown binding is refused naming it.
    pub fn of(ctx: &mut ExpandCtx<'_>, c: &Component) -> Result<Statistic, GraphError> {
        let id = Some(c.statistic(ctx)?);
        match c.statistic.0 {
            "occlusion" => Ok(Statistic { occlusion: id, ..Statistic::default() }),
            "reflectors" => Ok(Statistic { reflectors: id, ..Statistic::default() }),
            "bandlimit" => Ok(Statistic { bandlimit: id, ..Statistic::default() }),
            other => Err(GraphError::Expand {
                node: ctx.node().into(),
                message: format!(
                    "lighting component `{}` declares the statistic `{other}`; the rates kernels read `occlusion`, \
                     `reflectors` or `bandlimit`",
                    c.name
                ),
            }),
        }
    }
}

wedge_backends::kernel_bindings! {
    /// What a `defocus.rates` pass binds. The factoring node's own pass reads `lens` (and `velocity`
    /// under a shutter) and writes the primary outputs; a component's pass reads its [`Statistic`]
    /// too (the shadow's velocity for direct light, its first-pass flag) and writes its width and
    /// count as `omega`, `n`, `sigma` for the [`RateComponent`] its `component` parameter names.
    pub struct RatesIo / RatesData {
        read lens: [f32; 4],
        read_opt occlusion: [f32; 4],
        read_opt reflectors: [f32; 4],
        read_opt bandlimit: f32,
        read_opt velocity: [f32; 4],
        read_opt shadow_velocity: [f32; 4],
        /// The component's (median-filtered) factoring flag (eq. 5.30): `n` is `n^f` where it is
        /// set, else `n^c`; unbound, every pixel is combined. On the factoring node's own pass,
        /// `defocus.all_factored`'s pixels: eq. 5.33's width takes `screen_scale_factored` there.
        read_opt flag: u32,
        write_opt omega_defocus: f32,
        /// Eq. 5.33's width at `screen_scale_wide` on every pixel: the risk-based width's wider
        /// filter (`node.rs` step 3b), from the same rates as `omega_defocus` — no second pass.
        write_opt omega_defocus_wide: f32,
        write pixel_length: f32,
        write_opt n_primary: u32,
        write_opt omega: f32,
        write_opt n: u32,
        write_opt sigma_defocus: f32,
        write_opt sigma: f32,
    }
}

/// `defocus.rates`: per pixel the μ-scaled widths `Ω_x^d`, `Ω_x^s`, `Ω_x^i` (eqs. 5.7, 5.18, 5.22,
/// 5.29), `ℓ_p`, and the rounded counts `n_p`, `n_dir^{f|c}`, `n_ind^{f|c}` (eqs. 5.24–5.28); it
/// writes the defocus ones and, with a `component` parameter, that component's width `omega`, count
/// `n` (`^f` where `flag` is set, else `^c`: Sec. 5.7) and `sigma` ([`RatesIo`]). `sigma_*` are the
/// widths as the filters' Gaussian standard deviation in pixels, `1/(√32 Ω)` (eqs. 5.31, 5.33), for
/// heatmaps.
pub struct Rates;

/// A width `Ω` (pixel⁻¹) as the standard deviation in pixels of the Ch. 5 filters' Gaussian
/// `exp(−16 d² Ω²)`: `σ = 1/(√32 Ω)`.
/// (`√32` written out, as `shaders/defocus_formulas.wgsl` does, so both backends divide by the same
/// number.)
pub fn sigma_px(omega: f32) -> f32 {
    1.0 / (5.656_854 * omega)
}

/// The pass's [`RateComponent`] where it binds a component's outputs (`omega`, `n`, `sigma`), which
/// need it; `None` where it binds none of them.
pub fn rate_component(ctx: &KernelCtx<'_>, bound: bool) -> Result<Option<RateComponent>, BackendError> {
    match (bound, RateOptions::read(ctx)?.component) {
        (false, _) => Ok(None),
        (true, Some(c)) => Ok(Some(c)),
        (true, None) => Err(ctx.err(format!(
            "binds a component's `omega`, `n` or `sigma` without the `component` parameter (one of {:?})",
            RateComponent::OPTIONS
        ))),
    }
}

/// The `component` uniform: its index, 0 where the pass sizes no component.
pub fn component_uniform(ctx: &KernelCtx<'_>) -> Result<u32, BackendError> {
    Ok(RateOptions::read(ctx)?.component.map_or(0, |c| c as u32))
}

impl Kernel for Rates {
    wedge_backends::kernel_signature!(
        name: "defocus.rates", class: Bandwidth, bindings: RatesIo, params: [RatesParams, RateOptions]
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/defocus_rates.wgsl"), |ctx| {
                let (k, scales) = (rate_params(ctx)?, screen_scales(ctx)?);
                Ok(RatesParams::read(ctx)?
                    .uniforms()
                    .f32("pixel_scale", k.pixel_scale)
                    .f32("light_half_width", k.light_half_width)
                    .u32("max_p", formulas::strata_cap(k.max_primary))
                    .u32("max_p_moving", formulas::strata_cap(k.max_primary_moving))
                    .u32("max_s", formulas::strata_cap(k.max_per_primary))
                    .u32("max_s_shadow", formulas::strata_cap(k.max_shadow_per_primary))
                    .f32("environment_per_primary", k.environment_per_primary)
                    .u32("width_pixel_limit", u32::from(k.width_pixel_limit))
                    .f32("screen_scale", scales.other)
                    .f32("screen_scale_factored", scales.factored)
                    .f32("screen_scale_wide", scales.wide)
                    .u32("component", component_uniform(ctx)?))
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
        let io = RatesIo::read(ctx)?;
        let component = rate_component(ctx, io.omega.is_some() || io.n.is_some() || io.sigma.is_some())?;
        let scales = screen_scales(ctx)?;
        // One loop per component, its choice a constant in each: the rates no output reads (the
        // other components', every component's on the node's own pass) are never computed.
        let rows = match component {
            None => rate_rows(ctx, &io, &k, scales, |_, _| (0.0, 0)),
            Some(RateComponent::Direct) => rate_rows(ctx, &io, &k, scales, |r, f| RateComponent::Direct.pick(r, f)),
            Some(RateComponent::Indirect) => rate_rows(ctx, &io, &k, scales, |r, f| RateComponent::Indirect.pick(r, f)),
            Some(RateComponent::Environment) => {
                rate_rows(ctx, &io, &k, scales, |r, f| RateComponent::Environment.pick(r, f))
            }
        };
        let column = |f: &dyn Fn(&Row) -> f32| rows.iter().map(f).collect::<Vec<f32>>();
        io.omega_defocus.put_with(ctx, || column(&|r| r.omega_defocus))?;
        io.omega_defocus_wide.put_with(ctx, || column(&|r| r.omega_defocus_wide))?;
        io.pixel_length.put(ctx, column(&|r| r.pixel_length))?;
        io.n_primary.put_with(ctx, || rows.iter().map(|r| r.n_primary).collect())?;
        io.sigma_defocus.put_with(ctx, || column(&|r| sigma_px(r.omega_defocus)))?;
        if component.is_none() {
            return Ok(());
        }
        io.omega.put_with(ctx, || column(&|r| r.omega))?;
        io.n.put_with(ctx, || rows.iter().map(|r| r.n).collect())?;
        io.sigma.put_with(ctx, || column(&|r| sigma_px(r.omega)))
    }
}

/// Every pixel's [`Row`] of a `defocus.rates` pass, `chosen(rates, factors)` giving the component's
/// width and count (`factors`: the pixel's flag is set). Per pixel only what the outputs need.
fn rate_rows(
    ctx: &KernelCtx<'_>,
    io: &RatesData<'_>,
    k: &RateParams,
    scales: ScreenScales,
    chosen: impl Fn(&PixelRates, bool) -> (f32, u32) + Sync,
) -> Vec<Row> {
    ctx.map_pixels(false, |x, y| {
        let i = (y * ctx.width + x) as usize;
        let at = |b: Option<&[[f32; 4]]>| b.map(|b| b[i]);
        let o = OptionalStats {
            occlusion: at(io.occlusion),
            reflectors: at(io.reflectors),
            bandlimit: io.bandlimit.map(|b| b[i]),
            velocity: at(io.velocity),
            shadow_velocity: at(io.shadow_velocity),
        };
        let r = formulas::pixel_rates(&pixel_stats(io.lens[i], o), k);
        // The count the pixel takes: factored where its (median-filtered) flag is set, else
        // combined; eq. 5.33's width, `screen_scale_factored` where it is set.
        let factors = io.flag.is_some_and(|g| g[i] != 0);
        let (omega, n) = chosen(&r, factors);
        Row {
            omega_defocus: scales.at(factors) * r.omega_defocus,
            omega_defocus_wide: scales.wide * r.omega_defocus,
            pixel_length: r.pixel_length,
            n_primary: r.n_primary,
            omega,
            n,
        }
    })
}

/// One pixel of a `defocus.rates` pass: the columns it may write, and no more.
struct Row {
    omega_defocus: f32,
    omega_defocus_wide: f32,
    pixel_length: f32,
    n_primary: u32,
    /// The pass's component's width and the count the pixel takes (0 where it sizes none).
    omega: f32,
    n: u32,
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

wedge_backends::kernel_bindings! {
    /// What a `defocus.weighted_texture` pass binds: a part's `L`, its paths' mean `k` and
    /// unfiltered `Ē`, and the texture it writes.
    pub struct WeightedTextureIo / WeightedTextureData {
        read radiance: [f32; 3], read texture: [f32; 3], read irradiance: [f32; 3], write out: [f32; 3],
    }
}

/// `defocus.flags`: SepDir / SepInd for one component (eq. 5.30), 1 where `‖L − k E‖ < threshold`,
/// else 0 (also where any input is not finite). The 3×3 median (`neighbourhood.median3`) follows.
pub struct Flags;

impl Kernel for Flags {
    wedge_backends::kernel_signature!(
        name: "defocus.flags", class: Bandwidth, bindings: FlagsIo, params: [FlagsParams]
    );
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
    wedge_backends::kernel_signature!(name: "defocus.compose", class: Compose, bindings: ComposeIo);
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

/// `defocus.weighted_texture`: a factored part's texture weighted by the irradiance each path
/// brought, `L / Ē` per channel where `Ē > 0` (else the paths' mean `k`;
/// `formulas::weighted_texture`), for the compose (and the filters along the velocity) to take in
/// place of the paths' mean. WGSL: `shaders/defocus_weighted_texture.wgsl`.
pub struct WeightedTexture;

impl Kernel for WeightedTexture {
    wedge_backends::kernel_signature!(
        name: "defocus.weighted_texture", class: Compose, bindings: WeightedTextureIo
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/defocus_weighted_texture.wgsl"), |_| Ok(Uniforms::new()))
                .with_include("defocus_formulas.wgsl", include_str!("../../../shaders/defocus_formulas.wgsl"))
                .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let WeightedTextureData { radiance: l, texture: k, irradiance: e, out } = WeightedTextureIo::read(ctx)?;
        let texture: Vec<[f32; 3]> = ctx.map_pixels(false, |x, y| {
            let i = (y * ctx.width + x) as usize;
            formulas::weighted_texture(l[i], k[i], e[i])
        });
        out.put(ctx, texture)
    }
}
