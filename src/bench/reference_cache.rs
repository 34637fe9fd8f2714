//! On-disk cache of benchmark references, so reruns skip the most expensive render.
//!
//! A reference is stored as `<dir>/<key>.exr` (the image, lossless 32-bit float) and
//! `<dir>/<key>.txt` (what it is: one `name=value` per line). The key is a 64-bit FNV-1a hash of
//! a canonical description of everything the image depends on — the pipeline file's contents, the
//! scene spec (and the scene file's contents when it is a file), seed, resolution, sample count,
//! sampling, a format version and a hash of the running executable — and the description itself is stored and compared on load,
//! so a hash collision or a stale file reads as a miss, never as a wrong reference.

use std::fs;
use std::path::{Path, PathBuf};

use crate::image::{read_exr, write_exr, Image, ImageError};

/// Bump when the way references are made changes (seeds of the halves, averaging, …).
const FORMAT_VERSION: u32 = 1;

/// Hash of the running executable: a reference rendered by a different build (a sampler fix, a
/// new estimator) is a miss, not a silently stale answer. Falls back to the crate version when the
/// executable cannot be read.
fn renderer_fingerprint() -> String {
    static FP: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    FP.get_or_init(|| {
        std::env::current_exe()
            .and_then(fs::read)
            .map(|bytes| format!("{:016x}", fnv1a64(&bytes)))
            .unwrap_or_else(|_| env!("CARGO_PKG_VERSION").to_string())
    })
    .clone()
}

/// What a reference depends on.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceSpec {
    /// Contents of the pipeline file.
    pub pipeline_text: String,
    /// The effective scene spec (command-line override or the pipeline's).
    pub scene: String,
    /// Contents of the scene file, when the scene is a readable file.
    pub scene_bytes: Option<Vec<u8>>,
    pub seed: u32,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub sampling: String,
    /// The `--set` overrides the reference was rendered with (`NODE.PARAM=VALUE`, space-separated).
    pub params: String,
    /// Framed by the scene's own camera, not the pipeline's block ([`super::BenchOptions::scene_camera`]).
    pub scene_camera: bool,
}

