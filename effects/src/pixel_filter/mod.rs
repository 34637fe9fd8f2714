//! `PixelFilter`: pixel filtering for progressive rendering (issue 18; Schwenk's thesis,
//! `seeds/002_34c8a733cb47f3c2.txt` Ch. 3 "Filtering Pixel Radiance", Sec. 3.3 and the optimizations of
//! Sec. 3.6). One path per pixel per frame (`wedge render --progressive N`), accumulated over frames
//! through the graph's frame history; the high-variance paths are filtered by a cross-bilateral filter
//! on a schedule of frames and blended back per pixel under a threshold on perceived noise, so the
//! image converges to plain progressive accumulation (`s → 1`).
//!
//! Passes (kernels in [`kernels`], formulas unit-tested in [`formulas`]):
//! 1. `sample` (`pixel_filter.sample`, random, reference role `Sample`): `paths` jittered paths
//!    per pixel (through the camera's lens and over its shutter where they open) on the shared
//!    estimators (next-event estimation at every vertex, the indirect path of `indirect.rs`), split
//!    into `L_lv` and `L_u` by `split` (`indirect`: direct vs indirect light, the thesis's usual split;
//!    `caustics`: light reaching the first diffuse vertex through glossy scattering only; `all`:
//!    everything filtered, Fig. 3.7);
//! 2. `accumulate`: the running mean of both and `M2` of `Y(L_u)` (Welford/Chan), continuing the
//!    previous frame's (`ExpandCtx::previous_frame`);
//! 3. `range` (random): the range buffer of Sec. 3.3.3 — albedo lit by ambient light and a head light,
//!    nearest depth — `range_samples` (4) jittered rays more per filter pass;
//! 4. `width` (with `adaptive`): the per-pixel σ_s of eqs. 3.15–3.17;
//! 5. `filter` (`bilateral`: the brute-force filter of eq. 3.6 with Σa², eq. 3.5) or
//!    `filter_<k>_x/y` (`separable`: the iterated approximation of eq. 3.14, `iterations` × 2
//!    passes), on frames 1 (a single image), 4, 8, 16, … (`first_filter`, `filter_first_frame`);
//!    between them the last filtered buffer is kept through the history. Role `Bypass`: a reference
//!    is the plain accumulation of its `paths` = N samples;
//! 6. `blend`: eqs. 3.1 and 3.10–3.13 with the spike clamp of eq. 3.18 (`spike_clamp`).
//!
//! Outputs: `radiance` (the blended image), `unfiltered` (the plain accumulation `L_lv + L_u`),
//! `blend` (the blend factor `s` per pixel, the thesis's Fig. 3.3 bottom row) and `sigma` (the spatial
//! σ per pixel: `sigma_s`, or the adaptive width).
//!
//! Buffer conventions (all `vec4`): the accumulation `lv` = (mean `L_lv`, n), `u` = (mean `L_u`,
//! `M2` of `Y(L_u)`); the filter's `filtered` = (`L_f`, `Var[L_f]` absolute) and `variance` =
//! (`σ²`: the filtered per-sample variance of `L_u`, `r = Σa²`, n at the filter pass, [`formulas::FILTERED`]);
//! the range buffer = (colour, depth).
//!
//! Files: [`node`] (the `PixelFilter` node), [`formulas`] (pure per-pixel functions: the running
//! statistics, the blend factor, the filter schedule, the adaptive width), [`kernels`] (the seven
//! kernels). The camera paths it samples are shared with `RadianceFilter` ([`crate::camera_paths`]).

use std::sync::Arc;

use wedge_backends::KernelRegistry;

pub mod formulas;
pub mod kernels;
pub mod node;

pub use node::PixelFilter;

/// Register the pixel-filter kernels (`pixel_filter.sample`, `.accumulate`, `.range`, `.width`,
/// `.bilateral`, `.separable`, `.blend`).
pub fn register_kernels(reg: &mut KernelRegistry) {
    reg.register(Arc::new(kernels::PixelSample));
    reg.register(Arc::new(kernels::Accumulate));
    reg.register(Arc::new(kernels::RangeBuffer));
    reg.register(Arc::new(kernels::AdaptiveWidth));
    reg.register(Arc::new(kernels::Bilateral));
    reg.register(Arc::new(kernels::Separable));
    reg.register(Arc::new(kernels::Blend));
}
