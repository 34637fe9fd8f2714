//! Light-field reconstruction of indirect light and ambient occlusion (issue 17; Lehtinen, Aila,
//! Laine, Durand 2012, `seeds/001_2d3ed232e6777e89.txt`): the kernels of the `LightField` node
//! (`wedge_effects::light_field`). A very different reconstruction from the axis-aligned filters:
//! the input rays themselves become a point-sampled scene that many reconstruction rays query.
//!
//! - `light_field.sample` (random, reference role `Sample`): per pixel `count` camera paths of one
//!   secondary ray each (Sec. 2.1: each input sample is one secondary ray of a path). Each path's
//!   camera ray goes through the pixel centre, through its own lens point (`aperture_radius`,
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
use wedge_graph::Format;
use wedge_scene::{Camera, LensRay, LensShape, SceneAt};

use crate::kernel::{Binding, Counters, Kernel, KernelClass, KernelCtx, Reach, Uniforms, WgslSource};
use crate::kernels::direct::RAY_EPSILON;
use crate::kernels::hemisphere::{sample_diffuse, Lobe};
use crate::kernels::indirect::{lobe_mixture, path_from_hit, PathParams, PathRays, LOBE_SELECT};
use crate::kernels::paths::{camera_uniforms, pass_camera};
use crate::record;
use crate::rng::{dim, substream, PixelRng};
use crate::BackendError;

pub mod reconstruct;
pub mod splats;

pub use reconstruct::STACK_SIZE;

/// `flags` of a [`LightSample`]: no sample (the camera ray left the scene, or past `count`).
pub const SAMPLE_NONE: u32 = 0;
/// A secondary ray that hit a surface: a splat.
pub const SAMPLE_HIT: u32 = 1;
/// A secondary ray that left the scene: no splat, but shrinking retraces it to infinity.
pub const SAMPLE_ESCAPED: u32 = 2;

record! {
    /// One stored input sample (24 words; Sec. 2.1's tuple without the origin's motion vector, see
    /// the module doc): `origin` is where the ray started (the primary hit, offset along its
    /// normal), `distance` the ray parameter of `hit` (unit `direction`), `time` the path's shutter
    /// time in [−1, 1] (0 without motion), `velocity` the hit's world velocity per unit time, `lens`
    /// the camera ray's point on the unit lens disk (0 for a pinhole).
    pub struct LightSample / LIGHT_SAMPLE {
        origin: vec3,
        flags: u32,
        hit: vec3,
        distance: f32,
        normal: vec3,
        kappa: f32,
        direction: vec3,
        time: f32,
        radiance: vec3,
        velocity: vec3,
        lens: vec2,
    }
}

record! {
    /// One splat (20 words): a disk of `radius` at `centre` (a hit point, where it is at `time`) on
    /// the plane of `normal`, moving with `velocity` (world units per unit time), with its sample's
    /// `κ`, direction and radiance; `sample` = its input sample's index (`pixel·spp + s`), `flags` = 1
    /// for a splat, 0 for an unused slot.
    pub struct Splat / SPLAT {
        centre: vec3,
        radius: f32,
        normal: vec3,
        kappa: f32,
        direction: vec3,
        sample: u32,
        radiance: vec3,
        flags: u32,
        velocity: vec3,
        time: f32,
    }
}

impl Splat {
    /// Where the splat's centre is at time `t`: `h + v_h (t − t_i)` (exactly `h` for a still one).
    #[inline]
    pub fn centre_at(&self, t: f32) -> Vec3 {
        Vec3::from(self.centre) + Vec3::from(self.velocity) * (t - self.time)
    }
}

record! {
    /// One node of the splat BVH2 (8 words, obvhs's `Bvh2Node` layout): `count == 0` = inner node
    /// with children at `index` and `index + 1`; else a leaf of splats `index..index + count`. Node 0
    /// is the root. The boxes bound the splats over the whole shutter.
    pub struct SplatNode / SPLAT_NODE {
        min: vec3,
        count: u32,
        max: vec3,
        index: u32,
    }
}

