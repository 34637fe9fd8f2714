// paths.trace — the Ch. 5 path sampler: per pixel a run of paths (lens ray, shadow rays at the hit,
// one-bounce indirect samples) accumulated into one PathRecord; mirrors backends/src/kernels/paths.rs
// (PathsTrace::run_cpu, trace_one, indirect_ray, accumulate) with the same samples and order.
#include "common.wgsl"
#include "rng.wgsl"
#include "sobol.wgsl"
#include "camera.wgsl"
#include "light_sample.wgsl"
#include "indirect_path.wgsl"
#include "environment_light.wgsl"

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

// One path's additions to a component's sums (PathsTrace's `accumulate`): path weights (E = the mean
// of the `valid` finite samples summing to `e_sum`) or, where the camera ray is fixed, sample weights
// (the sums themselves, and w·valid to the component weight).
struct Added {
    l: vec3<f32>,
    k: vec3<f32>,
    e: vec3<f32>,
    w: f32,
}

fn added(k: vec3<f32>, e_sum: vec3<f32>, valid: u32, w: f32) -> Added {
    if (params.fixed_primary != 0u) {
        let n = f32(valid);
        return Added(k * e_sum * w, k * (n * w), e_sum * w, n * w);
    }
    var e = vec3<f32>(0.0);
    if (valid > 0u) {
        e = e_sum / f32(valid);
    }
    return Added(k * e * w, k * w, e * w, 0.0);
}

fn accumulate_direct(k: vec3<f32>, e_sum: vec3<f32>, valid: u32, w: f32) {
    let a = added(k, e_sum, valid, w);
    rec.l_direct = rec.l_direct + a.l;
    rec.k_direct = rec.k_direct + a.k;
    rec.e_direct = rec.e_direct + a.e;
    rec.w_direct = rec.w_direct + a.w;
}

fn accumulate_diffuse(k: vec3<f32>, e_sum: vec3<f32>, valid: u32, w: f32) {
    let a = added(k, e_sum, valid, w);
    rec.l_diffuse = rec.l_diffuse + a.l;
    rec.k_diffuse = rec.k_diffuse + a.k;
    rec.e_diffuse = rec.e_diffuse + a.e;
    rec.w_diffuse = rec.w_diffuse + a.w;
}

fn accumulate_env_diffuse(k: vec3<f32>, e_sum: vec3<f32>, valid: u32, w: f32) {
    let a = added(k, e_sum, valid, w);
    rec.l_env_diffuse = rec.l_env_diffuse + a.l;
    rec.k_env_diffuse = rec.k_env_diffuse + a.k;
    rec.e_env_diffuse = rec.e_env_diffuse + a.e;
    rec.w_env_diffuse = rec.w_env_diffuse + a.w;
}

fn accumulate_env_glossy(k: vec3<f32>, e_sum: vec3<f32>, valid: u32, w: f32) {
    let a = added(k, e_sum, valid, w);
    rec.l_env_glossy = rec.l_env_glossy + a.l;
    rec.k_env_glossy = rec.k_env_glossy + a.k;
    rec.e_env_glossy = rec.e_env_glossy + a.e;
    rec.w_env_glossy = rec.w_env_glossy + a.w;
}

