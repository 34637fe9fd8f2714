//! What the user (or a script step) can do, as one list of actions applied in one place: the
//! widgets and keys of the window and the steps of `--script` go through [`apply`], so a scripted
//! run exercises the same code as a person at the window.

use std::path::PathBuf;

use wedge_graph::ParamValue;

use super::camera::{dolly, orbit};
use super::model::{Lens, Model};
use super::outputs::{self, Picture};
use super::script::Step;
use crate::WedgeError;

/// What is shown: output A, optionally output B right of a split at `split` (0..1 of the width),
/// and the exposure images are scaled by before the sRGB curve.
#[derive(Clone, Debug, PartialEq)]
pub struct Display {
    pub output: String,
    pub compare: Option<String>,
    pub split: f32,
    pub exposure: f32,
}

impl Default for Display {
    fn default() -> Self {
        Display { output: "color".into(), compare: None, split: 0.5, exposure: 1.0 }
    }
}

impl Display {
    /// The picture of output A, or of A left of the split and B right of it when both are images of
    /// one size. `None` before the first frame or when output A does not exist.
    pub fn picture(&self, model: &Model) -> Option<Picture> {
        let run = model.mean()?;
        let (w, h) = (model.session.width, model.session.height);
        let a = outputs::picture(run, &self.output, w, h, self.exposure)?;
        let b = self.compare.as_deref().and_then(|b| outputs::picture(run, b, w, h, self.exposure));
        Some(match b {
            Some(b) if (b.width, b.height) == (a.width, a.height) => split(&a, &b, self.split),
            _ => a,
        })
    }
}

/// Columns left of `at` × width from `a`, the rest from `b` (same size).
fn split(a: &Picture, b: &Picture, at: f32) -> Picture {
    let cut = ((at.clamp(0.0, 1.0) * a.width as f32).round() as usize).min(a.width as usize) * 3;
    let row = a.width as usize * 3;
    let mut rgb = b.rgb.clone();
    for (dst, src) in rgb.chunks_mut(row).zip(a.rgb.chunks(row)) {
        dst[..cut].copy_from_slice(&src[..cut]);
    }
    Picture { rgb, ..a.clone() }
}

#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    Set(String, String, ParamValue),
    Mu(f64),
    Orbit(f32, f32),
    Dolly(f32),
    /// The lens and shutter widgets' values.
    Lens(Lens),
    ResetCamera,
    Output(String),
    Compare(Option<String>),
    Split(f32),
    Exposure(f32),
    /// Write the screenshot into this directory.
    Screenshot(PathBuf),
    Pause(bool),
}

/// A script step's actions, in [`Step`]'s documented order.
pub fn step_actions(step: &Step) -> Vec<Action> {
    let mut v = Vec::new();
    if let Some((name, value)) = &step.set {
        if let Some((node, param)) = name.split_once('.') {
            v.push(Action::Set(node.into(), param.into(), wedge_graph::ParamValue::from(value)));
        }
    }
    v.extend(step.mu.map(Action::Mu));
    v.extend(step.orbit.map(|(yaw, pitch)| Action::Orbit(yaw, pitch)));
    v.extend(step.dolly.map(Action::Dolly));
    v.extend(step.reset_camera.filter(|r| *r).map(|_| Action::ResetCamera));
    v.extend(step.output.clone().map(Action::Output));
    v.extend(step.compare.clone().map(|c| Action::Compare(Some(c))));
    v.extend(step.split.map(Action::Split));
    v.extend(step.screenshot.clone().map(Action::Screenshot));
    v
}

/// Apply `action`; `Ok(Some(line))` is a message for the status line (e.g. the files written).
pub fn apply(model: &mut Model, display: &mut Display, action: Action) -> Result<Option<String>, WedgeError> {
    match action {
        Action::Set(node, param, value) => model.set_param(&node, &param, value)?,
        Action::Mu(mu) => model.set_mu(mu)?,
        Action::Orbit(yaw, pitch) => model.set_camera(Some(orbit(&model.camera(), yaw, pitch)))?,
        Action::Dolly(f) => model.set_camera(Some(dolly(&model.camera(), f)))?,
        Action::Lens(lens) => model.set_lens(lens)?,
        Action::ResetCamera => model.set_camera(None)?,
        Action::Output(name) => display.output = known_output(model, name)?,
        Action::Compare(name) => display.compare = name.map(|n| known_output(model, n)).transpose()?,
        Action::Split(at) => display.split = at.clamp(0.0, 1.0),
        Action::Exposure(e) => display.exposure = e,
        Action::Pause(p) => model.paused = p,
        Action::Screenshot(dir) => return screenshot(model, display, &dir).map(Some),
    }
    Ok(None)
}

/// `name` when the current run has that output, else an error listing the ones it has.
fn known_output(model: &Model, name: String) -> Result<String, WedgeError> {
    let names = model.output_names();
    if names.contains(&name) {
        return Ok(name);
    }
    Err(WedgeError::Usage(format!(
        "output `{name}` does not exist in {}; {}its outputs are: {}",
        model.session.pipeline.path.display(),
        wedge_graph::suggestion(&name, names.iter().map(String::as_str)),
        names.join(", ")
    )))
}

fn screenshot(model: &Model, display: &Display, dir: &std::path::Path) -> Result<String, WedgeError> {
    let picture = display
        .picture(model)
        .ok_or_else(|| WedgeError::Usage(format!("screenshot into {}: nothing is shown yet", dir.display())))?;
    let written = model.screenshot(dir, &picture)?;
    let files: Vec<String> =
        written.files.iter().filter_map(|f| f.file_name()).map(|f| f.to_string_lossy().into_owned()).collect();
    Ok(format!(
        "screenshot after {} frame(s): wrote {} into {}\n{}",
        model.frames(),
        files.join(", "),
        dir.display(),
        written.warnings()
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_takes_a_left_of_the_cut() {
        let a = Picture { width: 4, height: 2, rgb: vec![10; 24] };
        let b = Picture { width: 4, height: 2, rgb: vec![200; 24] };
        let s = split(&a, &b, 0.5);
        assert_eq!(&s.rgb[..6], &[10; 6]);
        assert_eq!(&s.rgb[6..12], &[200; 6]);
        assert_eq!(&s.rgb[12..18], &[10; 6]);
        assert_eq!(split(&a, &b, 1.0).rgb, a.rgb);
        assert_eq!(split(&a, &b, 0.0).rgb, b.rgb);
    }
}
