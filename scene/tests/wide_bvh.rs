//! The 4-wide BVH on raw triangle soups (no scene loader in between, so duplicates and coplanar
//! overlaps survive): the collapsed tree covers every triangle reference exactly once with boxes that
//! contain their subtrees, oversized leaves are split, the stack bound holds, and traversal returns
//! exactly the brute-force answer under the closest-hit rule (smallest t, then lowest index) —
//! including ties between coincident triangles.

use glam::Vec3;
use wedge_scene::bvh::{
    self, build::BinaryNode, build::BinaryTree, child_ref, closer, intersect_triangle, stack_need, Bvh, Child, Simd,
    TriangleRecord, WideNode, MAX_LEAF, STACK_SIZE,
};

struct Rng(u64);
impl Rng {
    fn f(&mut self) -> f32 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
    fn v(&mut self) -> Vec3 {
        Vec3::new(self.f(), self.f(), self.f())
    }
}

/// Triangles stored in the BVH's order, as `Scene::from_triangles` does.
fn records(input: &[[Vec3; 3]], built: &bvh::BuiltBvh) -> Vec<TriangleRecord> {
    built
        .order
        .iter()
        .map(|&i| {
            let t = input[i as usize];
            TriangleRecord::new(t[0], t[1], t[2], 0, i)
        })
        .collect()
}

