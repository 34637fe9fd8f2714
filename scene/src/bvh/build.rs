//! Building the wide BVH: obvhs (or a median split) builds a binary tree, which [`collapse`] turns
//! into the wide nodes ([`WIDTH`] children) and leaves of least surface-area cost.
//!
//! PLOC pairs mutual nearest neighbours along the Morton order; when many primitives share one Morton
//! code (identical bounding-box centres, e.g. a million triangles rotated about one point) the merge
//! costs tie, only one pair merges per pass and the build turns quadratic with a chain-shaped tree (1M
//! such triangles did not finish in minutes). [`build`] detects that input and uses a plain
//! median-split builder instead ([`build_median`]: O(n log n), depth ≤ log2(n) + 1), and also falls
//! back to it when the collapsed tree could overflow the traversal stack.

use bytemuck::Zeroable;
use glam::Vec3;

use super::{leaf_ref, Child, WideNode, MAX_LEAF, STACK_SIZE, WIDTH};

/// A binary node as the builders produce it (the layout the traversal used before it went 4-wide).
/// Inner node: `count == 0`, children at `index` and `index + 1`. Leaf: `count > 0` primitives from
/// `order[index]`. Node 0 is the root.
#[derive(Clone, Copy, Debug, PartialEq, Zeroable)]
pub struct BinaryNode {
    pub min: [f32; 3],
    pub index: u32,
    pub max: [f32; 3],
    pub count: u32,
}

/// The result of building: wide nodes plus the input-triangle order the leaves expect.
pub struct BuiltBvh {
    pub nodes: Vec<WideNode>,
    /// `order[k]` = input index of the triangle that must be stored at position k.
    pub order: Vec<u32>,
    /// Levels of wide nodes (root alone = 1).
    pub depth: usize,
    /// Stack entries a traversal of this tree can need ([`stack_need`]); at most [`STACK_SIZE`] from
    /// [`build`].
    pub stack_need: usize,
}

/// A binary tree from one of the builders, before [`collapse`].
pub struct BinaryTree {
    pub nodes: Vec<BinaryNode>,
    pub order: Vec<u32>,
}

/// Build with obvhs (`fast_build`: [`PRESET`]) and collapse to wide nodes. With a preset that
/// pre-splits (spatial splits) a triangle is referenced from several leaves, so `order` may repeat
/// input indices; the scene stores one copy per reference.
pub fn build(tris: &[[Vec3; 3]]) -> BuiltBvh {
    if largest_morton_cell(tris) > MAX_SHARED_MORTON_CELL {
        return build_median(tris);
    }
    // Heavily nested boxes (e.g. a million triangles rotated about one axis, all centres on a line) make
    // PLOC pair poorly too, without any tie. A PLOC build of an evenly strided sample is cheap and shows
    // it: ordinary scenes' samples are 18–23 deep (built-ins), such inputs' 130+.
    if tris.len() > PROBE_SIZE {
        let sample: Vec<[Vec3; 3]> = tris.iter().step_by(tris.len() / PROBE_SIZE).copied().collect();
        let probe = binary_obvhs(&sample, PRESET);
        if binary_depth(&probe.nodes) > MAX_PROBE_DEPTH {
            return build_median(tris);
        }
    }
    let built = build_with(tris, PRESET);
    if built.stack_need > STACK_SIZE {
        return build_median(tris);
    }
    built
}

/// The obvhs preset scenes are built with: `fast_build` (PLOC, a little reinsertion) with one
/// triangle per leaf, so that [`collapse`] forms the leaves itself. Measured on the built-in scenes
/// (DESIGN-NOTES "Ray tracing core"): with the greedy collapse of earlier versions, `fast_build`'s
/// trees traced as fast as `medium_build`'s and `slow_build`'s (spatial splits) in 60–80% of
/// `medium_build`'s time; with the SAH-optimal collapse, one-triangle leaves take 3–6% fewer
/// instructions per ray than obvhs's own 8-triangle leaves.
pub const PRESET: obvhs::BvhBuildParams =
    obvhs::BvhBuildParams { max_prims_per_leaf: 1, ..obvhs::BvhBuildParams::fast_build() };

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
    collapse(&binary_median(tris))
}

