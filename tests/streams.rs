//! Graph-assigned random streams: every random pass of every shipped pipeline has the stream the
//! graph hashed from its name, no two collide, and no effect file writes a stream number.

use std::collections::BTreeMap;
use std::path::PathBuf;

use wedge::graph::{stream_id, ParamValue};
use wedge::{Overrides, Session};

#[test]
fn random_passes_have_their_hashed_stream_and_none_collide() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("pipelines");
    let mut seen: BTreeMap<i64, String> = BTreeMap::new();
    let mut random = 0;
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|x| x != "ron") {
            continue;
        }
        let s =
            Session::open(Some(&path), &Overrides { width: Some(8), height: Some(6), ..Default::default() }).unwrap();
        for p in s.schedule.passes.iter().filter(|p| p.random) {
            random += 1;
            // A pass continuing another's sequences (the shared sampler's adaptive pass) has the
            // stream of the pass it continues.
            let owner = p.continues.clone().unwrap_or_else(|| p.name.clone());
            assert_eq!(p.params["stream"], ParamValue::Int(i64::from(stream_id(&owner))), "{}", p.name);
            let ParamValue::Int(stream) = p.params["stream"] else { unreachable!() };
            // The same pass name in two pipelines is the same pass; different names must differ.
            if let Some(other) = seen.insert(stream, owner.clone()) {
                assert_eq!(other, owner, "streams collide");
            }
        }
    }
    assert!(random >= 6, "{random} random passes");
}

/// Every `.rs` file under `dir`, recursively.
fn rust_files(dir: &std::path::Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn effect_files_never_pick_a_stream() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("effects/src");
    let mut files = Vec::new();
    rust_files(&root, &mut files);
    assert!(files.len() > 20, "{files:?}");
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap();
        assert!(!text.contains(".param(\"stream\""), "{} sets a stream by hand; use .random()", file.display());
    }
    // The nodes that draw do so through their own random passes or through the shared sampler.
    for file in ["shadows/node.rs", "indirect/node.rs", "montecarlo.rs", "sampler.rs"] {
        let text = std::fs::read_to_string(root.join(file)).unwrap();
        assert!(text.contains(".random()") || text.contains("ctx.sampler("), "effects/src/{file}");
    }
}
