//! `paths.trace`: the path sampler of thesis Ch. 5 (Sec. 5.8) — per pixel, a run of paths, each one
//! primary lens ray, shadow rays to the area light at its hit and one-bounce indirect samples
//! (diffuse and, where the surface has a glossy lobe, glossy separately), accumulated into one
//! typed [`PathRecord`] per pixel. `paths.resolve` turns a record's sums into the means downstream
//! kernels read.
//!
//! **Samples.** Path `j` of a pixel takes sample `j` of that pixel's Owen-scrambled Sobol' sequences
//! ([`crate::sobol`]) for the image plane (`jitter`; off = the pixel centre, the thesis's one image
//! sample per pixel) and the lens; the `q`-th shadow ray of the pixel takes light sample `q`, the
//! `q`-th diffuse / glossy indirect sample hemisphere sample `q` of their own sequences. Indices run
//! over the pixel's whole history: a pass continuing a `previous` record starts at its counts, so
//! the second pass continues the first pass's stratification (every power-of-4 prefix is
//! stratified) and 16 paths then 16 more equal 32 in one pass, bit for bit. Beyond the first
//! bounce (next-event estimation at the indirect hit, further bounces) numbers are independent
//! (`rng::PixelRng` on a hashed sub-stream). Sub-streams are derived from the pass's `stream` by
//! hashing ([`crate::sobol::sequence_key`], [`crate::sobol::substream`]).
//!
//! **Estimators** (the existing ones, shared, not copied: `direct::light_sample`,
//! `direct::light_centre_factor`, `indirect::trace_path`; WGSL `light_sample.wgsl`,
//! `indirect_path.wgsl`). Per path with lens weight `w` ([`wedge_scene::LensShape`]) and hit `x`:
//! - direct (one light, `light`): `E = f_c · V̄` over the path's shadow rays with the centre-of-light
//!   form factor `f_c` (eqs. 5.9–5.14, docs/EQUATIONS.md reading: f_c in L, k and E), `k = k_d + π k_s
//!   ρ_s(ω_c)` (the glossy lobe toward the light centre folded into k, eq. 5.20), `L = k·E`;
//! - indirect diffuse: `E` = mean incident radiance of cosine-sampled one-bounce paths, `k = k_d`;
//! - indirect glossy: `E` = mean of `L_i · f cos/pdf` (k_s left out) over lobe samples, `k = k_s`.
//! - environment (thesis Ch. 6, [`crate::kernels::environment`]): look-ups into the map's
//!   4096-entry table, stratified per pixel; diffuse `E = L cos/(π pdf)`, glossy `E = L ρ cos/pdf`
//!   (with `environment_glossy: "mis"` each look-up paired with a lobe direction, pair
//!   `ENVIRONMENT_LOBE`, under the balance heuristic: [`lobe_look_up`]), the largest occluder term
//!   `cos θ / t` over bright blocked look-ups, and `w_env_missed` (paths whose camera ray saw the
//!   sky: `E` averages over the paths that hit). Camera rays that miss add the map
//!   (`Scene::background`) to emission.
//!
//! **Weights.** Where the camera ray moves between a pixel's paths (a lens, jitter), each path weighs
//! its lens weight `w` whatever its secondary count: the record sums `w·L`, `w·k`, `w·E` per component
//! (`E` the path's mean over its samples) and `w` per component, and apart the `w` of those paths
//! that missed every surface: `L` and `k` average over every path (a miss is black), `E` — the
//! irradiance at the surface — over the paths that hit (so SepDir, eq. 5.30, compares `Σ wL/Σ w`
//! with `(Σ wk/Σ w)(Σ wE/Σ w_hit)`, which a silhouette against the background does not break:
//! [`PathRecord::w_direct_missed`]; per-sample weights were measured worse under a lens,
//! `docs/DESIGN-NOTES.md` "Path weights, not sample weights"). Where the camera ray is fixed (a
//! pinhole through the pixel centre, thesis Ch. 3/4) every path has the same primary hit, and each
//! *sample* weighs the same: the record sums `w·k·Σe`, `w·k·v`, `w·Σe` and `w·v` (`v` the path's
//! finite samples), so a pixel's samples average exactly as one path's would however they are split
//! into paths, and an estimator whose count is 0 on a path adds nothing (Ch. 3 and Ch. 4 counts then
//! stop multiplying: `docs/SAMPLER-STAGE.md` "Samples, not paths").
//!
//! Besides, the record keeps the lens-averaged position λ and normal, emission, depth along the
//! optical axis and `|r|` range (circle of confusion per lens sample, eq. 5.2), occluder statistics
//! `d1, d2_min, d2_max` as `direct.light` defines them, indirect first-hit `z_min, z_max`, and counts
//! of paths, shadow rays, indirect samples and rays, and non-finite samples (counted, never summed;
//! a path whose samples of a component are all non-finite contributes `E = 0` there).
//! A record is only sums, minima, maxima and counts, so resuming (GPU chunks, a second pass) is
//! exact.
//!
//! **Parameters** of `paths.trace`: `count` (paths to add where `counts` is unbound), `jitter`
//! (bool), `lens` (`"disk"` | `"gaussian"`), `shadow_per_primary` and `indirect_per_primary`
//! (secondary samples per path where the buffers `shadow_total` / `diffuse_total` are unbound; 0 =
//! none), `ao` (optional bool:
//! a hemisphere sample's value is 1 where it hits a reflector within `max_distance`, optional, 0 =
//! no limit — `indirect.sample`'s ambient-occlusion mode; no glossy part, and the diffuse part's
//! texture is 1, so `l_diffuse = e_diffuse` is the occlusion a factoring node composes), `glossy` (optional bool,
//! default true: the glossy part where a surface has a lobe), `light` (the area light of the
//! direct component: Ch. 5 factors one light; indirect next-event estimation uses every light),
//! `form_factor` (optional: `"light_centre"`, the default, is f_c above; `"exact"` evaluates the
//! geometry term per light sample, the unbiased estimator `direct.light` offers under the same name),
//! `aperture_radius` and `focus_distance` (optional, world units: the thin lens, replacing the scene
//! camera's; a Defocus node sets them through the shared sampler), `direct` and `indirect` (optional bools, default true: which estimators run — the shared sampler
//! turns off the ones no node asked for, so a shadows-only pipeline traces no indirect rays),
//! `stream` (graph-assigned), `sampling` (`"stratified"`: the Sobol' sequences; `"independent"`:
//! independent numbers for the same dimensions, the Monte Carlo baseline), `brdf` (`"phong"` | `"blinn_phong"`), `bounces` (1 = the thesis's
//! one-bounce indirect sample).
//!
//! **Bindings.** `paths.trace` declares its bindings once, [`TraceIo`] (the sampler binds them
//! typed). `paths.resolve`'s stay data-driven on purpose: its 30 optional outputs are the shared
//! sampler's named outputs, which nodes ask for by name (`ExpandCtx::sampler_output(pass,
//! "defocus")`, any node, any crate) and which the sampler binds only where some node holds one —
//! so [`RESOLVE_OUTPUTS`] is their single declaration, from which come `paths.resolve`'s bindings,
//! the sampler's output list (`effects/src/sampler.rs`), the pass's writes and the CPU's per-output
//! switch. A struct would name each output again beside the list nodes look names up in.

use glam::{Vec2, Vec3};
use rayon::prelude::*;
use wedge_graph::Format;
use wedge_scene::{Camera, EnvironmentMap, LensShape, PreparedLight, SceneAt};

use crate::kernel::{Binding, Counters, Kernel, KernelClass, KernelCtx, Uniforms, WgslSource};
use crate::kernels::direct::{light_centre_factor, light_sample, FormFactor};
use crate::kernels::environment::{stratified_entry, uniform_entry, GlossySampling};
use crate::kernels::hemisphere::{glossy_brdf, glossy_pdf, sample_diffuse, sample_glossy, Lobe};
use crate::kernels::indirect::{trace_path, PathParams, PathRays, Vertex};
use crate::kernels::{luminance, widen_range};
use crate::params::{KernelParams, Sampling};
use crate::record;
use crate::rng::PixelRng;
use crate::sobol::{pair, sequence_key, substream, Sequence};
use crate::BackendError;

