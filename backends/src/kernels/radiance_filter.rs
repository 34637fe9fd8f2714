//! Radiance filtering for progressive rendering (issue 18; Schwenk's thesis,
//! `seeds/002_34c8a733cb47f3c2.txt` Ch. 4, "Filtering Incident Radiance"): the kernels of the
//! `RadianceFilter` node (`wedge_effects::radiance_filter`) and the pure formulas they share, each
//! unit-tested here and mirrored in WGSL (`shaders/radiance_filter_*.wgsl`).
//!
//! Instead of filtering pixel values (Ch. 3, `pixel_filter.rs`), each pixel re-uses its
//! neighbours' *incident* indirect radiance samples under its own BRDF (eq. 4.10), so texture and
//! geometry stay sharp; the kernel shrinks frame by frame so that the accumulated image keeps a
//! target variance and converges to plain path tracing (Sec. 4.3.3, the correction phase).
//!
//! - `radiance_filter.sample`: `count` jittered paths per pixel (one per frame), the same
//!   estimators as `pixel_filter.sample` ([`first_vertex`]): the batch's [`Stats`] of direct light
//!   (`lv`) and of the pixel's own indirect estimate (`hv`, with `M2` of its luminance), and the
//!   radiance sample of path 0 at the first non-specular vertex (Sec. 4.3.1, steps 1–2; wedge has no
//!   perfect specular surfaces, so it is the first hit): position, normal, albedo, direction, `L̆`.
//! - `radiance_filter.radius`: the image-space kernel radius of this frame per pixel: the warm-up
//!   radius `r_w1 k^-1/2` (eq. 4.15) for the first `warmup` frames, then the radius whose
//!   Epanechnikov kernel averages enough samples to reach the target variance `T_k = (2k−1)T_u`
//!   (eqs. 4.1, 4.2, 4.14) for the pixel's filtered perceived variance ([`kernel_radius`]), scaled
//!   by the previous frame's screen-space ambient-occlusion factor α (Sec. 4.3.1, step 3;
//!   [`occlusion_factor`]) unless `occlusion` is off.
//! - `radiance_filter.filter`: eq. 4.10–4.12 over the neighbours inside the kernel projected to the
//!   tangent plane (eqs. 4.19–4.22, [`TangentKernel`]), weighted by Epanechnikov (Sec. 4.3.6) and the
//!   normal heuristic `ν` (eq. 4.9); the per-path variance is filtered with the same weights
//!   (Sec. 4.3.4), and α gathered from the same samples. A radius under one pixel is the correction
//!   phase: the pixel's own estimate, exactly.
//! - `radiance_filter.compose`: this frame's direct + filtered indirect light accumulated over frames
//!   (the running mean of eq. 4.13), or — `correction: "switch"` — the plain accumulation once a pixel
//!   has entered the correction phase (Sec. 4.4.1's "little trick").
//!
//! Buffer conventions (all `vec4` unless said): `lv`/`hv` as in `pixel_filter.rs` ([`Stats`]);
//! `point` = (x, ray distance; 0 = the camera ray left the scene), `normal` = (n, material index),
//! `albedo` = (k_d, 0), `direction` = (ω_i, 1 = a sample to re-use), `incident` = (L̆, distance to
//! the surface the continuation ray hit, [`NO_BOUNCE_HIT`] if it left the scene); `filtered` =
//! (this frame's indirect light, [`FILTERED`] or [`OWN`]); `variance` = (σ² filtered, or −1 where no
//! neighbour had two paths, Σw, radius, occlusion factor α); `accumulated` = (mean, frames);
//! `radius` and `phase` are `f32`.

use glam::Vec3;
use wedge_graph::Format;

use crate::kernel::{Binding, Kernel, KernelClass, KernelCtx, Reach, Uniforms, WgslSource};
use crate::kernels::hemisphere::Lobe;
use crate::kernels::indirect::lobe_mixture;
use crate::kernels::pixel_filter::{CameraPaths, Stats};
use crate::kernels::{luminance, v3};
use crate::BackendError;

// ---------------------------------------------------------------------------------------------
// Formulas (pure; WGSL mirror: shaders/radiance_filter_formulas.wgsl)
// ---------------------------------------------------------------------------------------------

/// `filtered.w` of a pixel filtered over its neighbours (the preview phase).
pub const FILTERED: f32 = -1.0;
/// `filtered.w` of a pixel whose kernel holds only its own sample (radius < 1 pixel: the correction
/// phase, or no surface): the compose pass takes the pixel's own path-tracing estimate, bit for bit.
/// A reference, whose filter is bypassed to that estimate (`w` = M2 ≥ 0), is treated the same way.
pub const OWN: f32 = -2.0;

/// Effective samples of a 2-D Epanechnikov kernel per unit area, `(∫K)²/(∫K²)/area` = (π/2)²/(π/3)/π
/// = 3/4: with one sample per pixel, a kernel of image radius `r` averages `¾πr²` samples' worth
/// (reading: Sec. 4.3.5 says the radius must be adjusted for a non-uniform kernel, not how).
pub const EPANECHNIKOV_EFFICIENCY: f32 = 0.75;

