//! The per-pixel formulas of thesis Ch. 6 (environment lighting, `seeds/000_956e982470d7e5bf.txt`
//! Sec. 6.6–6.7; `docs/EQUATIONS.md` "Environment"), as pure functions. `shaders/environment_formulas.wgsl`
//! mirrors them expression for expression.
//!
//! Units: bandwidths `B` are spatial frequencies in 1/m on the receiver (the filter weight of eq.
//! 6.23 is `exp(−2 B² d²)`, a Gaussian of standard deviation `σ = 1/(2B)` metres); angular bandwidths
//! (`B_f`, `B_ρ`, `B_e`) are in cycles per radian, curvature `κ` in radians per metre.
//!
//! - Direct light (eq. 6.17; diffuse `B_ρ = 0` gives eq. 6.13):
//!   `B_x = κ (B_f + 2B_ρ) + (cos²θ_occ / z)(B_f + 2B_ρ + B_e)`, `B_f = 1`. The occluder term
//!   `cos²θ_occ / z` is the sampler's largest over the pixel's occluded environment samples (the
//!   thesis takes the closest occluder, "the most conservative bound"; the largest term is that bound
//!   whatever the angles), 0 where nothing was occluded.
//! - Indirect light (eq. 6.18): `B_x = B_h / z_min`, `B_h` = 2.8 diffuse, `4.27 + 0.15 m` Phong.
//! - `B_ρ` of a Phong lobe of exponent `m`: the thesis gives `B_ρ(64) = 10` and `B_ρ(32) = 3.5`
//!   (App. E), which no single power law fits; reading taken (docs/EQUATIONS.md): `B_ρ = 1.25 √m`, which
//!   gives its 10 at m = 64, the exponent of its glossy results (Fig. 6.7, 6.9).
//! - Screen-space curvature (eq. 6.20): `κ_X = angle(n(x,y), n(x+1,y)) / ‖p(x,y) − p(x+1,y)‖`, the
//!   magnitude (docs/EQUATIONS.md: |κ| by default); the backward neighbour where the forward one is not on
//!   the same object, 0 where neither is.
//! - μ (an extension: Ch. 6 has none): every bandwidth, at least the window's ([`window_bandwidth`]:
//!   a zero bandwidth is the widest filter the 30 × 30 window holds, which a Gaussian of σ = 15 px
//!   stands for), is multiplied by μ, so the filters shrink below a pixel as μ grows (Monte Carlo in
//!   the limit), and adaptive look-ups ([`look_ups`]) hold the filtered variance where filters are
//!   narrow.

use glam::Vec3;

/// `B_f`: the angular bandwidth of the clamped cosine (thesis Fig. 6.5, eq. 6.13).
pub const B_F: f32 = 1.0;
/// `B_h` of a diffuse receiver (eq. 6.18, Ch. 4's transfer bandlimit).
pub const B_H_DIFFUSE: f32 = 2.8;
/// A bandwidth that tells `filter.environment` to pass the pixel through.
pub const NOT_FILTERED: f32 = -1.0;

/// `B_ρ` of a Phong lobe of exponent `m` (reading: `1.25 √m`; 0 for a diffuse receiver).
pub fn phong_bandwidth(m: f32) -> f32 {
    if m > 0.0 {
        1.25 * m.sqrt()
    } else {
        0.0
    }
}

/// `B_h` of eq. 6.18 for a receiver of Phong exponent `m` (0: diffuse).
pub fn transfer_bandwidth(m: f32) -> f32 {
    if m > 0.0 {
        4.27 + 0.15 * m
    } else {
        B_H_DIFFUSE
    }
}

/// Direct-light bandwidth (eq. 6.17; eq. 6.13 for `b_rho = 0`) from the curvature along the axis,
/// the occluder term `cos²θ_occ / z` and the environment's bandwidth `b_e`.
pub fn direct_bandwidth(kappa: f32, occluder: f32, b_rho: f32, b_e: f32) -> f32 {
    let angular = B_F + 2.0 * b_rho;
    kappa.abs() * angular + occluder.max(0.0) * (angular + b_e)
}

