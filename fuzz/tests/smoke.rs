//! The CI fuzz smoke run: every target for a few seconds over its seeds and regression inputs,
//! asserting that no input panics, hangs or exceeds the memory cap (a hang or memory crasher ends
//! this test process with status 3 or 4, the input saved under the temporary output directory).

use std::sync::Mutex;

use wedge_fuzz::{by_name, fuzz, Config};

#[global_allocator]
static ALLOC: wedge_fuzz::alloc::CountingAlloc = wedge_fuzz::alloc::CountingAlloc;

/// The driver's crash bookkeeping is process-wide: one target at a time.
static SERIAL: Mutex<()> = Mutex::new(());

fn smoke(target: &str) {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let out = tempfile::tempdir().unwrap();
    let cfg = Config { seconds: 3.0, seed: 1, out: out.path().to_path_buf(), ..Config::default() };
    let report = fuzz(by_name(target).unwrap(), &cfg);
    eprintln!("{report}");
    assert!(wedge_fuzz::alloc::installed());
    // Seeds alone are more than this; the loop must have run mutations too.
    assert!(report.executions > 20, "{report}");
    assert!(report.outcomes >= 2, "{report}");
    assert!(report.crashers.is_empty(), "{report}");
}

#[test]
fn pipeline() {
    smoke("pipeline");
}

#[test]
fn exr() {
    smoke("exr");
}

#[test]
fn gltf() {
    smoke("gltf");
}

#[test]
fn glb() {
    smoke("glb");
}

#[test]
fn obj() {
    smoke("obj");
}

#[test]
fn seeds_load_cleanly() {
    // Every generated seed is a valid input (so fuzzing starts from inputs that reach deep code),
    // except the GLB-form glTF documents (no buffer URI), which only the glb target can read.
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    for t in wedge_fuzz::TARGETS {
        let seeds = wedge_fuzz::seeds::seeds(t.name);
        assert!(seeds.len() >= 3, "{}: {} seeds", t.name, seeds.len());
        for (i, s) in seeds.iter().enumerate() {
            let outcome = wedge_fuzz::run_one(*t, s);
            let no_uri_buffer = format!(r#"[{{"byteLength": {}}}]"#, wedge_fuzz::seeds::gltf_buffer().len());
            let no_uri = t.name == "gltf" && String::from_utf8_lossy(s).contains(&no_uri_buffer);
            if !no_uri {
                assert_eq!(outcome, wedge_fuzz::Outcome::Ok, "{} seed {i}", t.name);
            }
        }
    }
}

#[test]
fn same_seed_same_run() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let out = tempfile::tempdir().unwrap();
    let cfg =
        Config { seconds: 60.0, max_runs: Some(3000), seed: 42, out: out.path().to_path_buf(), ..Config::default() };
    let target = by_name("pipeline").unwrap();
    let a = fuzz(target, &cfg);
    let b = fuzz(target, &cfg);
    assert_eq!(a.executions, 3000);
    assert_eq!((a.corpus, a.outcomes), (b.corpus, b.outcomes));
}

#[test]
fn camera_path() {
    smoke("camera_path");
}

#[test]
fn set() {
    smoke("set");
}
