// filter.gaussian — one axis of the separable world-space Gaussian driven by a per-pixel bandwidth;
// mirrors backends/src/kernels/gaussian_filter.rs (filter_pixel) term by term and in the same order.
#include "common.wgsl"

const TANGENT_SLOPE: f32 = 0.2;

fn plane_distance2(a: vec3<f32>, b: vec3<f32>, n: vec3<f32>) -> f32 {
    let d = a - b;
    let along = dot3(d, n);
    return rmax(dot3(d, d) - along * along, 0.0);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let width = i32(frame.width);
    let height = i32(frame.height);
    let xy = vec2<i32>(pixel_xy(gid));
    let x = xy.x;
    let y = xy.y;
    let beta = bandwidth_at(i);
    let centre = value_at(i);
    if (beta <= 0.0 || position_at(i).w == 0.0 || !is_finite(beta)) {
        out_put(i, centre);
        return;
    }
    let d = rmax(normal_at(i).w, 1e-12);
    let r = ceil(3.0 * beta / d);
    var radius = params.max_radius;
    if (r < f32(params.max_radius)) {
        radius = max(i32(r), 0);
    }
    let xi = position_at(i).xyz;
    let ni = normal_at(i).xyz;
    let inv = -0.5 / (beta * beta);
    var sum = vec3<f32>(0.0);
    var wsum = 0.0;
    for (var k = -radius; k <= radius; k = k + 1) {
        var jx = x;
        var jy = y + k;
        if (params.axis == 0u) {
            jx = x + k;
            jy = y;
        }
        if (jx < 0 || jy < 0 || jx >= width || jy >= height) {
            continue;
        }
        let j = index_at(jx, jy);
        if (position_at(j).w != position_at(i).w) {
            continue;
        }
        if (dot3(ni, normal_at(j).xyz) < params.normal_cos) {
            continue;
        }
        let v = value_at(j);
        if (!is_finite3(v.xyz)) {
            continue;
        }
        let xj = position_at(j).xyz;
        let delta = xj - xi;
        if (abs(dot3(delta, ni)) > TANGENT_SLOPE * length3(delta) + 0.25 * d) {
            continue;
        }
        let bj = bandwidth_at(j);
        var inv_j = inv;
        if (params.reach == 1u && bj > 0.0 && bj < beta) {
            inv_j = -0.5 / (bj * bj);
        }
        let w = exp(plane_distance2(xi, xj, params.plane_normal.xyz) * inv_j);
        sum = sum + w * v.xyz;
        wsum = wsum + w;
    }
    if (wsum > 0.0) {
        out_put(i, vec4<f32>(sum.x / wsum, sum.y / wsum, sum.z / wsum, centre.w));
    } else {
        out_put(i, centre);
    }
}
