//! The pure formulas of pixel filtering (seed 002 Ch. 3), unit-tested here; WGSL mirror:
//! `shaders/pixel_filter_formulas.wgsl`.

use glam::Vec3;

pub use wedge_backends::kernels::luminance;

/// `variance.w` of a pixel the filter wrote. The accumulation's `M2` (≥ 0) never equals it, so a
/// reference, whose filters are bypassed to the accumulation, blends with `s = 1`, as does a frame
/// before the first filter pass (history zeros).
pub const FILTERED: f32 = -1.0;

/// Depth of a range-buffer sample whose ray left the scene: far from every surface, yet its square
/// over `2σ_d²` stays finite in f32 (so `exp` gives 0 on both backends, not `exp(-inf)`).
pub const MISS_DEPTH: f32 = 1e9;

/// One pixel's running statistics: the means of `L_lv` and `L_u`, the number of paths `n`, and
/// `M2 = Σ (Y_k − Ȳ)²` of the luminance of `L_u` (Welford; the per-path variance is `M2 / (n − 1)`,
/// the variance of the mean `M2 / (n (n − 1))`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Stats {
    pub lv: Vec3,
    pub u: Vec3,
    pub n: f32,
    pub m2: f32,
}

impl Stats {
    /// One path's sample.
    pub fn one(lv: Vec3, u: Vec3) -> Stats {
        Stats { lv, u, n: 1.0, m2: 0.0 }
    }
    /// From the buffers `lv` = (mean, n) and `u` = (mean, M2).
    pub fn from_buffers(lv: [f32; 4], u: [f32; 4]) -> Stats {
        Stats { lv: Vec3::new(lv[0], lv[1], lv[2]), u: Vec3::new(u[0], u[1], u[2]), n: lv[3], m2: u[3] }
    }
    pub fn lv_buffer(&self) -> [f32; 4] {
        [self.lv.x, self.lv.y, self.lv.z, self.n]
    }
    pub fn u_buffer(&self) -> [f32; 4] {
        [self.u.x, self.u.y, self.u.z, self.m2]
    }
    /// Two disjoint sets of paths as one (Chan, Golub and LeVeque's pairwise update; with `b` one
    /// path it is Welford's): `mean = mean_a + (mean_b − mean_a)·n_b/n`, `M2 = M2_a + M2_b +
    /// δ²·n_a·n_b/n`, δ the difference of the luminance means. Numerically stable: no sum of squares.
    /// The operation order is the WGSL's (`pf_combine`).
    pub fn combine(a: Stats, b: Stats) -> Stats {
        if !(b.n > 0.0) {
            return a;
        }
        if !(a.n > 0.0) {
            return b;
        }
        let n = a.n + b.n;
        let lv = a.lv + (b.lv - a.lv) * b.n / n;
        let u = a.u + (b.u - a.u) * b.n / n;
        let dy = luminance(b.u) - luminance(a.u);
        let m2 = a.m2 + b.m2 + dy * dy * a.n * b.n / n;
        Stats { lv, u, n, m2: m2.max(0.0) }
    }
    /// The unbiased per-path variance of `Y(L_u)`, `M2/(n − 1)`; `None` below two paths.
    pub fn sample_variance(&self) -> Option<f32> {
        (self.n >= 2.0).then(|| self.m2 / (self.n - 1.0))
    }
}

