// screen_trace.wgsl — screen-space rays against the real layer; mirrors
// backends/src/kernels/screen_trace.rs (ScreenTracer::trace, ::trace_linear) term by term and in the
// same order (the rule, and the hierarchical traversal over the real layer's depth pyramid, are in
// that file's module doc). Needs scene.wgsl (its real_layer.wgsl) and the including kernel's Params
// `cam_*` (kernels::paths::camera_uniforms), `thickness` and `max_steps`.
#include "common.wgsl"
#include "scene.wgsl"

const SCREEN_NEAR: f32 = 1e-3;
const SCREEN_FAR: f32 = 1e5;

const SCREEN_MISS: u32 = 0u;
const SCREEN_HIT: u32 = 1u;
const SCREEN_OFFSCREEN: u32 = 2u;
// screen_segment: the ray marches (any other kind: how it ended before its first step).
const SCREEN_MARCH: u32 = 3u;

// screen_trace.rs GRAZING and NO_SURFACE (f32::MAX, as bits).
const SCREEN_GRAZING: f32 = 1e-4;
const SCREEN_NO_SURFACE: u32 = 0x7f7fffffu;

struct ScreenHit {
    kind: u32,
    t: f32,
    x: u32,
    y: u32,
}

fn screen_project(p: vec3<f32>, z: f32) -> vec2<f32> {
    let w = f32(frame.full_width);
    let h = f32(frame.full_height);
    let d = p - params.cam_position;
    let sx = dot3(d, params.cam_right) / z;
    let sy = dot3(d, params.cam_up) / z;
    return vec2<f32>((sx / (params.cam_tan_half * (w / h)) + 1.0) * 0.5 * w, (1.0 - sy / params.cam_tan_half) * 0.5 * h);
}

fn screen_sight(s: vec2<f32>) -> vec3<f32> {
    let w = f32(frame.full_width);
    let h = f32(frame.full_height);
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
    if (abs(vn) < SCREEN_GRAZING) {
        return vec2<f32>(1.0, zp);
    }
    let lambda = dot3(p - params.cam_position, n) / vn;
    if (lambda > 0.0) {
        return vec2<f32>(1.0, lambda);
    }
    return vec2<f32>(1.0, zp);
}

// One ray's march (screen_trace.rs Segment).
struct ScreenSegment {
    o: vec3<f32>,
    e: vec3<f32>,
    s0: vec2<f32>,
    delta: vec2<f32>,
    k0: f32,
    k1: f32,
    u_first: f32,
    du: f32,
    u_out: f32,
    clipped: bool,
    origin: vec2<i32>,
    z0: f32,
    // For guessing where a run of steps leaves a cell: u_first / du, and per axis the steps per
    // pixel 1 / (delta · du) (0 where the segment does not move along the axis).
    k_first: f32,
    inv_step: vec2<f32>,
    end: u32,
}

fn screen_no_segment(end: u32) -> ScreenSegment {
    return ScreenSegment(vec3<f32>(0.0), vec3<f32>(0.0), vec2<f32>(0.0), vec2<f32>(0.0), 0.0, 0.0, 0.0, 0.0, 0.0, false,
        vec2<i32>(0), 0.0, 0.0, vec2<f32>(0.0), end);
}

// Where step k is along the segment.
fn screen_u(g: ScreenSegment, k: u32) -> f32 {
    return g.u_first + f32(k) * g.du;
}

// The pixel step k is in.
fn screen_pixel(g: ScreenSegment, k: u32) -> vec2<i32> {
    let s = g.s0 + g.delta * screen_u(g, k);
    return vec2<i32>(i32(floor(s.x)), i32(floor(s.y)));
}

// Perspective-correct depth of the ray point that projects to step k's screen point.
fn screen_z(g: ScreenSegment, k: u32) -> f32 {
    return 1.0 / (g.k0 + (g.k1 - g.k0) * screen_u(g, k));
}

// How the march ends after k steps without a hit.
fn screen_end(g: ScreenSegment, k: u32) -> ScreenHit {
    if (g.clipped && screen_u(g, k) >= g.u_out) {
        return ScreenHit(SCREEN_OFFSCREEN, 0.0, 0u, 0u);
    }
    return ScreenHit(SCREEN_MISS, 0.0, 0u, 0u);
}

