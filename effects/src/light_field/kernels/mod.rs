//! Light-field reconstruction of indirect light and ambient occlusion (issue 17; Lehtinen, Aila,
//! Laine, Durand 2012, `seeds/001_2d3ed232e6777e89.txt`): the kernels of the `LightField` node
//! (`wedge_effects::light_field`). A very different reconstruction from the axis-aligned filters:
//! the input rays themselves become a point-sampled scene that many reconstruction rays query.
//!
//! - `light_field.sample` (random, reference role `Sample`): per pixel `count` camera paths of one
//!   secondary ray each (Sec. 2.1: each input sample is one secondary ray of a path). Each path's
//!   camera ray goes through the pixel centre (`crate::camera_paths::CameraDraws`, unjittered),
//!   through its own lens point (`aperture_radius`,
//!   `focus_distance`, `lens`: the pass's thin lens, [`pass_camera`]) at its own shutter time where
//!   `time` is set — else every path has the same camera ray, traced once per pixel (a pinhole at
//!   the shutter's centre: the `Primary` G-buffer's hit). At the primary hit a direction from the
//!   surface's lobe mixture (cosine for AO) is traced as a path (`indirect::path_from_hit`: next-event
//!   estimation at `bounces` vertices) at the path's time. The first `layers` are kept as
//!   [`LightSample`] records (Sec. 2.1's tuple: origin, hit, normal at the hit, `κ`, direction,
//!   radiance `L`, and the time, lens point and motion vector of the hit), the first
//!   `layers("primary")` primary hits as [`LightPrimary`] records (one layer where the camera ray is
//!   fixed); `estimate` is their plain Monte Carlo estimate `Σ w·L f cos/pdf / Σ w` (`w` the lens
//!   weight; AO: the fraction of rays that hit within `max_distance`) with `Σ w` in `w` (the Vec4
//!   estimate convention: the node's `unfiltered` is its `rgb`). Chunked on the GPU (a reference's
//!   thousands of paths per pixel): between dispatches `estimate` holds the running sums.
//! - `light_field.splats` (a host kernel: [`splats`]): splat radii by the bandwidth-aware k-NN, the
//!   splat BVH (a motion BVH: each box bounds its splat over the shutter), consistency shrinking;
//!   writes the splats in leaf order, the tree's nodes and the mean final radius per pixel
//!   (`splat_radius`, a heatmap).
//! - `light_field.reconstruct` (random, a filter bypassed to `unfiltered` in references): eq. 3,
//!   `rays` reconstruction rays per pixel spread over its primary hits (ray `r` to hit `r mod P`,
//!   so `N × n` of the paper is `rays` in all), each from the hit's lobe mixture at the hit's time
//!   and resolved by RECONSTRUCT ([`reconstruct`]) through the splats moved to that time: per hit
//!   `mean(RECONSTRUCT(p, ω) f cos/pdf)`, per pixel the lens-weighted mean over its hits; AO: the
//!   fraction of rays whose nearest apparent surface lies within `max_distance`.
//!
//! **Motion** (Sec. 2.1's motion vectors): a sample stores its time `t_i` and the world velocity
//! `v_h` of its hit (per unit `t`, `SceneAt::velocity`); its splat is at `h + v_h (t − t_i)` at time
//! `t` ([`Splat::centre_at`]) — exact for translating objects, first order for rotating ones. The
//! origin's motion vector `v_o` of the paper is not stored: every reconstruction ray starts at a
//! primary hit of its own time, and shrinking retraces each input ray at its own time, so it never
//! enters.
//!
//! `κ` (eq. 2) of a sample is `4 √e` for a surface with a glossy lobe of Blinn exponent `e`
//! (Sec. 2.5's `4 √(1/r)` with PBRT's Blinn roughness `r = 1/e`; a Phong exponent `m` is taken as
//! the Blinn exponent `4m`), 0 for a diffuse one; `angular: false` sets every `κ = 0` (the
//! ablation of Fig. 10).
//!
//! Per-sample buffers (`BufferInfo::layers`): `samples` and `splats` hold `layers` = `spp` records
//! per pixel, `nodes` `2·spp` (a BVH2 over `n` splats has at most `2n − 1` nodes), `primary` one
//! (fixed camera ray) or `spp`.

