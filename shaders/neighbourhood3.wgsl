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
    // The median is the value with at most 4 others below it and at least 5 at or below it. Counted,
    // not sorted: the insertion sort this replaced (`while (b > 0u && v[b - 1u] > x)`, data-dependent
    // loop and writes into a local array) gave wrong medians on the GL backend (145 of 3072 pixels in
    // tests/parity.rs `parity_on_the_gl_backend`) while Vulkan agreed with the CPU.
    var m = v[0];
    for (var j = 0u; j < 9u; j = j + 1u) {
        var below = 0u;
        var at_or_below = 0u;
        for (var q = 0u; q < 9u; q = q + 1u) {
            below = below + select(0u, 1u, v[q] < v[j]);
            at_or_below = at_or_below + select(0u, 1u, v[q] <= v[j]);
        }
        if (below <= 4u && at_or_below >= 5u) {
            m = v[j];
        }
    }
    out_put(i, m);
}