record! {
    /// One pixel's accumulated paths. Sums are weighted by the lens weight `w`; means are
    /// `sum / weight` (emission: over all paths, a miss counts as black), `sum / w_<component>` (L and k
    /// of a component: see [`PathRecord::w_direct`]), `sum / (w_<component> − w_<component>_missed)` (its
    /// E: see [`PathRecord::w_direct_missed`]) or `sum / hit_weight` (position, normal, depth, d1: over
    /// paths that hit a surface).
    /// (The WGSL struct `PathRecord` is generated from the same list.)
    pub struct PathRecord / PATH_RECORD {
        /// Σ w·L, Σ w·k, Σ w·E of the direct component (f_c form factor, glossy folded into k).
        l_direct: vec3,
        k_direct: vec3,
        e_direct: vec3,
        /// Σ w·U: `e_direct`'s sum with every sample counted as visible (the same samples, the same
        /// weights): SoftShadows' ratio estimator of visibility `E/U` (module doc of `effects::shadows`).
        u_direct: vec3,
        /// The same for indirect diffuse (k = k_d) and indirect glossy (k = k_s).
        l_diffuse: vec3,
        k_diffuse: vec3,
        e_diffuse: vec3,
        l_glossy: vec3,
        k_glossy: vec3,
        e_glossy: vec3,
        /// Σ w·emission of the primary hits.
        emission: vec3,
        /// Σ w·x and Σ w·n over hits: the lens-averaged position λ and normal (eq. 5.31).
        position: vec3,
        normal: vec3,
        /// Σ w over all paths and over paths that hit.
        weight: f32,
        hit_weight: f32,
        /// What a component's L, k, E sums are divided by. Where the camera ray moves between paths (a
        /// lens, jitter) each path weighs `w`, whatever its secondary count: Σ w over the paths that
        /// carried the component, misses included (a miss is black). Where it is fixed (a pinhole
        /// through the pixel centre: every path has the same primary hit) each *sample* weighs the same:
        /// Σ w·(finite samples), so paths of unequal counts average exactly as one path would (module
        /// doc, "Weights").
        w_direct: f32,
        w_diffuse: f32,
        w_glossy: f32,
        /// Σ w of the paths that carried the component and missed every surface (path weights only;
        /// 0 through a fixed pinhole ray). A component's `E` is the irradiance *at the surface*, so it
        /// is averaged over the paths that hit (`w_<component> − w_<component>_missed`), while `L` and
        /// `k` count a miss as black. A pixel that a silhouette against the background crosses then
        /// factors as it would without the background — `k E = c k_hit E_hit`, `L = c (k E)_hit` for
        /// coverage `c` — instead of `k E = c² k_hit E_hit` (too dark by `c`, and the eq. 5.30 test's
        /// absolute threshold lets dim silhouettes through), and its `E` is not diluted into its
        /// neighbours' irradiance filters (`docs/DESIGN-NOTES.md` "Irradiance over the paths that hit").
        w_direct_missed: f32,
        w_diffuse_missed: f32,
        w_glossy_missed: f32,
        /// Σ w·z, z the hit's depth along the optical axis.
        depth: f32,
        /// Range of |r| (circle of confusion in pixels, eq. 5.2) over hits; 0, 0 without hits.
        r_min: f32,
        r_max: f32,
        /// Σ w·d1 over hits (light plane → receiver); occluder distances to the light plane over occluded
        /// shadow rays (0 without any), as `direct.light` defines them.
        d1: f32,
        d2_min: f32,
        d2_max: f32,
        /// First-hit distances of the indirect samples (0 without hits).
        z_min: f32,
        z_max: f32,
        /// 1 + object id of the pixel's first path that hit (0: none yet).
        object: u32,
        /// Primary rays (paths) and those that hit a surface.
        paths: u32,
        hits: u32,
        /// Shadow rays at primary hits and how many were occluded.
        shadow: u32,
        occluded: u32,
        /// Indirect samples taken (sequence indices) and hemisphere rays traced (a glossy sample below
        /// the surface traces none), rays that hit, and next-event shadow rays at the indirect hits.
        diffuse_samples: u32,
        glossy_samples: u32,
        indirect_rays: u32,
        indirect_hits: u32,
        bounce_shadow: u32,
        /// Samples whose value was NaN or infinite (excluded).
        non_finite: u32,
        /// Image-space velocity of the primary hits (pixels per half shutter; 0 without `time`): Σ w·v over
        /// hits, and its per-axis range over every path (a miss counts as 0: the background is still), so
        /// a pixel that saw two velocities shows a wide range (thesis App. B).
        vp_sum: vec2,
        vp_min: vec2,
        vp_max: vec2,
        /// Image-space velocity of the shadow of each occluded shadow sample (see [`shadow_velocity`]):
        /// Σ v over those samples, and its per-axis range.
        vs_sum: vec2,
        vs_min: vec2,
        vs_max: vec2,
        /// Σ w·L, Σ w·k, Σ w·E of the environment's direct light (thesis Ch. 6), diffuse part (`k = k_d`,
        /// `E = L_e cos/(π pdf)`) and glossy part (`k = k_s`, `E = L_e ρ_s cos/pdf`), and their weights as
        /// [`PathRecord::w_direct`]'s.
        l_env_diffuse: vec3,
        k_env_diffuse: vec3,
        e_env_diffuse: vec3,
        l_env_glossy: vec3,
        k_env_glossy: vec3,
        e_env_glossy: vec3,
        w_env_diffuse: f32,
        w_env_glossy: f32,
        /// Σ w of the paths that carried look-ups and missed every surface: the environment parts' `E`
        /// is averaged over the paths that hit (`w_env_* − w_env_missed`), as
        /// [`PathRecord::w_direct_missed`] says for the other components.
        w_env_missed: f32,
        /// The occluder term `cos²θ_occ / z` of eq. 6.13/6.17: its largest value over the occluded
        /// environment samples bright enough to count (0 without any; see [`occluder_term`]).
        env_occluder: f32,
        /// Σ w·m over hits: the Phong exponent the glossy part's `B_ρ` comes from (0: no lobe).
        exponent: f32,
        /// Environment look-ups (sequence indices), those occluded, and shadow rays traced for them (a
        /// look-up below the surface traces none).
        env_samples: u32,
        env_occluded: u32,
        env_rays: u32,
        /// The near layer (`docs/DESIGN-NOTES.md` "The near layer"): Σ w·L of the paths whose hit is in front
        /// of the focal plane and blurred over more than [`NEAR_LAYER_COC`] pixels, Σ w of those paths,
        /// and the least |r| among them (0 without any).
        l_near: vec3,
        w_near: f32,
        r_near: f32,
    }
}

/// A path belongs to the near layer where its hit's signed circle of confusion (eq. 5.2, positive in
/// front of the focal plane) exceeds this many pixels.
pub const NEAR_LAYER_COC: f32 = 2.0;

/// Σ w·L of every component and the emission so far: a path's own radiance is the change it makes.
fn radiance_sums(r: &PathRecord) -> Vec3 {
    [r.l_direct, r.l_diffuse, r.l_glossy, r.l_env_diffuse, r.l_env_glossy, r.emission]
        .iter()
        .map(|s| Vec3::from(*s))
        .sum()
}

fn add(a: &mut [f32; 3], b: Vec3) {
    *a = (Vec3::from(*a) + b).to_array();
}

impl PathRecord {
    fn mean_of(&self, s: [f32; 3], over: f32) -> Vec3 {
        if over > 0.0 {
            Vec3::from(s) / over
        } else {
            Vec3::ZERO
        }
    }
    /// Mean radiance of the pixel: direct + indirect diffuse + indirect glossy + environment diffuse
    /// and glossy + emission (and the environment where camera rays missed).
    pub fn radiance(&self) -> Vec3 {
        self.mean_of(self.l_direct, self.w_direct)
            + self.mean_of(self.l_diffuse, self.w_diffuse)
            + self.mean_of(self.l_glossy, self.w_glossy)
            + self.mean_of(self.l_env_diffuse, self.w_env_diffuse)
            + self.mean_of(self.l_env_glossy, self.w_env_glossy)
            + self.mean_of(self.emission, self.weight)
    }
    /// Mean (L, k, E) of the direct component (E over the paths that hit: [`PathRecord::w_direct_missed`]).
    pub fn direct(&self) -> (Vec3, Vec3, Vec3) {
        let w = self.w_direct;
        let e = self.mean_of(self.e_direct, w - self.w_direct_missed);
        (self.mean_of(self.l_direct, w), self.mean_of(self.k_direct, w), e)
    }
    /// Lens-averaged position λ and normal (not renormalised).
    pub fn lens_position(&self) -> Vec3 {
        self.mean_of(self.position, self.hit_weight)
    }
    pub fn lens_normal(&self) -> Vec3 {
        self.mean_of(self.normal, self.hit_weight)
    }
}

/// The camera model's uniform fields (`CameraModel` in `shaders/camera.wgsl`), in its field order.
pub fn camera_uniforms(u: Uniforms, cam: &Camera, shape: LensShape) -> Uniforms {
    let (right, up, forward) = cam.basis();
    u.vec3("cam_position", cam.position.to_array())
        .vec3("cam_right", right.to_array())
        .vec3("cam_up", up.to_array())
        .vec3("cam_forward", forward.to_array())
        .f32("cam_tan_half", (cam.vfov_deg.to_radians() * 0.5).tan())
        .f32("cam_aperture", cam.aperture_radius)
        .f32("cam_focus_distance", cam.effective_focus_distance())
        .u32("cam_gaussian", (shape == LensShape::Gaussian) as u32)
}

