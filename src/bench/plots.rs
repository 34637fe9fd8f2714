//! Log-log convergence plots (error against rays per pixel or seconds, thesis Fig. 4.10) drawn with
//! `plotters` into an RGB buffer and written as PNG.
//!
//! plotters is built without any font feature (no system fonts, no font files): text is drawn by
//! [`MonoText`] (see [`super::mono_text`]).

use std::path::Path;

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

pub use super::mono_text::MonoText;

use crate::image::{write_png_rgb8, ImageError};

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SeriesStyle {
    /// Points joined by a solid line.
    LinePoints,
    /// Dashed line, no markers (fits, reference lines).
    Dashed,
    /// Markers only.
    Points,
}

#[derive(Clone, Debug)]
pub struct Series {
    pub label: String,
    pub color: [u8; 3],
    pub style: SeriesStyle,
    /// `(x, y)`; non-positive, non-finite or absurd points are skipped (log axes), see [`usable`].
    pub points: Vec<(f64, f64)>,
}

#[derive(Clone, Debug)]
pub struct Plot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
}

pub const PLOT_WIDTH: u32 = 900;
pub const PLOT_HEIGHT: u32 = 640;

/// Colours shared by the plots and the report's legend.
pub const RED: [u8; 3] = [214, 39, 40];
pub const BLUE: [u8; 3] = [31, 119, 180];
pub const GREEN: [u8; 3] = [44, 160, 44];
pub const GREY: [u8; 3] = [110, 110, 110];

/// Smallest and largest coordinate a log axis takes. Outside it a value is not a measurement but
/// a corrupt or overflowed number (a cache file saying `noise_rmse=1e300`), and plotters' log-axis
/// tick generation does not finish on ranges spanning hundreds of decades or reaching infinity.
const MIN_PLOTTABLE: f64 = 1e-30;
const MAX_PLOTTABLE: f64 = 1e30;

/// Finite, positive and within [`MIN_PLOTTABLE`]..=[`MAX_PLOTTABLE`] on both axes.
fn usable(p: &(f64, f64)) -> bool {
    let ok = |v: f64| (MIN_PLOTTABLE..=MAX_PLOTTABLE).contains(&v);
    ok(p.0) && ok(p.1)
}

/// Points of `plot` that [`usable`] rejects (they are skipped, and the title says how many).
fn unplottable_points(plot: &Plot) -> usize {
    plot.series.iter().flat_map(|s| &s.points).filter(|p| !usable(p)).count()
}

/// The plot's title, with a note when points had to be skipped.
fn title_with_note(plot: &Plot) -> String {
    match unplottable_points(plot) {
        0 => plot.title.clone(),
        n => format!("{} [{n} point(s) off the plottable range skipped: NaN, inf, <= 0 or beyond 1e±30]", plot.title),
    }
}

/// Log range covering `values` with a margin of a tenth of a decade at each end.
fn log_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() || !hi.is_finite() {
        return (0.1, 10.0);
    }
    if hi <= lo {
        return (lo / 2.0, hi * 2.0);
    }
    // Values come from `usable` points (within 1e±30), so the margin below is at most ~5 decades
    // and the range stays finite and positive.
    let m = ((hi / lo).log10() * 0.08).max(0.05);
    (lo / 10f64.powf(m), hi * 10f64.powf(m))
}

fn rgb(c: [u8; 3]) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