fn screen_segment(o: vec3<f32>, d: vec3<f32>) -> ScreenSegment {
    let w = f32(frame.full_width);
    let h = f32(frame.full_height);
    let z0 = dot3(o - params.cam_position, params.cam_forward);
    if (!(z0 > SCREEN_NEAR)) {
        return screen_no_segment(SCREEN_OFFSCREEN);
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
                return screen_no_segment(SCREEN_OFFSCREEN);
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
        return screen_no_segment(SCREEN_OFFSCREEN);
    }
    let clipped = u_out < 1.0;
    let length = rmax(abs(delta.x), abs(delta.y));
    if (!(length > 0.0)) {
        return screen_no_segment(SCREEN_MISS);
    }
    let du = 1.0 / length;
    let origin = vec2<i32>(i32(floor(s0.x)), i32(floor(s0.y)));
    let u_first = rmax(u_in, du);
    var inv_step = vec2<f32>(0.0);
    if (delta.x != 0.0) {
        inv_step.x = 1.0 / (delta.x * du);
    }
    if (delta.y != 0.0) {
        inv_step.y = 1.0 / (delta.y * du);
    }
    return ScreenSegment(o, e, s0, delta, k0, k1, u_first, du, u_out, clipped, origin, z0, u_first / du, inv_step, SCREEN_MARCH);
}

// The exact test of step k (depth z_ray, the step before at z_prev): a SCREEN_HIT, or SCREEN_MISS
// for none.
fn screen_step_hit(g: ScreenSegment, k: u32, z_ray: f32, z_prev: f32) -> ScreenHit {
    let w = f32(frame.full_width);
    let h = f32(frame.full_height);
    let u = screen_u(g, k);
    let s = g.s0 + g.delta * u;
    let fx = floor(s.x);
    let fy = floor(s.y);
    if (fx >= 0.0 && fy >= 0.0 && fx < w && fy < h) {
        let px = i32(fx);
        let py = i32(fy);
        if (px != g.origin.x || py != g.origin.y) {
            let surface = screen_surface_depth(px, py, s);
            let z_s = surface.y;
            if (surface.x > 0.0) {
                let allowed = rmax(params.thickness * z_s, abs(z_ray - z_prev));
                if (z_ray >= z_s && z_ray - z_s <= allowed) {
                    let a = g.k0 * (1.0 - u);
                    let b = g.k1 * u;
                    let p = (g.o * a + g.e * b) / (a + b);
                    return ScreenHit(SCREEN_HIT, length3(p - g.o), u32(px), u32(py));
                }
            }
        }
    }
    return ScreenHit(SCREEN_MISS, 0.0, 0u, 0u);
}

// One step at a time: the reference (ScreenTracer::trace_linear).
fn screen_trace_linear(o: vec3<f32>, d: vec3<f32>) -> ScreenHit {
    let g = screen_segment(o, d);
    if (g.end != SCREEN_MARCH) {
        return ScreenHit(g.end, 0.0, 0u, 0u);
    }
    var z_prev = g.z0;
    var k = 0u;
    loop {
        if (!(screen_u(g, k) < g.u_out && k < params.max_steps)) {
            break;
        }
        let z_ray = screen_z(g, k);
        let hit = screen_step_hit(g, k, z_ray, z_prev);
        if (hit.kind == SCREEN_HIT) {
            return hit;
        }
        z_prev = z_ray;
        k = k + 1u;
    }
    return screen_end(g, k);
}

// screen_trace.rs first_out's predicates: mode 0 the march's end (u_j ≥ u_out), mode 1 step j's pixel
// outside cell `cell` of level l.
fn screen_out(g: ScreenSegment, mode: u32, j: u32, l: u32, cell: vec2<i32>) -> bool {
    if (mode == 0u) {
        return screen_u(g, j) >= g.u_out;
    }
    let p = screen_pixel(g, j);
    return (p.x >> l) != cell.x || (p.y >> l) != cell.y;
}

