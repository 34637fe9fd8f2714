//! Number formats of the bench tables (`report.md` of one bench, `suite.md` of a suite), so both
//! print the same value the same way. A value that could not be measured (NaN, or an infinite
//! ratio from a zero error) prints as `n/a`.

/// A ratio or count: two decimals, none from 100 up (`6.22`, `129`).
pub fn ratio(v: f64) -> String {
    if !v.is_finite() {
        "n/a".into()
    } else if v.abs() >= 100.0 {
        format!("{v:.0}")
    } else {
        format!("{v:.2}")
    }
}

/// An error or variance in scientific notation with `digits` decimals (`1.52e-3`); exactly 0 as `0`.
pub fn sci(v: f64, digits: usize) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.is_finite() {
        format!("{v:.digits$e}")
    } else {
        "n/a".into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats() {
        assert_eq!(ratio(6.2249), "6.22");
        assert_eq!(ratio(129.4), "129");
        assert_eq!(ratio(f64::NAN), "n/a");
        assert_eq!(ratio(f64::INFINITY), "n/a");
        assert_eq!(sci(1.5234e-3, 2), "1.52e-3");
        assert_eq!(sci(1.5234e-3, 3), "1.523e-3");
        assert_eq!(sci(0.0, 3), "0");
        assert_eq!(sci(f64::NAN, 2), "n/a");
    }
}
