// defocus.risk_choice — 1 (the wider screen filter) where the bias terms summed over the 7×7 box
// (clipped to the image) are below the noise terms' sum; mirrors effects/src/defocus/kernels/risk.rs
// (risk_choice), summed in the same order.
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
        for (var nx = max(xy.x - RISK_BOX, 0); nx <= min(xy.x + RISK_BOX, w - 1); nx = nx + 1) {
            let j = index_at(nx, ny);
            b = b + bias_at(j);
            n = n + noise_at(j);
        }
    }
    choice_put(i, select(0u, 1u, b < n));
}
