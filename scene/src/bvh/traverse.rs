//! CPU traversal of the 4-wide BVH: one ray at a time, the four child boxes of a node in one SIMD slab
//! test (glam `Vec4`: SSE on x86-64, NEON on aarch64, scalar elsewhere), hit children visited nearest
//! first (closest hit) from a fixed stack, leaves tested four triangles at a time
//! ([`TrianglePack::intersect`], the shared watertight test of [`super::triangle`] in lanes).
//! `shaders/bvh.wgsl` is the GPU mirror.
//!
//! The slab test picks each axis's near and far plane by the sign of the ray direction (Williams et
//! al. 2005), so it needs no per-axis min/max; the exit distance is widened by a few ulps (PBRT's
//! 1 + 2γ₃) so rounding never culls a triangle the triangle test would hit (thin boxes: a flat ground
//! has zero height). A NaN distance (origin on a slab plane of a ray parallel to it: 0 · ∞) must not
//! cull either: the reductions put the running value second, and SSE `maxps`/`minps` return their
//! second operand when either is NaN, as glam's scalar fallback does; NEON's `fmax`/`fmin` would
//! propagate the NaN, so there (and only there) NaN lanes are cleared first.

use std::mem::MaybeUninit;

use glam::{Vec3, Vec3A, Vec4};

use super::triangle::{closer, PackRay, TrianglePack};
use super::{Bvh, Hit, WideNode, LEAF_BIT, LEAF_FIRST_BITS, STACK_SIZE};

/// 1 + 2γ₃ rounded up (0x3f800003): the exit-distance widening of the slab test.
pub const WIDEN: f32 = 1.000_000_4;

/// A ray prepared for slab tests: origin and reciprocal direction splatted across the four lanes,
/// and per axis which `bounds` row holds the near plane (`2·axis` for a non-negative direction sign,
/// else `2·axis + 1`).
struct WideRay {
    o: [Vec4; 3],
    inv_d: [Vec4; 3],
    near: [usize; 3],
}

impl WideRay {
    fn new(o: Vec3A, d: Vec3A) -> Self {
        let inv = d.recip();
        let row = |axis: usize| 2 * axis + inv[axis].is_sign_negative() as usize;
        WideRay {
            o: [Vec4::splat(o.x), Vec4::splat(o.y), Vec4::splat(o.z)],
            inv_d: [Vec4::splat(inv.x), Vec4::splat(inv.y), Vec4::splat(inv.z)],
            near: [row(0), row(1), row(2)],
        }
    }

    /// Entry distances of the four children and the mask (bit i: child i overlaps `(tmin, tmax)`).
    #[inline(always)]
    fn slab(&self, n: &WideNode, tmin: Vec4, tmax: Vec4) -> (Vec4, u32) {
        let mut t_enter = tmin;
        let mut t_exit = tmax;
        for axis in 0..3 {
            let near = (Vec4::from(n.bounds[self.near[axis]]) - self.o[axis]) * self.inv_d[axis];
            let far = (Vec4::from(n.bounds[self.near[axis] ^ 1]) - self.o[axis]) * self.inv_d[axis];
            let (near, far) = nan_free(near, far);
            t_enter = near.max(t_enter);
            t_exit = far.min(t_exit);
        }
        (t_enter, t_enter.cmple(t_exit * WIDEN).bitmask())
    }
}

/// NaN lanes become "no constraint" where `max`/`min` would not already ignore them (see the module doc).
#[inline(always)]
fn nan_free(near: Vec4, far: Vec4) -> (Vec4, Vec4) {
    if cfg!(any(target_arch = "x86", target_arch = "x86_64")) {
        (near, far)
    } else {
        let n = near.is_nan_mask();
        let f = far.is_nan_mask();
        (
            Vec4::select(n, Vec4::NEG_INFINITY, near),
            Vec4::select(f, Vec4::INFINITY, far),
        )
    }
}

/// Closest hit (smallest `t`, ties to the lower triangle index: [`super::closer`]) with
/// `tmin < t < tmax`, or with `any_hit` the first hit found (shadow rays only ask whether there is one).
pub fn traverse(bvh: &Bvh, o: Vec3, d: Vec3, tmin: f32, tmax: f32, any_hit: bool) -> Option<Hit> {
    traverse_with(bvh, Start::root(tmax), o, d, tmin, any_hit, &mut ())
}

/// [`traverse`]'s closest hit, the query fixed at compile time (what `Scene`/`SceneAt` call).
pub fn closest(bvh: &Bvh, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
    traverse_impl::<false, ()>(
        &bvh.nodes,
        &bvh.packs,
        Start::root(tmax),
        o,
        d,
        tmin,
        &mut (),
    )
}

