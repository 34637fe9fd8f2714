//! The per-pixel formulas of thesis App. B (motion blur with secondary effects,
//! `seeds/000_956e982470d7e5bf.txt` Appendix B; `docs/EQUATIONS.md` "Motion"), as pure functions.
//! `shaders/motion_formulas.wgsl` mirrors them expression for expression, on top of the Ch. 5 rate
//! formulas it shares (`shaders/defocus_formulas.wgsl`).
//!
//! Units are Ch. 5's: widths `Ω` in pixel⁻¹ (`Ω_pix^max = 0.5`), velocities `v` in pixels per
//! **half** shutter (time `t ∈ [−1, 1]` over the shutter, `Ω_t^max = 1`: docs/EQUATIONS.md reading), so a
//! point moving at `v` sweeps `2|v|` pixels while the shutter is open.
//!
//! - Texture width (B.1) `Ω_{x,p}^m = min(Ω_pix^max, Ω_t^max/|v_p|)`, irradiance width (B.2)
//!   `Ω_{x,s}^m = min(Ω_pix^max, Ω_t^max/|v_s|)`, each μ-scaled by eq. 5.29 (literal or consistent,
//!   as Ch. 5). Where `|v|` is within the velocity tolerance of a still point the pixel is static: no
//!   filter (width 0; eq. B.1 alone would still blur a static surface at `Ω_pix^max`) and `v = 0` in
//!   the counts.
//! - The direct irradiance also takes the area-light width of eq. 5.18 without the lens term,
//!   `min(Ω_pix^max, ℓ_p Ω_y^max/s_min)`; indirect takes only eq. 5.22's reflector-depth width
//!   (App. B: "we only apply the standard irradiance filter based on minimum reflector depth").
//! - The environment's irradiance takes its Ch. 6 bandwidth as the direct light takes the area light's
//!   (`crate::defocus::formulas::omega_environment` without the lens term), like indirect light no
//!   velocity term (the sampler keeps no velocity of the environment's occluders), and its look-ups
//!   are eq. 5.24's factors at that width times the look-ups per primary ray, without a time factor.
//! - Primary rays (B.3) `n_p = (Ω_pix^max + Ω_x^t)² (1 + |v_p| Ω_x^t)²` with `Ω_x^t = Ω_{x,p}^m`
//!   (docs/EQUATIONS.md: "(B.3)'s Ω_x^t means Ω_{x,p}^m") — eq. 5.24 with `|v_p|` for `r_max`. A pixel
//!   that sees two or more velocities (primary hit or shadow) takes `multi_paths` primary rays (the
//!   thesis: 64).
//! - Shadow rays "similar to eq. 5.25": `(Ω_pix+Ω)²(1 + |v_s| Ω)²(1 + ℓ_I s_max Ω/ℓ_p)²` with
//!   `Ω = min(area-light width, Ω_{x,s}^m)` — the time factor from the shadow's own velocity (a static
//!   shadow on a moving receiver is constant over the shutter at a pixel). Indirect: eq. 5.26 without
//!   the time factor (App. B: "the (Ω_t^*)² term can be ignored"). Rounded to `p² s²` as Ch. 5.
//!   Multi-velocity pixels take one secondary ray per primary ray (Ch. 5's minimum): they are not
//!   filtered, only averaged over 3×3.
//! - **Single velocity** (factoring is "enforced at all pixels with a single primary hit velocity"):
//!   the spread of the velocities a pixel's paths saw (misses count as 0: the background is static)
//!   is within the tolerance of [`super::kernels::filter::velocity_tolerance`], for the
//!   primary hits and for the occluded shadow samples alike.

use super::kernels::filter::velocity_tolerance;
use glam::Vec2;

use crate::defocus::formulas::{
    direct_rate, environment_rate, indirect_rate, omega_direct, omega_environment, omega_indirect, omega_mu,
    pixel_length, primary_rate, primary_strata, secondary_strata, strata_cap, Mode,
};

/// `Ω_t^max`: the shutter's bandlimit over `t ∈ [−1, 1]` (docs/EQUATIONS.md "Motion"), the Motion node's
/// default (`omega_t`).
pub const OMEGA_T_MAX: f32 = 1.0;

