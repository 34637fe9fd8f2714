//! Defocus, factoring and two-level sampling (Mehta thesis Ch. 5, eqs. 5.2–5.33; `docs/EQUATIONS.md`
//! "Defocus + factoring + two-level sampling").
//!
//! This module holds the per-pixel parts of Ch. 5 that consume the path sampler's statistics:
//! - [`formulas`]: pure functions — circle of confusion (5.2) for both lens shapes, `ℓ_p`, the filter
//!   widths `Ω_x^d` (5.7–5.8), `Ω_x^s` (5.18), `Ω_x^i` (5.22), the rates `n_p`, `n_dir^{f|c}`,
//!   `n_ind^{f|c}` (5.24–5.28) with `Ω(μ)` (5.29) in a `literal` and a `consistent` mode, rounding for
//!   full stratification, and the factoring test (5.30);
//! - [`kernels`]: `defocus.rates` (widths and counts per pixel), `defocus.flags` (SepDir / SepInd,
//!   5.30) and `defocus.compose` (5.32), each with a CPU implementation and a WGSL one
//!   (`shaders/defocus_*.wgsl`); [`kernels::filter`]: `filter.defocus` (5.33).
//!
//! The shared kernels the Ch. 5 stages also use live in `wedge-backends`: `neighbourhood.max3` (3×3 max
//! on counts), `neighbourhood.median3` (3×3 median on flags), `filter.irradiance` (5.31) and the
//! filters' window (`kernels::filter_window`).
//! - [`node`]: the `Defocus` node, the pipeline's factoring node ([`wedge_graph::factoring`]);
//! - [`component`]: the passes a component node (SoftShadows, Indirect) adds under it.

use std::sync::Arc;

use wedge_backends::KernelRegistry;

pub mod component;
pub mod formulas;
pub mod kernels;
pub mod node;

pub use node::Defocus;

/// Register the defocus kernels (`defocus.rates`, `defocus.flags`, `defocus.compose`,
/// `defocus.weighted_texture`, `filter.defocus`, `defocus.layers`, `defocus.all_factored`).
pub fn register_kernels(reg: &mut KernelRegistry) {
    reg.register(Arc::new(kernels::Rates));
    reg.register(Arc::new(kernels::Flags));
    reg.register(Arc::new(kernels::Compose));
    reg.register(Arc::new(kernels::WeightedTexture));
    reg.register(Arc::new(kernels::filter::DefocusFilter));
    reg.register(Arc::new(kernels::layers::Layers));
    reg.register(Arc::new(kernels::all_factored::AllFactored));
    reg.register(Arc::new(kernels::risk::RiskTerms));
    reg.register(Arc::new(kernels::risk::RiskChoice));
    reg.register(Arc::new(kernels::risk::RiskSelect));
}
