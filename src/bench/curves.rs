//! Error-versus-cost curves in log-log space: the least-squares power-law fit, piecewise-linear
//! interpolation between measured points, and the inverse lookup "how much cost does this method
//! need to reach error `e`" that the equal-error speedup is built on.
//!
//! A Monte Carlo error curve is a power law `error = A · cost^b` only asymptotically: independent
//! sampling has `b = −1/2`, stratified sampling of soft shadows falls faster at low sample counts
//! and bends later. So no slope is assumed anywhere:
//!
//! * **Inside the measured range** the cost for a target error is interpolated linearly in
//!   `(ln cost, ln error)` between the two measured points that bracket it.
//! * **Outside it** (the target error is above the cheapest run's error or below the most
//!   expensive run's) the cost is extrapolated from the nearest end point along the slope of the
//!   least-squares fit over all points, and the result says so ([`Extrapolation`]): such a number
//!   is an estimate, not a measurement.
//! * **Non-monotone curves** (noise: a dearer run with a slightly larger error) are not reordered:
//!   the lookup takes the *first crossing*, the fewest measured-and-interpolated rays at which the
//!   curve reaches the target — the answer most favourable to the baseline, so a speedup computed
//!   from it is never inflated by the noise. [`CostEstimate::non_monotone`] flags such curves.

/// One measured run: its cost (rays per pixel, or seconds) and its error (e.g. RMSE).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point {
    pub cost: f64,
    pub error: f64,
}

impl Point {
    pub fn new(cost: f64, error: f64) -> Point {
        Point { cost, error }
    }
    /// Usable in log space: both coordinates finite and positive.
    fn usable(&self) -> bool {
        self.cost.is_finite() && self.error.is_finite() && self.cost > 0.0 && self.error > 0.0
    }
}

/// Least-squares line `ln error = intercept + slope · ln cost`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LogLogFit {
    pub intercept: f64,
    pub slope: f64,
    /// Coefficient of determination of the fit in log space (1 = every point on the line).
    pub r2: f64,
}

impl LogLogFit {
    /// The fitted error at `cost`.
    pub fn error_at(&self, cost: f64) -> f64 {
        (self.intercept + self.slope * cost.ln()).exp()
    }
    /// The fitted cost for `error`; `None` when the fit does not fall (slope ≥ 0).
    pub fn cost_for(&self, error: f64) -> Option<f64> {
        (self.slope < 0.0).then(|| ((error.ln() - self.intercept) / self.slope).exp())
    }
}

/// Fit `ln error = a + b ln cost` by ordinary least squares over the usable points. `None` with
/// fewer than two usable points or when every point has the same cost.
pub fn fit_loglog(points: &[Point]) -> Option<LogLogFit> {
    let pts: Vec<(f64, f64)> = points.iter().filter(|p| p.usable()).map(|p| (p.cost.ln(), p.error.ln())).collect();
    if pts.len() < 2 {
        return None;
    }
    let n = pts.len() as f64;
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let syy: f64 = pts.iter().map(|p| (p.1 - my) * (p.1 - my)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let slope = sxy / sxx;
    let intercept = my - slope * mx;
    let r2 = if syy > 0.0 { (sxy * sxy) / (sxx * syy) } else { 1.0 };
    Some(LogLogFit { intercept, slope, r2 })
}

/// Where an estimate lies relative to the measured points.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Extrapolation {
    /// Interpolated between two measured points (or exactly on one).
    None,
    /// The target error is larger than the cheapest run's: the method needs less than the
    /// cheapest measured cost; extrapolated towards lower cost.
    BelowCheapest,
    /// The target error is smaller than every measured error: the method needs more than the most
    /// expensive measured cost; extrapolated towards higher cost.
    BeyondDearest,
}

impl Extrapolation {
    pub fn is_extrapolated(self) -> bool {
        self != Extrapolation::None
    }
    /// Short tag for tables and CSV.
    pub fn tag(self) -> &'static str {
        match self {
            Extrapolation::None => "",
            Extrapolation::BelowCheapest => "extrapolated-below",
            Extrapolation::BeyondDearest => "extrapolated-beyond",
        }
    }
}

/// The cost a method needs for a target error.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CostEstimate {
    pub cost: f64,
    pub extrapolation: Extrapolation,
    /// The measured errors do not fall strictly as cost grows.
    pub non_monotone: bool,
}

/// A measured error curve: usable points sorted by cost, and their log-log fit.
#[derive(Clone, Debug)]
pub struct Curve {
    points: Vec<Point>,
    fit: Option<LogLogFit>,
}

