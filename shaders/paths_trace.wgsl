// paths.trace — the Ch. 5 path sampler: per pixel a run of paths (lens ray, shadow rays at the hit,
// one-bounce indirect samples) accumulated into one PathRecord; mirrors backends/src/kernels/paths.rs
// (PathsTrace::run_cpu, trace_one, indirect_ray, accumulate) with the same samples and order.
#include "common.wgsl"
#include "rng.wgsl"
#include "sobol.wgsl"
#include "camera.wgsl"
#include "light_sample.wgsl"
#include "indirect_path.wgsl"

const SALT_DIFFUSE_PATH: u32 = 1u;
const SALT_GLOSSY_PATH: u32 = 2u;

var<private> rec: PathRecord;

// draw: Sobol' (stratified) or independent sample `index` of pair `pair`.
fn draw(pixel: u32, pair: u32, index: u32) -> vec2<f32> {
    let key = sequence_key(frame.seed, pixel, params.stream, pair);
    if (params.stratified != 0u) {
        return sobol2(key, index);
    }
    return independent2(key, index);
}

fn accumulate_direct(k: vec3<f32>, e_sum: vec3<f32>, valid: u32, w: f32) {
    var e = vec3<f32>(0.0);
    if (valid > 0u) {
        e = e_sum / f32(valid);
    }
    rec.l_direct = rec.l_direct + k * e * w;
    rec.k_direct = rec.k_direct + k * w;
    rec.e_direct = rec.e_direct + e * w;
}

fn accumulate_diffuse(k: vec3<f32>, e_sum: vec3<f32>, valid: u32, w: f32) {
    var e = vec3<f32>(0.0);
    if (valid > 0u) {
        e = e_sum / f32(valid);
    }
    rec.l_diffuse = rec.l_diffuse + k * e * w;
    rec.k_diffuse = rec.k_diffuse + k * w;
    rec.e_diffuse = rec.e_diffuse + e * w;
}

fn accumulate_glossy(k: vec3<f32>, e_sum: vec3<f32>, valid: u32, w: f32) {
    var e = vec3<f32>(0.0);
    if (valid > 0u) {
        e = e_sum / f32(valid);
    }
    rec.l_glossy = rec.l_glossy + k * e * w;
    rec.k_glossy = rec.k_glossy + k * w;
    rec.e_glossy = rec.e_glossy + e * w;
}

// indirect_ray: one shared-estimator path with its rays and first hit recorded.
fn indirect_ray(x: vec3<f32>, n: vec3<f32>, wi: vec3<f32>, key: u32, q: u32) -> vec3<f32> {
    let before_secondary = rays_secondary;
    let before_shadow = rays_shadow;
    let r = trace_path(x, n, wi, key, q);
    rec.indirect_rays = rec.indirect_rays + (rays_secondary - before_secondary);
    rec.bounce_shadow = rec.bounce_shadow + (rays_shadow - before_shadow);
    if (r.hit) {
        rec.indirect_hits = rec.indirect_hits + 1u;
        if (rec.indirect_hits == 1u) {
            rec.z_min = r.first;
            rec.z_max = r.first;
        } else {
            rec.z_min = rmin(rec.z_min, r.first);
            rec.z_max = rmax(rec.z_max, r.first);
        }
    }
    return r.value;
}

fn trace_one(c: CameraModel, ray: LensRay, hit: Hit, pixel: u32, key_d: u32, key_g: u32, n_shadow: u32, n_indirect: u32) {
    let w = ray.weight;
    rec.paths = rec.paths + 1u;
    rec.weight = rec.weight + w;
    if (!hit.hit) {
        return;
    }
    let sp = surface(hit.triangle, hit.b1, hit.b2, ray.dir);
    let x = sp.position;
    let n = sp.shading_normal;
    let wo = -ray.dir;
    rec.hits = rec.hits + 1u;
    rec.hit_weight = rec.hit_weight + w;
    rec.position = rec.position + x * w;
    rec.normal = rec.normal + n * w;
    rec.emission = rec.emission + emission(sp) * w;
    if (rec.object == 0u) {
        rec.object = 1u + sp.object;
    }
    let z = dot3(x - c.position, c.forward);
    rec.depth = rec.depth + w * z;
    let coc = abs(coc_pixels(c, z));
    if (rec.hits == 1u) {
        rec.r_min = coc;
        rec.r_max = coc;
    } else {
        rec.r_min = rmin(rec.r_min, coc);
        rec.r_max = rmax(rec.r_max, coc);
    }
    let kd = albedo(sp);
    let mat = material(sp.material);
    let ks = mat.specular;
    let m = mat.phong_exponent;
    let is_glossy = m > 0.0 && max_element3(ks) > 0.0;

    if (params.direct != 0u) {
        trace_direct(x, n, wo, kd, ks, m, is_glossy, w, pixel, n_shadow);
    }
    if (params.indirect != 0u) {
        trace_indirect(x, n, wo, kd, ks, m, is_glossy, w, pixel, key_d, key_g, n_indirect);
    }
}

