//! False-colour maps of per-pixel quantities (error, sample counts, filter
//! weights, …) with a labelled colour bar, in the style of the thesis's
//! Fig. 3.7: the map itself, a title above it, and a colour bar with its
//! minimum, middle and maximum values and the unit.
//!
//! Choices, and why:
//!
//! * **Colormap: viridis** (via the `colorous` crate, which reproduces
//!   matplotlib's table exactly). It is perceptually uniform, readable by
//!   colour-blind viewers and stays monotonic when printed in grey, so equal
//!   steps in value look like equal steps in colour. Its darkest colour is a
//!   dark purple (#440154), distinct from the pure black used for masked
//!   pixels, and it contains no magenta, which is reserved for NaN.
//! * **Text: `embedded-graphics`** with its built-in 6×10 ISO-8859-1 mono
//!   font, drawn straight into the RGB8 buffer. The font is compiled into the
//!   crate, so it builds offline from crates.io with no system fonts or TTF
//!   files (unlike `plotters`' text backends), is pure Rust, well maintained,
//!   and a 6×10 bitmap font is crisp at 1× — a vector font rasterised at
//!   10 px would be blurry. ISO-8859-1 covers units such as `°`, `µ` and `²`.
//! * **Layout**: the colour bar goes on the right of the map; it goes
//!   **below** instead when the map is very narrow (narrower than
//!   [`NARROW_WIDTH`] px) or too short to hold a readable vertical bar with
//!   three labels (shorter than [`VERTICAL_BAR_MIN`] px). The map is drawn 1:1
//!   (no resampling, so every value is one output pixel) with a white margin,
//!   on a white background with black text, like a figure in a paper.
//!
//! Pixel colours: masked pixels are black, NaN magenta (255, 0, 255), everything else the
//! colormap, clamped at the range ends (±∞ too, e.g. an unbounded filter width; the range is
//! taken from finite values only).

use std::path::Path;

use embedded_graphics::{
    mono_font::{iso_8859_1::FONT_6X10, MonoTextStyle},
    pixelcolor::{Rgb888, RgbColor},
    prelude::{DrawTarget, Drawable, OriginDimensions, Pixel, Point, Size},
    text::{Alignment, Baseline, Text, TextStyleBuilder},
};
use rayon::prelude::*;

use crate::image::{write_png_rgb8, ImageError};

/// How values are mapped to the colormap.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    /// Colour proportional to the value.
    Linear,
    /// Colour proportional to log(value); for quantities spanning decades
    /// (relative error, variance). Values ≤ 0 get the lowest colour.
    Log,
}

/// What to draw and how to label it.
#[derive(Clone, Debug)]
pub struct HeatmapSpec<'a> {
    /// Drawn above the map.
    pub title: &'a str,
    /// Drawn with the colour bar's labels; empty for none.
    pub unit: &'a str,
    pub scale: Scale,
    /// Values mapped to the first and last colour (values outside are
    /// clamped). `None`: the minimum and maximum of the data, ignoring masked
    /// and non-finite values (and, for [`Scale::Log`], values ≤ 0). A
    /// reversed range is swapped; a range with a non-finite end is ignored
    /// (as if `None`); for `Log` a lower end ≤ 0 is replaced by the smallest
    /// positive value in the data.
    pub range: Option<(f32, f32)>,
    /// Per-pixel image-space vectors (e.g. velocities) drawn as white strokes over the map, one per
    /// [`ARROW_SPACING`]-pixel cell, through the cell's centre along the vector, as long as the
    /// vector (both ways: a point moving at `v` per half shutter sweeps `2v`) up to the cell; none
    /// where the vector is shorter than half a pixel. `None`: no strokes.
    pub arrows: Option<&'a [[f32; 2]]>,
}

/// Cell size, in pixels, of the strokes of [`HeatmapSpec::arrows`].
pub const ARROW_SPACING: u32 = 16;

/// Images narrower than this get the colour bar below instead of on the right.
pub const NARROW_WIDTH: u32 = 32;
/// Images shorter than this get the colour bar below: a vertical bar needs
/// this much height for three non-overlapping labels and a visible gradient.
pub const VERTICAL_BAR_MIN: u32 = 80;

