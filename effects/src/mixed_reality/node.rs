//! `MixedReality`: virtual objects inserted into a photograph of a real scene, with the real
//! scene's environment light, shadows and interreflections in both directions (thesis Ch. 6,
//! Sec. 6.3–6.5, `seeds/000_956e982470d7e5bf.txt`; supplemental `seeds/003_73c0b487982c85a7.txt`,
//! Algorithm 1; `docs/EQUATIONS.md` "Environment", mixed reality 6.1–6.2).
//!
//! The node
//! 1. asks the scene for the captured real world ([`SceneRequest::RealLayer`]: the camera image
//!    `L_cam`, world position and normal maps, the diffuse albedo — files, or a scene `capture`d by
//!    wedge itself) and for the environment map that lit it ([`SceneRequest::Environment`], as the
//!    `Environment` node does); the pipeline's scene holds only the virtual objects;
//! 2. samples both worlds with `mr.sample` (two-mode sampling: BVH rays for the virtual objects,
//!    screen-space rays over the position map for the real ones; `primary` × `per_primary` = 4 × 4 per
//!    pixel as Algorithm 1), giving `E_R^dir, E_R^ind, E_RV^dir, E_RV^ind` at real surfaces, the virtual
//!    surfaces' `E_V^dir, E_V^ind` and texture `k_V`, the mask `M`, and the occluder and indirect hit
//!    distances;
//! 3. sizes the filters with the `Environment` node's own kernels (curvature 6.20, bandwidths 6.13,
//!    6.17, 6.18, times μ) and filters each irradiance with its separable filter (6.21–6.23) — one
//!    bandwidth per pixel for `E_R` and `E_RV`, so where no virtual object changes the light the two
//!    filter to the same value and their ratio is exactly 1;
//! 4. composes eq. 6.2, `L = (1 − M) k_V E_V + M (E_RV / E_R) L_cam` (`mr.composite`).
//!
//! In a sequence (`wedge render --frames`) each frame has the real layer of its own camera (a
//! `capture` per frame, or maps named with `{frame}`: the `wedge` crate's `Session::run_frame`), and with
//! `temporal` every irradiance's y pass joins its previous frame, reprojected (eqs. 6.24–6.26), as the
//! `Environment` node's does (Sec. 6.7).
//!
//! Readings and measurements: `docs/DESIGN-NOTES.md` "Mixed reality"; the sampler's rules:
//! [`super::kernels`], the screen-space tracer's:
//! `wedge_backends::kernels::screen_trace`.

use std::collections::BTreeMap;

use wedge_backends::KernelParams;
use wedge_graph::{
    BufferId, ExpandCtx, Format, GraphError, NodeKind, ParamDecl, ParamValue, PortDecl, Reference, SceneRequest, Stage,
};

use super::kernels::sample::MrParams;
use super::kernels::{irradiance_io, CompositeIo, SampleIo};
use crate::environment::kernels::filter::BandwidthMaxIo;
use crate::environment::kernels::{AdaptiveLookUps, BandwidthIo};
use crate::environment::node::{environment_request, map_params, str_param, PartFilter, NORMAL_DEG};

pub struct MixedReality;

/// The six irradiances `mr.sample` writes (buffer names, in [`SampleIo`]'s order), each with the
/// bandwidth that filters it.
const IRRADIANCES: [(&str, Bandwidth); 6] = [
    ("e_r_dir", Bandwidth::DirectReal),
    ("e_r_ind", Bandwidth::IndirectReal),
    ("e_rv_dir", Bandwidth::DirectReal),
    ("e_rv_ind", Bandwidth::IndirectReal),
    ("e_v_dir", Bandwidth::DirectVirtual),
    ("e_v_ind", Bandwidth::IndirectVirtual),
];

/// Real surfaces are diffuse: their light takes the diffuse bandwidths; virtual ones the larger of
/// the diffuse and the glossy one (the glossy where the surface has a lobe).
#[derive(Clone, Copy, PartialEq)]
enum Bandwidth {
    DirectReal,
    IndirectReal,
    DirectVirtual,
    IndirectVirtual,
}