/// The camera a pass traces its camera rays with: the scene's, with the pass's thin lens where it
/// gives one — optional `aperture_radius` / `focus_distance` (world units; a Defocus node's, through
/// the shared sampler or the factoring settings) — and its `lens` shape (optional, default disk).
/// Shared by every kernel that traces its own camera rays (`paths.trace`, `light_field.sample`), so
/// they see one lens.
pub fn pass_camera(ctx: &KernelCtx<'_>) -> Result<(Camera, LensShape), BackendError> {
    let LensParams { lens, aperture_radius, focus_distance } = LensParams::read(ctx)?;
    let mut camera = ctx.scene.camera;
    if let Some(a) = aperture_radius {
        if !(a.is_finite() && a >= 0.0) {
            return Err(ctx.err(format!("`aperture_radius` = {a} must be a finite number >= 0")));
        }
        camera.aperture_radius = a;
    }
    if let Some(f) = focus_distance {
        if !(f.is_finite() && f > 0.0) {
            return Err(ctx.err(format!("`focus_distance` = {f} must be a finite number > 0")));
        }
        camera.focus_distance = f;
    }
    Ok((camera, lens.unwrap_or(LensShape::Disk)))
}

crate::kernel_params! {
    /// A pass's thin lens, each part optional ([`pass_camera`]: the scene camera's where absent).
    pub struct LensParams {
        lens: Option<LensShape>,
        aperture_radius: Option<f32>,
        focus_distance: Option<f32>,
    }
}

crate::kernel_params! {
    /// `paths.trace`'s parameters (module doc, "Parameters"), set by the shared sampler; an
    /// `Option` is one a pass may leave out, its default applied in [`settings`]. The WGSL block is
    /// built from the [`Settings`] they give (`PathsTrace::wgsl`).
    pub struct TraceParams {
        count: u32,
        jitter: bool,
        shadow_per_primary: u32,
        indirect_per_primary: u32,
        /// The direct estimator's area light: needed where `direct` is on.
        light: Option<i32>,
        stream: u32,
        sampling: Sampling,
        brdf: Lobe,
        bounces: u32,
        /// Default: the light-centre form factor.
        form_factor: Option<FormFactor>,
        /// Defaults: `ao`, `time`, `environment` off; `direct`, `indirect`, `glossy` on.
        ao: Option<bool>,
        direct: Option<bool>,
        indirect: Option<bool>,
        glossy: Option<bool>,
        time: Option<bool>,
        environment: Option<bool>,
        /// Default 0: no limit.
        max_distance: Option<f32>,
        /// Default 0.1 (thesis Sec. 6.7).
        occluder_threshold: Option<f32>,
        /// Default 0.
        environment_per_primary: Option<u32>,
        /// Default: the table alone (the thesis).
        environment_glossy: Option<GlossySampling>,
    }
}

/// Sub-stream salts of the independent numbers beyond the first bounce.
const SALT_DIFFUSE_PATH: u32 = 1;
const SALT_GLOSSY_PATH: u32 = 2;

/// Settings of one `paths.trace` pass.
struct Settings {
    /// Owen-scrambled Sobol' (`sampling: "stratified"`) or independent numbers (`"independent"`,
    /// the plain Monte Carlo baseline over the same dimensions).
    stratified: bool,
    count: u32,
    jitter: bool,
    lens: LensShape,
    shadow_per_primary: u32,
    indirect_per_primary: u32,
    /// The direct estimator's area light (read only where `direct` is on: an ambient-occlusion or
    /// indirect-only pipeline may have no light).
    light: usize,
    /// The camera ray is the same for every path of a pixel (pinhole through the pixel centre):
    /// samples, not paths, are weighted (module doc, "Weights").
    fixed_primary: bool,
    stream: u32,
    path: PathParams,
    /// Per-sample geometry term instead of the light-centre form factor f_c.
    exact: bool,
    /// Run the direct (shadow-ray) and the indirect (hemisphere) estimators, and the indirect
    /// estimator's glossy part (where the surface has a lobe, and not under ambient occlusion).
    direct: bool,
    indirect: bool,
    glossy: bool,
    /// The scene's camera with the pass's thin lens (`aperture_radius`, `focus_distance`, where given).
    camera: Camera,
    /// Each path at its own shutter time `t ∈ [−1, 1]` (thesis App. B), else every path at the
    /// shutter's centre `t = 0`.
    time: bool,
    /// The environment estimator (thesis Ch. 6) and its look-ups per path where `environment_total`
    /// is unbound.
    environment: bool,
    environment_per_primary: u32,
    /// At glossy receivers, each look-up paired with a lobe direction under MIS
    /// ([`GlossySampling::Mis`]).
    environment_mis: bool,
    /// Luminance below which an occluded environment sample does not count for the occluder term
    /// (thesis Sec. 6.7: "occluders which block samples with intensity below a threshold of 0.1"):
    /// `occluder_threshold` × the map's mean radiance luminance.
    occluder_luminance: f32,
}

fn settings(ctx: &KernelCtx<'_>) -> Result<Settings, BackendError> {
    let err = |message: String| BackendError::Kernel { pass: ctx.pass.into(), message };
    let p = TraceParams::read(ctx)?;
    let (camera, lens) = pass_camera(ctx)?;
    let ao = p.ao.unwrap_or(false);
    let max_distance = p.max_distance.unwrap_or(0.0);
    if !(max_distance.is_finite() && max_distance >= 0.0) {
        return Err(err(format!("`max_distance` = {max_distance} must be a finite number >= 0")));
    }
    let jitter = p.jitter;
    let direct = p.direct.unwrap_or(true);
    let time = p.time.unwrap_or(false);
    let environment = p.environment.unwrap_or(false);
    let env = ctx.scene.environment.as_ref();
    if environment && env.is_none() {
        return Err(err(format!(
            "the environment estimator is on but scene `{}` has no environment map — give the Environment node a \
             `map` (an EXR or .hdr file, or builtin:sky) or use a scene with one, e.g. --scene envmap",
            ctx.scene.name
        )));
    }
    let occluder_threshold = p.occluder_threshold.unwrap_or(0.1);
    if !(occluder_threshold.is_finite() && occluder_threshold >= 0.0) {
        return Err(err(format!("`occluder_threshold` = {occluder_threshold} must be a finite number >= 0")));
    }
    let mean_luminance = env.map_or(0.0, |e| (e.total_luminance() / (4.0 * std::f64::consts::PI)) as f32);
    let light = match (direct, p.light) {
        (false, _) => 0,
        (true, Some(i)) => ctx.check_light("light", i64::from(i))?,
        (true, None) => return Err(err("the direct estimator is on but the pass sets no `light`".into())),
    };
    Ok(Settings {
        // Under motion the same camera ray meets a different surface at each time.
        fixed_primary: !jitter && camera.aperture_radius == 0.0 && !time,
        time,
        camera,
        exact: p.form_factor == Some(FormFactor::Exact),
        direct,
        indirect: p.indirect.unwrap_or(true),
        glossy: p.glossy.unwrap_or(true) && !ao,
        stratified: p.sampling == Sampling::Stratified,
        count: p.count,
        jitter,
        lens,
        shadow_per_primary: p.shadow_per_primary,
        indirect_per_primary: p.indirect_per_primary,
        light,
        stream: p.stream,
        path: PathParams::new(ctx, p.brdf, p.bounces, ao, max_distance),
        environment,
        environment_per_primary: p.environment_per_primary.unwrap_or(0),
        environment_mis: p.environment_glossy == Some(GlossySampling::Mis),
        occluder_luminance: occluder_threshold * mean_luminance,
    })
}

/// A pixel's sequences in a pass, one per dimension pair ([`pair`]), keyed once per pixel: a draw
/// then pays only for its index (`Sequence`), not for re-hashing (seed, pixel, stream, pair) and
/// the scramble seeds each time (that was a quarter of the sampler's time). Only the pairs the
/// pass's settings draw from are keyed.
struct Draws {
    stratified: bool,
    sequences: [Sequence; pair::COUNT],
}

impl Draws {
    fn new(s: &Settings, seed: u32, pixel: u32) -> Draws {
        let used = [
            (pair::PIXEL, s.jitter),
            (pair::LENS, true),
            (pair::LIGHT, s.direct),
            (pair::HEMISPHERE_DIFFUSE, s.indirect),
            (pair::HEMISPHERE_GLOSSY, s.indirect && s.glossy),
            (pair::TIME, s.time),
            (pair::ENVIRONMENT, s.environment),
            (pair::ENVIRONMENT_LOBE, s.environment && s.environment_mis),
        ];
        let mut sequences = [Sequence::default(); pair::COUNT];
        for (p, on) in used {
            if on {
                sequences[p as usize] = Sequence::new(sequence_key(seed, pixel, s.stream, p));
            }
        }
        Draws { stratified: s.stratified, sequences }
    }

