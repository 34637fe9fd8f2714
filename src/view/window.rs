//! The event loop: a winit window whose egui panels are drawn by egui-wgpu on a wgpu device of
//! their own (the wgpu backend, when chosen, renders on another device; its buffers come back to
//! the host and are shown as a texture, like the CPU backend's).
//!
//! Each redraw: poll the watched files, take the frame the render thread finished and start the
//! next (a script instead renders one and waits, then applies its steps for that frame), draw the
//! panels, apply the edits they report. While nothing is left to render the loop sleeps until an
//! event arrives (waking to poll the files).

use std::num::NonZeroU32;
use std::path::PathBuf;
use std::sync::Arc;

use egui::ViewportId;
use egui_wgpu::winit::Painter;
use winit::application::ApplicationHandler;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::window::{Window, WindowId};

use super::control::{apply, step_actions, Action, Display};
use super::model::Model;
use super::script::Script;
use super::ui::Panels;
use crate::WedgeError;

/// Initial window size (points) between these: small renders get room for the controls, big ones
/// are scaled down to fit.
const MIN_WINDOW: (u32, u32) = (960, 640);
const MAX_WINDOW: (u32, u32) = (1600, 1000);
/// How often an idle window looks at the watched files.
const RELOAD_POLL: std::time::Duration = std::time::Duration::from_millis(250);
/// How often the window looks for a frame finished on the render thread.
const FRAME_POLL: std::time::Duration = std::time::Duration::from_millis(5);
/// Room for the controls beside and the status below the image.
const PANEL_ROOM: (u32, u32) = (340, 170);

/// Open the window and run until it closes (or the script ends); what to print on stdout.
pub fn run(model: Model, out: PathBuf, script: Option<Script>) -> Result<String, WedgeError> {
    let event_loop = EventLoop::new().map_err(|e| {
        WedgeError::Usage(format!(
            "wedge view: cannot open a window ({e}); it needs a display: run it on a desktop, set DISPLAY, or run it \
             under `xvfb-run -a`"
        ))
    })?;
    let mut app = App {
        model,
        display: Display::default(),
        panels: Panels::new(out),
        script,
        ctx: egui::Context::default(),
        gfx: None,
        result: Ok(String::new()),
        repaint_at: None,
    };
    event_loop
        .run_app(&mut app)
        .map_err(|e| WedgeError::Usage(format!("wedge view: the window's event loop failed: {e}")))?;
    app.result
}

/// The window and what draws into it.
struct Gfx {
    window: Arc<Window>,
    painter: Painter,
    input: egui_winit::State,
}

struct App {
    model: Model,
    display: Display,
    panels: Panels,
    script: Option<Script>,
    ctx: egui::Context,
    gfx: Option<Gfx>,
    /// What `run` returns: the screenshots written, or the error that ended the loop.
    result: Result<String, WedgeError>,
    /// When egui asked to be drawn again (a click is finished, an animation runs) without an event.
    repaint_at: Option<std::time::Instant>,
}

impl App {
    fn open(&self, el: &ActiveEventLoop) -> Result<Gfx, WedgeError> {
        let window_error =
            |e: &dyn std::fmt::Display| WedgeError::Usage(format!("wedge view: cannot open the window: {e}"));
        let (w, h) = (self.model.session.width + PANEL_ROOM.0, self.model.session.height + PANEL_ROOM.1);
        let attributes = Window::default_attributes()
            .with_title(format!("wedge view — {}", self.model.session.pipeline.path.display()))
            .with_inner_size(winit::dpi::LogicalSize::new(
                w.clamp(MIN_WINDOW.0, MAX_WINDOW.0),
                h.clamp(MIN_WINDOW.1, MAX_WINDOW.1),
            ));
        let window = Arc::new(el.create_window(attributes).map_err(|e| window_error(&e))?);
        let config = egui_wgpu::WgpuConfiguration::default();
        let mut painter =
            pollster::block_on(Painter::new(self.ctx.clone(), config, false, egui_wgpu::RendererOptions::default()));
        pollster::block_on(painter.set_window(ViewportId::ROOT, Some(window.clone()))).map_err(|e| window_error(&e))?;
        let input = egui_winit::State::new(
            self.ctx.clone(),
            ViewportId::ROOT,
            el,
            Some(window.scale_factor() as f32),
            None,
            painter.max_texture_side(),
        );
        Ok(Gfx { window, painter, input })
    }

    /// End the loop with `e` as the command's error.
    fn fail(&mut self, el: &ActiveEventLoop, e: WedgeError) {
        self.result = Err(e);
        el.exit();
    }

    fn redraw(&mut self, el: &ActiveEventLoop) {
        self.model.poll_reload();
        if self.script.is_some() {
            // A script waits for each frame, so its steps apply after exactly the frame they name.
            if self.model.wants_frame() {
                match self.model.render_frame() {
                    Ok(()) => self.run_script(el),
                    Err(e) => return self.fail(el, e),
                }
            }
        } else {
            if let Some(Err(e)) = self.model.poll_frame() {
                self.frame_failed(e);
            }
            self.start_frame();
        }
        let actions = self.paint();
        for action in actions {
            self.interactive(action);
        }
        // An edit restarted the mean: start its first frame now, not at the next event.
        if self.script.is_none() {
            self.start_frame();
        }
    }

