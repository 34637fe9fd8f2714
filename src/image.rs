//! Linear RGB images and their file I/O (OpenEXR in and out, PNG out).
//!
//! Everything the renderer produces is linear, scene-referred RGB in `f32`,
//! so that is the one in-memory format ([`Image`]). Two ways out of it:
//!
//! * **EXR** ([`read_exr`], [`write_exr`]) keeps the values bit for bit:
//!   32-bit float, lossless ZIP compression, NaN and infinity preserved —
//!   it is the format for references, comparisons and anything measured.
//! * **PNG** ([`write_png_srgb`], [`to_srgb8`]) is for looking at: exposure,
//!   clamp to [0, 1], sRGB transfer curve, 8 bits. Pixels with a non-finite
//!   channel are painted magenta so that a NaN a user would otherwise never
//!   notice shows up as a loud colour.
//!
//! **Nothing is written half-way.** Every writer writes to a hidden
//! temporary file with a unique name next to the destination
//! (`.<name>.<pid>.<random>.tmp`) and renames it over the destination only
//! once everything has been written and flushed (see [`crate::staging`],
//! which also refuses destinations that are not regular files: links,
//! directories, devices, FIFOs, sockets).
//! A rename within one directory is atomic, so an interrupted or failed write
//! leaves either the old file or no file, never a truncated image that a later
//! comparison would silently read as garbage.
//!
//! Errors ([`ImageError`]) always name the file and say what to do; bad input
//! files give errors, never panics.

use std::fs::File;
use std::io::{self, BufWriter};
use std::path::{Path, PathBuf};

use rayon::prelude::*;

/// Largest width or height accepted from an EXR file. Real renders are far
/// below this; a header claiming more is corrupt or hostile, and trusting it
/// would make us allocate gigabytes before noticing.
pub const MAX_DIMENSION: u64 = 1 << 16;
/// Largest pixel count accepted from an EXR file (2^28 pixels is 3 GiB as
/// `[f32; 3]`), for the same reason as [`MAX_DIMENSION`].
pub const MAX_PIXELS: u64 = 1 << 28;

/// Rec. 709 / sRGB luminance weights (the primaries wedge renders in).
const LUMA_709: [f32; 3] = [0.2126, 0.7152, 0.0722];

/// First four bytes of every OpenEXR file.
const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// Colour used in 8-bit output for pixels with a non-finite channel.
pub const MAGENTA: [u8; 3] = [255, 0, 255];

/// A linear RGB image: `pixels` is row-major, top row first,
/// `pixels.len() == width * height`.
///
/// The fields are public so that passes can fill images directly; functions
/// that read an `Image` from outside this module treat a wrong `pixels`
/// length as an error (writers) or as missing pixels, not as a panic.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<[f32; 3]>,
}

impl Image {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Self {
        Image { width, height, pixels: vec![[0.0; 3]; width as usize * height as usize] }
    }

    /// An image whose pixel `(x, y)` is `f(x, y)`; `y = 0` is the top row.
    pub fn from_fn(width: u32, height: u32, f: impl Fn(u32, u32) -> [f32; 3]) -> Self {
        let mut pixels = Vec::with_capacity(width as usize * height as usize);
        for y in 0..height {
            for x in 0..width {
                pixels.push(f(x, y));
            }
        }
        Image { width, height, pixels }
    }

