//! The per-pixel formulas of thesis Ch. 5 (defocus + factoring + two-level sampling,
//! `seeds/000_956e982470d7e5bf.txt` Sec. 5.4–5.8; `docs/EQUATIONS.md` "Defocus + factoring"), as pure
//! functions. `shaders/defocus_formulas.wgsl` mirrors them expression for expression; the kernels in
//! [`super::kernels`] evaluate them per pixel on both backends.
//!
//! Units follow the thesis: filter widths `Ω` are spatial bandlimits in pixel⁻¹ (the pixel limit is
//! `Ω_pix^max = 0.5`), circles of confusion `r` are radii in pixels, `ℓ_p` converts pixels to metres.
//!
//! Readings taken (see also `docs/DESIGN-NOTES.md`, "Readings taken — Defocus"):
//! - **Thin lens in pixels.** With `m = 2 tan(vfov/2) / height` (metres per pixel at unit depth), the
//!   thesis's `W/S = 1/(m f)`, so eq. 5.2 is `r = (a W/S)(f/z − 1) = (a/m)(1/z − 1/f)` and the
//!   magnification is `ℓ_p = S z/(W f) = m z`, with `z` the depth along the optical axis.
//! - **Lens shapes.** `disk` (uniform over the unit disk, pbrt/Mitsuba's thin lens) and `gaussian` (the
//!   thesis: weight `exp(−|u|²/2)`, σ = 1, truncated to `|u| ≤ 1`, applied as an explicit weight to
//!   uniformly drawn lens samples, Sec. 5.8 step 2). Both use `Ω_u^max = 1` (Sec. 5.4): the truncated
//!   Gaussian's per-axis standard deviation (0.4788) is within 5% of the disk's (0.5), so the thesis's
//!   bandlimit serves both.
//! - **Two modes for μ** (eq. 5.29). `literal`: `Ω(μ) = min(Ω_pix^max, μ Ω)` as printed. Every width is
//!   already ≤ `Ω_pix^max`, so for μ ≥ 1 the clamp holds the filters at `Ω_pix^max = 0.5` (a Gaussian
//!   of std 0.177 px that still mixes neighbours with weight e⁻⁴) and the counts at their μ = 1 values:
//!   the literal scheme does **not** converge to Monte Carlo as μ → ∞. `consistent`: `Ω(μ) = μ Ω`
//!   without the clamp, so as μ → ∞ every filter shrinks below a pixel (neighbour weights → 0) and
//!   every count grows without bound (capped only by `max_primary` / `max_per_primary`): plain Monte
//!   Carlo in the limit. The two modes agree for μ ≤ 1.
//! - **Missing statistics.** A pixel with no occluded shadow sample has no `s` (the light does not
//!   limit `Ω_x^s`, and `n_dir` has no light factor: one shadow ray per primary ray suffices for a
//!   constant visibility); likewise no reflector hit means no `z` term. `s` and `z` are clamped at 0.
//! - **Rounding for full stratification** (Sec. 5.8 footnote 6): `n_p → p²`, secondary counts →
//!   `p² s²` with `s ≥ 1` (at least one secondary ray per primary ray). A rate whose square root
//!   exceeds an integer `p` by less than [`ROUNDING_SLACK`] takes `p` strata, so float noise in e.g.
//!   `(0.5 + 0.5)² = 1` never adds a stratum.

use wedge_backends::kernels::filter_window;
use wedge_scene::{AreaLight, Camera, LightShape};

/// `Ω_pix^max`: the pixel bandlimit of one sample per pixel (thesis eq. 5.7).
pub const OMEGA_PIX_MAX: f32 = 0.5;
/// `Ω_u^max`: the lens aperture's bandlimit (thesis Sec. 5.4: Gaussian lens, σ = 1 over u ∈ [−1, 1]).
pub const OMEGA_U_MAX: f32 = 1.0;
/// Factoring threshold on `‖L − k E‖` (thesis eq. 5.30; absolute, in radiance units).
pub const FACTORING_THRESHOLD: f32 = 0.01;
/// A square root of a rate within this of an integer `p` rounds to `p`, not `p + 1`.
pub const ROUNDING_SLACK: f32 = 1e-4;
/// Filter constants of eqs. 5.31 and 5.33 (the shared filter kernels own them).
pub use filter_window::{FILTER_SHARPNESS, REJECT_EXPONENT, REJECT_WEIGHT};

