//! The pure formulas of radiance filtering (seed 002 Ch. 4), unit-tested here; WGSL mirror:
//! `shaders/radiance_filter_formulas.wgsl`.

use glam::Vec3;
use wedge_backends::kernels::v3;

use super::node::{DEFAULT_MAX_RADIUS, DEFAULT_T_U, DEFAULT_WARMUP, DEFAULT_WARMUP_RADIUS};

/// `filtered.w` of a pixel filtered over its neighbours (the preview phase).
pub const FILTERED: f32 = -1.0;
/// `filtered.w` of a pixel whose kernel holds only its own sample (radius < 1 pixel: the correction
/// phase, or no surface): the compose pass takes the pixel's own path-tracing estimate, bit for bit.
/// A reference, whose filter is bypassed to that estimate (`w` = M2 ≥ 0), is treated the same way.
pub const OWN: f32 = -2.0;

/// Effective samples of a 2-D Epanechnikov kernel per unit area, `(∫K)²/(∫K²)/area` = (π/2)²/(π/3)/π
/// = 3/4: with one sample per pixel, a kernel of image radius `r` averages `¾πr²` samples' worth
/// (reading: Sec. 4.3.5 says the radius must be adjusted for a non-uniform kernel, not how).
pub const EPANECHNIKOV_EFFICIENCY: f32 = 0.75;

/// `incident.w` of a radiance sample whose continuation ray left the scene (no occluder at any
/// distance).
pub const NO_BOUNCE_HIT: f32 = -1.0;

/// The smallest `|D·N|` eq. 4.21 divides by: the kernel is elongated at most 5× along the surface
/// at grazing angles (the thesis's "small ε … in practice, excessive elongation").
pub const MIN_COS: f32 = 0.2;

/// Target variance of frame `k` (1-based), eq. 4.14: `T_k = (2k − 1) T_u`, the largest variance of
/// frame `k`'s estimate that keeps the running mean at `T_u` (eq. 4.13).
#[inline]
pub fn target_variance(t_u: f32, k: u32) -> f32 {
    (2.0 * k as f32 - 1.0) * t_u
}

/// Warm-up radius of frame `k` (eq. 4.15): `r_w1 k^-1/2`.
#[inline]
pub fn warmup_radius(r_w1: f32, k: u32) -> f32 {
    r_w1 / (k as f32).sqrt()
}

/// Image-space radius (pixels) whose Epanechnikov kernel averages `M_k = v/T_k` samples (eq. 4.1),
/// `v` the pixel's perceived per-path variance: `√(M_k / (¾π))` — the circle covering `M_k` pixels of
/// eq. 4.2, corrected for the kernel's weights ([`EPANECHNIKOV_EFFICIENCY`]). `v = ∞` (a black
/// background under noise) gives ∞; the caller caps it.
#[inline]
pub fn variance_radius(v: f32, t_u: f32, k: u32) -> f32 {
    let m = v / target_variance(t_u, k);
    (m / (EPANECHNIKOV_EFFICIENCY * std::f32::consts::PI)).sqrt()
}

wedge_backends::kernel_params! {
    /// The settings of the kernel-radius rule: the parameters of `radiance_filter.radius`, the
    /// node's first five.
    pub struct RadiusRule {
        t_u: f32 = positive(DEFAULT_T_U, 1e6, "threshold T_u on the accumulated image's perceived variance (eq. 4.13)"),
        warmup: u32 = int(DEFAULT_WARMUP, 1, 1 << 20, "frames that use the warm-up radius r_w1 k^-1/2 (eq. 4.15) before the variance estimate"),
        warmup_radius: f32 = float(DEFAULT_WARMUP_RADIUS, 0.0, 1024.0, "warm-up radius r_w1 of the first frame (pixels)"),
        /// Also the filter's window cap (`FilterParams`).
        max_radius: u32 = int(DEFAULT_MAX_RADIUS, 0, 1024, "largest image-space kernel radius (pixels)"),
        /// Scale the radius by the previous frame's occlusion factor α.
        occlusion: bool = boolean(true, "scale the radius by a screen-space ambient-occlusion factor (Sec. 4.3.1, step 3) against light leaks"),
    }
}

