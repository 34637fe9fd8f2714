//! Run the example pipeline on the CPU, then (when an adapter exists) check every pass on wgpu.
use wedge::backends::{cpu::CpuBackend, gpu::GpuBackend, parity::run_parity, Silent};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let session = wedge_custom_kernel::session(&Default::default())?;
    let run = session.run(&mut CpuBackend::new(), &Silent)?;
    println!("cpu: {} passes, output {:?}", run.timings.len(), run.outputs.keys().collect::<Vec<_>>());
    match GpuBackend::new() {
        Ok(mut gpu) => {
            let job = session.job(session.seed, 0, &Silent);
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
