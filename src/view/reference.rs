//! The error view: the mean of the frames against a reference image (`wedge view --reference REF.exr`,
//! a script's `reference: "FILE"`, or one rendered in the background: [`super::background`]), shown as a heatmap of |image − reference| with its colour bar,
//! and the RMSE and relMSE of `wedge compare` (`crate::metrics`) in the status bar, so the numbers in
//! the window are the ones `wedge compare` prints for a screenshot's `render.exr`.

use std::path::Path;

use wedge_backends::RunResult;

use super::outputs::Picture;
use crate::heatmap::{render_heatmap, HeatmapSpec, Scale};
use crate::image::Image;
use crate::metrics::Metrics;
use crate::outputs::buffer_to_image;
use crate::WedgeError;

/// The output picker's name of the error view.
pub const ERROR_VIEW: &str = "error";

/// A reference image the size of the viewer's, and the metrics of the current mean against it.
#[derive(Clone, Debug)]
pub struct Reference {
    /// Where it comes from, for the status bar: the file, or the background reference's name.
    pub name: String,
    pub image: Image,
    /// Of the current mean's `color` against the reference; `Err` says why there are none (no
    /// frame yet, the pipeline's size changed on a reload).
    pub metrics: Result<Metrics, String>,
}

impl Reference {
    /// Read `path` (an EXR such as `wedge reference` writes) for a `width` × `height` viewer.
    pub fn load(path: &Path, width: u32, height: u32) -> Result<Reference, WedgeError> {
        let image = crate::image::read_exr(path)?;
        check_size(path, (image.width, image.height), (width, height))?;
        Ok(Reference::rendered(image, path.display().to_string()))
    }

    /// A reference image of the viewer's size rendered here, called `name` in the status bar.
    pub fn rendered(image: Image, name: String) -> Reference {
        Reference { name, image, metrics: Err("no frame rendered yet".into()) }
    }

    /// Recompute the metrics for `mean` (the viewer's mean run).
    pub fn update(&mut self, mean: Option<&RunResult>, width: u32, height: u32) {
        self.metrics = match mean.and_then(|run| run.output("color")) {
            None => Err("the pipeline has no `color` output to compare".into()),
            Some(color) => crate::metrics::compare(&buffer_to_image(color, width, height), &self.image)
                .map_err(|e| format!("{}: {e}", self.name)),
        };
    }

    /// The status bar's line: the metrics against the reference, or why there are none.
    pub fn summary(&self) -> String {
        match &self.metrics {
            Ok(m) => format!(
                "against {}: RMSE {:.6} · relMSE {:.6}{}",
                self.name,
                m.rmse,
                m.rel_mse,
                if m.non_finite > 0 {
                    format!(" ({} non-finite pixel(s) excluded)", m.non_finite)
                } else {
                    String::new()
                }
            ),
            Err(why) => format!("against {}: {why}", self.name),
        }
    }

    /// The heatmap of |`mean`'s colour − reference| (mean over the channels), `None` without a
    /// colour output or when the sizes differ.
    pub fn picture(&self, mean: &RunResult, width: u32, height: u32) -> Option<Picture> {
        let image = buffer_to_image(mean.output("color")?, width, height);
        if (image.width, image.height) != (self.image.width, self.image.height) {
            return None;
        }
        let error = abs_error(&image, &self.image);
        let spec = HeatmapSpec {
            title: "|image - reference|",
            unit: "",
            scale: Scale::Log,
            range: log_range(&error),
            arrows: None,
        };
        let (width, height, rgb) = render_heatmap(width, height, &error, None, &spec);
        Some(Picture { width, height, rgb })
    }
}

/// Decades of error the heatmap spans below the largest: float round-off (1e-19 next to 1e-2)
/// would otherwise take most of the colour bar.
const LOG_DECADES: f32 = 4.0;

/// The heatmap's range: [`LOG_DECADES`] decades up to the largest finite error (`None`: no error > 0).
fn log_range(error: &[f32]) -> Option<(f32, f32)> {
    let hi = error.iter().copied().filter(|e| e.is_finite()).fold(0.0f32, f32::max);
    (hi > 0.0).then(|| (hi * 10f32.powf(-LOG_DECADES), hi))
}

/// A reference of `found` pixels for a viewer of `want`: refused, with how to get a matching one.
fn check_size(path: &Path, found: (u32, u32), want: (u32, u32)) -> Result<(), WedgeError> {
    if found == want {
        return Ok(());
    }
    Err(WedgeError::Usage(format!(
        "{}: the reference is {}x{} but the viewer renders {}x{}; pass --width {} --height {}, or render a \
         reference of this size with `wedge reference PIPELINE --width {} --height {}`",
        path.display(),
        found.0,
        found.1,
        want.0,
        want.1,
        found.0,
        found.1,
        want.0,
        want.1
    )))
}

/// Per pixel, the mean over the channels of |test − reference| (NaN where either is not finite:
/// the heatmap paints it magenta). Images of one size.
pub fn abs_error(test: &Image, reference: &Image) -> Vec<f32> {
    let finite = |p: &[f32; 3]| p.iter().all(|c| c.is_finite());
    test.pixels
        .iter()
        .zip(&reference.pixels)
        .map(|(t, r)| {
            if !(finite(t) && finite(r)) {
                return f32::NAN;
            }
            (0..3).map(|c| (t[c] - r[c]).abs()).sum::<f32>() / 3.0
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn abs_error_is_the_mean_channel_difference_and_nan_for_non_finite() {
        let a = Image { width: 3, height: 1, pixels: vec![[1.0, 2.0, 3.0], [0.0; 3], [f32::NAN, 0.0, 0.0]] };
        let b = Image { width: 3, height: 1, pixels: vec![[1.0, 1.0, 0.0], [0.0; 3], [0.0; 3]] };
        let e = abs_error(&a, &b);
        assert_eq!(&e[..2], &[4.0 / 3.0, 0.0]);
        assert!(e[2].is_nan());
    }

    #[test]
    fn the_log_range_spans_four_decades_below_the_largest_error() {
        assert_eq!(log_range(&[0.0, 1e-20, 0.5, f32::NAN]), Some((0.5e-4, 0.5)));
        assert_eq!(log_range(&[0.0, f32::NAN]), None);
    }

    #[test]
    fn a_reference_of_another_size_names_the_file_both_sizes_and_the_fix() {
        let e = check_size(Path::new("ref.exr"), (64, 48), (16, 12)).unwrap_err().to_string();
        for want in ["ref.exr", "64x48", "16x12", "--width 64 --height 48", "wedge reference"] {
            assert!(e.contains(want), "{want}: {e}");
        }
        assert!(check_size(Path::new("ref.exr"), (16, 12), (16, 12)).is_ok());
    }
}
