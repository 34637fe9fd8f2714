//! The kernels of the `RadianceFilter` node (see [`super`]): `radiance_filter.sample`, `.radius`,
//! `.filter` and `.compose`, CPU here and WGSL in `shaders/radiance_filter_*.wgsl`, built on
//! [`super::formulas`] (WGSL mirror: `shaders/radiance_filter_formulas.wgsl`).

use glam::Vec3;
use wedge_backends::kernels::hemisphere::Lobe;
use wedge_backends::kernels::indirect::lobe_mixture;
use wedge_backends::kernels::{luminance, v3};
use wedge_backends::{BackendError, Kernel, KernelCtx, KernelParams, Reach, Uniforms, WgslSource};

use super::formulas::*;
use crate::camera_paths::CameraPaths;
use crate::pixel_filter::formulas::Stats;

// ---------------------------------------------------------------------------------------------
// Shared settings
// ---------------------------------------------------------------------------------------------

/// The angle one pixel subtends at the image centre, `2 tan(fov/2) / height`.
fn pixel_angle(ctx: &KernelCtx<'_>) -> f32 {
    2.0 * (ctx.scene.camera.vfov_deg.to_radians() * 0.5).tan() / ctx.full_size().1 as f32
}

/// The radiance sample of a pixel (Sec. 4.3.1, steps 1–2), one `vec4` buffer each (buffer
/// conventions in the module doc): `radiance_filter.sample` writes them, `radiance_filter.filter`
/// reads them, and the node wires them from this one list.
pub const SAMPLE_BUFFERS: [&str; 5] = ["point", "normal", "albedo", "direction", "incident"];

wedge_backends::kernel_params! {
    /// The filter pass's parameters: the prism's thickness, the window cap (declared with the
    /// radius rule, [`RadiusRule`]) and the BRDF the neighbours' radiance is weighed under.
    pub struct FilterParams {
        thickness: f32 = positive(0.2, 1e3, "half-height of the kernel's prism along the normal, in units of its tangent radius (eq. 4.18)"),
        max_radius: u32,
        brdf: Lobe,
    }
}

wedge_backends::param_choice! {
    /// The correction phase (Sec. 4.4.1): keep accumulating, or switch to the plain accumulation.
    pub enum Correction {
        Accumulate = "accumulate",
        Switch = "switch",
    }
}

