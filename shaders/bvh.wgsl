// bvh.wgsl — mirror of wedge_scene::bvh::{intersect_triangle, slab, traverse} over the SAME flat
// node and triangle arrays the CPU builds (uploaded unchanged). Fixed 64-entry stack, near child
// first, slab test with the exit widened by 3 ulps, Möller–Trumbore in f32.
#include "scene.wgsl"

const BVH_STACK_SIZE: u32 = 64u;

struct Hit {
    hit: bool,
    t: f32,
    triangle: u32,
    b1: f32,
    b2: f32,
}

fn no_hit() -> Hit {
    return Hit(false, 0.0, 0u, 0.0, 0.0);
}

fn intersect_triangle(tri: Triangle, o: vec3<f32>, d: vec3<f32>, tmin: f32, tmax: f32) -> vec4<f32> {
    // Returns (t, b1, b2, 1) on a hit, w = 0 otherwise.
    let e1 = tri.e1;
    let e2 = tri.e2;
    let p = cross3(d, e2);
    let det = dot3(e1, p);
    if (det == 0.0 || !is_finite(det)) {
        return vec4<f32>(0.0);
    }
    let inv_det = 1.0 / det;
    let s = o - tri.v0;
    let b1 = dot3(s, p) * inv_det;
    if (!(b1 >= 0.0 && b1 <= 1.0)) {
        return vec4<f32>(0.0);
    }
    let q = cross3(s, e1);
    let b2 = dot3(d, q) * inv_det;
    if (b2 < 0.0 || b1 + b2 > 1.0) {
        return vec4<f32>(0.0);
    }
    let t = dot3(e2, q) * inv_det;
    if (t > tmin && t < tmax) {
        return vec4<f32>(t, b1, b2, 1.0);
    }
    return vec4<f32>(0.0);
}

fn slab(node: BvhNode, o: vec3<f32>, inv_d: vec3<f32>, tmin: f32, tmax: f32) -> f32 {
    let t0 = (node.min - o) * inv_d;
    let t1 = (node.max - o) * inv_d;
    let near = gmin(t0, t1);
    let far = gmax(t0, t1);
    let t_enter = rmax(rmax(rmax(near.x, near.y), near.z), tmin);
    // 1.000_000_4_f32 = 0x3f800003
    let t_exit = rmin(rmin(rmin(far.x, far.y), far.z), tmax) * bitcast<f32>(0x3f800003u);
    if (t_enter <= t_exit) {
        return t_enter;
    }
    return inf();
}

fn traverse(o: vec3<f32>, d: vec3<f32>, tmin: f32, tmax: f32, any_hit: bool) -> Hit {
    var best = no_hit();
    if (!(is_finite3(o) && is_finite3(d))) {
        return best;
    }
    let inv_d = vec3<f32>(1.0 / d.x, 1.0 / d.y, 1.0 / d.z);
    var t_best = tmax;
    let big = inf();
    if (slab(bvh_node(0), o, inv_d, tmin, t_best) == big) {
        return best;
    }
    var stack: array<u32, BVH_STACK_SIZE>;
    var stack_t: array<f32, BVH_STACK_SIZE>;
    let widen = bitcast<f32>(0x3f800003u);
    var sp = 0u;
    var node = 0u;
    loop {
        let n = bvh_node(node);
        if (n.count > 0u) {
            for (var i = n.index; i < n.index + n.count; i = i + 1u) {
                let h = intersect_triangle(triangle(i), o, d, tmin, t_best);
                if (h.w != 0.0) {
                    t_best = h.x;
                    best = Hit(true, h.x, i, h.y, h.z);
                    if (any_hit) {
                        return best;
                    }
                }
            }
        } else {
            let a = n.index;
            let b = n.index + 1u;
            let ta = slab(bvh_node(a), o, inv_d, tmin, t_best);
            let tb = slab(bvh_node(b), o, inv_d, tmin, t_best);
            if (ta != big && tb != big) {
                // Any-hit takes the children in array order (the order cannot change its answer).
                var near = a;
                var far = b;
                var t_far = tb;
                if (!any_hit && !(ta <= tb)) {
                    near = b;
                    far = a;
                    t_far = ta;
                }
                stack[sp] = far;
                stack_t[sp] = t_far;
                sp = sp + 1u;
                node = near;
                continue;
            } else if (ta != big) {
                node = a;
                continue;
            } else if (tb != big) {
                node = b;
                continue;
            }
        }
        // Pop, dropping entries a closer hit has since made unreachable (closest hit only).
        loop {
            if (sp == 0u) {
                return best;
            }
            sp = sp - 1u;
            if (any_hit || stack_t[sp] <= t_best * widen) {
                break;
            }
        }
        node = stack[sp];
    }
    // Unreachable unless the driver cut the loop short (the loop only exits by `return`).
    atomicAdd(&counters[COUNTER_CUT_LOOPS], 1u);
    return best;
}

fn scene_intersect(o: vec3<f32>, d: vec3<f32>, tmin: f32, tmax: f32) -> Hit {
    return traverse(o, d, tmin, tmax, false);
}

fn scene_occluded(o: vec3<f32>, d: vec3<f32>, tmin: f32, tmax: f32) -> bool {
    return traverse(o, d, tmin, tmax, true).hit;
}
