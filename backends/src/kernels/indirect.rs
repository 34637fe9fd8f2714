//! `indirect.sample`: Monte Carlo path tracing of *indirect* light at each pixel's surface point
//! (thesis Ch. 4), and `indirect.compose`, which multiplies the textures back in after filtering.
//!
//! Per pixel, two components are sampled separately (thesis Sec. 4.5: "separately for the diffuse
//! and glossy components"), each with its own count:
//! - **diffuse**: cosine-weighted hemisphere rays; a sample's value is the incident indirect radiance
//!   `L_i(ω)` (the Lambertian `k_d/π · cos/pdf` is `k_d`, which multiplies after filtering);
//! - **glossy** (only where the `specular` G-buffer has `k_s > 0` and `m > 0`): Phong-lobe (or
//!   Blinn-Phong half-vector) importance sampling; the value is `L_i · f cos/pdf` without `k_s`.
//!
//! `L_i` is the light reflected at the first hit `y₁` and beyond: next-event estimation toward every
//! area light at each path vertex `y₁ … y_B` (`B = bounces`), continuing by sampling the vertex's
//! BRDF (one-sample mixture of its diffuse and glossy lobes, weight `f cos / pdf_mix`). Emission is
//! never picked up by hemisphere/bounce rays — lights enter only through next-event estimation — so
//! the primary hit's *direct* light is excluded (a direct-light node adds it) and nothing is counted
//! twice. No Russian roulette: paths stop after `B` vertices or on a miss (no environment light).
//!
//! `mode: "ao"`: a hemisphere ray's value is 1 when it hits a reflector (within `max_distance`, when
//! that is > 0) and 0 otherwise — the complement of ambient occlusion (thesis Sec. 4.6).
//!
//! Counts: a fixed `count`, or per pixel from `rays_diffuse` / `rays_glossy` (the adaptive second
//! pass) continuing `previous_diffuse` / `previous_glossy` (`w` = samples already in the mean), so the
//! first-pass samples are reused. First-bounce directions are stratified per pass with correlated
//! multi-jitter (any count) or independent; later bounces and light points use independent numbers
//! from dimensions shifted by `BOUNCE_STRIDE` per bounce. `depth` (optional) gets the first-hit
//! statistics the bandwidth needs: `z_min, z_max` over the hemisphere rays that hit, the number that
//! hit, and the number traced. Non-finite sample values are counted and excluded from the means.

use glam::{Vec2, Vec3};
use wedge_scene::{Scene, SceneAt, SurfacePoint};

use crate::bindings::PutWith;
use crate::kernel::{Counters, Kernel, KernelCtx, Uniforms, WgslSource};
use crate::kernels::direct::RAY_EPSILON;
use crate::kernels::environment::environment_event;
use crate::kernels::hemisphere::{glossy_brdf, glossy_pdf, sample_diffuse, sample_glossy, Lobe};
use crate::kernels::v3;
use crate::params::{KernelParams, Sampling};
use crate::rng::{dim, substream, PixelRng};
use crate::BackendError;

/// Sub-streams of a pass's `stream` per component (`rng::substream`), so each component has its
/// own sequence; mirrored in `shaders/indirect_sample.wgsl`.
pub const COMPONENT_DIFFUSE: u32 = 0;
pub const COMPONENT_GLOSSY: u32 = 1;

/// Dimension offset between lights in next-event estimation (far above any bounce's dimensions).
const LIGHT_DIM_STRIDE: u32 = 1 << 16;
/// Dimension choosing the lobe at a path vertex (within a bounce's stride, unused by `dim`); `pub`
/// for the kernels of `wedge-effects` that draw directions as these paths do (`light_field`).
pub const LOBE_SELECT: u32 = 14;

/// Estimator settings shared by every sample of a pass.
#[derive(Clone, Copy, Debug)]
pub struct PathParams {
    pub bounces: u32,
    pub ao: bool,
    /// AO: hits farther than this count as misses (`≤ 0`: no limit).
    pub max_distance: f32,
    pub lobe: Lobe,
    pub eps: f32,
}