wedge_backends::kernel_params! {
    /// The compose pass's parameter.
    pub struct ComposeParams {
        correction: Correction = choice(
            "accumulate",
            Correction::OPTIONS,
            "correction phase: keep accumulating (thesis, bias falls as O(1/N)) or switch to the plain accumulation (Sec. 4.4.1)"
        ),
    }
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

impl PixelSamples {
    /// The radiance sample in [`SAMPLE_BUFFERS`]' order.
    fn buffers(&self) -> [[f32; 4]; 5] {
        [self.point, self.normal, self.albedo, self.direction, self.incident]
    }
}

wedge_backends::kernel_bindings! {
    /// What a `radiance_filter.sample` pass binds: the batch's Stats — mean direct light (w = finite
    /// paths), mean own indirect (w = M2) — and path 0's radiance sample ([`SAMPLE_BUFFERS`]).
    pub struct SampleIo / SampleData {
        write lv: [f32; 4],
        write hv: [f32; 4],
        write point: [f32; 4],
        write normal: [f32; 4],
        write albedo: [f32; 4],
        write direction: [f32; 4],
        write incident: [f32; 4],
    }
}

impl Kernel for RadianceSample {
    wedge_backends::kernel_signature!(
        name: "radiance_filter.sample", class: Sampling, bindings: SampleIo, params: [CameraPaths], random: true
    );
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
        let io = SampleIo::read(ctx)?;
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
        io.lv.put(ctx, out.iter().map(|o| o.stats.lv_buffer()).collect())?;
        io.hv.put(ctx, out.iter().map(|o| o.stats.u_buffer()).collect())?;
        let samples = [io.point, io.normal, io.albedo, io.direction, io.incident];
        for (k, sample) in samples.into_iter().enumerate() {
            sample.put(ctx, out.iter().map(|o| o.buffers()[k]).collect())?;
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// radiance_filter.radius
// ---------------------------------------------------------------------------------------------

/// `radiance_filter.radius` (see the module doc): [`kernel_radius`] per pixel for frame
/// `k = frame + 1`, from the previous frame's filtered variance and accumulated image (history).
pub struct Radius;

wedge_backends::kernel_bindings! {
    /// What a `radiance_filter.radius` pass binds: the history — the previous frame's filtered
    /// variance and accumulated image (zeros/unbound in a first frame) — and the radius.
    pub struct RadiusIo / RadiusData {
        read_opt previous_variance: [f32; 4], read_opt previous_accumulated: [f32; 4], write radius: f32,
    }
}

impl Kernel for Radius {
    wedge_backends::kernel_signature!(
        name: "radiance_filter.radius", class: Bandwidth, bindings: RadiusIo, params: [RadiusRule]
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/radiance_filter_radius.wgsl"), |ctx| {
                Ok(RadiusRule::read(ctx)?.uniforms())
            })
            .with_include(
                "radiance_filter_formulas.wgsl",
                include_str!("../../../shaders/radiance_filter_formulas.wgsl"),
            )
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let rule = RadiusRule::read(ctx)?;
        let k = ctx.frame + 1;
        let RadiusData { previous_variance: pv, previous_accumulated: pa, radius } = RadiusIo::read(ctx)?;
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
        radius.put(ctx, out)
    }
}

// ---------------------------------------------------------------------------------------------
// radiance_filter.filter
// ---------------------------------------------------------------------------------------------

/// `radiance_filter.filter` (see the module doc).
pub struct Filter;

/// The filter pass's parameters and what it takes from the camera.
struct FilterSettings {
    p: FilterParams,
    pixel_angle: f32,
    eye: Vec3,
}

fn filter_settings(ctx: &KernelCtx<'_>) -> Result<FilterSettings, BackendError> {
    Ok(FilterSettings {
        p: FilterParams::read(ctx)?,
        pixel_angle: pixel_angle(ctx),
        // The lens centre: the kernel's view direction and the stored vertex's outgoing direction.
        // Under an aperture each path starts elsewhere on the lens, within `aperture_radius` of it;
        // the filter's glossy weight reads the centre's direction (an approximation that fades with
        // the filter as frames accumulate).
        eye: ctx.scene.camera.position,
    })
}

wedge_backends::kernel_bindings! {
    /// What a `radiance_filter.filter` pass binds: the radius, the radiance sample
    /// ([`SampleIo`]'s), the estimates and the filtered value with its variance.
    pub struct FilterIo / FilterData {
        read radius: f32,
        read point: [f32; 4],
        read normal: [f32; 4],
        read albedo: [f32; 4],
        read direction: [f32; 4],
        read incident: [f32; 4],
        /// This frame's own indirect estimate (the sample pass's `hv`): what a reference keeps.
        read own: [f32; 4],
        /// The accumulated statistics (n in lv.w, M2 in hv.w): the per-path variance to filter.
        read lv: [f32; 4],
        read hv: [f32; 4],
        write filtered: [f32; 4],
        write variance: [f32; 4],
    }
}

impl Kernel for Filter {
    wedge_backends::kernel_signature!(
        name: "radiance_filter.filter", class: Filter, bindings: FilterIo, params: [FilterParams]
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/radiance_filter_filter.wgsl"), |ctx| {
                let s = filter_settings(ctx)?;
                Ok(s.p.uniforms().vec3("eye", s.eye.to_array()).f32("pixel_angle", s.pixel_angle))
            })
            .with_include(
                "radiance_filter_formulas.wgsl",
                include_str!("../../../shaders/radiance_filter_formulas.wgsl"),
            )
            .with_scene()
            .with_reach(|ctx| Ok(Reach::Rows(FilterParams::read(ctx)?.max_radius))),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let s = filter_settings(ctx)?;
        let FilterData { radius, point, normal, albedo, direction, incident, lv, hv, filtered, variance, .. } =
            FilterIo::read(ctx)?;
        let materials = &ctx.scene.materials;
        let (w, h) = (ctx.width as i32, ctx.height as i32);
        let out = ctx.map_pixels(false, |px, py| {
            let c = (py as i32 * w + px as i32) as usize;
            let r = radius[c];
            let half = window(r, s.p.max_radius);
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
            let kernel = TangentKernel::new(x, n, s.eye, point[c][3], r.max(1.0), s.pixel_angle, s.p.thickness);
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
                        let v = mix.eval(s.p.brdf, kd, ks, m, n, wo, wi, cos_i);
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
        filtered.put(ctx, out.iter().map(|o| o.0).collect())?;
        variance.put(ctx, out.iter().map(|o| o.1).collect())
    }
}

// ---------------------------------------------------------------------------------------------
// radiance_filter.compose
// ---------------------------------------------------------------------------------------------

/// `radiance_filter.compose` (see the module doc).
pub struct Compose;

fn switch_mode(ctx: &KernelCtx<'_>) -> Result<bool, BackendError> {
    Ok(ComposeParams::read(ctx)?.correction == Correction::Switch)
}

wedge_backends::kernel_bindings! {
    /// What a `radiance_filter.compose` pass binds: this frame's estimates, the filtered value, the
    /// statistics and the history (accumulated image, phase) in; the new history and the images out.
    pub struct ComposeIo / ComposeData {
        read sample_lv: [f32; 4],
        read own: [f32; 4],
        read filtered: [f32; 4],
        read lv: [f32; 4],
        read hv: [f32; 4],
        read_opt previous_accumulated: [f32; 4],
        read_opt previous_phase: f32,
        write accumulated: [f32; 4],
        write radiance: [f32; 3],
        write unfiltered: [f32; 3],
        write phase: f32,
    }
}

impl Kernel for Compose {
    wedge_backends::kernel_signature!(
        name: "radiance_filter.compose", class: Compose, bindings: ComposeIo, params: [ComposeParams]
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/radiance_filter_compose.wgsl"), |ctx| {
                Ok(ComposeParams::read(ctx)?.uniforms())
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
        let io = ComposeIo::read(ctx)?;
        let (slv, own, filtered, lv, hv) = (io.sample_lv, io.own, io.filtered, io.lv, io.hv);
        let (pa, pp) = (io.previous_accumulated, io.previous_phase);
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
        io.accumulated.put(ctx, out.iter().map(|o| o.0).collect())?;
        io.radiance.put(ctx, out.iter().map(|o| o.1.to_array()).collect())?;
        io.unfiltered.put(ctx, out.iter().map(|o| o.3.to_array()).collect())?;
        io.phase.put(ctx, out.iter().map(|o| o.2).collect())
    }
}
