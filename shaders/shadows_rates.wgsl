// shadows.rates — total shadow rays per pixel (eq. 3.21) clamped to [initial, max], rounded up to a
// multiple of initial; mirrors effects/src/shadows/kernels.rs `Rates` and formulas.rs `whole_multiples`.
#include "common.wgsl"
#include "shadows_formulas.wgsl"

// n rounded up to a multiple of `initial` (saturating).
fn whole_multiples(n: u32) -> u32 {
    let k = n / params.initial + select(0u, 1u, n % params.initial != 0u);
    if (k > 0xffffffffu / params.initial) {
        return 0xffffffffu;
    }
    return k * params.initial;
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let occ = occlusion_at(i);
    if (!(occ.w > 0.0)) {
        rays_per_pixel_put(i, whole_multiples(params.initial));
        return;
    }
    let s = shadows_slopes(occ.x, occ.y, occ.z);
    let n = shadows_samples_per_pixel(s.x, s.y, normal_at(i).w, params.sigma, params.mu, params.alpha);
    if (is_finite(n)) {
        // `as u32` saturates (NaN → 0); n ≥ 0 here.
        let c = ceil(n);
        var v = params.cap;
        if (c < 4294967040.0) {
            v = u32(max(c, 0.0));
        }
        rays_per_pixel_put(i, whole_multiples(clamp(v, params.initial, params.cap)));
    } else {
        rays_per_pixel_put(i, whole_multiples(params.cap));
    }
}
