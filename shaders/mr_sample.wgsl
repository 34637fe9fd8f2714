// mr.sample — two-mode sampling of the real and the virtual world (thesis Ch. 6, Algorithm 1 of the
// supplement); mirrors effects/src/mixed_reality/kernels/sample.rs (sample_pixel, secondary,
// virtual_hit_radiance) with the same samples and operation order.
#include "common.wgsl"
#include "sobol.wgsl"
#include "camera.wgsl"
#include "bvh.wgsl"
#include "environment_light.wgsl"
#include "screen_trace.wgsl"

const REAL_OBJECT: u32 = 4194304u;


struct Sums {
    e_r_dir: vec3<f32>,
    e_r_ind: vec3<f32>,
    e_rv_dir: vec3<f32>,
    e_rv_ind: vec3<f32>,
    e_v_dir: vec3<f32>,
    e_v_ind: vec3<f32>,
    real_samples: u32,
    virtual_samples: u32,
    real_primary: u32,
    virtual_primary: u32,
    k_v: vec3<f32>,
    virtual_position: vec3<f32>,
    virtual_normal: vec3<f32>,
    virtual_object: u32,
    occluder: f32,
    exponent: f32,
    look_ups: u32,
    blocked: u32,
    z_min: f32,
    z_max: f32,
    ind_hits: u32,
    ind_rays: u32,
    screen_rays: u32,
    offscreen: u32,
    screen_hits: u32,
    primary_rays: u32,
    shadow_rays: u32,
    indirect_rays: u32,
    non_finite: u32,
}

var<private> sums: Sums;

fn mr_draw(pixel: u32, pair: u32, index: u32) -> vec2<f32> {
    let key = sequence_key(frame.seed, pixel, params.stream, pair);
    if (params.stratified != 0u) {
        return sobol2(key, index);
    }
    return independent2(key, index);
}

fn mr_luminance(c: vec3<f32>) -> f32 {
    return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
}

// A screen-space ray, counted.
fn mr_screen(o: vec3<f32>, d: vec3<f32>) -> ScreenHit {
    sums.screen_rays = sums.screen_rays + 1u;
    let h = screen_trace(o, d);
    if (h.kind == SCREEN_OFFSCREEN) {
        sums.offscreen = sums.offscreen + 1u;
    } else if (h.kind == SCREEN_HIT) {
        sums.screen_hits = sums.screen_hits + 1u;
    }
    return h;
}

fn per_k(l: vec3<f32>, k_v: vec3<f32>) -> vec3<f32> {
    var out = vec3<f32>(0.0);
    if (k_v.x > 0.0) { out.x = l.x / k_v.x; }
    if (k_v.y > 0.0) { out.y = l.y / k_v.y; }
    if (k_v.z > 0.0) { out.z = l.z / k_v.z; }
    return out;
}

fn virtual_hit_radiance(y: vec3<f32>, n: vec3<f32>, wo: vec3<f32>, kd: vec3<f32>, ks: vec3<f32>, m: f32, u: f32) -> vec3<f32> {
    let e = env_table(env_uniform_entry(u));
    let c = dot3(n, e.dir);
    if (!(c > 0.0 && e.pdf > 0.0)) {
        return vec3<f32>(0.0);
    }
    let origin = y + n * params.eps;
    sums.shadow_rays = sums.shadow_rays + 1u;
    if (scene_occluded(origin, e.dir, 0.0, inf())) {
        return vec3<f32>(0.0);
    }
    sums.shadow_rays = sums.shadow_rays + 1u;
    if (mr_screen(origin, e.dir).kind == SCREEN_HIT) {
        return vec3<f32>(0.0);
    }
    return e.radiance * surface_brdf(kd, ks, m, n, wo, e.dir) * (c / e.pdf);
}

fn finite_or_zero(v: vec3<f32>) -> vec3<f32> {
    if (is_finite3(v)) {
        return v;
    }
    return vec3<f32>(0.0);
}

