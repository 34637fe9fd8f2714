//! [`GpuBackend::dispatch`]: one pass on the device, in named phases — its layout (what it binds per
//! pixel, the binding plan, the bands of rows: [`PassLayout`]), the device resources it binds
//! ([`PassBindings`]: storage, counter blocks, the params uniform, bind groups), then per chunk of
//! samples the frame uniforms, the recorded commands ([`GpuBackend::submit_chunk`]) and the rays
//! and time they counted.

use std::sync::Arc;
use std::time::Instant;

use wedge_graph::Pass;

use super::bands::{self, Band, BindLimits};
use super::shaders::{self, BindingPlan};
use super::{gpu_err, DispatchTime, GpuBackend, KernelPipeline, COUNTER_BLOCK, WORKGROUP};
use crate::kernel::{Access, Binding, Reach};
use crate::{BackendError, Job, RayCounts};

/// What one pass binds per pixel and how its rows are split into bands.
struct PassLayout {
    bindings: Vec<Binding>,
    plan: BindingPlan,
    /// Packed plan: each binding's region (in elements per pixel) in the packed inputs or outputs,
    /// and those buffers' elements per pixel.
    packed_offsets: Vec<u64>,
    packed_in: u64,
    packed_out: u64,
    bands: Vec<Band>,
    /// Bit `k` set where binding `k` is bound (the frame uniform's `bound`).
    bound: u32,
}

impl PassLayout {
    fn components(&self, k: usize) -> u64 {
        self.bindings[k].format.components() as u64
    }

    fn bytes_per_pixel(&self, k: usize) -> u64 {
        self.components(k) * 4
    }
}

/// The device resources a pass binds for all its chunks.
struct PassBindings {
    /// Packed plan: one staging buffer for all inputs and one for all outputs.
    packed_inputs: Option<wgpu::Buffer>,
    packed_outputs: Option<wgpu::Buffer>,
    /// One counter block per band, `stride` bytes apart.
    counters: wgpu::Buffer,
    stride: u64,
    params: wgpu::Buffer,
    scene_group: Option<wgpu::BindGroup>,
    /// Group 1 (the bindings) per band.
    buffer_groups: Vec<wgpu::BindGroup>,
}

impl GpuBackend {
    /// Run one pass with its declared bindings mapped to device buffers (`None` = unbound optional):
    /// one dispatch per band of rows ([`bands::plan`]; one band unless the bindings exceed the
    /// device's limit), and for a chunked sampling kernel one round of them per chunk of samples.
    /// Returns its time, the rays it counted, its band count and binding plan.
    pub(super) fn dispatch(
        &mut self,
        job: &Job<'_>,
        pass: &Pass,
        buffers: &[Option<wgpu::Buffer>],
    ) -> Result<(DispatchTime, RayCounts, usize, BindingPlan), BackendError> {
        let kernel = job.kernels.get(&pass.kernel).expect("checked").clone();
        let src = Self::wgsl_of(kernel.as_ref())?;
        let (uniforms, reach) = Self::uniforms(job, pass, &src)?;
        let (p, src, plan) = self.pipeline(kernel.as_ref(), &uniforms)?;
        let what = format!("pass `{}` (kernel `{}`)", pass.name, pass.kernel);
        let layout = self.pass_layout(job, pass, kernel.bindings(), buffers, plan, reach, &what)?;
        let bound = self.pass_bindings(buffers, &layout, &p, &uniforms.words(), &what)?;
        // A chunked sampling kernel takes at most `samples_per_dispatch` samples per pixel per
        // dispatch; the next chunk runs while some pixel still has samples left.
        let chunk = if src.chunked { self.samples_per_dispatch.min(src.max_chunk) } else { u32::MAX };
        let mut rays = RayCounts::default();
        let mut time = DispatchTime { seconds: 0.0, from_timestamps: self.timestamps.is_some() };
        let mut chunk_begin = 0u32;
        loop {
            let chunk_end = chunk_begin.saturating_add(chunk);
            let start = Instant::now();
            let frames = self.frame_uniforms(job, &layout, (chunk_begin, chunk_end))?;
            self.scoped(&what, || self.submit_chunk(job, pass, &p, buffers, &layout, &bound, &frames))?;
            self.wait(&what)?;
            let wall = start.elapsed().as_secs_f64();
            let (counted, remaining) = self.read_counters(&bound.counters, layout.bands.len(), bound.stride)?;
            rays.add(&counted);
            self.add_chunk_time(&mut time, wall, &what)?;
            if remaining == 0 || chunk_end == u32::MAX {
                break;
            }
            chunk_begin = chunk_end;
        }
        Ok((time, rays, layout.bands.len(), plan))
    }

