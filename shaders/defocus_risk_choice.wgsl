// defocus.risk_choice — 1 (the wider screen filter) where the bias terms summed over the 7×7 box
// (clipped to the image) are below the noise terms' sum; mirrors effects/src/defocus/kernels/risk.rs
// (risk_choice), summed in the same order: each row of the box left to right, then the rows' sums.
#include "common.wgsl"

const RISK_BOX: i32 = 3;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let w = i32(frame.width);
    let h = i32(frame.height);
    let xy = vec2<i32>(pixel_xy(gid));
    var b = 0.0;
    var n = 0.0;
    for (var ny = max(xy.y - RISK_BOX, 0); ny <= min(xy.y + RISK_BOX, h - 1); ny = ny + 1) {
        var rb = 0.0;
        var rn = 0.0;
        for (var nx = max(xy.x - RISK_BOX, 0); nx <= min(xy.x + RISK_BOX, w - 1); nx = nx + 1) {
            let j = index_at(nx, ny);
            rb = rb + bias_at(j);
            rn = rn + noise_at(j);
        }
        b = b + rb;
        n = n + rn;
    }
    choice_put(i, select(0u, 1u, b < n));
}