record! {
    /// A primary hit as the reconstruction reads it (19 words; `valid` = 0: the camera ray left the
    /// scene): the point, its shading normal, `k_d`, `k_s`, Phong exponent `m`, the camera ray's
    /// origin `eye` (the lens point), its shutter `time` and lens `weight`.
    pub struct LightPrimary / LIGHT_PRIMARY {
        position: vec3,
        valid: u32,
        normal: vec3,
        m: f32,
        kd: vec3,
        time: f32,
        ks: vec3,
        weight: f32,
        eye: vec3,
    }
}

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

/// `κ` of a surface hit by an input ray (see the module doc): `4 √e_Blinn` where it has a glossy
/// lobe, else 0.
#[inline]
pub fn kappa(ks: Vec3, m: f32, lobe: Lobe) -> f32 {
    if m > 0.0 && ks.max_element() > 0.0 {
        let blinn = if lobe == Lobe::BlinnPhong { m } else { 4.0 * m };
        4.0 * blinn.sqrt()
    } else {
        0.0
    }
}

/// `mode`: ambient occlusion or radiance.
fn ao_mode(ctx: &KernelCtx<'_>) -> Result<bool, BackendError> {
    match ctx.str_param("mode")? {
        "radiance" => Ok(false),
        "ao" => Ok(true),
        other => Err(ctx.err(format!("unknown mode `{other}`; use radiance or ao"))),
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

/// The camera ray of sample `s` of `count` and its time: through the pixel centre, from its lens
/// point and at its shutter time (each its own dimension, stratified over the pixel's samples, or
/// independent), or — `fixed` — the pinhole ray at the shutter's centre.
#[allow(clippy::too_many_arguments)]
#[inline]
fn camera_sample(
    camera: &Camera,
    shape: LensShape,
    pixel: Vec2,
    size: (u32, u32),
    rng: &PixelRng,
    s: u32,
    count: u32,
    stratified: bool,
    time: bool,
) -> (LensRay, f32) {
    let draw = |dimension: u32| {
        Vec2::from(if stratified { rng.stratified2(s, count.max(1), dimension) } else { rng.uniform2(s, dimension) })
    };
    let lens = if camera.aperture_radius > 0.0 { draw(dim::LENS) } else { Vec2::splat(0.5) };
    let t = if time { 2.0 * draw(dim::TIME).x - 1.0 } else { 0.0 };
    (camera.ray(pixel, lens, size.0, size.1, shape), t)
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

/// Whether an AO ray that reached a surface at `t` counts as occluded.
#[inline]
fn ao_occluded(t: f32, max_distance: f32) -> bool {
    max_distance <= 0.0 || t <= max_distance
}

/// An AO reconstruction ray's value: 1 where what it sees at distance `t` occludes, else 0.
fn occlusion(t: Option<f32>, max_distance: f32) -> Vec3 {
    Vec3::splat(t.is_some_and(|t| ao_occluded(t, max_distance)) as u32 as f32)
}

// ---------------------------------------------------------------------------------------------
// light_field.sample
// ---------------------------------------------------------------------------------------------

/// `light_field.sample` (see the module doc).
pub struct LightFieldSample;

/// `time`: each path at its own shutter time (optional, default off).
fn time_param(ctx: &KernelCtx<'_>) -> Result<bool, BackendError> {
    if ctx.params.contains_key("time") {
        ctx.bool_param("time")
    } else {
        Ok(false)
    }
}

impl Kernel for LightFieldSample {
    fn name(&self) -> &'static str {
        "light_field.sample"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Sampling
    }
    fn draws_random(&self) -> bool {
        true
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            // `layers` records per pixel.
            Binding::write("samples", Format::Struct(&LIGHT_SAMPLE)),
            // `layers("primary")` records per pixel: the first paths' primary hits.
            Binding::write("primary", Format::Struct(&LIGHT_PRIMARY)),
            // rgb: Σ w·L f cos/pdf / Σ w over the finite samples; w: Σ w.
            Binding::write("estimate", Format::Vec4),
        ]
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/light_field_sample.wgsl"), |ctx| {
                let ao = ao_mode(ctx)?;
                let p = PathParams::from_params(ctx, ao, ctx.f32_param("max_distance")?)?;
                let (camera, shape) = pass_camera(ctx)?;
                let u = camera_uniforms(Uniforms::new(), &camera, shape)
                    .u32("count", ctx.int_param("count")?.max(0) as u32)
                    .u32("layers", ctx.layers("samples"))
                    .u32("primaries", ctx.layers("primary"))
                    .u32("time", time_param(ctx)? as u32)
                    .u32("angular", ctx.bool_param("angular")? as u32)
                    .u32("stratified", ctx.stratified_param()? as u32)
                    .u32("stream", ctx.int_param("stream")? as u32);
                Ok(p.uniforms(u, ctx))
            })
            .with_include("camera.wgsl", include_str!("../../../../shaders/camera.wgsl"))
            .with_include("lobe_mixture.wgsl", include_str!("../../../../shaders/lobe_mixture.wgsl"))
            .with_include("indirect_path.wgsl", include_str!("../../../../shaders/indirect_path.wgsl"))
            .with_include("light_field_common.wgsl", include_str!("../../../../shaders/light_field_common.wgsl"))
            .with_scene()
            // A reference traces thousands of paths per pixel: lavapipe stops a loop after 65,535
            // iterations (measured: a 1024-path reference of lightfield_indirect.ron at 32×24 cut
            // 656 loops unchunked).
            .chunked(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let ao = ao_mode(ctx)?;
        let max_distance = ctx.f32_param("max_distance")?;
        let p = PathParams::from_params(ctx, ao, max_distance)?;
        let count = ctx.int_param("count")?.max(0) as u32;
        let (layers, primaries) = (ctx.layers("samples"), ctx.layers("primary"));
        let angular = ctx.bool_param("angular")?;
        let stratified = ctx.stratified_param()?;
        let stream = ctx.int_param("stream")? as u32;
        let (camera, shape) = pass_camera(ctx)?;
        let time = time_param(ctx)?;
        // A pinhole at the shutter's centre: one camera ray for every path of a pixel.
        let fixed = camera.aperture_radius == 0.0 && !time;
        let scene = ctx.scene;
        let (seed, width, height) = (ctx.seed, ctx.width, ctx.height);
        struct Px {
            samples: Vec<LightSample>,
            primary: Vec<LightPrimary>,
            estimate: [f32; 4],
            rays: PathRays,
            primary_rays: u64,
            bad: u64,
        }
        let out = ctx.map_pixels(true, |px, py| {
            let i = (py * width + px) as usize;
            let mut o = Px {
                samples: vec![LightSample::default(); layers as usize],
                primary: vec![LightPrimary::default(); primaries as usize],
                estimate: [0.0; 4],
                rays: PathRays::default(),
                primary_rays: 0,
                bad: 0,
            };
            let rng = PixelRng::new(seed, i as u32, stream);
            let centre = Vec2::new(px as f32 + 0.5, py as f32 + 0.5);
            let (mut sum, mut sum_w) = (Vec3::ZERO, 0.0f32);
            let mut fixed_hit = None;
            for s in 0..count {
                let (ray, t) = camera_sample(&camera, shape, centre, (width, height), &rng, s, count, stratified, time);
                let at = scene.at(t);
                let trace = || at.intersect(ray.origin, ray.dir, 0.0, f32::INFINITY);
                let camera_hit = if fixed {
                    *fixed_hit.get_or_insert_with(|| {
                        o.primary_rays += 1;
                        trace()
                    })
                } else {
                    o.primary_rays += 1;
                    trace()
                };
                let prim = camera_hit.map(|hit| {
                    let sp = at.surface(&hit, ray.origin, ray.dir);
                    let mat = &scene.materials[sp.material as usize];
                    Primary {
                        x: sp.position,
                        n: sp.shading_normal,
                        kd: scene.albedo(&sp),
                        ks: mat.specular,
                        m: mat.phong_exponent,
                    }
                });
                if s < primaries {
                    o.primary[s as usize] = match &prim {
                        Some(q) => LightPrimary {
                            position: q.x.to_array(),
                            valid: 1,
                            normal: q.n.to_array(),
                            m: q.m,
                            kd: q.kd.to_array(),
                            time: t,
                            ks: q.ks.to_array(),
                            weight: ray.weight,
                            eye: ray.origin.to_array(),
                        },
                        None => LightPrimary {
                            time: t,
                            weight: ray.weight,
                            eye: ray.origin.to_array(),
                            ..Default::default()
                        },
                    };
                }
                let Some(prim) = prim else {
                    // The camera ray left the scene: no indirect light along it.
                    sum_w += ray.weight;
                    continue;
                };
                let wo = (ray.origin - prim.x).normalize_or_zero();
                let (wi, weight) = leave(&prim, wo, p.lobe, ao, &rng, s, count, stratified);
                let side = if wi.dot(prim.n) >= 0.0 { 1.0 } else { -1.0 };
                let origin = prim.x + prim.n * (side * p.eps);
                o.rays.secondary += 1;
                let hit = at.intersect(origin, wi, 0.0, f32::INFINITY);
                let mut rec = LightSample {
                    origin: origin.to_array(),
                    flags: SAMPLE_ESCAPED,
                    direction: wi.to_array(),
                    time: t,
                    lens: ray.lens.to_array(),
                    ..Default::default()
                };
                let mut value = Vec3::ZERO;
                if let Some(hit) = hit {
                    let sp = at.surface(&hit, origin, wi);
                    let mat = &scene.materials[sp.material as usize];
                    // Every hit is a sample of the light field, whatever this pixel's BRDF makes of
                    // it (a black or below-surface direction still gives other pixels a splat).
                    let radiance = if ao {
                        occlusion(Some(hit.t), max_distance)
                    } else {
                        path_from_hit(&at, &p, hit, origin, wi, &rng, s, &mut o.rays).0
                    };
                    value = radiance;
                    rec.flags = SAMPLE_HIT;
                    rec.hit = sp.position.to_array();
                    rec.distance = hit.t;
                    rec.normal = sp.shading_normal.to_array();
                    rec.kappa = if angular { kappa(mat.specular, mat.phong_exponent, p.lobe) } else { 0.0 };
                    rec.radiance = radiance.to_array();
                    rec.velocity = at.velocity(&sp).to_array();
                }
                let contribution = value * weight;
                if contribution.is_finite() {
                    sum += contribution * ray.weight;
                    sum_w += ray.weight;
                } else {
                    // Counted, never spread: the sample is kept without radiance.
                    o.bad += 1;
                    rec.radiance = [0.0; 3];
                }
                if s < layers {
                    o.samples[s as usize] = rec;
                }
            }
            let mean = if sum_w > 0.0 { sum / sum_w } else { Vec3::ZERO };
            o.estimate = [mean.x, mean.y, mean.z, sum_w];
            o
        });
        Counters::add(&ctx.counters.primary_rays, out.iter().map(|o| o.primary_rays).sum());
        Counters::add(&ctx.counters.secondary_rays, out.iter().map(|o| o.rays.secondary).sum());
        Counters::add(&ctx.counters.shadow_rays, out.iter().map(|o| o.rays.shadow).sum());
        Counters::add(&ctx.counters.non_finite_samples, out.iter().map(|o| o.bad).sum());
        ctx.put("estimate", out.iter().map(|o| o.estimate).collect::<Vec<_>>())?;
        ctx.put("primary", out.iter().flat_map(|o| o.primary.iter().copied()).collect::<Vec<_>>())?;
        ctx.put("samples", out.into_iter().flat_map(|o| o.samples).collect::<Vec<_>>())
    }
}

