// indirect.sample — path tracing of indirect light (diffuse and glossy components) or AO at each
// pixel's surface point, with next-event estimation at every path vertex, per-pixel counts,
// `previous_*` continuation and first-hit statistics; mirrors backends/src/kernels/indirect.rs
// (next_event, trace_path, IndirectSample::run_cpu) with the same RNG calls and dimensions.
#include "common.wgsl"
#include "rng.wgsl"
#include "bvh.wgsl"
#include "sampling.wgsl"
#include "hemisphere.wgsl"

#include "indirect_path.wgsl"

// Rust's `x as u32` (saturating; NaN → 0).
fn f32_to_u32_sat(x: f32) -> u32 {
    if (!(x > 0.0)) {
        return 0u;
    }
    if (x >= 4294967296.0) {
        return 0xffffffffu;
    }
    return u32(x);
}

// First-hit statistics over the hemisphere rays.
var<private> z_min: f32;
var<private> z_max: f32 = 0.0;
var<private> hits: u32 = 0u;
var<private> traced: u32 = 0u;

fn record(r: PathResult) {
    traced = traced + 1u;
    if (r.hit) {
        hits = hits + 1u;
        z_min = rmin(z_min, r.first);
        z_max = rmax(z_max, r.first);
    }
}

fn sample_2d(key: u32, s: u32, n: u32) -> vec2<f32> {
    if (params.stratified != 0u) {
        return rng_stratified2(key, s, n, DIM_BSDF);
    }
    return rng_uniform2(key, s, DIM_BSDF);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let want_glossy = glossy_bound() && specular_bound() && params.ao == 0u;
    var pd = vec4<f32>(0.0);
    if (previous_diffuse_bound()) {
        pd = previous_diffuse_at(i);
    }
    var pg = vec4<f32>(0.0);
    if (previous_glossy_bound()) {
        pg = previous_glossy_at(i);
    }
    var out_d = pd;
    var out_g = pg;
    var out_depth = vec4<f32>(0.0);
    var bad = 0u;
    // A dispatch that continues earlier chunks of the pass (WgslSource::chunked) starts from the raw
    // sums, counts and first-hit statistics they left in its outputs (common.wgsl).
    let resume = chunk_resumes();
    if (resume) {
        if (position_at(i).w == 0.0) {
            return;
        }
        out_d = diffuse_at(i);
        if (glossy_bound()) {
            out_g = glossy_at(i);
        }
    }
    if (position_at(i).w != 0.0) {
        let x = position_at(i).xyz;
        let n = normal_at(i).xyz;
        let wo = normalize_or_zero3(params.camera.xyz - x);
        var ks = vec3<f32>(0.0);
        var m = 0.0;
        if (specular_bound()) {
            ks = specular_at(i).xyz;
            m = specular_at(i).w;
        }
        let is_glossy = want_glossy && m > 0.0 && max_element3(ks) > 0.0;
        z_min = inf();
        if (resume && depth_bound()) {
            let dp = depth_at(i);
            hits = u32(dp.z);
            traced = u32(dp.w);
            if (hits > 0u) {
                z_min = dp.x;
            }
            z_max = dp.y;
        }
        // Diffuse component.
        var target_d = params.count;
        if (rays_diffuse_bound()) {
            target_d = rays_diffuse_at(i);
        }
        let done_d = f32_to_u32_sat(pd.w);
        let extra_d = select(0u, target_d - done_d, target_d > done_d);
        let key_d = rng_key(frame.seed, pixel_id(gid), rng_substream(params.stream, 0u)); // COMPONENT_DIFFUSE
        var rd = running_start(out_d, extra_d, resume);
        var s = frame.chunk_begin;
        for (; s < rd.end; s = s + 1u) {
            let u = sample_2d(key_d, s, extra_d);
            let wi = sample_diffuse(n, u);
            let r = trace_path(x, n, wi, key_d, s);
            record(r);
            if (is_finite3(r.value)) {
                rd.sum = rd.sum + r.value;
                rd.valid = rd.valid + 1u;
            } else {
                bad = bad + 1u;
            }
        }
        count_cut_loop(s, rd.end);
        out_d = running_finish(rd, extra_d, pd, f32(rd.valid), out_d);
        // Glossy component.
        if (is_glossy) {
            var target_g = params.count;
            if (rays_glossy_bound()) {
                target_g = rays_glossy_at(i);
            }
            let done_g = f32_to_u32_sat(pg.w);
            let extra_g = select(0u, target_g - done_g, target_g > done_g);
            let key_g = rng_key(frame.seed, pixel_id(gid), rng_substream(params.stream, 1u)); // COMPONENT_GLOSSY
            var rg = running_start(out_g, extra_g, resume);
            var sg = frame.chunk_begin;
            for (; sg < rg.end; sg = sg + 1u) {
                let u = sample_2d(key_g, sg, extra_g);
                let gs = sample_glossy(params.lobe, m, n, wo, u);
                var v = vec3<f32>(0.0);
                if (gs.weight > 0.0) {
                    let r = trace_path(x, n, gs.wi, key_g, sg);
                    record(r);
                    v = r.value * gs.weight;
                }
                if (is_finite3(v)) {
                    rg.sum = rg.sum + v;
                    rg.valid = rg.valid + 1u;
                } else {
                    bad = bad + 1u;
                }
            }
            count_cut_loop(sg, rg.end);
            out_g = running_finish(rg, extra_g, pg, f32(rg.valid), out_g);
        }
        var zmin_out = z_min;
        if (hits == 0u) {
            zmin_out = 0.0;
        }
        out_depth = vec4<f32>(zmin_out, z_max, f32(hits), f32(traced));
    }
    diffuse_put(i, out_d);
    if (glossy_bound()) {
        glossy_put(i, out_g);
    }
    if (depth_bound()) {
        depth_put(i, out_depth);
    }
    if (rays_secondary > 0u) {
        atomicAdd(&counters[COUNTER_SECONDARY], rays_secondary);
    }
    if (rays_shadow > 0u) {
        atomicAdd(&counters[COUNTER_SHADOW], rays_shadow);
    }
    if (bad > 0u) {
        atomicAdd(&counters[COUNTER_NON_FINITE], bad);
    }
}