/// Draw `plot` into an RGB8 buffer of `width × height`.
pub fn render_plot(plot: &Plot, width: u32, height: u32) -> Result<Vec<u8>, String> {
    let mut buf = vec![255u8; width as usize * height as usize * 3];
    {
        let root = MonoText::new(&mut buf, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let pts = || plot.series.iter().flat_map(|s| s.points.iter()).filter(|p| usable(p));
        let (x0, x1) = log_range(pts().map(|p| p.0));
        let (y0, y1) = log_range(pts().map(|p| p.1));
        let mut chart = ChartBuilder::on(&root)
            .caption(title_with_note(plot), ("sans-serif", 20))
            .margin(14)
            .x_label_area_size(44)
            .y_label_area_size(78)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .x_desc(plot.x_label.as_str())
            .y_desc(plot.y_label.as_str())
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 15))
            .x_label_formatter(&|v| fmt_tick(*v))
            .y_label_formatter(&|v| fmt_tick(*v))
            .light_line_style(RGBColor(238, 238, 238))
            .x_max_light_lines(2)
            .y_max_light_lines(2)
            .draw()
            .map_err(|e| e.to_string())?;
        for s in &plot.series {
            let points: Vec<(f64, f64)> = s.points.iter().copied().filter(usable).collect();
            if points.is_empty() {
                continue;
            }
            let color = rgb(s.color);
            let legend_color = color;
            match s.style {
                SeriesStyle::LinePoints => {
                    chart
                        .draw_series(LineSeries::new(points.clone(), color.stroke_width(2)))
                        .map_err(|e| e.to_string())?
                        .label(s.label.as_str())
                        .legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 20, y)], legend_color.stroke_width(2))
                        });
                    chart
                        .draw_series(points.iter().map(|p| Circle::new(*p, 4, color.filled())))
                        .map_err(|e| e.to_string())?;
                }
                SeriesStyle::Points => {
                    chart
                        .draw_series(points.iter().map(|p| TriangleMarker::new(*p, 7, color.filled())))
                        .map_err(|e| e.to_string())?
                        .label(s.label.as_str())
                        .legend(move |(x, y)| TriangleMarker::new((x + 10, y), 7, legend_color.filled()));
                }
                SeriesStyle::Dashed => {
                    chart
                        .draw_series(DashedLineSeries::new(points.clone(), 6, 5, color.stroke_width(1)))
                        .map_err(|e| e.to_string())?
                        .label(s.label.as_str())
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 8, y)], legend_color.stroke_width(1)));
                }
            }
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font(("sans-serif", 13))
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .draw()
            .map_err(|e| e.to_string())?;
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(buf)
}

/// Tick label: plain decimals in [0.001, 1e5), scientific outside.
fn fmt_tick(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if (0.001..1e5).contains(&a) {
        let s = format!("{:.4}", v);
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.0e}")
    }
}

/// Render and write `plot` as a PNG of the default size.
pub fn write_plot(path: &Path, plot: &Plot) -> Result<(), ImageError> {
    let rgb = render_plot(plot, PLOT_WIDTH, PLOT_HEIGHT)
        .map_err(|reason| ImageError::Encode { path: path.to_path_buf(), reason })?;
    write_png_rgb8(path, PLOT_WIDTH, PLOT_HEIGHT, &rgb)
}

/// One series of a [`BarChart`]: a value per category.
#[derive(Clone, Debug)]
pub struct BarSeries {
    pub label: String,
    pub color: [u8; 3],
    /// One per category; unusable values (NaN, ≤ 0, see [`usable`]) draw no bar.
    pub values: Vec<f64>,
}

/// Horizontal grouped bars on a log x axis, one group per category (top to bottom in order), each
/// bar drawn from `base` to its value (so values below `base` extend left), with dashed vertical
/// reference lines (`label`, x, colour).
#[derive(Clone, Debug)]
pub struct BarChart {
    pub title: String,
    pub x_label: String,
    pub categories: Vec<String>,
    pub series: Vec<BarSeries>,
    pub base: f64,
    pub lines: Vec<(String, f64, [u8; 3])>,
}