/// Colour of masked pixels.
pub const MASKED: [u8; 3] = [0, 0, 0];
/// Colour of non-finite values (same as the PNG writer's).
pub const NON_FINITE: [u8; 3] = crate::image::MAGENTA;

const BACKGROUND: [u8; 3] = [255, 255, 255];
const TEXT: Rgb888 = Rgb888::BLACK;
const FRAME: [u8; 3] = [64, 64, 64];
const CHAR_W: i32 = 6;
const CHAR_H: i32 = 10;
const PAD: i32 = 6;
const BAR_THICK: i32 = 16;
const TICK: i32 = 3;
/// Entries in the colour lookup table; 256 is all an 8-bit output can show.
const LUT_SIZE: usize = 256;

/// The colormap sampled at `t` in [0, 1] (0 = first colour, 1 = last).
pub fn colormap(t: f32) -> [u8; 3] {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let c = colorous::VIRIDIS.eval_continuous(t as f64);
    [c.r, c.g, c.b]
}

fn lut() -> Vec<[u8; 3]> {
    (0..LUT_SIZE).map(|i| colormap(i as f32 / (LUT_SIZE - 1) as f32)).collect()
}

/// Resolved value → [0, 1] mapping.
#[derive(Clone, Copy, Debug)]
struct Mapping {
    scale: Scale,
    lo: f32,
    hi: f32,
}

impl Mapping {
    fn new(values: &[f32], mask: Option<&[bool]>, spec: &HeatmapSpec) -> Mapping {
        let masked = |i: usize| mask.and_then(|m| m.get(i).copied()).unwrap_or(false);
        let usable = |i: usize, v: f32| v.is_finite() && !masked(i) && (spec.scale == Scale::Linear || v > 0.0);
        let data_range = || {
            values.iter().enumerate().filter(|&(i, &v)| usable(i, v)).fold(None, |acc: Option<(f32, f32)>, (_, &v)| {
                match acc {
                    None => Some((v, v)),
                    Some((a, b)) => Some((a.min(v), b.max(v))),
                }
            })
        };
        let explicit = spec.range.filter(|(a, b)| a.is_finite() && b.is_finite()).map(|(a, b)| (a.min(b), a.max(b)));
        let (mut lo, mut hi) = match (explicit, spec.scale) {
            (Some(r), _) => r,
            (None, Scale::Linear) => data_range().unwrap_or((0.0, 1.0)),
            (None, Scale::Log) => data_range().unwrap_or((1e-3, 1.0)),
        };
        if spec.scale == Scale::Log && lo <= 0.0 {
            // Log cannot show 0 or negatives: start at the smallest positive
            // datum, or a few decades below the top if there is none.
            lo = data_range().map(|(a, _)| a).filter(|&a| a < hi).unwrap_or(if hi > 0.0 { hi * 1e-3 } else { 1e-3 });
            if hi <= lo {
                hi = lo * 1e3;
            }
        }
        Mapping { scale: spec.scale, lo, hi }
    }

    /// Position on the colour bar of a finite value, in [0, 1]. A degenerate
    /// range (lo == hi, e.g. an all-zero error map) maps to 0.
    fn t(&self, v: f32) -> f32 {
        let t = match self.scale {
            _ if self.hi <= self.lo => 0.0,
            Scale::Linear => (v - self.lo) / (self.hi - self.lo),
            Scale::Log if v <= 0.0 => 0.0,
            Scale::Log => (v.ln() - self.lo.ln()) / (self.hi.ln() - self.lo.ln()),
        };
        if t.is_nan() {
            0.0
        } else {
            t.clamp(0.0, 1.0)
        }
    }

    /// The value at the middle of the bar: arithmetic mean for linear,
    /// geometric mean for log.
    fn mid(&self) -> f32 {
        match self.scale {
            Scale::Linear => 0.5 * (self.lo + self.hi),
            Scale::Log => (self.lo as f64 * self.hi as f64).sqrt() as f32,
        }
    }
}

/// Short tick label: up to 4 significant digits, scientific notation outside
/// [1e-3, 1e5) so labels stay narrow.
fn format_value(v: f32) -> String {
    if v == 0.0 {
        return "0".into();
    }
    if !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs() as f64;
    let trim = |s: String| -> String {
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    };
    if (1e-3..1e5).contains(&a) {
        let decimals = (3 - a.log10().floor() as i32).max(0) as usize;
        trim(format!("{:.*}", decimals, v))
    } else {
        let s = format!("{:.2e}", v);
        match s.split_once('e') {
            Some((m, e)) => format!("{}e{}", trim(m.to_string()), e),
            None => s,
        }
    }
}

