// indirect_path.wgsl — the indirect-light estimator shared by indirect.sample and paths.trace: a
// path leaving a surface point with next-event estimation at each vertex; mirrors
// backends/src/kernels/indirect.rs (next_event, trace_path) with the same RNG calls and dimensions.
// The including kernel's Params must have `eps`, `lobe`, `bounces`, `ao`, `max_distance` and
// `light_count`; rays traced are added to the private counters below.
#include "common.wgsl"
#include "rng.wgsl"
#include "bvh.wgsl"
#include "sampling.wgsl"
#include "hemisphere.wgsl"
#include "environment_light.wgsl"
#include "lobe_mixture.wgsl"

// Dimension offset between lights in next-event estimation.
const LIGHT_DIM_STRIDE: u32 = 65536u;

// Rays traced by the current invocation (for the counters).
var<private> rays_secondary: u32 = 0u;
var<private> rays_shadow: u32 = 0u;

// next_event: one uniform area sample per light, and one environment look-up where the scene has a map
// (indirect.rs next_event's first value).
fn next_event(y: vec3<f32>, n: vec3<f32>, wo: vec3<f32>, kd: vec3<f32>, ks: vec3<f32>, m: f32, key: u32, sample: u32, bounce: u32) -> vec3<f32> {
    return next_event_parts(y, n, wo, kd, ks, m, key, sample, bounce).total;
}

struct NextEvent {
    total: vec3<f32>,
    glossy: vec3<f32>, // the area lights' part through the glossy lobe (indirect.rs next_event's second value)
}

// Next-event estimation toward area light `l` alone (indirect.rs light_event): one uniform sample of
// it and its shadow ray; no ray where the sample faces away.
fn light_query(l: u32, y: vec3<f32>, n: vec3<f32>, wo: vec3<f32>, kd: vec3<f32>, ks: vec3<f32>, m: f32, key: u32, sample: u32, bounce: u32) -> ShadowQuery {
    let light = scene_light_at(l);
    let d = DIM_LIGHT + bounce * DIM_BOUNCE_STRIDE + l * LIGHT_DIM_STRIDE;
    let target_point = light_sample_point(light, rng_uniform2(key, sample, d));
    let to = target_point - y;
    let r2 = dot3(to, to);
    if (r2 <= 0.0) {
        return no_shadow_query();
    }
    let dir = to / sqrt(r2);
    let cos_y = dot3(n, dir);
    let cos_l = light_facing_cos(light, dir);
    if (cos_y <= 0.0 || cos_l <= 0.0) {
        return no_shadow_query();
    }
    let origin = y + n * params.eps;
    let seg = target_point - origin;
    let seg_len = length3(seg);
    var f = kd * FRAC_1_PI_F32;
    let geometry = cos_y * cos_l / r2 * light.normal_area.w;
    var glossy = vec3<f32>(0.0);
    if (m > 0.0 && max_element3(ks) > 0.0) {
        let g = ks * glossy_brdf(params.lobe, m, n, wo, dir);
        f = f + g;
        glossy = light.radiance.xyz * g * geometry;
    }
    let tmax = seg_len * bitcast<f32>(0x3f7ff972u); // (1.0 - 1e-4) in f32
    return ShadowQuery(true, origin, seg / seg_len, tmax, light.radiance.xyz * f * geometry, glossy);
}

// Next events toward the area lights `first..end` and, where `environment`, the environment after
// them (indirect.rs next_event / light_event), summed in that order. Every event's shadow ray is
// traced at the one `scene_occluded` call below: lavapipe inlines the whole traversal at each call
// site, so one site instead of one per kind of event shortens every cold compile of the kernels that
// include this file (docs/DESIGN-NOTES.md, "Cold compiles in CI").
fn next_events(first: u32, end: u32, environment: bool, y: vec3<f32>, n: vec3<f32>, wo: vec3<f32>, kd: vec3<f32>,
        ks: vec3<f32>, m: f32, key: u32, sample: u32, bounce: u32) -> NextEvent {
    var sum = vec3<f32>(0.0);
    var glossy_sum = vec3<f32>(0.0);
    var env = vec3<f32>(0.0);
    let last = select(end, end + 1u, environment);
    for (var l = first; l < last; l = l + 1u) {
        let is_env = l == end;
        var q: ShadowQuery;
        if (is_env) {
            q = environment_query(y, n, wo, kd, ks, m, key, sample, bounce);
        } else {
            q = light_query(l, y, n, wo, kd, ks, m, key, sample, bounce);
        }
        if (!q.wanted) {
            continue;
        }
        rays_shadow = rays_shadow + 1u;
        if (scene_occluded(q.origin, q.dir, 0.0, q.tmax)) {
            continue;
        }
        if (is_env) {
            env = q.total;
        } else {
            sum = sum + q.total;
            glossy_sum = glossy_sum + q.glossy;
        }
    }
    return NextEvent(sum + env, glossy_sum);
}