/// The radius of frame `k` (1-based) for a pixel: the warm-up radius for the first `warmup` frames
/// or where no variance is known yet (`sigma2 < 0`), else [`variance_radius`] of the perceived
/// variance `σ²/L_b²` (Sec. 3.3.1, as Sec. 4.3.4 uses it; `L_b` the luminance of the accumulated
/// image). Capped at `max_radius`; a NaN becomes 0 (no filtering, never a spread NaN).
pub fn kernel_radius(rule: &RadiusRule, k: u32, sigma2: f32, lb: f32) -> f32 {
    let r = if k <= rule.warmup || sigma2 < 0.0 {
        warmup_radius(rule.warmup_radius, k)
    } else if !(sigma2 > 0.0) {
        0.0
    } else if !(lb > 0.0) {
        rule.max_radius as f32
    } else {
        variance_radius(sigma2 / (lb * lb), rule.t_u, k)
    };
    if r.is_nan() {
        0.0
    } else {
        r.min(rule.max_radius as f32)
    }
}

/// Whether a sample's continuation ray, which hit a surface at `distance` ([`NO_BOUNCE_HIT`]: none),
/// was unoccluded within the kernel's tangent radius `rs`: the screen-space ambient occlusion of
/// Sec. 4.3.1 (step 3) with the kernel's own radius as the occlusion distance (reading: the thesis
/// names the factor and its effect — like the harmonic mean distance of irradiance caching, it
/// shrinks kernels near occluders against light leaks — not its formula).
#[inline]
pub fn unoccluded(distance: f32, rs: f32) -> bool {
    distance == NO_BOUNCE_HIT || distance > rs
}

/// The occlusion factor α ∈ [0, 1]: the kernel-weighted fraction of its samples whose continuation
/// rays were [`unoccluded`]; 1 without samples.
#[inline]
pub fn occlusion_factor(unoccluded_weight: f32, weight: f32) -> f32 {
    if weight > 0.0 {
        (unoccluded_weight / weight).min(1.0)
    } else {
        1.0
    }
}

/// The normal heuristic of eq. 4.9, `ν = max(0, n_j·n)^e`.
#[inline]
pub fn normal_weight(nj: Vec3, n: Vec3, e: f32) -> f32 {
    nj.dot(n).max(0.0).powf(e)
}

/// The exponent `e` of eq. 4.9 for a surface's glossy lobe: its Phong/Blinn exponent where it has
/// one, else 1 (reading: the thesis sets ν = 1 below e ≈ 128 to save a normal buffer; wedge has
/// the normals and keeps ν = max(0, n_j·n) so back-to-back surfaces never mix).
#[inline]
pub fn normal_exponent(ks: Vec3, m: f32) -> f32 {
    if m > 0.0 && ks.max_element() > 0.0 {
        m.max(1.0)
    } else {
        1.0
    }
}

/// The kernel's footprint on the tangent plane of the shading point (eqs. 4.19–4.22): an ellipse
/// with semi-axes `r_S` across the view direction and `r_D = r_S / max(ε, |D·N|)` along it, in a
/// prism of half-height `δ` along the normal. The Epanechnikov weight (Sec. 4.3.6) is
/// `1 − (s/r_S)² − (d/r_D)²` inside, 0 outside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TangentKernel {
    pub centre: Vec3,
    pub normal: Vec3,
    pub axis_s: Vec3,
    pub axis_d: Vec3,
    /// The tangent radius `r_S` (world units) and the reciprocals of both semi-axes.
    pub rs: f32,
    pub inv_rs: f32,
    pub inv_rd: f32,
    pub delta: f32,
}

