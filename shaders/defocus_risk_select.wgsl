// defocus.risk_select — the wider screen filter's value where the choice is 1, else the narrower's;
// mirrors effects/src/defocus/kernels/risk.rs (RiskSelect).
#include "common.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    if (choice_at(i) != 0u) {
        out_put(i, wide_at(i));
    } else {
        out_put(i, narrow_at(i));
    }
}
