//! `filter.irradiance` (thesis eq. 5.31): the factoring nodes' filter of factored irradiance `E`
//! with `w_i(j) = exp(−16 ‖λ(i) − λ(j)‖² (Ω(i)/ℓ_p(i))²)` on lens-averaged world positions `λ`, with
//! `Ω = Ω_x^s` (direct) or `Ω_x^i` (indirect) and `ℓ_p` converting it to metres, in the window and
//! with the rejection of [`super::filter_window`]. Neighbours whose (lens-averaged, normalised)
//! normals differ by more than the normal test allows (thesis: 10°) are not used. The pixel bound of
//! the window assumes `‖λ(i) − λ(j)‖ ≥ ℓ_p(i) |i − j|` (true on a surface facing the camera; slanted
//! surfaces are farther apart).
//!
//! Pass-through pixels (output = input): width not finite or ≤ 0, `ℓ_p` not finite or ≤ 0, no hit
//! (`position.w ≤ 0`) or a zero normal. Non-finite values are never used as neighbours; each pixel
//! whose own value is non-finite is counted once in `non_finite_samples`, and gets its neighbours'
//! average if it has any (else it keeps its value: it is never spread). Values are rgb (`vec3`), as
//! `paths.resolve` writes `E`. WGSL mirror: `shaders/filter_irradiance.wgsl`.
//!
//! On the CPU the separable passes run as lanes ([`super::filter_lanes`]): the same taps, tests and
//! weights, summed 8 at a time; the 2-D reference walks its window tap by tap.

use glam::Vec3;
use rayon::prelude::*;

use crate::kernel::{Kernel, KernelCtx, WgslSource};
use crate::kernels::filter_lanes::{lanes, line_array, weight_exp, Group, Lines, Window, LANES};
use crate::kernels::filter_window::{
    exponent, gather_taps, pair_weight, valid_width, within_filter, Axis, ScreenRadius,
};
use crate::kernels::{all_positive_zero, count_non_finite, is_finite3, v3};
use crate::params::KernelParams;
use crate::BackendError;

crate::kernel_params! {
    /// What a `filter.irradiance` pass carries: the window's cap (clamped as read), the cosine of
    /// the normal test and the optional [`Axis`] (absent = 2-D).
    pub struct IrradianceParams {
        max_radius: ScreenRadius,
        normal_cos: f32,
        axis: Axis,
    }
}

crate::kernel_bindings! {
    /// What a `filter.irradiance` pass binds: `E` (rgb), the lens-averaged G-buffer, the width
    /// `Ω` (pixel⁻¹) and `ℓ_p` converting it to metres.
    pub struct IrradianceIo / IrradianceData {
        read value: [f32; 3], read position: [f32; 4], read normal: [f32; 4], read omega: f32, read pixel_length: f32,
        write out: [f32; 3],
    }
}

/// A pixel as its neighbours' weights read it, prepared once per pass rather than per tap (each
/// pixel is a neighbour of up to 2R + 1 others in a separable pass, and would have its normal
/// normalised, its width divided and its value tested as often): lens-averaged position, unit
/// normal (zero where none), its value, and `g² = (Ω/ℓ_p)²` — NaN where the pixel is nobody's
/// neighbour (no hit, or a non-finite value), which the rejection test refuses as it refuses any
/// NaN exponent. One test per tap instead of three, the same decisions and the same operations in
/// the same order as per tap: the same bits.
#[derive(Clone, Copy)]
pub struct Neighbour {
    position: Vec3,
    g2: f32,
    normal: Vec3,
    value: [f32; 3],
}

/// Every pixel of the pass as a [`Neighbour`].
pub fn neighbours(d: &IrradianceData<'_>) -> Vec<Neighbour> {
    (0..d.position.len()).into_par_iter().map(|j| neighbour(d, j)).collect()
}

/// Pixel `j` as a [`Neighbour`].
fn neighbour(d: &IrradianceData<'_>, j: usize) -> Neighbour {
    let g = d.omega[j] / d.pixel_length[j];
    let usable = is_hit(d.position[j]) && is_finite3(d.value[j]);
    Neighbour {
        position: v3(d.position[j]),
        g2: if usable { g * g } else { f32::NAN },
        normal: v3(d.normal[j]).normalize_or_zero(),
        value: d.value[j],
    }
}

/// Eq. 5.31 at pixel `(x, y)`, its neighbours prepared by [`neighbours`].
pub fn irradiance_pixel(
    (x, y): (i32, i32),
    (width, height): (i32, i32),
    p: &IrradianceParams,
    d: &IrradianceData<'_>,
    prepared: &[Neighbour],
) -> [f32; 3] {
    let i = (y * width + x) as usize;
    let centre = d.value[i];
    let (om, ell, me) = (d.omega[i], d.pixel_length[i], prepared[i]);
    if !filters(i, d, &me) {
        return centre;
    }
    // The pixel's own `g²` (its record's is NaN where its value is not finite: it still gathers).
    let g = om / ell;
    let gi2 = g * g;
    let extent = p.axis.extent(p.max_radius.window(om));
    let tap = |_, n: &Neighbour, _| {
        if me.normal.dot(n.normal) < p.normal_cos {
            return None;
        }
        pair_weight((n.position - me.position).length_squared(), gi2, n.g2).map(|w| (w, n.value))
    };
    gather_taps(x, y, width, height, extent, prepared, tap).unwrap_or(centre)
}