    /// Pixel `(x, y)`. Panics when out of bounds, like slice indexing: an
    /// out-of-bounds read here is a bug in the caller, not bad input.
    pub fn get(&self, x: u32, y: u32) -> [f32; 3] {
        assert!(x < self.width && y < self.height, "pixel ({x}, {y}) outside {}x{} image", self.width, self.height);
        self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// Per-pixel luminance with Rec. 709 weights (0.2126, 0.7152, 0.0722),
    /// on the linear values. Non-finite channels give non-finite luminance.
    pub fn luminance(&self) -> Vec<f32> {
        self.pixels.iter().map(|p| LUMA_709[0] * p[0] + LUMA_709[1] * p[1] + LUMA_709[2] * p[2]).collect()
    }

    /// `width * height` as usize (u32 × u32 always fits in u64; on 32-bit
    /// targets this can only be wrong for images that could not be allocated).
    fn pixel_count(&self) -> usize {
        (self.width as u64 * self.height as u64) as usize
    }
}

/// Everything that can go wrong reading or writing an image. Each message
/// names the file and ends with what the user can do about it.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    /// The file could not be opened or read at the OS level.
    #[error("cannot read {}: {source}; check that the file exists and is readable", path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: io::Error,
    },
    /// The file is not an OpenEXR file, or is damaged or uses a feature the
    /// `exr` crate cannot decode.
    #[error("{} is not a readable OpenEXR image ({reason}); pass a valid .exr file, e.g. re-save it as a scanline or tiled RGB(A) EXR", path.display())]
    NotExr { path: PathBuf, reason: String },
    /// The EXR has no layer with R, G and B channels.
    #[error("{} has no layer with R, G and B channels (found: {found}); wedge needs an RGB or RGBA image, re-export it with R, G and B channels", path.display())]
    MissingChannels { path: PathBuf, found: String },
    /// The header claims a size that is empty or absurdly large.
    #[error("{} claims to be {width}x{height} pixels, outside the accepted 1..={max_dim} per side and {max_pixels} pixels in all; the file is probably corrupt, re-export it (or crop it if it really is that large)", path.display(), max_dim = MAX_DIMENSION, max_pixels = MAX_PIXELS)]
    BadSize { path: PathBuf, width: u64, height: u64 },
    /// The file could not be created, written, or moved into place.
    #[error("cannot write {}: {source}; check that the directory exists and is writable and that the disk is not full", path.display())]
    Write {
        path: PathBuf,
        #[source]
        source: io::Error,
    },
    /// The destination exists and is not a regular file (a symbolic link, a directory, a device, a
    /// FIFO, a socket): wedge neither replaces it nor writes through it.
    #[error("refusing to write {}: it is a {kind}, not a regular file, and wedge replaces only regular files; choose another output path", path.display())]
    NotRegularFile { path: PathBuf, kind: &'static str },
    /// The output is one of the command's inputs under another name.
    #[error("refusing to write {}: it is the input {} (the same file), which would be lost; choose another output path", path.display(), input.display())]
    OverwritesInput { path: PathBuf, input: PathBuf },
    /// An output directory (`--out`) exists as something else, or lies under something that is not a
    /// directory.
    #[error("cannot write into {}: it is a {kind}, not a directory; outputs go into a directory (`--out` names one), so choose a path that is a directory or does not exist yet", path.display())]
    NotADirectory { path: PathBuf, kind: &'static str },
    /// The encoder refused the data (should not happen with valid input).
    #[error("cannot encode {}: {reason}; this is likely a bug in wedge, please report it", path.display())]
    Encode { path: PathBuf, reason: String },
    /// A pixel buffer does not match the stated dimensions.
    #[error("cannot write {}: the image is {width}x{height} but has {actual} values where {expected} are needed; this is a bug in the code that built the image", path.display())]
    BufferSize { path: PathBuf, width: u32, height: u32, expected: usize, actual: usize },
    /// Two outputs of one run would be written to the same file (a `Heatmap` node named like an image).
    #[error("cannot write {} for {second}: {first} already writes it; rename the Heatmap node (its file is `<node name>.png`)", path.display())]
    Clash { path: PathBuf, first: String, second: String },
    /// A zero-width or zero-height image cannot be stored in PNG/EXR.
    #[error("cannot write {}: the image is {width}x{height}, which has no pixels; render at least one pixel", path.display())]
    Empty { path: PathBuf, width: u32, height: u32 },
}

// ---------------------------------------------------------------------------
// Atomic writing
// ---------------------------------------------------------------------------

/// Runs `write` against a buffered temporary file with a unique name and renames it over `path`
/// only if `write` succeeded and the data reached the disk; see [`crate::staging`].
///
/// `pub(crate)` so other writers in the crate (heatmaps, reports) share the same guarantee.
pub(crate) fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> Result<(), ImageError>,
) -> Result<(), ImageError> {
    crate::staging::write_file_atomically(path, write)
}

// ---------------------------------------------------------------------------
// EXR
// ---------------------------------------------------------------------------