fn accumulate_glossy(k: vec3<f32>, e_sum: vec3<f32>, valid: u32, w: f32) {
    let a = added(k, e_sum, valid, w);
    rec.l_glossy = rec.l_glossy + a.l;
    rec.k_glossy = rec.k_glossy + a.k;
    rec.e_glossy = rec.e_glossy + a.e;
    rec.w_glossy = rec.w_glossy + a.w;
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

// paths.rs `Projection::image_velocity`: the image velocity (pixels per unit t, y down) of a point at
// `x` moving at `v`; zero behind the camera.
fn image_velocity(c: CameraModel, x: vec3<f32>, v: vec3<f32>) -> vec2<f32> {
    let d = x - c.position;
    let z = dot3(d, c.forward);
    if (!(z > 0.0)) {
        return vec2<f32>(0.0);
    }
    let scale = f32(max(frame.full_height, 1u)) / (2.0 * c.tan_half);
    let vz = dot3(v, c.forward);
    let zz = z * z;
    let vx = scale * (dot3(v, c.right) * z - dot3(d, c.right) * vz) / zz;
    let vy = -scale * (dot3(v, c.up) * z - dot3(d, c.up) * vz) / zz;
    return vec2<f32>(vx, vy);
}

// paths.rs `shadow_velocity`: the shadow's image velocity, the occluder's world velocity times d1/d2
// (parallel-plane model, light points at rest), projected at the receiver.
fn shadow_velocity(c: CameraModel, x: vec3<f32>, d1: f32, d2: f32, occluder_velocity: vec3<f32>) -> vec2<f32> {
    if (!(d2 > 0.0)) {
        return vec2<f32>(0.0);
    }
    return image_velocity(c, x, occluder_velocity * (d1 / d2));
}

// The primary-hit velocity range (paths.rs `extend_range` on vp_min/vp_max).
fn extend_vp(v: vec2<f32>, first: bool) {
    if (first) {
        rec.vp_min = v;
        rec.vp_max = v;
    } else {
        rec.vp_min = min(rec.vp_min, v);
        rec.vp_max = max(rec.vp_max, v);
    }
}

// The shadow velocity range (vs_min/vs_max).
fn extend_vs(v: vec2<f32>, first: bool) {
    if (first) {
        rec.vs_min = v;
        rec.vs_max = v;
    } else {
        rec.vs_min = min(rec.vs_min, v);
        rec.vs_max = max(rec.vs_max, v);
    }
}

// Secondary samples one path carries per component (0: not sampled on it).
struct Secondary {
    shadow: u32,
    diffuse: u32,
    glossy: u32,
    environment: u32,
}

fn carries(on: u32, count: u32, w: f32) -> f32 {
    return select(0.0, w, on != 0u && count > 0u);
}

fn trace_one(c: CameraModel, ray: LensRay, hit: Hit, pixel: u32, key_d: u32, key_g: u32, count: Secondary) {
    let w = ray.weight;
    rec.paths = rec.paths + 1u;
    rec.weight = rec.weight + w;
    if (params.fixed_primary == 0u) {
        // Path weights: every path that carries a component counts for it, a miss as black.
        let direct = carries(params.direct, count.shadow, w);
        let diffuse = carries(params.indirect, count.diffuse, w);
        let glossy = carries(params.indirect * params.glossy, count.glossy, w);
        let environment = carries(params.environment, count.environment, w);
        rec.w_direct = rec.w_direct + direct;
        rec.w_diffuse = rec.w_diffuse + diffuse;
        rec.w_glossy = rec.w_glossy + glossy;
        rec.w_env_diffuse = rec.w_env_diffuse + environment;
        rec.w_env_glossy = rec.w_env_glossy + environment;
        if (!hit.hit) {
            // E averages over the hits (PathRecord::w_direct_missed in paths.rs).
            rec.w_direct_missed = rec.w_direct_missed + direct;
            rec.w_diffuse_missed = rec.w_diffuse_missed + diffuse;
            rec.w_glossy_missed = rec.w_glossy_missed + glossy;
            rec.w_env_missed = rec.w_env_missed + environment;
        }
    }
    if (!hit.hit) {
        // A miss sees the still background (App. B's velocity range), and the environment.
        extend_vp(vec2<f32>(0.0), rec.paths == 1u);
        rec.emission = rec.emission + scene_background(ray.dir) * w;
        return;
    }
    let sp = surface(hit.triangle, hit.b1, hit.b2, ray.dir);
    let x = sp.position;
    let n = sp.shading_normal;
    let wo = -ray.dir;
    var velocity = vec2<f32>(0.0);
    if (params.time != 0u) {
        velocity = image_velocity(c, x, object_velocity(sp.object, x));
    }
    extend_vp(velocity, rec.paths == 1u);
    rec.hits = rec.hits + 1u;
    rec.hit_weight = rec.hit_weight + w;
    rec.position = rec.position + x * w;
    rec.normal = rec.normal + n * w;
    rec.emission = rec.emission + emission(sp) * w;
    rec.vp_sum = rec.vp_sum + velocity * w;
    if (rec.object == 0u) {
        rec.object = 1u + sp.object;
    }
    let z = dot3(x - c.position, c.forward);
    rec.depth = rec.depth + w * z;
    let signed_coc = coc_pixels(c, z);
    let coc = abs(signed_coc);
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
    rec.exponent = rec.exponent + w * select(0.0, m, is_glossy);
    // A near-layer path's own radiance is what its estimators add to the sums below.
    let near = signed_coc > NEAR_LAYER_COC;
    var before = vec3<f32>(0.0);
    if (near) {
        before = radiance_sums();
    }
    if (params.environment != 0u && count.environment > 0u) {
        trace_environment(x, n, wo, kd, ks, m, is_glossy, w, pixel, count.environment);
    }
    if (params.direct != 0u && count.shadow > 0u) {
        trace_direct(c, x, n, wo, kd, ks, m, is_glossy, w, pixel, count.shadow);
    }
    if (params.indirect != 0u) {
        trace_indirect(x, n, wo, kd, ks, m, is_glossy, w, pixel, key_d, key_g, count);
    }
    if (near) {
        rec.l_near = rec.l_near + ((radiance_sums() - before) + emission(sp) * w);
        if (rec.w_near > 0.0) {
            rec.r_near = rmin(rec.r_near, coc);
        } else {
            rec.r_near = coc;
        }
        rec.w_near = rec.w_near + w;
    }
}

// paths.rs NEAR_LAYER_COC, radiance_sums: the near layer's test, and Σ w·L so far (a path's own
// radiance is the change it makes).
const NEAR_LAYER_COC: f32 = 2.0;

fn radiance_sums() -> vec3<f32> {
    return vec3<f32>(0.0) + rec.l_direct + rec.l_diffuse + rec.l_glossy + rec.l_env_diffuse + rec.l_env_glossy
        + rec.emission;
}

// Direct (eqs. 5.9–5.14, glossy folded into k: eq. 5.20); `exact`: per-sample geometry term.
fn trace_direct(c: CameraModel, x: vec3<f32>, n: vec3<f32>, wo: vec3<f32>, kd: vec3<f32>, ks: vec3<f32>, m: f32,
        is_glossy: bool, w: f32, pixel: u32, n_shadow: u32) {
    let l = scene_light_at(params.light);
    let fc = light_centre_factor(l, x, n);
    var k = kd;
    if (is_glossy) {
        let to_centre = normalize_or_zero3(l.centre_sigma.xyz - x);
        k = k + ks * (PI_F32 * glossy_brdf(params.lobe, m, n, wo, to_centre));
    }
    let d1 = abs(dot3(l.centre_sigma.xyz - x, l.normal_area.xyz));
    rec.d1 = rec.d1 + w * d1;
    var e = vec3<f32>(0.0);
    var unshadowed = vec3<f32>(0.0);
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
            var vs = vec2<f32>(0.0);
            if (params.time != 0u) {
                let occluder = surface(ls.hit.triangle, ls.hit.b1, ls.hit.b2, ls.dir);
                vs = shadow_velocity(c, x, d1, ls.distance, object_velocity(occluder.object, occluder.position));
            }
            rec.vs_sum = rec.vs_sum + vs;
            extend_vs(vs, rec.occluded == 1u);
        }
        if (is_finite3(ls.value) && is_finite3(ls.unshadowed)) {
            e = e + ls.value;
            unshadowed = unshadowed + ls.unshadowed;
            valid = valid + 1u;
        } else {
            rec.non_finite = rec.non_finite + 1u;
        }
    }
    // U takes E's weights (paths.rs trace_direct).
    var per = 1.0;
    if (params.fixed_primary == 0u) {
        per = 0.0;
        if (valid > 0u) {
            per = 1.0 / f32(valid);
        }
    }
    rec.u_direct = rec.u_direct + unshadowed * (per * w);
    accumulate_direct(k, e, valid, w);
}

