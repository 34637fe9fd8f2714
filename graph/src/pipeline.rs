//! The pipeline file: schema (serde + ron, unknown fields rejected) and source locations.
//!
//! ```ron
//! Pipeline(
//!     scene: "builtin:grids",          // or a scene file path, relative to this file
//!     width: 640, height: 480, seed: 1,
//!     camera: None,                    // or Some((position: (0,3,4), look_at: (0,0,0), up: (0,1,0), vfov_deg: 45))
//!     motion: [],                      // or [(object: "cube", translate: (0.3, 0, 0), rotate_deg: 20)]
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
    /// Shutter open and close times (the scene's time unit, e.g. seconds of a glTF animation); the
    /// interval a scene's animation is sampled over for motion blur. `None`: the scene's own.
    #[serde(default)]
    pub shutter: Option<(f32, f32)>,
}

/// One key of a camera path (`camera_path` in a pipeline): where the camera is at frame `frame`.
/// Between keys position and look-at move linearly; before the first and after the last key the
/// camera stays at that key. The rest of the camera (field of view, lens, shutter) is the pipeline's
/// `camera` block or the scene's.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CameraKey {
    pub frame: u32,
    pub position: (f32, f32, f32),
    pub look_at: (f32, f32, f32),
}

impl CameraKey {
    /// Every rule the key breaks: (field, message, help). Order of keys is checked by the validator.
    pub fn problems(&self) -> Vec<(&'static str, String, String)> {
        let mut out = Vec::new();
        let finite3 = |v: (f32, f32, f32)| v.0.is_finite() && v.1.is_finite() && v.2.is_finite();
        for (field, v) in [("position", self.position), ("look_at", self.look_at)] {
            if !finite3(v) {
                out.push((
                    field,
                    format!("camera key at frame {}: `{field}` {v:?} is not finite", self.frame),
                    "write three ordinary numbers".to_string(),
                ));
            }
        }
        if finite3(self.position) && self.position == self.look_at {
            out.push((
                "look_at",
                format!(
                    "camera key at frame {}: `look_at` equals `position`, so there is no view direction",
                    self.frame
                ),
                "move `look_at` to the point the camera looks at".to_string(),
            ));
        }
        out
    }
}

/// Motion of one scene object over the shutter, given in the pipeline (for scene formats without
/// animation, such as OBJ): a rigid translation and rotation **over the whole shutter, centred on the
/// pose the scene file has** — the object is at `−translate/2` (rotated by `−rotate_deg/2`) when the
/// shutter opens and at `+translate/2` (`+rotate_deg/2`) when it closes, so a render without motion
/// blur (the shutter's centre) shows the file's pose.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MotionSpec {
    /// The object's name in the scene (an OBJ `o`/`g` name, a glTF node or mesh name, a built-in
    /// object's name; `wedge export-scene` and the scene's load message list them).
    pub object: String,
    /// Displacement over the shutter, world units.
    #[serde(default)]
    pub translate: (f32, f32, f32),
    /// Rotation over the shutter about `axis` through `pivot`, degrees (|rotate_deg| < 180: two keys
    /// can only hold the short arc between them).
    #[serde(default)]
    pub rotate_deg: f32,
    #[serde(default = "default_up")]
    pub axis: (f32, f32, f32),
    /// Centre of rotation, world units; default the object's bounding-box centre.
    #[serde(default)]
    pub pivot: Option<(f32, f32, f32)>,
}

impl MotionSpec {
    /// Every rule the entry breaks: (field, message, help).
    pub fn problems(&self) -> Vec<(&'static str, String, String)> {
        let mut out = Vec::new();
        let finite3 = |v: (f32, f32, f32)| v.0.is_finite() && v.1.is_finite() && v.2.is_finite();
        if self.object.trim().is_empty() {
            out.push((
                "object",
                "a motion entry names no object".to_string(),
                "write `object: \"name\"` with a scene object's name".to_string(),
            ));
        }
        if !finite3(self.translate) {
            out.push((
                "translate",
                format!("motion of `{}`: translate {:?} is not finite", self.object, self.translate),
                "write three ordinary numbers (world units)".into(),
            ));
        }
        if !(self.rotate_deg.is_finite() && self.rotate_deg.abs() < 180.0) {
            out.push((
                "rotate_deg",
                format!("motion of `{}`: rotate_deg = {} is not an angle below 180°", self.object, self.rotate_deg),
                "rotations are stored as the poses at shutter open and close, and slerp takes the short arc between \
                 them: keep |rotate_deg| < 180 (a faster spin needs a shorter shutter)"
                    .into(),
            ));
        }
        let a = self.axis;
        if !finite3(a) || (self.rotate_deg != 0.0 && a.0 * a.0 + a.1 * a.1 + a.2 * a.2 == 0.0) {
            out.push((
                "axis",
                format!("motion of `{}`: axis {a:?} is not a direction", self.object),
                "write a non-zero axis, e.g. (0.0, 1.0, 0.0)".into(),
            ));
        }
        if let Some(p) = self.pivot {
            if !finite3(p) {
                out.push((
                    "pivot",
                    format!("motion of `{}`: pivot {p:?} is not finite", self.object),
                    "write a point in world units, or leave `pivot` out".into(),
                ));
            }
        }
        out
    }
}