crate::kernel_params! {
    /// The path estimator's two parameters, as every kernel that traces indirect paths reads them
    /// ([`PathParams::from_params`]).
    pub struct EstimatorParams {
        brdf: Lobe,
        /// Path vertices after the first hit (at least 1 is traced).
        bounces: u32,
    }
}

crate::param_choice! {
    /// `indirect.sample`'s `mode`: indirect radiance, or ambient occlusion.
    pub enum SampleMode { Radiance = "radiance", Ao = "ao" }
}

crate::kernel_params! {
    /// `indirect.sample`'s parameters, set by the node that adds the pass. Its WGSL block is the
    /// path estimator's ([`PathParams::uniforms`]) plus `count`, `stratified`, `stream`.
    pub struct SampleParams {
        mode: SampleMode,
        /// Samples per pixel and component where `rays_diffuse` / `rays_glossy` are unbound.
        count: u32,
        sampling: Sampling,
        /// AO: hits farther than this count as misses (0: no limit).
        max_distance: f32,
        /// The pass's random stream (graph-assigned).
        stream: u32,
        brdf: Lobe,
        bounces: u32,
    }
}

impl SampleParams {
    fn path(&self, ctx: &KernelCtx<'_>) -> PathParams {
        PathParams::new(ctx, self.brdf, self.bounces, self.mode == SampleMode::Ao, self.max_distance)
    }
}

impl PathParams {
    /// The estimator settings of a pass: `bounces` (at least 1) and `brdf` (`phong` |
    /// `blinn_phong`) from its parameters, the ray offset from the scene's extent; `ao` and
    /// `max_distance` as the kernel reads them (`indirect.sample`'s `mode`, `paths.trace`'s
    /// optional `ao`). One reading for every kernel that traces indirect paths.
    pub fn from_params(ctx: &KernelCtx<'_>, ao: bool, max_distance: f32) -> Result<PathParams, BackendError> {
        let EstimatorParams { brdf, bounces } = EstimatorParams::read(ctx)?;
        Ok(PathParams::new(ctx, brdf, bounces, ao, max_distance))
    }
    /// The settings from values already read (`bounces` at least 1).
    pub fn new(ctx: &KernelCtx<'_>, lobe: Lobe, bounces: u32, ao: bool, max_distance: f32) -> PathParams {
        PathParams { bounces: bounces.max(1), ao, max_distance, lobe, eps: RAY_EPSILON * ctx.scene.extent() }
    }
    /// The fields `shaders/indirect_path.wgsl` reads from the including kernel's `Params`: `eps`,
    /// `lobe`, `bounces`, `ao`, `max_distance` and the scene's `light_count`.
    pub fn uniforms(&self, u: Uniforms, ctx: &KernelCtx<'_>) -> Uniforms {
        u.f32("eps", self.eps)
            .u32("lobe", (self.lobe == Lobe::BlinnPhong) as u32)
            .u32("bounces", self.bounces)
            .u32("ao", self.ao as u32)
            .f32("max_distance", self.max_distance)
            .u32("light_count", ctx.scene.lights.len() as u32)
    }
}

/// Rays traced by one path, for the counters.
#[derive(Clone, Copy, Debug, Default)]
pub struct PathRays {
    pub secondary: u64,
    pub shadow: u64,
}

/// Relative weight of a lobe for lobe selection (mean of the rgb coefficients).
#[inline]
pub(crate) fn weight_of(c: Vec3) -> f32 {
    (c.x + c.y + c.z) / 3.0
}

/// The one-sample mixture of a surface's lobes (diffuse `k_d`, glossy `k_s`, `m`) a path continues
/// with: the probability `pd` of drawing the diffuse lobe, and whether there is a glossy one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LobeMixture {
    pub pd: f32,
    pub glossy: bool,
}

/// The mixture's BRDF `f = f_d + g` (diffuse and glossy parts) and solid-angle pdf at one direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LobeValue {
    pub f: Vec3,
    pub fd: Vec3,
    pub g: Vec3,
    pub pdf: f32,
}

