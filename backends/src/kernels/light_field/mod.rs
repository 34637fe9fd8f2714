//! Light-field reconstruction of indirect light and ambient occlusion (issue 17; Lehtinen, Aila,
//! Laine, Durand 2012, `seeds/001_2d3ed232e6777e89.txt`): the kernels of the `LightField` node
//! (`wedge_effects::light_field`). A very different reconstruction from the axis-aligned filters:
//! the input rays themselves become a point-sampled scene that many reconstruction rays query.
//!
//! - `light_field.sample` (random, reference role `Sample`): at each pixel's primary hit (the
//!   `Primary` G-buffer, one primary hit per pixel as the `Indirect` node uses), `count` secondary
//!   rays drawn from the surface's lobe mixture (cosine for AO), each traced as a path
//!   (`indirect::path_from_hit`: next-event estimation at `bounces` vertices). The first `layers`
//!   of them are kept as [`LightSample`] records (Sec. 2.1's tuple: origin, hit, normal at the hit,
//!   `κ`, direction, radiance `L`); `unfiltered` is their plain Monte Carlo estimate
//!   `mean(L f cos/pdf)` (AO: the fraction of rays that hit within `max_distance`).
//! - `light_field.splats` (a host kernel: [`splats`]): splat radii by the bandwidth-aware k-NN, the
//!   splat BVH, consistency shrinking; writes the splats in leaf order and the tree's nodes, the
//!   mean final radius per pixel (`splat_radius`, a heatmap), and each pixel's primary hit as one
//!   [`LightPrimary`] record (so the reconstruction fits WebGPU's 8 storage buffers per stage).
//! - `light_field.reconstruct` (random, a filter bypassed to `unfiltered` in references): eq. 3,
//!   `rays` reconstruction rays per pixel from the same lobe mixture, each resolved by
//!   RECONSTRUCT ([`reconstruct`]): `mean(RECONSTRUCT(p, ω) f cos/pdf)`; AO: the fraction of rays
//!   whose nearest apparent surface lies within `max_distance`.
//!
//! `κ` (eq. 2) of a sample is `4 √e` for a surface with a glossy lobe of Blinn exponent `e`
//! (Sec. 2.5's `4 √(1/r)` with PBRT's Blinn roughness `r = 1/e`; a Phong exponent `m` is taken as
//! the Blinn exponent `4m`), 0 for a diffuse one; `angular: false` sets every `κ = 0` (the
//! ablation of Fig. 10).
//!
//! Per-sample buffers (`BufferInfo::layers`): `samples` and `splats` hold `layers` = `spp` records
//! per pixel, `nodes` `2·spp` (a BVH2 over `n` splats has at most `2n − 1` nodes).

use glam::{Vec2, Vec3};
use wedge_graph::Format;

use crate::record;
use crate::kernel::{Binding, Counters, Kernel, KernelClass, KernelCtx, Reach, Uniforms, WgslSource};
use crate::kernels::direct::RAY_EPSILON;
use crate::kernels::hemisphere::{sample_diffuse, Lobe};
use crate::kernels::indirect::{lobe_mixture, path_from_hit, PathParams, PathRays, LOBE_SELECT};
use crate::kernels::v3;
use crate::rng::{dim, PixelRng};
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
    /// One stored input sample (18 words; Sec. 2.1's tuple without lens, time and motion vectors,
    /// which wedge's pinhole G-buffer does not have): `origin` is where the ray started (the primary
    /// hit, offset along its normal), `distance` the ray parameter of `hit` (unit `direction`).
    pub struct LightSample / LIGHT_SAMPLE {
        origin: vec3,
        flags: u32,
        hit: vec3,
        distance: f32,
        normal: vec3,
        kappa: f32,
        direction: vec3,
        radiance: vec3,
    }
}

record! {
    /// One splat (16 words): a disk of `radius` at `centre` (a hit point) on the plane of `normal`,
    /// with its sample's `κ`, direction and radiance; `sample` = its input sample's index
    /// (`pixel·spp + s`), `flags` = 1 for a splat, 0 for an unused slot.
    pub struct Splat / SPLAT {
        centre: vec3,
        radius: f32,
        normal: vec3,
        kappa: f32,
        direction: vec3,
        sample: u32,
        radiance: vec3,
        flags: u32,
    }
}

