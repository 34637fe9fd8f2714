//! The `PixelFilter` node: its ports, parameters and the passes of [`super`]'s module doc.

use wedge_backends::kernels::constant::FillF32Io;
use wedge_backends::KernelParams;
use wedge_graph::{
    BufferId, ExpandCtx, Format, GraphError, NodeKind, ParamDecl, ParamValue, PortDecl, Reference, Stage,
};

use super::kernels::blend::{BlendIo, SpikeParams, WidthIo, WidthParams};
use super::kernels::filter::{BilateralIo, FilterParams, PassParams, SeparableIo};
use super::kernels::sample::{AccumulateIo, RangeIo, SampleIo, SampleParams};
use super::kernels::{ScheduleParams, ThresholdParams};
use crate::camera_paths::TracerParams;

pub struct PixelFilter;

/// Defaults of `docs/EQUATIONS.md` ("Pixel filtering", the thesis's Sec. 3.5.2).
pub const DEFAULT_T: f64 = 0.01;
pub const DEFAULT_SIGMA_S: f64 = 8.0;
pub const DEFAULT_SIGMA_C: f64 = 0.02;
pub const DEFAULT_SIGMA_D: f64 = 2.0;

impl NodeKind for PixelFilter {
    fn kind(&self) -> &'static str {
        "PixelFilter"
    }
    fn doc(&self) -> &'static str {
        "Progressive path tracing with pixel filtering (Schwenk Ch. 3): high-variance paths filtered by a cross-bilateral filter and blended under a perceived-noise threshold"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        vec![]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![
            PortDecl::new("radiance", Format::Vec3, "the blended image L_lv + s L_u + (1 - s) L_f (eq. 3.1)"),
            PortDecl::new("unfiltered", Format::Vec3, "the plain progressive accumulation L_lv + L_u"),
            PortDecl::new("blend", Format::F32, "the blend factor s per pixel (eq. 3.13; 1 = unfiltered)"),
            PortDecl::new("sigma", Format::F32, "the spatial sigma of the filter per pixel (pixels)"),
        ]
    }
    /// Its `accumulate` pass keeps a running mean per pixel of every frame so far, with no
    /// reprojection: over a moving camera that mixes views.
    fn accumulates_frames(&self, _params: &std::collections::BTreeMap<String, ParamValue>) -> Option<&'static str> {
        Some("its progressive path-traced radiance (a running mean of every frame so far)")
    }
    /// A whole path-traced image from its own camera paths: through the camera block's lens where it
    /// has an aperture, over its shutter where it opens over an interval (`TermQuery::camera_view`);
    /// with `split: "direct"` the paths stop at their first vertex.
    fn terms(&self, port: &str, q: &wedge_graph::TermQuery<'_>) -> Option<wedge_graph::Terms> {
        use crate::light_terms::{first_vertex_direct, path_traced};
        let view = q.camera_view();
        let direct_only = q.choice("split") == Some("direct");
        matches!(port, "radiance" | "unfiltered").then(|| {
            if direct_only {
                first_vertex_direct(view)
            } else {
                path_traced(q, view)
            }
        })
    }
    fn params(&self) -> Vec<ParamDecl> {
        [
            SampleParams::decls(),
            ThresholdParams::decls(),
            FilterParams::decls(),
            ScheduleParams::decls(),
            vec![ParamDecl::choice(
                "filter",
                "bilateral",
                &["bilateral", "separable"],
                "brute-force cross-bilateral (eq. 3.6) or the iterated separable approximation (eq. 3.14)",
            )],
            PassParams::decls(),
            vec![ParamDecl::boolean("adaptive", false, "adapt the spatial width per pixel (eqs. 3.15-3.17)")],
            WidthParams::decls(),
            SpikeParams::decls(),
            vec![
                ParamDecl::int("range_samples", 4, 1, 64, "anti-aliasing samples of the range buffer per filter pass"),
                ParamDecl::int("paths", 1, 1, 1 << 20, "paths per pixel per frame"),
            ],
            TracerParams::decls(),
            vec![crate::params::brdf("glossy lobe of k_s, m")],
        ]
        .concat()
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        let p = |ctx: &ExpandCtx<'_>, n: &str| ctx.param(n).clone();
        let (paths, range_samples, sigma_s) = (p(ctx, "paths"), p(ctx, "range_samples"), p(ctx, "sigma_s"));

        // 1–2. This frame's paths and the running statistics.
        let (sample_lv, sample_hv) = (ctx.buffer("sample_lv", Format::Vec4), ctx.buffer("sample_hv", Format::Vec4));
        SampleIo { lv: sample_lv, hv: sample_hv }
            .bind(ctx.pass("sample", "pixel_filter.sample", Stage::Sample))
            .param("count", paths)
            .node_params(SampleParams::names())
            .node_params(TracerParams::names())
            .random()
            .reference(Reference::Sample)
            .finish();
        let (lv, hv) = (ctx.buffer("lv", Format::Vec4), ctx.buffer("hv", Format::Vec4));
        let (previous_lv, previous_hv) = (ctx.previous_frame(lv), ctx.previous_frame(hv));
        accumulate(ctx, [sample_lv, sample_hv], [previous_lv, previous_hv], [lv, hv]);

        // 3. The range buffer.
        let range = ctx.buffer("range", Format::Vec4);
        let previous_range = ctx.previous_frame(range);
        RangeIo { previous: Some(previous_range), range }
            .bind(ctx.pass("range", "pixel_filter.range", Stage::Sample))
            .param("count", range_samples)
            .node_params(ScheduleParams::names())
            .random()
            .reference(Reference::Sample)
            .finish();

        // 4. The spatial width.
        let (filtered, variance) = (ctx.buffer("filtered", Format::Vec4), ctx.buffer("variance", Format::Vec4));
        let (previous_filtered, previous_variance) = (ctx.previous_frame(filtered), ctx.previous_frame(variance));
        let adaptive = matches!(ctx.param("adaptive"), ParamValue::Bool(true));
        let sigma = ctx.buffer("sigma", Format::F32);
        if adaptive {
            let io = WidthIo {
                lv,
                previous_filtered: Some(previous_filtered),
                previous_variance: Some(previous_variance),
                sigma,
            };
            io.bind(ctx.pass("width", "pixel_filter.width", Stage::Bandwidth))
                .node_params(ThresholdParams::names())
                .node_params(WidthParams::names())
                .finish();
        } else {
            FillF32Io { out: sigma }
                .bind(ctx.pass("width", "fill.constant_f32", Stage::Bandwidth))
                .param("value", sigma_s)
                .finish();
        }
        let sigma_in = adaptive.then_some(sigma);

        // 5. The filter: written on filter frames, kept (through the history) on the others.
        let separable = matches!(ctx.param("filter"), ParamValue::Str(f) if f == "separable");
        if !separable {
            let io = BilateralIo {
                range,
                lv,
                hv,
                previous_filtered: Some(previous_filtered),
                previous_variance: Some(previous_variance),
                sigma: sigma_in,
                filtered,
                variance,
            };
            io.bind(ctx.pass("filter", "pixel_filter.bilateral", Stage::Filter))
                .node_params(ScheduleParams::names())
                .node_params(FilterParams::names())
                .reference(Reference::Bypass { input: "hv" })
                .finish();
        } else {
            let iterations = match ctx.param("iterations") {
                ParamValue::Int(n) => *n,
                _ => 3,
            };
            let (mut value, mut var) = (hv, None);
            for k in 1..=iterations {
                for (axis, name) in [(0, "x"), (1, "y")] {
                    let (first, last) = (k == 1 && axis == 0, k == iterations && axis == 1);
                    let local = format!("filter_{k}_{name}");
                    let (out, out_var) = if last {
                        (filtered, variance)
                    } else {
                        (ctx.buffer(&local, Format::Vec4), ctx.buffer(&format!("{local}_variance"), Format::Vec4))
                    };
                    let io = SeparableIo {
                        range,
                        value_in: value,
                        variance_in: var,
                        lv: (first || last).then_some(lv),
                        sigma: sigma_in,
                        previous_filtered: last.then_some(previous_filtered),
                        previous_variance: last.then_some(previous_variance),
                        value_out: out,
                        variance_out: out_var,
                    };
                    io.bind(ctx.pass(&local, "pixel_filter.separable", Stage::Filter))
                        .int("axis", axis)
                        .int("iteration", k)
                        .int("iterations", iterations)
                        .param("first", ParamValue::Bool(first))
                        .param("last", ParamValue::Bool(last))
                        .node_params(ScheduleParams::names())
                        .node_params(FilterParams::names())
                        .reference(Reference::Bypass { input: "value_in" })
                        .finish();
                    (value, var) = (out, Some(out_var));
                }
            }
        }

        // 6. The blend.
        let radiance = ctx.buffer("radiance", Format::Vec3);
        let unfiltered = ctx.buffer("unfiltered", Format::Vec3);
        let blend = ctx.buffer("blend", Format::F32);
        BlendIo { lv, hv, filtered, variance, radiance, unfiltered, blend }
            .bind(ctx.pass("blend", "pixel_filter.blend", Stage::Compose))
            .node_params(ThresholdParams::names())
            .node_params(SpikeParams::names())
            .finish();
        ctx.output("radiance", radiance);
        ctx.output("unfiltered", unfiltered);
        ctx.output("blend", blend);
        ctx.output("sigma", sigma);
        Ok(())
    }
}

/// `pixel_filter.accumulate`: this frame's `(lv, hv)` combined with the previous frame's into `out`
/// (RadianceFilter accumulates its paths the same way).
pub(crate) fn accumulate(ctx: &mut ExpandCtx<'_>, sample: [BufferId; 2], previous: [BufferId; 2], out: [BufferId; 2]) {
    let io = AccumulateIo {
        sample_lv: sample[0],
        sample_hv: sample[1],
        previous_lv: Some(previous[0]),
        previous_hv: Some(previous[1]),
        lv: out[0],
        hv: out[1],
    };
    io.bind(ctx.pass("accumulate", "pixel_filter.accumulate", Stage::Sample)).finish();
}