/// The blend factor `s` of eqs. 3.12–3.13 for perceived variances `u` (unfiltered) and `f`
/// (filtered) and threshold `t` (all ≥ 0; `u` or `f` may be `+∞` where the background radiance is 0):
/// - case 2, `u ≤ t`: 1 (the unfiltered buffer already meets the threshold; `u = f = 0` lands here);
/// - case 1, `tu + tf − uf < 0`: 0 (not even the filtered buffer meets it; `t = 0, u > 0, f > 0`);
/// - case 3: `s' = (f + √(tu + tf − uf)) / (u + f)`, the largest `s` with `s²u + (1−s)²f = t`
///   (eq. 3.9 with the covariance of eq. 3.8 set to zero, as the thesis does).
///
/// `u = +∞` (a black background, eq. 3.10, under noise) gives 0, the limit of `s'`.
#[allow(clippy::manual_clamp)]
pub fn blend_factor(u: f32, f: f32, t: f32) -> f32 {
    if !(u > t) {
        return 1.0;
    }
    if u == f32::INFINITY {
        return 0.0;
    }
    if f == f32::INFINITY {
        return 0.0;
    }
    let d = t * u + t * f - u * f;
    if d < 0.0 {
        return 0.0;
    }
    let s = (f + d.sqrt()) / (u + f);
    // max/min rather than clamp: NaN would become 0, as WGSL's rmax/rmin make it.
    s.max(0.0).min(1.0)
}

/// The spike clamp of eq. 3.18: `L_u` clamped per channel to `[L_f / c, c·L_f]`.
pub fn spike_clamp(lu: Vec3, lf: Vec3, c: f32) -> Vec3 {
    let lo = lf / c;
    let hi = lf * c;
    Vec3::new(lu.x.max(lo.x).min(hi.x), lu.y.max(lo.y).min(hi.y), lu.z.max(lo.z).min(hi.z))
}

/// Whether frame `frame` (0, 1, …: the frame has `frame + 1` paths per pixel) runs the filter
/// (thesis Sec. 3.3.3: "only every 2^i-th frame; usually starting with frame 4"): frames with
/// `n = first·2^i` paths, and — `first_frame` — the first frame of a run, so a single image and
/// the first frames of a progressive run are filtered too (a reading, see DESIGN-NOTES).
pub fn is_filter_frame(frame: u32, first: u32, first_frame: bool) -> bool {
    if frame == 0 && first_frame {
        return true;
    }
    let n = u64::from(frame) + 1;
    let first = u64::from(first.max(1));
    n % first == 0 && (n / first).is_power_of_two()
}

/// How many of frames `0..=frame` run the filter ([`is_filter_frame`]): the range buffer's pass
/// index (its running mean weighs each pass's samples equally).
pub fn filter_passes_through(frame: u32, first: u32, first_frame: bool) -> u32 {
    let mut count = u32::from(first_frame);
    let n = u64::from(frame) + 1;
    let mut k = u64::from(first.max(1));
    while k <= n {
        if !(k == 1 && first_frame) {
            count += 1;
        }
        k *= 2;
    }
    count
}

/// The spatial standard deviation of iteration `k` (1 ..= `iterations`) of the iterated separable
/// filter, eq. 3.14 (Gastal and Oliveira): `σ_k = σ √3 · 2^(N−k) / √(4^N − 1)`, so `Σ σ_k² = σ²`.
pub fn iteration_sigma(sigma: f32, k: u32, iterations: u32) -> f32 {
    let n = iterations.clamp(1, 16) as i32;
    let k = (k as i32).clamp(1, n);
    sigma * 3f32.sqrt() * 2f32.powi(n - k) / (4f32.powi(n) - 1.0).sqrt()
}

/// The adaptive spatial width of Sec. 3.6.3 at a pixel with per-path variance `sigma2` of `Y(L_u)`
/// (the filtered one of the last filter pass), `n` paths, background luminance `lb` (eq. 3.10) and
/// threshold `t`:
/// - eq. 3.15: the box half-extent `e = ½√(u/f) − ½` that brings the unfiltered perceived variance
///   `u = σ²/(n L_b²)` down to the target `f = t` (reading: the filtered buffer alone meets the
///   threshold), mapped to `σ = 1.5 e`;
/// - eqs. 3.16–3.17: clamped to `[σ̄(n)/c, c σ̄(n)]` around the guide `σ̄(n) = σ_s / √n`, and (reading)
///   never wider than `σ_s`, the user's maximum smoothing.
pub fn adaptive_sigma(sigma2: f32, n: f32, lb: f32, t: f32, sigma_s: f32, c: f32) -> f32 {
    let guide = sigma_s / n.max(1.0).sqrt();
    let ratio = if !(sigma2 > 0.0) {
        0.0
    } else {
        let target = n.max(1.0) * t * lb * lb;
        if target > 0.0 {
            sigma2 / target
        } else {
            f32::INFINITY
        }
    };
    let e = 0.5 * ratio.sqrt() - 0.5;
    let sigma = 1.5 * e;
    sigma.max(guide / c).min(guide * c).min(sigma_s)
}

