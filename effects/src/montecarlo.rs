//! `MonteCarlo`: plain Monte Carlo direct lighting with a fixed sample count and no filtering — a
//! baseline node (`wedge reference` no longer uses it: references are each pipeline's own graph
//! through `wedge_graph::reference`, which gives the same estimator for the shipped pipelines):
//! `sampling: "independent"` is the thesis's "standard Monte Carlo", `"stratified"` (correlated
//! multi-jitter over the light) the stronger baseline for soft shadows.
//!
//! With `bounces > 0` it also path-traces indirect light (the `Indirect` node's estimator,
//! `indirect.sample`, at `spp` hemisphere samples per component, unfiltered); `direct: false` leaves
//! the direct light out (an indirect-only baseline); `mode: "ao"` gives plain Monte Carlo ambient
//! occlusion instead. `bounces: 0, mode: "radiance"` (the default) is the original direct-only node.
//!
//! Its own paths start from the `Primary` G-buffer, a pinhole at the shutter's centre. Where the
//! pipeline's `camera:` block opens a lens or a shutter over an interval (on a moving scene) and no
//! Defocus/Motion node factors the pipeline, a pinhole image would not be the Monte Carlo image of
//! that camera (issue 34 §2): the node then traces `spp` camera paths per pixel through the lens and
//! over the shutter instead, on the one camera-path tracer the progressive nodes sample with
//! (`camera_paths.rs`, kernel `pixel_filter.sample`): next-event estimation at every vertex through
//! the scene's materials (the whole Phong BRDF), the emission and the environment its rays see
//! directly, `bounces` more vertices (`0`: the first vertex's direct light only; `direct: false`: the
//! indirect light alone; `sampling` places the camera rays' pixel, lens and time points, the light
//! points stay independent). `light` ≥ 0 takes that area light's direct light alone at the first
//! vertex (`CameraPaths::one_light`: no emission, environment or background); with `bounces` ≥ 1 the
//! later vertices sample every light, as the pinhole estimator's `indirect.sample` does — the same
//! terms, `direct(area light i) + indirect`. What that tracer does not do — the light-centre form
//! factor, ambient occlusion — is refused there, every such setting at once.

use wedge_backends::kernels::compose::ModulateIo;
use wedge_backends::kernels::direct::DirectIo;
use wedge_backends::kernels::indirect::{ComposeIo, SampleIo};
use wedge_graph::{
    BufferId, ExpandCtx, Format, GraphError, NodeKind, ParamDecl, ParamValue, PortDecl, Reference, Stage, TermQuery,
    View,
};

use crate::pixel_filter::kernels::sample::Split;

pub struct MonteCarlo;

