// neighbourhood.max3 / neighbourhood.median3 — 3×3 max (params.op = 0) or median (op = 1) of a u32
// per pixel, edges clamped; mirrors backends/src/kernels/neighbourhood3.rs (integers: exact).
#include "common.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let w = i32(frame.width);
    let h = i32(frame.height);
    let xy = vec2<i32>(pixel_xy(gid));
    var v: array<u32, 9>;
    var k = 0u;
    for (var dy = -1; dy <= 1; dy = dy + 1) {
        for (var dx = -1; dx <= 1; dx = dx + 1) {
            let nx = clamp(xy.x + dx, 0, w - 1);
            let ny = clamp(xy.y + dy, 0, h - 1);
            v[k] = value_at(index_at(nx, ny));
            k = k + 1u;
        }
    }
    if (params.op == 0u) {
        var m = v[0];
        for (var j = 1u; j < 9u; j = j + 1u) {
            m = max(m, v[j]);
        }
        out_put(i, m);
        return;
    }
    // Insertion sort of the nine values; the median is the fifth.
    for (var a = 1u; a < 9u; a = a + 1u) {
        let x = v[a];
        var b = a;
        while (b > 0u && v[b - 1u] > x) {
            v[b] = v[b - 1u];
            b = b - 1u;
        }
        v[b] = x;
    }
    out_put(i, v[4]);
}
