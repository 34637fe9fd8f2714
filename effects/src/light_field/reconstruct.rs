//! RECONSTRUCT(p, ω) of seed 001 (Lehtinen et al. 2012, `seeds/001_2d3ed232e6777e89.txt`,
//! Secs. 2.3.2–2.5): the incident radiance along one reconstruction ray, from the splats the ray
//! crosses. Pure functions over the splat tree the host pass builds ([`super::splats`]); WGSL
//! mirror `shaders/light_field_reconstruct.wgsl`, which visits the same nodes in the same order.
//!
//! 1. **Collect** (Sec. 2.3.2): walk the splat BVH and keep the [`MAX_HITS`] nearest splats the ray
//!    crosses (ordered by distance at [`order_key`]'s resolution, then by splat index — one total
//!    order, whatever the visiting order and the last bits of each distance).
//! 2. **Group** into apparent surfaces: greedily, nearest first, a splat joins the open surface unless
//!    it is in visibility conflict with one of its members ([`conflict`]); the first conflict closes
//!    the surface. The nearest surface is the one the ray sees.
//! 3. **Undersampled surfaces** (Sec. 2.5): a surface of one or two splats is re-tested with its
//!    splats' radii scaled by 1/2 and 2/3 (docs/EQUATIONS.md reading); if the ray misses them all, the
//!    next surface is the nearest.
//! 4. **Filter** (Sec. 2.4): front-facing splats only, unless all of the surface's splats face away
//!    (two-sided surfaces, Sec. 2.5) — or, with `two_sided` off, such a surface is passed through
//!    (no input ray saw its side the ray comes from: the leak over convex edges, DESIGN-NOTES
//!    "Light-field reconstruction"), and the next surface is the nearest; a diffuse surface (every `κ = 0`) averages its splats'
//!    radiance with a spatial tent at the ray's crossing; otherwise the splat whose tent × vMF
//!    filter (eq. 2) is largest gives its radiance (an anisotropic nearest neighbour).
//!
//! Ambient occlusion (Sec. 3.3): the filter is bypassed; the ray is occluded where the nearest
//! surface lies within `max_distance` (0 = any distance).

use glam::Vec3;

use super::{Splat, SplatNode};

/// Splats one reconstruction ray keeps (nearest first). With `k = 12` about a dozen splats cover a
/// point of a diffuse surface; glossy splats are wider. A ray through more keeps the nearest: the
/// nearest surface is what it needs.
pub const MAX_HITS: usize = 32;
/// Entries of the traversal stack; the host pass refuses a deeper tree (a BVH2 over a 720p image's
/// 8 spp is ~30 levels deep), so no traversal ever overflows it.
pub const STACK_SIZE: usize = 64;
/// Tolerance of the half-space test, as a fraction of the event line's length: samples on one
/// plane (up to ~0.6° of noise in their normals) never conflict.
pub const HALF_SPACE_TOLERANCE: f32 = 0.01;
/// `|ω·n|` below which a ray is taken as parallel to a splat.
const PARALLEL: f32 = 1e-6;

/// A splat crossed by a ray: its distance along the ray and its index.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RayHit {
    pub t: f32,
    pub splat: u32,
}

/// Mantissa bits a hit's distance drops for ordering: crossings within ~5·10⁻⁴ of each other
/// (a flat surface's overlapping splats, crossed at one point up to round-off) order by splat index,
/// so which of them a full list keeps does not hang on the last bits of `t` — which differ between
/// the CPU and a GPU that fuses multiply-adds.
pub const ORDER_DROP_BITS: u32 = 11;

/// The ordering key of a distance `t > 0` (a positive float's bits order as its value).
#[inline]
pub fn order_key(t: f32) -> u32 {
    t.to_bits() >> ORDER_DROP_BITS
}

/// The largest distance with the same [`order_key`].
#[inline]
pub fn key_end(t: f32) -> f32 {
    f32::from_bits(t.to_bits() | ((1 << ORDER_DROP_BITS) - 1))
}

