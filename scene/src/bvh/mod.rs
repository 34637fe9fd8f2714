//! The flat 8-wide BVH the CPU and the GPU both traverse, and the triangle layout they test against.
//!
//! - [`triangle`]: the one definition of a traced triangle, of a hit, and of the closest-hit tie rule.
//! - [`build`]: obvhs builds a binary tree (PLOC + reinsertion, `fast_build` with one triangle per
//!   leaf, in parallel); we collapse it into the [`WideNode`]s and leaves of least surface-area cost
//!   (dynamic programming over the binary tree), with a median-split fallback for inputs that make
//!   PLOC quadratic or too deep.
//! - [`traverse`]: the CPU traversal — a node's eight child boxes in one AVX slab test where the CPU
//!   has AVX (checked at run time: [`Simd`]), else as two 4-lane groups; children visited nearest
//!   first, any-hit for shadow rays. `shaders/bvh.wgsl` traverses the same nodes (uploaded unchanged)
//!   with `vec4` lane groups; the two need not visit nodes in the same order, since the closest hit is
//!   defined by [`triangle::closer`] (smallest `t`, then smallest triangle index) and both box tests
//!   are conservative (never cull a triangle the triangle test would hit).
//!
//! Why 8-wide: measured against the 4-wide tree it replaced (and that against the binary tree before
//! it), DESIGN-NOTES "Ray tracing core": 30–40% fewer node visits per ray on the large scenes, and
//! one AVX instruction tests eight boxes as SSE tests four — camera rays 0.78–0.81× → 0.98–1.01×
//! Embree's single-ray speed on `heavy`/`spheres`, one thread. Triangles stay in 4-wide packs (a leaf
//! has at most two).

pub mod build;
pub mod traverse;
pub mod triangle;

use bytemuck::{Pod, Zeroable};

pub use build::{build, build_median, build_with, largest_morton_cell, stack_need, stack_needs, tree_depth, BuiltBvh};
pub use traverse::{traverse, traverse_counted, traverse_from, traverse_simd, Simd, TraversalStats};
pub use triangle::{closer, intersect_triangle, Hit, TrianglePack, TriangleRecord, NO_LIGHT, NO_TRIANGLE};

/// Children per node (a multiple of 4: the portable slab test and the WGSL take four lanes at a time;
/// the AVX test eight).
pub const WIDTH: usize = 8;

/// Entries in the traversal stack (CPU and WGSL). The builder bounds the stack a tree can need
/// ([`build::stack_need`]) and rejects trees that need more, so it never overflows. A node whose
/// children are all hit pushes `WIDTH − 1` of them: 64 entries, enough for 4-wide trees, made the SAH
/// tree of `heavy` fall back to the median split at 8-wide (traced 2× the triangle packs per ray).
pub const STACK_SIZE: usize = 128;

/// Most triangles in one leaf of a [`BuiltBvh`] (obvhs's `max_prims_per_leaf` is 8; larger leaves are
/// split), and so at most two [`TrianglePack`]s per leaf of a [`Bvh`]. The reference has room for 8.
pub const MAX_LEAF: u32 = 8;

/// Set in a child reference that names a leaf (see [`WideNode::child`]).
pub const LEAF_BIT: u32 = 1 << 31;
/// A leaf's first triangle sits in the low 28 bits of its reference.
pub const LEAF_FIRST_BITS: u32 = 28;
/// Most triangle references a tree can address ([`LEAF_FIRST_BITS`]; scenes are limited to 2^26
/// triangles before that, `crate::limits::MAX_TRIANGLES`).
pub const MAX_REFERENCES: usize = 1 << LEAF_FIRST_BITS;

/// An 8-wide BVH node (256 bytes, 64-byte aligned so a node is exactly four cache lines; `repr(C)`,
/// Pod; uploaded to the GPU byte for byte). Node 0 is the root of a scene's static tree; each moving
/// instance's tree follows it in the same array ([`Bvh::pack_into`]), with its own root.
///
/// `bounds` holds the [`WIDTH`] child boxes as structure of arrays, so one SIMD lane is one child:
/// `bounds[2·axis]` the minima along `axis`, `bounds[2·axis + 1]` the maxima. An unused slot has the
/// inverted infinite box (min +∞, max −∞), which the slab test (near/far plane chosen by the ray's
/// direction sign) always culls: its entry is +∞ and its exit −∞ on every axis.
///
/// `child[i]` is a reference: an inner child is its node index (top bit clear); a leaf is
/// `LEAF_BIT | (count − 1) << 28 | first`. In a [`Bvh`] (what scenes trace) that is `count` triangle
/// packs from `Bvh::packs[first]`; in a [`BuiltBvh`] straight from the builder, `count`
/// (1..=[`MAX_LEAF`]) triangles from position `first` of its `order`. [`child_ref`] / [`leaf_ref`]
/// decode and encode it.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct WideNode {
    pub bounds: [[f32; WIDTH]; 6],
    pub child: [u32; WIDTH],
    /// Unused: pads the node to a whole number of cache lines. 112-byte 4-wide nodes straddle 2.75
    /// cache lines on average; padded, rays traced 2–5% faster on `heavy` and `spheres` (three
    /// alternating runs of the two bench binaries, DESIGN-NOTES "Ray tracing core") for 14% more node
    /// memory.
    pub pad: [u32; WIDTH],
}

