//! `wedge view --script S.ron`: a list of steps applied at given frames, for tests and demos.
//!
//! A script is a RON list; each step names the frame it acts after (0 = once the first frame is
//! shown) and one or more actions:
//!
//! ```ron
//! [
//!     (frame: 0, screenshot: "out/view/a"),
//!     (frame: 1, output: "unfiltered"),
//!     (frame: 2, set: ("shadows.mu", 4.0)),
//!     (frame: 3, orbit: (0.2, 0.0)),
//!     (frame: 4, screenshot: "out/view/b"),
//! ]
//! ```
//!
//! Errors name the file, line and column the way the pipeline loader's do (`FILE:LINE:COL: what`,
//! then `help:`), so a typo in a step reads like a typo in a pipeline.

use std::path::{Path, PathBuf};

use serde::Deserialize;
use wedge_graph::RawParam;

use crate::WedgeError;

/// One step of a script. Every action is optional; a step applies those it has in the order the
/// fields are listed here (parameters before the camera before the output choice before the
/// screenshot), so a screenshot in the same step sees the other changes' frame only later — put
/// it in a later step.
#[derive(Clone, Debug, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct Step {
    /// The step's place in the file (0-based), for messages: steps are sorted by frame.
    #[serde(skip)]
    pub order: usize,
    /// After which rendered frame (0-based, counted from the window's first frame) the step applies.
    pub frame: u64,
    /// `("NODE.PARAM", value)`: as `--set NODE.PARAM=value`; the value as a pipeline's `params`
    /// write it (`wedge_graph::RawParam`: a number, bool, string or `(r, g, b)`).
    #[serde(default)]
    pub set: Option<(String, RawParam)>,
    /// As `--mu`.
    #[serde(default)]
    pub mu: Option<f64>,
    /// Orbit the camera by (yaw, pitch) radians around its look-at point.
    #[serde(default)]
    pub orbit: Option<(f32, f32)>,
    /// Move the camera towards (> 0) or away from (< 0) its look-at point by this fraction of the distance.
    #[serde(default)]
    pub dolly: Option<f32>,
    /// Move the camera by (right, up, forward) in its own frame, in scene units (the look-at point
    /// moves along: the WASD/QE keys' move).
    #[serde(default)]
    pub fly: Option<(f32, f32, f32)>,
    /// Back to the pipeline's camera.
    #[serde(default)]
    pub reset_camera: Option<bool>,
    /// Load this EXR (of the viewer's size, e.g. `wedge reference`'s) as the error view's reference.
    #[serde(default)]
    pub reference: Option<PathBuf>,
    /// Render the error view's reference in the background at this many samples per pixel (as
    /// `--reference-spp`, for the camera shown now); the frames go on while it renders.
    #[serde(default)]
    pub reference_spp: Option<u32>,
    /// Wait at most this many seconds for the background reference and load it (an error if it is
    /// not done by then): a screenshot in a later step shows the error against it.
    #[serde(default)]
    pub wait_reference: Option<f64>,
    /// Show this output (a name from the output picker: `color`, `unfiltered`, a heatmap's name).
    #[serde(default)]
    pub output: Option<String>,
    /// A/B split: show `output` left of the split and this one right of it, at `split` (0..1).
    #[serde(default)]
    pub compare: Option<String>,
    #[serde(default)]
    pub split: Option<f32>,
    /// How A and B are shown: `"split"` (A/B at the split) or `"side_by_side"`.
    #[serde(default)]
    pub layout: Option<String>,
    /// Write the screenshot (EXR + PNG, as `render` writes its outputs) into this directory.
    #[serde(default)]
    pub screenshot: Option<PathBuf>,
}

