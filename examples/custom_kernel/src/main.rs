//! Run the example pipeline on the CPU, then (when an adapter exists) check every pass on wgpu.
use wedge::backends::{cpu::CpuBackend, gpu::GpuBackend, parity::run_parity, Job, Silent};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let session = wedge_custom_kernel::session(&Default::default())?;
    let run = session.run(&mut CpuBackend::new(), &Silent)?;
    println!("cpu: {} passes, output {:?}", run.timings.len(), run.outputs.keys().collect::<Vec<_>>());
    match GpuBackend::new() {
        Ok(mut gpu) => {
            let job = Job {
                schedule: &session.schedule,
                scene: &session.scene,
                kernels: &session.kernels,
                width: session.width,
                height: session.height,
                seed: session.seed,
                frame: 0,
                progress: &Silent,
            };
            let report = run_parity(&job, &mut gpu)?;
            print!("{}", report.table());
            if !report.ok() {
                return Err("parity mismatch".into());
            }
        }
        Err(e) => println!("wgpu skipped: {e}"),
    }
    Ok(())
}