/// [`build_median`]'s binary tree.
pub fn binary_median(tris: &[[Vec3; 3]]) -> BinaryTree {
    const LEAF: usize = 4;
    let boxes: Vec<(Vec3, Vec3)> = tris.iter().map(|t| (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]))).collect();
    let centres: Vec<Vec3> = boxes.iter().map(|(a, b)| (*a + *b) * 0.5).collect();
    let mut order: Vec<u32> = (0..tris.len() as u32).collect();
    let mut nodes = vec![BinaryNode::zeroed()];
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
            nodes[node] =
                BinaryNode { min: lo.to_array(), index: start as u32, max: hi.to_array(), count: (end - start) as u32 };
            continue;
        }
        let axis = (chi - clo).max_position();
        let mid = (end - start) / 2;
        order[start..end]
            .select_nth_unstable_by(mid, |&a, &b| centres[a as usize][axis].total_cmp(&centres[b as usize][axis]));
        let first_child = nodes.len();
        nodes.push(BinaryNode::zeroed());
        nodes.push(BinaryNode::zeroed());
        nodes[node] = BinaryNode { min: lo.to_array(), index: first_child as u32, max: hi.to_array(), count: 0 };
        todo.push((first_child, start, start + mid));
        todo.push((first_child + 1, start + mid, end));
    }
    BinaryTree { nodes, order }
}

/// [`build`] with explicit obvhs parameters (for experiments and benchmarks).
pub fn build_with(tris: &[[Vec3; 3]], params: obvhs::BvhBuildParams) -> BuiltBvh {
    collapse(&binary_obvhs(tris, params))
}

/// obvhs's binary tree in [`BinaryNode`]s.
pub fn binary_obvhs(tris: &[[Vec3; 3]], params: obvhs::BvhBuildParams) -> BinaryTree {
    use obvhs::{bvh2::builder::build_bvh2_from_tris, triangle::Triangle};
    let input: Vec<Triangle> =
        tris.iter().map(|t| Triangle { v0: t[0].into(), v1: t[1].into(), v2: t[2].into() }).collect();
    let mut core_time = std::time::Duration::ZERO;
    let bvh = build_bvh2_from_tris(&input, params, &mut core_time);
    let nodes: Vec<BinaryNode> = bvh
        .nodes
        .iter()
        .map(|n| BinaryNode {
            min: Vec3::from(n.aabb.min).to_array(),
            index: n.first_index,
            max: Vec3::from(n.aabb.max).to_array(),
            count: n.prim_count,
        })
        .collect();
    BinaryTree { nodes, order: bvh.primitive_indices }
}

/// Depth of the tree (root alone = 1), iteratively so deep trees cannot blow the Rust stack.
pub fn binary_depth(nodes: &[BinaryNode]) -> usize {
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

/// Relative costs of the work a ray does, for [`collapse`]'s surface-area cost: testing one wide
/// node's four boxes, and testing one [`super::TrianglePack`] (four triangles).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CollapseCost {
    pub node: f32,
    pub pack: f32,
}

/// The costs scenes' trees are collapsed with. Chosen by callgrind instructions per ray on `heavy` and
/// `spheres` (primary, shadow, diffuse rays; one-triangle `fast_build` leaves): pack cost 1.5 took
/// 0.3–0.6% fewer than 1.0 and 1–2% fewer than 0.7, and 2.0 made the same trees as 1.5.
pub const COLLAPSE_COST: CollapseCost = CollapseCost { node: 1.0, pack: 1.5 };

/// Collapse a binary tree into wide nodes with the least surface-area cost ([`collapse_with`] at
/// [`COLLAPSE_COST`]).
pub fn collapse(tree: &BinaryTree) -> BuiltBvh {
    collapse_with(tree, COLLAPSE_COST)
}

/// Collapse a binary tree into the wide tree of least expected cost under the surface-area model:
/// a ray entering a wide node's box pays `cost.node` (its [`WIDTH`] child boxes), a ray entering a leaf's
/// box pays `cost.pack` per [`super::TrianglePack`] (⌈triangles / 4⌉). Dynamic programming over the
/// binary tree, bottom up, as Ylitie et al. 2017 ("Efficient incoherent ray traversal on GPUs through
/// compressed wide BVHs", §4) do for 8-wide nodes: `C(n, i)`, the least cost of n's subtree spread
/// over at most `i` slots of its parent, is
/// - `i = 1`: a leaf of all its triangles (if at most [`MAX_LEAF`]), or a wide node over it:
///   `A(n)·cost.node + D(n, WIDTH)`;
/// - `i > 1`: `min(C(n, i − 1), D(n, i))`, with `D(n, j) = min over 0 < k < j of C(l, k) + C(r, j − k)`
///   (l, r its children): some slots go to the left subtree, the rest to the right.
///
/// Leaves of the binary tree may hold several triangles; one with more than [`MAX_LEAF`] is split into
/// chunks under an extra node with the same box, as [`collapse_greedy`] does. Triangles are stored in
/// the order the leaves are made (`BuiltBvh::order`).
pub fn collapse_with(tree: &BinaryTree, cost: CollapseCost) -> BuiltBvh {
    collapse_leaves(tree, cost, MAX_LEAF)
}

