//! Pixel filtering for progressive rendering (issue 18; Schwenk's thesis, `seeds/002_34c8a733cb47f3c2.txt`
//! Ch. 3, "Filtering Pixel Radiance"): the kernels of the `PixelFilter` node
//! (`wedge_effects::pixel_filter`) and the pure formulas they share, each unit-tested here and
//! mirrored in WGSL (`shaders/pixel_filter_*.wgsl`).
//!
//! A progressive render runs the pipeline once per frame (`render --progressive N`); the node's
//! running statistics go from one frame to the next through the graph's frame history
//! (`ExpandCtx::previous_frame`), and kernels that run on a schedule read the frame index
//! (`KernelCtx::frame`, WGSL `frame.frame_index`).
//!
//! - `pixel_filter.sample`: `count` paths per pixel (one per frame in progressive mode), each a
//!   jittered camera ray (thesis Sec. 3.3: pinhole, box pixel filter; through the lens and over the
//!   shutter where the camera opens them, [`camera_ray`]) shaded with the shared
//!   estimators of `indirect.rs` — next-event estimation at every vertex ([`next_event`]) and the
//!   one-sample lobe mixture continued by [`trace_path_split`] — split into the low-variance paths
//!   `L_lv` and the high-variance paths `L_u` by [`Split`] (Sec. 3.3, Fig. 3.1). Writes the batch's
//!   [`Stats`] (means, count, `M2` of `Y(L_u)`).
//! - `pixel_filter.accumulate`: the running statistics: the previous frame's [`Stats`] combined with
//!   this frame's batch ([`Stats::combine`], Welford/Chan: mean and `M2`, never sums of squares).
//! - `pixel_filter.range`: the range buffer (Sec. 3.3.3): albedo lit by ambient light and a head light
//!   ([`range_colour`]) in RGB, the nearest depth in A, `count` (4) jittered rays per filter pass
//!   averaged with the earlier passes' (4×, 8×, … supersampling).
//! - `pixel_filter.width`: the adaptive spatial width (Sec. 3.6.3, eqs. 3.15–3.17, [`adaptive_sigma`]).
//! - `pixel_filter.bilateral`: the brute-force cross-bilateral filter (eq. 3.6) of `L_u` with its
//!   variance reduction `Σa²` (eq. 3.5) and the per-pixel variance filtered with the same weights
//!   (Sec. 3.3.2); `pixel_filter.separable`: one 1-D pass of the iterated separable approximation
//!   (Sec. 3.6.1, eq. 3.14). Both run on filter frames only ([`is_filter_frame`]) and otherwise keep
//!   the last filtered buffer (the previous frame's, through the history).
//! - `pixel_filter.blend`: the per-pixel blend (eqs. 3.1, 3.10–3.13, [`blend_factor`]) with the
//!   optional spike clamp (eq. 3.18, [`spike_clamp`]).
//!
//! Buffer conventions (all `vec4`): the accumulation `lv` = (mean `L_lv`, n), `u` = (mean `L_u`,
//! `M2` of `Y(L_u)`); the filter's `filtered` = (`L_f`, `Var[L_f]` absolute) and `variance` =
//! (`σ²`: the filtered per-sample variance of `L_u`, `r = Σa²`, n at the filter pass, [`FILTERED`]);
//! the range buffer = (colour, depth).

use glam::{Vec2, Vec3};
use wedge_graph::Format;
use wedge_scene::{Camera, LensRay, LensShape, SceneAt};

use crate::kernel::{Binding, Counters, Kernel, KernelClass, KernelCtx, Reach, Uniforms, WgslSource};
use crate::kernels::indirect::{
    continuation_numbers, lobe_mixture, next_event, trace_path_split, LobeValue, PathParams, PathRays,
};
use crate::rng::{dim, PixelRng};
use crate::BackendError;

// ---------------------------------------------------------------------------------------------
// Formulas (pure; WGSL mirror: shaders/pixel_filter_formulas.wgsl)
// ---------------------------------------------------------------------------------------------

pub use crate::kernels::luminance;

/// `variance.w` of a pixel the filter wrote. The accumulation's `M2` (≥ 0) never equals it, so a
/// reference, whose filters are bypassed to the accumulation, blends with `s = 1`, as does a frame
/// before the first filter pass (history zeros).
pub const FILTERED: f32 = -1.0;

/// Depth of a range-buffer sample whose ray left the scene: far from every surface, yet its square
/// over `2σ_d²` stays finite in f32 (so `exp` gives 0 on both backends, not `exp(-inf)`).
pub const MISS_DEPTH: f32 = 1e9;

/// One pixel's running statistics: the means of `L_lv` and `L_u`, the number of paths `n`, and
/// `M2 = Σ (Y_k − Ȳ)²` of the luminance of `L_u` (Welford; the per-path variance is `M2 / (n − 1)`,
/// the variance of the mean `M2 / (n (n − 1))`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Stats {
    pub lv: Vec3,
    pub u: Vec3,
    pub n: f32,
    pub m2: f32,
}

impl Stats {
    /// One path's sample.
    pub fn one(lv: Vec3, u: Vec3) -> Stats {
        Stats { lv, u, n: 1.0, m2: 0.0 }
    }
    /// From the buffers `lv` = (mean, n) and `u` = (mean, M2).
    pub fn from_buffers(lv: [f32; 4], u: [f32; 4]) -> Stats {
        Stats { lv: Vec3::new(lv[0], lv[1], lv[2]), u: Vec3::new(u[0], u[1], u[2]), n: lv[3], m2: u[3] }
    }
    pub fn lv_buffer(&self) -> [f32; 4] {
        [self.lv.x, self.lv.y, self.lv.z, self.n]
    }
    pub fn u_buffer(&self) -> [f32; 4] {
        [self.u.x, self.u.y, self.u.z, self.m2]
    }
    /// Two disjoint sets of paths as one (Chan, Golub and LeVeque's pairwise update; with `b` one
    /// path it is Welford's): `mean = mean_a + (mean_b − mean_a)·n_b/n`, `M2 = M2_a + M2_b +
    /// δ²·n_a·n_b/n`, δ the difference of the luminance means. Numerically stable: no sum of squares.
    /// The operation order is the WGSL's (`pf_combine`).
    pub fn combine(a: Stats, b: Stats) -> Stats {
        if !(b.n > 0.0) {
            return a;
        }
        if !(a.n > 0.0) {
            return b;
        }
        let n = a.n + b.n;
        let lv = a.lv + (b.lv - a.lv) * b.n / n;
        let u = a.u + (b.u - a.u) * b.n / n;
        let dy = luminance(b.u) - luminance(a.u);
        let m2 = a.m2 + b.m2 + dy * dy * a.n * b.n / n;
        Stats { lv, u, n, m2: m2.max(0.0) }
    }
    /// The unbiased per-path variance of `Y(L_u)`, `M2/(n − 1)`; `None` below two paths.
    pub fn sample_variance(&self) -> Option<f32> {
        (self.n >= 2.0).then(|| self.m2 / (self.n - 1.0))
    }
}

