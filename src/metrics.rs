//! Image error metrics, shared by `wedge compare` and the benchmark harness.
//!
//! All metrics are computed on **linear** RGB values (no tone mapping, no
//! sRGB curve), in `f64`, and averaged over the used pixels **and** their
//! three channels. A pixel with any non-finite channel (NaN or ±inf) in either
//! the test or the reference image is excluded from every average and counted
//! in [`Metrics::non_finite`] instead: one NaN would otherwise turn every
//! metric into NaN and hide how good the rest of the image is, while silently
//! dropping it would hide the NaN. Callers should report `non_finite` when it
//! is not zero.
//!
//! The relMSE and SMAPE definitions (including the 0.01 guard terms) are
//! those of the tev image viewer, so numbers printed by wedge can be checked
//! against tev by eye.
//!
//! Summation is done in fixed-size chunks combined in order, so results are
//! bit-identical whatever the number of threads.

use rayon::prelude::*;

use crate::image::Image;

/// Guard added to denominators (tev's value): keeps zero-reference pixels
/// finite while being negligible for well-exposed values.
const EPS: f64 = 0.01;

/// Error metrics of a test image against a reference.
///
/// When no pixel is usable (every pixel non-finite, or an empty image) all
/// floating-point fields are NaN and `pixels` is 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Metrics {
    /// Root mean squared error: `sqrt(mean((x − r)²))`.
    pub rmse: f64,
    /// Relative mean squared error: `mean((x − r)² / (r² + 0.01))` (tev's
    /// definition; the 0.01 keeps pixels with a zero reference finite).
    pub rel_mse: f64,
    /// Peak signal-to-noise ratio in dB: `10·log10(peak² / MSE)` with
    /// `peak = 1.0` on the linear values (so for HDR content it is a relative
    /// figure, not comparable with 8-bit PSNR). Identical images give `+inf`.
    pub psnr: f64,
    /// Symmetric mean absolute percentage error:
    /// `mean(|x − r| / (|x| + |r| + 0.01))` (tev's definition), in [0, 1).
    pub smape: f64,
    /// Largest absolute difference `|x − r|` over all used pixels and channels.
    pub max_abs: f64,
    /// Pixels excluded because the test or the reference pixel has a
    /// non-finite channel.
    pub non_finite: usize,
    /// Pixels used in the averages (each contributes three channel values).
    pub pixels: usize,
}

/// Why two images could not be compared.
#[derive(Debug, thiserror::Error)]
pub enum MetricsError {
    #[error("image sizes differ: test is {}x{}, reference is {}x{}; render the test image at the reference's resolution", test.0, test.1, reference.0, reference.1)]
    SizeMismatch { test: (u32, u32), reference: (u32, u32) },
    #[error(
        "the {which} image claims {width}x{height} pixels but holds {actual}; this is a bug in the code that built it"
    )]
    BadBuffer { which: &'static str, width: u32, height: u32, actual: usize },
}

/// Running sums for one chunk of pixels.
#[derive(Clone, Copy, Default)]
struct Sums {
    sq: f64,
    rel_sq: f64,
    smape: f64,
    max_abs: f64,
    used: usize,
    non_finite: usize,
}

impl Sums {
    fn add(mut self, o: Sums) -> Sums {
        self.sq += o.sq;
        self.rel_sq += o.rel_sq;
        self.smape += o.smape;
        self.max_abs = self.max_abs.max(o.max_abs);
        self.used += o.used;
        self.non_finite += o.non_finite;
        self
    }
}

fn finite(p: &[f32; 3]) -> bool {
    p.iter().all(|c| c.is_finite())
}

fn check_buffer(which: &'static str, img: &Image) -> Result<(), MetricsError> {
    let expected = img.width as u64 * img.height as u64;
    if img.pixels.len() as u64 != expected {
        return Err(MetricsError::BadBuffer { which, width: img.width, height: img.height, actual: img.pixels.len() });
    }
    Ok(())
}

