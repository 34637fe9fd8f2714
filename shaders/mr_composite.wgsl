// mr.composite — differential compositing, thesis eq. 6.2: (1 − M) k_V E_V + M (E_RV / E_R) L_cam;
// mirrors effects/src/mixed_reality/ (formulas.rs composite, kernels/composite.rs MrComposite) in the same order.
#include "common.wgsl"
#include "scene.wgsl"

fn ratio_or_one(a: f32, b: f32) -> f32 {
    if (b > 0.0 && is_finite(a / b)) {
        return a / b;
    }
    return 1.0;
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let xy = global_xy(gid);
    let l_cam = real_camera(i32(xy.x), i32(xy.y));
    let t = texture_at(i);
    let m = t.w;
    let e_r = e_r_dir_at(i) + e_r_ind_at(i);
    let e_rv = e_rv_dir_at(i) + e_rv_ind_at(i);
    let real = l_cam * vec3<f32>(ratio_or_one(e_rv.x, e_r.x), ratio_or_one(e_rv.y, e_r.y), ratio_or_one(e_rv.z, e_r.z));
    let virt = t.xyz * (e_v_dir_at(i) + e_v_ind_at(i));
    var out = vec3<f32>(0.0);
    if (m >= 1.0) {
        out = real;
    } else if (m <= 0.0) {
        out = virt;
    } else {
        out = virt * (1.0 - m) + real * m;
    }
    out_put(i, out);
    if (reconstruction_bound()) {
        reconstruction_put(i, real_albedo(i32(xy.x), i32(xy.y)) * e_r);
    }
    if (mask_bound()) {
        mask_put(i, m);
    }
}
