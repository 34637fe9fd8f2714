// bandwidth.max — per pixel and axis the larger of two Ch. 6 bandwidths, a negative one ("do not
// filter") counting as absent. Mirrors effects/src/environment/kernels/filter.rs `bandwidth_max`.
#include "common.wgsl"

fn larger_bandwidth(x: f32, y: f32) -> f32 {
    if (x >= 0.0 && y >= 0.0) {
        return max(x, y);
    }
    if (x >= 0.0) {
        return x;
    }
    if (y >= 0.0) {
        return y;
    }
    return min(x, y);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let a = a_at(i);
    let b = b_at(i);
    out_put(i, vec2<f32>(larger_bandwidth(a.x, b.x), larger_bandwidth(a.y, b.y)));
}
