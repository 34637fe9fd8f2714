// pixel_filter_formulas.wgsl — the formulas of pixel filtering (seed 002, Ch. 3); mirrors
// effects/src/pixel_filter/formulas.rs (luminance, Stats::combine, blend_factor, spike_clamp,
// adaptive_sigma, range_colour, bilateral_weight, range_update) with the same operation order.
#include "common.wgsl"

const PF_FILTERED: f32 = -1.0;     // variance.w of a pixel the filter wrote (pixel_filter/formulas.rs FILTERED)
const PF_MISS_DEPTH: f32 = 1e9;    // range depth of a ray that left the scene (MISS_DEPTH)

fn pf_luminance(c: vec3<f32>) -> f32 {
    return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
}

// Running statistics of one pixel: means of L_lv and L_u, paths n, M2 of Y(L_u).
struct PfStats {
    lv: vec3<f32>,
    u: vec3<f32>,
    n: f32,
    m2: f32,
}

fn pf_stats(lv: vec4<f32>, u: vec4<f32>) -> PfStats {
    return PfStats(lv.xyz, u.xyz, lv.w, u.w);
}

// Stats::combine: Chan/Welford pairwise update.
fn pf_combine(a: PfStats, b: PfStats) -> PfStats {
    if (!(b.n > 0.0)) {
        return a;
    }
    if (!(a.n > 0.0)) {
        return b;
    }
    let n = a.n + b.n;
    let lv = a.lv + (b.lv - a.lv) * b.n / n;
    let u = a.u + (b.u - a.u) * b.n / n;
    let dy = pf_luminance(b.u) - pf_luminance(a.u);
    let m2 = a.m2 + b.m2 + dy * dy * a.n * b.n / n;
    return PfStats(lv, u, n, rmax(m2, 0.0));
}

// blend_factor: eqs. 3.12-3.13.
fn pf_blend_factor(u: f32, f: f32, t: f32) -> f32 {
    if (!(u > t)) {
        return 1.0;
    }
    if (u == inf() || f == inf()) {
        return 0.0;
    }
    let d = t * u + t * f - u * f;
    if (d < 0.0) {
        return 0.0;
    }
    let s = (f + sqrt(d)) / (u + f);
    return rmin(rmax(s, 0.0), 1.0);
}

// spike_clamp: eq. 3.18, per channel (Rust f32::max then f32::min).
fn pf_spike_clamp(lu: vec3<f32>, lf: vec3<f32>, c: f32) -> vec3<f32> {
    let lo = lf / c;
    let hi = lf * c;
    return vec3<f32>(rmin(rmax(lu.x, lo.x), hi.x), rmin(rmax(lu.y, lo.y), hi.y), rmin(rmax(lu.z, lo.z), hi.z));
}

// adaptive_sigma: eqs. 3.15-3.17.
fn pf_adaptive_sigma(sigma2: f32, n: f32, lb: f32, t: f32, sigma_s: f32, c: f32) -> f32 {
    let guide = sigma_s / sqrt(rmax(n, 1.0));
    var ratio = 0.0;
    if (sigma2 > 0.0) {
        let target_f = rmax(n, 1.0) * t * lb * lb;
        if (target_f > 0.0) {
            ratio = sigma2 / target_f;
        } else {
            ratio = inf();
        }
    }
    let e = 0.5 * sqrt(ratio) - 0.5;
    let sigma = 1.5 * e;
    return rmin(rmin(rmax(sigma, guide / c), guide * c), sigma_s);
}

fn pf_range_colour(kd: vec3<f32>, ks: vec3<f32>, c: f32) -> vec3<f32> {
    return (kd + ks) * (0.5 + 0.5 * c);
}

const PF_WEIGHT_CUTOFF: f32 = 80.0; // weights below e^-80 are 0 (pixel_filter/formulas.rs WEIGHT_CUTOFF)

