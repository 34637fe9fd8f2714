// sampler.pass_total — a channel's secondary samples over the adaptive pass:
// max(paths × max(per_path, at_least), rest), saturating, per_path and rest 0 when unbound; mirrors
// effects/src/sampler.rs (pass_total_pixel). Integer-only: both backends agree bit for bit.
#include "common.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let p = paths_at(i);
    var each = params.at_least;
    if (per_path_bound()) {
        each = max(per_path_at(i), each);
    }
    var total = 0xffffffffu;
    if (each == 0u || p <= 0xffffffffu / each) {
        total = p * each;
    }
    if (rest_bound()) {
        total = max(total, rest_at(i));
    }
    out_put(i, total);
}