impl NodeKind for MonteCarlo {
    fn kind(&self) -> &'static str {
        "MonteCarlo"
    }
    fn doc(&self) -> &'static str {
        "Unfiltered Monte Carlo direct illumination at a fixed sample count"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        vec![
            PortDecl::new("position", Format::Vec4, "from Primary"),
            PortDecl::new("normal", Format::Vec4, "from Primary"),
            PortDecl::optional("albedo", Format::Vec3, "multiplied after integration; white if absent"),
            PortDecl::optional("emission", Format::Vec3, "added to the result")
                .accepts(crate::light_terms::EMISSION_INPUT),
            PortDecl::optional(
                "specular",
                Format::Vec4,
                "k_s, m from Primary: glossy indirect component (bounces > 0)",
            ),
        ]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![PortDecl::new("radiance", Format::Vec3, "the Monte Carlo estimate")]
    }
    /// Its own paths from the Primary G-buffer (a pinhole): direct light of one or every area light
    /// with the wired `emission`, indirect light of `bounces`, or ambient occlusion. Through the
    /// camera block's lens or shutter (module doc): a path tracer's terms, seen that way.
    fn terms(&self, port: &str, q: &TermQuery<'_>) -> Option<wedge_graph::Terms> {
        use wedge_graph::{Term, TermKind, Terms};
        if port != "radiance" {
            return None;
        }
        if let Some(view) = camera_paths_view(q) {
            // The first vertex: one area light's direct light alone, or next-event estimation of every
            // light with what the path sees there.
            let first = || match one_light(q) {
                Some(i) => Terms::new()
                    .with(Term::new(TermKind::DirectArea, view).detail(crate::light_terms::lobes::PHONG).light(i)),
                None => crate::light_terms::first_vertex_direct(view),
            };
            return Some(match camera_paths_split(q.int("bounces").unwrap_or(0), q.flag("direct")) {
                Split::Direct => first(),
                Split::All => first().with(Term::new(TermKind::Indirect, view).detail(q.bounces("bounces"))),
                _ => crate::light_terms::indirect_or_ao(q, view, ""),
            });
        }
        if q.choice("mode") == Some("ao") {
            return Some(Terms::new().with(Term::new(TermKind::AmbientOcclusion, View::PINHOLE)));
        }
        let bounces = q.int("bounces").unwrap_or(0);
        let direct = q.flag("direct") || bounces == 0;
        let mut t = Terms::new();
        if direct {
            let light = Term::new(TermKind::DirectArea, View::PINHOLE).detail(crate::light_terms::lobes::DIFFUSE);
            t = t
                .with(match one_light(q) {
                    Some(i) => light.light(i),
                    None => light,
                })
                .plus(q.input("emission"));
        }
        if bounces > 0 {
            t = t.plus(Some(&crate::light_terms::indirect_or_ao(q, View::PINHOLE, "")));
        }
        Some(t)
    }
    fn params(&self) -> Vec<ParamDecl> {
        vec![
            ParamDecl::int("spp", 64, 1, 1 << 20, "light samples per pixel (per light)"),
            ParamDecl::choice(
                "sampling",
                "stratified",
                &["stratified", "independent"],
                "light sample placement (through a camera block's lens or shutter: the camera paths' pixel, lens and time points)",
            ),
            ParamDecl::int("light", -1, -1, 1 << 16, "area light index; -1 = every light"),
            crate::params::form_factor("exact", "per-sample geometry term, or the thesis's light-centre approximation"),
            ParamDecl::int(
                "bounces",
                0,
                0,
                64,
                "indirect bounces path-traced with next-event estimation (0 = direct only)",
            ),
            ParamDecl::choice(
                "mode",
                "radiance",
                &["radiance", "ao"],
                "radiance, or ambient occlusion (spp hemisphere rays)",
            ),
            ParamDecl::float("max_distance", 0.0, 0.0, 1e9, "AO: hits farther than this are misses (0 = no limit)"),
            crate::params::brdf("glossy lobe of k_s, m for indirect paths"),
            ParamDecl::boolean("direct", true, "include direct light (false with bounces > 0: indirect only)"),
        ]
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        let position = ctx.required("position")?;
        let normal = ctx.required("normal")?;
        let spp = ctx.param("spp").clone();
        let ao = matches!(ctx.param("mode"), ParamValue::Str(m) if m == "ao");
        let bounces = match ctx.param("bounces") {
            ParamValue::Int(b) => *b,
            _ => 0,
        };
        let direct = !ao && matches!(ctx.param("direct"), ParamValue::Bool(true));
        if !ao && bounces == 0 && !direct {
            return Err(GraphError::Expand {
                node: ctx.node().to_string(),
                message: "`direct: false` with `bounces: 0` samples nothing; set bounces ≥ 1 or direct: true".into(),
            });
        }
        if ctx.factoring().is_none() && !ctx.own_camera().fixed() {
            refuse_what_camera_paths_lack(ctx)?;
            through_the_camera(ctx, spp, bounces, direct);
            return Ok(());
        }
        let (albedo, emission, specular) = (ctx.input("albedo"), ctx.input("emission"), ctx.input("specular"));
        if !ao && bounces == 0 {
            let estimate = ctx.buffer("estimate", Format::Vec4);
            direct_io(position, normal, estimate)
                .bind(ctx.pass("sample", "direct.light", Stage::Sample))
                .param("count", spp)
                .node_params(&["sampling", "light", "form_factor"])
                .random()
                .reference(Reference::Sample)
                .finish();
            let radiance = ctx.buffer("radiance", Format::Vec3);
            let io = ModulateIo { value: estimate, albedo, emission, out: radiance };
            io.bind(ctx.pass("compose", "compose.modulate", Stage::Compose)).finish();
            ctx.output("radiance", radiance);
            return Ok(());
        }
        let estimate = direct.then(|| {
            let estimate = ctx.buffer("estimate", Format::Vec4);
            direct_io(position, normal, estimate)
                .bind(ctx.pass("sample", "direct.light", Stage::Sample))
                .param("count", spp.clone())
                .node_params(&["sampling", "light", "form_factor"])
                .random()
                .reference(Reference::Sample)
                .finish();
            estimate
        });
        let specular = if ao { None } else { specular };
        let diffuse = ctx.buffer("indirect_diffuse", Format::Vec4);
        let glossy = specular.map(|_| ctx.buffer("indirect_glossy", Format::Vec4));
        let io = SampleIo {
            position,
            normal,
            specular,
            rays_diffuse: None,
            rays_glossy: None,
            previous_diffuse: None,
            previous_glossy: None,
            diffuse,
            glossy,
            depth: None,
        };
        io.bind(ctx.pass("sample_indirect", "indirect.sample", Stage::Sample))
            .param("count", spp)
            .param("bounces", ParamValue::Int(bounces.max(1)))
            .node_params(&["sampling", "mode", "max_distance", "brdf"])
            .random()
            .reference(Reference::Sample)
            .finish();
        let radiance = ctx.buffer("radiance", Format::Vec3);
        // Emission is the zero-bounce part of the direct light: left out with it.
        let (albedo, emission) = if ao { (None, None) } else { (albedo, if direct { emission } else { None }) };
        let io = ComposeIo { diffuse, glossy, direct: estimate, albedo, specular, emission, out: radiance };
        io.bind(ctx.pass("compose", "indirect.compose", Stage::Compose)).finish();
        ctx.output("radiance", radiance);
        Ok(())
    }
}

