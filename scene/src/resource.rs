//! Finding and reading the files a scene file references (glTF buffers/images, OBJ material libraries
//! and textures, `.ron` meshes).
//!
//! Every reference is resolved relative to the referencing file, canonicalised (symlinks followed) and,
//! unless [`crate::LoadOptions::allow_outside_scene_dir`] is set, refused when it leaves the directory
//! of the scene file the user named: a downloaded scene must not be able to read `/etc/passwd` or
//! `~/.ssh` into a texture. Reads are size-capped before anything is allocated, and IO failures stay
//! [`SceneError::Io`] (naming the file and who referenced it), never a parse error.

use std::path::{Path, PathBuf};

use crate::limits::MAX_FILE_BYTES;
use crate::{LoadOptions, SceneError};

/// The policy for one top-level scene load: where its directory is and whether leaving it is allowed.
#[derive(Clone, Debug)]
pub(crate) struct Resources {
    /// Canonical directory of the scene file the user named.
    root: PathBuf,
    allow_outside: bool,
    /// The shutter (`Camera::shutter_open`, `shutter_close`) the caller asked for, which glTF
    /// animations are sampled at; `None`: the scene file's own (RON `shutter`), else 0, 0.
    pub shutter: Option<(f32, f32)>,
}

impl Resources {
    /// The policy for loading `scene_file` (a file the user named; reading it is always allowed).
    pub fn for_scene(scene_file: &Path, opts: &LoadOptions) -> Result<Resources, SceneError> {
        let dir = parent_dir(scene_file);
        let root = std::fs::canonicalize(dir).map_err(|e| SceneError::io(scene_file, e))?;
        Ok(Resources {
            root,
            allow_outside: opts.allow_outside_scene_dir,
            shutter: None,
        })
    }

    /// Resolve `reference` (a path written in `scene`, relative to `scene`'s directory unless absolute).
    /// `referenced_by` says where, e.g. `buffers[0].uri = "a.bin"` or `line 3: mtllib a.mtl`.
    pub fn resolve(
        &self,
        scene: &Path,
        reference: &Path,
        referenced_by: &str,
    ) -> Result<PathBuf, SceneError> {
        let joined = parent_dir(scene).join(reference);
        let by = format!("{} {referenced_by}", scene.display());
        let canonical = std::fs::canonicalize(&joined)
            .map_err(|e| SceneError::io_referenced(&joined, by, e))?;
        if !self.allow_outside && !canonical.starts_with(&self.root) {
            return Err(SceneError::OutsideSceneDir {
                scene: scene.to_path_buf(),
                referenced_by: referenced_by.to_string(),
                resolved: canonical,
                root: self.root.clone(),
            });
        }
        Ok(canonical)
    }

    /// Resolve and read a referenced file (see [`Resources::resolve`]).
    pub fn read_referenced(
        &self,
        scene: &Path,
        reference: &Path,
        referenced_by: &str,
    ) -> Result<Vec<u8>, SceneError> {
        let file = self.resolve(scene, reference, referenced_by)?;
        read_capped(&file, Some(format!("{} {referenced_by}", scene.display())))
    }
}

/// Read a whole file, refusing files over [`MAX_FILE_BYTES`] before allocating.
pub(crate) fn read_capped(
    file: &Path,
    referenced_by: Option<String>,
) -> Result<Vec<u8>, SceneError> {
    let io_err = |e| match &referenced_by {
        Some(by) => SceneError::io_referenced(file, by.clone(), e),
        None => SceneError::io(file, e),
    };
    let meta = std::fs::metadata(file).map_err(io_err)?;
    if !meta.is_file() {
        return Err(io_err(std::io::Error::other(
            "it is a directory or a device, not a regular file",
        )));
    }
    if meta.len() > MAX_FILE_BYTES {
        return Err(SceneError::invalid(
            file,
            format!(
                "the file has {} bytes, more than the limit of {MAX_FILE_BYTES}",
                meta.len()
            ),
            "split the scene into smaller files",
        ));
    }
    std::fs::read(file).map_err(io_err)
}

/// The directory a file's relative references start from (`.` for a bare file name).
pub(crate) fn parent_dir(file: &Path) -> &Path {
    match file.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}
