//! Motion blur with secondary effects (Mehta thesis App. B, `seeds/000_956e982470d7e5bf.txt`
//! Appendix B; `docs/EQUATIONS.md` "Motion"): Ch. 5's factoring and two-level sampling with shutter time
//! in place of the lens.
//!
//! - [`formulas`]: pure functions — the widths `Ω_{x,p}^m` (B.1), `Ω_{x,s}^m` (B.2), `n_p` (B.3),
//!   the App. B readings of the secondary counts, and the single-velocity test;
//! - [`kernels`]: `motion.rates` and `motion.flags`, each with a CPU implementation and a WGSL one
//!   (`shaders/motion_*.wgsl`); [`kernels::filter`]: the oriented filter (`filter.motion`, B.1–B.2)
//!   and the 3×3 radiance filter of multi-velocity pixels (`filter.radiance3`);
//! - [`node`]: the `Motion` node, the pipeline's factoring node when the scene moves, and the passes a
//!   component node gets under it.
//!
//! Shared kernels it also uses: `filter.irradiance` and the filters' window
//! (`wedge_backends::kernels::{irradiance_filter, filter_window}`).

use std::sync::Arc;

use wedge_backends::KernelRegistry;

pub mod formulas;
pub mod kernels;
pub mod node;

pub use node::Motion;

/// Register the motion kernels (`motion.rates`, `motion.flags`, `filter.motion`, `filter.radiance3`).
pub fn register_kernels(reg: &mut KernelRegistry) {
    reg.register(Arc::new(kernels::Rates));
    reg.register(Arc::new(kernels::Flags));
    reg.register(Arc::new(kernels::filter::MotionFilter));
    reg.register(Arc::new(kernels::filter::Radiance3Filter));
}