/// The [`Neighbour`] records of one line of a separable pass, one array per quantity (a window of
/// lanes loads each with vector loads), padded with records every tap rejects. A value that is not
/// finite is stored as 0 (its `g²` is NaN: every tap rejects it; [`Group`]).
struct LineRecords {
    /// The line's records (a window's centre reads its own here).
    ordered: Vec<Neighbour>,
    position: [Vec<f32>; 3],
    normal: [Vec<f32>; 3],
    g2: Vec<f32>,
    value: [Vec<f32>; 3],
}

impl LineRecords {
    fn new(pixels: &[usize], d: &IrradianceData<'_>) -> Self {
        let pad = Neighbour { position: Vec3::ZERO, g2: f32::NAN, normal: Vec3::ZERO, value: [0.0; 3] };
        let ordered = line_array(pixels, pad, |p| neighbour(d, p));
        let array = |f: &dyn Fn(&Neighbour) -> f32| ordered.iter().map(f).collect::<Vec<f32>>();
        LineRecords {
            position: [array(&|n| n.position.x), array(&|n| n.position.y), array(&|n| n.position.z)],
            normal: [array(&|n| n.normal.x), array(&|n| n.normal.y), array(&|n| n.normal.z)],
            g2: array(&|n| n.g2),
            value: [0, 1, 2].map(|c| array(&|n| if n.g2.is_nan() { 0.0 } else { n.value[c] })),
            ordered,
        }
    }
}

/// [`irradiance_pixel`] in a separable pass, its window `w` on the pixel's line: the same tests
/// (the normal test, `w_i(j)` and `w_j(i)` at 0.01, a NaN `g²` refused) as selects, not branches.
fn irradiance_lanes(
    i: usize,
    p: &IrradianceParams,
    d: &IrradianceData<'_>,
    me: &Neighbour,
    r: &LineRecords,
    w: Window,
) -> [f32; 3] {
    let g = d.omega[i] / d.pixel_length[i];
    let gi2 = g * g;
    let group = |k: usize| {
        let [px, py, pz] = r.position.each_ref().map(|a| lanes(a, k));
        let [nx, ny, nz] = r.normal.each_ref().map(|a| lanes(a, k));
        let (g2, value) = (lanes(&r.g2, k), r.value.each_ref().map(|a| lanes(a, k)));
        let mut weight = [0.0; LANES];
        for l in 0..LANES {
            let dot = me.normal.x * nx[l] + me.normal.y * ny[l] + me.normal.z * nz[l];
            let (dx, dy, dz) = (px[l] - me.position.x, py[l] - me.position.y, pz[l] - me.position.z);
            let d2 = dx * dx + dy * dy + dz * dz;
            let e_i = exponent(d2, gi2);
            // `&`, not `&&`: every test is computed, no branch (the lanes vectorize).
            let used = !(dot < p.normal_cos) & within_filter(e_i) & within_filter(exponent(d2, g2[l]));
            weight[l] = if used { weight_exp(-e_i) } else { 0.0 };
        }
        Group { weight, value }
    };
    w.mean(group).unwrap_or(d.value[i])
}

/// A separable pass (x or y) of eq. 5.31 on every pixel, line by line as lanes.
fn separable_pass(lines: &Lines, p: &IrradianceParams, io: &IrradianceData<'_>) -> Vec<[f32; 3]> {
    lines.map(
        |pixels| LineRecords::new(pixels, io),
        |i, r, t| filters(i, io, &r.ordered[t]).then(|| p.max_radius.window(io.omega[i]) as usize),
        |i, r, w| w.map_or(io.value[i], |w| irradiance_lanes(i, p, io, &r.ordered[w.centre], r, w)),
    )
}

/// Whether pixel `i` filters (else it passes its value through): a valid width and `ℓ_p`, a hit
/// and a normal.
fn filters(i: usize, d: &IrradianceData<'_>, me: &Neighbour) -> bool {
    valid_width(d.omega[i]) && valid_width(d.pixel_length[i]) && is_hit(d.position[i]) && me.normal != Vec3::ZERO
}

/// Whether a pixel's primary rays hit geometry (`position.w > 0`; false for NaN).
fn is_hit(position: [f32; 4]) -> bool {
    position[3] > 0.0
}

/// `filter.irradiance`: eq. 5.31 on factored irradiance.
pub struct IrradianceFilter;