impl RayHit {
    /// The total order of hits: by [`order_key`], then splat index.
    #[inline]
    fn before(&self, other: &RayHit) -> bool {
        let (a, b) = (order_key(self.t), order_key(other.t));
        a < b || (a == b && self.splat < other.splat)
    }
}

/// The ray parameter where `o + t·d` crosses the disk of `s` at shutter time `time` with its radius
/// scaled by `scale`, if it does with `t_min < t < t_max`.
#[inline]
pub fn disk_hit(s: &Splat, o: Vec3, d: Vec3, t_min: f32, t_max: f32, scale: f32, time: f32) -> Option<f32> {
    let n = Vec3::from(s.normal);
    let denom = d.dot(n);
    if denom.abs() < PARALLEL {
        return None;
    }
    let c = s.centre_at(time);
    let t = (c - o).dot(n) / denom;
    if !(t > t_min && t < t_max) {
        return None;
    }
    let r = s.radius * scale;
    ((o + d * t - c).length_squared() <= r * r).then_some(t)
}

/// The slab test of a node's box: whether the ray enters it before `t_max` (and after `t_min`).
#[inline]
pub(crate) fn box_entered(n: &SplatNode, o: Vec3, inv_d: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
    let t0 = (Vec3::from(n.min) - o) * inv_d;
    let t1 = (Vec3::from(n.max) - o) * inv_d;
    let near = t0.min(t1).max_element().max(t_min);
    let far = t0.max(t1).min_element().min(t_max);
    (near <= far).then_some(near)
}

/// Step 1: the [`MAX_HITS`] nearest splats `o + t·d` crosses at shutter time `time` with
/// `t_min < t < t_max`, sorted (the nodes bound the splats over the whole shutter).
/// Depth-first, left child first; a subtree is skipped once the list is full and the box starts
/// beyond its farthest entry (never one that could hold a nearer splat).
/// The tree's depth is at most [`STACK_SIZE`] (checked where it is built).
pub fn collect(
    nodes: &[SplatNode],
    splats: &[Splat],
    o: Vec3,
    d: Vec3,
    t_min: f32,
    t_max: f32,
    time: f32,
) -> Vec<RayHit> {
    let mut hits = Vec::with_capacity(MAX_HITS);
    if nodes.is_empty() {
        return hits;
    }
    let inv_d = d.recip();
    let mut stack = [0u32; STACK_SIZE];
    let mut sp = 1usize;
    while sp > 0 {
        sp -= 1;
        let node = &nodes[stack[sp] as usize];
        let limit = if hits.len() == MAX_HITS { key_end(hits[MAX_HITS - 1].t) } else { t_max };
        if box_entered(node, o, inv_d, t_min, limit).is_none() {
            continue;
        }
        if node.count == 0 {
            stack[sp] = node.index + 1;
            stack[sp + 1] = node.index;
            sp += 2;
            continue;
        }
        for k in node.index..node.index + node.count {
            let Some(t) = disk_hit(&splats[k as usize], o, d, t_min, t_max, 1.0, time) else {
                continue;
            };
            insert(&mut hits, RayHit { t, splat: k });
        }
    }
    hits
}

/// Insert into the sorted list, keeping at most [`MAX_HITS`].
#[inline]
fn insert(hits: &mut Vec<RayHit>, h: RayHit) {
    if hits.len() == MAX_HITS && !h.before(&hits[MAX_HITS - 1]) {
        return;
    }
    let at = hits.iter().position(|x| h.before(x)).unwrap_or(hits.len());
    if hits.len() == MAX_HITS {
        hits.pop();
    }
    hits.insert(at, h);
}

