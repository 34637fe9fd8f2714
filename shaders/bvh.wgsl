// bvh.wgsl — the GPU traversal of wedge_scene::bvh (scene/src/bvh/) over the SAME 8-wide nodes and
// triangle packs the CPU builds (uploaded unchanged): a node's eight child boxes as two groups of vec4
// lanes (slab test with the near/far plane chosen by the direction's sign, exit widened by 3 ulps, NaN
// lanes no constraint), the nearest hit child next and the others on a stack sized to the scene's trees (the CPU
// sorts them all: both orders give the same hit), leaves tested four
// triangles at a time with the same watertight test, in the same operation order, as the CPU
// (bit-identical t and barycentrics).
// The closest hit is the smallest t, ties to the lower triangle index (`closer`): an order-free rule,
// so the two backends agree without visiting nodes in the same order.
//
// Motion (wedge_scene::SceneAt::intersect): the static tree from node 0, then every instance whose
// swept box the ray enters before the best hit so far (found through the top-level tree over the
// swept boxes), through its own tree from its root with the ray moved into its rest pose at
// `scene_time` (same ray parameter; `traverse_tree` continues from the best hit, so the closest-hit
// rule holds across trees).
#include "scene.wgsl"

// BVH_STACK_SIZE (entries of the traversal stack) is generated per scene by the backend
// (backends/src/gpu/mod.rs `traversal_stack_entries`: the scene's trees' need, at most
// bvh::STACK_SIZE), so a small scene's kernels compile with a small stack.
const LEAF_BIT: u32 = 0x80000000u;
const LEAF_FIRST_MASK: u32 = 0x0fffffffu;

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

fn is_nan4(v: vec4<f32>) -> vec4<bool> {
    return (bitcast<vec4<u32>>(v) & vec4<u32>(0x7fffffffu)) > vec4<u32>(0x7f800000u);
}

fn is_finite4(v: vec4<f32>) -> vec4<bool> {
    return (bitcast<vec4<u32>>(v) & vec4<u32>(0x7f800000u)) != vec4<u32>(0x7f800000u);
}

// wedge_scene::bvh::closer: nearer, or equally near with a lower triangle index.
fn closer(t: f32, triangle: u32, t_best: f32, best_triangle: u32) -> bool {
    return t < t_best || (t == t_best && triangle < best_triangle);
}

struct PackHits {
    t: vec4<f32>,
    b1: vec4<f32>,
    b2: vec4<f32>,
    ok: vec4<bool>,
}

// bvh::triangle::Shear: the axes permuted so that k.z is the direction's largest component (the first
// of equal ones; x and y swapped where it is negative), the origin's components in that order, and
// the shear (d_kx · s_z, d_ky · s_z, s_z) with s_z = 1 / d_kz.
struct PackRay {
    k: vec3<u32>,
    o: vec3<f32>,
    s: vec3<f32>,
}

fn pack_ray(o: vec3<f32>, d: vec3<f32>) -> PackRay {
    let a = abs(d);
    var kz = select(0u, 1u, a.y > a.x);
    if (a.z > max(a.x, a.y)) {
        kz = 2u;
    }
    var kx = (kz + 1u) % 3u;
    var ky = (kz + 2u) % 3u;
    if (d[kz] < 0.0) {
        let swap = kx;
        kx = ky;
        ky = swap;
    }
    let sz = 1.0 / d[kz];
    return PackRay(vec3<u32>(kx, ky, kz), vec3<f32>(o[kx], o[ky], o[kz]), vec3<f32>(d[kx] * sz, d[ky] * sz, sz));
}

