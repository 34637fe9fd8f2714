//! `LightField`: visibility-aware reconstruction of the indirect light field (issue 17; Lehtinen,
//! Aila, Laine, Durand 2012, `seeds/001_2d3ed232e6777e89.txt`; docs/EQUATIONS.md "Light-field
//! reconstruction"). Where `Indirect` blurs each pixel's estimate with an axis-aligned filter, this
//! node keeps every secondary ray as a sample of the incident light field, turns the samples into
//! splats sized by a bandwidth-aware k-NN and shrunk against the input rays, and integrates each
//! pixel's BRDF with many reconstruction rays through that point-sampled scene (eq. 3). Direct
//! light is not included (Sec. 2): pair it with a direct-light node and an `Add`, as `Indirect`.
//!
//! Passes (kernels in [`super::kernels`]):
//! 1. `sample` (random, reference role `Sample`): `spp` camera paths per pixel of one secondary ray
//!    each, kept as per-sample records (a buffer of `spp` layers) with their primary hits, and their
//!    plain Monte Carlo estimate;
//! 2. `splats` (Bandwidth, a host kernel on every backend): k-NN radii (Sec. 2.2), the splat BVH,
//!    consistency shrinking (Sec. 2.3.1);
//! 3. `reconstruct` (Filter, random, bypassed to the plain estimate in references): `rays`
//!    reconstruction rays per pixel (Secs. 2.3.2–2.5); a ray that crosses no splat is traced into the
//!    scene and its hit path-traced (`gaps: "trace"`; the paper's `"black"` read open scenes dark).
//!
//! **Camera.** The node traces its own camera rays through the pixel centres (Sec. 2.1: the input is
//! the renderer's paths, and eq. 3 reconstructs at each of their primary hits). Under a factoring
//! node that samples the lens or the shutter ([`wedge_graph::factoring`]'s camera settings:
//! `aperture_radius`, `focus_distance`, `lens`; `time`) the paths take the same thin lens and each
//! its own lens point and shutter time, and the samples carry them (and the hits' motion vectors):
//! wire `radiance` to the factoring node's `indirect` input (e.g. `Defocus`, `Motion`), which adds it
//! to its other components and filters the sum in screen space. Then every input path has its own
//! primary hit (`primary` holds `spp` layers) and the reconstruction rays are shared among them.
//! Without a factoring node the paths take the pipeline's `camera:` block's lens and shutter
//! (`ExpandCtx::own_camera`; its image then says "through the lens", and adding it to a pinhole image
//! is refused); with neither, the camera ray is the pinhole through the pixel centre at the shutter's
//! centre, traced once per pixel.
//!
//! `mode: "ao"` is the ambient-occlusion variant (Sec. 3.3): the radiance filter is bypassed and a
//! reconstruction ray is occluded where its nearest apparent surface lies within `max_distance`;
//! the image is the occluded fraction, as `Indirect`'s AO mode (bright = occluded).

use wedge_backends::kernels::compose::ModulateIo;
use wedge_backends::kernels::constant::FillU32Io;
use wedge_backends::KernelParams;
use wedge_graph::{ExpandCtx, Format, GraphError, NodeKind, ParamDecl, ParamValue, PortDecl, Reference, Stage};

use super::kernels::reconstruct::{ReconstructIo, ReconstructParams};
use super::kernels::sample::{SampleIo, SampleParams};
use super::kernels::splats::{SplatParams, SplatsIo};
use super::kernels::EstimatorParams;
use super::records::{LIGHT_PRIMARY, LIGHT_SAMPLE, SPLAT, SPLAT_NODE};

pub struct LightField;

/// Paper defaults (Secs. 2.2, 2.5): `k = 12`, `α = 3`; 8 input samples per pixel (Figs. 1, 7, 9).
pub const DEFAULT_SPP: i64 = 8;
pub const DEFAULT_K: i64 = 12;
pub const DEFAULT_ALPHA: f64 = 3.0;
/// A glossy splat's radius cap, in units of its spatial-only k-NN radius (docs/DESIGN-NOTES.md
/// "Light-field reconstruction": measured on `cornell` and `suite_glossy`).
pub const DEFAULT_GLOSSY_CAP: f64 = 4.0;
/// Reconstruction rays per pixel: the paper uses 256–512; 64 keeps a 320×240 preview fast.
pub const DEFAULT_RAYS: i64 = 64;

