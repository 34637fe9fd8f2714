//! Tiles (`wedge render --tile I/N`, `--tile-grid CxR`): one rectangle of the image, rendered with
//! the apron the graph needs around it (`wedge_backends::tiles::apron`) so that its pixels are
//! exactly the whole image's, and written as a tile file that `wedge merge` assembles
//! ([`crate::merge`]).
//!
//! A tile file is an EXR (`tile_IIII_of_NNNN.exr`) holding the tile's rectangle of each image
//! `render` writes (`color` → render.exr, `unfiltered`) as 32-bit float channels `PORT.R/G/B`,
//! and in its header what merge checks before it trusts the tiles belong together: the pipeline's
//! and the scene's fingerprints, seed, frame, full size, grid, index, rectangle and wedge version.
//!
//! `render` uses the same tiles by itself when the whole image does not fit the memory limit
//! ([`grid_within`], [`render_all`]): it picks the fewest tiles that fit and renders them in sequence
//! in one process, assembling the images a whole render writes.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use wedge_backends::{Backend, Progress};

use crate::image::Image;
use crate::outputs::{buffer_to_image, IMAGE_PORTS};
use crate::progress::TaskProgress;
use crate::session::{RunMode, Session, WedgeError};

/// Most tiles one grid may have.
pub const MAX_TILES: u32 = 65_536;

/// A rectangle of the full image: `x, y` its top-left pixel, `w × h` its size.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Rect {
    pub x: u32,
    pub y: u32,
    pub w: u32,
    pub h: u32,
}

/// `cols × rows` tiles over the image, numbered row by row from 0 at the top left.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Grid {
    pub cols: u32,
    pub rows: u32,
}

impl Grid {
    pub fn count(self) -> u32 {
        self.cols * self.rows
    }

    /// The near-square grid of `n` tiles over a `width × height` image: of the factorisations
    /// `cols × rows = n`, the one whose tiles are closest to square.
    pub fn near_square(n: u32, (width, height): (u32, u32)) -> Grid {
        let aspect =
            |c: u32, r: u32| ((f64::from(width) / f64::from(c)) / (f64::from(height) / f64::from(r))).ln().abs();
        (1..=n.max(1))
            .filter(|c| n.is_multiple_of(*c))
            .map(|c| Grid { cols: c, rows: n / c })
            .min_by(|a, b| aspect(a.cols, a.rows).total_cmp(&aspect(b.cols, b.rows)))
            .unwrap_or(Grid { cols: 1, rows: 1 })
    }

    /// Tile `index`'s rectangle in a `width × height` image (integer splits: the tiles of a row
    /// differ by at most one pixel); an error if the grid has more columns or rows than pixels.
    pub fn rect(self, index: u32, (width, height): (u32, u32)) -> Result<Rect, WedgeError> {
        if self.cols > width || self.rows > height {
            return Err(WedgeError::Usage(format!(
                "a {}x{} tile grid does not fit a {width}x{height} image (every tile needs at least one pixel)",
                self.cols, self.rows
            )));
        }
        if index >= self.count() {
            return Err(WedgeError::Usage(format!(
                "tile {index} does not exist: a {}x{} grid has tiles 0..{}",
                self.cols,
                self.rows,
                self.count() - 1
            )));
        }
        let split = |i: u32, n: u32, side: u32| (u64::from(side) * u64::from(i) / u64::from(n)) as u32;
        let (c, r) = (index % self.cols, index / self.cols);
        let (x, y) = (split(c, self.cols, width), split(r, self.rows, height));
        Ok(Rect { x, y, w: split(c + 1, self.cols, width) - x, h: split(r + 1, self.rows, height) - y })
    }
}

/// `--tile I/N`: tile `I` (from 0) of `N`.
pub fn parse_tile(s: &str) -> Result<(u32, u32), String> {
    let usage = || format!("`{s}`: expected I/N, tile I (0..N-1) of N tiles, e.g. 0/4");
    let (i, n) = s.split_once('/').ok_or_else(usage)?;
    let (i, n) = (i.trim().parse::<u32>().map_err(|_| usage())?, n.trim().parse::<u32>().map_err(|_| usage())?);
    if n == 0 || n > MAX_TILES {
        return Err(format!("`{s}`: the number of tiles must be in 1..={MAX_TILES}"));
    }
    if i >= n {
        return Err(format!("`{s}`: tiles are numbered from 0, so tile {i} of {n} does not exist; use 0..{}", n - 1));
    }
    Ok((i, n))
}