/// Reads the first layer that has R, G and B channels (A, if present, is
/// ignored) at full resolution. Half, float and uint samples are all
/// converted to `f32`; values are not altered otherwise (NaN stays NaN).
///
/// Before decoding any pixels the header is checked, so that a file that is
/// not an EXR, has no RGB layer, or claims an absurd size
/// (see [`MAX_DIMENSION`], [`MAX_PIXELS`]) gives an error instead of a huge
/// allocation.
pub fn read_exr(path: &Path) -> Result<Image, ImageError> {
    // Named imports, not the prelude glob: its `Image` would shadow ours.
    use exr::prelude::read_first_rgba_layer_from_file;

    let not_exr = |e: exr::error::Error| match e {
        exr::error::Error::Io(source) if source.kind() != io::ErrorKind::UnexpectedEof => {
            ImageError::Read { path: path.to_path_buf(), source }
        }
        other => ImageError::NotExr { path: path.to_path_buf(), reason: other.to_string() },
    };

    // Open explicitly first so "file missing" is an I/O error, not "not an EXR".
    let read_err = |source| ImageError::Read { path: path.to_path_buf(), source };
    let mut file = File::open(path).map_err(read_err)?;
    // Check the magic number ourselves: the exr crate's message for a PNG or
    // a text file ("reference to missing bytes") would not tell the user
    // that the file simply is not an EXR.
    let mut magic = [0u8; 4];
    let reason = match io::Read::read_exact(&mut file, &mut magic) {
        Ok(()) if magic == EXR_MAGIC => None,
        Ok(()) => Some("it does not start with the OpenEXR magic number"),
        Err(e) if e.kind() == io::ErrorKind::UnexpectedEof => Some("it is too short to be one"),
        Err(e) => return Err(read_err(e)),
    };
    if let Some(reason) = reason {
        return Err(ImageError::NotExr { path: path.to_path_buf(), reason: reason.to_string() });
    }
    io::Seek::rewind(&mut file).map_err(read_err)?;
    let meta = exr::meta::MetaData::read_from_unbuffered(file, false).map_err(not_exr)?;

    // Size check over *all* headers: the reader may allocate per layer.
    for header in meta.headers.iter() {
        let (w, h) = (header.layer_size.0 as u64, header.layer_size.1 as u64);
        if w == 0 || h == 0 || w > MAX_DIMENSION || h > MAX_DIMENSION || w.saturating_mul(h) > MAX_PIXELS {
            return Err(ImageError::BadSize { path: path.to_path_buf(), width: w, height: h });
        }
    }
    let has_rgb = |header: &exr::meta::header::Header| {
        ["R", "G", "B"].iter().all(|&c| header.channels.list.iter().any(|ch| ch.name.eq(c)))
    };
    if !meta.headers.iter().any(has_rgb) {
        let found: Vec<String> =
            meta.headers.iter().flat_map(|h| h.channels.list.iter().map(|ch| ch.name.to_string())).collect();
        let found = if found.is_empty() { "no channels".to_string() } else { found.join(", ") };
        return Err(ImageError::MissingChannels { path: path.to_path_buf(), found });
    }

    let decoded = read_first_rgba_layer_from_file(
        path,
        |resolution, _channels| Image::new(resolution.width() as u32, resolution.height() as u32),
        |img: &mut Image, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            let i = pos.y() * img.width as usize + pos.x();
            img.pixels[i] = [r, g, b];
        },
    )
    .map_err(not_exr)?;
    Ok(decoded.layer_data.channel_data.pixels)
}

/// Writes `img` as a single-layer, 32-bit float RGB EXR (lossless ZIP,
/// scanlines — the most widely readable layout). Values are stored exactly,
/// including NaN and infinities, so a round trip is bit-exact.
pub fn write_exr(path: &Path, img: &Image) -> Result<(), ImageError> {
    use exr::prelude::{Blocks, Compression, Encoding, LineOrder, SpecificChannels, Vec2, WritableImage};

    check_buffer(path, img.width, img.height, img.pixels.len(), img.pixel_count())?;
    let width = img.width as usize;
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let p = img.pixels[y * width + x];
        (p[0], p[1], p[2])
    });
    let encoding =
        Encoding { compression: Compression::ZIP16, blocks: Blocks::ScanLines, line_order: LineOrder::Increasing };
    let exr_image = exr::image::Image::from_encoded_channels((width, img.height as usize), encoding, channels);
    write_atomically(path, |out| {
        let w = exr_image.write();
        let written = if one_thread() { w.non_parallel().to_buffered(out) } else { w.to_buffered(out) };
        written.map_err(|e| match e {
            exr::error::Error::Io(source) => ImageError::Write { path: path.to_path_buf(), source },
            other => ImageError::Encode { path: path.to_path_buf(), reason: other.to_string() },
        })
    })
}

