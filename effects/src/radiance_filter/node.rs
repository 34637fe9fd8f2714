//! The `RadianceFilter` node: its ports, parameters and the passes of [`super`]'s module doc.

use wedge_backends::KernelParams;
use wedge_graph::{ExpandCtx, Format, GraphError, NodeKind, ParamDecl, PortDecl, Reference, Stage};

use super::formulas::RadiusRule;
use super::kernels::{ComposeIo, ComposeParams, FilterIo, FilterParams, RadiusIo, SampleIo, SAMPLE_BUFFERS};
use crate::camera_paths::TracerParams;

pub struct RadianceFilter;

/// Defaults (readings in docs/DESIGN-NOTES.md "Radiance filtering"): the same perceived-variance
/// threshold as `PixelFilter`'s `t` (Sec. 3.5.2), the thesis's 4–8 warm-up frames (Sec. 4.3.4).
pub const DEFAULT_T_U: f64 = 0.01;
pub const DEFAULT_WARMUP: i64 = 4;
pub const DEFAULT_WARMUP_RADIUS: f64 = 8.0;
pub const DEFAULT_MAX_RADIUS: i64 = 16;

impl NodeKind for RadianceFilter {
    fn kind(&self) -> &'static str {
        "RadianceFilter"
    }
    fn doc(&self) -> &'static str {
        "Progressive path tracing with radiance filtering (Schwenk Ch. 4): neighbours' incident radiance re-used under each pixel's BRDF, kernels shrinking to keep a target variance"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        vec![]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![
            PortDecl::new(
                "radiance",
                Format::Vec3,
                "the accumulated image: direct + filtered indirect light (eqs. 4.10, 4.13)",
            ),
            PortDecl::new("unfiltered", Format::Vec3, "the plain progressive accumulation (path tracing)"),
            PortDecl::new("radius", Format::F32, "the image-space kernel radius of this frame (pixels)"),
            PortDecl::new(
                "phase",
                Format::F32,
                "1 where the pixel used only its own sample (correction phase), else 0",
            ),
        ]
    }
    /// A whole path-traced image from its own camera paths: through the camera block's lens where it
    /// has an aperture, over its shutter where it opens over an interval (`TermQuery::camera_view`).
    fn terms(&self, port: &str, q: &wedge_graph::TermQuery<'_>) -> Option<wedge_graph::Terms> {
        matches!(port, "radiance" | "unfiltered").then(|| crate::light_terms::path_traced(q, q.camera_view()))
    }
    fn params(&self) -> Vec<ParamDecl> {
        [
            RadiusRule::decls(),
            FilterParams::decls(),
            ComposeParams::decls(),
            TracerParams::decls(),
            vec![crate::params::brdf("glossy lobe of k_s, m")],
        ]
        .concat()
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        // 1–2. This frame's paths and radiance samples; the running statistics.
        let sample_lv = ctx.buffer("sample_lv", Format::Vec4);
        let own = ctx.buffer("own", Format::Vec4);
        let [point, normal, albedo, direction, incident] = SAMPLE_BUFFERS.map(|n| ctx.buffer(n, Format::Vec4));
        SampleIo { lv: sample_lv, hv: own, point, normal, albedo, direction, incident }
            .bind(ctx.pass("sample", "radiance_filter.sample", Stage::Sample))
            .int("count", 1)
            .node_params(TracerParams::names())
            .random()
            .reference(Reference::Sample)
            .finish();
        let (lv, hv) = (ctx.buffer("lv", Format::Vec4), ctx.buffer("hv", Format::Vec4));
        let (previous_lv, previous_hv) = (ctx.previous_frame(lv), ctx.previous_frame(hv));
        crate::pixel_filter::node::accumulate(ctx, [sample_lv, own], [previous_lv, previous_hv], [lv, hv]);

        // 3. The radius, from the previous frame's filtered variance and image.
        let (variance, accumulated) = (ctx.buffer("variance", Format::Vec4), ctx.buffer("accumulated", Format::Vec4));
        let (previous_variance, previous_accumulated) = (ctx.previous_frame(variance), ctx.previous_frame(accumulated));
        let radius = ctx.buffer("radius", Format::F32);
        let io = RadiusIo {
            previous_variance: Some(previous_variance),
            previous_accumulated: Some(previous_accumulated),
            radius,
        };
        io.bind(ctx.pass("radius", "radiance_filter.radius", Stage::Bandwidth))
            .node_params(RadiusRule::names())
            .finish();

        // 4. The filter.
        let filtered = ctx.buffer("filtered", Format::Vec4);
        FilterIo { radius, point, normal, albedo, direction, incident, own, lv, hv, filtered, variance }
            .bind(ctx.pass("filter", "radiance_filter.filter", Stage::Filter))
            .node_params(FilterParams::names())
            .reference(Reference::Bypass { input: "own" })
            .finish();

        // 5. The image.
        let radiance = ctx.buffer("radiance", Format::Vec3);
        let unfiltered = ctx.buffer("unfiltered", Format::Vec3);
        let phase = ctx.buffer("phase", Format::F32);
        let previous_phase = ctx.previous_frame(phase);
        let io = ComposeIo {
            sample_lv,
            own,
            filtered,
            lv,
            hv,
            previous_accumulated: Some(previous_accumulated),
            previous_phase: Some(previous_phase),
            accumulated,
            radiance,
            unfiltered,
            phase,
        };
        io.bind(ctx.pass("compose", "radiance_filter.compose", Stage::Compose))
            .node_params(ComposeParams::names())
            .finish();
        ctx.output("radiance", radiance);
        ctx.output("unfiltered", unfiltered);
        ctx.output("radius", radius);
        ctx.output("phase", phase);
        Ok(())
    }
}
