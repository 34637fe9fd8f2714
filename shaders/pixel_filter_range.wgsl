// pixel_filter.range — the range buffer (seed 002 Sec. 3.3.3): `count` jittered camera rays per pixel
// on filter frames, albedo under ambient + head light (pf_range_colour) averaged with the earlier
// passes', nearest depth; other frames keep the previous buffer. Mirrors
// effects/src/pixel_filter/kernels/sample.rs (RangeBuffer, range_update).
#include "common.wgsl"
#include "rng.wgsl"
#include "bvh.wgsl"
#include "sampling.wgsl"
#include "camera_path.wgsl"
#include "pixel_filter_formulas.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    var prev = vec4<f32>(0.0);
    if (previous_bound()) {
        prev = previous_at(i);
    }
    if (params.update == 0u) {
        range_put(i, prev);
        return;
    }
    let pixel = pixel_id(gid);
    let xy = global_xy(gid);
    let c = path_camera();
    let key = rng_key(frame.seed, pixel, params.stream);
    var sum = vec3<f32>(0.0);
    var depth = PF_MISS_DEPTH;
    for (var s = 0u; s < params.count; s = s + 1u) {
        let ray = path_camera_ray(c, key, s, xy);
        let hit = scene_intersect(ray.origin, ray.dir, 0.0, inf());
        if (hit.hit) {
            let sp = surface(hit.triangle, hit.b1, hit.b2, ray.dir);
            let m = material(sp.material);
            let cs = abs(dot3(sp.shading_normal, -ray.dir));
            sum = sum + pf_range_colour(albedo(sp), m.specular, cs);
            depth = rmin(depth, hit.t);
        }
    }
    var col = vec3<f32>(0.0);
    if (params.count > 0u) {
        col = sum / f32(params.count);
    }
    atomicAdd(&counters[COUNTER_PRIMARY], params.count);
    let k = params.pass_index;
    if (previous_bound() && k > 1.0) {
        let cc = prev.xyz + (col - prev.xyz) / k;
        range_put(i, vec4<f32>(cc, rmin(prev.w, depth)));
    } else {
        range_put(i, vec4<f32>(col, depth));
    }
}
