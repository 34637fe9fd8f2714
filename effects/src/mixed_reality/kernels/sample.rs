//! `mr.sample`: the two-mode sampler of Algorithm 1 (see [`super`]); WGSL `shaders/mr_sample.wgsl`.

use glam::{Vec2, Vec3};
use wedge_scene::{Camera, EnvSample, EnvironmentMap, Hit, RealLayer, Scene, SceneAt};

use wedge_backends::kernels::environment::{stratified_entry, uniform_entry};
use wedge_backends::kernels::hemisphere::{glossy_pdf, sample_diffuse, sample_glossy, Lobe};
use wedge_backends::kernels::indirect::Vertex;
use wedge_backends::kernels::paths::camera_uniforms;
use wedge_backends::kernels::screen_trace::{ScreenHit, ScreenTracer};
use wedge_backends::kernels::{luminance, widen_range};
use wedge_backends::sobol::{independent2, pair, sequence_key, sobol2};
use wedge_backends::{
    BackendError, Counters, Kernel, KernelCtx, KernelParams, PutWith, Sampling, Uniforms, WgslSource,
};

use super::SampleIo;

/// The object id (`position.w − 1`) of the real layer's surfaces: one "object" for the filters'
/// same-object test, far above any scene's object count (`1 + REAL_OBJECT` is exact in f32).
pub const REAL_OBJECT: u32 = 1 << 22;

/// Offset of secondary ray origins along the normal, relative to the scene's extent.
const EPS_RELATIVE: f32 = 1e-4;

wedge_backends::kernel_params! {
    /// `mr.sample`'s parameters the node declares and forwards as they are.
    pub struct MrParams {
        occluder_threshold: f32 = float(0.1, 0.0, 1e6, "look-ups dimmer than this × the map's mean radiance do not set the occluder term"),
        thickness: f32 = positive(0.05, 1e3, "screen-space rays: a real surface's assumed thickness, as a fraction of its depth"),
        max_steps: u32 = int(0, 0, 1 << 16, "screen-space rays: the most pixels one ray marches; 0 = the image diagonal"),
    }
}

wedge_backends::kernel_params! {
    /// `mr.sample`'s counts, which the node sets (`count` = its `primary`), and the pass's stream.
    pub struct MrCounts {
        count: u32,
        per_primary: u32,
        stream: u32,
        sampling: Sampling,
    }
}

/// `mr.sample`'s settings.
#[derive(Clone, Copy, Debug)]
pub struct MrSettings {
    pub count: u32,
    pub per_primary: u32,
    pub stratified: bool,
    pub stream: u32,
    pub occluder_luminance: f32,
    pub thickness: f32,
    pub max_steps: u32,
    pub eps: f32,
}

fn settings(ctx: &KernelCtx<'_>) -> Result<MrSettings, BackendError> {
    let err = |m: String| BackendError::Kernel { pass: ctx.pass.into(), message: m };
    let scene = ctx.scene;
    let layer = scene.real.as_ref().ok_or_else(|| {
        err("the scene has no real layer (camera image, position and normal maps): the MixedReality node loads one"
            .into())
    })?;
    // The full image's size: a tile's window reads the layer at its own place in it.
    let (width, height) = ctx.full_size();
    if layer.width() != width || layer.height() != height {
        return Err(err(format!(
            "the real layer is {}x{} but the image is {}x{}: render at the capture's size",
            layer.width(),
            layer.height(),
            width,
            height
        )));
    }
    let env = scene
        .environment
        .as_ref()
        .ok_or_else(|| err("mixed reality needs an environment map (the light of the real scene)".into()))?;
    let (p, c) = (MrParams::read(ctx)?, MrCounts::read(ctx)?);
    let (threshold, thickness) = (p.occluder_threshold, p.thickness);
    if !(threshold.is_finite() && threshold >= 0.0 && thickness.is_finite() && thickness > 0.0) {
        return Err(err(format!("occluder_threshold {threshold} must be >= 0 and thickness {thickness} > 0")));
    }
    let diagonal = (width as f32).hypot(height as f32).ceil() as u32 + 1;
    Ok(MrSettings {
        count: c.count.min(1 << 16),
        per_primary: c.per_primary.clamp(1, 1 << 12),
        stratified: c.sampling == Sampling::Stratified,
        stream: c.stream,
        occluder_luminance: threshold * (env.total_luminance() / (4.0 * std::f64::consts::PI)) as f32,
        thickness,
        max_steps: if p.max_steps == 0 { diagonal } else { p.max_steps.min(diagonal) },
        eps: EPS_RELATIVE * scene.extent().max(1e-3),
    })
}

