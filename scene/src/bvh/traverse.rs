//! CPU traversal of the 8-wide BVH: one ray at a time, the eight child boxes of a node in one AVX slab
//! test where the CPU has AVX (run-time check, [`Simd`]), else in two 4-lane groups (glam `Vec4`: SSE
//! on x86-64, NEON on aarch64, scalar elsewhere); hit children visited nearest first (closest hit)
//! from a fixed stack, leaves tested four triangles at a time
//! ([`TrianglePack::intersect`], the shared watertight test of [`super::triangle`] in lanes).
//! `shaders/bvh.wgsl` is the GPU mirror.
//!
//! The slab test picks each axis's near and far plane by the sign of the ray direction (Williams et
//! al. 2005), so it needs no per-axis min/max; the exit distance is widened by a few ulps (PBRT's
//! 1 + 2γ₃) so rounding never culls a triangle the triangle test would hit (thin boxes: a flat ground
//! has zero height). A NaN distance (origin on a slab plane of a ray parallel to it: 0 · ∞) must not
//! cull either: the reductions put the running value second, and SSE/AVX `maxps`/`minps` return their
//! second operand when either is NaN, as glam's scalar fallback does; NEON's `fmax`/`fmin` would
//! propagate the NaN, so there (and only there) NaN lanes are cleared first.

use std::mem::MaybeUninit;

use glam::{Vec3, Vec3A, Vec4};

use super::triangle::{closer, PackRay, TrianglePack};
use super::{Bvh, Hit, WideNode, LEAF_BIT, LEAF_FIRST_BITS, STACK_SIZE, WIDTH};

/// 1 + 2γ₃ rounded up (0x3f800003): the exit-distance widening of the slab test.
pub const WIDEN: f32 = 1.000_000_4;

/// How a node's [`WIDTH`] child boxes are tested against a ray: entry distances and the mask (bit i:
/// child i overlaps `(tmin, tmax)`). Every implementation does the same IEEE operations per lane in the
/// same order (subtract, multiply, max/min with the running value second, widened compare), so they
/// agree bit for bit and the choice is only a matter of speed ([`Simd`]).
trait SlabTest {
    /// A value splatted across the test's lanes.
    type Lanes;
    fn prepare(o: Vec3A, d: Vec3A) -> SlabRay<Self::Lanes>;
    fn slab(ray: &SlabRay<Self::Lanes>, n: &WideNode, tmin: f32, tmax: f32) -> ([f32; WIDTH], u32);
}

/// Which slab test a traversal runs. [`Simd::best`] is what scenes use: AVX where the CPU has it,
/// checked at run time (the binary stays portable), else four lanes at a time through glam (SSE on
/// x86-64, NEON on aarch64, scalar elsewhere).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Simd {
    /// Two 4-lane groups per 8-wide node (glam `Vec4`).
    Portable,
    /// One 8-lane AVX test per node (x86-64 with AVX only).
    Avx,
}

impl Simd {
    /// The fastest test this CPU runs.
    #[inline(always)]
    pub fn best() -> Simd {
        if Simd::Avx.available() {
            Simd::Avx
        } else {
            Simd::Portable
        }
    }

    /// Whether this CPU can run it.
    #[inline(always)]
    pub fn available(self) -> bool {
        match self {
            Simd::Portable => true,
            #[cfg(target_arch = "x86_64")]
            Simd::Avx => std::arch::is_x86_feature_detected!("avx"),
            #[cfg(not(target_arch = "x86_64"))]
            Simd::Avx => false,
        }
    }
}

/// A ray prepared for a slab test: origin and reciprocal direction splatted across the lanes `L`,
/// and per axis which `bounds` row holds the near plane (`2·axis` for a non-negative direction sign,
/// else `2·axis + 1`).
struct SlabRay<L> {
    o: [L; 3],
    inv_d: [L; 3],
    near: [usize; 3],
}

impl<L> SlabRay<L> {
    #[inline(always)]
    fn new(o: Vec3A, d: Vec3A, splat: impl Fn(f32) -> L) -> Self {
        let inv = d.recip();
        let row = |axis: usize| 2 * axis + inv[axis].is_sign_negative() as usize;
        SlabRay {
            o: [splat(o.x), splat(o.y), splat(o.z)],
            inv_d: [splat(inv.x), splat(inv.y), splat(inv.z)],
            near: [row(0), row(1), row(2)],
        }
    }
}

/// The slab test four lanes at a time (glam).
struct Portable;

impl SlabTest for Portable {
    type Lanes = Vec4;

