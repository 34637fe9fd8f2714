//! The CPU backend: runs each scheduled pass with rayon. Buffers live in physical slots assigned by
//! the schedule's pool plan, so intermediates whose lifetimes do not overlap share storage.

use std::collections::BTreeMap;
use std::time::Instant;

use wedge_graph::{BufferId, Pass};

use crate::buffer::BufferData;
use crate::kernel::{Counters, KernelCtx};
use crate::{Backend, BackendError, Job, PassTiming, RunResult};

#[derive(Default)]
pub struct CpuBackend;

impl CpuBackend {
    pub fn new() -> Self {
        CpuBackend
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
    let mut ctx = KernelCtx::for_pass(job, pass, counters, reads, writes);
    kernel.run_cpu(&mut ctx)?;
    let mut out = BTreeMap::new();
    for (name, data) in ctx.writes {
        let data = data.ok_or_else(|| BackendError::Binding {
            pass: pass.name.clone(),
            binding: name.clone(),
            message: "was bound but the kernel wrote nothing to it".into(),
        })?;
        out.insert(name, data);
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
        // Physical storage, indexed by pool slot; a slot holds the buffer currently living in it.
        let mut slots: Vec<Option<(BufferId, BufferData)>> = vec![None; sched.slot_formats.len()];
        let mut allocations = 0usize;
        // Previous-frame buffers are there before the first pass.
        for h in &sched.history {
            let slot = sched.slots[h.buffer.0].expect("a scheduled previous-frame buffer has a slot");
            slots[slot] = Some((h.buffer, crate::history_input(job, history, h)));
            allocations += 1;
        }
        let mut timings = Vec::with_capacity(sched.passes.len());
        for pass in &sched.passes {
            let start = Instant::now();
            let counters = Counters::default();
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
                run_pass(job, pass, &inputs, &counters)?
            };
            for (binding, data) in outputs {
                let id = pass.write(&binding).expect("bound");
                let slot = sched.slots[id.0].expect("scheduled buffer has a slot");
                // A slot's previous occupant is dropped when the next buffer of its pool slot is
                // written, so at most `slot_formats.len()` buffers are alive between passes (plus
                // the outputs of the pass running). `allocations` counts slots ever filled.
                if slots[slot].is_none() {
                    allocations += 1;
                }
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
        Ok(RunResult { outputs, sinks: Default::default(), timings, rays, allocations, history: next })
    }
}
