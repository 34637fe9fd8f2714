//! Hardening regressions (issue 10) through the `wedge` command line: the bad pipelines under
//! `tests/data/bad/pipeline/` and the pipeline crashers the fuzzer kept under
//! `tests/data/bad/fuzz/pipeline/` are answered with exit status 1, the file's line:col and the fix
//! on stderr — never a panic (exit 101). The other fuzz targets are replayed by
//! `cargo test -p wedge-fuzz` (fuzz/tests/regressions.rs).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn wedge_graph(file: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_wedge")).arg("graph").arg(file).output().expect("wedge runs")
}

fn bad(dir: &str, name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/bad").join(dir).join(name)
}

/// `wedge graph FILE` fails with status 1 and stderr containing `FILE:line:col` and every needle.
fn refused(name: &str, line_col: &str, needles: &[&str]) {
    let o = wedge_graph(&bad("pipeline", name));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{name}: {err}");
    assert!(!err.contains("panicked"), "{name}: {err}");
    assert!(err.contains(&format!("{name}:{line_col}")), "{name}: expected {line_col}: {err}");
    for n in needles {
        assert!(err.contains(n), "{name}: expected {n:?}: {err}");
    }
}

#[test]
fn bad_pipelines_name_position_and_fix() {
    refused("fractional_width.ron", "3:12", &["`width` must be a whole number", "`width: 64`"]);
    refused("negative_seed.ron", "5:11", &["`seed` cannot be negative", "0 to 4294967295"]);
    refused("quoted_height.ron", "4:13", &["`height` expects a whole number", "remove the quotes"]);
    refused("unclosed.ron", "7:", &["the `(` opened at 1:9 is closed", "add the missing `)`"]);
    refused("camera_degenerate.ron", "7:18", &["error[bad-camera]", "equals `position`", "vfov_deg` = 180"]);
    refused("camera_nan.ron", "6:19", &["`position` = [0.0, NaN, 4.0] is not finite", "`up` is (0, 0, 0)"]);
    refused("camera_up_parallel.ron", "5:13", &["parallel to the view direction"]);
}

#[test]
fn byte_order_mark_pipeline_is_accepted() {
    let o = wedge_graph(&bad("pipeline", "bom_ok.ron"));
    let (out, err) = (String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
    assert!(o.status.success(), "{out}{err}");
    assert!(out.contains("primary"), "{out}");
}

#[test]
fn fuzz_pipeline_crashers_fail_cleanly() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/bad/fuzz/pipeline");
    let Ok(entries) = std::fs::read_dir(&dir) else { return };
    for f in entries.filter_map(|e| e.ok().map(|e| e.path())) {
        if f.extension().is_some_and(|e| e == "txt") {
            continue;
        }
        let o = wedge_graph(&f);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{}: {err}", f.display());
        assert!(!err.contains("panicked"), "{}: {err}", f.display());
        assert!(err.contains(&f.display().to_string()), "{}: {err}", f.display());
    }
}