/// Indirect-light bandwidth (eq. 6.18), 0 (not filtered) where no indirect sample hit (`z_min ≤ 0`).
pub fn indirect_bandwidth(b_h: f32, z_min: f32) -> f32 {
    if z_min > 0.0 {
        b_h / z_min
    } else {
        0.0
    }
}

/// The occluder term `cos²θ_occ / z` of one occluded sample: `cos_theta` between the receiver normal
/// and the blocked direction, `z` the occluder's distance.
pub fn occluder_term(cos_theta: f32, z: f32) -> f32 {
    if z > 0.0 {
        cos_theta * cos_theta / z
    } else {
        0.0
    }
}

/// The angle between two unit normals over the distance between their points (eq. 6.20), in radians
/// per metre; 0 for coincident points. The angle is `2 asin(‖n0 − n1‖ / 2)`, not `acos(n0 · n1)`:
/// acos is ill-conditioned near 1, where nearly parallel normals (most pixels) sit, so a last-bit
/// difference in the dot product (a fused multiply-add on a GPU) would move κ by 1e-3 rad/m.
pub fn curvature(n0: Vec3, n1: Vec3, p0: Vec3, p1: Vec3) -> f32 {
    let d = (p1 - p0).length();
    if !(d > 0.0) {
        return 0.0;
    }
    let chord = (n0 - n1).length();
    2.0 * asin_series((0.5 * chord).min(1.0)) / d
}

/// `asin(s)` for `s ∈ [0, 1]` from its Taylor series to `s¹⁵` on `[0, ½]` (relative error < 2e-6 at
/// ½) and `π/2 − 2 asin(√((1 − s)/2))` above — only multiplications, additions and one square root,
/// so the WGSL mirror agrees to rounding (GPU `asin` implementations differ from Rust's by up to 4e-4
/// relative at small arguments, measured on lavapipe).
pub fn asin_series(s: f32) -> f32 {
    fn series(x: f32) -> f32 {
        let x2 = x * x;
        // Coefficients (2k)! / (4^k (k!)² (2k + 1)), k = 0..7.
        let c: [f32; 8] =
            [1.0, 1.0 / 6.0, 3.0 / 40.0, 5.0 / 112.0, 35.0 / 1152.0, 63.0 / 2816.0, 231.0 / 13312.0, 143.0 / 10240.0];
        let mut acc = c[7];
        for k in (0..7).rev() {
            acc = acc * x2 + c[k];
        }
        x * acc
    }
    if s <= 0.5 {
        series(s)
    } else {
        std::f32::consts::FRAC_PI_2 - 2.0 * series(((1.0 - s) * 0.5).sqrt())
    }
}

/// The standard deviation, in metres, of eq. 6.23's Gaussian `exp(−2 B² d²)`: `1/(2B)` (∞ for B = 0).
pub fn sigma_metres(b: f32) -> f32 {
    if b > 0.0 {
        0.5 / b
    } else {
        f32::INFINITY
    }
}

/// The filter's standard deviation in pixels along one axis, for a pixel footprint of `footprint`
/// metres, at most `max_radius` (the window's reach); 0 where there is no surface.
pub fn sigma_pixels(b: f32, footprint: f32, max_radius: f32) -> f32 {
    if !(footprint > 0.0) {
        0.0
    } else if b > 0.0 {
        (sigma_metres(b) / footprint).min(max_radius)
    } else {
        max_radius
    }
}

/// The bandwidths (1/m, per image axis) of one pixel's four filtered irradiances.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Bandwidths {
    /// Environment direct light, diffuse part (eq. 6.13) and glossy part (eq. 6.17 with `B_ρ(m)`).
    pub direct_diffuse: [f32; 2],
    pub direct_glossy: [f32; 2],
    /// Indirect light (eq. 6.18), diffuse and glossy (`B_h(m)`) parts; the same on both axes.
    pub indirect_diffuse: [f32; 2],
    pub indirect_glossy: [f32; 2],
}