/// `incident.w` of a radiance sample whose continuation ray left the scene (no occluder at any
/// distance).
pub const NO_BOUNCE_HIT: f32 = -1.0;

/// The smallest `|D·N|` eq. 4.21 divides by: the kernel is elongated at most 5× along the surface
/// at grazing angles (the thesis's "small ε … in practice, excessive elongation").
pub const MIN_COS: f32 = 0.2;

/// Target variance of frame `k` (1-based), eq. 4.14: `T_k = (2k − 1) T_u`, the largest variance of
/// frame `k`'s estimate that keeps the running mean at `T_u` (eq. 4.13).
#[inline]
pub fn target_variance(t_u: f32, k: u32) -> f32 {
    (2.0 * k as f32 - 1.0) * t_u
}

/// Warm-up radius of frame `k` (eq. 4.15): `r_w1 k^-1/2`.
#[inline]
pub fn warmup_radius(r_w1: f32, k: u32) -> f32 {
    r_w1 / (k as f32).sqrt()
}

/// Image-space radius (pixels) whose Epanechnikov kernel averages `M_k = v/T_k` samples (eq. 4.1),
/// `v` the pixel's perceived per-path variance: `√(M_k / (¾π))` — the circle covering `M_k` pixels of
/// eq. 4.2, corrected for the kernel's weights ([`EPANECHNIKOV_EFFICIENCY`]). `v = ∞` (a black
/// background under noise) gives ∞; the caller caps it.
#[inline]
pub fn variance_radius(v: f32, t_u: f32, k: u32) -> f32 {
    let m = v / target_variance(t_u, k);
    (m / (EPANECHNIKOV_EFFICIENCY * std::f32::consts::PI)).sqrt()
}

/// The settings of the kernel-radius rule.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadiusRule {
    /// Scale the radius by the previous frame's occlusion factor α (the radius pass).
    pub occlusion: bool,
    pub t_u: f32,
    pub warmup: u32,
    pub warmup_radius: f32,
    pub max_radius: f32,
}

/// The radius of frame `k` (1-based) for a pixel: the warm-up radius for the first `warmup` frames
/// or where no variance is known yet (`sigma2 < 0`), else [`variance_radius`] of the perceived
/// variance `σ²/L_b²` (Sec. 3.3.1, as Sec. 4.3.4 uses it; `L_b` the luminance of the accumulated
/// image). Capped at `max_radius`; a NaN becomes 0 (no filtering, never a spread NaN).
pub fn kernel_radius(rule: &RadiusRule, k: u32, sigma2: f32, lb: f32) -> f32 {
    let r = if k <= rule.warmup || sigma2 < 0.0 {
        warmup_radius(rule.warmup_radius, k)
    } else if !(sigma2 > 0.0) {
        0.0
    } else if !(lb > 0.0) {
        rule.max_radius
    } else {
        variance_radius(sigma2 / (lb * lb), rule.t_u, k)
    };
    if r.is_nan() {
        0.0
    } else {
        r.min(rule.max_radius)
    }
}

/// Whether a sample's continuation ray, which hit a surface at `distance` ([`NO_BOUNCE_HIT`]: none),
/// was unoccluded within the kernel's tangent radius `rs`: the screen-space ambient occlusion of
/// Sec. 4.3.1 (step 3) with the kernel's own radius as the occlusion distance (reading: the thesis
/// names the factor and its effect — like the harmonic mean distance of irradiance caching, it
/// shrinks kernels near occluders against light leaks — not its formula).
#[inline]
pub fn unoccluded(distance: f32, rs: f32) -> bool {
    distance == NO_BOUNCE_HIT || distance > rs
}

/// The occlusion factor α ∈ [0, 1]: the kernel-weighted fraction of its samples whose continuation
/// rays were [`unoccluded`]; 1 without samples.
#[inline]
pub fn occlusion_factor(unoccluded_weight: f32, weight: f32) -> f32 {
    if weight > 0.0 {
        (unoccluded_weight / weight).min(1.0)
    } else {
        1.0
    }
}

/// The normal heuristic of eq. 4.9, `ν = max(0, n_j·n)^e`.
#[inline]
pub fn normal_weight(nj: Vec3, n: Vec3, e: f32) -> f32 {
    nj.dot(n).max(0.0).powf(e)
}

/// The exponent `e` of eq. 4.9 for a surface's glossy lobe: its Phong/Blinn exponent where it has
/// one, else 1 (reading: the thesis sets ν = 1 below e ≈ 128 to save a normal buffer; wedge has
/// the normals and keeps ν = max(0, n_j·n) so back-to-back surfaces never mix).
#[inline]
pub fn normal_exponent(ks: Vec3, m: f32) -> f32 {
    if m > 0.0 && ks.max_element() > 0.0 {
        m.max(1.0)
    } else {
        1.0
    }
}