/// The blend factor `s` of eqs. 3.12–3.13 for perceived variances `u` (unfiltered) and `f`
/// (filtered) and threshold `t` (all ≥ 0; `u` or `f` may be `+∞` where the background radiance is 0):
/// - case 2, `u ≤ t`: 1 (the unfiltered buffer already meets the threshold; `u = f = 0` lands here);
/// - case 1, `tu + tf − uf < 0`: 0 (not even the filtered buffer meets it; `t = 0, u > 0, f > 0`);
/// - case 3: `s' = (f + √(tu + tf − uf)) / (u + f)`, the largest `s` with `s²u + (1−s)²f = t`
///   (eq. 3.9 with the covariance of eq. 3.8 set to zero, as the thesis does).
///
/// `u = +∞` (a black background, eq. 3.10, under noise) gives 0, the limit of `s'`.
#[allow(clippy::manual_clamp)]
pub fn blend_factor(u: f32, f: f32, t: f32) -> f32 {
    if !(u > t) {
        return 1.0;
    }
    if u == f32::INFINITY {
        return 0.0;
    }
    if f == f32::INFINITY {
        return 0.0;
    }
    let d = t * u + t * f - u * f;
    if d < 0.0 {
        return 0.0;
    }
    let s = (f + d.sqrt()) / (u + f);
    // max/min rather than clamp: NaN would become 0, as WGSL's rmax/rmin make it.
    s.max(0.0).min(1.0)
}

/// The spike clamp of eq. 3.18: `L_u` clamped per channel to `[L_f / c, c·L_f]`.
pub fn spike_clamp(lu: Vec3, lf: Vec3, c: f32) -> Vec3 {
    let lo = lf / c;
    let hi = lf * c;
    Vec3::new(lu.x.max(lo.x).min(hi.x), lu.y.max(lo.y).min(hi.y), lu.z.max(lo.z).min(hi.z))
}

/// Whether frame `frame` (0, 1, …: the frame has `frame + 1` paths per pixel) runs the filter
/// (thesis Sec. 3.3.3: "only every 2^i-th frame; usually starting with frame 4"): frames with
/// `n = first·2^i` paths, and — `first_frame` — the first frame of a run, so a single image and
/// the first frames of a progressive run are filtered too (a reading, see DESIGN-NOTES).
pub fn is_filter_frame(frame: u32, first: u32, first_frame: bool) -> bool {
    if frame == 0 && first_frame {
        return true;
    }
    let n = u64::from(frame) + 1;
    let first = u64::from(first.max(1));
    n % first == 0 && (n / first).is_power_of_two()
}

/// How many of frames `0..=frame` run the filter ([`is_filter_frame`]): the range buffer's pass
/// index (its running mean weighs each pass's samples equally).
pub fn filter_passes_through(frame: u32, first: u32, first_frame: bool) -> u32 {
    let mut count = u32::from(first_frame);
    let n = u64::from(frame) + 1;
    let mut k = u64::from(first.max(1));
    while k <= n {
        if !(k == 1 && first_frame) {
            count += 1;
        }
        k *= 2;
    }
    count
}

/// The spatial standard deviation of iteration `k` (1 ..= `iterations`) of the iterated separable
/// filter, eq. 3.14 (Gastal and Oliveira): `σ_k = σ √3 · 2^(N−k) / √(4^N − 1)`, so `Σ σ_k² = σ²`.
pub fn iteration_sigma(sigma: f32, k: u32, iterations: u32) -> f32 {
    let n = iterations.clamp(1, 16) as i32;
    let k = (k as i32).clamp(1, n);
    sigma * 3f32.sqrt() * 2f32.powi(n - k) / (4f32.powi(n) - 1.0).sqrt()
}

/// The adaptive spatial width of Sec. 3.6.3 at a pixel with per-path variance `sigma2` of `Y(L_u)`
/// (the filtered one of the last filter pass), `n` paths, background luminance `lb` (eq. 3.10) and
/// threshold `t`:
/// - eq. 3.15: the box half-extent `e = ½√(u/f) − ½` that brings the unfiltered perceived variance
///   `u = σ²/(n L_b²)` down to the target `f = t` (reading: the filtered buffer alone meets the
///   threshold), mapped to `σ = 1.5 e`;
/// - eqs. 3.16–3.17: clamped to `[σ̄(n)/c, c σ̄(n)]` around the guide `σ̄(n) = σ_s / √n`, and (reading)
///   never wider than `σ_s`, the user's maximum smoothing.
pub fn adaptive_sigma(sigma2: f32, n: f32, lb: f32, t: f32, sigma_s: f32, c: f32) -> f32 {
    let guide = sigma_s / n.max(1.0).sqrt();
    let ratio = if !(sigma2 > 0.0) {
        0.0
    } else {
        let target = n.max(1.0) * t * lb * lb;
        if target > 0.0 {
            sigma2 / target
        } else {
            f32::INFINITY
        }
    };
    let e = 0.5 * ratio.sqrt() - 0.5;
    let sigma = 1.5 * e;
    sigma.max(guide / c).min(guide * c).min(sigma_s)
}

/// The range buffer's colour of one surface (Sec. 3.3.3): its hemispherical reflectivity `ρ = k_d +
/// k_s` lit by unoccluded ambient light and by a head light at the eye (`cos` = |n·ω_eye|). Reading:
/// the two lights weigh ½ each, so a white surface facing the camera is 1.
#[inline]
pub fn range_colour(kd: Vec3, ks: Vec3, cos: f32) -> Vec3 {
    (kd + ks) * (0.5 + 0.5 * cos)
}

/// The cross-bilateral weight `a_i` of eq. 3.6 as one exponential: spatial distance² `ds2` (pixels²),
/// colour distance² `dc2` and depth difference `dd`, with `inv_*` = 1/(2σ²) of each kernel. Weights
/// below `e^-80` (1.8e-35) are 0 — on both backends alike (a GPU may flush what the CPU keeps as a
/// denormal), and most taps of a brute-force window on another surface skip the `exp`.
#[inline]
pub fn bilateral_weight(ds2: f32, dc2: f32, dd: f32, inv_s: f32, inv_c: f32, inv_d: f32) -> f32 {
    let x = ds2 * inv_s + dc2 * inv_c + dd * dd * inv_d;
    if !(x < WEIGHT_CUTOFF) {
        return 0.0;
    }
    (-x).exp()
}

/// Exponent beyond which a bilateral weight is 0 ([`bilateral_weight`]).
pub const WEIGHT_CUTOFF: f32 = 80.0;

/// `1 / (2σ²)`, 0 for σ = ∞ or a non-positive σ (that kernel off).
#[inline]
fn inv_two_sigma2(sigma: f32) -> f32 {
    if sigma > 0.0 && sigma.is_finite() {
        1.0 / (2.0 * sigma * sigma)
    } else {
        0.0
    }
}

// ---------------------------------------------------------------------------------------------
// Shared settings
// ---------------------------------------------------------------------------------------------

/// How paths are split into low- and high-variance buffers (Sec. 3.3, Fig. 3.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Split {
    /// `L_lv` = emission + direct light at the first vertex, `L_u` = the indirect light (the thesis's
    /// usual choice).
    Indirect,
    /// `L_u` = light reaching the first (diffuse) vertex through glossy scattering only (paths
    /// `L S+ D E`, [`trace_path_split`]); the rest in `L_lv`.
    Caustics,
    /// Everything in `L_u` (the thesis's Fig. 3.7).
    All,
}

impl Split {
    pub fn parse(s: &str) -> Option<Split> {
        match s {
            "indirect" => Some(Split::Indirect),
            "caustics" => Some(Split::Caustics),
            "all" => Some(Split::All),
            _ => None,
        }
    }
    fn code(self) -> u32 {
        match self {
            Split::Indirect => 0,
            Split::Caustics => 1,
            Split::All => 2,
        }
    }
}

