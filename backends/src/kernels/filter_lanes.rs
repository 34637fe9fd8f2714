//! The screen filters' 1-D passes as lanes (issue 35 §4: the filter passes' share of sampling time).
//!
//! A separable pass (`axis` 0 or 1 of [`super::filter_window`]) walks, for every pixel, a run of its
//! line: the same row (x pass) or column (y pass). Walked tap by tap over per-pixel records, each
//! tap is a chain of data-dependent branches (the normal test, the two rejections) and one scalar
//! `exp` — about 9 ns a tap on this project's machine, most of `filter.irradiance`'s time. Here a
//! pass first lays each line's per-pixel quantities out as arrays, one per quantity, then sums a
//! window [`LANES`] taps at a time with every test a select and the weight from [`weight_exp`], so
//! the compiler turns a window into vector instructions. A tap outside the
//! window or rejected weighs 0 and adds its value as 0, so a window's sums are those of its accepted
//! taps, summed per lane and then across lanes (a fixed order: the same bits whatever the thread
//! count or tiling).

use rayon::prelude::*;

use crate::kernels::filter_window::Axis;

/// Taps summed side by side (two SSE registers of `f32`, one AVX register).
pub const LANES: usize = 8;

/// `log2(e)`, and `ln 2` split in two (Cody and Waite: `n · LN2_HI` is exact for the `n` of
/// [`weight_exp`]'s range, so the reduced argument keeps its precision).
const LOG2_E: f32 = std::f32::consts::LOG2_E;
const LN2_HI: f32 = 0.693_359_4;
const LN2_LO: f32 = -2.121_944_4e-4;
/// `1.5 · 2²³`: adding and subtracting it rounds an `f32` below 2²² in magnitude to the nearest
/// integer without a rounding instruction (which the baseline x86-64 target lacks as a vector op).
const ROUNDER: f32 = 12_582_912.0;
/// The minimax polynomial of `(exp(r) − 1 − r) / r²` on `|r| ≤ ln 2 / 2` (the coefficients of the
/// Cephes library's `expf`), highest degree first.
const EXP_POLY: [f32; 6] = [1.987_569_1e-4, 1.398_199_9e-3, 8.333_452e-3, 4.166_579_6e-2, 0.166_666_65, 0.5];

/// `exp(x)` of a filter weight's exponent, `x ≤ 0` (`−16 d² g²`), within 2 ulp of the exact value
/// on `[−87, 0]`; `exp(0) = 1` exactly (a pixel's own tap weighs 1). Below −87 (beyond any kept
/// weight, which is ≥ 0.01) it returns `exp(−87)`, above 0 it returns 1, and NaN gives `exp(−87)`:
/// callers select the weight of a rejected tap away. Branch-free (an integer scale built in the
/// exponent bits), so a loop of taps vectorizes — which the C library's `expf` (one call a tap)
/// does not; one tap at a time that one is faster, and the tap-by-tap filters keep it.
#[inline(always)]
pub fn weight_exp(x: f32) -> f32 {
    // max and min, not clamp: a NaN exponent maps to −87, not to NaN.
    #[allow(clippy::manual_clamp)]
    let x = x.max(-87.0).min(0.0);
    let shifted = x * LOG2_E + ROUNDER;
    let n = shifted - ROUNDER;
    let r = (x - n * LN2_HI) - n * LN2_LO;
    let p = EXP_POLY[1..].iter().fold(EXP_POLY[0], |p, &c| p * r + c);
    let e = p * r * r + r + 1.0;
    // `shifted`'s low mantissa bits hold 2²² + n; shifted into the exponent field, 2²² and the
    // exponent of `shifted` fall off and the field holds n + 127 ∈ [1, 127] (n ∈ [−126, 0]): 2ⁿ,
    // without a float-to-integer conversion (scalar on the baseline target).
    e * f32::from_bits((shifted.to_bits() << 23).wrapping_add(127 << 23))
}

/// The lines of a separable pass: the image's rows (x pass) or columns (y pass).
#[derive(Clone, Copy, Debug)]
pub struct Lines {
    along_x: bool,
    width: usize,
    height: usize,
}