impl Curve {
    /// Keeps the usable points (finite, positive), sorted by cost.
    pub fn new(points: &[Point]) -> Curve {
        let mut pts: Vec<Point> = points.iter().copied().filter(Point::usable).collect();
        pts.sort_by(|a, b| a.cost.total_cmp(&b.cost));
        let fit = fit_loglog(&pts);
        Curve { points: pts, fit }
    }
    pub fn points(&self) -> &[Point] {
        &self.points
    }
    pub fn fit(&self) -> Option<LogLogFit> {
        self.fit
    }
    /// Errors fall strictly as cost grows.
    pub fn is_monotone(&self) -> bool {
        self.points.windows(2).all(|w| w[1].error < w[0].error)
    }

    /// Extrapolate from `anchor` along the fit's slope; `None` when the fit does not fall.
    fn extrapolate(&self, anchor: Point, target: f64) -> Option<f64> {
        let slope = self.fit?.slope;
        (slope < 0.0).then(|| (anchor.cost.ln() + (target.ln() - anchor.error.ln()) / slope).exp())
    }

    /// The cost at which the curve first reaches `target` (see the module docs). `None` for an
    /// empty curve, an unusable target, or when extrapolation is needed but the fit does not fall.
    pub fn cost_for_error(&self, target: f64) -> Option<CostEstimate> {
        if !(target.is_finite() && target > 0.0) || self.points.is_empty() {
            return None;
        }
        let non_monotone = !self.is_monotone();
        let est = |cost: f64, extrapolation| Some(CostEstimate { cost, extrapolation, non_monotone });
        let first = self.points[0];
        if first.error <= target {
            if first.error == target {
                return est(first.cost, Extrapolation::None);
            }
            return est(self.extrapolate(first, target)?, Extrapolation::BelowCheapest);
        }
        for w in self.points.windows(2) {
            let (a, b) = (w[0], w[1]);
            // Every earlier point is above the target, so `a` is too.
            if b.error <= target {
                let t = (target.ln() - a.error.ln()) / (b.error.ln() - a.error.ln());
                let cost = (a.cost.ln() + t * (b.cost.ln() - a.cost.ln())).exp();
                return est(cost, Extrapolation::None);
            }
        }
        let last = *self.points.last()?;
        est(self.extrapolate(last, target)?, Extrapolation::BeyondDearest)
    }

    /// The error at `cost`, interpolated in log-log between the bracketing points, or extrapolated
    /// along the fit's slope from the nearest end point.
    pub fn error_at(&self, cost: f64) -> Option<(f64, Extrapolation)> {
        if !(cost.is_finite() && cost > 0.0) || self.points.is_empty() {
            return None;
        }
        let (first, last) = (self.points[0], *self.points.last()?);
        let along = |p: Point, x: Extrapolation| {
            let slope = self.fit.map_or(0.0, |f| f.slope);
            Some(((p.error.ln() + slope * (cost.ln() - p.cost.ln())).exp(), x))
        };
        if cost < first.cost {
            return along(first, Extrapolation::BelowCheapest);
        }
        if cost > last.cost {
            return along(last, Extrapolation::BeyondDearest);
        }
        for w in self.points.windows(2) {
            let (a, b) = (w[0], w[1]);
            if cost <= b.cost {
                if b.cost == a.cost {
                    return Some((a.error, Extrapolation::None));
                }
                let t = (cost.ln() - a.cost.ln()) / (b.cost.ln() - a.cost.ln());
                return Some(((a.error.ln() + t * (b.error.ln() - a.error.ln())).exp(), Extrapolation::None));
            }
        }
        Some((last.error, Extrapolation::None))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-9 * b.abs().max(1.0)
    }

    /// error = cost^(-1/2) exactly.
    fn sqrt_curve() -> Curve {
        Curve::new(&[Point::new(16.0, 0.25), Point::new(1.0, 1.0), Point::new(4.0, 0.5)])
    }

    #[test]
    fn fit_of_exact_power_law() {
        let f = sqrt_curve().fit().unwrap();
        assert!(close(f.slope, -0.5) && close(f.intercept, 0.0) && close(f.r2, 1.0), "{f:?}");
        assert!(close(f.error_at(64.0), 0.125));
        assert!(close(f.cost_for(0.125).unwrap(), 64.0));
    }

    #[test]
    fn fit_by_hand() {
        // ln cost = 0, 1, 2; ln error = 0, -1, -1: mean x 1, mean y -2/3, Sxy = -1, Sxx = 2,
        // Syy = 2/3: slope -1/2, intercept -2/3 + 1/2 = -1/6, r² = 1 / (2 · 2/3) = 3/4.
        let e = std::f64::consts::E;
        let f = fit_loglog(&[Point::new(1.0, 1.0), Point::new(e, 1.0 / e), Point::new(e * e, 1.0 / e)]).unwrap();
        assert!(close(f.slope, -0.5) && close(f.intercept, -1.0 / 6.0) && close(f.r2, 0.75), "{f:?}");
    }