impl Kernel for IrradianceFilter {
    crate::kernel_signature!(
        name: "filter.irradiance", class: Filter, bindings: IrradianceIo, params: [IrradianceParams]
    );
    fn wgsl(&self) -> Option<WgslSource> {
        Some(
            WgslSource::new(include_str!("../../../shaders/filter_irradiance.wgsl"), |ctx| {
                Ok(IrradianceParams::read(ctx)?.uniforms())
            })
            .with_include("filter_window.wgsl", include_str!("../../../shaders/filter_window.wgsl"))
            .with_reach(|ctx| {
                let p = IrradianceParams::read(ctx)?;
                Ok(p.axis.reach(p.max_radius))
            }),
        )
    }
    fn run_cpu(&self, ctx: &mut KernelCtx<'_>) -> Result<(), BackendError> {
        let io = IrradianceIo::read(ctx)?;
        let p = IrradianceParams::read(ctx)?;
        count_non_finite(ctx, io.value);
        if all_positive_zero(io.value) {
            return io.out.put(ctx, io.value.to_vec());
        }
        let out = match Lines::of(p.axis, ctx.width, ctx.height) {
            Some(lines) => separable_pass(&lines, &p, &io),
            None => {
                let prepared = neighbours(&io);
                let size = (ctx.width as i32, ctx.height as i32);
                ctx.map_pixels(false, |x, y| irradiance_pixel((x as i32, y as i32), size, &p, &io, &prepared))
            }
        };
        io.out.put(ctx, out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bindings::Output;

    /// A small deterministic generator (the test's own inputs; no stream of the renderer's).
    struct Lcg(u64);
    impl Lcg {
        fn unit(&mut self) -> f32 {
            self.0 = self.0.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (self.0 >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    /// The lanes are the tap-by-tap pass (`irradiance_pixel` along the same axis) to rounding —
    /// the same taps used, the same pass-through pixels bit for bit — on an image whose lines are
    /// not a multiple of the lanes, with misses, zero normals, normals past the 10° test, values
    /// that are not finite, widths that bind the cap, zero and NaN widths.
    #[test]
    fn the_lanes_are_the_tap_by_tap_pass() {
        let (w, h) = (37u32, 23u32);
        let n = (w * h) as usize;
        let mut rng = Lcg(7);
        let mut value = vec![[0.0f32; 3]; n];
        let (mut position, mut normal) = (vec![[0.0f32; 4]; n], vec![[0.0f32; 4]; n]);
        let (mut omega, mut pixel_length) = (vec![0.0f32; n], vec![0.0f32; n]);
        for i in 0..n {
            let (x, y) = ((i % w as usize) as f32, (i / w as usize) as f32);
            value[i] = [rng.unit(), rng.unit() * 2.0, rng.unit() * 0.5];
            if rng.unit() < 0.05 {
                value[i][1] = [f32::NAN, f32::INFINITY][(rng.unit() * 2.0) as usize % 2];
            }
            let hit = if rng.unit() < 0.05 { 0.0 } else { 1.0 };
            position[i] = [x * 0.01 + rng.unit() * 0.004, y * 0.01, 1.0 + rng.unit() * 0.01, hit];
            let tilt = if rng.unit() < 0.1 { 0.5 } else { 0.05 };
            normal[i] = if rng.unit() < 0.03 { [0.0; 4] } else { [rng.unit() * tilt, rng.unit() * tilt, 1.0, 0.0] };
            omega[i] = match rng.unit() {
                u if u < 0.05 => 0.0,
                u if u < 0.08 => f32::NAN,
                u if u < 0.3 => 0.005,
                u => u * 0.6,
            };
            pixel_length[i] = 0.01 * (0.8 + rng.unit() * 0.4);
        }
        let io = IrradianceData {
            value: &value,
            position: &position,
            normal: &normal,
            omega: &omega,
            pixel_length: &pixel_length,
            out: Output::new("out"),
        };
        let prepared = neighbours(&io);
        for axis in [Axis::X, Axis::Y] {
            let p =
                IrradianceParams { max_radius: ScreenRadius::clamped(16), normal_cos: 10f32.to_radians().cos(), axis };
            let lanes = separable_pass(&Lines::of(axis, w, h).unwrap(), &p, &io);
            let (mut filtered, mut worst) = (0, 0.0f32);
            for i in 0..n {
                let xy = ((i % w as usize) as i32, (i / w as usize) as i32);
                let want = irradiance_pixel(xy, (w as i32, h as i32), &p, &io, &prepared);
                let got = lanes[i];
                if want.map(f32::to_bits) == value[i].map(f32::to_bits) {
                    assert_eq!(got.map(f32::to_bits), want.map(f32::to_bits), "{axis:?} pixel {i} passes through");
                    continue;
                }
                filtered += 1;
                for c in 0..3 {
                    let err = (got[c] - want[c]).abs() / want[c].abs().max(1e-3);
                    worst = worst.max(err);
                    assert!(err < 1e-5, "{axis:?} pixel {i} channel {c}: lanes {} tap by tap {}", got[c], want[c]);
                }
            }
            assert!(filtered > n / 2, "{axis:?}: {filtered} of {n} pixels filtered");
            println!("{axis:?}: {filtered} filtered pixels, worst relative difference {worst:.2e}");
        }
    }
}