/// The lobe mixture of a surface, lobes weighted by [`weight_of`]; `None` for a black surface, which
/// scatters nothing. WGSL mirror: `shaders/lobe_mixture.wgsl`.
pub fn lobe_mixture(kd: Vec3, ks: Vec3, m: f32) -> Option<LobeMixture> {
    let glossy = m > 0.0 && ks.max_element() > 0.0;
    let (wd, ws) = (weight_of(kd).max(0.0), if glossy { weight_of(ks).max(0.0) } else { 0.0 });
    (wd + ws > 0.0).then(|| LobeMixture { pd: wd / (wd + ws), glossy })
}

impl LobeMixture {
    /// A direction drawn from the mixture: the diffuse lobe when `select < pd`, else the glossy one,
    /// each from the 2-D number `u`.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn sample(&self, lobe: Lobe, m: f32, n: Vec3, wo: Vec3, u: Vec2, select: f32) -> Vec3 {
        if select < self.pd {
            sample_diffuse(n, u)
        } else {
            sample_glossy(lobe, m, n, wo, u).0
        }
    }
    /// The mixture at direction `wi` with `cos_i = n·wi > 0`: where a direction was drawn, and where
    /// another pixel's direction is re-weighted (radiance filtering's eq. 4.10, seed 002).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn eval(&self, lobe: Lobe, kd: Vec3, ks: Vec3, m: f32, n: Vec3, wo: Vec3, wi: Vec3, cos_i: f32) -> LobeValue {
        let fd = kd * std::f32::consts::FRAC_1_PI;
        let (mut f, mut g) = (fd, Vec3::ZERO);
        let mut pdf = self.pd * cos_i * std::f32::consts::FRAC_1_PI;
        if self.glossy {
            g = ks * glossy_brdf(lobe, m, n, wo, wi);
            f += g;
            pdf += (1.0 - self.pd) * glossy_pdf(lobe, m, n, wo, wi);
        }
        LobeValue { f, fd, g, pdf }
    }
}

/// The random numbers of a path's continuation at vertex `bounce` (0 = the first vertex): the 2-D
/// direction sample and the lobe choice.
#[inline]
pub fn continuation_numbers(rng: &PixelRng, sample: u32, bounce: u32) -> (Vec2, f32) {
    let u = Vec2::from(rng.uniform2(sample, dim::BSDF + bounce * dim::BOUNCE_STRIDE));
    (u, rng.uniform(sample, LOBE_SELECT + bounce * dim::BOUNCE_STRIDE))
}

/// A path vertex as the estimators shade it: its point `x`, shading normal `n`, the direction `wo`
/// back along the path, and its material's lobes — diffuse albedo `k_d` (textured), Phong `k_s` and
/// exponent `m`. One value for next-event estimation, the lobe mixture a path continues with and the
/// shared sampler's estimators (`paths.trace`), rather than six arguments passed down each call.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vertex {
    pub x: Vec3,
    pub n: Vec3,
    pub wo: Vec3,
    pub kd: Vec3,
    pub ks: Vec3,
    pub m: f32,
}

impl Vertex {
    /// The vertex where a ray travelling along `dir` meets surface `sp` of `scene`.
    #[inline]
    pub fn on(scene: &Scene, sp: &SurfacePoint, dir: Vec3) -> Vertex {
        let mat = &scene.materials[sp.material as usize];
        let (kd, ks, m) = (scene.albedo(sp), mat.specular, mat.phong_exponent);
        Vertex { x: sp.position, n: sp.shading_normal, wo: -dir, kd, ks, m }
    }
    /// Whether its material has a glossy lobe (`m > 0` and `k_s` not black).
    #[inline]
    pub fn glossy(&self) -> bool {
        self.m > 0.0 && self.ks.max_element() > 0.0
    }
    /// Its BRDF for light arriving along `wi`: `k_d/π + k_s ρ_s`.
    #[inline]
    pub fn brdf(&self, lobe: Lobe, wi: Vec3) -> Vec3 {
        let mut f = self.kd * std::f32::consts::FRAC_1_PI;
        if self.glossy() {
            f += self.ks * glossy_brdf(lobe, self.m, self.n, self.wo, wi);
        }
        f
    }
    /// Its lobe mixture ([`lobe_mixture`]).
    #[inline]
    pub fn mixture(&self) -> Option<LobeMixture> {
        lobe_mixture(self.kd, self.ks, self.m)
    }
}