/// The camera ray of path `j` through pixel (`px`, `py`) and its time: jittered over the pixel, over
/// the lens where the camera has an aperture and over the shutter where it is open over an interval
/// (`t` in [−1, 1], the scene's motion parameter; each a dimension of its own), so the accumulation
/// over frames converges to the image through the lens and over the shutter (issue 34 §2; seed 002
/// assumes a pinhole at one instant, and for such a camera the rays are as before, bit for bit). The
/// WGSL draws the same numbers in `pixel_filter_sample/range.wgsl` and `radiance_filter_sample.wgsl`.
fn camera_ray(
    cam: &Camera,
    rng: &PixelRng,
    j: u32,
    (px, py): (u32, u32),
    (width, height): (u32, u32),
) -> (LensRay, f32) {
    let jit = rng.uniform2(j, dim::PIXEL);
    let lens = if cam.aperture_radius > 0.0 { Vec2::from(rng.uniform2(j, dim::LENS)) } else { Vec2::splat(0.5) };
    let t = if shutter_is_open(cam) { 2.0 * rng.uniform2(j, dim::TIME)[0] - 1.0 } else { 0.0 };
    (cam.ray(Vec2::new(px as f32 + jit[0], py as f32 + jit[1]), lens, width, height, LensShape::Disk), t)
}

/// The camera's shutter is open over an interval: each path takes its own time.
fn shutter_is_open(cam: &Camera) -> bool {
    cam.shutter_open < cam.shutter_close
}

fn camera_uniforms(u: Uniforms, cam: &Camera) -> Uniforms {
    crate::kernels::paths::camera_uniforms(u, cam, LensShape::Disk).u32("cam_shutter", shutter_is_open(cam) as u32)
}

fn count_param(ctx: &KernelCtx<'_>, name: &str, max: i64) -> Result<u32, BackendError> {
    let v = ctx.int_param(name)?;
    if !(0..=max).contains(&v) {
        return Err(ctx.err(format!("`{name}` = {v} must be between 0 and {max}")));
    }
    Ok(v as u32)
}

/// The filter schedule of a pass: whether this frame filters, and which filter pass it is.
fn schedule(ctx: &KernelCtx<'_>) -> Result<(bool, u32), BackendError> {
    let first = count_param(ctx, "first_filter", 1 << 20)?.max(1);
    let first_frame = ctx.bool_param("filter_first_frame")?;
    Ok((is_filter_frame(ctx.frame, first, first_frame), filter_passes_through(ctx.frame, first, first_frame)))
}

/// The filter's kernel widths: spatial σ_s (pixels), colour σ_c, depth σ_d (metres), the truncation
/// in σ_s, and the largest window radius (pixels) any pixel may use.
#[derive(Clone, Copy, Debug)]
struct FilterParams {
    sigma_s: f32,
    sigma_c: f32,
    sigma_d: f32,
    truncate: f32,
}

impl FilterParams {
    fn read(ctx: &KernelCtx<'_>) -> Result<FilterParams, BackendError> {
        Ok(FilterParams {
            sigma_s: ctx.positive_f32_param("sigma_s")?,
            sigma_c: ctx.positive_f32_param("sigma_c")?,
            sigma_d: ctx.positive_f32_param("sigma_d")?,
            truncate: ctx.positive_f32_param("truncate")?,
        })
    }
    /// Window radius (pixels) for spatial σ `sigma`, capped at 1024.
    fn radius(&self, sigma: f32) -> u32 {
        (self.truncate * sigma).ceil().clamp(0.0, 1024.0) as u32
    }
    fn uniforms(&self, u: Uniforms) -> Uniforms {
        u.f32("sigma_s", self.sigma_s)
            .f32("inv_c", inv_two_sigma2(self.sigma_c))
            .f32("inv_d", inv_two_sigma2(self.sigma_d))
            .f32("truncate", self.truncate)
    }
}

// ---------------------------------------------------------------------------------------------
// pixel_filter.sample
// ---------------------------------------------------------------------------------------------

/// `pixel_filter.sample` (see the module doc).
pub struct PixelSample;

struct SampleSettings {
    paths: CameraPaths,
    split: Split,
}

fn sample_settings(ctx: &KernelCtx<'_>) -> Result<SampleSettings, BackendError> {
    let split = ctx.str_param("split")?;
    let split = Split::parse(split)
        .ok_or_else(|| ctx.err(format!("unknown split `{split}`; use indirect, caustics or all")))?;
    Ok(SampleSettings { paths: CameraPaths::read(ctx)?, split })
}

/// The camera paths of a progressive sampling pass (`pixel_filter.sample`,
/// `radiance_filter.sample`): `count` jittered paths per pixel ([`camera_ray`]), each shaded by
/// [`first_vertex`] on the stream `stream`.
pub struct CameraPaths {
    pub count: u32,
    pub path: PathParams,
    pub stream: u32,
    pub camera: Camera,
}

impl CameraPaths {
    /// From the pass's `count`, `stream`, `bounces` and `brdf` and the scene's camera.
    pub fn read(ctx: &KernelCtx<'_>) -> Result<CameraPaths, BackendError> {
        Ok(CameraPaths {
            count: count_param(ctx, "count", i64::from(u32::MAX))?,
            path: PathParams::from_params(ctx, false, 0.0)?,
            stream: ctx.int_param("stream")? as u32,
            camera: ctx.scene.camera,
        })
    }
    /// The WGSL's `Params` fields for them: the camera, `count`, `stream` and `indirect_path.wgsl`'s.
    pub fn uniforms(&self, u: Uniforms, ctx: &KernelCtx<'_>) -> Uniforms {
        let u = camera_uniforms(u, &self.camera).u32("count", self.count).u32("stream", self.stream);
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
            for j in 0..self.count {
                let (ray, t) = camera_ray(&self.camera, &rng, j, window.global_xy(px, py), window.full_size());
                let v = first_vertex(&ctx.scene.at(t), &self.path, ray.origin, ray.dir, &rng, j, &mut rays);
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

/// One path through the camera ray `(origin, dir)` up to its first vertex and beyond. Next-event
/// estimation at the first vertex gives the direct light; the indirect light continues with one
/// sample of the vertex's lobe mixture (as [`trace_path_split`] continues at later vertices, on the
/// first vertex's dimensions, which the later vertices do not use).
#[allow(clippy::too_many_arguments)]
pub fn first_vertex(
    at: &SceneAt<'_>,
    p: &PathParams,
    origin: Vec3,
    dir: Vec3,
    rng: &PixelRng,
    j: u32,
    rays: &mut PathRays,
) -> FirstVertex {
    let scene = at.scene();
    let Some(hit) = at.intersect(origin, dir, 0.0, f32::INFINITY) else {
        // The environment seen directly (black without a map).
        let bg = scene.background(dir);
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
    let (x, n, wo) = (sp.position, sp.shading_normal, -dir);
    let mat = &scene.materials[sp.material as usize];
    let kd = scene.albedo(&sp);
    let (ks, m) = (mat.specular, mat.phong_exponent);
    let emitted = scene.emission(&sp);
    let direct = next_event(at, p, x, n, wo, kd, ks, m, rng, j, 0, rays);
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
    if let Some(mix) = lobe_mixture(kd, ks, m) {
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

/// One camera path's `(L_lv, L_u)` under `split` (Sec. 3.3, Fig. 3.1).
pub fn split_path(v: &FirstVertex, split: Split) -> (Vec3, Vec3) {
    if v.surface.is_none() {
        return if split == Split::All { (Vec3::ZERO, v.direct) } else { (v.direct, Vec3::ZERO) };
    }
    match split {
        Split::Indirect => (v.direct, v.indirect),
        Split::Caustics => (v.direct + (v.indirect - v.caustic), v.caustic),
        Split::All => (Vec3::ZERO, v.direct + v.indirect),
    }
}

impl Kernel for PixelSample {
    fn name(&self) -> &'static str {
        "pixel_filter.sample"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Sampling
    }
    fn draws_random(&self) -> bool {
        true
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            // Mean L_lv, w = paths (finite ones) of this pass.
            Binding::write("lv", Format::Vec4),
            // Mean L_u, w = M2 of Y(L_u) over this pass's paths.
            Binding::write("hv", Format::Vec4),
        ]
    }
    /// WGSL mirror: `shaders/pixel_filter_sample.wgsl` (with the shared `indirect_path.wgsl`).
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/pixel_filter_sample.wgsl"), |ctx| {
                let s = sample_settings(ctx)?;
                Ok(s.paths.uniforms(Uniforms::new(), ctx).u32("split", s.split.code()))
            })
            .with_include("pixel_filter_formulas.wgsl", include_str!("../../../shaders/pixel_filter_formulas.wgsl"))
            .with_scene()
            .per_pixel()
            .chunked(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let s = sample_settings(ctx)?;
        let out: Vec<Stats> = s.paths.run(ctx, |st: &mut Stats, _, v| {
            let (lv, hv) = split_path(v, s.split);
            let finite = Vec3::is_finite(lv) && Vec3::is_finite(hv);
            if finite {
                *st = Stats::combine(*st, Stats::one(lv, hv));
            }
            finite
        });
        ctx.put("lv", out.iter().map(Stats::lv_buffer).collect::<Vec<_>>())?;
        ctx.put("hv", out.iter().map(Stats::u_buffer).collect::<Vec<_>>())
    }
}

// ---------------------------------------------------------------------------------------------
// pixel_filter.accumulate
// ---------------------------------------------------------------------------------------------

/// `pixel_filter.accumulate`: `(lv, hv) = combine(previous, sample)` per pixel ([`Stats::combine`]).
pub struct Accumulate;

impl Kernel for Accumulate {
    fn name(&self) -> &'static str {
        "pixel_filter.accumulate"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Compose
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("sample_lv", Format::Vec4),
            Binding::read("sample_hv", Format::Vec4),
            // The previous frame's accumulation (history; zeros in a first frame).
            Binding::read_opt("previous_lv", Format::Vec4),
            Binding::read_opt("previous_hv", Format::Vec4),
            Binding::write("lv", Format::Vec4),
            Binding::write("hv", Format::Vec4),
        ]
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/pixel_filter_accumulate.wgsl"), |_| Ok(Uniforms::new()))
                .with_include("pixel_filter_formulas.wgsl", include_str!("../../../shaders/pixel_filter_formulas.wgsl"))
                .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let (slv, shv) = (ctx.read::<[f32; 4]>("sample_lv")?, ctx.read::<[f32; 4]>("sample_hv")?);
        let (plv, phv) = (ctx.read_opt::<[f32; 4]>("previous_lv")?, ctx.read_opt::<[f32; 4]>("previous_hv")?);
        let out: Vec<Stats> = (0..ctx.pixels())
            .map(|i| {
                let prev = match (plv, phv) {
                    (Some(a), Some(b)) => Stats::from_buffers(a[i], b[i]),
                    _ => Stats::default(),
                };
                Stats::combine(prev, Stats::from_buffers(slv[i], shv[i]))
            })
            .collect();
        ctx.put("lv", out.iter().map(Stats::lv_buffer).collect::<Vec<_>>())?;
        ctx.put("hv", out.iter().map(Stats::u_buffer).collect::<Vec<_>>())
    }
}