/// Sample `index` of pair `pair` of pixel `pixel`'s sequence.
#[inline]
fn draw(s: &MrSettings, seed: u32, pixel: u32, pair: u32, index: u32) -> Vec2 {
    let key = sequence_key(seed, pixel, s.stream, pair);
    Vec2::from(if s.stratified { sobol2(key, index) } else { independent2(key, index) })
}

/// A surface a secondary sample starts from.
#[derive(Clone, Copy, Debug)]
struct Receiver {
    /// Virtual surfaces: their own; real ones `k_d, k_s, m = (1, 0, 0)` (diffuse; albedo divided out).
    v: Vertex,
    real: bool,
}

/// Per-pixel sums of `mr.sample`.
#[derive(Clone, Copy, Debug, Default)]
struct Sums {
    e_r_dir: Vec3,
    e_r_ind: Vec3,
    e_rv_dir: Vec3,
    e_rv_ind: Vec3,
    e_v_dir: Vec3,
    e_v_ind: Vec3,
    /// Secondary samples at real surfaces and at virtual ones (each sum's divisor).
    real_samples: u32,
    virtual_samples: u32,
    real_primary: u32,
    virtual_primary: u32,
    k_v: Vec3,
    virtual_position: Vec3,
    virtual_normal: Vec3,
    virtual_object: u32,
    occluder: f32,
    exponent: f32,
    look_ups: u32,
    blocked: u32,
    z_min: f32,
    z_max: f32,
    ind_hits: u32,
    ind_rays: u32,
    screen_rays: u32,
    offscreen: u32,
    screen_hits: u32,
    /// Rays traced, BVH and screen-space alike: camera rays, rays toward the environment (shadow
    /// rays, at the receivers and at virtual indirect hits), indirect rays.
    primary_rays: u32,
    shadow_rays: u32,
    indirect_rays: u32,
    non_finite: u32,
}

/// What the pixel's outputs are, in buffer order.
pub struct MrPixel {
    pub e: [[f32; 3]; 6],
    pub texture: [f32; 4],
    pub position: [f32; 4],
    pub normal: [f32; 4],
    pub environment: [f32; 4],
    pub depth: [f32; 4],
    pub screen: [f32; 4],
    /// Rays per kind (camera, toward the environment, indirect), BVH and screen-space rays alike.
    pub rays: [u64; 3],
    pub non_finite: u64,
}

/// The world as the two modes see it at one pixel.
struct World<'a> {
    scene: SceneAt<'a>,
    screen: &'a ScreenTracer<'a>,
}

impl World<'_> {
    /// A screen-space ray, counted.
    fn screen(&self, sums: &mut Sums, o: Vec3, d: Vec3) -> ScreenHit {
        sums.screen_rays += 1;
        let h = self.screen.trace(o, d);
        match h {
            ScreenHit::Offscreen => sums.offscreen += 1,
            ScreenHit::Hit { .. } => sums.screen_hits += 1,
            ScreenHit::Miss => {}
        }
        h
    }
}

/// Radiance leaving a virtual hit `y` toward `-d`: one environment look-up `u` with shadow rays in
/// both worlds (Algorithm 1, line 29).
fn virtual_hit_radiance(world: &World<'_>, s: &MrSettings, sums: &mut Sums, v: &Vertex, u: f32) -> Vec3 {
    let env = world.scene.scene().environment.as_ref().expect("checked in settings");
    let e = env.table(uniform_entry(u) as usize);
    let cos = v.n.dot(e.dir);
    if !(cos > 0.0 && e.pdf > 0.0) {
        return Vec3::ZERO;
    }
    let origin = v.x + v.n * s.eps;
    sums.shadow_rays += 1;
    if world.scene.occluded(origin, e.dir, 0.0, f32::INFINITY) {
        return Vec3::ZERO;
    }
    sums.shadow_rays += 1;
    if matches!(world.screen(sums, origin, e.dir), ScreenHit::Hit { .. }) {
        return Vec3::ZERO;
    }
    e.radiance * v.brdf(Lobe::Phong, e.dir) * (cos / e.pdf)
}

