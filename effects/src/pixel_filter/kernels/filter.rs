//! The filter passes of pixel filtering: `pixel_filter.bilateral` (the brute-force cross-bilateral
//! filter, eq. 3.6) and `pixel_filter.separable` (one 1-D pass of the iterated approximation,
//! eq. 3.14), both run on filter frames only and otherwise keep the last filtered buffer.

use glam::Vec3;
use wedge_backends::{BackendError, Kernel, KernelCtx, KernelParams, Output, Reach, Uniforms, WgslSource};

use super::{schedule, ScheduleParams};
use crate::pixel_filter::formulas::{bilateral_weight, inv_two_sigma2, iteration_sigma, luminance, FILTERED};
use crate::pixel_filter::node::{DEFAULT_SIGMA_C, DEFAULT_SIGMA_D, DEFAULT_SIGMA_S};

wedge_backends::kernel_params! {
    /// The filter's kernel widths: spatial σ_s (pixels), colour σ_c, depth σ_d (metres), and the
    /// truncation in σ_s (the largest window radius any pixel may use, [`FilterParams::radius`]).
    pub struct FilterParams {
        sigma_s: f32 = positive(DEFAULT_SIGMA_S, 256.0, "spatial standard deviation of the filter (pixels)"),
        sigma_c: f32 = positive(DEFAULT_SIGMA_C, 1e6, "range standard deviation of colours (linear RGB)"),
        sigma_d: f32 = positive(DEFAULT_SIGMA_D, 1e9, "range standard deviation of depths (scene units, metres)"),
        truncate: f32 = positive(3.0, 16.0, "the spatial kernel is cut at truncate × sigma"),
    }
}

wedge_backends::kernel_params! {
    /// One pass of the iterated separable filter (set by the node, but `iterations`, the node's
    /// own): its axis (0 = x, 1 = y), iteration (1-based) of `iterations`, and whether it is the
    /// chain's first or last pass.
    pub struct PassParams {
        axis: u32,
        iteration: u32,
        iterations: u32 = int(3, 1, 8, "iterations of the separable filter (eq. 3.14)"),
        first: bool,
        last: bool,
    }
}

impl FilterParams {
    /// Window radius (pixels) for spatial σ `sigma`, capped at 1024.
    fn radius(&self, sigma: f32) -> u32 {
        (self.truncate * sigma).ceil().clamp(0.0, 1024.0) as u32
    }
    /// The WGSL's fields: the kernels' `1/(2σ²)` rather than σ_c, σ_d.
    fn wgsl_uniforms(&self, u: Uniforms) -> Uniforms {
        u.f32("sigma_s", self.sigma_s)
            .f32("inv_c", inv_two_sigma2(self.sigma_c))
            .f32("inv_d", inv_two_sigma2(self.sigma_d))
            .f32("truncate", self.truncate)
    }
}

// ---------------------------------------------------------------------------------------------
// pixel_filter.bilateral (brute force, eq. 3.6)
// ---------------------------------------------------------------------------------------------

/// `pixel_filter.bilateral`: the brute-force cross-bilateral filter (see the module doc).
pub struct Bilateral;

/// Weighted luminance spread (West's weighted Welford): the per-path variance of a pixel's
/// neighbourhood when no pixel there has two paths yet (a single-path frame; a reading, see
/// DESIGN-NOTES: the thesis's eq. 3.5 assumption — neighbours are realisations of one variable).
#[derive(Clone, Copy, Default)]
struct Spread {
    w: f32,
    mean: f32,
    s: f32,
}

impl Spread {
    #[inline]
    fn add(&mut self, y: f32, a: f32) {
        self.w += a;
        let d = y - self.mean;
        self.mean += d * a / self.w;
        self.s += a * d * (y - self.mean);
    }
    fn variance(&self) -> f32 {
        if self.w > 0.0 {
            (self.s / self.w).max(0.0)
        } else {
            0.0
        }
    }
}

/// Sums of one filtered pixel.
#[derive(Clone, Copy, Default)]
struct Sums {
    a: f32,
    value: Vec3,
    /// Σ a²·r_in (r_in = 1 for the accumulation: eq. 3.5's Σa²).
    a2: f32,
    var: f32,
    var_w: f32,
    spread: Spread,
}

impl Sums {
    /// The filtered value, r = Σa²/A² and the per-path variance σ² (filtered, or the spread).
    fn finish(&self) -> (Vec3, f32, f32) {
        if !(self.a > 0.0) {
            return (Vec3::ZERO, 0.0, 0.0);
        }
        let value = self.value / self.a;
        let r = self.a2 / (self.a * self.a);
        let sigma2 = if self.var_w > 0.0 { self.var / self.var_w } else { self.spread.variance() };
        (value, r, sigma2)
    }
}