/// 64-bit FNV-1a.
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in bytes {
        h ^= *b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

impl ReferenceSpec {
    /// One line naming everything the image depends on (file contents by hash).
    pub fn description(&self) -> String {
        format!(
            "v{FORMAT_VERSION} wedge {} build {} pipeline {:016x} scene {:?} scene-file {} seed {} size {}x{} spp {} sampling {} set {:?} scene-camera {}",
            env!("CARGO_PKG_VERSION"),
            renderer_fingerprint(),
            fnv1a64(self.pipeline_text.as_bytes()),
            self.scene,
            self.scene_bytes.as_ref().map_or("-".to_string(), |b| format!("{:016x}", fnv1a64(b))),
            self.seed,
            self.width,
            self.height,
            self.spp,
            self.sampling,
            self.params,
            self.scene_camera
        )
    }
    /// The cache key: 16 hex digits.
    pub fn key(&self) -> String {
        format!("{:016x}", fnv1a64(self.description().as_bytes()))
    }
}

/// A reference image with what is known about it.
#[derive(Clone, Debug)]
pub struct StoredReference {
    pub image: Image,
    /// Estimated RMSE of the reference itself (see [`super::stats::reference_noise_rmse`]).
    pub noise_rmse: f64,
    /// Seconds the render took when it was made.
    pub render_seconds: f64,
    pub exr: PathBuf,
}

pub fn paths(dir: &Path, spec: &ReferenceSpec) -> (PathBuf, PathBuf) {
    let key = spec.key();
    (dir.join(format!("{key}.exr")), dir.join(format!("{key}.txt")))
}

/// The cached reference for `spec`, or `None` on a miss (absent, unreadable, or made for
/// something else).
pub fn load(dir: &Path, spec: &ReferenceSpec) -> Option<StoredReference> {
    let (exr, meta) = paths(dir, spec);
    let text = fs::read_to_string(&meta).ok()?;
    let field = |name: &str| {
        text.lines().find_map(|l| l.strip_prefix(name).and_then(|r| r.strip_prefix('=')).map(str::to_string))
    };
    if field("description")? != spec.description() {
        return None;
    }
    // A value no render can produce (NaN, inf, negative, or so large its square overflows) means
    // the file is corrupt or hand-edited: a miss, so the reference is rendered again.
    let noise_rmse: f64 = field("noise_rmse")?.parse().ok().filter(|v: &f64| *v >= 0.0 && (v * v).is_finite())?;
    let render_seconds: f64 = field("render_seconds")?.parse().ok().filter(|v: &f64| *v >= 0.0 && v.is_finite())?;
    let image = read_exr(&exr).ok()?;
    if (image.width, image.height) != (spec.width, spec.height) {
        return None;
    }
    Some(StoredReference { image, noise_rmse, render_seconds, exr })
}

/// Write the reference and its description; the image first, so a description never points at a
/// missing image.
pub fn store(
    dir: &Path,
    spec: &ReferenceSpec,
    image: &Image,
    noise_rmse: f64,
    render_seconds: f64,
) -> Result<PathBuf, ImageError> {
    fs::create_dir_all(dir).map_err(|source| ImageError::Write { path: dir.to_path_buf(), source })?;
    let (exr, meta) = paths(dir, spec);
    write_exr(&exr, image)?;
    let text = format!(
        "description={}\nnoise_rmse={noise_rmse:e}\nrender_seconds={render_seconds}\nspp={}\nsampling={}\n",
        spec.description(),
        spec.spp,
        spec.sampling
    );
    crate::image::write_atomically(&meta, |out| {
        std::io::Write::write_all(out, text.as_bytes())
            .map_err(|source| ImageError::Write { path: meta.clone(), source })
    })?;
    Ok(exr)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> ReferenceSpec {
        ReferenceSpec {
            pipeline_text: "Pipeline(...)".into(),
            scene: "builtin:grids".into(),
            scene_bytes: None,
            seed: 1,
            width: 4,
            height: 3,
            spp: 64,
            sampling: "stratified".into(),
            params: String::new(),
            scene_camera: false,
        }
    }

    #[test]
    fn fnv_known_values() {
        assert_eq!(fnv1a64(b""), 0xcbf29ce484222325);
        assert_eq!(fnv1a64(b"a"), 0xaf63dc4c8601ec8c);
    }

    #[test]
    fn key_changes_with_every_input() {
        let base = spec().key();
        let mut s = spec();
        s.seed = 2;
        assert_ne!(s.key(), base);
        let mut s = spec();
        s.pipeline_text.push(' ');
        assert_ne!(s.key(), base);
        let mut s = spec();
        s.spp = 128;
        assert_ne!(s.key(), base);
        let mut s = spec();
        s.scene_bytes = Some(vec![1, 2]);
        assert_ne!(s.key(), base);
        let mut s = spec();
        s.params = "defocus.aperture_radius=Float(0.05)".into();
        assert_ne!(s.key(), base);
        let mut s = spec();
        s.scene_camera = true;
        assert_ne!(s.key(), base);
        assert_eq!(spec().key(), base);
    }

    #[test]
    fn store_then_load_round_trips_and_rejects_other_specs() {
        let dir = tempfile::tempdir().unwrap();
        let img = Image::from_fn(4, 3, |x, y| [x as f32, y as f32, 0.5]);
        assert!(load(dir.path(), &spec()).is_none());
        store(dir.path(), &spec(), &img, 1.5e-3, 2.0).unwrap();
        let r = load(dir.path(), &spec()).unwrap();
        assert_eq!(r.image, img);
        assert_eq!((r.noise_rmse, r.render_seconds), (1.5e-3, 2.0));
        let mut other = spec();
        other.width = 5;
        assert!(load(dir.path(), &other).is_none());
    }

    #[test]
    fn corrupt_numbers_in_the_description_are_a_miss() {
        let dir = tempfile::tempdir().unwrap();
        let img = Image::from_fn(4, 3, |x, y| [x as f32, y as f32, 0.5]);
        let (_, meta) = paths(dir.path(), &spec());
        for (field, bad) in [
            ("noise_rmse", "1e300"),
            ("noise_rmse", "NaN"),
            ("noise_rmse", "inf"),
            ("noise_rmse", "-1"),
            ("noise_rmse", "x"),
            ("render_seconds", "inf"),
            ("render_seconds", "-2"),
        ] {
            store(dir.path(), &spec(), &img, 1.5e-3, 2.0).unwrap();
            let text = fs::read_to_string(&meta).unwrap();
            let edited: String = text
                .lines()
                .map(
                    |l| if l.starts_with(&format!("{field}=")) { format!("{field}={bad}\n") } else { format!("{l}\n") },
                )
                .collect();
            fs::write(&meta, edited).unwrap();
            assert!(load(dir.path(), &spec()).is_none(), "{field}={bad} must be a cache miss");
        }
    }
}