fn text_width(s: &str) -> i32 {
    s.chars().count() as i32 * CHAR_W
}

/// An RGB8 buffer as an `embedded-graphics` draw target, clipping to bounds.
struct Canvas<'a> {
    width: u32,
    height: u32,
    buf: &'a mut [u8],
}

impl Canvas<'_> {
    fn put(&mut self, x: i32, y: i32, c: [u8; 3]) {
        if x >= 0 && y >= 0 && (x as u32) < self.width && (y as u32) < self.height {
            let i = (y as usize * self.width as usize + x as usize) * 3;
            self.buf[i..i + 3].copy_from_slice(&c);
        }
    }

    fn rect(&mut self, x0: i32, y0: i32, w: i32, h: i32, c: [u8; 3]) {
        for y in y0..y0 + h {
            for x in x0..x0 + w {
                self.put(x, y, c);
            }
        }
    }

    /// Outline just outside the rectangle, so it never covers data.
    fn frame(&mut self, x0: i32, y0: i32, w: i32, h: i32) {
        self.rect(x0 - 1, y0 - 1, w + 2, 1, FRAME);
        self.rect(x0 - 1, y0 + h, w + 2, 1, FRAME);
        self.rect(x0 - 1, y0, 1, h, FRAME);
        self.rect(x0 + w, y0, 1, h, FRAME);
    }

    /// Text with its top edge at `y`; `x` is the left, centre or right end
    /// depending on `align`.
    /// [`HeatmapSpec::arrows`]: a white stroke per cell of the `width × height` map drawn at
    /// (`x0`, `y0`), clipped to the map.
    fn strokes(&mut self, v: &[[f32; 2]], width: u32, height: u32, x0: i32, y0: i32) {
        let half = (ARROW_SPACING / 2) as f32;
        for cy in (ARROW_SPACING / 2..height).step_by(ARROW_SPACING as usize) {
            for cx in (ARROW_SPACING / 2..width).step_by(ARROW_SPACING as usize) {
                let Some(&[vx, vy]) = v.get((cy * width + cx) as usize) else {
                    continue;
                };
                let len = (vx * vx + vy * vy).sqrt();
                if !(len >= 0.5 && len.is_finite()) {
                    continue;
                }
                let reach = len.min(half - 1.0) / len;
                let (dx, dy) = (vx * reach, vy * reach);
                let steps = (dx.abs().max(dy.abs()).ceil() as i32).max(1);
                for k in -steps..=steps {
                    let f = k as f32 / steps as f32;
                    let px = (cx as f32 + 0.5 + f * dx).floor() as i32;
                    let py = (cy as f32 + 0.5 + f * dy).floor() as i32;
                    if px >= 0 && py >= 0 && px < width as i32 && py < height as i32 {
                        self.put(x0 + px, y0 + py, [255, 255, 255]);
                    }
                }
            }
        }
    }

    fn text(&mut self, s: &str, x: i32, y: i32, align: Alignment) {
        let style = MonoTextStyle::new(&FONT_6X10, TEXT);
        let text_style = TextStyleBuilder::new().alignment(align).baseline(Baseline::Top).build();
        // Infallible: the canvas clips instead of failing.
        let _ = Text::with_text_style(s, Point::new(x, y), style, text_style).draw(self);
    }
}

impl OriginDimensions for Canvas<'_> {
    fn size(&self) -> Size {
        Size::new(self.width, self.height)
    }
}

impl DrawTarget for Canvas<'_> {
    type Color = Rgb888;
    type Error = std::convert::Infallible;

    fn draw_iter<I>(&mut self, pixels: I) -> Result<(), Self::Error>
    where
        I: IntoIterator<Item = Pixel<Self::Color>>,
    {
        for Pixel(p, c) in pixels {
            self.put(p.x, p.y, [c.r(), c.g(), c.b()]);
        }
        Ok(())
    }
}

/// Where everything goes; computed before allocating the buffer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Layout {
    out_w: i32,
    out_h: i32,
    map_x: i32,
    map_y: i32,
    below: bool,
}

