// radiance_filter.sample — `count` jittered paths per pixel (one per frame; through the camera's lens), their Stats of
// direct light and own indirect estimate, and path 0's radiance sample at the first vertex (seed 002
// Sec. 4.3.1, steps 1-2); mirrors effects/src/radiance_filter/kernels.rs (RadianceSample::run_cpu)
// with the same RNG calls and dimensions, on the shared first_vertex.wgsl.
// Chunked (WgslSource::chunked): a resuming dispatch continues the running statistics it left; the
// radiance sample is path 0's, written by the first chunk.
#include "common.wgsl"
#include "rng.wgsl"
#include "bvh.wgsl"
#include "sampling.wgsl"
#include "camera_path.wgsl"
#include "hemisphere.wgsl"
#include "indirect_path.wgsl"
#include "first_vertex.wgsl"
#include "pixel_filter_formulas.wgsl"
#include "radiance_filter_formulas.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let pixel = pixel_id(gid);
    let xy = global_xy(gid);
    let c = path_camera();
    let key = rng_key(frame.seed, pixel, params.stream);
    var st = PfStats(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, 0.0);
    if (chunk_resumes()) {
        st = pf_stats(lv_at(i), hv_at(i));
    } else {
        point_put(i, vec4<f32>(0.0));
        normal_put(i, vec4<f32>(0.0));
        albedo_put(i, vec4<f32>(0.0));
        direction_put(i, vec4<f32>(0.0));
        incident_put(i, vec4<f32>(0.0));
    }
    let end = chunk_end_of(params.count);
    var bad = 0u;
    var j = frame.chunk_begin;
    for (; j < end; j = j + 1u) {
        let ray = path_camera_ray(c, key, j, xy);
        let v = first_vertex(ray.origin, ray.dir, key, j);
        let finite = is_finite3(v.direct) && is_finite3(v.indirect);
        if (finite) {
            st = pf_combine(st, PfStats(v.direct, v.indirect, 1.0, 0.0));
        } else {
            bad = bad + 1u;
        }
        if (j == 0u && v.hit) {
            point_put(i, vec4<f32>(v.position, v.distance));
            normal_put(i, vec4<f32>(v.normal, f32(v.material)));
            albedo_put(i, vec4<f32>(v.albedo, 0.0));
            if (v.sampled && finite && is_finite3(v.incident)) {
                direction_put(i, vec4<f32>(v.wi, 1.0));
                var bounce = RF_NO_BOUNCE_HIT;
                if (v.bounce_hit) {
                    bounce = v.bounce_distance;
                }
                incident_put(i, vec4<f32>(v.incident, bounce));
            }
        }
    }
    count_cut_loop(j, end);
    lv_put(i, vec4<f32>(st.lv, st.n));
    hv_put(i, vec4<f32>(st.u, st.m2));
    if (end > frame.chunk_begin) {
        atomicAdd(&counters[COUNTER_PRIMARY], end - frame.chunk_begin);
    }
    atomicAdd(&counters[COUNTER_SHADOW], rays_shadow);
    atomicAdd(&counters[COUNTER_SECONDARY], rays_secondary);
    atomicAdd(&counters[COUNTER_NON_FINITE], bad);
}