/// The aperture's weight over the unit lens disk: the camera's (`wedge_scene::LensShape`, which the
/// path sampler applies; `disk` uniform, `gaussian` the thesis's `exp(−|u|²/2)`).
pub use wedge_scene::LensShape;

/// Per-axis standard deviation of the lens position `u` under the shape's weight on the unit disk
/// (closed forms: the disk's is 1/2; the truncated Gaussian's is `sqrt(E[|u|²]/2)` with
/// `E[|u|²] = 2(1 − 1.5 e^{−1/2}) / (1 − e^{−1/2}) = 0.45851`).
pub fn lens_std(shape: LensShape) -> f32 {
    match shape {
        LensShape::Disk => 0.5,
        LensShape::Gaussian => 0.478_803_7,
    }
}

/// `Ω_u^max` (Sec. 5.4): the same for both shapes (see the module docs).
pub fn omega_u_max(_shape: LensShape) -> f32 {
    OMEGA_U_MAX
}

/// A thin-lens camera in the pixel units of Ch. 5.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinLens {
    /// `a`: aperture radius, world units (0 = pinhole).
    pub aperture_radius: f32,
    /// `f`: distance to the plane in focus along the optical axis, world units (> 0).
    pub focus_distance: f32,
    /// `m = 2 tan(vfov/2) / height`: metres per pixel at unit depth.
    pub pixel_scale: f32,
}

impl ThinLens {
    pub fn new(aperture_radius: f32, focus_distance: f32, vfov_deg: f32, height: u32) -> ThinLens {
        ThinLens { aperture_radius, focus_distance, pixel_scale: pixel_scale(vfov_deg, height) }
    }

    /// Signed circle of confusion in pixels of a hit at depth `z` along the optical axis
    /// (thesis eq. 5.2: `r = (aW/S)(f/z − 1) = (a/m)(1/z − 1/f)`); positive in front of the focal
    /// plane. A pinhole (`a = 0`) gives exactly 0 at every depth. The statistics use `|r|`.
    pub fn circle_of_confusion(&self, z: f32) -> f32 {
        if self.aperture_radius == 0.0 {
            return 0.0;
        }
        (self.aperture_radius / self.pixel_scale) * (1.0 / z - 1.0 / self.focus_distance)
    }

    /// `ℓ_p = S z/(W f) = m z`: metres per pixel at depth `z` (thesis Sec. 5.4).
    pub fn pixel_length(&self, z: f32) -> f32 {
        pixel_length(self.pixel_scale, z)
    }

    /// Where the ray of pixel offset `x` (pixels) and lens position `u` meets a surface at depth `z`,
    /// in metres on that surface relative to the pixel's centre ray (thesis eq. 5.1/5.3:
    /// `λ = ℓ_p (x + r u)`).
    pub fn surface_offset(&self, x: [f32; 2], u: [f32; 2], z: f32) -> [f32; 2] {
        let (l, r) = (self.pixel_length(z), self.circle_of_confusion(z));
        [l * (x[0] + r * u[0]), l * (x[1] + r * u[1])]
    }
}

impl ThinLens {
    /// The camera's thin lens at an image `height` in pixels (an unset `focus_distance` focuses at
    /// the look-at point: `Camera::effective_focus_distance`).
    pub fn from_camera(camera: &Camera, height: u32) -> ThinLens {
        ThinLens::new(camera.aperture_radius, camera.effective_focus_distance(), camera.vfov_deg, height)
    }
}

/// `ℓ_I`: the light's physical half-width (thesis Sec. 5.5: `I(y)` over `[−ℓ_I, ℓ_I]`,
/// `Ω_y^max = 1/ℓ_I`), along its longer extent: half the longer side of a rectangle, half the
/// longest edge of a triangle. Not Ch. 3's `w/√12` std-dev reading (`docs/EQUATIONS.md`).
pub fn light_half_width(light: &AreaLight) -> f32 {
    match light.shape {
        LightShape::Rect { edge_u, edge_v, .. } => 0.5 * edge_u.length().max(edge_v.length()),
        LightShape::Triangle { v0, v1, v2 } => 0.5 * (v1 - v0).length().max((v2 - v1).length()).max((v0 - v2).length()),
    }
}

/// `m = 2 tan(vfov/2) / height`: metres per pixel at unit depth for a vertical field of view.
pub fn pixel_scale(vfov_deg: f32, height: u32) -> f32 {
    2.0 * (0.5 * vfov_deg.to_radians()).tan() / height.max(1) as f32
}