/// [`collapse_with`] making leaves of at most `max_leaf` (≤ [`MAX_LEAF`]) primitives out of inner
/// binary nodes (the binary tree's own leaves stay as they are).
fn collapse_leaves(tree: &BinaryTree, cost: CollapseCost, max_leaf: u32) -> BuiltBvh {
    let bin = &tree.nodes;
    let mut nodes = Vec::new();
    let mut order = Vec::with_capacity(tree.order.len());
    if !bin.is_empty() {
        let plan = CollapsePlan::new(bin, cost, max_leaf);
        nodes.push(WideNode::empty());
        // (wide node to fill, binary node whose subtree it covers)
        let mut todo = vec![(0usize, 0u32)];
        let mut slots = Vec::with_capacity(WIDTH);
        let mut prims = Vec::new();
        while let Some((w, b)) = todo.pop() {
            slots.clear();
            if bin[b as usize].count > 0 || plan.leaf[b as usize] {
                slots.push(b);
            } else {
                plan.expand_children(bin, b, WIDTH, &mut slots);
            }
            for (slot, &i) in slots.iter().enumerate() {
                let c = bin[i as usize];
                let r = if c.count == 0 && !plan.leaf[i as usize] {
                    nodes.push(WideNode::empty());
                    todo.push((nodes.len() - 1, i));
                    (nodes.len() - 1) as u32
                } else {
                    prims.clear();
                    subtree_prims(bin, &tree.order, i, &mut prims);
                    let first = order.len() as u32;
                    order.extend_from_slice(&prims);
                    leaf_slot(&mut nodes, first, prims.len() as u32, c.min, c.max)
                };
                nodes[w].set(slot, c.min, c.max, r);
            }
        }
    }
    let (depth, stack_need) = (tree_depth(&nodes), stack_need(&nodes));
    BuiltBvh { nodes, order, depth, stack_need }
}

/// [`collapse_with`]'s decisions per binary node.
struct CollapsePlan {
    /// Whether the node, given one slot, becomes a leaf (else a wide node over its subtree).
    leaf: Vec<bool>,
    /// For `i` = 2..=WIDTH slots (index `i − 2`): 0 if `C(n, i) = C(n, i − 1)`, else the slots `k` given
    /// to the left child (`D(n, i)`'s best split).
    split: Vec<[u8; WIDTH - 1]>,
    /// `D(n, WIDTH)`'s best split (a wide node over n distributes its slots this way).
    split4: Vec<u8>,
}

impl CollapsePlan {
    fn new(bin: &[BinaryNode], cost: CollapseCost, max_leaf: u32) -> CollapsePlan {
        let n = bin.len();
        // Children before parents: reverse of a pre-order walk (no recursion: trees can be deep).
        let mut pre = Vec::with_capacity(n);
        let mut todo = vec![0u32];
        while let Some(i) = todo.pop() {
            pre.push(i);
            let b = &bin[i as usize];
            if b.count == 0 {
                todo.push(b.index);
                todo.push(b.index + 1);
            }
        }
        let mut count = vec![0u32; n];
        let mut c = vec![[0f32; WIDTH]; n]; // c[n][i − 1] = C(n, i)
        let mut plan = CollapsePlan { leaf: vec![false; n], split: vec![[0; WIDTH - 1]; n], split4: vec![0; n] };
        let packs = |count: u32| count.div_ceil(4) as f32;
        for &i in pre.iter().rev() {
            let (i, b) = (i as usize, &bin[i as usize]);
            let a = area(b);
            if b.count > 0 {
                count[i] = b.count;
                let mut leaf = a * packs(b.count) * cost.pack;
                if b.count > MAX_LEAF {
                    leaf += a * cost.node; // `leaf_slot`'s extra node
                }
                c[i] = [leaf; WIDTH];
                plan.leaf[i] = true;
                continue;
            }
            let (l, r) = (b.index as usize, b.index as usize + 1);
            count[i] = count[l] + count[r];
            // D(n, j) for j = 2..=WIDTH and its best split.
            let mut d = [(f32::INFINITY, 0u8); WIDTH + 1];
            for (j, dj) in d.iter_mut().enumerate().skip(2) {
                for k in 1..j {
                    let v = c[l][k - 1] + c[r][j - k - 1];
                    if v < dj.0 {
                        *dj = (v, k as u8);
                    }
                }
            }
            let internal = a * cost.node + d[WIDTH].0;
            plan.split4[i] = d[WIDTH].1;
            let mut best = internal;
            if count[i] <= max_leaf {
                let leaf = a * packs(count[i]) * cost.pack;
                if leaf <= internal {
                    best = leaf;
                    plan.leaf[i] = true;
                }
            }
            c[i][0] = best;
            for j in 2..=WIDTH {
                if d[j].0 < c[i][j - 2] {
                    c[i][j - 1] = d[j].0;
                    plan.split[i][j - 2] = d[j].1;
                } else {
                    c[i][j - 1] = c[i][j - 2];
                }
            }
        }
        plan
    }