/// Writes `pixels` (`width × height`, row-major, top row first) as a single-layer, 32-bit float RGBA
/// EXR, like [`write_exr`] (lossless ZIP, scanlines, atomic). For maps whose fourth channel carries
/// data, e.g. `aov_position.exr`'s coverage in A.
pub fn write_exr_rgba(path: &Path, width: u32, height: u32, pixels: &[[f32; 4]]) -> Result<(), ImageError> {
    use exr::prelude::{Blocks, Compression, Encoding, LineOrder, SpecificChannels, Vec2, WritableImage};

    check_buffer(path, width, height, pixels.len(), width as usize * height as usize)?;
    let w = width as usize;
    let channels = SpecificChannels::rgba(|Vec2(x, y): Vec2<usize>| {
        let p = pixels[y * w + x];
        (p[0], p[1], p[2], p[3])
    });
    let encoding =
        Encoding { compression: Compression::ZIP16, blocks: Blocks::ScanLines, line_order: LineOrder::Increasing };
    let exr_image = exr::image::Image::from_encoded_channels((w, height as usize), encoding, channels);
    write_atomically(path, |out| {
        let w = exr_image.write();
        let written = if one_thread() { w.non_parallel().to_buffered(out) } else { w.to_buffered(out) };
        written.map_err(|e| match e {
            exr::error::Error::Io(source) => ImageError::Write { path: path.to_path_buf(), source },
            other => ImageError::Encode { path: path.to_path_buf(), reason: other.to_string() },
        })
    })
}

/// Whether the process runs one thread (`--threads 1`): EXRs are then compressed on the calling
/// thread (`non_parallel`), so that no compressor thread runs beside the one the user allowed. The
/// bytes are the same either way (blocks are written in line order).
/// Peak bytes the writers hold besides the image itself while writing one `width × height` image
/// as EXR and then PNG (the two run one after the other, so the larger counts):
/// - PNG ([`write_png_srgb`]): the sRGB bytes (3 per pixel), and the png crate's whole zlib stream,
///   which it builds in one `Vec` before writing the IDAT chunks (at most about the input, 3 per
///   pixel plus a filter byte per row, for an image that does not compress);
/// - EXR ([`write_exr`]): the exr crate keeps one ZIP16 block (16 rows of f32 RGB) per compressor
///   thread plus two in flight, each uncompressed and compressed (at most the same size again).
///
/// The tiled render's memory estimate counts them: an 8K render under a 4 GiB limit peaked at
/// 4.09 GiB without them (`crate::tiles::tiled_bytes`).
pub fn encoder_bytes(width: u32, height: u32) -> u64 {
    let (w, h) = (u64::from(width), u64::from(height));
    let png = w * h * 3 + (w * 3 + 1) * h;
    let threads = if one_thread() { 1 } else { rayon::current_num_threads() as u64 + 2 };
    let exr = threads * 2 * 16 * w * 12;
    png.max(exr)
}

fn one_thread() -> bool {
    rayon::current_num_threads() <= 1
}

fn check_buffer(path: &Path, width: u32, height: u32, actual: usize, expected: usize) -> Result<(), ImageError> {
    if width == 0 || height == 0 {
        return Err(ImageError::Empty { path: path.to_path_buf(), width, height });
    }
    if actual != expected {
        return Err(ImageError::BufferSize { path: path.to_path_buf(), width, height, expected, actual });
    }
    Ok(())
}

// ---------------------------------------------------------------------------
// PNG / 8-bit sRGB
// ---------------------------------------------------------------------------