const TITLE_BAND: i32 = CHAR_H + 2 * PAD;

fn layout(width: u32, height: u32, labels: &[String; 3], spec: &HeatmapSpec) -> Layout {
    let (w, h) = (width.min(i32::MAX as u32 / 4) as i32, height.min(i32::MAX as u32 / 4) as i32);
    let title_w = text_width(spec.title) + 2 * PAD;
    let unit_w = text_width(spec.unit);
    let label_w = labels.iter().map(|l| text_width(l)).max().unwrap_or(0);
    let below = width < NARROW_WIDTH || height < VERTICAL_BAR_MIN;
    if below {
        // Labels min | mid | max side by side under the bar, unit below them.
        let bar_min_w = 3 * label_w + 4 * CHAR_W;
        let content_w = w.max(bar_min_w).max(unit_w);
        let out_w = (content_w + 2 * PAD).max(title_w);
        let unit_h = if spec.unit.is_empty() { 0 } else { CHAR_H + 2 };
        let out_h = TITLE_BAND + h + 2 * PAD + BAR_THICK + TICK + 1 + CHAR_H + unit_h + PAD;
        Layout { out_w, out_h, map_x: (out_w - w) / 2, map_y: TITLE_BAND, below }
    } else {
        let panel_w = 2 * PAD + BAR_THICK + TICK + 2 + label_w.max(unit_w - BAR_THICK - TICK - 2);
        let out_w = (PAD + w + panel_w + PAD).max(title_w);
        let out_h = TITLE_BAND + h + PAD;
        Layout { out_w, out_h, map_x: PAD, map_y: TITLE_BAND, below }
    }
}

