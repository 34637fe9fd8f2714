// indirect_formulas.wgsl — the WGSL mirror of effects/src/indirect/formulas.rs (thesis eqs. 4.15,
// 4.16, 4.18, 4.21, A.3, A.5), same operation order. Included by indirect_bandwidth.wgsl and
// indirect_rates.wgsl.

// Receiver (indirect::Receiver): kind + Phong exponent m.
const RECEIVER_DIFFUSE: u32 = 0u;
const RECEIVER_BLINN_PHONG: u32 = 1u;
const RECEIVER_PHONG: u32 = 2u;

struct Receiver {
    kind: u32,
    m: f32,
}

// Settings (indirect::Settings).
struct IndirectSettings {
    mu: f32,
    alpha: f32,
    width_alpha: f32,
    z_fraction: f32,
    extent: f32,
    initial: u32,
    max_rays: u32,
}

// indirect::kernels::settings: the width's α, `width_alpha` where set (> 0), else α.
fn indirect_settings(initial: u32, max_rays: u32) -> IndirectSettings {
    let width_alpha = select(params.alpha, params.width_alpha, params.width_alpha > 0.0);
    return IndirectSettings(params.mu, params.alpha, width_alpha, params.z_min_fraction, params.extent, initial, max_rays);
}

// Ω_h^max (eqs. 4.18, A.3, A.5).
fn indirect_transfer_bandlimit(r: Receiver) -> f32 {
    if (r.kind == RECEIVER_BLINN_PHONG) {
        return 3.6 + 0.084 * r.m;
    }
    if (r.kind == RECEIVER_PHONG) {
        return 4.27 + 0.15 * r.m;
    }
    return 2.8;
}

// acos to about 1 ulp (musl's acosf), like Rust's f32::acos: the builtin acos may be a coarse
// polynomial (Mesa lowers it so), which moves eq. 4.21's count across ceil boundaries.
fn acos_r(z: f32) -> f32 {
    let p = z * (1.6666586697e-01 + z * (-4.2743422091e-02 + z * -8.6563630030e-03));
    let q = 1.0 + z * -7.0662963390e-01;
    return p / q;
}

fn acos_precise(x: f32) -> f32 {
    let pio2_hi: f32 = 1.5707962513e+00;
    let pio2_lo: f32 = 7.5497894159e-08;
    let hx = bitcast<u32>(x);
    let ix = hx & 0x7fffffffu;
    if (ix >= 0x3f800000u) {
        if (ix == 0x3f800000u) {
            if ((hx >> 31u) != 0u) {
                return 2.0 * pio2_hi;
            }
            return 0.0;
        }
        return bitcast<f32>(0x7fc00000u);
    }
    if (ix < 0x3f000000u) {
        if (ix <= 0x32800000u) {
            return pio2_hi;
        }
        return pio2_hi - (x - (pio2_lo - x * acos_r(x * x)));
    }
    if ((hx >> 31u) != 0u) {
        let z = (1.0 + x) * 0.5;
        let s = sqrt(z);
        let w = acos_r(z) * s - pio2_lo;
        return 2.0 * (pio2_hi - (s + w));
    }
    let z = (1.0 - x) * 0.5;
    let s = sqrt(z);
    let df = bitcast<f32>(bitcast<u32>(s) & 0xfffff000u);
    let c = (z - df * df) / (s + df);
    let w = acos_r(z) * s + c;
    return 2.0 * (df + w);
}

// γ of eq. 4.21.
fn indirect_gamma(r: Receiver) -> f32 {
    if (r.kind == RECEIVER_DIFFUSE) {
        return 0.4;
    }
    let c: f32 = 0.707106781186547524401; // FRAC_1_SQRT_2
    let half_pi: f32 = 1.57079632679489661923; // FRAC_PI_2
    return acos_precise(pow(c, 1.0 / rmax(r.m, 1e-6))) / half_pi;
}

fn indirect_clamp_z_min(z_min: f32, extent: f32, fraction: f32) -> f32 {
    return rmax(z_min, fraction * extent);
}

// Ω_x^r (eq. 4.15).
fn indirect_filter_bandwidth(omega_h: f32, z_min: f32, d: f32, mu: f32, alpha: f32) -> f32 {
    return mu * rmin(omega_h / z_min, alpha / d);
}

// β (eq. 4.16).
fn indirect_filter_beta(omega_x_r: f32) -> f32 {
    return 2.0 / omega_x_r;
}

// n (eq. 4.21), before clamping.
fn indirect_samples_per_pixel(gamma: f32, omega_h: f32, d: f32, z_min: f32, z_max: f32, mu: f32, alpha: f32) -> f32 {
    let first = mu * omega_h * d / z_min + alpha;
    let second = 1.0 + mu * z_max / z_min;
    return gamma * first * first * omega_h * omega_h * second * second;
}

// Rust's `x as u32` (saturating; NaN → 0).
fn indirect_to_u32(x: f32) -> u32 {
    if (!(x > 0.0)) {
        return 0u;
    }
    if (x >= 4294967296.0) {
        return 0xffffffffu;
    }
    return u32(x);
}

// ceil and clamp to [initial, max · max(μ, 1)].
fn indirect_clamp_rate(n: f32, mu: f32, initial: u32, max_rays: u32) -> u32 {
    let hi = indirect_to_u32(rmax(ceil(f32(max_rays) * rmax(mu, 1.0)), f32(initial)));
    if (is_finite(n)) {
        return clamp(indirect_to_u32(rmax(ceil(n), 0.0)), initial, hi);
    }
    return hi;
}

struct ComponentRate {
    beta: f32,
    rays: u32,
}

// indirect::component: β and n of one component from its first-pass statistics.
// `nearest` > 0: the width's z_min (indirect.nearest), unclamped; 0: the rates' clamped z_min.
fn indirect_component(r: Receiver, dp: vec4<f32>, nearest: f32, d: f32, s: IndirectSettings) -> ComponentRate {
    // No reflector found: the farthest one can be, the scene's size (see effects/src/indirect/mod.rs).
    var z = dp.xy;
    if (dp.z <= 0.0) {
        z = vec2<f32>(s.extent, s.extent);
    }
    let z_min = indirect_clamp_z_min(z.x, s.extent, s.z_fraction);
    let z_max = rmax(z.y, z_min);
    let omega_h = indirect_transfer_bandlimit(r);
    let z_width = select(z_min, nearest, nearest > 0.0);
    let beta = indirect_filter_beta(indirect_filter_bandwidth(omega_h, z_width, rmax(d, 1e-12), s.mu, s.width_alpha));
    let n = indirect_samples_per_pixel(indirect_gamma(r), omega_h, d, z_min, z_max, s.mu, s.alpha);
    return ComponentRate(beta, indirect_clamp_rate(n, s.mu, s.initial, s.max_rays));
}

// indirect::glossy_receiver's test: k_s > 0 and m > 0 (Rust f32::max over k_s).
fn indirect_has_glossy(spec: vec4<f32>) -> bool {
    return spec.w > 0.0 && rmax(rmax(spec.x, spec.y), spec.z) > 0.0;
}
