//! The CPU backend: runs each scheduled pass with rayon. Buffers live in physical slots assigned by
//! the schedule's pool plan, so intermediates whose lifetimes do not overlap share storage.
//!
//! The pool persists (issue 38 §2): a backend kept across frames holds each slot's storage after a
//! run, and a pass is offered what its output's slot held before ([`KernelCtx::output_vec`]), so
//! kernels that write in place allocate nothing after the first frame. A slot whose format or size
//! changed (another schedule or image size) gets fresh storage: the plan is re-made as it goes.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Instant;

use wedge_graph::{BufferId, Pass};

use crate::buffer::BufferData;
use crate::kernel::{Counters, KernelCtx};
use crate::{Backend, BackendError, Job, PassTiming, RunResult};

#[derive(Default)]
pub struct CpuBackend {
    /// Each pool slot's storage at the end of the last run, offered to the next run's writers.
    spare: Vec<Option<BufferData>>,
}

impl CpuBackend {
    pub fn new() -> Self {
        CpuBackend::default()
    }
}

/// The previous run's storage of each slot of `job`'s plan, kept where its format and length still fit.
fn spare_for(job: &Job<'_>, mut spare: Vec<Option<BufferData>>) -> Vec<Option<BufferData>> {
    let sched = job.schedule;
    spare.resize_with(sched.slot_formats.len(), || None);
    for (s, held) in spare.iter_mut().enumerate() {
        let len = job.width as usize * job.height as usize * sched.slot_layers[s] as usize;
        if held.as_ref().is_some_and(|b| b.format() != sched.slot_formats[s] || b.len() != len) {
            *held = None;
        }
    }
    spare
}

/// Previous-frame buffer `h` for this run, copied into `spare` where it fits; `true` if it did (no
/// fresh allocation).
fn history_into(
    job: &Job<'_>,
    history: &BTreeMap<BufferId, BufferData>,
    h: &wedge_graph::History,
    spare: Option<BufferData>,
) -> (BufferData, bool) {
    match (spare, history.get(&h.buffer)) {
        (Some(mut into), Some(from)) if from.format() == into.format() && from.len() == into.len() => {
            into.copy_from(from);
            (into, true)
        }
        _ => (crate::history_input(job, history, h), false),
    }
}

/// Check a pass's bindings against its kernel's declaration (see [`KernelRegistry::check_pass`]);
/// every backend calls it so they reject the same passes.
pub fn check_bindings(job: &Job<'_>, pass: &Pass) -> Result<(), BackendError> {
    job.kernels.check_pass(job.schedule, pass)
}

/// Run one pass on the CPU with the given input buffers; returns its outputs by binding name. The
/// parity harness uses this to run a pass in isolation.
pub fn run_pass(
    job: &Job<'_>,
    pass: &Pass,
    inputs: &BTreeMap<BufferId, &BufferData>,
    counters: &Counters,
) -> Result<BTreeMap<String, BufferData>, BackendError> {
    Ok(run_pass_recycled(job, pass, inputs, counters, BTreeMap::new())?.into_iter().map(|(n, (d, _))| (n, d)).collect())
}

/// [`run_pass`] offering `spare` storage (write binding → buffer) for the outputs; each output comes
/// back with whether it was written into spare storage (`true`) or freshly allocated.
fn run_pass_recycled(
    job: &Job<'_>,
    pass: &Pass,
    inputs: &BTreeMap<BufferId, &BufferData>,
    counters: &Counters,
    spare: BTreeMap<String, BufferData>,
) -> Result<BTreeMap<String, (BufferData, bool)>, BackendError> {
    check_bindings(job, pass)?;
    let kernel = job.kernels.get(&pass.kernel).expect("checked");
    let mut reads = BTreeMap::new();
    for (name, id) in &pass.reads {
        let b = inputs.get(id).ok_or_else(|| BackendError::Binding {
            pass: pass.name.clone(),
            binding: name.clone(),
            message: format!("reads `{}`, which holds no data", job.schedule.buffers[id.0].name),
        })?;
        reads.insert(name.clone(), *b);
    }
    let writes = pass.writes.iter().map(|(n, _)| (n.clone(), None)).collect();
    let mut ctx = KernelCtx::for_pass(job, pass, counters, reads, writes).with_recycled(spare);
    kernel.run_cpu(&mut ctx)?;
    let reused: Vec<bool> = ctx.writes.keys().map(|name| ctx.reused(name)).collect();
    let mut out = BTreeMap::new();
    for ((name, data), reused) in ctx.writes.into_iter().zip(reused) {
        let data = data.ok_or_else(|| BackendError::Binding {
            pass: pass.name.clone(),
            binding: name.clone(),
            message: "was bound but the kernel wrote nothing to it".into(),
        })?;
        out.insert(name, (data, reused));
    }
    Ok(out)
}