// ---------------------------------------------------------------------------------------------
// light_field.splats (host)
// ---------------------------------------------------------------------------------------------

/// `light_field.splats` (see the module doc and [`splats`]).
pub struct LightFieldSplats;

/// The splats, the tree and per-pixel statistics built from a pass's samples.
pub struct Built {
    pub splats: Vec<Splat>,
    pub nodes: Vec<SplatNode>,
    /// Splats that shrank.
    pub shrunk: usize,
}

/// Build everything the reconstruction reads from the stored samples (`layers` per pixel). A tree
/// deeper than the traversal stack ([`STACK_SIZE`]) is an error (the depth is returned).
pub fn build(samples: &[LightSample], knn: splats::KnnSettings, shrink: bool, t_min: f32) -> Result<Built, usize> {
    let mut list: Vec<Splat> = samples
        .iter()
        .enumerate()
        .filter(|(_, s)| s.flags == SAMPLE_HIT && Vec3::from(s.hit).is_finite())
        .map(|(k, s)| Splat {
            centre: s.hit,
            radius: 0.0,
            normal: s.normal,
            kappa: s.kappa,
            direction: s.direction,
            sample: k as u32,
            radiance: s.radiance,
            flags: 1,
            velocity: s.velocity,
            time: s.time,
        })
        .collect();
    let radii = splats::knn_radii(&list, knn);
    for (s, r) in list.iter_mut().zip(radii) {
        s.radius = r;
    }
    let mut nodes = splats::tree(&mut list);
    let depth = splats::depth(&nodes);
    if depth >= STACK_SIZE {
        return Err(depth);
    }
    let mut shrunk = 0;
    if shrink {
        let rays = input_rays(samples, &list);
        shrunk = splats::shrink(&mut nodes, &mut list, &rays, t_min);
    }
    Ok(Built { splats: list, nodes, shrunk })
}

