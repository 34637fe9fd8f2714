//! The kernels of the `PixelFilter` node (see [`super`]), CPU here and WGSL in
//! `shaders/pixel_filter_*.wgsl`, all built on [`super::formulas`] (WGSL mirror:
//! `shaders/pixel_filter_formulas.wgsl`). A progressive render runs the pipeline once per frame
//! (`render --progressive N`); the node's running statistics go from one frame to the next through
//! the graph's frame history (`ExpandCtx::previous_frame`), and kernels that run on a schedule read
//! the frame index (`KernelCtx::frame`, WGSL `frame.frame_index`).
//!
//! - `pixel_filter.sample`: `count` paths per pixel (one per frame in progressive mode), each a
//!   jittered camera ray (thesis Sec. 3.3: pinhole, box pixel filter; through the lens and over the
//!   shutter where the camera opens them, `CameraDraws::jittered`) shaded with the shared
//!   estimators of `indirect.rs` — next-event estimation at every vertex and the
//!   one-sample lobe mixture continued by `trace_path_split` — split into the low-variance paths
//!   `L_lv` and the high-variance paths `L_u` by [`sample::Split`] (Sec. 3.3, Fig. 3.1). Writes the batch's
//!   `Stats` (means, count, `M2` of `Y(L_u)`).
//! - `pixel_filter.accumulate`: the running statistics: the previous frame's `Stats` combined with
//!   this frame's batch (`Stats::combine`, Welford/Chan: mean and `M2`, never sums of squares).
//! - `pixel_filter.range`: the range buffer (Sec. 3.3.3): albedo lit by ambient light and a head light
//!   (`range_colour`) in RGB, the nearest depth in A, `count` (4) jittered rays per filter pass
//!   averaged with the earlier passes' (4×, 8×, … supersampling).
//! - `pixel_filter.width`: the adaptive spatial width (Sec. 3.6.3, eqs. 3.15–3.17, `adaptive_sigma`).
//! - `pixel_filter.bilateral`: the brute-force cross-bilateral filter (eq. 3.6) of `L_u` with its
//!   variance reduction `Σa²` (eq. 3.5) and the per-pixel variance filtered with the same weights
//!   (Sec. 3.3.2); `pixel_filter.separable`: one 1-D pass of the iterated separable approximation
//!   (Sec. 3.6.1, eq. 3.14). Both run on filter frames only (`is_filter_frame`) and otherwise keep
//!   the last filtered buffer (the previous frame's, through the history).
//! - `pixel_filter.blend`: the per-pixel blend (eqs. 3.1, 3.10–3.13, `blend_factor`) with the
//!   optional spike clamp (eq. 3.18, `spike_clamp`).
//!
//! Files: [`sample`] (sample, accumulate, range), [`filter`] (bilateral, separable), [`blend`] (width, blend).

use wedge_backends::{BackendError, KernelCtx, KernelParams};

use super::formulas::{filter_passes_through, is_filter_frame};
use super::node::DEFAULT_T;

pub mod blend;
pub mod filter;
pub mod sample;

pub use blend::{AdaptiveWidth, Blend};
pub use filter::{Bilateral, Separable};
pub use sample::{Accumulate, PixelSample, RangeBuffer};

wedge_backends::kernel_params! {
    /// The filter schedule (Sec. 3.3.3), read by the range buffer and the filters.
    pub struct ScheduleParams {
        first_filter: u32 = int(4, 1, 1 << 20, "the filter runs when a pixel has first_filter × 2^i paths (4, 8, 16, …)"),
        filter_first_frame: bool = boolean(true, "also filter the first frame (a single image, and the preview before frame 4)"),
    }
}

wedge_backends::kernel_params! {
    /// The threshold on perceived variance (eq. 3.11), read by the blend and the adaptive width.
    pub struct ThresholdParams {
        t: f32 = float(DEFAULT_T, 0.0, 1e6, "threshold on perceived variance (eq. 3.11); 0 = never blend in the filtered buffer where noise remains"),
    }
}

/// The filter schedule of a pass: whether this frame filters, and which filter pass it is.
fn schedule(ctx: &KernelCtx<'_>) -> Result<(bool, u32), BackendError> {
    let ScheduleParams { first_filter, filter_first_frame: first_frame } = ScheduleParams::read(ctx)?;
    let first = first_filter.max(1);
    Ok((is_filter_frame(ctx.frame, first, first_frame), filter_passes_through(ctx.frame, first, first_frame)))
}
