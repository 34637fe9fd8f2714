//! `direct.light`: Monte Carlo direct illumination from area lights at each pixel's surface point,
//! with the per-pixel occluder statistics soft-shadow filtering needs.
//!
//! Estimator (unbiased, per sample exact): for `y` uniform on the light (pdf `1/A`),
//! `L_e · V(x,y) · cos θ_x · cos θ_y / |x−y|² · A / π` — diffuse radiance for unit albedo; the albedo
//! (texture) multiplies after filtering. With `form_factor: "light_centre"` the geometric term is taken
//! at the light centre instead (thesis eq. 3.1's `r(x)`), so only visibility is sampled.
//!
//! Counts: a fixed `count`, or per pixel from `rays_per_pixel` (the adaptive second pass), continuing
//! an earlier estimate `previous` (its `w` = samples already taken) so the first-pass samples are reused.
//! Samples are stratified per pass with correlated multi-jitter over any count, or independent.
//! Non-finite sample values are counted and excluded from the mean. Random numbers: the pass's
//! graph-assigned `stream`, sub-stream per light `substream(stream, light)` (hashed; see `rng.rs`).

use glam::{Vec2, Vec3};
use rayon::prelude::*;
use wedge_scene::{Hit, PreparedLight, SceneAt};

use crate::bindings::PutWith;
use crate::kernel::{optional_rows, Counters, Kernel, KernelCtx, WgslSource};
use crate::kernels::v3;
use crate::params::{AnyLight, KernelParams, Sampling};
use crate::rng::{dim, substream, PixelRng};
use crate::BackendError;

crate::kernel_bindings! {
    /// What a `direct.light` pass binds.
    pub struct DirectIo / DirectData {
        read position: [f32; 4],
        read normal: [f32; 4],
        /// Per-pixel total sample count (including `previous`'s); else the `count` parameter.
        read_opt rays_per_pixel: u32,
        /// Earlier estimate to continue: rgb mean, w = samples in it.
        read_opt previous: [f32; 4],
        /// rgb mean of all samples so far, w = number of samples in the mean.
        write estimate: [f32; 4],
        /// d1, d2_min, d2_max, number of occluded samples (see [`OccluderStats`]).
        write_opt occlusion: [f32; 4],
    }
}

pub struct DirectLight;

/// Offset of shadow-ray origins along the normal, relative to the scene extent.
pub const RAY_EPSILON: f32 = 1e-4;

/// Occluder statistics of one pixel over its first-pass samples (thesis eq. 3.4 inputs). Distances
/// are measured perpendicular to the light plane, the `x`/`y` parameterisation of Sec. 3.3.
#[derive(Clone, Copy, Debug, Default)]
pub struct OccluderStats {
    pub d1: f32,
    pub d2_min: f32,
    pub d2_max: f32,
    pub occluded: u32,
}

/// Where a shadow ray was blocked (closest occluder from the receiver): its distance to the light
/// plane (thesis Sec. 3.3's `d2`), and the hit on the ray `origin + t·dir` (for its velocity under
/// motion blur).
#[derive(Clone, Copy, Debug)]
pub struct Occluder {
    pub distance: f32,
    pub hit: Hit,
    pub origin: Vec3,
    pub dir: Vec3,
}

/// One sample of direct light (see [`light_sample`]).
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// The sample's value before albedo: `unshadowed` where the light is visible, else 0.
    pub value: Vec3,
    /// The same sample without its shadow ray's verdict (0 where the light faces away or lies
    /// below the horizon): the denominator of the ratio estimator of visibility SoftShadows
    /// filters (`docs/DESIGN-NOTES.md` "SoftShadows after the suite").
    pub unshadowed: Vec3,
    /// Where occluded and the distance was wanted: the occluder.
    pub occluder: Option<Occluder>,
}