/// `--tile-grid CxR`: `C` columns by `R` rows.
pub fn parse_grid(s: &str) -> Result<Grid, String> {
    let usage = || format!("`{s}`: expected CxR (columns x rows), e.g. 4x2");
    let (c, r) = s.split_once(['x', 'X']).ok_or_else(usage)?;
    let (cols, rows) = (c.trim().parse::<u32>().map_err(|_| usage())?, r.trim().parse::<u32>().map_err(|_| usage())?);
    if cols == 0 || rows == 0 || u64::from(cols) * u64::from(rows) > u64::from(MAX_TILES) {
        return Err(format!("`{s}`: columns and rows must be >= 1, at most {MAX_TILES} tiles in all"));
    }
    Ok(Grid { cols, rows })
}

/// The grid of `render --tile I/N [--tile-grid CxR]`: the given one (which must have N tiles) or
/// the near-square one.
pub fn grid_of(n: u32, given: Option<Grid>, size: (u32, u32)) -> Result<Grid, WedgeError> {
    match given {
        Some(g) if g.count() != n => Err(WedgeError::Usage(format!(
            "--tile .../{n} and --tile-grid {}x{} ({} tiles) disagree; give N = columns x rows",
            g.cols,
            g.rows,
            g.count()
        ))),
        Some(g) => Ok(g),
        None => Ok(Grid::near_square(n, size)),
    }
}

/// Everything a tile file's header records (see the module docs).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TileHeader {
    pub pipeline_hash: u64,
    pub scene_hash: u64,
    pub seed: u32,
    pub frame: u32,
    pub full: (u32, u32),
    pub grid: Grid,
    pub index: u32,
    pub rect: Rect,
    /// Pixels computed around the rectangle on each side (clipped to the image).
    pub apron: u32,
    pub version: String,
}

impl TileHeader {
    /// The header fields that must be equal across the tiles of one image, as text for messages.
    pub fn set_key(&self) -> String {
        format!(
            "pipeline {:016x}, scene {:016x}, seed {}, frame {}, {}x{}, grid {}x{}, wedge {}",
            self.pipeline_hash,
            self.scene_hash,
            self.seed,
            self.frame,
            self.full.0,
            self.full.1,
            self.grid.cols,
            self.grid.rows,
            self.version
        )
    }

    /// `tile_IIII_of_NNNN.exr`.
    pub fn file_name(&self) -> String {
        format!("tile_{:04}_of_{:04}.exr", self.index, self.grid.count())
    }
}

/// One rendered tile: its header and its rectangle of each image (`(port, image)`).
pub struct Tile {
    pub header: TileHeader,
    pub images: Vec<(String, Image)>,
}

/// 64-bit FNV-1a over what is written to it: a stable fingerprint (not a cryptographic hash).
struct Fnv(u64);

impl std::fmt::Write for Fnv {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        for b in s.bytes() {
            self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
        }
        Ok(())
    }
}

fn fingerprint(f: impl FnOnce(&mut Fnv) -> std::fmt::Result) -> u64 {
    let mut h = Fnv(0xcbf2_9ce4_8422_2325);
    // Writing to Fnv never fails.
    let _ = f(&mut h);
    h.0
}

/// The session's pipeline as it runs: every pass, its kernel, parameters (after `--set`, `--mu`)
/// and buffers, and the image size.
pub fn pipeline_hash(session: &Session) -> u64 {
    fingerprint(|h| {
        write!(h, "{:?}|{:?}|{}x{}", session.schedule.passes, session.schedule.buffers, session.width, session.height)
    })
}

/// The session's scene: geometry, materials, lights, camera, instances and the environment map's
/// name and size (texture and environment pixels are not hashed; their files are named by the scene).
pub fn scene_hash(session: &Session) -> u64 {
    let s = &session.scene;
    fingerprint(|h| {
        write!(h, "{}|{:?}|{:?}|{:?}|{:?}|{:?}", s.name, s.triangles, s.materials, s.lights, s.camera, s.instances)?;
        write!(h, "|{}", s.textures.len())?;
        if let Some(env) = &s.environment {
            write!(h, "|{}|{}x{}|{}|{}", env.name(), env.width(), env.height(), env.scale(), env.rotation_deg())?;
        }
        Ok(())
    })
}