/// The kernel's footprint on the tangent plane of the shading point (eqs. 4.19–4.22): an ellipse
/// with semi-axes `r_S` across the view direction and `r_D = r_S / max(ε, |D·N|)` along it, in a
/// prism of half-height `δ` along the normal. The Epanechnikov weight (Sec. 4.3.6) is
/// `1 − (s/r_S)² − (d/r_D)²` inside, 0 outside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TangentKernel {
    pub centre: Vec3,
    pub normal: Vec3,
    pub axis_s: Vec3,
    pub axis_d: Vec3,
    /// The tangent radius `r_S` (world units) and the reciprocals of both semi-axes.
    pub rs: f32,
    pub inv_rs: f32,
    pub inv_rd: f32,
    pub delta: f32,
}

impl TangentKernel {
    /// The kernel at `x` (normal `n`) seen from `eye` at ray distance `distance`, image radius
    /// `r` pixels, `pixel_angle` = the angle one pixel subtends (`2 tan(fov/2) / height`), prism
    /// half-height `thickness · r_S`. `r_S` is eq. 4.20 with the image plane at unit distance as the
    /// reference plane: `r_S = r · pixel_angle · distance`.
    pub fn new(x: Vec3, n: Vec3, eye: Vec3, distance: f32, r: f32, pixel_angle: f32, thickness: f32) -> TangentKernel {
        let d = (x - eye).normalize_or_zero();
        let dn = d.dot(n);
        // Eq. 4.19 with the reading of docs/EQUATIONS.md: the tangent projection of D is D − (D·N)N.
        let mut a_d = d - n * dn;
        let len = a_d.length();
        if !(len > 1e-6) {
            // Seen head-on: any tangent direction (the orientation does not matter, Sec. 4.3.5).
            a_d = if n.x.abs() > 0.9 { Vec3::new(0.0, 1.0, 0.0) } else { Vec3::new(1.0, 0.0, 0.0) };
            a_d = (a_d - n * a_d.dot(n)).normalize();
        } else {
            a_d /= len;
        }
        let a_s = a_d.cross(n);
        let rs = r * pixel_angle * distance;
        let rd = rs / dn.abs().max(MIN_COS);
        TangentKernel {
            centre: x,
            normal: n,
            axis_s: a_s,
            axis_d: a_d,
            rs,
            inv_rs: 1.0 / rs,
            inv_rd: 1.0 / rd,
            delta: thickness * rs,
        }
    }

    /// The Epanechnikov weight of a sample at `xj`.
    #[inline]
    pub fn weight(&self, xj: Vec3) -> f32 {
        let v = xj - self.centre;
        if v.dot(self.normal).abs() > self.delta {
            return 0.0;
        }
        let s = v.dot(self.axis_s) * self.inv_rs;
        let d = v.dot(self.axis_d) * self.inv_rd;
        let u = s * s + d * d;
        if u < 1.0 {
            1.0 - u
        } else {
            0.0
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Shared settings
// ---------------------------------------------------------------------------------------------

/// The angle one pixel subtends at the image centre, `2 tan(fov/2) / height`.
fn pixel_angle(ctx: &KernelCtx<'_>) -> f32 {
    2.0 * (ctx.scene.camera.vfov_deg.to_radians() * 0.5).tan() / ctx.full_size().1 as f32
}

fn max_radius(ctx: &KernelCtx<'_>) -> Result<u32, BackendError> {
    let v = ctx.int_param("max_radius")?;
    if !(0..=1024).contains(&v) {
        return Err(ctx.err(format!("`max_radius` = {v} must be between 0 and 1024 pixels")));
    }
    Ok(v as u32)
}

fn lobe(ctx: &KernelCtx<'_>) -> Result<Lobe, BackendError> {
    <Lobe as crate::params::ParamField>::read(ctx, "brdf")
}

// ---------------------------------------------------------------------------------------------
// radiance_filter.sample
// ---------------------------------------------------------------------------------------------

/// `radiance_filter.sample` (see the module doc).
pub struct RadianceSample;

/// One pixel's outputs of `radiance_filter.sample`.
#[derive(Clone, Copy, Default)]
struct PixelSamples {
    stats: Stats,
    point: [f32; 4],
    normal: [f32; 4],
    albedo: [f32; 4],
    direction: [f32; 4],
    incident: [f32; 4],
}

impl Kernel for RadianceSample {
    fn name(&self) -> &'static str {
        "radiance_filter.sample"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Sampling
    }
    fn draws_random(&self) -> bool {
        true
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            // The batch's Stats: mean direct light (w = finite paths), mean own indirect (w = M2).
            Binding::write("lv", Format::Vec4),
            Binding::write("hv", Format::Vec4),
            // Path 0's radiance sample.
            Binding::write("point", Format::Vec4),
            Binding::write("normal", Format::Vec4),
            Binding::write("albedo", Format::Vec4),
            Binding::write("direction", Format::Vec4),
            Binding::write("incident", Format::Vec4),
        ]
    }
    /// WGSL mirror: `shaders/radiance_filter_sample.wgsl` (on the shared `first_vertex.wgsl`).
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/radiance_filter_sample.wgsl"), |ctx| {
                Ok(CameraPaths::read(ctx)?.uniforms(Uniforms::new(), ctx))
            })
            .with_include("pixel_filter_formulas.wgsl", include_str!("../../../shaders/pixel_filter_formulas.wgsl"))
            .with_include(
                "radiance_filter_formulas.wgsl",
                include_str!("../../../shaders/radiance_filter_formulas.wgsl"),
            )
            .with_scene()
            .per_pixel()
            .chunked(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let out: Vec<PixelSamples> = CameraPaths::read(ctx)?.run(ctx, |o: &mut PixelSamples, j, v| {
            let finite = v.direct.is_finite() && v.indirect.is_finite();
            if finite {
                o.stats = Stats::combine(o.stats, Stats::one(v.direct, v.indirect));
            }
            // Path 0's radiance sample (a reference draws more paths, and bypasses the filter).
            if let (0, Some(sf)) = (j, v.surface) {
                o.point = [sf.position.x, sf.position.y, sf.position.z, sf.distance];
                o.normal = [sf.normal.x, sf.normal.y, sf.normal.z, sf.material as f32];
                o.albedo = [sf.albedo.x, sf.albedo.y, sf.albedo.z, 0.0];
                if let (Some(wi), true) = (v.wi, finite && v.incident.is_finite()) {
                    o.direction = [wi.x, wi.y, wi.z, 1.0];
                    o.incident = [v.incident.x, v.incident.y, v.incident.z, v.bounce_distance.unwrap_or(NO_BOUNCE_HIT)];
                }
            }
            finite
        });
        ctx.put("lv", out.iter().map(|o| o.stats.lv_buffer()).collect::<Vec<_>>())?;
        ctx.put("hv", out.iter().map(|o| o.stats.u_buffer()).collect::<Vec<_>>())?;
        ctx.put("point", out.iter().map(|o| o.point).collect::<Vec<_>>())?;
        ctx.put("normal", out.iter().map(|o| o.normal).collect::<Vec<_>>())?;
        ctx.put("albedo", out.iter().map(|o| o.albedo).collect::<Vec<_>>())?;
        ctx.put("direction", out.iter().map(|o| o.direction).collect::<Vec<_>>())?;
        ctx.put("incident", out.iter().map(|o| o.incident).collect::<Vec<_>>())
    }
}