/// One primary sample's `per_primary` secondary samples at receiver `r` ([`super`]'s doc): each is a
/// direct-light look-up and an indirect ray, added to the receiver kind's sums.
#[allow(clippy::too_many_arguments)]
fn secondary(
    world: &World<'_>,
    s: &MrSettings,
    seed: u32,
    pixel: u32,
    shift: u32,
    first: u32,
    r: &Receiver,
    sums: &mut Sums,
) {
    let at = Secondary::new(world, s, seed, pixel, shift, r);
    for j in 0..s.per_primary {
        let q = first + j;
        let (dir_r, dir_rv) = at.direct(sums, q);
        let (ind_r, ind_rv) = at.indirect(sums, q);
        add_sample(sums, r.real, [dir_r, dir_rv, ind_r, ind_rv]);
    }
}

/// What [`secondary`]'s samples at one receiver share: the pixel's sequence, the ray origin and the
/// receiver's lobes, computed once per primary sample.
struct Secondary<'a> {
    world: &'a World<'a>,
    s: &'a MrSettings,
    seed: u32,
    pixel: u32,
    /// The stratified look-ups' shift ([`stratified_entry`]), the pixel's own.
    shift: u32,
    r: &'a Receiver,
    env: &'a EnvironmentMap,
    /// Secondary rays start off the surface by `s.eps`, so they do not hit it again.
    origin: Vec3,
    /// k_V for dividing a virtual sample's outgoing radiance (0 channels stay 0).
    k_v: Vec3,
    /// Whether a virtual receiver has a glossy lobe, and how often its indirect direction comes from it
    /// (the lobes' luminance ratio).
    glossy: bool,
    p_glossy: f32,
}

impl<'a> Secondary<'a> {
    fn new(world: &'a World<'a>, s: &'a MrSettings, seed: u32, pixel: u32, shift: u32, r: &'a Receiver) -> Self {
        let env = world.scene.scene().environment.as_ref().expect("checked in settings");
        let glossy = !r.real && r.v.glossy();
        let (lum_d, lum_s) = (luminance(r.v.kd), if glossy { luminance(r.v.ks) } else { 0.0 });
        let p_glossy = if lum_d + lum_s > 0.0 { lum_s / (lum_d + lum_s) } else { 0.0 };
        let (origin, k_v) = (r.v.x + r.v.n * s.eps, r.v.kd + r.v.ks);
        Secondary { world, s, seed, pixel, shift, r, env, origin, k_v, glossy, p_glossy }
    }

    /// Sample `index` of pair `pair` of the pixel's sequence.
    fn draw(&self, pair: u32, index: u32) -> Vec2 {
        draw(self.s, self.seed, self.pixel, pair, index)
    }

    /// `l` divided by k_V per channel (a channel where k_V is 0 stays 0): the filters multiply the
    /// texture back in.
    fn per_k(&self, l: Vec3) -> Vec3 {
        let k_v = self.k_v;
        Vec3::new(
            if k_v.x > 0.0 { l.x / k_v.x } else { 0.0 },
            if k_v.y > 0.0 { l.y / k_v.y } else { 0.0 },
            if k_v.z > 0.0 { l.z / k_v.z } else { 0.0 },
        )
    }

    /// Direct light of sample `q`: look-up `q` of the environment table with one BVH and one
    /// screen-space shadow ray; `(real world alone, both worlds)` (a virtual receiver has only the latter).
    fn direct(&self, sums: &mut Sums, q: u32) -> (Vec3, Vec3) {
        let (s, r) = (self.s, self.r);
        sums.look_ups += 1;
        let entry = if s.stratified {
            stratified_entry(self.shift, q)
        } else {
            uniform_entry(self.draw(pair::ENVIRONMENT, q).x)
        };
        let e = self.env.table(entry as usize);
        let cos = r.v.n.dot(e.dir);
        let (mut dir_r, mut dir_rv) = (Vec3::ZERO, Vec3::ZERO);
        if cos > 0.0 && e.pdf > 0.0 {
            let (t_v, t_r) = self.shadow_rays(sums, &e, cos);
            let l = e.radiance * (cos / e.pdf);
            if r.real {
                let lit = l * std::f32::consts::FRAC_1_PI;
                if t_r.is_none() {
                    dir_r = lit;
                    if t_v.is_none() {
                        dir_rv = lit;
                    }
                }
            } else if t_r.is_none() && t_v.is_none() {
                dir_rv = self.per_k(l * r.v.brdf(Lobe::Phong, e.dir));
            }
        }
        (dir_r, dir_rv)
    }