// Direct (eqs. 5.9–5.14, glossy folded into k: eq. 5.20); `exact`: per-sample geometry term.
fn trace_direct(x: vec3<f32>, n: vec3<f32>, wo: vec3<f32>, kd: vec3<f32>, ks: vec3<f32>, m: f32, is_glossy: bool,
        w: f32, pixel: u32, n_shadow: u32) {
    let l = area_light(params.light);
    let fc = light_centre_factor(l, x, n);
    var k = kd;
    if (is_glossy) {
        let to_centre = normalize_or_zero3(l.centre_sigma.xyz - x);
        k = k + ks * (PI_F32 * glossy_brdf(params.lobe, m, n, wo, to_centre));
    }
    rec.d1 = rec.d1 + w * abs(dot3(l.centre_sigma.xyz - x, l.normal_area.xyz));
    var e = vec3<f32>(0.0);
    var valid = 0u;
    for (var s = 0u; s < n_shadow; s = s + 1u) {
        let u = draw(pixel, PAIR_LIGHT, rec.shadow);
        rec.shadow = rec.shadow + 1u;
        let ls = light_sample(l, x, n, u, params.exact == 0u, fc, true);
        if (ls.occluded) {
            rec.occluded = rec.occluded + 1u;
            if (rec.occluded == 1u) {
                rec.d2_min = ls.distance;
                rec.d2_max = ls.distance;
            } else {
                rec.d2_min = rmin(rec.d2_min, ls.distance);
                rec.d2_max = rmax(rec.d2_max, ls.distance);
            }
        }
        if (is_finite3(ls.value)) {
            e = e + ls.value;
            valid = valid + 1u;
        } else {
            rec.non_finite = rec.non_finite + 1u;
        }
    }
    accumulate_direct(k, e, valid, w);
}

// Indirect diffuse, and glossy where the surface has a lobe.
fn trace_indirect(x: vec3<f32>, n: vec3<f32>, wo: vec3<f32>, kd: vec3<f32>, ks: vec3<f32>, m: f32, is_glossy: bool,
        w: f32, pixel: u32, key_d: u32, key_g: u32, n_indirect: u32) {
    var e = vec3<f32>(0.0);
    var valid = 0u;
    for (var s = 0u; s < n_indirect; s = s + 1u) {
        let q = rec.diffuse_samples;
        rec.diffuse_samples = rec.diffuse_samples + 1u;
        let wi = sample_diffuse(n, draw(pixel, PAIR_HEMISPHERE_DIFFUSE, q));
        let v = indirect_ray(x, n, wi, key_d, q);
        if (is_finite3(v)) {
            e = e + v;
            valid = valid + 1u;
        } else {
            rec.non_finite = rec.non_finite + 1u;
        }
    }
    accumulate_diffuse(kd, e, valid, w);

    // Indirect glossy.
    if (is_glossy) {
        e = vec3<f32>(0.0);
        valid = 0u;
        for (var s = 0u; s < n_indirect; s = s + 1u) {
            let q = rec.glossy_samples;
            rec.glossy_samples = rec.glossy_samples + 1u;
            let u = draw(pixel, PAIR_HEMISPHERE_GLOSSY, q);
            let gs = sample_glossy(params.lobe, m, n, wo, u);
            var v = vec3<f32>(0.0);
            if (gs.weight > 0.0) {
                v = indirect_ray(x, n, gs.wi, key_g, q) * gs.weight;
            }
            if (is_finite3(v)) {
                e = e + v;
                valid = valid + 1u;
            } else {
                rec.non_finite = rec.non_finite + 1u;
            }
        }
        accumulate_glossy(ks, e, valid, w);
    }
}

fn ceil_div(a: u32, b: u32) -> u32 {
    return a / b + select(0u, 1u, a % b != 0u);
}

