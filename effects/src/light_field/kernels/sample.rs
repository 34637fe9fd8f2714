//! `light_field.sample`: the input samples (see [`super`]); WGSL `shaders/light_field_sample.wgsl`.

use glam::Vec3;
use wedge_backends::kernels::indirect::{path_from_hit, PathParams, PathRays};
use wedge_backends::kernels::paths::pass_camera;
use wedge_backends::rng::PixelRng;
use wedge_backends::{BackendError, Counters, Kernel, KernelCtx, KernelParams, Sampling, Uniforms, WgslSource};
use wedge_scene::{Camera, Hit, LensRay, Scene, SceneAt};

use super::{leave, EstimatorParams, Primary, RandomStream};
use crate::camera_paths::{self, CameraDraws};
use crate::light_field::formulas::{kappa, occlusion};
use crate::light_field::records::{LightPrimary, LightSample, SAMPLE_ESCAPED, SAMPLE_HIT};

/// `light_field.sample` (see [`super`]).
pub struct LightFieldSample;

wedge_backends::kernel_params! {
    /// `light_field.sample`'s own parameter, declared by the node and forwarded.
    pub struct SampleParams {
        angular: bool = boolean(true, "use each sample's angular bandwidth kappa (eq. 2); false treats every surface as diffuse (Fig. 10's ablation)"),
    }
}

wedge_backends::kernel_params! {
    /// What the node sets on the pass: `count` paths per pixel (its `spp`; a reference's N) and
    /// `time`, whether each path takes its own shutter time (the factoring node's camera settings).
    pub struct SamplePass {
        count: u32,
        time: bool,
        sampling: Sampling,
    }
}

wedge_backends::kernel_bindings! {
    /// What a `light_field.sample` pass binds.
    pub struct SampleIo / SampleData {
        /// `layers` records per pixel.
        write samples: LightSample,
        /// `layers("primary")` records per pixel: the first paths' primary hits.
        write primary: LightPrimary,
        /// rgb: Σ w·L f cos/pdf / Σ w over the finite samples; w: Σ w.
        write estimate: [f32; 4],
    }
}

impl Kernel for LightFieldSample {
    wedge_backends::kernel_signature!(
        name: "light_field.sample", class: Sampling, bindings: SampleIo, params: [EstimatorParams, SampleParams, SamplePass, RandomStream], random: true
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/light_field_sample.wgsl"), |ctx| {
                let s = Setup::read(ctx)?;
                // The path settings as `indirect_path.wgsl` reads them (`PathParams::uniforms`).
                let u = camera_paths::camera_uniforms(Uniforms::new(), &s.camera, s.draws)
                    .u32("count", s.count)
                    .u32("layers", s.layers)
                    .u32("primaries", s.primaries)
                    .bool("angular", s.angular)
                    .u32("stratified", s.stratified as u32)
                    .u32("stream", s.stream);
                Ok(s.p.uniforms(u, ctx))
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
        let setup = Setup::read(ctx)?;
        let out = ctx.map_pixels(true, |px, py| setup.pixel(px, py));
        write_outputs(ctx, out)
    }
}

/// The pass's settings, read once: what every pixel's paths share.
struct Setup<'s> {
    p: PathParams,
    ao: bool,
    max_distance: f32,
    angular: bool,
    count: u32,
    stratified: bool,
    stream: u32,
    camera: Camera,
    /// Through the pixel centre, from each path's lens point and at its shutter time where the
    /// pass has a lens / `time`.
    draws: CameraDraws,
    /// A pinhole at the shutter's centre: one camera ray for every path of a pixel.
    fixed: bool,
    layers: u32,
    primaries: u32,
    scene: &'s Scene,
    seed: u32,
    width: u32,
    height: u32,
}

/// One pixel's outputs and the rays it traced.
struct Px {
    samples: Vec<LightSample>,
    primary: Vec<LightPrimary>,
    estimate: [f32; 4],
    rays: PathRays,
    primary_rays: u64,
    bad: u64,
}