/// `ℓ_p = m z` (thesis Sec. 5.4).
pub fn pixel_length(pixel_scale: f32, z: f32) -> f32 {
    pixel_scale * z
}

/// `a / b`, or +∞ when `b ≤ 0`: a bandlimit term whose statistic is absent (no defocus, no
/// occluder, no reflector) does not limit the filter.
fn ratio_or_inf(a: f32, b: f32) -> f32 {
    if b > 0.0 {
        a / b
    } else {
        f32::INFINITY
    }
}

/// Defocus filter width `Ω_x^d = min(Ω_pix^max, Ω_u^max / r_min)` (thesis eq. 5.7).
pub fn omega_defocus(r_min: f32, omega_pix: f32) -> f32 {
    omega_pix.min(ratio_or_inf(OMEGA_U_MAX, r_min.abs()))
}

/// Direct-irradiance filter width
/// `Ω_x^s = min(Ω_pix^max, ℓ_p Ω_y^max / s_min, Ω_u^max / r_min)` with `Ω_y^max = 1/ℓ_I`
/// (thesis eq. 5.18; `ℓ_I` the light's physical half-width). A point light (`ℓ_I = 0`) or a pixel
/// without occluder (`s_min = 0`) drops the light term.
pub fn omega_direct(r_min: f32, s_min: f32, pixel_length: f32, light_half_width: f32, omega_pix: f32) -> f32 {
    let light = ratio_or_inf(pixel_length, light_half_width * s_min.max(0.0));
    omega_defocus(r_min, omega_pix).min(light)
}

/// Indirect-irradiance filter width `Ω_x^i = min(Ω_pix^max, ℓ_p Ω_v^max / z_min, Ω_u^max / r_min)`
/// (thesis eq. 5.22; `Ω_v^max` the transfer bandlimit of Ch. 4: 2.8 diffuse, `4.27 + 0.15 m` Phong).
pub fn omega_indirect(r_min: f32, z_min: f32, pixel_length: f32, omega_v: f32, omega_pix: f32) -> f32 {
    let reflector = ratio_or_inf(pixel_length * omega_v, z_min.max(0.0));
    omega_defocus(r_min, omega_pix).min(reflector)
}

/// Ch. 6's spatial bandwidth `B` (1/m; its filter `exp(−2B²d²)`, d in metres, has σ = 1/(2B) m) as
/// Ch. 5's width `Ω` (pixel⁻¹; `exp(−16 Ω² d²)`, d in pixels, σ = 1/(√32 Ω) px) of the same Gaussian
/// on a surface of `ℓ_p` metres per pixel: `Ω = 2 B ℓ_p / √32`.
pub const OMEGA_PER_ENVIRONMENT_BANDWIDTH: f32 = 0.353_553_4;

/// Environment-irradiance filter width `Ω_x^e = min(Ω_pix^max, c B ℓ_p, Ω_u^max / r_min)`: eq.
/// 5.18's form with the environment's own bandlimit — Ch. 6's `B` of the direct light (eqs. 6.13,
/// 6.17; curvature, occluders, `B_e`, the lobe) in place of the area light's term, converted by
/// [`OMEGA_PER_ENVIRONMENT_BANDWIDTH`] = c. A pixel without a bandwidth (`B ≤ 0`) drops the term.
pub fn omega_environment(r_min: f32, bandlimit: f32, pixel_length: f32, omega_pix: f32) -> f32 {
    let own = if bandlimit > 0.0 { OMEGA_PER_ENVIRONMENT_BANDWIDTH * bandlimit * pixel_length } else { f32::INFINITY };
    omega_defocus(r_min, omega_pix).min(own)
}

/// A pixel's environment bandwidth statistic as the rates read it: absent, not finite or below 0
/// reads 0 (no bandwidth known). `shaders/defocus_formulas.wgsl` `defocus_bandlimit`.
pub fn bandlimit_of(b: Option<f32>) -> f32 {
    b.filter(|b| b.is_finite()).unwrap_or(0.0).max(0.0)
}

