//! Hot reload without a watcher crate: the viewer polls the modification time of the pipeline file
//! (and of the scene file it names) once per frame. A `stat` per file per frame costs microseconds
//! and works the same on every platform and with editors that replace the file on save.

use std::path::{Path, PathBuf};
use std::time::SystemTime;

/// The files a session was built from and their modification times then.
#[derive(Default)]
pub struct Watch {
    files: Vec<(PathBuf, Option<SystemTime>)>,
}

fn modified(path: &Path) -> Option<SystemTime> {
    std::fs::metadata(path).and_then(|m| m.modified()).ok()
}

impl Watch {
    /// Watch `files` from now on.
    pub fn new(files: Vec<PathBuf>) -> Watch {
        Watch { files: files.into_iter().map(|f| (modified(&f), f)).map(|(t, f)| (f, t)).collect() }
    }

    /// Whether any file changed (or appeared, or vanished) since the last call; remembers the new times.
    pub fn changed(&mut self) -> bool {
        let mut any = false;
        for (path, time) in &mut self.files {
            let now = modified(path);
            if now != *time {
                *time = now;
                any = true;
            }
        }
        any
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn notices_a_rewrite() {
        let dir = tempfile::tempdir().expect("tempdir");
        let file = dir.path().join("p.ron");
        std::fs::write(&file, "a").expect("write");
        let mut watch = Watch::new(vec![file.clone()]);
        assert!(!watch.changed());
        // Some file systems keep whole seconds: set the time rather than wait.
        let later = SystemTime::now() + std::time::Duration::from_secs(5);
        std::fs::File::options().write(true).open(&file).and_then(|f| f.set_modified(later)).expect("touch");
        assert!(watch.changed());
        assert!(!watch.changed());
    }
}
