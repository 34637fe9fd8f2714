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

#[test]
fn effect_files_never_pick_a_stream() {
    for (file, text) in [
        ("shadows.rs", include_str!("../effects/src/shadows.rs")),
        ("indirect.rs", include_str!("../effects/src/indirect.rs")),
        ("montecarlo.rs", include_str!("../effects/src/montecarlo.rs")),
        ("sampler.rs", include_str!("../effects/src/sampler.rs")),
    ] {
        assert!(!text.contains("\"stream\""), "effects/src/{file} sets a stream by hand; use .random()");
        // An effect draws through its own random passes or through the shared sampler.
        assert!(text.contains(".random()") || text.contains("ctx.sampler("), "effects/src/{file}");
    }
}