/// Next-event estimation at path vertex `v`: one uniform area sample per light, and one environment
/// table look-up where the scene has a map ([`environment_event`]). Its value, and the part of it the
/// area lights send through the vertex's glossy lobe (`k_s ρ_s`), which the caustic paths of
/// `pixel_filter.sample` follow (environment light is left out of that part).
#[inline]
pub fn next_event(
    scene: &SceneAt<'_>,
    p: &PathParams,
    v: &Vertex,
    rng: &PixelRng,
    sample: u32,
    bounce: u32,
    rays: &mut PathRays,
) -> (Vec3, Vec3) {
    let mut sum = Vec3::ZERO;
    let mut glossy_sum = Vec3::ZERO;
    for l in 0..scene.scene().lights.len() {
        if let Some((value, glossy)) = light_event(scene, p, l, v, rng, sample, bounce, rays) {
            sum += value;
            glossy_sum += glossy;
        }
    }
    // The environment is a light too (thesis Ch. 6: it lights the reflectors of E^ind).
    (sum + environment_event(scene, p, v, rng, sample, bounce, &mut rays.shadow), glossy_sum)
}

/// Next-event estimation toward area light `l` alone: one uniform sample of it and its shadow ray;
/// the light it sends off the vertex and the part through the glossy lobe, `None` where the sample
/// faces away or is blocked. [`next_event`] sums it over the lights (a light's dimensions are
/// its own, so one light's estimate is the same alone or among the others).
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn light_event(
    scene: &SceneAt<'_>,
    p: &PathParams,
    l: usize,
    v: &Vertex,
    rng: &PixelRng,
    sample: u32,
    bounce: u32,
    rays: &mut PathRays,
) -> Option<(Vec3, Vec3)> {
    let Vertex { x: y, n, wo, kd, ks, m } = *v;
    let light = scene.light(l);
    let d = dim::LIGHT + bounce * dim::BOUNCE_STRIDE + l as u32 * LIGHT_DIM_STRIDE;
    let target = light.sample_point(Vec2::from(rng.uniform2(sample, d)));
    let to = target - y;
    let r2 = to.length_squared();
    if r2 <= 0.0 {
        return None;
    }
    let dir = to / r2.sqrt();
    let cos_y = n.dot(dir);
    let cos_l = light.facing_cos(light.normal(), dir);
    if cos_y <= 0.0 || cos_l <= 0.0 {
        return None;
    }
    let origin = y + n * p.eps;
    let seg = target - origin;
    let seg_len = seg.length();
    rays.shadow += 1;
    if scene.occluded(origin, seg / seg_len, 0.0, seg_len * (1.0 - 1e-4)) {
        return None;
    }
    let mut f = kd * std::f32::consts::FRAC_1_PI;
    let geometry = cos_y * cos_l / r2 * light.area();
    let mut glossy = Vec3::ZERO;
    if v.glossy() {
        let g = ks * glossy_brdf(p.lobe, m, n, wo, dir);
        f += g;
        glossy = light.radiance * g * geometry;
    }
    Some((light.radiance * f * geometry, glossy))
}

/// Trace one path leaving `x` (normal `n`) in direction `wi`. Returns the incident indirect radiance
/// along `wi` (AO: 1 or 0) and the distance to the first hit, if any. (The WGSL `trace_path` takes
/// the same point, direction, RNG key and sample; scene, settings and counters are globals there.)
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn trace_path(
    scene: &SceneAt<'_>,
    p: &PathParams,
    x: Vec3,
    n: Vec3,
    wi: Vec3,
    rng: &PixelRng,
    sample: u32,
    rays: &mut PathRays,
) -> (Vec3, Option<f32>) {
    let (radiance, _, first) = trace_path_split(scene, p, x, n, wi, rng, sample, rays);
    (radiance, first)
}

