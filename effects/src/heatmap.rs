//! `Heatmap`: a sink for one per-pixel diagnostic, so a pipeline shows as many filter widths and ray
//! counts as its nodes produce (thesis Fig. 5.8(e–g): the defocus, direct and indirect filter widths
//! and the primary, shadow and indirect counts) without a port per effect on `Output`.
//!
//! Wire exactly one input: `width` (`f32`, a filter width in pixels; 0 = not filtered, masked black),
//! `count` (`u32`, rays or samples per pixel), `value` (any other `f32`) or `motion` (`vec4`: an
//! image-space velocity and a filter along it, as the Motion node's `velocity` port and `motion.rates`
//! write them — drawn as the filter's σ in pixels with a stroke along the velocity every 16 pixels,
//! like the oriented weights of thesis Fig. B.1(f)). `wedge render` writes it
//! next to the image as `<node name>.png` with a colour bar, titled with the node's name (so the name
//! must be a plain file name). Parameters: `scale` (`log`, the default, or `linear`), `unit` (the
//! colour bar's unit; default `px` for a width, `rays` for a count, none for a value) and `mask_zero`
//! (draw values ≤ 0 black as "not applicable"; default true for a width only). Being a sink, it keeps
//! the passes it reads from being culled; a reference drops it like `Output`'s diagnostics (inputs
//! written in the bandwidth or counts stages).
//!
//! The run hands back each sink's kind and parameters with its buffers
//! (`wedge_backends::RunResult::sinks`); [`describe`] turns them into what the image writer draws,
//! so the writer knows no parameter of this node.

use std::collections::BTreeMap;

use wedge_graph::{ExpandCtx, Format, GraphError, NodeKind, ParamDecl, ParamValue, PortDecl};

/// The kind name, as a pipeline writes it and a run reports its sinks.
pub const KIND: &str = "Heatmap";

/// The input ports, each with its colour-bar unit and whether values ≤ 0 are masked by default.
pub const PORTS: [(&str, &str, bool); 4] =
    [("width", "px", true), ("count", "rays", false), ("value", "", false), ("motion", "px", true)];

/// Units a `unit` parameter may name (`none`: no unit drawn). A closed list because pipeline
/// parameters have no free-text kind; the node's name is the free-text title.
pub const UNITS: &[&str] = &["px", "rays", "paths", "samples", "none"];

/// What the image writer draws for one `Heatmap` input.
#[derive(Clone, Debug, PartialEq)]
pub struct HeatmapDesc {
    /// Drawn above the map; the node's name.
    pub title: String,
    /// Drawn with the colour bar's labels; empty for none.
    pub unit: String,
    /// Log scale (else linear).
    pub log: bool,
    /// Values ≤ 0 drawn black, left out of the colour range.
    pub mask_zero: bool,
    /// The input is a `motion` vec4 (`v_x, v_y, Ω, σ`): draw `σ`, with strokes along `v`.
    pub velocity: bool,
}

/// How to draw input `port` of the `Heatmap` node `node` with (validated) parameters `params`;
/// `None` for a port this kind does not have.
pub fn describe(node: &str, params: &BTreeMap<String, ParamValue>, port: &str) -> Option<HeatmapDesc> {
    let &(_, unit, mask) = PORTS.iter().find(|(p, _, _)| *p == port)?;
    let unit = match params.get("unit") {
        Some(ParamValue::Str(u)) if u == "none" => String::new(),
        Some(ParamValue::Str(u)) => u.clone(),
        _ => unit.to_string(),
    };
    let log = !matches!(params.get("scale"), Some(ParamValue::Str(s)) if s == "linear");
    let mask_zero = match params.get("mask_zero") {
        Some(ParamValue::Bool(b)) => *b,
        _ => mask,
    };
    Some(HeatmapDesc { title: node.to_string(), unit, log, mask_zero, velocity: port == "motion" })
}

