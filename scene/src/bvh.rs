//! The flat BVH2 the CPU and the GPU both traverse, and the triangle layout they test against.
//!
//! obvhs builds the tree (PLOC + reinsertion, `medium_build`); we only keep its node array and
//! primitive order. PLOC pairs mutual nearest neighbours along the Morton order; when many primitives
//! share one Morton code (identical bounding-box centres, e.g. a million triangles rotated about one
//! point) the merge costs tie, only one pair merges per pass and the build turns quadratic with a
//! chain-shaped tree (1M such triangles did not finish in minutes). [`build`] detects that input and
//! uses a plain median-split builder instead ([`build_median`]: O(n log n), depth ≤ log2(n) + 1), and
//! also falls back to it when obvhs returns a tree deeper than the traversal stack. The traversal below is deliberately plain — a fixed 64-entry stack, near child first
//! (closest hit; any-hit takes the children in array order), slab test, Möller–Trumbore in f32 — so the
//! WGSL kernel can mirror it line by line and the two agree. The CPU version evaluates the same formulas
//! on glam `Vec3A` (SSE) lanes; see [`slab`] for why that is bit-identical to the scalar form.

use bytemuck::{Pod, Zeroable};
use glam::{Vec3, Vec3A};

/// Depth of the traversal stack. The builder rejects trees deeper than this (a push happens at most once
/// per level, so depth ≤ STACK_SIZE guarantees the stack never overflows).
pub const STACK_SIZE: usize = 64;

/// Marker for "no light" in [`TriangleRecord::light`].
pub const NO_LIGHT: u32 = u32::MAX;

/// GPU-friendly flattened BVH2 node (32 bytes). Inner node: `count == 0`, children at `index` and
/// `index + 1`. Leaf: `count > 0` triangles starting at `Scene::triangles[index]`. Node 0 is the root.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct BvhNode {
    pub min: [f32; 3],
    pub index: u32,
    pub max: [f32; 3],
    pub count: u32,
}

/// A triangle as traced (48 bytes, `repr(C)`, Pod): `v0`, `e1 = v1 - v0`, `e2 = v2 - v0`, each followed
/// by a u32 so every vec3 sits in a 16-byte slot (WGSL `vec3<f32>` + `u32` packs exactly like this):
/// - `material`: index into `Scene::materials` (same as `Scene::shading[i].material`, duplicated so a
///   shadow/any-hit kernel need not read the shading array),
/// - `light`: index into `Scene::lights` of the emitter this triangle belongs to, or [`NO_LIGHT`],
/// - `source`: the triangle's index in the input order given to `Scene::from_triangles` (before BVH
///   reordering), for debugging and for callers that kept per-input-triangle data.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct TriangleRecord {
    pub v0: [f32; 3],
    pub material: u32,
    pub e1: [f32; 3],
    pub light: u32,
    pub e2: [f32; 3],
    pub source: u32,
}

impl TriangleRecord {
    pub fn new(a: Vec3, b: Vec3, c: Vec3, material: u32, source: u32) -> Self {
        TriangleRecord {
            v0: a.to_array(),
            material,
            e1: (b - a).to_array(),
            light: NO_LIGHT,
            e2: (c - a).to_array(),
            source,
        }
    }
    pub fn vertices(&self) -> [Vec3; 3] {
        let v0 = Vec3::from(self.v0);
        [v0, v0 + Vec3::from(self.e1), v0 + Vec3::from(self.e2)]
    }
}

/// A ray–scene intersection: distance along the (not necessarily unit) direction, the triangle index in
/// `Scene::triangles`, and the barycentric weights of v1 and v2 (v0's is 1 - b1 - b2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub triangle: u32,
    pub b1: f32,
    pub b2: f32,
}

/// Möller–Trumbore. Returns (t, b1, b2) for a hit with tmin < t < tmax. Single-sided tests are not done:
/// both faces are hit.
#[inline]
pub fn intersect_triangle(
    tri: &TriangleRecord,
    o: Vec3,
    d: Vec3,
    tmin: f32,
    tmax: f32,
) -> Option<(f32, f32, f32)> {
    intersect_triangle_a(tri, o.into(), d.into(), tmin, tmax)
}

