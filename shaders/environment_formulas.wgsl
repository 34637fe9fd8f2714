// environment_formulas.wgsl — the Ch. 6 per-pixel formulas; mirrors effects/src/environment/formulas.rs
// (curvature, sigma_pixels, phong_bandwidth, transfer_bandwidth, direct_bandwidth,
// indirect_bandwidth, pixel_bandwidths, look_ups) expression for expression.

const ENV_B_F: f32 = 1.0;
const ENV_B_H_DIFFUSE: f32 = 2.8;
const ENV_NOT_FILTERED: f32 = -1.0;

// Eq. 6.20: 2 asin(‖n0 − n1‖/2) over ‖p1 − p0‖ (0 for coincident points).
fn env_curvature(n0: vec3<f32>, n1: vec3<f32>, p0: vec3<f32>, p1: vec3<f32>) -> f32 {
    let d = length3(p1 - p0);
    if (!(d > 0.0)) {
        return 0.0;
    }
    let chord = length3(n0 - n1);
    return 2.0 * env_asin(rmin(0.5 * chord, 1.0)) / d;
}

// formulas.rs `asin_series`: Taylor series to s^15 on [0, 1/2], π/2 − 2 asin(√((1 − s)/2)) above.
fn env_asin_series(x: f32) -> f32 {
    let x2 = x * x;
    var acc = 143.0 / 10240.0;
    acc = acc * x2 + 231.0 / 13312.0;
    acc = acc * x2 + 63.0 / 2816.0;
    acc = acc * x2 + 35.0 / 1152.0;
    acc = acc * x2 + 5.0 / 112.0;
    acc = acc * x2 + 3.0 / 40.0;
    acc = acc * x2 + 1.0 / 6.0;
    acc = acc * x2 + 1.0;
    return x * acc;
}

fn env_asin(s: f32) -> f32 {
    if (s <= 0.5) {
        return env_asin_series(s);
    }
    return 1.5707963267948966 - 2.0 * env_asin_series(sqrt((1.0 - s) * 0.5));
}

fn env_sigma_pixels(b: f32, footprint: f32, max_radius: f32) -> f32 {
    if (!(footprint > 0.0)) {
        return 0.0;
    }
    if (b > 0.0) {
        return rmin((0.5 / b) / footprint, max_radius);
    }
    return max_radius;
}

fn env_phong_bandwidth(m: f32) -> f32 {
    if (m > 0.0) {
        return 1.25 * sqrt(m);
    }
    return 0.0;
}

fn env_transfer_bandwidth(m: f32) -> f32 {
    if (m > 0.0) {
        return 4.27 + 0.15 * m;
    }
    return ENV_B_H_DIFFUSE;
}

// Eq. 6.17 (6.13 for b_rho = 0).
fn env_direct_bandwidth(kappa: f32, occluder: f32, b_rho: f32, b_e: f32) -> f32 {
    let angular = ENV_B_F + 2.0 * b_rho;
    return abs(kappa) * angular + rmax(occluder, 0.0) * (angular + b_e);
}

// Eq. 6.18.
fn env_indirect_bandwidth(b_h: f32, z_min: f32) -> f32 {
    if (z_min > 0.0) {
        return b_h / z_min;
    }
    return 0.0;
}

struct EnvBandwidths {
    direct_diffuse: vec2<f32>,
    direct_glossy: vec2<f32>,
    indirect_diffuse: vec2<f32>,
    indirect_glossy: vec2<f32>,
}

// formulas.rs `window_bandwidth`: 1/(2 R ℓ), 0 without a surface.
fn env_window_bandwidth(footprint: f32, max_radius: f32) -> f32 {
    if (footprint > 0.0 && max_radius > 0.0) {
        return 0.5 / (max_radius * footprint);
    }
    return 0.0;
}

fn env_pixel_bandwidths(kappa: vec2<f32>, occluder: f32, exponent: f32, z_min: f32, b_e: f32, mu: f32, floor: f32) -> EnvBandwidths {
    let b_rho = env_phong_bandwidth(exponent);
    let dd = vec2<f32>(mu * rmax(env_direct_bandwidth(kappa.x, occluder, 0.0, b_e), floor),
        mu * rmax(env_direct_bandwidth(kappa.y, occluder, 0.0, b_e), floor));
    let dg = vec2<f32>(mu * rmax(env_direct_bandwidth(kappa.x, occluder, b_rho, b_e), floor),
        mu * rmax(env_direct_bandwidth(kappa.y, occluder, b_rho, b_e), floor));
    let id = mu * rmax(env_indirect_bandwidth(ENV_B_H_DIFFUSE, z_min), floor);
    let ig = mu * rmax(env_indirect_bandwidth(env_transfer_bandwidth(exponent), z_min), floor);
    if (!(exponent > 0.0)) {
        // No lobe: the glossy parts pass through the filter (ENV_NOT_FILTERED).
        return EnvBandwidths(dd, vec2<f32>(ENV_NOT_FILTERED), vec2<f32>(id), vec2<f32>(ENV_NOT_FILTERED));
    }
    return EnvBandwidths(dd, dg, vec2<f32>(id), vec2<f32>(ig));
}

// Adaptive look-ups (the extension): base · σ_ref² / (σ_X σ_Y), in [base, max].
fn env_look_ups(base: u32, sigma: vec2<f32>, sigma_ref: f32, max_rays: u32) -> u32 {
    let area = sigma.x * sigma.y;
    var want = f32(base);
    if (area > 0.0) {
        want = ceil(f32(base) * sigma_ref * sigma_ref / area);
    }
    return min(max(u32(rmin(want, f32(max_rays))), base), max(max_rays, base));
}
