//! `wedge merge DIR --out OUT`: assemble the tile files of `render --tile` ([`crate::tiles`]) into
//! the images `render` writes (render.exr/.png, unfiltered.exr/.png), as one all-or-nothing set.
//!
//! Before anything is written the tiles must belong together and cover the image exactly: every
//! `.exr` in DIR must be a wedge tile of the same pipeline, scene, seed, frame, size, grid and wedge
//! version; each grid index must appear once with the rectangle the grid gives it. Otherwise merge
//! refuses, naming the mismatched files, the duplicated and the missing tiles. The pixels are copied
//! unchanged and written by `render`'s own writers, so a merged render.exr has the bytes of a
//! single-process render. Heatmaps and AOVs are not in tile files, so merge does not write them.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::image::Image;
use crate::session::WedgeError;
use crate::tiles::{read_tile, Grid, Tile};

/// Merge the tiles in `dir` into `out`; returns the lines to print.
pub fn merge(dir: &Path, out: &Path) -> Result<String, WedgeError> {
    crate::staging::check_output_dir(out)?;
    let files = tile_files(dir)?;
    let tiles: Vec<(PathBuf, Tile)> =
        files.into_iter().map(|f| read_tile(&f).map(|t| (f, t))).collect::<Result<_, _>>()?;
    check_set(&tiles)?;
    check_cover(&tiles)?;
    let images = assemble(&tiles)?;
    let written = crate::outputs::write_images(out, "render", &images)?;
    let first = &tiles[0].1.header;
    let mut text = format!(
        "merged {} tiles ({}x{} grid) into a {}x{} image\n",
        tiles.len(),
        first.grid.cols,
        first.grid.rows,
        first.full.0,
        first.full.1
    );
    text.push_str(&written.warnings());
    for f in &written.files {
        text.push_str(&format!("wrote {}\n", f.display()));
    }
    Ok(text)
}

/// The `.exr` files of `dir`, sorted by name (other files are left alone).
fn tile_files(dir: &Path) -> Result<Vec<PathBuf>, WedgeError> {
    let entries = std::fs::read_dir(dir)
        .map_err(|e| WedgeError::Usage(format!("{}: cannot read the tile directory: {e}", dir.display())))?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "exr") && p.is_file())
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(WedgeError::Usage(format!(
            "{}: no tile files (.exr) to merge; render them with `wedge render --tile I/N --out {}`",
            dir.display(),
            dir.display()
        )));
    }
    Ok(files)
}

/// Every tile of the same image as the first: same pipeline, scene, seed, frame, size, grid, version.
fn check_set(tiles: &[(PathBuf, Tile)]) -> Result<(), WedgeError> {
    let key = tiles[0].1.header.set_key();
    let odd: Vec<String> = tiles
        .iter()
        .filter(|(_, t)| t.header.set_key() != key)
        .map(|(p, t)| format!("  {}: {}", p.display(), t.header.set_key()))
        .collect();
    if odd.is_empty() {
        return Ok(());
    }
    Err(WedgeError::Usage(format!(
        "tiles that do not belong with {} ({key}):\n{}\nremove them or render them again with the same pipeline, scene, seed and size",
        tiles[0].0.display(),
        odd.join("\n")
    )))
}

/// Each index of the grid exactly once, with the rectangle the grid gives it.
fn check_cover(tiles: &[(PathBuf, Tile)]) -> Result<(), WedgeError> {
    let h = &tiles[0].1.header;
    let grid: Grid = h.grid;
    let mut by_index: BTreeMap<u32, Vec<&Path>> = BTreeMap::new();
    let mut problems = Vec::new();
    for (path, t) in tiles {
        match grid.rect(t.header.index, h.full) {
            Ok(r) if r == t.header.rect => by_index.entry(t.header.index).or_default().push(path),
            _ => problems.push(format!(
                "  {}: tile {} has rect {:?}, not the grid's",
                path.display(),
                t.header.index,
                t.header.rect
            )),
        }
    }
    for (i, paths) in by_index.iter().filter(|(_, p)| p.len() > 1) {
        let names: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
        problems.push(format!("  extra: tile {i} appears {} times ({})", paths.len(), names.join(", ")));
    }
    let missing: Vec<String> =
        (0..grid.count()).filter(|i| !by_index.contains_key(i)).map(|i| format!("{i}/{}", grid.count())).collect();
    if !missing.is_empty() {
        problems.push(format!(
            "  missing: tile(s) {} (render them with `wedge render ... --tile I/N`)",
            missing.join(", ")
        ));
    }
    if problems.is_empty() {
        return Ok(());
    }
    Err(WedgeError::Usage(format!(
        "the tiles do not cover the {}x{} image exactly:\n{}",
        h.full.0,
        h.full.1,
        problems.join("\n")
    )))
}

/// The full images, each tile's pixels copied to its rectangle; every tile must hold the same images.
fn assemble(tiles: &[(PathBuf, Tile)]) -> Result<Vec<(String, Image)>, WedgeError> {
    let (w, h) = tiles[0].1.header.full;
    let ports: Vec<&String> = tiles[0].1.images.iter().map(|(p, _)| p).collect();
    let mut out: Vec<(String, Image)> = ports.iter().map(|p| (p.to_string(), Image::new(w, h))).collect();
    for (path, t) in tiles {
        crate::tiles::paste(&mut out, t).map_err(|e| WedgeError::Usage(format!("{}: {e}", path.display())))?;
    }
    Ok(out)
}
