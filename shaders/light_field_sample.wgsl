// light_field.sample — per pixel `count` camera paths (through the pixel centre, each from its own
// lens point and at its own shutter time where the pass has a lens / `time`; else one pinhole ray at
// the shutter's centre, traced once), one secondary ray each traced as a path (next-event estimation
// at `bounces` vertices) at the path's time; the first `layers` kept as LightSample records, the
// first `primaries` primary hits as LightPrimary records, and their plain Monte Carlo estimate;
// mirrors effects/src/light_field/kernels/sample.rs (Setup::pixel and its phases; the camera rays of
// camera_paths.rs CameraDraws, `camera_path.wgsl`) with the same RNG calls and dimensions. Chunked over the paths (a reference's N): between dispatches
// `estimate` holds the running sums (Σ w·L f cos/pdf, Σ w), the last one their mean.
#include "common.wgsl"
#include "rng.wgsl"
#include "bvh.wgsl"
#include "sampling.wgsl"
#include "camera.wgsl"
#include "camera_path.wgsl"
#include "hemisphere.wgsl"
#include "indirect_path.wgsl"
#include "light_field_common.wgsl"

// κ of eq. 2 for a surface with glossy lobe k_s, m (mod.rs kappa).
fn lf_kappa(ks: vec3<f32>, m: f32) -> f32 {
    if (m > 0.0 && max_element3(ks) > 0.0) {
        var blinn = 4.0 * m;
        if (params.lobe == 1u) {
            blinn = m;
        }
        return 4.0 * sqrt(blinn);
    }
    return 0.0;
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let layers = params.layers;
    var sum = vec3<f32>(0.0);
    var sum_w = 0.0;
    if (chunk_resumes()) {
        let running = estimate_at(i);
        sum = running.xyz;
        sum_w = running.w;
    } else {
        let none = LightSample(vec3<f32>(0.0), SAMPLE_NONE, vec3<f32>(0.0), 0.0, vec3<f32>(0.0), 0.0, vec3<f32>(0.0), 0.0,
            vec3<f32>(0.0), vec3<f32>(0.0), vec2<f32>(0.0));
        for (var s = 0u; s < layers; s = s + 1u) {
            samples_put(i * layers + s, none);
        }
    }
    let c = path_camera();
    // A pinhole at the shutter's centre: one camera ray for every path of the pixel.
    let fixed = params.cam_aperture == 0.0 && params.cam_shutter == 0u;
    let xy = pixel_xy(gid);
    let key = rng_key(frame.seed, pixel_id(gid), params.stream);
    var bad = 0u;
    var rays_primary = 0u;
    // As the CPU: a fixed camera ray is traced once (per dispatch: a later chunk re-traces it,
    // uncounted).
    var fixed_hit: Hit;
    var have_hit = false;
    let end = chunk_end_of(params.count);
    var s = frame.chunk_begin;
    for (; s < end; s = s + 1u) {
        // Through the pixel centre (`params.jitter` = 0), at the path's lens point and time.
        let ray = path_camera_ray(c, key, s, xy);
        if (!fixed || !have_hit) {
            fixed_hit = scene_intersect(ray.origin, ray.dir, 0.0, inf());
            have_hit = true;
            if (!fixed || frame.chunk_begin == 0u) {
                rays_primary = rays_primary + 1u;
            }
        }
        let camera_hit = fixed_hit;
        var prim = LightPrimary(vec3<f32>(0.0), 0u, vec3<f32>(0.0), 0.0, vec3<f32>(0.0), scene_time, vec3<f32>(0.0), ray.weight, ray.origin);
        if (camera_hit.hit) {
            let sp = surface(camera_hit.triangle, camera_hit.b1, camera_hit.b2, ray.dir);
            let mat = material(sp.material);
            prim.position = sp.position;
            prim.valid = 1u;
            prim.normal = sp.shading_normal;
            prim.m = mat.phong_exponent;
            prim.kd = albedo(sp);
            prim.ks = mat.specular;
        }
        if (s < params.primaries) {
            primary_put(i * params.primaries + s, prim);
        }
        if (!camera_hit.hit) {
            // The camera ray left the scene: no indirect light along it.
            sum_w = sum_w + ray.weight;
            continue;
        }
        let x = prim.position;
        let n = prim.normal;
        let wo = normalize_or_zero3(ray.origin - x);
        let l = lf_leave(n, prim.kd, prim.ks, prim.m, wo, key, s, params.count, params.stratified != 0u);
        let side = select(-1.0, 1.0, dot3(l.wi, n) >= 0.0);
        let origin = x + n * (side * params.eps);
        rays_secondary = rays_secondary + 1u;
        let hit = scene_intersect(origin, l.wi, 0.0, inf());
        var rec = LightSample(origin, SAMPLE_ESCAPED, vec3<f32>(0.0), 0.0, vec3<f32>(0.0), 0.0, l.wi, scene_time,
            vec3<f32>(0.0), vec3<f32>(0.0), ray.lens);
        var value = vec3<f32>(0.0);
        if (hit.hit) {
            let sp = surface(hit.triangle, hit.b1, hit.b2, l.wi);
            let mat = material(sp.material);
            var radiance = vec3<f32>(0.0);
            if (params.ao != 0u) {
                radiance = vec3<f32>(select(0.0, 1.0, lf_ao_occluded(hit.t)));
            } else {
                radiance = path_from_hit(hit, origin, l.wi, key, s).value;
            }
            value = radiance;
            rec.flags = SAMPLE_HIT;
            rec.hit = sp.position;
            rec.distance = hit.t;
            rec.normal = sp.shading_normal;
            if (params.angular != 0u) {
                rec.kappa = lf_kappa(mat.specular, mat.phong_exponent);
            }
            rec.radiance = radiance;
            rec.velocity = object_velocity(sp.object, sp.position);
        }
        let contribution = value * l.weight;
        if (is_finite3(contribution)) {
            sum = sum + contribution * ray.weight;
            sum_w = sum_w + ray.weight;
        } else {
            bad = bad + 1u;
            rec.radiance = vec3<f32>(0.0);
        }
        if (s < layers) {
            samples_put(i * layers + s, rec);
        }
    }
    count_cut_loop(s, end);
    if (end < params.count) {
        estimate_put(i, vec4<f32>(sum, sum_w));
    } else {
        var mean = vec3<f32>(0.0);
        if (sum_w > 0.0) {
            mean = sum / sum_w;
        }
        estimate_put(i, vec4<f32>(mean, sum_w));
    }
    atomicAdd(&counters[COUNTER_PRIMARY], rays_primary);
    atomicAdd(&counters[COUNTER_SHADOW], rays_shadow);
    atomicAdd(&counters[COUNTER_SECONDARY], rays_secondary);
    atomicAdd(&counters[COUNTER_NON_FINITE], bad);
}