    /// The BVH and the screen-space shadow ray toward look-up `e` (`cos` = its cosine at the receiver):
    /// the distances to the virtual and the real blocker. A bright look-up's nearest blocker sets the
    /// occluder term (a dim one's BVH ray only asks whether anything is in the way: `INFINITY`).
    fn shadow_rays(&self, sums: &mut Sums, e: &EnvSample, cos: f32) -> (Option<f32>, Option<f32>) {
        let (world, origin) = (self.world, self.origin);
        sums.shadow_rays += 2;
        let bright = luminance(e.radiance) >= self.s.occluder_luminance;
        let t_v = if bright {
            world.scene.intersect(origin, e.dir, 0.0, f32::INFINITY).map(|h| h.t)
        } else {
            world.scene.occluded(origin, e.dir, 0.0, f32::INFINITY).then_some(f32::INFINITY)
        };
        let t_r = match world.screen(sums, origin, e.dir) {
            ScreenHit::Hit { t, .. } => Some(t),
            _ => None,
        };
        if t_v.is_some() || t_r.is_some() {
            sums.blocked += 1;
            let t = t_v.unwrap_or(f32::INFINITY).min(t_r.unwrap_or(f32::INFINITY));
            if bright && t.is_finite() && t > 0.0 {
                sums.occluder = sums.occluder.max(cos / t);
            }
        }
        (t_v, t_r)
    }

    /// Indirect light of sample `q`: one direction from the receiver's BRDF, traced in both worlds;
    /// `(real world alone, both worlds: the nearest hit)`.
    fn indirect(&self, sums: &mut Sums, q: u32) -> (Vec3, Vec3) {
        let r = self.r;
        let wi = self.indirect_direction(q);
        let cos_i = r.v.n.dot(wi);
        let (mut ind_r, mut ind_rv) = (Vec3::ZERO, Vec3::ZERO);
        if cos_i > 0.0 && wi.is_finite() {
            let pdf = self.indirect_pdf(cos_i, wi);
            sums.ind_rays += 1;
            // One BVH and one screen-space ray.
            sums.indirect_rays += 2;
            let (l_r, l_v) = self.trace_indirect(sums, wi, q);
            let nearest = match (l_r, l_v) {
                (Some(a), Some(b)) => Some(if a.0 < b.0 { a } else { b }),
                (a, b) => a.or(b),
            };
            if let Some((t, _)) = nearest {
                record_indirect_depth(sums, t);
            }
            if pdf > 0.0 {
                if let Some((_, l)) = l_r {
                    ind_r = self.indirect_weight(l, wi, cos_i, pdf);
                }
                if let Some((_, l)) = nearest {
                    ind_rv = self.indirect_weight(l, wi, cos_i, pdf);
                }
            }
        }
        (ind_r, ind_rv)
    }

    /// Sample `q`'s indirect direction: the glossy lobe with probability `p_glossy`, else the diffuse one.
    fn indirect_direction(&self, q: u32) -> Vec3 {
        let r = self.r;
        let u = self.draw(pair::HEMISPHERE_DIFFUSE, q);
        let pick = self.draw(pair::HEMISPHERE_GLOSSY, q);
        if self.glossy && pick.x < self.p_glossy {
            sample_glossy(Lobe::Phong, r.v.m, r.v.n, r.v.wo, u).0
        } else {
            sample_diffuse(r.v.n, u)
        }
    }

    /// The mixture pdf of the two lobes toward `wi` (diffuse alone: cos/π).
    fn indirect_pdf(&self, cos_i: f32, wi: Vec3) -> f32 {
        let r = self.r;
        let pdf_d = cos_i * std::f32::consts::FRAC_1_PI;
        if self.glossy {
            (1.0 - self.p_glossy) * pdf_d + self.p_glossy * glossy_pdf(Lobe::Phong, r.v.m, r.v.n, r.v.wo, wi)
        } else {
            pdf_d
        }
    }