record! {
    /// One node of the splat BVH2 (8 words, obvhs's `Bvh2Node` layout): `count == 0` = inner node
    /// with children at `index` and `index + 1`; else a leaf of splats `index..index + count`. Node 0
    /// is the root.
    pub struct SplatNode / SPLAT_NODE {
        min: vec3,
        count: u32,
        max: vec3,
        index: u32,
    }
}

record! {
    /// A pixel's primary hit as the reconstruction reads it (14 words; `valid` = 0: no surface),
    /// written by the host pass from the G-buffer so `light_field.reconstruct` binds one buffer for
    /// it (WebGPU's 8 storage buffers per stage).
    pub struct LightPrimary / LIGHT_PRIMARY {
        position: vec3,
        valid: u32,
        normal: vec3,
        m: f32,
        kd: vec3,
        ks: vec3,
    }
}

impl LightPrimary {
    fn at(&self) -> Option<Primary> {
        (self.valid != 0).then(|| Primary { x: Vec3::from(self.position), n: Vec3::from(self.normal), kd: Vec3::from(self.kd), ks: Vec3::from(self.ks), m: self.m })
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

/// The primary hit of pixel `i` from the G-buffer: point, normal, `k_d`, `k_s`, `m`.
struct Primary {
    x: Vec3,
    n: Vec3,
    kd: Vec3,
    ks: Vec3,
    m: f32,
}

struct GBuffer<'a> {
    position: &'a [[f32; 4]],
    normal: &'a [[f32; 4]],
    albedo: Option<&'a [[f32; 3]]>,
    specular: Option<&'a [[f32; 4]]>,
}

impl<'a> GBuffer<'a> {
    fn read(ctx: &KernelCtx<'a>) -> Result<GBuffer<'a>, BackendError> {
        Ok(GBuffer {
            position: ctx.read("position")?,
            normal: ctx.read("normal")?,
            albedo: ctx.read_opt("albedo")?,
            specular: ctx.read_opt("specular")?,
        })
    }
    fn record(&self, i: usize) -> LightPrimary {
        match self.at(i) {
            Some(p) => LightPrimary { position: p.x.to_array(), valid: 1, normal: p.n.to_array(), m: p.m, kd: p.kd.to_array(), ks: p.ks.to_array() },
            None => LightPrimary::default(),
        }
    }
    fn at(&self, i: usize) -> Option<Primary> {
        if self.position[i][3] == 0.0 {
            return None;
        }
        let (ks, m) = self.specular.map_or((Vec3::ZERO, 0.0), |s| (v3(s[i]), s[i][3]));
        Some(Primary { x: v3(self.position[i]), n: v3(self.normal[i]), kd: self.albedo.map_or(Vec3::ONE, |a| Vec3::from(a[i])), ks, m })
    }
}

/// A direction leaving a primary hit (sample `s` of `count`): from its lobe mixture (cosine for AO
/// or a black surface), its 2-D number stratified over the pass's samples (or independent: a
/// reference's `sampling`), and the weight `f cos/pdf` of eq. 3 (1 for AO; 0 for a direction below
/// the surface).
#[allow(clippy::too_many_arguments)]
#[inline]
fn leave(p: &Primary, wo: Vec3, lobe: Lobe, ao: bool, rng: &PixelRng, s: u32, count: u32, stratified: bool) -> (Vec3, Vec3) {
    let u = Vec2::from(if stratified { rng.stratified2(s, count.max(1), dim::BSDF) } else { rng.uniform2(s, dim::BSDF) });
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

// ---------------------------------------------------------------------------------------------
// light_field.sample
// ---------------------------------------------------------------------------------------------

/// `light_field.sample` (see the module doc).
pub struct LightFieldSample;

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
            Binding::read("position", Format::Vec4),
            Binding::read("normal", Format::Vec4),
            Binding::read_opt("albedo", Format::Vec3),
            Binding::read_opt("specular", Format::Vec4),
            // `layers` records per pixel.
            Binding::write("samples", Format::Struct(&LIGHT_SAMPLE)),
            Binding::write("unfiltered", Format::Vec3),
        ]
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/light_field_sample.wgsl"), |ctx| {
                let ao = ao_mode(ctx)?;
                let p = PathParams::from_params(ctx, ao, ctx.f32_param("max_distance")?)?;
                Ok(p.uniforms(Uniforms::new(), ctx)
                    .u32("count", ctx.int_param("count")?.max(0) as u32)
                    .u32("layers", ctx.layers("samples"))
                    .u32("angular", ctx.bool_param("angular")? as u32)
                    .u32("stratified", ctx.stratified_param()? as u32)
                    .u32("stream", ctx.int_param("stream")? as u32)
                    .vec3("camera", ctx.scene.camera.position.to_array()))
            })
            .with_include("lobe_mixture.wgsl", include_str!("../../../../shaders/lobe_mixture.wgsl"))
            .with_include("indirect_path.wgsl", include_str!("../../../../shaders/indirect_path.wgsl"))
            .with_include("light_field_common.wgsl", include_str!("../../../../shaders/light_field_common.wgsl"))
            .with_scene(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let g = GBuffer::read(ctx)?;
        let ao = ao_mode(ctx)?;
        let max_distance = ctx.f32_param("max_distance")?;
        let p = PathParams::from_params(ctx, ao, max_distance)?;
        let count = ctx.int_param("count")?.max(0) as u32;
        let layers = ctx.layers("samples");
        let angular = ctx.bool_param("angular")?;
        let stratified = ctx.stratified_param()?;
        let stream = ctx.int_param("stream")? as u32;
        let (seed, width, camera) = (ctx.seed, ctx.width, ctx.scene.camera.position);
        let at = ctx.scene.at(0.0);
        struct Px {
            samples: Vec<LightSample>,
            unfiltered: Vec3,
            rays: PathRays,
            bad: u64,
        }
        let out = ctx.map_pixels(true, |px, py| {
            let i = (py * width + px) as usize;
            let mut o = Px { samples: vec![LightSample::default(); layers as usize], unfiltered: Vec3::ZERO, rays: PathRays::default(), bad: 0 };
            let Some(prim) = g.at(i) else {
                return o;
            };
            let wo = (camera - prim.x).normalize_or_zero();
            let rng = PixelRng::new(seed, i as u32, stream);
            let (mut sum, mut valid) = (Vec3::ZERO, 0u32);
            for s in 0..count {
                let (wi, weight) = leave(&prim, wo, p.lobe, ao, &rng, s, count, stratified);
                let side = if wi.dot(prim.n) >= 0.0 { 1.0 } else { -1.0 };
                let origin = prim.x + prim.n * (side * p.eps);
                o.rays.secondary += 1;
                let hit = at.intersect(origin, wi, 0.0, f32::INFINITY);
                let mut rec = LightSample { origin: origin.to_array(), flags: SAMPLE_ESCAPED, direction: wi.to_array(), ..Default::default() };
                let mut value = Vec3::ZERO;
                if let Some(hit) = hit {
                    let sp = at.surface(&hit, origin, wi);
                    let mat = &ctx.scene.materials[sp.material as usize];
                    // Every hit is a sample of the light field, whatever this pixel's BRDF makes of
                    // it (a black or below-surface direction still gives other pixels a splat).
                    let radiance = if ao {
                        Vec3::splat(ao_occluded(hit.t, max_distance) as u32 as f32)
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
                }
                let contribution = value * weight;
                if contribution.is_finite() {
                    sum += contribution;
                    valid += 1;
                } else {
                    // Counted, never spread: the sample is kept without radiance.
                    o.bad += 1;
                    rec.radiance = [0.0; 3];
                }
                if s < layers {
                    o.samples[s as usize] = rec;
                }
            }
            o.unfiltered = if valid > 0 { sum / valid as f32 } else { Vec3::ZERO };
            o
        });
        Counters::add(&ctx.counters.secondary_rays, out.iter().map(|o| o.rays.secondary).sum());
        Counters::add(&ctx.counters.shadow_rays, out.iter().map(|o| o.rays.shadow).sum());
        Counters::add(&ctx.counters.non_finite_samples, out.iter().map(|o| o.bad).sum());
        ctx.put("unfiltered", out.iter().map(|o| o.unfiltered.to_array()).collect::<Vec<_>>())?;
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
        .map(|(k, s)| Splat { centre: s.hit, radius: 0.0, normal: s.normal, kappa: s.kappa, direction: s.direction, sample: k as u32, radiance: s.radiance, flags: 1 })
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
        // Where each input sample's splat now is (leaf order), for "its own" splat.
        let mut position = vec![u32::MAX; samples.len()];
        for (k, s) in list.iter().enumerate() {
            position[s.sample as usize] = k as u32;
        }
        let rays: Vec<splats::InputRay> = samples
            .iter()
            .enumerate()
            .filter(|(_, s)| s.flags != SAMPLE_NONE)
            .map(|(k, s)| splats::InputRay {
                origin: Vec3::from(s.origin),
                direction: Vec3::from(s.direction),
                distance: if s.flags == SAMPLE_HIT { s.distance } else { f32::INFINITY },
                own: position[k],
            })
            .collect();
        shrunk = splats::shrink(&mut nodes, &mut list, &rays, t_min);
    }
    Ok(Built { splats: list, nodes, shrunk })
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
        return Err(ctx.err(format!("`glossy_cap` = {glossy_cap} must be ≥ 1 (0 or less: no cap is written as a large number)")));
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
            Binding::read("position", Format::Vec4),
            Binding::read("normal", Format::Vec4),
            Binding::read_opt("albedo", Format::Vec3),
            Binding::read_opt("specular", Format::Vec4),
            Binding::write("primary", Format::Struct(&LIGHT_PRIMARY)),
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
            ctx.put("splat_radius", sum.iter().zip(&n).map(|(s, &n)| if n > 0 { s / n as f32 } else { 0.0 }).collect::<Vec<_>>())?;
        }
        let g = GBuffer::read(ctx)?;
        ctx.put("primary", (0..pixels).map(|i| g.record(i)).collect::<Vec<_>>())?;
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
                Ok(Uniforms::new()
                    .f32("eps", p.eps)
                    .u32("lobe", (p.lobe == Lobe::BlinnPhong) as u32)
                    .u32("ao", ao as u32)
                    .f32("max_distance", p.max_distance)
                    .u32("rays", reconstruction_rays(ctx)?)
                    .u32("stream", ctx.int_param("stream")? as u32)
                    .vec3("camera", ctx.scene.camera.position.to_array()))
            })
            .with_include("lobe_mixture.wgsl", include_str!("../../../../shaders/lobe_mixture.wgsl"))
            .with_include("light_field_common.wgsl", include_str!("../../../../shaders/light_field_common.wgsl"))
            .with_reach(|_| Ok(Reach::Image))
            // Each ray walks the splat tree (hundreds of nodes and splats where glossy splats are
            // wide): 4 rays per dispatch keep lavapipe's per-invocation loop count far below its cap.
            .chunked_by(4),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let primary = ctx.read::<LightPrimary>("primary")?;
        let ao = ao_mode(ctx)?;
        let max_distance = ctx.f32_param("max_distance")?;
        let p = PathParams::from_params(ctx, ao, max_distance)?;
        let rays = reconstruction_rays(ctx)?;
        let stream = ctx.int_param("stream")? as u32;
        let splats = ctx.read::<Splat>("splats")?;
        let nodes = ctx.read::<SplatNode>("nodes")?;
        let (seed, width, camera) = (ctx.seed, ctx.width, ctx.scene.camera.position);
        let out = ctx.map_pixels(true, |px, py| {
            let i = (py * width + px) as usize;
            let Some(prim) = primary[i].at() else {
                return Vec3::ZERO;
            };
            let wo = (camera - prim.x).normalize_or_zero();
            let rng = PixelRng::new(seed, i as u32, stream);
            let mut sum = Vec3::ZERO;
            for r in 0..rays {
                let (wi, weight) = leave(&prim, wo, p.lobe, ao, &rng, r, rays, true);
                if weight == Vec3::ZERO {
                    continue;
                }
                let side = if wi.dot(prim.n) >= 0.0 { 1.0 } else { -1.0 };
                let origin = prim.x + prim.n * (side * p.eps);
                let seen = reconstruct::reconstruct(nodes, splats, origin, wi, p.eps);
                let value = if ao { Vec3::splat(seen.distance.is_some_and(|t| ao_occluded(t, max_distance)) as u32 as f32) } else { seen.radiance };
                sum += value * weight;
            }
            sum / rays as f32
        });
        ctx.put("radiance", out.into_iter().map(|o| o.to_array()).collect::<Vec<_>>())
    }
}

/// The most reconstruction rays per pixel.
pub const MAX_RAYS: u32 = 1 << 14;

/// `rays`: reconstruction rays per pixel (N of eq. 3).
fn reconstruction_rays(ctx: &KernelCtx<'_>) -> Result<u32, BackendError> {
    let n = ctx.int_param("rays")?;
    // At most 2^14: the WGSL loop stays far below a driver's cap on loop iterations (lavapipe: 65,535).
    u32::try_from(n).ok().filter(|n| (1..=MAX_RAYS).contains(n)).ok_or_else(|| ctx.err(format!("`rays` = {n} must be between 1 and {MAX_RAYS}")))
}