/// Draw `chart` into an RGB8 buffer of `width × height`.
pub fn render_bar_chart(chart: &BarChart, width: u32, height: u32) -> Result<Vec<u8>, String> {
    let mut buf = vec![255u8; width as usize * height as usize * 3];
    {
        let root = MonoText::new(&mut buf, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let n = chart.categories.len().max(1);
        let xs = chart
            .series
            .iter()
            .flat_map(|s| s.values.iter().copied())
            .chain(chart.lines.iter().map(|l| l.1))
            .chain([chart.base])
            .map(|v| (v, 1.0))
            .filter(usable)
            .map(|p| p.0);
        let (x0, x1) = log_range(xs);
        // A third more on the right (in log space) keeps the legend clear of the longest bars, a
        // little more on the left the value labels of bars below `base` clear of the names.
        let span = x1 / x0;
        let (x0, x1) = (x0 / span.powf(0.08), x1 * span.powf(0.35));
        let label_px = chart.categories.iter().map(|c| c.chars().count()).max().unwrap_or(4) as u32 * 7 + 16;
        let mut ch = ChartBuilder::on(&root)
            .caption(chart.title.as_str(), ("sans-serif", 20))
            .margin(14)
            .x_label_area_size(44)
            .y_label_area_size(label_px.min(width / 3))
            .build_cartesian_2d((x0..x1).log_scale(), 0f64..n as f64)
            .map_err(|e| e.to_string())?;
        ch.configure_mesh()
            .x_desc(chart.x_label.as_str())
            .label_style(("sans-serif", 13))
            .axis_desc_style(("sans-serif", 15))
            .x_label_formatter(&|v| format!("{}x", fmt_tick(*v)))
            .y_labels(0)
            .disable_y_mesh()
            .light_line_style(RGBColor(238, 238, 238))
            .x_max_light_lines(2)
            .draw()
            .map_err(|e| e.to_string())?;
        // Category k occupies y ∈ [n − 1 − k, n − k] (the first at the top); its bars share 80% of it.
        let groups = chart.series.len().max(1) as f64;
        for (si, s) in chart.series.iter().enumerate() {
            let color = rgb(s.color);
            let bars: Vec<Rectangle<(f64, f64)>> = s
                .values
                .iter()
                .enumerate()
                .filter(|(_, v)| usable(&(**v, 1.0)))
                .map(|(k, &v)| {
                    let top = (n - k) as f64 - 0.1 - 0.8 * si as f64 / groups;
                    let bottom = top - 0.8 / groups;
                    Rectangle::new([(chart.base.min(v), bottom), (chart.base.max(v), top)], color.filled())
                })
                .collect();
            let legend_color = color;
            ch.draw_series(bars)
                .map_err(|e| e.to_string())?
                .label(s.label.as_str())
                .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 16, y + 5)], legend_color.filled()));
            // The value at the bar's far end (right of bars above `base`, left of those below).
            let values = s.values.iter().enumerate().filter(|(_, v)| usable(&(**v, 1.0))).map(|(k, &v)| {
                let centre = (n - k) as f64 - 0.1 - 0.8 * (si as f64 + 0.5) / groups;
                let h = if v >= chart.base { HPos::Left } else { HPos::Right };
                let style =
                    TextStyle::from(("sans-serif", 12).into_font()).pos(Pos::new(h, VPos::Center)).color(&BLACK);
                Text::new(format!(" {v:.2}x "), (v, centre), style)
            });
            ch.draw_series(values).map_err(|e| e.to_string())?;
        }
        for (label, x, c) in &chart.lines {
            if !usable(&(*x, 1.0)) {
                continue;
            }
            let color = rgb(*c);
            ch.draw_series(DashedLineSeries::new(vec![(*x, 0.0), (*x, n as f64)], 6, 5, color.stroke_width(1)))
                .map_err(|e| e.to_string())?
                .label(label.as_str())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(1)));
        }
        ch.configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font(("sans-serif", 13))
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .draw()
            .map_err(|e| e.to_string())?;
        // Category names left of the plotting area, centred on their group.
        let style =
            TextStyle::from(("sans-serif", 13).into_font()).pos(Pos::new(HPos::Right, VPos::Center)).color(&BLACK);
        for (k, name) in chart.categories.iter().enumerate() {
            let (px, py) = ch.backend_coord(&(x0, (n - k) as f64 - 0.5));
            root.draw(&Text::new(name.as_str(), (px - 6, py), style.clone())).map_err(|e| e.to_string())?;
        }
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(buf)
}

/// Height of a bar chart of `categories` rows (at least the default plot height).
pub fn bar_chart_height(categories: usize) -> u32 {
    (160 + 44 * categories as u32).max(PLOT_HEIGHT)
}