    /// The slots of a wide node over inner node `b`: `D(b, width)`'s split, expanded.
    fn expand_children(&self, bin: &[BinaryNode], b: u32, width: usize, out: &mut Vec<u32>) {
        let k = self.split4[b as usize] as usize;
        debug_assert!(width == WIDTH && k > 0);
        let first = bin[b as usize].index;
        self.expand(bin, first, k, out);
        self.expand(bin, first + 1, width - k, out);
    }

    /// The binary nodes that fill at most `i` slots for node `b`'s subtree (`C(b, i)`'s choice).
    fn expand(&self, bin: &[BinaryNode], b: u32, mut i: usize, out: &mut Vec<u32>) {
        let node = &bin[b as usize];
        while i > 1 && node.count == 0 && self.split[b as usize][i - 2] == 0 {
            i -= 1;
        }
        if i == 1 || node.count > 0 {
            out.push(b);
            return;
        }
        let k = self.split[b as usize][i - 2] as usize;
        self.expand(bin, node.index, k, out);
        self.expand(bin, node.index + 1, i - k, out);
    }
}

/// The primitives under binary node `b`, in tree order.
fn subtree_prims(bin: &[BinaryNode], order: &[u32], b: u32, out: &mut Vec<u32>) {
    let mut todo = vec![b];
    while let Some(i) = todo.pop() {
        let n = &bin[i as usize];
        if n.count > 0 {
            out.extend_from_slice(&order[n.index as usize..(n.index + n.count) as usize]);
        } else {
            todo.push(n.index + 1);
            todo.push(n.index);
        }
    }
}

/// The collapse used before [`collapse`] (kept for comparison: the bench's build table). Collapse a
/// binary tree into wide nodes, top down: each wide node takes its binary node's two
/// children and keeps opening the inner child with the largest surface area (the one rays most
/// likely enter) until it holds [`WIDTH`] children or only leaves — the usual greedy SAH collapse
/// (Wald et al. 2008, "Getting rid of packets"). Leaves keep their triangle ranges; a leaf larger than
/// [`MAX_LEAF`] is split into chunks under an extra node with the same box.
pub fn collapse_greedy(tree: &BinaryTree) -> BuiltBvh {
    let bin = &tree.nodes;
    let mut nodes = Vec::new();
    if !bin.is_empty() {
        nodes.push(WideNode::empty());
        // (wide node to fill, binary node whose subtree it covers)
        let mut todo = vec![(0usize, 0u32)];
        while let Some((w, b)) = todo.pop() {
            let n = bin[b as usize];
            let mut open: Vec<u32> = if n.count > 0 { vec![b] } else { vec![n.index, n.index + 1] };
            while open.len() < WIDTH {
                let widest = open
                    .iter()
                    .enumerate()
                    .filter(|(_, &i)| bin[i as usize].count == 0)
                    .max_by(|x, y| area(&bin[*x.1 as usize]).total_cmp(&area(&bin[*y.1 as usize])));
                let Some((k, &i)) = widest else { break };
                let first = bin[i as usize].index;
                open.splice(k..=k, [first, first + 1]);
            }
            for (slot, &i) in open.iter().enumerate() {
                let c = bin[i as usize];
                let r = if c.count == 0 {
                    nodes.push(WideNode::empty());
                    todo.push((nodes.len() - 1, i));
                    (nodes.len() - 1) as u32
                } else {
                    leaf_slot(&mut nodes, c.index, c.count, c.min, c.max)
                };
                nodes[w].set(slot, c.min, c.max, r);
            }
        }
    }
    let (depth, stack_need) = (tree_depth(&nodes), stack_need(&nodes));
    BuiltBvh { nodes, order: tree.order.clone(), depth, stack_need }
}

