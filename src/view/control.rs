//! What the user (or a script step) can do, as one list of actions applied in one place: the
//! widgets and keys of the window and the steps of `--script` go through [`apply`], so a scripted
//! run exercises the same code as a person at the window.

use std::path::PathBuf;

use wedge_graph::ParamValue;

use super::camera::{dolly, fly, look, orbit};
use super::model::{Lens, Model};
use super::outputs::{self, Picture};
use super::probes;
use super::reference::ERROR_VIEW;
use super::script::Step;
use crate::WedgeError;

/// How outputs A and B are put together when B is chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Layout {
    /// A left of the split, B right of it (images of one size; else A alone).
    #[default]
    Split,
    /// A and B next to each other, each whole (any sizes: a heatmap beside an image).
    SideBySide,
}

impl Layout {
    /// The script's and the widget's names.
    pub const NAMES: [(&'static str, Layout); 2] = [("split", Layout::Split), ("side_by_side", Layout::SideBySide)];

    /// The layout called `name` (`"split"`, `"side_by_side"`).
    pub fn parse(name: &str) -> Option<Layout> {
        Layout::NAMES.iter().find(|(n, _)| *n == name).map(|(_, l)| *l)
    }
}

/// What is shown: output A, optionally output B (right of a split at `split`, 0..1 of the width,
/// or beside A), and the exposure images are scaled by before the sRGB curve.
#[derive(Clone, Debug, PartialEq)]
pub struct Display {
    pub output: String,
    pub compare: Option<String>,
    pub split: f32,
    pub layout: Layout,
    pub exposure: f32,
}

impl Default for Display {
    fn default() -> Self {
        Display { output: "color".into(), compare: None, split: 0.5, layout: Layout::Split, exposure: 1.0 }
    }
}

impl Display {
    /// The picture of output A, or of A and B as [`Display::layout`] puts them. `None` before the
    /// first frame or when output A does not exist.
    pub fn picture(&self, model: &Model) -> Option<Picture> {
        let a = self.output_picture(model, &self.output)?;
        let b = self.compare.as_deref().and_then(|b| self.output_picture(model, b));
        Some(match (b, self.layout) {
            (Some(b), Layout::Split) if (b.width, b.height) == (a.width, a.height) => split(&a, &b, self.split),
            (Some(b), Layout::SideBySide) => side_by_side(&a, &b),
            _ => a,
        })
    }

    /// One entry of the output picker as a picture: the error view, or an output of the mean run.
    fn output_picture(&self, model: &Model, name: &str) -> Option<Picture> {
        let run = model.mean()?;
        let (w, h) = (model.session.width, model.session.height);
        match model.reference() {
            Some(reference) if name == ERROR_VIEW => reference.picture(run, w, h),
            _ => outputs::picture(run, name, w, h, self.exposure)
                .or_else(|| probes::picture(run, name, w, h, &model.session.scene.bounds)),
        }
    }
}

/// Columns between A and B in the side-by-side picture.
pub const SIDE_BY_SIDE_GAP: u32 = 2;
/// The gap's and the padding's colour (the window's background).
const GAP_RGB: [u8; 3] = [20, 20, 20];

/// `a` and `b` next to each other, tops aligned, [`SIDE_BY_SIDE_GAP`] columns apart; the shorter one
/// padded below.
fn side_by_side(a: &Picture, b: &Picture) -> Picture {
    let (width, height) = (a.width + SIDE_BY_SIDE_GAP + b.width, a.height.max(b.height));
    let mut rgb: Vec<u8> = GAP_RGB.iter().copied().cycle().take(width as usize * height as usize * 3).collect();
    let row = width as usize * 3;
    for (picture, x0) in [(a, 0), (b, a.width + SIDE_BY_SIDE_GAP)] {
        let src_row = picture.width as usize * 3;
        for (y, src) in picture.rgb.chunks(src_row).enumerate() {
            let start = y * row + x0 as usize * 3;
            rgb[start..start + src_row].copy_from_slice(src);
        }
    }
    Picture { width, height, rgb }
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
    /// Move the camera in its own frame (right, up, forward), in scene units.
    Fly(glam::Vec3),
    /// Turn the camera on the spot by (yaw, pitch) radians.
    Look(f32, f32),
    /// The lens and shutter widgets' values.
    Lens(Lens),
    ResetCamera,
    Output(String),
    Compare(Option<String>),
    Split(f32),
    Layout(Layout),
    Exposure(f32),
    /// Load this reference image (the error view's).
    Reference(PathBuf),
    /// Render the reference in the background at this many samples per pixel.
    RenderReference(u32),
    /// Wait at most this long for the background reference.
    WaitReference(std::time::Duration),
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
    v.extend(step.fly.map(|(x, y, z)| Action::Fly(glam::Vec3::new(x, y, z))));
    v.extend(step.reset_camera.filter(|r| *r).map(|_| Action::ResetCamera));
    v.extend(step.reference.clone().map(Action::Reference));
    v.extend(step.reference_spp.map(Action::RenderReference));
    let wait =
        step.wait_reference.map(|s| std::time::Duration::try_from_secs_f64(s).unwrap_or(std::time::Duration::ZERO));
    v.extend(wait.map(Action::WaitReference));
    v.extend(step.output.clone().map(Action::Output));
    v.extend(step.compare.clone().map(|c| Action::Compare(Some(c))));
    v.extend(step.split.map(Action::Split));
    v.extend(step.layout.as_deref().and_then(Layout::parse).map(Action::Layout));
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
        Action::Fly(d) => model.set_camera(Some(fly(&model.camera(), d)))?,
        Action::Look(yaw, pitch) => model.set_camera(Some(look(&model.camera(), yaw, pitch)))?,
        Action::Lens(lens) => model.set_lens(lens)?,
        Action::ResetCamera => model.set_camera(None)?,
        Action::Output(name) => display.output = shown_output(model, name)?,
        Action::Compare(name) => display.compare = name.map(|n| shown_output(model, n)).transpose()?,
        Action::Split(at) => display.split = at.clamp(0.0, 1.0),
        Action::Layout(layout) => display.layout = layout,
        Action::Reference(path) => model.set_reference(&path)?,
        Action::RenderReference(spp) => model.render_reference(spp)?,
        Action::WaitReference(timeout) => model.wait_reference(timeout)?,
        Action::Exposure(e) => display.exposure = e,
        Action::Pause(p) => model.paused = p,
        Action::Screenshot(dir) => return screenshot(model, display, &dir).map(Some),
    }
    Ok(None)
}

/// `name` when the picker offers it, probed if it is a buffer of the schedule ([`Model::probe`]).
fn shown_output(model: &mut Model, name: String) -> Result<String, WedgeError> {
    let name = known_output(model, name)?;
    model.probe(&name)?;
    Ok(name)
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
    let against = model.reference().map_or(String::new(), |r| format!("{}\n", r.summary()));
    Ok(format!(
        "screenshot after {} frame(s): wrote {} into {}\n{against}{}",
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

    #[test]
    fn side_by_side_puts_b_right_of_a_past_the_gap_and_pads_the_shorter() {
        let a = Picture { width: 2, height: 1, rgb: vec![10; 6] };
        let b = Picture { width: 1, height: 2, rgb: vec![200; 6] };
        let s = side_by_side(&a, &b);
        let w = 2 + SIDE_BY_SIDE_GAP + 1;
        assert_eq!((s.width, s.height), (w, 2));
        let px = |x: u32, y: u32| &s.rgb[((y * w + x) * 3) as usize..((y * w + x) * 3 + 3) as usize];
        assert_eq!(px(1, 0), &[10; 3]);
        assert_eq!(px(2, 0), &GAP_RGB);
        assert_eq!(px(w - 1, 0), &[200; 3]);
        assert_eq!(px(w - 1, 1), &[200; 3]);
        assert_eq!(px(0, 1), &GAP_RGB, "A is padded below");
    }

    #[test]
    fn layouts_parse_by_their_script_names() {
        assert_eq!(Layout::parse("side_by_side"), Some(Layout::SideBySide));
        assert_eq!(Layout::parse("split"), Some(Layout::Split));
        assert_eq!(Layout::parse("sbs"), None);
    }
}