fn secondary(pixel: u32, shift: u32, first: u32, x: vec3<f32>, n: vec3<f32>, wo: vec3<f32>, kd: vec3<f32>, ks: vec3<f32>, m: f32, real: bool) {
    let origin = x + n * params.eps;
    let k_v = kd + ks;
    let glossy = !real && m > 0.0 && max_element3(ks) > 0.0;
    let lum_d = mr_luminance(kd);
    var lum_s = 0.0;
    if (glossy) {
        lum_s = mr_luminance(ks);
    }
    var p_glossy = 0.0;
    if (lum_d + lum_s > 0.0) {
        p_glossy = lum_s / (lum_d + lum_s);
    }
    for (var j = 0u; j < params.per_primary; j = j + 1u) {
        let q = first + j;
        if (real) {
            sums.real_samples = sums.real_samples + 1u;
        } else {
            sums.virtual_samples = sums.virtual_samples + 1u;
        }
        // Direct light: look-up q of the table.
        sums.look_ups = sums.look_ups + 1u;
        var entry = 0u;
        if (params.stratified != 0u) {
            entry = env_stratified_entry(shift, q);
        } else {
            entry = env_uniform_entry(mr_draw(pixel, PAIR_ENVIRONMENT, q).x);
        }
        let e = env_table(entry);
        let c = dot3(n, e.dir);
        var dir_r = vec3<f32>(0.0);
        var dir_rv = vec3<f32>(0.0);
        if (c > 0.0 && e.pdf > 0.0) {
            sums.shadow_rays = sums.shadow_rays + 2u;
            let bright = mr_luminance(e.radiance) >= params.occluder_luminance;
            // Closest hit where bright, any hit otherwise: one inlined traversal (docs/DESIGN-NOTES.md,
            // "Cold compiles in CI").
            let hv = scene_trace(origin, e.dir, 0.0, inf(), !bright);
            let has_v = hv.hit;
            var t_v = inf();
            if (hv.hit && bright) {
                t_v = hv.t;
            }
            let hr = mr_screen(origin, e.dir);
            let has_r = hr.kind == SCREEN_HIT;
            if (has_v || has_r) {
                sums.blocked = sums.blocked + 1u;
                var t_r = inf();
                if (has_r) {
                    t_r = hr.t;
                }
                let t = rmin(t_v, t_r);
                if (bright && is_finite(t) && t > 0.0) {
                    sums.occluder = rmax(sums.occluder, c / t);
                }
            }
            let l = e.radiance * (c / e.pdf);
            if (real) {
                let lit = l * FRAC_1_PI_F32;
                if (!has_r) {
                    dir_r = lit;
                    if (!has_v) {
                        dir_rv = lit;
                    }
                }
            } else if (!has_r && !has_v) {
                dir_rv = per_k(l * surface_brdf(kd, ks, m, n, wo, e.dir), k_v);
            }
        }
        // Indirect light: one direction from the receiver's BRDF.
        let u = mr_draw(pixel, PAIR_HEMISPHERE_DIFFUSE, q);
        let pick = mr_draw(pixel, PAIR_HEMISPHERE_GLOSSY, q);
        var wi = vec3<f32>(0.0);
        if (glossy && pick.x < p_glossy) {
            wi = sample_glossy(LOBE_PHONG, m, n, wo, u).wi;
        } else {
            wi = sample_diffuse(n, u);
        }
        let cos_i = dot3(n, wi);
        var ind_r = vec3<f32>(0.0);
        var ind_rv = vec3<f32>(0.0);
        if (cos_i > 0.0 && is_finite3(wi)) {
            let pdf_d = cos_i * FRAC_1_PI_F32;
            var pdf = pdf_d;
            if (glossy) {
                pdf = (1.0 - p_glossy) * pdf_d + p_glossy * glossy_pdf(LOBE_PHONG, m, n, wo, wi);
            }
            sums.ind_rays = sums.ind_rays + 1u;
            sums.indirect_rays = sums.indirect_rays + 2u;
            let hit_v = scene_intersect(origin, wi, 0.0, inf());
            let hit_r = mr_screen(origin, wi);
            let has_r = hit_r.kind == SCREEN_HIT;
            var l_r = vec3<f32>(0.0);
            if (has_r) {
                l_r = real_camera(i32(hit_r.x), i32(hit_r.y));
            }
            var l_v = vec3<f32>(0.0);
            if (hit_v.hit) {
                let sp = surface(hit_v.triangle, hit_v.b1, hit_v.b2, wi);
                let mat = material(sp.material);
                let kd_v = albedo(sp);
                let u_env = mr_draw(pixel, PAIR_PATH, q).x;
                l_v = virtual_hit_radiance(sp.position, sp.shading_normal, -wi, kd_v, mat.specular, mat.phong_exponent, u_env);
            }
            var has_near = false;
            var t_near = 0.0;
            var l_near = vec3<f32>(0.0);
            if (has_r && hit_v.hit) {
                has_near = true;
                if (hit_r.t < hit_v.t) {
                    t_near = hit_r.t;
                    l_near = l_r;
                } else {
                    t_near = hit_v.t;
                    l_near = l_v;
                }
            } else if (has_r) {
                has_near = true;
                t_near = hit_r.t;
                l_near = l_r;
            } else if (hit_v.hit) {
                has_near = true;
                t_near = hit_v.t;
                l_near = l_v;
            }
            if (has_near) {
                sums.ind_hits = sums.ind_hits + 1u;
                if (sums.ind_hits == 1u) {
                    sums.z_min = t_near;
                    sums.z_max = t_near;
                } else {
                    sums.z_min = rmin(sums.z_min, t_near);
                    sums.z_max = rmax(sums.z_max, t_near);
                }
            }
            if (pdf > 0.0) {
                if (real) {
                    if (has_r) {
                        ind_r = l_r * (cos_i * FRAC_1_PI_F32 / pdf);
                    }
                    if (has_near) {
                        ind_rv = l_near * (cos_i * FRAC_1_PI_F32 / pdf);
                    }
                } else {
                    let f = surface_brdf(kd, ks, m, n, wo, wi);
                    if (has_r) {
                        ind_r = per_k(l_r * f * (cos_i / pdf), k_v);
                    }
                    if (has_near) {
                        ind_rv = per_k(l_near * f * (cos_i / pdf), k_v);
                    }
                }
            }
        }
        if (!is_finite3(dir_r)) { sums.non_finite = sums.non_finite + 1u; }
        if (!is_finite3(dir_rv)) { sums.non_finite = sums.non_finite + 1u; }
        if (!is_finite3(ind_r)) { sums.non_finite = sums.non_finite + 1u; }
        if (!is_finite3(ind_rv)) { sums.non_finite = sums.non_finite + 1u; }
        if (real) {
            sums.e_r_dir = sums.e_r_dir + finite_or_zero(dir_r);
            sums.e_rv_dir = sums.e_rv_dir + finite_or_zero(dir_rv);
            sums.e_r_ind = sums.e_r_ind + finite_or_zero(ind_r);
            sums.e_rv_ind = sums.e_rv_ind + finite_or_zero(ind_rv);
        } else {
            sums.e_v_dir = sums.e_v_dir + finite_or_zero(dir_rv);
            sums.e_v_ind = sums.e_v_ind + finite_or_zero(ind_rv);
        }
    }
}

