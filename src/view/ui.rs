//! The window's panels, drawn with egui each frame from the model: the controls on the left
//! (output picker, A/B split, exposure, `mu`, camera, the generated parameter widgets), the
//! timings and diagnostics at the bottom, the image in the middle (drag to orbit, wheel to dolly).
//! Drawing changes nothing: every edit comes back as an [`Action`] for [`super::control::apply`].

use std::path::PathBuf;

use egui::{Color32, Rect, Sense, TextureHandle, TextureOptions};

use super::control::{Action, Display, Layout};
use super::model::{Lens, Model};
use super::outputs::Picture;
use super::params;

/// Radians of orbit per point of mouse drag.
const ORBIT_PER_POINT: f32 = 0.01;
/// Fraction of the distance dollied per point of wheel scroll.
const DOLLY_PER_POINT: f32 = 0.002;
/// Radians the camera turns per point of right-button drag.
const LOOK_PER_POINT: f32 = 0.004;
/// Fraction of the scene's size (its bounds' diagonal) flown per second a WASD/QE key is held.
const FLY_PER_SECOND: f32 = 0.25;
/// Longest time step of one fly move (a stalled frame does not jump the camera across the scene).
const MAX_FLY_STEP: f32 = 0.1;

/// What the panels keep between frames: the texture of the shown picture and the status line.
pub struct Panels {
    texture: Option<TextureHandle>,
    /// The picture in the texture, to upload only when it changes.
    uploaded: Option<Picture>,
    /// The last message (files a screenshot wrote, a refused change).
    pub status: String,
    /// Where F12 and the screenshot button write.
    out: PathBuf,
}

impl Panels {
    pub fn new(out: PathBuf) -> Panels {
        Panels { texture: None, uploaded: None, status: String::new(), out }
    }

