//! The risk-based screen-filter width (the Defocus node's `screen_scale_wide`; docs/DESIGN-NOTES.md
//! "A per-pixel width by estimated risk" and "The risk-based width, shipped"): eq. 5.33's filter at two widths, the node's (`narrow`,
//! `screen_scale`) and a wider one (`wide`, `screen_scale_wide`), and per pixel the one whose
//! estimated squared error is the smaller — the greedy choice among filter scales of adaptive
//! denoisers (Rousselle et al.'s), with the composed image's variance from the narrow filter's
//! residual.
//!
//! Three passes, so each backend takes the same decision on the same inputs:
//! 1. `defocus.risk_terms` (per pixel, [`risk_terms`]): what taking `wide` adds to the squared
//!    error, as two non-negative terms — `bias`, the squared bias it adds before its noise is
//!    taken out, and `noise`, that noise plus the variance it removes — from
//!    - the normalised windows' overlaps of the two filters at this pixel ([`Overlaps`]: the
//!      centre's truncated Gaussians `exp(−16 d² Ω²)` of `filter_window`, 1-D sums squared for the
//!      2-D product);
//!    - the variance `σ²` of the composed value `Y` (`value`), from what the narrow filter removes:
//!      `r = Y − narrow` has `E[r²] = σ² (1 − 2N₀ + ΣN²) + b_n²` (`N₀` the filter's weight of the
//!      pixel itself) where neighbours' noise is independent (each pixel draws its own sequences)
//!      and of locally equal variance, and the narrow filter — eq. 5.33's width, which passes the
//!      band — has little bias `b_n`; so `σ² = r² / (1 − 2N₀ + ΣN²)`. Not the spread of a pixel's
//!      paths, nor two halves of them: the paths are stratified over the lens, light and lobe
//!      together, so both overstate the variance of their mean, 20–30× at blurred highlights
//!      (measured: docs/DESIGN-NOTES.md "The risk-based width, shipped");
//!    - the bias: `E[D²] = (b_w − b_n)² + Var D` for `D = wide − narrow`, `Var D = σ² Σ(W − N)²`,
//!      and a smooth image's bias under a Gaussian grows as its σ², `b_w = k b_n` with `k = σ_w²/σ_n²
//!      = (Ω_n/Ω_w)²`, so the squared bias `wide` adds is `b_w² − b_n² = g (D² − Var D)` with
//!      `g = (k+1)/(k−1)`; the variance it removes is `σ² (ΣN² − ΣW²)`. So `bias = g D²` and
//!      `noise = g Var D + σ² (ΣN² − ΣW²)`: their difference is the gain, each term summed without
//!      cancelling (the backends' `exp` differ by a few ulp; a difference near 0 would tell).
//!
//!    Sums over the colour channels. Both 0 where a width is not a filter width, `wide` is not wider
//!    (its width over [`WIDER`] of the narrow one's), the narrow filter is the identity, or a term is
//!    not finite.
//! 2. `defocus.risk_choice` ([`risk_choice`]): both terms summed over a `(2·RISK_BOX + 1)²` box
//!    (clipped to the image): 1 (`wide`) where the bias sum is below the noise sum, else 0. Sums,
//!    not a pixel's own terms: one pixel's `r²` has about one degree of freedom.
//! 3. `defocus.risk_select`: `wide` where the choice is 1, else `narrow`.
//!
//! As μ grows both widths shrink (each is eq. 5.33's, ∝ μ), so the choice converges with them to
//! plain Monte Carlo. WGSL mirrors: `shaders/defocus_risk_{terms,choice,select}.wgsl`.

use rayon::prelude::*;
use wedge_backends::kernels::filter_window::{
    valid_width, window_radius, ScreenRadius, FILTER_SHARPNESS, MAX_RADIUS_LIMIT, REJECT_EXPONENT,
};
use wedge_backends::{BackendError, Kernel, KernelCtx, KernelParams, Reach, Uniforms, WgslSource};

/// Half-width of the box the terms are summed over (7×7).
pub const RISK_BOX: i32 = 3;
/// A wide width that is not at most this share of the narrow one is the same filter: no choice.
pub const WIDER: f32 = 0.95;
/// Taps of a 1-D window half: the centre and up to the largest `max_radius`.
const MAX_TAPS: usize = MAX_RADIUS_LIMIT as usize + 1;