/// The range buffer's colour of one surface (Sec. 3.3.3): its hemispherical reflectivity `ρ = k_d +
/// k_s` lit by unoccluded ambient light and by a head light at the eye (`cos` = |n·ω_eye|). Reading:
/// the two lights weigh ½ each, so a white surface facing the camera is 1.
#[inline]
pub fn range_colour(kd: Vec3, ks: Vec3, cos: f32) -> Vec3 {
    (kd + ks) * (0.5 + 0.5 * cos)
}

/// The cross-bilateral weight `a_i` of eq. 3.6 as one exponential: spatial distance² `ds2` (pixels²),
/// colour distance² `dc2` and depth difference `dd`, with `inv_*` = 1/(2σ²) of each kernel. Weights
/// below `e^-80` (1.8e-35) are 0 — on both backends alike (a GPU may flush what the CPU keeps as a
/// denormal), and most taps of a brute-force window on another surface skip the `exp`.
#[inline]
pub fn bilateral_weight(ds2: f32, dc2: f32, dd: f32, inv_s: f32, inv_c: f32, inv_d: f32) -> f32 {
    let x = ds2 * inv_s + dc2 * inv_c + dd * dd * inv_d;
    if !(x < WEIGHT_CUTOFF) {
        return 0.0;
    }
    (-x).exp()
}

/// Exponent beyond which a bilateral weight is 0 ([`bilateral_weight`]).
pub const WEIGHT_CUTOFF: f32 = 80.0;

