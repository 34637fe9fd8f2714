//! `SoftShadows`: axis-aligned filtering of area-light soft shadows (Mehta thesis Ch. 3,
//! `seeds/000_956e982470d7e5bf.txt`; `docs/EQUATIONS.md` "SoftShadows").
//!
//! Sampling is the shared sampler's ([`crate::sampler`], `docs/SAMPLER-STAGE.md` §4): the node asks
//! it for the `light` estimator with the Ch. 3 constants — one primary path per pixel through the
//! centre (`n_p = 1`), `initial_rays` (8; the thesis's 9 = 3×3 is not a stratified prefix of the
//! sampler's base-2 sequence; measured in docs/SAMPLER-STAGE.md §4) stratified light samples on it, `light`, `form_factor` —
//! and reads the first pass's occluder statistics `d1, d2_min, d2_max`. Its own passes:
//! `fill` (unoccluded pixels take their neighbours' averages within 5 pixels, Sec. 3.6)
//! → `bandwidth` (β, eq. 3.13) → `rates` (n, eq. 3.21, capped at `max_rays · max(μ, 1)²`: 64 at
//! μ = 2, see [`rays_cap`]), submitted to the sampler as `n` shadow rays
//! over both passes (`PerPrimary::Spread`: the sampler traces the `n − initial_rays` left on paths of
//! about `initial_rays` through the pixel centre, continuing the first pass's stratified light
//! samples; with a fixed camera ray its record weighs every shadow ray the same) → `visibility`
//! (the pair ΣE, ΣU: the sampler's final direct estimate and the same samples unshadowed) →
//! `filter_x` → `filter_y` (separable world-space Gaussian in the light's plane, eq. 3.12, 10° normal
//! test, mutual reach) → `shade` (eq. 3.1's `r(x)` — the closed-form unoccluded irradiance — times
//! the filtered ratio ΣE/ΣU) → `compose` (albedo after filtering). With `irradiance: "sampled"` the
//! filters take E itself and there is no `visibility`/`shade`. Pixels with no occluder statistics,
//! own or neighbours', are not filtered (analytic: their own E/U, exactly 1 where no ray was
//! blocked). docs/DESIGN-NOTES.md "SoftShadows after the suite".
//!
//! Files: [`node`] (the `SoftShadows` node, alone and as a factoring node's component),
//! [`formulas`] (eqs. 3.4, 3.13, 3.21 and the count cap, pure functions) and [`kernels`]
//! (`shadows.bandwidth`, `shadows.rates`, `shadows.visibility`, `shadows.shade`; CPU here, WGSL in
//! `shaders/shadows_*.wgsl`).

use std::sync::Arc;

use wedge_backends::KernelRegistry;

pub mod formulas;
pub mod kernels;
pub mod node;

pub use formulas::{filter_beta, rays_cap, samples_per_pixel, slopes, whole_multiples};
pub use node::SoftShadows;

/// Register the soft-shadow kernels.
pub fn register_kernels(reg: &mut KernelRegistry) {
    reg.register(Arc::new(kernels::Bandwidth));
    reg.register(Arc::new(kernels::Rates));
    reg.register(Arc::new(kernels::Visibility));
    reg.register(Arc::new(kernels::Shade));
}