/// [`trace_path`] (its radiance, bit for bit) and the part of it that reached `x` through glossy
/// scattering only: at every vertex the area lights' glossy part of next-event estimation
/// ([`next_event`]) times the product of the earlier vertices' glossy parts `k_s ρ_s cos/pdf`
/// (the light of `L S+` paths; seed 002 Sec. 3.3's "caustic paths" for Phong surfaces, see
/// docs/DESIGN-NOTES.md). AO: no caustic part.
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn trace_path_split(
    scene: &SceneAt<'_>,
    p: &PathParams,
    x: Vec3,
    n: Vec3,
    wi: Vec3,
    rng: &PixelRng,
    sample: u32,
    rays: &mut PathRays,
) -> (Vec3, Vec3, Option<f32>) {
    let side = if wi.dot(n) >= 0.0 { 1.0 } else { -1.0 };
    let origin = x + n * (side * p.eps);
    let dir = wi;
    rays.secondary += 1;
    let Some(hit) = scene.intersect(origin, dir, 0.0, f32::INFINITY) else {
        return (Vec3::ZERO, Vec3::ZERO, None);
    };
    let first = hit.t;
    if p.ao {
        // Reflectors beyond `max_distance` return 0: for AO they are not reflectors (nor in z stats).
        let inside = p.max_distance <= 0.0 || first <= p.max_distance;
        return if inside { (Vec3::ONE, Vec3::ZERO, Some(first)) } else { (Vec3::ZERO, Vec3::ZERO, None) };
    }
    let (radiance, caustic) = path_from_hit(scene, p, hit, origin, dir, rng, sample, rays);
    (radiance, caustic, Some(first))
}

/// The radiance a path brings back from its first hit `hit` (of the ray `origin + t·dir`) toward
/// the ray's origin: next-event estimation at each of `p.bounces` vertices, continued by the
/// vertex's lobe mixture — [`trace_path_split`]'s radiance and caustic part after its first ray
/// (which the light-field sampler traces itself, to keep the hit as a sample).
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn path_from_hit(
    scene: &SceneAt<'_>,
    p: &PathParams,
    mut hit: wedge_scene::Hit,
    mut origin: Vec3,
    mut dir: Vec3,
    rng: &PixelRng,
    sample: u32,
    rays: &mut PathRays,
) -> (Vec3, Vec3) {
    let mut radiance = Vec3::ZERO;
    let mut throughput = Vec3::ONE;
    let mut caustic = Vec3::ZERO;
    let mut caustic_throughput = Vec3::ONE;
    for bounce in 1..=p.bounces {
        let v = Vertex::on(scene.scene(), &scene.surface(&hit, origin, dir), dir);
        let Vertex { x: y, n: ny, wo, kd, ks, m } = v;
        let (event, glossy_event) = next_event(scene, p, &v, rng, sample, bounce, rays);
        radiance += throughput * event;
        caustic += caustic_throughput * glossy_event;
        if bounce == p.bounces {
            break;
        }
        // Continue: one-sample mixture of the vertex's lobes.
        let Some(mix) = v.mixture() else {
            break;
        };
        let (u, select) = continuation_numbers(rng, sample, bounce);
        let next = mix.sample(p.lobe, m, ny, wo, u, select);
        let cos_i = next.dot(ny);
        if cos_i <= 0.0 {
            break;
        }
        let v = mix.eval(p.lobe, kd, ks, m, ny, wo, next, cos_i);
        if v.pdf <= 0.0 {
            break;
        }
        throughput *= v.f * (cos_i / v.pdf);
        caustic_throughput *= v.g * (cos_i / v.pdf);
        origin = y + ny * p.eps;
        dir = next;
        rays.secondary += 1;
        match scene.intersect(origin, dir, 0.0, f32::INFINITY) {
            Some(h) => hit = h,
            None => break,
        }
    }
    (radiance, caustic)
}

pub struct IndirectSample;

/// Running mean of one component: rgb mean and the number of samples in it.
fn continue_mean(prev: [f32; 4], sum: Vec3, valid: u32) -> [f32; 4] {
    let total = prev[3] + valid as f32;
    let mean = if total > 0.0 { (Vec3::new(prev[0], prev[1], prev[2]) * prev[3] + sum) / total } else { Vec3::ZERO };
    [mean.x, mean.y, mean.z, total]
}

