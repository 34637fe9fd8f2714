//! The sampling passes of pixel filtering: `pixel_filter.sample` (this frame's camera paths split
//! into `L_lv` and `L_u`), `pixel_filter.accumulate` (the running statistics) and
//! `pixel_filter.range` (the range buffer, Sec. 3.3.3).

use glam::Vec3;
use wedge_backends::params::AnyLight;
use wedge_backends::rng::PixelRng;
use wedge_backends::{BackendError, Counters, Kernel, KernelCtx, KernelParams, Uniforms, WgslSource};

use super::{schedule, ScheduleParams};
use crate::camera_paths::{camera_uniforms, CameraDraws, CameraPaths, FirstVertex, PathCount};
use crate::pixel_filter::formulas::{range_colour, Stats, MISS_DEPTH};

wedge_backends::param_choice! {
    /// How paths are split into low- and high-variance buffers (Sec. 3.3, Fig. 3.1).
    pub enum Split {
        /// `L_lv` = emission + direct light at the first vertex, `L_u` = the indirect light (the
        /// thesis's usual choice).
        Indirect = "indirect",
        /// `L_u` = light reaching the first (diffuse) vertex through glossy scattering only (paths
        /// `L S+ D E`, `trace_path_split`); the rest in `L_lv`.
        Caustics = "caustics",
        /// Everything in `L_u` (the thesis's Fig. 3.7).
        All = "all",
        /// The direct light only (emission and next-event estimation at the first vertex) in `L_lv`,
        /// the path not continued: nothing to filter (MonteCarlo through a lens, `bounces: 0`).
        Direct = "direct",
    }
}

wedge_backends::kernel_params! {
    /// `pixel_filter.sample`'s own parameter (with [`CameraPaths`]'): the split.
    pub struct SampleParams {
        split: Split = choice("indirect", Split::OPTIONS, "which paths are high-variance and filtered: indirect light, caustic paths (L S+ D E), all, or none (direct: the direct light only, no indirect traced)"),
    }
}

wedge_backends::kernel_params! {
    /// The one area light whose direct light alone the first vertex takes
    /// ([`CameraPaths::one_light`]; absent or −1: every light) — set by MonteCarlo through a lens
    /// (its `light`), not declared by PixelFilter.
    pub struct OneLight {
        light: Option<AnyLight>,
    }
}

/// `pixel_filter.sample` (see the module doc).
pub struct PixelSample;

fn sample_settings(ctx: &KernelCtx<'_>) -> Result<(CameraPaths, SampleParams), BackendError> {
    let s = SampleParams::read(ctx)?;
    let paths = CameraPaths::read(ctx)?;
    let one_light = OneLight::read(ctx)?.light.and_then(|l| l.0);
    Ok((CameraPaths { continues: s.split != Split::Direct, one_light, ..paths }, s))
}

/// One camera path's `(L_lv, L_u)` under `split` (Sec. 3.3, Fig. 3.1).
pub fn split_path(v: &FirstVertex, split: Split) -> (Vec3, Vec3) {
    if v.surface.is_none() {
        return if split == Split::All { (Vec3::ZERO, v.direct) } else { (v.direct, Vec3::ZERO) };
    }
    match split {
        Split::Indirect | Split::Direct => (v.direct, v.indirect),
        Split::Caustics => (v.direct + (v.indirect - v.caustic), v.caustic),
        Split::All => (Vec3::ZERO, v.direct + v.indirect),
    }
}

wedge_backends::kernel_bindings! {
    /// What a `pixel_filter.sample` pass binds.
    pub struct SampleIo / SampleData {
        /// Mean L_lv, w = paths (finite ones) of this pass.
        write lv: [f32; 4],
        /// Mean L_u, w = M2 of Y(L_u) over this pass's paths.
        write hv: [f32; 4],
    }
}

impl Kernel for PixelSample {
    wedge_backends::kernel_signature!(
        name: "pixel_filter.sample", class: Sampling, bindings: SampleIo, params: [CameraPaths, SampleParams, OneLight], random: true
    );
    /// WGSL mirror: `shaders/pixel_filter_sample.wgsl` (with the shared `indirect_path.wgsl`).
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/pixel_filter_sample.wgsl"), |ctx| {
                let (paths, s) = sample_settings(ctx)?;
                Ok(paths.uniforms(s.uniforms(), ctx))
            })
            .with_include("pixel_filter_formulas.wgsl", include_str!("../../../../shaders/pixel_filter_formulas.wgsl"))
            .with_scene()
            .per_pixel()
            .chunked(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let (paths, s) = sample_settings(ctx)?;
        let io = SampleIo::read(ctx)?;
        let out: Vec<Stats> = paths.run(ctx, |st: &mut Stats, _, v| {
            let (lv, hv) = split_path(v, s.split);
            let finite = Vec3::is_finite(lv) && Vec3::is_finite(hv);
            if finite {
                *st = Stats::combine(*st, Stats::one(lv, hv));
            }
            finite
        });
        io.lv.put(ctx, out.iter().map(Stats::lv_buffer).collect())?;
        io.hv.put(ctx, out.iter().map(Stats::u_buffer).collect())
    }
}