fn default_up() -> (f32, f32, f32) {
    (0.0, 1.0, 0.0)
}

/// Largest pipeline file accepted, checked before parsing: real pipelines are a few KiB, and ron
/// keeps the whole parse tree in memory (a 50 MB file with 1.2M nodes took 3.4 GB).
pub const MAX_PIPELINE_BYTES: usize = 1 << 20;
/// Most nodes a pipeline may have, checked right after parsing, before validation and expansion.
pub const MAX_NODES: usize = 1024;
/// Most `params` plus `inputs` entries one node may have (real kinds declare fewer than 16).
pub const MAX_NODE_ENTRIES: usize = 256;
/// Longest node name, kind, port or parameter name, reference or string value, in characters.
pub const MAX_NAME_CHARS: usize = 256;
/// Longest `scene` path, in characters (Linux's PATH_MAX).
pub const MAX_SCENE_CHARS: usize = 4096;

/// One violated camera rule: the field to point at, what is wrong, and the fix.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraProblem {
    /// The field of [`CameraSpec`] that is wrong (as written in the file).
    pub field: &'static str,
    pub message: String,
    pub help: String,
}

/// Camera rule 3 ([`CameraSpec::problems`]): the least sine of the angle between `up` and the view.
pub(crate) const MIN_UP_SINE: f64 = 1e-3;

impl CameraSpec {
    /// Rules 1–3 of [`CameraSpec::problems`] (the view: finite points, a view direction, an `up` off
    /// it) for a camera at `pos` looking at `at`, in f64: also what a camera path is checked with
    /// between its keys ([`crate::camera_path`]).
    pub fn view_problems(pos: [f64; 3], at: [f64; 3], up: [f64; 3]) -> Vec<CameraProblem> {
        let mut out = Vec::new();
        let mut bad =
            |field: &'static str, message: String, help: String| out.push(CameraProblem { field, message, help });
        let finite = |a: [f64; 3]| a.iter().all(|x| x.is_finite());
        for (field, value) in [("position", pos), ("look_at", at), ("up", up)] {
            if !finite(value) {
                bad(
                    field,
                    format!("camera `{field}` = {value:?} is not finite"),
                    format!("write three ordinary numbers for `{field}`, e.g. (0.0, 1.0, 4.0)"),
                );
            }
        }
        let dir = [at[0] - pos[0], at[1] - pos[1], at[2] - pos[2]];
        let len = |a: [f64; 3]| (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        let dir_ok = finite(pos) && finite(at) && len(dir) > 0.0 && len(dir).is_finite();
        if finite(pos) && finite(at) && !dir_ok {
            bad(
                "look_at",
                format!(
                    "camera `look_at` {at:?} {} `position`, so there is no view direction",
                    if len(dir) == 0.0 { "equals" } else { "is too far from" }
                ),
                "move `look_at` to the point the camera should look at, away from `position`".into(),
            );
        }
        if finite(up) {
            if len(up) == 0.0 {
                bad(
                    "up",
                    "camera `up` is (0, 0, 0), so the image has no up direction".into(),
                    "set `up` to the world's up direction, usually (0.0, 1.0, 0.0)".into(),
                );
            } else if dir_ok {
                let c =
                    [dir[1] * up[2] - dir[2] * up[1], dir[2] * up[0] - dir[0] * up[2], dir[0] * up[1] - dir[1] * up[0]];
                let sine = len(c) / (len(dir) * len(up));
                if sine < MIN_UP_SINE {
                    bad(
                        "up",
                        format!(
                            "camera `up` {up:?} is parallel to the view direction (look_at - position = {dir:?}), \
                             so the image's up direction is undefined"
                        ),
                        "choose an `up` not along the view direction, e.g. (0.0, 0.0, -1.0) for a camera \
                         looking straight down"
                            .into(),
                    );
                }
            }
        }
        out
    }

    /// Check the camera against the rules that make it render something; every broken rule is
    /// returned. A camera that breaks one renders black (NaN rays) or nonsense without any error.
    ///
    /// The rules (kept identical to `wedge_scene::Camera::validate` for scene-file cameras; the two
    /// crates do not depend on each other, so a change here must be made there too):
    /// 1. `position`, `look_at` and `up` are finite (no NaN or infinity);
    /// 2. `look_at - position` is finite and non-zero (there is a view direction);
    /// 3. `up` is non-zero and not parallel to the view direction: the sine of the angle between
    ///    them is at least 1e-3 (about 0.06°), so the camera frame is well defined;
    /// 4. `vfov_deg` is finite with 0 < `vfov_deg` < 180;
    /// 5. `aperture_radius` is finite and >= 0 (0 is a pinhole);
    /// 6. `focus_distance`, when given, is finite and > 0;
    /// 7. `shutter`, when given, is two finite times with open <= close.
    ///
    /// Arithmetic is in f64 so that large but finite coordinates do not overflow in the checks.
    pub fn problems(&self) -> Vec<CameraProblem> {
        let v = |t: (f32, f32, f32)| [f64::from(t.0), f64::from(t.1), f64::from(t.2)];
        let mut out = Self::view_problems(v(self.position), v(self.look_at), v(self.up));
        let mut bad =
            |field: &'static str, message: String, help: String| out.push(CameraProblem { field, message, help });
        if !(self.vfov_deg.is_finite() && self.vfov_deg > 0.0 && self.vfov_deg < 180.0) {
            bad(
                "vfov_deg",
                format!("camera `vfov_deg` = {} is not a field of view in degrees", self.vfov_deg),
                "set `vfov_deg` to a value with 0 < vfov_deg < 180, e.g. 45.0".into(),
            );
        }
        if !(self.aperture_radius.is_finite() && self.aperture_radius >= 0.0) {
            bad(
                "aperture_radius",
                format!("camera `aperture_radius` = {} is not a lens radius", self.aperture_radius),
                "set `aperture_radius` to 0.0 (pinhole) or a small positive radius in metres".into(),
            );
        }
        if let Some((open, close)) = self.shutter {
            if !(open.is_finite() && close.is_finite() && open <= close) {
                bad(
                    "shutter",
                    format!("camera `shutter` = ({open}, {close}) is not an interval"),
                    "write `shutter: Some((open, close))` with finite times and open <= close (equal: no motion blur)"
                        .into(),
                );
            }
        }
        if let Some(f) = self.focus_distance {
            if !(f.is_finite() && f > 0.0) {
                bad(
                    "focus_distance",
                    format!("camera `focus_distance` = {f} is not a distance"),
                    "write `focus_distance: Some(d)` with d > 0 in metres, or `None` to focus on `look_at`".into(),
                );
            }
        }
        out
    }
}

/// A parameter as written; checked against the node kind's [`crate::ParamDecl`] by the validator.
/// Deserialized by hand (not `untagged`) so that a value of no kind says what a parameter may be,
/// and a list of the wrong length says so, at its position.
#[derive(Clone, Debug, PartialEq)]
pub enum RawParam {
    Bool(bool),
    Int(i64),
    Float(f64),
    Str(String),
    /// `(r, g, b)` or `[x, y, z]`: a [`crate::ParamKind::Vec3`].
    Vec3([f64; 3]),
}

impl<'de> Deserialize<'de> for RawParam {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(RawParamVisitor)
    }
}

