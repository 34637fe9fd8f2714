//! One kernel run outside any pipeline: a one-pass schedule built from the kernel's own declared
//! bindings. For tests and for user crates trying a new kernel on both backends (parity of a lone
//! kernel before it is wired into a node), so nobody rebuilds a `Schedule` by hand.

use std::collections::BTreeMap;
use std::sync::Arc;

use wedge_graph::{BufferId, BufferInfo, Lifetime, ParamValue, Pass, Schedule, Stage};
use wedge_scene::Scene;

use crate::buffer::BufferData;
use crate::gpu::GpuBackend;
use crate::kernel::{Access, Counters, Kernel, KernelRegistry, RayCounts, Silent};
use crate::{BackendError, Job};

/// A kernel bound to named inputs and a parameter block, ready to run on either backend.
pub struct LonePass<'a> {
    pub schedule: Schedule,
    pub pass: Pass,
    pub kernels: KernelRegistry,
    /// The given inputs by the buffer id the pass reads them as.
    pub inputs: BTreeMap<BufferId, &'a BufferData>,
}

impl<'a> LonePass<'a> {
    /// Bind every given input to the kernel's read binding of that name and every write binding to a
    /// fresh buffer. A required input that is not given is an error naming it; optional ones stay
    /// unbound. A random kernel's pass is declared random; its `stream` is then given in `params`.
    pub fn new<K: AsRef<str> + Ord>(
        kernel: Arc<dyn Kernel>,
        params: BTreeMap<String, ParamValue>,
        inputs: &'a BTreeMap<K, BufferData>,
    ) -> Result<LonePass<'a>, BackendError> {
        let by_name: BTreeMap<&str, &'a BufferData> = inputs.iter().map(|(k, v)| (k.as_ref(), v)).collect();
        let mut pass = Pass::new(kernel.name(), "lone", kernel.name(), Stage::Sample);
        pass.random = kernel.draws_random();
        pass.params = params;
        let (mut buffers, mut data) = (Vec::new(), BTreeMap::new());
        for b in kernel.bindings() {
            let id = BufferId(buffers.len());
            match b.access {
                Access::Read => match by_name.get(b.name) {
                    Some(d) => {
                        pass.reads.push((b.name.to_string(), id));
                        data.insert(id, *d);
                    }
                    None if b.optional => continue,
                    None => {
                        return Err(BackendError::Binding {
                            pass: kernel.name().to_string(),
                            binding: b.name.to_string(),
                            message: "a required input of the kernel was not given".into(),
                        })
                    }
                },
                Access::Write => pass.writes.push((b.name.to_string(), id)),
            }
            buffers.push(BufferInfo::new(b.name, b.format));
        }
        let n = buffers.len();
        let schedule = Schedule {
            passes: vec![pass.clone()],
            buffers,
            lifetimes: vec![Some(Lifetime { first: 0, last: 0 }); n],
            slots: (0..n).map(Some).collect(),
            slot_formats: Vec::new(),
            slot_layers: Vec::new(),
            sink_inputs: Vec::new(),
            history: Vec::new(),
            culled: Vec::new(),
        };
        let mut kernels = KernelRegistry::new();
        kernels.register(kernel);
        Ok(LonePass { schedule, pass, kernels, inputs: data })
    }

    /// Declare binding `binding` a per-sample buffer of `layers` elements per pixel
    /// ([`wedge_graph::BufferInfo::layers`]); bindings are images otherwise.
    pub fn with_layers(mut self, binding: &str, layers: u32) -> Self {
        for (name, id) in self.pass.reads.iter().chain(&self.pass.writes) {
            if name == binding {
                self.schedule.buffers[id.0].layers = layers.max(1);
            }
        }
        self
    }

    /// The job the pass runs in: `scene`, image size and seed.
    pub fn job<'s>(&'s self, scene: &'s Scene, width: u32, height: u32, seed: u32) -> Job<'s> {
        Job {
            schedule: &self.schedule,
            scene,
            kernels: &self.kernels,
            width,
            height,
            seed,
            frame: 0,
            progress: &Silent,
            window: crate::Window::whole(width, height),
        }
    }

    /// Run on the CPU backend: every write binding by name, and the ray counters.
    pub fn run_cpu(
        &self,
        scene: &Scene,
        width: u32,
        height: u32,
        seed: u32,
    ) -> Result<(BTreeMap<String, BufferData>, RayCounts), BackendError> {
        let counters = Counters::default();
        let out = crate::cpu::run_pass(&self.job(scene, width, height, seed), &self.pass, &self.inputs, &counters)?;
        Ok((out, counters.snapshot()))
    }

    /// Run on the wgpu backend: every write binding by name, and the ray counters.
    pub fn run_gpu(
        &self,
        gpu: &mut GpuBackend,
        scene: &Scene,
        width: u32,
        height: u32,
        seed: u32,
    ) -> Result<(BTreeMap<String, BufferData>, RayCounts), BackendError> {
        let (out, _, rays) = gpu.run_pass(&self.job(scene, width, height, seed), &self.pass, &self.inputs)?;
        Ok((out, rays))
    }
}