/// The apron of `session`'s pipeline, or why it cannot be tiled (naming the node); and an error if
/// `grid` does not fit the image. What `wedge farm` checks before it submits anything.
pub fn check(session: &Session, grid: Grid) -> Result<u32, WedgeError> {
    grid.rect(grid.count() - 1, (session.width, session.height))?;
    apron(session)
}

/// How far around its rectangle a tile of `session`'s image computes (the sum of the passes' reach
/// along each chain), or why the pipeline cannot be tiled.
pub fn apron(session: &Session) -> Result<u32, WedgeError> {
    wedge_backends::tiles::apron(&session.job(session.seed, 0, &wedge_backends::Silent))
        .map_err(|e| WedgeError::Usage(format!("--tile: {}: {e}", session.pipeline.path.display())))
}

/// What one tile computes: its rectangle, the apron around it and the rectangle with the apron
/// (`x0, y0, width, height`, clipped to the image).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TilePlan {
    pub index: u32,
    pub grid: Grid,
    pub rect: Rect,
    pub apron: u32,
    pub grown: (u32, u32, u32, u32),
}

impl TilePlan {
    /// The pixels the tile computes: its rectangle with the apron.
    pub fn pixels(&self) -> u64 {
        u64::from(self.grown.2) * u64::from(self.grown.3)
    }
}

/// The work of rendering every tile of `grid` ([`TaskProgress::work`]: passes × pixels with aprons).
pub fn work(session: &Session, grid: Grid) -> Result<u64, WedgeError> {
    let passes = session.schedule.passes.len();
    (0..grid.count())
        .try_fold(0u64, |sum, i| Ok(sum.saturating_add(TaskProgress::work(passes, plan(session, i, grid)?.pixels()))))
}

/// Plan tile `index` of `grid`, or why it cannot be rendered (the grid, a pass reading the whole
/// image), before any backend is opened.
pub fn plan(session: &Session, index: u32, grid: Grid) -> Result<TilePlan, WedgeError> {
    let full = (session.width, session.height);
    let rect = grid.rect(index, full)?;
    let apron = apron(session)?;
    let grown = wedge_backends::tiles::grow((rect.x, rect.y, rect.w, rect.h), apron, full);
    Ok(TilePlan { index, grid, rect, apron, grown })
}

/// Render tile `index` of `grid` of `session`'s image on `backend`.
pub fn render_tile(
    session: &Session,
    backend: &mut dyn Backend,
    progress: &dyn Progress,
    index: u32,
    grid: Grid,
) -> Result<Tile, WedgeError> {
    render_planned(session, backend, progress, &plan(session, index, grid)?)
}

/// Render a planned tile on `backend`.
pub fn render_planned(
    session: &Session,
    backend: &mut dyn Backend,
    progress: &dyn Progress,
    plan: &TilePlan,
) -> Result<Tile, WedgeError> {
    let window = wedge_backends::tiles::window_of(plan.grown, (session.width, session.height));
    let run = session.run_window(backend, progress, window, (plan.grown.2, plan.grown.3))?;
    Ok(tile_of(session, plan, &run, session.frame))
}

/// Render a planned tile of frame `frame` of a sequence that started at `first`, set up as
/// `render --frames` sets that frame up (`Session::run_window_frame`; no history: a pipeline that
/// keeps some is refused before, by [`check_frames`]).
pub fn render_planned_frame(
    session: &mut Session,
    backend: &mut dyn Backend,
    progress: &dyn Progress,
    plan: &TilePlan,
    (frame, first): (u32, u32),
) -> Result<Tile, WedgeError> {
    let window = wedge_backends::tiles::window_of(plan.grown, (session.width, session.height));
    let run = session.run_window_frame(backend, progress, window, (plan.grown.2, plan.grown.3), frame, first)?;
    Ok(tile_of(session, plan, &run, frame))
}

/// Tiles of a sequence's frames: refused for a pipeline that keeps frame history, whose frame reads
/// the whole previous frame (a tile would need its history from a larger apron every frame back).
pub fn check_frames(session: &Session) -> Result<(), WedgeError> {
    if session.schedule.history.is_empty() {
        return Ok(());
    }
    Err(WedgeError::Usage(format!(
        "--tile with --frames: {} keeps frame history (a temporal filter or progressive accumulation reads the frame          before), which tiles of single frames cannot carry; render its frames whole (--frames with --shard          --shard-mode chunks splits them over tasks)",
        session.pipeline.path.display()
    )))
}