// ---------------------------------------------------------------------------------------------
// pixel_filter.range
// ---------------------------------------------------------------------------------------------

/// `pixel_filter.range` (see the module doc).
pub struct RangeBuffer;

impl Kernel for RangeBuffer {
    fn name(&self) -> &'static str {
        "pixel_filter.range"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Sampling
    }
    fn draws_random(&self) -> bool {
        true
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            // The range buffer so far (history; zeros in a first frame).
            Binding::read_opt("previous", Format::Vec4),
            // rgb: mean colour (range_colour) over the filter passes' samples; w: nearest depth.
            Binding::write("range", Format::Vec4),
        ]
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/pixel_filter_range.wgsl"), |ctx| {
                let (update, pass) = schedule(ctx)?;
                let u = camera_uniforms(Uniforms::new(), &ctx.scene.camera);
                Ok(u.u32("count", count_param(ctx, "count", 4096)?)
                    .u32("stream", ctx.int_param("stream")? as u32)
                    .u32("update", update as u32)
                    .f32("pass_index", pass.max(1) as f32))
            })
            .with_include("pixel_filter_formulas.wgsl", include_str!("../../../shaders/pixel_filter_formulas.wgsl"))
            .with_scene()
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let (update, pass) = schedule(ctx)?;
        let count = count_param(ctx, "count", 4096)?;
        let previous = ctx.read_opt::<[f32; 4]>("previous")?;
        if !update {
            let out = previous.map_or_else(|| vec![[0.0; 4]; ctx.pixels()], |p| p.to_vec());
            return ctx.put("range", out);
        }
        let stream = ctx.int_param("stream")? as u32;
        let cam = ctx.scene.camera;
        // The full image's pixel and size (a tile's window is part of it).
        let (seed, width, window) = (ctx.seed, ctx.width, ctx.window);
        let k = pass.max(1) as f32;
        let out = ctx.map_pixels(false, |px, py| {
            let rng = PixelRng::new(seed, window.pixel_id(px, py), stream);
            let (mut sum, mut depth) = (Vec3::ZERO, MISS_DEPTH);
            for s in 0..count {
                let (ray, t) = camera_ray(&cam, &rng, s, window.global_xy(px, py), window.full_size());
                let at = ctx.scene.at(t);
                if let Some(hit) = at.intersect(ray.origin, ray.dir, 0.0, f32::INFINITY) {
                    let sp = at.surface(&hit, ray.origin, ray.dir);
                    let mat = &at.scene().materials[sp.material as usize];
                    let cos = sp.shading_normal.dot(-ray.dir).abs();
                    sum += range_colour(at.scene().albedo(&sp), mat.specular, cos);
                    depth = depth.min(hit.t);
                }
            }
            let c = if count > 0 { sum / count as f32 } else { Vec3::ZERO };
            range_update(previous.map(|p| p[(py * width + px) as usize]), c, depth, k)
        });
        Counters::add(&ctx.counters.primary_rays, ctx.pixels() as u64 * u64::from(count));
        ctx.put("range", out)
    }
}

/// The range buffer after filter pass `k` (1, 2, …): the running mean of the passes' colours and the
/// nearest depth (Sec. 3.3.3: "we keep the nearest depth per pixel").
pub fn range_update(previous: Option<[f32; 4]>, colour: Vec3, depth: f32, k: f32) -> [f32; 4] {
    match previous {
        Some(p) if k > 1.0 => {
            let prev = Vec3::new(p[0], p[1], p[2]);
            let c = prev + (colour - prev) / k;
            [c.x, c.y, c.z, p[3].min(depth)]
        }
        _ => [colour.x, colour.y, colour.z, depth],
    }
}

// ---------------------------------------------------------------------------------------------
// pixel_filter.width
// ---------------------------------------------------------------------------------------------

/// `pixel_filter.width`: the per-pixel spatial σ of the adaptive filter (eqs. 3.15–3.17) from the
/// last filter pass's filtered variance and background; before any filter pass, the guide σ̄(n).
pub struct AdaptiveWidth;

fn width_params(ctx: &KernelCtx<'_>) -> Result<(f32, f32, f32), BackendError> {
    let t = ctx.f32_param("t")?;
    if !(t >= 0.0 && t.is_finite()) {
        return Err(ctx.err(format!("`t` = {t} must be a finite number >= 0")));
    }
    Ok((ctx.positive_f32_param("sigma_s")?, ctx.positive_f32_param("adaptive_c")?, t))
}

