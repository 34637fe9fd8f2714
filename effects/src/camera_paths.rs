//! The camera paths of the progressive nodes (`PixelFilter`, `RadianceFilter`; seed 002 Sec. 3.3 and
//! 4.3.1): one path tracer both sample with, so the two estimate the same radiance the same way.
//! [`CameraDraws`] jitters a path over the pixel, the lens and the shutter; [`first_vertex`] shades it
//! with the shared estimators of `wedge_backends::kernels::indirect` (next-event estimation at every
//! vertex, the lobe-mixture continuation) and keeps the first vertex's radiance sample;
//! [`CameraPaths`] runs `count` of them per pixel. WGSL mirror: `shaders/first_vertex.wgsl`, and
//! `shaders/camera_path.wgsl` for the camera and the ray (`path_camera`, `path_camera_ray`).

use glam::{Vec2, Vec3};
use wedge_backends::kernels::hemisphere::Lobe;
use wedge_backends::kernels::indirect::{
    continuation_numbers, light_event, next_event, trace_path_split, LobeValue, PathParams, PathRays, Vertex,
};
use wedge_backends::rng::{dim, PixelRng};
use wedge_backends::{BackendError, Counters, KernelCtx, KernelParams, ParamSpec, Sampling, Uniforms};
use wedge_scene::{Camera, LensRay, LensShape, SceneAt};

/// How a pass's camera rays sample the camera — the one camera draw of every node that traces its
/// own camera paths (PixelFilter, RadianceFilter, MonteCarlo through a lens, LightField; issue 34
/// §3). Each of the pixel, the lens and the shutter is a dimension of its own (`dim::PIXEL`, `LENS`,
/// `TIME`): independent numbers, or with `strata` = n > 0 sample `j` of n stratified ones (CMJ per
/// dimension). WGSL mirror: `camera_path.wgsl` (`path_camera_ray`).
#[derive(Clone, Copy, Debug)]
pub struct CameraDraws {
    /// The lens's aperture shape (a Gaussian lens weighs its rays).
    pub shape: LensShape,
    /// Jittered over the pixel, or through its centre (LightField's primary hits).
    pub jitter: bool,
    /// Each ray takes its own shutter time `t` in [−1, 1] (the scene's motion parameter), else 0.
    pub time: bool,
    pub strata: u32,
}

impl CameraDraws {
    /// The progressive nodes' draws: jittered over the pixel, through a disk lens where the camera
    /// has an aperture and over the shutter where it is open over an interval, so the accumulation
    /// over frames converges to the image through the lens and over the shutter (issue 34 §2; seed
    /// 002 assumes a pinhole at one instant, and for such a camera the rays are as before).
    pub fn jittered(cam: &Camera, strata: u32) -> CameraDraws {
        CameraDraws { shape: LensShape::Disk, jitter: true, time: shutter_is_open(cam), strata }
    }

    /// The camera ray of path `j` through pixel (`px`, `py`) of an image `width` × `height`, and its
    /// time; the lens is sampled where `cam` has an aperture.
    pub fn ray(
        &self,
        cam: &Camera,
        rng: &PixelRng,
        j: u32,
        (px, py): (u32, u32),
        (width, height): (u32, u32),
    ) -> (LensRay, f32) {
        let draw =
            |d: u32| Vec2::from(if self.strata > 0 { rng.stratified2(j, self.strata, d) } else { rng.uniform2(j, d) });
        let offset = if self.jitter { draw(dim::PIXEL) } else { Vec2::splat(0.5) };
        let lens = if cam.aperture_radius > 0.0 { draw(dim::LENS) } else { Vec2::splat(0.5) };
        let t = if self.time { 2.0 * draw(dim::TIME).x - 1.0 } else { 0.0 };
        (cam.ray(Vec2::new(px as f32 + offset.x, py as f32 + offset.y), lens, width, height, self.shape), t)
    }
}

/// The camera's shutter is open over an interval: each path takes its own time.
pub fn shutter_is_open(cam: &Camera) -> bool {
    cam.shutter_open < cam.shutter_close
}

/// The camera's WGSL uniforms (`camera.wgsl`) and `draws`' as `camera_path.wgsl` reads them
/// (`path_camera`, `path_camera_ray`): `cam_shutter` (its `time`), `jitter` and `strata`.
pub fn camera_uniforms(u: Uniforms, cam: &Camera, draws: CameraDraws) -> Uniforms {
    wedge_backends::kernels::paths::camera_uniforms(u, cam, draws.shape)
        .u32("cam_shutter", draws.time as u32)
        .u32("jitter", draws.jitter as u32)
        .u32("strata", draws.strata)
}

