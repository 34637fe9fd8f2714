//! Mixed reality: virtual objects inserted into a photograph of a real scene (thesis Ch. 6,
//! Sec. 6.3–6.5; supplemental seed 003, Algorithm 1; `docs/EQUATIONS.md` "Environment", mixed
//! reality 6.1–6.2).
//!
//! - [`node`]: the `MixedReality` node (two-mode sampling, the `Environment` node's bandwidths and
//!   filters, differential compositing);
//! - [`formulas`]: differential compositing at one pixel (eq. 6.2);
//! - [`kernels`]: `mr.sample` (Algorithm 1's two-mode sampler) and `mr.composite` (eq. 6.2), each with
//!   its CPU implementation and its WGSL (`shaders/mr_*.wgsl`). The screen-space tracer they use is
//!   shared: `wedge_backends::kernels::screen_trace` (the wgpu backend builds its depth pyramid).

use std::sync::Arc;

use wedge_backends::KernelRegistry;

pub mod formulas;
pub mod kernels;
pub mod node;

pub use node::MixedReality;

/// Register the mixed-reality kernels (`mr.sample`, `mr.composite`).
pub fn register_kernels(reg: &mut KernelRegistry) {
    reg.register(Arc::new(kernels::MrSample));
    reg.register(Arc::new(kernels::MrComposite));
}
