// defocus.all_factored — 1 where a component's flag, the previous pass's result (where bound) are set
// and no emission channel is above 0 (where bound; NaN counts as emission); mirrors
// effects/src/defocus/kernels/all_factored.rs.
#include "common.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    var factored = flag_at(i) != 0u;
    if (previous_bound()) {
        factored = factored && previous_at(i) != 0u;
    }
    if (emission_bound()) {
        let e = emission_at(i);
        factored = factored && e.x <= 0.0 && e.y <= 0.0 && e.z <= 0.0;
    }
    out_put(i, select(0u, 1u, factored));
}
