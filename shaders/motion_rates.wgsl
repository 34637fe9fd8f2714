// motion.rates — App. B widths and counts per pixel (eqs. B.1–B.3, 5.18, 5.22, 5.25, 5.26 as read in
// effects/src/motion/formulas.rs); mirrors effects/src/motion/kernels.rs `Rates`.
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
    let velocity = velocity_at(i);
    let shadow = shadow_velocity_at(i);
    let occ = occlusion_at(i);
    let occluded = occlusion_bound() && occ.w > 0.0;
    var s = vec2<f32>(0.0);
    if (occluded) {
        s = shadows_slopes(occ.x, occ.y, occ.z);
    }
    var z = vec2<f32>(0.0);
    let refl = reflectors_at(i);
    if (reflectors_bound() && refl.z > 0.0) {
        z = refl.xy;
    }
    let depth = depth_at(i);
    let k = MotionConstants(
        params.mu, params.mode, params.omega_pix, params.omega_t, params.pixel_scale, params.light_half_width, params.omega_v,
        params.max_p, params.max_s, params.max_s_shadow, params.multi_paths, params.environment_per_primary,
    );
    // The environment's Ch. 6 bandwidth (formulas.rs bandlimit_of).
    var bandlimit = 0.0;
    if (bandlimit_bound()) {
        bandlimit = defocus_bandlimit(bandlimit_at(i));
    }
    let r = motion_pixel_rates(
        velocity, shadow, occluded && shadow_velocity_bound(), depth.w > 0.0, depth.z, s.x, s.y, z.x, z.y, bandlimit, k,
    );
    texture_motion_put(i, vec4<f32>(velocity.x, velocity.y, r.omega_texture, motion_sigma(r.omega_texture)));
    shadow_motion_put(i, vec4<f32>(shadow.x, shadow.y, r.omega_shadow, motion_sigma(r.omega_shadow)));
    n_primary_put(i, r.n_primary);
    pixel_length_put(i, r.pixel_length);
    sigma_texture_put(i, motion_sigma(r.omega_texture));
    // A component's pass (params.component: 0 direct, 1 indirect, 2 environment; kernels.rs select).
    var omega = r.omega_direct;
    var n = r.n_direct;
    if (params.component == 1u) {
        omega = r.omega_indirect;
        n = r.n_indirect;
    } else if (params.component == 2u) {
        omega = r.omega_environment;
        n = r.n_environment;
    }
    omega_put(i, omega);
    n_put(i, n);
    sigma_put(i, motion_sigma(omega));
}
