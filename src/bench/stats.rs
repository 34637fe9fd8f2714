//! Error decomposition and ratios: the bias/variance split from two seeds, the reference's own
//! noise from its two halves, and the equal-error speedup.
//!
//! ## Reference noise
//! The reference `R = (A + B) / 2` is the mean of two half-sample-count renders with different
//! seeds. Per pixel value, `A = I + a`, `B = I + b` with `a`, `b` independent, zero mean, variance
//! `σ²` each. Then `E[(A − B)²] = 2σ²`, and `R`'s error `(a + b)/2` has variance `σ²/2`
//! `= E[(A − B)²] / 4`. Hence the reference's RMSE is estimated by
//! `sqrt(mean((A − B)²)) / 2 = RMSE(A, B) / (√2 · √2)`: one √2 turns the difference of two renders
//! into one render's noise, the other is the gain of averaging two of them.
//!
//! ## Bias and variance of a render
//! Render the method twice, seeds 1 and 2: `X₁ = I + β + v₁`, `X₂ = I + β + v₂` (β the bias,
//! the v's independent with variance `σ²`). `E[(X₁ − X₂)²] = 2σ²`, so the variance is
//! `mean((X₁ − X₂)²) / 2`. Against a noisy reference, `MSE(X₁, R) = β² + σ² + σ_R²`, so
//! `bias² = MSE − variance − σ_R²`. That difference of estimates can come out negative when the
//! bias is small (noise in the estimates); it is then clamped to 0 and the clamp is reported.

use crate::image::Image;
use crate::metrics::{compare, MetricsError};

/// Mean over pixels and channels of `(a − b)²` (the squared RMSE between two images).
pub fn mean_squared_difference(a: &Image, b: &Image) -> Result<f64, MetricsError> {
    let m = compare(a, b)?;
    Ok(m.rmse * m.rmse)
}

/// RMSE of the reference `(A + B)/2` estimated from its two halves (see the module docs).
pub fn reference_noise_rmse(half_a: &Image, half_b: &Image) -> Result<f64, MetricsError> {
    Ok(compare(half_a, half_b)?.rmse / 2.0)
}

/// Which part of the MSE dominates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dominant {
    Bias,
    Variance,
}

impl Dominant {
    pub fn name(self) -> &'static str {
        match self {
            Dominant::Bias => "bias",
            Dominant::Variance => "variance",
        }
    }
}

/// A render's MSE split into bias² and variance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BiasVariance {
    /// MSE against the reference.
    pub mse: f64,
    /// `mean((X₁ − X₂)²) / 2`.
    pub variance: f64,
    /// The reference's own variance `σ_R²` (subtracted from the MSE).
    pub reference_variance: f64,
    /// `max(0, mse − variance − reference_variance)`.
    pub bias2: f64,
    /// `mse − variance − reference_variance` before the clamp.
    pub bias2_unclamped: f64,
    /// The unclamped bias² was negative and has been set to 0.
    pub clamped: bool,
}

impl BiasVariance {
    pub fn dominant(&self) -> Dominant {
        if self.bias2 > self.variance {
            Dominant::Bias
        } else {
            Dominant::Variance
        }
    }
    /// bias² as a fraction of `bias² + variance` (0 when both are 0).
    pub fn bias_fraction(&self) -> f64 {
        let s = self.bias2 + self.variance;
        if s > 0.0 {
            self.bias2 / s
        } else {
            0.0
        }
    }
}

/// Split `mse` given the mean squared difference of two seed renders and the reference variance.
pub fn split_bias_variance(mse: f64, seed_msd: f64, reference_variance: f64) -> BiasVariance {
    let variance = seed_msd / 2.0;
    let bias2_unclamped = mse - variance - reference_variance;
    let clamped = bias2_unclamped < 0.0;
    BiasVariance { mse, variance, reference_variance, bias2: bias2_unclamped.max(0.0), bias2_unclamped, clamped }
}

/// `baseline_cost / pipeline_cost`; NaN when either is not finite and positive.
pub fn speedup(baseline_cost: f64, pipeline_cost: f64) -> f64 {
    if baseline_cost.is_finite() && pipeline_cost.is_finite() && baseline_cost > 0.0 && pipeline_cost > 0.0 {
        baseline_cost / pipeline_cost
    } else {
        f64::NAN
    }
}

/// The per-pixel mean of two images (the reference from its halves).
pub fn average(a: &Image, b: &Image) -> Image {
    Image {
        width: a.width,
        height: a.height,
        pixels: a
            .pixels
            .iter()
            .zip(&b.pixels)
            .map(|(p, q)| [(p[0] + q[0]) * 0.5, (p[1] + q[1]) * 0.5, (p[2] + q[2]) * 0.5])
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12
    }

    #[test]
    fn split_by_hand() {
        // MSE 0.05, seeds differ by msd 0.04 → variance 0.02; reference variance 0.01 → bias² 0.02.
        let s = split_bias_variance(0.05, 0.04, 0.01);
        assert!(close(s.variance, 0.02) && close(s.bias2, 0.02) && !s.clamped, "{s:?}");
        assert!(close(s.bias_fraction(), 0.5));
        let s = split_bias_variance(0.10, 0.04, 0.0);
        assert!(close(s.bias2, 0.08) && s.dominant() == Dominant::Bias);
    }

    #[test]
    fn zero_variance_is_all_bias() {
        // A deterministic method: both seeds give the same image.
        let s = split_bias_variance(0.09, 0.0, 0.0);
        assert_eq!(s.variance, 0.0);
        assert!(close(s.bias2, 0.09) && s.dominant() == Dominant::Bias && close(s.bias_fraction(), 1.0));
        // Nothing at all: variance wins the tie, fraction 0.
        let z = split_bias_variance(0.0, 0.0, 0.0);
        assert_eq!((z.bias2, z.dominant(), z.bias_fraction(), z.clamped), (0.0, Dominant::Variance, 0.0, false));
    }

    #[test]
    fn negative_bias_is_clamped_and_flagged() {
        // Unbiased noisy method whose MSE came out below its variance estimate.
        let s = split_bias_variance(0.018, 0.04, 0.001);
        assert!(s.clamped && s.bias2 == 0.0 && close(s.bias2_unclamped, -0.003), "{s:?}");
        assert_eq!(s.dominant(), Dominant::Variance);
    }

    #[test]
    fn reference_noise_from_halves() {
        // A = 1 + 0.1, B = 1 − 0.1 everywhere: RMSE(A, B) = 0.2, reference noise 0.2 / 2 = 0.1.
        let a = Image::from_fn(4, 3, |_, _| [1.1, 1.1, 1.1]);
        let b = Image::from_fn(4, 3, |_, _| [0.9, 0.9, 0.9]);
        let n = reference_noise_rmse(&a, &b).unwrap();
        assert!((n - 0.1).abs() < 1e-6, "{n}");
        let r = average(&a, &b);
        assert!(r.pixels.iter().all(|p| (p[0] - 1.0).abs() < 1e-6));
        assert!((mean_squared_difference(&a, &b).unwrap() - 0.04).abs() < 1e-6);
    }

    #[test]
    fn speedup_ratios() {
        assert!(close(speedup(600.0, 100.0), 6.0));
        assert!(speedup(600.0, 0.0).is_nan());
        assert!(speedup(f64::INFINITY, 10.0).is_nan());
    }
}
