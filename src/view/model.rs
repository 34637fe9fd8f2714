//! The viewer's state, apart from any window: the session built from the pipeline and the current
//! overrides, the backend it runs on, the running mean of its frames, the camera the user moved, and
//! the diagnostics of the last failed reload. The window ([`super::window`]) and the script runner
//! drive it through these methods; nothing here draws.
//!
//! A change (parameter, `mu`, camera, a saved pipeline) rebuilds the session with the changed
//! overrides and starts the average over. Frames run on the render thread ([`super::render`]); the
//! window starts one and takes it when done ([`Model::start_frame`], [`Model::poll_frame`]), a
//! script or test renders one and waits ([`Model::render_frame`]).
//!
//! A parameter or `mu` change re-runs only the passes downstream of it in the first frame after it
//! (on either backend): the first frame of every session keeps its buffers ([`Kept`]), the rebuilt
//! session's schedule says which of its passes differ from the kept run's or read what those write
//! (`Schedule::changed_since`), and only those run, the others' buffers taken from the kept run —
//! same seed and frame, so the image is a whole run's bit for bit. Later frames (new seeds) run in
//! full; a camera move, a lens change, a reload or a changed scene request runs in full.
//!
//! The kept buffers count against `--memory-limit` (`Session::view_memory_estimate`): where one
//! frame's run fits the limit but not with a kept run beside it, first frames keep nothing, every
//! frame runs in full, and [`Model::notice`] says so and which limit would do; where not even one
//! run fits, opening (or the rebuild a change asks for) is refused as `render` refuses it.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use wedge_backends::RunResult;
use wedge_graph::ParamValue;
use wedge_scene::{Camera, SceneSource};

use super::accumulate::Accumulator;
use super::reference::{Reference, ERROR_VIEW};
use super::render::{Done, Engine, FirstFrame, KeptRun, Partial, Renderer, LOST};
use super::watch::Watch;
use super::ViewOptions;
use crate::outputs::{write_run_with_picture, Picture, WrittenRun};
use crate::session::{format_bytes, RunMode};
use crate::{Overrides, Session, WedgeError};

/// The lens and shutter of the pipeline's camera block, as the window edits them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lens {
    pub aperture_radius: f32,
    pub focus_distance: f32,
    pub shutter: (f32, f32),
}

impl Lens {
    pub fn of(cam: &Camera) -> Lens {
        Lens {
            aperture_radius: cam.aperture_radius,
            focus_distance: cam.focus_distance,
            shutter: (cam.shutter_open, cam.shutter_close),
        }
    }
}

/// The buffers of a session's first frame, with the schedule that wrote them: what a parameter
/// change's first frame takes the passes upstream of the change from.
struct Kept {
    buffers: Arc<KeptRun>,
    schedule: wedge_graph::Schedule,
}

/// Most frames averaged; past it the image stops changing and the viewer stops rendering.
pub const MAX_FRAMES: u32 = 1 << 16;