/// The statistics of one pixel the bandwidths come from.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelStats {
    /// Screen-space curvature `(κ_X, κ_Y)`, rad/m (eq. 6.20).
    pub kappa: [f32; 2],
    /// The occluder term `cos²θ_occ / z` (1/m; 0: nothing bright occluded).
    pub occluder: f32,
    /// The receiver's Phong exponent (0: diffuse).
    pub exponent: f32,
    /// The nearest indirect hit, metres (0: none).
    pub z_min: f32,
}

/// The smallest bandwidth a filter of `max_radius` pixels can show, for a pixel footprint of
/// `footprint` metres: the Gaussian of σ = `max_radius` pixels, `1/(2 R ℓ)` (0 without a surface). A
/// smaller bandwidth (eq. 6.13 gives 0 on a flat, unoccluded receiver) is the same filter once the
/// window truncates it.
pub fn window_bandwidth(footprint: f32, max_radius: f32) -> f32 {
    if footprint > 0.0 && max_radius > 0.0 {
        0.5 / (max_radius * footprint)
    } else {
        0.0
    }
}

/// All four bandwidths of a pixel: the formula's, at least the window's ([`window_bandwidth`]
/// `floor`), times `mu` (the extension; 1 = the thesis up to the floor). The floor is what makes μ
/// consistent: a zero bandwidth times μ would stay the widest filter however large μ grows.
pub fn pixel_bandwidths(s: &PixelStats, b_e: f32, mu: f32, floor: f32) -> Bandwidths {
    let b_rho = phong_bandwidth(s.exponent);
    let axis = |b_rho: f32| [0, 1].map(|a| mu * direct_bandwidth(s.kappa[a], s.occluder, b_rho, b_e).max(floor));
    let indirect = |b_h: f32| [mu * indirect_bandwidth(b_h, s.z_min).max(floor); 2];
    // A receiver without a lobe has no glossy irradiance to filter: -1, "pass through" to the filter,
    // which then skips the pixel (the glossy parts are 0 there).
    let glossy = s.exponent > 0.0;
    Bandwidths {
        direct_diffuse: axis(0.0),
        direct_glossy: if glossy { axis(b_rho) } else { [NOT_FILTERED; 2] },
        indirect_diffuse: indirect(B_H_DIFFUSE),
        indirect_glossy: if glossy { indirect(transfer_bandwidth(s.exponent)) } else { [NOT_FILTERED; 2] },
    }
}