/// Every input ray of `samples` (Sec. 2.3.1: escaped ones to infinity, each at its own time), naming
/// its own splat among `splats` (in leaf order, as [`build`] stores them; `u32::MAX`: none).
pub fn input_rays(samples: &[LightSample], splats: &[Splat]) -> Vec<splats::InputRay> {
    let mut position = vec![u32::MAX; samples.len()];
    for (k, s) in splats.iter().enumerate() {
        position[s.sample as usize] = k as u32;
    }
    samples
        .iter()
        .enumerate()
        .filter(|(_, s)| s.flags != SAMPLE_NONE)
        .map(|(k, s)| splats::InputRay {
            origin: Vec3::from(s.origin),
            direction: Vec3::from(s.direction),
            distance: if s.flags == SAMPLE_HIT { s.distance } else { f32::INFINITY },
            own: position[k],
            time: s.time,
        })
        .collect()
}

fn knn_settings(ctx: &KernelCtx<'_>) -> Result<splats::KnnSettings, BackendError> {
    let k = ctx.int_param("k")?;
    if !(1..=256).contains(&k) {
        return Err(ctx.err(format!("`k` = {k} must be between 1 and 256")));
    }
    let alpha = ctx.f32_param("alpha")?;
    if !(alpha >= 1.0 && alpha.is_finite()) {
        return Err(ctx.err(format!("`alpha` = {alpha} must be a finite number ≥ 1")));
    }
    let glossy_cap = ctx.f32_param("glossy_cap")?;
    if !(glossy_cap >= 1.0) {
        return Err(ctx
            .err(format!("`glossy_cap` = {glossy_cap} must be ≥ 1 (0 or less: no cap is written as a large number)")));
    }
    Ok(splats::KnnSettings { k: k as u32, alpha, glossy_cap })
}

