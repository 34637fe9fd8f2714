// screen_trace.wgsl — screen-space rays against the real layer; mirrors
// backends/src/kernels/screen_trace.rs (ScreenTracer::trace) term by term and in the same order (the
// rule is in that file's module doc). Needs scene.wgsl (its real_layer.wgsl) and the including kernel's Params
// `cam_*` (kernels::paths::camera_uniforms), `thickness` and `max_steps`.
#include "common.wgsl"
#include "scene.wgsl"

const SCREEN_NEAR: f32 = 1e-3;
const SCREEN_FAR: f32 = 1e5;

const SCREEN_MISS: u32 = 0u;
const SCREEN_HIT: u32 = 1u;
const SCREEN_OFFSCREEN: u32 = 2u;

struct ScreenHit {
    kind: u32,
    t: f32,
    x: u32,
    y: u32,
}

fn screen_project(p: vec3<f32>, z: f32) -> vec2<f32> {
    let w = f32(frame.width);
    let h = f32(frame.height);
    let d = p - params.cam_position;
    let sx = dot3(d, params.cam_right) / z;
    let sy = dot3(d, params.cam_up) / z;
    return vec2<f32>((sx / (params.cam_tan_half * (w / h)) + 1.0) * 0.5 * w, (1.0 - sy / params.cam_tan_half) * 0.5 * h);
}

fn screen_sight(s: vec2<f32>) -> vec3<f32> {
    let w = f32(frame.width);
    let h = f32(frame.height);
    let sx = (2.0 * s.x / w - 1.0) * params.cam_tan_half * (w / h);
    let sy = (1.0 - 2.0 * s.y / h) * params.cam_tan_half;
    return params.cam_forward + sx * params.cam_right + sy * params.cam_up;
}

// The view depth of pixel (x, y)'s real surface (its tangent plane) along the sight line through s
// in .y; .x = 0 where the pixel shows no real surface.
fn screen_surface_depth(x: i32, y: i32, s: vec2<f32>) -> vec2<f32> {
    let pw = real_position(x, y);
    if (!(pw.w > 0.0)) {
        return vec2<f32>(0.0);
    }
    let p = pw.xyz;
    let n = real_normal(x, y);
    let v = screen_sight(s);
    let vn = dot3(v, n);
    let zp = dot3(p - params.cam_position, params.cam_forward);
    if (abs(vn) < 1e-4) {
        return vec2<f32>(1.0, zp);
    }
    let lambda = dot3(p - params.cam_position, n) / vn;
    if (lambda > 0.0) {
        return vec2<f32>(1.0, lambda);
    }
    return vec2<f32>(1.0, zp);
}

fn screen_trace(o: vec3<f32>, d: vec3<f32>) -> ScreenHit {
    let w = f32(frame.width);
    let h = f32(frame.height);
    let z0 = dot3(o - params.cam_position, params.cam_forward);
    if (!(z0 > SCREEN_NEAR)) {
        return ScreenHit(SCREEN_OFFSCREEN, 0.0, 0u, 0u);
    }
    let dz = dot3(d, params.cam_forward);
    var t_end = SCREEN_FAR;
    if (dz < 0.0) {
        t_end = rmin((z0 - SCREEN_NEAR) / -dz, SCREEN_FAR);
    }
    let e = o + d * t_end;
    let z1 = rmax(z0 + dz * t_end, SCREEN_NEAR);
    let s0 = screen_project(o, z0);
    let s1 = screen_project(e, z1);
    let k0 = 1.0 / z0;
    let k1 = 1.0 / z1;
    let delta = s1 - s0;
    var u_in = 0.0;
    var u_out = 1.0;
    let ps = array<f32, 4>(-delta.x, delta.x, -delta.y, delta.y);
    let qs = array<f32, 4>(s0.x, w - s0.x, s0.y, h - s0.y);
    for (var k = 0; k < 4; k = k + 1) {
        let p = ps[k];
        let q = qs[k];
        if (p == 0.0) {
            if (q < 0.0) {
                return ScreenHit(SCREEN_OFFSCREEN, 0.0, 0u, 0u);
            }
        } else {
            let r = q / p;
            if (p < 0.0) {
                u_in = rmax(u_in, r);
            } else {
                u_out = rmin(u_out, r);
            }
        }
    }
    if (!(u_in < u_out)) {
        return ScreenHit(SCREEN_OFFSCREEN, 0.0, 0u, 0u);
    }
    let clipped = u_out < 1.0;
    let length = rmax(abs(delta.x), abs(delta.y));
    if (!(length > 0.0)) {
        return ScreenHit(SCREEN_MISS, 0.0, 0u, 0u);
    }
    let du = 1.0 / length;
    let ox = i32(floor(s0.x));
    let oy = i32(floor(s0.y));
    var z_prev = z0;
    var u = rmax(u_in, du);
    var steps = 0u;
    loop {
        if (!(u < u_out && steps < params.max_steps)) {
            break;
        }
        steps = steps + 1u;
        let s = s0 + delta * u;
        let fx = floor(s.x);
        let fy = floor(s.y);
        let z_ray = 1.0 / (k0 + (k1 - k0) * u);
        if (fx >= 0.0 && fy >= 0.0 && fx < w && fy < h) {
            let px = i32(fx);
            let py = i32(fy);
            if (px != ox || py != oy) {
                let surface = screen_surface_depth(px, py, s);
                let z_s = surface.y;
                if (surface.x > 0.0) {
                    let allowed = rmax(params.thickness * z_s, abs(z_ray - z_prev));
                    if (z_ray >= z_s && z_ray - z_s <= allowed) {
                        let a = k0 * (1.0 - u);
                        let b = k1 * u;
                        let p = (o * a + e * b) / (a + b);
                        return ScreenHit(SCREEN_HIT, length3(p - o), u32(px), u32(py));
                    }
                }
            }
        }
        z_prev = z_ray;
        u = u + du;
    }
    if (clipped && u >= u_out) {
        return ScreenHit(SCREEN_OFFSCREEN, 0.0, 0u, 0u);
    }
    return ScreenHit(SCREEN_MISS, 0.0, 0u, 0u);
}
