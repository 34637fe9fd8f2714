//! The formulas of thesis Ch. 3 as pure per-pixel functions: the occlusion spectrum's slopes
//! (eq. 3.4), the filter width β (eq. 3.13), the sample count n (eq. 3.21) and how the pass caps
//! and rounds it. Mirrored term by term in `shaders/shadows_formulas.wgsl`.

/// Slopes of the occlusion spectrum's double wedge (thesis eq. 3.4):
/// `s_min = d1/d2_max − 1`, `s_max = d1/d2_min − 1`.
pub fn slopes(d1: f32, d2_min: f32, d2_max: f32) -> (f32, f32) {
    (d1 / d2_max - 1.0, d1 / d2_min - 1.0)
}

/// Filter std-dev β in metres (thesis eq. 3.13):
/// `β = (1/k)(1/μ) max[σ s_min, 1/Ω_x^max]` with `Ω_x^max = α/d` (eq. 3.6, conservative choice).
/// As μ → ∞, β → 0: the filter shrinks to the pixel itself and the result converges to Monte Carlo.
pub fn filter_beta(sigma: f32, s_min: f32, d: f32, mu: f32, alpha: f32, k: f32) -> f32 {
    (sigma * s_min).max(d / alpha) / (k * mu)
}

/// Samples per pixel (thesis eq. 3.21), including the initial ones:
/// `n(μ) = 4(1 + μ s_max/s_min)² (μ (2/s_min) sqrt(A_p/A_l) + α/(1 + s_min))²`,
/// with `A_p = d²` and `A_l = (2σ)²` (Sec. 3.5.1). Returns `f32::INFINITY` when `s_min ≤ 0`
/// (occluder on the receiver), which the caller clamps to the maximum count.
pub fn samples_per_pixel(s_min: f32, s_max: f32, d: f32, sigma: f32, mu: f32, alpha: f32) -> f32 {
    if s_min <= 0.0 || !s_min.is_finite() {
        return f32::INFINITY;
    }
    let a_p = d * d;
    let a_l = (2.0 * sigma) * (2.0 * sigma);
    let first = 1.0 + mu * s_max / s_min;
    let second = mu * (2.0 / s_min) * (a_p / a_l).sqrt() + alpha / (1.0 + s_min);
    4.0 * first * first * second * second
}

/// `n` rounded up to a multiple of `initial` (the first pass's light samples): the sampler's base-2
/// sequence is stratified in blocks of powers of 2, so a pixel's shadow rays stay whole blocks of 8.
/// Measured on `shadows.ron` (160×120, seeds 1–3): RMSE 2% lower than exact counts at 1.1% more rays
/// (docs/SAMPLER-STAGE.md "Samples, not paths").
pub fn whole_multiples(n: u32, initial: u32) -> u32 {
    let initial = initial.max(1);
    n.div_ceil(initial).saturating_mul(initial)
}

