// light_sample.wgsl — the direct-light estimator shared by direct.light and paths.trace: one shadow
// ray toward a point on an area light, and the centre-of-light form factor (thesis eq. 3.1's r(x),
// Ch. 5's f_c); mirrors backends/src/kernels/direct.rs (light_sample, light_centre_factor).
// The including kernel's Params must have `extent` (the scene's extent, for the ray offset).
#include "common.wgsl"
#include "bvh.wgsl"
#include "sampling.wgsl"

const RAY_EPSILON: f32 = 1e-4;

// direct.rs `light_sample`'s value and `Occluder`: where occluded (and the distance wanted), the
// occluder's distance to the light plane and its hit on the ray `origin + t·dir`.
struct LightSample {
    value: vec3<f32>,
    unshadowed: vec3<f32>, // the value were the light visible (direct.rs LightSample::unshadowed)
    occluded: bool,
    distance: f32,
    hit: Hit,
    origin: vec3<f32>,
    dir: vec3<f32>,
}

fn light_sample(l: Light, x: vec3<f32>, n: vec3<f32>, u: vec2<f32>, use_centre: bool, factor: vec3<f32>, want_distance: bool) -> LightSample {
    var r = LightSample(vec3<f32>(0.0), vec3<f32>(0.0), false, 0.0, no_hit(), vec3<f32>(0.0), vec3<f32>(0.0));
    let y = light_sample_point(l, u);
    let to = y - x;
    let r2 = dot3(to, to);
    let dir = to / sqrt(r2);
    let cos_x = dot3(n, dir);
    let ln = l.normal_area.xyz;
    let cos_y = light_facing_cos(l, dir);
    if (cos_x <= 0.0 || cos_y <= 0.0) {
        return r;
    }
    if (use_centre) {
        r.unshadowed = factor;
    } else {
        r.unshadowed = l.radiance.xyz * (cos_x * cos_y / r2 * l.normal_area.w / PI_F32);
    }
    let origin = x + n * (RAY_EPSILON * params.extent);
    let seg = y - origin;
    let seg_len = length3(seg);
    let ray_dir = seg / seg_len;
    let tmax = seg_len * bitcast<f32>(0x3f7ff972u); // (1.0 - 1e-4) in f32
    // Closest hit where the occluder's distance is wanted, any hit otherwise: one `scene_trace` call
    // site either way (the traversal is inlined per site; docs/DESIGN-NOTES.md, "Cold compiles in CI").
    let hit = scene_trace(origin, ray_dir, 0.0, tmax, !want_distance);
    if (hit.hit) {
        if (want_distance) {
            let p = origin + ray_dir * hit.t;
            r.occluded = true;
            r.distance = abs(dot3(l.centre_sigma.xyz - p, ln));
            r.hit = hit;
            r.origin = origin;
            r.dir = ray_dir;
        }
        return r;
    }
    r.value = r.unshadowed;
    return r;
}

fn light_centre_factor(l: Light, x: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let to = l.centre_sigma.xyz - x;
    let r2 = dot3(to, to);
    let dir = to / sqrt(r2);
    let cos_x = rmax(dot3(n, dir), 0.0);
    var cos_y = dot3(l.normal_area.xyz, -dir);
    if (l.two_sided != 0u) {
        cos_y = abs(cos_y);
    } else {
        cos_y = rmax(cos_y, 0.0);
    }
    return l.radiance.xyz * (cos_x * cos_y / r2 * l.normal_area.w / PI_F32);
}