impl Kernel for LightFieldSplats {
    fn name(&self) -> &'static str {
        "light_field.splats"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Bandwidth
    }
    fn host(&self) -> bool {
        true
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("samples", Format::Struct(&LIGHT_SAMPLE)),
            Binding::write("splats", Format::Struct(&SPLAT)),
            Binding::write("nodes", Format::Struct(&SPLAT_NODE)),
            Binding::write_opt("splat_radius", Format::F32),
        ]
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let knn = knn_settings(ctx)?;
        let shrink = ctx.bool_param("shrink")?;
        let samples = ctx.read::<LightSample>("samples")?;
        let (spp, pixels) = (ctx.layers("samples") as usize, ctx.pixels());
        let (splat_slots, node_slots) = (pixels * ctx.layers("splats") as usize, pixels * ctx.layers("nodes") as usize);
        let built = build(samples, knn, shrink, RAY_EPSILON * ctx.scene.extent()).map_err(|depth| {
            ctx.err(format!("the splat tree is {depth} levels deep, more than the traversal stack's {STACK_SIZE}; use fewer samples (`spp`) or a smaller image"))
        })?;
        if built.splats.len() > splat_slots || built.nodes.len() > node_slots {
            return Err(ctx.err(format!(
                "{} splats and {} nodes do not fit the node's buffers ({splat_slots}, {node_slots}); `splats` needs ≥ spp and `nodes` ≥ 2·spp layers",
                built.splats.len(),
                built.nodes.len()
            )));
        }
        if ctx.is_bound("splat_radius") {
            let (mut sum, mut n) = (vec![0.0f32; pixels], vec![0u32; pixels]);
            for s in &built.splats {
                let p = s.sample as usize / spp.max(1);
                sum[p] += s.radius;
                n[p] += 1;
            }
            ctx.put(
                "splat_radius",
                sum.iter().zip(&n).map(|(s, &n)| if n > 0 { s / n as f32 } else { 0.0 }).collect::<Vec<_>>(),
            )?;
        }
        let mut splats = built.splats;
        splats.resize(splat_slots, Splat::default());
        let mut nodes = built.nodes;
        nodes.resize(node_slots, SplatNode::default());
        ctx.put("splats", splats)?;
        ctx.put("nodes", nodes)
    }
}