fn brute(tris: &[TriangleRecord], o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<(u32, f32)> {
    let mut best: Option<(u32, f32)> = None;
    for (i, t) in tris.iter().enumerate() {
        if let Some((t, _, _)) = intersect_triangle(t, o, d, tmin, f32::INFINITY) {
            let (tb, ib) = best.map_or((tmax, 0), |b| (b.1, b.0));
            if t < tmax && closer(t, i as u32, tb, ib) {
                best = Some((i as u32, t));
            }
        }
    }
    best
}

/// Every reference appears once; boxes contain their children's; leaves are small; stack bound holds.
fn check_structure(nodes: &[WideNode], tris: &[TriangleRecord]) {
    let mut seen = vec![0u32; tris.len()];
    let mut todo = vec![0usize];
    while let Some(i) = todo.pop() {
        let n = &nodes[i];
        for s in 0..bvh::WIDTH {
            if !n.used(s) {
                continue;
            }
            let lo = Vec3::new(n.bounds[0][s], n.bounds[2][s], n.bounds[4][s]);
            let hi = Vec3::new(n.bounds[1][s], n.bounds[3][s], n.bounds[5][s]);
            match child_ref(n.child[s]) {
                Child::Node(j) => {
                    assert!(j as usize > i, "children follow their parent");
                    let c = &nodes[j as usize];
                    for cs in (0..bvh::WIDTH).filter(|&cs| c.used(cs)) {
                        let clo = Vec3::new(c.bounds[0][cs], c.bounds[2][cs], c.bounds[4][cs]);
                        let chi = Vec3::new(c.bounds[1][cs], c.bounds[3][cs], c.bounds[5][cs]);
                        assert!(clo.cmpge(lo).all() && chi.cmple(hi).all(), "node {j} slot {cs} outside its parent");
                    }
                    todo.push(j as usize);
                }
                Child::Leaf { first, count } => {
                    assert!((1..=MAX_LEAF).contains(&count));
                    for k in first..first + count {
                        seen[k as usize] += 1;
                        for v in tris[k as usize].vertices() {
                            assert!(v.cmpge(lo).all() && v.cmple(hi).all(), "triangle {k} outside its leaf box");
                        }
                    }
                }
            }
        }
    }
    assert!(seen.iter().all(|&c| c == 1), "every triangle reference in exactly one leaf");
    assert!(stack_need(nodes) <= STACK_SIZE);
}

/// The packed leaves hold exactly the triangles (same bits) the unpacked leaves referenced.
fn check_packs(bvh: &Bvh, tris: &[TriangleRecord]) {
    let mut seen = vec![0u32; tris.len()];
    for n in &bvh.nodes {
        for c in n.children() {
            if let Child::Leaf { first, count } = c {
                assert!(count <= 2, "a leaf of at most 8 triangles takes at most two packs");
                for p in &bvh.packs[first as usize..(first + count) as usize] {
                    for lane in 0..4 {
                        let i = p.index[lane];
                        if i == wedge_scene::bvh::NO_TRIANGLE {
                            assert_eq!([p.v1[0][lane], p.v2[0][lane], p.v1[1][lane], p.v2[2][lane]], [0.0; 4]);
                            continue;
                        }
                        seen[i as usize] += 1;
                        let t = &tris[i as usize];
                        for axis in 0..3 {
                            assert_eq!(
                                [p.v0[axis][lane], p.v1[axis][lane], p.v2[axis][lane]].map(f32::to_bits),
                                [t.v0[axis], t.v1[axis], t.v2[axis]].map(f32::to_bits)
                            );
                        }
                    }
                }
            }
        }
    }
    assert!(seen.iter().all(|&c| c == 1), "every triangle in exactly one pack lane");
}

fn check_rays(name: &str, tris: &[TriangleRecord], nodes: &[WideNode], rng: &mut Rng, rays: usize) -> (u32, u32) {
    let bvh = Bvh::pack(nodes.to_vec(), tris);
    check_packs(&bvh, tris);
    let (mut hits, mut ties) = (0, 0);
    for k in 0..rays {
        let o = rng.v() * 3.0 - Vec3::splat(1.0);
        let target = rng.v();
        // Some rays axis-parallel (zero direction components: the 0 · ∞ slab case).
        let mut d = target - o;
        if k % 7 == 0 {
            d.x = 0.0;
        }
        if k % 11 == 0 {
            d.y = 0.0;
            d.z = 0.0;
        }
        if d == Vec3::ZERO {
            continue;
        }
        let tmax = if k % 3 == 0 { 0.5 + rng.f() } else { f32::INFINITY };
        let want = brute(tris, o, d, 1e-5, tmax);
        let got = bvh::traverse(&bvh, o, d, 1e-5, tmax, false);
        assert_eq!(got.map(|h| (h.triangle, h.t.to_bits())), want.map(|(i, t)| (i, t.to_bits())), "{name} ray {k}");
        let occluded = bvh::traverse(&bvh, o, d, 1e-5, tmax, true).is_some();
        assert_eq!(occluded, want.is_some(), "{name} ray {k}: any-hit");
        // Every slab test this CPU runs (portable 4-lane groups, AVX) gives the same hit, bits and all.
        for simd in [Simd::Portable, Simd::Avx].into_iter().filter(|s| s.available()) {
            let hit = bvh::traverse_simd(&bvh, simd, o, d, 1e-5, tmax, false);
            assert_eq!(hit, got, "{name} ray {k}: {simd:?}");
            let any = bvh::traverse_simd(&bvh, simd, o, d, 1e-5, tmax, true).is_some();
            assert_eq!(any, occluded, "{name} ray {k}: {simd:?} any-hit");
        }
        if let Some((i, t)) = want {
            hits += 1;
            ties += tris.iter().enumerate().any(|(j, tr)| {
                j as u32 != i && intersect_triangle(tr, o, d, 1e-5, f32::INFINITY).is_some_and(|h| h.0 == t)
            }) as u32;
        }
    }
    (hits, ties)
}

#[test]
fn random_soup_with_coincident_copies_matches_brute_force_exactly() {
    let mut rng = Rng(7);
    let mut input: Vec<[Vec3; 3]> = (0..3000)
        .map(|_| {
            let c = rng.v();
            let s = 0.02 + 0.1 * rng.f();
            [c, c + (rng.v() - 0.5) * s, c + (rng.v() - 0.5) * s]
        })
        .collect();
    // Coincident copies (the same triangle twice, and with its vertices rotated) force ties.
    for i in 0..300 {
        let t = input[i * 7];
        input.push(t);
        input.push([t[1], t[2], t[0]]);
    }
    let built = bvh::build(&input);
    let tris = records(&input, &built);
    check_structure(&built.nodes, &tris);
    let (hits, ties) = check_rays("soup", &tris, &built.nodes, &mut rng, 4000);
    println!(
        "soup: {} triangles, {} nodes, depth {}, stack need {}; {hits} hits, {ties} ties",
        tris.len(),
        built.nodes.len(),
        built.depth,
        built.stack_need
    );
    assert!(hits > 1000 && ties > 20, "{hits} hits, {ties} ties: the test must exercise ties");
}

#[test]
fn median_fallback_tree_traces_the_same() {
    let mut rng = Rng(11);
    let input: Vec<[Vec3; 3]> = (0..2000)
        .map(|_| {
            let c = rng.v();
            [c, c + (rng.v() - 0.5) * 0.1, c + (rng.v() - 0.5) * 0.1]
        })
        .collect();
    let built = bvh::build_median(&input);
    let tris = records(&input, &built);
    check_structure(&built.nodes, &tris);
    check_rays("median", &tris, &built.nodes, &mut rng, 2000);
}

/// A binary leaf larger than a wide leaf holds (a builder preset with big leaves) is split into chunks.
#[test]
fn oversized_leaves_are_split() {
    let mut rng = Rng(3);
    let input: Vec<[Vec3; 3]> = (0..45)
        .map(|_| {
            let c = rng.v();
            [c, c + rng.v() * 0.2, c + rng.v() * 0.2]
        })
        .collect();
    // Root with two leaves of 40 and 5 triangles.
    let boxed = |r: std::ops::Range<usize>| {
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for t in &input[r] {
            for v in t {
                lo = lo.min(*v);
                hi = hi.max(*v);
            }
        }
        (lo.to_array(), hi.to_array())
    };
    let (a, b, all) = (boxed(0..40), boxed(40..45), boxed(0..45));
    let tree = BinaryTree {
        nodes: vec![
            BinaryNode { min: all.0, index: 1, max: all.1, count: 0 },
            BinaryNode { min: a.0, index: 0, max: a.1, count: 40 },
            BinaryNode { min: b.0, index: 40, max: b.1, count: 5 },
        ],
        order: (0..45).collect(),
    };
    let built = bvh::build::collapse(&tree);
    let tris = records(&input, &built);
    check_structure(&built.nodes, &tris);
    check_rays("split leaves", &tris, &built.nodes, &mut rng, 1000);
}

/// The surface-area cost [`bvh::build::collapse_with`] minimises, evaluated on a collapsed tree: the
/// root's box and every inner slot's box cost `node`, every leaf slot's box `pack` per pack.
fn sah_cost(nodes: &[WideNode], cost: bvh::build::CollapseCost) -> f64 {
    let area = |lo: Vec3, hi: Vec3| {
        let e = hi - lo;
        (e.x * e.y + e.y * e.z + e.z * e.x) as f64
    };
    let slot_box = |n: &WideNode, s: usize| {
        (
            Vec3::new(n.bounds[0][s], n.bounds[2][s], n.bounds[4][s]),
            Vec3::new(n.bounds[1][s], n.bounds[3][s], n.bounds[5][s]),
        )
    };
    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for s in (0..bvh::WIDTH).filter(|&s| nodes[0].used(s)) {
        let (a, b) = slot_box(&nodes[0], s);
        lo = lo.min(a);
        hi = hi.max(b);
    }
    let mut total = area(lo, hi) * cost.node as f64;
    for n in nodes {
        for s in (0..bvh::WIDTH).filter(|&s| n.used(s)) {
            let (a, b) = slot_box(n, s);
            total += area(a, b)
                * match child_ref(n.child[s]) {
                    Child::Node(_) => cost.node as f64,
                    Child::Leaf { count, .. } => count.div_ceil(4) as f64 * cost.pack as f64,
                };
        }
    }
    total
}

/// The dynamic-programming collapse finds the least-cost 4-wide tree over a binary tree's nodes, so
/// it never costs more than the greedy collapse of the same binary tree (one of the trees it
/// considers), on obvhs's 8-triangle leaves and on one-triangle leaves; and its trees trace exactly.
#[test]
fn optimal_collapse_costs_no_more_than_greedy() {
    use bvh::build::{binary_obvhs, collapse_greedy, collapse_with, CollapseCost};
    let mut rng = Rng(5);
    let input: Vec<[Vec3; 3]> = (0..4000)
        .map(|_| {
            let c = rng.v();
            let s = 0.01 + 0.15 * rng.f() * rng.f();
            [c, c + (rng.v() - 0.5) * s, c + (rng.v() - 0.5) * s]
        })
        .collect();
    for leaf in [8, 1] {
        let params = obvhs::BvhBuildParams { max_prims_per_leaf: leaf, ..obvhs::BvhBuildParams::fast_build() };
        let tree = binary_obvhs(&input, params);
        let greedy = collapse_greedy(&tree);
        for cost in
            [bvh::build::COLLAPSE_COST, CollapseCost { node: 1.0, pack: 0.5 }, CollapseCost { node: 1.0, pack: 4.0 }]
        {
            let optimal = collapse_with(&tree, cost);
            let (g, o) = (sah_cost(&greedy.nodes, cost), sah_cost(&optimal.nodes, cost));
            println!(
                "leaf {leaf}, {cost:?}: greedy {g:.1}, optimal {o:.1} ({} / {} nodes)",
                greedy.nodes.len(),
                optimal.nodes.len()
            );
            assert!(o <= g * (1.0 + 1e-5), "leaf {leaf}, {cost:?}: optimal {o} > greedy {g}");
            let tris = records(&input, &optimal);
            check_structure(&optimal.nodes, &tris);
            check_rays("optimal collapse", &tris, &optimal.nodes, &mut rng, 300);
        }
    }
}

/// Möller–Trumbore exactly as wedge traced triangles before the watertight test (the old
/// `triangle_hit`: edge vectors `e1 = v1 − v0`, `e2 = v2 − v0`, written out per component), hits with
/// t > 0, for the leak comparison below.
fn moller_trumbore(t: &TriangleRecord, o: Vec3, d: Vec3) -> Option<f32> {
    let (e1, e2, v0) = (t.e1().to_array(), t.e2().to_array(), t.v0);
    let p = [d.y * e2[2] - d.z * e2[1], d.z * e2[0] - d.x * e2[2], d.x * e2[1] - d.y * e2[0]];
    let det = (e1[0] * p[0] + e1[1] * p[1]) + e1[2] * p[2];
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv_det = 1.0 / det;
    let s = [o.x - v0[0], o.y - v0[1], o.z - v0[2]];
    let b1 = ((s[0] * p[0] + s[1] * p[1]) + s[2] * p[2]) * inv_det;
    if !(0.0..=1.0).contains(&b1) {
        return None;
    }
    let q = [s[1] * e1[2] - s[2] * e1[1], s[2] * e1[0] - s[0] * e1[2], s[0] * e1[1] - s[1] * e1[0]];
    let b2 = ((d.x * q[0] + d.y * q[1]) + d.z * q[2]) * inv_det;
    if b2 < 0.0 || b1 + b2 > 1.0 {
        return None;
    }
    Some(((e2[0] * q[0] + e2[1] * q[1]) + e2[2] * q[2]) * inv_det).filter(|&t| t > 0.0)
}

/// A closed mesh: a UV sphere of radius `r` about `c` with jittered vertices, each vertex stored once
/// and shared by the triangles around it (so neighbours see bit-identical corners).
fn closed_sphere(rng: &mut Rng, c: Vec3, r: f32, slices: usize, stacks: usize) -> (Vec<Vec3>, Vec<[usize; 3]>) {
    let mut v = vec![c + Vec3::Y * r];
    for i in 1..stacks {
        for j in 0..slices {
            let (th, ph) =
                (std::f32::consts::PI * i as f32 / stacks as f32, std::f32::consts::TAU * j as f32 / slices as f32);
            let jitter = 1.0 + 0.05 * (rng.f() - 0.5);
            v.push(c + Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin()) * (r * jitter));
        }
    }
    v.push(c - Vec3::Y * r);
    let at = |i: usize, j: usize| 1 + (i - 1) * slices + j % slices;
    let mut f = Vec::new();
    for j in 0..slices {
        f.push([0, at(1, j + 1), at(1, j)]);
        f.push([v.len() - 1, at(stacks - 1, j), at(stacks - 1, j + 1)]);
        for i in 1..stacks - 1 {
            f.push([at(i, j), at(i, j + 1), at(i + 1, j)]);
            f.push([at(i, j + 1), at(i + 1, j + 1), at(i + 1, j)]);
        }
    }
    (v, f)
}