    /// The indirect ray `wi` in both worlds: `(distance, radiance)` of the real (screen-space) hit, the
    /// camera image there, and of the virtual (BVH) hit, one environment look-up there.
    fn trace_indirect(&self, sums: &mut Sums, wi: Vec3, q: u32) -> (Option<IndirectHit>, Option<IndirectHit>) {
        let (world, origin) = (self.world, self.origin);
        let hit_v = world.scene.intersect(origin, wi, 0.0, f32::INFINITY);
        let hit_r = world.screen(sums, origin, wi);
        let l_r = match hit_r {
            ScreenHit::Hit { t, x, y } => Some((t, world.screen.layer.camera(x, y))),
            _ => None,
        };
        let l_v = hit_v.map(|h| {
            let v = Vertex::on(world.scene.scene(), &world.scene.surface(&h, origin, wi), wi);
            let u_env = self.draw(pair::PATH, q).x;
            (h.t, virtual_hit_radiance(world, self.s, sums, &v, u_env))
        });
        (l_r, l_v)
    }

    /// Radiance `l` arriving along `wi` as the receiver's estimate: over the diffuse BRDF for a real
    /// receiver (albedo divided out), through the Phong BRDF and divided by k_V for a virtual one.
    fn indirect_weight(&self, l: Vec3, wi: Vec3, cos_i: f32, pdf: f32) -> Vec3 {
        let r = self.r;
        if r.real {
            l * (cos_i * std::f32::consts::FRAC_1_PI / pdf)
        } else {
            self.per_k(l * r.v.brdf(Lobe::Phong, wi) * (cos_i / pdf))
        }
    }
}

/// An indirect ray's hit: its distance and the radiance it sends back toward the receiver.
type IndirectHit = (f32, Vec3);

/// Note an indirect hit at distance `t`: the pixel's hit count and the range of hit distances.
fn record_indirect_depth(sums: &mut Sums, t: f32) {
    sums.ind_hits += 1;
    widen_range((&mut sums.z_min, &mut sums.z_max), t, sums.ind_hits == 1);
}

/// Count one secondary sample and add its estimates `[dir_r, dir_rv, ind_r, ind_rv]` to its receiver
/// kind's sums (a virtual receiver has only the both-worlds ones); a non-finite estimate is counted
/// and adds 0.
fn add_sample(sums: &mut Sums, real: bool, [dir_r, dir_rv, ind_r, ind_rv]: [Vec3; 4]) {
    for v in [dir_r, dir_rv, ind_r, ind_rv] {
        if !v.is_finite() {
            sums.non_finite += 1;
        }
    }
    let f = |v: Vec3| if v.is_finite() { v } else { Vec3::ZERO };
    if real {
        sums.real_samples += 1;
        sums.e_r_dir += f(dir_r);
        sums.e_rv_dir += f(dir_rv);
        sums.e_r_ind += f(ind_r);
        sums.e_rv_ind += f(ind_rv);
    } else {
        sums.virtual_samples += 1;
        sums.e_v_dir += f(dir_rv);
        sums.e_v_ind += f(ind_rv);
    }
}

/// `mr.sample` at pixel `(px, py)`; `screen` is the real layer's tracer for `camera` (built once per
/// image: it holds the layer's depth pyramid).
#[allow(clippy::too_many_arguments)]
pub fn sample_pixel(
    scene: &Scene,
    camera: &Camera,
    screen: &ScreenTracer<'_>,
    s: &MrSettings,
    seed: u32,
    px: u32,
    py: u32,
    width: u32,
    height: u32,
) -> MrPixel {
    let layer = screen.layer;
    let world = World { scene: scene.at(0.0), screen };
    let pixel = py * width + px;
    let mut sums = Sums::default();
    let shift = if s.stratified { uniform_entry(draw(s, seed, pixel, pair::ENVIRONMENT, 0).x) } else { 0 };
    let real_point = layer.position(px, py);
    let h = height.max(1) as f32;
    let tan_half = (camera.vfov_deg.to_radians() * 0.5).tan();
    let pixel_angle = 2.0 * tan_half / h;
    let mut footprint = 0.0f32;
    for i in 0..s.count {
        let jitter = if s.count > 1 { draw(s, seed, pixel, pair::PIXEL, i) } else { Vec2::splat(0.5) };
        let (o, d) = camera.generate_ray(px as f32 + jitter.x, py as f32 + jitter.y, width, height, Vec2::splat(0.5));
        sums.primary_rays += 1;
        let hit = world.scene.intersect(o, d, 0.0, f32::INFINITY);
        let depth_r = real_point.map(|p| (p - o).length());
        let real = match (hit.as_ref(), depth_r) {
            (None, _) => true,
            (Some(h), Some(dr)) => dr < h.t,
            (Some(_), None) => false,
        };
        let first = i * s.per_primary;
        let r = if real {
            sums.real_primary += 1;
            let Some(p) = real_point else {
                // Neither world has a surface here: the camera image shows the environment.
                continue;
            };
            let n = layer.normal(px, py);
            Receiver { v: Vertex { x: p, n, wo: -d, kd: Vec3::ONE, ks: Vec3::ZERO, m: 0.0 }, real: true }
        } else {
            let h = hit.expect("a virtual sample has a hit");
            let (r, area) = virtual_receiver(&world, &mut sums, &h, o, d, pixel_angle);
            footprint += area;
            r
        };
        secondary(&world, s, seed, pixel, shift, first, &r, &mut sums);
    }
    let surface = filter_surface(&sums, s, layer, camera, (px, py), pixel_angle, footprint);
    pixel_outputs(&sums, surface)
}

