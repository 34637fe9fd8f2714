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

use wedge_backends::kernels::compose::ModulateIo;
use wedge_backends::kernels::direct::DirectIo;
use wedge_backends::kernels::indirect::{ComposeIo, SampleIo};
use wedge_graph::{
    BufferId, ExpandCtx, Format, GraphError, NodeKind, ParamDecl, ParamValue, PortDecl, Reference, Stage,
};

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
    /// with the wired `emission`, indirect light of `bounces`, or ambient occlusion.
    fn terms(&self, port: &str, q: &wedge_graph::TermQuery<'_>) -> Option<wedge_graph::Terms> {
        use wedge_graph::{Term, TermKind, Terms, View};
        if port != "radiance" {
            return None;
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
                .with(match u32::try_from(q.int("light").unwrap_or(-1)) {
                    Ok(i) => light.light(i),
                    Err(_) => light,
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
            ParamDecl::choice("sampling", "stratified", &["stratified", "independent"], "light sample placement"),
            ParamDecl::int("light", -1, -1, 1 << 16, "area light index; -1 = every light"),
            ParamDecl::choice(
                "form_factor",
                "exact",
                &["exact", "light_centre"],
                "per-sample geometry term, or the thesis's light-centre approximation",
            ),
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
        let (albedo, emission, specular) = (ctx.input("albedo"), ctx.input("emission"), ctx.input("specular"));
        if !ao && bounces == 0 {
            if !direct {
                return Err(GraphError::Expand {
                    node: ctx.node().to_string(),
                    message: "`direct: false` with `bounces: 0` samples nothing; set bounces ≥ 1 or direct: true"
                        .into(),
                });
            }
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

/// A plain `direct.light` pass: `spp` samples from scratch, no occluder statistics.
fn direct_io(position: BufferId, normal: BufferId, estimate: BufferId) -> DirectIo {
    DirectIo { position, normal, rays_per_pixel: None, previous: None, estimate, occlusion: None }
}