// ---------------------------------------------------------------------------------------------
// radiance_filter.radius
// ---------------------------------------------------------------------------------------------

/// `radiance_filter.radius` (see the module doc): [`kernel_radius`] per pixel for frame
/// `k = frame + 1`, from the previous frame's filtered variance and accumulated image (history).
pub struct Radius;

fn radius_rule(ctx: &KernelCtx<'_>) -> Result<RadiusRule, BackendError> {
    let warmup = ctx.int_param("warmup")?;
    if !(1..=1 << 20).contains(&warmup) {
        return Err(ctx.err(format!("`warmup` = {warmup} must be between 1 and {}", 1 << 20)));
    }
    Ok(RadiusRule {
        occlusion: ctx.bool_param("occlusion")?,
        t_u: ctx.positive_f32_param("t_u")?,
        warmup: warmup as u32,
        warmup_radius: ctx.f32_param("warmup_radius")?.max(0.0),
        max_radius: max_radius(ctx)? as f32,
    })
}

impl Kernel for Radius {
    fn name(&self) -> &'static str {
        "radiance_filter.radius"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Bandwidth
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            // History: the previous frame's filtered variance and accumulated image (zeros/unbound
            // in a first frame).
            Binding::read_opt("previous_variance", Format::Vec4),
            Binding::read_opt("previous_accumulated", Format::Vec4),
            Binding::write("radius", Format::F32),
        ]
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/radiance_filter_radius.wgsl"), |ctx| {
                let r = radius_rule(ctx)?;
                Ok(Uniforms::new()
                    .u32("occlusion", r.occlusion as u32)
                    .f32("t_u", r.t_u)
                    .u32("warmup", r.warmup)
                    .f32("warmup_radius", r.warmup_radius)
                    .f32("max_radius", r.max_radius))
            })
            .with_include(
                "radiance_filter_formulas.wgsl",
                include_str!("../../../shaders/radiance_filter_formulas.wgsl"),
            )
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let rule = radius_rule(ctx)?;
        let k = ctx.frame + 1;
        let pv = ctx.read_opt::<[f32; 4]>("previous_variance")?;
        let pa = ctx.read_opt::<[f32; 4]>("previous_accumulated")?;
        let out: Vec<f32> = (0..ctx.pixels())
            .map(|i| {
                let (sigma2, lb, alpha) = match (pv, pa) {
                    // A first frame's history is zeros: w = 0 frames accumulated, no variance.
                    (Some(v), Some(a)) if a[i][3] > 0.0 => {
                        (v[i][0], luminance(Vec3::new(a[i][0], a[i][1], a[i][2])), v[i][3])
                    }
                    _ => (-1.0, 0.0, 1.0),
                };
                let r = kernel_radius(&rule, k, sigma2, lb);
                if rule.occlusion {
                    r * alpha
                } else {
                    r
                }
            })
            .collect();
        ctx.put("radius", out)
    }
}

