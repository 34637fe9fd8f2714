//! `Output`: the sink. Whatever is wired to its inputs is what a run hands back (and what the CLI
//! writes as images and heatmaps); passes that feed none of its inputs are culled.

use wedge_graph::{ExpandCtx, Format, GraphError, NodeKind, ParamDecl, PortDecl};

pub struct Output;

impl NodeKind for Output {
    fn kind(&self) -> &'static str {
        "Output"
    }
    fn doc(&self) -> &'static str {
        "Sink: the final image and optional diagnostics written by the CLI"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        vec![
            PortDecl::new("color", Format::Vec3, "final linear radiance"),
            PortDecl::optional("unfiltered", Format::Vec3, "the same estimate before filtering"),
            PortDecl::optional("filter_width", Format::F32, "filter std-dev in pixels (0 = not filtered)"),
            PortDecl::optional("rays_per_pixel", Format::U32, "rays traced per pixel"),
        ]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![]
    }
    fn params(&self) -> Vec<ParamDecl> {
        vec![]
    }
    fn is_sink(&self) -> bool {
        true
    }
    fn expand(&self, _ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        Ok(())
    }
}