/// Sample `s`'s camera ray, its shutter time `t` and the scene at that time.
struct CameraSample<'a> {
    s: u32,
    ray: LensRay,
    t: f32,
    at: SceneAt<'a>,
}

impl<'s> Setup<'s> {
    /// The parameters, layer counts and camera of the pass (errors name the parameter).
    fn read(ctx: &KernelCtx<'s>) -> Result<Self, BackendError> {
        let (e, p) = EstimatorParams::read_paths(ctx)?;
        let (angular, SamplePass { count, time, sampling }) =
            (SampleParams::read(ctx)?.angular, SamplePass::read(ctx)?);
        let RandomStream { stream } = RandomStream::read(ctx)?;
        let (camera, shape) = pass_camera(ctx)?;
        let stratified = sampling == Sampling::Stratified;
        let strata = if stratified { count.max(1) } else { 0 };
        Ok(Setup {
            p,
            ao: p.ao,
            max_distance: e.max_distance,
            angular,
            count,
            stratified,
            stream,
            camera,
            draws: CameraDraws { shape, jitter: false, time, strata },
            fixed: camera.aperture_radius == 0.0 && !time,
            layers: ctx.layers("samples"),
            primaries: ctx.layers("primary"),
            scene: ctx.scene,
            seed: ctx.seed,
            width: ctx.width,
            height: ctx.height,
        })
    }

    /// One pixel's `count` paths: each one's primary record and secondary sample, and the weighted
    /// mean of the finite contributions.
    fn pixel(&self, px: u32, py: u32) -> Px {
        let i = (py * self.width + px) as usize;
        let mut o = Px {
            samples: vec![LightSample::default(); self.layers as usize],
            primary: vec![LightPrimary::default(); self.primaries as usize],
            estimate: [0.0; 4],
            rays: PathRays::default(),
            primary_rays: 0,
            bad: 0,
        };
        let rng = PixelRng::new(self.seed, i as u32, self.stream);
        let (mut sum, mut sum_w) = (Vec3::ZERO, 0.0f32);
        let mut fixed_hit = None;
        for s in 0..self.count {
            let (ray, t) = self.draws.ray(&self.camera, &rng, s, (px, py), (self.width, self.height));
            let cs = CameraSample { s, ray, t, at: self.scene.at(t) };
            let prim = self.primary_hit(&cs, &mut fixed_hit, &mut o.primary_rays);
            if s < self.primaries {
                o.primary[s as usize] = primary_record(prim.as_ref(), &cs);
            }
            let Some(prim) = prim else {
                // The camera ray left the scene: no indirect light along it.
                sum_w += ray.weight;
                continue;
            };
            let (mut rec, contribution) = self.secondary(&cs, &prim, &rng, &mut o.rays);
            if contribution.is_finite() {
                sum += contribution * ray.weight;
                sum_w += ray.weight;
            } else {
                // Counted, never spread: the sample is kept without radiance.
                o.bad += 1;
                rec.radiance = [0.0; 3];
            }
            if s < self.layers {
                o.samples[s as usize] = rec;
            }
        }
        let mean = if sum_w > 0.0 { sum / sum_w } else { Vec3::ZERO };
        o.estimate = [mean.x, mean.y, mean.z, sum_w];
        o
    }

    /// The camera ray's primary hit, if any; a `fixed` ray is traced once per pixel (`fixed_hit`).
    fn primary_hit(
        &self,
        cs: &CameraSample<'_>,
        fixed_hit: &mut Option<Option<Hit>>,
        primary_rays: &mut u64,
    ) -> Option<Primary> {
        let (scene, ray, at) = (self.scene, &cs.ray, &cs.at);
        let trace = || at.intersect(ray.origin, ray.dir, 0.0, f32::INFINITY);
        let camera_hit = if self.fixed {
            *fixed_hit.get_or_insert_with(|| {
                *primary_rays += 1;
                trace()
            })
        } else {
            *primary_rays += 1;
            trace()
        };
        camera_hit.map(|hit| {
            let sp = at.surface(&hit, ray.origin, ray.dir);
            let mat = &scene.materials[sp.material as usize];
            Primary {
                x: sp.position,
                n: sp.shading_normal,
                kd: scene.albedo(&sp),
                ks: mat.specular,
                m: mat.phong_exponent,
            }
        })
    }