/// A wide tree over boxes, one box per leaf: each leaf reference is `leaf_ref(box index, 1)` (no
/// `order`). Scenes build their top-level tree over moving instances' swept boxes with it
/// ([`crate::Scene::instance_root`]). Top-down, each binary split at the least
/// `A(left)·|left| + A(right)·|right|` over the boxes sorted by centre along each axis, except that
/// below depth [`BOX_SAH_DEPTH`] (nested or coincident boxes can make SAH peel one box at a time)
/// and whenever the collapsed tree would need more than [`TOP_STACK_SIZE`] stack entries, it splits
/// at the median: the tree's depth stays within `BOX_SAH_DEPTH + log2(n) + 1`.
pub fn build_boxes(boxes: &[([f32; 3], [f32; 3])]) -> BuiltBvh {
    let cost = CollapseCost { node: 1.0, pack: 1.0 };
    let built = collapse_leaves(&binary_boxes(boxes, BOX_SAH_DEPTH), cost, 1);
    let built =
        if built.stack_need + 1 > TOP_STACK_SIZE { collapse_leaves(&binary_boxes(boxes, 0), cost, 1) } else { built };
    // Leaves name positions in `order`; name the boxes instead.
    let mut nodes = built.nodes;
    for n in &mut nodes {
        for slot in 0..WIDTH {
            if let (true, Child::Leaf { first, count }) = (n.used(slot), super::child_ref(n.child[slot])) {
                debug_assert_eq!(count, 1);
                n.child[slot] = leaf_ref(built.order[first as usize], 1);
            }
        }
    }
    BuiltBvh { nodes, order: built.order, depth: built.depth, stack_need: built.stack_need }
}

/// Binary levels [`build_boxes`] splits by surface area before it splits at the median.
pub const BOX_SAH_DEPTH: usize = 24;

/// Stack entries of a top-level walk over a [`build_boxes`] tree (CPU `traverse::walk_leaves`, WGSL
/// `scene_trace`): it pushes every entered child of a node, so it needs `stack_need + 1`.
pub const TOP_STACK_SIZE: usize = 32;

/// A binary tree over boxes, one box per leaf, split at the median of its largest axis at every
/// level: at most `⌈log2 n⌉ + 1` levels whatever the boxes. The fallback of builders whose depth is
/// not bounded (the light-field splat tree, `wedge_effects::light_field::splats`), when
/// their tree is deeper than a traversal stack allows.
pub fn binary_median_boxes(boxes: &[([f32; 3], [f32; 3])]) -> BinaryTree {
    binary_boxes(boxes, 0)
}

