//! `defocus.layers`: a blurred near layer composited over the rest (docs/DESIGN-NOTES.md "The near layer").
//!
//! Where a blurred foreground lies over a sharp background, eq. 5.33's width comes from the pixel's
//! least circle of confusion (the sharp background's, ≈ 0), so the filter stays at a pixel and the
//! lens's variance — which lens samples the foreground blocks — stays too. The sampler splits a
//! pixel's paths by depth (`paths.resolve_near`'s `near`, `near_coc`): those in front of the focal
//! plane and blurred over more than `NEAR_LAYER_COC` pixels form the near layer, `F = Σ_near w L / Σ w`
//! (premultiplied by its coverage `α = Σ_near w / Σ w`), `r_near` their least circle of confusion.
//! `F` and `α` are the foreground's blurred image and coverage, band-limited by the foreground's own
//! circle of confusion, so they take eq. 5.33's Gaussian at `Ω = μ Ω_u / r_near` (and its rejection
//! of a neighbour outside whose own near filter the pixel lies: `filter_window::pair_weight`). The
//! rest is `(1 − α) T`: its coverage is the foreground's (smooth: `1 − α̃`), its radiance
//! `T = (I − F) / (1 − α)` the pixel's own far paths (a sharp background is one point for every
//! lens sample that sees it). So a pixel
//! whose paths are partly near — and whose near paths are blurred over [`LAYER_SEPARATION`] times
//! its least circle of confusion, so the two layers are apart in depth — outputs `F̃ + (1 − α̃) T`.
//! Every other pixel keeps eq. 5.33's value; a neighbour with only near paths lends the filter its
//! composed radiance `I` (factored where eq. 5.30 allowed), not its raw `F`.
//!
//! Not in the thesis (Ch. 5 filters one layer per pixel); the option `layers` of the Defocus node,
//! off by default. As μ grows the near filter shrinks to the pixel, `F̃ → F`, `α̃ → α`, and the
//! composite is `F + (I − F) = I`: the consistent mode's limit is unchanged.

use wedge_backends::kernels::filter_window::{gather_taps, window_radius, Axis, CentreWeights, ScreenRadius};
use wedge_backends::{BackendError, Kernel, KernelCtx, KernelParams, WgslSource};

use crate::defocus::formulas::OMEGA_U_MAX;

wedge_backends::kernel_bindings! {
    /// What a `defocus.layers` pass binds: the composed radiance `I` before eq. 5.33 and after it,
    /// the near layer (`F` rgb, `α`) and its least circle of confusion (x), the pixel's range of
    /// circles of confusion (`paths.resolve`'s `defocus`: x = `r_min`), and the output.
    pub struct LayersIo / LayersData {
        read composed: [f32; 3], read filtered: [f32; 3], read near: [f32; 4], read near_coc: [f32; 4],
        read lens: [f32; 4], write out: [f32; 3],
    }
}

wedge_backends::kernel_params! {
    /// μ of eq. 5.29 (the factoring node's) and the window's cap (its `max_radius`).
    pub struct LayersParams {
        mu: f32,
        max_radius: ScreenRadius,
    }
}

/// Coverage from which a pixel counts as wholly near (no far path of its own).
const FULL: f32 = 0.9999;
/// A pixel composites its layers only where they are apart: its near paths blurred over this many
/// times the least circle of confusion among all its paths (a foreground over a sharp background,
/// not one surface whose blur crosses `NEAR_LAYER_COC` within the pixel, as a receding floor's does).
pub const LAYER_SEPARATION: f32 = 4.0;

/// The near layer's width `Ω = μ Ω_u / r_near` (eq. 5.7's lens term at its circle of confusion).
fn near_width(mu: f32, r_near: f32) -> f32 {
    mu * OMEGA_U_MAX / r_near
}

/// The buffers a layers pass reads ([`LayersIo`]), by pixel index.
struct LayerInputs<'a> {
    composed: &'a [[f32; 3]],
    filtered: &'a [[f32; 3]],
    near: &'a [[f32; 4]],
    near_coc: &'a [[f32; 4]],
    lens: &'a [[f32; 4]],
}

/// What pixel `j` lends a neighbour's near filter, found once per pixel rather than once per tap of
/// every window that holds it: its near width² for the rejection — 0 where it has no near path (its
/// coverage 0, a sample of the layer's edge, rejects nobody) — and its `(F, α)`, or `(I, 1)` where
/// all its paths are near.
#[derive(Clone, Copy, Debug)]
struct NearTap {
    g2: f32,
    value: [f32; 4],
}

