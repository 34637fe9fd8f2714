// primary.gbuffer — one primary ray through each pixel centre; mirrors
// backends/src/kernels/primary.rs (camera ray, BVH closest hit, surface, albedo, emission, footprint).
#include "common.wgsl"
#include "bvh.wgsl"
#include "sampling.wgsl"

struct Ray {
    o: vec3<f32>,
    d: vec3<f32>,
}

// Camera::generate_ray with lens = (0.5, 0.5).
fn generate_ray(px: f32, py: f32) -> Ray {
    let right = params.right;
    let up = params.up;
    let forward = params.forward;
    let position = params.position;
    let tan_half = params.tan_half;
    let w = f32(max(frame.full_width, 1u));
    let h = f32(max(frame.full_height, 1u));
    let sx = (2.0 * px / w - 1.0) * tan_half * (w / h);
    let sy = (1.0 - 2.0 * py / h) * tan_half;
    let dir = normalize3(forward + sx * right + sy * up);
    let aperture = params.aperture;
    if (aperture <= 0.0) {
        return Ray(position, dir);
    }
    let focus = position + dir * (params.focus_distance / dot3(dir, forward));
    let d = concentric_disk(vec2<f32>(0.5)) * aperture;
    let origin = position + d.x * right + d.y * up;
    return Ray(origin, normalize3(focus - origin));
}

fn put3(buf_is_albedo: bool, i: u32, v: vec3<f32>) {
    if (buf_is_albedo) {
        albedo_put(i, v);
    } else {
        emission_put(i, v);
    }
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    atomicAdd(&counters[COUNTER_PRIMARY], 1u);
    let xy = global_xy(gid);
    let ray = generate_ray(f32(xy.x) + 0.5, f32(xy.y) + 0.5);
    let hit = scene_intersect(ray.o, ray.d, 0.0, inf());
    if (!hit.hit) {
        position_put(i, vec4<f32>(0.0));
        normal_put(i, vec4<f32>(0.0));
        put3(true, i, vec3<f32>(0.0));
        // A camera ray that leaves the scene sees the environment (black without a map).
        put3(false, i, scene_background(ray.d));
        if (specular_bound()) {
            specular_put(i, vec4<f32>(0.0));
        }
        return;
    }
    let sp = surface(hit.triangle, hit.b1, hit.b2, ray.d);
    let n = sp.shading_normal;
    let c = rmax(abs(dot3(n, -ray.d)), 0.05);
    let footprint = hit.t * params.pixel_angle / sqrt(c);
    position_put(i, vec4<f32>(sp.position, 1.0 + f32(sp.object)));
    normal_put(i, vec4<f32>(n, footprint));
    put3(true, i, albedo(sp));
    put3(false, i, emission(sp));
    if (specular_bound()) {
        let m = material(sp.material);
        specular_put(i, vec4<f32>(m.specular, m.phong_exponent));
    }
}