impl Lines {
    /// The lines of a pass along `axis`; `None` for the 2-D pass (no line to walk).
    pub fn of(axis: Axis, width: u32, height: u32) -> Option<Lines> {
        let along_x = match axis {
            Axis::X => true,
            Axis::Y => false,
            Axis::Both => return None,
        };
        Some(Lines { along_x, width: width as usize, height: height as usize })
    }

    /// Pixels per line.
    fn len(&self) -> usize {
        if self.along_x {
            self.width
        } else {
            self.height
        }
    }

    /// The row-major index of position `t` of line `line`.
    fn pixel(&self, line: usize, t: usize) -> usize {
        if self.along_x {
            line * self.width + t
        } else {
            t * self.width + line
        }
    }

    /// Every pixel filtered, returned in row-major order. Line by line (in parallel): `records`
    /// lays out the line's records from its pixels' row-major indices (small enough to stay in
    /// cache; a whole pass's records in line order cost more to write than the lanes saved), then
    /// `f(pixel, records, window)` gives each of its pixels' results, `window` the positions within
    /// `radius(pixel, records, position)` of the pixel on its line, clipped to the line — `None`
    /// where the radius is `None` (a pixel that does not filter).
    pub fn map<R, T: Copy + Send + Default>(
        &self,
        records: impl Fn(&[usize]) -> R + Sync,
        radius: impl Fn(usize, &R, usize) -> Option<usize> + Sync,
        f: impl Fn(usize, &R, Option<Window>) -> T + Sync,
    ) -> Vec<T> {
        let len = self.len();
        let count = self.width * self.height / len.max(1);
        let per_line: Vec<Vec<T>> = (0..count)
            .into_par_iter()
            .map(|line| {
                let pixels: Vec<usize> = (0..len).map(|t| self.pixel(line, t)).collect();
                let r = records(&pixels);
                let window = |t: usize, radius: usize| {
                    let (lo, hi) = (t.saturating_sub(radius), (t + radius).min(len - 1));
                    Window { first: lo, len: hi - lo + 1, centre: t }
                };
                pixels.iter().enumerate().map(|(t, &i)| f(i, &r, radius(i, &r, t).map(|d| window(t, d)))).collect()
            })
            .collect();
        if self.along_x {
            return per_line.concat();
        }
        let mut out = vec![T::default(); self.width * self.height];
        for (line, values) in per_line.iter().enumerate() {
            for (t, v) in values.iter().enumerate() {
                out[self.pixel(line, t)] = *v;
            }
        }
        out
    }
}

/// A line's values of one quantity, `f(pixel)` in line order, followed by [`LANES`] copies of
/// `pad` (a window's last group of lanes reads past the line; `pad` is a record every tap rejects).
pub fn line_array<T: Copy>(pixels: &[usize], pad: T, f: impl Fn(usize) -> T) -> Vec<T> {
    pixels.iter().map(|&p| f(p)).chain(std::iter::repeat_n(pad, LANES)).collect()
}

/// One pixel's window on its line: `len` line-order positions from `first`; `centre` is the
/// pixel's own position.
#[derive(Clone, Copy, Debug)]
pub struct Window {
    pub first: usize,
    pub len: usize,
    pub centre: usize,
}

/// A group of [`LANES`] taps: each one's weight (≥ 0; 0 for a rejected tap) and its `N` values,
/// which must be finite (a record stores 0 for a value that is not: its tap is rejected, and 0
/// times 0 adds nothing) — the weights are the only select, and the loop has no branch.
pub struct Group<'a, const N: usize> {
    pub weight: [f32; LANES],
    pub value: [&'a [f32; LANES]; N],
}

/// The [`LANES`] records of one group from `k` on (a fixed-size array: the lanes' loop has no
/// bounds to test).
#[inline(always)]
pub fn lanes(records: &[f32], k: usize) -> &[f32; LANES] {
    records[k..k + LANES].try_into().expect("a group is LANES records")
}

