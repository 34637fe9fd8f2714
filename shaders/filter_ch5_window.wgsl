// The window and rejection constants both Ch. 5 filters share (filter.irradiance, eq. 5.31;
// filter.defocus, eq. 5.33); mirrors the constants and `window_radius` of
// backends/src/kernels/filter_ch5.rs.

const FILTER_SHARPNESS: f32 = 16.0;
const REJECT_EXPONENT: f32 = 4.6051702;
const REJECT_RADIUS: f32 = 0.5364915;

fn valid_width(w: f32) -> bool {
    return w > 0.0 && is_finite(w);
}

// ceil(0.5365 / Ω), at most the cap (filter_ch5.rs window_radius).
fn window_radius(omega: f32, cap: i32) -> i32 {
    let r = REJECT_RADIUS / omega;
    if (!(r < f32(cap))) {
        return cap;
    }
    return max(i32(ceil(r)), 0);
}
