// sampler.combine — one step of the per-pixel max of count requests:
// out = max(ceil(value / unit) - minus (saturating), other, at_least); mirrors effects/src/sampler.rs
// (combine_pixel). Integer-only: both backends agree bit for bit.
#include "common.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let v = value_at(i);
    // ceil(v / unit) without overflow at v near 2^32.
    var paths = v / params.unit;
    if (v % params.unit != 0u) {
        paths = paths + 1u;
    }
    var out = 0u;
    if (paths > params.minus) {
        out = paths - params.minus;
    }
    if (other_bound()) {
        out = max(out, other_at(i));
    }
    out_put(i, max(out, params.at_least));
}