/// The tile of `plan` cut from `run` (its grown rectangle), with its header (`frame`: the frame it shows).
fn tile_of(session: &Session, plan: &TilePlan, run: &wedge_backends::RunResult, frame: u32) -> Tile {
    let full = (session.width, session.height);
    let TilePlan { index, grid, rect, apron, grown } = *plan;
    let images = IMAGE_PORTS
        .iter()
        .filter_map(|(port, _)| run.output(port).map(|b| (port.to_string(), buffer_to_image(b, grown.2, grown.3))))
        .map(|(port, img)| (port, crop(&img, rect.x - grown.0, rect.y - grown.1, rect.w, rect.h)))
        .collect();
    let header = TileHeader {
        pipeline_hash: pipeline_hash(session),
        scene_hash: scene_hash(session),
        seed: session.seed,
        frame,
        full,
        grid,
        index,
        rect,
        apron,
        version: env!("CARGO_PKG_VERSION").to_string(),
    };
    Tile { header, images }
}

/// The `w × h` rectangle of `img` at `(x, y)`.
fn crop(img: &Image, x: u32, y: u32, w: u32, h: u32) -> Image {
    Image::from_fn(w, h, |i, j| img.pixels[((y + j) * img.width + x + i) as usize])
}

const ATTRS: [&str; 10] = [
    "wedge_pipeline_hash",
    "wedge_scene_hash",
    "wedge_seed",
    "wedge_frame",
    "wedge_full_size",
    "wedge_grid",
    "wedge_tile",
    "wedge_rect",
    "wedge_apron",
    "wedge_version",
];

fn header_values(h: &TileHeader) -> [String; 10] {
    [
        format!("{:016x}", h.pipeline_hash),
        format!("{:016x}", h.scene_hash),
        h.seed.to_string(),
        h.frame.to_string(),
        format!("{}x{}", h.full.0, h.full.1),
        format!("{}x{}", h.grid.cols, h.grid.rows),
        h.index.to_string(),
        format!("{},{},{},{}", h.rect.x, h.rect.y, h.rect.w, h.rect.h),
        h.apron.to_string(),
        h.version.clone(),
    ]
}

/// Write `tile` into `dir` (created if needed) as its tile file, atomically; returns its path.
pub fn write_tile(dir: &Path, tile: &Tile) -> Result<PathBuf, WedgeError> {
    use exr::prelude::{
        AnyChannel, AnyChannels, AttributeValue, Blocks, Compression, Encoding, FlatSamples, Layer, LayerAttributes,
        LineOrder, Text, WritableImage,
    };
    crate::staging::create_output_dir(dir)?;
    let path = dir.join(tile.header.file_name());
    let text = |s: &str| {
        Text::new_or_none(s).ok_or_else(|| WedgeError::Usage(format!("tile header value `{s}` is not plain ASCII")))
    };
    let mut attributes = LayerAttributes::named(text("wedge_tile")?);
    for (name, value) in ATTRS.iter().zip(header_values(&tile.header)) {
        attributes.other.insert(text(name)?, AttributeValue::Text(text(&value)?));
    }
    let mut channels = Vec::new();
    for (port, img) in &tile.images {
        for (c, letter) in ["R", "G", "B"].iter().enumerate() {
            let samples = img.pixels.iter().map(|p| p[c]).collect();
            channels.push(AnyChannel::new(text(&format!("{port}.{letter}"))?, FlatSamples::F32(samples)));
        }
    }
    let size = (tile.header.rect.w as usize, tile.header.rect.h as usize);
    let encoding =
        Encoding { compression: Compression::ZIP16, blocks: Blocks::ScanLines, line_order: LineOrder::Increasing };
    let layer = Layer::new(size, attributes, encoding, AnyChannels::sort(channels.into()));
    let image = exr::image::Image::from_layer(layer);
    crate::image::write_atomically(&path, |out| {
        image
            .write()
            .to_buffered(out)
            .map_err(|e| crate::image::ImageError::Encode { path: path.clone(), reason: e.to_string() })
    })?;
    Ok(path)
}