/// A fan: `n` triangles around the vertex `c` (vertex 0), their rim jittered in radius and height,
/// every spoke shared by two triangles.
fn fan(rng: &mut Rng, c: Vec3, r: f32, n: usize) -> (Vec<Vec3>, Vec<[usize; 3]>) {
    let mut v = vec![c];
    for j in 0..n {
        let ph = std::f32::consts::TAU * j as f32 / n as f32;
        let (rr, h) = (r * (1.0 + 0.3 * (rng.f() - 0.5)), r * 0.2 * (rng.f() - 0.5));
        v.push(c + Vec3::new(ph.cos() * rr, h, ph.sin() * rr));
    }
    let f = (0..n).map(|j| [0, 1 + j, 1 + (j + 1) % n]).collect();
    (v, f)
}

/// Rays that cannot miss: aimed exactly at shared vertices and at points of shared edges, from inside
/// a closed mesh or from either side of a fan (the cases where a test can let a ray slip between two
/// triangles). Rays, then misses of the watertight test through the BVH (= brute force, asserted;
/// any-hit too) and of Möller–Trumbore by brute force, for vertex-aimed and edge-aimed rays.
#[derive(Default, Debug)]
struct Leaks {
    rays: [usize; 2],
    watertight: [usize; 2],
    moller_trumbore: [usize; 2],
}

