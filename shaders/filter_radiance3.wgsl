// filter.radiance3 — thesis App. B: at pixels whose `mask` is set (multi-velocity pixels), a 1-2-1 tent
// over the 3×3 neighbourhood of the finite radiance values, or with `velocity` bound a 1-2-1 filter
// over the pixel and its two masked neighbours along its velocity; mirrors
// effects/src/motion/kernels/filter.rs (radiance3_pixel) term by term and in the same order.
#include "common.wgsl"
#include "velocity.wgsl"

var<private> sum: vec3<f32>;
var<private> wsum: f32;

fn tap(p: vec2<i32>, w: f32, masked_only: bool) {
    if (p.x < 0 || p.y < 0 || p.x >= i32(frame.width) || p.y >= i32(frame.height)) {
        return;
    }
    let j = index_at(p.x, p.y);
    let v = value_at(j);
    if (!is_finite3(v) || (masked_only && mask_at(j) == 0u)) {
        return;
    }
    sum = sum + w * v;
    wsum = wsum + w;
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let centre = value_at(i);
    if (!is_finite3(centre)) {
        atomicAdd(&counters[COUNTER_NON_FINITE], 1u);
    }
    if (mask_at(i) == 0u) {
        out_put(i, centre);
        return;
    }
    let xy = vec2<i32>(pixel_xy(gid));
    sum = vec3<f32>(0.0);
    wsum = 0.0;
    if (!velocity_bound()) {
        for (var dy = -1; dy <= 1; dy = dy + 1) {
            for (var dx = -1; dx <= 1; dx = dx + 1) {
                tap(xy + vec2<i32>(dx, dy), f32((2 - abs(dx)) * (2 - abs(dy))), false);
            }
        }
    } else {
        tap(xy, 2.0, false);
        let v = velocity_at(i).xy;
        let len = velocity_length(v);
        if (len > 0.0 && is_finite(len)) {
            let d = vec2<f32>(v.x / len, v.y / len);
            for (var k = -1; k <= 1; k = k + 2) {
                let kf = f32(k);
                tap(vec2<i32>(i32(floor(f32(xy.x) + 0.5 + kf * d.x)), i32(floor(f32(xy.y) + 0.5 + kf * d.y))), 1.0, true);
            }
        }
    }
    if (wsum > 0.0) {
        out_put(i, vec3<f32>(sum.x / wsum, sum.y / wsum, sum.z / wsum));
    } else {
        out_put(i, centre);
    }
}
