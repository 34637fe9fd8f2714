// pixel_filter.bilateral — the brute-force cross-bilateral filter (seed 002 eq. 3.6) of the
// accumulated L_u with Σa² (eq. 3.5) and the per-path variance filtered with the same weights
// (Sec. 3.3.2); on frames that do not filter it keeps the previous buffers. Mirrors
// effects/src/pixel_filter/kernels/filter.rs (Bilateral::run_cpu, add_tap, Sums::finish, filter_outputs).
#include "common.wgsl"
#include "pixel_filter_formulas.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let j = pixel_index(gid);
    if (params.update == 0u) {
        filtered_put(j, previous_filtered_at(j));
        variance_put(j, previous_variance_at(j));
        return;
    }
    let xy = vec2<i32>(pixel_xy(gid));
    let w = i32(frame.width);
    let h = i32(frame.height);
    var sg = params.sigma_s;
    if (sigma_bound()) {
        sg = rmin(sigma_at(j), params.sigma_s);
    }
    let cut = params.truncate * sg;
    let radius = min(pf_radius(params.truncate, sg), i32(params.radius));
    let inv_s = pf_inv_two_sigma2(sg);
    let rj = range_at(j);
    let spread = lv_at(j).w < 2.0;
    var sums = pf_sums();
    for (var y = max(xy.y - radius, 0); y <= min(xy.y + radius, h - 1); y = y + 1) {
        for (var x = max(xy.x - radius, 0); x <= min(xy.x + radius, w - 1); x = x + 1) {
            let dx = f32(x - xy.x);
            let dy = f32(y - xy.y);
            let ds2 = dx * dx + dy * dy;
            if (ds2 > cut * cut) {
                continue;
            }
            let i = index_at(x, y);
            pf_add_tap(&sums, range_at(i), rj.xyz, rj.w, ds2, inv_s, params.inv_c, params.inv_d, lv_at(i).w, hv_at(i), 1.0,
                0.0, false, true, spread);
        }
    }
    let o = pf_filter_outputs(pf_finish(sums), lv_at(j).w);
    filtered_put(j, o.filtered);
    variance_put(j, o.variance);
}