use glam::{Vec2, Vec3};
use wedge_backends::kernels::hemisphere::{sample_diffuse, Lobe};
use wedge_backends::kernels::indirect::{lobe_mixture, PathParams, LOBE_SELECT};
use wedge_backends::rng::{dim, PixelRng};
use wedge_backends::{BackendError, KernelCtx, KernelParams};

use super::records::LightPrimary;

pub mod reconstruct;
pub mod sample;
pub mod splats;

pub use reconstruct::{LightFieldReconstruct, MAX_RAYS};
pub use sample::LightFieldSample;
pub use splats::LightFieldSplats;

impl LightPrimary {
    fn at(&self) -> Option<Primary> {
        (self.valid != 0).then(|| Primary {
            x: Vec3::from(self.position),
            n: Vec3::from(self.normal),
            kd: Vec3::from(self.kd),
            ks: Vec3::from(self.ks),
            m: self.m,
        })
    }
}

wedge_backends::param_choice! {
    /// `mode`: indirect radiance, or ambient occlusion.
    pub enum Mode { Radiance = "radiance", Ao = "ao" }
}

wedge_backends::kernel_params! {
    /// The estimator both ray-tracing kernels (`light_field.sample`, `.reconstruct`) read; the node
    /// declares them (`brdf`: the shared declaration, `crate::params::brdf`) and forwards them to both.
    pub struct EstimatorParams {
        mode: Mode = choice("radiance", Mode::OPTIONS, "indirect radiance, or ambient occlusion (Sec. 3.3)"),
        max_distance: f32 = float(0.0, 0.0, 1e9, "AO: surfaces farther than this do not occlude (0 = no limit)"),
        bounces: u32 = int(1, 1, 64, "path vertices beyond the primary hit with next-event estimation (1 = one-bounce indirect)"),
        brdf: Lobe,
    }
}

impl EstimatorParams {
    /// The pass's estimator and its path settings (`bounces` and `brdf` as every kernel that traces
    /// indirect paths reads them, `PathParams::from_params`).
    fn read_paths(ctx: &KernelCtx<'_>) -> Result<(EstimatorParams, PathParams), BackendError> {
        let e = EstimatorParams::read(ctx)?;
        let p = PathParams::from_params(ctx, e.mode == Mode::Ao, e.max_distance)?;
        Ok((e, p))
    }
}

wedge_backends::kernel_params! {
    /// The pass's random stream: the graph assigns it to a `.random()` pass (not a node parameter).
    pub struct RandomStream {
        stream: u32,
    }
}

/// A primary hit: point, shading normal (facing the camera ray), `k_d`, `k_s`, `m`.
struct Primary {
    x: Vec3,
    n: Vec3,
    kd: Vec3,
    ks: Vec3,
    m: f32,
}

/// A direction leaving a primary hit (sample `s` of `count`): from its lobe mixture (cosine for AO
/// or a black surface), its 2-D number stratified over the pass's samples (or independent: a
/// reference's `sampling`), and the weight `f cos/pdf` of eq. 3 (1 for AO; 0 for a direction below
/// the surface).
#[allow(clippy::too_many_arguments)]
#[inline]
fn leave(
    p: &Primary,
    wo: Vec3,
    lobe: Lobe,
    ao: bool,
    rng: &PixelRng,
    s: u32,
    count: u32,
    stratified: bool,
) -> (Vec3, Vec3) {
    let u =
        Vec2::from(if stratified { rng.stratified2(s, count.max(1), dim::BSDF) } else { rng.uniform2(s, dim::BSDF) });
    let select = rng.uniform(s, LOBE_SELECT);
    let mix = if ao { None } else { lobe_mixture(p.kd, p.ks, p.m) };
    let Some(mix) = mix else {
        return (sample_diffuse(p.n, u), if ao { Vec3::ONE } else { Vec3::ZERO });
    };
    let wi = mix.sample(lobe, p.m, p.n, wo, u, select);
    let cos_i = wi.dot(p.n);
    if cos_i <= 0.0 {
        return (wi, Vec3::ZERO);
    }
    let v = mix.eval(lobe, p.kd, p.ks, p.m, p.n, wo, wi, cos_i);
    (wi, if v.pdf > 0.0 { v.f * (cos_i / v.pdf) } else { Vec3::ZERO })
}