/// [`intersect_triangle`] on SIMD vectors. Bit-identical to the scalar formulation: glam's `Vec3A`
/// dot is `(x·x' + y·y') + z·z'` and its cross computes the same products and differences as `Vec3`'s
/// (Rust never fuses multiply-adds), so hits, t and barycentrics match the WGSL mirror exactly.
#[inline(always)]
fn intersect_triangle_a(
    tri: &TriangleRecord,
    o: Vec3A,
    d: Vec3A,
    tmin: f32,
    tmax: f32,
) -> Option<(f32, f32, f32)> {
    let e1 = Vec3A::from(tri.e1);
    let e2 = Vec3A::from(tri.e2);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None; // ray parallel to the plane (or degenerate triangle)
    }
    let inv_det = 1.0 / det;
    let s = o - Vec3A::from(tri.v0);
    let b1 = s.dot(p) * inv_det;
    if !(0.0..=1.0).contains(&b1) {
        return None;
    }
    let q = s.cross(e1);
    let b2 = d.dot(q) * inv_det;
    if b2 < 0.0 || b1 + b2 > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv_det;
    if t > tmin && t < tmax {
        Some((t, b1, b2))
    } else {
        None
    }
}

/// Slab test. Returns the entry distance if the ray overlaps the box within (tmin, tmax), else +inf.
/// The exit distance is widened by a few ulps (PBRT's 1 + 2γ₃) so rounding never culls a triangle that
/// Möller–Trumbore would hit — thin boxes (a flat ground plane has zero height) need this.
///
/// NaN handling (0 · inf: origin on a slab plane, axis-parallel ray): the per-axis near/far are glam's
/// `if a < b { a } else { b }` (a NaN in `t1` propagates), and the reductions ignore NaN axes like
/// `f32::max`/`f32::min` (so an all-NaN axis, a flat box containing the origin, does not cull).
#[inline]
pub fn slab(node: &BvhNode, o: Vec3, inv_d: Vec3, tmin: f32, tmax: f32) -> f32 {
    slab_a(node, o.into(), inv_d.into(), Vec3A::splat(tmin), tmax)
}

/// [`slab`] on SIMD vectors, bit-identical to the scalar form: `Vec3A::min/max` are SSE `minps/maxps`
/// (= glam `Vec3`'s `if a < b { a } else { b }`, NaN → second operand), and folding `tmin`/`tmax` in
/// lane-wise *before* the horizontal reduction (`maxps(near, tmin)` turns a NaN lane into `tmin`)
/// gives exactly the NaN-ignoring `f32::max`/`f32::min` chain of the scalar code.
#[inline(always)]
fn slab_a(node: &BvhNode, o: Vec3A, inv_d: Vec3A, tmin: Vec3A, tmax: f32) -> f32 {
    let t0 = (Vec3A::from(node.min) - o) * inv_d;
    let t1 = (Vec3A::from(node.max) - o) * inv_d;
    let near = t0.min(t1);
    let far = t0.max(t1);
    let t_enter = near.max(tmin).max_element();
    let t_exit = far.min(Vec3A::splat(tmax)).min_element() * 1.000_000_4;
    if t_enter <= t_exit {
        t_enter
    } else {
        f32::INFINITY
    }
}

/// Shared traversal. With `any_hit` it returns the first hit found (shadow rays); otherwise the closest.
pub fn traverse(
    nodes: &[BvhNode],
    tris: &[TriangleRecord],
    o: Vec3,
    d: Vec3,
    tmin: f32,
    tmax: f32,
    any_hit: bool,
) -> Option<Hit> {
    if any_hit {
        traverse_impl::<true>(nodes, tris, o, d, tmin, tmax)
    } else {
        traverse_impl::<false>(nodes, tris, o, d, tmin, tmax)
    }
}

