//! Running a schedule on the device: a whole run ([`Backend::run_frame`]) with per-pixel buffers in
//! the schedule's pool slots, and a partial run ([`PartialRun::run_partial`], issue 38's `wedge
//! view`) with one device buffer per logical buffer, all kept on the device for the next change.
//!
//! Both go through one loop ([`GpuBackend::run_passes`]); they differ only in where a buffer lives
//! ([`Placement`]) and in which passes run. A partial run's skipped passes hand on the kept run's
//! `wgpu::Buffer`s as they are (no copy, no round trip through the host); the passes it runs write
//! fresh buffers, so a kept buffer is never written and the caller's earlier set stays intact. The
//! dispatches are the whole run's (same kernels, parameters, seed, frame, bands and chunks), so the
//! image is the whole run's bit for bit.

use std::collections::BTreeMap;
use std::time::Instant;

use wedge_graph::{BufferId, Format, Pass, Schedule};

use super::{gpu_err, storage_size, to_bytes, GpuBackend};
use crate::buffer::BufferData;
use crate::kernel::{Access, Counters};
use crate::partial::{kept_outputs, passes_to_run, KeptShape, PartialRun};
use crate::{Backend, BackendError, Job, PassTiming, RayCounts, RunResult};

/// A buffer a partial run keeps on the device, with the shape it was made for.
#[derive(Clone)]
pub struct DeviceBuffer {
    buffer: wgpu::Buffer,
    format: Format,
    len: usize,
}

impl KeptShape for DeviceBuffer {
    fn shape(&self) -> (Format, usize) {
        (self.format, self.len)
    }
}

/// Every buffer a partial run held, on the device, by buffer name: what the next change's
/// [`PartialRun::run_partial`] takes the skipped passes' outputs from. Only valid with the backend
/// (device) that made it.
pub type KeptBuffers = BTreeMap<String, DeviceBuffer>;

/// Bytes a kept set holds on the device.
pub fn kept_bytes(kept: &KeptBuffers) -> u64 {
    kept.values().map(|b| (b.len * b.format.components() * 4) as u64).sum()
}

/// Where a run's per-pixel buffers live.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Placement {
    /// The schedule's pool slots (`Schedule::slots`): a whole run allocates `slot_formats.len()` buffers.
    Pooled,
    /// One buffer per logical buffer, indexed by its id: a partial run, whose buffers outlive it.
    PerBuffer,
}

/// A run's device buffers as it goes: each slot's buffer and which logical buffer lives in it.
struct Slots {
    placement: Placement,
    bufs: Vec<Option<wgpu::Buffer>>,
    holder: Vec<Option<BufferId>>,
    /// Pooled: each slot's buffer from the backend's previous whole run, not yet taken by this one.
    /// Its contents are stale, like a slot's after its earlier holder's last reader: every kernel
    /// writes all of its outputs' pixels before reading them (a chunked kernel resumes only from
    /// what its own first chunk wrote), so nothing depends on a slot starting zeroed.
    spare: Vec<Option<wgpu::Buffer>>,
    /// Buffers this run allocated.
    allocations: usize,
}

impl Slots {
    /// Empty slots; `spare` is what a pooled run may write into instead of allocating (empty for
    /// [`Placement::PerBuffer`], whose buffers are never written twice).
    fn new(sched: &Schedule, placement: Placement, mut spare: Vec<Option<wgpu::Buffer>>) -> Slots {
        let n = match placement {
            Placement::Pooled => sched.slot_formats.len(),
            Placement::PerBuffer => sched.buffers.len(),
        };
        spare.resize(n, None);
        Slots { placement, bufs: vec![None; n], holder: vec![None; n], spare, allocations: 0 }
    }

    /// What the backend keeps for its next pooled run: each slot's last buffer, or the one this
    /// run did not take.
    fn into_pool(self) -> Vec<Option<wgpu::Buffer>> {
        self.bufs.into_iter().zip(self.spare).map(|(b, s)| b.or(s)).collect()
    }