    /// Draw everything; the user's edits of this frame.
    pub fn show(&mut self, ui: &mut egui::Ui, model: &Model, display: &Display) -> Vec<Action> {
        let mut actions = Vec::new();
        keys(ui, model, &self.out, &mut actions);
        egui::Panel::left("controls").resizable(true).show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| self.controls(ui, model, display, &mut actions));
        });
        // Resizable and scrolled: long diagnostics must not squeeze the image away.
        egui::Panel::bottom("status").resizable(true).default_size(120.0).show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| self.status_bar(ui, model));
        });
        egui::CentralPanel::default().show(ui, |ui| self.image(ui, model, display, &mut actions));
        actions
    }

    fn controls(&mut self, ui: &mut egui::Ui, model: &Model, display: &Display, actions: &mut Vec<Action>) {
        let names = model.output_names();
        ui.heading("Output");
        if let Some(a) = pick(ui, "output A", Some(&display.output), names, false) {
            actions.extend(a.map(Action::Output));
        }
        if let Some(b) = pick(ui, "B", display.compare.as_ref(), names, true) {
            actions.push(Action::Compare(b));
        }
        if display.compare.is_some() {
            layout_ui(ui, display, actions);
        }
        let mut exposure = display.exposure;
        if ui.add(egui::Slider::new(&mut exposure, 0.01..=100.0).logarithmic(true).text("exposure")).changed() {
            actions.push(Action::Exposure(exposure));
        }
        ui.separator();
        self.global(ui, model, actions);
        camera_ui(ui, model, actions);
        ui.separator();
        ui.heading("Parameters");
        if let Some((node, param, value)) = params::pipeline_ui(ui, &model.session.pipeline) {
            actions.push(Action::Set(node, param, value));
        }
    }

    /// `--mu`, pause and the screenshot button.
    fn global(&mut self, ui: &mut egui::Ui, model: &Model, actions: &mut Vec<Action>) {
        // `--mu`, else the first node's own `mu` (what the nodes run with until the slider moves).
        let first = || model.session.pipeline.nodes.iter().find_map(|n| n.params.get("mu")?.as_f64());
        let mut mu = params::shown(ui, "global mu", model.overrides.mu.or_else(first).unwrap_or(1.0));
        let r = ui.add(egui::Slider::new(&mut mu, 0.05..=50.0).logarithmic(true).text("mu (all nodes)"));
        actions.extend(params::commit(ui, "global mu", &r, mu).map(Action::Mu));
        let mut paused = model.paused;
        if ui.checkbox(&mut paused, "pause (Space)").changed() {
            actions.push(Action::Pause(paused));
        }
        let spp = super::background::BUTTON_SPP;
        if ui.button(format!("render a reference ({spp} spp) in the background")).clicked() {
            actions.push(Action::RenderReference(spp));
        }
        if ui.button(format!("screenshot (F12) into {}", self.out.display())).clicked() {
            actions.push(Action::Screenshot(self.out.clone()));
        }
    }

    fn status_bar(&self, ui: &mut egui::Ui, model: &Model) {
        // Diagnostics first: they are what the user must see after a save.
        if let Some(error) = &model.error {
            ui.colored_label(
                Color32::from_rgb(255, 110, 110),
                "the last edit did not load; showing the last good pipeline:",
            );
            ui.monospace(error);
        }
        ui.label(stats_line(model));
        if let Some(notice) = &model.notice {
            ui.label(notice);
        }
        if let Some(reference) = model.reference() {
            ui.label(format!("error {}", reference.summary()));
        }
        if let Some(label) = model.background_label() {
            ui.label(format!("rendering {label} in the background…"));
        }
        if let Some(run) = model.mean() {
            let (ran, of) = model.passes_run;
            let header = format!("pass times of the last frame ({}; {ran} of {of} passes ran)", model.timed_by);
            egui::CollapsingHeader::new(header).show(ui, |ui| {
                for t in &run.timings {
                    ui.monospace(format!("{:<32} {:<22} {:>9.2} ms", t.pass, t.kernel, t.seconds * 1e3));
                }
            });
        }
        if !self.status.is_empty() {
            ui.label(&self.status);
        }
    }

    fn image(&mut self, ui: &mut egui::Ui, model: &Model, display: &Display, actions: &mut Vec<Action>) {
        // Until the first frame after a change arrives, the last picture stays (it can be orbited).
        let texture = match (display.picture(model), &self.texture) {
            (Some(picture), _) => self.upload(ui.ctx(), picture),
            (None, Some(last)) => last.clone(),
            (None, None) => {
                ui.label("rendering the first frame...");
                return;
            }
        };
        if model.frames() == 0 {
            ui.label("rendering the first frame after the change...");
        }
        let size = texture.size_vec2();
        let scale = (ui.available_width() / size.x).min(ui.available_height() / size.y).max(0.01);
        let (rect, response) = ui.allocate_exact_size(size * scale, Sense::drag());
        let uv = Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0));
        ui.painter().image(texture.id(), rect, uv, Color32::WHITE);
        if display.compare.is_some() && display.layout == Layout::Split {
            let x = rect.left() + display.split * rect.width();
            ui.painter().vline(x, rect.y_range(), egui::Stroke::new(1.0, Color32::WHITE));
        }
        // Not on the frame the drag starts: its delta may hold the pointer's jump to the image.
        let drag = if response.drag_started() { egui::Vec2::ZERO } else { response.drag_delta() };
        if drag != egui::Vec2::ZERO {
            // Left button orbits around the look-at point, right button looks around on the spot.
            if response.dragged_by(egui::PointerButton::Secondary) {
                actions.push(Action::Look(-drag.x * LOOK_PER_POINT, -drag.y * LOOK_PER_POINT));
            } else {
                actions.push(Action::Orbit(-drag.x * ORBIT_PER_POINT, drag.y * ORBIT_PER_POINT));
            }
        }
        let scroll = if response.hovered() { ui.input(|i| i.smooth_scroll_delta.y) } else { 0.0 };
        if scroll != 0.0 {
            actions.push(Action::Dolly((scroll * DOLLY_PER_POINT).clamp(-0.5, 0.5)));
        }
    }

    /// The texture showing `picture`, uploaded only when it differs from the last one.
    fn upload(&mut self, ctx: &egui::Context, picture: Picture) -> TextureHandle {
        let image = || egui::ColorImage::from_rgb([picture.width as usize, picture.height as usize], &picture.rgb);
        // Nearest: one rendered pixel stays one block of screen pixels, noise is not smoothed away.
        let options = TextureOptions::NEAREST;
        match &mut self.texture {
            Some(t) if self.uploaded.as_ref() == Some(&picture) => return t.clone(),
            Some(t) => t.set(image(), options),
            None => self.texture = Some(ctx.load_texture("wedge view image", image(), options)),
        }
        self.uploaded = Some(picture);
        self.texture.clone().expect("set above")
    }
}

/// The WASD/QE keys: right (D − A), up (E − Q), forward (W − S), each −1, 0 or 1.
const FLY_KEYS: [(egui::Key, egui::Key); 3] =
    [(egui::Key::D, egui::Key::A), (egui::Key::E, egui::Key::Q), (egui::Key::W, egui::Key::S)];