impl Step {
    /// Whether the step does anything (an empty step is almost certainly a mistake).
    fn has_action(&self) -> bool {
        let Step {
            order: _,
            frame: _,
            set,
            mu,
            orbit,
            dolly,
            fly,
            reset_camera,
            reference,
            reference_spp,
            wait_reference,
            output,
            compare,
            split,
            layout,
            screenshot,
        } = self;
        set.is_some()
            || mu.is_some()
            || orbit.is_some()
            || dolly.is_some()
            || fly.is_some()
            || reset_camera.is_some()
            || reference.is_some()
            || reference_spp.is_some()
            || wait_reference.is_some()
            || output.is_some()
            || compare.is_some()
            || split.is_some()
            || layout.is_some()
            || screenshot.is_some()
    }
}

/// A parsed script: steps sorted by frame (stable, so steps of one frame keep file order).
#[derive(Clone, Debug, PartialEq)]
pub struct Script {
    pub path: PathBuf,
    pub steps: Vec<Step>,
}

/// Longest script file read (a script is a few dozen lines; this refuses a wrong file early).
const MAX_SCRIPT_BYTES: u64 = 1 << 20;

impl Script {
    /// Read and check `path`.
    pub fn load(path: &Path) -> Result<Script, WedgeError> {
        let io = |e: std::io::Error| WedgeError::Usage(format!("{}: cannot read the script: {e}", path.display()));
        let len = std::fs::metadata(path).map_err(io)?.len();
        if len > MAX_SCRIPT_BYTES {
            return Err(WedgeError::Usage(format!(
                "{}: the script is {len} bytes, more than {MAX_SCRIPT_BYTES}; is it the right file?",
                path.display()
            )));
        }
        Script::parse(path, &std::fs::read_to_string(path).map_err(io)?)
    }

    /// Parse `text` (named `path` in messages).
    pub fn parse(path: &Path, text: &str) -> Result<Script, WedgeError> {
        // Implicit `Some`: a step writes `output: "color"`, not `output: Some("color")`.
        let options = ron::Options::default().with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME);
        let mut steps: Vec<Step> = options.from_str(text).map_err(|e| {
            WedgeError::Usage(format!(
                "{}:{}:{}: {}\n  help: a script is a list of steps such as [(frame: 2, set: (\"shadows.mu\", 4.0)), \
                 (frame: 3, screenshot: \"out/view\")]; a step's fields are frame, set, mu, orbit, dolly, fly, reset_camera, \
                 reference, reference_spp, wait_reference, output, compare, split, layout, screenshot",
                path.display(),
                e.span.start.line,
                e.span.start.col,
                e.code
            ))
        })?;
        for (i, step) in steps.iter_mut().enumerate() {
            step.order = i;
            check_step(path, i, step)?;
        }
        steps.sort_by_key(|s| s.frame);
        Ok(Script { path: path.to_path_buf(), steps })
    }

    /// The frame after which the script is done (the window closes then).
    pub fn last_frame(&self) -> u64 {
        self.steps.last().map_or(0, |s| s.frame)
    }

    /// The steps that apply after frame `frame`.
    pub fn at(&self, frame: u64) -> impl Iterator<Item = &Step> {
        self.steps.iter().filter(move |s| s.frame == frame)
    }
}

