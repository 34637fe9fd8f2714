//! The real world of a mixed-reality render (thesis Ch. 6.1–6.5, issue 15): what a camera captured and
//! the geometry behind each of its pixels, as scene data beside the triangles.
//!
//! The thesis's MR system inserts virtual objects into a photograph. The real scene is never a mesh:
//! it is known per pixel of the camera image, as
//!
//! - **`camera`**: the photograph `L_cam` itself, linear RGB radiance (the real surfaces' outgoing
//!   radiance toward the camera; differential compositing adds to it and screen-space indirect rays
//!   look it up);
//! - **`position`**: the world-space point the pixel centre sees (metres, the frame the virtual meshes
//!   and the camera are placed in), and in `w` the **coverage**: 1 where a real surface covers the
//!   pixel centre, 0 where none does (the environment is seen there). Screen-space rays march this
//!   map to intersect real geometry;
//! - **`normal`**: the unit world-space normal there (0 where not covered);
//! - **`albedo`**: the real surface's diffuse albedo `k_d`, linear RGB in [0, 1] (0 where not covered;
//!   a capture that does not have one per pixel gives a constant, [`RealAlbedo::Constant`]).
//!
//! All four maps have the camera image's resolution, row 0 at the top, column 0 at the left (as the
//! renderer's images), and pixel `(x, y)` is the ray through the pixel centre `(x + 0.5, y + 0.5)`
//! of the pipeline's camera. `wedge render --aov position,normal,albedo` writes exactly these maps for
//! any scene (`aov_position.exr`, `aov_normal.exr`, `aov_albedo.exr`), so a wedge render can stand in
//! for a capture.
//!
//! # Files ([`RealLayer::open`])
//!
//! OpenEXR (`.exr`, half or float, RGB or RGBA) for every map; the camera image and the albedo may also
//! be PNG or JPEG (8 or 16 bits, sRGB-encoded: decoded to linear). Positions and normals must be EXR:
//! an 8-bit image cannot hold world coordinates or unit vectors. The position map's `A` channel is the
//! coverage; a position map without `A` is covered everywhere. Other maps' `A` is ignored.
//!
//! # Checks ([`RealLayer::from_maps`], and every file through it)
//!
//! Nothing is clamped or repaired silently, except that normals are renormalised (a half-float EXR
//! cannot store a unit vector exactly). Refused, each with the map, the count of bad pixels of each
//! kind and the first one's column and row:
//!
//! - sizes: every map `width × height` pixels, `1 ≤ width, height ≤ MAX_TEXTURE_SIDE`, at most
//!   `MAX_TEXTURE_PIXELS` pixels ([`crate::limits`]), and (files) equal across the four maps;
//! - coverage not exactly 0 or 1 (a soft matte must be thresholded by the user: a half-covered pixel
//!   has no single position);
//! - the camera image anywhere: NaN, infinite, negative, or over `MAX_RADIANCE`;
//! - where covered: a non-finite position or one beyond `MAX_COORDINATE`, a non-finite normal or one
//!   whose length is outside `0.5 ..= 2` (not a normal map: maybe an encoded `0.5·n + 0.5` image), a
//!   non-finite or negative albedo, or one over 1 (a surface reflecting more than it receives creates
//!   energy).
//!
//! Where a pixel is not covered, its position, normal and albedo carry no meaning, so whatever the file
//! holds there (renderers often write 0, NaN or infinity for "no hit") is ignored and stored as 0.
//!
//! The GPU receives the layer as one scene array of four `vec4<f32>` per pixel
//! (`backends/src/gpu/scene.rs`, `shaders/real_layer.wgsl`), followed by the depth pyramid the
//! screen-space tracer skips by (`wedge_backends::kernels::screen_trace::DepthPyramid`).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use glam::Vec3;

use crate::limits::{MAX_COORDINATE, MAX_RADIANCE, MAX_TEXTURE_PIXELS, MAX_TEXTURE_SIDE};
use crate::SceneError;

/// Shortest and longest normal accepted before renormalising: wider than half-float rounding and
/// 8-bit quantisation could ever produce, narrow enough to catch an `0.5·n + 0.5`-encoded map (whose
/// "normals" are about 0.87 long only by accident) only where it is far off, and a map of zeros.
pub const NORMAL_LENGTH_RANGE: (f32, f32) = (0.5, 2.0);

