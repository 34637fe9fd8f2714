// pixel_filter.separable — one 1-D pass of the iterated separable cross-bilateral filter (seed 002
// Sec. 3.6.1, eq. 3.14): axis 0 = x, 1 = y; the first pass reads the accumulation, later ones the
// chain (rgb, r) and (sigma², valid); the last writes filtered/variance (or keeps the previous ones on
// frames that do not filter). Mirrors effects/src/pixel_filter/kernels/filter.rs (Separable::run_cpu).
#include "common.wgsl"
#include "pixel_filter_formulas.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let j = pixel_index(gid);
    let first = params.first != 0u;
    let last = params.last != 0u;
    if (params.update == 0u) {
        if (last) {
            value_out_put(j, previous_filtered_at(j));
            variance_out_put(j, previous_variance_at(j));
        } else {
            value_out_put(j, vec4<f32>(0.0));
            variance_out_put(j, vec4<f32>(0.0));
        }
        return;
    }
    let xy = vec2<i32>(pixel_xy(gid));
    let w = i32(frame.width);
    let h = i32(frame.height);
    var sg = params.sigma_s;
    if (sigma_bound()) {
        sg = rmin(sigma_at(j), params.sigma_s);
    }
    sg = sg * params.scale;
    let cut = params.truncate * sg;
    let radius = min(pf_radius(params.truncate, sg), i32(params.radius));
    let inv_s = pf_inv_two_sigma2(sg);
    let rj = range_at(j);
    var lo: i32;
    var hi: i32;
    if (params.axis == 0u) {
        lo = max(xy.x - radius, 0);
        hi = min(xy.x + radius, w - 1);
    } else {
        lo = max(xy.y - radius, 0);
        hi = min(xy.y + radius, h - 1);
    }
    var sums = pf_sums();
    for (var k = lo; k <= hi; k = k + 1) {
        var x = k;
        var y = xy.y;
        var d = k - xy.x;
        if (params.axis != 0u) {
            x = xy.x;
            y = k;
            d = k - xy.y;
        }
        let ds2 = f32(d * d);
        if (ds2 > cut * cut) {
            continue;
        }
        let i = index_at(x, y);
        let value = value_in_at(i);
        if (first) {
            pf_add_tap(&sums, range_at(i), rj.xyz, rj.w, ds2, inv_s, params.inv_c, params.inv_d, lv_at(i).w, value, 1.0, 0.0,
                false, true, lv_at(j).w < 2.0);
        } else {
            let v = variance_in_at(i);
            var n = 0.0;
            if (v.y > 0.0) {
                n = 1.0;
            }
            pf_add_tap(&sums, range_at(i), rj.xyz, rj.w, ds2, inv_s, params.inv_c, params.inv_d, n, value, value.w, v.x,
                true, false, false);
        }
    }
    let f = pf_finish(sums);
    if (last) {
        let o = pf_filter_outputs(f, lv_at(j).w);
        value_out_put(j, o.filtered);
        variance_out_put(j, o.variance);
    } else {
        var valid = 0.0;
        if (sums.a > 0.0) {
            valid = 1.0;
        }
        value_out_put(j, vec4<f32>(f.value, f.r));
        variance_out_put(j, vec4<f32>(f.sigma2, valid, 0.0, 0.0));
    }
}
