//! `RadianceFilter`: radiance filtering for progressive rendering (issue 18; Schwenk's thesis,
//! `seeds/002_34c8a733cb47f3c2.txt` Ch. 4 "Filtering Incident Radiance", Sec. 4.3). One path per
//! pixel per frame (`wedge render --progressive N`); each pixel's indirect light is estimated from
//! its neighbours' incident-radiance samples under its own BRDF (eq. 4.10), so texture and geometry
//! stay sharp; the kernel shrinks so the accumulated image keeps the target variance `T_u` while the
//! radius falls as `k^-1/2` (eqs. 4.13–4.15) until each pixel is plain path tracing (the correction
//! phase, Sec. 4.4).
//!
//! Passes (kernels in [`kernels`], formulas unit-tested in [`formulas`]):
//! 1. `sample` (random, reference role `Sample`): paths and the radiance samples (position, normal,
//!    albedo, direction, incident radiance `L̆` at the first vertex);
//! 2. `accumulate` (`pixel_filter.accumulate`, shared with `PixelFilter`): the running statistics of
//!    direct light and of the pixel's own indirect estimate (Welford/Chan `M2`);
//! 3. `radius` (Bandwidth): this frame's image-space radius per pixel (warm-up, then target variance),
//!    scaled by the screen-space ambient-occlusion factor of the previous frame's filter (`occlusion`);
//! 4. `filter` (role `Bypass`: a reference is plain path tracing): eqs. 4.10–4.12 with the
//!    Epanechnikov kernel on the tangent plane (eqs. 4.19–4.22) and the normal heuristic (eq. 4.9);
//! 5. `compose`: the running mean of direct + filtered indirect light (or the plain accumulation
//!    once a pixel is in the correction phase, `correction: "switch"`).
//!
//! Outputs: `radiance`, `unfiltered` (the plain progressive accumulation), `radius` (pixels, the
//! thesis's Fig. 4.2 bottom row) and `phase` (1 = the pixel's own sample only: correction phase).
//!
//! The kernels in detail:
//! - `radiance_filter.sample`: `count` jittered paths per pixel (one per frame), the same
//!   estimators as `pixel_filter.sample` (`first_vertex`): the batch's `Stats` of direct light
//!   (`lv`) and of the pixel's own indirect estimate (`hv`, with `M2` of its luminance), and the
//!   radiance sample of path 0 at the first non-specular vertex (Sec. 4.3.1, steps 1–2; wedge has no
//!   perfect specular surfaces, so it is the first hit): position, normal, albedo, direction, `L̆`.
//! - `radiance_filter.radius`: the image-space kernel radius of this frame per pixel: the warm-up
//!   radius `r_w1 k^-1/2` (eq. 4.15) for the first `warmup` frames, then the radius whose
//!   Epanechnikov kernel averages enough samples to reach the target variance `T_k = (2k−1)T_u`
//!   (eqs. 4.1, 4.2, 4.14) for the pixel's filtered perceived variance (`kernel_radius`), scaled
//!   by the previous frame's screen-space ambient-occlusion factor α (Sec. 4.3.1, step 3;
//!   `occlusion_factor`) unless `occlusion` is off.
//! - `radiance_filter.filter`: eq. 4.10–4.12 over the neighbours inside the kernel projected to the
//!   tangent plane (eqs. 4.19–4.22, `TangentKernel`), weighted by Epanechnikov (Sec. 4.3.6) and the
//!   normal heuristic `ν` (eq. 4.9); the per-path variance is filtered with the same weights
//!   (Sec. 4.3.4), and α gathered from the same samples. A radius under one pixel is the correction
//!   phase: the pixel's own estimate, exactly.
//! - `radiance_filter.compose`: this frame's direct + filtered indirect light accumulated over frames
//!   (the running mean of eq. 4.13), or — `correction: "switch"` — the plain accumulation once a pixel
//!   has entered the correction phase (Sec. 4.4.1's "little trick").
//!
//! Buffer conventions (all `vec4` unless said): `lv`/`hv` as in `PixelFilter` (`Stats`);
//! `point` = (x, ray distance; 0 = the camera ray left the scene), `normal` = (n, material index),
//! `albedo` = (k_d, 0), `direction` = (ω_i, 1 = a sample to re-use), `incident` = (L̆, distance to
//! the surface the continuation ray hit, `NO_BOUNCE_HIT` if it left the scene); `filtered` =
//! (this frame's indirect light, `FILTERED` or `OWN`); `variance` = (σ² filtered, or −1 where no
//! neighbour had two paths, Σw, radius, occlusion factor α); `accumulated` = (mean, frames);
//! `radius` and `phase` are `f32`.
//!
//! Files: [`node`] (the `RadianceFilter` node), [`formulas`] (pure per-pixel functions: target
//! variance, kernel radius, the tangent-plane kernel, occlusion, compose), [`kernels`] (the four
//! kernels). Its camera paths are `PixelFilter`'s ([`crate::camera_paths`]), and its `accumulate`
//! pass is `pixel_filter.accumulate`.

use std::sync::Arc;

use wedge_backends::KernelRegistry;

pub mod formulas;
pub mod kernels;
pub mod node;

pub use node::RadianceFilter;

/// Register the radiance-filter kernels (`radiance_filter.sample`, `.radius`, `.filter`, `.compose`).
pub fn register_kernels(reg: &mut KernelRegistry) {
    reg.register(Arc::new(kernels::RadianceSample));
    reg.register(Arc::new(kernels::Radius));
    reg.register(Arc::new(kernels::Filter));
    reg.register(Arc::new(kernels::Compose));
}