pub struct Model {
    pipeline: Option<PathBuf>,
    /// The command line's overrides with the widgets' changes applied.
    pub overrides: Overrides,
    /// The last session that built; a failed rebuild keeps it (and its image). Shared with the render
    /// thread while a frame renders; its scene camera is set to [`Model::camera`] between frames.
    pub session: Arc<Session>,
    /// The session's own camera (the pipeline's), under the user's moves.
    base_camera: Camera,
    renderer: Renderer,
    /// Bumped by every change: a frame started before it is dropped, not averaged.
    generation: u64,
    acc: Accumulator,
    watch: Watch,
    /// Where the user moved the camera: (position, look-at) over the session's camera (`None`: the
    /// pipeline's). Only rays change, so no rebuild.
    view: Option<(glam::Vec3, glam::Vec3)>,
    /// The lens and shutter set in the window, written into the pipeline's camera block before each
    /// build (they reach the nodes' filters, not only the rays). A save of the file clears them.
    lens: Option<Lens>,
    /// Why the last rebuild or frame failed, as `wedge graph` prints it; cleared by the next success.
    pub error: Option<String>,
    /// Frames rendered since the window opened (the script's clock).
    pub rendered: u64,
    /// Wall time of the last frame and the time between the last two frames.
    pub last_frame_seconds: f64,
    pub frame_interval: f64,
    last_frame_end: Option<Instant>,
    /// The outputs of the last frame rendered (kept across a change, until the next frame).
    outputs: Vec<String>,
    /// No new frames while set (the user paused, or a frame failed).
    pub paused: bool,
    /// The error view's reference image and the mean's metrics against it.
    reference: Option<Reference>,
    /// The buffers of the schedule the picker offers besides the sinks' outputs ([`super::probes`]),
    /// and those picked so far (the session hands them back; kept across rebuilds while they exist).
    probe_names: Vec<String>,
    probes: Vec<String>,
    /// How the backend times its passes (the wgpu backend uses timestamp queries where the adapter
    /// has `TIMESTAMP_QUERY`, `backends/src/gpu/mod.rs`).
    pub timed_by: &'static str,
    /// The last first frame's buffers (`None` after a camera move or a full rebuild until the next
    /// first frame renders, and while the memory limit leaves no room for them).
    kept: Option<Kept>,
    /// The memory limit and where it came from (`--memory-limit`, or the default's derivation).
    budget: Option<(u64, String)>,
    /// How the backend's memory is estimated.
    mode: RunMode,
    /// Whether first frames keep their buffers (the limit leaves room for them).
    keeps: bool,
    /// Why partial re-runs are off, with the limit that would allow them (`None` while they are on).
    pub notice: Option<String>,
    /// Per pass of the session's schedule, whether its next first frame runs it (`None`: all).
    rerun: Option<Vec<bool>>,
    /// Passes the last frame ran, of how many the schedule has.
    pub passes_run: (usize, usize),
    /// A reference rendering in the background, loaded into [`Model::reference`] when done.
    background: Option<super::background::Background>,
}

impl Model {
    /// Open the session the command line asks for; an error here ends `wedge view` like `render`.
    pub fn open(opts: &ViewOptions) -> Result<Model, WedgeError> {
        let session = Session::open_with(&opts.registries, opts.pipeline.as_deref(), &opts.overrides)?;
        let budget = crate::session::memory_budget(opts.memory_limit);
        let mode = if opts.backend == "wgpu" { RunMode::Gpu } else { RunMode::Cpu };
        let (keeps, notice) = keep_buffers(&session, mode, budget.as_ref())?;
        if let Some(notice) = &notice {
            eprintln!("note: {notice}");
        }
        let (backend, timed_by) = match opts.backend.as_str() {
            "wgpu" => {
                let gpu = crate::session::open_gpu(opts.gpu_limits.as_deref())?;
                let by = if gpu.has_timestamps() { "GPU timestamp queries" } else { "wall clock around each dispatch" };
                (Engine::Gpu(Box::new(gpu)), by)
            }
            _ => (Engine::Cpu(wedge_backends::cpu::CpuBackend::new()), "wall clock on the CPU"),
        };
        let watch = Watch::new(watched_files(opts.pipeline.as_ref(), &session, &opts.overrides));
        let probe_names = super::probes::candidates(&session)?;
        let mut model = Model {
            pipeline: opts.pipeline.clone(),
            overrides: opts.overrides.clone(),
            base_camera: session.scene.camera,
            session: Arc::new(session),
            renderer: Renderer::new(backend)?,
            generation: 0,
            acc: Accumulator::default(),
            watch,
            view: None,
            lens: None,
            error: None,
            rendered: 0,
            last_frame_seconds: 0.0,
            frame_interval: 0.0,
            last_frame_end: None,
            paused: false,
            outputs: Vec::new(),
            reference: None,
            probe_names,
            probes: Vec::new(),
            timed_by,
            kept: None,
            budget,
            mode,
            keeps,
            notice,
            rerun: None,
            passes_run: (0, 0),
            background: None,
        };
        if let Some(path) = &opts.reference {
            model.set_reference(path)?;
        }
        if let Some(spp) = opts.reference_spp {
            model.render_reference(spp)?;
        }
        Ok(model)
    }

    /// Compare the mean with the EXR at `path` from now on (the `error` output, the metrics); a
    /// file of another size than the viewer's is refused, naming both sizes.
    pub fn set_reference(&mut self, path: &std::path::Path) -> Result<(), WedgeError> {
        let mut reference = Reference::load(path, self.session.width, self.session.height)?;
        reference.update(self.acc.mean(), self.session.width, self.session.height);
        self.reference = Some(reference);
        self.list_outputs();
        Ok(())
    }

