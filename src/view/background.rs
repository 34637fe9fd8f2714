//! A reference rendered in the background for the error view (`wedge view --reference-spp N`, a
//! script's `reference_spp: N`): a thread builds the pipeline's reference
//! (`Session::reference_with`, the graph with its filters bypassed at `N` samples per pixel) for
//! the camera the window shows and renders it on the CPU, while the window keeps rendering and
//! answering; the model polls it and loads the image as the error view's reference when it is done.

use std::path::PathBuf;
use std::sync::mpsc::{channel, Receiver, RecvTimeoutError, TryRecvError};
use std::time::Duration;

use wedge_scene::Camera;

use crate::image::Image;
use crate::outputs::buffer_to_image;
use crate::session::Registries;
use crate::{Overrides, Session, WedgeError};

/// Samples per pixel of the reference the window's button renders: seconds for a small image.
pub const BUTTON_SPP: u32 = 64;

/// What the reference is rendered from: the window's pipeline, overrides and camera.
pub struct Request {
    pub registries: Registries,
    pub pipeline: Option<PathBuf>,
    pub overrides: Overrides,
    pub camera: Camera,
    pub spp: u32,
}

/// A reference rendering on its own thread (the thread ends with its render; dropping this lets
/// the result go unread).
pub struct Background {
    pub spp: u32,
    done: Receiver<Result<Image, WedgeError>>,
}

impl Background {
    /// Start rendering `request`'s reference.
    pub fn start(request: Request) -> Result<Background, WedgeError> {
        let (tx, done) = channel();
        let spp = request.spp;
        std::thread::Builder::new()
            .name("wedge view reference".into())
            .spawn(move || {
                // The window may be gone by the time it is done; nobody is left to tell.
                let _ = tx.send(render(&request));
            })
            .map_err(|e| WedgeError::Usage(format!("wedge view: cannot start the reference thread: {e}")))?;
        Ok(Background { spp, done })
    }

    /// The finished reference, if it is done (non-blocking).
    pub fn poll(&self) -> Option<Result<Image, WedgeError>> {
        match self.done.try_recv() {
            Ok(done) => Some(done),
            Err(TryRecvError::Empty) => None,
            Err(TryRecvError::Disconnected) => Some(Err(lost())),
        }
    }

    /// The reference, waiting at most `timeout` for it (`None`: not done by then).
    pub fn wait(&self, timeout: Duration) -> Option<Result<Image, WedgeError>> {
        match self.done.recv_timeout(timeout) {
            Ok(done) => Some(done),
            Err(RecvTimeoutError::Timeout) => None,
            Err(RecvTimeoutError::Disconnected) => Some(Err(lost())),
        }
    }

    /// How the status bar names the reference.
    pub fn label(&self) -> String {
        label(self.spp)
    }
}

/// The name of a background reference of `spp` samples per pixel in the status bar.
pub fn label(spp: u32) -> String {
    format!("the background reference ({spp} spp)")
}

/// The reference image of `request` (its `color` output), rendered on the CPU.
fn render(request: &Request) -> Result<Image, WedgeError> {
    let Request { registries, pipeline, overrides, camera, spp } = request;
    let mut session = Session::reference_with(registries, pipeline.as_deref(), *spp, "stratified", overrides)?;
    session.scene.camera = *camera;
    let run = session.run(&mut wedge_backends::cpu::CpuBackend::new(), &wedge_backends::Silent)?;
    let color = run.output("color").ok_or_else(|| {
        WedgeError::Usage(format!(
            "{}: the reference has no `color` output to compare",
            session.pipeline.path.display()
        ))
    })?;
    Ok(buffer_to_image(color, session.width, session.height))
}

fn lost() -> WedgeError {
    WedgeError::Usage("wedge view: the reference thread stopped (it panicked; see the message above)".into())
}