wedge_backends::kernel_params! {
    /// A sampling pass's paths per pixel (`count`, set by the node) and random stream (`stream`, set
    /// by the graph for a `.random()` pass): `pixel_filter.sample`, `pixel_filter.range`,
    /// `radiance_filter.sample`.
    pub struct PathCount {
        count: u32,
        stream: u32,
    }
}

wedge_backends::kernel_params! {
    /// The path tracer's settings, declared alike on both progressive nodes, forwarded to their
    /// sampling passes and read there ([`CameraPaths::read`]). `sampling` places the camera rays'
    /// numbers: independent (a progressive frame's one path), or stratified over the pass's paths (a
    /// stratified reference's, MonteCarlo's through a lens).
    pub struct TracerParams {
        bounces: u32 = int(3, 1, 64, "path vertices after the first, each with next-event estimation"),
        brdf: Lobe,
        sampling: Sampling = choice("independent", Sampling::OPTIONS, "the camera rays' pixel, lens and time numbers: stratified over a pixel's paths of the pass (CMJ per dimension) or independent; light and later-vertex numbers stay independent"),
    }
}

/// The camera paths of a progressive sampling pass (`pixel_filter.sample`,
/// `radiance_filter.sample`): `count` jittered paths per pixel ([`CameraDraws::jittered`]), each shaded by
/// [`first_vertex`] on the stream `stream`.
pub struct CameraPaths {
    pub count: u32,
    pub path: PathParams,
    pub stream: u32,
    pub camera: Camera,
    /// Paths continue past their first vertex (`false`: the direct light there only).
    pub continues: bool,
    /// The first vertex's direct light is area light `l`'s alone — no emission, environment or
    /// background (MonteCarlo's `light` through a lens); `None`: all of them.
    pub one_light: Option<usize>,
    /// The camera rays: jittered, their numbers independent or `count` stratified ones.
    pub draws: CameraDraws,
}

impl CameraPaths {
    /// From the pass's `count`, `stream`, `bounces`, `brdf` and `sampling` and the scene's camera.
    pub fn read(ctx: &KernelCtx<'_>) -> Result<CameraPaths, BackendError> {
        let PathCount { count, stream } = PathCount::read(ctx)?;
        let TracerParams { bounces, brdf, sampling } = TracerParams::read(ctx)?;
        let path = PathParams::new(ctx, brdf, bounces, false, 0.0);
        let (camera, strata) = (ctx.scene.camera, if sampling == Sampling::Stratified { count } else { 0 });
        let draws = CameraDraws::jittered(&camera, strata);
        Ok(CameraPaths { count, path, stream, camera, continues: true, one_light: None, draws })
    }
    /// The parameters [`CameraPaths::read`] reads, for `Kernel::params`.
    pub fn specs() -> Vec<ParamSpec> {
        [PathCount::specs(), TracerParams::specs()].concat()
    }
    /// The WGSL's `Params` fields for them: the camera, `strata`, `count`, `stream`, `continues` and
    /// `indirect_path.wgsl`'s.
    pub fn uniforms(&self, u: Uniforms, ctx: &KernelCtx<'_>) -> Uniforms {
        let u = camera_uniforms(u, &self.camera, self.draws)
            .u32("count", self.count)
            .u32("stream", self.stream)
            .u32("continues", self.continues as u32)
            .i32("one_light", self.one_light.map_or(-1, |l| l as i32));
        self.path.uniforms(u, ctx)
    }
    /// Every pixel's paths folded into a `T` by `fold(state, j, path)`, which says whether path `j`
    /// was finite (the others are counted as non-finite samples); rays are counted too.
    pub fn run<T: Default + Send>(
        &self,
        ctx: &KernelCtx<'_>,
        fold: impl Fn(&mut T, u32, &FirstVertex) -> bool + Sync,
    ) -> Vec<T> {
        // The full image's pixel and size (a tile's window is part of it).
        let (seed, window) = (ctx.seed, ctx.window);
        let out = ctx.map_pixels(true, |px, py| {
            let rng = PixelRng::new(seed, window.pixel_id(px, py), self.stream);
            let (mut state, mut rays, mut bad) = (T::default(), PathRays::default(), 0u64);
            let pixel = window.global_xy(px, py);
            for j in 0..self.count {
                let (ray, t) = self.draws.ray(&self.camera, &rng, j, pixel, window.full_size());
                let at = ctx.scene.at(t);
                let v = first_vertex(&at, self, ray.origin, ray.dir, &rng, j, &mut rays);
                if !fold(&mut state, j, &v) {
                    bad += 1;
                }
            }
            (state, rays, bad)
        });
        Counters::add(&ctx.counters.primary_rays, ctx.pixels() as u64 * u64::from(self.count));
        Counters::add(&ctx.counters.shadow_rays, out.iter().map(|o| o.1.shadow).sum());
        Counters::add(&ctx.counters.secondary_rays, out.iter().map(|o| o.1.secondary).sum());
        Counters::add(&ctx.counters.non_finite_samples, out.iter().map(|o| o.2).sum());
        out.into_iter().map(|o| o.0).collect()
    }
}