impl NodeKind for MixedReality {
    fn kind(&self) -> &'static str {
        "MixedReality"
    }
    fn doc(&self) -> &'static str {
        "Virtual objects in a photograph: two-mode sampling, Ch. 6 filtering, differential compositing (thesis Ch. 6)"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        Vec::new()
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![
            PortDecl::new("radiance", Format::Vec3, "the composite (eq. 6.2)"),
            PortDecl::new("unfiltered", Format::Vec3, "the composite of the unfiltered irradiances"),
            PortDecl::new(
                "reconstruction",
                Format::Vec3,
                "k_R·E_R: should match the camera image on real surfaces (a check of the inputs)",
            ),
            PortDecl::new("filter_width", Format::F32, "the direct light's filter width σ (pixels)"),
            PortDecl::new("bandwidth", Format::F32, "the direct light's bandwidth B_x"),
            PortDecl::new("mask", Format::F32, "M, the fraction of the pixel the real world covers"),
            PortDecl::new("screen", Format::Vec4, "screen-space rays per pixel, those that left the image, hits"),
        ]
    }
    /// The composite (eq. 6.2): the real layer, and the virtual objects' direct and one-bounce
    /// environment light, from its own pinhole camera paths.
    fn terms(&self, port: &str, _q: &wedge_graph::TermQuery<'_>) -> Option<wedge_graph::Terms> {
        use wedge_graph::{Term, TermKind, Terms, View};
        let v = View::PINHOLE;
        matches!(port, "radiance" | "unfiltered").then(|| {
            Terms::new()
                .with(Term::new(TermKind::RealLayer, v))
                .with(Term::new(TermKind::DirectEnvironment, v))
                .with(Term::new(TermKind::Indirect, v).detail("1 bounce"))
        })
    }
    fn params(&self) -> Vec<ParamDecl> {
        // The environment that lit the real scene: `map`, `scale`, `rotation_deg` as `Environment`.
        let mut params = map_params().to_vec();
        params.extend([
            ParamDecl::path("camera_image", "", "the photograph L_cam: EXR (linear) or PNG/JPEG (sRGB), relative to the pipeline file"),
            ParamDecl::path("position_map", "", "world position per pixel: EXR, RGB = xyz, A = 1 where a real surface covers the pixel"),
            ParamDecl::path("normal_map", "", "world normal per pixel: EXR, RGB = unit xyz"),
            ParamDecl::path("albedo_map", "", "the real surfaces' diffuse albedo (EXR or PNG); empty = the constant `albedo`"),
            ParamDecl::float("albedo", 0.5, 0.0, 1.0, "grey diffuse albedo of the real surfaces where no albedo_map is given"),
            ParamDecl::path("capture", "", "instead of the maps: a scene (builtin:NAME or a file) wedge renders from the pipeline's camera as the real input"),
            ParamDecl::int("capture_spp", 256, 1, 1 << 16, "with `capture`: samples per pixel of its camera image"),
            ParamDecl::int("primary", 4, 1, 256, "primary samples per pixel (Algorithm 1: 4)"),
            ParamDecl::int("per_primary", 4, 1, 4096, "direct and indirect samples per primary sample (Algorithm 1: 4)"),
            ParamDecl::float("b_e", -1.0, 0.0, 1e4, "B_e in cycles per radian; -1 = the map's 99%-energy bandwidth").or_special(-1.0, "automatic: the map's 99%-energy bandwidth"),
            crate::params::mu(1.0, "μ (an extension): scales every bandwidth; larger = narrower filters"),
            ParamDecl::int("max_radius", 15, 1, 64, "filter half-width in pixels (the thesis's 30 × 30 window)"),
        ]);
        params.extend(MrParams::decls());
        params.extend([
            ParamDecl::boolean("temporal", false, "in a sequence: join each irradiance's previous frame, reprojected, in its y pass (eqs. 6.24-6.26, as Environment)"),
            ParamDecl::int("max_motion", 32, 0, 4096, "with `temporal`: pixels a point may move between frames and keep its history"),
        ]);
        params
    }
    fn scene_requests(&self, params: &BTreeMap<String, ParamValue>) -> Vec<SceneRequest> {
        vec![
            environment_request(params),
            SceneRequest::RealLayer {
                camera_image: str_param(params, "camera_image"),
                position_map: str_param(params, "position_map"),
                normal_map: str_param(params, "normal_map"),
                albedo_map: str_param(params, "albedo_map"),
                albedo: params.get("albedo").and_then(ParamValue::as_f64).unwrap_or(0.5),
                capture: str_param(params, "capture"),
                capture_spp: match params.get("capture_spp") {
                    Some(ParamValue::Int(n)) => *n,
                    _ => 256,
                },
            },
        ]
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        if let Some(f) = ctx.factoring() {
            return Err(GraphError::Expand {
                node: ctx.node().into(),
                message: format!(
                    "cannot render under the factoring node `{}`: the real layer is one still photograph (no lens or shutter \
                     samples; README \"What does not compose\") — render mixed reality in a pipeline without \
                     Defocus or Motion",
                    f.node
                ),
            });
        }
        // The camera block's lens or open shutter (on a moving scene) is refused for the same reason:
        // its pinhole paths would put sharp virtual objects into a photograph the block says is not.
        if !ctx.own_camera().fixed() {
            return Err(GraphError::Expand {
                node: ctx.node().into(),
                message: "cannot render through the `camera:` block's lens or open shutter: the real layer is one \
                          still photograph (no lens or shutter samples; README \"What does not compose\") — set \
                          aperture_radius: 0 and equal shutter times for mixed reality"
                    .into(),
            });
        }
        let int = |name: &str| match ctx.param(name) {
            ParamValue::Int(v) => *v,
            other => unreachable!("`{name}` is declared an integer, found {other}"),
        };
        let (primary, per_primary) = (int("primary"), int("per_primary"));

        // 1. Two-mode sampling (Algorithm 1).
        let e = IRRADIANCES.map(|(n, _)| ctx.buffer(n, Format::Vec3));
        let [texture, position, normal, stats, depth, screen] = [
            ("texture", Format::Vec4),
            ("position", Format::Vec4),
            ("normal", Format::Vec4),
            ("environment", Format::Vec4),
            ("depth", Format::Vec4),
            ("screen", Format::Vec4),
        ]
        .map(|(n, f)| ctx.buffer(n, f));
        let io = irradiance_io!(SampleIo, e, {
            texture, position, normal, environment: stats, depth, screen: Some(screen)
        });
        io.bind(ctx.pass("sample", "mr.sample", Stage::Sample))
            .param("count", ParamValue::Int(primary))
            .param("per_primary", ParamValue::Int(per_primary))
            .param("sampling", ParamValue::Str("stratified".into()))
            .node_params(MrParams::names())
            .random()
            .reference(Reference::Sample)
            .finish();

        // 2. Curvature (6.20) and bandwidths (6.13, 6.17, 6.18): the Environment node's kernels on
        // the sampler's conventions.
        let (curvature, _magnitude) = crate::environment::node::curvature_pass(ctx, position, normal);
        let [direct_diffuse, direct_glossy, indirect_diffuse, indirect_glossy] =
            ["direct_diffuse", "direct_glossy", "indirect_diffuse", "indirect_glossy"]
                .map(|n| ctx.buffer(&format!("bandwidth_{n}"), Format::Vec2));
        let (bandwidth, width) = (ctx.buffer("bandwidth", Format::F32), ctx.buffer("filter_width", Format::F32));
        let io = BandwidthIo {
            direct_diffuse: Some(direct_diffuse),
            direct_glossy: Some(direct_glossy),
            indirect_diffuse: Some(indirect_diffuse),
            indirect_glossy: Some(indirect_glossy),
            bandwidth: Some(bandwidth),
            filter_width: Some(width),
            ..BandwidthIo::inputs(curvature, stats, normal, Some(depth))
        };
        io.bind(ctx.pass("bandwidth", "environment.bandwidth", Stage::Bandwidth))
            .node_params(&["b_e", "mu", "max_radius"])
            .param("adaptive", ParamValue::Str(AdaptiveLookUps::Off.as_str().into()))
            .float("sigma_ref", 1.0)
            .int("max_rays", 1)
            .int("base", primary * per_primary)
            .float("count_mu", 1.0)
            .finish();
        let mut larger = |name: &str, a, b| {
            let out = ctx.buffer(name, Format::Vec2);
            BandwidthMaxIo { a, b, out }.bind(ctx.pass(name, "bandwidth.max", Stage::Bandwidth)).finish();
            out
        };
        let direct_virtual = larger("bandwidth_direct_virtual", direct_diffuse, direct_glossy);
        let indirect_virtual = larger("bandwidth_indirect_virtual", indirect_diffuse, indirect_glossy);

        // 3. The separable filter of each irradiance (6.21–6.23).
        let filter = PartFilter {
            position,
            normal,
            max_radius: ctx.param("max_radius").clone(),
            max_motion: ctx.param("max_motion").clone(),
            normal_cos: ParamValue::Float(NORMAL_DEG.to_radians().cos()),
            // E_R and E_RV take the same history as they take the same filter, so where no virtual
            // object changes the light their ratio stays exactly 1 over a sequence too.
            temporal: ctx.param("temporal").as_bool() == Some(true),
        };
        let filtered: [BufferId; 6] = std::array::from_fn(|k| {
            let ((name, which), id) = (IRRADIANCES[k], e[k]);
            let bw = match which {
                Bandwidth::DirectReal => direct_diffuse,
                Bandwidth::IndirectReal => indirect_diffuse,
                Bandwidth::DirectVirtual => direct_virtual,
                Bandwidth::IndirectVirtual => indirect_virtual,
            };
            filter.apply(ctx, name, id, bw)
        });

        // 4. Differential compositing (6.2), of the filtered and of the raw irradiances.
        // `extra`: the reconstruction and the mask, where wanted.
        let composite = |ctx: &mut ExpandCtx<'_>, name: &str, e: [BufferId; 6], extra: Option<(BufferId, BufferId)>| {
            let out = ctx.buffer(name, Format::Vec3);
            let io = irradiance_io!(CompositeIo, e, {
                texture, out, reconstruction: extra.map(|(r, _)| r), mask: extra.map(|(_, m)| m)
            });
            io.bind(ctx.pass(name, "mr.composite", Stage::Compose)).finish();
            out
        };
        let (reconstruction, mask) = (ctx.buffer("reconstruction", Format::Vec3), ctx.buffer("mask", Format::F32));
        let radiance = composite(ctx, "composite", filtered, Some((reconstruction, mask)));
        let unfiltered = composite(ctx, "composite_unfiltered", e, None);
        ctx.output("radiance", radiance);
        ctx.output("unfiltered", unfiltered);
        ctx.output("reconstruction", reconstruction);
        ctx.output("filter_width", width);
        ctx.output("bandwidth", bandwidth);
        ctx.output("mask", mask);
        ctx.output("screen", screen);
        Ok(())
    }
}