// Every area light, then the environment, which is a light too (indirect.rs next_event).
fn next_event_parts(y: vec3<f32>, n: vec3<f32>, wo: vec3<f32>, kd: vec3<f32>, ks: vec3<f32>, m: f32, key: u32, sample: u32, bounce: u32) -> NextEvent {
    return next_events(0u, params.light_count, true, y, n, wo, kd, ks, m, key, sample, bounce);
}

struct PathResult {
    value: vec3<f32>,
    hit: bool,   // the first ray hit (AO: a reflector within max_distance)
    first: f32,  // distance to the first hit
}

// trace_path: one path leaving `x` (normal `n`) in direction `wi`.
fn trace_path(x: vec3<f32>, n: vec3<f32>, wi: vec3<f32>, key: u32, sample: u32) -> PathResult {
    let r = trace_path_split(x, n, wi, key, sample);
    return PathResult(r.value, r.hit, r.first);
}

struct PathSplit {
    value: vec3<f32>,
    caustic: vec3<f32>, // the light that reached x through glossy scattering only (indirect.rs trace_path_split)
    hit: bool,
    first: f32,
}

fn trace_path_split(x: vec3<f32>, n: vec3<f32>, wi: vec3<f32>, key: u32, sample: u32) -> PathSplit {
    let side = select(-1.0, 1.0, dot3(wi, n) >= 0.0);
    let origin = x + n * (side * params.eps);
    let dir = wi;
    rays_secondary = rays_secondary + 1u;
    let hit = scene_intersect(origin, dir, 0.0, inf());
    if (!hit.hit) {
        return PathSplit(vec3<f32>(0.0), vec3<f32>(0.0), false, 0.0);
    }
    let first = hit.t;
    if (params.ao != 0u) {
        let inside = params.max_distance <= 0.0 || first <= params.max_distance;
        if (inside) {
            return PathSplit(vec3<f32>(1.0), vec3<f32>(0.0), true, first);
        }
        return PathSplit(vec3<f32>(0.0), vec3<f32>(0.0), false, 0.0);
    }
    let r = path_from_hit(hit, origin, dir, key, sample);
    return PathSplit(r.value, r.caustic, true, first);
}

struct FromHit {
    value: vec3<f32>,
    caustic: vec3<f32>,
}

// path_from_hit: what a path brings back from its first hit `hit_in` of the ray origin_in + t dir_in
// (indirect.rs path_from_hit; the light-field sampler traces the first ray itself).
fn path_from_hit(hit_in: Hit, origin_in: vec3<f32>, dir_in: vec3<f32>, key: u32, sample: u32) -> FromHit {
    var hit = hit_in;
    var origin = origin_in;
    var dir = dir_in;
    var radiance = vec3<f32>(0.0);
    var throughput = vec3<f32>(1.0);
    var caustic = vec3<f32>(0.0);
    var caustic_throughput = vec3<f32>(1.0);
    for (var bounce = 1u; bounce <= params.bounces; bounce = bounce + 1u) {
        let sp = surface(hit.triangle, hit.b1, hit.b2, dir);
        let y = sp.position;
        let ny = sp.shading_normal;
        let wo = -dir;
        let mat = material(sp.material);
        let kd = albedo(sp);
        let ks = mat.specular;
        let m = mat.phong_exponent;
        let event = next_event_parts(y, ny, wo, kd, ks, m, key, sample, bounce);
        radiance = radiance + throughput * event.total;
        caustic = caustic + caustic_throughput * event.glossy;
        if (bounce == params.bounces) {
            break;
        }
        // Continue: one-sample mixture of the vertex's lobes.
        let mix = lobe_mixture(kd, ks, m);
        if (!mix.some) {
            break;
        }
        let u = rng_uniform2(key, sample, DIM_BSDF + bounce * DIM_BOUNCE_STRIDE);
        let next = lobe_sample(params.lobe, m, ny, wo, mix, u, rng_uniform(key, sample, LOBE_SELECT + bounce * DIM_BOUNCE_STRIDE));
        let cos_i = dot3(next, ny);
        if (cos_i <= 0.0) {
            break;
        }
        let v = lobe_eval(params.lobe, kd, ks, m, mix, ny, wo, next, cos_i);
        if (v.pdf <= 0.0) {
            break;
        }
        throughput = throughput * (v.f * (cos_i / v.pdf));
        caustic_throughput = caustic_throughput * (v.g * (cos_i / v.pdf));
        origin = y + ny * params.eps;
        dir = next;
        rays_secondary = rays_secondary + 1u;
        hit = scene_intersect(origin, dir, 0.0, inf());
        if (!hit.hit) {
            break;
        }
    }
    return FromHit(radiance, caustic);
}