    /// Make runs hand back buffer `name` of the schedule (a [`super::probes`] candidate) from the
    /// next frame on; nothing for a sink's output or a buffer already probed. Waits for the frame in
    /// flight (the session is rescheduled) and starts the mean over.
    pub fn probe(&mut self, name: &str) -> Result<(), WedgeError> {
        if !self.probe_names.iter().any(|n| n == name) || self.probes.iter().any(|n| n == name) {
            return Ok(());
        }
        if let Some(done) = self.renderer.wait() {
            self.finish(done)?;
        }
        let mut probes = self.probes.clone();
        probes.push(name.to_string());
        let session = Arc::get_mut(&mut self.session)
            .ok_or_else(|| WedgeError::Usage("wedge view: the render thread still holds the session".into()))?;
        super::probes::set_probes(session, &probes)?;
        self.probes = probes;
        self.restart();
        Ok(())
    }

    /// The reference the error view compares with, if one is loaded.
    pub fn reference(&self) -> Option<&Reference> {
        self.reference.as_ref()
    }

    /// The picker's names: the last run's outputs, the error view when a reference is loaded, then
    /// every buffer of the schedule that can be shown.
    fn list_outputs(&mut self) {
        let mut names = self.acc.mean().map(super::outputs::names).unwrap_or_default();
        if self.reference.is_some() && !names.iter().any(|n| n == ERROR_VIEW) {
            names.push(ERROR_VIEW.to_string());
        }
        if !names.is_empty() {
            names.extend(self.probe_names.iter().filter(|n| !names.contains(n)).cloned().collect::<Vec<_>>());
        }
        // Kept across a change until the next frame arrives, as the picture is.
        if !names.is_empty() {
            self.outputs = names;
        }
    }