/// The virtual surface a camera ray `(o, d)` hit at `h`, as a receiver; its texture, position, normal,
/// object and Phong exponent go into the pixel's sums, and its footprint term (the hit's
/// world-space width over one pixel, widened at grazing angles) is returned with it.
fn virtual_receiver(
    world: &World<'_>,
    sums: &mut Sums,
    h: &Hit,
    o: Vec3,
    d: Vec3,
    pixel_angle: f32,
) -> (Receiver, f32) {
    let scene = world.scene.scene();
    let sp = world.scene.surface(h, o, d);
    let v = Vertex::on(scene, &sp, d);
    sums.virtual_primary += 1;
    sums.k_v += v.kd + v.ks;
    sums.virtual_position += sp.position;
    sums.virtual_normal += sp.shading_normal;
    if sums.virtual_object == 0 {
        sums.virtual_object = 1 + sp.object;
    }
    sums.exponent += if v.glossy() { v.m } else { 0.0 };
    let c = sp.shading_normal.dot(-d).abs().max(0.05);
    let area = h.t * pixel_angle / c.sqrt();
    (Receiver { v, real: false }, area)
}

/// The filters' surface at the pixel, `(position, normal)` as the buffers hold them: the pixel's
/// majority kind (real on a tie); none where neither has one.
fn filter_surface(
    sums: &Sums,
    s: &MrSettings,
    layer: &RealLayer,
    camera: &Camera,
    (px, py): (u32, u32),
    pixel_angle: f32,
    footprint: f32,
) -> ([f32; 4], [f32; 4]) {
    let real_surfaces = sums.real_samples / s.per_primary.max(1);
    if real_surfaces > 0 && real_surfaces >= sums.virtual_primary {
        let p = layer.position(px, py).expect("real samples have the pixel's real point");
        let n = layer.normal(px, py);
        let z = (p - camera.position).length();
        let c = n.dot((camera.position - p).normalize_or_zero()).abs().max(0.05);
        ([p.x, p.y, p.z, 1.0 + REAL_OBJECT as f32], [n.x, n.y, n.z, z * pixel_angle / c.sqrt()])
    } else if sums.virtual_primary > 0 {
        let k = sums.virtual_primary as f32;
        let p = sums.virtual_position / k;
        let n = (sums.virtual_normal / k).normalize_or_zero();
        ([p.x, p.y, p.z, sums.virtual_object as f32], [n.x, n.y, n.z, footprint / k])
    } else {
        ([0.0; 4], [0.0; 4])
    }
}