/// The sRGB opto-electronic transfer function (IEC 61966-2-1), for `v` in [0, 1].
#[inline]
fn srgb_oetf(v: f32) -> f32 {
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// One linear value → 8-bit sRGB code: multiply by `exposure`, clamp to
/// [0, 1] (NaN from e.g. `0 * inf` exposure counts as 0), encode, round.
#[inline]
fn encode_channel(v: f32, exposure: f32) -> u8 {
    let e = v * exposure;
    let e = if e.is_nan() { 0.0 } else { e.clamp(0.0, 1.0) };
    (srgb_oetf(e) * 255.0 + 0.5) as u8
}

/// Converts to interleaved 8-bit sRGB (`width * height * 3` bytes, row-major,
/// top row first): each channel is multiplied by `exposure` (a linear scale,
/// 1.0 = unchanged), clamped to [0, 1] and encoded with the sRGB curve.
/// A pixel with any non-finite channel becomes [`MAGENTA`] so that it is
/// visible rather than silently clamped to black or white.
pub fn to_srgb8(img: &Image, exposure: f32) -> Vec<u8> {
    let mut out = vec![0u8; img.pixels.len() * 3];
    // Parallel because this runs on every preview of full-size renders and
    // the powf per channel dominates.
    out.par_chunks_mut(3).zip(img.pixels.par_iter()).for_each(|(o, p)| {
        if p.iter().all(|c| c.is_finite()) {
            for c in 0..3 {
                o[c] = encode_channel(p[c], exposure);
            }
        } else {
            o.copy_from_slice(&MAGENTA);
        }
    });
    out
}

/// Writes `img` as an 8-bit sRGB PNG after [`to_srgb8`] (exposure, clamp,
/// sRGB curve, magenta for non-finite pixels).
pub fn write_png_srgb(path: &Path, img: &Image, exposure: f32) -> Result<(), ImageError> {
    check_buffer(path, img.width, img.height, img.pixels.len(), img.pixel_count())?;
    let rgb = to_srgb8(img, exposure);
    write_png_rgb8(path, img.width, img.height, &rgb)
}

/// Writes already-encoded interleaved RGB8 data (`width * height * 3` bytes,
/// top row first) as a PNG. Used for previews, heatmaps and FLIP maps.
pub fn write_png_rgb8(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<(), ImageError> {
    use ::image::ImageEncoder;

    let expected = (width as u64 * height as u64 * 3) as usize;
    check_buffer(path, width, height, rgb.len(), expected)?;
    write_atomically(path, |out| {
        ::image::codecs::png::PngEncoder::new(out)
            .write_image(rgb, width, height, ::image::ExtendedColorType::Rgb8)
            .map_err(|e| match e {
                ::image::ImageError::IoError(source) => ImageError::Write { path: path.to_path_buf(), source },
                other => ImageError::Encode { path: path.to_path_buf(), reason: other.to_string() },
            })
    })
}

/// A looping animated GIF written one frame at a time, so a sequence of any length holds one
/// frame in memory (`render --frames` streams its preview through it). Each frame is encoded as
/// [`to_srgb8`] encodes it for a PNG, quantised to GIF's 256-colour palette (NeuQuant, `gif`'s
/// speed 10). The file is complete only after [`GifStream::finish`] wrote the trailer and synced it;
/// it is meant to be written inside a [`crate::staging::Staging`] set, whose commit makes it visible.
pub struct GifStream {
    path: PathBuf,
    encoder: gif::Encoder<BufWriter<File>>,
    width: u32,
    height: u32,
    /// Display time of each frame in centiseconds (GIF's unit).
    delay: u16,
}

impl GifStream {
    /// Start `path` (created or truncated) for `width × height` frames shown at `fps` frames per second.
    pub fn create(path: &Path, width: u32, height: u32, fps: u32) -> Result<GifStream, ImageError> {
        let too_big = || ImageError::Encode {
            path: path.to_path_buf(),
            reason: format!("{width}x{height} is larger than a GIF can hold (65535 pixels a side)"),
        };
        let (w, h) = (u16::try_from(width).map_err(|_| too_big())?, u16::try_from(height).map_err(|_| too_big())?);
        let file = File::create(path).map_err(|source| ImageError::Write { path: path.to_path_buf(), source })?;
        let mut encoder = gif::Encoder::new(BufWriter::new(file), w, h, &[]).map_err(|e| gif_error(path, e))?;
        encoder.set_repeat(gif::Repeat::Infinite).map_err(|e| gif_error(path, e))?;
        let delay = u16::try_from((100 / fps.max(1)).max(1)).unwrap_or(u16::MAX);
        Ok(GifStream { path: path.to_path_buf(), encoder, width, height, delay })
    }

    /// Append one frame (the size given to [`GifStream::create`]).
    pub fn push(&mut self, img: &Image) -> Result<(), ImageError> {
        check_buffer(&self.path, img.width, img.height, img.pixels.len(), img.pixel_count())?;
        if (img.width, img.height) != (self.width, self.height) {
            return Err(ImageError::Encode {
                path: self.path.clone(),
                reason: format!("a {}x{} frame in a {}x{} animation", img.width, img.height, self.width, self.height),
            });
        }
        let rgb = to_srgb8(img, 1.0);
        let mut frame = gif::Frame::from_rgb_speed(self.width as u16, self.height as u16, &rgb, 10);
        frame.delay = self.delay;
        self.encoder.write_frame(&frame).map_err(|e| gif_error(&self.path, e))
    }

    /// Write the trailer, flush and sync: after this the file is a complete GIF.
    pub fn finish(self) -> Result<(), ImageError> {
        let path = self.path;
        let out = self.encoder.into_inner().map_err(|e| gif_error(&path, e))?;
        let file = out.into_inner().map_err(|e| ImageError::Write { path: path.clone(), source: e.into_error() })?;
        file.sync_all().map_err(|source| ImageError::Write { path, source })
    }
}

/// A `gif` encoding error as an [`ImageError`] naming `path` (I/O errors keep their cause: a full
/// disk must say so).
fn gif_error(path: &Path, e: gif::EncodingError) -> ImageError {
    match e {
        gif::EncodingError::Io(source) => ImageError::Write { path: path.to_path_buf(), source },
        other => ImageError::Encode { path: path.to_path_buf(), reason: other.to_string() },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs;
    use std::io::Write;

    fn gradient(w: u32, h: u32) -> Image {
        Image::from_fn(w, h, |x, y| [x as f32 * 0.37 - 1.0, y as f32 * 1e-3, (x * y) as f32 * 123.456])
    }

    fn dir_entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> =
            fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        v.sort();
        v
    }

    #[test]
    fn constructors_get_and_luminance() {
        let img = Image::from_fn(3, 2, |x, y| [x as f32, y as f32, 1.0]);
        assert_eq!(img.pixels.len(), 6);
        assert_eq!(img.get(2, 1), [2.0, 1.0, 1.0]);
        assert_eq!(img.pixels[5], [2.0, 1.0, 1.0], "row-major, top row first");
        assert_eq!(Image::new(2, 2).pixels, vec![[0.0; 3]; 4]);
        let lum = Image::from_fn(1, 1, |_, _| [1.0, 1.0, 1.0]).luminance();
        assert!((lum[0] - 1.0).abs() < 1e-6, "weights sum to one");
        let lum = Image::from_fn(3, 1, |x, _| {
            let mut p = [0.0; 3];
            p[x as usize] = 1.0;
            p
        })
        .luminance();
        assert_eq!(lum, vec![0.2126, 0.7152, 0.0722]);
    }

    #[test]
    fn exr_round_trip_is_exact() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.exr");
        let mut img = gradient(37, 19);
        // Values a lossy or half-float path would alter, and non-finite ones
        // that EXR must keep as they are.
        img.pixels[0] = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY];
        img.pixels[1] = [1.0e-30, 3.402_823e38, 0.1];
        write_exr(&path, &img).unwrap();
        let back = read_exr(&path).unwrap();
        assert_eq!((back.width, back.height), (37, 19));
        for (a, b) in img.pixels.iter().zip(&back.pixels) {
            for c in 0..3 {
                assert_eq!(a[c].to_bits(), b[c].to_bits());
            }
        }
        assert_eq!(dir_entries(dir.path()), vec!["a.exr"], "no temporary file left behind");
    }

    #[test]
    fn exr_half_rgba_is_read() {
        use exr::prelude::*;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("half.exr");
        write_rgba_file(&path, 4, 3, |x, y| {
            (f16::from_f32(x as f32), f16::from_f32(y as f32 * 0.5), f16::from_f32(2.0), f16::from_f32(0.25))
        })
        .unwrap();
        let img = read_exr(&path).unwrap();
        assert_eq!((img.width, img.height), (4, 3));
        assert_eq!(img.get(3, 2), [3.0, 1.0, 2.0]);
    }

    #[test]
    fn exr_without_rgb_is_an_error_naming_channels() {
        use exr::prelude::*;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("depth.exr");
        let layer = Layer::new(
            (2, 2),
            LayerAttributes::named("main"),
            Encoding::UNCOMPRESSED,
            AnyChannels::sort(SmallVec::from_vec(vec![AnyChannel::new("Z", FlatSamples::F32(vec![1.0; 4]))])),
        );
        exr::image::Image::from_layer(layer).write().to_file(&path).unwrap();
        let err = read_exr(&path).unwrap_err();
        assert!(matches!(err, ImageError::MissingChannels { .. }), "{err:?}");
        let msg = err.to_string();
        assert!(msg.contains("depth.exr") && msg.contains('Z'), "{msg}");
    }

    #[test]
    fn absurd_exr_size_is_rejected_before_decoding() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("huge.exr");
        write_exr(&path, &gradient(2, 2)).unwrap();
        let mut bytes = fs::read(&path).unwrap();
        // Patch the dataWindow (box2i: xmin, ymin, xmax, ymax as i32 LE)
        // to claim 1,000,000 x 1,000,000 pixels.
        let key = b"dataWindow\0box2i\0";
        let at = bytes.windows(key.len()).position(|w| w == key).unwrap() + key.len() + 4;
        bytes[at + 8..at + 12].copy_from_slice(&999_999i32.to_le_bytes());
        bytes[at + 12..at + 16].copy_from_slice(&999_999i32.to_le_bytes());
        fs::write(&path, &bytes).unwrap();
        let err = read_exr(&path).unwrap_err();
        assert!(matches!(err, ImageError::BadSize { width: 1_000_000, height: 1_000_000, .. }), "{err:?}");
        assert!(err.to_string().contains("huge.exr"));
    }

    #[test]
    fn non_exr_and_missing_files_are_errors_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("notes.exr");
        fs::write(&path, b"this is plain text, not an image").unwrap();
        let err = read_exr(&path).unwrap_err();
        assert!(matches!(err, ImageError::NotExr { .. }), "{err:?}");
        assert!(err.to_string().contains("notes.exr") && err.to_string().contains("magic"), "{err}");
        let empty = dir.path().join("empty.exr");
        fs::write(&empty, b"").unwrap();
        assert!(matches!(read_exr(&empty), Err(ImageError::NotExr { .. })));

        // A PNG is not an EXR either.
        let png = dir.path().join("pic.png");
        write_png_rgb8(&png, 1, 1, &[1, 2, 3]).unwrap();
        let err = read_exr(&png).unwrap_err();
        assert!(err.to_string().contains("pic.png"), "{err}");

        // Truncated EXR: valid header, pixels cut off.
        let trunc = dir.path().join("trunc.exr");
        write_exr(&trunc, &gradient(64, 64)).unwrap();
        let bytes = fs::read(&trunc).unwrap();
        fs::write(&trunc, &bytes[..bytes.len() / 2]).unwrap();
        let err = read_exr(&trunc).unwrap_err();
        assert!(err.to_string().contains("trunc.exr"), "{err}");

        let missing = dir.path().join("missing.exr");
        let err = read_exr(&missing).unwrap_err();
        assert!(matches!(err, ImageError::Read { .. }), "{err:?}");
        assert!(err.to_string().contains("missing.exr"), "{err}");
    }

    #[test]
    fn srgb_encoding_of_known_values() {
        let img = Image::from_fn(4, 1, |x, _| {
            let v = [0.0, 0.5, 1.0, 2.0][x as usize];
            [v, v, v]
        });
        let rgb = to_srgb8(&img, 1.0);
        assert_eq!(rgb, vec![0, 0, 0, 188, 188, 188, 255, 255, 255, 255, 255, 255]);
        // Exposure is a plain multiply: 0.25 * 2 = 0.5 -> 188; negatives clamp to 0.
        let img = Image::from_fn(2, 1, |x, _| if x == 0 { [0.25; 3] } else { [-1.0; 3] });
        assert_eq!(to_srgb8(&img, 2.0), vec![188, 188, 188, 0, 0, 0]);
        // The linear segment near black: 0.001 * 12.92 * 255 = 3.29 -> 3.
        assert_eq!(encode_channel(0.001, 1.0), 3);
    }

    #[test]
    fn non_finite_pixels_are_magenta_in_png_output() {
        let img = Image::from_fn(3, 1, |x, _| match x {
            0 => [f32::NAN, 0.0, 0.0],
            1 => [0.0, f32::INFINITY, 0.0],
            _ => [0.5; 3],
        });
        let rgb = to_srgb8(&img, 1.0);
        assert_eq!(&rgb[0..3], &MAGENTA);
        assert_eq!(&rgb[3..6], &MAGENTA);
        assert_eq!(&rgb[6..9], &[188, 188, 188]);
    }

    #[test]
    fn png_written_and_decodable() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.png");
        let img = Image::from_fn(5, 3, |x, y| [x as f32 / 4.0, y as f32 / 2.0, 0.5]);
        write_png_srgb(&path, &img, 1.0).unwrap();
        let decoded = ::image::open(&path).unwrap().to_rgb8();
        assert_eq!(decoded.dimensions(), (5, 3));
        assert_eq!(decoded.as_raw(), &to_srgb8(&img, 1.0));
        // Overwriting an existing file works (rename over the destination).
        write_png_srgb(&path, &Image::new(5, 3), 1.0).unwrap();
        assert_eq!(::image::open(&path).unwrap().to_rgb8().as_raw(), &vec![0u8; 45]);
        assert_eq!(dir_entries(dir.path()), vec!["out.png"]);
    }

    #[test]
    fn writing_into_a_missing_directory_fails_and_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("no").join("such");
        let img = gradient(4, 4);
        for (name, result) in [
            ("x.exr", write_exr(&missing.join("x.exr"), &img)),
            ("x.png", write_png_srgb(&missing.join("x.png"), &img, 1.0)),
        ] {
            let err = result.unwrap_err();
            assert!(matches!(err, ImageError::Write { .. }), "{err:?}");
            assert!(err.to_string().contains(name), "{err}");
        }
        assert!(dir_entries(dir.path()).is_empty(), "nothing created");
    }

    #[test]
    fn failed_write_keeps_the_previous_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("keep.png");
        write_png_rgb8(&path, 1, 1, &[9, 9, 9]).unwrap();
        let before = fs::read(&path).unwrap();
        // Encoder error midway (simulated): the destination is untouched
        // and the temporary file is cleaned up.
        let err = write_atomically(&path, |out| {
            out.write_all(b"partial").unwrap();
            Err(ImageError::Encode { path: path.clone(), reason: "simulated".into() })
        })
        .unwrap_err();
        assert!(matches!(err, ImageError::Encode { .. }));
        assert_eq!(fs::read(&path).unwrap(), before);
        assert_eq!(dir_entries(dir.path()), vec!["keep.png"]);
    }

    #[test]
    fn bad_buffers_are_errors_not_panics() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.png");
        let err = write_png_rgb8(&path, 2, 2, &[0; 5]).unwrap_err();
        assert!(matches!(err, ImageError::BufferSize { expected: 12, actual: 5, .. }), "{err:?}");
        let err = write_png_rgb8(&path, 0, 2, &[]).unwrap_err();
        assert!(matches!(err, ImageError::Empty { .. }), "{err:?}");
        let mut img = Image::new(2, 2);
        img.pixels.pop();
        assert!(matches!(write_exr(&dir.path().join("bad.exr"), &img), Err(ImageError::BufferSize { .. })));
        assert!(dir_entries(dir.path()).is_empty());
    }
}
