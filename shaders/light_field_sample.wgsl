// light_field.sample — `count` secondary rays per primary hit, each a path (next-event estimation
// at `bounces` vertices), the first `layers` kept as LightSample records, and their plain Monte
// Carlo estimate; mirrors backends/src/kernels/light_field/mod.rs (LightFieldSample::run_cpu) with
// the same RNG calls and dimensions. Not chunked: the unfiltered mean has no room for a running
// count, and `count` (spp, or a reference's N) stays far below a driver's loop cap.
#include "common.wgsl"
#include "rng.wgsl"
#include "bvh.wgsl"
#include "sampling.wgsl"
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
    let none = LightSample(vec3<f32>(0.0), SAMPLE_NONE, vec3<f32>(0.0), 0.0, vec3<f32>(0.0), 0.0, vec3<f32>(0.0), vec3<f32>(0.0));
    for (var s = 0u; s < layers; s = s + 1u) {
        samples_put(i * layers + s, none);
    }
    let pos = position_at(i);
    if (pos.w == 0.0) {
        unfiltered_put(i, vec3<f32>(0.0));
        return;
    }
    let x = pos.xyz;
    let n = normal_at(i).xyz;
    var kd = vec3<f32>(1.0);
    if (albedo_bound()) {
        kd = albedo_at(i);
    }
    var spec = vec4<f32>(0.0);
    if (specular_bound()) {
        spec = specular_at(i);
    }
    let wo = normalize_or_zero3(params.camera - x);
    let key = rng_key(frame.seed, pixel_id(gid), params.stream);
    var sum = vec3<f32>(0.0);
    var valid = 0u;
    var bad = 0u;
    var s = 0u;
    for (; s < params.count; s = s + 1u) {
        let l = lf_leave(n, kd, spec.xyz, spec.w, wo, key, s, params.count, params.stratified != 0u);
        let side = select(-1.0, 1.0, dot3(l.wi, n) >= 0.0);
        let origin = x + n * (side * params.eps);
        rays_secondary = rays_secondary + 1u;
        let hit = scene_intersect(origin, l.wi, 0.0, inf());
        var rec = LightSample(origin, SAMPLE_ESCAPED, vec3<f32>(0.0), 0.0, vec3<f32>(0.0), 0.0, l.wi, vec3<f32>(0.0));
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
        }
        let contribution = value * l.weight;
        if (is_finite3(contribution)) {
            sum = sum + contribution;
            valid = valid + 1u;
        } else {
            bad = bad + 1u;
            rec.radiance = vec3<f32>(0.0);
        }
        if (s < layers) {
            samples_put(i * layers + s, rec);
        }
    }
    count_cut_loop(s, params.count);
    var mean = vec3<f32>(0.0);
    if (valid > 0u) {
        mean = sum / f32(valid);
    }
    unfiltered_put(i, mean);
    atomicAdd(&counters[COUNTER_SHADOW], rays_shadow);
    atomicAdd(&counters[COUNTER_SECONDARY], rays_secondary);
    atomicAdd(&counters[COUNTER_NON_FINITE], bad);
}