impl Backend for CpuBackend {
    fn name(&self) -> &'static str {
        "cpu"
    }

    fn run_frame(
        &mut self,
        job: &Job<'_>,
        history: &BTreeMap<BufferId, BufferData>,
    ) -> Result<RunResult, BackendError> {
        let sched = job.schedule;
        let mut rays = crate::RayCounts::default();
        // Physical storage, indexed by pool slot; a slot holds the buffer currently living in it, and
        // `spare` the storage the previous run left there.
        let mut slots: Vec<Option<(BufferId, BufferData)>> = vec![None; sched.slot_formats.len()];
        let mut spare = spare_for(job, std::mem::take(&mut self.spare));
        // Buffers freshly allocated in this run (not written into a slot's earlier storage).
        let mut allocations = 0usize;
        // Previous-frame buffers are there before the first pass.
        for h in &sched.history {
            let slot = sched.slots[h.buffer.0].expect("a scheduled previous-frame buffer has a slot");
            let (data, reused) = history_into(job, history, h, spare[slot].take());
            allocations += usize::from(!reused);
            slots[slot] = Some((h.buffer, data));
        }
        let mut timings = Vec::with_capacity(sched.passes.len());
        for pass in &sched.passes {
            let start = Instant::now();
            let counters = Counters::default();
            // What each output's slot held before: a buffer whose lifetime has ended (a slot is only
            // reused after its last reader, never by a pass reading it), else the last run's storage.
            let mut offered = BTreeMap::new();
            for (binding, id) in &pass.writes {
                let slot = sched.slots[id.0].expect("scheduled buffer has a slot");
                if let Some(b) = slots[slot].take().map(|(_, b)| b).or_else(|| spare[slot].take()) {
                    offered.insert(binding.clone(), b);
                }
            }
            let outputs = {
                let mut inputs = BTreeMap::new();
                for (_, id) in &pass.reads {
                    let slot = sched.slots[id.0].expect("scheduled buffer has a slot");
                    match &slots[slot] {
                        Some((held, data)) if held == id => {
                            inputs.insert(*id, data);
                        }
                        _ => {
                            return Err(BackendError::Other(format!(
                                "pass `{}` reads `{}` after its storage was reused (pool plan bug)",
                                pass.name, sched.buffers[id.0].name
                            )))
                        }
                    }
                }
                run_pass_recycled(job, pass, &inputs, &counters, offered)?
            };
            for (binding, (data, reused)) in outputs {
                let id = pass.write(&binding).expect("bound");
                let slot = sched.slots[id.0].expect("scheduled buffer has a slot");
                // At most `slot_formats.len()` buffers are alive between passes; storage a kernel
                // did not take (it `put` a Vec of its own) was dropped with its context.
                allocations += usize::from(!reused);
                slots[slot] = Some((id, data));
            }
            let kernel = job.kernels.get(&pass.kernel).expect("checked");
            let counts = counters.snapshot();
            rays.add(&counts);
            timings.push(PassTiming {
                pass: pass.name.clone(),
                kernel: pass.kernel.clone(),
                class: kernel.class(),
                seconds: start.elapsed().as_secs_f64(),
                counts,
            });
            job.progress.pass_done(&pass.name);
        }
        let mut outputs = BTreeMap::new();
        for (node, port, id) in &sched.sink_inputs {
            let slot = sched.slots[id.0].expect("sink buffer has a slot");
            match &slots[slot] {
                Some((held, data)) if held == id => {
                    outputs.insert((node.clone(), port.clone()), data.clone());
                }
                _ => return Err(BackendError::Other(format!("sink input `{node}.{port}` was overwritten"))),
            }
        }
        let mut next = BTreeMap::new();
        for h in &sched.history {
            let slot = sched.slots[h.source.0].expect("a previous-frame source has a slot");
            match &slots[slot] {
                Some((held, data)) if *held == h.source => {
                    next.insert(h.buffer, data.clone());
                }
                _ => {
                    return Err(BackendError::Other(format!(
                        "`{}` was overwritten before the run ended",
                        sched.buffers[h.source.0].name
                    )))
                }
            }
        }
        // Outputs and history were handed back as copies (the caller keeps them: a sink's buffer goes
        // to the image writers, history into the next frame); the storage stays for the next run.
        self.spare = slots.into_iter().map(|s| s.map(|(_, b)| b)).collect();
        Ok(RunResult { outputs, sinks: Default::default(), timings, rays, allocations, history: next })
    }
}

