// radiance_filter.radius — this frame's image-space kernel radius per pixel (seed 002 eqs. 4.1, 4.2,
// 4.14, 4.15) scaled by the previous frame's occlusion factor; mirrors effects/src/radiance_filter/kernels.rs (Radius::run_cpu, kernel_radius).
#include "common.wgsl"
#include "radiance_filter_formulas.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let k = frame.frame_index + 1u;
    var sigma2 = -1.0;
    var lb = 0.0;
    var alpha = 1.0;
    if (previous_variance_bound() && previous_accumulated_bound()) {
        let a = previous_accumulated_at(i);
        if (a.w > 0.0) {
            let v = previous_variance_at(i);
            sigma2 = v.x;
            alpha = v.w;
            lb = rf_luminance(a.xyz);
        }
    }
    let r = rf_kernel_radius(params.t_u, params.warmup, params.warmup_radius, f32(params.max_radius), k, sigma2, lb);
    if (params.occlusion != 0u) {
        radius_put(i, r * alpha);
    } else {
        radius_put(i, r);
    }
}
