// direct.light — light sampling with the counter-based RNG and CMJ stratification, per-pixel counts,
// `previous` continuation and occluder statistics; mirrors backends/src/kernels/direct.rs.
#include "common.wgsl"
#include "rng.wgsl"
#include "bvh.wgsl"
#include "sampling.wgsl"

#include "light_sample.wgsl"

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
        let l = scene_light_at(li);
        if (want_stats) {
            d1 = abs(dot3(l.centre_sigma.xyz - x, l.normal_area.xyz));
        }
        let key = rng_key(frame.seed, pixel_id(gid), rng_substream(params.stream, li));
        let use_centre = params.form_factor == 1u;
        var factor = vec3<f32>(0.0);
        if (use_centre) {
            factor = light_centre_factor(l, x, n);
        }
        var s = s_begin;
        for (; s < run.end; s = s + 1u) {
            var u: vec2<f32>;
            if (params.sampling == 0u) {
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