    /// Sample `index` of pair `pair` (one the settings draw from).
    #[inline]
    fn draw(&self, pair: u32, index: u32) -> Vec2 {
        let q = &self.sequences[pair as usize];
        Vec2::from(if self.stratified { q.point(index) } else { q.independent(index) })
    }
}

crate::kernel_bindings! {
    /// What a `paths.trace` pass binds (the sampler's two passes: `effects/src/sampler.rs`).
    pub struct TraceIo / TraceData {
        /// The record to continue (its counts give the first sample indices); absent = none.
        read_opt previous: PathRecord,
        /// Paths to add per pixel; else the `count` parameter.
        read_opt counts: u32,
        /// Shadow rays and indirect samples per part over this pass's paths, split evenly
        /// ([`Split`]); unbound: the per-path parameters (glossy: the diffuse part's counts).
        read_opt shadow_total: u32,
        read_opt diffuse_total: u32,
        read_opt glossy_total: u32,
        read_opt environment_total: u32,
        write record: PathRecord,
    }
}

/// `paths.trace` (module doc): adds paths to each pixel's record.
pub struct PathsTrace;

impl Kernel for PathsTrace {
    crate::kernel_signature!(
        name: "paths.trace", class: Sampling, bindings: TraceIo, params: [TraceParams, LensParams], random: true
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/paths_trace.wgsl"), |ctx| {
                let s = settings(ctx)?;
                let u = camera_uniforms(Uniforms::new(), &s.camera, s.lens)
                    .u32("stratified", s.stratified as u32)
                    .u32("count", s.count)
                    .u32("jitter", s.jitter as u32)
                    .u32("shadow_per_primary", s.shadow_per_primary)
                    .u32("indirect_per_primary", s.indirect_per_primary)
                    .u32("light", s.light as u32)
                    .u32("stream", s.stream)
                    .f32("extent", ctx.scene.extent())
                    .u32("fixed_primary", s.fixed_primary as u32)
                    .u32("exact", s.exact as u32)
                    .u32("direct", s.direct as u32)
                    .u32("indirect", s.indirect as u32)
                    .u32("glossy", s.glossy as u32)
                    .u32("time", s.time as u32)
                    .u32("environment", s.environment as u32)
                    .u32("environment_per_primary", s.environment_per_primary)
                    .u32("environment_mis", s.environment_mis as u32)
                    .f32("occluder_luminance", s.occluder_luminance);
                Ok(s.path.uniforms(u, ctx))
            })
            .with_scene()
            .per_pixel()
            .chunked(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let s = settings(ctx)?;
        let scene = ctx.scene;
        let cam = &s.camera;
        let forward = cam.basis().2;
        let TraceData { previous, counts, shadow_total, diffuse_total, glossy_total, environment_total, record } =
            TraceIo::read(ctx)?;
        // Camera rays, footprints and random numbers of the full image's pixels (a tile is part of it).
        let (seed, width, window) = (ctx.seed, ctx.width, ctx.window);
        let (full_width, height) = ctx.full_size();
        let has_light = s.light < scene.lights.len();
        // The light's per-sample constants, once per pass where every path sees it at the same time
        // (else once per path, at the path's time).
        let still_light = (has_light && !s.time).then(|| scene.at(0.0).light(s.light).prepare());
        let projection = Projection::new(cam, height);
        let rays = cam.rays(full_width, height);
        // Through the pixel centre of a pinhole camera every path of a pixel has the same camera ray
        // (the lens sample only changes a Gaussian lens's weight): trace it once per pixel and pass,
        // and count it once, as plain Monte Carlo with one primary and N shadow rays would.
        let fixed_primary = s.fixed_primary;
        let pixel_record = |px: u32, py: u32| {
            let i = (py * width + px) as usize;
            let pixel = window.pixel_id(px, py);
            let mut r = previous.map_or_else(PathRecord::default, |p| p[i]);
            let first = r.paths;
            let count = counts.map_or(s.count, |c| c[i]).min(u32::MAX - first);
            let split = |total: Option<&[u32]>, per_path: u32| {
                total.map_or(Split::per_path(per_path), |t| Split::new(t[i], count))
            };
            let diffuse = split(diffuse_total, s.indirect_per_primary);
            let (shadow, glossy) =
                (split(shadow_total, s.shadow_per_primary), glossy_total.map_or(diffuse, |t| Split::new(t[i], count)));
            let environment = split(environment_total, s.environment_per_primary);
            if count == 0 {
                return r;
            }
            let draws = Draws::new(&s, seed, pixel);
            let rng_d = PixelRng::new(seed, pixel, substream(s.stream, SALT_DIFFUSE_PATH));
            let rng_g = PixelRng::new(seed, pixel, substream(s.stream, SALT_GLOSSY_PATH));
            let mut fixed_hit = None;
            for j in first..first + count {
                let jitter = if s.jitter { draws.draw(pair::PIXEL, j) } else { Vec2::splat(0.5) };
                let lens = draws.draw(pair::LENS, j);
                let (gx, gy) = window.global_xy(px, py);
                let ray = rays.ray(Vec2::new(gx as f32, gy as f32) + jitter, lens, s.lens);
                // The path's shutter time (App. B), its own stratified dimension.
                let at = scene.at(if s.time { 2.0 * draws.draw(pair::TIME, j).x - 1.0 } else { 0.0 });
                let trace = || at.intersect(ray.origin, ray.dir, 0.0, f32::INFINITY);
                let hit = if fixed_primary { *fixed_hit.get_or_insert_with(trace) } else { trace() };
                let t = j - first;
                let n = Secondary {
                    shadow: shadow.at(t),
                    diffuse: diffuse.at(t),
                    glossy: glossy.at(t),
                    environment: environment.at(t),
                };
                let light = still_light.or_else(|| has_light.then(|| at.light(s.light).prepare()));
                let view = View { forward, height, projection: &projection };
                trace_one(&at, &s, light.as_ref(), &view, &ray, hit, &draws, &rng_d, &rng_g, n, &mut r);
            }
            r
        };
        // Written in place, row by row, into the pool's storage (as `direct.light` does): no per-row
        // vectors flattened into a third.
        let mut records = record.storage(ctx)?;
        let progress = ctx.progress;
        progress.begin(ctx.pass, ctx.height as u64);
        records.par_chunks_mut((width as usize).max(1)).enumerate().for_each(|(y, row)| {
            for (x, r) in row.iter_mut().enumerate() {
                *r = pixel_record(x as u32, y as u32);
            }
            progress.advance(1);
        });
        progress.end();
        let sum = |f: fn(&PathRecord) -> u32| -> u64 {
            records.iter().zip(0..).map(|(r, i)| (f(r) - previous.map_or(0, |p| f(&p[i]))) as u64).sum()
        };
        // Primary rays traced: one per path, or one per pixel and pass where the camera ray is fixed.
        let primary = if fixed_primary {
            records.iter().zip(0..).filter(|(r, i)| r.paths > previous.map_or(0, |p| p[*i].paths)).count() as u64
        } else {
            sum(|r| r.paths)
        };
        Counters::add(&ctx.counters.primary_rays, primary);
        Counters::add(&ctx.counters.shadow_rays, sum(|r| r.shadow) + sum(|r| r.bounce_shadow) + sum(|r| r.env_rays));
        Counters::add(&ctx.counters.secondary_rays, sum(|r| r.indirect_rays));
        Counters::add(&ctx.counters.non_finite_samples, sum(|r| r.non_finite));
        record.put(ctx, records)
    }
}

/// A component's secondary samples over a pass's paths: `q` per path, and one more on each of the
/// first `r` (so a total `T` over `P` paths is `q = T / P`, `r = T mod P`: exact, as even as it can
/// be). A node's counts stop multiplying with another's: each total is split over the same paths.
#[derive(Clone, Copy)]
struct Split {
    q: u32,
    r: u32,
}

impl Split {
    fn new(total: u32, paths: u32) -> Split {
        let p = paths.max(1);
        Split { q: total / p, r: total % p }
    }
    fn per_path(n: u32) -> Split {
        Split { q: n, r: 0 }
    }
    /// Samples on path `t` of the pass.
    fn at(self, t: u32) -> u32 {
        self.q + u32::from(t < self.r)
    }
}

/// Secondary samples one path carries per component (0: that component is not sampled on it).
#[derive(Clone, Copy)]
struct Secondary {
    shadow: u32,
    diffuse: u32,
    glossy: u32,
    environment: u32,
}

/// World velocities (per unit shutter time) as image-space velocities in pixels: the derivative of the
/// pinhole projection of [`Camera::ray`] at a point (`shaders/paths_trace.wgsl` `image_velocity`).
pub struct Projection {
    position: Vec3,
    right: Vec3,
    up: Vec3,
    forward: Vec3,
    /// Pixels per unit of `x/z` on the image plane: `h / (2 tan(fov/2))`.
    scale: f32,
}