    /// The direction leaving `prim` and what it hits: the sample's record and its contribution
    /// `L · f cos/pdf` (the caller weighs it by the camera ray's weight).
    fn secondary(
        &self,
        cs: &CameraSample<'_>,
        prim: &Primary,
        rng: &PixelRng,
        rays: &mut PathRays,
    ) -> (LightSample, Vec3) {
        let (p, s, ray, at) = (&self.p, cs.s, &cs.ray, &cs.at);
        let wo = (ray.origin - prim.x).normalize_or_zero();
        let (wi, weight) = leave(prim, wo, p.lobe, self.ao, rng, s, self.count, self.stratified);
        let side = if wi.dot(prim.n) >= 0.0 { 1.0 } else { -1.0 };
        let origin = prim.x + prim.n * (side * p.eps);
        rays.secondary += 1;
        let hit = at.intersect(origin, wi, 0.0, f32::INFINITY);
        let mut rec = LightSample {
            origin: origin.to_array(),
            flags: SAMPLE_ESCAPED,
            direction: wi.to_array(),
            time: cs.t,
            lens: ray.lens.to_array(),
            ..Default::default()
        };
        let mut value = Vec3::ZERO;
        if let Some(hit) = hit {
            let sp = at.surface(&hit, origin, wi);
            let mat = &self.scene.materials[sp.material as usize];
            // Every hit is a sample of the light field, whatever this pixel's BRDF makes of
            // it (a black or below-surface direction still gives other pixels a splat).
            let radiance = if self.ao {
                occlusion(Some(hit.t), self.max_distance)
            } else {
                path_from_hit(at, p, hit, origin, wi, rng, s, rays).0
            };
            value = radiance;
            rec.flags = SAMPLE_HIT;
            rec.hit = sp.position.to_array();
            rec.distance = hit.t;
            rec.normal = sp.shading_normal.to_array();
            rec.kappa = if self.angular { kappa(mat.specular, mat.phong_exponent, p.lobe) } else { 0.0 };
            rec.radiance = radiance.to_array();
            rec.velocity = at.velocity(&sp).to_array();
        }
        (rec, value * weight)
    }
}

/// The primary record of a camera ray: its hit (`prim`), or only its time, weight and eye point
/// where it left the scene.
fn primary_record(prim: Option<&Primary>, cs: &CameraSample<'_>) -> LightPrimary {
    let (ray, t) = (&cs.ray, cs.t);
    match prim {
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
        None => LightPrimary { time: t, weight: ray.weight, eye: ray.origin.to_array(), ..Default::default() },
    }
}

/// Add the pixels' ray counts to the pass's counters and write the estimate, primary and sample
/// outputs.
fn write_outputs(ctx: &mut KernelCtx<'_>, out: Vec<Px>) -> Result<(), BackendError> {
    Counters::add(&ctx.counters.primary_rays, out.iter().map(|o| o.primary_rays).sum());
    Counters::add(&ctx.counters.secondary_rays, out.iter().map(|o| o.rays.secondary).sum());
    Counters::add(&ctx.counters.shadow_rays, out.iter().map(|o| o.rays.shadow).sum());
    Counters::add(&ctx.counters.non_finite_samples, out.iter().map(|o| o.bad).sum());
    let io = SampleIo::read(ctx)?;
    io.estimate.put(ctx, out.iter().map(|o| o.estimate).collect())?;
    io.primary.put(ctx, out.iter().flat_map(|o| o.primary.iter().copied()).collect())?;
    io.samples.put(ctx, out.into_iter().flat_map(|o| o.samples).collect())
}
