//! Scene errors. Every message reads "<file>: <what> — <fix>" so a user can act on it without reading code.

use std::path::{Path, PathBuf};

/// Everything that can go wrong while loading or building a scene. Loading never panics on bad input;
/// it returns one of these instead.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file (or a file it references) could not be read.
    #[error("{}: cannot read file ({source}) — check the path and permissions", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The file was read but its contents are not valid (parse error, bad indices, NaN vertices…).
    #[error("{}: {what} — {fix}", path.display())]
    Invalid {
        path: PathBuf,
        what: String,
        fix: String,
    },
    /// The file extension is not one we load.
    #[error("{}: unsupported scene format — use .gltf, .glb, .obj or .ron", path.display())]
    UnsupportedFormat { path: PathBuf },
    /// `SceneSource::Builtin` with a name we do not know.
    #[error("builtin:{name}: no such built-in scene — use one of {known}")]
    UnknownBuiltin { name: String, known: String },
}

impl SceneError {
    pub(crate) fn invalid(path: &Path, what: impl Into<String>, fix: impl Into<String>) -> Self {
        SceneError::Invalid {
            path: path.to_path_buf(),
            what: what.into(),
            fix: fix.into(),
        }
    }
    pub(crate) fn io(path: &Path, source: std::io::Error) -> Self {
        SceneError::Io {
            path: path.to_path_buf(),
            source,
        }
    }
}
