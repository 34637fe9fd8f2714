//! Safe output files: unique temporary names, all-or-nothing sets of files, refusal to replace
//! anything that is not a regular file, and removal of temporaries on SIGINT/SIGTERM.
//!
//! * **One file** ([`crate::image`]'s writers go through [`write_file_atomically`]): the data goes to
//!   a temporary sibling with a unique name (`.<name>.<pid>.<random>.tmp`, made by `tempfile`), is
//!   flushed to disk, and is renamed over the destination. Two processes writing the same path at
//!   once each write their own temporary, so the destination always holds one process's complete
//!   file, never an interleaving.
//! * **A set of files** ([`Staging`]: the images of one `wedge render`, a bench report): every file
//!   is written into a fresh temporary directory inside the output directory
//!   (`.wedge-<pid>-<random>/`); only when all of them were written are they renamed into place.
//!   If any write fails, nothing new appears and the old files stay. If a rename fails half-way,
//!   the files already renamed are rolled back from hard-link backups of the old ones.
//!   *Residual window*: the N renames are N atomic steps, not one, so a reader looking at the
//!   directory during the (microseconds long) commit, or a `kill -9`/power cut in that instant,
//!   can still see a mix of old and new files; every single file is complete at all times.
//! * **Only regular files are replaced.** A destination that exists and is anything else — a
//!   symbolic link, a directory, a character or block device, a FIFO, a socket — is refused with an
//!   error naming the path and its kind, before anything of the set is moved into place (renaming
//!   over a link would silently replace the link and writing through it would change a file
//!   elsewhere; renaming over `/dev/null` or a FIFO would replace the node a system or another
//!   program relies on by a regular file). The output *directory* may be a link. An output
//!   directory that exists as something other than a directory is named the same way
//!   ([`check_output_dir`]), so `--out render.png` is not answered with "File exists".
//! * **Signals**: [`install_signal_handler`] starts a thread that, on SIGINT or SIGTERM, removes
//!   every temporary registered here, prints one line and exits 130 (SIGINT) or 143 (SIGTERM). A
//!   commit in progress finishes first (it holds the registry's lock), so a signal never splits a
//!   set either.

use std::fs::{self, File};
use std::io::{self, BufWriter};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

use crate::image::ImageError;

/// Temporary files and directories that exist only while a write is in progress.
static TEMPORARIES: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn temporaries() -> MutexGuard<'static, Vec<PathBuf>> {
    // A writer that panicked while holding the lock leaves a valid list behind.
    TEMPORARIES.lock().unwrap_or_else(|e| e.into_inner())
}

fn unregister(list: &mut Vec<PathBuf>, path: &Path) {
    list.retain(|p| p != path);
}

/// Remove a file or a directory tree, retrying a few times: a writer thread may create a file in
/// a directory while it is being emptied.
fn remove_path(path: &Path) -> bool {
    for _ in 0..4 {
        let gone = match fs::symlink_metadata(path) {
            Err(_) => return true,
            Ok(m) if m.is_dir() => fs::remove_dir_all(path).is_ok(),
            Ok(_) => fs::remove_file(path).is_ok(),
        };
        if gone {
            return true;
        }
    }
    false
}

/// Remove every registered temporary (what a signal does before exiting); returns how many were
/// registered. The handler holds the lock until the process exits, and everything that creates a
/// temporary or commits takes it, so nothing new appears on disk after the removal.
fn remove_temporaries(list: &mut Vec<PathBuf>) -> usize {
    let n = list.len();
    for p in list.drain(..) {
        remove_path(&p);
    }
    n
}

/// Install the SIGINT/SIGTERM handler (see the module doc). Call once, early in `main`.
pub fn install_signal_handler() -> io::Result<()> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM])?;
    std::thread::Builder::new().name("wedge-signals".into()).spawn(move || {
        if let Some(signal) = signals.forever().next() {
            let mut list = temporaries();
            let removed = remove_temporaries(&mut list);
            let (name, code) = if signal == SIGTERM { ("SIGTERM", 143) } else { ("SIGINT", 130) };
            eprintln!("wedge: stopped by {name}; removed {removed} temporary file(s)/folder(s), finished outputs are untouched");
            std::process::exit(code);
        }
    })?;
    Ok(())
}

