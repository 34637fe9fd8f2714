// neighbourhood.fill — average of neighbours' statistics within a radius for pixels without their
// own; mirrors backends/src/kernels/neighbourhood_fill.rs (same visiting order, so the sums agree).
#include "common.wgsl"

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (!pixel_of(gid)) {
        return;
    }
    let i = pixel_index(gid);
    let w = i32(frame.width);
    let h = i32(frame.height);
    let xy = vec2<i32>(pixel_xy(gid));
    let x = xy.x;
    let y = xy.y;
    let v = value_at(i);
    if (v.w > 0.0) {
        out_put(i, vec4<f32>(v.xyz, 1.0));
        return;
    }
    if (position_at(i).w == 0.0) {
        out_put(i, vec4<f32>(0.0));
        return;
    }
    let radius = params.radius;
    var sum = vec3<f32>(0.0);
    var n = 0u;
    for (var dy = -radius; dy <= radius; dy = dy + 1) {
        for (var dx = -radius; dx <= radius; dx = dx + 1) {
            if (dx * dx + dy * dy > radius * radius) {
                continue;
            }
            let nx = x + dx;
            let ny = y + dy;
            if (nx < 0 || ny < 0 || nx >= w || ny >= h) {
                continue;
            }
            let j = index_at(nx, ny);
            let u = value_at(j);
            if (u.w > 0.0 && position_at(j).w == position_at(i).w) {
                sum = sum + u.xyz;
                n = n + 1u;
            }
        }
    }
    if (n == 0u) {
        out_put(i, vec4<f32>(0.0));
    } else {
        out_put(i, vec4<f32>(sum / f32(n), 2.0));
    }
}