/// Environment look-ups per pixel: eq. 5.24's spatial and lens factors at the component's width
/// times `per_primary`, the look-ups per primary ray Ch. 6 takes (Algorithm 1: 4) — Ch. 6 gives no
/// rate formula, and its importance-sampled look-ups need no angular factor grown from the map.
/// `Ω = Ω_x^e` for factored pixels, `Ω_x^d` for combined ones, μ-scaled. Unrounded.
pub fn environment_rate(omega: f32, r_max: f32, per_primary: f32, omega_pix: f32) -> f32 {
    primary_rate(omega, r_max, omega_pix) * per_primary.max(1.0)
}

/// The time factor of a count where the paths also sample the shutter, `(1 + |v| Ω)²`
/// (docs/DEFOCUS-MOTION.md DM.8, DM.11, DM.12: the alias spacing along time of a shear of slope `v`
/// inside a filter passband `Ω`; squared as App. B's B.3 squares it). Exactly 1 at `v = 0`, so a
/// still pixel keeps Ch. 5's counts bit for bit.
pub fn time_factor(speed: f32, omega: f32) -> f32 {
    let f = 1.0 + speed * omega;
    f * f
}

wedge_backends::param_choice! {
    /// How μ scales a bandwidth (eq. 5.29); a kernel's uniform block carries it as 0 literal, 1 consistent.
    pub enum Mode {
        /// `Ω(μ) = min(Ω_pix^max, μ Ω)` as printed: stops at Ω_pix^max, does not converge as μ → ∞.
        Literal = "literal",
        /// `Ω(μ) = μ Ω`: filters shrink to one pixel and counts grow without bound as μ → ∞.
        Consistent = "consistent",
    }
}

/// `Ω(μ)` (thesis eq. 5.29, or without the clamp in [`Mode::Consistent`]).
pub fn omega_mu(omega: f32, mu: f32, mode: Mode, omega_pix: f32) -> f32 {
    match mode {
        Mode::Literal => omega_pix.min(mu * omega),
        Mode::Consistent => mu * omega,
    }
}

/// The width of the screen-space defocus filter (eq. 5.33) where a primary ray hit: eq. 5.7's
/// `Ω_x^d` μ-scaled (`d`) with the pixel limit, or without it the lens term alone, `μ Ω_u^max / r_min`
/// — which grows without bound as the circle of confusion shrinks, so an in-focus pixel is not
/// blurred at all (infinite: a pass-through in `filter.defocus`). The counts keep `d` either way
/// (docs/DESIGN-NOTES.md "The filters against their own rays").
pub fn screen_width(d: f32, r_min: f32, mu: f32, pixel_limit: bool) -> f32 {
    if pixel_limit {
        d
    } else {
        mu * ratio_or_inf(OMEGA_U_MAX, r_min.abs())
    }
}

/// Primal-domain filter width in pixels, `R = 1/Ω` (thesis eqs. 5.8, 5.19, 5.23: `max{2, r_min}` for
/// defocus at Ω_pix^max = 0.5).
pub fn filter_width_px(omega: f32) -> f32 {
    1.0 / omega
}

/// Primary rays per pixel `n_p = (Ω_pix^max + Ω_x^d)² (1 + r_max Ω_x^d)²` (thesis eqs. 5.24, 5.29),
/// `omega_d` already scaled by μ. Unrounded.
pub fn primary_rate(omega_d: f32, r_max: f32, omega_pix: f32) -> f32 {
    let spatial = omega_pix + omega_d;
    let lens = 1.0 + r_max.abs() * omega_d;
    spatial * spatial * lens * lens
}

/// Shadow rays per pixel (thesis eqs. 5.25, 5.27):
/// `(Ω_pix^max + Ω)² (1 + r_max Ω)² (1 + ℓ_I s_max Ω/ℓ_p)²` with `Ω = Ω_x^s` for factored pixels
/// (`n_dir^f`) or `Ω = Ω_x^d` for combined ones (`n_dir^c`), μ-scaled. A point light or a pixel
/// without occluder has no light factor, so `n_dir^c = n_p`. Unrounded.
pub fn direct_rate(
    omega: f32,
    r_max: f32,
    s_max: f32,
    pixel_length: f32,
    light_half_width: f32,
    omega_pix: f32,
) -> f32 {
    let spread = light_half_width * s_max.max(0.0);
    let light = if spread > 0.0 { 1.0 + spread * omega / pixel_length } else { 1.0 };
    primary_rate(omega, r_max, omega_pix) * light * light
}