impl TangentKernel {
    /// The kernel at `x` (normal `n`) seen from `eye` at ray distance `distance`, image radius
    /// `r` pixels, `pixel_angle` = the angle one pixel subtends (`2 tan(fov/2) / height`), prism
    /// half-height `thickness · r_S`. `r_S` is eq. 4.20 with the image plane at unit distance as the
    /// reference plane: `r_S = r · pixel_angle · distance`.
    pub fn new(x: Vec3, n: Vec3, eye: Vec3, distance: f32, r: f32, pixel_angle: f32, thickness: f32) -> TangentKernel {
        let d = (x - eye).normalize_or_zero();
        let dn = d.dot(n);
        // Eq. 4.19 with the reading of docs/EQUATIONS.md: the tangent projection of D is D − (D·N)N.
        let mut a_d = d - n * dn;
        let len = a_d.length();
        if !(len > 1e-6) {
            // Seen head-on: any tangent direction (the orientation does not matter, Sec. 4.3.5).
            a_d = if n.x.abs() > 0.9 { Vec3::new(0.0, 1.0, 0.0) } else { Vec3::new(1.0, 0.0, 0.0) };
            a_d = (a_d - n * a_d.dot(n)).normalize();
        } else {
            a_d /= len;
        }
        let a_s = a_d.cross(n);
        let rs = r * pixel_angle * distance;
        let rd = rs / dn.abs().max(MIN_COS);
        TangentKernel {
            centre: x,
            normal: n,
            axis_s: a_s,
            axis_d: a_d,
            rs,
            inv_rs: 1.0 / rs,
            inv_rd: 1.0 / rd,
            delta: thickness * rs,
        }
    }

    /// The Epanechnikov weight of a sample at `xj`.
    #[inline]
    pub fn weight(&self, xj: Vec3) -> f32 {
        let v = xj - self.centre;
        if v.dot(self.normal).abs() > self.delta {
            return 0.0;
        }
        let s = v.dot(self.axis_s) * self.inv_rs;
        let d = v.dot(self.axis_d) * self.inv_rd;
        let u = s * s + d * d;
        if u < 1.0 {
            1.0 - u
        } else {
            0.0
        }
    }
}

/// The window of a pixel's kernel: `floor(r)` pixels either side, at most `max_radius`; 0 (its own
/// sample only) below one pixel.
#[inline]
pub fn window(r: f32, max_radius: u32) -> i32 {
    if r >= 1.0 {
        (r.floor() as i32).min(max_radius as i32)
    } else {
        0
    }
}