    pub fn backend_name(&self) -> &'static str {
        self.renderer.name()
    }

    /// The mean of the frames since the last change.
    pub fn mean(&self) -> Option<&RunResult> {
        self.acc.mean()
    }

    /// The names the output picker offers (those of the last frame rendered).
    pub fn output_names(&self) -> &[String] {
        &self.outputs
    }

    pub fn frames(&self) -> u32 {
        self.acc.frames()
    }

    /// The camera frames are rendered with.
    pub fn camera(&self) -> Camera {
        let cam = self.base_camera;
        self.view.map_or(cam, |(position, look_at)| Camera { position, look_at, ..cam })
    }

    /// The diagonal of the scene's bounds (1 for an empty or unbounded scene): what the fly keys'
    /// speed is scaled by.
    pub fn scene_size(&self) -> f32 {
        let d = self.session.scene.bounds.size().length();
        if d.is_finite() && d > 0.0 {
            d
        } else {
            1.0
        }
    }

    /// Whether the pipeline has a camera block (whose lens and shutter the window can change).
    pub fn has_camera_block(&self) -> bool {
        self.session.pipeline.pipeline.camera.is_some()
    }

    /// Whether the next frame would add to the image (not paused, not converged).
    pub fn wants_frame(&self) -> bool {
        !self.paused && self.acc.frames() < MAX_FRAMES
    }

    /// Whether a frame is on the render thread (or finished and not taken).
    pub fn frame_in_flight(&mut self) -> bool {
        self.renderer.poll();
        self.renderer.in_flight()
    }

    /// Whether the frame in flight has finished.
    pub fn frame_ready(&mut self) -> bool {
        self.renderer.poll()
    }

    /// Start the next frame on the render thread unless one is in flight or none is wanted.
    pub fn start_frame(&mut self) -> Result<(), WedgeError> {
        if self.renderer.in_flight() || !self.wants_frame() {
            return Ok(());
        }
        // The render thread let go of the session after its last frame, so the camera can be set.
        let camera = self.camera();
        if self.session.scene.camera != camera {
            let Some(session) = Arc::get_mut(&mut self.session) else {
                return Ok(());
            };
            session.scene.camera = camera;
        }
        let first = match (&self.kept, &self.rerun) {
            _ if !self.keeps => FirstFrame::Whole,
            (Some(kept), Some(rerun)) => {
                FirstFrame::Partial(Partial { kept: kept.buffers.clone(), rerun: rerun.clone() })
            }
            _ => FirstFrame::Keep,
        };
        self.renderer.start(self.session.clone(), self.acc.frames(), self.generation, first)
    }

    /// Take the finished frame, if any, into the mean: `Some(Ok(true))` when one was added,
    /// `Some(Ok(false))` when it was started before a change and dropped. A background reference
    /// that finished is loaded too; one that failed says why in [`Model::error`], and frames go on.
    pub fn poll_frame(&mut self) -> Option<Result<bool, WedgeError>> {
        if let Some(Err(e)) = self.poll_reference() {
            self.error = Some(format!("error: the background reference: {e}"));
        }
        self.renderer.take().map(|done| self.finish(done))
    }

    /// Render one more frame (a new seed) and add it to the mean, waiting for it (scripts, tests).
    pub fn render_frame(&mut self) -> Result<(), WedgeError> {
        // A frame started before a change is dropped; then this one starts from the new state.
        if let Some(done) = self.renderer.wait() {
            self.finish(done)?;
        }
        let paused = std::mem::replace(&mut self.paused, false);
        let started = self.start_frame();
        self.paused = paused;
        started?;
        match self.renderer.wait() {
            Some(done) => self.finish(done).map(|_| ()),
            None => Err(WedgeError::Usage(format!("no frame was started: {} frames are averaged already", MAX_FRAMES))),
        }
    }

    fn finish(&mut self, done: Done) -> Result<bool, WedgeError> {
        if done.generation != self.generation && done.generation != LOST {
            return Ok(false);
        }
        let end = Instant::now();
        self.last_frame_seconds = done.seconds;
        self.frame_interval = self.last_frame_end.map_or(done.seconds, |t| (end - t).as_secs_f64());
        self.last_frame_end = Some(end);
        let run = done.run?;
        self.passes_run = (run.timings.len(), self.session.schedule.passes.len());
        if let Some(buffers) = done.kept {
            self.kept = Some(Kept { buffers: Arc::new(buffers), schedule: self.session.schedule.clone() });
            self.rerun = None;
        }
        self.acc.add(run);
        self.list_outputs();
        if let Some(reference) = &mut self.reference {
            reference.update(self.acc.mean(), self.session.width, self.session.height);
        }
        self.rendered += 1;
        Ok(true)
    }

    /// Start the mean over (something changed): frames in flight are dropped when they arrive.
    fn restart(&mut self) {
        self.acc.reset();
        self.generation += 1;
        self.kept = None;
        self.rerun = None;
    }

    /// Set `node.param` (as `--set`) and rebuild; on a refusal the old value stays and the error is returned.
    pub fn set_param(&mut self, node: &str, param: &str, value: ParamValue) -> Result<(), WedgeError> {
        let mut ov = self.overrides.clone();
        ov.params.retain(|(n, p, _)| !(n == node && p == param));
        ov.params.push((node.to_string(), param.to_string(), value));
        self.rebuild_downstream(ov)
    }

    /// Set `--mu` and rebuild.
    pub fn set_mu(&mut self, mu: f64) -> Result<(), WedgeError> {
        let ov = Overrides { mu: Some(mu), ..self.overrides.clone() };
        self.rebuild_downstream(ov)
    }

    /// Move the camera to `camera`'s position and look-at (`None`: back to the pipeline's, lens
    /// included) and start the average over.
    pub fn set_camera(&mut self, camera: Option<Camera>) -> Result<(), WedgeError> {
        self.view = camera.map(|c| (c.position, c.look_at));
        self.restart();
        if camera.is_none() && self.lens.take().is_some() {
            return self.rebuild_with(self.overrides.clone());
        }
        Ok(())
    }

    /// Set the lens and shutter of the pipeline's camera block and rebuild; refused (old lens kept)
    /// when the pipeline does not accept it.
    pub fn set_lens(&mut self, lens: Lens) -> Result<(), WedgeError> {
        let old = self.lens.replace(lens);
        let rebuilt = self.rebuild_with(self.overrides.clone());
        if rebuilt.is_err() {
            self.lens = old;
        }
        rebuilt
    }

    /// Reload when the pipeline or scene file changed on disk. A file that no longer loads keeps
    /// the last good session and sets [`Model::error`] to what `wedge graph` would print. Whether a
    /// file changed (the window has something new to show).
    pub fn poll_reload(&mut self) -> bool {
        if !self.watch.changed() {
            return false;
        }
        self.lens = None;
        match self.build(&self.overrides) {
            Ok(session) => self.replace(session),
            Err(e) => self.error = Some(format!("error: {e}")),
        }
        true
    }

    /// A session of the pipeline file with `ov` and the window's lens.
    fn build(&self, ov: &Overrides) -> Result<Session, WedgeError> {
        let mut loaded = crate::session::load_pipeline_or_default(self.pipeline.as_deref())?;
        if let (Some(lens), Some(spec)) = (self.lens, loaded.pipeline.camera.as_mut()) {
            spec.aperture_radius = lens.aperture_radius;
            spec.focus_distance = Some(lens.focus_distance);
            spec.shutter = Some(lens.shutter);
        }
        // The registries the window opened with (a user's binary's nodes), kept by every session.
        let crate::session::Registries { nodes, kernels } = self.session.registries();
        let session = Session::build(loaded, ov, nodes, kernels)?;
        // A change that makes one run too large for the limit is refused like `render` refuses it.
        keep_buffers(&session, self.mode, self.budget.as_ref())?;
        Ok(session)
    }

    fn rebuild_with(&mut self, ov: Overrides) -> Result<(), WedgeError> {
        let session = self.build(&ov)?;
        self.overrides = ov;
        self.replace(session);
        Ok(())
    }

    fn replace(&mut self, mut session: Session) {
        // The picked buffers stay picked while the new pipeline has them.
        self.probe_names = super::probes::candidates(&session).unwrap_or_default();
        self.probes.retain(|p| self.probe_names.contains(p));
        if let Err(e) = super::probes::set_probes(&mut session, &self.probes) {
            self.probes.clear();
            eprintln!("warning: the buffers picked for the viewer are dropped: {e}");
        }
        self.watch = Watch::new(watched_files(self.pipeline.as_ref(), &session, &self.overrides));
        self.base_camera = session.scene.camera;
        // Checked by `build`: only whether the kept buffers still fit can change here.
        (self.keeps, self.notice) = keep_buffers(&session, self.mode, self.budget.as_ref()).unwrap_or((false, None));
        self.session = Arc::new(session);
        self.restart();
        self.error = None;
        self.paused = false;
    }

    /// Write the mean run's outputs as `wedge render` writes them into `dir`, with `picture` (what
    /// the window shows) as `view.png`, all or nothing.
    pub fn screenshot(
        &self,
        dir: &std::path::Path,
        picture: &super::outputs::Picture,
    ) -> Result<WrittenRun, WedgeError> {
        crate::staging::check_output_dir(dir)?;
        let run = self
            .mean()
            .ok_or_else(|| WedgeError::Usage("no frame has been rendered yet to take a screenshot of".into()))?;
        let shown = Picture { name: "view", width: picture.width, height: picture.height, rgb: &picture.rgb };
        Ok(write_run_with_picture(dir, "render", run, &shown, self.session.width, self.session.height)?)
    }
}