// ---------------------------------------------------------------------------------------------
// light_field.reconstruct
// ---------------------------------------------------------------------------------------------

/// `light_field.reconstruct` (see the module doc).
pub struct LightFieldReconstruct;

impl Kernel for LightFieldReconstruct {
    fn name(&self) -> &'static str {
        "light_field.reconstruct"
    }
    /// Ray tracing through the splats: its time is the reconstruction rays' (the paper's 189 s of
    /// 199), and parity judges it as a ray-tracing pass — a reconstruction ray grazing a splat's rim
    /// or a visibility-conflict boundary flips on float round-off as a scene ray grazing an edge does.
    fn class(&self) -> KernelClass {
        KernelClass::Sampling
    }
    fn draws_random(&self) -> bool {
        true
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("primary", Format::Struct(&LIGHT_PRIMARY)),
            Binding::read("splats", Format::Struct(&SPLAT)),
            Binding::read("nodes", Format::Struct(&SPLAT_NODE)),
            // What a reference keeps (the filter bypassed); unused here.
            Binding::read("unfiltered", Format::Vec3),
            Binding::write("radiance", Format::Vec3),
        ]
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/light_field_reconstruct.wgsl"), |ctx| {
                let ao = ao_mode(ctx)?;
                let p = PathParams::from_params(ctx, ao, ctx.f32_param("max_distance")?)?;
                let u = Uniforms::new()
                    .u32("rays", reconstruction_rays(ctx)?)
                    .u32("primaries", ctx.layers("primary"))
                    .u32("two_sided", two_sided(ctx, ao)? as u32)
                    .u32("trace_gaps", trace_gaps(ctx)? as u32)
                    .u32("stream", ctx.int_param("stream")? as u32);
                Ok(p.uniforms(u, ctx))
            })
            .with_include("lobe_mixture.wgsl", include_str!("../../../../shaders/lobe_mixture.wgsl"))
            .with_include("indirect_path.wgsl", include_str!("../../../../shaders/indirect_path.wgsl"))
            .with_include("light_field_common.wgsl", include_str!("../../../../shaders/light_field_common.wgsl"))
            .with_scene()
            .with_reach(|_| Ok(Reach::Image))
            // Each ray walks the splat tree (hundreds of nodes and splats where glossy splats are
            // wide): 4 rays per dispatch keep lavapipe's per-invocation loop count far below its cap.
            .chunked_by(4),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let primary = ctx.read::<LightPrimary>("primary")?;
        let hits_per_pixel = ctx.layers("primary") as usize;
        let ao = ao_mode(ctx)?;
        let max_distance = ctx.f32_param("max_distance")?;
        let p = PathParams::from_params(ctx, ao, max_distance)?;
        let rays = reconstruction_rays(ctx)?;
        let two_sided = two_sided(ctx, ao)?;
        let trace_gaps = trace_gaps(ctx)?;
        let stream = ctx.int_param("stream")? as u32;
        let splats = ctx.read::<Splat>("splats")?;
        let nodes = ctx.read::<SplatNode>("nodes")?;
        let (seed, width) = (ctx.seed, ctx.width);
        let out = ctx.map_pixels(true, |px, py| {
            let i = (py * width + px) as usize;
            let hits = &primary[i * hits_per_pixel..(i + 1) * hits_per_pixel];
            let share = RayShare::new(hits, rays);
            let (mut sum, mut traced) = (Vec3::ZERO, PathRays::default());
            for r in 0..rays {
                let (j, k) = share.ray(r);
                let hit = &hits[j as usize];
                let Some(prim) = hit.at() else {
                    continue;
                };
                let rng = hit_rng(seed, i as u32, stream, j);
                let wo = (Vec3::from(hit.eye) - prim.x).normalize_or_zero();
                let (wi, weight) = leave(&prim, wo, p.lobe, ao, &rng, k, share.rays_of(j), true);
                if weight == Vec3::ZERO {
                    continue;
                }
                let side = if wi.dot(prim.n) >= 0.0 { 1.0 } else { -1.0 };
                let origin = prim.x + prim.n * (side * p.eps);
                let seen = reconstruct::reconstruct(nodes, splats, origin, wi, p.eps, hit.time, two_sided);
                let value = match seen.distance {
                    None if trace_gaps => trace_gap(&ctx.scene.at(hit.time), &p, origin, wi, &rng, k, &mut traced),
                    distance if ao => occlusion(distance, max_distance),
                    _ => seen.radiance,
                };
                sum += value * weight * share.scale(j);
            }
            (sum / share.total_weight(), traced)
        });
        Counters::add(&ctx.counters.shadow_rays, out.iter().map(|o| o.1.shadow).sum());
        Counters::add(&ctx.counters.secondary_rays, out.iter().map(|o| o.1.secondary).sum());
        ctx.put("radiance", out.into_iter().map(|o| o.0.to_array()).collect::<Vec<_>>())
    }
}

