//! `wedge view`: an interactive window for authoring pipelines (issue 38).
//!
//! The pipeline renders with [`crate::Session`] on the chosen backend; the window (winit, egui
//! drawn through egui-wgpu on its own wgpu device) shows the mean of the frames rendered since the
//! last change, tone-mapped as `wedge render` writes its PNG, or any other output of the run. The
//! rendered buffers come back to the host on either backend and are uploaded as a texture, so the
//! CPU backend and the wgpu backend are shown the same way.
//!
//! - [`model`]: session, backend, frame averaging, rebuilds on changes, hot reload, screenshots;
//! - [`outputs`]: the output picker's entries as pictures; [`params`]: widgets from declarations;
//! - [`reference`]: the error view against a reference image, [`background`]: one rendered in the
//!   background; [`probes`]: any buffer of the schedule;
//! - [`camera`]: orbit and dolly; [`script`]: `--script` steps; [`watch`]: file polling;
//! - [`control`]: the actions widgets, keys and script steps share;
//! - [`ui`]: the panels; [`window`]: the winit/egui-wgpu event loop.

pub mod accumulate;
pub mod background;
pub mod camera;
pub mod control;
pub mod model;
pub mod outputs;
pub mod params;
pub mod probes;
pub mod reference;
pub mod render;
pub mod script;
mod ui;
pub mod watch;
mod window;

use std::path::PathBuf;

use crate::{Overrides, WedgeError};

/// What `wedge view` was asked for on the command line.
#[derive(Clone, Debug)]
pub struct ViewOptions {
    pub pipeline: Option<PathBuf>,
    /// The node kinds and kernels the pipeline may use (a user's binary: [`crate::cli::main`]).
    pub registries: crate::session::Registries,
    /// `--scene`, `--width`, `--height`, `--seed`, `--set`, `--mu`, as for `render`.
    pub overrides: Overrides,
    /// `cpu` or `wgpu`.
    pub backend: String,
    pub gpu_limits: Option<String>,
    /// Where the screenshot key writes (`--out`, as for `render`).
    pub out: PathBuf,
    /// `--memory-limit`, as for `render` (checked for the first session).
    pub memory_limit: Option<u64>,
    /// `--script`: run these steps, write their screenshots and exit.
    pub script: Option<PathBuf>,
    /// `--reference`: an EXR of the viewer's size (`wedge reference`'s) for the error view.
    pub reference: Option<PathBuf>,
    /// `--reference-spp N`: render the error view's reference in the background at `N` samples per
    /// pixel (the pipeline's `wedge reference`, for the camera the window opens with).
    pub reference_spp: Option<u32>,
}

/// Open the window and run until it is closed (or the script is done). Returns what to print.
pub fn run(opts: ViewOptions) -> Result<String, WedgeError> {
    // A bad script is refused before a window opens.
    let script = opts.script.as_deref().map(script::Script::load).transpose()?;
    let model = model::Model::open(&opts)?;
    window::run(model, opts.out.clone(), script)
}