/// `filtered` and `variance` of a pixel with `n` paths from its filtered value, r and σ².
fn filter_outputs(value: Vec3, r: f32, sigma2: f32, n: f32) -> ([f32; 4], [f32; 4]) {
    if !(n > 0.0) {
        return ([0.0; 4], [0.0; 4]);
    }
    let f_abs = r * sigma2 / n;
    ([value.x, value.y, value.z, f_abs], [sigma2, r, n, FILTERED])
}

fn filter_uniforms(ctx: &KernelCtx<'_>) -> Result<Uniforms, BackendError> {
    let (update, _) = schedule(ctx)?;
    let p = FilterParams::read(ctx)?;
    Ok(p.wgsl_uniforms(Uniforms::new().u32("update", update as u32)).u32("radius", p.radius(p.sigma_s)))
}

/// A filtered value and its variance, as the history holds them (`previous_*`) or a pass writes them.
type Pair<T> = (T, T);

/// Keep the last filter pass's buffers `previous` (or zeros before the first) as `out`.
fn keep_previous(
    ctx: &mut KernelCtx<'_>,
    previous: Pair<Option<&[[f32; 4]]>>,
    out: Pair<Output<'_, [f32; 4]>>,
) -> Result<(), BackendError> {
    let n = ctx.pixels();
    let kept = |p: Option<&[[f32; 4]]>| p.map_or_else(|| vec![[0.0; 4]; n], |p| p.to_vec());
    out.0.put(ctx, kept(previous.0))?;
    out.1.put(ctx, kept(previous.1))
}

wedge_backends::kernel_bindings! {
    /// What a `pixel_filter.bilateral` pass binds.
    pub struct BilateralIo / BilateralData {
        read range: [f32; 4],
        read lv: [f32; 4],
        read hv: [f32; 4],
        read_opt previous_filtered: [f32; 4],
        read_opt previous_variance: [f32; 4],
        /// Per-pixel spatial σ (adaptive width); unbound: `sigma_s`.
        read_opt sigma: f32,
        write filtered: [f32; 4],
        write variance: [f32; 4],
    }
}

impl Kernel for Bilateral {
    wedge_backends::kernel_signature!(
        name: "pixel_filter.bilateral", class: Filter, bindings: BilateralIo, params: [ScheduleParams, FilterParams]
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/pixel_filter_bilateral.wgsl"), filter_uniforms)
                .with_include(
                    "pixel_filter_formulas.wgsl",
                    include_str!("../../../../shaders/pixel_filter_formulas.wgsl"),
                )
                .with_reach(|ctx| {
                    let p = FilterParams::read(ctx)?;
                    Ok(Reach::Rows(p.radius(p.sigma_s)))
                }),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let (update, _) = schedule(ctx)?;
        let io = BilateralIo::read(ctx)?;
        if !update {
            return keep_previous(ctx, (io.previous_filtered, io.previous_variance), (io.filtered, io.variance));
        }
        let p = FilterParams::read(ctx)?;
        let BilateralData { range, lv, hv, sigma, .. } = io;
        let (w, h) = (ctx.width as i32, ctx.height as i32);
        let max_radius = p.radius(p.sigma_s) as i32;
        let (inv_c, inv_d) = (inv_two_sigma2(p.sigma_c), inv_two_sigma2(p.sigma_d));
        let out = ctx.map_pixels(false, |px, py| {
            let j = (py as i32 * w + px as i32) as usize;
            let sg = sigma.map_or(p.sigma_s, |s| s[j]).min(p.sigma_s);
            let cut = p.truncate * sg;
            let radius = (p.radius(sg) as i32).min(max_radius);
            let centre = Centre::new(range[j], [inv_two_sigma2(sg), inv_c, inv_d], true, lv[j][3] < 2.0);
            let mut sums = Sums::default();
            for y in (py as i32 - radius).max(0)..=(py as i32 + radius).min(h - 1) {
                for x in (px as i32 - radius).max(0)..=(px as i32 + radius).min(w - 1) {
                    let (dx, dy) = ((x - px as i32) as f32, (y - py as i32) as f32);
                    let ds2 = dx * dx + dy * dy;
                    if ds2 > cut * cut {
                        continue;
                    }
                    let i = (y * w + x) as usize;
                    let tap = Tap { range: range[i], n: lv[i][3], hv: hv[i], r_in: 1.0, var_in: None };
                    sums.add(&centre, ds2, tap);
                }
            }
            let (value, r, sigma2) = sums.finish();
            filter_outputs(value, r, sigma2, lv[j][3])
        });
        io.filtered.put(ctx, out.iter().map(|o| o.0).collect())?;
        io.variance.put(ctx, out.iter().map(|o| o.1).collect())
    }
}