/// The cap on eq. 3.21's count as the pass applies it: `max_rays · max(μ, 1)²`, then at most
/// `rays_cap` (an absolute ceiling, as Indirect's), and at least `initial`.
/// Eq. 3.21 grows as `(1 + μ s_max/s_min)²`: under several occluder layers (s_max/s_min large) it
/// asks for hundreds of rays that buy little once β is set by `s_min`, and a low cap spends them
/// where they help (`suite_slats`, 320×240: 1.19× → 2.52× vs stratified MC with 64 instead of 400,
/// docs/DESIGN-NOTES.md "The cap on eq. 3.21's count"). Scaling with μ² keeps it consistent: as μ
/// grows the cap recedes and the counts converge to eq. 3.21's, i.e. to Monte Carlo.
pub fn rays_cap(max_rays: i64, mu: f32, absolute: i64, initial: u32) -> u32 {
    let scaled = max_rays.max(1) as f64 * f64::from(mu.max(1.0)).powi(2);
    (scaled.min(absolute.max(1) as f64).min(f64::from(u32::MAX)) as u32).max(initial)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slopes_eq_3_4() {
        // d1 = 3, occluders at 1 and 2 from the light: s_min = 3/2 − 1, s_max = 3/1 − 1.
        let (s_min, s_max) = slopes(3.0, 1.0, 2.0);
        assert!((s_min - 0.5).abs() < 1e-6);
        assert!((s_max - 2.0).abs() < 1e-6);
    }

    #[test]
    fn beta_eq_3_13_by_hand() {
        // σ = 0.3, s_min = 0.5, d = 0.01, μ = 2, α = 1, k = 3: max(0.15, 0.01)/6 = 0.025.
        let b = filter_beta(0.3, 0.5, 0.01, 2.0, 1.0, 3.0);
        assert!((b - 0.025).abs() < 1e-7, "{b}");
        // Pixel limit wins when σ s_min < d/α: max(0.003, 0.01)/(3·1) = 0.0033333.
        let b = filter_beta(0.3, 0.01, 0.01, 1.0, 1.0, 3.0);
        assert!((b - 0.01 / 3.0).abs() < 1e-7, "{b}");
        // α < 1 raises the pixel limit: d/α = 0.02.
        let b = filter_beta(0.0, 0.0, 0.01, 1.0, 0.5, 1.0);
        assert!((b - 0.02).abs() < 1e-7);
    }

    #[test]
    fn beta_shrinks_to_a_pixel_as_mu_grows() {
        // β scales as 1/μ; at μ = 1e6 it is far below a pixel (d = 0.01), so the Gaussian's weight
        // on the nearest neighbour, exp(−d²/(2β²)), underflows to 0: a one-pixel filter.
        let b = filter_beta(0.3, 0.5, 0.01, 1e6, 1.0, 3.0);
        assert!(b < 1e-6);
        assert_eq!((-(0.01f32 * 0.01) / (2.0 * b * b)).exp(), 0.0);
        assert!(
            (filter_beta(0.3, 0.5, 0.01, 4.0, 1.0, 3.0) * 2.0 - filter_beta(0.3, 0.5, 0.01, 2.0, 1.0, 3.0)).abs()
                < 1e-7
        );
    }

    #[test]
    fn samples_eq_3_21_by_hand() {
        // s_min = 0.5, s_max = 2, d = 0.01, σ = 0.1 (A_l = 0.04, sqrt(A_p/A_l) = 0.05), μ = 2, α = 1:
        // 4 (1 + 2·4)² (2·4·0.05 + 1/1.5)² = 4 · 81 · (0.4 + 0.666667)² = 368.64.
        let n = samples_per_pixel(0.5, 2.0, 0.01, 0.1, 2.0, 1.0);
        assert!((n - 368.64).abs() < 0.01, "{n}");
        // μ = 1: 4 (1 + 4)² (0.2 + 0.666667)² = 100 · 0.751111 = 75.1111.
        let n = samples_per_pixel(0.5, 2.0, 0.01, 0.1, 1.0, 1.0);
        assert!((n - 75.1111).abs() < 0.001, "{n}");
        // A single occluder depth (s_max = s_min) and a tiny pixel: 4·(1+μ)²·(α/(1+s))² → μ = 1: 16/2.25.
        let n = samples_per_pixel(0.5, 0.5, 0.0, 0.1, 1.0, 1.0);
        assert!((n - 16.0 / 2.25).abs() < 1e-4, "{n}");
        // Contact shadows (s_min → 0) need unbounded samples: the caller clamps.
        assert!(samples_per_pixel(0.0, 2.0, 0.01, 0.1, 2.0, 1.0).is_infinite());
    }

    #[test]
    fn samples_grow_quadratically_in_mu() {
        // Fig. 3.5(a): for large μ, n ∝ μ⁴ asymptotically only through both factors; check monotone growth.
        let mut last = 0.0;
        for mu in [0.5, 1.0, 2.0, 4.0, 8.0] {
            let n = samples_per_pixel(0.5, 2.0, 0.01, 0.1, mu, 1.0);
            assert!(n > last);
            last = n;
        }
    }

    #[test]
    fn rays_cap_scales_with_mu_squared() {
        // Default 16 → 64 at μ = 2; below μ = 1 it stays 16; never under the first pass; the
        // absolute cap wins last.
        let no_ceiling = i64::MAX;
        assert_eq!(rays_cap(16, 2.0, no_ceiling, 8), 64);
        assert_eq!(rays_cap(16, 0.5, no_ceiling, 8), 16);
        assert_eq!(rays_cap(16, 8.0, no_ceiling, 8), 1024);
        assert_eq!(rays_cap(2, 1.0, no_ceiling, 8), 8);
        assert_eq!(rays_cap(16, 1e6, no_ceiling, 8), u32::MAX);
        assert_eq!(rays_cap(16, 1e6, 100, 8), 100);
        assert_eq!(rays_cap(16, 1e6, 1, 8), 8);
        // The cap binds eq. 3.21's count at μ = 64 but recedes past it as μ grows (consistency).
        let n = samples_per_pixel(0.5, 2.0, 0.01, 0.1, 64.0, 1.0);
        assert!(f64::from(rays_cap(16, 64.0, no_ceiling, 8)) < f64::from(n));
        assert!(f64::from(rays_cap(16, 1e4, no_ceiling, 8)) > f64::from(n));
    }
}
