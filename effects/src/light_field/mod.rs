//! Light-field reconstruction of indirect light and ambient occlusion (issue 17; Lehtinen, Aila,
//! Laine, Durand 2012, `seeds/001_2d3ed232e6777e89.txt`; docs/EQUATIONS.md "Light-field
//! reconstruction"): the input secondary rays become a point-sampled scene (splats) that many
//! reconstruction rays per pixel query (eq. 3).
//!
//! - [`node`]: the `LightField` node (its passes, the camera it traces through);
//! - [`formulas`]: pure functions — `κ` (eq. 2), the AO test, the share of eq. 3's rays among a
//!   pixel's primary hits;
//! - [`records`]: the per-sample buffers' records (samples, splats, tree nodes, primary hits);
//! - [`splats`]: the splats' preprocessing (k-NN radii, the splat BVH, shrinking; Secs. 2.2–2.3.1);
//! - [`reconstruct`]: RECONSTRUCT, what one ray sees through the splats (Secs. 2.3.2–2.5);
//! - [`kernels`]: `light_field.sample`, `light_field.splats` (a host kernel) and
//!   `light_field.reconstruct`, each with its CPU implementation and (but the host one) its WGSL
//!   (`shaders/light_field_*.wgsl`).

use std::sync::Arc;

use wedge_backends::KernelRegistry;

pub mod formulas;
pub mod kernels;
pub mod node;
pub mod reconstruct;
pub mod records;
pub mod splats;

pub use node::{LightField, DEFAULT_ALPHA, DEFAULT_GLOSSY_CAP, DEFAULT_K, DEFAULT_RAYS, DEFAULT_SPP};
pub use reconstruct::STACK_SIZE;
pub use records::{
    LightPrimary, LightSample, Splat, SplatNode, LIGHT_PRIMARY, LIGHT_SAMPLE, SAMPLE_ESCAPED, SAMPLE_HIT, SAMPLE_NONE,
    SPLAT, SPLAT_NODE,
};

/// Register the light-field kernels (`light_field.sample`, `.splats`, `.reconstruct`).
pub fn register_kernels(reg: &mut KernelRegistry) {
    reg.register(Arc::new(kernels::LightFieldSample));
    reg.register(Arc::new(kernels::LightFieldSplats));
    reg.register(Arc::new(kernels::LightFieldReconstruct));
}