/// One sample of direct light toward `light` (as it is at the scene's time) from point `x` with
/// normal `n`: the value (before albedo), the same without visibility, and, when occluded and
/// `want_distance`, the occluder. The light comes prepared ([`PreparedLight`]): its normal, area
/// and centre are the same for every sample, so they are computed once, not per sample.
#[inline]
pub fn light_sample(
    scene: &SceneAt<'_>,
    light: &PreparedLight,
    x: Vec3,
    n: Vec3,
    u: Vec2,
    centre_factor: Option<Vec3>,
    want_distance: bool,
) -> LightSample {
    let none = LightSample { value: Vec3::ZERO, unshadowed: Vec3::ZERO, occluder: None };
    let origin = shadow_origin(scene, x, n);
    shadow_ray(light, x, n, origin, u, centre_factor).map_or(none, |ray| ray.trace(scene, light, want_distance))
}

/// Where the shadow rays from `x` (normal `n`) start: off the surface, by [`RAY_EPSILON`] of the
/// scene's extent. The same for every sample of a point, so callers with many take it once.
#[inline]
pub fn shadow_origin(scene: &SceneAt<'_>, x: Vec3, n: Vec3) -> Vec3 {
    x + n * (RAY_EPSILON * scene.scene().extent())
}

/// A light sample's shadow ray, before it is traced: the first half of [`light_sample`], apart so
/// that a pixel's rays can be made in one loop and traced in the next (independent iterations the
/// processor overlaps, where one sample at a time waited on each square root and division).
#[derive(Clone, Copy, Debug, Default)]
pub struct ShadowRay {
    /// The sample's value if the light is visible (before albedo).
    pub unshadowed: Vec3,
    pub origin: Vec3,
    pub dir: Vec3,
    pub tmax: f32,
}

/// The shadow ray of the sample at `u` on `light` from `x` (normal `n`, rays starting at `origin`,
/// [`shadow_origin`]), or `None` where the light faces away or lies below the horizon (value 0).
#[inline]
pub fn shadow_ray(
    light: &PreparedLight,
    x: Vec3,
    n: Vec3,
    origin: Vec3,
    u: Vec2,
    centre_factor: Option<Vec3>,
) -> Option<ShadowRay> {
    let y = light.sample_point(u);
    let to = y - x;
    let r2 = to.length_squared();
    let dir = to / r2.sqrt();
    let cos_x = n.dot(dir);
    let cos_y = light.facing_cos(light.normal, dir);
    if cos_x <= 0.0 || cos_y <= 0.0 {
        return None;
    }
    let unshadowed = match centre_factor {
        Some(f) => f,
        None => light.radiance * (cos_x * cos_y / r2 * light.area / std::f32::consts::PI),
    };
    // The shadow ray aims at `y` from its offset origin, stopping just short of the light so the
    // light's own triangles never count as occluders.
    let seg = y - origin;
    let seg_len = seg.length();
    Some(ShadowRay { unshadowed, origin, dir: seg / seg_len, tmax: seg_len * (1.0 - 1e-4) })
}

impl ShadowRay {
    /// Trace the ray: the sample's value (`unshadowed` where nothing blocks it), and where blocked
    /// and `want_distance`, the occluder.
    #[inline]
    pub fn trace(&self, scene: &SceneAt<'_>, light: &PreparedLight, want_distance: bool) -> LightSample {
        let ShadowRay { unshadowed, origin, dir, tmax } = *self;
        let mut out = LightSample { value: Vec3::ZERO, unshadowed, occluder: None };
        if want_distance {
            if let Some(hit) = scene.intersect(origin, dir, 0.0, tmax) {
                let p = origin + dir * hit.t;
                let distance = (light.centre - p).dot(light.normal).abs();
                out.occluder = Some(Occluder { distance, hit, origin, dir });
                return out;
            }
        } else if scene.occluded(origin, dir, 0.0, tmax) {
            return out;
        }
        out.value = unshadowed;
        out
    }
}

/// Shadow rays made per batch by [`light_samples`]: enough independent work to hide the latency of
/// each ray's square roots and divisions, small enough for the stack.
const BATCH: usize = 16;