// The first j in lo..hi where screen_out holds, else hi (screen_trace.rs first_out).
fn screen_first_out(g: ScreenSegment, lo: u32, hi: u32, guess: u32, mode: u32, l: u32, cell: vec2<i32>) -> u32 {
    let s = clamp(guess, lo, hi);
    var a = 0u;
    var b = 0u;
    if (s == hi || screen_out(g, mode, s, l, cell)) {
        if (s == lo || !screen_out(g, mode, s - 1u, l, cell)) {
            return s;
        }
        a = lo;
        b = s - 1u;
    } else {
        if (s + 1u == hi || screen_out(g, mode, s + 1u, l, cell)) {
            return s + 1u;
        }
        a = s + 2u;
        b = hi;
    }
    loop {
        if (a >= b) {
            break;
        }
        let m = a + (b - a) / 2u;
        if (screen_out(g, mode, m, l, cell)) {
            b = m;
        } else {
            a = m + 1u;
        }
    }
    return a;
}

// The step index where the segment crosses a cell's far side along one axis (screen_trace.rs
// cell_end's `cross`; only a guess: screen_first_out settles it).
fn screen_cross(g: ScreenSegment, s0: f32, inv: f32, c: i32, l: u32) -> f32 {
    var side = 0.0;
    if (inv > 0.0) {
        side = f32((c + 1) << l);
    } else if (inv < 0.0) {
        side = f32(c << l);
    } else {
        return 3.0e38;
    }
    return (side - s0) * inv - g.k_first;
}

// The first step after k (at most n) whose pixel is outside cell `cell` of level l.
fn screen_cell_end(g: ScreenSegment, k: u32, n: u32, l: u32, cell: vec2<i32>) -> u32 {
    if (k + 1u >= n) {
        return n;
    }
    // Rounded up (an integer-valued guess one high costs one more look).
    let at = trunc(rmin(screen_cross(g, g.s0.x, g.inv_step.x, cell.x, l), screen_cross(g, g.s0.y, g.inv_step.y, cell.y, l))) + 1.0;
    var guess = n;
    if (at < f32(n)) {
        guess = u32(rmax(at, f32(k + 1u)));
    }
    return screen_first_out(g, k + 1u, n, guess, 1u, l, cell);
}

// The hierarchical march (ScreenTracer::trace): the linear march's answer, skipping runs of steps the
// real layer's depth pyramid shows cannot hit.
fn screen_trace(o: vec3<f32>, d: vec3<f32>) -> ScreenHit {
    let g = screen_segment(o, d);
    if (g.end != SCREEN_MARCH) {
        return ScreenHit(g.end, 0.0, 0u, 0u);
    }
    let w = i32(frame.full_width);
    let h = i32(frame.full_height);
    var guess = params.max_steps;
    let steps = ceil((g.u_out - g.u_first) / g.du);
    if (steps < f32(params.max_steps)) {
        guess = u32(rmax(steps, 0.0));
    }
    let n = screen_first_out(g, 0u, params.max_steps, guess, 0u, 0u, vec2<i32>(0));
    let top = real_pyramid_level(0u).w - 1u;
    var z_prev = g.z0;
    var k = 0u;
    var level = 0u;
    loop {
        if (k >= n) {
            break;
        }
        let p = screen_pixel(g, k);
        let z_k = screen_z(g, k);
        if (p.x < 0 || p.y < 0 || p.x >= w || p.y >= h) {
            z_prev = z_k;
            k = k + 1u;
            continue;
        }
        var l = level;
        var skipped = false;
        loop {
            let cell = vec2<i32>(p.x >> l, p.y >> l);
            let bound = real_pyramid_get(real_pyramid_level(l), cell.x, cell.y);
            let none = bitcast<u32>(bound) == SCREEN_NO_SURFACE;
            if (none || bound > z_k) {
                let end = screen_cell_end(g, k, n, l, cell);
                let z_last = screen_z(g, end - 1u);
                if (none || bound > z_last) {
                    z_prev = z_last;
                    k = end;
                    level = min(l + 1u, top);
                    skipped = true;
                    break;
                }
            }
            if (l == 0u) {
                break;
            }
            l = l - 1u;
        }
        if (skipped) {
            continue;
        }
        let hit = screen_step_hit(g, k, z_k, z_prev);
        if (hit.kind == SCREEN_HIT) {
            return hit;
        }
        z_prev = z_k;
        k = k + 1u;
        level = 0u;
    }
    return screen_end(g, k);
}
