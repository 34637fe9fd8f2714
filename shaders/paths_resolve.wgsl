// paths.resolve — a PathRecord's sums as means; mirrors backends/src/kernels/paths.rs (resolve,
// PathRecord::{radiance, lens_position, lens_normal}).
#include "common.wgsl"

fn mean_of(s: vec3<f32>, over: f32) -> vec3<f32> {
    if (over > 0.0) {
        return s / over;
    }
    return vec3<f32>(0.0);
}

// paths.rs velocity_stats: mean (0 where `over` is 0) and per-axis range.
fn velocity_stats(sum: vec2<f32>, over: f32, vmin: vec2<f32>, vmax: vec2<f32>) -> vec4<f32> {
    var mean = vec2<f32>(0.0);
    if (over > 0.0) {
        mean = vec2<f32>(sum.x / over, sum.y / over);
    }
    return vec4<f32>(mean.x, mean.y, vmax.x - vmin.x, vmax.y - vmin.y);
}

fn hit_mean(r: PathRecord, s: f32) -> f32 {
    if (r.hit_weight > 0.0) {
        return s / r.hit_weight;
    }
    return 0.0;
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let r = record_at(i);
    let w = r.weight;
    let radiance = mean_of(r.l_direct, r.w_direct) + mean_of(r.l_diffuse, r.w_diffuse) + mean_of(r.l_glossy, r.w_glossy)
        + mean_of(r.l_env_diffuse, r.w_env_diffuse) + mean_of(r.l_env_glossy, r.w_env_glossy) + mean_of(r.emission, w);
    radiance_put(i, radiance);
    l_direct_put(i, mean_of(r.l_direct, r.w_direct));
    k_direct_put(i, mean_of(r.k_direct, r.w_direct));
    e_direct_put(i, mean_of(r.e_direct, r.w_direct - r.w_direct_missed));
    l_diffuse_put(i, mean_of(r.l_diffuse, r.w_diffuse));
    k_diffuse_put(i, mean_of(r.k_diffuse, r.w_diffuse));
    e_diffuse_put(i, mean_of(r.e_diffuse, r.w_diffuse - r.w_diffuse_missed));
    l_glossy_put(i, mean_of(r.l_glossy, r.w_glossy));
    k_glossy_put(i, mean_of(r.k_glossy, r.w_glossy));
    e_glossy_put(i, mean_of(r.e_glossy, r.w_glossy - r.w_glossy_missed));
    emission_put(i, mean_of(r.emission, w));
    var position = vec4<f32>(0.0);
    var normal = vec4<f32>(0.0);
    var defocus = vec4<f32>(0.0);
    if (r.hits > 0u) {
        let lambda = mean_of(r.position, r.hit_weight);
        let n = normalize_or_zero3(mean_of(r.normal, r.hit_weight));
        let to = lambda - params.camera;
        let t = length3(to);
        let d = to / t;
        let c = rmax(abs(dot3(n, -d)), 0.05);
        let footprint = t * params.pixel_angle / sqrt(c);
        let z = hit_mean(r, r.depth);
        position = vec4<f32>(lambda, f32(r.object));
        normal = vec4<f32>(n, footprint);
        defocus = vec4<f32>(r.r_min, r.r_max, z, 2.0 * z * params.tan_half / f32(max(frame.full_height, 1u)));
    }
    position_put(i, position);
    normal_put(i, normal);
    defocus_put(i, defocus);
    occlusion_put(i, vec4<f32>(hit_mean(r, r.d1), r.d2_min, r.d2_max, f32(r.occluded)));
    depth_put(i, vec4<f32>(r.z_min, r.z_max, f32(r.indirect_hits), f32(r.indirect_rays)));
    counts_put(i, vec4<f32>(f32(r.paths), f32(r.shadow), f32(r.diffuse_samples + r.glossy_samples), f32(r.non_finite)));
    direct_put(i, vec4<f32>(mean_of(r.e_direct, r.w_direct - r.w_direct_missed), f32(r.shadow)));
    diffuse_put(i, vec4<f32>(mean_of(r.e_diffuse, r.w_diffuse - r.w_diffuse_missed), f32(r.diffuse_samples)));
    glossy_put(i, vec4<f32>(mean_of(r.e_glossy, r.w_glossy - r.w_glossy_missed), f32(r.glossy_samples)));
    velocity_put(i, velocity_stats(r.vp_sum, r.hit_weight, r.vp_min, r.vp_max));
    shadow_velocity_put(i, velocity_stats(r.vs_sum, f32(r.occluded), r.vs_min, r.vs_max));
    l_env_diffuse_put(i, mean_of(r.l_env_diffuse, r.w_env_diffuse));
    k_env_diffuse_put(i, mean_of(r.k_env_diffuse, r.w_env_diffuse));
    e_env_diffuse_put(i, mean_of(r.e_env_diffuse, r.w_env_diffuse - r.w_env_missed));
    l_env_glossy_put(i, mean_of(r.l_env_glossy, r.w_env_glossy));
    k_env_glossy_put(i, mean_of(r.k_env_glossy, r.w_env_glossy));
    e_env_glossy_put(i, mean_of(r.e_env_glossy, r.w_env_glossy - r.w_env_missed));
    environment_put(i, vec4<f32>(r.env_occluder, hit_mean(r, r.exponent), f32(r.env_samples), f32(r.env_occluded)));
    direct_unshadowed_put(i, vec4<f32>(mean_of(r.u_direct, r.w_direct - r.w_direct_missed), f32(r.shadow)));
}