/// The visibility-conflict test of Sec. 2.3.2 (Fig. 5) for a ray from `o` along `d`: the event line
/// through the two hit points meets the ray's `st` plane (through `o`, normal `d`) at `x`; the
/// samples conflict where `x` lies in the positive half-space of both, `(x − h)·n > 0` (beyond
/// [`HALF_SPACE_TOLERANCE`] of the line's length, so one plane's samples never conflict).
#[inline]
pub fn conflict(o: Vec3, d: Vec3, hi: Vec3, ni: Vec3, hj: Vec3, nj: Vec3) -> bool {
    let e = hj - hi;
    let along = e.dot(d);
    if along.abs() < PARALLEL * e.length() {
        // The event line is parallel to the st plane: it never crosses it.
        return false;
    }
    // x = hi + u·e; (x − hi)·ni = u (e·ni), (x − hj)·nj = (u − 1)(e·nj).
    let u = (o - hi).dot(d) / along;
    let tol = HALF_SPACE_TOLERANCE * e.length();
    let side_i = if u >= 0.0 { e.dot(ni) } else { -e.dot(ni) };
    let side_j = if u >= 1.0 { e.dot(nj) } else { -e.dot(nj) };
    side_i > tol && side_j > tol
}

/// The von Mises–Fisher angular filter of eq. 2, `A_i(ω) = exp(κ_i (ω_i·ω) − κ_i)`.
#[inline]
pub fn angular_filter(kappa: f32, wi: Vec3, w: Vec3) -> f32 {
    (kappa * (wi.dot(w) - 1.0)).exp()
}

/// The spatial tent of a splat at the ray's crossing `q` at time `time`: `1 − |q − c|/r` (Sec. 2.4).
#[inline]
pub fn tent(s: &Splat, q: Vec3, time: f32) -> f32 {
    if s.radius > 0.0 {
        (1.0 - (q - s.centre_at(time)).length() / s.radius).max(0.0)
    } else {
        0.0
    }
}

/// What a reconstruction ray sees.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Seen {
    /// Incident radiance along the ray (0 where it sees no surface).
    pub radiance: Vec3,
    /// Distance to the nearest apparent surface; `None` = no surface.
    pub distance: Option<f32>,
    /// Splats in the nearest surface (after the undersampling test).
    pub splats: u32,
}

/// Whether a ray along `d` meets splat `s` from its front (the side its input ray came from).
#[inline]
fn front(s: &Splat, d: Vec3) -> bool {
    d.dot(Vec3::from(s.normal)) < 0.0
}

/// Steps 2–4 on the sorted hits of one ray at shutter time `time`; `two_sided`: a surface seen only
/// from behind gives its splats' radiance (the paper's Sec. 2.5), else it is passed through.
#[allow(clippy::too_many_arguments)]
pub fn resolve(
    splats: &[Splat],
    hits: &[RayHit],
    o: Vec3,
    d: Vec3,
    t_min: f32,
    t_max: f32,
    time: f32,
    two_sided: bool,
) -> Seen {
    let mut start = 0usize;
    while start < hits.len() {
        // Step 2: the open surface grows until a conflict.
        let mut end = start + 1;
        'grow: while end < hits.len() {
            let s = &splats[hits[end].splat as usize];
            for m in &hits[start..end] {
                let q = &splats[m.splat as usize];
                if conflict(o, d, q.centre_at(time), Vec3::from(q.normal), s.centre_at(time), Vec3::from(s.normal)) {
                    break 'grow;
                }
            }
            end += 1;
        }
        let members = &hits[start..end];
        // Step 3: one or two splats: re-test at 1/2 or 2/3 of their radii.
        let scale = match members.len() {
            1 => 0.5,
            2 => 2.0 / 3.0,
            _ => 1.0,
        };
        let kept = |h: &&RayHit| {
            scale == 1.0 || disk_hit(&splats[h.splat as usize], o, d, t_min, t_max, scale, time).is_some()
        };
        let surface: Vec<RayHit> = members.iter().filter(kept).copied().collect();
        if surface.is_empty() || (!two_sided && !surface.iter().any(|h| front(&splats[h.splat as usize], d))) {
            start = end;
            continue;
        }
        return Seen {
            radiance: filter(splats, &surface, o, d, time),
            distance: Some(surface[0].t),
            splats: surface.len() as u32,
        };
    }
    Seen::default()
}

