// fog.apply — out = colour + (color − colour)·T, T = exp(−density·|position − eye|), T = 0 where no
// surface is seen (position.w = 0). The same formula as `fogged` in src/lib.rs.
#include "common.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let x = position_at(i);
    var t = 0.0;
    if (x.w > 0.0) {
        t = exp(-params.density * length(x.xyz - params.eye));
    }
    out_put(i, params.colour + (color_at(i) - params.colour) * t);
}