fn mean3(v: vec3<f32>, n: u32) -> vec3<f32> {
    if (n > 0u) {
        return v / f32(n);
    }
    return vec3<f32>(0.0);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    // The pixel's place in the full image: the real layer, camera rays and random numbers use it.
    let xy = global_xy(gid);
    let px = xy.x;
    let py = xy.y;
    let pixel = pixel_id(gid);
    let cam = CameraModel(params.cam_position, params.cam_right, params.cam_up, params.cam_forward, params.cam_tan_half,
        params.cam_aperture, params.cam_focus_distance, params.cam_gaussian);
    var shift = 0u;
    if (params.stratified != 0u) {
        shift = env_uniform_entry(mr_draw(pixel, PAIR_ENVIRONMENT, 0u).x);
    }
    let real_pw = real_position(i32(px), i32(py));
    let has_real = real_pw.w > 0.0;
    let h = f32(max(frame.full_height, 1u));
    let pixel_angle = 2.0 * params.cam_tan_half / h;
    var footprint = 0.0;
    // Chunks (WgslSource::chunked): this dispatch takes primary samples [chunk_begin, end); a pixel
    // finished by an earlier chunk keeps its outputs; one that resumes restores its running sums.
    let resume = chunk_resumes();
    let end = chunk_end_of(params.count);
    if (resume && end <= frame.chunk_begin) {
        return;
    }
    if (resume) {
        footprint = restore_sums(i, has_real);
    }
    var s = frame.chunk_begin;
    for (; s < end; s = s + 1u) {
        var jitter = vec2<f32>(0.5);
        if (params.count > 1u) {
            jitter = mr_draw(pixel, PAIR_PIXEL, s);
        }
        let ray = camera_ray(cam, vec2<f32>(f32(px) + jitter.x, f32(py) + jitter.y), vec2<f32>(0.5));
        let o = ray.origin;
        let d = ray.dir;
        sums.primary_rays = sums.primary_rays + 1u;
        let hit = scene_intersect(o, d, 0.0, inf());
        var real = true;
        if (hit.hit) {
            if (has_real) {
                real = length3(real_pw.xyz - o) < hit.t;
            } else {
                real = false;
            }
        }
        let first = s * params.per_primary;
        if (real) {
            sums.real_primary = sums.real_primary + 1u;
            if (!has_real) {
                continue;
            }
            let n = real_normal(i32(px), i32(py));
            secondary(pixel, shift, first, real_pw.xyz, n, -d, vec3<f32>(1.0), vec3<f32>(0.0), 0.0, true);
        } else {
            let sp = surface(hit.triangle, hit.b1, hit.b2, d);
            let mat = material(sp.material);
            let kd = albedo(sp);
            let ks = mat.specular;
            let m = mat.phong_exponent;
            sums.virtual_primary = sums.virtual_primary + 1u;
            sums.k_v = sums.k_v + (kd + ks);
            sums.virtual_position = sums.virtual_position + sp.position;
            sums.virtual_normal = sums.virtual_normal + sp.shading_normal;
            if (sums.virtual_object == 0u) {
                sums.virtual_object = 1u + sp.object;
            }
            let glossy = m > 0.0 && max_element3(ks) > 0.0;
            if (glossy) {
                sums.exponent = sums.exponent + m;
            } else {
                sums.exponent = sums.exponent + 0.0;
            }
            let c = rmax(abs(dot3(sp.shading_normal, -d)), 0.05);
            footprint = footprint + hit.t * pixel_angle / sqrt(c);
            secondary(pixel, shift, first, sp.position, sp.shading_normal, -d, kd, ks, m, false);
        }
    }
    count_cut_loop(s, end);
    if (end < params.count) {
        save_sums(i, footprint);
        add_counters();
        return;
    }
    let nr = sums.real_samples;
    let nv = sums.virtual_samples;
    let total = sums.real_primary + sums.virtual_primary;
    var m_real = 1.0;
    if (total > 0u) {
        m_real = f32(sums.real_primary) / f32(total);
    }
    let k_v = mean3(sums.k_v, sums.virtual_primary);
    let real_surfaces = sums.real_samples / max(params.per_primary, 1u);
    var position = vec4<f32>(0.0);
    var normal = vec4<f32>(0.0);
    if (real_surfaces > 0u && real_surfaces >= sums.virtual_primary) {
        let p = real_pw.xyz;
        let n = real_normal(i32(px), i32(py));
        let z = length3(p - params.cam_position);
        let c = rmax(abs(dot3(n, normalize_or_zero3(params.cam_position - p))), 0.05);
        position = vec4<f32>(p, 1.0 + f32(REAL_OBJECT));
        normal = vec4<f32>(n, z * pixel_angle / sqrt(c));
    } else if (sums.virtual_primary > 0u) {
        let k = f32(sums.virtual_primary);
        let p = sums.virtual_position / k;
        let n = normalize_or_zero3(sums.virtual_normal / k);
        position = vec4<f32>(p, f32(sums.virtual_object));
        normal = vec4<f32>(n, footprint / k);
    }
    var exponent = 0.0;
    if (sums.virtual_primary > 0u) {
        exponent = sums.exponent / f32(sums.virtual_primary);
    }
    e_r_dir_put(i, mean3(sums.e_r_dir, nr));
    e_r_ind_put(i, mean3(sums.e_r_ind, nr));
    e_rv_dir_put(i, mean3(sums.e_rv_dir, nr));
    e_rv_ind_put(i, mean3(sums.e_rv_ind, nr));
    e_v_dir_put(i, mean3(sums.e_v_dir, nv));
    e_v_ind_put(i, mean3(sums.e_v_ind, nv));
    texture_put(i, vec4<f32>(k_v, m_real));
    position_put(i, position);
    normal_put(i, normal);
    environment_put(i, vec4<f32>(sums.occluder, exponent, f32(sums.look_ups), f32(sums.blocked)));
    var z_min = 0.0;
    if (sums.ind_hits > 0u) {
        z_min = sums.z_min;
    }
    depth_put(i, vec4<f32>(z_min, sums.z_max, f32(sums.ind_hits), f32(sums.ind_rays)));
    if (screen_bound()) {
        screen_put(i, vec4<f32>(f32(sums.screen_rays), f32(sums.offscreen), f32(sums.screen_hits), 0.0));
    }
    add_counters();
}