/// Step 4 on the nearest surface's splats (non-empty) at time `time`.
pub fn filter(splats: &[Splat], surface: &[RayHit], o: Vec3, d: Vec3, time: f32) -> Vec3 {
    let faces_ray = |h: &RayHit| front(&splats[h.splat as usize], d);
    let any_front = surface.iter().any(faces_ray);
    let glossy = surface.iter().any(|h| splats[h.splat as usize].kappa > 0.0);
    let (mut sum, mut sum_w) = (Vec3::ZERO, 0.0f32);
    let (mut best, mut best_w) = (Vec3::ZERO, -1.0f32);
    let mut mean = (Vec3::ZERO, 0u32);
    for h in surface.iter().filter(|h| !any_front || faces_ray(h)) {
        let s = &splats[h.splat as usize];
        let l = Vec3::from(s.radiance);
        let w = tent(s, o + d * h.t, time);
        mean = (mean.0 + l, mean.1 + 1);
        if glossy {
            let wg = w * angular_filter(s.kappa, Vec3::from(s.direction), d);
            if wg > best_w {
                (best, best_w) = (l, wg);
            }
        } else {
            sum += l * w;
            sum_w += w;
        }
    }
    if glossy {
        best
    } else if sum_w > 0.0 {
        sum / sum_w
    } else {
        // Every crossing exactly on a rim (tent 0): the plain mean.
        mean.0 / mean.1.max(1) as f32
    }
}