/// F12 screenshot, Space pause, R reset the camera, WASD/QE fly while held.
fn keys(ui: &egui::Ui, model: &Model, out: &std::path::Path, actions: &mut Vec<Action>) {
    let (f12, space, r) =
        ui.input(|i| (i.key_pressed(egui::Key::F12), i.key_pressed(egui::Key::Space), i.key_pressed(egui::Key::R)));
    // Keys typed into a text field are the field's.
    if ui.ctx().egui_wants_keyboard_input() {
        return;
    }
    let (axes, dt) = ui.input(|i| {
        let axis = |(plus, minus): (egui::Key, egui::Key)| f32::from(i.key_down(plus)) - f32::from(i.key_down(minus));
        (glam::Vec3::from(FLY_KEYS.map(axis)), i.stable_dt.min(MAX_FLY_STEP))
    });
    if axes != glam::Vec3::ZERO {
        actions.push(Action::Fly(axes * (FLY_PER_SECOND * model.scene_size() * dt)));
        // Held keys send no events of their own: draw again to keep moving.
        ui.ctx().request_repaint();
    }
    if f12 {
        actions.push(Action::Screenshot(out.to_path_buf()));
    }
    if space {
        actions.push(Action::Pause(!model.paused));
    }
    if r {
        actions.push(Action::ResetCamera);
    }
}

/// Frames, time per frame, frames per second and rays per pixel.
fn stats_line(model: &Model) -> String {
    let px = f64::from(model.session.width) * f64::from(model.session.height);
    let rays = model.mean().map_or(0.0, |r| r.rays.total_rays() as f64 / px.max(1.0));
    format!(
        "{} on {}, {}x{}: {} frame(s) averaged{} · last frame {:.1} ms · {:.1} fps · {:.2} rays/px per frame ({:.1} in the mean)",
        model.session.pipeline.path.display(),
        model.backend_name(),
        model.session.width,
        model.session.height,
        model.frames(),
        if model.paused { " (paused)" } else { "" },
        model.last_frame_seconds * 1e3,
        1.0 / model.frame_interval.max(1e-9),
        rays,
        rays * f64::from(model.frames())
    )
}

/// Split or side by side; the split's place.
fn layout_ui(ui: &mut egui::Ui, display: &Display, actions: &mut Vec<Action>) {
    ui.horizontal(|ui| {
        for (label, layout) in [("A/B split", Layout::Split), ("side by side", Layout::SideBySide)] {
            if ui.selectable_label(display.layout == layout, label).clicked() && display.layout != layout {
                actions.push(Action::Layout(layout));
            }
        }
    });
    if display.layout == Layout::Split {
        let mut at = display.split;
        if ui.add(egui::Slider::new(&mut at, 0.0..=1.0).text("split")).changed() {
            actions.push(Action::Split(at));
        }
    }
}

/// A combo box over `names`; `Some(choice)` when the user picked one (`None` = "none", if `optional`).
fn pick(
    ui: &mut egui::Ui,
    label: &str,
    current: Option<&String>,
    names: &[String],
    optional: bool,
) -> Option<Option<String>> {
    let mut chosen = current.cloned();
    egui::ComboBox::from_label(label).selected_text(current.map_or("none", |s| s.as_str())).show_ui(ui, |ui| {
        if optional {
            ui.selectable_value(&mut chosen, None, "none");
        }
        for n in names {
            ui.selectable_value(&mut chosen, Some(n.clone()), n);
        }
    });
    (chosen.as_ref() != current).then_some(chosen)
}

/// Reset, and the lens and shutter of the pipeline's camera block when it has one.
fn camera_ui(ui: &mut egui::Ui, model: &Model, actions: &mut Vec<Action>) {
    ui.heading("Camera");
    ui.label("drag the image to orbit, right-drag to look around, wheel to dolly, WASD/QE to fly");
    if ui.button("reset camera (R)").clicked() {
        actions.push(Action::ResetCamera);
    }
    if !model.has_camera_block() {
        return;
    }
    let mut lens = Lens::of(&model.camera());
    let mut committed = false;
    let mut field = |ui: &mut egui::Ui, v: &mut f32, lo: f32, label: &str| {
        *v = params::shown(ui, label, *v);
        let r = ui
            .horizontal(|ui| ui.add(egui::DragValue::new(v).range(lo..=f32::MAX).speed(0.01)) | ui.label(label))
            .inner;
        committed |= params::commit(ui, label, &r, *v).is_some();
    };
    field(ui, &mut lens.aperture_radius, 0.0, "aperture radius");
    field(ui, &mut lens.focus_distance, 1e-3, "focus distance");
    field(ui, &mut lens.shutter.0, f32::MIN, "shutter open");
    field(ui, &mut lens.shutter.1, f32::MIN, "shutter close");
    if committed {
        actions.push(Action::Lens(lens));
    }
}
