//! `Heatmap`: a sink for one per-pixel diagnostic, so a pipeline shows as many filter widths and ray
//! counts as its nodes produce (thesis Fig. 5.8(e–g): the defocus, direct and indirect filter widths
//! and the primary, shadow and indirect counts) without a port per effect on `Output`.
//!
//! Wire exactly one input: `width` (`f32`, a filter width in pixels; 0 = not filtered, masked) or
//! `count` (`u32`, rays or samples per pixel). `wedge render` writes it next to the image as
//! `<node name>.png`, log scale with a colour bar, titled with the node's name. Being a sink, it keeps
//! the passes it reads from being culled; a reference drops it like `Output`'s diagnostics (inputs
//! written in the bandwidth or counts stages).

use wedge_graph::{ExpandCtx, Format, GraphError, NodeKind, ParamDecl, PortDecl};

/// The ports the CLI writes as heatmaps, with the unit shown on the colour bar.
pub const PORTS: [(&str, &str); 2] = [("width", "px"), ("count", "rays")];

pub struct Heatmap;

impl NodeKind for Heatmap {
    fn kind(&self) -> &'static str {
        "Heatmap"
    }
    fn doc(&self) -> &'static str {
        "Sink: one per-pixel filter width or ray count, written as <name>.png with a colour bar"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        vec![
            PortDecl::optional("width", Format::F32, "a filter width in pixels (0 = not filtered)"),
            PortDecl::optional("count", Format::U32, "rays or samples per pixel"),
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
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        let wired = PORTS.iter().filter(|(p, _)| ctx.input(p).is_some()).count();
        if wired != 1 {
            return Err(GraphError::Expand {
                node: ctx.node().into(),
                message: format!(
                    "wire exactly one of `width` (a filter width, f32) and `count` (a ray count, u32); {wired} are wired"
                ),
            });
        }
        Ok(())
    }
}