/// What a file system object that is not a regular file is, in words, for messages.
fn kind_name(t: fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_char_device() {
            return "character device";
        } else if t.is_block_device() {
            return "block device";
        } else if t.is_fifo() {
            return "FIFO (named pipe)";
        } else if t.is_socket() {
            return "socket";
        }
    }
    if t.is_symlink() {
        "symbolic link"
    } else if t.is_dir() {
        "directory"
    } else if t.is_file() {
        "regular file"
    } else {
        "special file"
    }
}

/// Refuse a destination that exists and is not a regular file (see the module doc). The link
/// itself is looked at, not what it points to.
fn refuse_non_regular(dest: &Path) -> Result<(), ImageError> {
    match fs::symlink_metadata(dest) {
        Ok(m) if !m.file_type().is_file() => {
            Err(ImageError::NotRegularFile { path: dest.to_path_buf(), kind: kind_name(m.file_type()) })
        }
        _ => Ok(()),
    }
}

/// Refuse an output directory `dir` that exists as something other than a directory, or lies
/// under such a thing (`--out render.png/x`): the nearest of `dir` and its ancestors that exists
/// decides. Cheap and writes nothing, so a command can call it before it renders.
pub fn check_output_dir(dir: &Path) -> Result<(), ImageError> {
    for a in dir.ancestors().filter(|a| !a.as_os_str().is_empty()) {
        // Following links: an output directory that is a link to a directory is fine.
        if let Ok(m) = fs::metadata(a) {
            return match m.is_dir() {
                true => Ok(()),
                false => Err(ImageError::NotADirectory { path: a.to_path_buf(), kind: kind_name(m.file_type()) }),
            };
        }
    }
    Ok(())
}

/// Refuse writing `dest` when it is the file `input` under another name (`./a.exr`, a hard link, a
/// link to it): `compare a.exr b.exr --heatmap a.exr` must not replace what it reads. Compared by
/// device and inode, so only where both exist.
pub fn refuse_input_as_output(dest: &Path, input: &Path) -> Result<(), ImageError> {
    match same_file(dest, input) {
        true => Err(ImageError::OverwritesInput { path: dest.to_path_buf(), input: input.to_path_buf() }),
        false => Ok(()),
    }
}

#[cfg(unix)]
fn same_file(a: &Path, b: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (fs::metadata(a), fs::metadata(b)) {
        (Ok(x), Ok(y)) => (x.dev(), x.ino()) == (y.dev(), y.ino()),
        _ => false,
    }
}

#[cfg(not(unix))]
fn same_file(a: &Path, b: &Path) -> bool {
    matches!((fs::canonicalize(a), fs::canonicalize(b)), (Ok(x), Ok(y)) if x == y)
}

/// [`check_output_dir`], then create `dir` and its missing parents.
pub fn create_output_dir(dir: &Path) -> Result<(), ImageError> {
    check_output_dir(dir)?;
    fs::create_dir_all(dir).map_err(|source| ImageError::Write { path: dir.to_path_buf(), source })
}

/// The directory part of `path` (`.` for a bare file name).
fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// Runs `write` against a buffered temporary file with a unique name next to `path`, flushes it
/// to disk and renames it over `path`; on any error the temporary is removed and `path` is
/// untouched. Refuses a `path` that exists and is not a regular file, before writing and again
/// just before the rename.
pub(crate) fn write_file_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<(), ImageError>,
) -> Result<(), ImageError> {
    let io_err = |source: io::Error| ImageError::Write { path: path.to_path_buf(), source };
    let name = path
        .file_name()
        .ok_or_else(|| io_err(io::Error::new(io::ErrorKind::InvalidInput, "the path does not end in a file name")))?;
    refuse_non_regular(path)?;
    let prefix = format!(".{}.{}.", name.to_string_lossy(), std::process::id());
    let tmp = {
        let mut list = temporaries();
        let mut builder = tempfile::Builder::new();
        builder.prefix(&prefix).suffix(".tmp");
        // tempfile makes private (0600) files; an output should get the usual mode (0666 less the umask).
        #[cfg(unix)]
        builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
        let tmp = builder.tempfile_in(parent_dir(path)).map_err(io_err)?;
        list.push(tmp.path().to_path_buf());
        tmp
    };
    let tmp_path = tmp.path().to_path_buf();
    let result = (|| {
        let (file, tmp_path_guard) = tmp.into_parts();
        let mut out = BufWriter::new(file);
        write(&mut out)?;
        let file = out.into_inner().map_err(|e| io_err(e.into_error()))?;
        // On disk before the rename: a crash right after it must not leave an empty file there.
        file.sync_all().map_err(io_err)?;
        drop(file);
        let _list = temporaries();
        refuse_non_regular(path)?;
        tmp_path_guard.persist(path).map_err(|e| io_err(e.error))
    })();
    // On error the `TempPath` guard has already removed the file when it was dropped.
    unregister(&mut temporaries(), &tmp_path);
    result
}