/// The traversal loop, monomorphised for any-hit / closest-hit so the per-leaf `any_hit` branch and
/// the closest-hit-only pop culling cost nothing in the other variant.
///
/// Closest hit: the stack keeps each deferred (far) child's entry distance next to its index; a popped
/// entry that starts beyond the (widened) current `t_best` is dropped without fetching the node — the
/// same test [`slab`] would fail on it now, one level earlier. Any-hit never shrinks `t_best` before it
/// returns, so it skips that bookkeeping.
#[inline(always)]
fn traverse_impl<const ANY_HIT: bool>(
    nodes: &[BvhNode],
    tris: &[TriangleRecord],
    o: Vec3,
    d: Vec3,
    tmin: f32,
    tmax: f32,
) -> Option<Hit> {
    if nodes.is_empty() || !(o.is_finite() && d.is_finite()) {
        return None;
    }
    let o = Vec3A::from(o);
    let d = Vec3A::from(d);
    let inv_d = d.recip();
    let tmin_v = Vec3A::splat(tmin);
    let mut best: Option<Hit> = None;
    let mut t_best = tmax;
    if slab_a(&nodes[0], o, inv_d, tmin_v, t_best) == f32::INFINITY {
        return None;
    }
    let mut stack = [0u32; STACK_SIZE];
    let mut stack_t = [0f32; STACK_SIZE];
    let mut sp = 0usize;
    let mut node = 0u32;
    loop {
        let n = &nodes[node as usize];
        if n.count > 0 {
            // Leaf: test its triangles.
            for i in n.index..n.index + n.count {
                if let Some((t, b1, b2)) =
                    intersect_triangle_a(&tris[i as usize], o, d, tmin, t_best)
                {
                    t_best = t;
                    best = Some(Hit {
                        t,
                        triangle: i,
                        b1,
                        b2,
                    });
                    if ANY_HIT {
                        return best;
                    }
                }
            }
        } else {
            // Inner node: visit the nearer child first, keep the farther one for later.
            let a = n.index;
            let b = n.index + 1;
            let ta = slab_a(&nodes[a as usize], o, inv_d, tmin_v, t_best);
            let tb = slab_a(&nodes[b as usize], o, inv_d, tmin_v, t_best);
            if ta != f32::INFINITY && tb != f32::INFINITY {
                // Any-hit only answers "is there a hit", so the order cannot change its result; a fixed
                // order skips the (unpredictable) compare and measured faster at the same node count.
                let (near, far, t_far) = if ANY_HIT || ta <= tb {
                    (a, b, tb)
                } else {
                    (b, a, ta)
                };
                stack[sp] = far;
                stack_t[sp] = t_far;
                sp += 1;
                node = near;
                continue;
            } else if ta != f32::INFINITY {
                node = a;
                continue;
            } else if tb != f32::INFINITY {
                node = b;
                continue;
            }
        }
        // Pop, dropping entries a closer hit has since made unreachable (closest hit only).
        loop {
            if sp == 0 {
                return best;
            }
            sp -= 1;
            if ANY_HIT || stack_t[sp] <= t_best * 1.000_000_4 {
                break;
            }
        }
        node = stack[sp];
    }
}

/// The result of building: nodes plus the input-triangle order the leaves expect.
pub struct BuiltBvh {
    pub nodes: Vec<BvhNode>,
    /// `order[k]` = input index of the triangle that must be stored at position k.
    pub order: Vec<u32>,
    pub depth: usize,
}

/// Build with obvhs and flatten. With a preset that pre-splits (spatial splits) a triangle is referenced
/// from several leaves, so `order` may repeat input indices; the scene stores one copy per reference.
/// `medium_build` (no splits) measured as fast as `slow_build` on `grids` and `heavy` (slow/very_slow
/// visit 2–11% fewer nodes but the difference was within noise, at 2–6× the build time); smaller
/// leaves (`max_prims_per_leaf` 4, or collapse cost 1–2) trade triangle tests for more node visits.
pub fn build(tris: &[[Vec3; 3]]) -> BuiltBvh {
    if largest_morton_cell(tris) > MAX_SHARED_MORTON_CELL {
        return build_median(tris);
    }
    // Heavily nested boxes (e.g. a million triangles rotated about one axis, all centres on a line) make
    // PLOC pair poorly too, without any tie. A PLOC build of an evenly strided sample is cheap and shows
    // it: ordinary scenes' samples are 18–23 deep (built-ins), such inputs' 130+.
    if tris.len() > PROBE_SIZE {
        let sample: Vec<[Vec3; 3]> = tris
            .iter()
            .step_by(tris.len() / PROBE_SIZE)
            .copied()
            .collect();
        if build_with(&sample, obvhs::BvhBuildParams::medium_build()).depth > MAX_PROBE_DEPTH {
            return build_median(tris);
        }
    }
    let built = build_with(tris, obvhs::BvhBuildParams::medium_build());
    if built.depth > STACK_SIZE {
        return build_median(tris);
    }
    built
}

/// Sample size of [`build`]'s PLOC probe on large inputs.
pub const PROBE_SIZE: usize = 16384;
/// Deepest sample tree [`build`] accepts before using [`build_median`] for the whole input.
pub const MAX_PROBE_DEPTH: usize = 48;

/// Most primitives allowed to share one Morton cell before [`build`] avoids PLOC. PLOC needs about
/// one pass over all nodes per primitive in the largest tied group, so this bounds its extra passes.
pub const MAX_SHARED_MORTON_CELL: usize = 256;

