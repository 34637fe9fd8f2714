//! Environment lighting and temporal filtering (Mehta thesis Ch. 6, `seeds/000_956e982470d7e5bf.txt`
//! Sec. 6.5–6.7; `docs/EQUATIONS.md` "Environment"): image-based lighting from a lat-long map
//! (`wedge_scene::EnvironmentMap`), filtered with axis-aligned bandwidths from curvature, occluders,
//! the BRDF and the map's own bandwidth, and across the frames of a camera path.
//!
//! - [`formulas`]: pure functions — curvature (6.20), bandwidths (6.13, 6.17, 6.18), `B_ρ`, σ, and the
//!   adaptive look-ups of the μ extension;
//! - [`kernels`]: `environment.curvature` and `environment.bandwidth`, each with a CPU implementation
//!   and a WGSL one (`shaders/environment_*.wgsl`); [`kernels::filter`]: the separable and temporal
//!   filter (`filter.environment`, `filter.environment_history`, 6.21–6.26) and `bandwidth.max`
//!   (MixedReality's larger of two parts' bandwidths, fed to the same filter);
//! - [`node`]: the `Environment` node.
//!
//! The sampler's `environment` estimator (table look-ups, occluder term, environment next-event
//! estimation at indirect vertices) is shared machinery in `wedge_backends::kernels::{paths,
//! environment}`.

use std::sync::Arc;

use wedge_backends::KernelRegistry;

pub mod formulas;
pub mod kernels;
pub mod node;

pub use node::Environment;

/// Register the environment kernels (`environment.curvature`, `environment.bandwidth`, its filters
/// and `bandwidth.max`).
pub fn register_kernels(reg: &mut KernelRegistry) {
    reg.register(Arc::new(kernels::Curvature));
    reg.register(Arc::new(kernels::Bandwidth));
    reg.register(Arc::new(kernels::filter::EnvironmentFilter));
    reg.register(Arc::new(kernels::filter::EnvironmentHistory));
    reg.register(Arc::new(kernels::filter::BandwidthMax));
}