/// Re-running only the passes downstream of a parameter change (see the module's doc).
impl Model {
    /// Rebuild with `ov` (a parameter or `mu` changed, nothing else), keeping the last first frame's
    /// buffers for the passes the change leaves alone.
    fn rebuild_downstream(&mut self, ov: Overrides) -> Result<(), WedgeError> {
        let session = self.build(&ov)?;
        let kept = self.kept.take().filter(|_| same_scene_requests(&self.session, &session));
        let rerun = kept.as_ref().map(|k| session.schedule.changed_since(&k.schedule));
        self.overrides = ov;
        self.replace(session);
        if self.keeps {
            (self.kept, self.rerun) = (kept, rerun);
        }
        Ok(())
    }

    /// How many of the schedule's passes the next first frame runs (all without kept buffers).
    pub fn passes_to_rerun(&self) -> usize {
        let all = self.session.schedule.passes.len();
        self.rerun.as_ref().filter(|_| self.keeps).map_or(all, |r| r.iter().filter(|&&run| run).count())
    }
}

/// The error view's reference rendered in the background ([`super::background`]).
impl Model {
    /// Start rendering the pipeline's reference at `spp` samples per pixel for the camera shown now
    /// (with the current overrides); the window keeps rendering, and the reference replaces the
    /// error view's when it is done. A second request replaces one still rendering.
    pub fn render_reference(&mut self, spp: u32) -> Result<(), WedgeError> {
        if spp == 0 {
            return Err(WedgeError::Usage("--reference-spp 0: a reference needs at least 1 sample per pixel".into()));
        }
        let request = super::background::Request {
            registries: self.session.registries(),
            pipeline: self.pipeline.clone(),
            overrides: self.overrides.clone(),
            camera: self.camera(),
            spp,
        };
        self.background = Some(super::background::Background::start(request)?);
        Ok(())
    }