/// One pixel of [`AdaptiveWidth`].
pub fn width_pixel(lv: [f32; 4], filtered: [f32; 4], variance: [f32; 4], sigma_s: f32, c: f32, t: f32) -> f32 {
    let n = lv[3];
    if variance[3] != FILTERED {
        return (sigma_s / n.max(1.0).sqrt()).min(sigma_s);
    }
    let lb = luminance(Vec3::new(filtered[0] + lv[0], filtered[1] + lv[1], filtered[2] + lv[2]));
    adaptive_sigma(variance[0], n, lb, t, sigma_s, c)
}

impl Kernel for AdaptiveWidth {
    fn name(&self) -> &'static str {
        "pixel_filter.width"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Bandwidth
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("lv", Format::Vec4),
            Binding::read_opt("previous_filtered", Format::Vec4),
            Binding::read_opt("previous_variance", Format::Vec4),
            Binding::write("sigma", Format::F32),
        ]
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/pixel_filter_width.wgsl"), |ctx| {
                let (sigma_s, c, t) = width_params(ctx)?;
                Ok(Uniforms::new().f32("sigma_s", sigma_s).f32("adaptive_c", c).f32("t", t))
            })
            .with_include("pixel_filter_formulas.wgsl", include_str!("../../../shaders/pixel_filter_formulas.wgsl"))
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let (sigma_s, c, t) = width_params(ctx)?;
        let lv = ctx.read::<[f32; 4]>("lv")?;
        let pf = ctx.read_opt::<[f32; 4]>("previous_filtered")?;
        let pv = ctx.read_opt::<[f32; 4]>("previous_variance")?;
        let at = |b: Option<&[[f32; 4]]>, i: usize| b.map_or([0.0; 4], |b| b[i]);
        let out: Vec<f32> =
            (0..ctx.pixels()).map(|i| width_pixel(lv[i], at(pf, i), at(pv, i), sigma_s, c, t)).collect();
        ctx.put("sigma", out)
    }
}

// ---------------------------------------------------------------------------------------------
// pixel_filter.bilateral (brute force, eq. 3.6)
// ---------------------------------------------------------------------------------------------

/// `pixel_filter.bilateral`: the brute-force cross-bilateral filter (see the module doc).
pub struct Bilateral;

/// Weighted luminance spread (West's weighted Welford): the per-path variance of a pixel's
/// neighbourhood when no pixel there has two paths yet (a single-path frame; a reading, see
/// DESIGN-NOTES: the thesis's eq. 3.5 assumption — neighbours are realisations of one variable).
#[derive(Clone, Copy, Default)]
struct Spread {
    w: f32,
    mean: f32,
    s: f32,
}

impl Spread {
    #[inline]
    fn add(&mut self, y: f32, a: f32) {
        self.w += a;
        let d = y - self.mean;
        self.mean += d * a / self.w;
        self.s += a * d * (y - self.mean);
    }
    fn variance(&self) -> f32 {
        if self.w > 0.0 {
            (self.s / self.w).max(0.0)
        } else {
            0.0
        }
    }
}

/// Sums of one filtered pixel.
#[derive(Clone, Copy, Default)]
struct Sums {
    a: f32,
    value: Vec3,
    /// Σ a²·r_in (r_in = 1 for the accumulation: eq. 3.5's Σa²).
    a2: f32,
    var: f32,
    var_w: f32,
    spread: Spread,
}

impl Sums {
    /// The filtered value, r = Σa²/A² and the per-path variance σ² (filtered, or the spread).
    fn finish(&self) -> (Vec3, f32, f32) {
        if !(self.a > 0.0) {
            return (Vec3::ZERO, 0.0, 0.0);
        }
        let value = self.value / self.a;
        let r = self.a2 / (self.a * self.a);
        let sigma2 = if self.var_w > 0.0 { self.var / self.var_w } else { self.spread.variance() };
        (value, r, sigma2)
    }
}

/// `filtered` and `variance` of a pixel with `n` paths from its filtered value, r and σ².
fn filter_outputs(value: Vec3, r: f32, sigma2: f32, n: f32) -> ([f32; 4], [f32; 4]) {
    if !(n > 0.0) {
        return ([0.0; 4], [0.0; 4]);
    }
    let f_abs = r * sigma2 / n;
    ([value.x, value.y, value.z, f_abs], [sigma2, r, n, FILTERED])
}

fn filter_uniforms(ctx: &KernelCtx<'_>) -> Result<Uniforms, BackendError> {
    let (update, _) = schedule(ctx)?;
    let p = FilterParams::read(ctx)?;
    Ok(p.uniforms(Uniforms::new().u32("update", update as u32)).u32("radius", p.radius(p.sigma_s)))
}

/// Keep the last filter pass's buffers (or zeros before the first).
fn keep_previous(ctx: &mut KernelCtx<'_>, filtered: &str, variance: &str) -> Result<(), BackendError> {
    let n = ctx.pixels();
    let pf = ctx.read_opt::<[f32; 4]>("previous_filtered")?.map_or_else(|| vec![[0.0; 4]; n], |p| p.to_vec());
    let pv = ctx.read_opt::<[f32; 4]>("previous_variance")?.map_or_else(|| vec![[0.0; 4]; n], |p| p.to_vec());
    ctx.put(filtered, pf)?;
    ctx.put(variance, pv)
}

impl Kernel for Bilateral {
    fn name(&self) -> &'static str {
        "pixel_filter.bilateral"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Filter
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("range", Format::Vec4),
            Binding::read("lv", Format::Vec4),
            Binding::read("hv", Format::Vec4),
            Binding::read_opt("previous_filtered", Format::Vec4),
            Binding::read_opt("previous_variance", Format::Vec4),
            // Per-pixel spatial σ (adaptive width); unbound: `sigma_s`.
            Binding::read_opt("sigma", Format::F32),
            Binding::write("filtered", Format::Vec4),
            Binding::write("variance", Format::Vec4),
        ]
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/pixel_filter_bilateral.wgsl"), filter_uniforms)
                .with_include("pixel_filter_formulas.wgsl", include_str!("../../../shaders/pixel_filter_formulas.wgsl"))
                .with_reach(|ctx| {
                    let p = FilterParams::read(ctx)?;
                    Ok(Reach::Rows(p.radius(p.sigma_s)))
                }),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let (update, _) = schedule(ctx)?;
        if !update {
            return keep_previous(ctx, "filtered", "variance");
        }
        let p = FilterParams::read(ctx)?;
        let range = ctx.read::<[f32; 4]>("range")?;
        let lv = ctx.read::<[f32; 4]>("lv")?;
        let hv = ctx.read::<[f32; 4]>("hv")?;
        let sigma = ctx.read_opt::<f32>("sigma")?;
        let (w, h) = (ctx.width as i32, ctx.height as i32);
        let max_radius = p.radius(p.sigma_s) as i32;
        let (inv_c, inv_d) = (inv_two_sigma2(p.sigma_c), inv_two_sigma2(p.sigma_d));
        let out = ctx.map_pixels(false, |px, py| {
            let j = (py as i32 * w + px as i32) as usize;
            let sg = sigma.map_or(p.sigma_s, |s| s[j]).min(p.sigma_s);
            let cut = p.truncate * sg;
            let radius = (p.radius(sg) as i32).min(max_radius);
            let inv_s = inv_two_sigma2(sg);
            let (cj, dj) = (Vec3::new(range[j][0], range[j][1], range[j][2]), range[j][3]);
            let spread = lv[j][3] < 2.0;
            let mut sums = Sums::default();
            for y in (py as i32 - radius).max(0)..=(py as i32 + radius).min(h - 1) {
                for x in (px as i32 - radius).max(0)..=(px as i32 + radius).min(w - 1) {
                    let (dx, dy) = ((x - px as i32) as f32, (y - py as i32) as f32);
                    let ds2 = dx * dx + dy * dy;
                    if ds2 > cut * cut {
                        continue;
                    }
                    let i = (y * w + x) as usize;
                    add_tap(
                        &mut sums, range[i], cj, dj, ds2, inv_s, inv_c, inv_d, lv[i][3], hv[i], 1.0, None, true, spread,
                    );
                }
            }
            let (value, r, sigma2) = sums.finish();
            filter_outputs(value, r, sigma2, lv[j][3])
        });
        ctx.put("filtered", out.iter().map(|o| o.0).collect::<Vec<_>>())?;
        ctx.put("variance", out.iter().map(|o| o.1).collect::<Vec<_>>())
    }
}