wedge_backends::kernel_bindings! {
    /// What a `defocus.risk_terms` pass binds: the composed value, the two filtered images and their
    /// widths `Ω_x^d`, and the two terms.
    pub struct RiskTermsIo / RiskTermsData {
        read value: [f32; 3], read narrow: [f32; 3], read wide: [f32; 3], read omega: f32, read omega_wide: f32,
        write bias: f32, write noise: f32,
    }
}

wedge_backends::kernel_bindings! {
    /// What a `defocus.risk_choice` pass binds: the two terms and the choice (1 = wide).
    pub struct RiskChoiceIo / RiskChoiceData {
        read bias: f32, read noise: f32, write choice: u32,
    }
}

wedge_backends::kernel_bindings! {
    /// What a `defocus.risk_select` pass binds: the choice, the two filtered images, the result.
    pub struct RiskSelectIo / RiskSelectData {
        read choice: u32, read narrow: [f32; 3], read wide: [f32; 3], write out: [f32; 3],
    }
}

wedge_backends::kernel_params! {
    /// `defocus.risk_terms`'s window cap: the screen filter's `max_radius`.
    pub struct RiskParams {
        max_radius: ScreenRadius,
    }
}

/// Tap `d ≥ 1` of one centre's 1-D truncated Gaussian `exp(−16 d² g²)` (the centre tap is 1): 0
/// outside its window ([`window_radius`] under `cap`) or past the 0.01 rejection, as the filter.
fn gaussian_tap(g: f32, cap: i32, d: i32) -> f32 {
    let e = FILTER_SHARPNESS * (d * d) as f32 * (g * g);
    if d <= window_radius(g, cap) && e <= REJECT_EXPONENT {
        (-e).exp()
    } else {
        0.0
    }
}

/// The 2-D overlaps of the normalised filters `N`, `W` of two (valid) widths at one pixel that the
/// terms need, each summed so that nothing cancels to a few ulp.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Overlaps {
    /// `1 − 2N₀ + ΣN² = (1 − N₀)² + Σ_{j≠0} N_j²`: the share of a pixel's noise the narrow filter's
    /// residual keeps, 0 for the identity.
    pub kept: f32,
    /// `ΣN² − ΣW²`: the share of the noise the wide filter removes beyond the narrow one.
    pub removed: f32,
    /// `Σ(W − N)² = ΣW² − 2ΣNW + ΣN²`: the share of the noise in `wide − narrow`.
    pub apart: f32,
}

impl Overlaps {
    /// The overlaps of widths `g_n`, `g_w` (pixel⁻¹) under window cap `cap`, from the normalised
    /// 1-D taps `n_d`, `w_d` (`d = −R..R`): with `A = Σn²`, `B = Σnw`, `C = Σw²`, the 2-D sums are
    /// `A²`, `B²`, `C²` (each filter a product of two 1-D ones), so `removed = (A − C)(A + C)` and
    /// `apart = (A − B)² + (C − B)² + 2B Σ(n − w)²`, with `A − C`, `A − B`, `C − B` summed tap by
    /// tap; `kept = (1 − n₀²)² + o² + 2n₀²o` with `n₀` the centre tap and `o = Σ_{d≠0} n_d²`.
    pub fn new(g_n: f32, g_w: f32, cap: i32) -> Overlaps {
        let radius = window_radius(g_n, cap).max(window_radius(g_w, cap)).clamp(0, MAX_TAPS as i32 - 1);
        let mut taps = [(0.0f32, 0.0f32); MAX_TAPS];
        let (mut sa, mut sb) = (0.0f32, 0.0f32);
        for d in 1..=radius {
            let t = (gaussian_tap(g_n, cap, d), gaussian_tap(g_w, cap, d));
            taps[d as usize] = t;
            sa += 2.0 * t.0;
            sb += 2.0 * t.1;
        }
        let (n0, w0) = (1.0 / (1.0 + sa), 1.0 / (1.0 + sb));
        // n₀ − w₀ = (sb − sa) n₀ w₀, not a difference of two numbers near 1.
        let d0 = (sb - sa) * n0 * w0;
        let mut s = Sums {
            a: n0 * n0,
            b: n0 * w0,
            c: w0 * w0,
            a_minus_c: d0 * (n0 + w0),
            a_minus_b: n0 * d0,
            c_minus_b: -w0 * d0,
            apart_1d: d0 * d0,
            off: 0.0,
        };
        for &(x, y) in &taps[1..=radius as usize] {
            s.add(x * n0, y * w0);
        }
        let rest = sa * (2.0 + sa) * (n0 * n0);
        Overlaps {
            kept: rest * rest + s.off * s.off + 2.0 * (n0 * n0) * s.off,
            removed: s.a_minus_c * (s.a + s.c),
            apart: s.a_minus_b * s.a_minus_b + s.c_minus_b * s.c_minus_b + 2.0 * s.b * s.apart_1d,
        }
    }
}