/// The one area light `light` names (`None`: −1, every light).
fn one_light(q: &TermQuery<'_>) -> Option<u32> {
    u32::try_from(q.int("light").unwrap_or(-1)).ok()
}

/// The view of the node's own camera paths where it traces them through the `camera:` block's lens or
/// over its shutter (no factoring node; module doc), else `None` (a pinhole: the G-buffer's paths).
fn camera_paths_view(q: &TermQuery<'_>) -> Option<View> {
    let view = q.camera_view();
    (!q.factored() && view != View::PINHOLE).then_some(view)
}

/// The settings the camera-path tracer has no counterpart for (module doc), each with the value it
/// does take (as RON writes it, `ParamValue`'s `Display`): any other is refused, all at once, before
/// anything runs.
const CAMERA_PATHS_LACK: [(&str, &str, &str); 2] = [
    ("form_factor", "\"exact\"", "its next-event estimation takes the exact geometry term"),
    ("mode", "\"radiance\"", "it traces radiance, not ambient occlusion"),
];

fn refuse_what_camera_paths_lack(ctx: &ExpandCtx<'_>) -> Result<(), GraphError> {
    let lacking: Vec<String> = CAMERA_PATHS_LACK
        .iter()
        .filter(|(name, taken, _)| ctx.param(name).to_string() != *taken)
        .map(|(name, taken, why)| format!("`{name}: {}` ({why}; leave it at {taken})", ctx.param(name)))
        .collect();
    if lacking.is_empty() {
        return Ok(());
    }
    Err(GraphError::Expand {
        node: ctx.node().to_string(),
        message: format!(
            "traces its own camera paths through the camera: block's lens or open shutter (no Defocus or Motion \
             node factors the pipeline), on the path tracer PixelFilter samples with, which cannot honour {} — or \
             give the camera block aperture_radius: 0 and equal shutter times for the pinhole G-buffer estimator",
            lacking.join(", ")
        ),
    })
}

/// The part of its camera paths the node's image is, as `pixel_filter.sample` splits them: `bounces`
/// vertices after the first (`All`, or `Indirect`'s `L_u` without the `direct` light), or the first
/// vertex's direct light (`Direct`, `L_lv`). Its terms and its passes both follow from it.
fn camera_paths_split(bounces: i64, direct: bool) -> Split {
    match (bounces, direct) {
        (0, _) => Split::Direct,
        (_, true) => Split::All,
        (_, false) => Split::Indirect,
    }
}

/// `spp` camera paths per pixel through the camera block's lens and over its shutter, split by
/// [`camera_paths_split`]; the mean of each pixel's finite paths is the image.
fn through_the_camera(ctx: &mut ExpandCtx<'_>, spp: ParamValue, bounces: i64, direct: bool) {
    use crate::pixel_filter::kernels::sample::SampleIo;
    let (lv, hv) = (ctx.buffer("paths_lv", Format::Vec4), ctx.buffer("paths_hv", Format::Vec4));
    let split = camera_paths_split(bounces, direct);
    SampleIo { lv, hv }
        .bind(ctx.pass("sample", "pixel_filter.sample", Stage::Sample))
        .param("count", spp)
        .param("split", ParamValue::Str(split.as_str().into()))
        .param("bounces", ParamValue::Int(bounces.max(1)))
        .node_params(&["brdf", "sampling", "light"])
        .random()
        .reference(Reference::Sample)
        .finish();
    let radiance = ctx.buffer("radiance", Format::Vec3);
    let value = if split == Split::Direct { lv } else { hv };
    ModulateIo { value, albedo: None, emission: None, out: radiance }
        .bind(ctx.pass("compose", "compose.modulate", Stage::Compose))
        .finish();
    ctx.output("radiance", radiance);
}

/// A plain `direct.light` pass: `spp` samples from scratch, no occluder statistics.
fn direct_io(position: BufferId, normal: BufferId, estimate: BufferId) -> DirectIo {
    DirectIo { position, normal, rays_per_pixel: None, previous: None, estimate, occlusion: None }
}