// ---------------------------------------------------------------------------------------------
// pixel_filter.accumulate
// ---------------------------------------------------------------------------------------------

/// `pixel_filter.accumulate`: `(lv, hv) = combine(previous, sample)` per pixel ([`Stats::combine`]).
pub struct Accumulate;

wedge_backends::kernel_bindings! {
    /// What a `pixel_filter.accumulate` pass binds.
    pub struct AccumulateIo / AccumulateData {
        read sample_lv: [f32; 4],
        read sample_hv: [f32; 4],
        /// The previous frame's accumulation (history; zeros in a first frame).
        read_opt previous_lv: [f32; 4],
        read_opt previous_hv: [f32; 4],
        write lv: [f32; 4],
        write hv: [f32; 4],
    }
}

impl Kernel for Accumulate {
    wedge_backends::kernel_signature!(name: "pixel_filter.accumulate", class: Compose, bindings: AccumulateIo);
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/pixel_filter_accumulate.wgsl"), |_| Ok(Uniforms::new()))
                .with_include(
                    "pixel_filter_formulas.wgsl",
                    include_str!("../../../../shaders/pixel_filter_formulas.wgsl"),
                )
                .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let AccumulateData { sample_lv: slv, sample_hv: shv, previous_lv: plv, previous_hv: phv, lv, hv } =
            AccumulateIo::read(ctx)?;
        let out: Vec<Stats> = (0..ctx.pixels())
            .map(|i| {
                let prev = match (plv, phv) {
                    (Some(a), Some(b)) => Stats::from_buffers(a[i], b[i]),
                    _ => Stats::default(),
                };
                Stats::combine(prev, Stats::from_buffers(slv[i], shv[i]))
            })
            .collect();
        lv.put(ctx, out.iter().map(Stats::lv_buffer).collect())?;
        hv.put(ctx, out.iter().map(Stats::u_buffer).collect())
    }
}

// ---------------------------------------------------------------------------------------------
// pixel_filter.range
// ---------------------------------------------------------------------------------------------

/// `pixel_filter.range` (see the module doc).
pub struct RangeBuffer;

wedge_backends::kernel_bindings! {
    /// What a `pixel_filter.range` pass binds.
    pub struct RangeIo / RangeData {
        /// The range buffer so far (history; zeros in a first frame).
        read_opt previous: [f32; 4],
        /// rgb: mean colour (range_colour) over the filter passes' samples; w: nearest depth.
        write range: [f32; 4],
    }
}

impl Kernel for RangeBuffer {
    wedge_backends::kernel_signature!(
        name: "pixel_filter.range", class: Sampling, bindings: RangeIo, params: [PathCount, ScheduleParams], random: true
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/pixel_filter_range.wgsl"), |ctx| {
                let (update, pass) = schedule(ctx)?;
                let cam = &ctx.scene.camera;
                let u = camera_uniforms(PathCount::read(ctx)?.uniforms(), cam, CameraDraws::jittered(cam, 0));
                Ok(u.u32("update", update as u32).f32("pass_index", pass.max(1) as f32))
            })
            .with_include("pixel_filter_formulas.wgsl", include_str!("../../../../shaders/pixel_filter_formulas.wgsl"))
            .with_scene()
            .per_pixel(),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let (update, pass) = schedule(ctx)?;
        let PathCount { count, stream } = PathCount::read(ctx)?;
        let RangeData { previous, range } = RangeIo::read(ctx)?;
        if !update {
            let out = previous.map_or_else(|| vec![[0.0; 4]; ctx.pixels()], |p| p.to_vec());
            return range.put(ctx, out);
        }
        let cam = ctx.scene.camera;
        // The full image's pixel and size (a tile's window is part of it).
        let (seed, width, window) = (ctx.seed, ctx.width, ctx.window);
        let k = pass.max(1) as f32;
        let draws = CameraDraws::jittered(&cam, 0);
        let out = ctx.map_pixels(false, |px, py| {
            let rng = PixelRng::new(seed, window.pixel_id(px, py), stream);
            let (mut sum, mut depth) = (Vec3::ZERO, MISS_DEPTH);
            for s in 0..count {
                let (ray, t) = draws.ray(&cam, &rng, s, window.global_xy(px, py), window.full_size());
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
        range.put(ctx, out)
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