    fn start_frame(&mut self) {
        if let Err(e) = self.model.start_frame() {
            self.frame_failed(e);
        }
    }

    /// A frame that failed pauses the viewer with the error shown (the next change resumes it).
    fn frame_failed(&mut self, e: WedgeError) {
        self.model.error = Some(format!("error: {e}"));
        self.model.paused = true;
    }

    /// Draw the panels; the edits the user made in them.
    fn paint(&mut self) -> Vec<Action> {
        let Some(gfx) = self.gfx.as_mut() else {
            return Vec::new();
        };
        let raw = gfx.input.take_egui_input(&gfx.window);
        let mut actions = Vec::new();
        let (panels, model, display) = (&mut self.panels, &self.model, &self.display);
        let mut out = self.ctx.run_ui(raw, |ui| actions = panels.show(ui, model, display));
        gfx.input.handle_platform_output(&gfx.window, out.platform_output);
        // egui asks to be drawn again (a held fly key, the end of a click) after this delay.
        let delay = out.viewport_output.get(&ViewportId::ROOT).map(|v| v.repaint_delay);
        if let Some(at) = delay.and_then(|d| std::time::Instant::now().checked_add(d)) {
            self.repaint_at = Some(self.repaint_at.map_or(at, |t| t.min(at)));
        }
        let shapes = self.ctx.tessellate(out.shapes, out.pixels_per_point);
        let clear = [0.08, 0.08, 0.08, 1.0];
        gfx.painter.paint_and_update_textures(
            ViewportId::ROOT,
            out.pixels_per_point,
            clear,
            &shapes,
            &mut out.textures_delta,
            Vec::new(),
            &gfx.window,
        );
        actions
    }

    /// Apply an edit from the window: a refused one is reported in the status line, not fatal.
    fn interactive(&mut self, action: Action) {
        match apply(&mut self.model, &mut self.display, action) {
            Ok(Some(message)) => {
                eprint!("{message}");
                self.panels.status = message;
            }
            Ok(None) => {}
            Err(e) => {
                eprintln!("error: {e}");
                self.panels.status = format!("error: {e}");
            }
        }
    }

    /// The script's steps for the frame just rendered; the end of the script closes the window.
    fn run_script(&mut self, el: &ActiveEventLoop) {
        let Some(script) = &self.script else { return };
        let frame = self.model.rendered - 1;
        let steps: Vec<_> = script.at(frame).map(|s| (s.order, step_actions(s))).collect();
        let (path, done) = (script.path.clone(), frame >= script.last_frame());
        for (order, actions) in steps {
            for action in actions {
                match apply(&mut self.model, &mut self.display, action) {
                    Ok(Some(message)) => {
                        if let Ok(text) = &mut self.result {
                            text.push_str(&message);
                        }
                    }
                    Ok(None) => {}
                    Err(e) => {
                        let e =
                            WedgeError::Usage(format!("{}: step {} (frame {frame}): {e}", path.display(), order + 1));
                        return self.fail(el, e);
                    }
                }
            }
        }
        if done {
            el.exit();
        }
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, el: &ActiveEventLoop) {
        if self.gfx.is_some() {
            return;
        }
        match self.open(el) {
            Ok(gfx) => {
                gfx.window.request_redraw();
                self.gfx = Some(gfx);
            }
            Err(e) => self.fail(el, e),
        }
    }

    fn window_event(&mut self, el: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some(gfx) = self.gfx.as_mut() else { return };
        let response = gfx.input.on_window_event(&gfx.window, &event);
        match event {
            WindowEvent::CloseRequested => el.exit(),
            WindowEvent::Resized(size) => {
                if let (Some(w), Some(h)) = (NonZeroU32::new(size.width), NonZeroU32::new(size.height)) {
                    gfx.painter.on_window_resized(ViewportId::ROOT, w, h);
                }
            }
            WindowEvent::RedrawRequested => self.redraw(el),
            _ => {}
        }
        if response.repaint {
            if let Some(gfx) = &self.gfx {
                gfx.window.request_redraw();
            }
        }
    }

    fn about_to_wait(&mut self, el: &ActiveEventLoop) {
        let redraw = |gfx: &Option<Gfx>| gfx.iter().for_each(|g| g.window.request_redraw());
        let now = std::time::Instant::now();
        // egui's own repaint requests (the end of a click, a hover animation).
        if self.repaint_at.is_some_and(|t| t <= now) {
            self.repaint_at = None;
            redraw(&self.gfx);
        }
        let soon = |d: std::time::Duration| self.repaint_at.map_or(now + d, |t| t.min(now + d));
        if self.script.is_some() {
            // A script renders frame after frame as fast as it can.
            el.set_control_flow(ControlFlow::Poll);
            redraw(&self.gfx);
        } else if self.model.frame_in_flight() {
            // Look for the finished frame often; draw only when it is there (or on input).
            if self.model.frame_ready() {
                redraw(&self.gfx);
            }
            el.set_control_flow(ControlFlow::WaitUntil(soon(FRAME_POLL)));
        } else if self.model.wants_frame() {
            redraw(&self.gfx);
            el.set_control_flow(ControlFlow::Poll);
        } else {
            // Converged or paused: sleep, waking a few times a second to notice a saved pipeline.
            if self.model.poll_reload() {
                redraw(&self.gfx);
            }
            el.set_control_flow(ControlFlow::WaitUntil(soon(RELOAD_POLL)));
        }
    }
}
