// filter.motion — thesis App. B eqs. B.1/B.2: a 1-D Gaussian oriented along the pixel's velocity, with
// the Ch. 5 weight and w_j(i) < 0.01 rejection, neighbours without a filter or with another velocity
// dropped; mirrors effects/src/motion/kernels/filter.rs (motion_pixel) term by term and in the same
// order.
#include "common.wgsl"
#include "filter_window.wgsl"
#include "velocity.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let xy = vec2<i32>(pixel_xy(gid));
    let centre = value_at(i);
    if (!is_finite3(centre)) {
        atomicAdd(&counters[COUNTER_NON_FINITE], 1u);
    }
    let mi = motion_at(i);
    let vi = mi.xy;
    let om = mi.z;
    let len = velocity_length(vi);
    if (!(len > 0.0 && is_finite(len)) || !valid_width(om)) {
        out_put(i, centre);
        return;
    }
    let d = vec2<f32>(vi.x / len, vi.y / len);
    let gi2 = om * om;
    let r = window_radius(om, params.max_radius);
    var sum = vec3<f32>(0.0);
    var wsum = 0.0;
    for (var k = -r; k <= r; k = k + 1) {
        let kf = f32(k);
        let p = vec2<i32>(i32(floor(f32(xy.x) + 0.5 + kf * d.x)), i32(floor(f32(xy.y) + 0.5 + kf * d.y)));
        if (!in_frame(p)) {
            continue;
        }
        let j = index_at(p.x, p.y);
        let v = value_at(j);
        let mj = motion_at(j);
        if (!is_finite3(v) || !valid_width(mj.z) || !same_velocity(vi, mj.xy)) {
            continue;
        }
        let w = pair_weight(f32(k * k), gi2, mj.z * mj.z);
        if (w > 0.0) {
            sum = sum + w * v;
            wsum = wsum + w;
        }
    }
    out_put(i, weighted_mean(sum, wsum, centre));
}