struct RawParamVisitor;

impl<'de> serde::de::Visitor<'de> for RawParamVisitor {
    type Value = RawParam;
    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a parameter value: a number, true/false, a \"string\" or three numbers (r, g, b)")
    }
    fn visit_bool<E: serde::de::Error>(self, v: bool) -> Result<RawParam, E> {
        Ok(RawParam::Bool(v))
    }
    fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<RawParam, E> {
        Ok(RawParam::Int(v))
    }
    /// Beyond i64 (`99999999999999999999`): a float, which the declaration then refuses by range.
    fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<RawParam, E> {
        Ok(i64::try_from(v).map_or(RawParam::Float(v as f64), RawParam::Int))
    }
    fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<RawParam, E> {
        Ok(RawParam::Float(v))
    }
    fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<RawParam, E> {
        Ok(RawParam::Str(v.to_string()))
    }
    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<RawParam, A::Error> {
        let mut v = Vec::new();
        while let Some(x) = seq.next_element::<f64>()? {
            v.push(x);
        }
        let n = v.len();
        <[f64; 3]>::try_from(v).map(RawParam::Vec3).map_err(|_| {
            serde::de::Error::custom(format!("a colour or vector parameter takes three numbers (r, g, b), not {n}"))
        })
    }
}

impl From<&RawParam> for ParamValue {
    fn from(r: &RawParam) -> Self {
        match r {
            RawParam::Bool(b) => ParamValue::Bool(*b),
            RawParam::Int(i) => ParamValue::Int(*i),
            RawParam::Float(f) => ParamValue::Float(*f),
            RawParam::Str(s) => ParamValue::Str(s.clone()),
            RawParam::Vec3(v) => ParamValue::Vec3(*v),
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
    /// Motion of scene objects over the shutter, for scenes that carry none ([`MotionSpec`]).
    #[serde(default)]
    pub motion: Vec<MotionSpec>,
    /// Keys of a camera path over the frames of a sequence (`wedge render --frames A..B`), in
    /// increasing frame order ([`CameraKey`]).
    #[serde(default)]
    pub camera_path: Vec<CameraKey>,
    pub nodes: Vec<NodeSpec>,
}
