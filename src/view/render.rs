//! The render thread: frames run on a thread of their own so the window stays responsive while a
//! slow frame (a large `mu`, a big image on the CPU) renders. The thread owns the backend; the model
//! hands it a shared session and a frame number, and gets the run back tagged with the generation it
//! was started for, so a frame that finishes after a change is dropped instead of averaged.
//!
//! A first frame (frame 0, the one a change shows first) keeps every buffer it wrote and hands them
//! back ([`KeptRun`]); the next change's first frame runs only the passes downstream of the change
//! ([`Partial`], `Session::run_partial_frame`) and takes the others' buffers from those. On the CPU
//! they are host buffers; on the wgpu backend they stay on the device (`wedge_backends::gpu::run`),
//! only the sinks' inputs are read back. Where `--memory-limit` leaves no room for them
//! ([`super::model`]) no first frame keeps anything and every frame runs in full.

use std::sync::mpsc::{channel, Receiver, Sender, TryRecvError};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Instant;

use wedge_backends::cpu::CpuBackend;
use wedge_backends::gpu::GpuBackend;
use wedge_backends::{Backend, PartialRun, RunResult, Silent};

use crate::{Session, WedgeError};

/// A frame to render: frame `frame` of `session` (seed + frame, no history), for `generation`.
struct Job {
    session: Arc<Session>,
    frame: u32,
    generation: u64,
    /// How a first frame runs: keeping its buffers (re-running only some passes where given) or not.
    first: FirstFrame,
}

/// How a first frame (frame 0) runs; later frames run in full through the backend's pool.
#[derive(Clone)]
pub enum FirstFrame {
    /// In full, keeping nothing (`--memory-limit` leaves no room for a kept run).
    Whole,
    /// In full, keeping every buffer for the next change.
    Keep,
    /// Only some passes, the others' buffers from an earlier first frame; keeping the result.
    Partial(Partial),
}

/// A first frame that re-runs only some passes: `kept` are the buffers of the last first frame
/// (same scene, camera, size, seed), `rerun` one flag per pass of the new session's schedule.
#[derive(Clone)]
pub struct Partial {
    pub kept: Arc<KeptRun>,
    pub rerun: Vec<bool>,
}

/// What renders: the CPU backend or the wgpu one (each can keep a first frame's buffers).
pub enum Engine {
    Cpu(CpuBackend),
    Gpu(Box<GpuBackend>),
}

/// A first frame's buffers, on the backend that wrote them: host buffers on the CPU, device
/// buffers on the wgpu backend.
pub enum KeptRun {
    Cpu(wedge_backends::cpu::KeptBuffers),
    Gpu(wedge_backends::gpu::KeptBuffers),
}

impl Engine {
    fn name(&self) -> &'static str {
        match self {
            Engine::Cpu(cpu) => cpu.name(),
            Engine::Gpu(gpu) => gpu.name(),
        }
    }
}

/// The generation of the report that the render thread is gone (never stale).
pub const LOST: u64 = u64::MAX;

/// A finished frame.
pub struct Done {
    pub generation: u64,
    pub run: Result<RunResult, WedgeError>,
    /// Wall time of the frame on the render thread.
    pub seconds: f64,
    /// A first frame's buffers, for the next change's [`Partial`].
    pub kept: Option<KeptRun>,
}

pub struct Renderer {
    jobs: Option<Sender<Job>>,
    done: Receiver<Done>,
    thread: Option<JoinHandle<()>>,
    name: &'static str,
    /// A frame is on the render thread.
    in_flight: bool,
    /// A finished frame not taken yet.
    ready: Option<Done>,
}

impl Renderer {
    /// Start the render thread with `backend`.
    pub fn new(backend: Engine) -> Result<Renderer, WedgeError> {
        let name = backend.name();
        let (jobs, job_rx) = channel::<Job>();
        let (done_tx, done) = channel::<Done>();
        let thread = std::thread::Builder::new()
            .name("wedge view render".into())
            .spawn(move || serve(backend, job_rx, done_tx))
            .map_err(|e| WedgeError::Usage(format!("wedge view: cannot start the render thread: {e}")))?;
        Ok(Renderer { jobs: Some(jobs), done, thread: Some(thread), name, in_flight: false, ready: None })
    }