impl LayerInputs<'_> {
    /// Whether pixel `i` composites its layers: partly near, its near paths blurred over
    /// [`LAYER_SEPARATION`] times its least circle of confusion.
    fn mixed(&self, i: usize) -> bool {
        let (a, r) = (self.near[i][3], self.near_coc[i][0]);
        a > 0.0 && a < FULL && r > LAYER_SEPARATION * self.lens[i][0]
    }

    /// Pixel `j`'s [`NearTap`] at the node's μ.
    fn near_tap(&self, j: usize, mu: f32) -> NearTap {
        let (n, rj) = (self.near[j], self.near_coc[j][0]);
        let gj = if n[3] > 0.0 && rj > 0.0 { near_width(mu, rj) } else { 0.0 };
        let value = if n[3] >= FULL {
            let c = self.composed[j];
            [c[0], c[1], c[2], 1.0]
        } else {
            n
        };
        NearTap { g2: gj * gj, value }
    }
}

/// The composite at pixel `(x, y)` (module doc); `taps[j]` is [`LayerInputs::near_tap`]`(j)`.
fn layered_pixel(
    x: i32,
    y: i32,
    (width, height): (i32, i32),
    p: &LayersParams,
    frame: &LayerInputs,
    taps: &[NearTap],
) -> [f32; 3] {
    let i = (y * width + x) as usize;
    if !frame.mixed(i) {
        return frame.filtered[i];
    }
    let (own, r) = (frame.near[i], frame.near_coc[i][0]);
    let omega = near_width(p.mu, r);
    let radius = window_radius(omega, p.max_radius.get());
    let weights = CentreWeights::new(omega * omega, radius);
    let tap = |_, t: &NearTap, d: (i32, i32)| Some((weights.pair(d, t.g2)?, t.value));
    // The centre always passes (d = 0), so the window has a weight.
    let [f0, f1, f2, alpha] = gather_taps(x, y, width, height, (radius, radius), taps, tap).unwrap_or(own);
    let f = [f0, f1, f2];
    let cover = 1.0 - own[3];
    let far = [0, 1, 2].map(|c| (frame.composed[i][c] - own[c]) / cover);
    [0, 1, 2].map(|c| f[c] + (1.0 - alpha) * far[c])
}

/// `defocus.layers`: see the module doc.
pub struct Layers;

