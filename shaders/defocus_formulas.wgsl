// defocus_formulas.wgsl — the WGSL mirror of effects/src/defocus/formulas.rs (thesis eqs. 5.2,
// 5.7, 5.18, 5.22, 5.24–5.30), same operation order. Included by defocus_rates.wgsl and
// defocus_flags.wgsl; the path sampler may include it for the circle of confusion.

const DEFOCUS_OMEGA_U_MAX: f32 = 1.0;
const DEFOCUS_ROUNDING_SLACK: f32 = 1e-4;

// Signed circle of confusion in pixels (eq. 5.2): (a/m)(1/z − 1/f); exactly 0 for a pinhole.
fn defocus_circle_of_confusion(aperture_radius: f32, focus_distance: f32, pixel_scale: f32, z: f32) -> f32 {
    if (aperture_radius == 0.0) {
        return 0.0;
    }
    return (aperture_radius / pixel_scale) * (1.0 / z - 1.0 / focus_distance);
}

// a / b, or +inf when b ≤ 0 (an absent statistic does not limit the filter).
fn defocus_ratio_or_inf(a: f32, b: f32) -> f32 {
    if (b > 0.0) {
        return a / b;
    }
    return inf();
}

// Ω_x^d (eq. 5.7)
fn defocus_omega_defocus(r_min: f32, omega_pix: f32) -> f32 {
    return rmin(omega_pix, defocus_ratio_or_inf(DEFOCUS_OMEGA_U_MAX, abs(r_min)));
}

// Ω_x^s (eq. 5.18), Ω_y^max = 1/ℓ_I
fn defocus_omega_direct(r_min: f32, s_min: f32, pixel_length: f32, light_half_width: f32, omega_pix: f32) -> f32 {
    let light = defocus_ratio_or_inf(pixel_length, light_half_width * rmax(s_min, 0.0));
    return rmin(defocus_omega_defocus(r_min, omega_pix), light);
}

// Ω_x^e: eq. 5.18's form with the environment's Ch. 6 bandwidth B (1/m) as its own term (formulas.rs
// omega_environment; 0.3535534 = 2/√32, OMEGA_PER_ENVIRONMENT_BANDWIDTH).
fn defocus_omega_environment(r_min: f32, bandlimit: f32, pixel_length: f32, omega_pix: f32) -> f32 {
    var own = inf();
    if (bandlimit > 0.0) {
        own = 0.3535534 * bandlimit * pixel_length;
    }
    return rmin(defocus_omega_defocus(r_min, omega_pix), own);
}

// Ω_x^i (eq. 5.22)
fn defocus_omega_indirect(r_min: f32, z_min: f32, pixel_length: f32, omega_v: f32, omega_pix: f32) -> f32 {
    let reflector = defocus_ratio_or_inf(pixel_length * omega_v, rmax(z_min, 0.0));
    return rmin(defocus_omega_defocus(r_min, omega_pix), reflector);
}

// Ω(μ) (eq. 5.29); mode 0 literal (clamped at Ω_pix^max), 1 consistent (no clamp).
fn defocus_omega_mu(omega: f32, mu: f32, mode: u32, omega_pix: f32) -> f32 {
    if (mode == 0u) {
        return rmin(omega_pix, mu * omega);
    }
    return mu * omega;
}

// formulas.rs screen_width: the screen filter's width, eq. 5.7's d, or the lens term alone.
fn defocus_screen_width(d: f32, r_min: f32, mu: f32, pixel_limit: u32) -> f32 {
    if (pixel_limit != 0u) {
        return d;
    }
    return mu * defocus_ratio_or_inf(DEFOCUS_OMEGA_U_MAX, abs(r_min));
}

// n_p (eq. 5.24)
fn defocus_primary_rate(omega_d: f32, r_max: f32, omega_pix: f32) -> f32 {
    let spatial = omega_pix + omega_d;
    let lens = 1.0 + abs(r_max) * omega_d;
    return spatial * spatial * lens * lens;
}

