//! # wedge-effects
//!
//! Effect nodes, one file each. An effect is three things (see `docs/ARCHITECTURE.md`): what to sample,
//! its bandwidth and rate formulas (pure per-pixel functions, unit-tested against the thesis), and the
//! buffers it reads and writes. The heavy machinery — sampling, neighbourhood fill, the separable
//! world-space Gaussian, compose — is shared from `wedge-backends`.
//!
//! - [`primary`]: `Primary`, the G-buffer every effect reads.
//! - [`sampler`]: the shared path sampler (first pass, count combination, adaptive pass) nodes ask
//!   for from `expand` (`wedge_graph::sampler`); registered as the registry's sampler kind.
//! - [`shadows`]: `SoftShadows`, axis-aligned filtering of area-light soft shadows (thesis Ch. 3).
//! - [`indirect`]: `Indirect`, axis-aligned filtering of diffuse/glossy indirect light and AO (thesis Ch. 4).
//! - [`defocus`]: `Defocus`, thin-lens depth of field with factoring and two-level sampling (thesis Ch. 5).
//! - [`motion`]: `Motion`, motion blur with factoring and two-level sampling (thesis App. B).
//! - [`environment`]: `Environment`, environment-map lighting with axis-aligned and temporal
//!   filtering (thesis Ch. 6).
//! - [`mixed_reality`]: `MixedReality`, virtual objects in a photograph: two-mode sampling,
//!   Ch. 6 filtering and differential compositing (thesis Ch. 6).
//! - [`factored`]: the passes both factoring nodes build alike (filter chains, the compose of a
//!   component's factored parts).
//! - [`plain_camera`]: a component rendered as plain Monte Carlo through the `camera:` block's lens
//!   and shutter where no factoring node filters them.
//! - [`pixel_filter`]: `PixelFilter`, progressive path tracing with pixel filtering (Schwenk's
//!   thesis, seed 002 Ch. 3): accumulation over frames, cross-bilateral filter, perceptual blend.
//! - [`radiance_filter`]: `RadianceFilter`, progressive path tracing with radiance filtering (seed 002
//!   Ch. 4): neighbours' incident radiance under each pixel's BRDF, kernels shrinking as `k^-1/2`.
//! - [`camera_paths`]: the path tracer both progressive nodes sample with (camera ray, first vertex).
//! - [`light_field`]: `LightField`, visibility-aware reconstruction of the indirect light field
//!   (Lehtinen et al. 2012, seed 001): secondary rays as splats, many reconstruction rays per pixel.
//! - [`add`]: `Add`, the sum of two radiance images (direct + indirect composed by the graph).
//! - [`montecarlo`]: `MonteCarlo`, plain (stratified or independent) Monte Carlo — a baseline node
//!   (references come from each pipeline's own graph, `wedge_graph::reference`).
//! - [`output`]: `Output`, the sink whose inputs a run hands back; [`heatmap`]: `Heatmap`, a sink for
//!   one more filter width or ray count, written as its own heatmap.
//!
//! Every pass an effect adds names its [`wedge_graph::Stage`] (first paths, bandwidths and rates,
//! adaptive paths, filters, compose, …), says whether it draws random numbers (`.random()`: the
//! graph assigns its stream from its name; effect files never pick stream numbers) and declares its
//! [`wedge_graph::Reference`] role (filters `Bypass`, rate passes `Count`, first passes `Continued`,
//! sampling passes `Sample`), from which `wedge reference` builds the pipeline's Monte Carlo reference.
//!
//! A user crate adds its own node the same way: implement [`wedge_graph::NodeKind`] (and any
//! [`wedge_backends::Kernel`] it needs) and register both next to [`register`]'s.

// `!(x > 0.0)` is how the kernels reject NaN along with the values they exclude (a NaN compares
// false); clippy's `partial_cmp` rewrite would hide that.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::sync::Arc;

use wedge_backends::KernelRegistry;
use wedge_graph::NodeRegistry;

pub mod add;
pub mod camera_paths;
pub mod defocus;
pub mod environment;
pub mod factored;
pub mod filtering;
pub mod heatmap;
pub mod indirect;
pub mod light_field;
mod light_terms;
pub mod mixed_reality;
pub mod montecarlo;
pub mod motion;
pub mod output;
pub mod params;
pub mod pixel_filter;
pub mod plain_camera;
pub mod primary;
pub mod radiance_filter;
pub mod sampler;
pub mod shadows;

/// Register wedge's node kinds and every kernel they use (shared and effect-specific).
pub fn register(nodes: &mut NodeRegistry, kernels: &mut KernelRegistry) {
    wedge_backends::register_shared_kernels(kernels);
    nodes.register_sampler(Arc::new(sampler::PathSampler));
    sampler::register_kernels(kernels);
    nodes.register(Arc::new(primary::Primary));
    nodes.register(Arc::new(output::Output));
    nodes.register(Arc::new(heatmap::Heatmap));
    nodes.register(Arc::new(montecarlo::MonteCarlo));
    nodes.register(Arc::new(shadows::SoftShadows));
    shadows::register_kernels(kernels);
    nodes.register(Arc::new(indirect::Indirect));
    indirect::register_kernels(kernels);
    nodes.register(Arc::new(add::Add));
    add::register_kernels(kernels);
    nodes.register(Arc::new(defocus::Defocus));
    defocus::register_kernels(kernels);
    nodes.register(Arc::new(motion::Motion));
    motion::register_kernels(kernels);
    nodes.register(Arc::new(environment::Environment));
    environment::register_kernels(kernels);
    nodes.register(Arc::new(mixed_reality::MixedReality));
    mixed_reality::register_kernels(kernels);
    nodes.register(Arc::new(pixel_filter::PixelFilter));
    pixel_filter::register_kernels(kernels);
    nodes.register(Arc::new(radiance_filter::RadianceFilter));
    radiance_filter::register_kernels(kernels);
    nodes.register(Arc::new(light_field::LightField));
    light_field::register_kernels(kernels);
}

/// The registries with everything wedge ships.
pub fn builtin() -> (NodeRegistry, KernelRegistry) {
    let mut n = NodeRegistry::new();
    let mut k = KernelRegistry::new();
    register(&mut n, &mut k);
    (n, k)
}