    /// `slot`'s label and size in bytes (`width × height × layers` elements of its format).
    fn shape(&self, job: &Job<'_>, slot: usize) -> (String, u64) {
        let sched = job.schedule;
        let (f, n, label) = match self.placement {
            Placement::Pooled => {
                let f = sched.slot_formats[slot];
                (f, sched.slot_layers[slot], format!("pool slot {slot} ({f})"))
            }
            Placement::PerBuffer => {
                let info = &sched.buffers[slot];
                (info.format, info.layers, info.name.clone())
            }
        };
        let bytes = job.width as usize * job.height as usize * n as usize * f.components() * 4;
        (label, bytes as u64)
    }

    /// The previous run's buffer for `slot` if it has the size `bytes` asks for (else it is dropped).
    fn reuse(&mut self, slot: usize, bytes: u64) -> Option<wgpu::Buffer> {
        self.spare.get_mut(slot)?.take().filter(|b| b.size() == storage_size(bytes))
    }

    fn slot(&self, sched: &Schedule, id: BufferId) -> Result<usize, BackendError> {
        match self.placement {
            Placement::Pooled => sched.slots[id.0]
                .ok_or_else(|| gpu_err(format!("buffer `{}` has no pool slot", sched.buffers[id.0].name))),
            Placement::PerBuffer => Ok(id.0),
        }
    }

    /// The device buffer holding `id`, which `pass` reads; an error when its storage was reused.
    fn holding(&self, sched: &Schedule, pass: &Pass, id: BufferId) -> Result<&wgpu::Buffer, BackendError> {
        let slot = self.slot(sched, id)?;
        match (&self.bufs[slot], self.holder[slot] == Some(id)) {
            (Some(buf), true) => Ok(buf),
            _ => Err(BackendError::Other(format!(
                "pass `{}` reads `{}` after its storage was reused (pool plan bug)",
                pass.name, sched.buffers[id.0].name
            ))),
        }
    }

    /// A device buffer for `id` to be written: the pool slot's own (allocated on first use), or a
    /// fresh one per buffer (never a kept buffer another run may still read).
    fn for_write(&mut self, gpu: &GpuBackend, job: &Job<'_>, id: BufferId) -> Result<wgpu::Buffer, BackendError> {
        let sched = job.schedule;
        let slot = self.slot(sched, id)?;
        if self.bufs[slot].is_none() || self.placement == Placement::PerBuffer {
            let (label, bytes) = self.shape(job, slot);
            let buf = match self.reuse(slot, bytes) {
                Some(buf) => buf,
                None => {
                    self.allocations += 1;
                    gpu.storage(&label, bytes)?
                }
            };
            self.bufs[slot] = Some(buf);
        }
        self.holder[slot] = Some(id);
        Ok(self.bufs[slot].clone().expect("allocated above"))
    }

    /// Previous-frame buffer `id` uploaded as `data` into its slot: written into the previous run's
    /// buffer for that slot where it fits, else into a fresh one.
    fn upload(&mut self, gpu: &GpuBackend, job: &Job<'_>, id: BufferId, data: &[u8]) -> Result<(), BackendError> {
        let slot = self.slot(job.schedule, id)?;
        let (_, bytes) = self.shape(job, slot);
        let buf = match self.reuse(slot, bytes).filter(|b| data.len() as u64 <= b.size()) {
            Some(buf) => {
                gpu.shared.queue.write_buffer(&buf, 0, data);
                buf
            }
            None => {
                self.allocations += 1;
                gpu.storage_init(&job.schedule.buffers[id.0].name, data)?
            }
        };
        self.put(job.schedule, id, buf)
    }

    /// Put `buf` (uploaded or kept) in `id`'s slot.
    fn put(&mut self, sched: &Schedule, id: BufferId, buf: wgpu::Buffer) -> Result<(), BackendError> {
        let slot = self.slot(sched, id)?;
        (self.bufs[slot], self.holder[slot]) = (Some(buf), Some(id));
        Ok(())
    }
}

