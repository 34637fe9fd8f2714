// radiance_filter_formulas.wgsl — the formulas of radiance filtering (seed 002, Ch. 4); mirrors
// effects/src/radiance_filter/formulas.rs (target_variance, warmup_radius, variance_radius,
// kernel_radius, normal_weight, normal_exponent, TangentKernel, window, compose_pixel) with the same
// operation order.
#include "common.wgsl"

const RF_FILTERED: f32 = -1.0;   // filtered.w of a pixel filtered over its neighbours (FILTERED)
const RF_OWN: f32 = -2.0;        // filtered.w of a pixel that keeps its own estimate (OWN)
const RF_EPANECHNIKOV_EFFICIENCY: f32 = 0.75;
const RF_MIN_COS: f32 = 0.2;
const RF_PI: f32 = 3.14159265358979323846;
const RF_NO_BOUNCE_HIT: f32 = -1.0; // incident.w of a continuation ray that left the scene

fn rf_luminance(c: vec3<f32>) -> f32 {
    return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
}

// Eq. 4.14.
fn rf_target_variance(t_u: f32, k: u32) -> f32 {
    return (2.0 * f32(k) - 1.0) * t_u;
}

// Eq. 4.15.
fn rf_warmup_radius(r_w1: f32, k: u32) -> f32 {
    return r_w1 / sqrt(f32(k));
}

// Eqs. 4.1-4.2 with the Epanechnikov correction.
fn rf_variance_radius(v: f32, t_u: f32, k: u32) -> f32 {
    let m = v / rf_target_variance(t_u, k);
    return sqrt(m / (RF_EPANECHNIKOV_EFFICIENCY * RF_PI));
}

fn rf_kernel_radius(t_u: f32, warmup: u32, r_w1: f32, max_radius: f32, k: u32, sigma2: f32, lb: f32) -> f32 {
    var r: f32;
    if (k <= warmup || sigma2 < 0.0) {
        r = rf_warmup_radius(r_w1, k);
    } else if (!(sigma2 > 0.0)) {
        r = 0.0;
    } else if (!(lb > 0.0)) {
        r = max_radius;
    } else {
        r = rf_variance_radius(sigma2 / (lb * lb), t_u, k);
    }
    if (is_nan(r)) {
        return 0.0;
    }
    return rmin(r, max_radius);
}

// Eq. 4.9.
fn rf_normal_weight(nj: vec3<f32>, n: vec3<f32>, e: f32) -> f32 {
    return pow(rmax(dot3(nj, n), 0.0), e);
}

fn rf_normal_exponent(ks: vec3<f32>, m: f32) -> f32 {
    if (m > 0.0 && rmax(ks.x, rmax(ks.y, ks.z)) > 0.0) {
        return rmax(m, 1.0);
    }
    return 1.0;
}

// Eqs. 4.19-4.22: the kernel on the tangent plane.
struct TangentKernel {
    centre: vec3<f32>,
    normal: vec3<f32>,
    axis_s: vec3<f32>,
    axis_d: vec3<f32>,
    rs: f32,
    inv_rs: f32,
    inv_rd: f32,
    delta: f32,
}

fn rf_tangent_kernel(x: vec3<f32>, n: vec3<f32>, eye: vec3<f32>, distance: f32, r: f32, pixel_angle: f32,
    thickness: f32) -> TangentKernel {
    let d = normalize_or_zero3(x - eye);
    let dn = dot3(d, n);
    var a_d = d - n * dn;
    let len = length3(a_d);
    if (!(len > 1e-6)) {
        if (abs(n.x) > 0.9) {
            a_d = vec3<f32>(0.0, 1.0, 0.0);
        } else {
            a_d = vec3<f32>(1.0, 0.0, 0.0);
        }
        a_d = normalize3(a_d - n * dot3(a_d, n));
    } else {
        a_d = a_d / len;
    }
    let a_s = cross3(a_d, n);
    let rs = r * pixel_angle * distance;
    let rd = rs / rmax(abs(dn), RF_MIN_COS);
    return TangentKernel(x, n, a_s, a_d, rs, 1.0 / rs, 1.0 / rd, thickness * rs);
}

fn rf_kernel_weight(k: TangentKernel, xj: vec3<f32>) -> f32 {
    let v = xj - k.centre;
    if (abs(dot3(v, k.normal)) > k.delta) {
        return 0.0;
    }
    let s = dot3(v, k.axis_s) * k.inv_rs;
    let d = dot3(v, k.axis_d) * k.inv_rd;
    let u = s * s + d * d;
    if (u < 1.0) {
        return 1.0 - u;
    }
    return 0.0;
}

// Screen-space ambient occlusion (Sec. 4.3.1 step 3): unoccluded, and the factor alpha.
fn rf_unoccluded(distance: f32, rs: f32) -> bool {
    return distance == RF_NO_BOUNCE_HIT || distance > rs;
}

fn rf_occlusion_factor(unoccluded_weight: f32, weight: f32) -> f32 {
    if (weight > 0.0) {
        return rmin(unoccluded_weight / weight, 1.0);
    }
    return 1.0;
}

fn rf_window(r: f32, max_radius: u32) -> i32 {
    if (r >= 1.0) {
        return min(i32(floor(r)), i32(max_radius));
    }
    return 0;
}
