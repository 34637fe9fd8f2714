//! Finding and reading the files a scene file or a pipeline references (glTF buffers/images, OBJ
//! material libraries and textures, `.ron` meshes; a pipeline's scene, environment map, real-layer
//! maps and captured scene).
//!
//! One rule for both ([`Confinement`]): every reference is resolved relative to the referencing
//! file, canonicalised (symlinks followed) and, unless [`crate::LoadOptions::allow_outside_dir`]
//! (`--allow-outside-dir`) is set, refused when it leaves the directory of the file the user named —
//! the scene file for a scene's references, the pipeline file for a pipeline's: a downloaded scene or
//! pipeline must not be able to read `/etc/passwd` or `~/.ssh` into a texture or a map. Names that are
//! not files (`builtin:…`, glTF `data:` URIs) are the callers' to recognise before they get here.
//! Reads are size-capped before anything is allocated, and IO failures stay [`SceneError::Io`]
//! (naming the file and who referenced it), never a parse error.

use std::path::{Path, PathBuf};

use crate::limits::MAX_FILE_BYTES;
use crate::{LoadOptions, SceneError};

/// Whose directory confines the references: named in the refusal, so the user knows which
/// directory the files must lie under.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ConfinedTo {
    /// The directory of the scene file the user named.
    Scene,
    /// The directory of the pipeline file.
    Pipeline,
}

impl ConfinedTo {
    /// `scene` or `pipeline`, for messages.
    pub fn noun(self) -> &'static str {
        match self {
            ConfinedTo::Scene => "scene",
            ConfinedTo::Pipeline => "pipeline",
        }
    }
}

/// Where the files a scene or a pipeline names may lie: under the canonical directory `root` of the
/// file the user named, unless leaving it is allowed (module doc).
#[derive(Clone, Debug)]
pub struct Confinement {
    /// Canonical directory of the file the user named.
    root: PathBuf,
    allow_outside: bool,
    to: ConfinedTo,
}

impl Confinement {
    /// The confinement of references made from `file` (a file the user named; reading it is always
    /// allowed) to its directory; `allow_outside` lifts it (`--allow-outside-dir`).
    pub fn of_file(file: &Path, to: ConfinedTo, allow_outside: bool) -> Result<Confinement, SceneError> {
        let root = std::fs::canonicalize(parent_dir(file)).map_err(|e| SceneError::io(file, e))?;
        Ok(Confinement { root, allow_outside, to })
    }

    /// Resolve `reference` (a path written in `file`, relative to `file`'s directory unless absolute):
    /// the canonical path, refused when it leaves the root and that is not allowed. `referenced_by`
    /// says where in `file`, e.g. `buffers[0].uri = "a.bin"` or `line 3: mtllib a.mtl`.
    pub fn resolve(&self, file: &Path, reference: &Path, referenced_by: &str) -> Result<PathBuf, SceneError> {
        let joined = parent_dir(file).join(reference);
        let by = format!("{} {referenced_by}", file.display());
        let canonical = std::fs::canonicalize(&joined).map_err(|e| SceneError::io_referenced(&joined, by, e))?;
        if !self.allow_outside && !canonical.starts_with(&self.root) {
            return Err(SceneError::OutsideDir {
                file: file.to_path_buf(),
                referenced_by: referenced_by.to_string(),
                resolved: canonical,
                root: self.root.clone(),
                dir_of: self.to.noun(),
            });
        }
        Ok(canonical)
    }
}

/// The policy for one top-level scene load: its [`Confinement`] and the shutter.
#[derive(Clone, Debug)]
pub(crate) struct Resources {
    confinement: Confinement,
    /// The shutter (`Camera::shutter_open`, `shutter_close`) the caller asked for, which glTF
    /// animations are sampled at; `None`: the scene file's own (RON `shutter`), else 0, 0.
    pub shutter: Option<(f32, f32)>,
}

impl Resources {
    /// The policy for loading `scene_file` (a file the user named; reading it is always allowed).
    pub fn for_scene(scene_file: &Path, opts: &LoadOptions) -> Result<Resources, SceneError> {
        let confinement = Confinement::of_file(scene_file, ConfinedTo::Scene, opts.allow_outside_dir)?;
        Ok(Resources { confinement, shutter: None })
    }

    /// Resolve `reference`, written in `scene` ([`Confinement::resolve`]).
    pub fn resolve(&self, scene: &Path, reference: &Path, referenced_by: &str) -> Result<PathBuf, SceneError> {
        self.confinement.resolve(scene, reference, referenced_by)
    }

    /// Resolve and read a referenced file (see [`Resources::resolve`]).
    pub fn read_referenced(&self, scene: &Path, reference: &Path, referenced_by: &str) -> Result<Vec<u8>, SceneError> {
        let file = self.resolve(scene, reference, referenced_by)?;
        read_capped(&file, Some(format!("{} {referenced_by}", scene.display())))
    }
}

/// Read a whole file, refusing files over [`MAX_FILE_BYTES`] before allocating.
pub(crate) fn read_capped(file: &Path, referenced_by: Option<String>) -> Result<Vec<u8>, SceneError> {
    let io_err = |e| match &referenced_by {
        Some(by) => SceneError::io_referenced(file, by.clone(), e),
        None => SceneError::io(file, e),
    };
    let meta = std::fs::metadata(file).map_err(io_err)?;
    if !meta.is_file() {
        return Err(io_err(std::io::Error::other("it is a directory or a device, not a regular file")));
    }
    if meta.len() > MAX_FILE_BYTES {
        return Err(SceneError::invalid(
            file,
            format!("the file has {} bytes, more than the limit of {MAX_FILE_BYTES}", meta.len()),
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
