//! `Primary`: the per-pixel surface every effect shades — one ray through each pixel centre.

use wedge_backends::kernels::primary::GBufferIo;
use wedge_graph::{ExpandCtx, Format, GraphError, NodeKind, ParamDecl, PortDecl, Stage, TermQuery, Terms, View};

pub struct Primary;

impl NodeKind for Primary {
    fn kind(&self) -> &'static str {
        "Primary"
    }
    fn doc(&self) -> &'static str {
        "G-buffer from one primary ray per pixel centre: position, normal (+ pixel footprint), albedo, emission"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        vec![]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![
            PortDecl::new(
                "position",
                Format::Vec4,
                "world position; w = 1 + object id where a surface is seen, 0 for background",
            ),
            PortDecl::new("normal", Format::Vec4, "unit shading normal; w = projected pixel size d (metres)"),
            PortDecl::new("albedo", Format::Vec3, "diffuse albedo k_d (texture applied)"),
            PortDecl::new("emission", Format::Vec3, "emitted radiance of the visible surface"),
            PortDecl::new("specular", Format::Vec4, "glossy k_s (rgb) and Phong exponent m (w; 0 = no glossy lobe)"),
        ]
    }
    fn params(&self) -> Vec<ParamDecl> {
        vec![]
    }
    /// `emission` is what the pixel-centre rays see directly (the environment where they miss).
    fn terms(&self, port: &str, _q: &TermQuery<'_>) -> Option<Terms> {
        (port == "emission").then(|| crate::light_terms::seen_directly(View::PINHOLE))
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        let position = ctx.buffer("position", Format::Vec4);
        let normal = ctx.buffer("normal", Format::Vec4);
        let albedo = ctx.buffer("albedo", Format::Vec3);
        let emission = ctx.buffer("emission", Format::Vec3);
        let specular = ctx.buffer("specular", Format::Vec4);
        let io = GBufferIo { position, normal, albedo, emission, specular: Some(specular) };
        io.bind(ctx.pass("gbuffer", "primary.gbuffer", Stage::Sample)).finish();
        for (port, id) in [
            ("position", position),
            ("normal", normal),
            ("albedo", albedo),
            ("emission", emission),
            ("specular", specular),
        ] {
            ctx.output(port, id);
        }
        Ok(())
    }
}