impl GpuBackend {
    /// Run the passes `rerun` marks (see [`passes_to_run`]) into `slots`, after uploading the
    /// previous-frame buffers; a skipped pass's outputs must be in `slots` already. Per-pass
    /// timings and the rays counted.
    fn run_passes(
        &mut self,
        job: &Job<'_>,
        history: &BTreeMap<BufferId, BufferData>,
        slots: &mut Slots,
        rerun: &[bool],
    ) -> Result<(Vec<PassTiming>, RayCounts), BackendError> {
        let sched = job.schedule;
        let passes: Vec<&Pass> = passes_to_run(job, rerun).filter(|(_, run)| *run).map(|(p, _)| p).collect();
        // Fail before any work if a pass cannot run here (bindings, missing WGSL, shader errors).
        if self.kernels_ready(job, &passes)? {
            self.scene_buffers(job.scene)?;
        }
        let (mut rays, mut timings) = (RayCounts::default(), Vec::with_capacity(passes.len()));
        self.last_device_times.clear();
        self.last_bands.clear();
        self.last_plans.clear();
        // Previous-frame buffers are uploaded before the first pass.
        for h in &sched.history {
            slots.upload(self, job, h.buffer, &to_bytes(&crate::history_input(job, history, h)))?;
        }
        for pass in passes {
            let kernel = job.kernels.get(&pass.kernel).expect("checked").clone();
            if kernel.host() {
                let t = self.run_host_pass(job, pass, slots)?;
                rays.add(&t.counts);
                timings.push(t);
                job.progress.pass_done(&pass.name);
                continue;
            }
            let mut bufs = Vec::new();
            for b in kernel.bindings() {
                let id = match b.access {
                    Access::Read => pass.read(b.name),
                    Access::Write => pass.write(b.name),
                };
                bufs.push(match (b.access, id) {
                    (_, None) => None,
                    (Access::Read, Some(id)) => Some(slots.holding(sched, pass, id)?.clone()),
                    (Access::Write, Some(id)) => Some(slots.for_write(self, job, id)?),
                });
            }
            let (t, counted, bands, plan) = self.dispatch(job, pass, &bufs)?;
            rays.add(&counted);
            self.last_bands.push((pass.name.clone(), bands));
            self.last_plans.push((pass.name.clone(), plan));
            if t.from_timestamps {
                self.last_device_times.push((pass.name.clone(), t.seconds));
            }
            timings.push(PassTiming {
                pass: pass.name.clone(),
                kernel: pass.kernel.clone(),
                class: kernel.class(),
                seconds: t.seconds,
                counts: counted,
            });
            job.progress.pass_done(&pass.name);
        }
        Ok((timings, rays))
    }

    /// A [`crate::Kernel::host`] pass inside a run: its inputs read back from their slots, the CPU
    /// implementation run, its outputs written into their slots.
    fn run_host_pass(&mut self, job: &Job<'_>, pass: &Pass, slots: &mut Slots) -> Result<PassTiming, BackendError> {
        let (sched, start) = (job.schedule, Instant::now());
        let mut data = BTreeMap::new();
        for (_, id) in &pass.reads {
            let info = &sched.buffers[id.0];
            let what = format!("reading `{}` for host pass `{}`", info.name, pass.name);
            data.insert(*id, self.read_logical(job, slots.holding(sched, pass, *id)?, *id, &what)?);
        }
        let inputs: BTreeMap<BufferId, &BufferData> = data.iter().map(|(k, v)| (*k, v)).collect();
        let counters = Counters::default();
        let out = crate::cpu::run_pass(job, pass, &inputs, &counters)?;
        for (binding, d) in out {
            let id = pass.write(&binding).expect("bound");
            let buf = slots.for_write(self, job, id)?;
            self.shared.queue.write_buffer(&buf, 0, &to_bytes(&d));
        }
        let kernel = job.kernels.get(&pass.kernel).expect("checked");
        Ok(PassTiming {
            pass: pass.name.clone(),
            kernel: pass.kernel.clone(),
            class: kernel.class(),
            seconds: start.elapsed().as_secs_f64(),
            counts: counters.snapshot(),
        })
    }

