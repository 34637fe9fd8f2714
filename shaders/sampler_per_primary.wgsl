// sampler.per_primary — secondary samples per path from an estimator's total over the adaptive pass:
// the smallest square s² with paths · s² >= total (Sec. 5.8 footnote 6), s in [1, 64]; mirrors
// effects/src/sampler.rs (per_primary_pixel). Integer-only: both backends agree bit for bit.
#include "common.wgsl"

const MAX_STRATA: u32 = 64u;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let p = max(paths_at(i), 1u);
    let t = total_at(i);
    // q = ceil(t / p) without overflow; s² >= q is the condition.
    var q = t / p;
    if (t % p != 0u) {
        q = q + 1u;
    }
    var s = min(u32(sqrt(f32(q))), MAX_STRATA);
    while (s > 1u && s * s > q) {
        s = s - 1u;
    }
    while (s < MAX_STRATA && s * s < q) {
        s = s + 1u;
    }
    s = max(s, 1u);
    out_put(i, s * s);
}