/// One tap of the cross-bilateral filter at neighbour `i`: its range entry, its path count `n` and
/// value `hv` (`hv.w` = M2 on the first pass, where `first`; later passes carry the value's `r` in
/// `r_in` and the filtered σ² in `var_in`). `spread`: keep the one-path spread, needed only where the
/// centre pixel has fewer than two paths (otherwise its own tap, weight 1, makes the variance sum
/// non-empty and the spread unused).
#[allow(clippy::too_many_arguments)]
#[inline]
fn add_tap(
    sums: &mut Sums,
    range_i: [f32; 4],
    cj: Vec3,
    dj: f32,
    ds2: f32,
    inv_s: f32,
    inv_c: f32,
    inv_d: f32,
    n: f32,
    hv: [f32; 4],
    r_in: f32,
    var_in: Option<f32>,
    first: bool,
    spread: bool,
) {
    if !(n > 0.0) {
        return;
    }
    let dc = Vec3::new(range_i[0], range_i[1], range_i[2]) - cj;
    let a = bilateral_weight(ds2, dc.dot(dc), dj - range_i[3], inv_s, inv_c, inv_d);
    if !(a > 0.0) {
        // Underflowed (another surface): nothing to add, and the spread's first weight must be > 0.
        return;
    }
    let value = Vec3::new(hv[0], hv[1], hv[2]);
    sums.a += a;
    sums.value += value * a;
    sums.a2 += a * a * r_in;
    if first {
        if n >= 2.0 {
            sums.var += a * (hv[3] / (n - 1.0));
            sums.var_w += a;
        }
        if spread {
            sums.spread.add(luminance(value), a);
        }
    } else if let Some(v) = var_in {
        sums.var += a * v;
        sums.var_w += a;
    }
}

// ---------------------------------------------------------------------------------------------
// pixel_filter.separable (eq. 3.14)
// ---------------------------------------------------------------------------------------------

/// `pixel_filter.separable`: one 1-D pass (`axis` 0 = x, 1 = y) of iteration `iteration` of
/// `iterations` of the iterated separable cross-bilateral filter (Sec. 3.6.1, eq. 3.14). The first
/// pass reads the accumulation (`hv` = mean, M2; `lv` for n), later ones the chain's `value_in` =
/// (rgb, r) and `variance_in` = (σ², valid); `r` propagates as `Σ a_i² r_i / A²` (exact for the first x-then-y
/// iteration, whose rows are independent; an approximation after, reading). The last pass writes
/// `filtered`/`variance` as [`Bilateral`] does and keeps them on frames that do not filter.
pub struct Separable;

struct SeparableParams {
    filter: FilterParams,
    axis: u32,
    iteration: u32,
    iterations: u32,
    first: bool,
    last: bool,
    update: bool,
}

fn separable_params(ctx: &KernelCtx<'_>) -> Result<SeparableParams, BackendError> {
    let (update, _) = schedule(ctx)?;
    Ok(SeparableParams {
        filter: FilterParams::read(ctx)?,
        axis: count_param(ctx, "axis", 1)?,
        iteration: count_param(ctx, "iteration", 16)?.max(1),
        iterations: count_param(ctx, "iterations", 16)?.max(1),
        first: ctx.bool_param("first")?,
        last: ctx.bool_param("last")?,
        update,
    })
}

impl SeparableParams {
    /// The pass's widest window radius (σ_s of this iteration).
    fn radius(&self) -> u32 {
        self.filter.radius(iteration_sigma(self.filter.sigma_s, self.iteration, self.iterations))
    }
}

impl Kernel for Separable {
    fn name(&self) -> &'static str {
        "pixel_filter.separable"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Filter
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("range", Format::Vec4),
            // First pass: the accumulation hv = (mean, M2); later: the chain's (rgb, r).
            Binding::read("value_in", Format::Vec4),
            // Later passes: (σ², valid, 0, 0).
            Binding::read_opt("variance_in", Format::Vec4),
            // First and last passes: the accumulation's lv (w = n).
            Binding::read_opt("lv", Format::Vec4),
            Binding::read_opt("sigma", Format::F32),
            Binding::read_opt("previous_filtered", Format::Vec4),
            Binding::read_opt("previous_variance", Format::Vec4),
            Binding::write("value_out", Format::Vec4),
            Binding::write("variance_out", Format::Vec4),
        ]
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/pixel_filter_separable.wgsl"), |ctx| {
                let s = separable_params(ctx)?;
                Ok(s.filter
                    .uniforms(Uniforms::new().u32("update", s.update as u32))
                    .u32("axis", s.axis)
                    .f32("scale", iteration_sigma(1.0, s.iteration, s.iterations))
                    .u32("radius", s.radius())
                    .u32("first", s.first as u32)
                    .u32("last", s.last as u32))
            })
            .with_include("pixel_filter_formulas.wgsl", include_str!("../../../shaders/pixel_filter_formulas.wgsl"))
            .with_reach(|ctx| {
                let s = separable_params(ctx)?;
                Ok(if s.axis == 0 { Reach::Cols(s.radius()) } else { Reach::Rows(s.radius()) })
            }),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let s = separable_params(ctx)?;
        if !s.update {
            if s.last {
                return keep_previous(ctx, "value_out", "variance_out");
            }
            // Nothing reads an intermediate pass's output on a frame that does not filter.
            let n = ctx.pixels();
            ctx.put("value_out", vec![[0.0f32; 4]; n])?;
            return ctx.put("variance_out", vec![[0.0f32; 4]; n]);
        }
        let p = s.filter;
        let range = ctx.read::<[f32; 4]>("range")?;
        let value = ctx.read::<[f32; 4]>("value_in")?;
        let var = ctx.read_opt::<[f32; 4]>("variance_in")?;
        let lv = ctx.read_opt::<[f32; 4]>("lv")?;
        let sigma = ctx.read_opt::<f32>("sigma")?;
        if (s.first || s.last) && lv.is_none() {
            return Err(ctx.err("the first and last passes read `lv` (the path counts)".into()));
        }
        if !s.first && var.is_none() {
            return Err(ctx.err("a pass after the first reads `variance_in`".into()));
        }
        let (w, h) = (ctx.width as i32, ctx.height as i32);
        let max_radius = s.radius() as i32;
        let scale = iteration_sigma(1.0, s.iteration, s.iterations);
        let (inv_c, inv_d) = (inv_two_sigma2(p.sigma_c), inv_two_sigma2(p.sigma_d));
        let out = ctx.map_pixels(false, |px, py| {
            let j = (py as i32 * w + px as i32) as usize;
            let sg = sigma.map_or(p.sigma_s, |v| v[j]).min(p.sigma_s) * scale;
            let cut = p.truncate * sg;
            let radius = (p.radius(sg) as i32).min(max_radius);
            let inv_s = inv_two_sigma2(sg);
            let (cj, dj) = (Vec3::new(range[j][0], range[j][1], range[j][2]), range[j][3]);
            let mut sums = Sums::default();
            let (lo, hi) = if s.axis == 0 {
                ((px as i32 - radius).max(0), (px as i32 + radius).min(w - 1))
            } else {
                ((py as i32 - radius).max(0), (py as i32 + radius).min(h - 1))
            };
            for k in lo..=hi {
                let (x, y, d) = if s.axis == 0 { (k, py as i32, k - px as i32) } else { (px as i32, k, k - py as i32) };
                let ds2 = (d * d) as f32;
                if ds2 > cut * cut {
                    continue;
                }
                let i = (y * w + x) as usize;
                if s.first {
                    let spread = lv.unwrap()[j][3] < 2.0;
                    add_tap(
                        &mut sums,
                        range[i],
                        cj,
                        dj,
                        ds2,
                        inv_s,
                        inv_c,
                        inv_d,
                        lv.unwrap()[i][3],
                        value[i],
                        1.0,
                        None,
                        true,
                        spread,
                    );
                } else {
                    let v = var.unwrap()[i];
                    // A pixel without paths is not in the chain (valid flag 0).
                    let n = if v[1] > 0.0 { 1.0 } else { 0.0 };
                    add_tap(
                        &mut sums,
                        range[i],
                        cj,
                        dj,
                        ds2,
                        inv_s,
                        inv_c,
                        inv_d,
                        n,
                        value[i],
                        value[i][3],
                        Some(v[0]),
                        false,
                        false,
                    );
                }
            }
            let (val, r, sigma2) = sums.finish();
            if s.last {
                filter_outputs(val, r, sigma2, lv.unwrap()[j][3])
            } else {
                let valid = if sums.a > 0.0 { 1.0 } else { 0.0 };
                ([val.x, val.y, val.z, r], [sigma2, valid, 0.0, 0.0])
            }
        });
        ctx.put("value_out", out.iter().map(|o| o.0).collect::<Vec<_>>())?;
        ctx.put("variance_out", out.iter().map(|o| o.1).collect::<Vec<_>>())
    }
}