fn count_leaks(
    rng: &mut Rng,
    v: &[Vec3],
    f: &[[usize; 3]],
    shared_vertices: &[usize],
    origin: &mut dyn FnMut(&mut Rng) -> Vec3,
) -> Leaks {
    let input: Vec<[Vec3; 3]> = f.iter().map(|t| t.map(|i| v[i])).collect();
    let built = bvh::build(&input);
    let tris = records(&input, &built);
    let b = Bvh::pack(built.nodes, &tris);
    // Shared edges: those of two faces.
    let mut edges = std::collections::BTreeMap::new();
    for t in f {
        for e in 0..3 {
            let (p, q) = (t[e], t[(e + 1) % 3]);
            *edges.entry((p.min(q), p.max(q))).or_insert(0) += 1;
        }
    }
    let mut targets: Vec<(usize, Vec3)> = shared_vertices.iter().map(|&i| (0, v[i])).collect();
    for (&(p, q), _) in edges.iter().filter(|(_, &n)| n == 2) {
        for _ in 0..6 {
            targets.push((1, v[p] + (v[q] - v[p]) * rng.f()));
        }
    }
    let mut l = Leaks::default();
    for &(kind, target) in &targets {
        for _ in 0..4 {
            let o = origin(rng);
            let d = (target - o) * (0.5 + rng.f());
            let hit = bvh::traverse(&b, o, d, 0.0, f32::INFINITY, false);
            let any = bvh::traverse(&b, o, d, 0.0, f32::INFINITY, true);
            let brute = tris.iter().any(|t| intersect_triangle(t, o, d, 0.0, f32::INFINITY).is_some());
            assert_eq!(hit.is_some(), brute, "traversal = brute force");
            assert_eq!(any.is_some(), brute, "any-hit = brute force");
            l.rays[kind] += 1;
            l.watertight[kind] += hit.is_none() as usize;
            l.moller_trumbore[kind] += tris.iter().all(|t| moller_trumbore(t, o, d).is_none()) as usize;
        }
    }
    l
}

