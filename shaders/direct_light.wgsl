// direct.light — light sampling with the counter-based RNG and CMJ stratification, per-pixel counts,
// `previous` continuation and occluder statistics; mirrors backends/src/kernels/direct.rs.
#include "common.wgsl"
#include "rng.wgsl"
#include "bvh.wgsl"
#include "sampling.wgsl"

const RAY_EPSILON: f32 = 1e-4;

struct LightSample {
    value: vec3<f32>,
    occluded: bool,
    distance: f32,
}

fn light_sample(l: Light, x: vec3<f32>, n: vec3<f32>, u: vec2<f32>, use_centre: bool, factor: vec3<f32>, want_distance: bool) -> LightSample {
    var r = LightSample(vec3<f32>(0.0), false, 0.0);
    let y = light_sample_point(l, u);
    let to = y - x;
    let r2 = dot3(to, to);
    let dir = to / sqrt(r2);
    let cos_x = dot3(n, dir);
    let ln = l.normal_area.xyz;
    var cos_y = dot3(ln, -dir);
    if (l.two_sided != 0u) {
        cos_y = abs(cos_y);
    }
    if (cos_x <= 0.0 || cos_y <= 0.0) {
        return r;
    }
    let origin = x + n * (RAY_EPSILON * params.extent);
    let seg = y - origin;
    let seg_len = length3(seg);
    let ray_dir = seg / seg_len;
    let tmax = seg_len * bitcast<f32>(0x3f7ff972u); // (1.0 - 1e-4) in f32
    if (want_distance) {
        let hit = scene_intersect(origin, ray_dir, 0.0, tmax);
        if (hit.hit) {
            let p = origin + ray_dir * hit.t;
            r.occluded = true;
            r.distance = abs(dot3(l.centre_sigma.xyz - p, ln));
            return r;
        }
    } else if (scene_occluded(origin, ray_dir, 0.0, tmax)) {
        return r;
    }
    if (use_centre) {
        r.value = factor;
    } else {
        r.value = l.radiance.xyz * (cos_x * cos_y / r2 * l.normal_area.w / PI_F32);
    }
    return r;
}

fn light_centre_factor(l: Light, x: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let to = l.centre_sigma.xyz - x;
    let r2 = dot3(to, to);
    let dir = to / sqrt(r2);
    let cos_x = rmax(dot3(n, dir), 0.0);
    var cos_y = dot3(l.normal_area.xyz, -dir);
    if (l.two_sided != 0u) {
        cos_y = abs(cos_y);
    } else {
        cos_y = rmax(cos_y, 0.0);
    }
    return l.radiance.xyz * (cos_x * cos_y / r2 * l.normal_area.w / PI_F32);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let want_stats = occlusion_bound();
    var prev = vec4<f32>(0.0);
    if (previous_bound()) {
        prev = previous_at(i);
    }
    let resume = chunk_resumes();
    if (position_at(i).w == 0.0) {
        if (resume) {
            return;
        }
        estimate_put(i, prev);
        if (want_stats) {
            occlusion_put(i, vec4<f32>(0.0));
        }
        return;
    }
    let x = position_at(i).xyz;
    let n = normal_at(i).xyz;
    var target_count = params.count;
    if (rays_per_pixel_bound()) {
        target_count = rays_per_pixel_at(i);
    }
    let done = u32(prev.w);
    let extra = select(0u, target_count - done, target_count > done);
    // This dispatch's samples (all of them unless the backend chunks the pass) and, when it
    // continues earlier chunks, their raw sum, count and occluder statistics (common.wgsl).
    var partial = prev;
    if (resume) {
        partial = estimate_at(i);
    }
    var run = running_start(partial, extra, resume);
    if (!run.has_work) {
        return; // finished in an earlier chunk
    }
    let s_begin = frame.chunk_begin;
    var bad = 0u;
    var d1 = 0.0;
    var d2_min = inf();
    var d2_max = 0.0;
    var occluded = 0u;
    if (resume) {
        if (want_stats) {
            let o = occlusion_at(i);
            d1 = o.x;
            occluded = u32(o.w);
            if (occluded > 0u) {
                d2_min = o.y;
            }
            d2_max = o.z;
        }
    }
    var first = 0u;
    var end = params.light_count;
    if (params.light >= 0) {
        first = u32(params.light);
        end = first + 1u;
    }
    let n_lights = end - first;
    for (var li = first; li < end; li = li + 1u) {
        let l = area_light(li);
        if (want_stats) {
            d1 = abs(dot3(l.centre_sigma.xyz - x, l.normal_area.xyz));
        }
        let key = rng_key(frame.seed, pixel_id(gid), rng_substream(params.stream, li));
        let use_centre = params.light_centre != 0u;
        var factor = vec3<f32>(0.0);
        if (use_centre) {
            factor = light_centre_factor(l, x, n);
        }
        var s = s_begin;
        for (; s < run.end; s = s + 1u) {
            var u: vec2<f32>;
            if (params.stratified != 0u) {
                u = rng_stratified2(key, s, extra, DIM_LIGHT);
            } else {
                u = rng_uniform2(key, s, DIM_LIGHT);
            }
            let ls = light_sample(l, x, n, u, use_centre, factor, want_stats);
            if (ls.occluded) {
                occluded = occluded + 1u;
                d2_min = rmin(d2_min, ls.distance);
                d2_max = rmax(d2_max, ls.distance);
            }
            if (is_finite3(ls.value)) {
                run.sum = run.sum + ls.value;
                run.valid = run.valid + 1u;
            } else {
                bad = bad + 1u;
            }
        }
        count_cut_loop(s, run.end);
    }
    // Each light took the same samples: the estimate's count is per light.
    estimate_put(i, running_finish(run, extra, prev, f32(run.valid) / f32(max(n_lights, 1u)), partial));
    if (occluded == 0u) {
        d2_min = 0.0;
    }
    if (want_stats) {
        occlusion_put(i, vec4<f32>(d1, d2_min, d2_max, f32(occluded)));
    }
    let rays = select(0u, run.end - s_begin, run.end > s_begin) * n_lights;
    if (rays > 0u) {
        atomicAdd(&counters[COUNTER_SHADOW], rays);
    }
    if (bad > 0u) {
        atomicAdd(&counters[COUNTER_NON_FINITE], bad);
    }
}