/// The 1-D sums of [`Overlaps::new`] (centre tap first, each off-centre tap twice).
struct Sums {
    a: f32,
    b: f32,
    c: f32,
    a_minus_c: f32,
    a_minus_b: f32,
    c_minus_b: f32,
    apart_1d: f32,
    off: f32,
}

impl Sums {
    /// Add the normalised taps `n`, `w` at `±d`.
    fn add(&mut self, n: f32, w: f32) {
        self.a += 2.0 * n * n;
        self.b += 2.0 * n * w;
        self.c += 2.0 * w * w;
        self.a_minus_c += 2.0 * (n - w) * (n + w);
        self.a_minus_b += 2.0 * n * (n - w);
        self.c_minus_b += 2.0 * w * (w - n);
        self.apart_1d += 2.0 * (n - w) * (n - w);
        self.off += 2.0 * n * n;
    }
}

/// Per-pixel inputs of [`risk_terms`].
#[derive(Clone, Copy, Debug)]
pub struct RiskInputs {
    pub value: [f32; 3],
    pub narrow: [f32; 3],
    pub wide: [f32; 3],
    pub omega: f32,
    pub omega_wide: f32,
}

fn dist2(a: [f32; 3], b: [f32; 3]) -> f32 {
    let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
}

/// Pass 1 of the module doc at one pixel: `(bias, noise)`, the gain of `wide` being their
/// difference; `(0, 0)` where there is no estimate.
pub fn risk_terms(p: &RiskInputs, cap: i32) -> (f32, f32) {
    let (n, w) = (p.omega, p.omega_wide);
    if !(valid_width(n) && valid_width(w) && w <= WIDER * n) {
        return (0.0, 0.0);
    }
    let o = Overlaps::new(n, w, cap);
    // A narrow filter that is the identity keeps all of the noise, and its residual says nothing.
    if !(o.kept > 0.0) {
        return (0.0, 0.0);
    }
    let variance = dist2(p.value, p.narrow) / o.kept;
    // (k + 1)/(k − 1) for k = (Ω_n/Ω_w)².
    let growth = (n * n + w * w) / ((n - w) * (n + w));
    let bias = growth * dist2(p.wide, p.narrow);
    let noise = growth * variance * o.apart + variance * o.removed;
    if bias.is_finite() && noise.is_finite() {
        (bias, noise)
    } else {
        (0.0, 0.0)
    }
}

/// Pass 2 of the module doc at pixel `(x, y)` of a `width × height` image of terms: each row of the
/// box summed left to right, then the rows' sums top to bottom — the order in which the CPU pass
/// ([`risk_choices`]) shares a row's sum among the 7 pixels above and below it, and the WGSL sums.
pub fn risk_choice(x: i32, y: i32, width: i32, height: i32, bias: &[f32], noise: &[f32]) -> u32 {
    let (mut b, mut n) = (0.0f32, 0.0f32);
    for ny in box_range(y, height) {
        b += row_sum(bias, x, ny, width);
        n += row_sum(noise, x, ny, width);
    }
    u32::from(b < n)
}

/// Pass 2 on every pixel: the box's row sums once per pixel, then per pixel the sum of its box's
/// row sums — [`risk_choice`] bit for bit, 14 additions a term instead of 49.
pub fn risk_choices(width: i32, height: i32, bias: &[f32], noise: &[f32]) -> Vec<u32> {
    let pixels = || (0..width * height).into_par_iter().map(|i| (i % width, i / width));
    let rows: Vec<(f32, f32)> =
        pixels().map(|(x, y)| (row_sum(bias, x, y, width), row_sum(noise, x, y, width))).collect();
    pixels()
        .map(|(x, y)| {
            let (mut b, mut n) = (0.0f32, 0.0f32);
            for ny in box_range(y, height) {
                let (rb, rn) = rows[(ny * width + x) as usize];
                b += rb;
                n += rn;
            }
            u32::from(b < n)
        })
        .collect()
}

