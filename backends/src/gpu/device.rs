//! The process's wgpu devices: one per (graphics APIs, limits) choice, opened by the first
//! [`super::GpuBackend`] that asks for it and shared by every later one, **with the kernels compiled
//! on it**.
//!
//! Why shared: building a kernel's pipeline is the expensive step of a wgpu run. On Mesa's lavapipe
//! each `create_compute_pipeline` of the path tracer spends about a second in the driver's own passes
//! even with a warm shader cache (1.2–3.4 s per pipeline file at 32×24, more than the passes
//! themselves), and on real drivers it is the stutter of a first frame. A process that opens several
//! backends — a library user's renders and parity checks side by side, threads of their own, the
//! test suite — built the same kernels again for each. (wedge's own commands open one per process.) Pipelines belong to a device, so sharing them
//! means sharing the device; wgpu devices and queues are meant to be shared between threads.
//!
//! What stays per backend (in [`super::GpuBackend`]): its buffers and pools, scratch buffers, the
//! timestamp query set, binding limit, forced packing and the uniform layouts it checked. Error
//! scopes are wgpu's thread-local ones, so a validation error is reported by the call that caused
//! it. What is shared: errors wgpu reports outside any scope (none are expected; whichever backend
//! checks first reports them) and a lost device — after which the next open makes a new one.
//!
//! **Not GL.** wgpu's GL backend has one context per device, taken by every call under a lock that
//! panics when it waits over a second ("Could not lock adapter context"); two backends on one GL
//! device in two threads hit it while one compiles a kernel (`tests/parity.rs` did). Each GL backend
//! opens its own device, as before.

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use super::{gpu_err, KernelPipeline, LimitsChoice, INSTALL_HINT};
use crate::BackendError;

/// One opened device and what every backend on it shares.
pub(super) struct SharedDevice {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    pub limits: wgpu::Limits,
    /// The features the device was opened with (`TIMESTAMP_QUERY` where the adapter has it).
    pub features: wgpu::Features,
    /// Errors wgpu reported outside an error scope, and device-lost reports.
    pub errors: Arc<Mutex<Vec<String>>>,
    /// Set by the device-lost callback: a lost device is never handed out again.
    lost: Arc<AtomicBool>,
    /// Compiled kernels by the hash of their generated WGSL, binding plan and scene use
    /// (`GpuBackend::pipeline_source`).
    pub pipelines: Mutex<HashMap<u64, Arc<KernelPipeline>>>,
}

impl SharedDevice {
    /// The kernel compiled under `key`, if a backend on this device built it.
    pub fn pipeline(&self, key: u64) -> Option<Arc<KernelPipeline>> {
        self.pipelines.lock().unwrap_or_else(|e| e.into_inner()).get(&key).cloned()
    }

    pub fn keep_pipeline(&self, key: u64, pipeline: Arc<KernelPipeline>) {
        self.pipelines.lock().unwrap_or_else(|e| e.into_inner()).insert(key, pipeline);
    }
}

/// The devices opened so far (but GL's), by the graphics APIs the instance was allowed and the limits
/// asked for. Kept for the process's life: a backend opened later finds its kernels compiled.
type Opened = Vec<((wgpu::Backends, LimitsChoice), Arc<SharedDevice>)>;
static OPENED: Mutex<Opened> = Mutex::new(Vec::new());

/// The device for `backends` (`None`: what `WGPU_BACKEND` names, else all) and `choice`: the one
/// already open, unless it was lost, else a new one.
pub(super) fn shared(
    backends: Option<wgpu::Backends>,
    choice: LimitsChoice,
) -> Result<Arc<SharedDevice>, BackendError> {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    if let Some(b) = backends {
        desc.backends = b;
    }
    let key = (desc.backends, choice);
    // Held while opening, so that two threads asking at once open one device.
    let mut opened = OPENED.lock().unwrap_or_else(|e| e.into_inner());
    opened.retain(|(_, d)| !d.lost.load(Ordering::SeqCst));
    if let Some((_, d)) = opened.iter().find(|(k, _)| *k == key) {
        return Ok(d.clone());
    }
    let device = Arc::new(open(desc, choice)?);
    if device.info.backend != wgpu::Backend::Gl {
        opened.push((key, device.clone()));
    }
    Ok(device)
}

/// Open the adapter `desc` allows (high performance preference) with the limits `choice` names,
/// errors routed to the shared log instead of wgpu's panicking handler.
fn open(desc: wgpu::InstanceDescriptor, choice: LimitsChoice) -> Result<SharedDevice, BackendError> {
    let instance = wgpu::Instance::new(desc);
    let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        force_fallback_adapter: false,
        compatible_surface: None,
        ..Default::default()
    }))
    .map_err(|e| gpu_err(format!("{INSTALL_HINT} (wgpu: {e})")))?;
    let info = adapter.get_info();
    let limits = match choice {
        LimitsChoice::Adapter => adapter.limits(),
        LimitsChoice::WebGpuDefault => wgpu::Limits::default(),
    };
    let features = adapter.features() & wgpu::Features::TIMESTAMP_QUERY;
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("wedge"),
        required_features: features,
        required_limits: limits.clone(),
        ..Default::default()
    }))
    .map_err(|e| {
        gpu_err(format!("adapter `{}` refused a device with the requested limits ({choice:?}): {e}", info.name))
    })?;
    let errors = Arc::new(Mutex::new(Vec::new()));
    let lost = Arc::new(AtomicBool::new(false));
    {
        let errors = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = errors.lock() {
                v.push(e.to_string());
            }
        }));
    }
    {
        let (errors, lost) = (errors.clone(), lost.clone());
        device.set_device_lost_callback(move |reason, message| {
            lost.store(true, Ordering::SeqCst);
            if let Ok(mut v) = errors.lock() {
                v.push(format!("the GPU device was lost ({reason:?}): {message}"));
            }
        });
    }
    Ok(SharedDevice { device, queue, info, limits, features, errors, lost, pipelines: Mutex::default() })
}