/// `gaps`: whether a reconstruction ray that crosses no splat is traced into the scene (`trace`) or
/// black (`black`, the paper's rule).
fn trace_gaps(ctx: &KernelCtx<'_>) -> Result<bool, BackendError> {
    match ctx.str_param("gaps")? {
        "trace" => Ok(true),
        "black" => Ok(false),
        other => Err(ctx.err(format!("unknown gaps `{other}`; use trace or black"))),
    }
}

/// A reconstruction ray the splats do not answer (`gaps: trace`): where the input rays reached a
/// surface too sparsely for splats to cover it, the ray is traced into the scene and its hit
/// path-traced as an input ray's would be (`path_from_hit`, continuing the ray's own sequence past
/// the direction it was drawn with) — for AO, occluded where that hit is within `max_distance`. A
/// ray that leaves the scene is 0, as an input ray that escapes. The estimate stays eq. 3's mean
/// over the pixel's rays; it no longer counts unresolved rays as black.
fn trace_gap(
    at: &SceneAt<'_>,
    p: &PathParams,
    origin: Vec3,
    wi: Vec3,
    rng: &PixelRng,
    k: u32,
    rays: &mut PathRays,
) -> Vec3 {
    rays.secondary += 1;
    let Some(hit) = at.intersect(origin, wi, 0.0, f32::INFINITY) else {
        return Vec3::ZERO;
    };
    if p.ao {
        return occlusion(Some(hit.t), p.max_distance);
    }
    path_from_hit(at, p, hit, origin, wi, rng, k, rays).0
}