/// Primary rays per pixel at a pixel that sees two or more velocities: the Motion node's default. The
/// thesis (App. B: "a large constant primary sampling rate (64 rays)") is [`THESIS_MULTI_VELOCITY_PATHS`];
/// 16 jointly stratified paths filtered along the velocity measured better per ray (DESIGN-NOTES
/// "Motion").
pub const MULTI_VELOCITY_PATHS: i64 = 16;
/// App. B's primary rays at multi-velocity pixels.
pub const THESIS_MULTI_VELOCITY_PATHS: i64 = 64;

/// `min(Ω_pix^max, Ω_t^max/|v|)` (eqs. B.1, B.2), before μ.
pub fn omega_motion(speed: f32, omega_t: f32, omega_pix: f32) -> f32 {
    if speed > 0.0 {
        omega_pix.min(omega_t / speed)
    } else {
        omega_pix
    }
}

/// Whether a velocity is a motion to filter along: faster than the tolerance of a still point.
pub fn moving(v: [f32; 2]) -> bool {
    Vec2::from(v).length() > velocity_tolerance(0.0)
}

/// The fastest image speed among a pixel's paths, from a sampler velocity statistic (mean, per-axis
/// range; px per half shutter): `|mean| + |range|/2`, 0 within the tolerance of a still point or where
/// not finite. What a count needs where a pixel may see several motions (docs/DEFOCUS-MOTION.md 2.3:
/// widths want the slowest, counts the fastest).
pub fn fastest_speed(v: [f32; 4]) -> f32 {
    let s = Vec2::new(v[0], v[1]).length() + 0.5 * Vec2::new(v[2], v[3]).length();
    if s.is_finite() && s > velocity_tolerance(0.0) {
        s
    } else {
        0.0
    }
}

/// Whether velocities of mean `mean` and per-axis range `spread` (max − min over the samples) are one
/// motion: the range is within the tolerance of the fastest sample (≈ |mean| + |spread|/2).
pub fn single_velocity(mean: [f32; 2], spread: [f32; 2]) -> bool {
    let s = Vec2::from(spread).length();
    s <= velocity_tolerance(Vec2::from(mean).length() + 0.5 * s)
}

/// One pixel's first-pass statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MotionStats {
    /// Mean image-space velocity of the primary hits and its per-axis range over all paths.
    pub v_p: [f32; 2],
    pub v_p_spread: [f32; 2],
    /// The same for the shadows (occluded shadow samples); meaningful where `occluded`.
    pub v_s: [f32; 2],
    pub v_s_spread: [f32; 2],
    pub occluded: bool,
    /// Some primary ray hit geometry; `depth` along the optical axis (for ℓ_p).
    pub hit: bool,
    pub depth: f32,
    /// Shadow slopes (eq. 5.17) and reflector distances, 0 where absent.
    pub s_min: f32,
    pub s_max: f32,
    pub z_min: f32,
    pub z_max: f32,
    /// The environment's Ch. 6 bandwidth `B` (1/m), 0 where none.
    pub bandlimit: f32,
}

impl MotionStats {
    /// One velocity for the primary hits and for the shadows (factoring applies, App. B).
    pub fn single(&self) -> bool {
        single_velocity(self.v_p, self.v_p_spread) && (!self.occluded || single_velocity(self.v_s, self.v_s_spread))
    }
}

/// Constants of one rates evaluation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionParams {
    pub mu: f32,
    pub mode: Mode,
    pub omega_pix: f32,
    /// `Ω_t^max`, the shutter's bandlimit ([`OMEGA_T_MAX`] by default).
    pub omega_t: f32,
    /// `m`: metres per pixel at unit depth.
    pub pixel_scale: f32,
    /// `ℓ_I`: the area light's physical half-width (0: no light term).
    pub light_half_width: f32,
    /// `Ω_v^max` of the receiver's transfer function (Ch. 4: 2.8 diffuse).
    pub omega_v: f32,
    pub max_primary: u32,
    /// Caps on hemisphere and environment samples, and on shadow rays, per primary ray (Defocus's
    /// `RateParams`).
    pub max_per_primary: u32,
    pub max_shadow_per_primary: u32,
    /// Primary rays at multi-velocity pixels (capped by `max_primary`).
    pub multi_paths: u32,
    /// Environment look-ups per primary ray (`crate::defocus::formulas::environment_rate`).
    pub environment_per_primary: f32,
}

