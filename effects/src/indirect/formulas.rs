//! The formulas of thesis Ch. 4 and App. A as pure per-pixel functions: the receiver's transfer
//! bandlimit and γ, the clamped `z_min`, the filter bandwidth and width β (eqs. 4.15–4.16, 4.18,
//! A.3, A.5), the sample count (eq. 4.21) and its clamp; [`component`] puts them together for one
//! component at one pixel. Mirrored in `shaders/indirect_formulas.wgsl`.

use std::f32::consts::FRAC_PI_2;

use wedge_backends::kernels::neighbourhood_others::same_object_neighbours;

/// Receiver BRDF for the transfer-function bandlimit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Receiver {
    Diffuse,
    BlinnPhong(f32),
    Phong(f32),
}

/// Transfer-function bandlimit `Ω_h^max` capturing 99% of its energy (thesis eq. 4.18, A.3, A.5):
/// diffuse 2.8, Blinn-Phong `3.6 + 0.084 m`, Phong `4.27 + 0.15 m`.
pub fn transfer_bandlimit(r: Receiver) -> f32 {
    match r {
        Receiver::Diffuse => 2.8,
        Receiver::BlinnPhong(m) => 3.6 + 0.084 * m,
        Receiver::Phong(m) => 4.27 + 0.15 * m,
    }
}

/// `γ` of eq. 4.21: 0.4 for diffuse; `acos(c^{1/m})/(π/2)` with `c = 1/√2` for glossy receivers
/// (the fraction of the hemisphere's angular extent the lobe occupies at half power).
pub fn gamma(r: Receiver) -> f32 {
    match r {
        Receiver::Diffuse => 0.4,
        Receiver::BlinnPhong(m) | Receiver::Phong(m) => {
            let c = std::f32::consts::FRAC_1_SQRT_2;
            c.powf(1.0 / m.max(1e-6)).acos() / FRAC_PI_2
        }
    }
}

/// `z_min` clamped to at least `fraction` of the scene's largest dimension (thesis Sec. 4.5).
pub fn clamp_z_min(z_min: f32, extent: f32, fraction: f32) -> f32 {
    z_min.max(fraction * extent)
}

/// Filter bandwidth (world units⁻¹), thesis eq. 4.15: `Ω_x^r = μ · min(Ω_h/z_min, α/d)`.
pub fn filter_bandwidth(omega_h: f32, z_min: f32, d: f32, mu: f32, alpha: f32) -> f32 {
    mu * (omega_h / z_min).min(alpha / d)
}

/// Spatial std-dev (metres), thesis eq. 4.16: `β = 2/Ω_x^r`. As μ → ∞, β → 0: a one-pixel filter.
pub fn filter_beta(omega_x_r: f32) -> f32 {
    2.0 / omega_x_r
}

/// Samples per pixel (thesis eq. 4.21), before clamping:
/// `n = γ (μ Ω_h sqrt(A_p)/z_min + α)² Ω_h² (1 + μ z_max/z_min)²` with `A_p = d²`.
pub fn samples_per_pixel(gamma: f32, omega_h: f32, d: f32, z_min: f32, z_max: f32, mu: f32, alpha: f32) -> f32 {
    let first = mu * omega_h * d / z_min + alpha;
    let second = 1.0 + mu * z_max / z_min;
    gamma * first * first * omega_h * omega_h * second * second
}

/// Round eq. 4.21 up and clamp to `[initial, max · max(μ, 1)]` (thesis: 16 and 100μ).
pub fn clamp_rate(n: f32, mu: f32, initial: u32, max: u32) -> u32 {
    let hi = ((max as f32) * mu.max(1.0)).ceil().max(initial as f32) as u32;
    if n.is_finite() {
        (n.ceil().max(0.0) as u32).clamp(initial, hi)
    } else {
        hi
    }
}

/// The nearest reflector the eight neighbours' first passes saw, on the pixel's own object: the
/// minimum of their `z_min` over those with hits, 0 where there is none (or the pixel has no
/// samples). Eq. 4.15's `z_min` is "the minimum world-space distance to any reflector"; the
/// minimum of one pixel's 16 cosine-weighted rays over-estimates it (near reflectors at grazing
/// angles are rarely sampled), and with it the filter width (docs/DESIGN-NOTES.md "AO over
/// fourteen scenes"). The neighbours' 8 × 16 rays see more of the hemisphere; the pixel's own are
/// left out so that its width does not depend on the samples its estimate reuses (as
/// `neighbourhood.others` does for the rates). Mirrored in `shaders/indirect_nearest.wgsl`.
pub fn nearest(depth: &[[f32; 4]], position: &[[f32; 4]], w: i32, h: i32, x: i32, y: i32) -> f32 {
    let i = (y * w + x) as usize;
    if !(depth[i][3] > 0.0) {
        return 0.0;
    }
    let hits = same_object_neighbours(position, w, h, x, y).map(|j| depth[j]).filter(|v| v[3] > 0.0 && v[2] > 0.0);
    let z = hits.fold(f32::INFINITY, |z, v| z.min(v[0]));
    if z.is_finite() {
        z
    } else {
        0.0
    }
}