// TrianglePack::intersect: the watertight test (Woop, Benthin, Wald 2013; bvh/triangle.rs) on the
// four lanes of pack `pi`, tmin < t <= tmax (inclusive for the tie rule), the same operations in the
// same order as the CPU (bit-identical t and barycentrics where nothing fuses multiply-adds).
fn pack_intersect(pi: u32, r: PackRay, tmin: f32, tmax: f32) -> PackHits {
    let ax = triangle_pack_row(pi, 0u, r.k.x) - vec4<f32>(r.o.x);
    let ay = triangle_pack_row(pi, 0u, r.k.y) - vec4<f32>(r.o.y);
    let az = triangle_pack_row(pi, 0u, r.k.z) - vec4<f32>(r.o.z);
    let bx = triangle_pack_row(pi, 1u, r.k.x) - vec4<f32>(r.o.x);
    let by = triangle_pack_row(pi, 1u, r.k.y) - vec4<f32>(r.o.y);
    let bz = triangle_pack_row(pi, 1u, r.k.z) - vec4<f32>(r.o.z);
    let cx = triangle_pack_row(pi, 2u, r.k.x) - vec4<f32>(r.o.x);
    let cy = triangle_pack_row(pi, 2u, r.k.y) - vec4<f32>(r.o.y);
    let cz = triangle_pack_row(pi, 2u, r.k.z) - vec4<f32>(r.o.z);
    let sx = vec4<f32>(r.s.x);
    let sy = vec4<f32>(r.s.y);
    let sz = vec4<f32>(r.s.z);
    let ax2 = ax - sx * az;
    let ay2 = ay - sy * az;
    let bx2 = bx - sx * bz;
    let by2 = by - sy * bz;
    let cx2 = cx - sx * cz;
    let cy2 = cy - sy * cz;
    let u = cx2 * by2 - cy2 * bx2;
    let v = ax2 * cy2 - ay2 * cx2;
    let w = bx2 * ay2 - by2 * ax2;
    let zero = vec4<f32>(0.0);
    let neg = (u < zero) | (v < zero) | (w < zero);
    let pos = (u > zero) | (v > zero) | (w > zero);
    let det = (u + v) + w;
    let azs = sz * az;
    let bzs = sz * bz;
    let czs = sz * cz;
    let inv_det = vec4<f32>(1.0) / det;
    let t = ((u * azs + v * bzs) + w * czs) * inv_det;
    let bound = t_error_bound(max3_abs(ax2, bx2, cx2), max3_abs(ay2, by2, cy2), max3_abs(azs, bzs, czs),
        max3_abs(u, v, w), abs(inv_det));
    let ok = !(neg & pos) & (det != zero) & (t > bound) & (t > vec4<f32>(tmin)) & (t <= vec4<f32>(tmax));
    return PackHits(t, v * inv_det, w * inv_det, ok);
}

fn max3_abs(p: vec4<f32>, q: vec4<f32>, r: vec4<f32>) -> vec4<f32> {
    return max(max(abs(p), abs(q)), abs(r));
}

// bvh::triangle::GAMMA: γ(2), γ(3), γ(5) for f32.
const GAMMA_2: u32 = 0x34000001u;
const GAMMA_3: u32 = 0x34400002u;
const GAMMA_5: u32 = 0x34a00003u;

// bvh::triangle::t_error_bound: the rounding error bound a hit's t must exceed (PBRT-v3 §3.9.6).
fn t_error_bound(max_x: vec4<f32>, max_y: vec4<f32>, max_z: vec4<f32>, max_e: vec4<f32>, abs_inv_det: vec4<f32>) -> vec4<f32> {
    let g2 = vec4<f32>(bitcast<f32>(GAMMA_2));
    let g3 = vec4<f32>(bitcast<f32>(GAMMA_3));
    let g5 = vec4<f32>(bitcast<f32>(GAMMA_5));
    let delta_z = g3 * max_z;
    let delta_x = g5 * (max_x + max_z);
    let delta_y = g5 * (max_y + max_z);
    let delta_e = vec4<f32>(2.0) * ((g2 * max_x * max_y + delta_y * max_x) + delta_x * max_y);
    return vec4<f32>(3.0) * ((g3 * max_e * max_z + delta_e * max_z) + delta_z * max_e) * abs_inv_det;
}

// Entry distances of children 4g .. 4g + 3 of the node whose first element in `scene_data` is `base`,
// +inf where the child is missed (the CPU's `SlabTest::slab`, one lane group). The rows are read
// straight from the scene array: copying the whole 256-byte node into a local struct and indexing it
// by lane made lavapipe spill it.
fn node_slab(base: u32, g: u32, o: vec3<f32>, inv_d: vec3<f32>, tmin: f32, tmax: f32) -> vec4<f32> {
    var t_enter = vec4<f32>(tmin);
    var t_exit = vec4<f32>(tmax);
    let neg = inv_d < vec3<f32>(0.0);
    for (var axis = 0u; axis < 3u; axis = axis + 1u) {
        let lo = bitcast<vec4<f32>>(scene_data[base + (2u * axis) * BVH_GROUPS + g]);
        let hi = bitcast<vec4<f32>>(scene_data[base + (2u * axis + 1u) * BVH_GROUPS + g]);
        let near = (select(lo, hi, neg[axis]) - vec4<f32>(o[axis])) * vec4<f32>(inv_d[axis]);
        let far = (select(hi, lo, neg[axis]) - vec4<f32>(o[axis])) * vec4<f32>(inv_d[axis]);
        t_enter = select(max(near, t_enter), t_enter, is_nan4(near));
        t_exit = select(min(far, t_exit), t_exit, is_nan4(far));
    }
    // 1.000_000_4_f32 = 0x3f800003 (bvh::traverse::WIDEN)
    let hit = t_enter <= t_exit * vec4<f32>(bitcast<f32>(0x3f800003u));
    return select(vec4<f32>(inf()), t_enter, hit);
}