crate::kernel_bindings! {
    /// What an `indirect.sample` pass binds.
    pub struct SampleIo / SampleData {
        read position: [f32; 4],
        read normal: [f32; 4],
        /// k_s rgb, w = Phong exponent m (from Primary); absent = no glossy component.
        read_opt specular: [f32; 4],
        /// Per-pixel total sample counts (including `previous_*`'s); else `count`.
        read_opt rays_diffuse: u32,
        read_opt rays_glossy: u32,
        read_opt previous_diffuse: [f32; 4],
        read_opt previous_glossy: [f32; 4],
        /// rgb mean, w = samples in the mean.
        write diffuse: [f32; 4],
        write_opt glossy: [f32; 4],
        /// z_min, z_max, hemisphere rays that hit, hemisphere rays traced (this pass).
        write_opt depth: [f32; 4],
    }
}

impl Kernel for IndirectSample {
    crate::kernel_signature!(
        name: "indirect.sample", class: Sampling, bindings: SampleIo, params: [SampleParams], random: true
    );
    /// WGSL mirror: `shaders/indirect_sample.wgsl` with the sampling of `shaders/hemisphere.wgsl`.
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/indirect_sample.wgsl"), |ctx| {
                let s = SampleParams::read(ctx)?;
                let u = Uniforms::new()
                    .vec3("camera", ctx.scene.camera.position.to_array())
                    .u32("count", s.count)
                    .u32("stratified", (s.sampling == Sampling::Stratified) as u32)
                    .u32("stream", s.stream);
                Ok(s.path(ctx).uniforms(u, ctx))
            })
            .with_include("hemisphere.wgsl", include_str!("../../../shaders/hemisphere.wgsl"))
            .with_scene()
            .per_pixel()
            .chunked(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let scene = ctx.scene;
        let io = SampleIo::read(ctx)?;
        let (position, normal, specular) = (io.position, io.normal, io.specular);
        let (rays_d, rays_g, prev_d, prev_g) =
            (io.rays_diffuse, io.rays_glossy, io.previous_diffuse, io.previous_glossy);
        let s = SampleParams::read(ctx)?;
        let (count, stream, stratified) = (s.count, s.stream, s.sampling == Sampling::Stratified);
        let p = s.path(ctx);
        let ao = p.ao;
        let want_glossy = io.glossy.is_some() && specular.is_some() && !ao;
        let (seed, width, window) = (ctx.seed, ctx.width, ctx.window);
        let camera = scene.camera.position;
        // A Ch. 4 kernel: the scene at the shutter's centre.
        let at = scene.at(0.0);

        struct Px {
            d: [f32; 4],
            g: [f32; 4],
            depth: [f32; 4],
            rays: PathRays,
            bad: u64,
        }
        let results = ctx.map_pixels(true, |px, py| {
            let i = (py * width + px) as usize;
            let pd = prev_d.map_or([0.0; 4], |b| b[i]);
            let pg = prev_g.map_or([0.0; 4], |b| b[i]);
            let mut out = Px { d: pd, g: pg, depth: [0.0; 4], rays: PathRays::default(), bad: 0 };
            if position[i][3] == 0.0 {
                return out;
            }
            let x = v3(position[i]);
            let n = v3(normal[i]);
            let wo = (camera - x).normalize_or_zero();
            let (ks, m) = specular.map_or((Vec3::ZERO, 0.0), |s| (v3(s[i]), s[i][3]));
            let glossy = want_glossy && m > 0.0 && ks.max_element() > 0.0;
            let (mut z_min, mut z_max, mut hits, mut traced) = (f32::INFINITY, 0.0f32, 0u32, 0u32);
            // One component's `extra` paths, each leaving in the direction `direction(u)` draws with
            // its weight (0: none traced), on the component's own sub-stream (keyed by the full
            // image's pixel, so a tile draws what the whole image draws there); their mean
            // continues `previous`.
            let mut component = |sub: u32, extra: u32, previous: [f32; 4], direction: &dyn Fn(Vec2) -> (Vec3, f32)| {
                let rng = PixelRng::new(seed, window.pixel_id(px, py), substream(stream, sub));
                let (mut sum, mut valid) = (Vec3::ZERO, 0u32);
                for s in 0..extra {
                    let u = if stratified { rng.stratified2(s, extra, dim::BSDF) } else { rng.uniform2(s, dim::BSDF) };
                    let (wi, w) = direction(Vec2::from(u));
                    let v = if w > 0.0 {
                        let (v, t) = trace_path(&at, &p, x, n, wi, &rng, s, &mut out.rays);
                        traced += 1;
                        if let Some(t) = t {
                            hits += 1;
                            z_min = z_min.min(t);
                            z_max = z_max.max(t);
                        }
                        v * w
                    } else {
                        Vec3::ZERO
                    };
                    if v.is_finite() {
                        sum += v;
                        valid += 1;
                    } else {
                        out.bad += 1;
                    }
                }
                continue_mean(previous, sum, valid)
            };
            let extra = |rays: Option<&[u32]>, previous: [f32; 4]| {
                rays.map_or(count, |r| r[i]).saturating_sub(previous[3] as u32)
            };
            let d = component(COMPONENT_DIFFUSE, extra(rays_d, pd), pd, &|u| (sample_diffuse(n, u), 1.0));
            let g = glossy
                .then(|| component(COMPONENT_GLOSSY, extra(rays_g, pg), pg, &|u| sample_glossy(p.lobe, m, n, wo, u)));
            (out.d, out.g) = (d, g.unwrap_or(pg));
            if hits == 0 {
                z_min = 0.0;
            }
            out.depth = [z_min, z_max, hits as f32, traced as f32];
            out
        });
        let secondary: u64 = results.iter().map(|r| r.rays.secondary).sum();
        let shadow: u64 = results.iter().map(|r| r.rays.shadow).sum();
        let bad: u64 = results.iter().map(|r| r.bad).sum();
        Counters::add(&ctx.counters.secondary_rays, secondary);
        Counters::add(&ctx.counters.shadow_rays, shadow);
        Counters::add(&ctx.counters.non_finite_samples, bad);
        io.depth.put_with(ctx, || results.iter().map(|r| r.depth).collect())?;
        io.glossy.put_with(ctx, || results.iter().map(|r| r.g).collect())?;
        io.diffuse.put(ctx, results.into_iter().map(|r| r.d).collect())
    }
}