/// Renders `values` (row-major, `width * height`, top row first) as a
/// false-colour map with title and colour bar; returns
/// `(out_width, out_height, rgb8)`. See the module docs for layout and
/// colours. `mask[i] == true` draws pixel `i` black (e.g. "not filtered").
///
/// Never panics on mismatched input: missing values count as non-finite
/// (magenta), missing mask entries as unmasked, extra entries are ignored.
pub fn render_heatmap(
    width: u32,
    height: u32,
    values: &[f32],
    mask: Option<&[bool]>,
    spec: &HeatmapSpec,
) -> (u32, u32, Vec<u8>) {
    let n = width as usize * height as usize;
    let values = &values[..values.len().min(n)];
    let mapping = Mapping::new(values, mask, spec);
    let mut labels = [mapping.lo, mapping.mid(), mapping.hi].map(format_value);
    if mapping.hi <= mapping.lo {
        // Degenerate range: one value, shown once rather than three times.
        labels = [labels[0].clone(), String::new(), String::new()];
    }
    let lay = layout(width, height, &labels, spec);
    let (out_w, out_h) = (lay.out_w as u32, lay.out_h as u32);
    let mut buf: Vec<u8> = BACKGROUND.iter().copied().cycle().take(out_w as usize * out_h as usize * 3).collect();
    let lut = lut();
    let colour_of = |t: f32| lut[(t * (LUT_SIZE - 1) as f32 + 0.5) as usize];

    // The map, one output row per input row (parallel: maps can be 4K).
    let row_bytes = out_w as usize * 3;
    if width > 0 {
        buf.par_chunks_mut(row_bytes).skip(lay.map_y as usize).take(height as usize).enumerate().for_each(
            |(y, row)| {
                for x in 0..width as usize {
                    let i = y * width as usize + x;
                    let masked = mask.and_then(|m| m.get(i).copied()).unwrap_or(false);
                    let c = match values.get(i) {
                        _ if masked => MASKED,
                        Some(&v) if v.is_finite() => colour_of(mapping.t(v)),
                        // ±∞ (e.g. an unbounded filter width) saturates; only NaN is magenta.
                        Some(&v) if v.is_infinite() => colour_of(if v > 0.0 { 1.0 } else { 0.0 }),
                        _ => NON_FINITE,
                    };
                    let o = (lay.map_x as usize + x) * 3;
                    row[o..o + 3].copy_from_slice(&c);
                }
            },
        );
    }

    let mut canvas = Canvas { width: out_w, height: out_h, buf: &mut buf };
    if let Some(arrows) = spec.arrows {
        canvas.strokes(arrows, width, height, lay.map_x, lay.map_y);
    }
    canvas.text(spec.title, lay.out_w / 2, PAD, Alignment::Center);
    let (w, h) = (width as i32, height as i32);
    if lay.below {
        let bar_x = PAD;
        let bar_w = lay.out_w - 2 * PAD;
        let bar_y = lay.map_y + h + 2 * PAD;
        for i in 0..bar_w {
            let t = if bar_w > 1 { i as f32 / (bar_w - 1) as f32 } else { 0.0 };
            canvas.rect(bar_x + i, bar_y, 1, BAR_THICK, colour_of(t));
        }
        canvas.frame(bar_x, bar_y, bar_w, BAR_THICK);
        let tick_y = bar_y + BAR_THICK + 1;
        let label_y = tick_y + TICK;
        let ticks =
            [(bar_x, Alignment::Left), (bar_x + bar_w / 2, Alignment::Center), (bar_x + bar_w - 1, Alignment::Right)];
        for ((x, align), label) in ticks.into_iter().zip(&labels) {
            if !label.is_empty() {
                canvas.rect(x, tick_y, 1, TICK - 1, FRAME);
                let anchor = if align == Alignment::Right { x + 1 } else { x };
                canvas.text(label, anchor, label_y, align);
            }
        }
        if !spec.unit.is_empty() {
            canvas.text(spec.unit, lay.out_w / 2, label_y + CHAR_H + 2, Alignment::Center);
        }
    } else {
        let bar_x = lay.map_x + w + 2 * PAD;
        // Unit above the bar; the bar then spans the rest of the map height,
        // leaving half a line at either end so the end labels fit.
        let unit_h = if spec.unit.is_empty() { 0 } else { CHAR_H + 2 };
        let bar_top = lay.map_y + unit_h + CHAR_H / 2;
        let bar_h = (lay.map_y + h - CHAR_H / 2 - bar_top).max(1);
        if !spec.unit.is_empty() {
            canvas.text(spec.unit, bar_x, lay.map_y, Alignment::Left);
        }
        for i in 0..bar_h {
            // Top of the bar is the maximum.
            let t = if bar_h > 1 { 1.0 - i as f32 / (bar_h - 1) as f32 } else { 0.0 };
            canvas.rect(bar_x, bar_top + i, BAR_THICK, 1, colour_of(t));
        }
        canvas.frame(bar_x, bar_top, BAR_THICK, bar_h);
        let tick_x = bar_x + BAR_THICK + 1;
        let ticks = [bar_top + bar_h - 1, bar_top + bar_h / 2, bar_top];
        for (y, label) in ticks.into_iter().zip(&labels) {
            if !label.is_empty() {
                canvas.rect(tick_x, y, TICK - 1, 1, FRAME);
                canvas.text(label, tick_x + TICK + 1, y - CHAR_H / 2, Alignment::Left);
            }
        }
    }
    (out_w, out_h, buf)
}