/// Render and write `chart` as a PNG ([`PLOT_WIDTH`] wide, [`bar_chart_height`] high).
pub fn write_bar_chart(path: &Path, chart: &BarChart) -> Result<(), ImageError> {
    let height = bar_chart_height(chart.categories.len());
    let rgb = render_bar_chart(chart, PLOT_WIDTH, height)
        .map_err(|reason| ImageError::Encode { path: path.to_path_buf(), reason })?;
    write_png_rgb8(path, PLOT_WIDTH, height, &rgb)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plot_draws_data_and_text() {
        let plot = Plot {
            title: "RMSE vs rays".into(),
            x_label: "rays per pixel".into(),
            y_label: "RMSE".into(),
            series: vec![
                Series {
                    label: "a".into(),
                    color: RED,
                    style: SeriesStyle::LinePoints,
                    points: vec![(1.0, 1.0), (4.0, 0.5), (16.0, 0.25), (0.0, 1.0)],
                },
                Series { label: "b".into(), color: GREEN, style: SeriesStyle::Points, points: vec![(2.0, 0.3)] },
                Series {
                    label: "c".into(),
                    color: GREY,
                    style: SeriesStyle::Dashed,
                    points: vec![(1.0, 0.1), (16.0, 0.1)],
                },
            ],
        };
        let buf = render_plot(&plot, 400, 300).unwrap();
        let count = |c: [u8; 3]| buf.chunks(3).filter(|p| *p == c).count();
        assert!(count(RED) > 50, "red line drawn");
        assert!(count(GREEN) > 10, "green markers drawn");
        // Dark text pixels (title, ticks, labels) exist beyond the axis lines.
        assert!(count([0, 0, 0]) > 500);
    }

    #[test]
    fn bar_chart_draws_bars_lines_and_names() {
        let chart = BarChart {
            title: "speedup".into(),
            x_label: "x".into(),
            categories: vec!["one".into(), "two".into(), "three".into()],
            series: vec![
                BarSeries { label: "a".into(), color: BLUE, values: vec![2.0, 0.5, f64::NAN] },
                BarSeries { label: "b".into(), color: RED, values: vec![10.0, 3.0, 1.5] },
            ],
            base: 1.0,
            lines: vec![("2x".into(), 2.0, GREY)],
        };
        let buf = render_bar_chart(&chart, 600, 400).unwrap();
        let count = |c: [u8; 3]| buf.chunks(3).filter(|p| *p == c).count();
        assert!(count(BLUE) > 300, "blue bars drawn");
        assert!(count(RED) > 600, "red bars drawn");
        assert!(count(GREY) > 20, "the 2x line drawn");
        assert!(count([0, 0, 0]) > 300, "text and axes drawn");
        assert_eq!(bar_chart_height(3), PLOT_HEIGHT);
        assert!(bar_chart_height(20) > PLOT_HEIGHT);
    }

    #[test]
    fn ticks() {
        assert_eq!(fmt_tick(0.25), "0.25");
        assert_eq!(fmt_tick(100.0), "100");
        assert_eq!(fmt_tick(0.002), "0.002");
        assert_eq!(fmt_tick(0.0001), "1e-4");
    }
}

#[cfg(test)]
mod extreme_value_tests {
    use super::*;
    use std::sync::mpsc;
    use std::time::Duration;

    /// Render on a thread and give up after `secs`: a hang fails the test instead of stalling it.
    fn render_within(plot: Plot, secs: u64) -> Result<Vec<u8>, String> {
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            let _ = tx.send(render_plot(&plot, 300, 200));
        });
        rx.recv_timeout(Duration::from_secs(secs)).expect("render_plot must finish (it hung on extreme values)")
    }

    fn plot_with(points: Vec<(f64, f64)>) -> Plot {
        Plot {
            title: "t".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            series: vec![
                Series {
                    label: "ok".into(),
                    color: RED,
                    style: SeriesStyle::LinePoints,
                    points: vec![(1.0, 0.1), (16.0, 0.02)],
                },
                Series { label: "bad".into(), color: GREY, style: SeriesStyle::Dashed, points },
            ],
        }
    }

    #[test]
    fn extreme_and_non_finite_values_neither_hang_nor_panic() {
        for bad in [1e300, f64::MAX, f64::INFINITY, f64::NAN, 0.0, -1.0, 1e-300, f64::MIN_POSITIVE] {
            let buf = render_within(plot_with(vec![(1.0, bad), (16.0, bad)]), 30).unwrap();
            let red = buf.chunks(3).filter(|p| *p == RED).count();
            assert!(red > 20, "the usable series is still drawn with {bad:e} beside it");
        }
        // Only unusable points: an empty chart, no hang.
        let only_bad = Plot { series: vec![plot_with(vec![(1e300, 1e300)]).series[1].clone()], ..plot_with(vec![]) };
        render_within(only_bad, 30).unwrap();
    }

    #[test]
    fn skipped_points_are_counted_in_the_title() {
        let plot = plot_with(vec![(1.0, 1e300), (f64::NAN, 1.0), (2.0, 0.5)]);
        assert_eq!(unplottable_points(&plot), 2);
        assert!(title_with_note(&plot).contains("2 point(s) off the plottable range"), "{}", title_with_note(&plot));
        assert_eq!(title_with_note(&plot_with(vec![(2.0, 0.5)])), "t");
    }
}