/// The centre pixel of a filter window: its range entry (colour, depth), the kernels' `1/(2σ²)`
/// (spatial, colour, depth), whether the pass reads the accumulation (`first`: `hv.w` = M2) and
/// whether it keeps the one-path spread (`spread`: needed only where the centre pixel has fewer
/// than two paths; otherwise its own tap, weight 1, makes the variance sum non-empty).
struct Centre {
    colour: Vec3,
    depth: f32,
    inv: [f32; 3],
    first: bool,
    spread: bool,
}

impl Centre {
    fn new(range: [f32; 4], inv: [f32; 3], first: bool, spread: bool) -> Centre {
        Centre { colour: Vec3::new(range[0], range[1], range[2]), depth: range[3], inv, first, spread }
    }
}

/// One neighbour of the cross-bilateral filter: its range entry, its path count `n` and value `hv`
/// (`hv.w` = M2 on the first pass; later passes carry the value's `r` in `r_in` and the filtered σ²
/// in `var_in`).
struct Tap {
    range: [f32; 4],
    n: f32,
    hv: [f32; 4],
    r_in: f32,
    var_in: Option<f32>,
}

impl Sums {
    /// Add one tap at spatial distance² `ds2` from the centre.
    #[inline]
    fn add(&mut self, c: &Centre, ds2: f32, tap: Tap) {
        let Tap { range: range_i, n, hv, r_in, var_in } = tap;
        if !(n > 0.0) {
            return;
        }
        let dc = Vec3::new(range_i[0], range_i[1], range_i[2]) - c.colour;
        let a = bilateral_weight(ds2, dc.dot(dc), c.depth - range_i[3], c.inv[0], c.inv[1], c.inv[2]);
        if !(a > 0.0) {
            // Underflowed (another surface): nothing to add, and the spread's first weight must be > 0.
            return;
        }
        let value = Vec3::new(hv[0], hv[1], hv[2]);
        self.a += a;
        self.value += value * a;
        self.a2 += a * a * r_in;
        if c.first {
            if n >= 2.0 {
                self.var += a * (hv[3] / (n - 1.0));
                self.var_w += a;
            }
            if c.spread {
                self.spread.add(luminance(value), a);
            }
        } else if let Some(v) = var_in {
            self.var += a * v;
            self.var_w += a;
        }
    }
}

// ---------------------------------------------------------------------------------------------
// pixel_filter.separable (eq. 3.14)
// ---------------------------------------------------------------------------------------------

/// `pixel_filter.separable`: one 1-D pass (`axis` 0 = x, 1 = y) of iteration `iteration` of
/// `iterations` of the iterated separable cross-bilateral filter (Sec. 3.6.1, eq. 3.14). The first
/// pass reads the accumulation (`hv` = mean, M2; `lv` for n), later ones the chain's `value_in` =
/// (rgb, r) and `variance_in` = (σ², valid); `r` propagates as `Σ a_i² r_i / A²` (exact for the first x-then-y
/// iteration, whose rows are independent; an approximation after, reading). The last pass writes
/// `filtered`/`variance` as [`Bilateral`] does and keeps them on frames that do not filter.
pub struct Separable;

/// A separable pass's settings: its widths, its place in the chain, whether this frame filters.
struct SeparableSettings {
    filter: FilterParams,
    axis: u32,
    iteration: u32,
    iterations: u32,
    first: bool,
    last: bool,
    update: bool,
}

fn separable_params(ctx: &KernelCtx<'_>) -> Result<SeparableSettings, BackendError> {
    let (update, _) = schedule(ctx)?;
    let PassParams { axis, iteration, iterations, first, last } = PassParams::read(ctx)?;
    let (iteration, iterations) = (iteration.max(1), iterations.max(1));
    Ok(SeparableSettings { filter: FilterParams::read(ctx)?, axis, iteration, iterations, first, last, update })
}

impl SeparableSettings {
    /// The pass's widest window radius (σ_s of this iteration).
    fn radius(&self) -> u32 {
        self.filter.radius(iteration_sigma(self.filter.sigma_s, self.iteration, self.iterations))
    }
}

wedge_backends::kernel_bindings! {
    /// What a `pixel_filter.separable` pass binds.
    pub struct SeparableIo / SeparableData {
        read range: [f32; 4],
        /// First pass: the accumulation hv = (mean, M2); later: the chain's (rgb, r).
        read value_in: [f32; 4],
        /// Later passes: (σ², valid, 0, 0).
        read_opt variance_in: [f32; 4],
        /// First and last passes: the accumulation's lv (w = n).
        read_opt lv: [f32; 4],
        read_opt sigma: f32,
        read_opt previous_filtered: [f32; 4],
        read_opt previous_variance: [f32; 4],
        write value_out: [f32; 4],
        write variance_out: [f32; 4],
    }
}