// ---------------------------------------------------------------------------------------------
// pixel_filter.blend
// ---------------------------------------------------------------------------------------------

/// `pixel_filter.blend`: `L = L_lv + s·L_u + (1 − s)·L_f` (eq. 3.1) with `s` from
/// [`blend_factor`]; `unfiltered` = `L_lv + L_u`, the plain progressive accumulation; `blend` = s.
pub struct Blend;

/// Settings of the blend: threshold `t`, and the spike clamp's `c` (eq. 3.18; 0 = off).
#[derive(Clone, Copy, Debug)]
pub struct BlendParams {
    pub t: f32,
    pub spike_c: f32,
}

fn blend_params(ctx: &KernelCtx<'_>) -> Result<BlendParams, BackendError> {
    let t = ctx.f32_param("t")?;
    if !(t >= 0.0 && t.is_finite()) {
        return Err(ctx.err(format!("`t` = {t} must be a finite number >= 0")));
    }
    let spike_c = if ctx.bool_param("spike_clamp")? { ctx.positive_f32_param("spike_c")? } else { 0.0 };
    Ok(BlendParams { t, spike_c })
}

/// One pixel of [`Blend`]: (radiance, unfiltered, s).
pub fn blend_pixel(
    lv: [f32; 4],
    hv: [f32; 4],
    filtered: [f32; 4],
    variance: [f32; 4],
    b: BlendParams,
) -> (Vec3, Vec3, f32) {
    let v3 = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]);
    let (llv, lu, lf) = (v3(lv), v3(hv), v3(filtered));
    let n = lv[3];
    let unfiltered = llv + lu;
    if !(n > 0.0) || variance[3] != FILTERED {
        return (unfiltered, unfiltered, 1.0);
    }
    // Eq. 3.10: the background radiance; eq. 3.4: perceived variances. The unfiltered buffer's
    // variance is the filtered per-path variance over the current n (Sec. 3.3.2); the filtered
    // buffer's was fixed at its filter pass.
    let lb = luminance(lf + llv);
    let (u_abs, f_abs) = (variance[0] / n, filtered[3]);
    let perceived = |v: f32| {
        if !(v > 0.0) {
            0.0
        } else if lb > 0.0 {
            v / (lb * lb)
        } else {
            f32::INFINITY
        }
    };
    let s = blend_factor(perceived(u_abs), perceived(f_abs), b.t);
    if s >= 1.0 {
        // Converged: the plain accumulation, bit for bit (no clamp: consistency, see DESIGN-NOTES).
        return (unfiltered, unfiltered, 1.0);
    }
    let lu = if b.spike_c > 0.0 { spike_clamp(lu, lf, b.spike_c) } else { lu };
    (llv + (lu * s + lf * (1.0 - s)), unfiltered, s)
}