/// Indirect samples per pixel (thesis eqs. 5.26, 5.28):
/// `(Ω_pix^max + Ω)² (1 + r_max Ω)² (Ω_v^max + z_max Ω/ℓ_p)²` with `Ω = Ω_x^i` (`n_ind^f`) or
/// `Ω_x^d` (`n_ind^c`), μ-scaled. A pixel without reflector hit keeps the `Ω_v^max` term. Unrounded.
pub fn indirect_rate(omega: f32, r_max: f32, z_max: f32, pixel_length: f32, omega_v: f32, omega_pix: f32) -> f32 {
    let depth = z_max.max(0.0);
    let angular = if depth > 0.0 { omega_v + depth * omega / pixel_length } else { omega_v };
    primary_rate(omega, r_max, omega_pix) * angular * angular
}

/// Strata per lens axis `p` for `n_p` primary rays, so the pass traces `p²` (Sec. 5.8 footnote 6):
/// `p = ceil(sqrt(n_p))` in `[1, max_p]`. A rate that is not finite takes `max_p`.
pub fn primary_strata(n_p: f32, max_p: u32) -> u32 {
    strata(n_p, max_p)
}

/// Strata per secondary axis `s` for `n` secondary rays at a pixel with `p²` primary rays: the pass
/// traces `s²` per primary ray, `p² s²` in all, with `s = ceil(sqrt(n / p²))` in `[1, max_s]` (at
/// least one secondary ray per primary ray, Sec. 5.7 footnote 5).
pub fn secondary_strata(n: f32, p: u32, max_s: u32) -> u32 {
    let p2 = (p.max(1) * p.max(1)) as f32;
    strata(n / p2, max_s)
}

fn strata(n: f32, max: u32) -> u32 {
    let max = max.max(1);
    let root = n.sqrt() - ROUNDING_SLACK;
    if !root.is_finite() || root >= max as f32 {
        return max;
    }
    (root.ceil() as u32).clamp(1, max)
}

/// The largest `p` with `p² ≤ cap` (at least 1): strata that fit a count cap.
pub fn strata_cap(cap: u32) -> u32 {
    let mut p = (cap as f64).sqrt() as u32;
    while p > 1 && p * p > cap {
        p -= 1;
    }
    while (p + 1) * (p + 1) <= cap {
        p += 1;
    }
    p.max(1)
}

/// The primary strata per side a pixel may take: `still` (from `max_primary`) times the time
/// factor's per-side `1 + |v| Ω` (`speed_factor`), at most `moving` (from `max_primary_moving`) —
/// so the cap binds the lens's share of the count and the shutter's share multiplies after it
/// (a blurred foreground's lens counts are capped, a mover keeps the time factor's paths:
/// docs/DESIGN-NOTES.md "Defocus's primary-ray cap under a moving shutter"). `still` where
/// `moving ≤ still` (the default) or the pixel is still.
pub fn primary_cap(still: u32, moving: u32, speed_factor: f32) -> u32 {
    if moving <= still {
        return still;
    }
    let c = still as f32 * speed_factor;
    if c >= moving as f32 || !c.is_finite() {
        return moving;
    }
    (c as u32).max(still)
}

/// Secondary rays per primary ray after the 3×3 max filter, which can leave a total `n` that is not
/// a multiple of the (also filtered) `n_p`: the smallest square `s²` with `n_p s² ≥ n`, at least 1.
/// Integer arithmetic, so both backends agree exactly.
pub fn secondary_per_primary(n_p: u32, n: u32) -> u32 {
    let n_p = n_p.max(1) as u64;
    let mut s = 1u64;
    while n_p * s * s < n as u64 {
        s += 1;
    }
    (s * s) as u32
}

/// Per-pixel inputs of the rates: the first pass's lens and occlusion statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelStats {
    /// `r_min`, `r_max`: smallest and largest `|r|` (pixels) over the pixel's lens samples (eq. 5.2).
    pub r_min: f32,
    pub r_max: f32,
    /// Lens-averaged depth along the optical axis (for `ℓ_p`).
    pub depth: f32,
    /// Whether any primary ray hit geometry (else the pixel takes one ray of each kind).
    pub hit: bool,
    /// Shadow slopes (eq. 5.17), 0 where no shadow sample was occluded.
    pub s_min: f32,
    pub s_max: f32,
    /// Reflector distances for indirect light, 0 where no indirect sample hit.
    pub z_min: f32,
    pub z_max: f32,
    /// The environment's own spatial bandwidth `B` (1/m, Ch. 6), 0 where none is known.
    pub bandlimit: f32,
    /// Where the paths also sample the shutter (a moving scene): the fastest image speed of the
    /// primary hits and of the shadows, px per half shutter (0: still, or no shutter sampled).
    pub v_p: f32,
    pub v_s: f32,
}