impl Kernel for Separable {
    wedge_backends::kernel_signature!(
        name: "pixel_filter.separable", class: Filter, bindings: SeparableIo, params: [ScheduleParams, FilterParams, PassParams]
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../../shaders/pixel_filter_separable.wgsl"), |ctx| {
                let s = separable_params(ctx)?;
                Ok(s.filter
                    .wgsl_uniforms(Uniforms::new().u32("update", s.update as u32))
                    .u32("axis", s.axis)
                    .f32("scale", iteration_sigma(1.0, s.iteration, s.iterations))
                    .u32("radius", s.radius())
                    .u32("first", s.first as u32)
                    .u32("last", s.last as u32))
            })
            .with_include("pixel_filter_formulas.wgsl", include_str!("../../../../shaders/pixel_filter_formulas.wgsl"))
            .with_reach(|ctx| {
                let s = separable_params(ctx)?;
                Ok(if s.axis == 0 { Reach::Cols(s.radius()) } else { Reach::Rows(s.radius()) })
            }),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let s = separable_params(ctx)?;
        let io = SeparableIo::read(ctx)?;
        if !s.update {
            if s.last {
                return keep_previous(
                    ctx,
                    (io.previous_filtered, io.previous_variance),
                    (io.value_out, io.variance_out),
                );
            }
            // Nothing reads an intermediate pass's output on a frame that does not filter.
            let n = ctx.pixels();
            io.value_out.put(ctx, vec![[0.0f32; 4]; n])?;
            return io.variance_out.put(ctx, vec![[0.0f32; 4]; n]);
        }
        let p = &s.filter;
        let SeparableData { range, value_in: value, variance_in: var, lv, sigma, .. } = io;
        if (s.first || s.last) && lv.is_none() {
            return Err(ctx.err("the first and last passes read `lv` (the path counts)".into()));
        }
        if !s.first && var.is_none() {
            return Err(ctx.err("a pass after the first reads `variance_in`".into()));
        }
        let (w, h) = (ctx.width as i32, ctx.height as i32);
        let max_radius = s.radius() as i32;
        let scale = iteration_sigma(1.0, s.iteration, s.iterations);
        let (inv_c, inv_d) = (inv_two_sigma2(p.sigma_c), inv_two_sigma2(p.sigma_d));
        let out = ctx.map_pixels(false, |px, py| {
            let j = (py as i32 * w + px as i32) as usize;
            let sg = sigma.map_or(p.sigma_s, |v| v[j]).min(p.sigma_s) * scale;
            let cut = p.truncate * sg;
            let radius = (p.radius(sg) as i32).min(max_radius);
            // The one-path spread only on the first pass (later passes carry σ²).
            let spread = s.first && lv.unwrap()[j][3] < 2.0;
            let centre = Centre::new(range[j], [inv_two_sigma2(sg), inv_c, inv_d], s.first, spread);
            let mut sums = Sums::default();
            let (lo, hi) = if s.axis == 0 {
                ((px as i32 - radius).max(0), (px as i32 + radius).min(w - 1))
            } else {
                ((py as i32 - radius).max(0), (py as i32 + radius).min(h - 1))
            };
            for k in lo..=hi {
                let (x, y, d) = if s.axis == 0 { (k, py as i32, k - px as i32) } else { (px as i32, k, k - py as i32) };
                let ds2 = (d * d) as f32;
                if ds2 > cut * cut {
                    continue;
                }
                let i = (y * w + x) as usize;
                let tap = if s.first {
                    Tap { range: range[i], n: lv.unwrap()[i][3], hv: value[i], r_in: 1.0, var_in: None }
                } else {
                    let v = var.unwrap()[i];
                    // A pixel without paths is not in the chain (valid flag 0).
                    let n = if v[1] > 0.0 { 1.0 } else { 0.0 };
                    Tap { range: range[i], n, hv: value[i], r_in: value[i][3], var_in: Some(v[0]) }
                };
                sums.add(&centre, ds2, tap);
            }
            let (val, r, sigma2) = sums.finish();
            if s.last {
                filter_outputs(val, r, sigma2, lv.unwrap()[j][3])
            } else {
                let valid = if sums.a > 0.0 { 1.0 } else { 0.0 };
                ([val.x, val.y, val.z, r], [sigma2, valid, 0.0, 0.0])
            }
        });
        io.value_out.put(ctx, out.iter().map(|o| o.0).collect())?;
        io.variance_out.put(ctx, out.iter().map(|o| o.1).collect())
    }
}
