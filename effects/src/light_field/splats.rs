//! The preprocessing of seed 001 (Lehtinen et al. 2012, Secs. 2.2–2.3.1): the input samples become
//! splats — disks on their hit points' tangent planes — sized by a bandwidth-aware k-NN search,
//! put in a BVH, and shrunk until no input ray crosses another sample's splat before its own hit.
//! Runs on the host on every backend (`light_field.splats` is a `Kernel::host` kernel), as the
//! scene's BVH is built; the GPU traverses the tree it writes.
//!
//! - **Radius** (Sec. 2.2): the distance from `h_i` to its `k`-th nearest neighbour `h_j` among the
//!   samples whose direction passes the angular test `A_i(ω_j) ≥ 1/2` (eq. 2: `ω_i·ω_j ≥ 1 − ln 2/κ_i`),
//!   under the metric `|d + (α − 1)(d·n_i) n_i|` that stretches offsets along the normal by `α`
//!   ([`metric_distance`]). The search asks a k-d tree (`kiddo`) for the Euclidean nearest
//!   candidates and widens until the `k`-th metric distance is within the candidates' Euclidean
//!   reach — exact, since the metric is never shorter than the Euclidean distance.
//! - **Tree**: obvhs's BVH2 (PLOC) over the splats' boxes, flattened to [`SplatNode`]s with the
//!   splats stored in leaf order, so a leaf's `index..index + count` are splat indices. A moving
//!   splat's box bounds its disk over the whole shutter (a motion BVH, Sec. 2.3: the disk's box at
//!   `t = −1` and `t = 1`, exact for its linear motion), so a ray of any time finds it.
//! - **Motion**: the k-NN measures distances between the splats where they are at the shutter's
//!   centre (`t = 0`: a moving surface's samples of different times are neighbours on the
//!   surface, as in its own frame); shrinking retraces each input ray at its own time against the
//!   splats where they are then.
//! - **Shrinking** (Sec. 2.3.1): every input ray (the ones that left the scene too, to infinity) is
//!   retraced through the tree; a splat it crosses before its own hit (by more than
//!   [`SHRINK_TOLERANCE`]) shrinks to just short of the crossing. Each splat takes the smallest
//!   radius any ray asks for, so the result does not depend on the order; then the boxes are refit.

use std::num::NonZeroUsize;

use glam::Vec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;

use super::reconstruct::{box_entered, disk_hit};
use super::records::{LightSample, SAMPLE_HIT, SAMPLE_NONE};
use super::{Splat, SplatNode, STACK_SIZE};

/// The k-NN settings (Sec. 2.2; paper: `k = 12`, `α = 3`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KnnSettings {
    pub k: u32,
    pub alpha: f32,
    /// A glossy sample's radius is at most this many times its spatial-only k-NN radius (∞: the
    /// paper's unbounded search; see [`knn_radii`]).
    pub glossy_cap: f32,
}

/// A shrunk splat's radius is this fraction of the distance to the crossing it must avoid.
pub const SHRINK_MARGIN: f32 = 0.999;
/// A crossing within this fraction of the ray's length before its own hit is the hit's own surface
/// (the neighbours' tangent disks of a curved surface), not an occluder.
pub const SHRINK_TOLERANCE: f32 = 1e-3;

/// The metric of Sec. 2.2: `|d + (α − 1)(d·n) n|`, offsets along the normal stretched by `α`.
#[inline]
pub fn metric_distance(d: Vec3, n: Vec3, alpha: f32) -> f32 {
    (d + n * ((alpha - 1.0) * d.dot(n))).length()
}

/// Whether sample `j`'s direction passes sample `i`'s angular test `A_i(ω_j) ≥ 1/2` (eq. 2).
#[inline]
pub fn angular_match(kappa_i: f32, wi: Vec3, wj: Vec3) -> bool {
    kappa_i <= 0.0 || wi.dot(wj) >= 1.0 - std::f32::consts::LN_2 / kappa_i
}