    /// The name of the background reference still rendering, if one is.
    pub fn background_label(&self) -> Option<String> {
        self.background.as_ref().map(|b| b.label())
    }

    /// Load the background reference if it is done: `Some(Ok(()))` when it was loaded now.
    pub fn poll_reference(&mut self) -> Option<Result<(), WedgeError>> {
        let done = self.background.as_ref()?.poll()?;
        Some(self.load_background(done))
    }

    /// Wait at most `timeout` for the background reference and load it; an error when none is
    /// rendering or it is not done by then (a script's `wait_reference`).
    pub fn wait_reference(&mut self, timeout: std::time::Duration) -> Result<(), WedgeError> {
        let background = self.background.as_ref().ok_or_else(|| {
            WedgeError::Usage("no reference is rendering: ask for one first (reference_spp, --reference-spp)".into())
        })?;
        match background.wait(timeout) {
            Some(done) => self.load_background(done),
            None => Err(WedgeError::Usage(format!(
                "{} was not done after {:.1} s; wait longer or ask for fewer samples",
                background.label(),
                timeout.as_secs_f64()
            ))),
        }
    }

    fn load_background(&mut self, done: Result<crate::image::Image, WedgeError>) -> Result<(), WedgeError> {
        let name = self.background.take().map(|b| b.label()).unwrap_or_default();
        let mut reference = Reference::rendered(done?, name);
        reference.update(self.acc.mean(), self.session.width, self.session.height);
        self.reference = Some(reference);
        self.list_outputs();
        Ok(())
    }
}

/// Whether first frames of `session` may keep their buffers under `budget` (limit, where it came
/// from), with a note saying why not where they may not; an error when not even one frame's run fits.
fn keep_buffers(
    session: &Session,
    mode: RunMode,
    budget: Option<&(u64, String)>,
) -> Result<(bool, Option<String>), WedgeError> {
    let Some((limit, source)) = budget else {
        return Ok((true, None));
    };
    let run = session.view_memory_estimate(mode, false);
    run.check(*limit, source)?;
    let (run, kept) = (run.total(), session.view_memory_estimate(mode, true));
    if kept.total() <= *limit {
        return Ok((true, None));
    }
    Ok((
        false,
        Some(format!(
            "partial re-runs are off: keeping a first frame's buffers for them needs an estimated {} beside the {} of a \
             frame ({} in all), over the memory limit of {} ({source}); every frame after a change runs in full. Raise \
             the limit with --memory-limit {}M to re-run only the passes a change touches",
            format_bytes(kept.total() - run),
            format_bytes(run),
            format_bytes(kept.total()),
            format_bytes(*limit),
            kept.total().div_ceil(1 << 20)
        )),
    ))
}

/// Whether two sessions' nodes ask the scene for the same things (an environment map, a real
/// layer): a parameter that changes one changes what every pass tracing the scene sees.
fn same_scene_requests(a: &Session, b: &Session) -> bool {
    let requests =
        |s: &Session| -> Vec<_> { s.pipeline.nodes.iter().flat_map(|n| n.kind.scene_requests(&n.params)).collect() };
    requests(a) == requests(b)
}

/// The pipeline file and, where it names one (and `--scene` does not replace it), its scene file.
fn watched_files(pipeline: Option<&PathBuf>, session: &Session, ov: &Overrides) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = pipeline.cloned().into_iter().collect();
    if ov.scene.is_none() {
        if let SceneSource::File(scene) = crate::session::scene_source(&session.pipeline, None) {
            files.push(scene);
        }
    }
    files
}