// n_dir^f / n_dir^c (eqs. 5.25, 5.27)
fn defocus_direct_rate(omega: f32, r_max: f32, s_max: f32, pixel_length: f32, light_half_width: f32, omega_pix: f32) -> f32 {
    let spread = light_half_width * rmax(s_max, 0.0);
    var light = 1.0;
    if (spread > 0.0) {
        light = 1.0 + spread * omega / pixel_length;
    }
    return defocus_primary_rate(omega, r_max, omega_pix) * light * light;
}

// n_ind^f / n_ind^c (eqs. 5.26, 5.28)
fn defocus_indirect_rate(omega: f32, r_max: f32, z_max: f32, pixel_length: f32, omega_v: f32, omega_pix: f32) -> f32 {
    let depth = rmax(z_max, 0.0);
    var angular = omega_v;
    if (depth > 0.0) {
        angular = omega_v + depth * omega / pixel_length;
    }
    return defocus_primary_rate(omega, r_max, omega_pix) * angular * angular;
}

// ceil(sqrt(n)) in [1, max] (Sec. 5.8 footnote 6); not finite → max.
fn defocus_strata(n: f32, max_strata: u32) -> u32 {
    let m = max(max_strata, 1u);
    let root = sqrt(n) - DEFOCUS_ROUNDING_SLACK;
    if (!is_finite(root) || root >= f32(m)) {
        return m;
    }
    return clamp(u32(ceil(root)), 1u, m);
}

// formulas.rs primary_cap: `still` strata per side times 1 + |v| Ω, at most `moving` (`still` where
// moving <= still).
fn defocus_primary_cap(still: u32, moving: u32, speed_factor: f32) -> u32 {
    if (moving <= still) {
        return still;
    }
    let c = f32(still) * speed_factor;
    if (c >= f32(moving) || !is_finite(c)) {
        return moving;
    }
    return max(u32(c), still);
}

fn defocus_secondary_strata(n: f32, p: u32, max_s: u32) -> u32 {
    let q = max(p, 1u);
    let p2 = f32(q * q);
    return defocus_strata(n / p2, max_s);
}

// Secondary rays per primary ray after the 3×3 max: smallest s² with n_p s² ≥ n (at least 1).
fn defocus_secondary_per_primary(n_p: u32, n: u32) -> u32 {
    let np = max(n_p, 1u);
    var s = 1u;
    while (np * s * s < n) {
        s = s + 1u;
    }
    return s * s;
}

// formulas.rs bandlimit_of: a bandwidth statistic that is not finite or below 0 reads 0.
fn defocus_bandlimit(b: f32) -> f32 {
    if (is_finite(b)) {
        return rmax(b, 0.0);
    }
    return 0.0;
}

// formulas.rs environment_rate: eq. 5.24's factors times the look-ups per primary ray.
fn defocus_environment_rate(omega: f32, r_max: f32, per_primary: f32, omega_pix: f32) -> f32 {
    return defocus_primary_rate(omega, r_max, omega_pix) * rmax(per_primary, 1.0);
}

// formulas.rs time_factor: (1 + |v| Ω)², exactly 1 at v = 0.
fn defocus_time_factor(speed: f32, omega: f32) -> f32 {
    let f = 1.0 + speed * omega;
    return f * f;
}

struct DefocusRates {
    omega_defocus: f32,
    omega_direct: f32,
    omega_indirect: f32,
    pixel_length: f32,
    n_primary: u32,
    n_direct_factored: u32,
    n_direct_combined: u32,
    n_indirect_factored: u32,
    n_indirect_combined: u32,
    omega_environment: f32,
    n_environment_factored: u32,
    n_environment_combined: u32,
}

