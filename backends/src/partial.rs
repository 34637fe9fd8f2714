//! Re-running part of a schedule (issue 38, `wedge view`): a backend that keeps every buffer of a
//! run can run only the passes a change touches (`Schedule::changed_since` says which) and take the
//! other passes' outputs from the kept run — same seed and frame, so the image is a whole run's bit
//! for bit. The CPU backend keeps host buffers ([`crate::cpu::KeptBuffers`]), the wgpu backend
//! device buffers (`gpu::KeptBuffers`, no round trip through the host). Callers that keep a run
//! hold every buffer of the schedule unpooled (`Schedule::buffer_bytes().unpooled`) besides a
//! run's own: `wedge::Session::view_memory_estimate` counts them against `--memory-limit`.

use std::collections::BTreeMap;

use wedge_graph::{BufferId, Format, Pass};

use crate::{Backend, BackendError, BufferData, Job, RunResult};

/// A backend that can run a subset of a schedule's passes with the others' outputs kept from an
/// earlier run of the same scene, camera, size, seed and frame.
pub trait PartialRun: Backend {
    /// Every buffer a run held, by buffer name (names are stable across rebuilds of a pipeline,
    /// ids are not).
    type Kept: Default + Send + Sync + 'static;

    /// Run only the passes `rerun` marks (one flag per scheduled pass; missing flags run), taking
    /// every other pass's outputs from `kept`; hand back the run and every buffer it holds, kept and
    /// written. With `kept` empty and every flag set it is a whole run that keeps its buffers. Each
    /// buffer has storage of its own (no pool: all of them outlive the run). A skipped pass whose
    /// outputs `kept` lacks is an error (the caller runs in full).
    fn run_partial(
        &mut self,
        job: &Job<'_>,
        history: &BTreeMap<BufferId, BufferData>,
        kept: &Self::Kept,
        rerun: &[bool],
    ) -> Result<(RunResult, Self::Kept), BackendError>;
}

/// What a kept buffer must match to stand in for a skipped pass's output.
pub trait KeptShape {
    /// Its format and elements (pixels × layers).
    fn shape(&self) -> (Format, usize);
}

impl KeptShape for std::sync::Arc<BufferData> {
    fn shape(&self) -> (Format, usize) {
        (self.format(), BufferData::len(self))
    }
}

/// Each scheduled pass with whether this run runs it (`rerun`'s flag; a pass past its end runs).
pub fn passes_to_run<'s>(job: &Job<'s>, rerun: &'s [bool]) -> impl Iterator<Item = (&'s Pass, bool)> {
    job.schedule.passes.iter().zip(rerun.iter().copied().chain(std::iter::repeat(true)))
}

/// The kept buffers standing in for skipped `pass`'s outputs, by buffer id; an error naming the
/// first output `kept` lacks in this run's format and size.
pub fn kept_outputs<T: KeptShape + Clone>(
    job: &Job<'_>,
    pass: &Pass,
    kept: &BTreeMap<String, T>,
) -> Result<Vec<(BufferId, T)>, BackendError> {
    let sched = job.schedule;
    pass.writes
        .iter()
        .map(|(_, id)| {
            let info = &sched.buffers[id.0];
            let len = job.width as usize * job.height as usize * info.layers as usize;
            let data = kept.get(&info.name).filter(|d| d.shape() == (info.format, len));
            data.map(|d| (*id, d.clone())).ok_or_else(|| {
                BackendError::Other(format!(
                    "pass `{}` is skipped but no `{}` of its shape was kept",
                    pass.name, info.name
                ))
            })
        })
        .collect()
}