// Child `lane`'s reference of the node at `base` (after its six rows of bounds).
fn node_child(base: u32, lane: u32) -> u32 {
    return scene_data[base + 6u * BVH_GROUPS + lane / 4u][lane % 4u];
}

// bvh::traverse_from: the tree rooted at node `root`, for hits closer (`closer`) than the best so far
// (`t_best_in`, `best_triangle_in`; the ray's tmax and 0 when there is none). No hit: `hit` false.
fn traverse_tree(root: u32, o: vec3<f32>, d: vec3<f32>, tmin: f32, t_best_in: f32, best_triangle_in: u32, any_hit: bool) -> Hit {
    var best = no_hit();
    if (!(is_finite3(o) && is_finite3(d))) {
        return best;
    }
    let inv_d = vec3<f32>(1.0 / d.x, 1.0 / d.y, 1.0 / d.z);
    let pr = pack_ray(o, d);
    let big = inf();
    let widen = bitcast<f32>(0x3f800003u);
    var t_best = t_best_in;
    var best_triangle = best_triangle_in;
    var stack: array<u32, BVH_STACK_SIZE>;
    var stack_t: array<f32, BVH_STACK_SIZE>;
    var sp = 0u;
    var current = root; // a node reference
    loop {
        if ((current & LEAF_BIT) == 0u) {
            let base = wide_node_base(current);
            // Continue with the nearest hit child (ties and any-hit: the lowest lane) and push the
            // others with their entry distances, which the pop still culls against the best hit.
            // The CPU sorts them all; the hit rule does not depend on the order, and here a rank sort
            // over eight lanes cost lavapipe more than it saved (DESIGN-NOTES "8-wide nodes").
            var next = 0u;
            var next_t = big;
            var found = false;
            for (var g = 0u; g < BVH_GROUPS; g = g + 1u) {
                let te = node_slab(base, g, o, inv_d, tmin, t_best);
                for (var l = 0u; l < 4u; l = l + 1u) {
                    let t = te[l];
                    if (t == big) {
                        continue;
                    }
                    let child = node_child(base, 4u * g + l);
                    if (!found) {
                        found = true;
                        next = child;
                        next_t = t;
                        continue;
                    }
                    if (!any_hit && t < next_t) {
                        stack[sp] = next;
                        stack_t[sp] = next_t;
                        next = child;
                        next_t = t;
                    } else {
                        stack[sp] = child;
                        stack_t[sp] = t;
                    }
                    sp = sp + 1u;
                }
            }
            if (found) {
                current = next;
                continue;
            }
        } else {
            let first = current & LEAF_FIRST_MASK;
            let count = ((current >> 28u) & 7u) + 1u;
            for (var pi = first; pi < first + count; pi = pi + 1u) {
                let index = triangle_pack_index(pi);
                let h = pack_intersect(pi, pr, tmin, t_best);
                for (var lane = 0u; lane < 4u; lane = lane + 1u) {
                    if (!h.ok[lane]) {
                        continue;
                    }
                    if (any_hit) {
                        // Any hit strictly inside the ray's interval answers the query.
                        if (h.t[lane] < t_best) {
                            return Hit(true, h.t[lane], index[lane], h.b1[lane], h.b2[lane]);
                        }
                    } else if (closer(h.t[lane], index[lane], t_best, best_triangle)) {
                        t_best = h.t[lane];
                        best_triangle = index[lane];
                        best = Hit(true, h.t[lane], index[lane], h.b1[lane], h.b2[lane]);
                    }
                }
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
        current = stack[sp];
    }
    // Unreachable unless the driver cut the loop short (the loop only exits by `return`).
    atomicAdd(&counters[COUNTER_CUT_LOOPS], 1u);
    return best;
}

// bvh::traverse: the static tree (node 0) alone.
fn traverse(o: vec3<f32>, d: vec3<f32>, tmin: f32, tmax: f32, any_hit: bool) -> Hit {
    return traverse_tree(0u, o, d, tmin, tmax, 0u, any_hit);
}

// scene.rs `box_entered`: whether the ray enters the box with tmin < t < tmax (the nodes' slab test
// on one box: exit widened, NaN no constraint).
fn box_entered(bmin: vec3<f32>, bmax: vec3<f32>, o: vec3<f32>, inv_d: vec3<f32>, tmin: f32, tmax: f32) -> bool {
    var t_enter = tmin;
    var t_exit = tmax;
    let neg = inv_d < vec3<f32>(0.0);
    let lo = select(bmin, bmax, neg);
    let hi = select(bmax, bmin, neg);
    for (var axis = 0u; axis < 3u; axis = axis + 1u) {
        let near = (lo[axis] - o[axis]) * inv_d[axis];
        let far = (hi[axis] - o[axis]) * inv_d[axis];
        t_enter = select(max(near, t_enter), t_enter, is_nan(near));
        t_exit = select(min(far, t_exit), t_exit, is_nan(far));
    }
    return t_enter <= t_exit * bitcast<f32>(0x3f800003u);
}

// Entries of the top-level walk's stack in `scene_trace` (bvh::build::TOP_STACK_SIZE; the scene
// build keeps the top-level tree within it).
const TOP_STACK_SIZE: u32 = 32u;

// SceneAt::intersect / SceneAt::occluded at `scene_time`: the static tree (node 0), then every
// instance whose swept box the ray enters before the best hit so far, traversed from its root with
// the ray moved into its rest pose. The instances are found by walking the top-level tree over their
// swept boxes (bvh::traverse::walk_leaves; from `scene_layout.instance_root`, its leaves name
// instances) between traversals: one call of `traverse_tree` in one loop, so the traversal is
// inlined once per call site as before motion. Measured on lavapipe (`wedge render
// pipelines/shadows.ron --backend wgpu`, 96×72, static `grids`, sampling time) before the top-level
// tree: a static traversal followed by a loop of instance traversals (inlined twice) ran 2.3× slower
// than before motion, a static fast path before the loop 1.3×, one loop over all instances 1.11×
// (1.55 → 1.73 s), and switching trees inside one traversal loop where the stack runs empty 1.15×.
// Images are bit-identical either way; real GPUs are not measured here.
fn scene_trace(o: vec3<f32>, d: vec3<f32>, tmin: f32, tmax: f32, any_hit: bool) -> Hit {
    var best = no_hit();
    var limit = tmax;
    var tri = 0u;
    let inv_d = vec3<f32>(1.0 / d.x, 1.0 / d.y, 1.0 / d.z);
    let big = inf();
    var top: array<u32, TOP_STACK_SIZE>;
    var top_sp = 0u;
    if (scene_layout.instance_count > 0u) {
        top[0] = scene_layout.instance_root;
        top_sp = 1u;
    }
    var root = 0u;
    var ro = o;
    var rd = d;
    loop {
        let h = traverse_tree(root, ro, rd, tmin, limit, tri, any_hit);
        if (h.hit) {
            best = h;
            if (any_hit) {
                return best;
            }
            limit = h.t;
            tri = h.triangle;
        }
        // The next instance whose swept box the ray enters before `limit` (children pushed in lane
        // order: the hit rule does not depend on the order instances are traced in).
        var found = false;
        var inst: Instance;
        loop {
            if (top_sp == 0u) {
                break;
            }
            top_sp = top_sp - 1u;
            let r = top[top_sp];
            if ((r & LEAF_BIT) != 0u) {
                inst = scene_instance(r & LEAF_FIRST_MASK);
                if (box_entered(inst.swept_min, inst.swept_max, o, inv_d, tmin, limit)) {
                    found = true;
                    break;
                }
                continue;
            }
            let base = wide_node_base(r);
            for (var g = 0u; g < BVH_GROUPS; g = g + 1u) {
                let te = node_slab(base, g, o, inv_d, tmin, limit);
                for (var l = 0u; l < 4u; l = l + 1u) {
                    if (te[l] != big) {
                        top[top_sp] = node_child(base, 4u * g + l);
                        top_sp = top_sp + 1u;
                    }
                }
            }
        }
        if (!found) {
            return best;
        }
        let xf = instance_transform(inst, scene_time);
        ro = xf_inverse_point(xf, o);
        rd = xf_inverse_vector(xf, d);
        root = inst.root;
    }
    // Unreachable unless the driver cut the loop short (the loop only exits by `return`).
    return best;
}

fn scene_intersect(o: vec3<f32>, d: vec3<f32>, tmin: f32, tmax: f32) -> Hit {
    return scene_trace(o, d, tmin, tmax, false);
}

fn scene_occluded(o: vec3<f32>, d: vec3<f32>, tmin: f32, tmax: f32) -> bool {
    return scene_trace(o, d, tmin, tmax, true).hit;
}