/// Read a tile file: its header (an error naming the file if it is not a wedge tile) and images.
pub fn read_tile(path: &Path) -> Result<Tile, WedgeError> {
    use exr::prelude::{AttributeValue, FlatSamples, Text};
    let bad = |why: String| WedgeError::Usage(format!("{}: not a wedge tile file ({why})", path.display()));
    let image = exr::prelude::read_first_flat_layer_from_file(path).map_err(|e| bad(e.to_string()))?;
    let layer = &image.layer_data;
    let attr = |name: &str| -> Result<String, WedgeError> {
        let key = Text::new_or_none(name).ok_or_else(|| bad(name.to_string()))?;
        match layer.attributes.other.get(&key) {
            Some(AttributeValue::Text(t)) => Ok(t.to_string()),
            _ => Err(bad(format!("no `{name}` attribute"))),
        }
    };
    let header = parse_header(&attr, &bad)?;
    let (w, h) = (layer.size.0, layer.size.1);
    if (w, h) != (header.rect.w as usize, header.rect.h as usize) {
        return Err(bad(format!("its pixels are {w}x{h} but its rect says {}x{}", header.rect.w, header.rect.h)));
    }
    let mut images = Vec::new();
    for (port, _) in IMAGE_PORTS {
        let channel = |letter: &str| {
            let wanted = format!("{port}.{letter}");
            layer.channel_data.list.iter().find(|c| c.name.eq(&wanted)).map(|c| match &c.sample_data {
                FlatSamples::F32(v) => Ok(v.clone()),
                _ => Err(bad(format!("channel {port}.{letter} is not 32-bit float"))),
            })
        };
        let (Some(r), Some(g), Some(b)) = (channel("R"), channel("G"), channel("B")) else { continue };
        let (r, g, b) = (r?, g?, b?);
        let pixels = (0..w * h).map(|i| [r[i], g[i], b[i]]).collect();
        images.push((port.to_string(), Image { width: w as u32, height: h as u32, pixels }));
    }
    Ok(Tile { header, images })
}

fn parse_header(
    attr: &dyn Fn(&str) -> Result<String, WedgeError>,
    bad: &dyn Fn(String) -> WedgeError,
) -> Result<TileHeader, WedgeError> {
    let hex =
        |name: &str| attr(name).and_then(|v| u64::from_str_radix(&v, 16).map_err(|_| bad(format!("`{name}` = `{v}`"))));
    let int = |name: &str| attr(name).and_then(|v| v.parse::<u32>().map_err(|_| bad(format!("`{name}` = `{v}`"))));
    let pair = |name: &str| {
        attr(name).and_then(|v| {
            let (a, b) = v.split_once('x').ok_or_else(|| bad(format!("`{name}` = `{v}`")))?;
            Ok((
                a.parse::<u32>().map_err(|_| bad(format!("`{name}` = `{v}`")))?,
                b.parse::<u32>().map_err(|_| bad(format!("`{name}` = `{v}`")))?,
            ))
        })
    };
    let rect = attr("wedge_rect")?;
    let r: Vec<u32> = rect
        .split(',')
        .map(|p| p.parse::<u32>())
        .collect::<Result<_, _>>()
        .map_err(|_| bad(format!("`wedge_rect` = `{rect}`")))?;
    let [x, y, w, h] = r[..] else { return Err(bad(format!("`wedge_rect` = `{rect}`"))) };
    let (cols, rows) = pair("wedge_grid")?;
    Ok(TileHeader {
        pipeline_hash: hex("wedge_pipeline_hash")?,
        scene_hash: hex("wedge_scene_hash")?,
        seed: int("wedge_seed")?,
        frame: int("wedge_frame")?,
        full: pair("wedge_full_size")?,
        grid: Grid { cols, rows },
        index: int("wedge_tile")?,
        rect: Rect { x, y, w, h },
        apron: int("wedge_apron")?,
        version: attr("wedge_version")?,
    })
}

/// What a tiled render holds besides one tile's run: the assembled full `color` and `unfiltered`
/// images (f32 RGB each).
const ASSEMBLED_BYTES_PER_PIXEL: u64 = 2 * 12;

/// Most tiles `render` splits an image into by itself to fit a memory limit.
pub const MAX_AUTO_TILES: u32 = 4096;