/// [`light_sample`] for samples `0..count` of one point, the sample points `draw(s)`, handing each
/// result to `each` in sample order: the rays of a batch are made first, then traced (the same numbers
/// as one [`light_sample`] per sample; measured in docs/DESIGN-NOTES.md "Passes at the rate of their rays").
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn light_samples(
    scene: &SceneAt<'_>,
    light: &PreparedLight,
    (x, n): (Vec3, Vec3),
    centre_factor: Option<Vec3>,
    want_distance: bool,
    count: u32,
    draw: impl Fn(u32) -> Vec2,
    mut each: impl FnMut(LightSample),
) {
    let origin = shadow_origin(scene, x, n);
    let none = LightSample { value: Vec3::ZERO, unshadowed: Vec3::ZERO, occluder: None };
    let mut rays = [None::<ShadowRay>; BATCH];
    for first in (0..count).step_by(BATCH) {
        let batch = &mut rays[..(count - first).min(BATCH as u32) as usize];
        for (s, ray) in (first..).zip(batch.iter_mut()) {
            *ray = shadow_ray(light, x, n, origin, draw(s), centre_factor);
        }
        for ray in batch.iter() {
            each(ray.map_or(none, |r| r.trace(scene, light, want_distance)));
        }
    }
}

/// Unoccluded diffuse radiance (unit albedo) with the geometry evaluated at the light centre: the
/// thesis's `r(x)` (eq. 3.1).
pub fn light_centre_factor(light: &PreparedLight, x: Vec3, n: Vec3) -> Vec3 {
    let to = light.centre - x;
    let r2 = to.length_squared();
    let dir = to / r2.sqrt();
    let cos_x = n.dot(dir).max(0.0);
    let cos_y = light.normal.dot(-dir);
    let cos_y = if light.two_sided { cos_y.abs() } else { cos_y.max(0.0) };
    light.radiance * (cos_x * cos_y / r2 * light.area / std::f32::consts::PI)
}

crate::param_choice! {
    /// The geometry term of a light sample: evaluated per sample (`exact`, unbiased) or the thesis's
    /// light-centre form factor `f_c` (`light_centre`). WGSL: `params.form_factor`, 1 = light centre.
    pub enum FormFactor { Exact = "exact", LightCentre = "light_centre" }
}

crate::kernel_params! {
    /// `direct.light`'s parameters, all set by the node that adds the pass (WGSL: `params.NAME`,
    /// plus the scene's `extent` and `light_count`).
    pub struct DirectParams {
        /// One area light, or every light (negative).
        light: AnyLight,
        /// Samples per pixel where `rays_per_pixel` is unbound.
        count: u32,
        sampling: Sampling,
        form_factor: FormFactor,
        /// The pass's random stream (graph-assigned).
        stream: u32,
    }
}