impl Kernel for Layers {
    wedge_backends::kernel_signature!(
        name: "defocus.layers", class: Filter, bindings: LayersIo, params: [LayersParams]
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/defocus_layers.wgsl"), |ctx| {
                Ok(LayersParams::read(ctx)?.uniforms())
            })
            .with_include("filter_window.wgsl", include_str!("../../../../shaders/filter_window.wgsl"))
            .with_reach(|ctx| Ok(Axis::Both.reach(LayersParams::read(ctx)?.max_radius))),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let LayersData { composed, filtered, near, near_coc, lens, out } = LayersIo::read(ctx)?;
        let p = LayersParams::read(ctx)?;
        let frame = LayerInputs { composed, filtered, near, near_coc, lens };
        if !(0..near.len()).any(|i| frame.mixed(i)) {
            // No pixel composites (an in-focus frame, a foreground-free view): eq. 5.33's image.
            return out.put(ctx, filtered.to_vec());
        }
        let w = ctx.width as usize;
        let taps = ctx.map_pixels(false, |x, y| frame.near_tap(y as usize * w + x as usize, p.mu));
        let size = (ctx.width as i32, ctx.height as i32);
        let v = ctx.map_pixels(false, |x, y| layered_pixel(x as i32, y as i32, size, &p, &frame, &taps));
        out.put(ctx, v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A synthetic frame: composed radiance, near layer, its circles of confusion, the truth.
    type Frame = (Vec<[f32; 3]>, Vec<[f32; 4]>, Vec<[f32; 4]>, Vec<[f32; 3]>);

    /// A blurred foreground of radiance `A` over a sharp stripe texture: per pixel, `n` lens paths of
    /// which a binomial number (from a fixed hash) see the foreground with the true coverage `c(x)`,
    /// a ramp across the image. Returns (composed, near, near_coc, truth) for `r_near` = 8 px.
    fn scene(n: u32, w: i32, h: i32) -> Frame {
        let a = 0.6f32;
        let mut state = 0x9e37_79b9u32;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            (state >> 8) as f32 / (1u32 << 24) as f32
        };
        let (mut composed, mut near, mut coc, mut truth) = (vec![], vec![], vec![], vec![]);
        for _y in 0..h {
            for x in 0..w {
                let c = 0.2 + 0.6 * x as f32 / (w - 1) as f32;
                let t = if x % 2 == 0 { 0.9 } else { 0.1 };
                let hits = (0..n).filter(|_| next() < c).count() as f32;
                let alpha = hits / n as f32;
                let f = a * alpha;
                let i = f + (1.0 - alpha) * t;
                composed.push([i; 3]);
                near.push([f, f, f, alpha]);
                coc.push([8.0, 0.0, 0.0, 0.0]);
                truth.push([a * c + (1.0 - c) * t; 3]);
            }
        }
        (composed, near, coc, truth)
    }

    /// `defocus.layers` over a frame as `run_cpu` runs it, row by row.
    fn layers(p: &LayersParams, frame: &LayerInputs, (w, h): (i32, i32)) -> Vec<[f32; 3]> {
        let taps: Vec<NearTap> = (0..frame.near.len()).map(|j| frame.near_tap(j, p.mu)).collect();
        (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| layered_pixel(x, y, (w, h), p, frame, &taps))
            .collect()
    }

    fn run(mu: f32, composed: &[[f32; 3]], near: &[[f32; 4]], coc: &[[f32; 4]], w: i32, h: i32) -> Vec<[f32; 3]> {
        let p = LayersParams { mu, max_radius: ScreenRadius::clamped(16) };
        let lens = vec![[0.0; 4]; near.len()];
        let frame = LayerInputs { composed, filtered: composed, near, near_coc: coc, lens: &lens };
        layers(&p, &frame, (w, h))
    }

    fn mse(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
        a.iter().zip(b).map(|(a, b)| f64::from(a[0] - b[0]).powi(2)).sum::<f64>() / a.len() as f64
    }

    /// The lens's variance at a mixed pixel — how many paths the foreground blocks, times the sharp
    /// background's contrast — is what the near filter removes: with 16 paths per pixel the composite's
    /// error is several times lower than the pixel's own estimate's.
    #[test]
    fn the_near_layer_filter_removes_the_coverage_noise_over_a_sharp_background() {
        let (w, h) = (64, 32);
        let (composed, near, coc, truth) = scene(16, w, h);
        let layered = run(0.7, &composed, &near, &coc, w, h);
        let (before, after) = (mse(&composed, &truth), mse(&layered, &truth));
        assert!(after < 0.2 * before, "MSE {before:e} -> {after:e}");
    }

    /// As μ grows the near filter shrinks to the pixel, and `F + (1 − α)(I − F)/(1 − α) = I`: the
    /// composite becomes the pixel's own estimate (eq. 5.33's limit too), so the option keeps the
    /// consistent mode's convergence to Monte Carlo.
    #[test]
    fn as_mu_grows_the_composite_is_the_pixels_own_estimate() {
        let (w, h) = (32, 16);
        let (composed, near, coc, _) = scene(16, w, h);
        let layered = run(1e4, &composed, &near, &coc, w, h);
        for (l, c) in layered.iter().zip(&composed) {
            assert!((l[0] - c[0]).abs() <= 1e-6 * c[0].abs().max(1.0), "{l:?} vs {c:?}");
        }
    }

    /// Pixels with no near path, or only near paths, keep eq. 5.33's value bit for bit.
    #[test]
    fn pixels_that_are_not_mixed_keep_the_filtered_value() {
        let (w, h) = (4, 1);
        let composed = vec![[0.5; 3]; 4];
        let filtered = vec![[0.25; 3]; 4];
        let near = vec![[0.0; 4], [0.5, 0.5, 0.5, 1.0], [0.0; 4], [0.5, 0.5, 0.5, 1.0]];
        let coc = vec![[0.0; 4], [8.0, 0.0, 0.0, 0.0], [0.0; 4], [8.0, 0.0, 0.0, 0.0]];
        let p = LayersParams { mu: 1.0, max_radius: ScreenRadius::clamped(16) };
        let lens = vec![[0.0; 4]; 4];
        let frame = LayerInputs { composed: &composed, filtered: &filtered, near: &near, near_coc: &coc, lens: &lens };
        assert_eq!(layers(&p, &frame, (w, h)), vec![[0.25; 3]; 4]);
        // A mixed pixel whose far paths are blurred too (r_min 3 px against r_near 8) is one surface
        // crossing the split, not a foreground over a background.
        let near = vec![[0.25, 0.25, 0.25, 0.5]; 4];
        let lens = vec![[3.0, 8.0, 0.0, 1.0]; 4];
        let frame = LayerInputs { composed: &composed, filtered: &filtered, near: &near, near_coc: &coc, lens: &lens };
        assert_eq!(layers(&p, &frame, (w, h))[1], [0.25; 3]);
    }
}