// paths.rs `occluder_term`: cos²θ_occ / z = cos θ / t for a look-up blocked at distance t.
fn occluder_term(c: f32, t: f32) -> f32 {
    if (t > 0.0) {
        return c / t;
    }
    return 0.0;
}

// The environment estimator (paths.rs `trace_environment`, thesis Ch. 6).
fn trace_environment(x: vec3<f32>, n: vec3<f32>, wo: vec3<f32>, kd: vec3<f32>, ks: vec3<f32>, m: f32, is_glossy: bool,
        w: f32, pixel: u32, count: u32) {
    var shift = 0u;
    if (params.stratified != 0u) {
        shift = env_uniform_entry(draw(pixel, PAIR_ENVIRONMENT, 0u).x);
    }
    let origin = x + n * params.eps;
    let mis = is_glossy && params.environment_mis != 0u;
    var ed = vec3<f32>(0.0);
    var eg = vec3<f32>(0.0);
    var valid_d = 0u;
    var valid_g = 0u;
    for (var s = 0u; s < count; s = s + 1u) {
        let q = rec.env_samples;
        rec.env_samples = rec.env_samples + 1u;
        var entry: u32;
        if (params.stratified != 0u) {
            entry = env_stratified_entry(shift, q);
        } else {
            entry = env_uniform_entry(draw(pixel, PAIR_ENVIRONMENT, q).x);
        }
        let e = env_table(entry);
        var vd = vec3<f32>(0.0);
        var vg = vec3<f32>(0.0);
        // Ray 0 is the table's direction; under MIS ray 1 is the lobe's (paths.rs `lobe_look_up`). One
        // loop and one `scene_trace` call (any hit or closest by a flag, not `scene_occluded` and
        // `scene_intersect`): lavapipe inlines the traversal at every call site, and each site costs
        // compile time on every cold CI machine (docs/DESIGN-NOTES.md, "Cold compiles in CI").
        for (var k = 0u; k < select(1u, 2u, mis); k = k + 1u) {
            let table = k == 0u;
            var dir = e.dir;
            if (!table) {
                dir = sample_glossy(params.lobe, m, n, wo, draw(pixel, PAIR_ENVIRONMENT_LOBE, q)).wi;
            }
            let c = dot3(n, dir);
            if (!(c > 0.0 && select(is_finite3(dir), e.pdf > 0.0, table))) {
                continue;
            }
            rec.env_rays = rec.env_rays + 1u;
            // The occluder's distance only where the table's sample is bright enough to count
            // (closest hit); any hit otherwise.
            let measure = table && luminance3(e.radiance) >= params.occluder_luminance;
            let h = scene_trace(origin, dir, 0.0, inf(), !measure);
            if (h.hit && measure) {
                rec.env_occluder = rmax(rec.env_occluder, occluder_term(c, h.t));
            }
            if (h.hit) {
                rec.env_occluded = rec.env_occluded + select(0u, 1u, table);
            } else if (table) {
                let l = e.radiance * (c / e.pdf);
                vd = l * FRAC_1_PI_F32;
                if (mis) {
                    let p_lobe = glossy_pdf(params.lobe, m, n, wo, dir);
                    vg = e.radiance * glossy_brdf(params.lobe, m, n, wo, dir) * (c / (e.pdf + p_lobe));
                } else if (is_glossy) {
                    vg = l * glossy_brdf(params.lobe, m, n, wo, dir);
                }
            } else {
                // L ρ_s cos / (pdf_map + pdf_lobe): the balance heuristic's weight times f / pdf_lobe.
                let pdf = env_pdf(dir) + glossy_pdf(params.lobe, m, n, wo, dir);
                vg = vg + env_radiance(dir) * glossy_brdf(params.lobe, m, n, wo, dir) * (c / pdf);
            }
        }
        if (is_finite3(vd)) {
            ed = ed + vd;
            valid_d = valid_d + 1u;
        } else {
            rec.non_finite = rec.non_finite + 1u;
        }
        if (is_finite3(vg)) {
            eg = eg + vg;
            valid_g = valid_g + 1u;
        } else {
            rec.non_finite = rec.non_finite + 1u;
        }
    }
    accumulate_env_diffuse(kd, ed, valid_d, w);
    accumulate_env_glossy(select(vec3<f32>(0.0), ks, is_glossy), eg, valid_g, w);
}

