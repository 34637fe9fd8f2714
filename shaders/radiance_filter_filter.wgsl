// radiance_filter.filter — eqs. 4.10-4.12 (seed 002): the neighbours' incident radiance samples under
// this pixel's BRDF and pdf, weighted by the Epanechnikov kernel on the tangent plane (eqs. 4.19-4.22)
// and the normal heuristic (eq. 4.9); the per-path variance filtered with the same weights (Sec.
// 4.3.4). Mirrors effects/src/radiance_filter/kernels.rs (Filter::run_cpu).
#include "common.wgsl"
#include "hemisphere.wgsl"
#include "lobe_mixture.wgsl"
#include "radiance_filter_formulas.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let c = pixel_index(gid);
    let xy = vec2<i32>(pixel_xy(gid));
    let w = i32(frame.width);
    let h = i32(frame.height);
    let r = radius_at(c);
    let half = rf_window(r, params.max_radius);
    let pc = point_at(c);
    if (!(pc.w > 0.0)) {
        filtered_put(c, vec4<f32>(0.0, 0.0, 0.0, RF_OWN));
        variance_put(c, vec4<f32>(0.0, 0.0, r, 0.0));
        return;
    }
    let x = pc.xyz;
    let nc = normal_at(c);
    let n = nc.xyz;
    let mat = material(u32(nc.w));
    let kd = albedo_at(c).xyz;
    let ks = mat.specular;
    let m = mat.phong_exponent;
    let mix = lobe_mixture(kd, ks, m);
    let e = rf_normal_exponent(ks, m);
    let wo = normalize_or_zero3(params.eye - x);
    let kernel = rf_tangent_kernel(x, n, params.eye, pc.w, rmax(r, 1.0), params.pixel_angle, params.thickness);
    var sum_w = 0.0;
    var sum = vec3<f32>(0.0);
    var var_w = 0.0;
    var var_sum = 0.0;
    var open_w = 0.0;
    for (var y = max(xy.y - half, 0); y <= min(xy.y + half, h - 1); y = y + 1) {
        for (var xx = max(xy.x - half, 0); xx <= min(xy.x + half, w - 1); xx = xx + 1) {
            let j = index_at(xx, y);
            let dj = direction_at(j);
            let pj = point_at(j);
            if (!(dj.w > 0.0 && pj.w > 0.0)) {
                continue;
            }
            var wk = 1.0;
            if (j != c) {
                wk = rf_kernel_weight(kernel, pj.xyz) * rf_normal_weight(normal_at(j).xyz, n, e);
            }
            if (!(wk > 0.0)) {
                continue;
            }
            let wi = dj.xyz;
            let cos_i = dot3(wi, n);
            var term = vec3<f32>(0.0);
            if (mix.some && cos_i > 0.0) {
                let lv = lobe_eval(params.brdf, kd, ks, m, mix, n, wo, wi, cos_i);
                if (lv.pdf > 0.0) {
                    term = incident_at(j).xyz * (lv.f * (cos_i / lv.pdf));
                }
            }
            sum_w = sum_w + wk;
            sum = sum + term * wk;
            if (rf_unoccluded(incident_at(j).w, kernel.rs)) {
                open_w = open_w + wk;
            }
            let lj = lv_at(j).w;
            if (lj >= 2.0) {
                var_w = var_w + wk;
                var_sum = var_sum + wk * (hv_at(j).w / (lj - 1.0));
            }
        }
    }
    var value = vec3<f32>(0.0);
    if (sum_w > 0.0) {
        value = sum / sum_w;
    }
    var sigma2 = -1.0;
    if (var_w > 0.0) {
        sigma2 = var_sum / var_w;
    }
    var code = RF_OWN;
    if (half > 0) {
        code = RF_FILTERED;
    }
    filtered_put(c, vec4<f32>(value, code));
    variance_put(c, vec4<f32>(sigma2, sum_w, r, rf_occlusion_factor(open_w, sum_w)));
}