impl Projection {
    pub fn new(cam: &Camera, height: u32) -> Projection {
        let (right, up, forward) = cam.basis();
        let scale = height.max(1) as f32 / (2.0 * (cam.vfov_deg.to_radians() * 0.5).tan());
        Projection { position: cam.position, right, up, forward, scale }
    }

    /// The image velocity (pixels per unit t, x right, y down) of a point at `x` moving at `v`; zero
    /// behind the camera.
    pub fn image_velocity(&self, x: Vec3, v: Vec3) -> Vec2 {
        let d = x - self.position;
        let z = d.dot(self.forward);
        if !(z > 0.0) {
            return Vec2::ZERO;
        }
        let vz = v.dot(self.forward);
        let zz = z * z;
        let vx = self.scale * (v.dot(self.right) * z - d.dot(self.right) * vz) / zz;
        let vy = -self.scale * (v.dot(self.up) * z - d.dot(self.up) * vz) / zz;
        Vec2::new(vx, vy)
    }
}

/// The camera quantities a path's statistics need: the optical axis, the image height (for the
/// circle of confusion) and the projection (for velocities).
struct View<'a> {
    forward: Vec3,
    height: u32,
    projection: &'a Projection,
}

/// The image-space velocity of the shadow an occluder casts on a receiver (thesis App. B's `v_s`):
/// in the parallel-plane geometry of Sec. 3.3, the shadow of an occluder point at distance `d2` from
/// the light plane, seen from a light point, falls on the receiver at distance `d1` at
/// `y + (o − y) d1/d2`, so it moves at `(d1/d2) V_o + (1 − d1/d2) V_y` for occluder and light-point
/// velocities `V_o`, `V_y` (in-plane components; the receiver's own motion does not move it). Its image
/// velocity is that motion's at the receiver point `x`. Light points are taken at rest (`V_y = 0`: a
/// reading — the light's motion is sampled by the shadow rays, only not in `v_s`).
fn shadow_velocity(projection: &Projection, x: Vec3, d1: f32, d2: f32, occluder_velocity: Vec3) -> Vec2 {
    if !(d2 > 0.0) {
        return Vec2::ZERO;
    }
    projection.image_velocity(x, occluder_velocity * (d1 / d2))
}

/// Fold velocity `v` into a running range; the first sample starts it.
fn extend_range(min: &mut [f32; 2], max: &mut [f32; 2], v: Vec2, first: bool) {
    if first {
        (*min, *max) = (v.to_array(), v.to_array());
    } else {
        *min = Vec2::from(*min).min(v).to_array();
        *max = Vec2::from(*max).max(v).to_array();
    }
}

/// One path: the primary ray `ray` with its closest `hit`, then the direct and indirect estimators there.
#[allow(clippy::too_many_arguments)]
fn trace_one(
    scene: &SceneAt<'_>,
    s: &Settings,
    light: Option<&PreparedLight>,
    view: &View<'_>,
    ray: &wedge_scene::LensRay,
    hit: Option<wedge_scene::Hit>,
    draws: &Draws,
    rng_d: &PixelRng,
    rng_g: &PixelRng,
    count: Secondary,
    r: &mut PathRecord,
) {
    let w = ray.weight;
    r.paths += 1;
    r.weight += w;
    if !s.fixed_primary {
        // Path weights: every path that carries a component counts for it, a miss as black (for L
        // and k; E averages over the hits: `PathRecord::w_direct_missed`).
        let carries = |on: bool, count: u32| if on && count > 0 { w } else { 0.0 };
        let (direct, diffuse, glossy, environment) = (
            carries(s.direct, count.shadow),
            carries(s.indirect, count.diffuse),
            carries(s.indirect && s.glossy, count.glossy),
            carries(s.environment, count.environment),
        );
        r.w_direct += direct;
        r.w_diffuse += diffuse;
        r.w_glossy += glossy;
        r.w_env_diffuse += environment;
        r.w_env_glossy += environment;
        if hit.is_none() {
            r.w_direct_missed += direct;
            r.w_diffuse_missed += diffuse;
            r.w_glossy_missed += glossy;
            r.w_env_missed += environment;
        }
    }
    let sp = hit.map(|h| scene.surface(&h, ray.origin, ray.dir));
    // Image velocity of the primary hit (App. B's v_p); a miss sees the still background.
    let velocity = match sp {
        Some(sp) if s.time => view.projection.image_velocity(sp.position, scene.velocity(&sp)),
        _ => Vec2::ZERO,
    };
    extend_range(&mut r.vp_min, &mut r.vp_max, velocity, r.paths == 1);
    let Some(sp) = sp else {
        // A camera ray that leaves the scene sees the environment (black without a map).
        add(&mut r.emission, scene.scene().background(ray.dir) * w);
        return;
    };
    let v = Vertex::on(scene.scene(), &sp, ray.dir);
    let (x, n) = (v.x, v.n);
    r.hits += 1;
    r.hit_weight += w;
    add(&mut r.position, x * w);
    add(&mut r.normal, n * w);
    add(&mut r.emission, scene.scene().emission(&sp) * w);
    r.vp_sum = (Vec2::from(r.vp_sum) + velocity * w).to_array();
    if r.object == 0 {
        r.object = 1 + sp.object;
    }
    // Depth along the optical axis and the circle of confusion of this lens sample (eq. 5.2).
    let z = (x - s.camera.position).dot(view.forward);
    r.depth += w * z;
    let signed_coc = s.camera.coc_pixels(z, view.height);
    let coc = signed_coc.abs();
    widen_range((&mut r.r_min, &mut r.r_max), coc, r.hits == 1);
    // A near-layer path's own radiance is what its estimators add to the sums below.
    let near_before = (signed_coc > NEAR_LAYER_COC).then(|| radiance_sums(r));
    let glossy = v.glossy();
    r.exponent += w * if glossy { v.m } else { 0.0 };
    let at = PathHit { v, glossy, w };
    if s.environment && count.environment > 0 {
        trace_environment(scene, s, &at, draws, count.environment, r);
    }
    if let Some(light) = light.filter(|_| s.direct && count.shadow > 0) {
        trace_direct(scene, s, light, view.projection, &at, draws, count.shadow, r);
    }
    if s.indirect {
        trace_indirect(scene, s, &at, draws, (rng_d, rng_g), count, r);
    }
    if let Some(before) = near_before {
        let own = radiance_sums(r) - before + scene.scene().emission(&sp) * w;
        add(&mut r.l_near, own);
        r.r_near = if r.w_near > 0.0 { r.r_near.min(coc) } else { coc };
        r.w_near += w;
    }
}

/// The primary hit a path's estimators shade: the vertex (a lobe where `glossy`) and the path's
/// lens weight.
#[derive(Clone, Copy)]
struct PathHit {
    v: Vertex,
    glossy: bool,
    w: f32,
}

/// The direct estimator at hit `x` (see the module doc).
#[allow(clippy::too_many_arguments)]
fn trace_direct(
    scene: &SceneAt<'_>,
    s: &Settings,
    light: &PreparedLight,
    projection: &Projection,
    at: &PathHit,
    draws: &Draws,
    n_shadow: u32,
    r: &mut PathRecord,
) {
    let PathHit { v: Vertex { x, n, wo, kd, ks, m }, glossy, w } = *at;
    // Direct: centre-of-light form factor (or, with `exact`, the per-sample geometry term),
    // visibility sampled (eqs. 5.9–5.14); the glossy lobe toward the light centre folds into k
    // (eq. 5.20).
    let fc = light_centre_factor(light, x, n);
    let mut k = kd;
    if glossy {
        let to_centre = (light.centre - x).normalize_or_zero();
        k += ks * (std::f32::consts::PI * glossy_brdf(s.path.lobe, m, n, wo, to_centre));
    }
    let d1 = (light.centre - x).dot(light.normal).abs();
    r.d1 += w * d1;
    let (mut e, mut unshadowed, mut valid) = (Vec3::ZERO, Vec3::ZERO, 0u32);
    for _ in 0..n_shadow {
        let u = draws.draw(pair::LIGHT, r.shadow);
        r.shadow += 1;
        let ls = light_sample(scene, light, x, n, u, if s.exact { None } else { Some(fc) }, true);
        let v = ls.value;
        if let Some(o) = ls.occluder {
            let d2 = o.distance;
            r.occluded += 1;
            widen_range((&mut r.d2_min, &mut r.d2_max), d2, r.occluded == 1);
            let vs = if s.time {
                let occluder = scene.surface(&o.hit, o.origin, o.dir);
                shadow_velocity(projection, x, d1, d2, scene.velocity(&occluder))
            } else {
                Vec2::ZERO
            };
            r.vs_sum = (Vec2::from(r.vs_sum) + vs).to_array();
            extend_range(&mut r.vs_min, &mut r.vs_max, vs, r.occluded == 1);
        }
        if v.is_finite() && ls.unshadowed.is_finite() {
            e += v;
            unshadowed += ls.unshadowed;
            valid += 1;
        } else {
            r.non_finite += 1;
        }
    }
    // U takes E's weights (a path's mean, or the sample sum with a fixed camera ray).
    let per = if s.fixed_primary {
        1.0
    } else if valid > 0 {
        1.0 / valid as f32
    } else {
        0.0
    };
    add(&mut r.u_direct, unshadowed * (per * w));
    let sums = Sums { l: &mut r.l_direct, k: &mut r.k_direct, e: &mut r.e_direct, w: &mut r.w_direct };
    accumulate(sums, k, e, valid, w, s.fixed_primary);
}