    #[inline(always)]
    fn prepare(o: Vec3A, d: Vec3A) -> SlabRay<Vec4> {
        SlabRay::new(o, d, Vec4::splat)
    }

    #[inline(always)]
    fn slab(ray: &SlabRay<Vec4>, n: &WideNode, tmin: f32, tmax: f32) -> ([f32; WIDTH], u32) {
        let mut t_out = [0.0; WIDTH];
        let mut mask = 0u32;
        for g in 0..WIDTH / 4 {
            let row = |r: usize| Vec4::from_slice(&n.bounds[r][4 * g..4 * g + 4]);
            let mut t_enter = Vec4::splat(tmin);
            let mut t_exit = Vec4::splat(tmax);
            for axis in 0..3 {
                let near = (row(ray.near[axis]) - ray.o[axis]) * ray.inv_d[axis];
                let far = (row(ray.near[axis] ^ 1) - ray.o[axis]) * ray.inv_d[axis];
                let (near, far) = nan_free(near, far);
                t_enter = near.max(t_enter);
                t_exit = far.min(t_exit);
            }
            t_out[4 * g..4 * g + 4].copy_from_slice(&t_enter.to_array());
            mask |= t_enter.cmple(t_exit * WIDEN).bitmask() << (4 * g);
        }
        (t_out, mask)
    }
}

/// The slab test eight lanes at a time with AVX, and the traversal compiled with AVX enabled so the
/// intrinsics inline into it (the rest of the loop, glam's SSE, is then VEX-encoded too).
#[cfg(target_arch = "x86_64")]
mod avx {
    use std::arch::x86_64::*;

    use glam::{Vec3, Vec3A};

    use super::super::triangle::TrianglePack;
    use super::super::{Hit, WideNode, WIDTH};
    use super::{Counter, SlabRay, SlabTest, Start, WIDEN};

    const _: () = assert!(WIDTH == 8, "the AVX slab test is one 8-lane register per row");

    pub(super) struct Avx;

    impl SlabTest for Avx {
        type Lanes = __m256;

        #[inline(always)]
        fn prepare(o: Vec3A, d: Vec3A) -> SlabRay<__m256> {
            // SAFETY: only reached through `traverse`, which runs where the CPU has AVX.
            SlabRay::new(o, d, |x| unsafe { _mm256_set1_ps(x) })
        }

        #[inline(always)]
        fn slab(ray: &SlabRay<__m256>, n: &WideNode, tmin: f32, tmax: f32) -> ([f32; WIDTH], u32) {
            // SAFETY: AVX as above; each `bounds` row is 32 bytes at a 32-byte offset of a 64-byte
            // aligned node, so the aligned loads are in bounds and aligned.
            unsafe {
                let row = |r: usize| _mm256_load_ps(n.bounds[r].as_ptr());
                let mut t_enter = _mm256_set1_ps(tmin);
                let mut t_exit = _mm256_set1_ps(tmax);
                for axis in 0..3 {
                    let near = _mm256_mul_ps(_mm256_sub_ps(row(ray.near[axis]), ray.o[axis]), ray.inv_d[axis]);
                    let far = _mm256_mul_ps(_mm256_sub_ps(row(ray.near[axis] ^ 1), ray.o[axis]), ray.inv_d[axis]);
                    // `maxps`/`minps` return the second operand when either is NaN, as the
                    // portable test's SSE does: a NaN distance never culls.
                    t_enter = _mm256_max_ps(near, t_enter);
                    t_exit = _mm256_min_ps(far, t_exit);
                }
                let hit = _mm256_cmp_ps::<_CMP_LE_OQ>(t_enter, _mm256_mul_ps(t_exit, _mm256_set1_ps(WIDEN)));
                let mut t = [0.0f32; WIDTH];
                _mm256_storeu_ps(t.as_mut_ptr(), t_enter);
                (t, _mm256_movemask_ps(hit) as u32)
            }
        }
    }

    /// [`super::traverse_impl`] with the AVX slab test.
    ///
    /// # Safety
    /// The CPU must have AVX ([`super::Simd::Avx`]`.available()`).
    #[target_feature(enable = "avx")]
    pub(super) unsafe fn traverse<const ANY_HIT: bool, C: Counter>(
        nodes: &[WideNode],
        packs: &[TrianglePack],
        start: Start,
        o: Vec3,
        d: Vec3,
        tmin: f32,
        counter: &mut C,
    ) -> Option<Hit> {
        super::traverse_impl::<ANY_HIT, C, Avx>(nodes, packs, start, o, d, tmin, counter)
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
        (Vec4::select(n, Vec4::NEG_INFINITY, near), Vec4::select(f, Vec4::INFINITY, far))
    }
}

