//! Mixed reality (thesis Ch. 6, Sec. 6.3–6.5; supplemental seed 003, Algorithm 1): two-mode
//! sampling of the real and the virtual world, and differential compositing. WGSL mirrors:
//! `shaders/mr_sample.wgsl` ([`sample`]), `shaders/mr_composite.wgsl` ([`composite`]).
//!
//! **Two modes.** Virtual geometry is the scene's triangles (the BVH: only virtual objects); real
//! geometry is the captured real layer (`wedge_scene::RealLayer`: per-pixel position, normal, albedo
//! and the camera image `L_cam`), intersected by screen-space rays ([`wedge_backends::kernels::screen_trace`]).
//!
//! `mr.sample` (Algorithm 1): per pixel `count` primary samples (jittered in the pixel, Sobol' pair
//! `PIXEL`); a sample is *real* where no virtual surface is hit or the pixel's real surface is nearer
//! (line 7; the real layer is one surface per pixel, so every sample of a pixel sees the same real
//! point), else *virtual*; `M` = the real fraction. Each sample takes `per_primary` secondary samples:
//! - direct light: a look-up into the environment's table (stratified per pixel as the sampler does,
//!   `environment::stratified_entry`), tested against both worlds — a virtual shadow ray (BVH,
//!   any-hit unless the look-up is bright enough to set the occluder term) and a screen-space one. At a
//!   real sample, `E_R^dir` counts it when no real surface blocks it, `E_RV^dir` when nothing blocks it
//!   (lines 20–25). At a virtual sample, `E_V^dir` counts it when nothing blocks it.
//! - indirect light: a cosine-hemisphere direction (real surfaces are diffuse), or at a virtual
//!   sample one of the surface's lobes picked by reflectance (diffuse or Phong, the mixture pdf), traced
//!   in both modes. A real hit returns `L_cam` at the hit's pixel (line 28); a virtual hit returns its
//!   radiance from one environment look-up with shadow rays in both modes (line 29: "tracing a secondary
//!   shadow ray to an environment map sample"). `E_R^ind` takes the real hit only (virtual objects do
//!   not exist there), `E_RV^ind` and `E_V^ind` the nearer of the two (lines 30–40). A ray that hits
//!   nothing adds 0: the environment is the direct term's.
//!
//! **Readings taken** (docs/DESIGN-NOTES.md "Mixed reality"): irradiances are wedge's `E` (a diffuse
//! surface's outgoing radiance is `k E`: `E = L cos / (π pdf)`), each sum divided by its own sample
//! count (docs/EQUATIONS.md); the real irradiances average over the pixel's real samples and the virtual
//! ones over its virtual samples (Algorithm 1 divides everything by 16, which at a silhouette mixes
//! the two kinds into one ratio), so that eq. 6.2 composes `(1 − M) k_V E_V + M (E_RV / E_R) L_cam`
//! exactly at partly covered pixels; at a virtual sample `E_V` is its outgoing radiance divided by
//! `k_V = k_d + k_s` (the thesis: "we may represent this outgoing radiance with the same symbol E_RV"),
//! so `k̄_V Ē_V` restores it after filtering. Samples where neither world has a surface (the sky seen
//! through the pixel) are real with no irradiance: `E_R = E_RV = 0`, and the composite keeps `L_cam`.
//!
//! Outputs per pixel: the six irradiances (vec3), `texture` (`k_V`, `M`), the filter's `position`
//! (`w` = 1 + object id; real surfaces [`REAL_OBJECT`]) and `normal` (`w` the footprint) of the pixel's
//! majority kind, `environment` and `depth` in the sampler's conventions (occluder term `cos θ / t` over
//! bright blocked look-ups of either world, mean Phong exponent, look-ups, blocked look-ups; indirect
//! `z_min`, `z_max`, hits, rays) so the Environment node's bandwidth kernels apply unchanged, and
//! `screen` (screen-space rays, those that left the image, hits). Ray counts: camera rays as
//! primary, rays toward the environment as shadow, indirect rays as secondary — a BVH ray and a
//! screen-space ray one each, since both are traced for every direction.

pub mod composite;
pub mod sample;

pub use composite::MrComposite;
pub use sample::{MrSample, REAL_OBJECT};

wedge_backends::kernel_bindings! {
    /// What an `mr.sample` pass writes: the six irradiances (in [`sample::MrPixel::e`] order, the
    /// order [`CompositeIo`] reads them), then the filter's and bandwidths' inputs.
    pub struct SampleIo / SampleData {
        write e_r_dir: [f32; 3],
        write e_r_ind: [f32; 3],
        write e_rv_dir: [f32; 3],
        write e_rv_ind: [f32; 3],
        write e_v_dir: [f32; 3],
        write e_v_ind: [f32; 3],
        write texture: [f32; 4],
        write position: [f32; 4],
        write normal: [f32; 4],
        write environment: [f32; 4],
        write depth: [f32; 4],
        write_opt screen: [f32; 4],
    }
}

wedge_backends::kernel_bindings! {
    /// What an `mr.composite` pass binds: the six (filtered) irradiances, `texture` (`k_V`, `M`), the
    /// composite and, optionally, the reconstruction and `M` on its own (for a heatmap).
    pub struct CompositeIo / CompositeData {
        read e_r_dir: [f32; 3],
        read e_r_ind: [f32; 3],
        read e_rv_dir: [f32; 3],
        read e_rv_ind: [f32; 3],
        read e_v_dir: [f32; 3],
        read e_v_ind: [f32; 3],
        read texture: [f32; 4],
        write out: [f32; 3],
        write_opt reconstruction: [f32; 3],
        write_opt mask: f32,
    }
}

/// `Io { e_r_dir: e[0], …, e_v_ind: e[5], rest }`: a [`SampleIo`] or [`CompositeIo`] with the six
/// irradiances from an array in their declaration order (the node keeps them as `[BufferId; 6]`).
macro_rules! irradiance_io {
    ($io:ident, $e:expr, { $($rest:tt)* }) => {{
        let [e_r_dir, e_r_ind, e_rv_dir, e_rv_ind, e_v_dir, e_v_ind] = $e;
        $io { e_r_dir, e_r_ind, e_rv_dir, e_rv_ind, e_v_dir, e_v_ind, $($rest)* }
    }};
}
pub(crate) use irradiance_io;