/// [`traverse`]'s any-hit query: whether anything is hit with `tmin < t < tmax`.
pub fn occluded(bvh: &Bvh, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> bool {
    traverse_impl::<true, ()>(
        &bvh.nodes,
        &bvh.packs,
        Start::root(tmax),
        o,
        d,
        tmin,
        &mut (),
    )
    .is_some()
}

/// [`traverse`] of the tree whose root is node `root` (scenes store one tree per moving instance in
/// the same arrays, `Scene::instances`), for a query that already holds a best hit `best` from
/// another tree: only a hit [`closer`] than it is returned (`None` otherwise), so traversing the
/// trees one after another gives the same answer as one tree over all their triangles.
#[allow(clippy::too_many_arguments)]
pub fn traverse_from(
    bvh: &Bvh,
    root: u32,
    o: Vec3,
    d: Vec3,
    tmin: f32,
    tmax: f32,
    any_hit: bool,
    best: Option<&Hit>,
) -> Option<Hit> {
    let start = Start {
        root,
        t_best: best.map_or(tmax, |h| h.t),
        best_triangle: best.map_or(0, |h| h.triangle),
    };
    traverse_with(bvh, start, o, d, tmin, any_hit, &mut ())
}

/// Where a traversal starts: its root node, and the best hit so far (`t_best` = the ray's `tmax`
/// and triangle 0 when there is none; see [`closer`]).
#[derive(Clone, Copy)]
struct Start {
    root: u32,
    t_best: f32,
    best_triangle: u32,
}

impl Start {
    /// Node 0 with nothing hit yet.
    #[inline(always)]
    fn root(tmax: f32) -> Start {
        Start {
            root: 0,
            t_best: tmax,
            best_triangle: 0,
        }
    }
}

/// Work a traversal did: wide nodes whose four boxes were tested, and triangle packs tested.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TraversalStats {
    pub nodes: u64,
    pub packs: u64,
}

/// [`traverse`], adding its work to `stats` (a separate monomorphisation: [`traverse`] counts nothing).
pub fn traverse_counted(
    bvh: &Bvh,
    o: Vec3,
    d: Vec3,
    tmin: f32,
    tmax: f32,
    any_hit: bool,
    stats: &mut TraversalStats,
) -> Option<Hit> {
    traverse_with(bvh, Start::root(tmax), o, d, tmin, any_hit, stats)
}

/// The query `(tmin, start.t_best)` from `start.root`.
#[inline(always)]
fn traverse_with<C: Counter>(
    bvh: &Bvh,
    start: Start,
    o: Vec3,
    d: Vec3,
    tmin: f32,
    any_hit: bool,
    counter: &mut C,
) -> Option<Hit> {
    if any_hit {
        traverse_impl::<true, C>(&bvh.nodes, &bvh.packs, start, o, d, tmin, counter)
    } else {
        traverse_impl::<false, C>(&bvh.nodes, &bvh.packs, start, o, d, tmin, counter)
    }
}

/// What [`traverse_impl`] reports its work to; `()` ignores it.
trait Counter {
    fn node(&mut self);
    fn pack(&mut self);
}

impl Counter for () {
    #[inline(always)]
    fn node(&mut self) {}
    #[inline(always)]
    fn pack(&mut self) {}
}

impl Counter for TraversalStats {
    fn node(&mut self) {
        self.nodes += 1;
    }
    fn pack(&mut self) {
        self.packs += 1;
    }
}

