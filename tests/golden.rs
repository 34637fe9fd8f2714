//! Golden images: every shipped pipeline (`pipelines/*.ron`) rendered at 48×36 on the CPU backend,
//! and its stratified reference at 8 samples, each output's bits hashed and compared with
//! `tests/data/golden_cpu.txt`. A refactor must leave every image bit for bit (issue 34 §3: the
//! camera-path nodes through a pinhole; issue 36: the kernels' migration), and this is what proves
//! it on every CI run rather than once by hand. A change that means to change images re-blesses the
//! file — `WEDGE_BLESS=1 cargo test --release --test golden` — and commits it: its diff names the
//! pipelines the change touched. The CPU backend only: its images do not depend on the thread
//! count (`tests/tiles.rs`), and the wgpu backend is checked against it by `tests/parity.rs`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use wedge::backends::cpu::CpuBackend;
use wedge::backends::Silent;
use wedge::{Overrides, Session};

const SIZE: (u32, u32) = (48, 36);
const REFERENCE_SPP: u32 = 8;

fn golden_file() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/golden_cpu.txt")
}

/// FNV-1a (64-bit): a hash that is the same on every machine and toolchain, unlike std's.
fn fnv1a(hash: u64, bytes: &[u8]) -> u64 {
    bytes.iter().fold(hash, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
}

/// One hash over a run's outputs: each sink port's name and its buffer's bytes, in name order.
fn outputs_hash(session: &Session) -> u64 {
    let run = session.run(&mut CpuBackend::new(), &Silent).expect("the pipeline runs");
    run.outputs.iter().fold(0xcbf2_9ce4_8422_2325, |h, ((sink, port), data)| {
        fnv1a(fnv1a(fnv1a(h, sink.as_bytes()), port.as_bytes()), data.as_bytes())
    })
}

/// `name render` and `name reference` → the hash of each run, for every shipped pipeline.
fn current() -> BTreeMap<String, String> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines");
    let mut paths: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("pipelines/ is listed")
        .map(|e| e.expect("a directory entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .collect();
    paths.sort();
    let ov = Overrides { width: Some(SIZE.0), height: Some(SIZE.1), ..Default::default() };
    let mut out = BTreeMap::new();
    for path in paths {
        let name = path.file_stem().expect("a file name").to_string_lossy().into_owned();
        let render = Session::open(Some(&path), &ov).unwrap_or_else(|e| panic!("{name}: {e}"));
        out.insert(format!("{name} render"), format!("{:016x}", outputs_hash(&render)));
        let reference = Session::reference(Some(&path), REFERENCE_SPP, "stratified", &ov)
            .unwrap_or_else(|e| panic!("{name} reference: {e}"));
        out.insert(format!("{name} reference"), format!("{:016x}", outputs_hash(&reference)));
    }
    out
}

fn stored() -> BTreeMap<String, String> {
    let text = std::fs::read_to_string(golden_file()).unwrap_or_default();
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .filter_map(|l| l.rsplit_once(' ').map(|(k, v)| (k.to_string(), v.to_string())))
        .collect()
}

#[test]
fn every_shipped_pipeline_renders_its_golden_bits() {
    let now = current();
    if std::env::var("WEDGE_BLESS").is_ok_and(|v| v == "1") {
        let mut text = format!(
            "# tests/golden.rs: every shipped pipeline at {}x{} (CPU) and its stratified reference at {} spp,\n\
             # FNV-1a of each run's outputs. Re-bless: WEDGE_BLESS=1 cargo test --release --test golden\n",
            SIZE.0, SIZE.1, REFERENCE_SPP
        );
        for (k, v) in &now {
            text.push_str(&format!("{k} {v}\n"));
        }
        std::fs::write(golden_file(), text).expect("the golden file is written");
        return;
    }
    let was = stored();
    let mut wrong: Vec<String> = Vec::new();
    for (k, v) in &now {
        match was.get(k) {
            Some(w) if w == v => {}
            Some(w) => wrong.push(format!("{k}: {v}, golden {w}")),
            None => wrong.push(format!("{k}: {v}, not in the golden file")),
        }
    }
    wrong.extend(was.keys().filter(|k| !now.contains_key(*k)).map(|k| format!("{k}: in the golden file, no such run")));
    assert!(
        wrong.is_empty(),
        "{} run(s) differ from tests/data/golden_cpu.txt:\n  {}\nIf the change means to change these images, \
         re-bless with `WEDGE_BLESS=1 cargo test --release --test golden` and commit the file",
        wrong.len(),
        wrong.join("\n  ")
    );
}