    /// Phase 1: the pass's layout — per-sample buffers only on the direct plan and in one band, the
    /// widest per-pixel binding (or packed buffer), the workgroup limit, the bands.
    #[allow(clippy::too_many_arguments)]
    fn pass_layout(
        &self,
        job: &Job<'_>,
        pass: &Pass,
        bindings: Vec<Binding>,
        buffers: &[Option<wgpu::Buffer>],
        plan: BindingPlan,
        reach: Reach,
        what: &str,
    ) -> Result<PassLayout, BackendError> {
        if buffers.len() > 32 {
            return Err(gpu_err(format!("kernel `{}` declares more than 32 bindings", pass.kernel)));
        }
        // Elements per pixel of each bound binding (per-sample buffers, `BufferInfo::layers`).
        let layers = |k: usize| {
            let id = match bindings[k].access {
                Access::Read => pass.read(bindings[k].name),
                Access::Write => pass.write(bindings[k].name),
            };
            id.and_then(|id| job.schedule.buffers.get(id.0)).map_or(1, |b| u64::from(b.layers))
        };
        let layered: Vec<&str> =
            (0..buffers.len()).filter(|&k| buffers[k].is_some() && layers(k) > 1).map(|k| bindings[k].name).collect();
        if !layered.is_empty() && plan == BindingPlan::Packed {
            return Err(gpu_err(format!(
                "{what}: binds per-sample buffers ({}), which the packed binding plan this device needs (too few storage \
                 buffers per shader stage) does not support; run it with --backend cpu or on a device with more storage bindings",
                layered.join(", ")
            )));
        }
        let (packed_offsets, packed_in, packed_out) = shaders::packed_layout(&bindings);
        // What one band binds per pixel: the widest buffer, or (packed) the larger packed buffer.
        let widest = match plan {
            BindingPlan::Direct => (0..buffers.len())
                .filter(|&k| buffers[k].is_some())
                .map(|k| bindings[k].format.components() as u64 * 4 * layers(k))
                .max()
                .unwrap_or(4),
            BindingPlan::Packed => packed_in.max(packed_out).max(1) * 4,
        };
        let max_groups = self.shared.limits.max_compute_workgroups_per_dimension;
        if job.width.div_ceil(WORKGROUP) > max_groups {
            return Err(gpu_err(format!(
                "{what}: {} pixels per row need {} workgroups, over this device's max_compute_workgroups_per_dimension ({max_groups})",
                job.width,
                job.width.div_ceil(WORKGROUP)
            )));
        }
        let limits = BindLimits {
            max_binding: self.max_binding,
            offset_alignment: self.shared.limits.min_storage_buffer_offset_alignment as u64,
            max_rows: max_groups.saturating_mul(WORKGROUP),
        };
        let bands =
            bands::plan(job.width, job.height, widest, reach, &limits).map_err(|e| gpu_err(format!("{what}: {e}")))?;
        if !layered.is_empty() && bands.len() > 1 {
            // Bands are offsets of whole pixels into image buffers; a kernel reading per-sample
            // buffers declares `Reach::Image` (its samples are read from anywhere).
            return Err(gpu_err(format!(
                "{what}: binds per-sample buffers ({}) and would be split into bands of rows; declare Reach::Image",
                layered.join(", ")
            )));
        }
        let bound = buffers.iter().enumerate().fold(0u32, |m, (k, b)| if b.is_some() { m | (1 << k) } else { m });
        Ok(PassLayout { bindings, plan, packed_offsets, packed_in, packed_out, bands, bound })
    }