/// The box's rows (or columns) around `at`, clipped to `0..extent`.
fn box_range(at: i32, extent: i32) -> std::ops::RangeInclusive<i32> {
    (at - RISK_BOX).max(0)..=(at + RISK_BOX).min(extent - 1)
}

/// Row `y`'s terms in the box around column `x`, left to right.
fn row_sum(terms: &[f32], x: i32, y: i32, width: i32) -> f32 {
    box_range(x, width).map(|nx| terms[(y * width + nx) as usize]).fold(0.0, |s, t| s + t)
}

/// `defocus.risk_terms`: pass 1 of the module doc.
pub struct RiskTerms;

impl Kernel for RiskTerms {
    wedge_backends::kernel_signature!(
        name: "defocus.risk_terms", class: Bandwidth, bindings: RiskTermsIo, params: [RiskParams]
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/defocus_risk_terms.wgsl"), |ctx| {
                Ok(RiskParams::read(ctx)?.uniforms())
            })
            .with_include("filter_window.wgsl", include_str!("../../../../shaders/filter_window.wgsl"))
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let RiskTermsData { value, narrow, wide, omega, omega_wide, bias, noise } = RiskTermsIo::read(ctx)?;
        let cap = RiskParams::read(ctx)?.max_radius.get();
        let terms = ctx.map_pixels(false, |x, y| {
            let i = (y * ctx.width + x) as usize;
            let p = RiskInputs {
                value: value[i],
                narrow: narrow[i],
                wide: wide[i],
                omega: omega[i],
                omega_wide: omega_wide[i],
            };
            risk_terms(&p, cap)
        });
        bias.put(ctx, terms.iter().map(|t| t.0).collect())?;
        noise.put(ctx, terms.iter().map(|t| t.1).collect())
    }
}

/// `defocus.risk_choice`: pass 2 of the module doc.
pub struct RiskChoice;

impl Kernel for RiskChoice {
    wedge_backends::kernel_signature!(name: "defocus.risk_choice", class: Bandwidth, bindings: RiskChoiceIo);
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/defocus_risk_choice.wgsl"), |_| Ok(Uniforms::new()))
                .with_reach(|_| Ok(Reach::Rows(RISK_BOX as u32))),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let RiskChoiceData { bias, noise, choice } = RiskChoiceIo::read(ctx)?;
        let chosen = risk_choices(ctx.width as i32, ctx.height as i32, bias, noise);
        choice.put(ctx, chosen)
    }
}

/// `defocus.risk_select`: pass 3 of the module doc.
pub struct RiskSelect;

impl Kernel for RiskSelect {
    wedge_backends::kernel_signature!(name: "defocus.risk_select", class: Filter, bindings: RiskSelectIo);
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/defocus_risk_select.wgsl"), |_| Ok(Uniforms::new()))
                .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let RiskSelectData { choice, narrow, wide, out } = RiskSelectIo::read(ctx)?;
        let picked = ctx.map_pixels(false, |x, y| {
            let i = (y * ctx.width + x) as usize;
            if choice[i] != 0 {
                wide[i]
            } else {
                narrow[i]
            }
        });
        out.put(ctx, picked)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 2-D sums by brute force over the product filters: (kept, ΣN², ΣNW, ΣW²).
    fn brute(g_n: f32, g_w: f32, cap: i32) -> (f32, f32, f32, f32) {
        let taps = |g: f32| -> Vec<f32> {
            let v: Vec<f32> = (-cap..=cap).map(|d| if d == 0 { 1.0 } else { gaussian_tap(g, cap, d.abs()) }).collect();
            let s: f32 = v.iter().sum();
            v.iter().map(|x| x / s).collect()
        };
        let (n, w) = (taps(g_n), taps(g_w));
        let (mut nn, mut nw, mut ww) = (0.0f32, 0.0f32, 0.0f32);
        for (i, j) in (0..n.len()).flat_map(|i| (0..n.len()).map(move |j| (i, j))) {
            let (a, b) = (n[i] * n[j], w[i] * w[j]);
            nn += a * a;
            nw += a * b;
            ww += b * b;
        }
        let centre = n[cap as usize] * n[cap as usize];
        (1.0 - 2.0 * centre + nn, nn, nw, ww)
    }

