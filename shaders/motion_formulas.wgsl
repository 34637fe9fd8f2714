// motion_formulas.wgsl — the WGSL mirror of effects/src/motion/formulas.rs (thesis App. B eqs.
// B.1–B.3 with the Ch. 5 rates of defocus_formulas.wgsl), same operation order. Included by
// motion_rates.wgsl and motion_flags.wgsl after common.wgsl, defocus_formulas.wgsl and velocity.wgsl.

// min(Ω_pix^max, Ω_t^max/|v|) (eqs. B.1, B.2), before μ.
fn motion_omega(speed: f32, omega_t: f32, omega_pix: f32) -> f32 {
    if (speed > 0.0) {
        return rmin(omega_pix, omega_t / speed);
    }
    return omega_pix;
}

fn motion_moving(v: vec2<f32>) -> bool {
    return velocity_length(v) > velocity_tolerance(0.0);
}

// |v|, or 0 within the tolerance of a still point (formulas.rs pixel_rates `speed`).
fn motion_speed(v: vec2<f32>) -> f32 {
    if (motion_moving(v)) {
        return velocity_length(v);
    }
    return 0.0;
}

// formulas.rs fastest_speed: |mean| + |range|/2, 0 within the tolerance of a still point.
fn motion_fastest(v: vec4<f32>) -> f32 {
    let s = velocity_length(v.xy) + 0.5 * velocity_length(v.zw);
    if (is_finite(s) && s > velocity_tolerance(0.0)) {
        return s;
    }
    return 0.0;
}

fn motion_single_velocity(mean: vec2<f32>, spread: vec2<f32>) -> bool {
    let s = velocity_length(spread);
    return s <= velocity_tolerance(velocity_length(mean) + 0.5 * s);
}

// MotionStats::single: one velocity for the primary hits, and for the shadows where occluded.
fn motion_single(velocity: vec4<f32>, shadow: vec4<f32>, occluded: bool) -> bool {
    return motion_single_velocity(velocity.xy, velocity.zw) && (!occluded || motion_single_velocity(shadow.xy, shadow.zw));
}

struct MotionRates {
    single: bool,
    omega_texture: f32,
    omega_direct: f32,
    omega_shadow: f32,
    omega_indirect: f32,
    omega_environment: f32,
    pixel_length: f32,
    n_primary: u32,
    n_direct: u32,
    n_indirect: u32,
    n_environment: u32,
}

// The constants of formulas.rs MotionParams (max_p, max_s, max_s_shadow: strata caps).
struct MotionConstants {
    mu: f32,
    mode: u32,
    omega_pix: f32,
    omega_t: f32,
    pixel_scale: f32,
    light_half_width: f32,
    omega_v: f32,
    max_p: u32,
    max_s: u32,
    max_s_shadow: u32,
    multi_paths: u32,
    environment_per_primary: f32,
}

fn motion_total(n: f32, p: u32, single: bool, max_s: u32) -> u32 {
    var q = 1u;
    if (single) {
        q = defocus_secondary_strata(n, p, max_s);
    }
    return p * p * q * q;
}

// formulas.rs pixel_rates.
fn motion_pixel_rates(
    velocity: vec4<f32>, shadow: vec4<f32>, occluded: bool, hit: bool, depth: f32,
    s_min: f32, s_max: f32, z_min: f32, z_max: f32, bandlimit: f32, k: MotionConstants,
) -> MotionRates {
    let single = motion_single(velocity, shadow, occluded);
    if (!hit) {
        return MotionRates(single, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1u, 1u, 1u, 1u);
    }
    let op = k.omega_pix;
    let l_p = k.pixel_scale * depth;
    let speed_p = motion_speed(velocity.xy);
    var speed_s = 0.0;
    if (occluded) {
        speed_s = motion_speed(shadow.xy);
    }
    let texture = defocus_omega_mu(motion_omega(speed_p, k.omega_t, op), k.mu, k.mode, op);
    let shadow_w = defocus_omega_mu(motion_omega(speed_s, k.omega_t, op), k.mu, k.mode, op);
    let direct = defocus_omega_mu(defocus_omega_direct(0.0, s_min, l_p, k.light_half_width, op), k.mu, k.mode, op);
    let indirect = defocus_omega_mu(defocus_omega_indirect(0.0, z_min, l_p, k.omega_v, op), k.mu, k.mode, op);
    let environment = defocus_omega_mu(defocus_omega_environment(0.0, bandlimit, l_p, op), k.mu, k.mode, op);
    var p = defocus_strata(f32(k.multi_paths), k.max_p);
    if (single) {
        p = defocus_strata(defocus_primary_rate(texture, speed_p, op), k.max_p);
    }
    let omega_d = rmin(direct, shadow_w);
    var omega_texture = 0.0;
    if (single && speed_p > 0.0) {
        omega_texture = texture;
    }
    var omega_shadow = 0.0;
    if (single && speed_s > 0.0) {
        omega_shadow = shadow_w;
    }
    return MotionRates(
        single, omega_texture, direct, omega_shadow, indirect, environment, l_p, p * p,
        motion_total(defocus_direct_rate(omega_d, speed_s, s_max, l_p, k.light_half_width, op), p, single, k.max_s_shadow),
        motion_total(defocus_indirect_rate(indirect, 0.0, z_max, l_p, k.omega_v, op), p, single, k.max_s),
        motion_total(defocus_environment_rate(environment, 0.0, k.environment_per_primary, op), p, single, k.max_s),
    );
}

// kernels.rs sigma_or_zero: the filter's σ in pixels, 0 where it does not filter.
fn motion_sigma(omega: f32) -> f32 {
    if (omega > 0.0) {
        return defocus_sigma_px(omega);
    }
    return 0.0;
}