/// Computes all [`Metrics`] of `test` against `reference` (see the field
/// docs for the definitions). Errors if the sizes differ.
pub fn compare(test: &Image, reference: &Image) -> Result<Metrics, MetricsError> {
    if (test.width, test.height) != (reference.width, reference.height) {
        return Err(MetricsError::SizeMismatch {
            test: (test.width, test.height),
            reference: (reference.width, reference.height),
        });
    }
    check_buffer("test", test)?;
    check_buffer("reference", reference)?;

    // Fixed chunk size, partial sums collected in order: deterministic.
    const CHUNK: usize = 4096;
    let partials: Vec<Sums> = test
        .pixels
        .par_chunks(CHUNK)
        .zip(reference.pixels.par_chunks(CHUNK))
        .map(|(t, r)| {
            let mut s = Sums::default();
            for (x, y) in t.iter().zip(r) {
                if !(finite(x) && finite(y)) {
                    s.non_finite += 1;
                    continue;
                }
                s.used += 1;
                for c in 0..3 {
                    let (xv, rv) = (x[c] as f64, y[c] as f64);
                    let d = xv - rv;
                    s.sq += d * d;
                    s.rel_sq += d * d / (rv * rv + EPS);
                    s.smape += d.abs() / (xv.abs() + rv.abs() + EPS);
                    s.max_abs = s.max_abs.max(d.abs());
                }
            }
            s
        })
        .collect();
    let s = partials.into_iter().fold(Sums::default(), Sums::add);

    if s.used == 0 {
        return Ok(Metrics {
            rmse: f64::NAN,
            rel_mse: f64::NAN,
            psnr: f64::NAN,
            smape: f64::NAN,
            max_abs: f64::NAN,
            non_finite: s.non_finite,
            pixels: 0,
        });
    }
    let n = (s.used * 3) as f64;
    let mse = s.sq / n;
    Ok(Metrics {
        rmse: mse.sqrt(),
        rel_mse: s.rel_sq / n,
        // peak = 1: 10·log10(1 / mse); mse = 0 gives +inf by IEEE division.
        psnr: 10.0 * (1.0 / mse).log10(),
        smape: s.smape / n,
        max_abs: s.max_abs,
        non_finite: s.non_finite,
        pixels: s.used,
    })
}

