// pixel_filter.sample — `count` jittered pinhole paths per pixel (one per frame in progressive mode),
// split into L_lv and L_u (seed 002 Sec. 3.3, Fig. 3.1), accumulated with Stats::combine; mirrors
// backends/src/kernels/pixel_filter.rs (PixelSample::run_cpu, path_sample) with the same RNG calls
// and dimensions, on the shared estimators of indirect_path.wgsl (next_event, trace_path_split).
// Chunked (WgslSource::chunked): a resuming dispatch continues the running statistics it left.
#include "common.wgsl"
#include "rng.wgsl"
#include "bvh.wgsl"
#include "sampling.wgsl"
#include "camera.wgsl"
#include "hemisphere.wgsl"
#include "indirect_path.wgsl"
#include "pixel_filter_formulas.wgsl"

const SPLIT_INDIRECT: u32 = 0u;
const SPLIT_CAUSTICS: u32 = 1u;
const SPLIT_ALL: u32 = 2u;

struct SplitSample {
    lv: vec3<f32>,
    hv: vec3<f32>,
}

fn path_sample(origin: vec3<f32>, dir: vec3<f32>, key: u32, j: u32) -> SplitSample {
    let hit = scene_intersect(origin, dir, 0.0, inf());
    if (!hit.hit) {
        let bg = scene_background(dir);
        if (params.split == SPLIT_ALL) {
            return SplitSample(vec3<f32>(0.0), bg);
        }
        return SplitSample(bg, vec3<f32>(0.0));
    }
    let sp = surface(hit.triangle, hit.b1, hit.b2, dir);
    let x = sp.position;
    let n = sp.shading_normal;
    let wo = -dir;
    let mat = material(sp.material);
    let kd = albedo(sp);
    let ks = mat.specular;
    let m = mat.phong_exponent;
    let emitted = emission(sp);
    let direct = next_event(x, n, wo, kd, ks, m, key, j, 0u);
    let is_glossy = m > 0.0 && max_element3(ks) > 0.0;
    let wd = rmax(weight_of(kd), 0.0);
    var ws = 0.0;
    if (is_glossy) {
        ws = rmax(weight_of(ks), 0.0);
    }
    var indirect = vec3<f32>(0.0);
    var caustic = vec3<f32>(0.0);
    if (wd + ws > 0.0) {
        let pd = wd / (wd + ws);
        let u = rng_uniform2(key, j, DIM_BSDF);
        var wi: vec3<f32>;
        if (rng_uniform(key, j, LOBE_SELECT) < pd) {
            wi = sample_diffuse(n, u);
        } else {
            wi = sample_glossy(params.lobe, m, n, wo, u).wi;
        }
        let cos_i = dot3(wi, n);
        if (cos_i > 0.0) {
            let fd = kd * FRAC_1_PI_F32;
            var f = fd;
            var pdf = pd * cos_i * FRAC_1_PI_F32;
            if (is_glossy) {
                f = f + ks * glossy_brdf(params.lobe, m, n, wo, wi);
                pdf = pdf + (1.0 - pd) * glossy_pdf(params.lobe, m, n, wo, wi);
            }
            if (pdf > 0.0) {
                let r = trace_path_split(x, n, wi, key, j);
                indirect = r.value * (f * (cos_i / pdf));
                caustic = r.caustic * (fd * (cos_i / pdf));
            }
        }
    }
    if (params.split == SPLIT_ALL) {
        return SplitSample(vec3<f32>(0.0), emitted + direct + indirect);
    }
    if (params.split == SPLIT_CAUSTICS) {
        return SplitSample(emitted + direct + (indirect - caustic), caustic);
    }
    return SplitSample(emitted + direct, indirect);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let pixel = pixel_id(gid);
    let xy = pixel_xy(gid);
    let c = CameraModel(params.cam_position, params.cam_right, params.cam_up, params.cam_forward, params.cam_tan_half,
        params.cam_aperture, params.cam_focus_distance, params.cam_gaussian);
    let key = rng_key(frame.seed, pixel, params.stream);
    var st = PfStats(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, 0.0);
    if (chunk_resumes()) {
        st = pf_stats(lv_at(i), hv_at(i));
    }
    let end = chunk_end_of(params.count);
    var bad = 0u;
    var j = frame.chunk_begin;
    for (; j < end; j = j + 1u) {
        let jit = rng_uniform2(key, j, DIM_PIXEL);
        let ray = camera_ray(c, vec2<f32>(f32(xy.x) + jit.x, f32(xy.y) + jit.y), vec2<f32>(0.5));
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