/// RECONSTRUCT(p, ω) at shutter time `time` (the splats where they are then): collect, then
/// resolve ([`resolve`]'s `two_sided`).
pub fn reconstruct(
    nodes: &[SplatNode],
    splats: &[Splat],
    o: Vec3,
    d: Vec3,
    t_min: f32,
    time: f32,
    two_sided: bool,
) -> Seen {
    let hits = collect(nodes, splats, o, d, t_min, f32::INFINITY, time);
    resolve(splats, &hits, o, d, t_min, f32::INFINITY, time, two_sided)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn splat(c: Vec3, n: Vec3, r: f32, l: f32) -> Splat {
        Splat {
            centre: c.to_array(),
            radius: r,
            normal: n.to_array(),
            kappa: 0.0,
            direction: (-n).to_array(),
            sample: 0,
            radiance: [l; 3],
            flags: 1,
            ..Default::default()
        }
    }

    #[test]
    fn disks_are_hit_inside_their_radius() {
        let s = splat(Vec3::ZERO, Vec3::Y, 1.0, 1.0);
        assert_eq!(disk_hit(&s, Vec3::new(0.5, 2.0, 0.0), -Vec3::Y, 0.0, 10.0, 1.0, 0.0), Some(2.0));
        assert_eq!(disk_hit(&s, Vec3::new(1.5, 2.0, 0.0), -Vec3::Y, 0.0, 10.0, 1.0, 0.0), None);
        assert_eq!(disk_hit(&s, Vec3::new(0.6, 2.0, 0.0), -Vec3::Y, 0.0, 10.0, 0.5, 0.0), None);
        // Two-sided, and only within (t_min, t_max).
        assert_eq!(disk_hit(&s, Vec3::new(0.0, -2.0, 0.0), Vec3::Y, 0.0, 10.0, 1.0, 0.0), Some(2.0));
        assert_eq!(disk_hit(&s, Vec3::new(0.0, 2.0, 0.0), -Vec3::Y, 0.0, 1.5, 1.0, 0.0), None);
        // Parallel rays never hit.
        assert_eq!(disk_hit(&s, Vec3::new(-2.0, 0.0, 0.0), Vec3::X, 0.0, 10.0, 1.0, 0.0), None);
    }

    #[test]
    fn samples_on_one_plane_never_conflict_stacked_ones_do() {
        let o = Vec3::new(0.0, 3.0, 0.0);
        let d = Vec3::new(0.1, -1.0, 0.05).normalize();
        // Floor samples: the event line lies in the floor, x on the floor: not in either half-space.
        assert!(!conflict(o, d, Vec3::new(0.0, 0.0, 0.0), Vec3::Y, Vec3::new(0.3, 0.0, 0.1), Vec3::Y));
        // A table top above the floor, both facing up: x above both → conflict (Fig. 5, right).
        assert!(conflict(o, d, Vec3::new(0.0, 1.0, 0.0), Vec3::Y, Vec3::new(0.1, 0.0, 0.0), Vec3::Y));
        assert!(conflict(o, d, Vec3::new(0.1, 0.0, 0.0), Vec3::Y, Vec3::new(0.0, 1.0, 0.0), Vec3::Y));
        // A concave corner (floor and wall): x behind the wall → no conflict (Fig. 5, left).
        let o = Vec3::new(1.0, 1.0, 0.0);
        let d = Vec3::new(-1.0, -1.0, 0.0).normalize();
        assert!(!conflict(o, d, Vec3::new(0.2, 0.0, 0.0), Vec3::Y, Vec3::new(0.0, 0.2, 0.0), Vec3::X));
    }

    #[test]
    fn a_plane_of_constant_radiance_reconstructs_exactly() {
        // A grid of diffuse splats of radiance 0.7 on the floor; any ray that sees it returns 0.7.
        let mut splats = Vec::new();
        for i in 0..10 {
            for j in 0..10 {
                splats.push(splat(Vec3::new(i as f32 * 0.1, 0.0, j as f32 * 0.1), Vec3::Y, 0.25, 0.7));
            }
        }
        let nodes = super::super::splats::tree(&mut splats);
        for (k, d) in
            [Vec3::new(0.1, -1.0, 0.2), Vec3::new(-0.3, -1.0, 0.0), Vec3::new(0.0, -1.0, 0.0)].into_iter().enumerate()
        {
            let seen = reconstruct(&nodes, &splats, Vec3::new(0.45, 1.0, 0.45), d.normalize(), 1e-4, 0.0, true);
            assert!(seen.splats >= 3, "ray {k}: {seen:?}");
            assert!((seen.radiance - Vec3::splat(0.7)).abs().max_element() < 1e-6, "ray {k}: {seen:?}");
        }
    }

    #[test]
    fn the_nearest_surface_hides_the_one_behind_it() {
        // Two parallel planes, the near one bright, the far one dark: the far one never leaks in.
        let mut splats = Vec::new();
        for i in 0..6 {
            for j in 0..6 {
                let (x, z) = (i as f32 * 0.1, j as f32 * 0.1);
                splats.push(splat(Vec3::new(x, 0.5, z), Vec3::Y, 0.2, 1.0));
                splats.push(splat(Vec3::new(x + 0.05, 0.0, z + 0.05), Vec3::Y, 0.2, 0.0));
            }
        }
        let nodes = super::super::splats::tree(&mut splats);
        let seen = reconstruct(&nodes, &splats, Vec3::new(0.25, 2.0, 0.25), -Vec3::Y, 1e-4, 0.0, true);
        assert_eq!(seen.radiance, Vec3::ONE);
        assert!((seen.distance.unwrap() - 1.5).abs() < 1e-5);
    }

    #[test]
    fn glossy_surfaces_take_one_samples_value() {
        // Splats with κ > 0: the result is exactly one splat's radiance, the one whose direction
        // matches the ray best at equal tent weight.
        let mut splats = Vec::new();
        for (k, dir) in
            [Vec3::new(0.0, -1.0, 0.0), Vec3::new(0.6, -0.8, 0.0), Vec3::new(-0.6, -0.8, 0.0)].into_iter().enumerate()
        {
            let mut s = splat(Vec3::new(0.0, 0.0, 0.0), Vec3::Y, 1.0, k as f32 + 1.0);
            s.kappa = 8.0;
            s.direction = dir.to_array();
            splats.push(s);
        }
        let nodes = super::super::splats::tree(&mut splats);
        let d = Vec3::new(0.55, -0.8, 0.0).normalize();
        let seen = reconstruct(&nodes, &splats, Vec3::ZERO - d * 2.0, d, 1e-4, 0.0, true);
        assert_eq!(seen.radiance, Vec3::splat(2.0));
    }

    #[test]
    fn a_lone_splat_is_tested_at_half_its_radius() {
        let mut splats = vec![splat(Vec3::ZERO, Vec3::Y, 1.0, 1.0)];
        let nodes = super::super::splats::tree(&mut splats);
        let near_rim = reconstruct(&nodes, &splats, Vec3::new(0.7, 1.0, 0.0), -Vec3::Y, 1e-4, 0.0, true);
        assert_eq!(near_rim.distance, None);
        let centre = reconstruct(&nodes, &splats, Vec3::new(0.3, 1.0, 0.0), -Vec3::Y, 1e-4, 0.0, true);
        assert_eq!(centre.distance, Some(1.0));
    }

    #[test]
    fn a_moving_plane_is_where_it_is_at_the_rays_time() {
        // A strip of constant radiance x ∈ [0, 1] at the shutter's centre, moving +x by 0.5 per unit
        // time, sampled at times spread over the shutter (each splat stored where its sample saw it).
        // A ray at x = 1.3 sees it at t = 1 (strip at [0.5, 1.5]) and not at t = −1 ([−0.5, 0.5]);
        // at any time where it sees it, the value is exact.
        let v = Vec3::new(0.5, 0.0, 0.0);
        let mut splats = Vec::new();
        for i in 0..=20 {
            for j in 0..6 {
                let t = -1.0 + 2.0 * ((i * 6 + j) % 9) as f32 / 8.0;
                let rest = Vec3::new(i as f32 * 0.05, 0.0, j as f32 * 0.1);
                let mut s = splat(rest + v * t, Vec3::Y, 0.15, 0.7);
                (s.velocity, s.time) = (v.to_array(), t);
                splats.push(s);
            }
        }
        let nodes = super::super::splats::tree(&mut splats);
        let at = |x: f32, time: f32| reconstruct(&nodes, &splats, Vec3::new(x, 1.0, 0.25), -Vec3::Y, 1e-4, time, true);
        let late = at(1.3, 1.0);
        assert_eq!(late.distance, Some(1.0), "{late:?}");
        assert!((late.radiance - Vec3::splat(0.7)).abs().max_element() < 1e-6, "{late:?}");
        assert_eq!(at(1.3, -1.0).distance, None);
        assert_eq!(at(-0.3, -1.0).distance, Some(1.0));
        assert_eq!(at(-0.3, 1.0).distance, None);
        // The tree's boxes bound every splat over the whole shutter.
        for s in &splats {
            for t in [-1.0, -0.3, 0.0, 0.8, 1.0] {
                let c = s.centre_at(t);
                assert!(Vec3::from(nodes[0].min).cmple(c).all() && c.cmple(Vec3::from(nodes[0].max)).all());
            }
        }
    }

    #[test]
    fn a_surface_seen_only_from_behind_is_two_sided_or_passed() {
        // A floor sampled from above (normals +y). From above both rules see it; from below, two-sided
        // it gives its radiance, passed the ray sees nothing.
        let mut splats = Vec::new();
        for i in 0..6 {
            for j in 0..6 {
                splats.push(splat(Vec3::new(i as f32 * 0.1, 0.0, j as f32 * 0.1), Vec3::Y, 0.2, 1.0));
            }
        }
        let nodes = super::super::splats::tree(&mut splats);
        let (above, below) = (Vec3::new(0.25, 1.0, 0.25), Vec3::new(0.25, -1.0, 0.25));
        for two_sided in [true, false] {
            let seen = reconstruct(&nodes, &splats, above, -Vec3::Y, 1e-4, 0.0, two_sided);
            assert_eq!((seen.radiance, seen.distance), (Vec3::ONE, Some(1.0)));
        }
        let two_sided = reconstruct(&nodes, &splats, below, Vec3::Y, 1e-4, 0.0, true);
        assert_eq!((two_sided.radiance, two_sided.distance), (Vec3::ONE, Some(1.0)));
        assert_eq!(reconstruct(&nodes, &splats, below, Vec3::Y, 1e-4, 0.0, false), Seen::default());
    }
}