    /// Logical buffer `id` (its format, `width × height × layers` elements) read back from `buf`.
    fn read_logical(
        &self,
        job: &Job<'_>,
        buf: &wgpu::Buffer,
        id: BufferId,
        what: &str,
    ) -> Result<BufferData, BackendError> {
        let info = &job.schedule.buffers[id.0];
        self.read_buffer(what, buf, info.format, job.width as usize * job.height as usize * info.layers as usize)
    }

    /// The sinks' inputs and the next frame's previous-frame buffers, read back from `slots`.
    fn read_results(&self, job: &Job<'_>, slots: &Slots) -> Result<RunResult, BackendError> {
        let sched = job.schedule;
        let held = |id: BufferId| {
            let slot = slots.slot(sched, id).ok()?;
            slots.bufs[slot].as_ref().filter(|_| slots.holder[slot] == Some(id))
        };
        let mut outputs = BTreeMap::new();
        for (node, port, id) in &sched.sink_inputs {
            let buf =
                held(*id).ok_or_else(|| BackendError::Other(format!("sink input `{node}.{port}` was overwritten")))?;
            outputs.insert(
                (node.clone(), port.clone()),
                self.read_logical(job, buf, *id, &format!("reading `{node}.{port}`"))?,
            );
        }
        let mut history = BTreeMap::new();
        for h in &sched.history {
            let name = &sched.buffers[h.source.0].name;
            let buf = held(h.source)
                .ok_or_else(|| BackendError::Other(format!("`{name}` was overwritten before the run ended")))?;
            history.insert(h.buffer, self.read_logical(job, buf, h.source, &format!("reading `{name}`"))?);
        }
        let allocations = slots.allocations;
        Ok(RunResult {
            outputs,
            sinks: Default::default(),
            timings: Vec::new(),
            rays: RayCounts::default(),
            allocations,
            history,
        })
    }
}

impl Backend for GpuBackend {
    fn name(&self) -> &'static str {
        "wgpu"
    }

    fn run_frame(
        &mut self,
        job: &Job<'_>,
        history: &BTreeMap<BufferId, BufferData>,
    ) -> Result<RunResult, BackendError> {
        // The previous whole run's slot buffers are written in place; this run's are kept for the
        // next (a failed run's too: their contents never matter, only their sizes).
        let mut slots = Slots::new(job.schedule, Placement::Pooled, std::mem::take(&mut self.pool));
        let run = self.run_passes(job, history, &mut slots, &[]);
        let run = run.and_then(|(timings, rays)| Ok(RunResult { timings, rays, ..self.read_results(job, &slots)? }));
        self.pool = slots.into_pool();
        run
    }
}

impl PartialRun for GpuBackend {
    type Kept = KeptBuffers;

    /// See [`PartialRun::run_partial`]: the kept buffers stay on the device; only the sinks'
    /// inputs and the previous-frame sources are read back, as in a whole run.
    fn run_partial(
        &mut self,
        job: &Job<'_>,
        history: &BTreeMap<BufferId, BufferData>,
        kept: &KeptBuffers,
        rerun: &[bool],
    ) -> Result<(RunResult, KeptBuffers), BackendError> {
        let sched = job.schedule;
        let mut slots = Slots::new(sched, Placement::PerBuffer, Vec::new());
        for (pass, run) in passes_to_run(job, rerun) {
            if !run {
                for (id, b) in kept_outputs(job, pass, kept)? {
                    slots.put(sched, id, b.buffer)?;
                }
            }
        }
        let (timings, rays) = self.run_passes(job, history, &mut slots, rerun)?;
        let run = RunResult { timings, rays, ..self.read_results(job, &slots)? };
        let pixels = job.width as usize * job.height as usize;
        let all = slots
            .bufs
            .into_iter()
            .zip(slots.holder)
            .filter_map(|(buf, id)| {
                let (buf, info) = (buf?, &sched.buffers[id?.0]);
                let shape = DeviceBuffer { buffer: buf, format: info.format, len: pixels * info.layers as usize };
                Some((info.name.clone(), shape))
            })
            .collect();
        Ok((run, all))
    }
}