/// Checks that need more than the RON schema: a step that does something, values in range.
fn check_step(path: &Path, index: usize, step: &Step) -> Result<(), WedgeError> {
    let blame = |what: String| {
        WedgeError::Usage(format!("{}: step {} (frame {}): {what}", path.display(), index + 1, step.frame))
    };
    if !step.has_action() {
        return Err(blame(
            "the step does nothing; give it an action such as output: \"unfiltered\" or screenshot: \"out/view\""
                .into(),
        ));
    }
    if let Some(split) = step.split.filter(|s| !(0.0..=1.0).contains(s)) {
        return Err(blame(format!("split {split} is outside 0..1 (0 = all B, 1 = all A)")));
    }
    if let Some(layout) = step.layout.as_deref().filter(|l| super::control::Layout::parse(l).is_none()) {
        let names: Vec<&str> = super::control::Layout::NAMES.iter().map(|(n, _)| *n).collect();
        return Err(blame(format!("layout `{layout}` is not one of {}", names.join(", "))));
    }
    if let Some(wait) = step.wait_reference.filter(|w| !(w.is_finite() && (0.0..=3600.0).contains(w))) {
        return Err(blame(format!("wait_reference {wait} must be a number of seconds in 0..3600")));
    }
    if step.reference_spp == Some(0) {
        return Err(blame("reference_spp 0: a reference needs at least 1 sample per pixel".into()));
    }
    if let Some(mu) = step.mu.filter(|m| !(m.is_finite() && *m > 0.0)) {
        return Err(blame(format!("mu {mu} must be a finite number > 0, as for --mu")));
    }
    if let Some((name, _)) =
        step.set.as_ref().filter(|(n, _)| n.split_once('.').is_none_or(|(a, b)| a.is_empty() || b.is_empty()))
    {
        return Err(blame(format!("set names `{name}`; write \"NODE.PARAM\", e.g. (\"shadows.mu\", 4.0)")));
    }
    let finite = |v: Option<f32>| v.is_none_or(f32::is_finite);
    let fly_finite = step.fly.is_none_or(|(x, y, z)| [x, y, z].iter().all(|v| v.is_finite()));
    if !finite(step.orbit.map(|o| o.0)) || !finite(step.orbit.map(|o| o.1)) || !finite(step.dolly) || !fly_finite {
        return Err(blame("orbit, dolly and fly take finite numbers".into()));
    }
    if step.dolly.is_some_and(|d| d >= 1.0) {
        return Err(blame("dolly must be < 1 (1 would put the camera on its look-at point)".into()));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Script, String> {
        Script::parse(Path::new("s.ron"), text).map_err(|e| e.to_string())
    }

    #[test]
    fn parses_steps_and_sorts_them_by_frame() {
        let s = parse(r#"[(frame: 3, screenshot: "out/a"), (frame: 1, set: ("shadows.mu", 2.0)), (frame: 1, output: "unfiltered")]"#)
            .expect("valid");
        assert_eq!(s.steps.iter().map(|s| s.frame).collect::<Vec<_>>(), [1, 1, 3]);
        assert_eq!(s.steps[0].set, Some(("shadows.mu".into(), RawParam::Float(2.0))));
        assert_eq!(s.steps[1].output.as_deref(), Some("unfiltered"));
        assert_eq!(s.last_frame(), 3);
        assert_eq!(s.at(1).count(), 2);
    }

    #[test]
    fn integers_stay_integers() {
        let s = parse(r#"[(frame: 0, set: ("shadows.max_rays", 8))]"#).expect("valid");
        assert_eq!(
            s.steps[0].set.as_ref().map(|(_, v)| wedge_graph::ParamValue::from(v)),
            Some(wedge_graph::ParamValue::Int(8))
        );
    }

    #[test]
    fn an_unknown_field_names_file_line_and_column() {
        let e = parse("[\n  (frame: 0, screenshoot: \"a\"),\n]").unwrap_err();
        assert!(e.starts_with("s.ron:2:"), "{e}");
        assert!(e.contains("screenshoot"), "{e}");
        assert!(e.contains("help:"), "{e}");
    }

    #[test]
    fn a_syntax_error_names_its_position() {
        let e = parse("[(frame: 0, output: \"color\"").unwrap_err();
        assert!(e.starts_with("s.ron:1:"), "{e}");
    }

    #[test]
    fn bad_values_are_refused_with_the_step() {
        for (text, want) in [
            ("[(frame: 2)]", "step 1 (frame 2): the step does nothing"),
            ("[(frame: 0, split: 1.5)]", "split 1.5 is outside"),
            ("[(frame: 0, mu: -1.0)]", "mu -1 must be"),
            ("[(frame: 0, set: (\"mu\", 1.0))]", "write \"NODE.PARAM\""),
            ("[(frame: 0, dolly: 1.0)]", "dolly must be < 1"),
            ("[(frame: 0, layout: \"sbs\")]", "layout `sbs` is not one of split, side_by_side"),
            ("[(frame: -1, output: \"color\")]", "s.ron:1:"),
        ] {
            let e = parse(text).unwrap_err();
            assert!(e.contains(want), "{text}: {e}");
        }
    }
}
