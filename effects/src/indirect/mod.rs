//! `Indirect`: axis-aligned filtering of diffuse and glossy indirect light, multi-bounce, and the
//! ambient-occlusion variant (Mehta thesis Ch. 4, eqs. 4.15–4.21, App. A; `docs/EQUATIONS.md` "Indirect").
//!
//! Sampling is the shared sampler's ([`crate::sampler`], `docs/SAMPLER-STAGE.md` §4): the node asks
//! it for the `hemisphere` estimator with the Ch. 4 constants — one path through the pixel centre,
//! `initial_rays` (16) stratified hemisphere samples per component on it, `bounces`, `brdf`, and the
//! AO mode — and reads the first pass's first-hit distances `z_min, z_max` (`depth`). Its own passes:
//! `bandwidth` (β per component, eqs. 4.15–4.16, 4.18, A.3, A.5) → `rates` (n per component,
//! eq. 4.21), submitted as each component's samples over both passes (`PerPrimary::Spread` on the
//! sampler's `diffuse` and `glossy` channels: up to n, reusing the first 16, each component with its
//! own count, every sample weighing the same) → `filter_x`/`filter_y` per component on the sampler's
//! final `diffuse` / `glossy` estimates (the shared separable world-space Gaussian, full 3-D
//! distance, 10° normal test) → `compose` (k_d and k_s multiply after filtering).
//!
//! Readings taken (documented in the report and `docs/EQUATIONS.md`'s map):
//! - **Components**: the diffuse component (cosine sampling) and, on pixels whose `specular` input has
//!   `k_s > 0, m > 0`, the glossy component (Phong-lobe sampling) are each sampled with *their own*
//!   count from eq. 4.21 (own `Ω_h`, own `γ`) and filtered with their own β. `rays_per_pixel` is the
//!   sum of both counts (hemisphere rays, i.e. paths, per pixel).
//! - **Indirect only**: the primary hit's direct light is not included (lights enter only by
//!   next-event estimation at path vertices beyond the primary hit); pair the node with a direct-light
//!   node (`SoftShadows`, `MonteCarlo`) and an `Add`.
//! - `z_min` is clamped to at least `z_min_fraction` (2%) of the scene's largest dimension; `z_max` is
//!   kept ≥ the clamped `z_min`.
//! - **No reflector found**: a pixel whose first-pass rays all miss (AO: nothing within
//!   `max_distance`) takes `z_min = z_max =` the scene's largest dimension, the farthest any reflector
//!   can be: eqs. 4.15–4.21 then give a wide filter (usually the whole `max_radius` window) and about
//!   the initial count, and β still shrinks as `1/μ`, so μ → ∞ stays plain Monte Carlo. Leaving such
//!   pixels unfiltered instead keeps exactly the pixels whose 16 rays happened to miss at 0, a
//!   selection bias: on the open `curved` AO scene the image mean was 27% low. (`z_min = ∞`, i.e.
//!   `β = ∞`, removes that bias too but never converges as μ grows.)
//! - Rates are clamped to `[initial_rays, max_rays · max(μ, 1)]` (thesis: 16 and 100μ).
//! - **The filter width's `z_min` and pixel bound** (`width_z_min`, `width_alpha`): eq. 4.15's
//!   `z_min` is "the minimum distance to any reflector"; the minimum of a pixel's 16 cosine-weighted
//!   first-pass rays over-estimates it, and the filter comes out several times too wide: AO over
//!   fourteen built-in scenes was 98% bias, 0.81× fewer rays than stratified MC. The default
//!   `"nearest"` takes the width's `z_min` from the nearest reflector the eight neighbours' first
//!   passes saw on the same object (pass `nearest`, kernel `indirect.nearest`; 8 × 16 rays, the
//!   pixel's own left out), unclamped, and the width's pixel bound `β ≥ 2/(μ·width_alpha)` px with
//!   `width_alpha` 4 (the rates keep `alpha` 0.3 and the clamped statistics: same rays). Both are
//!   needed (AO, the same fourteen scenes at 96×72: 0.81× → 0.93× nearest alone, 1.04× α 1 alone,
//!   1.89× both with α 1, 2.51× with α 4; fourteen scenes not used to choose it: 0.40× → 1.42× (α 1)
//!   → 1.94× (α 4); indirect light on twelve: 1.48× → 2.40×, worst 0.68× → 0.97× (α 1);
//!   docs/DESIGN-NOTES.md "AO over fourteen scenes", "The filters against their own rays"). β still
//!   shrinks as `1/μ`, so μ → ∞ stays plain Monte Carlo. `width_z_min: "statistics", width_alpha: 0`
//!   is the thesis's width.
//! - **Whose statistics** (`statistics`): the thesis's `z_min, z_max` are the pixel's own first
//!   pass's, whose samples its estimate then reuses, so a pixel's count and width correlate with
//!   its own value (AO on `curved`: unfiltered mean −1.1%, filtered −3.3%). `"neighbours"` runs
//!   `neighbourhood.others` first (pass `statistics`): the means of the eight neighbours' `z_min`,
//!   `z_max` on the same object, the pixel's own left out (AO: −1.1% → +0.0% and −3.3% → −0.4%;
//!   indirect light: the same speedups; the default; `"own"` keeps the thesis's; docs/DESIGN-NOTES.md
//!   "AO: the mean and the pixel's own statistics"). Not used under a factoring node.
//!
//! Files: [`node`] (the `Indirect` node, alone and as a factoring node's component), [`formulas`]
//! (eqs. 4.15–4.21, A.3, A.5 as pure functions) and [`kernels`] (`indirect.bandwidth`,
//! `indirect.rates`; CPU here, WGSL in `shaders/indirect_{bandwidth,rates}.wgsl`). The path estimator
//! itself is the shared sampler's (`wedge_backends::kernels::indirect`).

use std::sync::Arc;

use wedge_backends::KernelRegistry;

pub mod formulas;
pub mod kernels;
pub mod node;

pub use node::Indirect;

/// Register the indirect-light kernels.
pub fn register_kernels(reg: &mut KernelRegistry) {
    reg.register(Arc::new(kernels::Bandwidth));
    reg.register(Arc::new(kernels::Rates));
    reg.register(Arc::new(kernels::Nearest));
}
