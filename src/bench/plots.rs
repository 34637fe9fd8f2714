//! Log-log convergence plots (error against rays per pixel or seconds, thesis Fig. 4.10) drawn with
//! `plotters` into an RGB buffer and written as PNG.
//!
//! plotters is built without any font feature (no system fonts, no font files): text is drawn by
//! [`MonoText`] (see [`super::mono_text`]).

use std::path::Path;

use plotters::prelude::*;

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
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], legend_color.stroke_width(2)));
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
                Series { label: "c".into(), color: GREY, style: SeriesStyle::Dashed, points: vec![(1.0, 0.1), (16.0, 0.1)] },
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
                Series { label: "ok".into(), color: RED, style: SeriesStyle::LinePoints, points: vec![(1.0, 0.1), (16.0, 0.02)] },
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