/// Per-pixel relative squared error for the error heatmap: for each pixel,
/// the mean over its three channels of `(x − r)² / (r² + 0.01)` — the
/// per-pixel term of [`Metrics::rel_mse`], so the map's mean over finite
/// pixels equals `rel_mse`.
///
/// The result has one value per pixel of `test` (row-major). Pixels with a
/// non-finite channel in either image are NaN (the heatmap paints them
/// magenta). This function does not fail: if the sizes differ (which
/// [`compare`] reports as an error), pixels without a counterpart at the same
/// `(x, y)` in the reference are NaN too.
pub fn error_map(test: &Image, reference: &Image) -> Vec<f32> {
    let (tw, rw) = (test.width as usize, reference.width as usize);
    let n = tw * test.height as usize;
    (0..n)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % tw, i / tw);
            let t = test.pixels.get(i);
            let r = if x < rw && y < reference.height as usize { reference.pixels.get(y * rw + x) } else { None };
            match (t, r) {
                (Some(t), Some(r)) if finite(t) && finite(r) => {
                    let mut acc = 0.0f64;
                    for c in 0..3 {
                        let (xv, rv) = (t[c] as f64, r[c] as f64);
                        acc += (xv - rv) * (xv - rv) / (rv * rv + EPS);
                    }
                    (acc / 3.0) as f32
                }
                _ => f32::NAN,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-9
    }

    fn two_pixel(a: [f32; 3], b: [f32; 3]) -> Image {
        Image { width: 2, height: 1, pixels: vec![a, b] }
    }

    #[test]
    fn identical_images() {
        let img = Image::from_fn(7, 5, |x, y| [x as f32, y as f32 * 0.1, 3.0]);
        let m = compare(&img, &img).unwrap();
        assert_eq!(m.rmse, 0.0);
        assert_eq!(m.rel_mse, 0.0);
        assert_eq!(m.smape, 0.0);
        assert_eq!(m.max_abs, 0.0);
        assert_eq!(m.psnr, f64::INFINITY);
        assert_eq!((m.pixels, m.non_finite), (35, 0));
        assert!(error_map(&img, &img).iter().all(|&v| v == 0.0));
    }

    #[test]
    fn two_by_one_hand_computed() {
        // Differences: pixel 0: (0.5, 0, -0.5), pixel 1: (0, 0, -1).
        let test = two_pixel([1.0, 0.5, 0.0], [0.0, 0.0, 0.0]);
        let reference = two_pixel([0.5, 0.5, 0.5], [0.0, 0.0, 1.0]);
        let m = compare(&test, &reference).unwrap();
        // Squared errors 0.25, 0, 0.25, 0, 0, 1 -> MSE = 1.5 / 6 = 0.25.
        assert!(close(m.rmse, 0.5), "{m:?}");
        // 10·log10(1 / 0.25) = 10·log10(4).
        assert!(close(m.psnr, 6.020599913279624), "{m:?}");
        // (0.25/0.26 + 0 + 0.25/0.26 + 0/0.01 + 0/0.01 + 1/1.01) / 6
        assert!(close(m.rel_mse, 0.4855293221629855), "{m:?}");
        // (0.5/1.51 + 0/1.01 + 0.5/0.51 + 0 + 0 + 1/1.01) / 6
        assert!(close(m.smape, 0.38360283242971743), "{m:?}");
        assert!(close(m.max_abs, 1.0));
        assert_eq!((m.pixels, m.non_finite), (2, 0));

        let map = error_map(&test, &reference);
        assert!((map[0] as f64 - (0.5 / 0.26) / 3.0).abs() < 1e-6);
        assert!((map[1] as f64 - (1.0 / 1.01) / 3.0).abs() < 1e-6);
    }

    #[test]
    fn zero_reference_stays_finite_in_rel_mse() {
        // 0.125 is exact in f32, so the expected values are exact too.
        let test = two_pixel([0.125, 0.0, 0.0], [0.0; 3]);
        let reference = two_pixel([0.0; 3], [0.0; 3]);
        let m = compare(&test, &reference).unwrap();
        // One non-zero term: 0.125² / (0² + 0.01) = 1.5625, averaged over 6.
        assert!(close(m.rel_mse, 1.5625 / 6.0), "{m:?}");
        // SMAPE: 0.125 / (0.125 + 0 + 0.01), averaged over 6.
        assert!(close(m.smape, 0.125 / 0.135 / 6.0), "{m:?}");
        assert!(m.rel_mse.is_finite() && m.smape.is_finite());
    }

    #[test]
    fn non_finite_pixels_are_counted_and_excluded() {
        let test = Image { width: 3, height: 1, pixels: vec![[f32::NAN, 0.0, 0.0], [1.0; 3], [0.5; 3]] };
        let reference = Image { width: 3, height: 1, pixels: vec![[0.0; 3], [1.0; 3], [f32::INFINITY, 0.0, 0.0]] };
        let m = compare(&test, &reference).unwrap();
        assert_eq!((m.non_finite, m.pixels), (2, 1));
        // Only the identical middle pixel is averaged.
        assert_eq!(m.rmse, 0.0);
        assert_eq!(m.psnr, f64::INFINITY);
        let map = error_map(&test, &reference);
        assert!(map[0].is_nan() && map[2].is_nan());
        assert_eq!(map[1], 0.0);
    }

    #[test]
    fn nothing_usable_gives_nan_and_zero_pixels() {
        let test = Image { width: 1, height: 1, pixels: vec![[f32::NAN; 3]] };
        let m = compare(&test, &Image::new(1, 1)).unwrap();
        assert_eq!((m.pixels, m.non_finite), (0, 1));
        assert!(m.rmse.is_nan() && m.psnr.is_nan());
    }

    #[test]
    fn size_mismatch_names_both_sizes() {
        let err = compare(&Image::new(4, 3), &Image::new(3, 4)).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("4x3") && msg.contains("3x4"), "{msg}");
        // error_map does not panic on mismatched sizes.
        let map = error_map(&Image::new(4, 3), &Image::new(3, 4));
        assert_eq!(map.len(), 12);
        assert!(map[3].is_nan() && map[0] == 0.0);
    }

    #[test]
    fn malformed_buffer_is_an_error() {
        let mut bad = Image::new(2, 2);
        bad.pixels.pop();
        assert!(matches!(compare(&bad, &Image::new(2, 2)), Err(MetricsError::BadBuffer { which: "test", .. })));
    }

    #[test]
    fn result_is_independent_of_chunking() {
        // More pixels than one chunk, so several partial sums are combined.
        let a = Image::from_fn(300, 50, |x, y| [(x as f32).sin(), (y as f32).cos(), 0.3]);
        let b = Image::from_fn(300, 50, |x, y| [(x as f32 * 1.01).sin(), (y as f32).cos() * 0.9, 0.3]);
        let m = compare(&a, &b).unwrap();
        let (mut sq, mut rel) = (0.0f64, 0.0f64);
        for (x, r) in a.pixels.iter().zip(&b.pixels) {
            for c in 0..3 {
                let d = x[c] as f64 - r[c] as f64;
                sq += d * d;
                rel += d * d / (r[c] as f64 * r[c] as f64 + 0.01);
            }
        }
        let n = (a.pixels.len() * 3) as f64;
        assert!((m.rmse - (sq / n).sqrt()).abs() < 1e-12);
        assert!((m.rel_mse - rel / n).abs() < 1e-12);
        let map = error_map(&a, &b);
        let map_mean = map.iter().map(|&v| v as f64).sum::<f64>() / map.len() as f64;
        assert!((map_mean - m.rel_mse).abs() < 1e-6 * m.rel_mse.max(1.0));
    }
}