// ---------------------------------------------------------------------------------------------
// radiance_filter.filter
// ---------------------------------------------------------------------------------------------

/// `radiance_filter.filter` (see the module doc).
pub struct Filter;

#[derive(Clone, Copy, Debug)]
struct FilterSettings {
    lobe: Lobe,
    thickness: f32,
    max_radius: u32,
    pixel_angle: f32,
    eye: Vec3,
}

fn filter_settings(ctx: &KernelCtx<'_>) -> Result<FilterSettings, BackendError> {
    Ok(FilterSettings {
        lobe: lobe(ctx)?,
        thickness: ctx.positive_f32_param("thickness")?,
        max_radius: max_radius(ctx)?,
        pixel_angle: pixel_angle(ctx),
        // The lens centre: the kernel's view direction and the stored vertex's outgoing direction.
        // Under an aperture each path starts elsewhere on the lens, within `aperture_radius` of it;
        // the filter's glossy weight reads the centre's direction (an approximation that fades with
        // the filter as frames accumulate).
        eye: ctx.scene.camera.position,
    })
}

/// The window of a pixel's kernel: `floor(r)` pixels either side, at most `max_radius`; 0 (its own
/// sample only) below one pixel.
#[inline]
pub fn window(r: f32, max_radius: u32) -> i32 {
    if r >= 1.0 {
        (r.floor() as i32).min(max_radius as i32)
    } else {
        0
    }
}

impl Kernel for Filter {
    fn name(&self) -> &'static str {
        "radiance_filter.filter"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Filter
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("radius", Format::F32),
            Binding::read("point", Format::Vec4),
            Binding::read("normal", Format::Vec4),
            Binding::read("albedo", Format::Vec4),
            Binding::read("direction", Format::Vec4),
            Binding::read("incident", Format::Vec4),
            // This frame's own indirect estimate (the sample pass's `hv`): what a reference keeps.
            Binding::read("own", Format::Vec4),
            // The accumulated statistics (n in lv.w, M2 in hv.w): the per-path variance to filter.
            Binding::read("lv", Format::Vec4),
            Binding::read("hv", Format::Vec4),
            Binding::write("filtered", Format::Vec4),
            Binding::write("variance", Format::Vec4),
        ]
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/radiance_filter_filter.wgsl"), |ctx| {
                let s = filter_settings(ctx)?;
                Ok(Uniforms::new()
                    .vec3("eye", s.eye.to_array())
                    .u32("lobe", (s.lobe == Lobe::BlinnPhong) as u32)
                    .f32("thickness", s.thickness)
                    .u32("max_radius", s.max_radius)
                    .f32("pixel_angle", s.pixel_angle))
            })
            .with_include(
                "radiance_filter_formulas.wgsl",
                include_str!("../../../shaders/radiance_filter_formulas.wgsl"),
            )
            .with_scene()
            .with_reach(|ctx| Ok(Reach::Rows(max_radius(ctx)?))),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let s = filter_settings(ctx)?;
        let radius = ctx.read::<f32>("radius")?;
        let point = ctx.read::<[f32; 4]>("point")?;
        let normal = ctx.read::<[f32; 4]>("normal")?;
        let albedo = ctx.read::<[f32; 4]>("albedo")?;
        let direction = ctx.read::<[f32; 4]>("direction")?;
        let incident = ctx.read::<[f32; 4]>("incident")?;
        let lv = ctx.read::<[f32; 4]>("lv")?;
        let hv = ctx.read::<[f32; 4]>("hv")?;
        let materials = &ctx.scene.materials;
        let (w, h) = (ctx.width as i32, ctx.height as i32);
        let out = ctx.map_pixels(false, |px, py| {
            let c = (py as i32 * w + px as i32) as usize;
            let r = radius[c];
            let half = window(r, s.max_radius);
            if !(point[c][3] > 0.0) {
                // No surface: no indirect light to filter, and no variance (radius 0 from the next frame).
                return ([0.0, 0.0, 0.0, OWN], [0.0, 0.0, r, 0.0]);
            }
            let (x, n) = (v3(point[c]), v3(normal[c]));
            let mat = &materials[normal[c][3] as usize];
            let (kd, ks, m) = (v3(albedo[c]), mat.specular, mat.phong_exponent);
            let mix = lobe_mixture(kd, ks, m);
            let e = normal_exponent(ks, m);
            let wo = (s.eye - x).normalize_or_zero();
            let kernel = TangentKernel::new(x, n, s.eye, point[c][3], r.max(1.0), s.pixel_angle, s.thickness);
            let (mut sum_w, mut sum) = (0.0f32, Vec3::ZERO);
            let (mut var_w, mut var) = (0.0f32, 0.0f32);
            let mut open_w = 0.0f32;
            for y in (py as i32 - half).max(0)..=(py as i32 + half).min(h - 1) {
                for xx in (px as i32 - half).max(0)..=(px as i32 + half).min(w - 1) {
                    let j = (y * w + xx) as usize;
                    if !(direction[j][3] > 0.0 && point[j][3] > 0.0) {
                        continue;
                    }
                    let wk =
                        if j == c { 1.0 } else { kernel.weight(v3(point[j])) * normal_weight(v3(normal[j]), n, e) };
                    if !(wk > 0.0) {
                        continue;
                    }
                    // Eq. 4.10's term: the neighbour's incident radiance under this pixel's BRDF and pdf.
                    let wi = v3(direction[j]);
                    let cos_i = wi.dot(n);
                    let mut term = Vec3::ZERO;
                    if let (Some(mix), true) = (mix, cos_i > 0.0) {
                        let v = mix.eval(s.lobe, kd, ks, m, n, wo, wi, cos_i);
                        if v.pdf > 0.0 {
                            term = v3(incident[j]) * (v.f * (cos_i / v.pdf));
                        }
                    }
                    sum_w += wk;
                    sum += term * wk;
                    if unoccluded(incident[j][3], kernel.rs) {
                        open_w += wk;
                    }
                    // Sec. 4.3.4: the per-path variance filtered with the same weights.
                    if lv[j][3] >= 2.0 {
                        var_w += wk;
                        var += wk * (hv[j][3] / (lv[j][3] - 1.0));
                    }
                }
            }
            let value = if sum_w > 0.0 { sum / sum_w } else { Vec3::ZERO };
            let sigma2 = if var_w > 0.0 { var / var_w } else { -1.0 };
            let code = if half > 0 { FILTERED } else { OWN };
            ([value.x, value.y, value.z, code], [sigma2, sum_w, r, occlusion_factor(open_w, sum_w)])
        });
        ctx.put("filtered", out.iter().map(|o| o.0).collect::<Vec<_>>())?;
        ctx.put("variance", out.iter().map(|o| o.1).collect::<Vec<_>>())
    }
}

