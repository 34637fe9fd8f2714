//! Scene errors. Every message reads "<file>: <what> — <fix>" so a user can act on it without reading code.
//! Reading problems (missing file, permission denied) and content problems (parse errors, bad indices,
//! NaN vertices) are different variants, so a missing file is never reported as a broken one.

use std::path::{Path, PathBuf};

/// Everything that can go wrong while loading or building a scene. Loading never panics on bad input;
/// it returns one of these instead.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file (or a file it references) could not be read.
    #[error("{}: cannot read {}({}) — {}", path.display(), referenced_by_text(referenced_by), io_what(source), io_fix(source))]
    Io {
        path: PathBuf,
        /// Who named this file, e.g. `scene.gltf buffers[0].uri`; `None` for the scene file itself.
        referenced_by: Option<String>,
        #[source]
        source: std::io::Error,
    },
    /// The file was read but its contents are not valid (parse error, bad indices, NaN vertices…).
    #[error("{}: {what} — {fix}", path.display())]
    Invalid { path: PathBuf, what: String, fix: String },
    /// A scene file or a pipeline references a file outside the directory of the scene file or the
    /// pipeline file (refused by default so neither can read arbitrary files such as `/etc/passwd`;
    /// see `scene/src/resource.rs`).
    #[error(
        "{}: {referenced_by} points to {}, which is outside the {dir_of} directory {} — move the file under \
         that directory, or allow it with --allow-outside-dir (LoadOptions::allow_outside_dir)",
        file.display(), resolved.display(), root.display()
    )]
    OutsideDir {
        /// The file holding the reference (a scene file or a pipeline file).
        file: PathBuf,
        /// Where in it, e.g. `buffers[0].uri = "/etc/passwd"`.
        referenced_by: String,
        /// The referenced file, canonical (symlinks followed).
        resolved: PathBuf,
        /// The directory it had to lie under, canonical.
        root: PathBuf,
        /// Whose directory that is: `scene` or `pipeline`.
        dir_of: &'static str,
    },
    /// The file extension is not one we load.
    #[error("{}: unsupported scene format — use .gltf, .glb, .obj or .ron", path.display())]
    UnsupportedFormat { path: PathBuf },
    /// `SceneSource::Builtin` with a name we do not know.
    #[error("builtin:{name}: no such built-in scene — use one of {known}")]
    UnknownBuiltin { name: String, known: String },
}

fn referenced_by_text(by: &Option<String>) -> String {
    match by {
        Some(by) => format!("the file referenced by {by} "),
        None => "the file ".to_string(),
    }
}

fn io_what(e: &std::io::Error) -> String {
    match e.kind() {
        std::io::ErrorKind::NotFound => "it does not exist".to_string(),
        std::io::ErrorKind::PermissionDenied => "permission denied".to_string(),
        _ => e.to_string(),
    }
}

fn io_fix(e: &std::io::Error) -> &'static str {
    match e.kind() {
        std::io::ErrorKind::NotFound => "check the path (relative paths start at the referencing file's directory)",
        std::io::ErrorKind::PermissionDenied => "make the file readable (chmod) or run as a user who may read it",
        _ => "check the path, the permissions and the disk",
    }
}

impl SceneError {
    pub(crate) fn invalid(path: &Path, what: impl Into<String>, fix: impl Into<String>) -> Self {
        SceneError::Invalid { path: path.to_path_buf(), what: what.into(), fix: fix.into() }
    }
    pub(crate) fn io(path: &Path, source: std::io::Error) -> Self {
        SceneError::Io { path: path.to_path_buf(), referenced_by: None, source }
    }
    pub(crate) fn io_referenced(path: &Path, referenced_by: String, source: std::io::Error) -> Self {
        SceneError::Io { path: path.to_path_buf(), referenced_by: Some(referenced_by), source }
    }
}