/// The surface a camera path's first vertex lies on.
#[derive(Clone, Copy, Debug)]
pub struct FirstSurface {
    pub position: Vec3,
    pub normal: Vec3,
    /// Ray distance from the camera.
    pub distance: f32,
    pub albedo: Vec3,
    pub material: u32,
}

/// One camera path's first vertex: what the path tracer estimates there, and the radiance sample
/// radiance filtering stores (seed 002 Sec. 4.3.1, steps 1–2).
#[derive(Clone, Copy, Debug)]
pub struct FirstVertex {
    /// Emission + next-event estimation at the first vertex; the background on a miss.
    pub direct: Vec3,
    /// The indirect estimate `f L̆ cos/pdf` and its caustic part `f_d L̆_c cos/pdf`.
    pub indirect: Vec3,
    pub caustic: Vec3,
    pub surface: Option<FirstSurface>,
    /// The continuation direction drawn from the lobe mixture (`None`: black surface or a miss) and
    /// the incident radiance `L̆` along it (0 where it fell below the surface or had pdf 0).
    pub wi: Option<Vec3>,
    pub incident: Vec3,
    /// How far the continuation ray went before it hit a surface (`None`: it left the scene, or was
    /// not traced).
    pub bounce_distance: Option<f32>,
}

/// One path of `paths` through the camera ray `(origin, dir)` up to its first vertex and, where it
/// `continues`, beyond. Next-event estimation at the first vertex gives the direct light (toward
/// `one_light` alone, where set); the indirect light continues with one sample of the vertex's lobe
/// mixture (as [`trace_path_split`] continues at later vertices, on the first vertex's dimensions,
/// which the later vertices do not use).
pub fn first_vertex(
    at: &SceneAt<'_>,
    paths: &CameraPaths,
    origin: Vec3,
    dir: Vec3,
    rng: &PixelRng,
    j: u32,
    rays: &mut PathRays,
) -> FirstVertex {
    let (scene, p) = (at.scene(), &paths.path);
    let Some(hit) = at.intersect(origin, dir, 0.0, f32::INFINITY) else {
        // The environment seen directly (black without a map), unless one light is asked for.
        let bg = if paths.one_light.is_some() { Vec3::ZERO } else { scene.background(dir) };
        return FirstVertex {
            direct: bg,
            indirect: Vec3::ZERO,
            caustic: Vec3::ZERO,
            surface: None,
            wi: None,
            incident: Vec3::ZERO,
            bounce_distance: None,
        };
    };
    let sp = at.surface(&hit, origin, dir);
    let vertex = Vertex::on(scene, &sp, dir);
    let Vertex { x, n, wo, kd, ks, m } = vertex;
    let (emitted, direct) = match paths.one_light {
        None => (scene.emission(&sp), next_event(at, p, &vertex, rng, j, 0, rays).0),
        Some(l) => (Vec3::ZERO, light_event(at, p, l, &vertex, rng, j, 0, rays).map_or(Vec3::ZERO, |e| e.0)),
    };
    let surface = Some(FirstSurface { position: x, normal: n, distance: hit.t, albedo: kd, material: sp.material });
    let mut v = FirstVertex {
        direct: emitted + direct,
        indirect: Vec3::ZERO,
        caustic: Vec3::ZERO,
        surface,
        wi: None,
        incident: Vec3::ZERO,
        bounce_distance: None,
    };
    // The first vertex's lobe mixture (trace_path's continuation, bounce 0's dimensions).
    if let Some(mix) = vertex.mixture().filter(|_| paths.continues) {
        let (u, select) = continuation_numbers(rng, j, 0);
        let wi = mix.sample(p.lobe, m, n, wo, u, select);
        v.wi = Some(wi);
        let cos_i = wi.dot(n);
        if cos_i > 0.0 {
            let LobeValue { f, fd, pdf, .. } = mix.eval(p.lobe, kd, ks, m, n, wo, wi, cos_i);
            if pdf > 0.0 {
                let (li, lc, first) = trace_path_split(at, p, x, n, wi, rng, j, rays);
                v.incident = li;
                v.bounce_distance = first;
                v.indirect = li * (f * (cos_i / pdf));
                // Caustic paths leave the first vertex by its diffuse part.
                v.caustic = lc * (fd * (cos_i / pdf));
            }
        }
    }
    v
}