    #[test]
    fn overlaps_are_the_product_filters_sums() {
        for (g_n, g_w) in [(0.2, 0.12), (0.05, 0.03), (0.5, 0.3), (0.2, 0.19), (2.0, 0.5)] {
            let o = Overlaps::new(g_n, g_w, 16);
            let (kept, nn, nw, ww) = brute(g_n, g_w, 16);
            let close = |a: f32, b: f32| (a - b).abs() < 1e-5 * (1.0 + b.abs());
            assert!(close(o.kept, kept) && close(o.removed, nn - ww) && close(o.apart, ww - 2.0 * nw + nn), "{o:?}");
            assert!(o.removed >= 0.0 && o.apart >= 0.0);
        }
        // An identity narrow filter (Ω past the 0.01 rejection at 1 px): its residual keeps nothing.
        assert_eq!(Overlaps::new(2.0, 1.9, 16).kept, 0.0);
        // Continuous limit of ΣN² − ΣW² for σ = 0.177/Ω px: (1 / (2 √π σ))² each.
        let s = |g: f32| (1.0 / (2.0 * std::f32::consts::PI.sqrt() * (0.176_777 / g))).powi(2);
        assert!((Overlaps::new(0.05, 0.03, 16).removed / (s(0.05) - s(0.03)) - 1.0).abs() < 0.03);
    }

    fn inputs(value: f32, narrow: f32, wide: f32) -> RiskInputs {
        RiskInputs { value: [value; 3], narrow: [narrow; 3], wide: [wide; 3], omega: 0.2, omega_wide: 0.12 }
    }

    fn gain(p: &RiskInputs) -> f32 {
        let (b, n) = risk_terms(p, 16);
        b - n
    }

    #[test]
    fn noise_takes_the_wide_filter_and_a_difference_beyond_it_the_narrow_one() {
        // Noisy (the narrow filter removed much) and both filters agree: the wide one only removes
        // variance.
        assert!(gain(&inputs(1.0, 0.8, 0.8)) < 0.0);
        // Noiseless and the filters differ: only bias is added.
        assert!(gain(&inputs(0.8, 0.8, 0.5)) > 0.0);
        // No estimate: a pass-through width, a "wide" that is not wider, a value that is not finite.
        for p in [
            RiskInputs { omega: 0.0, ..inputs(1.0, 0.8, 0.8) },
            RiskInputs { omega_wide: 0.195, ..inputs(1.0, 0.8, 0.8) },
            inputs(f32::NAN, 0.8, 0.8),
        ] {
            assert_eq!(risk_terms(&p, 16), (0.0, 0.0), "{p:?}");
        }
    }

    /// The pass shares each row's sum and is the per-pixel box bit for bit, near ties included.
    #[test]
    fn the_pass_is_the_per_pixel_box() {
        let (w, h) = (23, 17);
        let mut state = 5u64;
        let mut unit = || {
            state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let bias: Vec<f32> = (0..w * h).map(|_| unit() * 1e-3).collect();
        let noise: Vec<f32> = bias.iter().map(|b| b * (0.999 + 0.002 * unit())).collect();
        let pass = risk_choices(w, h, &bias, &noise);
        for y in 0..h {
            for x in 0..w {
                assert_eq!(pass[(y * w + x) as usize], risk_choice(x, y, w, h, &bias, &noise), "({x}, {y})");
            }
        }
        assert!(pass.contains(&0) && pass.contains(&1));
    }

    #[test]
    fn the_choice_sums_its_box() {
        let (w, h) = (9, 9);
        let (mut bias, noise) = (vec![0.1f32; 81], vec![0.0f32; 81]);
        bias[40] = 0.0;
        let mut noise_here = noise.clone();
        noise_here[40] = 10.0;
        assert_eq!(risk_choice(4, 4, w, h, &bias, &noise_here), 1);
        // Beyond the box's reach the one pixel does not count.
        assert_eq!(risk_choice(0, 0, w, h, &bias, &noise_here), 0);
        assert_eq!(risk_choice(1, 1, w, h, &bias, &noise_here), 1);
        assert_eq!(risk_choice(4, 4, w, h, &bias, &noise), 0);
    }
}