/// A set of output files written all-or-nothing (see the module doc).
pub struct Staging {
    /// The output directory the files are committed into.
    dir: PathBuf,
    /// The temporary directory inside `dir` the files are written to first.
    tmp: PathBuf,
    /// Relative names of the files planned, in order.
    files: Vec<PathBuf>,
}

impl Staging {
    /// Create `dir` if needed and a fresh temporary directory inside it.
    pub fn new(dir: &Path) -> Result<Staging, ImageError> {
        let io_err = |source: io::Error| ImageError::Write { path: dir.to_path_buf(), source };
        create_output_dir(dir)?;
        let mut list = temporaries();
        let tmp = tempfile::Builder::new()
            .prefix(&format!(".wedge-{}-", std::process::id()))
            .tempdir_in(dir)
            .map_err(io_err)?
            .keep();
        list.push(tmp.clone());
        Ok(Staging { dir: dir.to_path_buf(), tmp, files: Vec::new() })
    }

    /// Where to write the file that becomes `dir/rel` on [`commit`](Self::commit); `rel` may have
    /// sub-directories (`images/crop.png`).
    pub fn file(&mut self, rel: impl AsRef<Path>) -> Result<PathBuf, ImageError> {
        let rel = rel.as_ref().to_path_buf();
        let staged = self.tmp.join(&rel);
        let parent = parent_dir(&staged);
        // Under the lock: after a signal's handler removed the staging directory (and holds the
        // lock until the process exits), this must not create it again.
        let _list = temporaries();
        fs::create_dir_all(parent).map_err(|source| ImageError::Write { path: self.dir.join(&rel), source })?;
        self.files.push(rel);
        Ok(staged)
    }

    /// Move every planned file into place, or none: see the module doc. Returns the final paths.
    pub fn commit(self) -> Result<Vec<PathBuf>, ImageError> {
        let mut list = temporaries();
        let result = self.commit_locked();
        remove_path(&self.tmp);
        unregister(&mut list, &self.tmp);
        result
    }

    fn commit_locked(&self) -> Result<Vec<PathBuf>, ImageError> {
        let dests: Vec<PathBuf> = self.files.iter().map(|r| self.dir.join(r)).collect();
        // Every destination before the first rename: a set with one bad destination moves nothing.
        for d in &dests {
            refuse_non_regular(d)?;
        }
        // Hard-link backups of the files about to be replaced, so a failed rename can restore them.
        let backup_dir = self.tmp.join(".previous");
        let mut backups: Vec<Option<PathBuf>> = Vec::with_capacity(dests.len());
        for (i, d) in dests.iter().enumerate() {
            let backup = backup_dir.join(i.to_string());
            let linked = d.is_file() && fs::create_dir_all(&backup_dir).is_ok() && fs::hard_link(d, &backup).is_ok();
            backups.push(linked.then_some(backup));
        }
        for (i, (rel, dest)) in self.files.iter().zip(&dests).enumerate() {
            let renamed = fs::create_dir_all(parent_dir(dest)).and_then(|_| fs::rename(self.tmp.join(rel), dest));
            if let Err(source) = renamed {
                for (done, backup) in dests[..i].iter().zip(&backups) {
                    match backup {
                        Some(b) => {
                            let _ = fs::rename(b, done);
                        }
                        None => {
                            let _ = fs::remove_file(done);
                        }
                    }
                }
                return Err(ImageError::Write { path: dest.clone(), source });
            }
        }
        Ok(dests)
    }
}