    /// Phase 2: the storage each binding uses (the buffer, a dummy for an unbound optional one, or
    /// the packed staging buffers as large as the largest band's window), the counter blocks, the
    /// params uniform, and the bind groups of the scene (group 2) and of each band's bindings
    /// (group 1).
    fn pass_bindings(
        &mut self,
        buffers: &[Option<wgpu::Buffer>],
        layout: &PassLayout,
        p: &Arc<KernelPipeline>,
        words: &[u32],
        what: &str,
    ) -> Result<PassBindings, BackendError> {
        let largest_window = layout.bands.iter().map(|b| b.end - b.first).max().unwrap_or(0);
        let mut bufs = Vec::with_capacity(buffers.len());
        let mut packed: Vec<wgpu::Buffer> = Vec::new();
        match layout.plan {
            BindingPlan::Direct => {
                for (k, b) in buffers.iter().enumerate() {
                    bufs.push(match b {
                        Some(b) => b.clone(),
                        None => self.dummy(k)?,
                    });
                }
            }
            BindingPlan::Packed => {
                if layout.packed_in > 0 {
                    packed.push(self.storage("packed inputs", largest_window * layout.packed_in * 4)?);
                }
                if layout.packed_out > 0 {
                    packed.push(self.storage("packed outputs", largest_window * layout.packed_out * 4)?);
                }
            }
        }
        // One counter block (8 × u32, see shaders/common.wgsl) per band, each at an aligned offset;
        // summed in 64 bits after each dispatch. Cleared before each submission, so a kept one from
        // an earlier dispatch serves as well.
        let stride = (self.shared.limits.min_storage_buffer_offset_alignment as u64).max(COUNTER_BLOCK);
        let counters_size = stride * layout.bands.len() as u64;
        let counters = self.scratch(("counters", 0), counters_size, || self.storage("counters", counters_size))?;
        let params = self.uniform_buffer("params", 0, words)?;
        let (scene_group, buffer_groups) =
            self.scoped(what, || (self.scene_group(p), self.buffer_groups(p, buffers, layout, &bufs, &packed)))?;
        Ok(PassBindings {
            packed_inputs: if layout.packed_in > 0 { packed.first().cloned() } else { None },
            packed_outputs: if layout.packed_out > 0 { packed.last().cloned() } else { None },
            counters,
            stride,
            params,
            scene_group,
            buffer_groups,
        })
    }