fn pf_bilateral_weight(ds2: f32, dc2: f32, dd: f32, inv_s: f32, inv_c: f32, inv_d: f32) -> f32 {
    let x = ds2 * inv_s + dc2 * inv_c + dd * dd * inv_d;
    if (!(x < PF_WEIGHT_CUTOFF)) {
        return 0.0;
    }
    return exp(-x);
}

fn pf_inv_two_sigma2(sigma: f32) -> f32 {
    if (sigma > 0.0 && is_finite(sigma)) {
        return 1.0 / (2.0 * sigma * sigma);
    }
    return 0.0;
}

// The window radius of spatial sigma `sigma`: ceil(truncate * sigma), at most 1024.
fn pf_radius(truncate: f32, sigma: f32) -> i32 {
    return i32(rmin(rmax(ceil(truncate * sigma), 0.0), 1024.0));
}

// Sums of one filtered pixel (pixel_filter/kernels/filter.rs Sums, Spread).
struct PfSums {
    a: f32,
    value: vec3<f32>,
    a2: f32,
    var_sum: f32,
    var_w: f32,
    spread_w: f32,
    spread_mean: f32,
    spread_s: f32,
}

fn pf_sums() -> PfSums {
    return PfSums(0.0, vec3<f32>(0.0), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
}

// add_tap: one neighbour of the cross-bilateral filter.
fn pf_add_tap(s: ptr<function, PfSums>, range_i: vec4<f32>, cj: vec3<f32>, dj: f32, ds2: f32, inv_s: f32, inv_c: f32,
        inv_d: f32, n: f32, hv: vec4<f32>, r_in: f32, var_in: f32, has_var_in: bool, first: bool, spread: bool) {
    if (!(n > 0.0)) {
        return;
    }
    let dc = range_i.xyz - cj;
    let a = pf_bilateral_weight(ds2, dot3(dc, dc), dj - range_i.w, inv_s, inv_c, inv_d);
    if (!(a > 0.0)) {
        return;
    }
    let value = hv.xyz;
    (*s).a = (*s).a + a;
    (*s).value = (*s).value + value * a;
    (*s).a2 = (*s).a2 + a * a * r_in;
    if (first) {
        if (n >= 2.0) {
            (*s).var_sum = (*s).var_sum + a * (hv.w / (n - 1.0));
            (*s).var_w = (*s).var_w + a;
        }
        if (spread) {
            let y = pf_luminance(value);
            (*s).spread_w = (*s).spread_w + a;
            let d = y - (*s).spread_mean;
            (*s).spread_mean = (*s).spread_mean + d * a / (*s).spread_w;
            (*s).spread_s = (*s).spread_s + a * d * (y - (*s).spread_mean);
        }
    } else if (has_var_in) {
        (*s).var_sum = (*s).var_sum + a * var_in;
        (*s).var_w = (*s).var_w + a;
    }
}

struct PfFiltered {
    value: vec3<f32>,
    r: f32,
    sigma2: f32,
}

// Sums::finish.
fn pf_finish(s: PfSums) -> PfFiltered {
    if (!(s.a > 0.0)) {
        return PfFiltered(vec3<f32>(0.0), 0.0, 0.0);
    }
    let value = s.value / s.a;
    let r = s.a2 / (s.a * s.a);
    var sigma2 = 0.0;
    if (s.var_w > 0.0) {
        sigma2 = s.var_sum / s.var_w;
    } else if (s.spread_w > 0.0) {
        sigma2 = rmax(s.spread_s / s.spread_w, 0.0);
    }
    return PfFiltered(value, r, sigma2);
}

struct PfOutputs {
    filtered: vec4<f32>,
    variance: vec4<f32>,
}

// filter_outputs.
fn pf_filter_outputs(f: PfFiltered, n: f32) -> PfOutputs {
    if (!(n > 0.0)) {
        return PfOutputs(vec4<f32>(0.0), vec4<f32>(0.0));
    }
    let f_abs = f.r * f.sigma2 / n;
    return PfOutputs(vec4<f32>(f.value, f_abs), vec4<f32>(f.sigma2, f.r, n, PF_FILTERED));
}