impl Kernel for DirectLight {
    crate::kernel_signature!(
        name: "direct.light", class: Sampling, bindings: DirectIo, params: [DirectParams], random: true
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/direct_light.wgsl"), |ctx| {
                Ok(DirectParams::read(ctx)?
                    .uniforms()
                    .f32("extent", ctx.scene.extent())
                    .u32("light_count", ctx.scene.lights.len() as u32))
            })
            .with_scene()
            .per_pixel()
            .chunked(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let scene = ctx.scene;
        let io = DirectIo::read(ctx)?;
        let (position, normal, rpp, previous) = (io.position, io.normal, io.rays_per_pixel, io.previous);
        let DirectParams { light, count, sampling, form_factor, stream } = DirectParams::read(ctx)?;
        let lights = light.lights(scene.lights.len());
        let stratified = sampling == Sampling::Stratified;
        let centre = form_factor == FormFactor::LightCentre;
        let want_stats = io.occlusion.is_some();
        let seed = ctx.seed;
        let width = ctx.width;
        let counters = ctx.counters;
        let window = ctx.window;
        // A Ch. 3 kernel: the scene at the shutter's centre.
        let at = scene.at(0.0);
        // Each light's per-sample constants once per pass, not per pixel.
        let prepared: Vec<(usize, PreparedLight)> = lights.iter().map(|&l| (l, at.light(l).prepare())).collect();

        let pixel = |px: u32, py: u32| {
            let i = (py * width + px) as usize;
            let prev = previous.map_or([0.0; 4], |p| p[i]);
            if position[i][3] == 0.0 {
                return (prev, [0.0; 4], 0u64, 0u64);
            }
            let x = v3(position[i]);
            let n = v3(normal[i]);
            let target = rpp.map_or(count, |r| r[i]);
            let done = prev[3] as u32;
            let extra = target.saturating_sub(done);
            let mut sum = Vec3::ZERO;
            let mut valid = 0u32;
            let mut bad = 0u64;
            let mut stats = OccluderStats { d2_min: f32::INFINITY, ..Default::default() };
            for (l, light) in &prepared {
                let l = *l;
                if want_stats {
                    stats.d1 = (light.centre - x).dot(light.normal).abs();
                }
                // Keyed by the full image's pixel, so a tile draws what the whole image draws there.
                let rng = PixelRng::new(seed, window.pixel_id(px, py), substream(stream, l as u32));
                let factor = centre.then(|| light_centre_factor(light, x, n));
                let draw = |s| {
                    Vec2::from(if stratified {
                        rng.stratified2(s, extra, dim::LIGHT)
                    } else {
                        rng.uniform2(s, dim::LIGHT)
                    })
                };
                light_samples(&at, light, (x, n), factor, want_stats, extra, draw, |ls| {
                    let v = ls.value;
                    if let Some(d2) = ls.occluder.map(|o| o.distance) {
                        stats.occluded += 1;
                        stats.d2_min = stats.d2_min.min(d2);
                        stats.d2_max = stats.d2_max.max(d2);
                    }
                    if v.is_finite() {
                        sum += v;
                        valid += 1;
                    } else {
                        bad += 1;
                    }
                });
            }
            // With several lights, each light gets `extra` samples and the estimates add.
            let per_light = valid as f32 / lights.len().max(1) as f32;
            let total = prev[3] + per_light;
            let mean =
                if total > 0.0 { (Vec3::new(prev[0], prev[1], prev[2]) * prev[3] + sum) / total } else { Vec3::ZERO };
            if stats.occluded == 0 {
                stats.d2_min = 0.0;
            }
            let occ = [stats.d1, stats.d2_min, stats.d2_max, stats.occluded as f32];
            ([mean.x, mean.y, mean.z, total], occ, (extra as u64) * lights.len() as u64, bad)
        };
        // Outputs written in place, row by row (recycled storage of a persistent pool, issue 38 §2);
        // the ray and non-finite counts are summed per row, exact in any order.
        let mut estimate = io.estimate.storage(ctx)?;
        let mut occlusion = io.occlusion.storage(ctx)?;
        // (`max(1)`: chunks of an empty image's empty buffers.)
        let row = (width as usize).max(1);
        let occlusion_rows = optional_rows(occlusion.as_mut(), row, ctx.height as usize);
        let progress = ctx.progress;
        progress.begin(ctx.pass, ctx.height as u64);
        let (rays, bad) = estimate
            .par_chunks_mut(row)
            .zip(occlusion_rows)
            .enumerate()
            .map(|(y, (est, mut occ))| {
                let mut sums = (0u64, 0u64);
                for (x, e) in est.iter_mut().enumerate() {
                    let (mean, stats, rays, bad) = pixel(x as u32, y as u32);
                    *e = mean;
                    if let Some(o) = occ.as_mut() {
                        o[x] = stats;
                    }
                    sums = (sums.0 + rays, sums.1 + bad);
                }
                progress.advance(1);
                sums
            })
            .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
        progress.end();
        Counters::add(&counters.shadow_rays, rays);
        Counters::add(&counters.non_finite_samples, bad);
        io.occlusion.put_some(ctx, occlusion)?;
        io.estimate.put(ctx, estimate)
    }
}