/// Where the real surfaces' diffuse albedo comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum RealAlbedo {
    /// A map file (`.exr` linear, or `.png`/`.jpg` sRGB), the camera image's size.
    Map(PathBuf),
    /// One albedo for every covered pixel (linear RGB, each in [0, 1]).
    Constant([f32; 3]),
}

/// The captured real world of a mixed-reality render: per pixel of the camera image, the image
/// itself, the world position and coverage, the normal and the diffuse albedo (module doc). Cheap to
/// clone: the maps are shared.
#[derive(Clone)]
pub struct RealLayer {
    name: String,
    width: u32,
    height: u32,
    maps: Arc<Maps>,
}

struct Maps {
    camera: Vec<[f32; 3]>,
    position: Vec<[f32; 4]>,
    normal: Vec<[f32; 3]>,
    albedo: Vec<[f32; 3]>,
}

impl std::fmt::Debug for RealLayer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RealLayer")
            .field("name", &self.name)
            .field("width", &self.width)
            .field("height", &self.height)
            .field("covered", &self.covered_count())
            .finish()
    }
}

/// The four maps, for messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Which {
    Camera,
    Position,
    Normal,
    Albedo,
}

impl Which {
    fn what(self) -> &'static str {
        match self {
            Which::Camera => "camera image",
            Which::Position => "position map",
            Which::Normal => "normal map",
            Which::Albedo => "albedo map",
        }
    }
}

/// Where each map came from, for error messages: a file, or (in memory) the layer's name.
struct Sources<'a> {
    camera: &'a Path,
    position: &'a Path,
    normal: &'a Path,
    albedo: &'a Path,
}

impl Sources<'_> {
    fn of(&self, which: Which) -> &Path {
        match which {
            Which::Camera => self.camera,
            Which::Position => self.position,
            Which::Normal => self.normal,
            Which::Albedo => self.albedo,
        }
    }
}

impl RealLayer {
    /// A layer from maps in memory (row-major, row 0 at the top, `width × height` entries each; module
    /// doc for the conventions and every check). Normals of covered pixels are renormalised; position,
    /// normal and albedo of uncovered pixels are stored as 0. Errors name the map (as `real layer`).
    pub fn from_maps(
        width: u32,
        height: u32,
        camera: Vec<[f32; 3]>,
        position: Vec<[f32; 4]>,
        normal: Vec<[f32; 3]>,
        albedo: Vec<[f32; 3]>,
    ) -> Result<RealLayer, SceneError> {
        let p = Path::new("real layer");
        let sources = Sources { camera: p, position: p, normal: p, albedo: p };
        RealLayer::checked("real layer (in memory)", &sources, width, height, camera, position, normal, albedo)
    }

