// environment.bandwidth — eqs. 6.13, 6.17, 6.18 per pixel, the heatmap widths and the adaptive
// look-ups; mirrors effects/src/environment/kernels.rs (`pixel_stats`, `pixel_outputs`).
#include "common.wgsl"
#include "environment_formulas.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let env = environment_at(i);
    var z_min = 0.0;
    if (depth_bound()) {
        let d = depth_at(i);
        if (d.z > 0.0) {
            z_min = d.x;
        }
    }
    let footprint = normal_at(i).w;
    let b = env_pixel_bandwidths(curvature_at(i), env.x, env.y, z_min, params.b_e, params.mu,
        env_window_bandwidth(footprint, params.max_radius));
    var shown = b.direct_diffuse;
    if (env.y > 0.0) {
        shown = b.direct_glossy;
    }
    let sigma = vec2<f32>(env_sigma_pixels(shown.x, footprint, params.max_radius), env_sigma_pixels(shown.y, footprint, params.max_radius));
    direct_diffuse_put(i, b.direct_diffuse);
    direct_glossy_put(i, b.direct_glossy);
    indirect_diffuse_put(i, b.indirect_diffuse);
    indirect_glossy_put(i, b.indirect_glossy);
    bandwidth_put(i, 0.5 * (shown.x + shown.y));
    bandlimit_put(i, rmax(shown.x, shown.y));
    filter_width_put(i, 0.5 * (sigma.x + sigma.y));
    // AdaptiveLookUps::applies: 0 off, 1 glossy receivers, 2 all.
    var rays = params.base;
    if (params.adaptive == 2u || (params.adaptive == 1u && env.y > 0.0)) {
        // The widths at `count_mu` times the bandwidths (kernels.rs `pixel_outputs`).
        let sigma_count = vec2<f32>(env_sigma_pixels(shown.x * params.count_mu, footprint, params.max_radius),
            env_sigma_pixels(shown.y * params.count_mu, footprint, params.max_radius));
        rays = env_look_ups(params.base, sigma_count, params.sigma_ref, params.max_rays);
    }
    rays_put(i, rays);
}