/// The splat radius of every splat (Sec. 2.2): the metric distance to its `k`-th qualifying
/// neighbour; with fewer than `k` qualifying samples in all, the farthest of them (0 with none).
///
/// Diffuse samples (`κ = 0`, every neighbour qualifies) search a 3-D tree of hit points. Glossy
/// ones search a 6-D tree of `(h, s·ω)`: a neighbour whose direction fails the angular test is at
/// least `s·√(2 ln2/κ)` away in it, so the qualifying ones come first instead of being sifted
/// from all the spatially near samples (with `κ ≈ 36`, ~1 in 20 qualifies). `s` balances the two
/// parts at the diffuse samples' typical radius; it changes only the speed: the search widens
/// until the `k`-th metric distance is provably the nearest (see [`knn_search`]).
pub fn knn_radii(splats: &[Splat], s: KnnSettings) -> Vec<f32> {
    let n = splats.len();
    if n < 2 || s.k == 0 {
        return vec![0.0; n];
    }
    // Every splat where it is at the shutter's centre (its stored hit point if it does not move).
    let centres: Vec<Vec3> = splats.iter().map(|p| p.centre_at(0.0)).collect();
    let points: Vec<[f32; 3]> = centres.iter().map(|c| c.to_array()).collect();
    let Ok(tree3) = ImmutableKdTree::<f32, 3>::new_from_slice(&points) else {
        return vec![0.0; n];
    };
    // The search without the angular test: a diffuse sample's radius, and a glossy sample's cap.
    let spatial = |i: usize| {
        knn_search(splats, &centres, i, 0.0, s, n, 0.0, f32::INFINITY, |want| {
            tree3
                .query(&points[i])
                .nearest_n::<SquaredEuclidean<f32>>(want)
                .execute()
                .into_iter()
                .map(|f| (f.item, f.distance))
                .collect()
        })
    };
    let diffuse: Vec<usize> = (0..n).filter(|&i| !(splats[i].kappa > 0.0)).collect();
    let glossy: Vec<usize> = (0..n).filter(|&i| splats[i].kappa > 0.0).collect();
    let mut radii = vec![0.0f32; n];
    let found: Vec<f32> = diffuse.par_iter().map(|&i| spatial(i)).collect();
    for (&i, r) in diffuse.iter().zip(found) {
        radii[i] = r;
    }
    if glossy.is_empty() {
        return radii;
    }
    // s: the median diffuse radius (else the median spatial-only radius of some glossy samples)
    // over the median glossy angular reach √(2 ln2/κ).
    let median = |mut v: Vec<f32>| {
        v.sort_by(f32::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(0.0)
    };
    let typical = if diffuse.is_empty() {
        median(glossy.iter().step_by((glossy.len() / 64).max(1)).map(|&i| spatial(i)).collect())
    } else {
        median(diffuse.iter().map(|&i| radii[i]).collect())
    };
    let reach = median(glossy.iter().map(|&i| (2.0 * std::f32::consts::LN_2 / splats[i].kappa).sqrt()).collect());
    let scale = if reach > 0.0 && typical > 0.0 { 4.0 * typical / reach } else { 1.0 };
    let points6: Vec<[f32; 6]> = splats
        .iter()
        .zip(&centres)
        .map(|(p, c)| [c.x, c.y, c.z, scale * p.direction[0], scale * p.direction[1], scale * p.direction[2]])
        .collect();
    let Ok(tree6) = ImmutableKdTree::<f32, 6>::new_from_slice(&points6) else {
        return radii;
    };
    let found: Vec<f32> = glossy
        .par_iter()
        .map(|&i| {
            // Not retrieved ⇒ 6-D distance² ≥ reach² ⇒ if it qualifies (|Δω|² ≤ 2 ln2/κ), its
            // spatial distance² ≥ reach² − s²·2 ln2/κ.
            let slack = scale * scale * 2.0 * std::f32::consts::LN_2 / splats[i].kappa;
            let cap = if s.glossy_cap.is_finite() { s.glossy_cap * spatial(i) } else { f32::INFINITY };
            knn_search(splats, &centres, i, splats[i].kappa, s, n, slack, cap, |want| {
                tree6
                    .query(&points6[i])
                    .nearest_n::<SquaredEuclidean<f32>>(want)
                    .execute()
                    .into_iter()
                    .map(|f| (f.item, f.distance))
                    .collect()
            })
        })
        .collect();
    for (&i, r) in glossy.iter().zip(found) {
        radii[i] = r;
    }
    radii
}

/// The k-NN search of sample `i` (`centres`: every splat's centre at the search's time):
/// `nearest(m)` returns the `m` nearest `(item, squared distance)`
/// in some space where every sample not returned lies at squared distance ≥ the last returned one,
/// and a qualifying sample's squared spatial distance is at least its squared distance there minus
/// `slack`; `kappa` is the `κ` of its angular test (0: none). Widens (×4) until the `k`-th
/// qualifying metric distance is within the spatial reach of what was returned — exact, as the
/// metric is never shorter than the spatial distance — or the reach passes `cap`, which the `k`-th
/// distance then exceeds too: the result is `min(k-th distance, cap)`.
#[allow(clippy::too_many_arguments)]
fn knn_search(
    splats: &[Splat],
    centres: &[Vec3],
    i: usize,
    kappa: f32,
    s: KnnSettings,
    n: usize,
    slack: f32,
    cap: f32,
    nearest: impl Fn(NonZeroUsize) -> Vec<(u32, f32)>,
) -> f32 {
    let k = s.k as usize;
    let p = &splats[i];
    let (hi, ni, wi) = (centres[i], Vec3::from(p.normal), Vec3::from(p.direction));
    let mut want = (4 * k + 1).min(n);
    loop {
        let found = nearest(NonZeroUsize::new(want).expect("n ≥ 2"));
        let reach = found.last().map_or(0.0, |f| (f.1 - slack).max(0.0).sqrt());
        let mut dist: Vec<f32> = found
            .iter()
            .filter(|f| f.0 as usize != i)
            .filter(|f| angular_match(kappa, wi, Vec3::from(splats[f.0 as usize].direction)))
            .map(|f| metric_distance(centres[f.0 as usize] - hi, ni, s.alpha))
            .collect();
        dist.sort_by(f32::total_cmp);
        let everything = want >= n;
        if dist.len() >= k && (dist[k - 1] <= reach || everything) {
            return dist[k - 1].min(cap);
        }
        if everything {
            return dist.last().copied().unwrap_or(0.0).min(cap);
        }
        if reach >= cap {
            return cap;
        }
        want = (want * 4).min(n);
    }
}

/// The box of a splat's disk over the whole shutter: `c(t) ± r·sqrt(1 − n_a²)` per axis, for `c(t)`
/// at `t = −1` and `t = 1` (the centre moves linearly between them); a still splat's disk box.
#[inline]
pub fn disk_box(s: &Splat) -> ([f32; 3], [f32; 3]) {
    let n = Vec3::from(s.normal);
    let e = (Vec3::ONE - n * n).max(Vec3::ZERO).powf(0.5) * s.radius.max(0.0);
    let (open, close) = (s.centre_at(-1.0), s.centre_at(1.0));
    ((open.min(close) - e).to_array(), (open.max(close) + e).to_array())
}

struct SplatBox(obvhs::aabb::Aabb);

impl obvhs::Boundable for SplatBox {
    fn aabb(&self) -> obvhs::aabb::Aabb {
        self.0
    }
}

/// The node of an empty tree: an inner node whose inverted box no ray enters.
pub fn empty_node() -> SplatNode {
    SplatNode { min: [f32::MAX; 3], count: 0, max: [f32::MIN; 3], index: 0 }
}

/// Build the splat tree and reorder `splats` into leaf order: obvhs's BVH2 (PLOC, at most
/// [`LEAF_SIZE`] splats per leaf); where that tree is too deep for the traversal stack (PLOC's
/// depth is unbounded: overlapping wide glossy splats reached 74 levels on `suite_glossy`), a
/// median-split tree (`wedge_scene::bvh::build::binary_median_boxes`, ≤ ⌈log2 n⌉ + 1 levels).
/// Deterministic (both builders build the same tree for the same boxes).
pub fn tree(splats: &mut Vec<Splat>) -> Vec<SplatNode> {
    if splats.is_empty() {
        return vec![empty_node()];
    }
    let boxes: Vec<([f32; 3], [f32; 3])> = splats.iter().map(disk_box).collect();
    let mut params = obvhs::BvhBuildParams::medium_build();
    params.max_prims_per_leaf = LEAF_SIZE;
    let mut core = std::time::Duration::ZERO;
    let prims: Vec<SplatBox> = boxes
        .iter()
        .map(|(lo, hi)| SplatBox(obvhs::aabb::Aabb::new(Vec3::from(*lo).into(), Vec3::from(*hi).into())))
        .collect();
    let bvh = obvhs::bvh2::builder::build_bvh2(&prims, params, &mut core);
    let mut nodes: Vec<SplatNode> = bvh
        .nodes
        .iter()
        .map(|n| SplatNode {
            min: Vec3::from(n.aabb.min).to_array(),
            count: n.prim_count,
            max: Vec3::from(n.aabb.max).to_array(),
            index: n.first_index,
        })
        .collect();
    let mut order = bvh.primitive_indices;
    if depth(&nodes) >= STACK_SIZE {
        let median = wedge_scene::bvh::build::binary_median_boxes(&boxes);
        nodes =
            median.nodes.iter().map(|n| SplatNode { min: n.min, count: n.count, max: n.max, index: n.index }).collect();
        order = median.order;
    }
    *splats = order.iter().map(|&i| splats[i as usize]).collect();
    refit(&mut nodes, splats);
    nodes
}

/// Splats per leaf of the splat tree.
pub const LEAF_SIZE: u32 = 4;

/// Levels of the tree (root alone = 1). A traversal's stack holds at most one entry per level
/// plus one, so a tree is traversable with [`STACK_SIZE`] entries when this is below it.
pub fn depth(nodes: &[SplatNode]) -> usize {
    if nodes.is_empty() {
        return 0;
    }
    let (mut deepest, mut todo) = (0, vec![(0u32, 1usize)]);
    while let Some((i, d)) = todo.pop() {
        deepest = deepest.max(d);
        let n = nodes[i as usize];
        if n.count == 0 && d < nodes.len() {
            todo.push((n.index, d + 1));
            todo.push((n.index + 1, d + 1));
        }
    }
    deepest
}

/// Recompute every box bottom-up from the splats' disks (after shrinking).
pub fn refit(nodes: &mut [SplatNode], splats: &[Splat]) {
    if nodes.is_empty() || splats.is_empty() {
        return;
    }
    // Post-order without recursion: visit order, then boxes in reverse.
    let mut order = Vec::with_capacity(nodes.len());
    let mut todo = vec![0u32];
    while let Some(i) = todo.pop() {
        order.push(i);
        let n = nodes[i as usize];
        if n.count == 0 {
            todo.push(n.index);
            todo.push(n.index + 1);
        }
    }
    for &i in order.iter().rev() {
        let n = nodes[i as usize];
        let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
        if n.count == 0 {
            for c in [n.index, n.index + 1] {
                lo = lo.min(Vec3::from(nodes[c as usize].min));
                hi = hi.max(Vec3::from(nodes[c as usize].max));
            }
        } else {
            for s in &splats[n.index as usize..(n.index + n.count) as usize] {
                let (a, b) = disk_box(s);
                lo = lo.min(Vec3::from(a));
                hi = hi.max(Vec3::from(b));
            }
        }
        nodes[i as usize].min = lo.to_array();
        nodes[i as usize].max = hi.to_array();
    }
}

/// One input ray for shrinking: from `origin` along unit `direction` to its own hit at `distance`
/// (∞ for a ray that left the scene), its own splat (`u32::MAX`: none), and its shutter time.
#[derive(Clone, Copy, Debug)]
pub struct InputRay {
    pub origin: Vec3,
    pub direction: Vec3,
    pub distance: f32,
    pub own: u32,
    pub time: f32,
}

/// Every crossing of `ray` (at its time) with a splat other than its own, before its own hit:
/// `(splat, the radius that avoids it)`.
pub fn blockers(nodes: &[SplatNode], splats: &[Splat], ray: &InputRay, t_min: f32) -> Vec<(u32, f32)> {
    let t_max = if ray.distance.is_finite() { ray.distance * (1.0 - SHRINK_TOLERANCE) } else { f32::INFINITY };
    let mut out = Vec::new();
    if nodes.is_empty() || !(t_max > t_min) {
        return out;
    }
    let inv_d = ray.direction.recip();
    let mut stack = [0u32; STACK_SIZE];
    let mut sp = 1usize;
    while sp > 0 {
        sp -= 1;
        let node = &nodes[stack[sp] as usize];
        if box_entered(node, ray.origin, inv_d, t_min, t_max).is_none() {
            continue;
        }
        if node.count == 0 {
            stack[sp] = node.index;
            stack[sp + 1] = node.index + 1;
            sp += 2;
            continue;
        }
        for k in node.index..node.index + node.count {
            if k == ray.own {
                continue;
            }
            let s = &splats[k as usize];
            if let Some(t) = disk_hit(s, ray.origin, ray.direction, t_min, t_max, 1.0, ray.time) {
                let q = ray.origin + ray.direction * t;
                out.push((k, (q - s.centre_at(ray.time)).length() * SHRINK_MARGIN));
            }
        }
    }
    out
}

/// Shrink splats until no input ray crosses another sample's splat before its own hit (Sec. 2.3.1),
/// then refit the boxes. Returns how many splats shrank. One round suffices: shrinking only removes
/// crossings.
pub fn shrink(nodes: &mut [SplatNode], splats: &mut [Splat], rays: &[InputRay], t_min: f32) -> usize {
    let asks: Vec<(u32, f32)> = rays.par_iter().flat_map_iter(|r| blockers(nodes, splats, r, t_min)).collect();
    let mut radius: Vec<f32> = splats.iter().map(|s| s.radius).collect();
    for (k, r) in asks {
        let slot = &mut radius[k as usize];
        *slot = slot.min(r);
    }
    let mut shrunk = 0;
    for (s, r) in splats.iter_mut().zip(radius) {
        if r < s.radius {
            s.radius = r;
            shrunk += 1;
        }
    }
    refit(nodes, splats);
    shrunk
}

/// The splats, the tree and per-pixel statistics built from a pass's samples.
pub struct Built {
    pub splats: Vec<Splat>,
    pub nodes: Vec<SplatNode>,
    /// Splats that shrank.
    pub shrunk: usize,
}

/// Build everything the reconstruction reads from the stored samples (`layers` per pixel). A tree
/// deeper than the traversal stack ([`STACK_SIZE`]) is an error (the depth is returned).
pub fn build(samples: &[LightSample], knn: KnnSettings, shrink: bool, t_min: f32) -> Result<Built, usize> {
    let mut list: Vec<Splat> = samples
        .iter()
        .enumerate()
        .filter(|(_, s)| s.flags == SAMPLE_HIT && Vec3::from(s.hit).is_finite())
        .map(|(k, s)| Splat {
            centre: s.hit,
            radius: 0.0,
            normal: s.normal,
            kappa: s.kappa,
            direction: s.direction,
            sample: k as u32,
            radiance: s.radiance,
            flags: 1,
            velocity: s.velocity,
            time: s.time,
        })
        .collect();
    let radii = knn_radii(&list, knn);
    for (s, r) in list.iter_mut().zip(radii) {
        s.radius = r;
    }
    let mut nodes = tree(&mut list);
    let depth = self::depth(&nodes);
    if depth >= STACK_SIZE {
        return Err(depth);
    }
    let mut shrunk = 0;
    if shrink {
        let rays = input_rays(samples, &list);
        shrunk = self::shrink(&mut nodes, &mut list, &rays, t_min);
    }
    Ok(Built { splats: list, nodes, shrunk })
}

/// Every input ray of `samples` (Sec. 2.3.1: escaped ones to infinity, each at its own time), naming
/// its own splat among `splats` (in leaf order, as [`build`] stores them; `u32::MAX`: none).
pub fn input_rays(samples: &[LightSample], splats: &[Splat]) -> Vec<InputRay> {
    let mut position = vec![u32::MAX; samples.len()];
    for (k, s) in splats.iter().enumerate() {
        position[s.sample as usize] = k as u32;
    }
    samples
        .iter()
        .enumerate()
        .filter(|(_, s)| s.flags != SAMPLE_NONE)
        .map(|(k, s)| InputRay {
            origin: Vec3::from(s.origin),
            direction: Vec3::from(s.direction),
            distance: if s.flags == SAMPLE_HIT { s.distance } else { f32::INFINITY },
            own: position[k],
            time: s.time,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(c: Vec3, n: Vec3, w: Vec3, kappa: f32) -> Splat {
        Splat {
            centre: c.to_array(),
            radius: 0.0,
            normal: n.to_array(),
            kappa,
            direction: w.to_array(),
            sample: 0,
            radiance: [0.0; 3],
            flags: 1,
            ..Default::default()
        }
    }

    #[test]
    fn metric_stretches_the_normal_offset() {
        assert_eq!(metric_distance(Vec3::new(1.0, 0.0, 0.0), Vec3::Y, 3.0), 1.0);
        assert_eq!(metric_distance(Vec3::new(0.0, 1.0, 0.0), Vec3::Y, 3.0), 3.0);
        assert!(angular_match(0.0, Vec3::X, -Vec3::X));
        // κ = 10: A ≥ 1/2 ⇔ ω_i·ω_j ≥ 1 − ln2/10 ≈ 0.9307 (about 21.5°).
        let w = |deg: f32| Vec3::new(deg.to_radians().sin(), deg.to_radians().cos(), 0.0);
        assert!(angular_match(10.0, w(0.0), w(21.0)));
        assert!(!angular_match(10.0, w(0.0), w(22.0)));
    }

    #[test]
    fn knn_radius_is_the_kth_neighbour_brute_force() {
        // Points on a jittered grid on a bumpy floor, mixed normals and gloss: the tree search must
        // equal brute force.
        let mut v = Vec::new();
        let mut h = 1u32;
        let mut rnd = || {
            h = wedge_backends::rng::pcg_hash(h);
            wedge_backends::rng::to_unit(h)
        };
        for i in 0..30 {
            for j in 0..30 {
                let c = Vec3::new(i as f32 * 0.1 + 0.05 * rnd(), 0.02 * rnd(), j as f32 * 0.1 + 0.05 * rnd());
                let w = Vec3::new(rnd() - 0.5, -1.0, rnd() - 0.5).normalize();
                let kappa = if (i + j) % 3 == 0 { 12.0 } else { 0.0 };
                v.push(sample(c, Vec3::new(0.1 * rnd(), 1.0, 0.0).normalize(), w, kappa));
            }
        }
        let s = KnnSettings { k: 12, alpha: 3.0, glossy_cap: f32::INFINITY };
        let radii = knn_radii(&v, s);
        for i in (0..v.len()).step_by(7) {
            let p = &v[i];
            let mut d: Vec<f32> = (0..v.len())
                .filter(|&j| j != i && angular_match(p.kappa, Vec3::from(p.direction), Vec3::from(v[j].direction)))
                .map(|j| metric_distance(Vec3::from(v[j].centre) - Vec3::from(p.centre), Vec3::from(p.normal), 3.0))
                .collect();
            d.sort_by(f32::total_cmp);
            assert_eq!(radii[i], d[11], "sample {i}");
        }
        // Glossy samples reach farther than diffuse ones (Fig. 3).
        let mean = |g: bool| {
            let r: Vec<f32> = (0..v.len()).filter(|&i| (v[i].kappa > 0.0) == g).map(|i| radii[i]).collect();
            r.iter().sum::<f32>() / r.len() as f32
        };
        assert!(mean(true) > 1.5 * mean(false), "glossy {} diffuse {}", mean(true), mean(false));
    }

    #[test]
    fn shrinking_leaves_no_input_ray_blocked() {
        // A thin wall in front of a floor: the wall's sparse samples get large splats that cross
        // rays to the floor; after shrinking no ray crosses another's splat before its own hit.
        let mut v = Vec::new();
        let mut rays = Vec::new();
        let eye = Vec3::new(0.0, 2.0, -3.0);
        for i in 0..20 {
            for j in 0..20 {
                let target = Vec3::new(i as f32 * 0.1 - 1.0, 0.0, j as f32 * 0.1);
                // The wall: z = 0.5, x in [-0.1, 0.1], y below 1.2.
                let dir = (target - eye).normalize();
                let tw = (0.5 - eye.z) / dir.z;
                let pw = eye + dir * tw;
                let (h, n) = if pw.x.abs() < 0.1 && pw.y < 1.2 { (pw, -Vec3::Z) } else { (target, Vec3::Y) };
                rays.push(InputRay {
                    origin: eye,
                    direction: dir,
                    distance: (h - eye).length(),
                    own: v.len() as u32,
                    time: 0.0,
                });
                v.push(sample(h, n, dir, 0.0));
            }
        }
        let radii = knn_radii(&v, KnnSettings { k: 12, alpha: 3.0, glossy_cap: f32::INFINITY });
        for (s, r) in v.iter_mut().zip(&radii) {
            s.radius = *r;
        }
        // Rays name their splat by input index; the tree reorders splats, so map them.
        let mut tagged = v.clone();
        for (k, s) in tagged.iter_mut().enumerate() {
            s.sample = k as u32;
        }
        let mut nodes = tree(&mut tagged);
        let position: Vec<u32> = {
            let mut p = vec![0; tagged.len()];
            for (k, s) in tagged.iter().enumerate() {
                p[s.sample as usize] = k as u32;
            }
            p
        };
        for r in &mut rays {
            r.own = position[r.own as usize];
        }
        let before: usize = rays.iter().map(|r| blockers(&nodes, &tagged, r, 1e-4).len()).sum();
        assert!(before > 0, "the test must start with crossings");
        let shrunk = shrink(&mut nodes, &mut tagged, &rays, 1e-4);
        assert!(shrunk > 0);
        let after: usize = rays.iter().map(|r| blockers(&nodes, &tagged, r, 1e-4).len()).sum();
        assert_eq!(after, 0, "{before} crossings before, {after} after");
    }
}