/// `indirect.compose`: `out = diffuse·k_d + glossy·k_s + direct·k_d + emission` — the textures
/// multiply after filtering (thesis Sec. 4.5). Every input but `diffuse` is optional (absent `k_d`
/// is white, absent `k_s` zero).
pub struct IndirectCompose;

crate::kernel_bindings! {
    /// What an `indirect.compose` pass binds.
    pub struct ComposeIo / ComposeData {
        read diffuse: [f32; 4],
        read_opt glossy: [f32; 4],
        read_opt direct: [f32; 4],
        read_opt albedo: [f32; 3],
        read_opt specular: [f32; 4],
        read_opt emission: [f32; 3],
        write out: [f32; 3],
    }
}

impl Kernel for IndirectCompose {
    crate::kernel_signature!(name: "indirect.compose", class: Compose, bindings: ComposeIo);
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/indirect_compose.wgsl"), |_| Ok(Uniforms::new()))
                .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let ComposeData { diffuse, glossy, direct, albedo, specular, emission, out: composed } = ComposeIo::read(ctx)?;
        let out = (0..ctx.pixels())
            .map(|i| {
                let kd = albedo.map_or([1.0; 3], |a| a[i]);
                let ks = specular.map_or([0.0; 4], |s| s[i]);
                std::array::from_fn(|c| {
                    let mut v = diffuse[i][c] * kd[c];
                    if let Some(g) = glossy {
                        v += g[i][c] * ks[c];
                    }
                    if let Some(d) = direct {
                        v += d[i][c] * kd[c];
                    }
                    if let Some(e) = emission {
                        v += e[i][c];
                    }
                    v
                })
            })
            .collect::<Vec<[f32; 3]>>();
        composed.put(ctx, out)
    }
}
