//! `MonteCarlo`: plain Monte Carlo direct lighting with a fixed sample count and no filtering — the
//! reference renderer (`wedge reference`) and the baselines every effect is measured against:
//! `sampling: "independent"` is the thesis's "standard Monte Carlo", `"stratified"` (correlated
//! multi-jitter over the light) the stronger baseline for soft shadows.

use wedge_graph::{ExpandCtx, Format, GraphError, NodeKind, ParamDecl, PortDecl};

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
            PortDecl::optional("emission", Format::Vec3, "added to the result"),
        ]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![PortDecl::new("radiance", Format::Vec3, "the Monte Carlo estimate")]
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
        ]
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        let position = ctx.required("position")?;
        let normal = ctx.required("normal")?;
        let spp = ctx.param("spp").clone();
        let estimate = ctx.buffer("estimate", Format::Vec4);
        ctx.pass("sample", "direct.light")
            .read("position", position)
            .read("normal", normal)
            .write("estimate", estimate)
            .param("count", spp)
            .node_params(&["sampling", "light", "form_factor"])
            .int("stream", 0)
            .finish();
        let radiance = ctx.buffer("radiance", Format::Vec3);
        let (albedo, emission) = (ctx.input("albedo"), ctx.input("emission"));
        ctx.pass("compose", "compose.modulate")
            .read("value", estimate)
            .read_opt("albedo", albedo)
            .read_opt("emission", emission)
            .write("out", radiance)
            .finish();
        ctx.output("radiance", radiance);
        Ok(())
    }
}