    #[test]
    fn fit_needs_two_distinct_costs() {
        assert!(fit_loglog(&[Point::new(4.0, 0.5)]).is_none());
        assert!(fit_loglog(&[Point::new(4.0, 0.5), Point::new(4.0, 0.4)]).is_none());
        // Unusable points are ignored.
        assert!(fit_loglog(&[Point::new(4.0, 0.5), Point::new(0.0, 0.4), Point::new(8.0, f64::NAN)]).is_none());
    }

    #[test]
    fn interpolation_inside_the_range() {
        let c = sqrt_curve();
        // Half-way in log error between (1, 1) and (4, 0.5): ln c = 0.5 · ln 4, c = 2.
        let e = c.cost_for_error(1.0 / 2f64.sqrt()).unwrap();
        assert!(close(e.cost, 2.0) && e.extrapolation == Extrapolation::None && !e.non_monotone, "{e:?}");
        // Exactly on a measured point.
        let e = c.cost_for_error(0.5).unwrap();
        assert!(close(e.cost, 4.0) && e.extrapolation == Extrapolation::None);
        let e = c.cost_for_error(1.0).unwrap();
        assert!(close(e.cost, 1.0) && e.extrapolation == Extrapolation::None);
        let (err, x) = c.error_at(8.0).unwrap();
        assert!(close(err, 0.25 * 2f64.sqrt()) && x == Extrapolation::None);
    }

    #[test]
    fn target_below_the_curve_is_extrapolated_and_flagged() {
        let c = sqrt_curve();
        // From (16, 0.25) along slope -1/2: 16 · (0.125 / 0.25)^(-2) = 64.
        let e = c.cost_for_error(0.125).unwrap();
        assert!(close(e.cost, 64.0) && e.extrapolation == Extrapolation::BeyondDearest, "{e:?}");
        assert!(e.extrapolation.is_extrapolated());
        let (err, x) = c.error_at(64.0).unwrap();
        assert!(close(err, 0.125) && x == Extrapolation::BeyondDearest);
    }

    #[test]
    fn target_above_the_curve_is_extrapolated_and_flagged() {
        let c = sqrt_curve();
        // From (1, 1) along slope -1/2: (2 / 1)^(-2) = 0.25.
        let e = c.cost_for_error(2.0).unwrap();
        assert!(close(e.cost, 0.25) && e.extrapolation == Extrapolation::BelowCheapest, "{e:?}");
    }

    #[test]
    fn non_monotone_curve_takes_the_first_crossing() {
        let c = Curve::new(&[Point::new(1.0, 1.0), Point::new(2.0, 0.4), Point::new(4.0, 0.6), Point::new(8.0, 0.2)]);
        assert!(!c.is_monotone());
        // 0.5 is crossed first between (1, 1) and (2, 0.4): ln c = ln 2 · ln 0.5 / ln 0.4.
        let e = c.cost_for_error(0.5).unwrap();
        let want = (2f64.ln() * 0.5f64.ln() / 0.4f64.ln()).exp();
        assert!(close(e.cost, want) && e.non_monotone && e.extrapolation == Extrapolation::None, "{e:?} vs {want}");
        // 0.3 is only reached between (4, 0.6) and (8, 0.2): ln c = ln 4 + ln 2 · ln(0.5) / ln(1/3).
        let e = c.cost_for_error(0.3).unwrap();
        let want = (4f64.ln() + 2f64.ln() * (0.3f64 / 0.6).ln() / (0.2f64 / 0.6).ln()).exp();
        assert!(close(e.cost, want), "{e:?} vs {want}");
    }

    #[test]
    fn flat_or_rising_curve_cannot_be_extrapolated() {
        let c = Curve::new(&[Point::new(1.0, 0.5), Point::new(4.0, 0.5)]);
        assert!(c.cost_for_error(0.1).is_none());
        let one = Curve::new(&[Point::new(4.0, 0.5)]);
        assert!(one.cost_for_error(0.1).is_none());
        assert!(close(one.cost_for_error(0.5).unwrap().cost, 4.0));
        assert!(Curve::new(&[]).cost_for_error(0.5).is_none());
        assert!(sqrt_curve().cost_for_error(0.0).is_none());
        assert!(sqrt_curve().cost_for_error(f64::NAN).is_none());
    }
}
