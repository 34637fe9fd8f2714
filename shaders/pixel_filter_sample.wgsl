// pixel_filter.sample — `count` jittered paths per pixel (through the lens where the camera has one) (one per frame in progressive mode),
// split into L_lv and L_u (seed 002 Sec. 3.3, Fig. 3.1), accumulated with Stats::combine; mirrors
// effects/src/pixel_filter/kernels/sample.rs (PixelSample::run_cpu, path_sample) with the same RNG calls
// and dimensions, on the shared first_vertex.wgsl (next_event, trace_path_split of indirect_path.wgsl).
// Chunked (WgslSource::chunked): a resuming dispatch continues the running statistics it left.
#include "common.wgsl"
#include "rng.wgsl"
#include "bvh.wgsl"
#include "sampling.wgsl"
#include "camera_path.wgsl"
#include "hemisphere.wgsl"
#include "indirect_path.wgsl"
#include "first_vertex.wgsl"
#include "pixel_filter_formulas.wgsl"

const SPLIT_INDIRECT: u32 = 0u;
const SPLIT_CAUSTICS: u32 = 1u;
const SPLIT_ALL: u32 = 2u;
const SPLIT_DIRECT: u32 = 3u;

struct SplitSample {
    lv: vec3<f32>,
    hv: vec3<f32>,
}

fn path_sample(origin: vec3<f32>, dir: vec3<f32>, key: u32, j: u32) -> SplitSample {
    let v = first_vertex(origin, dir, key, j);
    if (!v.hit) {
        if (params.split == SPLIT_ALL) {
            return SplitSample(vec3<f32>(0.0), v.direct);
        }
        return SplitSample(v.direct, vec3<f32>(0.0));
    }
    if (params.split == SPLIT_ALL) {
        return SplitSample(vec3<f32>(0.0), v.direct + v.indirect);
    }
    if (params.split == SPLIT_CAUSTICS) {
        return SplitSample(v.direct + (v.indirect - v.caustic), v.caustic);
    }
    // SPLIT_INDIRECT, or SPLIT_DIRECT (its paths stop at the first vertex: indirect is 0).
    return SplitSample(v.direct, v.indirect);
}

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
    }
    let end = chunk_end_of(params.count);
    var bad = 0u;
    var j = frame.chunk_begin;
    for (; j < end; j = j + 1u) {
        let ray = path_camera_ray(c, key, j, xy);
        let s = path_sample(ray.origin, ray.dir, key, j);
        if (is_finite3(s.lv) && is_finite3(s.hv)) {
            st = pf_combine(st, PfStats(s.lv, s.hv, 1.0, 0.0));
        } else {
            bad = bad + 1u;
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
