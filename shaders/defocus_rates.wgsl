// defocus.rates — widths (eqs. 5.7, 5.18, 5.22, 5.29) and rounded counts (eqs. 5.24–5.28) per pixel;
// mirrors effects/src/defocus/kernels.rs `Rates` with the formulas of defocus_formulas.wgsl.
#include "common.wgsl"
#include "shadows_formulas.wgsl"
#include "defocus_formulas.wgsl"
#include "velocity.wgsl"
#include "motion_formulas.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let lens = lens_at(i);
    var s = vec2<f32>(0.0);
    let occ = occlusion_at(i);
    let occluded = occlusion_bound() && occ.w > 0.0;
    if (occluded) {
        s = shadows_slopes(occ.x, occ.y, occ.z);
    }
    // Speeds for the counts where the paths sample the shutter (kernels.rs pixel_stats).
    var v_p = 0.0;
    if (velocity_bound()) {
        v_p = motion_fastest(velocity_at(i));
    }
    var v_s = 0.0;
    if (shadow_velocity_bound() && occluded) {
        v_s = motion_fastest(shadow_velocity_at(i));
    }
    var z = vec2<f32>(0.0);
    let refl = reflectors_at(i);
    if (reflectors_bound() && refl.z > 0.0) {
        z = refl.xy;
    }
    // The environment's Ch. 6 bandwidth (formulas.rs bandlimit_of).
    var bandlimit = 0.0;
    if (bandlimit_bound()) {
        bandlimit = defocus_bandlimit(bandlimit_at(i));
    }
    let r = defocus_pixel_rates(
        lens.x, lens.y, lens.z, lens.w > 0.0, s.x, s.y, z.x, z.y, bandlimit, v_p, v_s,
        params.mu, params.mode, params.omega_pix, params.pixel_scale, params.light_half_width, params.omega_v,
        params.max_p, params.max_p_moving, params.max_s, params.max_s_shadow, params.environment_per_primary, params.width_pixel_limit,
    );
    // The node's screen_scale on eq. 5.33's width, screen_scale_factored where the flag is set
    // (kernels.rs Rates::run_cpu; 1 = the thesis).
    let flag_set = flag_bound() && flag_at(i) != 0u;
    let omega_defocus = select(params.screen_scale, params.screen_scale_factored, flag_set) * r.omega_defocus;
    omega_defocus_put(i, omega_defocus);
    // The risk-based width's wider filter: screen_scale_wide on every pixel (kernels.rs Row).
    omega_defocus_wide_put(i, params.screen_scale_wide * r.omega_defocus);
    pixel_length_put(i, r.pixel_length);
    n_primary_put(i, r.n_primary);
    sigma_defocus_put(i, defocus_sigma_px(omega_defocus));
    // A component's pass (params.component: 0 direct, 1 indirect, 2 environment; kernels.rs
    // RateComponent): its width, and the count the pixel takes — factored where its (median-filtered)
    // flag is set, else combined.
    var omega = r.omega_direct;
    var n_f = r.n_direct_factored;
    var n_c = r.n_direct_combined;
    if (params.component == 1u) {
        omega = r.omega_indirect;
        n_f = r.n_indirect_factored;
        n_c = r.n_indirect_combined;
    } else if (params.component == 2u) {
        omega = r.omega_environment;
        n_f = r.n_environment_factored;
        n_c = r.n_environment_combined;
    }
    omega_put(i, omega);
    n_put(i, select(n_c, n_f, flag_set));
    sigma_put(i, defocus_sigma_px(omega));
}