// ---------------------------------------------------------------------------------------------
// radiance_filter.compose
// ---------------------------------------------------------------------------------------------

/// `radiance_filter.compose` (see the module doc).
pub struct Compose;

/// One pixel of the compose pass: `(accumulated, radiance, phase)` from this frame's direct light
/// `sample_lv` (w = finite paths), own indirect estimate `own`, filtered indirect light
/// `filtered`, the accumulated unfiltered image `unfiltered`, the previous accumulation and phase.
/// A frame whose own path was not finite (`sample_lv.w = 0`) adds nothing to the pixel.
pub fn compose_pixel(
    sample_lv: [f32; 4],
    own: [f32; 4],
    filtered: [f32; 4],
    unfiltered: Vec3,
    previous: [f32; 4],
    previous_phase: f32,
    switch: bool,
) -> ([f32; 4], Vec3, f32) {
    let own_only = filtered[3] != FILTERED;
    let indirect = if own_only { v3(own) } else { v3(filtered) };
    let x = v3(sample_lv) + indirect;
    let b = sample_lv[3];
    let mut acc = previous;
    if b > 0.0 {
        let n = previous[3] + b;
        let mean = v3(previous) + (x - v3(previous)) * (b / n);
        acc = [mean.x, mean.y, mean.z, n];
    }
    let now = if own_only { 1.0 } else { 0.0 };
    let phase = if switch { previous_phase.max(now) } else { now };
    let radiance = if switch && phase >= 1.0 { unfiltered } else { v3(acc) };
    (acc, radiance, phase)
}

fn switch_mode(ctx: &KernelCtx<'_>) -> Result<bool, BackendError> {
    match ctx.str_param("correction")? {
        "accumulate" => Ok(false),
        "switch" => Ok(true),
        other => Err(ctx.err(format!("unknown correction `{other}`; use accumulate or switch"))),
    }
}

