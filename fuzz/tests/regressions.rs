//! Every crasher the fuzzer found is kept under `tests/data/bad/fuzz/<target>/` and replayed here:
//! each must now give an error (`Err`), not a panic, hang or runaway allocation (the last two end
//! this process with status 3 or 4 and name the input).

use std::sync::Mutex;

use wedge_fuzz::{by_name, driver, run_one, Outcome};

#[global_allocator]
static ALLOC: wedge_fuzz::alloc::CountingAlloc = wedge_fuzz::alloc::CountingAlloc;

static SERIAL: Mutex<()> = Mutex::new(());

/// Replay the target's regression inputs; returns how many there were.
fn replay(target: &str) -> usize {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let t = by_name(target).unwrap();
    wedge_fuzz::alloc::arm(2048 << 20);
    let files = driver::files_in(&driver::regression_dir(target));
    let mut failures = Vec::new();
    for f in &files {
        let data = std::fs::read(f).unwrap();
        match run_one(t, &data) {
            Outcome::Err(message) => {
                // The message must name the file the reader was given (or one it refers to).
                let names: &[&str] = match target {
                    "pipeline" => &["fuzz.ron"],
                    "gltf" => &["scene.gltf", "buffer.bin", "tex.png"],
                    "glb" => &["scene.glb", "tex.png"],
                    "obj" => &["scene.obj", "scene.mtl", "tex.png"],
                    _ => &["image.exr"],
                };
                if !names.iter().any(|n| message.contains(n)) {
                    failures.push(format!("{}: message names no file: {message}", f.display()));
                }
            }
            Outcome::Ok => failures.push(format!("{}: accepted (expected an error)", f.display())),
            Outcome::Panic(p) => failures.push(format!("{}: panicked: {p}", f.display())),
        }
    }
    wedge_fuzz::alloc::arm(0);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    files.len()
}

#[test]
fn pipeline() {
    replay("pipeline");
}

#[test]
fn gltf() {
    assert!(replay("gltf") > 0);
}

#[test]
fn glb() {
    assert!(replay("glb") > 0);
}

#[test]
fn obj() {
    assert!(replay("obj") > 0);
}

#[test]
fn exr() {
    replay("exr");
}