impl Kernel for Blend {
    fn name(&self) -> &'static str {
        "pixel_filter.blend"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Compose
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("lv", Format::Vec4),
            Binding::read("hv", Format::Vec4),
            Binding::read("filtered", Format::Vec4),
            Binding::read("variance", Format::Vec4),
            Binding::write("radiance", Format::Vec3),
            Binding::write("unfiltered", Format::Vec3),
            Binding::write("blend", Format::F32),
        ]
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/pixel_filter_blend.wgsl"), |ctx| {
                let b = blend_params(ctx)?;
                Ok(Uniforms::new().f32("t", b.t).f32("spike_c", b.spike_c))
            })
            .with_include("pixel_filter_formulas.wgsl", include_str!("../../../shaders/pixel_filter_formulas.wgsl"))
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let b = blend_params(ctx)?;
        let lv = ctx.read::<[f32; 4]>("lv")?;
        let hv = ctx.read::<[f32; 4]>("hv")?;
        let filtered = ctx.read::<[f32; 4]>("filtered")?;
        let variance = ctx.read::<[f32; 4]>("variance")?;
        let out: Vec<(Vec3, Vec3, f32)> =
            (0..ctx.pixels()).map(|i| blend_pixel(lv[i], hv[i], filtered[i], variance[i], b)).collect();
        ctx.put("radiance", out.iter().map(|o| o.0.to_array()).collect::<Vec<_>>())?;
        ctx.put("unfiltered", out.iter().map(|o| o.1.to_array()).collect::<Vec<_>>())?;
        ctx.put("blend", out.iter().map(|o| o.2).collect::<Vec<_>>())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blend_case_three_meets_the_threshold_exactly() {
        // s'²u + (1 − s')²f = t (eq. 3.9 without covariance) wherever case 3 applies.
        for &(u, f, t) in
            &[(1.0f32, 0.1, 0.5), (4.0, 0.05, 0.2), (0.3, 0.01, 0.02), (100.0, 0.001, 0.01), (2.0, 1.0, 1.5)]
        {
            let s = blend_factor(u, f, t);
            assert!(s > 0.0 && s < 1.0, "case 3 at {u} {f} {t}: {s}");
            let v = s * s * u + (1.0 - s) * (1.0 - s) * f;
            assert!((v - t).abs() <= 1e-5 * t.max(1.0), "{u} {f} {t}: s {s} gives {v}");
        }
    }

    #[test]
    fn blend_edge_cases_of_eq_3_13() {
        assert_eq!(blend_factor(0.0, 0.0, 0.01), 1.0, "u = f = 0 → case 2");
        assert_eq!(blend_factor(0.0, 0.0, 0.0), 1.0, "u = f = 0, t = 0 → case 2");
        assert_eq!(blend_factor(0.5, 0.1, 0.0), 0.0, "t = 0, u > 0 → case 1");
        assert_eq!(blend_factor(0.5, 0.0, 0.0), 0.0, "t = 0, u > 0, f = 0 → 0");
        // tu + tf − uf < 0: f above t (and u too).
        assert_eq!(blend_factor(2.0, 1.0, 0.5), 0.0);
        assert_eq!(blend_factor(0.01, 5.0, 0.01), 1.0, "u ≤ t → 1 whatever f");
        assert_eq!(blend_factor(0.009, 5.0, 0.01), 1.0);
        assert_eq!(blend_factor(f32::INFINITY, 0.1, 0.01), 0.0, "black background under noise");
        // Continuity at u = t (Appendix 3.A, eq. 3.21): s' → 1.
        assert!((blend_factor(0.01 * (1.0 + 1e-6), 0.001, 0.01) - 1.0).abs() < 1e-4);
        // Point (b), u = ft/(f − t): s' = f/(u + f), then case 1.
        let (f, t) = (0.5f32, 0.25f32);
        let ub = f * t / (f - t);
        assert!((blend_factor(ub * (1.0 - 1e-4), f, t) - f / (ub + f)).abs() < 1e-2);
        assert_eq!(blend_factor(ub * 1.01, f, t), 0.0);
    }

    #[test]
    fn blend_factor_falls_monotonically_with_u_between_a_and_b() {
        // Appendix 3.A: strictly decreasing for t < u < ft/(f − t), with f = r u (eq. 3.23).
        let (t, r) = (1.0f32, 0.1f32);
        let mut last = 1.0f32;
        for k in 1..200 {
            let u = t + k as f32 * 0.04;
            let s = blend_factor(u, r * u, t);
            if s == 0.0 {
                break;
            }
            assert!(s < last, "u {u}: {s} ≥ {last}");
            last = s;
        }
    }

    #[test]
    fn filter_schedule_is_first_frame_and_first_times_powers_of_two() {
        let frames: Vec<u32> = (0..70).filter(|&f| is_filter_frame(f, 4, true)).collect();
        assert_eq!(frames, vec![0, 3, 7, 15, 31, 63], "n = 1, 4, 8, 16, 32, 64");
        let thesis: Vec<u32> = (0..70).filter(|&f| is_filter_frame(f, 4, false)).collect();
        assert_eq!(thesis, vec![3, 7, 15, 31, 63]);
        let every: Vec<u32> = (0..9).filter(|&f| is_filter_frame(f, 1, true)).collect();
        assert_eq!(every, vec![0, 1, 3, 7]);
        for first in [1, 2, 4, 8] {
            for ff in [false, true] {
                let mut count = 0;
                for f in 0..300 {
                    count += is_filter_frame(f, first, ff) as u32;
                    assert_eq!(
                        filter_passes_through(f, first, ff),
                        count,
                        "first {first}, first frame {ff}, frame {f}"
                    );
                }
            }
        }
        // No overflow at the last frame index: n = 2^32 paths.
        assert!(is_filter_frame(u32::MAX, 1 << 31, false));
        assert!(!is_filter_frame(u32::MAX - 1, 1 << 31, false));
        assert_eq!(filter_passes_through(u32::MAX, 4, true), 32);
    }

    #[test]
    fn iterated_sigmas_add_up_to_sigma() {
        for n in 1..6 {
            let total: f32 = (1..=n).map(|k| iteration_sigma(8.0, k, n).powi(2)).sum();
            assert!((total - 64.0).abs() < 1e-3, "N = {n}: {total}");
        }
        // Three iterations (the thesis's default): 0.873σ, 0.436σ, 0.218σ.
        assert!((iteration_sigma(1.0, 1, 3) - 0.8729).abs() < 1e-3);
        assert!((iteration_sigma(1.0, 3, 3) - 0.2182).abs() < 1e-3);
    }

    #[test]
    fn adaptive_width_follows_eqs_3_15_to_3_17() {
        // A variance whose box extent is exactly e: u/f = (2e + 1)², σ = 1.5e, inside the interval.
        let (n, lb, t) = (16.0f32, 1.0f32, 0.01f32);
        let e = 1.5f32;
        let sigma2 = (2.0 * e + 1.0).powi(2) * n * t * lb * lb;
        let s = adaptive_sigma(sigma2, n, lb, t, 8.0, 4.0);
        assert!((s - 1.5 * e).abs() < 1e-4, "{s}");
        // Clamped to [σ̄/c, cσ̄] with σ̄(16) = 2, and never above σ_s.
        assert_eq!(adaptive_sigma(0.0, 16.0, 1.0, 0.01, 8.0, 4.0), 0.5);
        assert_eq!(adaptive_sigma(1e9, 16.0, 1.0, 0.01, 8.0, 4.0), 8.0);
        assert_eq!(adaptive_sigma(1e9, 1.0, 1.0, 0.01, 8.0, 4.0), 8.0);
        assert_eq!(adaptive_sigma(1.0, 4.0, 0.0, 0.01, 8.0, 2.0), 8.0, "black background: widest");
    }

    #[test]
    fn spike_clamp_keeps_within_factor_c_of_the_filtered_value() {
        let lf = Vec3::new(1.0, 0.5, 0.0);
        let out = spike_clamp(Vec3::new(10.0, 0.1, 3.0), lf, 2.0);
        assert_eq!(out, Vec3::new(2.0, 0.25, 0.0));
        assert_eq!(spike_clamp(Vec3::new(1.5, 0.3, 0.0), lf, 2.0), Vec3::new(1.5, 0.3, 0.0));
    }

    #[test]
    fn combine_is_welford_and_halves_combine() {
        // Means and M2 against a two-pass f64 computation.
        let xs: Vec<f32> = (0..1000).map(|k| ((k * 7919) % 1013) as f32 / 1013.0 * 3.0 + 1e3).collect();
        let mut st = Stats::default();
        for &x in &xs {
            st = Stats::combine(st, Stats::one(Vec3::splat(x), Vec3::splat(x)));
        }
        let mean = xs.iter().map(|&x| x as f64).sum::<f64>() / xs.len() as f64;
        let m2: f64 = xs.iter().map(|&x| (x as f64 - mean).powi(2)).sum();
        assert!((st.lv.x as f64 - mean).abs() < 1e-3 * 1e-3 * mean, "{} vs {mean}", st.lv.x);
        // Luminance weights sum to 1 up to f32 rounding: Y(x, x, x) = x (1 ± 1e-7).
        assert!(((st.m2 as f64) - m2).abs() < 2e-3 * m2, "M2 {} vs {m2} (offset 1000: no cancellation)", st.m2);
        // Combining two halves equals one pass over all, to rounding.
        let (a, b) = xs.split_at(400);
        let fold = |v: &[f32]| {
            v.iter().fold(Stats::default(), |s, &x| Stats::combine(s, Stats::one(Vec3::ZERO, Vec3::splat(x))))
        };
        let both = Stats::combine(fold(a), fold(b));
        assert_eq!(both.n, 1000.0);
        assert!((both.m2 - st.m2).abs() < 1e-3 * st.m2, "{} vs {}", both.m2, st.m2);
    }

    /// On a synthetic input (uniform samples, variance 1/12), `M2/(n − 1)` after n paths is an
    /// unbiased estimate: its mean over 80 000 pixels is 1/12 within 1% (about 4 standard errors).
    #[test]
    fn variance_estimate_is_unbiased_on_a_synthetic_input() {
        for n in [2u32, 4, 16] {
            let mut total = 0.0f64;
            let pixels = 80_000u32;
            for p in 0..pixels {
                let rng = PixelRng::new(7, p, 11);
                let mut st = Stats::default();
                for k in 0..n {
                    st = Stats::combine(st, Stats::one(Vec3::ZERO, Vec3::splat(rng.uniform(k, 0))));
                }
                total += st.sample_variance().unwrap() as f64;
            }
            let mean = total / pixels as f64;
            assert!((mean * 12.0 - 1.0).abs() < 0.01, "n = {n}: mean sample variance {mean} vs {}", 1.0 / 12.0);
        }
    }
}