/// [`render_heatmap`] and write the result as a PNG (atomically, like every
/// writer in [`crate::image`]). Unlike `render_heatmap`, a `values` or `mask`
/// length that does not match `width * height` is reported as an error,
/// since a file written from mismatched data would be misleading.
pub fn write_heatmap_png(
    path: &Path,
    width: u32,
    height: u32,
    values: &[f32],
    mask: Option<&[bool]>,
    spec: &HeatmapSpec,
) -> Result<(), ImageError> {
    let n = width as usize * height as usize;
    for actual in std::iter::once(values.len()).chain(mask.map(|m| m.len())) {
        if actual != n {
            return Err(ImageError::BufferSize { path: path.to_path_buf(), width, height, expected: n, actual });
        }
    }
    let (w, h, rgb) = render_heatmap(width, height, values, mask, spec);
    write_png_rgb8(path, w, h, &rgb)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(scale: Scale) -> HeatmapSpec<'static> {
        HeatmapSpec { title: "relative error", unit: "relMSE", scale, range: None, arrows: None }
    }

    /// Colour of map pixel (x, y) in a rendered heatmap.
    fn map_pixel(out: &(u32, u32, Vec<u8>), lay: &Layout, x: u32, y: u32) -> [u8; 3] {
        let i = ((lay.map_y as usize + y as usize) * out.0 as usize + lay.map_x as usize + x as usize) * 3;
        [out.2[i], out.2[i + 1], out.2[i + 2]]
    }

    fn layout_of(w: u32, h: u32, values: &[f32], mask: Option<&[bool]>, s: &HeatmapSpec) -> Layout {
        let m = Mapping::new(values, mask, s);
        let mut labels = [m.lo, m.mid(), m.hi].map(format_value);
        if m.hi <= m.lo {
            labels = [labels[0].clone(), String::new(), String::new()];
        }
        layout(w, h, &labels, s)
    }

    #[test]
    fn strokes_follow_the_vectors_of_each_cell() {
        // 32×32: cell centres at 8 and 24. One cell moves along +x by 3 px, one along −y by 20 px (capped
        // at the cell), the others are still.
        let (w, h) = (32u32, 32u32);
        let values = vec![1.0f32; (w * h) as usize];
        let mut v = vec![[0.0f32; 2]; (w * h) as usize];
        v[(8 * w + 8) as usize] = [3.0, 0.0];
        v[(8 * w + 24) as usize] = [0.0, -20.0];
        let s = HeatmapSpec { arrows: Some(&v), ..spec(Scale::Linear) };
        let out = render_heatmap(w, h, &values, None, &s);
        let lay = layout_of(w, h, &values, None, &s);
        let white = |x, y| map_pixel(&out, &lay, x, y) == [255, 255, 255];
        // ±3 px along the row through the centre, nothing beyond.
        assert!((5..=11).all(|x| white(x, 8)));
        assert!(!white(4, 8) && !white(12, 8) && !white(8, 7));
        // A long vector is capped at the cell: ±7 px.
        assert!((1..=15).all(|y| white(24, y)));
        assert!(!white(24, 0) && !white(24, 16));
        // Still cells draw nothing.
        assert!(!white(8, 24) && !white(24, 24));
    }

    #[test]
    fn output_dimensions_right_and_below() {
        let (w, h) = (200, 120);
        let values: Vec<f32> = (0..w * h).map(|i| i as f32).collect();
        let out = render_heatmap(w, h, &values, None, &spec(Scale::Linear));
        assert_eq!(out.2.len(), out.0 as usize * out.1 as usize * 3);
        assert!(out.0 > w + BAR_THICK as u32, "bar on the right widens the image: {}", out.0);
        assert_eq!(out.1, h + TITLE_BAND as u32 + PAD as u32);
        assert!(!layout_of(w, h, &values, None, &spec(Scale::Linear)).below);

        // Very narrow: bar below, image taller than the map + title.
        let values = vec![1.0; 8 * 300];
        let out = render_heatmap(8, 300, &values, None, &spec(Scale::Linear));
        assert!(layout_of(8, 300, &values, None, &spec(Scale::Linear)).below);
        assert!(out.1 > 300 + TITLE_BAND as u32 + BAR_THICK as u32);
        assert_eq!(out.2.len(), out.0 as usize * out.1 as usize * 3);

        // Empty map and mismatched input do not panic.
        let out = render_heatmap(0, 0, &[], None, &spec(Scale::Log));
        assert_eq!(out.2.len(), out.0 as usize * out.1 as usize * 3);
        let out = render_heatmap(4, 4, &[1.0], Some(&[true]), &spec(Scale::Linear));
        assert_eq!(out.2.len(), out.0 as usize * out.1 as usize * 3);
    }

    #[test]
    fn masked_non_finite_min_and_max_colours() {
        let (w, h) = (100, 100);
        let mut values: Vec<f32> = (0..w * h).map(|i| 1.0 + i as f32).collect();
        values[5] = f32::NAN;
        values[6] = f32::INFINITY;
        let mut mask = vec![false; (w * h) as usize];
        mask[7] = true;
        values[7] = 1e9; // masked, so must not stretch the range
        for scale in [Scale::Linear, Scale::Log] {
            let s = spec(scale);
            let out = render_heatmap(w, h, &values, Some(&mask), &s);
            let lay = layout_of(w, h, &values, Some(&mask), &s);
            assert_eq!(map_pixel(&out, &lay, 0, 0), colormap(0.0), "min -> first colour");
            assert_eq!(map_pixel(&out, &lay, 99, 99), colormap(1.0), "max -> last colour");
            assert_eq!(map_pixel(&out, &lay, 5, 0), NON_FINITE);
            assert_eq!(map_pixel(&out, &lay, 6, 0), colormap(1.0), "+inf saturates (does not stretch the range)");
            assert_eq!(map_pixel(&out, &lay, 7, 0), MASKED);
        }
        // viridis ends, as in matplotlib.
        assert_eq!(colormap(0.0), [0x44, 0x01, 0x54]);
        assert_eq!(colormap(1.0), [0xfd, 0xe7, 0x25]);
    }

    #[test]
    fn explicit_range_clamps_and_log_maps_decades_evenly() {
        let s = HeatmapSpec { range: Some((10.0, 1000.0)), arrows: None, ..spec(Scale::Log) };
        let m = Mapping::new(&[], None, &s);
        assert!((m.t(100.0) - 0.5).abs() < 1e-6);
        assert_eq!(m.t(1.0), 0.0);
        assert_eq!(m.t(1e6), 1.0);
        assert_eq!(m.t(-5.0), 0.0);
        assert!((m.mid() - 100.0).abs() < 1e-3);
        // Reversed range is swapped; all-equal data maps to the first colour.
        let m = Mapping::new(&[], None, &HeatmapSpec { range: Some((2.0, 0.0)), arrows: None, ..spec(Scale::Linear) });
        assert_eq!((m.lo, m.hi), (0.0, 2.0));
        let m = Mapping::new(&[3.0, 3.0], None, &spec(Scale::Linear));
        assert_eq!(m.t(3.0), 0.0);
        // Log with zeros in the data ignores them for the range.
        let m = Mapping::new(&[0.0, 0.01, 1.0], None, &spec(Scale::Log));
        assert_eq!((m.lo, m.hi), (0.01, 1.0));
    }

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(format_value(0.0), "0");
        assert_eq!(format_value(1.0), "1");
        assert_eq!(format_value(0.5), "0.5");
        assert_eq!(format_value(123.456), "123.5");
        assert_eq!(format_value(0.0012345), "0.001234");
        assert_eq!(format_value(2.5e-5), "2.5e-5");
        assert_eq!(format_value(1e6), "1e6");
        assert_eq!(format_value(-3.0), "-3");
    }

    #[test]
    fn text_is_drawn() {
        let (w, h) = (120, 100);
        let values: Vec<f32> = (0..w * h).map(|i| i as f32).collect();
        let out = render_heatmap(w, h, &values, None, &spec(Scale::Linear));
        // The title band (above the map) contains black text pixels.
        let band = &out.2[..out.0 as usize * TITLE_BAND as usize * 3];
        assert!(band.chunks(3).any(|p| p == [0, 0, 0]), "title drawn");
        // The label column right of the bar contains black text pixels.
        let lay = layout_of(w, h, &values, None, &spec(Scale::Linear));
        let label_x0 = (lay.map_x + w as i32 + 2 * PAD + BAR_THICK + TICK + 2) as usize;
        let has_text = (lay.map_y as usize..out.1 as usize).any(|y| {
            (label_x0..out.0 as usize).any(|x| {
                let i = (y * out.0 as usize + x) * 3;
                out.2[i..i + 3] == [0, 0, 0]
            })
        });
        assert!(has_text, "tick labels drawn");
    }

    #[test]
    fn png_written_and_bad_lengths_rejected() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("err.png");
        let values: Vec<f32> = (0..64 * 96).map(|i| (i as f32 * 0.01).sin().abs()).collect();
        write_heatmap_png(&path, 64, 96, &values, None, &spec(Scale::Linear)).unwrap();
        let img = ::image::open(&path).unwrap().to_rgb8();
        let (ow, oh, _) = render_heatmap(64, 96, &values, None, &spec(Scale::Linear));
        assert_eq!(img.dimensions(), (ow, oh));
        let err = write_heatmap_png(&dir.path().join("bad.png"), 64, 96, &values[1..], None, &spec(Scale::Linear))
            .unwrap_err();
        assert!(err.to_string().contains("bad.png"), "{err}");
        let err = write_heatmap_png(&dir.path().join("bad.png"), 64, 96, &values, Some(&[true]), &spec(Scale::Linear))
            .unwrap_err();
        assert!(matches!(err, ImageError::BufferSize { actual: 1, .. }), "{err:?}");
        assert!(!dir.path().join("bad.png").exists());
    }
}
