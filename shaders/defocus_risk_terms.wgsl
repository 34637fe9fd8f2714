// defocus.risk_terms — what the wider screen filter adds to a pixel's squared error, as two
// non-negative terms (bias, noise): the composed value's variance from the narrow filter's residual,
// the filters' overlaps summed without cancelling; mirrors effects/src/defocus/kernels/risk.rs
// (gaussian_tap, Overlaps::new, Sums::add, risk_terms) term by term and in the same order.
#include "common.wgsl"
#include "filter_window.wgsl"

const MAX_TAPS: i32 = 65;
const WIDER: f32 = 0.95;

fn gaussian_tap(g: f32, cap: i32, d: i32) -> f32 {
    let e = FILTER_SHARPNESS * f32(d * d) * (g * g);
    if (d <= window_radius(g, cap) && e <= REJECT_EXPONENT) {
        return exp(-e);
    }
    return 0.0;
}

struct Overlaps {
    kept: f32,
    removed: f32,
    apart: f32,
}

fn overlaps(g_n: f32, g_w: f32, cap: i32) -> Overlaps {
    let radius = clamp(max(window_radius(g_n, cap), window_radius(g_w, cap)), 0, MAX_TAPS - 1);
    var taps: array<vec2<f32>, 65>;
    var sa = 0.0;
    var sb = 0.0;
    for (var d = 1; d <= radius; d = d + 1) {
        let t = vec2<f32>(gaussian_tap(g_n, cap, d), gaussian_tap(g_w, cap, d));
        taps[d] = t;
        sa = sa + 2.0 * t.x;
        sb = sb + 2.0 * t.y;
    }
    let n0 = 1.0 / (1.0 + sa);
    let w0 = 1.0 / (1.0 + sb);
    let d0 = (sb - sa) * n0 * w0;
    var a = n0 * n0;
    var b = n0 * w0;
    var c = w0 * w0;
    var a_minus_c = d0 * (n0 + w0);
    var a_minus_b = n0 * d0;
    var c_minus_b = -w0 * d0;
    var apart_1d = d0 * d0;
    var off = 0.0;
    for (var d = 1; d <= radius; d = d + 1) {
        let n = taps[d].x * n0;
        let w = taps[d].y * w0;
        a = a + 2.0 * n * n;
        b = b + 2.0 * n * w;
        c = c + 2.0 * w * w;
        a_minus_c = a_minus_c + 2.0 * (n - w) * (n + w);
        a_minus_b = a_minus_b + 2.0 * n * (n - w);
        c_minus_b = c_minus_b + 2.0 * w * (w - n);
        apart_1d = apart_1d + 2.0 * (n - w) * (n - w);
        off = off + 2.0 * n * n;
    }
    let rest = sa * (2.0 + sa) * (n0 * n0);
    return Overlaps(rest * rest + off * off + 2.0 * (n0 * n0) * off, a_minus_c * (a + c),
        a_minus_b * a_minus_b + c_minus_b * c_minus_b + 2.0 * b * apart_1d);
}

fn dist2(a: vec3<f32>, b: vec3<f32>) -> f32 {
    let d = a - b;
    return d.x * d.x + d.y * d.y + d.z * d.z;
}

// (bias, noise) of the module doc; (0, 0) without an estimate.
fn risk_terms(i: u32) -> vec2<f32> {
    let n = omega_at(i);
    let w = omega_wide_at(i);
    if (!(valid_width(n) && valid_width(w) && w <= WIDER * n)) {
        return vec2<f32>(0.0);
    }
    let o = overlaps(n, w, params.max_radius);
    if (!(o.kept > 0.0)) {
        return vec2<f32>(0.0);
    }
    let variance = dist2(value_at(i), narrow_at(i)) / o.kept;
    let growth = (n * n + w * w) / ((n - w) * (n + w));
    let bias = growth * dist2(wide_at(i), narrow_at(i));
    let noise = growth * variance * o.apart + variance * o.removed;
    if (is_finite(bias) && is_finite(noise)) {
        return vec2<f32>(bias, noise);
    }
    return vec2<f32>(0.0);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let t = risk_terms(i);
    bias_put(i, t.x);
    noise_put(i, t.y);
}