/// One pixel's widths (μ-scaled; 0 = no such filter) and rounded counts.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MotionRates {
    pub single: bool,
    /// Texture filter along `v_p` (B.1).
    pub omega_texture: f32,
    /// Direct irradiance: area-light width (5.18 without the lens term) and the filter along `v_s` (B.2).
    pub omega_direct: f32,
    pub omega_shadow: f32,
    /// Indirect irradiance: reflector-depth width (5.22 without the lens term).
    pub omega_indirect: f32,
    /// Environment irradiance: Ch. 6's bandwidth as a width (no lens term).
    pub omega_environment: f32,
    pub pixel_length: f32,
    pub n_primary: u32,
    pub n_direct: u32,
    pub n_indirect: u32,
    pub n_environment: u32,
}

/// All of App. B's sampling for one pixel (see the module doc).
#[inline(always)]
pub fn pixel_rates(s: &MotionStats, k: &MotionParams) -> MotionRates {
    let max_p = strata_cap(k.max_primary);
    let (max_s, max_s_shadow) = (strata_cap(k.max_per_primary), strata_cap(k.max_shadow_per_primary));
    let single = s.single();
    let mu = |omega: f32| omega_mu(omega, k.mu, k.mode, k.omega_pix);
    if !s.hit {
        return MotionRates {
            single,
            n_primary: 1,
            n_direct: 1,
            n_indirect: 1,
            n_environment: 1,
            ..MotionRates::default()
        };
    }
    let l_p = pixel_length(k.pixel_scale, s.depth);
    // A velocity within the tolerance of a still point is no motion: neither filtered nor counted.
    let speed = |v: [f32; 2]| if moving(v) { Vec2::from(v).length() } else { 0.0 };
    let speed_p = speed(s.v_p);
    let speed_s = if s.occluded { speed(s.v_s) } else { 0.0 };
    let texture = mu(omega_motion(speed_p, k.omega_t, k.omega_pix));
    let shadow = mu(omega_motion(speed_s, k.omega_t, k.omega_pix));
    let direct = mu(omega_direct(0.0, s.s_min, l_p, k.light_half_width, k.omega_pix));
    let indirect = mu(omega_indirect(0.0, s.z_min, l_p, k.omega_v, k.omega_pix));
    let environment = mu(omega_environment(0.0, s.bandlimit, l_p, k.omega_pix));
    let p = if single {
        primary_strata(primary_rate(texture, speed_p, k.omega_pix), max_p)
    } else {
        primary_strata(k.multi_paths as f32, max_p)
    };
    let total_capped = |n: f32, cap: u32| {
        let q = if single { secondary_strata(n, p, cap) } else { 1 };
        p * p * q * q
    };
    let total = |n: f32| total_capped(n, max_s);
    let omega_d = direct.min(shadow);
    MotionRates {
        single,
        omega_texture: if single && speed_p > 0.0 { texture } else { 0.0 },
        omega_direct: direct,
        omega_shadow: if single && speed_s > 0.0 { shadow } else { 0.0 },
        omega_indirect: indirect,
        omega_environment: environment,
        pixel_length: l_p,
        n_primary: p * p,
        n_direct: total_capped(
            direct_rate(omega_d, speed_s, s.s_max, l_p, k.light_half_width, k.omega_pix),
            max_s_shadow,
        ),
        n_indirect: total(indirect_rate(indirect, 0.0, s.z_max, l_p, k.omega_v, k.omega_pix)),
        n_environment: total(environment_rate(environment, 0.0, k.environment_per_primary, k.omega_pix)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> MotionParams {
        MotionParams {
            mu: 1.0,
            mode: Mode::Literal,
            omega_pix: 0.5,
            omega_t: OMEGA_T_MAX,
            pixel_scale: 0.002,
            light_half_width: 0.25,
            omega_v: 2.8,
            max_primary: 256,
            max_per_primary: 4,
            max_shadow_per_primary: 4,
            multi_paths: THESIS_MULTI_VELOCITY_PATHS as u32,
            environment_per_primary: 4.0,
        }
    }

    #[test]
    fn widths_follow_b1_and_skip_static_pixels() {
        assert_eq!(omega_motion(0.0, OMEGA_T_MAX, 0.5), 0.5);
        assert_eq!(omega_motion(1.0, OMEGA_T_MAX, 0.5), 0.5);
        assert_eq!(omega_motion(10.0, OMEGA_T_MAX, 0.5), 0.1);
        let s = MotionStats { v_p: [10.0, 0.0], hit: true, depth: 2.0, ..Default::default() };
        let r = pixel_rates(&s, &params());
        assert!(r.single);
        assert_eq!(r.omega_texture, 0.1);
        // B.3: (0.5 + 0.1)²(1 + 10·0.1)² = 1.44 → 2² primary rays.
        assert_eq!(r.n_primary, 4);
        let still = pixel_rates(&MotionStats { v_p: [0.3, 0.0], ..s }, &params());
        assert_eq!(still.omega_texture, 0.0, "no filter below the velocity tolerance");
        assert_eq!(still.n_primary, 1);
    }

    #[test]
    fn two_velocities_take_sixty_four_paths_and_no_filter() {
        // Half the paths hit an object moving at 12 px, half the static background.
        let s = MotionStats { v_p: [12.0, 0.0], v_p_spread: [12.0, 0.0], hit: true, depth: 2.0, ..Default::default() };
        let r = pixel_rates(&s, &params());
        assert!(!r.single);
        assert_eq!((r.n_primary, r.omega_texture, r.n_direct), (64, 0.0, 64));
        // A rotating object: spread within a quarter of the speed is one motion.
        assert!(single_velocity([12.0, 0.0], [2.0, 1.0]));
    }

    #[test]
    fn a_moving_shadow_adds_the_time_factor_and_its_own_filter() {
        let base = MotionStats { hit: true, depth: 2.0, occluded: true, s_min: 0.5, s_max: 1.0, ..Default::default() };
        let still = pixel_rates(&base, &params());
        let moving = pixel_rates(&MotionStats { v_s: [0.0, 8.0], ..base }, &params());
        assert_eq!(still.omega_shadow, 0.0);
        assert_eq!(moving.omega_shadow, 0.125);
        assert!(moving.n_direct >= still.n_direct);
    }

    #[test]
    fn the_environment_takes_its_bandwidth_as_a_width_and_no_time_factor() {
        // ℓ_p = 0.004 m at depth 2; B = 100/m → Ω = 0.3536 · 100 · 0.004 = 0.1414 px⁻¹.
        let base = MotionStats { hit: true, depth: 2.0, bandlimit: 100.0, ..Default::default() };
        let r = pixel_rates(&base, &params());
        assert!((r.omega_environment - 0.141_421_4).abs() < 1e-5, "{r:?}");
        // (0.5 + 0.1414)² × 4 look-ups per primary ray = 1.65 → 2² at one primary ray.
        assert_eq!((r.n_primary, r.n_environment), (1, 4));
        // No bandwidth: the pixel limit; a moving receiver does not add a time factor (as indirect).
        let flat = pixel_rates(&MotionStats { bandlimit: 0.0, ..base }, &params());
        assert_eq!(flat.omega_environment, 0.5);
        let moving = pixel_rates(&MotionStats { v_p: [10.0, 0.0], ..base }, &params());
        assert_eq!(
            (moving.n_primary, moving.n_environment),
            (4, 4),
            "one look-up on each of 2² timed paths: {moving:?}"
        );
    }

    #[test]
    fn shadow_rays_and_hemisphere_samples_have_their_own_caps() {
        // A penumbra pixel near a reflector on a still receiver: one primary ray, many secondaries
        // asked for by both the light and the hemisphere.
        let s = MotionStats {
            hit: true,
            depth: 2.0,
            occluded: true,
            s_min: 0.2,
            s_max: 4.0,
            z_min: 0.01,
            z_max: 0.02,
            ..Default::default()
        };
        let k = MotionParams { max_per_primary: 1, max_shadow_per_primary: 4, ..params() };
        let r = pixel_rates(&s, &k);
        assert_eq!((r.n_primary, r.n_direct, r.n_indirect), (1, 4, 1), "{r:?}");
        let both = pixel_rates(&s, &params());
        assert_eq!((both.n_direct, both.n_indirect), (4, 4), "{both:?}");
    }

    #[test]
    fn consistent_mode_grows_counts_without_bound() {
        let s = MotionStats { v_p: [10.0, 0.0], hit: true, depth: 2.0, ..Default::default() };
        let mut k = params();
        k.mode = Mode::Consistent;
        k.max_primary = 1 << 20;
        let counts: Vec<u32> =
            [1.0, 4.0, 16.0].iter().map(|&mu| pixel_rates(&s, &MotionParams { mu, ..k }).n_primary).collect();
        assert!(counts[0] < counts[1] && counts[1] < counts[2], "{counts:?}");
    }
}