/// How a pixel's `rays` reconstruction rays are shared among its `P` primary hits (eq. 3 per hit,
/// the pixel the lens-weighted mean over hits): ray `r` goes to hit `r mod P` as its `r / P`-th, so
/// hit `j` takes `⌊N/P⌋ + [j < N mod P]` rays; a ray's value is weighted `w_j / n_j` and the pixel
/// divided by `Σ w_j` over the hits that have rays. Mirrored in `light_field_reconstruct.wgsl`.
pub struct RayShare<'a> {
    hits: &'a [LightPrimary],
    rays: u32,
}

impl<'a> RayShare<'a> {
    pub fn new(hits: &'a [LightPrimary], rays: u32) -> Self {
        RayShare { hits, rays }
    }
    fn count(&self) -> u32 {
        self.hits.len().max(1) as u32
    }
    /// Ray `r`'s hit and its index among that hit's rays.
    #[inline]
    pub fn ray(&self, r: u32) -> (u32, u32) {
        (r % self.count(), r / self.count())
    }
    /// Rays of hit `j`.
    #[inline]
    pub fn rays_of(&self, j: u32) -> u32 {
        self.rays / self.count() + u32::from(j < self.rays % self.count())
    }
    /// The weight of one of hit `j`'s rays, `w_j / n_j`.
    #[inline]
    pub fn scale(&self, j: u32) -> f32 {
        self.hits[j as usize].weight / self.rays_of(j).max(1) as f32
    }
    /// `Σ w_j` over the hits that have rays (1 where that is 0, so an empty pixel is 0).
    pub fn total_weight(&self) -> f32 {
        let w: f32 =
            (0..self.hits.len() as u32).filter(|&j| self.rays_of(j) > 0).map(|j| self.hits[j as usize].weight).sum();
        if w > 0.0 {
            w
        } else {
            1.0
        }
    }
}

/// The random sequence of the reconstruction rays of a pixel's primary hit `j` (its own
/// sub-stream, so each hit's rays are stratified among themselves).
#[inline]
fn hit_rng(seed: u32, pixel: u32, stream: u32, j: u32) -> PixelRng {
    PixelRng::new(seed, pixel, substream(stream, j))
}

/// `back_faces`: whether a surface a reconstruction ray sees only from behind gives its splats'
/// radiance (`two_sided`, the paper's Sec. 2.5) or is passed through (`pass`: no input ray saw that
/// side); `auto` (the default) is `two_sided` for ambient occlusion (a surface occludes from either
/// side) and `pass` for radiance (its value on that side was never measured). Measured in
/// docs/DESIGN-NOTES.md "Light-field reconstruction".
fn two_sided(ctx: &KernelCtx<'_>, ao: bool) -> Result<bool, BackendError> {
    if !ctx.params.contains_key("back_faces") {
        return Ok(true);
    }
    match ctx.str_param("back_faces")? {
        "auto" => Ok(ao),
        "two_sided" => Ok(true),
        "pass" => Ok(false),
        other => Err(ctx.err(format!("unknown back_faces `{other}`; use auto, two_sided or pass"))),
    }
}

/// The most reconstruction rays per pixel.
pub const MAX_RAYS: u32 = 1 << 14;

/// `rays`: reconstruction rays per pixel (N of eq. 3).
fn reconstruction_rays(ctx: &KernelCtx<'_>) -> Result<u32, BackendError> {
    let n = ctx.int_param("rays")?;
    // At most 2^14: the WGSL loop stays far below a driver's cap on loop iterations (lavapipe: 65,535).
    u32::try_from(n)
        .ok()
        .filter(|n| (1..=MAX_RAYS).contains(n))
        .ok_or_else(|| ctx.err(format!("`rays` = {n} must be between 1 and {MAX_RAYS}")))
}