impl Kernel for Compose {
    fn name(&self) -> &'static str {
        "radiance_filter.compose"
    }
    fn class(&self) -> KernelClass {
        KernelClass::Compose
    }
    fn bindings(&self) -> Vec<Binding> {
        vec![
            Binding::read("sample_lv", Format::Vec4),
            Binding::read("own", Format::Vec4),
            Binding::read("filtered", Format::Vec4),
            Binding::read("lv", Format::Vec4),
            Binding::read("hv", Format::Vec4),
            Binding::read_opt("previous_accumulated", Format::Vec4),
            Binding::read_opt("previous_phase", Format::F32),
            Binding::write("accumulated", Format::Vec4),
            Binding::write("radiance", Format::Vec3),
            Binding::write("unfiltered", Format::Vec3),
            Binding::write("phase", Format::F32),
        ]
    }
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/radiance_filter_compose.wgsl"), |ctx| {
                Ok(Uniforms::new().u32("switch_mode", switch_mode(ctx)? as u32))
            })
            .with_include(
                "radiance_filter_formulas.wgsl",
                include_str!("../../../shaders/radiance_filter_formulas.wgsl"),
            )
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let switch = switch_mode(ctx)?;
        let (slv, own, filtered) =
            (ctx.read::<[f32; 4]>("sample_lv")?, ctx.read::<[f32; 4]>("own")?, ctx.read::<[f32; 4]>("filtered")?);
        let (lv, hv) = (ctx.read::<[f32; 4]>("lv")?, ctx.read::<[f32; 4]>("hv")?);
        let pa = ctx.read_opt::<[f32; 4]>("previous_accumulated")?;
        let pp = ctx.read_opt::<f32>("previous_phase")?;
        let out: Vec<([f32; 4], Vec3, f32, Vec3)> = (0..ctx.pixels())
            .map(|i| {
                let unfiltered = v3(lv[i]) + v3(hv[i]);
                let (acc, radiance, phase) = compose_pixel(
                    slv[i],
                    own[i],
                    filtered[i],
                    unfiltered,
                    pa.map_or([0.0; 4], |p| p[i]),
                    pp.map_or(0.0, |p| p[i]),
                    switch,
                );
                (acc, radiance, phase, unfiltered)
            })
            .collect();
        ctx.put("accumulated", out.iter().map(|o| o.0).collect::<Vec<_>>())?;
        ctx.put("radiance", out.iter().map(|o| o.1.to_array()).collect::<Vec<_>>())?;
        ctx.put("unfiltered", out.iter().map(|o| o.3.to_array()).collect::<Vec<_>>())?;
        ctx.put("phase", out.iter().map(|o| o.2).collect::<Vec<_>>())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn target_variance_keeps_the_running_mean_at_the_threshold() {
        // Eq. 4.13 with equality: ((k−1)/k)² T + T_k/k² = T for T_k = (2k−1)T (eq. 4.14).
        for &t in &[1e-4f32, 0.01, 0.3, 7.0] {
            for k in 1..200u32 {
                let kf = k as f64;
                let tk = f64::from(target_variance(t, k));
                let lhs = ((kf - 1.0) / kf).powi(2) * f64::from(t) + tk / (kf * kf);
                assert!((lhs - f64::from(t)).abs() <= 1e-6 * f64::from(t), "k {k} t {t}: {lhs}");
            }
        }
    }

    #[test]
    fn radius_falls_as_one_over_root_k() {
        let rule = RadiusRule { occlusion: false, t_u: 0.01, warmup: 4, warmup_radius: 8.0, max_radius: 1e9 };
        // Warm-up (eq. 4.15): r_w1 k^-1/2.
        assert_eq!(kernel_radius(&rule, 1, -1.0, 1.0), 8.0);
        assert!((kernel_radius(&rule, 4, 0.5, 1.0) - 4.0).abs() < 1e-6);
        // After it, for a fixed variance: r_k ∝ (2k−1)^-1/2 → k^-1/2 (eq. 4.32's Θ(k^-1/2)).
        for k in [5u32, 10, 100, 1000] {
            let (a, b) = (kernel_radius(&rule, k, 0.5, 1.0), kernel_radius(&rule, 4 * k, 0.5, 1.0));
            let expect = ((8.0 * k as f32 - 1.0) / (2.0 * k as f32 - 1.0)).sqrt();
            assert!((a / b - expect).abs() < 1e-4 * expect, "k {k}: {a}/{b}");
        }
        // The kernel's effective sample count reaches M_k = v/T_k: ¾πr² = v/T_k.
        let (v, k) = (0.8f32, 7u32);
        let r = variance_radius(v, 0.01, k);
        assert!((EPANECHNIKOV_EFFICIENCY * std::f32::consts::PI * r * r - v / target_variance(0.01, k)).abs() < 1e-3);
    }

    #[test]
    fn radius_edge_cases() {
        let rule = RadiusRule { occlusion: false, t_u: 0.01, warmup: 2, warmup_radius: 6.0, max_radius: 16.0 };
        // Unknown variance after warm-up: warm-up radius; zero variance: no filter; black
        // background under noise: the cap; NaN: no filter.
        assert!((kernel_radius(&rule, 9, -1.0, 1.0) - 2.0).abs() < 1e-6);
        assert_eq!(kernel_radius(&rule, 9, 0.0, 1.0), 0.0);
        assert_eq!(kernel_radius(&rule, 9, 0.1, 0.0), 16.0);
        assert_eq!(kernel_radius(&rule, 9, f32::NAN, 1.0), 0.0);
        assert_eq!(kernel_radius(&rule, 9, 1e30, 1.0), 16.0);
    }

    #[test]
    fn epanechnikov_footprint_on_the_tangent_plane() {
        // A floor (n = +y) seen at 60° from the normal: r_S across, r_S / cos 60° = 2 r_S along.
        let n = Vec3::Y;
        let x = Vec3::ZERO;
        let eye = Vec3::new(0.0, 60f32.to_radians().cos(), -60f32.to_radians().sin()) * 10.0;
        let k = TangentKernel::new(x, n, eye, 10.0, 4.0, 0.01, 0.1);
        let rs = 4.0 * 0.01 * 10.0;
        assert!((k.weight(x) - 1.0).abs() < 1e-6);
        // Across (x axis): 0 at r_S, ¾ at r_S/2.
        assert!((k.weight(Vec3::new(0.5 * rs, 0.0, 0.0)) - 0.75).abs() < 1e-4);
        assert_eq!(k.weight(Vec3::new(1.001 * rs, 0.0, 0.0)), 0.0);
        // Along the view direction: twice as far.
        assert!((k.weight(Vec3::new(0.0, 0.0, rs)) - 0.75).abs() < 1e-4);
        assert!(k.weight(Vec3::new(0.0, 0.0, 1.99 * rs)) > 0.0);
        assert_eq!(k.weight(Vec3::new(0.0, 0.0, 2.01 * rs)), 0.0);
        // Off the plane by more than δ = 0.1 r_S: another surface.
        assert_eq!(k.weight(Vec3::new(0.0, 0.11 * rs, 0.0)), 0.0);
        assert!(k.weight(Vec3::new(0.0, 0.09 * rs, 0.0)) > 0.99);
        // Head-on: a circle.
        let k = TangentKernel::new(x, n, Vec3::new(0.0, 10.0, 0.0), 10.0, 4.0, 0.01, 0.1);
        assert!((k.weight(Vec3::new(0.5 * rs, 0.0, 0.0)) - k.weight(Vec3::new(0.0, 0.0, 0.5 * rs))).abs() < 1e-5);
    }

    #[test]
    fn occlusion_factor_is_the_weighted_unoccluded_fraction() {
        assert!(unoccluded(NO_BOUNCE_HIT, 0.1) && unoccluded(0.2, 0.1) && !unoccluded(0.05, 0.1));
        assert_eq!(occlusion_factor(0.0, 0.0), 1.0);
        assert_eq!(occlusion_factor(0.75, 3.0), 0.25);
        assert_eq!(occlusion_factor(3.0000002, 3.0), 1.0);
    }

    #[test]
    fn normal_heuristic() {
        assert_eq!(normal_weight(Vec3::Y, -Vec3::Y, 1.0), 0.0);
        assert!((normal_weight(Vec3::new(0.0, 1.0, 1.0).normalize(), Vec3::Y, 2.0) - 0.5).abs() < 1e-6);
        assert_eq!(normal_exponent(Vec3::ZERO, 50.0), 1.0);
        assert_eq!(normal_exponent(Vec3::splat(0.3), 50.0), 50.0);
    }

    #[test]
    fn compose_accumulates_and_switches() {
        let own = [0.5, 0.5, 0.5, 0.0];
        let filtered = [0.2, 0.2, 0.2, FILTERED];
        // Preview frame: direct + filtered, running mean over frames.
        let (acc, rad, phase) =
            compose_pixel([1.0, 1.0, 1.0, 1.0], own, filtered, Vec3::splat(9.0), [0.0; 4], 0.0, false);
        assert_eq!(acc, [1.2, 1.2, 1.2, 1.0]);
        assert_eq!((rad, phase), (Vec3::splat(1.2), 0.0));
        let (acc, _, _) =
            compose_pixel([2.0, 2.0, 2.0, 1.0], own, [0.0, 0.0, 0.0, OWN], Vec3::splat(9.0), acc, 0.0, false);
        // Own estimate in the correction phase: 2 + 0.5, mean with 1.2.
        assert!((acc[0] - 1.85).abs() < 1e-6 && acc[3] == 2.0);
        // A non-finite path adds nothing.
        let (same, _, _) = compose_pixel([0.0, 0.0, 0.0, 0.0], own, filtered, Vec3::ZERO, acc, 0.0, false);
        assert_eq!(same, acc);
        // Switch: once in the correction phase, the plain accumulation, and it stays there.
        let (_, rad, phase) =
            compose_pixel([1.0, 1.0, 1.0, 1.0], own, [0.0, 0.0, 0.0, OWN], Vec3::splat(9.0), acc, 0.0, true);
        assert_eq!((rad, phase), (Vec3::splat(9.0), 1.0));
        let (_, rad, phase) = compose_pixel([1.0, 1.0, 1.0, 1.0], own, filtered, Vec3::splat(9.0), acc, 1.0, true);
        assert_eq!((rad, phase), (Vec3::splat(9.0), 1.0));
        // A reference's bypassed filter (w = M2 ≥ 0) keeps the own estimate.
        let (acc, _, _) =
            compose_pixel([1.0, 1.0, 1.0, 4.0], own, [0.5, 0.5, 0.5, 0.3], Vec3::ZERO, [0.0; 4], 0.0, false);
        assert_eq!(acc, [1.5, 1.5, 1.5, 4.0]);
    }
}