/// The occluder term `cos²θ_occ / z` of eqs. 6.13 and 6.17 for an environment sample along a direction
/// at `cos θ` to the normal, blocked at distance `t` along it. The thesis's flatland occluder is a
/// half-plane at height `z` above the receiver whose edge is seen at `θ_occ` (Fig. 6.4(c), eq. 6.8);
/// the edge lies at distance `t = z / cos θ_occ` along the blocked direction, so the term is
/// `cos θ / t` (docs/EQUATIONS.md "Environment"; docs/DESIGN-NOTES.md "The Environment node").
#[inline]
pub fn occluder_term(cos: f32, t: f32) -> f32 {
    if t > 0.0 {
        cos / t
    } else {
        0.0
    }
}

/// The environment estimator at hit `x` (thesis Ch. 6, Sec. 6.5.2): `count` look-ups into the map's
/// table (stratified: [`crate::kernels::environment::stratified_entry`]), each with a shadow ray to
/// infinity; `E_d = L cos/(π pdf)` with `k = k_d` and, where the surface has a lobe, `E_s = L ρ_s
/// cos/pdf` with `k = k_s` (Phong receivers, eq. 6.14). Occluded samples at least
/// `occluder_luminance` bright keep the largest [`occluder_term`]. With `environment_mis` a glossy
/// receiver's look-up `q` is a pair — the table's direction and one drawn from the lobe
/// ([`lobe_look_up`]) — and `E_s` sums the two under the balance heuristic.
fn trace_environment(scene: &SceneAt<'_>, s: &Settings, at: &PathHit, draws: &Draws, count: u32, r: &mut PathRecord) {
    let PathHit { v: Vertex { x, n, wo, kd, ks, m }, glossy, w } = *at;
    let Some(env) = scene.scene().environment.as_ref() else { return };
    let shift = if s.stratified { uniform_entry(draws.draw(pair::ENVIRONMENT, 0).x) } else { 0 };
    let origin = x + n * s.path.eps;
    let mis = glossy && s.environment_mis;
    let (mut ed, mut eg, mut valid_d, mut valid_g) = (Vec3::ZERO, Vec3::ZERO, 0u32, 0u32);
    for _ in 0..count {
        let q = r.env_samples;
        r.env_samples += 1;
        let entry =
            if s.stratified { stratified_entry(shift, q) } else { uniform_entry(draws.draw(pair::ENVIRONMENT, q).x) };
        let e = env.table(entry as usize);
        let cos = n.dot(e.dir);
        let (mut vd, mut vg) = (Vec3::ZERO, Vec3::ZERO);
        if cos > 0.0 && e.pdf > 0.0 {
            r.env_rays += 1;
            // The occluder's distance only where the sample is bright enough to count (any-hit otherwise).
            let occluded = if luminance(e.radiance) >= s.occluder_luminance {
                match scene.intersect(origin, e.dir, 0.0, f32::INFINITY) {
                    Some(h) => {
                        r.env_occluder = r.env_occluder.max(occluder_term(cos, h.t));
                        true
                    }
                    None => false,
                }
            } else {
                scene.occluded(origin, e.dir, 0.0, f32::INFINITY)
            };
            if occluded {
                r.env_occluded += 1;
            } else {
                let l = e.radiance * (cos / e.pdf);
                vd = l * std::f32::consts::FRAC_1_PI;
                if mis {
                    let p_lobe = glossy_pdf(s.path.lobe, m, n, wo, e.dir);
                    vg = e.radiance * glossy_brdf(s.path.lobe, m, n, wo, e.dir) * (cos / (e.pdf + p_lobe));
                } else if glossy {
                    vg = l * glossy_brdf(s.path.lobe, m, n, wo, e.dir);
                }
            }
        }
        if mis {
            let lobe = LobeAt { lobe: s.path.lobe, m, n, wo, origin };
            vg += lobe_look_up(scene, env, &lobe, draws.draw(pair::ENVIRONMENT_LOBE, q), r);
        }
        for (v, e, valid) in [(vd, &mut ed, &mut valid_d), (vg, &mut eg, &mut valid_g)] {
            if v.is_finite() {
                *e += v;
                *valid += 1;
            } else {
                r.non_finite += 1;
            }
        }
    }
    let sums =
        Sums { l: &mut r.l_env_diffuse, k: &mut r.k_env_diffuse, e: &mut r.e_env_diffuse, w: &mut r.w_env_diffuse };
    accumulate(sums, kd, ed, valid_d, w, s.fixed_primary);
    let sums = Sums { l: &mut r.l_env_glossy, k: &mut r.k_env_glossy, e: &mut r.e_env_glossy, w: &mut r.w_env_glossy };
    accumulate(sums, if glossy { ks } else { Vec3::ZERO }, eg, valid_g, w, s.fixed_primary);
}

/// A glossy receiver's lobe where the environment is looked up.
struct LobeAt {
    lobe: Lobe,
    m: f32,
    n: Vec3,
    wo: Vec3,
    /// The shadow rays' origin, off the surface.
    origin: Vec3,
}

/// The lobe's half of an MIS look-up pair: a direction drawn from the glossy lobe with `u`, a shadow
/// ray, and `L ρ_s cos / (pdf_map + pdf_lobe)` — the balance heuristic's weight times `f / pdf_lobe`
/// (the table's half is `L ρ_s cos / (pdf + pdf_lobe)` at the table's direction). The map's pdf is the
/// continuous one the table was drawn from (`EnvironmentMap::pdf`), so the pair estimates the
/// lighting integral wherever the lobe or the map is sharp; 0 below the surface or occluded.
/// (`shaders/paths_trace.wgsl` traces it as ray 1 of the table's loop, to share the traversal.)
fn lobe_look_up(scene: &SceneAt<'_>, env: &EnvironmentMap, at: &LobeAt, u: Vec2, r: &mut PathRecord) -> Vec3 {
    let (wi, _) = sample_glossy(at.lobe, at.m, at.n, at.wo, u);
    let cos = at.n.dot(wi);
    if !(cos > 0.0 && wi.is_finite()) {
        return Vec3::ZERO;
    }
    r.env_rays += 1;
    if scene.occluded(at.origin, wi, 0.0, f32::INFINITY) {
        return Vec3::ZERO;
    }
    let pdf = env.pdf(wi) + glossy_pdf(at.lobe, at.m, at.n, at.wo, wi);
    env.radiance(wi) * glossy_brdf(at.lobe, at.m, at.n, at.wo, wi) * (cos / pdf)
}

/// The indirect estimators (diffuse, and glossy where the surface has a lobe) at hit `x`.
fn trace_indirect(
    scene: &SceneAt<'_>,
    s: &Settings,
    at: &PathHit,
    draws: &Draws,
    (rng_d, rng_g): (&PixelRng, &PixelRng),
    count: Secondary,
    r: &mut PathRecord,
) {
    let PathHit { v: Vertex { x, n, wo, kd, ks, m }, glossy, w } = *at;

    // Indirect diffuse: cosine-sampled one-bounce paths; E = incident radiance, k = k_d. Ambient
    // occlusion is not reflected light: its texture is 1 (L = E = the occluded fraction), so a
    // factoring node composes and blurs the occlusion itself (docs/NODES.md "Composing effects").
    let kd = if s.path.ao { Vec3::ONE } else { kd };
    if count.diffuse > 0 {
        let (mut e, mut valid) = (Vec3::ZERO, 0u32);
        for _ in 0..count.diffuse {
            let q = r.diffuse_samples;
            r.diffuse_samples += 1;
            let wi = sample_diffuse(n, draws.draw(pair::HEMISPHERE_DIFFUSE, q));
            let v = indirect_ray(scene, &s.path, x, n, wi, rng_d, q, r);
            if v.is_finite() {
                e += v;
                valid += 1;
            } else {
                r.non_finite += 1;
            }
        }
        let sums = Sums { l: &mut r.l_diffuse, k: &mut r.k_diffuse, e: &mut r.e_diffuse, w: &mut r.w_diffuse };
        accumulate(sums, kd, e, valid, w, s.fixed_primary);
    }

    // Indirect glossy: lobe-sampled; E = L_i · f cos/pdf without k_s, k = k_s. Ambient occlusion
    // has no glossy part.
    if glossy && s.glossy && count.glossy > 0 {
        let (mut e, mut valid) = (Vec3::ZERO, 0u32);
        for _ in 0..count.glossy {
            let q = r.glossy_samples;
            r.glossy_samples += 1;
            let u = draws.draw(pair::HEMISPHERE_GLOSSY, q);
            let (wi, weight) = sample_glossy(s.path.lobe, m, n, wo, u);
            let v =
                if weight > 0.0 { indirect_ray(scene, &s.path, x, n, wi, rng_g, q, r) * weight } else { Vec3::ZERO };
            if v.is_finite() {
                e += v;
                valid += 1;
            } else {
                r.non_finite += 1;
            }
        }
        let sums = Sums { l: &mut r.l_glossy, k: &mut r.k_glossy, e: &mut r.e_glossy, w: &mut r.w_glossy };
        accumulate(sums, ks, e, valid, w, s.fixed_primary);
    }
}