/// Constants of one rates evaluation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RateParams {
    pub mu: f32,
    pub mode: Mode,
    pub omega_pix: f32,
    /// `m`: metres per pixel at unit depth.
    pub pixel_scale: f32,
    /// `ℓ_I`: the area light's physical half-width (not Ch. 3's `w/√12`).
    pub light_half_width: f32,
    /// `Ω_v^max` of the receiver's transfer function (Ch. 4: 2.8 diffuse).
    pub omega_v: f32,
    /// Cap on primary rays per pixel (rounded down to a square).
    pub max_primary: u32,
    /// Cap on a moving pixel's primary rays where the paths sample the shutter: `max_primary`'s
    /// strata times the time factor's `1 + |v| Ω` per side, up to this ([`primary_cap`]); at or
    /// below `max_primary`, `max_primary` everywhere.
    pub max_primary_moving: u32,
    /// Cap on secondary rays per primary ray (rounded down to a square): hemisphere and environment
    /// samples.
    pub max_per_primary: u32,
    /// The same for the direct light's shadow rays, whose variance (the light's, in penumbrae)
    /// secondaries do reduce (docs/DESIGN-NOTES.md "Shadow rays per primary under Motion").
    pub max_shadow_per_primary: u32,
    /// Environment look-ups per primary ray at the pixel limit ([`environment_rate`]).
    pub environment_per_primary: f32,
    /// The screen-space filter's width capped at `Ω_pix^max` as eq. 5.7 caps `Ω_x^d` (the thesis: an
    /// in-focus pixel gets a σ = 0.35 px Gaussian), or (false) the lens term alone ([`screen_width`]).
    pub width_pixel_limit: bool,
}

/// Widths (μ-scaled) and rounded counts of one pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelRates {
    pub omega_defocus: f32,
    pub omega_direct: f32,
    pub omega_indirect: f32,
    pub pixel_length: f32,
    pub n_primary: u32,
    pub n_direct_factored: u32,
    pub n_direct_combined: u32,
    pub n_indirect_factored: u32,
    pub n_indirect_combined: u32,
    pub omega_environment: f32,
    pub n_environment_factored: u32,
    pub n_environment_combined: u32,
}

