//! The `wedge` binary from an integration test: a fresh temporary directory per test, and a run's
//! output with the exit code and stderr checked.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A fresh, empty directory `wedge-<suite>-<pid>-<name>` under the system's temporary directory.
pub fn temp_dir(suite: &str, name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("wedge-{suite}-{}-{name}", std::process::id()));
    let _ = fs::remove_dir_all(&d);
    fs::create_dir_all(&d).unwrap();
    d
}

/// The path of shipped pipeline `name` (e.g. `shadows.ron`), as a string for `wedge`'s arguments.
pub fn pipeline(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines").join(name).to_string_lossy().into_owned()
}

/// Run `wedge ARGS` in `cwd`.
pub fn wedge(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_wedge")).args(args).current_dir(cwd).output().expect("wedge runs")
}

/// Assert a refusal (a non-zero exit, no panic) whose stderr holds every fragment; returns stderr.
pub fn refused(o: &Output, needles: &[&str]) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_ne!(o.status.code(), Some(0), "must be refused; stderr: {err}");
    assert!(!err.contains("panicked"), "{err}");
    for n in needles {
        assert!(err.contains(n), "stderr should mention {n:?}: {err}");
    }
    err
}