// formulas.rs pixel_rates: widths (μ-scaled) and rounded counts of one pixel.
fn defocus_pixel_rates(
    r_min: f32, r_max: f32, depth: f32, hit: bool, s_min: f32, s_max: f32, z_min: f32, z_max: f32, bandlimit: f32,
    v_p: f32, v_s: f32,
    mu: f32, mode: u32, omega_pix: f32, pixel_scale: f32, light_half_width: f32, omega_v: f32,
    max_p: u32, max_p_moving: u32, max_s: u32, max_s_shadow: u32, environment_per_primary: f32, width_pixel_limit: u32,
) -> DefocusRates {
    let omega_pix_mu = defocus_omega_mu(omega_pix, mu, mode, omega_pix);
    if (!hit) {
        return DefocusRates(omega_pix_mu, omega_pix_mu, omega_pix_mu, 0.0, 1u, 1u, 1u, 1u, 1u, omega_pix_mu, 1u, 1u);
    }
    let l_p = pixel_scale * depth;
    let d = defocus_omega_mu(defocus_omega_defocus(r_min, omega_pix), mu, mode, omega_pix);
    let sd = defocus_omega_mu(defocus_omega_direct(r_min, s_min, l_p, light_half_width, omega_pix), mu, mode, omega_pix);
    let si = defocus_omega_mu(defocus_omega_indirect(r_min, z_min, l_p, omega_v, omega_pix), mu, mode, omega_pix);
    let cap_p = defocus_primary_cap(max_p, max_p_moving, 1.0 + v_p * d);
    let p = defocus_strata(defocus_primary_rate(d, r_max, omega_pix) * defocus_time_factor(v_p, d), cap_p);
    let pp = p * p;
    let qdf = defocus_secondary_strata(
        defocus_direct_rate(sd, r_max, s_max, l_p, light_half_width, omega_pix) * defocus_time_factor(v_s, sd), p, max_s_shadow);
    let qdc = defocus_secondary_strata(
        defocus_direct_rate(d, r_max, s_max, l_p, light_half_width, omega_pix) * defocus_time_factor(v_p + v_s, d), p, max_s_shadow);
    let qif = defocus_secondary_strata(defocus_indirect_rate(si, r_max, z_max, l_p, omega_v, omega_pix), p, max_s);
    let qic = defocus_secondary_strata(
        defocus_indirect_rate(d, r_max, z_max, l_p, omega_v, omega_pix) * defocus_time_factor(v_p, d), p, max_s);
    let se = defocus_omega_mu(defocus_omega_environment(r_min, bandlimit, l_p, omega_pix), mu, mode, omega_pix);
    let qef = defocus_secondary_strata(defocus_environment_rate(se, r_max, environment_per_primary, omega_pix), p, max_s);
    let qec = defocus_secondary_strata(
        defocus_environment_rate(d, r_max, environment_per_primary, omega_pix) * defocus_time_factor(v_p, d), p, max_s);
    return DefocusRates(
        defocus_screen_width(d, r_min, mu, width_pixel_limit), sd, si, l_p, pp, pp * qdf * qdf, pp * qdc * qdc, pp * qif * qif, pp * qic * qic, se, pp * qef * qef, pp * qec * qec,
    );
}

// SepDir / SepInd (eq. 5.30), compared squared: ‖L − k E‖² < threshold².
fn defocus_separable(l: vec3<f32>, k: vec3<f32>, e: vec3<f32>, threshold: f32) -> bool {
    let d = vec3<f32>(l.x - k.x * e.x, l.y - k.y * e.y, l.z - k.z * e.z);
    let err2 = d.x * d.x + d.y * d.y + d.z * d.z;
    return err2 < threshold * threshold;
}

// The irradiance-weighted texture L / Ē per channel where Ē > 0, else k (formulas.rs `weighted_texture`).
fn defocus_weighted_texture(l: vec3<f32>, k: vec3<f32>, e_raw: vec3<f32>) -> vec3<f32> {
    var out = k;
    for (var c = 0; c < 3; c++) {
        let w = l[c] / e_raw[c];
        if (e_raw[c] > 0.0 && is_finite(w)) {
            out[c] = w;
        }
    }
    return out;
}

// One component's term of eq. 5.32: k E (filtered E) where factored, else L.
fn defocus_compose_term(l: vec3<f32>, k: vec3<f32>, e: vec3<f32>, factored: bool) -> vec3<f32> {
    if (factored) {
        return vec3<f32>(k.x * e.x, k.y * e.y, k.z * e.z);
    }
    return l;
}

// A width Ω as the Ch. 5 filters' Gaussian standard deviation in pixels, 1/(√32 Ω) (kernels.rs `sigma_px`).
fn defocus_sigma_px(omega: f32) -> f32 {
    return 1.0 / (5.656854 * omega);
}