/// Whether `name` can be a file name in the output directory as it is: ASCII letters, digits, `_`
/// and `-` (validation already refuses dots and blanks; this also refuses `/`, `\` and the like,
/// which would write outside the output directory).
fn plain_file_name(name: &str) -> bool {
    !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

pub struct Heatmap;

impl NodeKind for Heatmap {
    fn kind(&self) -> &'static str {
        KIND
    }
    fn doc(&self) -> &'static str {
        "Sink: one per-pixel filter width, ray count or other value, written as <name>.png with a colour bar"
    }
    fn inputs(&self) -> Vec<PortDecl> {
        vec![
            PortDecl::optional("width", Format::F32, "a filter width in pixels (0 = not filtered)"),
            PortDecl::optional("count", Format::U32, "rays or samples per pixel"),
            PortDecl::optional("value", Format::F32, "any other per-pixel scalar"),
            PortDecl::optional(
                "motion",
                Format::Vec4,
                "a velocity (px per half shutter) and its filter (Ω, σ px): σ with strokes along v",
            ),
        ]
    }
    fn outputs(&self) -> Vec<PortDecl> {
        vec![]
    }
    fn params(&self) -> Vec<ParamDecl> {
        vec![
            ParamDecl::choice("scale", "log", &["log", "linear"], "colour proportional to log(value) or to value"),
            ParamDecl::choice("unit", "px", UNITS, "the colour bar's unit (default: px for width, rays for count)")
                .optional(),
            ParamDecl::boolean("mask_zero", true, "draw values <= 0 black (default: true for width only)").optional(),
        ]
    }
    fn is_sink(&self) -> bool {
        true
    }
    fn expand(&self, ctx: &mut ExpandCtx<'_>) -> Result<(), GraphError> {
        let node = ctx.node();
        let err = |message: String| GraphError::Expand { node: node.into(), message };
        if !plain_file_name(node) {
            return Err(err(format!(
                "a Heatmap is written as `<node name>.png`, so its name may hold only ASCII letters, digits, `_` \
                 and `-`; rename `{node}`, e.g. `width_direct`"
            )));
        }
        let wired: Vec<&str> = PORTS.iter().map(|(p, _, _)| *p).filter(|p| ctx.input(p).is_some()).collect();
        if wired.len() != 1 {
            let which =
                if wired.is_empty() { "none is".to_string() } else { format!("`{}` are", wired.join("` and `")) };
            return Err(err(format!(
                "wire exactly one of `width` (a filter width, f32), `count` (a ray count, u32), `value` (another \
                 f32) and `motion` (a velocity and its filter, vec4); {which} wired"
            )));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(entries: &[(&str, ParamValue)]) -> BTreeMap<String, ParamValue> {
        entries.iter().map(|(k, v)| (k.to_string(), v.clone())).collect()
    }

    #[test]
    fn defaults_follow_the_port_and_parameters_override_them() {
        let none = params(&[("scale", ParamValue::Str("log".into()))]);
        let d = describe("w", &none, "width").unwrap();
        assert_eq!(
            d,
            HeatmapDesc { title: "w".into(), unit: "px".into(), log: true, mask_zero: true, velocity: false }
        );
        assert!(describe("m", &none, "motion").unwrap().velocity);
        let c = describe("n", &none, "count").unwrap();
        assert_eq!((c.unit.as_str(), c.mask_zero), ("rays", false));
        assert_eq!(describe("v", &none, "value").unwrap().unit, "");
        assert_eq!(describe("v", &none, "color"), None);

        let set = params(&[
            ("scale", ParamValue::Str("linear".into())),
            ("unit", ParamValue::Str("samples".into())),
            ("mask_zero", ParamValue::Bool(true)),
        ]);
        let c = describe("n", &set, "count").unwrap();
        assert_eq!(
            c,
            HeatmapDesc { title: "n".into(), unit: "samples".into(), log: false, mask_zero: true, velocity: false }
        );
        let no_unit = params(&[("unit", ParamValue::Str("none".into())), ("mask_zero", ParamValue::Bool(false))]);
        let w = describe("w", &no_unit, "width").unwrap();
        assert_eq!((w.unit.as_str(), w.mask_zero), ("", false));
    }

    #[test]
    fn names_must_be_plain_file_names() {
        for ok in ["width_direct", "rays-2", "N"] {
            assert!(plain_file_name(ok), "{ok}");
        }
        for bad in ["", "/tmp/x", "a/b", "a\\b", "é", "a:b"] {
            assert!(!plain_file_name(bad), "{bad}");
        }
    }
}