// Work units of one path for chunking: its rays (the camera ray, the shadow rays, and per indirect
// sample of each part a ray and a next-event shadow ray per bounce) in eighths, at least 1.
fn path_units(n_shadow: u32, n_indirect: u32) -> u32 {
    var rays = 1u;
    if (params.direct != 0u) {
        rays = rays + min(n_shadow, 0x100000u);
    }
    if (params.indirect != 0u) {
        rays = rays + 4u * min(n_indirect, 0x100000u) * min(params.bounces, 64u);
    }
    return max(1u, ceil_div(rays, 8u));
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let pixel = pixel_id(gid);
    let xy = pixel_xy(gid);
    let prev = previous_at(i); // zero when unbound
    var count = params.count;
    if (counts_bound()) {
        count = counts_at(i);
    }
    count = min(count, 0xffffffffu - prev.paths); // the CPU's saturating first + count
    var n_shadow = params.shadow_per_primary;
    if (shadow_per_primary_bound()) {
        n_shadow = shadow_per_primary_at(i);
    }
    n_shadow = max(n_shadow, 1u);
    var n_indirect = params.indirect_per_primary;
    if (indirect_per_primary_bound()) {
        n_indirect = indirect_per_primary_at(i);
    }
    n_indirect = max(n_indirect, 1u);
    // Chunks are counted in work units of about 8 rays (path_units): path k of this pass runs in the
    // dispatch whose unit range [chunk_begin, chunk_end) holds k·units, so a dispatch traces at most
    // ~8 × chunk rays per pixel however many secondary samples a path carries (lavapipe cuts a loop
    // after 65,535 iterations over a whole invocation: 16 paths × 64 indirect samples were cut). A
    // resuming dispatch continues the record the earlier chunks left (sums, extrema and counts: exact
    // in any chunking).
    let resume = chunk_resumes();
    let units = path_units(n_shadow, n_indirect);
    var total = 0xffffffffu;
    if (count <= 0xffffffffu / units) {
        total = count * units;
    }
    let k_begin = ceil_div(frame.chunk_begin, units);
    let end = min(count, ceil_div(chunk_end_of(total), units));
    if (resume && end <= k_begin) {
        return;
    }
    if (resume) {
        rec = record_at(i);
    } else {
        rec = prev;
    }
    let first = prev.paths;
    let c = CameraModel(params.cam_position, params.cam_right, params.cam_up, params.cam_forward, params.cam_tan_half,
        params.cam_aperture, params.cam_focus_distance, params.cam_gaussian);
    let key_d = rng_key(frame.seed, pixel, substream(params.stream, SALT_DIFFUSE_PATH));
    let key_g = rng_key(frame.seed, pixel, substream(params.stream, SALT_GLOSSY_PATH));
    let before = rec;
    // As the CPU: through the pixel centre of a pinhole camera the camera ray is the same for every
    // path, so it is traced once (per dispatch: a chunked pass re-traces it per chunk, uncounted) and
    // counted once per pixel and pass.
    let fixed_primary = params.jitter == 0u && params.cam_aperture == 0.0;
    var fixed_hit: Hit;
    var have_hit = false;
    var k = k_begin;
    for (; k < end; k = k + 1u) {
        let j = first + k;
        var jitter = vec2<f32>(0.5);
        if (params.jitter != 0u) {
            jitter = draw(pixel, PAIR_PIXEL, j);
        }
        let lens = draw(pixel, PAIR_LENS, j);
        let ray = camera_ray(c, vec2<f32>(f32(xy.x), f32(xy.y)) + jitter, lens);
        if (!fixed_primary || !have_hit) {
            fixed_hit = scene_intersect(ray.origin, ray.dir, 0.0, inf());
            have_hit = true;
        }
        trace_one(c, ray, fixed_hit, pixel, key_d, key_g, n_shadow, n_indirect);
    }
    count_cut_loop(k, end);
    var primary = rec.paths - before.paths;
    if (fixed_primary) {
        // Counted in the chunk that starts the pass, when the pass traces any path here.
        primary = select(0u, 1u, frame.chunk_begin == 0u && rec.paths > before.paths);
    }
    if (primary > 0u) {
        atomicAdd(&counters[COUNTER_PRIMARY], primary);
    }
    let shadow = (rec.shadow - before.shadow) + (rec.bounce_shadow - before.bounce_shadow);
    if (shadow > 0u) {
        atomicAdd(&counters[COUNTER_SHADOW], shadow);
    }
    if (rec.indirect_rays > before.indirect_rays) {
        atomicAdd(&counters[COUNTER_SECONDARY], rec.indirect_rays - before.indirect_rays);
    }
    if (rec.non_finite > before.non_finite) {
        atomicAdd(&counters[COUNTER_NON_FINITE], rec.non_finite - before.non_finite);
    }
    record_put(i, rec);
}