// Rec. 709 luminance (paths.rs `luminance`).
fn luminance3(c: vec3<f32>) -> f32 {
    return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
}

// Indirect diffuse, and glossy where the surface has a lobe.
fn trace_indirect(x: vec3<f32>, n: vec3<f32>, wo: vec3<f32>, kd: vec3<f32>, ks: vec3<f32>, m: f32, is_glossy: bool,
        w: f32, pixel: u32, key_d: u32, key_g: u32, count: Secondary) {
    var e = vec3<f32>(0.0);
    var valid = 0u;
    if (count.diffuse > 0u) {
        for (var s = 0u; s < count.diffuse; s = s + 1u) {
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
        // Ambient occlusion is not reflected light: texture 1 (paths.rs `trace_indirect`).
        accumulate_diffuse(select(kd, vec3<f32>(1.0), params.ao != 0u), e, valid, w);
    }

    // Indirect glossy (`glossy` is off under ambient occlusion).
    if (is_glossy && params.glossy != 0u && count.glossy > 0u) {
        e = vec3<f32>(0.0);
        valid = 0u;
        for (var s = 0u; s < count.glossy; s = s + 1u) {
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

// PathsTrace's `Split`: a total over `paths` paths as (quotient, remainder); path t carries the quotient
// and one more where t < remainder.
fn split_total(total: u32, paths: u32) -> vec2<u32> {
    let p = max(paths, 1u);
    return vec2<u32>(total / p, total % p);
}

fn secondary_on(shadow: vec2<u32>, diffuse: vec2<u32>, glossy: vec2<u32>, environment: vec2<u32>, t: u32) -> Secondary {
    return Secondary(shadow.x + select(0u, 1u, t < shadow.y), diffuse.x + select(0u, 1u, t < diffuse.y),
        glossy.x + select(0u, 1u, t < glossy.y), environment.x + select(0u, 1u, t < environment.y));
}

fn ceil_div(a: u32, b: u32) -> u32 {
    return a / b + select(0u, 1u, a % b != 0u);
}

// Work units of one path for chunking: its rays (the camera ray, the shadow rays, per indirect
// sample of each part a ray and a next-event shadow ray per bounce, and per environment look-up one
// ray, two under MIS, where a glossy receiver adds the lobe's) in eighths, at least 1.
fn path_units(count: Secondary) -> u32 {
    var rays = 1u;
    if (params.direct != 0u) {
        rays = rays + min(count.shadow, 0x100000u);
    }
    if (params.indirect != 0u) {
        rays = rays + 2u * (min(count.diffuse, 0x100000u) + min(count.glossy, 0x100000u)) * min(params.bounces, 64u);
    }
    if (params.environment != 0u) {
        rays = rays + (1u + params.environment_mis) * min(count.environment, 0x100000u);
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
    let xy = global_xy(gid);
    let prev = previous_at(i); // zero when unbound
    var count = params.count;
    if (counts_bound()) {
        count = counts_at(i);
    }
    count = min(count, 0xffffffffu - prev.paths); // the CPU's saturating first + count
    // Per component: q samples per path and one more on the first r paths (PathsTrace's `Split`).
    // A total over the pass: its quotient and remainder per path; unbound, the per-path parameter.
    var shadow_split = vec2<u32>(params.shadow_per_primary, 0u);
    var diffuse_split = vec2<u32>(params.indirect_per_primary, 0u);
    if (shadow_total_bound()) {
        shadow_split = split_total(shadow_total_at(i), count);
    }
    if (diffuse_total_bound()) {
        diffuse_split = split_total(diffuse_total_at(i), count);
    }
    var glossy_split = diffuse_split;
    if (glossy_total_bound()) {
        glossy_split = split_total(glossy_total_at(i), count);
    }
    var environment_split = vec2<u32>(params.environment_per_primary, 0u);
    if (environment_total_bound()) {
        environment_split = split_total(environment_total_at(i), count);
    }
    // Path 0 carries the most of each: its counts size the chunks' work units.
    let n = secondary_on(shadow_split, diffuse_split, glossy_split, environment_split, 0u);
    // Chunks are counted in work units of about 8 rays (path_units): path k of this pass runs in the
    // dispatch whose unit range [chunk_begin, chunk_end) holds k·units, so a dispatch traces at most
    // ~8 × chunk rays per pixel however many secondary samples a path carries (lavapipe cuts a loop
    // after 65,535 iterations over a whole invocation: 16 paths × 64 indirect samples were cut). A
    // resuming dispatch continues the record the earlier chunks left (sums, extrema and counts: exact
    // in any chunking).
    let resume = chunk_resumes();
    let units = path_units(n);
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
    let fixed_primary = params.fixed_primary != 0u;
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
        // The path's shutter time (App. B), its own stratified dimension; 0 = the shutter's centre.
        scene_time = 0.0;
        if (params.time != 0u) {
            scene_time = 2.0 * draw(pixel, PAIR_TIME, j).x - 1.0;
        }
        if (!fixed_primary || !have_hit) {
            fixed_hit = scene_intersect(ray.origin, ray.dir, 0.0, inf());
            have_hit = true;
        }
        trace_one(c, ray, fixed_hit, pixel, key_d, key_g, secondary_on(shadow_split, diffuse_split, glossy_split, environment_split, k));
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
    let shadow = (rec.shadow - before.shadow) + (rec.bounce_shadow - before.bounce_shadow) + (rec.env_rays - before.env_rays);
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