/// The largest number of triangles whose bounding-box centres fall into the same cell of a 2^21-per-axis
/// grid over the centres' bounds (the resolution of obvhs's 64-bit Morton codes).
pub fn largest_morton_cell(tris: &[[Vec3; 3]]) -> usize {
    let centre = |t: &[Vec3; 3]| (t[0].min(t[1]).min(t[2]) + t[0].max(t[1]).max(t[2])) * 0.5;
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for t in tris {
        let c = centre(t);
        lo = lo.min(c);
        hi = hi.max(c);
    }
    let scale = ((1u32 << 21) - 1) as f32 / (hi - lo).max(Vec3::splat(f32::MIN_POSITIVE));
    let mut cells: std::collections::HashMap<u64, usize> = std::collections::HashMap::new();
    let mut largest = 0;
    for t in tris {
        let q = ((centre(t) - lo) * scale).to_array().map(|x| x as u64); // NaN/inf saturate, never panic
        let n = cells.entry(q[0] << 42 | q[1] << 21 | q[2]).or_insert(0);
        *n += 1;
        largest = largest.max(*n);
    }
    largest
}

/// Top-down median split on the longest axis of the centres' bounds (ties split by position in the
/// list, so identical centres still halve): O(n log n) and depth ≤ ⌈log2(n / 4)⌉ + 1 on any input.
/// Slower to trace than obvhs's trees on ordinary scenes, so only [`build`]'s fallback.
pub fn build_median(tris: &[[Vec3; 3]]) -> BuiltBvh {
    const LEAF: usize = 4;
    let boxes: Vec<(Vec3, Vec3)> = tris
        .iter()
        .map(|t| (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2])))
        .collect();
    let centres: Vec<Vec3> = boxes.iter().map(|(a, b)| (*a + *b) * 0.5).collect();
    let mut order: Vec<u32> = (0..tris.len() as u32).collect();
    let mut nodes = vec![BvhNode::zeroed()];
    let mut todo = vec![(0usize, 0usize, tris.len())];
    while let Some((node, start, end)) = todo.pop() {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        let (mut clo, mut chi) = (lo, hi);
        for &i in &order[start..end] {
            lo = lo.min(boxes[i as usize].0);
            hi = hi.max(boxes[i as usize].1);
            clo = clo.min(centres[i as usize]);
            chi = chi.max(centres[i as usize]);
        }
        if end - start <= LEAF {
            nodes[node] = BvhNode {
                min: lo.to_array(),
                index: start as u32,
                max: hi.to_array(),
                count: (end - start) as u32,
            };
            continue;
        }
        let axis = (chi - clo).max_position();
        let mid = (end - start) / 2;
        order[start..end].select_nth_unstable_by(mid, |&a, &b| {
            centres[a as usize][axis].total_cmp(&centres[b as usize][axis])
        });
        let first_child = nodes.len();
        nodes.push(BvhNode::zeroed());
        nodes.push(BvhNode::zeroed());
        nodes[node] = BvhNode {
            min: lo.to_array(),
            index: first_child as u32,
            max: hi.to_array(),
            count: 0,
        };
        todo.push((first_child, start, start + mid));
        todo.push((first_child + 1, start + mid, end));
    }
    let depth = tree_depth(&nodes);
    BuiltBvh {
        nodes,
        order,
        depth,
    }
}

/// [`build`] with explicit obvhs parameters (for experiments and benchmarks).
pub fn build_with(tris: &[[Vec3; 3]], params: obvhs::BvhBuildParams) -> BuiltBvh {
    use obvhs::{bvh2::builder::build_bvh2_from_tris, triangle::Triangle};
    let input: Vec<Triangle> = tris
        .iter()
        .map(|t| Triangle {
            v0: t[0].into(),
            v1: t[1].into(),
            v2: t[2].into(),
        })
        .collect();
    let mut core_time = std::time::Duration::ZERO;
    let bvh = build_bvh2_from_tris(&input, params, &mut core_time);
    let nodes: Vec<BvhNode> = bvh
        .nodes
        .iter()
        .map(|n| BvhNode {
            min: Vec3::from(n.aabb.min).to_array(),
            index: n.first_index,
            max: Vec3::from(n.aabb.max).to_array(),
            count: n.prim_count,
        })
        .collect();
    let depth = tree_depth(&nodes);
    BuiltBvh {
        nodes,
        order: bvh.primitive_indices,
        depth,
    }
}

/// Depth of the tree (root alone = 1), iteratively so deep trees cannot blow the Rust stack.
pub fn tree_depth(nodes: &[BvhNode]) -> usize {
    if nodes.is_empty() {
        return 0;
    }
    let mut max_depth = 0;
    let mut todo = vec![(0u32, 1usize)];
    while let Some((i, d)) = todo.pop() {
        max_depth = max_depth.max(d);
        let n = &nodes[i as usize];
        if n.count == 0 {
            todo.push((n.index, d + 1));
            todo.push((n.index + 1, d + 1));
        }
    }
    max_depth
}