fn add_counters() {
    atomicAdd(&counters[COUNTER_PRIMARY], sums.primary_rays);
    atomicAdd(&counters[COUNTER_SHADOW], sums.shadow_rays);
    atomicAdd(&counters[COUNTER_SECONDARY], sums.indirect_rays);
    atomicAdd(&counters[COUNTER_NON_FINITE], sums.non_finite);
}

// Between chunks a pixel's outputs hold its raw running sums (the final means are taken once, from
// the same sums in the same order as one dispatch: the image does not depend on chunking). Counts
// are stored as f32, exact below 2^24. Not kept: the ray counters (added per dispatch) and the
// sample counts, which follow from the primaries taken (`chunk_begin`): `real_primary` is stored,
// the rest are virtual, and each primary with a surface takes `per_primary` samples.
fn save_sums(i: u32, footprint: f32) {
    e_r_dir_put(i, sums.e_r_dir);
    e_r_ind_put(i, sums.e_r_ind);
    e_rv_dir_put(i, sums.e_rv_dir);
    e_rv_ind_put(i, sums.e_rv_ind);
    e_v_dir_put(i, sums.e_v_dir);
    e_v_ind_put(i, sums.e_v_ind);
    texture_put(i, vec4<f32>(sums.k_v, f32(sums.real_primary)));
    position_put(i, vec4<f32>(sums.virtual_position, f32(sums.virtual_object)));
    normal_put(i, vec4<f32>(sums.virtual_normal, footprint));
    environment_put(i, vec4<f32>(sums.occluder, sums.exponent, f32(sums.look_ups), f32(sums.blocked)));
    depth_put(i, vec4<f32>(sums.z_min, sums.z_max, f32(sums.ind_hits), f32(sums.ind_rays)));
    if (screen_bound()) {
        screen_put(i, vec4<f32>(f32(sums.screen_rays), f32(sums.offscreen), f32(sums.screen_hits), 0.0));
    }
}