impl Window {
    /// The weighted mean over the window of its taps, `group(k)` giving the [`LANES`] taps from
    /// line-order position `k` on; `None` where no weight is positive. Taps past the window (up to
    /// the next multiple of [`LANES`]) are computed and weighed 0: the records must extend
    /// [`LANES`] past the last position ([`line_array`]).
    #[inline(always)]
    pub fn mean<'a, const N: usize>(&self, group: impl Fn(usize) -> Group<'a, N>) -> Option<[f32; N]> {
        let mut sums = [[0.0f32; LANES]; N];
        let mut weights = [0.0f32; LANES];
        for start in (0..self.len).step_by(LANES) {
            let taps = group(self.first + start);
            for lane in 0..LANES {
                let w = if start + lane < self.len { taps.weight[lane] } else { 0.0 };
                weights[lane] += w;
                for (sum, value) in sums.iter_mut().zip(&taps.value) {
                    sum[lane] += w * value[lane];
                }
            }
        }
        let wsum: f32 = weights.iter().sum();
        (wsum > 0.0).then(|| sums.map(|s| s.iter().sum::<f32>() / wsum))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Within 2 ulp of the exact exponential over the weights' whole range, exact at 0, and the
    /// clamps where the callers select the result away.
    #[test]
    fn weight_exp_is_within_two_ulp_of_exp() {
        let mut worst = 0.0f64;
        for i in 0..=2_000_000 {
            let x = -87.0 * i as f32 / 2_000_000.0;
            let want = (x as f64).exp() as f32;
            worst = worst.max(want.to_bits().abs_diff(weight_exp(x).to_bits()) as f64);
        }
        assert!(worst <= 2.0, "worst {worst} ulp");
        assert_eq!(weight_exp(0.0), 1.0);
        assert_eq!(weight_exp(1.0), 1.0);
        assert_eq!(weight_exp(-1000.0), weight_exp(-87.0));
        assert_eq!(weight_exp(f32::NAN), weight_exp(-87.0));
    }

    /// A y pass's lines are the image's columns, and `map` returns row-major results with each
    /// window clipped to its line.
    #[test]
    fn lines_walk_columns_and_clip_windows() {
        let lines = Lines::of(Axis::Y, 3, 4).unwrap();
        let got = lines.map(
            |pixels| line_array(pixels, usize::MAX, |p| p),
            |_, _, _| Some(1),
            |p, r, w| w.map(|w| (p, r[w.centre], w.first, w.len)),
        );
        // Pixel (1, 0) = 1: column 1, position 0, window 0..=1.
        assert_eq!(got[1], Some((1, 1, 0, 2)));
        // Pixel (1, 2) = 7: position 2, window 1..=3.
        assert_eq!(got[7], Some((7, 7, 1, 3)));
        assert_eq!(line_array(&[4, 7], 0, |p| p + 1), [&[5, 8][..], &[0; LANES]].concat());
        assert!(Lines::of(Axis::Both, 3, 4).is_none());
        let rows = Lines::of(Axis::X, 3, 4).unwrap().map(
            |pixels| pixels.to_vec(),
            |_, _, _| Some(0),
            |p, r, w| (p, w.map(|w| r[w.centre])),
        );
        assert!(rows.iter().enumerate().all(|(i, &(p, q))| p == i && q == Some(i)));
        let none = Lines::of(Axis::X, 3, 4).unwrap().map(|_| (), |_, _, _| None, |_, _, w| w.is_none());
        assert!(none.iter().all(|&n| n));
    }

    /// The lane sums are the scalar weighted mean (to rounding), with taps past the window and
    /// rejected taps left out.
    #[test]
    fn a_window_mean_is_the_weighted_mean_of_its_taps() {
        let values: Vec<f32> = (0..40).map(|i| i as f32 * 0.5).collect();
        let w = Window { first: 3, len: 13, centre: 9 };
        let weight = |k: usize| if k.is_multiple_of(5) { 0.0 } else { 1.0 / (1 + k) as f32 };
        let group = |k: usize| Group { weight: std::array::from_fn(|l| weight(k + l)), value: [lanes(&values, k)] };
        let got = w.mean(group).unwrap();
        let (mut s, mut ws) = (0.0f64, 0.0f64);
        for (k, &v) in values.iter().enumerate().take(16).skip(3) {
            if !k.is_multiple_of(5) {
                s += v as f64 / (1 + k) as f64;
                ws += 1.0 / (1 + k) as f64;
            }
        }
        assert!((got[0] as f64 - s / ws).abs() < 1e-6, "{} vs {}", got[0], s / ws);
        let zero = |_| Group { weight: [0.0; LANES], value: [&[1.0; LANES]] };
        assert_eq!(Window { first: 0, len: 5, centre: 2 }.mean(zero), None);
    }
}
