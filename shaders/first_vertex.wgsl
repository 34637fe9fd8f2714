// first_vertex.wgsl — a camera path's first vertex (mirrors effects/src/camera_paths.rs
// first_vertex): emission + next-event estimation there, the indirect
// estimate f L cos/pdf through one sample of the lobe mixture, its caustic part, and the radiance
// sample radiance filtering stores (seed 002 Sec. 4.3.1). Shared by pixel_filter.sample and
// radiance_filter.sample; the including kernel's Params are indirect_path.wgsl's and CameraPaths'
// `continues` (0: the path stops at its first vertex, the direct light only) and `one_light` (≥ 0:
// the first vertex's direct light is that area light's alone, no emission, environment or background).
#include "indirect_path.wgsl"
#include "lobe_mixture.wgsl"

struct FirstVertex {
    hit: bool,
    direct: vec3<f32>,
    indirect: vec3<f32>,
    caustic: vec3<f32>,
    position: vec3<f32>,
    normal: vec3<f32>,
    distance: f32,
    albedo: vec3<f32>,
    material: u32,
    sampled: bool,
    wi: vec3<f32>,
    incident: vec3<f32>,
    bounce_hit: bool,
    bounce_distance: f32,
}

fn first_vertex(origin: vec3<f32>, dir: vec3<f32>, key: u32, j: u32) -> FirstVertex {
    var v = FirstVertex(false, vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), 0.0,
        vec3<f32>(0.0), 0u, false, vec3<f32>(0.0), vec3<f32>(0.0), false, 0.0);
    let hit = scene_intersect(origin, dir, 0.0, inf());
    if (!hit.hit) {
        if (params.one_light < 0) {
            v.direct = scene_background(dir);
        }
        return v;
    }
    let sp = surface(hit.triangle, hit.b1, hit.b2, dir);
    let x = sp.position;
    let n = sp.shading_normal;
    let wo = -dir;
    let mat = material(sp.material);
    let kd = albedo(sp);
    let ks = mat.specular;
    let m = mat.phong_exponent;
    v.hit = true;
    // Every light and the environment, or light `one_light` alone: one `next_events` call, so one
    // inlined traversal for both (indirect_path.wgsl).
    let single = params.one_light >= 0;
    let first = select(0u, u32(params.one_light), single);
    let end = select(params.light_count, first + 1u, single);
    let events = next_events(first, end, !single, x, n, wo, kd, ks, m, key, j, 0u).total;
    if (single) {
        v.direct = events;
    } else {
        v.direct = emission(sp) + events;
    }
    v.position = x;
    v.normal = n;
    v.distance = hit.t;
    v.albedo = kd;
    v.material = sp.material;
    let mix = lobe_mixture(kd, ks, m);
    if (mix.some && params.continues != 0u) {
        // trace_path_split's continuation numbers at bounce 0 (indirect.rs continuation_numbers).
        let wi = lobe_sample(params.lobe, m, n, wo, mix, rng_uniform2(key, j, DIM_BSDF), rng_uniform(key, j, LOBE_SELECT));
        v.sampled = true;
        v.wi = wi;
        let cos_i = dot3(wi, n);
        if (cos_i > 0.0) {
            let lv = lobe_eval(params.lobe, kd, ks, m, mix, n, wo, wi, cos_i);
            if (lv.pdf > 0.0) {
                let r = trace_path_split(x, n, wi, key, j);
                v.incident = r.value;
                v.bounce_hit = r.hit;
                v.bounce_distance = r.first;
                v.indirect = r.value * (lv.f * (cos_i / lv.pdf));
                // Caustic paths leave the first vertex by its diffuse part.
                v.caustic = r.caustic * (lv.fd * (cos_i / lv.pdf));
            }
        }
    }
    return v;
}
