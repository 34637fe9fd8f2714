// indirect.sample — path tracing of indirect light (diffuse and glossy components) or AO at each
// pixel's surface point, with next-event estimation at every path vertex, per-pixel counts,
// `previous_*` continuation and first-hit statistics; mirrors backends/src/kernels/indirect.rs
// (next_event, trace_path, IndirectSample::run_cpu) with the same RNG calls and dimensions.
#include "common.wgsl"
#include "rng.wgsl"
#include "bvh.wgsl"
#include "sampling.wgsl"
#include "hemisphere.wgsl"

// Dimension offset between lights in next-event estimation.
const LIGHT_DIM_STRIDE: u32 = 65536u;
// Dimension choosing the lobe at a path vertex.
const LOBE_SELECT: u32 = 14u;

// Rays traced by the current invocation (for the counters).
var<private> rays_secondary: u32 = 0u;
var<private> rays_shadow: u32 = 0u;

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

fn weight_of(c: vec3<f32>) -> f32 {
    return (c.x + c.y + c.z) / 3.0;
}

// next_event: one uniform area sample per light.
fn next_event(y: vec3<f32>, n: vec3<f32>, wo: vec3<f32>, kd: vec3<f32>, ks: vec3<f32>, m: f32, key: u32, sample: u32, bounce: u32) -> vec3<f32> {
    var sum = vec3<f32>(0.0);
    let is_glossy = m > 0.0 && max_element3(ks) > 0.0;
    for (var l = 0u; l < params.light_count; l = l + 1u) {
        let light = area_light(l);
        let d = DIM_LIGHT + bounce * DIM_BOUNCE_STRIDE + l * LIGHT_DIM_STRIDE;
        let target_point = light_sample_point(light, rng_uniform2(key, sample, d));
        let to = target_point - y;
        let r2 = dot3(to, to);
        if (r2 <= 0.0) {
            continue;
        }
        let dir = to / sqrt(r2);
        let cos_y = dot3(n, dir);
        let ln = light.normal_area.xyz;
        var cos_l = dot3(ln, -dir);
        if (light.two_sided != 0u) {
            cos_l = abs(cos_l);
        }
        if (cos_y <= 0.0 || cos_l <= 0.0) {
            continue;
        }
        let origin = y + n * params.eps;
        let seg = target_point - origin;
        let seg_len = length3(seg);
        rays_shadow = rays_shadow + 1u;
        if (scene_occluded(origin, seg / seg_len, 0.0, seg_len * bitcast<f32>(0x3f7ff972u))) { // (1.0 - 1e-4) in f32
            continue;
        }
        var f = kd * FRAC_1_PI_F32;
        if (is_glossy) {
            f = f + ks * glossy_brdf(params.lobe, m, n, wo, dir);
        }
        sum = sum + light.radiance.xyz * f * (cos_y * cos_l / r2 * light.normal_area.w);
    }
    return sum;
}

struct PathResult {
    value: vec3<f32>,
    hit: bool,   // the first ray hit (AO: a reflector within max_distance)
    first: f32,  // distance to the first hit
}

// trace_path: one path leaving `x` (normal `n`) in direction `wi`.
fn trace_path(x: vec3<f32>, n: vec3<f32>, wi: vec3<f32>, key: u32, sample: u32) -> PathResult {
    let side = select(-1.0, 1.0, dot3(wi, n) >= 0.0);
    var origin = x + n * (side * params.eps);
    var dir = wi;
    rays_secondary = rays_secondary + 1u;
    var hit = scene_intersect(origin, dir, 0.0, inf());
    if (!hit.hit) {
        return PathResult(vec3<f32>(0.0), false, 0.0);
    }
    let first = hit.t;
    if (params.ao != 0u) {
        let inside = params.max_distance <= 0.0 || first <= params.max_distance;
        if (inside) {
            return PathResult(vec3<f32>(1.0), true, first);
        }
        return PathResult(vec3<f32>(0.0), false, 0.0);
    }
    var radiance = vec3<f32>(0.0);
    var throughput = vec3<f32>(1.0);
    for (var bounce = 1u; bounce <= params.bounces; bounce = bounce + 1u) {
        let sp = surface(hit.triangle, hit.b1, hit.b2, dir);
        let y = sp.position;
        let ny = sp.shading_normal;
        let wo = -dir;
        let mat = material(sp.material);
        let kd = albedo(sp);
        let ks = mat.specular;
        let m = mat.phong_exponent;
        radiance = radiance + throughput * next_event(y, ny, wo, kd, ks, m, key, sample, bounce);
        if (bounce == params.bounces) {
            break;
        }
        // Continue: one-sample mixture of the vertex's lobes.
        let is_glossy = m > 0.0 && max_element3(ks) > 0.0;
        let wd = rmax(weight_of(kd), 0.0);
        var ws = 0.0;
        if (is_glossy) {
            ws = rmax(weight_of(ks), 0.0);
        }
        if (wd + ws <= 0.0) {
            break;
        }
        let pd = wd / (wd + ws);
        let d = DIM_BSDF + bounce * DIM_BOUNCE_STRIDE;
        let u = rng_uniform2(key, sample, d);
        var next: vec3<f32>;
        if (rng_uniform(key, sample, LOBE_SELECT + bounce * DIM_BOUNCE_STRIDE) < pd) {
            next = sample_diffuse(ny, u);
        } else {
            next = sample_glossy(params.lobe, m, ny, wo, u).wi;
        }
        let cos_i = dot3(next, ny);
        if (cos_i <= 0.0) {
            break;
        }
        var f = kd * FRAC_1_PI_F32;
        var pdf = pd * cos_i * FRAC_1_PI_F32;
        if (is_glossy) {
            f = f + ks * glossy_brdf(params.lobe, m, ny, wo, next);
            pdf = pdf + (1.0 - pd) * glossy_pdf(params.lobe, m, ny, wo, next);
        }
        if (pdf <= 0.0) {
            break;
        }
        throughput = throughput * (f * (cos_i / pdf));
        origin = y + ny * params.eps;
        dir = next;
        rays_secondary = rays_secondary + 1u;
        hit = scene_intersect(origin, dir, 0.0, inf());
        if (!hit.hit) {
            break;
        }
    }
    return PathResult(radiance, true, first);
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