// The sums `save_sums` left in the outputs; returns the footprint sum.
fn restore_sums(i: u32, has_real: bool) -> f32 {
    sums.e_r_dir = e_r_dir_at(i);
    sums.e_r_ind = e_r_ind_at(i);
    sums.e_rv_dir = e_rv_dir_at(i);
    sums.e_rv_ind = e_rv_ind_at(i);
    sums.e_v_dir = e_v_dir_at(i);
    sums.e_v_ind = e_v_ind_at(i);
    let t = texture_at(i);
    sums.k_v = t.xyz;
    sums.real_primary = u32(t.w);
    sums.virtual_primary = frame.chunk_begin - sums.real_primary;
    if (has_real) {
        sums.real_samples = sums.real_primary * params.per_primary;
    }
    sums.virtual_samples = sums.virtual_primary * params.per_primary;
    let p = position_at(i);
    sums.virtual_position = p.xyz;
    sums.virtual_object = u32(p.w);
    let n = normal_at(i);
    sums.virtual_normal = n.xyz;
    let e = environment_at(i);
    sums.occluder = e.x;
    sums.exponent = e.y;
    sums.look_ups = u32(e.z);
    sums.blocked = u32(e.w);
    let z = depth_at(i);
    sums.z_min = z.x;
    sums.z_max = z.y;
    sums.ind_hits = u32(z.z);
    sums.ind_rays = u32(z.w);
    if (screen_bound()) {
        let c = screen_at(i);
        sums.screen_rays = u32(c.x);
        sums.offscreen = u32(c.y);
        sums.screen_hits = u32(c.z);
    }
    return n.w;
}