/// Adaptive look-ups per pixel (an extension: Ch. 6 takes a fixed 16). A Gaussian of σ pixels
/// averages about `4π σ_X σ_Y` pixels' worth of samples; where the filter is narrower than
/// `sigma_ref` pixels the pixel takes `base · σ_ref² / (σ_X σ_Y)` look-ups, so its filtered estimate
/// keeps the variance a `sigma_ref` filter over `base` look-ups has; never fewer than `base`, at most
/// `max`. As μ grows the filters shrink and the counts grow to `max` (consistency: `max` → ∞ is
/// Monte Carlo).
pub fn look_ups(base: u32, sigma: [f32; 2], sigma_ref: f32, max: u32) -> u32 {
    let area = sigma[0] * sigma[1];
    // No surface (σ = 0): nothing to filter, the base count.
    let want = if area > 0.0 { (base as f32 * sigma_ref * sigma_ref / area).ceil() } else { base as f32 };
    (want.min(max as f32) as u32).max(base).min(max.max(base))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_thesis_worked_examples() {
        // Fig. 6.5: κ = 0.5, one occluder at θ_occ = 0, z = 2, B_e = 3, B_f = 1: B_x = 2.5 (eq. 6.13).
        assert!((direct_bandwidth(0.5, occluder_term(1.0, 2.0), 0.0, 3.0) - 2.5).abs() < 1e-6);
        // App. E: glossy n = 32 with B_ρ = 3.5, κ = 0.5, θ_occ = π/4, z = 2, B_e = 4: B_x = 7 (eq. 6.17).
        let c = std::f32::consts::FRAC_PI_4.cos();
        assert!((direct_bandwidth(0.5, occluder_term(c, 2.0), 3.5, 4.0) - 7.0).abs() < 1e-5);
        // Eq. 6.6 without visibility: B_x = κ B_f.
        assert_eq!(direct_bandwidth(0.25, 0.0, 0.0, 4.0), 0.25);
        // Phong m = 64: the thesis's B_ρ = 10 (Fig. 6.9).
        assert_eq!(phong_bandwidth(64.0), 10.0);
        assert_eq!(indirect_bandwidth(B_H_DIFFUSE, 0.5), 5.6);
        assert_eq!(indirect_bandwidth(B_H_DIFFUSE, 0.0), 0.0);
    }

    #[test]
    fn curvature_of_a_circle_is_its_inverse_radius() {
        // Two points 0.01 rad apart on a unit circle.
        let (a, b) = (0.0f32, 0.01f32);
        let p = |t: f32| Vec3::new(t.cos(), t.sin(), 0.0);
        let k = curvature(p(a), p(b), p(a), p(b));
        assert!((k - 1.0).abs() < 1e-3, "{k}");
        assert_eq!(curvature(Vec3::Z, Vec3::Z, Vec3::ZERO, Vec3::ZERO), 0.0);
        for k in 0..=100 {
            let x = k as f32 / 100.0;
            assert!((asin_series(x) - x.asin()).abs() <= 2e-6 * x.asin().max(1e-3), "{x}");
        }
        // Opposite normals: π over the distance.
        assert!((curvature(Vec3::Z, -Vec3::Z, Vec3::ZERO, Vec3::X) - std::f32::consts::PI).abs() < 1e-6);
    }

    #[test]
    fn bandwidths_scale_with_mu_and_sigma_is_half_the_inverse() {
        let s = PixelStats { kappa: [0.5, 0.0], occluder: 0.5, exponent: 64.0, z_min: 0.5 };
        let b = pixel_bandwidths(&s, 3.0, 1.0, 0.0);
        assert_eq!(b.direct_diffuse, [2.5, 2.0]);
        let diffuse = pixel_bandwidths(&PixelStats { exponent: 0.0, ..s }, 3.0, 1.0, 0.0);
        assert_eq!((diffuse.direct_glossy, diffuse.indirect_glossy), ([NOT_FILTERED; 2], [NOT_FILTERED; 2]));
        // B_ρ(64) = 10: κ(1 + 20) + 0.5 (1 + 20 + 3).
        assert_eq!(b.direct_glossy, [0.5 * 21.0 + 0.5 * 24.0, 0.5 * 24.0]);
        assert_eq!(b.indirect_diffuse, [5.6, 5.6]);
        let b2 = pixel_bandwidths(&s, 3.0, 2.0, 0.0);
        assert_eq!(b2.direct_diffuse, [5.0, 4.0]);
        // A flat, unoccluded receiver: eq. 6.13 gives 0; the window's floor, then μ.
        let flat = PixelStats { kappa: [0.0; 2], occluder: 0.0, exponent: 0.0, z_min: 0.0 };
        let floor = window_bandwidth(0.01, 15.0);
        assert!((floor - 0.5 / 0.15).abs() < 1e-5);
        assert_eq!(pixel_bandwidths(&flat, 3.0, 1.0, floor).direct_diffuse, [floor; 2]);
        assert_eq!(pixel_bandwidths(&flat, 3.0, 8.0, floor).direct_diffuse, [8.0 * floor; 2]);
        assert_eq!(sigma_metres(2.0), 0.25);
        assert_eq!(sigma_pixels(2.0, 0.05, 30.0), 5.0);
        assert_eq!(sigma_pixels(0.0, 0.05, 15.0), 15.0);
    }

    #[test]
    fn look_ups_hold_base_for_wide_filters_and_grow_for_narrow_ones() {
        assert_eq!(look_ups(16, [2.0, 3.0], 1.0, 256), 16);
        assert_eq!(look_ups(16, [0.5, 0.5], 1.0, 256), 64);
        assert_eq!(look_ups(16, [0.01, 0.01], 1.0, 256), 256);
        assert_eq!(look_ups(16, [0.0, 0.0], 1.0, 256), 16);
    }
}