/// One pixel of the compose pass: `(accumulated, radiance, phase)` from this frame's direct light
/// `sample_lv` (w = finite paths), own indirect estimate `own`, filtered indirect light
/// `filtered`, the accumulated unfiltered image `unfiltered`, the previous accumulation and phase.
/// A frame whose own path was not finite (`sample_lv.w = 0`) adds nothing to the pixel.
pub fn compose_pixel(
    sample_lv: [f32; 4],
    own: [f32; 4],
    filtered: [f32; 4],
    unfiltered: Vec3,
    previous: [f32; 4],
    previous_phase: f32,
    switch: bool,
) -> ([f32; 4], Vec3, f32) {
    let own_only = filtered[3] != FILTERED;
    let indirect = if own_only { v3(own) } else { v3(filtered) };
    let x = v3(sample_lv) + indirect;
    let b = sample_lv[3];
    let mut acc = previous;
    if b > 0.0 {
        let n = previous[3] + b;
        let mean = v3(previous) + (x - v3(previous)) * (b / n);
        acc = [mean.x, mean.y, mean.z, n];
    }
    let now = if own_only { 1.0 } else { 0.0 };
    let phase = if switch { previous_phase.max(now) } else { now };
    let radiance = if switch && phase >= 1.0 { unfiltered } else { v3(acc) };
    (acc, radiance, phase)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn target_variance_keeps_the_running_mean_at_the_threshold() {
        // Eq. 4.13 with equality: ((k−1)/k)² T + T_k/k² = T for T_k = (2k−1)T (eq. 4.14).
        for &t in &[1e-4f32, 0.01, 0.3, 7.0] {
            for k in 1..200u32 {
                let kf = k as f64;
                let tk = f64::from(target_variance(t, k));
                let lhs = ((kf - 1.0) / kf).powi(2) * f64::from(t) + tk / (kf * kf);
                assert!((lhs - f64::from(t)).abs() <= 1e-6 * f64::from(t), "k {k} t {t}: {lhs}");
            }
        }
    }

    #[test]
    fn radius_falls_as_one_over_root_k() {
        let rule = RadiusRule { occlusion: false, t_u: 0.01, warmup: 4, warmup_radius: 8.0, max_radius: 1 << 30 };
        // Warm-up (eq. 4.15): r_w1 k^-1/2.
        assert_eq!(kernel_radius(&rule, 1, -1.0, 1.0), 8.0);
        assert!((kernel_radius(&rule, 4, 0.5, 1.0) - 4.0).abs() < 1e-6);
        // After it, for a fixed variance: r_k ∝ (2k−1)^-1/2 → k^-1/2 (eq. 4.32's Θ(k^-1/2)).
        for k in [5u32, 10, 100, 1000] {
            let (a, b) = (kernel_radius(&rule, k, 0.5, 1.0), kernel_radius(&rule, 4 * k, 0.5, 1.0));
            let expect = ((8.0 * k as f32 - 1.0) / (2.0 * k as f32 - 1.0)).sqrt();
            assert!((a / b - expect).abs() < 1e-4 * expect, "k {k}: {a}/{b}");
        }
        // The kernel's effective sample count reaches M_k = v/T_k: ¾πr² = v/T_k.
        let (v, k) = (0.8f32, 7u32);
        let r = variance_radius(v, 0.01, k);
        assert!((EPANECHNIKOV_EFFICIENCY * std::f32::consts::PI * r * r - v / target_variance(0.01, k)).abs() < 1e-3);
    }

    #[test]
    fn radius_edge_cases() {
        let rule = RadiusRule { occlusion: false, t_u: 0.01, warmup: 2, warmup_radius: 6.0, max_radius: 16 };
        // Unknown variance after warm-up: warm-up radius; zero variance: no filter; black
        // background under noise: the cap; NaN: no filter.
        assert!((kernel_radius(&rule, 9, -1.0, 1.0) - 2.0).abs() < 1e-6);
        assert_eq!(kernel_radius(&rule, 9, 0.0, 1.0), 0.0);
        assert_eq!(kernel_radius(&rule, 9, 0.1, 0.0), 16.0);
        assert_eq!(kernel_radius(&rule, 9, f32::NAN, 1.0), 0.0);
        assert_eq!(kernel_radius(&rule, 9, 1e30, 1.0), 16.0);
    }

    #[test]
    fn epanechnikov_footprint_on_the_tangent_plane() {
        // A floor (n = +y) seen at 60° from the normal: r_S across, r_S / cos 60° = 2 r_S along.
        let n = Vec3::Y;
        let x = Vec3::ZERO;
        let eye = Vec3::new(0.0, 60f32.to_radians().cos(), -60f32.to_radians().sin()) * 10.0;
        let k = TangentKernel::new(x, n, eye, 10.0, 4.0, 0.01, 0.1);
        let rs = 4.0 * 0.01 * 10.0;
        assert!((k.weight(x) - 1.0).abs() < 1e-6);
        // Across (x axis): 0 at r_S, ¾ at r_S/2.
        assert!((k.weight(Vec3::new(0.5 * rs, 0.0, 0.0)) - 0.75).abs() < 1e-4);
        assert_eq!(k.weight(Vec3::new(1.001 * rs, 0.0, 0.0)), 0.0);
        // Along the view direction: twice as far.
        assert!((k.weight(Vec3::new(0.0, 0.0, rs)) - 0.75).abs() < 1e-4);
        assert!(k.weight(Vec3::new(0.0, 0.0, 1.99 * rs)) > 0.0);
        assert_eq!(k.weight(Vec3::new(0.0, 0.0, 2.01 * rs)), 0.0);
        // Off the plane by more than δ = 0.1 r_S: another surface.
        assert_eq!(k.weight(Vec3::new(0.0, 0.11 * rs, 0.0)), 0.0);
        assert!(k.weight(Vec3::new(0.0, 0.09 * rs, 0.0)) > 0.99);
        // Head-on: a circle.
        let k = TangentKernel::new(x, n, Vec3::new(0.0, 10.0, 0.0), 10.0, 4.0, 0.01, 0.1);
        assert!((k.weight(Vec3::new(0.5 * rs, 0.0, 0.0)) - k.weight(Vec3::new(0.0, 0.0, 0.5 * rs))).abs() < 1e-5);
    }

    #[test]
    fn occlusion_factor_is_the_weighted_unoccluded_fraction() {
        assert!(unoccluded(NO_BOUNCE_HIT, 0.1) && unoccluded(0.2, 0.1) && !unoccluded(0.05, 0.1));
        assert_eq!(occlusion_factor(0.0, 0.0), 1.0);
        assert_eq!(occlusion_factor(0.75, 3.0), 0.25);
        assert_eq!(occlusion_factor(3.0000002, 3.0), 1.0);
    }

    #[test]
    fn normal_heuristic() {
        assert_eq!(normal_weight(Vec3::Y, -Vec3::Y, 1.0), 0.0);
        assert!((normal_weight(Vec3::new(0.0, 1.0, 1.0).normalize(), Vec3::Y, 2.0) - 0.5).abs() < 1e-6);
        assert_eq!(normal_exponent(Vec3::ZERO, 50.0), 1.0);
        assert_eq!(normal_exponent(Vec3::splat(0.3), 50.0), 50.0);
    }

    #[test]
    fn compose_accumulates_and_switches() {
        let own = [0.5, 0.5, 0.5, 0.0];
        let filtered = [0.2, 0.2, 0.2, FILTERED];
        // Preview frame: direct + filtered, running mean over frames.
        let (acc, rad, phase) =
            compose_pixel([1.0, 1.0, 1.0, 1.0], own, filtered, Vec3::splat(9.0), [0.0; 4], 0.0, false);
        assert_eq!(acc, [1.2, 1.2, 1.2, 1.0]);
        assert_eq!((rad, phase), (Vec3::splat(1.2), 0.0));
        let (acc, _, _) =
            compose_pixel([2.0, 2.0, 2.0, 1.0], own, [0.0, 0.0, 0.0, OWN], Vec3::splat(9.0), acc, 0.0, false);
        // Own estimate in the correction phase: 2 + 0.5, mean with 1.2.
        assert!((acc[0] - 1.85).abs() < 1e-6 && acc[3] == 2.0);
        // A non-finite path adds nothing.
        let (same, _, _) = compose_pixel([0.0, 0.0, 0.0, 0.0], own, filtered, Vec3::ZERO, acc, 0.0, false);
        assert_eq!(same, acc);
        // Switch: once in the correction phase, the plain accumulation, and it stays there.
        let (_, rad, phase) =
            compose_pixel([1.0, 1.0, 1.0, 1.0], own, [0.0, 0.0, 0.0, OWN], Vec3::splat(9.0), acc, 0.0, true);
        assert_eq!((rad, phase), (Vec3::splat(9.0), 1.0));
        let (_, rad, phase) = compose_pixel([1.0, 1.0, 1.0, 1.0], own, filtered, Vec3::splat(9.0), acc, 1.0, true);
        assert_eq!((rad, phase), (Vec3::splat(9.0), 1.0));
        // A reference's bypassed filter (w = M2 ≥ 0) keeps the own estimate.
        let (acc, _, _) =
            compose_pixel([1.0, 1.0, 1.0, 4.0], own, [0.5, 0.5, 0.5, 0.3], Vec3::ZERO, [0.0; 4], 0.0, false);
        assert_eq!(acc, [1.5, 1.5, 1.5, 4.0]);
    }
}
