//! The user-defined kernel runs through wedge's parity harness like wedge's own kernels.
use wedge::backends::{gpu::GpuBackend, parity::run_parity, Silent};

#[test]
fn custom_kernel_parity() {
    let gpu = match GpuBackend::new() {
        Ok(g) => g,
        Err(e) if std::env::var("CI").is_ok_and(|v| v == "true") => panic!("CI=true and no wgpu adapter: {e}"),
        Err(e) => {
            eprintln!("custom_kernel_parity: SKIPPED — {e}");
            return;
        }
    };
    let mut gpu = gpu;
    let session = wedge_custom_kernel::session(&Default::default()).unwrap();
    let job = session.job(session.seed, 0, &Silent);
    let report = run_parity(&job, &mut gpu).unwrap();
    println!("{}", report.table());
    assert!(report.rows.iter().any(|r| r.kernel == "example.exposure"), "the custom kernel did not run");
    assert!(report.ok());
    // The exposure pass multiplies by the same float on both backends: exactly equal.
    let row = report.rows.iter().find(|r| r.kernel == "example.exposure").unwrap();
    assert_eq!(row.max_abs, 0.0);
}
