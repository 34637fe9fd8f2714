//! Mean FLIP (NVIDIA's perceptual difference metric, LDR variant) between two renders.
//!
//! LDR-FLIP works on 8-bit sRGB images, so both images go through [`crate::image::to_srgb8`] at
//! exposure 1 (clamp to [0, 1], sRGB curve) first; the number therefore measures what a viewer of
//! the PNGs sees, not HDR error. Viewing conditions: FLIP's default 67 pixels per degree.

use crate::image::{to_srgb8, Image};

/// Mean of the FLIP error map of `test` against `reference` (0 = identical, 1 = maximal).
/// NaN when the sizes differ or the image is empty.
pub fn mean_flip(test: &Image, reference: &Image) -> f64 {
    if (test.width, test.height) != (reference.width, reference.height) || test.pixels.is_empty() {
        return f64::NAN;
    }
    let t = nv_flip::FlipImageRgb8::with_data(test.width, test.height, &to_srgb8(test, 1.0));
    let r = nv_flip::FlipImageRgb8::with_data(reference.width, reference.height, &to_srgb8(reference, 1.0));
    let map = nv_flip::flip(r, t, nv_flip::DEFAULT_PIXELS_PER_DEGREE).to_vec();
    map.iter().map(|&v| v as f64).sum::<f64>() / map.len() as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_is_zero_and_different_is_positive() {
        let a = Image::from_fn(32, 24, |x, y| [x as f32 / 32.0, y as f32 / 24.0, 0.5]);
        assert_eq!(mean_flip(&a, &a), 0.0);
        let b = Image::from_fn(32, 24, |x, _| if x % 2 == 0 { [1.0; 3] } else { [0.0; 3] });
        let f = mean_flip(&b, &a);
        assert!(f > 0.05 && f <= 1.0, "{f}");
        assert!(mean_flip(&a, &Image::new(3, 3)).is_nan());
    }
}