    /// Read a layer from files (module doc): the camera image (`.exr`, `.png`, `.jpg`), the position
    /// map with coverage in `A` (`.exr`), the normal map (`.exr`) and the albedo (a map like the
    /// camera image's, or a constant). Every error names the file; maps of different sizes are refused
    /// naming both files and sizes.
    pub fn open(
        camera_image: &Path,
        position: &Path,
        normal: &Path,
        albedo: RealAlbedo,
    ) -> Result<RealLayer, SceneError> {
        let cam = read_map(camera_image, Which::Camera)?;
        let (w, h) = (cam.width, cam.height);
        let same_size = |m: &Decoded, file: &Path, which: Which| -> Result<(), SceneError> {
            if (m.width, m.height) == (w, h) {
                return Ok(());
            }
            Err(SceneError::invalid(
                file,
                format!(
                    "the {} is {}x{} pixels but the camera image {} is {w}x{h}",
                    which.what(),
                    m.width,
                    m.height,
                    camera_image.display()
                ),
                "give every map of the real layer at the camera image's resolution (one entry per camera pixel)",
            ))
        };
        let pos = read_map(position, Which::Position)?;
        same_size(&pos, position, Which::Position)?;
        let nor = read_map(normal, Which::Normal)?;
        same_size(&nor, normal, Which::Normal)?;
        let n = w as usize * h as usize;
        let (albedo_pixels, albedo_path) = match &albedo {
            RealAlbedo::Map(path) => {
                let a = read_map(path, Which::Albedo)?;
                same_size(&a, path, Which::Albedo)?;
                (a.pixels.iter().map(|p| [p[0], p[1], p[2]]).collect(), path.clone())
            }
            RealAlbedo::Constant(c) => (vec![*c; n], PathBuf::from(format!("constant albedo {c:?}"))),
        };
        let sources = Sources { camera: camera_image, position, normal, albedo: &albedo_path };
        RealLayer::checked(
            &camera_image.display().to_string(),
            &sources,
            w,
            h,
            cam.pixels.iter().map(|p| [p[0], p[1], p[2]]).collect(),
            pos.pixels,
            nor.pixels.iter().map(|p| [p[0], p[1], p[2]]).collect(),
            albedo_pixels,
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn checked(
        name: &str,
        sources: &Sources<'_>,
        width: u32,
        height: u32,
        camera: Vec<[f32; 3]>,
        mut position: Vec<[f32; 4]>,
        mut normal: Vec<[f32; 3]>,
        mut albedo: Vec<[f32; 3]>,
    ) -> Result<RealLayer, SceneError> {
        check_size(sources.camera, width, height)?;
        let n = width as usize * height as usize;
        for (which, len) in [
            (Which::Camera, camera.len()),
            (Which::Position, position.len()),
            (Which::Normal, normal.len()),
            (Which::Albedo, albedo.len()),
        ] {
            if len != n {
                return Err(SceneError::invalid(
                    sources.of(which),
                    format!("the {} has {len} pixels for a {width}x{height} layer (expected {n})", which.what()),
                    "give width × height entries per map, row-major with row 0 at the top",
                ));
            }
        }
        // Coverage first: what the other maps must hold depends on it.
        let mut t = Tally::new(["NaN", "infinite", "other than 0 or 1"]);
        for (k, p) in position.iter().enumerate() {
            let w = p[3];
            t.add(k, [w.is_nan(), w.is_infinite(), w.is_finite() && w != 0.0 && w != 1.0]);
        }
        t.refuse(
            sources.position,
            width,
            Which::Position,
            "coverage values (position w / the A channel)",
            "write A = 1 where a real surface covers the pixel centre and 0 where the environment is seen; threshold \
             a soft matte (a half-covered pixel has no single position)",
        )?;
        let covered: Vec<bool> = position.iter().map(|p| p[3] == 1.0).collect();

        let mut t = Tally::new(["NaN", "infinite", "negative", "over 1e12"]);
        for (k, c) in camera.iter().enumerate() {
            t.add(
                k,
                [
                    c.iter().any(|v| v.is_nan()),
                    c.iter().any(|v| v.is_infinite()),
                    c.iter().any(|&v| v < 0.0),
                    c.iter().any(|&v| v.is_finite() && v > MAX_RADIANCE),
                ],
            );
        }
        t.refuse(
            sources.camera,
            width,
            Which::Camera,
            "pixels",
            "give linear radiance, finite and >= 0 (fix the image or re-export it); the layer is refused rather than \
             clamped, so no pixel is silently changed",
        )?;

        let mut t = Tally::new(["NaN", "infinite", "beyond 1e8 m"]);
        for (k, p) in position.iter().enumerate().filter(|&(k, _)| covered[k]) {
            let xyz = &p[..3];
            t.add(
                k,
                [
                    xyz.iter().any(|v| v.is_nan()),
                    xyz.iter().any(|v| v.is_infinite()),
                    xyz.iter().any(|v| v.is_finite() && v.abs() > MAX_COORDINATE),
                ],
            );
        }
        t.refuse(
            sources.position,
            width,
            Which::Position,
            "covered positions",
            "give world-space positions in metres where A = 1 (set A = 0 where the pixel sees no real surface)",
        )?;

        let (lo, hi) = NORMAL_LENGTH_RANGE;
        let mut t = Tally::new(["NaN", "infinite", "of length outside 0.5..2"]);
        for (k, v) in normal.iter().enumerate().filter(|&(k, _)| covered[k]) {
            let finite = v.iter().all(|c| c.is_finite());
            let len = Vec3::from(*v).length();
            t.add(
                k,
                [v.iter().any(|c| c.is_nan()), v.iter().any(|c| c.is_infinite()), finite && !(lo..=hi).contains(&len)],
            );
        }
        t.refuse(
            sources.normal,
            width,
            Which::Normal,
            "covered normals",
            "give unit world-space normals as float xyz in R, G, B (not an 8-bit 0.5·n + 0.5 encoding) where the \
             position map's A = 1",
        )?;

        let mut t = Tally::new(["NaN", "infinite", "negative", "over 1 (energy-creating)"]);
        for (k, a) in albedo.iter().enumerate().filter(|&(k, _)| covered[k]) {
            t.add(
                k,
                [
                    a.iter().any(|v| v.is_nan()),
                    a.iter().any(|v| v.is_infinite()),
                    a.iter().any(|&v| v < 0.0),
                    a.iter().any(|&v| v.is_finite() && v > 1.0),
                ],
            );
        }
        t.refuse(
            sources.albedo,
            width,
            Which::Albedo,
            "covered albedo values",
            "give the diffuse albedo k_d as linear RGB in [0, 1] (a surface cannot reflect more light than it \
             receives); rescale the map or give a constant",
        )?;

        // Only now change anything: renormalise covered normals, zero what uncovered pixels hold.
        for k in 0..n {
            if covered[k] {
                normal[k] = Vec3::from(normal[k]).normalize().to_array();
            } else {
                position[k] = [0.0; 4];
                normal[k] = [0.0; 3];
                albedo[k] = [0.0; 3];
            }
        }
        Ok(RealLayer {
            name: name.to_string(),
            width,
            height,
            maps: Arc::new(Maps { camera, position, normal, albedo }),
        })
    }

    /// The camera image's file, or `real layer (in memory)`.
    pub fn name(&self) -> &str {
        &self.name
    }
    pub fn width(&self) -> u32 {
        self.width
    }
    pub fn height(&self) -> u32 {
        self.height
    }

    fn index(&self, x: u32, y: u32) -> usize {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside the {}x{} real layer",
            self.width,
            self.height
        );
        y as usize * self.width as usize + x as usize
    }

    /// The index of pixel `(x, y)` into the `*_map` slices, `None` outside the image (where WGSL's
    /// `real_*` accessors read zeros: a screen-space march that leaves the screen sees nothing).
    pub fn index_of(&self, x: i32, y: i32) -> Option<usize> {
        let inside = x >= 0 && y >= 0 && (x as u32) < self.width && (y as u32) < self.height;
        inside.then(|| y as usize * self.width as usize + x as usize)
    }

    /// `L_cam` at pixel `(x, y)`, linear RGB. Panics outside the layer (a caller's bug, like slicing).
    pub fn camera(&self, x: u32, y: u32) -> Vec3 {
        Vec3::from(self.maps.camera[self.index(x, y)])
    }
    /// The world position the pixel centre sees, `None` where no real surface covers it.
    pub fn position(&self, x: u32, y: u32) -> Option<Vec3> {
        let p = self.maps.position[self.index(x, y)];
        (p[3] == 1.0).then(|| Vec3::new(p[0], p[1], p[2]))
    }
    /// The unit world normal there (0 where not covered).
    pub fn normal(&self, x: u32, y: u32) -> Vec3 {
        Vec3::from(self.maps.normal[self.index(x, y)])
    }
    /// The diffuse albedo there, linear RGB in [0, 1] (0 where not covered).
    pub fn albedo(&self, x: u32, y: u32) -> Vec3 {
        Vec3::from(self.maps.albedo[self.index(x, y)])
    }
    /// Whether a real surface covers the pixel centre.
    pub fn covered(&self, x: u32, y: u32) -> bool {
        self.maps.position[self.index(x, y)][3] == 1.0
    }
    /// How many pixels are covered.
    pub fn covered_count(&self) -> usize {
        self.maps.position.iter().filter(|p| p[3] == 1.0).count()
    }

    /// `L_cam`, row-major, row 0 at the top.
    pub fn camera_map(&self) -> &[[f32; 3]] {
        &self.maps.camera
    }
    /// World xyz and coverage w (1 covered, 0 not; xyz 0 where not covered).
    pub fn position_map(&self) -> &[[f32; 4]] {
        &self.maps.position
    }
    /// Unit normals (0 where not covered).
    pub fn normal_map(&self) -> &[[f32; 3]] {
        &self.maps.normal
    }
    /// Diffuse albedo (0 where not covered).
    pub fn albedo_map(&self) -> &[[f32; 3]] {
        &self.maps.albedo
    }

    /// Bytes the layer holds on the CPU (52 per pixel), for memory estimates.
    pub fn bytes(&self) -> u64 {
        let m = &self.maps;
        (std::mem::size_of_val(m.camera.as_slice())
            + std::mem::size_of_val(m.position.as_slice())
            + std::mem::size_of_val(m.normal.as_slice())
            + std::mem::size_of_val(m.albedo.as_slice())) as u64
    }
}

fn check_size(path: &Path, width: u32, height: u32) -> Result<(), SceneError> {
    if width == 0 || height == 0 {
        return Err(SceneError::invalid(
            path,
            format!("the real layer is empty ({width}x{height} pixels)"),
            "give maps of at least 1x1 pixel, at the camera image's resolution",
        ));
    }
    if width > MAX_TEXTURE_SIDE || height > MAX_TEXTURE_SIDE || width as u64 * height as u64 > MAX_TEXTURE_PIXELS {
        return Err(SceneError::invalid(
            path,
            format!(
                "the real layer is {width}x{height} pixels, more than the limit ({MAX_TEXTURE_SIDE} per side, \
                 {MAX_TEXTURE_PIXELS} pixels in all)"
            ),
            "downscale the camera image and its maps together",
        ));
    }
    Ok(())
}

/// Counts of bad pixels by kind, and the first of each (a pixel counts once per kind).
struct Tally<const N: usize> {
    kinds: [&'static str; N],
    counts: [u64; N],
    first: [Option<usize>; N],
}

impl<const N: usize> Tally<N> {
    fn new(kinds: [&'static str; N]) -> Self {
        Tally { kinds, counts: [0; N], first: [None; N] }
    }

    fn add(&mut self, k: usize, is: [bool; N]) {
        for (n, is) in is.into_iter().enumerate() {
            if is {
                self.counts[n] += 1;
                self.first[n].get_or_insert(k);
            }
        }
    }

    /// `Err` naming `file`, the map and what was counted ("the position map has bad covered positions:
    /// 3 NaN, 1 infinite (first NaN at column 0, row 0; …)") and `fix`, when anything was.
    fn refuse(&self, file: &Path, width: u32, which: Which, noun: &str, fix: &str) -> Result<(), SceneError> {
        if self.counts.iter().all(|&c| c == 0) {
            return Ok(());
        }
        let present = (0..N).filter(|&n| self.counts[n] > 0);
        let counts: Vec<String> = present.clone().map(|n| format!("{} {}", self.counts[n], self.kinds[n])).collect();
        let at: Vec<String> = present
            .map(|n| {
                let k = self.first[n].unwrap_or(0);
                format!("first {} at column {}, row {}", self.kinds[n], k % width as usize, k / width as usize)
            })
            .collect();
        Err(SceneError::invalid(
            file,
            format!("the {} has bad {noun}: {} ({})", which.what(), counts.join(", "), at.join("; ")),
            fix,
        ))
    }
}

/// A map as read from a file: RGBA per pixel (A = 1 where the file has no alpha).
struct Decoded {
    width: u32,
    height: u32,
    pixels: Vec<[f32; 4]>,
}

/// Read one map (module doc: EXR for all, PNG/JPEG sRGB for the camera image and the albedo).
fn read_map(path: &Path, which: Which) -> Result<Decoded, SceneError> {
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    let eight_bit_ok = matches!(which, Which::Camera | Which::Albedo);
    match ext.as_deref() {
        Some("exr") => read_exr(path, which),
        Some("png") | Some("jpg") | Some("jpeg") if eight_bit_ok => read_srgb(path, which),
        Some("png") | Some("jpg") | Some("jpeg") => Err(SceneError::invalid(
            path,
            format!(
                "the {} is a PNG/JPEG image, which cannot hold world-space {}",
                which.what(),
                match which {
                    Which::Position => "coordinates (metres, any sign and size)",
                    _ => "unit vectors at float precision",
                }
            ),
            format!(
                "write the {} as an OpenEXR file (.exr, float or half RGB{}); only the camera image and the albedo may \
                 be PNG or JPEG",
                which.what(),
                if which == Which::Position { ", coverage in A" } else { "" }
            ),
        )),
        _ => Err(SceneError::invalid(
            path,
            format!("the {} is not a format we read", which.what()),
            if eight_bit_ok {
                "give an OpenEXR (.exr) file, or a PNG/JPEG (sRGB)"
            } else {
                "give an OpenEXR (.exr) file"
            },
        )),
    }
}

fn read_exr(path: &Path, which: Which) -> Result<Decoded, SceneError> {
    use exr::prelude::{ReadChannels, ReadLayers};
    let bytes = crate::resource::read_capped(path, None)?;
    let not_exr = |why: String| {
        SceneError::invalid(
            path,
            format!("the {} is not a readable OpenEXR image ({why})", which.what()),
            "re-export it as an RGB or RGBA OpenEXR (half or float)",
        )
    };
    if bytes.len() < 4 || bytes[..4] != [0x76, 0x2f, 0x31, 0x01] {
        return Err(not_exr("it does not start with the OpenEXR magic number".into()));
    }
    let meta = exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(&bytes[..]), false)
        .map_err(|e| not_exr(e.to_string()))?;
    // Every layer's size before decoding: the reader may allocate per layer.
    for h in meta.headers.iter() {
        let side = |v: usize| u32::try_from(v).unwrap_or(u32::MAX);
        check_size(path, side(h.layer_size.0).max(1), side(h.layer_size.1).max(1))?;
    }
    let has_rgb =
        |h: &exr::meta::header::Header| ["R", "G", "B"].iter().all(|c| h.channels.list.iter().any(|ch| ch.name.eq(c)));
    if !meta.headers.iter().any(has_rgb) {
        let found: Vec<String> =
            meta.headers.iter().flat_map(|h| h.channels.list.iter().map(|c| c.name.to_string())).collect();
        return Err(SceneError::invalid(
            path,
            format!(
                "the {} has no layer with R, G and B channels (it has {})",
                which.what(),
                if found.is_empty() { "none".to_string() } else { found.join(", ") }
            ),
            "export it with R, G, B channels (x, y, z for positions and normals)",
        ));
    }
    struct Pixels {
        w: usize,
        px: Vec<[f32; 4]>,
    }
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |res, _| Pixels { w: res.width(), px: vec![[0.0; 4]; res.width() * res.height()] },
            |p: &mut Pixels, pos, (r, g, b, a): (f32, f32, f32, f32)| {
                let i = pos.y() * p.w + pos.x();
                if let Some(t) = p.px.get_mut(i) {
                    *t = [r, g, b, a];
                }
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(&bytes[..]))
        .map_err(|e| not_exr(e.to_string()))?;
    let layer = image.layer_data;
    let (w, h) = (layer.size.0 as u32, layer.size.1 as u32);
    check_size(path, w, h)?;
    Ok(Decoded { width: w, height: h, pixels: layer.channel_data.pixels.px })
}

/// PNG or JPEG, 8 or 16 bits, sRGB-encoded: decoded to linear RGB (alpha ignored).
fn read_srgb(path: &Path, which: Which) -> Result<Decoded, SceneError> {
    let bytes = crate::resource::read_capped(path, None)?;
    let unreadable = |e: &dyn std::fmt::Display| {
        SceneError::invalid(
            path,
            format!("the {} is not a readable PNG or JPEG image ({e})", which.what()),
            "re-export it as PNG, JPEG or OpenEXR",
        )
    };
    let reader =
        || image::ImageReader::new(std::io::Cursor::new(&bytes[..])).with_guessed_format().map_err(|e| unreadable(&e));
    let (w, h) = reader()?.into_dimensions().map_err(|e| unreadable(&e))?;
    check_size(path, w, h)?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_TEXTURE_SIDE);
    limits.max_image_height = Some(MAX_TEXTURE_SIDE);
    // RGBA16 at the largest allowed size plus decoder scratch, then the f32 copy.
    limits.max_alloc = Some(MAX_TEXTURE_PIXELS * 8 + (64 << 20));
    let mut decoder = reader()?;
    decoder.limits(limits);
    let img = decoder.decode().map_err(|e| unreadable(&e))?.into_rgb32f();
    let (w, h) = (img.width(), img.height());
    check_size(path, w, h)?;
    // 8- and 16-bit codes alike through the exact sRGB curve (into_rgb32f only scales to [0, 1]).
    let pixels = img
        .pixels()
        .map(|p| {
            let l = |c: f32| crate::texture::srgb_to_linear(c.clamp(0.0, 1.0));
            [l(p[0]), l(p[1]), l(p[2]), 1.0]
        })
        .collect();
    Ok(Decoded { width: w, height: h, pixels })
}