    /// Group 2: the scene's data and layout, where the kernel reads the scene.
    fn scene_group(&self, p: &KernelPipeline) -> Option<wgpu::BindGroup> {
        match (&p.g2, &self.scene) {
            (Some(layout), Some(s)) => Some(self.shared.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("scene"),
                layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: s.data.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 1, resource: s.layout.as_entire_binding() },
                ],
            })),
            _ => None,
        }
    }

    /// Group 1 per band: each binding's window of rows (the whole buffer when one band covers the
    /// image), or the packed staging buffers.
    fn buffer_groups(
        &self,
        p: &KernelPipeline,
        buffers: &[Option<wgpu::Buffer>],
        layout: &PassLayout,
        bufs: &[wgpu::Buffer],
        packed: &[wgpu::Buffer],
    ) -> Vec<wgpu::BindGroup> {
        let bands = &layout.bands;
        bands
            .iter()
            .map(|&Band { first, end, .. }| {
                let entries: Vec<_> = match layout.plan {
                    BindingPlan::Direct => bufs
                        .iter()
                        .enumerate()
                        .map(|(k, b)| {
                            let resource = match &buffers[k] {
                                Some(_) if bands.len() > 1 => wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                                    buffer: b,
                                    offset: first * layout.bytes_per_pixel(k),
                                    size: wgpu::BufferSize::new((end - first) * layout.bytes_per_pixel(k)),
                                }),
                                _ => b.as_entire_binding(),
                            };
                            wgpu::BindGroupEntry { binding: k as u32, resource }
                        })
                        .collect(),
                    BindingPlan::Packed => packed
                        .iter()
                        .enumerate()
                        .map(|(k, b)| wgpu::BindGroupEntry { binding: k as u32, resource: b.as_entire_binding() })
                        .collect(),
                };
                self.shared.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("buffers"),
                    layout: &p.g1,
                    entries: &entries,
                })
            })
            .collect()
    }

    /// Phase 3, per chunk: one frame uniform per band (shaders/common.wgsl `Frame`), kept across
    /// chunks, dispatches and runs.
    fn frame_uniforms(
        &self,
        job: &Job<'_>,
        layout: &PassLayout,
        (chunk_begin, chunk_end): (u32, u32),
    ) -> Result<Vec<wgpu::Buffer>, BackendError> {
        layout
            .bands
            .iter()
            .enumerate()
            .map(|(n, &Band { row0, row_end, first, end })| {
                let frame = [
                    job.width,
                    job.height,
                    job.seed,
                    layout.bound,
                    f32::INFINITY.to_bits(),
                    0x3f80_0800,
                    0x3f80_1000,
                    row0,
                    row_end,
                    first as u32,
                    chunk_begin,
                    chunk_end,
                    (end - first) as u32,
                    job.frame,
                    job.window.x0,
                    job.window.y0,
                    job.window.full_width,
                    job.window.full_height,
                    0,
                    0,
                ];
                self.uniform_buffer("frame", n as u64, &frame)
            })
            .collect()
    }

    /// Phase 4, per chunk: record and submit the chunk's commands — the counters cleared, then per
    /// band the packed inputs staged, the compute pass (timed from the first band to the last) and
    /// the packed outputs copied back; the timestamps resolved.
    #[allow(clippy::too_many_arguments)]
    fn submit_chunk(
        &self,
        job: &Job<'_>,
        pass: &Pass,
        p: &KernelPipeline,
        buffers: &[Option<wgpu::Buffer>],
        layout: &PassLayout,
        bound: &PassBindings,
        frames: &[wgpu::Buffer],
    ) {
        let frame_groups: Vec<_> = frames.iter().enumerate().map(|(n, f)| self.frame_group(p, bound, n, f)).collect();
        let mut enc =
            self.shared.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(&pass.name) });
        enc.clear_buffer(&bound.counters, 0, None);
        let last = layout.bands.len() - 1;
        for (n, ((g0, g1), band)) in frame_groups.iter().zip(&bound.buffer_groups).zip(&layout.bands).enumerate() {
            if layout.plan == BindingPlan::Packed {
                Self::stage_packed_inputs(&mut enc, buffers, layout, bound, band);
            }
            {
                // The first band's pass starts the timer and the last one stops it.
                let ts = self.timestamps.as_ref().filter(|_| n == 0 || n == last).map(|(qs, _)| {
                    wgpu::ComputePassTimestampWrites {
                        query_set: qs,
                        beginning_of_pass_write_index: (n == 0).then_some(0),
                        end_of_pass_write_index: (n == last).then_some(1),
                    }
                });
                let mut cp = enc
                    .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(&pass.name), timestamp_writes: ts });
                cp.set_pipeline(&p.pipeline);
                if let Some(g2) = &bound.scene_group {
                    cp.set_bind_group(2, g2, &[]);
                }
                cp.set_bind_group(0, g0, &[]);
                cp.set_bind_group(1, g1, &[]);
                cp.dispatch_workgroups(
                    job.width.div_ceil(WORKGROUP),
                    (band.row_end - band.row0).div_ceil(WORKGROUP),
                    1,
                );
            }
            if layout.plan == BindingPlan::Packed {
                Self::copy_packed_outputs(&mut enc, job, buffers, layout, bound, band);
            }
        }
        if let Some((qs, resolve)) = &self.timestamps {
            enc.resolve_query_set(qs, 0..2, resolve, 0);
        }
        self.shared.queue.submit([enc.finish()]);
    }

    /// Group 0 of band `n`: its frame uniform, the params, its counter block.
    fn frame_group(&self, p: &KernelPipeline, bound: &PassBindings, n: usize, frame: &wgpu::Buffer) -> wgpu::BindGroup {
        self.shared.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("frame"),
            layout: &p.g0,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: frame.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: bound.params.as_entire_binding() },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: &bound.counters,
                        offset: n as u64 * bound.stride,
                        size: wgpu::BufferSize::new(COUNTER_BLOCK),
                    }),
                },
            ],
        })
    }

    /// Packed plan: fill every bound binding's region with the band's window — inputs, and outputs
    /// too (a resuming kernel reads them; unwritten pixels keep their value).
    fn stage_packed_inputs(
        enc: &mut wgpu::CommandEncoder,
        buffers: &[Option<wgpu::Buffer>],
        layout: &PassLayout,
        bound: &PassBindings,
        band: &Band,
    ) {
        let window = band.end - band.first;
        for (k, b) in buffers.iter().enumerate() {
            let staging =
                if layout.bindings[k].access == Access::Read { &bound.packed_inputs } else { &bound.packed_outputs };
            let (Some(b), Some(dst)) = (b, staging) else {
                continue;
            };
            let c = layout.components(k);
            enc.copy_buffer_to_buffer(
                b,
                band.first * c * 4,
                dst,
                layout.packed_offsets[k] * window * 4,
                window * c * 4,
            );
        }
    }

    /// Packed plan: copy back the rows this band computed (not its halo) into each written binding.
    fn copy_packed_outputs(
        enc: &mut wgpu::CommandEncoder,
        job: &Job<'_>,
        buffers: &[Option<wgpu::Buffer>],
        layout: &PassLayout,
        bound: &PassBindings,
        band: &Band,
    ) {
        let Some(src) = &bound.packed_outputs else { return };
        let window = band.end - band.first;
        let own = band.row0 as u64 * job.width as u64 - band.first;
        let rows = (band.row_end - band.row0) as u64 * job.width as u64;
        for (k, b) in buffers.iter().enumerate() {
            let Some(b) = b else { continue };
            if layout.bindings[k].access != Access::Write {
                continue;
            }
            let c = layout.components(k);
            enc.copy_buffer_to_buffer(
                src,
                (layout.packed_offsets[k] * window + own * c) * 4,
                b,
                band.row0 as u64 * job.width as u64 * c * 4,
                rows * c * 4,
            );
        }
    }

    /// Phase 5, per chunk: its time — the device's timestamps where the adapter gives them (a zero
    /// span means it did not), else the wall clock `wall`.
    fn add_chunk_time(&self, time: &mut DispatchTime, wall: f64, what: &str) -> Result<(), BackendError> {
        let device_seconds = match &self.timestamps {
            Some((_, resolve)) => {
                let bytes = self.read_bytes(what, resolve, 16)?;
                let t: Vec<u64> = bytemuck::pod_collect_to_vec(&bytes);
                t[1].saturating_sub(t[0]) as f64 * self.shared.queue.get_timestamp_period() as f64 * 1e-9
            }
            None => 0.0,
        };
        if device_seconds > 0.0 {
            time.seconds += device_seconds;
        } else {
            time.seconds += wall;
            time.from_timestamps = false;
        }
        Ok(())
    }
}