    pub fn name(&self) -> &'static str {
        self.name
    }

    /// Whether a frame is rendering or finished but not taken.
    pub fn in_flight(&self) -> bool {
        self.in_flight || self.ready.is_some()
    }

    /// Render frame `frame` of `session` (a first frame as `first` says); the caller checks
    /// [`Renderer::in_flight`] first.
    pub fn start(
        &mut self,
        session: Arc<Session>,
        frame: u32,
        generation: u64,
        first: FirstFrame,
    ) -> Result<(), WedgeError> {
        let job = Job { session, frame, generation, first };
        let sent = self.jobs.as_ref().is_some_and(|j| j.send(job).is_ok());
        if !sent {
            return Err(stopped());
        }
        self.in_flight = true;
        Ok(())
    }

    /// Whether the frame in flight has finished (without taking it).
    pub fn poll(&mut self) -> bool {
        if self.ready.is_none() && self.in_flight {
            match self.done.try_recv() {
                Ok(done) => self.arrived(done),
                Err(TryRecvError::Empty) => {}
                Err(TryRecvError::Disconnected) => self.arrived(lost()),
            }
        }
        self.ready.is_some()
    }

    /// The finished frame, if any (non-blocking).
    pub fn take(&mut self) -> Option<Done> {
        self.poll();
        self.ready.take()
    }

    /// The frame in flight, waiting for it (`None`: nothing in flight).
    pub fn wait(&mut self) -> Option<Done> {
        if self.ready.is_none() && self.in_flight {
            let done = self.done.recv().unwrap_or_else(|_| lost());
            self.arrived(done);
        }
        self.ready.take()
    }

    fn arrived(&mut self, done: Done) {
        self.in_flight = false;
        self.ready = Some(done);
    }
}

impl Drop for Renderer {
    fn drop(&mut self) {
        // Closing the channel ends the thread after its frame.
        self.jobs = None;
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// The render thread's loop: one job at a time until the window goes.
fn serve(mut engine: Engine, jobs: Receiver<Job>, done: Sender<Done>) {
    while let Ok(job) = jobs.recv() {
        let start = Instant::now();
        let (run, kept) = render(&mut engine, &job);
        // Let go of the session before reporting, so the model may change it (its camera) at once.
        drop(job.session);
        let finished = Done { generation: job.generation, run, seconds: start.elapsed().as_secs_f64(), kept };
        if done.send(finished).is_err() {
            return;
        }
    }
}

/// Render `job` on `engine`: a first frame keeps its buffers (running only the partial job's
/// passes where it has one) unless told not to; every other frame runs in full through the pool.
fn render(engine: &mut Engine, job: &Job) -> (Result<RunResult, WedgeError>, Option<KeptRun>) {
    let whole = job.frame > 0 || matches!(job.first, FirstFrame::Whole);
    let kept = match &job.first {
        FirstFrame::Partial(p) => Some((&*p.kept, &p.rerun[..])),
        _ => None,
    };
    match engine {
        Engine::Cpu(cpu) if whole => (job.session.run_progressive_frame(cpu, &Silent, job.frame, None), None),
        Engine::Gpu(gpu) if whole => (job.session.run_progressive_frame(gpu.as_mut(), &Silent, job.frame, None), None),
        Engine::Cpu(cpu) => {
            let kept = kept.and_then(|(k, rerun)| if let KeptRun::Cpu(k) = k { Some((k, rerun)) } else { None });
            let (run, kept) = first_frame(cpu, &job.session, kept);
            (run, kept.map(KeptRun::Cpu))
        }
        Engine::Gpu(gpu) => {
            let kept = kept.and_then(|(k, rerun)| if let KeptRun::Gpu(k) = k { Some((k, rerun)) } else { None });
            let (run, kept) = first_frame(gpu.as_mut(), &job.session, kept);
            (run, kept.map(KeptRun::Gpu))
        }
    }
}

/// Frame 0 of `session` on `backend`, keeping its buffers: only `partial`'s passes where given
/// (the others' buffers from its kept run), else every pass.
fn first_frame<B: PartialRun>(
    backend: &mut B,
    session: &Session,
    partial: Option<(&B::Kept, &[bool])>,
) -> (Result<RunResult, WedgeError>, Option<B::Kept>) {
    let empty = B::Kept::default();
    let (kept, rerun) = partial.map_or((&empty, None), |(k, r)| (k, Some(r)));
    let mut ran = session.run_partial_frame(backend, &Silent, 0, kept, rerun);
    if ran.is_err() && rerun.is_some() {
        // A kept buffer that does not fit (or any failure of the shortcut): the whole frame,
        // whose error, if it fails too, is the one worth showing.
        ran = session.run_partial_frame(backend, &Silent, 0, &empty, None);
    }
    match ran {
        Ok((run, buffers)) => (Ok(run), Some(buffers)),
        Err(e) => (Err(e), None),
    }
}

fn stopped() -> WedgeError {
    WedgeError::Usage("wedge view: the render thread has stopped (it panicked; see the message above)".into())
}

/// What a frame reports when the render thread is gone.
fn lost() -> Done {
    Done { generation: LOST, run: Err(stopped()), seconds: 0.0, kept: None }
}