/// A decoded child reference.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Child {
    Node(u32),
    Leaf { first: u32, count: u32 },
}

/// Encode a leaf reference (`first < 2^28`, `1 <= count <= MAX_LEAF`).
pub fn leaf_ref(first: u32, count: u32) -> u32 {
    debug_assert!(first < (1 << LEAF_FIRST_BITS) && (1..=MAX_LEAF).contains(&count));
    LEAF_BIT | (count - 1) << LEAF_FIRST_BITS | first
}

/// Decode a child reference.
#[inline(always)]
pub fn child_ref(r: u32) -> Child {
    if r & LEAF_BIT == 0 {
        Child::Node(r)
    } else {
        Child::Leaf { first: r & ((1 << LEAF_FIRST_BITS) - 1), count: ((r >> LEAF_FIRST_BITS) & 7) + 1 }
    }
}

impl WideNode {
    /// A node with every slot unused.
    pub fn empty() -> Self {
        let (lo, hi) = ([f32::INFINITY; WIDTH], [f32::NEG_INFINITY; WIDTH]);
        WideNode { bounds: [lo, hi, lo, hi, lo, hi], child: [u32::MAX; WIDTH], pad: [0; WIDTH] }
    }

    /// Put a child with box `(min, max)` in slot `i`.
    pub fn set(&mut self, i: usize, min: [f32; 3], max: [f32; 3], child: u32) {
        for axis in 0..3 {
            self.bounds[2 * axis][i] = min[axis];
            self.bounds[2 * axis + 1][i] = max[axis];
        }
        self.child[i] = child;
    }

    /// Whether slot `i` holds a child (unused slots carry the inverted box).
    pub fn used(&self, i: usize) -> bool {
        self.bounds[0][i] <= self.bounds[1][i]
    }

    /// The used slots' decoded references.
    pub fn children(&self) -> impl Iterator<Item = Child> + '_ {
        (0..WIDTH).filter(|&i| self.used(i)).map(|i| child_ref(self.child[i]))
    }
}

/// What scenes trace: the wide nodes and the triangle packs their leaves reference (CPU and GPU alike).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Bvh {
    pub nodes: Vec<WideNode>,
    pub packs: Vec<TrianglePack>,
}

impl Bvh {
    /// Pack a built tree's leaves: each leaf's triangle range (positions in `tris`, the triangles in
    /// BVH order) becomes consecutive [`TrianglePack`]s of four, and its reference points at them.
    pub fn pack(nodes: Vec<WideNode>, tris: &[TriangleRecord]) -> Bvh {
        let mut bvh = Bvh { nodes: Vec::with_capacity(nodes.len()), packs: Vec::with_capacity(tris.len() / 2) };
        bvh.pack_into(nodes, tris, 0);
        bvh
    }

    /// Append a built tree (its nodes numbered from 0, its leaves naming positions in `tris`) after the
    /// trees already here, as [`Bvh::pack`] does for the first: inner references are shifted by the
    /// node count so far, leaves point at new packs, and each pack's `index` is `first_triangle` plus
    /// the position in `tris` (so `tris` are the scene's triangles from `first_triangle` on). Returns
    /// the new tree's root. Scenes keep one tree per moving instance this way (`Scene::instances`),
    /// all traversed by the same code from their own root ([`traverse_from`]).
    pub fn pack_into(&mut self, nodes: Vec<WideNode>, tris: &[TriangleRecord], first_triangle: u32) -> u32 {
        let root = self.nodes.len() as u32;
        for mut node in nodes {
            for slot in 0..WIDTH {
                if !node.used(slot) {
                    continue;
                }
                match child_ref(node.child[slot]) {
                    Child::Node(j) => node.child[slot] = j + root,
                    Child::Leaf { first, count } => {
                        let start = self.packs.len() as u32;
                        let end = first + count;
                        for c in (first..end).step_by(4) {
                            self.packs.push(TrianglePack::new(&tris[c as usize..end as usize], first_triangle + c));
                        }
                        node.child[slot] = leaf_ref(start, self.packs.len() as u32 - start);
                    }
                }
            }
            self.nodes.push(node);
        }
        root
    }

    /// Bytes the structure occupies (nodes and packs).
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.nodes.as_slice()) + std::mem::size_of_val(self.packs.as_slice())
    }
}