/// `1 / (2σ²)`, 0 for σ = ∞ or a non-positive σ (that kernel off).
#[inline]
pub fn inv_two_sigma2(sigma: f32) -> f32 {
    if sigma > 0.0 && sigma.is_finite() {
        1.0 / (2.0 * sigma * sigma)
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wedge_backends::rng::PixelRng;

    #[test]
    fn blend_case_three_meets_the_threshold_exactly() {
        // s'²u + (1 − s')²f = t (eq. 3.9 without covariance) wherever case 3 applies.
        for &(u, f, t) in
            &[(1.0f32, 0.1, 0.5), (4.0, 0.05, 0.2), (0.3, 0.01, 0.02), (100.0, 0.001, 0.01), (2.0, 1.0, 1.5)]
        {
            let s = blend_factor(u, f, t);
            assert!(s > 0.0 && s < 1.0, "case 3 at {u} {f} {t}: {s}");
            let v = s * s * u + (1.0 - s) * (1.0 - s) * f;
            assert!((v - t).abs() <= 1e-5 * t.max(1.0), "{u} {f} {t}: s {s} gives {v}");
        }
    }

    #[test]
    fn blend_edge_cases_of_eq_3_13() {
        assert_eq!(blend_factor(0.0, 0.0, 0.01), 1.0, "u = f = 0 → case 2");
        assert_eq!(blend_factor(0.0, 0.0, 0.0), 1.0, "u = f = 0, t = 0 → case 2");
        assert_eq!(blend_factor(0.5, 0.1, 0.0), 0.0, "t = 0, u > 0 → case 1");
        assert_eq!(blend_factor(0.5, 0.0, 0.0), 0.0, "t = 0, u > 0, f = 0 → 0");
        // tu + tf − uf < 0: f above t (and u too).
        assert_eq!(blend_factor(2.0, 1.0, 0.5), 0.0);
        assert_eq!(blend_factor(0.01, 5.0, 0.01), 1.0, "u ≤ t → 1 whatever f");
        assert_eq!(blend_factor(0.009, 5.0, 0.01), 1.0);
        assert_eq!(blend_factor(f32::INFINITY, 0.1, 0.01), 0.0, "black background under noise");
        // Continuity at u = t (Appendix 3.A, eq. 3.21): s' → 1.
        assert!((blend_factor(0.01 * (1.0 + 1e-6), 0.001, 0.01) - 1.0).abs() < 1e-4);
        // Point (b), u = ft/(f − t): s' = f/(u + f), then case 1.
        let (f, t) = (0.5f32, 0.25f32);
        let ub = f * t / (f - t);
        assert!((blend_factor(ub * (1.0 - 1e-4), f, t) - f / (ub + f)).abs() < 1e-2);
        assert_eq!(blend_factor(ub * 1.01, f, t), 0.0);
    }

    #[test]
    fn blend_factor_falls_monotonically_with_u_between_a_and_b() {
        // Appendix 3.A: strictly decreasing for t < u < ft/(f − t), with f = r u (eq. 3.23).
        let (t, r) = (1.0f32, 0.1f32);
        let mut last = 1.0f32;
        for k in 1..200 {
            let u = t + k as f32 * 0.04;
            let s = blend_factor(u, r * u, t);
            if s == 0.0 {
                break;
            }
            assert!(s < last, "u {u}: {s} ≥ {last}");
            last = s;
        }
    }

    #[test]
    fn filter_schedule_is_first_frame_and_first_times_powers_of_two() {
        let frames: Vec<u32> = (0..70).filter(|&f| is_filter_frame(f, 4, true)).collect();
        assert_eq!(frames, vec![0, 3, 7, 15, 31, 63], "n = 1, 4, 8, 16, 32, 64");
        let thesis: Vec<u32> = (0..70).filter(|&f| is_filter_frame(f, 4, false)).collect();
        assert_eq!(thesis, vec![3, 7, 15, 31, 63]);
        let every: Vec<u32> = (0..9).filter(|&f| is_filter_frame(f, 1, true)).collect();
        assert_eq!(every, vec![0, 1, 3, 7]);
        for first in [1, 2, 4, 8] {
            for ff in [false, true] {
                let mut count = 0;
                for f in 0..300 {
                    count += is_filter_frame(f, first, ff) as u32;
                    assert_eq!(
                        filter_passes_through(f, first, ff),
                        count,
                        "first {first}, first frame {ff}, frame {f}"
                    );
                }
            }
        }
        // No overflow at the last frame index: n = 2^32 paths.
        assert!(is_filter_frame(u32::MAX, 1 << 31, false));
        assert!(!is_filter_frame(u32::MAX - 1, 1 << 31, false));
        assert_eq!(filter_passes_through(u32::MAX, 4, true), 32);
    }

    #[test]
    fn iterated_sigmas_add_up_to_sigma() {
        for n in 1..6 {
            let total: f32 = (1..=n).map(|k| iteration_sigma(8.0, k, n).powi(2)).sum();
            assert!((total - 64.0).abs() < 1e-3, "N = {n}: {total}");
        }
        // Three iterations (the thesis's default): 0.873σ, 0.436σ, 0.218σ.
        assert!((iteration_sigma(1.0, 1, 3) - 0.8729).abs() < 1e-3);
        assert!((iteration_sigma(1.0, 3, 3) - 0.2182).abs() < 1e-3);
    }

    #[test]
    fn adaptive_width_follows_eqs_3_15_to_3_17() {
        // A variance whose box extent is exactly e: u/f = (2e + 1)², σ = 1.5e, inside the interval.
        let (n, lb, t) = (16.0f32, 1.0f32, 0.01f32);
        let e = 1.5f32;
        let sigma2 = (2.0 * e + 1.0).powi(2) * n * t * lb * lb;
        let s = adaptive_sigma(sigma2, n, lb, t, 8.0, 4.0);
        assert!((s - 1.5 * e).abs() < 1e-4, "{s}");
        // Clamped to [σ̄/c, cσ̄] with σ̄(16) = 2, and never above σ_s.
        assert_eq!(adaptive_sigma(0.0, 16.0, 1.0, 0.01, 8.0, 4.0), 0.5);
        assert_eq!(adaptive_sigma(1e9, 16.0, 1.0, 0.01, 8.0, 4.0), 8.0);
        assert_eq!(adaptive_sigma(1e9, 1.0, 1.0, 0.01, 8.0, 4.0), 8.0);
        assert_eq!(adaptive_sigma(1.0, 4.0, 0.0, 0.01, 8.0, 2.0), 8.0, "black background: widest");
    }

    #[test]
    fn spike_clamp_keeps_within_factor_c_of_the_filtered_value() {
        let lf = Vec3::new(1.0, 0.5, 0.0);
        let out = spike_clamp(Vec3::new(10.0, 0.1, 3.0), lf, 2.0);
        assert_eq!(out, Vec3::new(2.0, 0.25, 0.0));
        assert_eq!(spike_clamp(Vec3::new(1.5, 0.3, 0.0), lf, 2.0), Vec3::new(1.5, 0.3, 0.0));
    }

    #[test]
    fn combine_is_welford_and_halves_combine() {
        // Means and M2 against a two-pass f64 computation.
        let xs: Vec<f32> = (0..1000).map(|k| ((k * 7919) % 1013) as f32 / 1013.0 * 3.0 + 1e3).collect();
        let mut st = Stats::default();
        for &x in &xs {
            st = Stats::combine(st, Stats::one(Vec3::splat(x), Vec3::splat(x)));
        }
        let mean = xs.iter().map(|&x| x as f64).sum::<f64>() / xs.len() as f64;
        let m2: f64 = xs.iter().map(|&x| (x as f64 - mean).powi(2)).sum();
        assert!((st.lv.x as f64 - mean).abs() < 1e-3 * 1e-3 * mean, "{} vs {mean}", st.lv.x);
        // Luminance weights sum to 1 up to f32 rounding: Y(x, x, x) = x (1 ± 1e-7).
        assert!(((st.m2 as f64) - m2).abs() < 2e-3 * m2, "M2 {} vs {m2} (offset 1000: no cancellation)", st.m2);
        // Combining two halves equals one pass over all, to rounding.
        let (a, b) = xs.split_at(400);
        let fold = |v: &[f32]| {
            v.iter().fold(Stats::default(), |s, &x| Stats::combine(s, Stats::one(Vec3::ZERO, Vec3::splat(x))))
        };
        let both = Stats::combine(fold(a), fold(b));
        assert_eq!(both.n, 1000.0);
        assert!((both.m2 - st.m2).abs() < 1e-3 * st.m2, "{} vs {}", both.m2, st.m2);
    }

    /// On a synthetic input (uniform samples, variance 1/12), `M2/(n − 1)` after n paths is an
    /// unbiased estimate: its mean over 80 000 pixels is 1/12 within 1% (about 4 standard errors).
    #[test]
    fn variance_estimate_is_unbiased_on_a_synthetic_input() {
        for n in [2u32, 4, 16] {
            let mut total = 0.0f64;
            let pixels = 80_000u32;
            for p in 0..pixels {
                let rng = PixelRng::new(7, p, 11);
                let mut st = Stats::default();
                for k in 0..n {
                    st = Stats::combine(st, Stats::one(Vec3::ZERO, Vec3::splat(rng.uniform(k, 0))));
                }
                total += st.sample_variance().unwrap() as f64;
            }
            let mean = total / pixels as f64;
            assert!((mean * 12.0 - 1.0).abs() < 0.01, "n = {n}: mean sample variance {mean} vs {}", 1.0 / 12.0);
        }
    }
}
