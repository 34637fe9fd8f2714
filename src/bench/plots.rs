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
    /// `(x, y)`; non-positive or non-finite points are skipped (log axes).
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

fn usable(p: &(f64, f64)) -> bool {
    p.0.is_finite() && p.1.is_finite() && p.0 > 0.0 && p.1 > 0.0
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
            .caption(&plot.title, ("sans-serif", 20))
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