/// The pixel's outputs from its sums: each sum over its own sample count, `(position, normal)` from
/// [`filter_surface`].
fn pixel_outputs(sums: &Sums, (position, normal): ([f32; 4], [f32; 4])) -> MrPixel {
    let mean = |v: Vec3, n: u32| if n > 0 { (v / n as f32).to_array() } else { [0.0; 3] };
    let (nr, nv) = (sums.real_samples, sums.virtual_samples);
    let total = sums.real_primary + sums.virtual_primary;
    let m_real = if total > 0 { sums.real_primary as f32 / total as f32 } else { 1.0 };
    let k_v = mean(sums.k_v, sums.virtual_primary);
    let exponent = if sums.virtual_primary > 0 { sums.exponent / sums.virtual_primary as f32 } else { 0.0 };
    MrPixel {
        e: [
            mean(sums.e_r_dir, nr),
            mean(sums.e_r_ind, nr),
            mean(sums.e_rv_dir, nr),
            mean(sums.e_rv_ind, nr),
            mean(sums.e_v_dir, nv),
            mean(sums.e_v_ind, nv),
        ],
        texture: [k_v[0], k_v[1], k_v[2], m_real],
        position,
        normal,
        environment: [sums.occluder, exponent, sums.look_ups as f32, sums.blocked as f32],
        depth: [
            if sums.ind_hits > 0 { sums.z_min } else { 0.0 },
            sums.z_max,
            sums.ind_hits as f32,
            sums.ind_rays as f32,
        ],
        screen: [sums.screen_rays as f32, sums.offscreen as f32, sums.screen_hits as f32, 0.0],
        rays: [sums.primary_rays as u64, sums.shadow_rays as u64, sums.indirect_rays as u64],
        non_finite: sums.non_finite as u64,
    }
}

/// `mr.sample`: the two-mode sampler ([`super`]'s doc).
pub struct MrSample;

impl Kernel for MrSample {
    wedge_backends::kernel_signature!(
        name: "mr.sample", class: Sampling, bindings: SampleIo, params: [MrParams, MrCounts], random: true
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/mr_sample.wgsl"), |ctx| {
                let s = settings(ctx)?;
                let u = Uniforms::new()
                    .u32("count", s.count)
                    .u32("per_primary", s.per_primary)
                    .u32("stratified", s.stratified as u32)
                    .u32("stream", s.stream)
                    .f32("occluder_luminance", s.occluder_luminance)
                    .f32("thickness", s.thickness)
                    .u32("max_steps", s.max_steps)
                    .f32("eps", s.eps)
                    // surface_brdf (environment_light.wgsl) reads the lobe: Phong, as the CPU's brdf.
                    .u32("lobe", 0);
                Ok(camera_uniforms(u, &ctx.scene.camera, wedge_scene::LensShape::Disk))
            })
            .with_include("screen_trace.wgsl", include_str!("../../../../shaders/screen_trace.wgsl"))
            .with_scene()
            .per_pixel()
            // A reference takes thousands of primaries per pixel; lavapipe stops an invocation's
            // loops after 65,535 iterations in all (measured: 57.4 of 64 primaries per pixel at
            // 32x24 unchunked), so the primaries run as chunks that resume from the saved sums.
            .chunked(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let s = settings(ctx)?;
        let io = SampleIo::read(ctx)?;
        let (scene, seed, window) = (ctx.scene, ctx.seed, ctx.window);
        let (width, height) = window.full_size();
        let camera = scene.camera;
        let layer = scene.real.as_ref().expect("checked in settings");
        let screen = ScreenTracer::new(layer, &camera, s.thickness, s.max_steps);
        // Each pixel at its place in the full image (a tile's window is part of it).
        let px = ctx.map_pixels(true, |x, y| {
            let (gx, gy) = window.global_xy(x, y);
            sample_pixel(scene, &camera, &screen, &s, seed, gx, gy, width, height)
        });
        let total = |k: usize| px.iter().map(|p| p.rays[k]).sum::<u64>();
        Counters::add(&ctx.counters.primary_rays, total(0));
        Counters::add(&ctx.counters.shadow_rays, total(1));
        Counters::add(&ctx.counters.secondary_rays, total(2));
        Counters::add(&ctx.counters.non_finite_samples, px.iter().map(|p| p.non_finite).sum());
        let e = [io.e_r_dir, io.e_r_ind, io.e_rv_dir, io.e_rv_ind, io.e_v_dir, io.e_v_ind];
        for (k, out) in e.into_iter().enumerate() {
            out.put(ctx, px.iter().map(|p| p.e[k]).collect())?;
        }
        io.texture.put(ctx, px.iter().map(|p| p.texture).collect())?;
        io.position.put(ctx, px.iter().map(|p| p.position).collect())?;
        io.normal.put(ctx, px.iter().map(|p| p.normal).collect())?;
        io.environment.put(ctx, px.iter().map(|p| p.environment).collect())?;
        io.depth.put(ctx, px.iter().map(|p| p.depth).collect())?;
        io.screen.put_with(ctx, || px.iter().map(|p| p.screen).collect())
    }
}