/// Closest hit (smallest `t`, ties to the lower triangle index: [`super::closer`]) with
/// `tmin < t < tmax`, or with `any_hit` the first hit found (shadow rays only ask whether there is one).
pub fn traverse(bvh: &Bvh, o: Vec3, d: Vec3, tmin: f32, tmax: f32, any_hit: bool) -> Option<Hit> {
    traverse_with(bvh, Start::root(tmax), o, d, tmin, any_hit, &mut ())
}

/// [`traverse`]'s closest hit, the query fixed at compile time (what `Scene`/`SceneAt` call).
pub fn closest(bvh: &Bvh, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
    dispatch::<false, ()>(bvh, Simd::best(), Start::root(tmax), o, d, tmin, &mut ())
}

/// [`traverse`]'s any-hit query: whether anything is hit with `tmin < t < tmax`.
pub fn occluded(bvh: &Bvh, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> bool {
    dispatch::<true, ()>(bvh, Simd::best(), Start::root(tmax), o, d, tmin, &mut ()).is_some()
}

/// [`traverse`] with a chosen slab test (`Portable` wherever `simd` is not available), for tests
/// that compare the implementations and for benchmarks that measure them.
pub fn traverse_simd(bvh: &Bvh, simd: Simd, o: Vec3, d: Vec3, tmin: f32, tmax: f32, any_hit: bool) -> Option<Hit> {
    if any_hit {
        dispatch::<true, ()>(bvh, simd, Start::root(tmax), o, d, tmin, &mut ())
    } else {
        dispatch::<false, ()>(bvh, simd, Start::root(tmax), o, d, tmin, &mut ())
    }
}

/// The traversal with `simd`'s slab test where the CPU has it, else the portable one.
#[inline(always)]
fn dispatch<const ANY_HIT: bool, C: Counter>(
    bvh: &Bvh,
    simd: Simd,
    start: Start,
    o: Vec3,
    d: Vec3,
    tmin: f32,
    counter: &mut C,
) -> Option<Hit> {
    #[cfg(target_arch = "x86_64")]
    if simd == Simd::Avx && simd.available() {
        // SAFETY: the CPU has AVX (checked at run time just above).
        return unsafe { avx::traverse::<ANY_HIT, C>(&bvh.nodes, &bvh.packs, start, o, d, tmin, counter) };
    }
    let _ = simd;
    traverse_impl::<ANY_HIT, C, Portable>(&bvh.nodes, &bvh.packs, start, o, d, tmin, counter)
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
    let start = Start { root, t_best: best.map_or(tmax, |h| h.t), best_triangle: best.map_or(0, |h| h.triangle) };
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
        Start { root: 0, t_best: tmax, best_triangle: 0 }
    }
}

/// Work a traversal did: wide nodes whose boxes were tested, and triangle packs tested.
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
        dispatch::<true, C>(bvh, Simd::best(), start, o, d, tmin, counter)
    } else {
        dispatch::<false, C>(bvh, Simd::best(), start, o, d, tmin, counter)
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
fn traverse_impl<const ANY_HIT: bool, C: Counter, S: SlabTest>(
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
    let ray = S::prepare(o, d);
    let pack_ray = PackRay::new(o, d);
    let mut t_best = start.t_best;
    let mut best = Hit { t: t_best, triangle: start.best_triangle, b1: 0.0, b2: 0.0 };
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
            let (t, mut mask) = S::slab(&ray, n, tmin, t_best);
            if mask != 0 {
                let first = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                if mask == 0 {
                    current = n.child[first];
                    continue;
                }
                // Two or more children: continue with the nearest, push the rest farthest first so
                // they pop in near-to-far order.
                let mut order = [first; WIDTH];
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
                    return Some(Hit { t: t[lane], triangle, b1: b1[lane], b2: b2[lane] });
                }
                while mask != 0 {
                    let lane = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    if closer(t[lane], pack.index[lane], t_best, best.triangle) {
                        t_best = t[lane];
                        best = Hit { t: t_best, triangle: pack.index[lane], b1: b1[lane], b2: b2[lane] };
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
    let ray = Portable::prepare(Vec3A::from(o), Vec3A::from(d));
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
        let (t, mut mask) = Portable::slab(&ray, n, tmin, limit);
        // Push the entered children farthest first, so the nearest pops first.
        let mut hit = [(0u32, 0f32); WIDTH];
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