/// One indirect path (shared estimator `indirect::trace_path`), with its rays and first hit recorded.
#[allow(clippy::too_many_arguments)]
fn indirect_ray(
    scene: &SceneAt<'_>,
    p: &PathParams,
    x: Vec3,
    n: Vec3,
    wi: Vec3,
    rng: &PixelRng,
    q: u32,
    r: &mut PathRecord,
) -> Vec3 {
    let mut rays = PathRays::default();
    let (v, t) = trace_path(scene, p, x, n, wi, rng, q, &mut rays);
    r.indirect_rays += rays.secondary as u32;
    r.bounce_shadow += rays.shadow as u32;
    if let Some(t) = t {
        r.indirect_hits += 1;
        widen_range((&mut r.z_min, &mut r.z_max), t, r.indirect_hits == 1);
    }
    v
}

/// One component's sums in a record.
struct Sums<'a> {
    l: &'a mut [f32; 3],
    k: &'a mut [f32; 3],
    e: &'a mut [f32; 3],
    w: &'a mut f32,
}

/// Add one path's component from its `valid` finite samples summing to `e` and texture `k`
/// (module doc, "Weights"): with path weights, `E` = their mean (0 without any), `k` and `L = k·E`,
/// each times the lens weight (the component weight was added with the path); with sample weights
/// (`fixed_primary`), the sums themselves, `k` times `valid`, and `w·valid` to the component weight.
fn accumulate(sums: Sums<'_>, k: Vec3, e: Vec3, valid: u32, w: f32, fixed_primary: bool) {
    let (e, n) =
        if fixed_primary { (e, valid as f32) } else { (if valid > 0 { e / valid as f32 } else { Vec3::ZERO }, 1.0) };
    add(sums.l, k * e * w);
    add(sums.k, k * (n * w));
    add(sums.e, e * w);
    if fixed_primary {
        *sums.w += n * w;
    }
}

/// `paths.resolve`: a [`PathRecord`]'s sums as the means downstream kernels read, in the
/// conventions of the existing buffers, every output optional:
/// - `radiance`: mean L of all components plus emission (the Monte Carlo estimate of the pixel);
/// - `l_direct`, `k_direct`, `e_direct`, and the same for `diffuse` and `glossy`: lens-weighted
///   means of L, k, E per component (eqs. 5.9–5.14, 5.21; SepDir/SepInd compare L with k·E; E, and
///   every E below, over the paths that hit a surface: [`PathRecord::w_direct_missed`]);
/// - `emission`: mean emission of the primary hits;
/// - `position` (λ, w = 1 + object id, 0 where no path hit) and `normal` (unit lens-averaged
///   normal, w = projected pixel size at λ, as `primary.gbuffer` computes it): what filters read;
/// - `defocus`: `r_min`, `r_max` (|circle of confusion| in pixels, eq. 5.2), mean depth `z` along
///   the optical axis, and `ℓ_p = 2 z tan(fov/2)/h` (metres per pixel at that depth, Ch. 5);
/// - `occlusion`: mean `d1`, `d2_min`, `d2_max`, occluded shadow rays (as `direct.light` writes it);
/// - `depth`: `z_min`, `z_max`, indirect rays that hit, indirect rays (as `indirect.sample`);
/// - `counts`: paths (primary samples; a fixed camera ray is traced once for all of them), shadow rays, indirect samples (diffuse + glossy), non-finite samples;
/// - `direct`: mean direct E (rgb) and w = shadow rays, the value/sample-count convention of
///   `direct.light`'s `estimate`, which the world-space filters read (Vec4); `direct_unshadowed`:
///   the same samples' mean with every shadow ray counted as unblocked (U; `E/U` is the ratio
///   estimate of visibility SoftShadows filters);
/// - `diffuse`, `glossy`: the same for the indirect parts (mean E, w = their samples), the convention
///   of `indirect.sample`'s estimates (Ch. 4 filters them, then multiplies k_d and k_s back in);
/// - `velocity`: mean image-space velocity of the primary hits (px per half shutter) and its per-axis
///   range over the paths (misses as 0); `shadow_velocity`: the same over the occluded shadow samples
///   (thesis App. B's `v_p`, `v_s` and "distinct velocities");
/// - `l_env_diffuse`, …, `e_env_glossy`: L, k, E of the environment's diffuse and glossy parts (E
///   over the paths that hit: [`PathRecord::w_env_missed`]);
///   `environment`: the occluder term `cos²θ_occ/z` (largest over the bright occluded look-ups, 0
///   without), the mean Phong exponent of the hits (0: no lobe), look-ups, occluded look-ups.
pub struct PathsResolve;

/// Every output of `paths.resolve`, in binding order (all optional): the single declaration of the
/// shared sampler's outputs (module doc, "Bindings").
pub const RESOLVE_OUTPUTS: [(&str, Format); 30] = [
    ("radiance", Format::Vec3),
    ("l_direct", Format::Vec3),
    ("k_direct", Format::Vec3),
    ("e_direct", Format::Vec3),
    ("l_diffuse", Format::Vec3),
    ("k_diffuse", Format::Vec3),
    ("e_diffuse", Format::Vec3),
    ("l_glossy", Format::Vec3),
    ("k_glossy", Format::Vec3),
    ("e_glossy", Format::Vec3),
    ("emission", Format::Vec3),
    ("position", Format::Vec4),
    ("normal", Format::Vec4),
    ("defocus", Format::Vec4),
    ("occlusion", Format::Vec4),
    ("depth", Format::Vec4),
    ("counts", Format::Vec4),
    ("direct", Format::Vec4),
    ("diffuse", Format::Vec4),
    ("glossy", Format::Vec4),
    ("velocity", Format::Vec4),
    ("shadow_velocity", Format::Vec4),
    ("l_env_diffuse", Format::Vec3),
    ("k_env_diffuse", Format::Vec3),
    ("e_env_diffuse", Format::Vec3),
    ("l_env_glossy", Format::Vec3),
    ("k_env_glossy", Format::Vec3),
    ("e_env_glossy", Format::Vec3),
    ("environment", Format::Vec4),
    ("direct_unshadowed", Format::Vec4),
];

/// The outputs of `paths.resolve_near` ([`PathsResolveNear`]): the near layer. A kernel of their
/// own, because `paths.resolve`'s record and 30 outputs with the counters already fill the 32
/// storage buffers per shader stage many devices (lavapipe among them) bind directly.
pub const NEAR_LAYER_OUTPUTS: [(&str, Format); 2] = [("near", Format::Vec4), ("near_coc", Format::Vec4)];

/// A mean and its sample count: the estimate convention the world-space filters read.
fn estimate(e: [f32; 3], samples: u32) -> [f32; 4] {
    [e[0], e[1], e[2], samples as f32]
}