/// Every buffer a run held, by buffer name (names are stable across rebuilds of a pipeline, ids
/// are not): what [`CpuBackend::run_partial`] keeps for the next change. Shared, not copied: a
/// partial run's skipped passes hand their kept buffers on as they are.
pub type KeptBuffers = BTreeMap<String, Arc<BufferData>>;

impl crate::PartialRun for CpuBackend {
    type Kept = KeptBuffers;

    /// See [`crate::PartialRun::run_partial`]. This runs outside the pool (its buffers outlive the
    /// run), so it is for the viewer's first frame after a change, not for every frame.
    fn run_partial(
        &mut self,
        job: &Job<'_>,
        history: &BTreeMap<BufferId, BufferData>,
        kept: &KeptBuffers,
        rerun: &[bool],
    ) -> Result<(RunResult, KeptBuffers), BackendError> {
        let sched = job.schedule;
        let mut held: BTreeMap<BufferId, Arc<BufferData>> =
            sched.history.iter().map(|h| (h.buffer, Arc::new(crate::history_input(job, history, h)))).collect();
        let (mut rays, mut timings, mut allocations) = (crate::RayCounts::default(), Vec::new(), 0);
        for (pass, run) in crate::partial::passes_to_run(job, rerun) {
            if !run {
                held.extend(crate::partial::kept_outputs(job, pass, kept)?);
                continue;
            }
            let start = Instant::now();
            let counters = Counters::default();
            let outputs = run_pass(job, pass, &held.iter().map(|(id, d)| (*id, &**d)).collect(), &counters)?;
            allocations += outputs.len();
            for (binding, data) in outputs {
                held.insert(pass.write(&binding).expect("bound"), Arc::new(data));
            }
            let counts = counters.snapshot();
            rays.add(&counts);
            let class = job.kernels.get(&pass.kernel).expect("checked").class();
            let (name, kernel) = (pass.name.clone(), pass.kernel.clone());
            timings.push(PassTiming { pass: name, kernel, class, seconds: start.elapsed().as_secs_f64(), counts });
            job.progress.pass_done(&pass.name);
        }
        let take = |id: &BufferId, what: &str| {
            held.get(id)
                .map(|d| BufferData::clone(d))
                .ok_or_else(|| BackendError::Other(format!("{what} `{}` holds no data", sched.buffers[id.0].name)))
        };
        let mut outputs = BTreeMap::new();
        for (node, port, id) in &sched.sink_inputs {
            outputs.insert((node.clone(), port.clone()), take(id, "sink input")?);
        }
        let mut next = BTreeMap::new();
        for h in &sched.history {
            next.insert(h.buffer, take(&h.source, "previous-frame source")?);
        }
        let run = RunResult { outputs, sinks: Default::default(), timings, rays, allocations, history: next };
        let all = held.into_iter().map(|(id, data)| (sched.buffers[id.0].name.clone(), data)).collect();
        Ok((run, all))
    }
}
