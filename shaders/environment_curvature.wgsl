// environment.curvature — (|κ_X|, |κ_Y|) per pixel (eq. 6.20); mirrors
// effects/src/environment/kernels.rs `curvature_at`.
#include "common.wgsl"
#include "environment_formulas.wgsl"

fn curvature_along(x: i32, y: i32, axis: u32) -> f32 {
    let w = i32(frame.width);
    let h = i32(frame.height);
    let i = index_at(x, y);
    let pi = position_at(i);
    if (!(pi.w > 0.0)) {
        return 0.0;
    }
    for (var k = 0; k < 2; k = k + 1) {
        let step = select(-1, 1, k == 0);
        var jx = x;
        var jy = y;
        if (axis == 0u) {
            jx = x + step;
        } else {
            jy = y + step;
        }
        if (jx < 0 || jy < 0 || jx >= w || jy >= h) {
            continue;
        }
        let j = index_at(jx, jy);
        let pj = position_at(j);
        if (pj.w == pi.w) {
            return env_curvature(normal_at(i).xyz, normal_at(j).xyz, pi.xyz, pj.xyz);
        }
    }
    return 0.0;
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let xy = pixel_xy(gid);
    let kappa = vec2<f32>(curvature_along(i32(xy.x), i32(xy.y), 0u), curvature_along(i32(xy.x), i32(xy.y), 1u));
    curvature_put(i, kappa);
    magnitude_put(i, 0.5 * (kappa.x + kappa.y));
}