/// The traversal loop, monomorphised for any-hit / closest-hit.
///
/// The stack holds child references with their entry distance. Closest hit drops a popped entry that
/// starts beyond the (widened) best distance without touching it; any-hit never shrinks its interval
/// before it returns, so it skips that and the sort.
#[inline(always)]
fn traverse_impl<const ANY_HIT: bool, C: Counter>(
    nodes: &[WideNode],
    packs: &[TrianglePack],
    start: Start,
    o: Vec3,
    d: Vec3,
    tmin: f32,
    counter: &mut C,
) -> Option<Hit> {
    if (start.root as usize) >= nodes.len() || !(o.is_finite() && d.is_finite()) {
        return None;
    }
    let (o, d) = (Vec3A::from(o), Vec3A::from(d));
    let ray = WideRay::new(o, d);
    let pack_ray = PackRay::new(o, d);
    let tmin_v = Vec4::splat(tmin);
    let mut t_best = start.t_best;
    let mut best = Hit {
        t: t_best,
        triangle: start.best_triangle,
        b1: 0.0,
        b2: 0.0,
    };
    let mut found = false;
    // Not zeroed: clearing 512 bytes was 9% of a primary ray's instructions (callgrind, `spheres`).
    // Entries below `sp` are always written by a push before a pop reads them.
    let mut stack = [MaybeUninit::<u32>::uninit(); STACK_SIZE];
    let mut stack_t = [MaybeUninit::<f32>::uninit(); STACK_SIZE];
    let mut sp = 0usize;
    let mut current = start.root; // a node reference
    loop {
        if current & LEAF_BIT == 0 {
            let n = &nodes[current as usize];
            counter.node();
            let (t_enter, mut mask) = ray.slab(n, tmin_v, Vec4::splat(t_best));
            if mask != 0 {
                let t = t_enter.to_array();
                let first = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                if mask == 0 {
                    current = n.child[first];
                    continue;
                }
                // Two to four children: continue with the nearest, push the rest farthest first so
                // they pop in near-to-far order.
                let mut order = [first, 0, 0, 0];
                let mut k = 1;
                while mask != 0 {
                    order[k] = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    k += 1;
                }
                if !ANY_HIT {
                    for i in 1..k {
                        let mut j = i;
                        while j > 0 && t[order[j]] < t[order[j - 1]] {
                            order.swap(j, j - 1);
                            j -= 1;
                        }
                    }
                }
                for &c in order[1..k].iter().rev() {
                    stack[sp] = MaybeUninit::new(n.child[c]);
                    stack_t[sp] = MaybeUninit::new(t[c]);
                    sp += 1;
                }
                current = n.child[order[0]];
                continue;
            }
        } else {
            let first = current & ((1 << LEAF_FIRST_BITS) - 1);
            let count = ((current >> LEAF_FIRST_BITS) & 7) + 1;
            for pack in &packs[first as usize..(first + count) as usize] {
                counter.pack();
                let (t, b1, b2, mut mask) = pack.intersect(&pack_ray, tmin, t_best);
                if ANY_HIT {
                    // Any hit strictly inside the ray's interval answers the query.
                    mask &= t.cmplt(Vec4::splat(t_best)).bitmask();
                    if mask == 0 {
                        continue;
                    }
                    let lane = mask.trailing_zeros() as usize;
                    let triangle = pack.index[lane];
                    return Some(Hit {
                        t: t[lane],
                        triangle,
                        b1: b1[lane],
                        b2: b2[lane],
                    });
                }
                while mask != 0 {
                    let lane = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    if closer(t[lane], pack.index[lane], t_best, best.triangle) {
                        t_best = t[lane];
                        best = Hit {
                            t: t_best,
                            triangle: pack.index[lane],
                            b1: b1[lane],
                            b2: b2[lane],
                        };
                        found = true;
                    }
                }
            }
        }
        // Pop, dropping entries a closer hit has since made unreachable (closest hit only).
        loop {
            if sp == 0 {
                return found.then_some(best);
            }
            sp -= 1;
            // SAFETY: `sp` < the number of pushes not yet popped, so this entry was written.
            if ANY_HIT || unsafe { stack_t[sp].assume_init() } <= t_best * WIDEN {
                break;
            }
        }
        // SAFETY: as above.
        current = unsafe { stack[sp].assume_init() };
    }
}

/// Walk a tree whose leaves name items rather than triangle packs (a top-level tree from
/// [`super::build::build_boxes`]: leaf `first..first + count` are item indices) from node `root`:
/// `visit(item)` is called for every leaf whose box the ray enters with `tmin < t` and `t` up to the
/// limit (the slab test of [`traverse`], exit widened), nearest box first. `visit` returns the limit
/// from then on (the best hit distance so far, which culls boxes beyond it), or `None` to stop.
/// Scenes walk their moving instances this way (`SceneAt::intersect`); the stack has
/// [`super::build::TOP_STACK_SIZE`] entries, which `build_boxes` keeps the tree within.
pub fn walk_leaves(
    bvh: &Bvh,
    root: u32,
    o: Vec3,
    d: Vec3,
    tmin: f32,
    mut limit: f32,
    mut visit: impl FnMut(u32) -> Option<f32>,
) {
    use super::build::TOP_STACK_SIZE;
    if (root as usize) >= bvh.nodes.len() {
        return;
    }
    let ray = WideRay::new(Vec3A::from(o), Vec3A::from(d));
    let tmin_v = Vec4::splat(tmin);
    let mut stack = [(0u32, 0f32); TOP_STACK_SIZE];
    stack[0] = (root, tmin);
    let mut sp = 1usize;
    while sp > 0 {
        sp -= 1;
        let (r, t_enter) = stack[sp];
        // NaN entry distances (0·∞) never cull, as in the slab test.
        if t_enter > limit * WIDEN {
            continue;
        }
        if r & LEAF_BIT != 0 {
            let first = r & ((1 << LEAF_FIRST_BITS) - 1);
            let count = ((r >> LEAF_FIRST_BITS) & 7) + 1;
            for item in first..first + count {
                match visit(item) {
                    Some(l) => limit = l,
                    None => return,
                }
            }
            continue;
        }
        let n = &bvh.nodes[r as usize];
        let (t, mut mask) = ray.slab(n, tmin_v, Vec4::splat(limit));
        let t = t.to_array();
        // Push the entered children farthest first, so the nearest pops first.
        let mut hit = [(0u32, 0f32); 4];
        let mut k = 0;
        while mask != 0 {
            let c = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            hit[k] = (n.child[c], t[c]);
            k += 1;
        }
        hit[..k].sort_unstable_by(|a, b| b.1.total_cmp(&a.1));
        stack[sp..sp + k].copy_from_slice(&hit[..k]);
        sp += k;
    }
}