/// What one pixel's formulas need, for one component.
#[derive(Clone, Copy, Debug)]
pub struct ComponentRate {
    pub beta: f32,
    pub rays: u32,
}

/// Formula settings read from a pass's parameter block.
#[derive(Clone, Copy, Debug)]
pub struct Settings {
    pub mu: f32,
    pub alpha: f32,
    /// α of eq. 4.15's pixel bound in the filter width alone (= `alpha` for the thesis's width).
    pub width_alpha: f32,
    pub z_fraction: f32,
    pub extent: f32,
    pub initial: u32,
    pub max: u32,
}

/// β and n for one component at one pixel from its first-pass statistics `depth` (z_min, z_max,
/// hits, traced), the nearest reflector its neighbourhood's first passes saw (`nearest`, 0 = none:
/// see [`nearest`]) and footprint `d`.
/// Pixels whose first-pass rays all missed take `z_min = z_max = extent`, the farthest a reflector
/// can be (see the module docs). The width's `z_min` is `nearest` where there is one, unclamped
/// (eq. 4.15's pixel bound limits the width), else the rates' clamped `z_min` (the thesis's).
pub fn component(r: Receiver, depth: [f32; 4], nearest: f32, d: f32, s: &Settings) -> ComponentRate {
    let (z_min, z_max) = if depth[2] > 0.0 { (depth[0], depth[1]) } else { (s.extent, s.extent) };
    let z_min = clamp_z_min(z_min, s.extent, s.z_fraction);
    let z_max = z_max.max(z_min);
    let omega_h = transfer_bandlimit(r);
    let z_width = if nearest > 0.0 { nearest } else { z_min };
    let beta = filter_beta(filter_bandwidth(omega_h, z_width, d.max(1e-12), s.mu, s.width_alpha));
    let n = samples_per_pixel(gamma(r), omega_h, d, z_min, z_max, s.mu, s.alpha);
    ComponentRate { beta, rays: clamp_rate(n, s.mu, s.initial, s.max) }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol * b.abs().max(1e-6)
    }

    #[test]
    fn bandlimits_eq_4_18_a_3_a_5() {
        assert_eq!(transfer_bandlimit(Receiver::Diffuse), 2.8);
        // Blinn-Phong m = 12 (thesis Fig. 4.8): 3.6 + 1.008 = 4.608; m = 20: 5.28.
        assert!(close(transfer_bandlimit(Receiver::BlinnPhong(12.0)), 4.608, 1e-6));
        assert!(close(transfer_bandlimit(Receiver::BlinnPhong(20.0)), 5.28, 1e-6));
        // Phong m = 12: 4.27 + 1.8 = 6.07; m = 20: 7.27.
        assert!(close(transfer_bandlimit(Receiver::Phong(12.0)), 6.07, 1e-6));
        assert!(close(transfer_bandlimit(Receiver::Phong(20.0)), 7.27, 1e-6));
    }

    #[test]
    fn gamma_by_hand() {
        assert_eq!(gamma(Receiver::Diffuse), 0.4);
        // m = 1: acos(1/√2) = π/4 → 0.5. m = 12: acos(0.5^{1/24}) = acos(0.971532) = 0.239 → 0.15218.
        assert!(close(gamma(Receiver::Phong(1.0)), 0.5, 1e-5));
        assert!(close(gamma(Receiver::Phong(12.0)), 0.152_18, 1e-3), "{}", gamma(Receiver::Phong(12.0)));
        assert!(gamma(Receiver::BlinnPhong(50.0)) < gamma(Receiver::BlinnPhong(12.0)));
    }

    #[test]
    fn bandwidth_and_beta_eq_4_15_4_16_by_hand() {
        // Ω_h = 2.8, z_min = 0.5, d = 0.01, μ = 0.9, α = 0.3: min(5.6, 30) = 5.6 → Ω = 5.04, β = 0.396825.
        let w = filter_bandwidth(2.8, 0.5, 0.01, 0.9, 0.3);
        assert!(close(w, 5.04, 1e-6), "{w}");
        assert!(close(filter_beta(w), 2.0 / 5.04, 1e-6));
        // Pixel limit wins for a very near reflector: z_min = 0.05 → 56 vs α/d = 30 → Ω = 27, β = 0.074074.
        let w = filter_bandwidth(2.8, 0.05, 0.01, 0.9, 0.3);
        assert!(close(w, 27.0, 1e-6), "{w}");
        assert!(close(filter_beta(w), 0.074_074, 1e-4));
        // z_min clamp: 2% of a 5 m scene = 0.1 m.
        assert!(close(clamp_z_min(0.01, 5.0, 0.02), 0.1, 1e-6));
        assert_eq!(clamp_z_min(0.3, 5.0, 0.02), 0.3);
    }

    #[test]
    fn one_pixel_filter_as_mu_grows() {
        // μ = 1e6: β far below a pixel (d = 0.01): the nearest neighbour's weight underflows to 0.
        let b = filter_beta(filter_bandwidth(2.8, 0.5, 0.01, 1e6, 0.3));
        assert!(b < 1e-6, "{b}");
        assert_eq!((-(0.01f32 * 0.01) / (2.0 * b * b)).exp(), 0.0);
        // β ∝ 1/μ.
        let b1 = filter_beta(filter_bandwidth(2.8, 0.5, 0.01, 1.0, 0.3));
        let b2 = filter_beta(filter_bandwidth(2.8, 0.5, 0.01, 2.0, 0.3));
        assert!(close(b1, 2.0 * b2, 1e-6));
    }

    #[test]
    fn samples_eq_4_21_by_hand() {
        // Diffuse: γ = 0.4, Ω_h = 2.8, d = 0.01, z_min = 0.5, z_max = 2, μ = 0.9, α = 0.3:
        // (0.9·2.8·0.01/0.5 + 0.3)² = (0.0504 + 0.3)² = 0.12278; Ω_h² = 7.84; (1 + 0.9·4)² = 21.16.
        // n = 0.4 · 0.12278016 · 7.84 · 21.16 = 8.14766.
        let n = samples_per_pixel(0.4, 2.8, 0.01, 0.5, 2.0, 0.9, 0.3);
        assert!(close(n, 8.147_66, 1e-4), "{n}");
        assert_eq!(clamp_rate(n, 0.9, 16, 100), 16, "clamped up to the 16 initial rays");
        // z_max/z_min = 20: (1 + 18)² = 361 → n = 0.4 · 0.12278 · 7.84 · 361 = 139.0 → clamp at 100.
        let n = samples_per_pixel(0.4, 2.8, 0.01, 0.5, 10.0, 0.9, 0.3);
        assert!(close(n, 139.002, 1e-3), "{n}");
        assert_eq!(clamp_rate(n, 0.9, 16, 100), 100);
        // μ = 2 raises the cap to 200: n = 0.4 (0.112 + 0.3)² 7.84 (1 + 40)² = 0.4·0.169744·7.84·1681 = 894.8 → 200.
        let n = samples_per_pixel(0.4, 2.8, 0.01, 0.5, 10.0, 2.0, 0.3);
        assert!(close(n, 894.81, 1e-3), "{n}");
        assert_eq!(clamp_rate(n, 2.0, 16, 100), 200);
        // In range: z_max/z_min = 6 → (1 + 5.4)² = 40.96 → n = 0.4·0.12278·7.84·40.96 = 15.77 → 16;
        // z_max/z_min = 8 → (8.2)² = 67.24 → 25.89 → 26.
        let n = samples_per_pixel(0.4, 2.8, 0.01, 0.5, 4.0, 0.9, 0.3);
        assert!(close(n, 25.889, 1e-3), "{n}");
        assert_eq!(clamp_rate(n, 0.9, 16, 100), 26);
        // Glossy Phong m = 12: γ = 0.15218, Ω_h = 6.07; same geometry as the first case:
        // (0.9·6.07·0.02 + 0.3)² = (0.10926 + 0.3)² = 0.167494; n = 0.15218·0.167494·36.8449·21.16 = 19.873.
        let g = gamma(Receiver::Phong(12.0));
        let n = samples_per_pixel(g, 6.07, 0.01, 0.5, 2.0, 0.9, 0.3);
        assert!(close(n, 19.873, 2e-3), "{n}");
        assert_eq!(clamp_rate(f32::INFINITY, 0.5, 16, 100), 100);
    }

    #[test]
    fn component_uses_clamped_depths() {
        let s =
            Settings { mu: 0.9, alpha: 0.3, width_alpha: 0.3, z_fraction: 0.02, extent: 5.0, initial: 16, max: 100 };
        // z_min = 0.01 clamps to 0.1: Ω = 0.9·min(28, 30) = 25.2 → β = 0.079365.
        let c = component(Receiver::Diffuse, [0.01, 0.5, 16.0, 16.0], 0.0, 0.01, &s);
        assert!(close(c.beta, 2.0 / 25.2, 1e-5), "{}", c.beta);
        // No hits: z_min = z_max = extent = 5: Ω = 0.9·min(0.56, 30) = 0.504 → β = 3.968;
        // n = 0.4·(0.9·2.8·0.01/5 + 0.3)²·7.84·1.9² = 1.037 → the initial 16.
        let c = component(Receiver::Diffuse, [0.0, 0.0, 0.0, 16.0], 0.0, 0.01, &s);
        assert!(close(c.beta, 2.0 / 0.504, 1e-5), "{}", c.beta);
        assert_eq!(c.rays, 16);
        // ... and still a one-pixel filter as μ → ∞ (consistency): β = 2/(1e6·0.56) ≪ d.
        let c = component(Receiver::Diffuse, [0.0, 0.0, 0.0, 16.0], 0.0, 0.01, &Settings { mu: 1e6, ..s });
        assert!(c.beta < 0.01 / 100.0, "{}", c.beta);
    }

    #[test]
    fn the_width_takes_the_nearest_reflector_and_its_own_pixel_bound() {
        let s =
            Settings { mu: 0.9, alpha: 0.3, width_alpha: 0.3, z_fraction: 0.02, extent: 5.0, initial: 16, max: 100 };
        let depth = [0.5, 2.0, 16.0, 16.0];
        let thesis = component(Receiver::Diffuse, depth, 0.0, 0.01, &s);
        // A neighbourhood reflector at 0.2 (below the statistics' 0.5): Ω = 0.9·min(14, 30) = 12.6.
        let near = component(Receiver::Diffuse, depth, 0.2, 0.01, &s);
        assert!(close(near.beta, 2.0 / 12.6, 1e-5), "{}", near.beta);
        // The rates do not change: eq. 4.21 keeps the statistics' z_min and α.
        assert_eq!(near.rays, thesis.rays);
        // Unclamped: 0.05 < the 2% clamp (0.1) → Ω = 0.9·min(56, 30) = 27 (the pixel bound, α = 0.3);
        // with the width's α = 1: 0.9·min(56, 100) = 50.4.
        let c = component(Receiver::Diffuse, depth, 0.05, 0.01, &s);
        assert!(close(c.beta, 2.0 / 27.0, 1e-5), "{}", c.beta);
        let c = component(Receiver::Diffuse, depth, 0.05, 0.01, &Settings { width_alpha: 1.0, ..s });
        assert!(close(c.beta, 2.0 / 50.4, 1e-5), "{}", c.beta);
        assert_eq!(c.rays, thesis.rays);
        // Consistent: a one-pixel filter as μ → ∞ whatever the reflector.
        let c = component(Receiver::Diffuse, depth, 3.0, 0.01, &Settings { mu: 1e6, width_alpha: 1.0, ..s });
        assert!(c.beta < 0.01 / 100.0, "{}", c.beta);
    }

    #[test]
    fn nearest_is_the_neighbours_minimum_on_the_same_object() {
        // 3×3 on one object; the centre's own near hit (0.1) is left out.
        let mut depth = vec![[1.0, 2.0, 4.0, 16.0]; 9];
        depth[4] = [0.1, 3.0, 9.0, 16.0];
        depth[0] = [0.5, 1.0, 2.0, 16.0];
        depth[8] = [0.05, 0.0, 0.0, 16.0]; // no hits: its minimum is not a distance
        let position = vec![[0.0, 0.0, 0.0, 1.0]; 9];
        assert_eq!(nearest(&depth, &position, 3, 3, 1, 1), 0.5);
        // A corner sees the centre's 0.1 among its neighbours.
        assert_eq!(nearest(&depth, &position, 3, 3, 0, 0), 0.1);
        // Another object's pixels do not count: none left → 0 (the statistics' z_min is used).
        let mut other = position.clone();
        other[4][3] = 2.0;
        assert_eq!(nearest(&depth, &other, 3, 3, 1, 1), 0.0);
        // A pixel without samples (background) gets none.
        depth[4][3] = 0.0;
        assert_eq!(nearest(&depth, &position, 3, 3, 1, 1), 0.0);
    }
}