/// All of Sec. 5.7 for one pixel: the widths of eqs. 5.7, 5.18, 5.22 scaled by μ (eq. 5.29), the
/// rates of eqs. 5.24–5.28, rounded to `p²` and `p² s²`. A pixel whose primary rays all missed takes
/// the pixel-limit widths and one ray of each kind. Where the paths also sample the shutter, the
/// counts take the time factor of the speeds that shear them (docs/DEFOCUS-MOTION.md: primary rays
/// and the combined `n^c` the primary hit's, plus the shadow's for direct light; factored direct
/// irradiance the shadow's; factored indirect and environment irradiance none, App. B's reading);
/// the widths stay Ch. 5's — the lens × shutter band is the intersection of the two (DM.4), so a
/// width that passes the lens's band passes the product's.
#[inline(always)]
pub fn pixel_rates(s: &PixelStats, k: &RateParams) -> PixelRates {
    let max_p = strata_cap(k.max_primary);
    let (max_s, max_s_shadow) = (strata_cap(k.max_per_primary), strata_cap(k.max_shadow_per_primary));
    let omega_pix_mu = omega_mu(k.omega_pix, k.mu, k.mode, k.omega_pix);
    if !s.hit {
        return PixelRates {
            omega_defocus: omega_pix_mu,
            omega_direct: omega_pix_mu,
            omega_indirect: omega_pix_mu,
            pixel_length: 0.0,
            n_primary: 1,
            n_direct_factored: 1,
            n_direct_combined: 1,
            n_indirect_factored: 1,
            n_indirect_combined: 1,
            omega_environment: omega_pix_mu,
            n_environment_factored: 1,
            n_environment_combined: 1,
        };
    }
    let l_p = pixel_length(k.pixel_scale, s.depth);
    let d = omega_mu(omega_defocus(s.r_min, k.omega_pix), k.mu, k.mode, k.omega_pix);
    let sd = omega_mu(omega_direct(s.r_min, s.s_min, l_p, k.light_half_width, k.omega_pix), k.mu, k.mode, k.omega_pix);
    let si = omega_mu(omega_indirect(s.r_min, s.z_min, l_p, k.omega_v, k.omega_pix), k.mu, k.mode, k.omega_pix);
    let se = omega_mu(omega_environment(s.r_min, s.bandlimit, l_p, k.omega_pix), k.mu, k.mode, k.omega_pix);
    let (vp, vs) = (s.v_p, s.v_s);
    let cap_p = primary_cap(max_p, strata_cap(k.max_primary_moving), 1.0 + vp * d);
    let p = primary_strata(primary_rate(d, s.r_max, k.omega_pix) * time_factor(vp, d), cap_p);
    let total_capped = |n: f32, cap: u32| {
        let q = secondary_strata(n, p, cap);
        p * p * q * q
    };
    let total = |n: f32| total_capped(n, max_s);
    let shadows = |n: f32| total_capped(n, max_s_shadow);
    PixelRates {
        omega_defocus: screen_width(d, s.r_min, k.mu, k.width_pixel_limit),
        omega_direct: sd,
        omega_indirect: si,
        pixel_length: l_p,
        n_primary: p * p,
        n_direct_factored: shadows(
            direct_rate(sd, s.r_max, s.s_max, l_p, k.light_half_width, k.omega_pix) * time_factor(vs, sd),
        ),
        n_direct_combined: shadows(
            direct_rate(d, s.r_max, s.s_max, l_p, k.light_half_width, k.omega_pix) * time_factor(vp + vs, d),
        ),
        n_indirect_factored: total(indirect_rate(si, s.r_max, s.z_max, l_p, k.omega_v, k.omega_pix)),
        n_indirect_combined: total(
            indirect_rate(d, s.r_max, s.z_max, l_p, k.omega_v, k.omega_pix) * time_factor(vp, d),
        ),
        omega_environment: se,
        n_environment_factored: total(environment_rate(se, s.r_max, k.environment_per_primary, k.omega_pix)),
        n_environment_combined: total(
            environment_rate(d, s.r_max, k.environment_per_primary, k.omega_pix) * time_factor(vp, d),
        ),
    }
}

/// Whether a pixel's radiance factors into texture × irradiance (thesis eq. 5.30):
/// `‖L − k E‖ < threshold` (Euclidean RGB distance, `k E` per channel). Any non-finite input gives
/// `false`: such a pixel is not factored (its samples are excluded where they are filtered).
/// Compared squared (`‖·‖² < threshold²`, the same condition without a rounded square root).
pub fn separable(l: [f32; 3], k: [f32; 3], e: [f32; 3], threshold: f32) -> bool {
    let d = [l[0] - k[0] * e[0], l[1] - k[1] * e[1], l[2] - k[2] * e[2]];
    let err2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    err2 < threshold * threshold
}

/// The texture a factored pixel's paths saw, weighted by the irradiance each brought: `L / Ē` per
/// channel (`Ē` the path-averaged, unfiltered irradiance), where `Ē > 0`; else the plain path mean
/// `k`. Each path's `L = k E` under the light-centre form factor, so `L / Ē` is the E-weighted mean of
/// the paths' `k` (times the fraction of paths that hit), which the lens-integrated pixel needs:
/// `k̄ Ē` misses the covariance of `k` and `E` over the lens (a blurred highlight's paths bring both
/// its texture and its light), a bias of −1% on `dof_bokeh`. Where `k` is constant over the paths,
/// `L / Ē = k̄` (docs/DESIGN-NOTES.md "The irradiance-weighted texture").
pub fn weighted_texture(l: [f32; 3], k: [f32; 3], e_raw: [f32; 3]) -> [f32; 3] {
    std::array::from_fn(|c| {
        let w = l[c] / e_raw[c];
        if e_raw[c] > 0.0 && w.is_finite() {
            w
        } else {
            k[c]
        }
    })
}

/// One component's term of the composed radiance (thesis eq. 5.32): the factored product `k E` (with
/// `E` filtered) where the pixel's flag says the component factors, else its lens-integrated `L`.
pub fn compose_term(l: [f32; 3], k: [f32; 3], e: [f32; 3], factored: bool) -> [f32; 3] {
    if factored {
        [k[0] * e[0], k[1] * e[1], k[2] * e[2]]
    } else {
        l
    }
}
