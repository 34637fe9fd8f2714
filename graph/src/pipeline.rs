//! The pipeline file: schema (serde + ron, unknown fields rejected) and source locations.
//!
//! ```ron
//! Pipeline(
//!     scene: "builtin:grids",          // or a scene file path, relative to this file
//!     width: 640, height: 480, seed: 1,
//!     camera: None,                    // or Some((position: (0,3,4), look_at: (0,0,0), up: (0,1,0), vfov_deg: 45))
//!     nodes: [
//!         (name: "primary", kind: "Primary"),
//!         (name: "shadows", kind: "SoftShadows", params: {"mu": 2.0},
//!          inputs: {"position": "primary.position", "normal": "primary.normal"}),
//!         (name: "out", kind: "Output", inputs: {"color": "shadows.radiance"}),
//!     ],
//! )
//! ```

use std::path::PathBuf;

use serde::Deserialize;

use crate::decl::ParamValue;

/// A line/column position in a pipeline file (1-based), for error messages.
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub struct Location {
    pub file: PathBuf,
    pub line: usize,
    pub col: usize,
}

impl std::fmt::Display for Location {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}:{}", self.file.display(), self.line, self.col)
    }
}

#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    pub position: (f32, f32, f32),
    pub look_at: (f32, f32, f32),
    #[serde(default = "default_up")]
    pub up: (f32, f32, f32),
    pub vfov_deg: f32,
    #[serde(default)]
    pub aperture_radius: f32,
    #[serde(default)]
    pub focus_distance: Option<f32>,
}

fn default_up() -> (f32, f32, f32) {
    (0.0, 1.0, 0.0)
}

/// A parameter as written; checked against the node kind's [`crate::ParamDecl`] by the validator.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(untagged)]
pub enum RawParam {
    Bool(bool),
    Int(i64),
    Float(f64),
    Str(String),
}

impl From<&RawParam> for ParamValue {
    fn from(r: &RawParam) -> Self {
        match r {
            RawParam::Bool(b) => ParamValue::Bool(*b),
            RawParam::Int(i) => ParamValue::Int(*i),
            RawParam::Float(f) => ParamValue::Float(*f),
            RawParam::Str(s) => ParamValue::Str(s.clone()),
        }
    }
}

#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct NodeSpec {
    pub name: String,
    pub kind: String,
    /// Written as a map `{"mu": 2.0}`; kept as a list so a name given twice is reported, not lost.
    #[serde(default, deserialize_with = "crate::source_map::map_as_pairs")]
    pub params: Vec<(String, RawParam)>,
    /// Input port → `"<node>.<output port>"`, written as a map; a port given twice (two producers)
    /// is reported, not silently overwritten.
    #[serde(default, deserialize_with = "crate::source_map::map_as_pairs")]
    pub inputs: Vec<(String, String)>,
}

#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Pipeline {
    /// `builtin:<name>` or a path to a scene file (relative to the pipeline file).
    pub scene: String,
    pub width: u32,
    pub height: u32,
    #[serde(default)]
    pub seed: u32,
    #[serde(default)]
    pub camera: Option<CameraSpec>,
    pub nodes: Vec<NodeSpec>,
}