impl Drop for Staging {
    /// An uncommitted set (an error on the way) is discarded; after `commit` this finds nothing.
    fn drop(&mut self) {
        let mut list = temporaries();
        if remove_path(&self.tmp) {
            unregister(&mut list, &self.tmp);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> =
            fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        v.sort();
        v
    }

    #[test]
    fn a_committed_set_replaces_the_old_files_and_leaves_no_temporaries() {
        let d = tempfile::tempdir().unwrap();
        fs::write(d.path().join("a.txt"), "old a").unwrap();
        let mut s = Staging::new(d.path()).unwrap();
        fs::write(s.file("a.txt").unwrap(), "new a").unwrap();
        fs::write(s.file("sub/b.txt").unwrap(), "new b").unwrap();
        assert!(temporaries().iter().any(|p| p.starts_with(d.path())), "staging dir registered");
        let files = s.commit().unwrap();
        assert_eq!(files, vec![d.path().join("a.txt"), d.path().join("sub/b.txt")]);
        assert_eq!(fs::read_to_string(d.path().join("a.txt")).unwrap(), "new a");
        assert_eq!(fs::read_to_string(d.path().join("sub/b.txt")).unwrap(), "new b");
        assert_eq!(entries(d.path()), ["a.txt", "sub"]);
        assert!(!temporaries().iter().any(|p| p.starts_with(d.path())), "unregistered after commit");
    }

    #[test]
    fn a_set_dropped_before_commit_leaves_old_files_and_no_temporaries() {
        let d = tempfile::tempdir().unwrap();
        fs::write(d.path().join("a.txt"), "old a").unwrap();
        {
            let mut s = Staging::new(d.path()).unwrap();
            fs::write(s.file("a.txt").unwrap(), "new a").unwrap();
            // b.txt's writer "fails": the set is dropped.
            let _ = s.file("b.txt").unwrap();
        }
        assert_eq!(fs::read_to_string(d.path().join("a.txt")).unwrap(), "old a");
        assert_eq!(entries(d.path()), ["a.txt"]);
    }

    #[test]
    fn a_failed_rename_rolls_back_the_files_already_moved() {
        let d = tempfile::tempdir().unwrap();
        fs::write(d.path().join("a.txt"), "old a").unwrap();
        // `sub` is a regular file: every destination passes the check (`sub/b.txt` does not
        // exist), a.txt moves, then `sub/` cannot be created.
        fs::write(d.path().join("sub"), "a file").unwrap();
        let mut s = Staging::new(d.path()).unwrap();
        fs::write(s.file("a.txt").unwrap(), "new a").unwrap();
        fs::write(s.file("sub/b.txt").unwrap(), "new b").unwrap();
        let err = s.commit().unwrap_err().to_string();
        assert!(err.contains("b.txt"), "{err}");
        assert_eq!(fs::read_to_string(d.path().join("a.txt")).unwrap(), "old a", "rolled back");
        assert_eq!(fs::read_to_string(d.path().join("sub")).unwrap(), "a file");
        assert_eq!(entries(d.path()), ["a.txt", "sub"]);
    }

    /// Every kind that is not a regular file, refused with its kind named, by the set (before any
    /// file moved: a.txt keeps its old bytes) and by the single-file writer.
    #[cfg(unix)]
    #[test]
    fn a_destination_that_is_not_a_regular_file_is_refused_with_its_kind() {
        let d = tempfile::tempdir().unwrap();
        let fifo = d.path().join("pipe.exr");
        let c = std::ffi::CString::new(fifo.as_os_str().as_encoded_bytes()).unwrap();
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o644) }, 0, "mkfifo");
        fs::create_dir(d.path().join("dir.png")).unwrap();
        let _socket = std::os::unix::net::UnixListener::bind(d.path().join("sock.png")).unwrap();
        fs::write(d.path().join("a.txt"), "old a").unwrap();
        for (name, kind) in [("pipe.exr", "FIFO (named pipe)"), ("dir.png", "directory"), ("sock.png", "socket")] {
            let mut s = Staging::new(d.path()).unwrap();
            fs::write(s.file("a.txt").unwrap(), "new a").unwrap();
            fs::write(s.file(name).unwrap(), "new").unwrap();
            let err = s.commit().unwrap_err().to_string();
            assert!(
                err.contains(&format!(
                    "refusing to write {}: it is a {kind}, not a regular file",
                    d.path().join(name).display()
                )),
                "{err}"
            );
            assert_eq!(fs::read_to_string(d.path().join("a.txt")).unwrap(), "old a", "{name}: nothing moved");
            let err = write_file_atomically(&d.path().join(name), |_| Ok(())).unwrap_err().to_string();
            assert!(err.contains(kind), "{err}");
        }
        let m = fs::symlink_metadata(&fifo).unwrap();
        assert!(std::os::unix::fs::FileTypeExt::is_fifo(&m.file_type()), "still a FIFO");
        assert!(d.path().join("dir.png").is_dir());
        assert_eq!(entries(d.path()), ["a.txt", "dir.png", "pipe.exr", "sock.png"]);
    }

    #[test]
    fn an_output_directory_that_is_a_file_is_named_with_its_kind() {
        let d = tempfile::tempdir().unwrap();
        let file = d.path().join("render.png");
        fs::write(&file, "png").unwrap();
        for dir in [file.clone(), file.join("deeper/still")] {
            let err = Staging::new(&dir).err().expect("refused").to_string();
            assert!(
                err.contains(&format!("cannot write into {}: it is a regular file, not a directory", file.display())),
                "{err}"
            );
        }
        assert!(check_output_dir(&d.path().join("new/dir")).is_ok());
        assert_eq!(fs::read_to_string(&file).unwrap(), "png");
        assert_eq!(entries(d.path()), ["render.png"]);
    }

    #[cfg(unix)]
    #[test]
    fn a_symlink_destination_is_refused_and_its_target_untouched() {
        let d = tempfile::tempdir().unwrap();
        let target = d.path().join("precious.txt");
        fs::write(&target, "keep me").unwrap();
        std::os::unix::fs::symlink(&target, d.path().join("a.txt")).unwrap();
        let mut s = Staging::new(d.path()).unwrap();
        fs::write(s.file("a.txt").unwrap(), "new a").unwrap();
        let err = s.commit().unwrap_err().to_string();
        assert!(err.contains("a.txt") && err.contains("symbolic link"), "{err}");
        assert!(fs::symlink_metadata(d.path().join("a.txt")).unwrap().file_type().is_symlink());
        assert_eq!(fs::read_to_string(&target).unwrap(), "keep me");
        // The single-file writer refuses it too.
        let err = write_file_atomically(&d.path().join("a.txt"), |_| Ok(())).unwrap_err().to_string();
        assert!(err.contains("symbolic link"), "{err}");
        assert_eq!(entries(d.path()), ["a.txt", "precious.txt"]);
    }

    #[test]
    fn single_file_temporaries_have_unique_names_and_vanish() {
        let d = tempfile::tempdir().unwrap();
        let path = d.path().join("x.bin");
        let mut seen = Vec::new();
        write_file_atomically(&path, |_| {
            seen = entries(d.path());
            Ok(())
        })
        .unwrap();
        assert_eq!(seen.len(), 1);
        let pid = format!(".x.bin.{}.", std::process::id());
        assert!(seen[0].starts_with(&pid) && seen[0].ends_with(".tmp"), "{seen:?}");
        assert_eq!(entries(d.path()), ["x.bin"]);
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = fs::metadata(&path).unwrap().permissions().mode() & 0o777;
            // Like any file the user creates: 0666 less the umask, not tempfile's private 0600.
            let status = fs::read_to_string("/proc/self/status").unwrap_or_default();
            if let Some(umask) = status.lines().find_map(|l| l.strip_prefix("Umask:")) {
                let umask = u32::from_str_radix(umask.trim(), 8).unwrap();
                assert_eq!(mode, 0o666 & !umask, "{mode:o} with umask {umask:o}");
            }
        }
    }

    #[test]
    fn removing_temporaries_empties_the_registry_and_the_disk() {
        let d = tempfile::tempdir().unwrap();
        let s = Staging::new(d.path()).unwrap();
        let tmp = s.tmp.clone();
        fs::write(tmp.join("half-written"), "x").unwrap();
        let mut list = temporaries();
        let mine: Vec<PathBuf> = list.iter().filter(|p| p.starts_with(d.path())).cloned().collect();
        list.retain(|p| !p.starts_with(d.path()));
        drop(list);
        let mut only_mine = mine;
        assert_eq!(remove_temporaries(&mut only_mine), 1);
        assert!(!tmp.exists());
        drop(s);
        assert!(entries(d.path()).is_empty());
    }
}
