// motion.flags — `flag` 1 where a pixel's paths saw one velocity (primary hits, and shadows where
// occluded), so App. B factors it; `multi` the opposite; mirrors effects/src/motion/kernels.rs `Flags`.
#include "common.wgsl"
#include "defocus_formulas.wgsl"
#include "velocity.wgsl"
#include "motion_formulas.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let occluded = occlusion_bound() && shadow_velocity_bound() && occlusion_at(i).w > 0.0;
    let single = motion_single(velocity_at(i), shadow_velocity_at(i), occluded);
    flag_put(i, select(0u, 1u, single));
    multi_put(i, select(1u, 0u, single));
}
