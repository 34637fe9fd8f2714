// sampling.wgsl — sample warps shared by kernels: area-light points (AreaLight::sample_point),
// the camera's concentric disk (camera::concentric_disk). Mirrors the Rust operation order.
#include "scene.wgsl"

const PI_F32: f32 = 3.14159265358979323846;

fn light_sample_point(l: Light, u: vec2<f32>) -> vec3<f32> {
    if (l.kind == LIGHT_RECT) {
        return l.p0.xyz + u.x * l.p1.xyz + u.y * l.p2.xyz;
    }
    let su = sqrt(rmax(u.x, 0.0));
    return (1.0 - su) * l.p0.xyz + su * (1.0 - u.y) * l.p1.xyz + su * u.y * l.p2.xyz;
}

// The cosine at the light of a sample reached along `dir` (AreaLight::facing_cos): |cos| for a
// two-sided light, <= 0 where the sample sees the light's back.
fn light_facing_cos(l: Light, dir: vec3<f32>) -> f32 {
    let c = dot3(l.normal_area.xyz, -dir);
    if (l.two_sided != 0u) {
        return abs(c);
    }
    return c;
}

fn concentric_disk(u: vec2<f32>) -> vec2<f32> {
    let o = 2.0 * u - vec2<f32>(1.0);
    if (o.x == 0.0 && o.y == 0.0) {
        return vec2<f32>(0.0);
    }
    var r: f32;
    var theta: f32;
    let quarter = PI_F32 / 4.0;
    let half = PI_F32 / 2.0;
    if (abs(o.x) > abs(o.y)) {
        r = o.x;
        theta = quarter * (o.y / o.x);
    } else {
        r = o.y;
        theta = half - quarter * (o.x / o.y);
    }
    return vec2<f32>(cos(theta), sin(theta)) * r;
}