/// The estimated peak of rendering `session`'s image as `grid`'s tiles in sequence in one process:
/// the largest tile's run with its apron, plus the assembled full images, plus the encoders'
/// buffers for writing one full image ([`crate::image::encoder_bytes`]). The last tile's run is over
/// when the images are written; the sum stays an upper bound whether or not the allocator has given
/// its memory back by then.
pub fn tiled_bytes(session: &Session, mode: RunMode, grid: Grid, apron: u32) -> u64 {
    let (w, h) = (session.width, session.height);
    let grown = |side: u32, n: u32| side.div_ceil(n).saturating_add(2 * apron).min(side);
    let tile = session.memory_estimate_at(mode, (grown(w, grid.cols), grown(h, grid.rows))).total();
    tile.saturating_add(u64::from(w) * u64::from(h) * ASSEMBLED_BYTES_PER_PIXEL)
        .saturating_add(crate::image::encoder_bytes(w, h))
}

/// The fewest tiles (near-square grids of 2, 3, 4, … up to [`MAX_AUTO_TILES`]) whose tiled render
/// fits `limit` bytes, with its estimate; `Ok(None)` when none does (the scene alone may not fit),
/// an error when the pipeline cannot be tiled (naming the pass that reads the whole image).
pub fn grid_within(session: &Session, mode: RunMode, limit: u64) -> Result<Option<(Grid, u64)>, WedgeError> {
    let apron = apron(session)?;
    let size = (session.width, session.height);
    Ok((2..=MAX_AUTO_TILES)
        .map(|n| Grid::near_square(n, size))
        .filter(|g| g.cols <= size.0 && g.rows <= size.1)
        .map(|g| (g, tiled_bytes(session, mode, g, apron)))
        .find(|(_, bytes)| *bytes <= limit))
}

/// Render every tile of `grid` in sequence on `backend` and assemble the full images (`color`,
/// `unfiltered`): the pixels a whole render computes, tile by tile.
pub fn render_all(
    session: &Session,
    backend: &mut dyn Backend,
    progress: &TaskProgress<'_>,
    grid: Grid,
) -> Result<Vec<(String, Image)>, WedgeError> {
    let mut full: Vec<(String, Image)> = Vec::new();
    for index in 0..grid.count() {
        let plan = plan(session, index, grid)?;
        progress.at(Some((index, grid.count())), None, plan.pixels());
        let tile = render_planned(session, backend, progress, &plan)?;
        if full.is_empty() {
            full = tile.images.iter().map(|(p, _)| (p.clone(), Image::new(session.width, session.height))).collect();
        }
        paste(&mut full, &tile)?;
    }
    Ok(full)
}

/// Copy `tile`'s images into their rectangle of the full images (the same ports, in order).
pub fn paste(full: &mut [(String, Image)], tile: &Tile) -> Result<(), WedgeError> {
    let ports = |v: &[(String, Image)]| v.iter().map(|(p, _)| p.clone()).collect::<Vec<_>>();
    if ports(full) != ports(&tile.images) {
        return Err(WedgeError::Usage(format!(
            "tile {} holds images {:?}, the others {:?}",
            tile.header.index,
            ports(&tile.images),
            ports(full)
        )));
    }
    let r = tile.header.rect;
    for ((_, whole), (_, img)) in full.iter_mut().zip(&tile.images) {
        let w = whole.width;
        for y in 0..r.h {
            let src = (y * r.w) as usize;
            let dst = ((r.y + y) * w + r.x) as usize;
            whole.pixels[dst..dst + r.w as usize].copy_from_slice(&img.pixels[src..src + r.w as usize]);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grids_cover_the_image() {
        let g = Grid::near_square(4, (64, 48));
        assert_eq!(g, Grid { cols: 2, rows: 2 });
        assert_eq!(Grid::near_square(2, (64, 16)), Grid { cols: 2, rows: 1 });
        assert_eq!(Grid::near_square(7, (64, 48)).count(), 7);
        let g = Grid { cols: 3, rows: 2 };
        let area: u32 = (0..6).map(|i| g.rect(i, (64, 47)).map(|r| r.w * r.h).unwrap()).sum();
        assert_eq!(area, 64 * 47);
        assert!(g.rect(6, (64, 47)).is_err());
        assert!(Grid { cols: 65, rows: 1 }.rect(0, (64, 47)).is_err());
    }

    #[test]
    fn parses_tile_and_grid() {
        assert_eq!(parse_tile("3/4"), Ok((3, 4)));
        assert!(parse_tile("4/4").is_err());
        assert!(parse_tile("0/0").is_err());
        assert!(parse_tile("a/4").is_err());
        assert_eq!(parse_grid("4x2"), Ok(Grid { cols: 4, rows: 2 }));
        assert!(parse_grid("0x2").is_err());
        assert!(parse_grid("4").is_err());
    }
}