/// [`build_boxes`]'s binary tree: one box per leaf, surface-area splits above depth `sah_depth`.
fn binary_boxes(boxes: &[([f32; 3], [f32; 3])], sah_depth: usize) -> BinaryTree {
    let centre = |i: u32| {
        let (lo, hi) = boxes[i as usize];
        Vec3::from(lo) + Vec3::from(hi)
    };
    let union = |ids: &[u32]| {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for &i in ids {
            lo = lo.min(Vec3::from(boxes[i as usize].0));
            hi = hi.max(Vec3::from(boxes[i as usize].1));
        }
        (lo, hi)
    };
    let half_area = |(lo, hi): (Vec3, Vec3)| {
        let e = (hi - lo).max(Vec3::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    };
    let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
    let mut nodes = Vec::with_capacity(2 * boxes.len());
    if boxes.is_empty() {
        return BinaryTree { nodes, order };
    }
    nodes.push(BinaryNode::zeroed());
    let mut todo = vec![(0usize, 0usize, boxes.len(), 0usize)];
    let mut right_area = Vec::new();
    while let Some((node, start, end, depth)) = todo.pop() {
        let (lo, hi) = union(&order[start..end]);
        if end - start == 1 {
            nodes[node] = BinaryNode { min: lo.to_array(), index: start as u32, max: hi.to_array(), count: 1 };
            continue;
        }
        let ids = &mut order[start..end];
        let n = ids.len();
        // (cost, axis, boxes on the left)
        let mut best = (f32::INFINITY, 0usize, n / 2);
        if depth < sah_depth {
            for axis in 0..3 {
                ids.sort_by(|&a, &b| centre(a)[axis].total_cmp(&centre(b)[axis]).then(a.cmp(&b)));
                right_area.clear();
                right_area.resize(n, 0.0);
                let (mut rlo, mut rhi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
                for k in (1..n).rev() {
                    rlo = rlo.min(Vec3::from(boxes[ids[k] as usize].0));
                    rhi = rhi.max(Vec3::from(boxes[ids[k] as usize].1));
                    right_area[k] = half_area((rlo, rhi));
                }
                let (mut llo, mut lhi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
                for k in 1..n {
                    llo = llo.min(Vec3::from(boxes[ids[k - 1] as usize].0));
                    lhi = lhi.max(Vec3::from(boxes[ids[k - 1] as usize].1));
                    let c = half_area((llo, lhi)) * k as f32 + right_area[k] * (n - k) as f32;
                    if c < best.0 {
                        best = (c, axis, k);
                    }
                }
            }
        } else {
            best.1 = (hi - lo).max_position();
        }
        let (axis, mid) = (best.1, best.2);
        ids.sort_by(|&a, &b| centre(a)[axis].total_cmp(&centre(b)[axis]).then(a.cmp(&b)));
        let first_child = nodes.len();
        nodes.push(BinaryNode::zeroed());
        nodes.push(BinaryNode::zeroed());
        nodes[node] = BinaryNode { min: lo.to_array(), index: first_child as u32, max: hi.to_array(), count: 0 };
        todo.push((first_child, start, start + mid, depth + 1));
        todo.push((first_child + 1, start + mid, end, depth + 1));
    }
    BinaryTree { nodes, order }
}

/// A reference to `count` triangles from `first`: a leaf, or for more than [`MAX_LEAF`] a new node
/// over up to [`WIDTH`] chunks (recursively), each with the whole leaf's box.
fn leaf_slot(nodes: &mut Vec<WideNode>, first: u32, count: u32, min: [f32; 3], max: [f32; 3]) -> u32 {
    if count <= MAX_LEAF {
        return leaf_ref(first, count);
    }
    let w = nodes.len();
    nodes.push(WideNode::empty());
    let chunk = count.div_ceil(WIDTH as u32);
    for (slot, start) in (first..first + count).step_by(chunk as usize).enumerate() {
        let r = leaf_slot(nodes, start, chunk.min(first + count - start), min, max);
        nodes[w].set(slot, min, max, r);
    }
    w as u32
}

fn area(n: &BinaryNode) -> f32 {
    let e = Vec3::from(n.max) - Vec3::from(n.min);
    e.x * e.y + e.y * e.z + e.z * e.x
}

/// Children of node `i` that are nodes (not leaves), with the number of used slots.
fn inner_children(nodes: &[WideNode], i: usize) -> (usize, impl Iterator<Item = usize> + '_) {
    let n = &nodes[i];
    let used = (0..WIDTH).filter(|&s| n.used(s)).count();
    let inner = n.children().filter_map(|c| match c {
        Child::Node(j) => Some(j as usize),
        Child::Leaf { .. } => None,
    });
    (used, inner)
}

/// Levels of wide nodes (root alone = 1; 0 for an empty tree). Children always follow their parent
/// in the array, so one backward pass computes it without recursion.
pub fn tree_depth(nodes: &[WideNode]) -> usize {
    let mut depth = vec![1usize; nodes.len()];
    for i in (0..nodes.len()).rev() {
        let (_, inner) = inner_children(nodes, i);
        depth[i] = 1 + inner.map(|j| depth[j]).max().unwrap_or(0);
    }
    depth.first().copied().unwrap_or(0)
}

/// Most stack entries a traversal can hold: a node whose `k` children are all hit pushes `k − 1` and
/// continues into one of them, so a subtree needs `(k − 1) + max over its inner children`. The
/// traversals (CPU and WGSL) have [`STACK_SIZE`] entries; [`build`] keeps every tree within it.
pub fn stack_need(nodes: &[WideNode]) -> usize {
    stack_needs(nodes).first().copied().unwrap_or(0)
}

/// [`stack_need`] of the subtree at every node of `nodes` (a scene's node array holds several trees:
/// the need of one is the entry at its root).
pub fn stack_needs(nodes: &[WideNode]) -> Vec<usize> {
    let mut need = vec![0usize; nodes.len()];
    for i in (0..nodes.len()).rev() {
        let (used, inner) = inner_children(nodes, i);
        need[i] = used.saturating_sub(1) + inner.map(|j| need[j]).max().unwrap_or(0);
    }
    need
}