/// Rays aimed exactly at the shared vertices and edges of closed meshes (jittered UV spheres: 24 × 12,
/// 528 triangles, from random points inside) and of fans (16 triangles round a vertex, from random
/// points above and below) must hit them. The watertight test never misses, through the BVH or by
/// brute force; Möller–Trumbore, which wedge used before, does (printed; DESIGN-NOTES "Ray tracing
/// core" has the counts).
#[test]
fn rays_through_shared_edges_and_vertices_never_leak() {
    let mut rng = Rng(21);
    let mut total = Leaks::default();
    let mut add = |what: String, l: Leaks| {
        println!(
            "{what}: {} + {} rays at vertices + edges, misses: watertight {} + {}, Möller–Trumbore {} + {}",
            l.rays[0], l.rays[1], l.watertight[0], l.watertight[1], l.moller_trumbore[0], l.moller_trumbore[1]
        );
        for k in 0..2 {
            total.rays[k] += l.rays[k];
            total.watertight[k] += l.watertight[k];
            total.moller_trumbore[k] += l.moller_trumbore[k];
        }
    };
    for (c, r) in [(Vec3::ZERO, 1.0), (Vec3::new(1000.0, 37.0, -500.0), 1.0), (Vec3::new(3.0, -2.0, 1.0), 0.01)] {
        let (v, f) = closed_sphere(&mut rng, c, r, 24, 12);
        let all: Vec<usize> = (0..v.len()).collect();
        let mut inside = |rng: &mut Rng| c + (rng.v() - Vec3::splat(0.5)) * r;
        let l = count_leaks(&mut rng, &v, &f, &all, &mut inside);
        add(format!("sphere at {c} radius {r}"), l);
    }
    for (c, r) in [(Vec3::new(0.3, 0.7, -0.2), 1.0), (Vec3::new(-40.0, 3.0, 25.0), 2.0)] {
        let (v, f) = fan(&mut rng, c, r, 16);
        let mut around = |rng: &mut Rng| {
            let side = if rng.f() < 0.5 { -1.0 } else { 1.0 };
            c + Vec3::new(rng.f() - 0.5, side * (0.5 + rng.f()), rng.f() - 0.5) * (2.0 * r)
        };
        // The centre vertex 250 times over (from 1000 origins).
        let l = count_leaks(&mut rng, &v, &f, &[0; 250], &mut around);
        add(format!("fan at {c} radius {r}"), l);
    }
    println!("total: {total:?}");
    assert_eq!(total.watertight, [0, 0], "the watertight test leaked");
    assert!(
        total.moller_trumbore[0] > 0 && total.moller_trumbore[1] > 0,
        "the rays should be hard enough to make Möller–Trumbore leak"
    );
}

#[test]
fn gamma_constants_are_n_u_over_1_minus_n_u() {
    let u = f32::EPSILON * 0.5;
    for (k, n) in [2.0f32, 3.0, 5.0].into_iter().enumerate() {
        assert_eq!(bvh::triangle::GAMMA[k], n * u / (1.0 - n * u));
    }
}