impl NodeKind for LightField {
    fn kind(&self) -> &'static str {
        "LightField"
    }
    fn doc(&self) -> &'static str {
        "Visibility-aware reconstruction of the indirect light field (Lehtinen et al. 2012): secondary rays as splats, many reconstruction rays per pixel; indirect light or ambient occlusion"
    }
    /// None: the node traces its own camera paths (see the module doc).
    fn inputs(&self) -> Vec<PortDecl> {
        vec![]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![
            PortDecl::new(
                "radiance",
                Format::Vec3,
                "reconstructed indirect light (eq. 3); AO mode: the occluded fraction",
            ),
            PortDecl::new("unfiltered", Format::Vec3, "the plain Monte Carlo estimate of the same input rays"),
            PortDecl::new(
                "splat_radius",
                Format::F32,
                "mean splat radius (world units) of the pixel's input samples, after shrinking",
            ),
            PortDecl::new("rays_per_pixel", Format::U32, "input secondary rays (paths) per pixel"),
        ]
    }
    /// Indirect light or ambient occlusion, through the camera of the pipeline's factoring node
    /// (whose lens and shutter its own camera rays sample).
    fn terms(&self, port: &str, q: &wedge_graph::TermQuery<'_>) -> Option<wedge_graph::Terms> {
        matches!(port, "radiance" | "unfiltered").then(|| crate::light_terms::indirect_or_ao(q, q.own_view(), ""))
    }
    /// The kernels' declarations, in the order the node has always listed them (`wedge view`'s
    /// widgets, messages): `spp`, `rays`, `k`, `alpha`, `glossy_cap`, `angular`, `shrink`,
    /// `back_faces`, `gaps`, then the estimator's and `brdf`.
    fn params(&self) -> Vec<ParamDecl> {
        let (rays, splats) = (ReconstructParams::decls(), SplatParams::decls());
        let spp = "input secondary rays per pixel, each kept as a sample (paper: 1-16)";
        [
            vec![ParamDecl::int("spp", DEFAULT_SPP, 1, 16, spp)],
            rays[..1].to_vec(),
            splats[..3].to_vec(),
            SampleParams::decls(),
            splats[3..].to_vec(),
            rays[1..].to_vec(),
            EstimatorParams::decls(),
            vec![crate::params::brdf("glossy lobe of k_s, m")],
        ]
        .concat()
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        let spp = ctx.param("spp").as_count().unwrap_or(1);
        let camera = ctx.own_camera();

        // 1. The input samples and their primary hits (one per pixel where every path has the same
        // camera ray).
        let samples = ctx.layered_buffer("samples", Format::Struct(&LIGHT_SAMPLE), spp);
        let primary =
            ctx.layered_buffer("primary", Format::Struct(&LIGHT_PRIMARY), if camera.fixed() { 1 } else { spp });
        let estimate = ctx.buffer("estimate", Format::Vec4);
        let mut b = SampleIo { samples, primary, estimate }
            .bind(ctx.pass("sample", "light_field.sample", Stage::Sample))
            .int("count", i64::from(spp))
            .param("sampling", ParamValue::Str("stratified".into()))
            .node_params(EstimatorParams::names())
            .node_params(SampleParams::names());
        for (name, value) in camera.params() {
            b = b.param(name, value);
        }
        b.random().reference(Reference::Sample).finish();
        // The plain estimate's rgb (the Vec4 estimate convention's mean).
        let unfiltered = ctx.buffer("unfiltered", Format::Vec3);
        let io = ModulateIo { value: estimate, albedo: None, emission: None, out: unfiltered };
        io.bind(ctx.pass("unfiltered", "compose.modulate", Stage::Sample)).finish();

        // Input rays per pixel: the constant spp (a diagnostic, like other nodes' ray counts: a
        // reference does not hand it back).
        let rays = ctx.buffer("rays_per_pixel", Format::U32);
        let fill = ctx.pass("rays", "fill.constant", Stage::Bandwidth);
        FillU32Io { out: rays }.bind(fill).int("value", i64::from(spp)).finish();

        // 2. Splats and their tree (a BVH2 over n splats has at most 2n − 1 nodes).
        let splats = ctx.layered_buffer("splats", Format::Struct(&SPLAT), spp);
        let nodes = ctx.layered_buffer("nodes", Format::Struct(&SPLAT_NODE), 2 * spp);
        let splat_radius = ctx.buffer("splat_radius", Format::F32);
        SplatsIo { samples, splats, nodes, splat_radius: Some(splat_radius) }
            .bind(ctx.pass("splats", "light_field.splats", Stage::Bandwidth))
            .node_params(SplatParams::names())
            .finish();

        // 3. Reconstruction rays.
        let radiance = ctx.buffer("radiance", Format::Vec3);
        ReconstructIo { primary, splats, nodes, unfiltered, radiance }
            .bind(ctx.pass("reconstruct", "light_field.reconstruct", Stage::Filter))
            .node_params(EstimatorParams::names())
            .node_params(ReconstructParams::names())
            .random()
            .reference(Reference::Bypass { input: "unfiltered" })
            .finish();

        ctx.output("radiance", radiance);
        ctx.output("unfiltered", unfiltered);
        ctx.output("splat_radius", splat_radius);
        ctx.output("rays_per_pixel", rays);
        Ok(())
    }
}
