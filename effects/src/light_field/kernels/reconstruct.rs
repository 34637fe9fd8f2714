//! `light_field.reconstruct`: eq. 3's reconstruction rays through the splats (see [`super`]); WGSL
//! `shaders/light_field_reconstruct.wgsl`.

use glam::Vec3;
use wedge_backends::kernels::indirect::{path_from_hit, PathParams, PathRays};
use wedge_backends::rng::{substream, PixelRng};
use wedge_backends::{BackendError, Counters, Kernel, KernelCtx, KernelParams, Reach, Uniforms, WgslSource};
use wedge_scene::SceneAt;

use super::{leave, EstimatorParams, RandomStream};
use crate::light_field::formulas::{occlusion, RayShare};
use crate::light_field::node::DEFAULT_RAYS;
use crate::light_field::reconstruct;
use crate::light_field::records::{LightPrimary, Splat, SplatNode};

/// `light_field.reconstruct` (see [`super`]).
pub struct LightFieldReconstruct;

wedge_backends::param_choice! {
    /// `back_faces`: whether a surface a reconstruction ray sees only from behind gives its splats'
    /// radiance (`two_sided`, the paper's Sec. 2.5) or is passed through (`pass`: no input ray saw
    /// that side); `auto` is `two_sided` for ambient occlusion (a surface occludes from either side)
    /// and `pass` for radiance (its value on that side was never measured). Measured in
    /// docs/DESIGN-NOTES.md "Light-field reconstruction".
    pub enum BackFaces { Auto = "auto", TwoSided = "two_sided", Pass = "pass" }
}

wedge_backends::param_choice! {
    /// `gaps`: whether a reconstruction ray that crosses no splat is traced into the scene (`trace`)
    /// or black (`black`, the paper's rule).
    pub enum Gaps { Trace = "trace", Black = "black" }
}

wedge_backends::kernel_params! {
    /// `light_field.reconstruct`'s own parameters (besides [`EstimatorParams`]), declared by the node
    /// and forwarded.
    pub struct ReconstructParams {
        rays: u32 = int(DEFAULT_RAYS, 1, 1 << 14, "reconstruction rays per pixel, N of eq. 3 (paper: 256-512)"),
        back_faces: BackFaces = choice("auto", BackFaces::OPTIONS, "a surface a reconstruction ray sees only from behind: its splats' radiance (two_sided, the paper's Sec. 2.5), or passed through to the next surface (pass: no input ray saw that side, e.g. splats overhanging a convex edge); auto = two_sided for AO, pass for radiance"),
        gaps: Gaps = choice("trace", Gaps::OPTIONS, "a reconstruction ray that crosses no splat: traced into the scene and its hit path-traced like an input ray (trace; where the input rays reached a surface too sparsely to cover it with splats), or black (the paper's rule, which read the open envmap_light 14-23% dark; docs/NODES.md \"Composing effects\")"),
    }
}

impl ReconstructParams {
    /// The pass's settings: these parameters (`rays` checked) and whether back faces are two-sided.
    fn read_checked(ctx: &KernelCtx<'_>, ao: bool) -> Result<(ReconstructParams, bool), BackendError> {
        let p = ReconstructParams::read(ctx)?;
        // At most 2^14: the WGSL loop stays far below a driver's cap on loop iterations (lavapipe: 65,535).
        if !(1..=MAX_RAYS).contains(&p.rays) {
            return Err(ctx.err(format!("`rays` = {} must be between 1 and {MAX_RAYS}", p.rays)));
        }
        let two_sided = match p.back_faces {
            BackFaces::Auto => ao,
            BackFaces::TwoSided => true,
            BackFaces::Pass => false,
        };
        Ok((p, two_sided))
    }
}

wedge_backends::kernel_bindings! {
    /// What a `light_field.reconstruct` pass binds.
    pub struct ReconstructIo / ReconstructData {
        read primary: LightPrimary,
        read splats: Splat,
        read nodes: SplatNode,
        /// What a reference keeps (the filter bypassed); unused here.
        read unfiltered: [f32; 3],
        write radiance: [f32; 3],
    }
}

impl Kernel for LightFieldReconstruct {
    // Class `Sampling`: ray tracing through the splats, its time is the reconstruction rays' (the
    // paper's 189 s of 199), and parity judges it as a ray-tracing pass — a reconstruction ray grazing
    // a splat's rim or a visibility-conflict boundary flips on float round-off as a scene ray grazing
    // an edge does.
    wedge_backends::kernel_signature!(
        name: "light_field.reconstruct",
        class: Sampling,
        bindings: ReconstructIo,
        params: [EstimatorParams, ReconstructParams, RandomStream],
        random: true
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/light_field_reconstruct.wgsl"), |ctx| {
                let (_, p) = EstimatorParams::read_paths(ctx)?;
                let (r, two_sided) = ReconstructParams::read_checked(ctx, p.ao)?;
                let u = Uniforms::new()
                    .u32("rays", r.rays)
                    .u32("primaries", ctx.layers("primary"))
                    .bool("two_sided", two_sided)
                    .bool("trace_gaps", r.gaps == Gaps::Trace)
                    .u32("stream", RandomStream::read(ctx)?.stream);
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
        let ReconstructData { primary, splats, nodes, radiance: out_radiance, .. } = ReconstructIo::read(ctx)?;
        let hits_per_pixel = ctx.layers("primary") as usize;
        let (e, p) = EstimatorParams::read_paths(ctx)?;
        let (ao, max_distance) = (p.ao, e.max_distance);
        let (r, two_sided) = ReconstructParams::read_checked(ctx, ao)?;
        let (rays, trace_gaps) = (r.rays, r.gaps == Gaps::Trace);
        let RandomStream { stream } = RandomStream::read(ctx)?;
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
        out_radiance.put(ctx, out.into_iter().map(|o| o.0.to_array()).collect())
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

/// The random sequence of the reconstruction rays of a pixel's primary hit `j` (its own
/// sub-stream, so each hit's rays are stratified among themselves).
#[inline]
fn hit_rng(seed: u32, pixel: u32, stream: u32, j: u32) -> PixelRng {
    PixelRng::new(seed, pixel, substream(stream, j))
}

/// The most reconstruction rays per pixel.
pub const MAX_RAYS: u32 = 1 << 14;
