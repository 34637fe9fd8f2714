// shadows_formulas.wgsl — the WGSL mirror of effects/src/shadows/formulas.rs (thesis eqs. 3.4,
// 3.13, 3.21), same operation order. Included by shadows_bandwidth.wgsl and shadows_rates.wgsl.

// s_min, s_max (eq. 3.4)
fn shadows_slopes(d1: f32, d2_min: f32, d2_max: f32) -> vec2<f32> {
    return vec2<f32>(d1 / d2_max - 1.0, d1 / d2_min - 1.0);
}

// β (eq. 3.13)
fn shadows_filter_beta(sigma: f32, s_min: f32, d: f32, mu: f32, alpha: f32, k: f32) -> f32 {
    return rmax(sigma * s_min, d / alpha) / (k * mu);
}

// n(μ) (eq. 3.21); +inf when s_min ≤ 0 or not finite.
fn shadows_samples_per_pixel(s_min: f32, s_max: f32, d: f32, sigma: f32, mu: f32, alpha: f32) -> f32 {
    if (s_min <= 0.0 || !is_finite(s_min)) {
        return inf();
    }
    let a_p = d * d;
    let a_l = (2.0 * sigma) * (2.0 * sigma);
    let first = 1.0 + mu * s_max / s_min;
    let second = mu * (2.0 / s_min) * sqrt(a_p / a_l) + alpha / (1.0 + s_min);
    return 4.0 * first * first * second * second;
}