/// Output `k` of [`RESOLVE_OUTPUTS`] for one pixel (a Vec3 output in the first three components).
/// One output at a time, so a pass computes and stores only what it binds (resolving every output of
/// every pixel into one intermediate array took 150 ms per pass at 640×480, most of it the array).
fn resolve_output(k: usize, r: &PathRecord, cam: &Camera, pixel_angle: f32, tan_half: f32, height: u32) -> [f32; 4] {
    let mean = |s: [f32; 3], over: f32| {
        let m = r.mean_of(s, over);
        [m.x, m.y, m.z, 0.0]
    };
    let hit_mean = |s: f32| if r.hit_weight > 0.0 { s / r.hit_weight } else { 0.0 };
    // Position (λ, 1 + object), normal (w = footprint) and defocus (r range, depth, ℓ_p) of a hit pixel.
    let surface = |which: usize| -> [f32; 4] {
        if r.hits == 0 {
            return [0.0; 4];
        }
        let lambda = r.lens_position();
        if which == 0 {
            return [lambda.x, lambda.y, lambda.z, r.object as f32];
        }
        if which == 2 {
            let z = hit_mean(r.depth);
            return [r.r_min, r.r_max, z, 2.0 * z * tan_half / height.max(1) as f32];
        }
        let n = r.lens_normal().normalize_or_zero();
        let to = lambda - cam.position;
        let t = to.length();
        let d = to / t;
        let cos = n.dot(-d).abs().max(0.05);
        [n.x, n.y, n.z, t * pixel_angle / cos.sqrt()]
    };
    let e = |s: [f32; 3], over: f32| {
        let m = mean(s, over);
        [m[0], m[1], m[2]]
    };
    match RESOLVE_OUTPUTS[k].0 {
        "radiance" => {
            let m = r.radiance();
            [m.x, m.y, m.z, 0.0]
        }
        "l_direct" => mean(r.l_direct, r.w_direct),
        "k_direct" => mean(r.k_direct, r.w_direct),
        "e_direct" => mean(r.e_direct, r.w_direct - r.w_direct_missed),
        "l_diffuse" => mean(r.l_diffuse, r.w_diffuse),
        "k_diffuse" => mean(r.k_diffuse, r.w_diffuse),
        "e_diffuse" => mean(r.e_diffuse, r.w_diffuse - r.w_diffuse_missed),
        "l_glossy" => mean(r.l_glossy, r.w_glossy),
        "k_glossy" => mean(r.k_glossy, r.w_glossy),
        "e_glossy" => mean(r.e_glossy, r.w_glossy - r.w_glossy_missed),
        "emission" => mean(r.emission, r.weight),
        "position" => surface(0),
        "normal" => surface(1),
        "defocus" => surface(2),
        "occlusion" => [hit_mean(r.d1), r.d2_min, r.d2_max, r.occluded as f32],
        "depth" => [r.z_min, r.z_max, r.indirect_hits as f32, r.indirect_rays as f32],
        "counts" => {
            [r.paths as f32, r.shadow as f32, (r.diffuse_samples + r.glossy_samples) as f32, r.non_finite as f32]
        }
        "direct" => estimate(e(r.e_direct, r.w_direct - r.w_direct_missed), r.shadow),
        "diffuse" => estimate(e(r.e_diffuse, r.w_diffuse - r.w_diffuse_missed), r.diffuse_samples),
        "glossy" => estimate(e(r.e_glossy, r.w_glossy - r.w_glossy_missed), r.glossy_samples),
        "velocity" => velocity_stats(r.vp_sum, r.hit_weight, r.vp_min, r.vp_max),
        "shadow_velocity" => velocity_stats(r.vs_sum, r.occluded as f32, r.vs_min, r.vs_max),
        "l_env_diffuse" => mean(r.l_env_diffuse, r.w_env_diffuse),
        "k_env_diffuse" => mean(r.k_env_diffuse, r.w_env_diffuse),
        "e_env_diffuse" => mean(r.e_env_diffuse, r.w_env_diffuse - r.w_env_missed),
        "l_env_glossy" => mean(r.l_env_glossy, r.w_env_glossy),
        "k_env_glossy" => mean(r.k_env_glossy, r.w_env_glossy),
        "e_env_glossy" => mean(r.e_env_glossy, r.w_env_glossy - r.w_env_missed),
        "environment" => [r.env_occluder, hit_mean(r.exponent), r.env_samples as f32, r.env_occluded as f32],
        "direct_unshadowed" => estimate(e(r.u_direct, r.w_direct - r.w_direct_missed), r.shadow),
        other => unreachable!("RESOLVE_OUTPUTS names `{other}`, which resolve_output does not know"),
    }
}

/// A resolve kernel's bindings: the record, then each of `outputs`, optional.
fn resolve_bindings(outputs: &[(&'static str, Format)]) -> Vec<Binding> {
    let mut b = vec![Binding::read("record", Format::Struct(&PATH_RECORD))];
    b.extend(outputs.iter().map(|(n, f)| Binding::write_opt(n, *f)));
    b
}

/// A resolve kernel's CPU run: each bound one of `outputs`, `value(k, record)` per pixel (a Vec3
/// output takes the first three components). Only the bound outputs are computed, all of them in
/// one sweep over the records, row by row: a record (109 words) is read once, not once per output
/// (the pass was bound by that traffic: ten outputs walked ~130 MB of records ten times).
fn put_resolved(
    ctx: &mut KernelCtx<'_>,
    outputs: &[(&'static str, Format)],
    value: impl Fn(usize, &PathRecord) -> [f32; 4] + Sync,
) -> Result<(), BackendError> {
    let records = ctx.read::<PathRecord>("record")?;
    let bound: Vec<usize> = (0..outputs.len()).filter(|&k| ctx.is_bound(outputs[k].0)).collect();
    let width = (ctx.width as usize).max(1);
    let mut columns: Vec<Vec<[f32; 4]>> = bound.iter().map(|_| vec![[0.0; 4]; ctx.pixels()]).collect();
    // Row y of every bound output, side by side.
    let mut rows: Vec<Vec<&mut [[f32; 4]]>> = (0..ctx.height).map(|_| Vec::with_capacity(bound.len())).collect();
    for column in &mut columns {
        for (row, out) in column.chunks_mut(width).zip(rows.iter_mut()) {
            out.push(row);
        }
    }
    rows.into_par_iter().zip(records.par_chunks(width)).for_each(|(mut outs, row)| {
        for (x, r) in row.iter().enumerate() {
            for (out, &k) in outs.iter_mut().zip(&bound) {
                out[x] = value(k, r);
            }
        }
    });
    for (k, values) in bound.into_iter().zip(columns) {
        let (name, format) = outputs[k];
        if format == Format::Vec3 {
            ctx.put(name, values.into_iter().map(|v| [v[0], v[1], v[2]]).collect::<Vec<_>>())?;
        } else {
            ctx.put(name, values)?;
        }
    }
    Ok(())
}

/// A velocity's mean (`sum / over`, 0 where `over` is 0) and its per-axis range `max − min`.
fn velocity_stats(sum: [f32; 2], over: f32, min: [f32; 2], max: [f32; 2]) -> [f32; 4] {
    let mean = |s: f32| if over > 0.0 { s / over } else { 0.0 };
    [mean(sum[0]), mean(sum[1]), max[0] - min[0], max[1] - min[1]]
}

impl Kernel for PathsResolve {
    fn name(&self) -> &'static str {
        "paths.resolve"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Compose
    }
    fn bindings(&self) -> Vec<Binding> {
        resolve_bindings(&RESOLVE_OUTPUTS)
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/paths_resolve.wgsl"), |ctx| {
                let cam = &ctx.scene.camera;
                let tan_half = (cam.vfov_deg.to_radians() * 0.5).tan();
                Ok(Uniforms::new()
                    .vec3("camera", cam.position.to_array())
                    .f32("pixel_angle", 2.0 * tan_half / ctx.full_size().1 as f32)
                    .f32("tan_half", tan_half))
            })
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let cam = ctx.scene.camera;
        let tan_half = (cam.vfov_deg.to_radians() * 0.5).tan();
        let height = ctx.full_size().1;
        let pixel_angle = 2.0 * tan_half / height as f32;
        put_resolved(ctx, &RESOLVE_OUTPUTS, |k, r| resolve_output(k, r, &cam, pixel_angle, tan_half, height))
    }
}

/// `paths.resolve_near`: the near layer of a [`PathRecord`] ([`NEAR_LAYER_OUTPUTS`], both
/// optional) — `near`: the radiance of the paths whose hit lies in front of the focal plane, blurred
/// over more than [`NEAR_LAYER_COC`] pixels, over all paths (`Σ_near w L / Σ w`, rgb: premultiplied
/// by its coverage) and its coverage `Σ_near w / Σ w` (w); `near_coc`: the least |circle of
/// confusion| among those paths (x; 0 without any). Defocus's `layers` reads them
/// (`effects/src/defocus/kernels/layers.rs`). WGSL mirror: `shaders/paths_resolve_near.wgsl`.
pub struct PathsResolveNear;

/// Output `k` of [`NEAR_LAYER_OUTPUTS`] for one pixel.
fn resolve_near(k: usize, r: &PathRecord) -> [f32; 4] {
    match NEAR_LAYER_OUTPUTS[k].0 {
        "near" => {
            let m = r.mean_of(r.l_near, r.weight);
            [m.x, m.y, m.z, if r.weight > 0.0 { r.w_near / r.weight } else { 0.0 }]
        }
        "near_coc" => [r.r_near, 0.0, 0.0, 0.0],
        other => unreachable!("NEAR_LAYER_OUTPUTS names `{other}`, which resolve_near does not know"),
    }
}

impl Kernel for PathsResolveNear {
    fn name(&self) -> &'static str {
        "paths.resolve_near"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Compose
    }
    fn bindings(&self) -> Vec<Binding> {
        resolve_bindings(&NEAR_LAYER_OUTPUTS)
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/paths_resolve_near.wgsl"), |_| Ok(Uniforms::new()))
                .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        put_resolved(ctx, &NEAR_LAYER_OUTPUTS, resolve_near)
    }
}
