//! Bounding volume hierarchy over object boxes: the model database every culler walks.
//!
//! Built top-down with the binned surface area heuristic (SAH) over box centroids
//! (I. Wald, "On fast construction of SAH-based bounding volume hierarchies",
//! IEEE Symposium on Interactive Ray Tracing, 2007). Nodes live in one array with
//! siblings adjacent and every child after its parent, so a refit after objects
//! move is a single reverse pass. Items of any subtree are contiguous in
//! [`Bvh::items`], so a subtree found wholly visible (or wholly hidden) is a slice.

use crate::geom::{Aabb, Containment, Eye, Frustum, View};
use glam::Vec3;
use std::ops::Range;

/// Deepest tree [`Bvh::build`] makes (root = depth 1). Bounding it lets every
/// traversal use a fixed stack instead of allocating or recursing.
const MAX_DEPTH: usize = 128;

/// From this depth on, nodes are halved by count instead of by SAH: halving at
/// most `u32::MAX` items reaches single items within 32 levels, so the tree
/// never exceeds [`MAX_DEPTH`] however skewed the input.
const COUNT_SPLIT_DEPTH: usize = MAX_DEPTH - 32;

/// More bins buy almost nothing (Wald 2007 finds 16 ample); the cap bounds a build's scratch.
const MAX_BINS: usize = 256;

/// Cost of an inner node, in item tests: a visited inner node tests both children.
/// Only the leaf-or-split decision for small nodes depends on it.
const INNER_NODE_COST: f32 = 2.0;

/// Build settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BvhConfig {
    /// Most items per leaf (0 is taken as 1). Nodes with more items are always
    /// split; smaller ones are split only when the SAH says that is cheaper.
    pub max_leaf_size: usize,
    /// SAH bins per axis (clamped to 2..=256).
    pub bins: usize,
}

impl Default for BvhConfig {
    fn default() -> Self {
        BvhConfig {
            max_leaf_size: 4,
            bins: 16,
        }
    }
}

/// One node of a [`Bvh`].
///
/// Inner node: `count == 0`, children are nodes `first` and `first + 1`, both
/// stored after this node. Leaf: `count >= 1`, items `first..first + count` of
/// [`Bvh::items`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BvhNode {
    /// Box holding every non-empty item box in the subtree ([`Aabb::EMPTY`] if none).
    pub bounds: Aabb,
    /// Inner: index of the first child (the second is `first + 1`). Leaf: first index into the items.
    pub first: u32,
    /// Items in a leaf; 0 for an inner node.
    pub count: u32,
}

impl BvhNode {
    /// True for a leaf (a node that holds items rather than children).
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }
}

/// A bounding volume hierarchy over a slice of boxes; item `i` is box `i` (an object id).
///
/// The hierarchy stores no boxes of its own beyond node bounds: queries take
/// the same box slice it was built (or last refitted) with.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    nodes: Vec<BvhNode>,
    items: Vec<u32>,
    /// Kept so that `Bvh::assert_well_formed` (tests) can check leaf sizes.
    #[cfg_attr(not(test), allow(dead_code))] // read by `assert_well_formed` and the tests
    max_leaf_size: u32,
    #[cfg_attr(not(test), allow(dead_code))] // read by `assert_well_formed` and the tests
    depth: u32,
}

/// Grows `acc` by `b`, skipping boxes that hold no point: an inverted or NaN box
/// would otherwise stretch (or poison) the bounds of everything above it.
fn add(acc: Aabb, b: &Aabb) -> Aabb {
    if b.is_empty() {
        acc
    } else {
        acc.union(*b)
    }
}

/// One item during the build. Partitioning these records, rather than ids that
/// index `boxes`, keeps every pass over a node's items sequential in memory.
#[derive(Clone, Copy)]
struct Record {
    /// [`Aabb::EMPTY`] for boxes that hold no point, so plain unions skip them.
    bounds: Aabb,
    /// NaN for boxes that hold no point or have no finite centre: they then fall
    /// in bin 0 instead of poisoning the centroid bounds.
    centroid: Vec3,
    id: u32,
}

impl Record {
    fn new(id: usize, b: &Aabb) -> Record {
        let c = b.center();
        Record {
            bounds: if b.is_empty() { Aabb::EMPTY } else { *b },
            centroid: if !b.is_empty() && c.is_finite() { c } else { Vec3::NAN },
            id: id as u32,
        }
    }
}

/// Bin of a centroid; binning and partitioning must agree exactly, so both call this.
fn bin_of(c: Vec3, axis: usize, lo: f32, scale: f32, bins: usize) -> usize {
    // `as` saturates (NaN and negatives give 0), so rounding can never index out of range.
    (((c[axis] - lo) * scale) as usize).min(bins - 1)
}

/// Reorders `v` so every element satisfying `left` comes first; returns how many do.
/// Hoare-style from both ends: only misplaced records (40 bytes each) are swapped.
fn partition<T>(v: &mut [T], mut left: impl FnMut(&T) -> bool) -> usize {
    let (mut i, mut j) = (0, v.len());
    loop {
        while i < j && left(&v[i]) {
            i += 1;
        }
        while i < j && !left(&v[j - 1]) {
            j -= 1;
        }
        if i == j {
            return i;
        }
        v.swap(i, j - 1);
        i += 1;
        j -= 1;
    }
}

/// A pending node of the top-down build.
struct Task {
    node: usize,
    start: usize,
    end: usize,
    depth: usize,
}

/// Scratch reused for every node of one build.
struct Binner {
    max_leaf: usize,
    /// Bins of axis `a` are `a * bins..(a + 1) * bins`.
    bin_bounds: Vec<Aabb>,
    bin_counts: Vec<u32>,
    /// Area and count of bins `plane..`, for each split plane.
    right: Vec<(f32, u32)>,
}

/// The best SAH split found so far.
#[derive(Clone, Copy)]
struct Split {
    /// Sum over both sides of item count times surface area.
    cost: f32,
    /// Difference of the side counts: breaks cost ties (all-flat input) toward balance.
    imbalance: u32,
    axis: usize,
    /// Bins `..plane` go left.
    plane: usize,
}

impl Binner {
    /// Partitions one node's records for a split and returns the size of the
    /// left part, or `None` to make the node a leaf. `bounds` and `cbounds` are
    /// the node's bounds and the bounds of its finite centroids.
    fn split(&mut self, recs: &mut [Record], bounds: &Aabb, cbounds: &Aabb, depth: usize) -> Option<usize> {
        let n = recs.len();
        if n <= 1 || (n <= self.max_leaf && depth >= COUNT_SPLIT_DEPTH) {
            return None;
        }
        if depth >= COUNT_SPLIT_DEPTH {
            return Some(median_split(recs, cbounds));
        }
        let extent = cbounds.extent();
        let bins = self.right.len();
        let scale = Vec3::splat(bins as f32) / extent;
        // Identical (or no finite) centroids along an axis: nothing to separate there.
        let active: [bool; 3] = std::array::from_fn(|a| extent[a] > 0.0 && scale[a].is_finite());
        self.bin_bounds.fill(Aabb::EMPTY);
        self.bin_counts.fill(0);
        // One pass bins all three axes: the records are read once, not three times.
        for r in recs.iter() {
            for axis in (0..3).filter(|&a| active[a]) {
                let b = axis * bins + bin_of(r.centroid, axis, cbounds.min[axis], scale[axis], bins);
                self.bin_counts[b] += 1;
                self.bin_bounds[b] = self.bin_bounds[b].union(r.bounds);
            }
        }
        let mut best: Option<Split> = None;
        for axis in (0..3).filter(|&a| active[a]) {
            let bin_bounds = &self.bin_bounds[axis * bins..(axis + 1) * bins];
            let bin_counts = &self.bin_counts[axis * bins..(axis + 1) * bins];
            let (mut acc, mut count) = (Aabb::EMPTY, 0);
            for plane in (1..bins).rev() {
                acc = acc.union(bin_bounds[plane]);
                count += bin_counts[plane];
                self.right[plane] = (acc.surface_area(), count);
            }
            let (mut acc, mut count) = (Aabb::EMPTY, 0);
            for plane in 1..bins {
                acc = acc.union(bin_bounds[plane - 1]);
                count += bin_counts[plane - 1];
                let (right_area, right_count) = self.right[plane];
                if count == 0 || right_count == 0 {
                    continue;
                }
                let cost = count as f32 * acc.surface_area() + right_count as f32 * right_area;
                if cost.is_nan() {
                    continue;
                }
                let imbalance = count.abs_diff(right_count);
                let better = match best {
                    None => true,
                    Some(b) => cost < b.cost || (cost == b.cost && imbalance < b.imbalance),
                };
                if better {
                    best = Some(Split {
                        cost,
                        imbalance,
                        axis,
                        plane,
                    });
                }
            }
        }

        if n <= self.max_leaf {
            let area = bounds.surface_area();
            // Split only when strictly cheaper: flat nodes and NaN costs (infinite boxes) stay leaves.
            match best {
                Some(b) if INNER_NODE_COST * area + b.cost < n as f32 * area => {}
                _ => return None,
            }
        }
        match best {
            Some(b) => {
                let (lo, scale) = (cbounds.min[b.axis], scale[b.axis]);
                let mid = partition(recs, |r| bin_of(r.centroid, b.axis, lo, scale, bins) < b.plane);
                debug_assert!(mid > 0 && mid < n, "SAH split left a side empty");
                Some(mid)
            }
            None => Some(median_split(recs, cbounds)),
        }
    }
}

/// Halves `recs` by count, ordered along the widest centroid axis when there is
/// one; used when centroids coincide (SAH cannot separate them) and below
/// [`COUNT_SPLIT_DEPTH`].
fn median_split(recs: &mut [Record], cbounds: &Aabb) -> usize {
    let mid = recs.len() / 2;
    let extent = cbounds.extent();
    let axis = extent.max_position();
    if extent[axis] > 0.0 && extent[axis].is_finite() {
        recs.select_nth_unstable_by(mid, |a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
    }
    mid
}

impl Bvh {
    /// Deepest tree [`Bvh::build`] produces; traversals rely on it for their fixed-size stacks.
    #[cfg(test)]
    pub const MAX_DEPTH: usize = MAX_DEPTH;

    /// Builds a hierarchy over `boxes`; item `i` is `boxes[i]`.
    ///
    /// Splits minimise the binned SAH over box centroids; items whose centroids
    /// coincide are split by count. Empty input gives a hierarchy with no nodes.
    /// Boxes that hold no point (inverted, NaN) are accepted: they are placed in
    /// some leaf but do not grow any node's bounds.
    ///
    /// # Panics
    /// If there are more than `u32::MAX` boxes.
    pub fn build(boxes: &[Aabb], config: &BvhConfig) -> Bvh {
        let n = boxes.len();
        assert!(
            u32::try_from(n).is_ok(),
            "a BVH holds at most {} items, got {n}",
            u32::MAX
        );
        let max_leaf = config.max_leaf_size.clamp(1, u32::MAX as usize);
        if n == 0 {
            return Bvh {
                max_leaf_size: max_leaf as u32,
                ..Bvh::default()
            };
        }
        let bins = config.bins.clamp(2, MAX_BINS);
        let mut binner = Binner {
            max_leaf,
            bin_bounds: vec![Aabb::EMPTY; 3 * bins],
            bin_counts: vec![0; 3 * bins],
            right: vec![(0.0, 0); bins],
        };
        let mut recs: Vec<Record> = boxes.iter().enumerate().map(|(i, b)| Record::new(i, b)).collect();
        let placeholder = BvhNode {
            bounds: Aabb::EMPTY,
            first: 0,
            count: 0,
        };
        let mut nodes = Vec::with_capacity(2 * n.div_ceil(max_leaf));
        nodes.push(placeholder);
        let mut depth = 0;
        // Explicit work stack: SAH trees on skewed input can be far deeper than the call stack likes.
        let mut work = vec![Task {
            node: 0,
            start: 0,
            end: n,
            depth: 1,
        }];
        while let Some(t) = work.pop() {
            depth = depth.max(t.depth);
            let range = &mut recs[t.start..t.end];
            let (mut bounds, mut cbounds) = (Aabb::EMPTY, Aabb::EMPTY);
            for r in range.iter() {
                bounds = bounds.union(r.bounds);
                if r.centroid.is_finite() {
                    cbounds = cbounds.grow(r.centroid);
                }
            }
            nodes[t.node] = match binner.split(range, &bounds, &cbounds, t.depth) {
                None => BvhNode {
                    bounds,
                    first: t.start as u32,
                    count: (t.end - t.start) as u32,
                },
                Some(left_len) => {
                    let first = nodes.len();
                    nodes.push(placeholder);
                    nodes.push(placeholder);
                    let mid = t.start + left_len;
                    // Left popped first: a subtree's nodes end up close together in memory.
                    work.push(Task {
                        node: first + 1,
                        start: mid,
                        end: t.end,
                        depth: t.depth + 1,
                    });
                    work.push(Task {
                        node: first,
                        start: t.start,
                        end: mid,
                        depth: t.depth + 1,
                    });
                    BvhNode {
                        bounds,
                        first: first as u32,
                        count: 0,
                    }
                }
            };
        }
        nodes.shrink_to_fit();
        Bvh {
            nodes,
            items: recs.iter().map(|r| r.id).collect(),
            max_leaf_size: max_leaf as u32,
            depth: depth as u32,
        }
    }

    /// Recomputes every node's bounds from `boxes` (the objects' current boxes),
    /// keeping the topology. Cheap enough to run every frame; the tree gets looser
    /// as objects drift from where they were at build time.
    ///
    /// # Panics
    /// If `boxes` does not have one box per item.
    #[cfg(test)]
    pub fn refit(&mut self, boxes: &[Aabb]) {
        self.refit_noting(boxes, |_| {});
    }

    /// Refits as `Bvh::refit` (tests) does, calling `changed(index)` for every node whose bounds
    /// changed (children before their parents): what per-node state kept
    /// across frames must forget.
    ///
    /// # Panics
    /// If `boxes` does not have one box per item.
    pub fn refit_noting(&mut self, boxes: &[Aabb], mut changed: impl FnMut(u32)) {
        assert_eq!(boxes.len(), self.items.len(), "refit needs one box per BVH item");
        // Children come after their parents, so a reverse pass sees children first.
        for i in (0..self.nodes.len()).rev() {
            let node = self.nodes[i];
            let bounds = if node.is_leaf() {
                self.leaf_items(&node)
                    .iter()
                    .fold(Aabb::EMPTY, |acc, &id| add(acc, &boxes[id as usize]))
            } else {
                let c = node.first as usize;
                self.nodes[c].bounds.union(self.nodes[c + 1].bounds)
            };
            if bounds != node.bounds {
                changed(i as u32);
            }
            self.nodes[i].bounds = bounds;
        }
    }

    /// Number of nodes (node 0 is the root; children come after their parents).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Bytes the tree holds on the heap (nodes and item list).
    pub(crate) fn heap_bytes(&self) -> usize {
        crate::vec_bytes(&self.nodes) + crate::vec_bytes(&self.items)
    }

    /// All nodes; node 0 is the root. Children come after their parents.
    pub fn nodes(&self) -> &[BvhNode] {
        &self.nodes
    }

    /// Item ids (indices into the build's boxes) in leaf order.
    pub fn items(&self) -> &[u32] {
        &self.items
    }

    /// The items of a leaf of this hierarchy; empty for an inner node.
    pub fn leaf_items(&self, node: &BvhNode) -> &[u32] {
        if node.is_leaf() {
            &self.items[node.first as usize..(node.first + node.count) as usize]
        } else {
            &[]
        }
    }

    /// Every item below a node of this hierarchy (the node's own items for a
    /// leaf). Subtrees hold contiguous item ranges, so this is a slice and costs
    /// one walk down each edge of the subtree.
    pub fn subtree_items(&self, node: &BvhNode) -> &[u32] {
        &self.items[self.subtree_range(node)]
    }

    /// Where [`Bvh::subtree_items`] lies in [`Bvh::items`].
    pub(crate) fn subtree_range(&self, node: &BvhNode) -> Range<usize> {
        let mut lo = node;
        while !lo.is_leaf() {
            lo = &self.nodes[lo.first as usize];
        }
        let mut hi = node;
        while !hi.is_leaf() {
            hi = &self.nodes[hi.first as usize + 1];
        }
        lo.first as usize..(hi.first + hi.count) as usize
    }

    /// True when the hierarchy holds no items (and no nodes).
    #[cfg(test)]
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Nodes on the longest root-to-leaf path: 0 when empty, 1 for a lone leaf.
    /// Never more than [`Bvh::MAX_DEPTH`].
    #[cfg(test)]
    pub fn depth(&self) -> usize {
        self.depth as usize
    }

    /// Appends to `out` the ids of items whose box is not
    /// [`Containment::Outside`] `frustum`; returns the number of box tests made
    /// (node tests plus item tests).
    ///
    /// A node wholly inside has its whole subtree appended without further
    /// tests; items of intersecting leaves are tested one by one against
    /// `boxes[id]`. For non-empty boxes the result equals a linear scan with
    /// [`Frustum::test_aabb`] (the test is monotone under box containment).
    /// Items with empty boxes are reported only if a subtree holding them is
    /// wholly inside. Output order follows the tree, not the ids.
    pub fn frustum_cull(&self, boxes: &[Aabb], frustum: &Frustum, out: &mut Vec<u32>) -> u64 {
        if self.nodes.is_empty() {
            return 0;
        }
        debug_assert_eq!(boxes.len(), self.items.len(), "one box per BVH item");
        let mut stack = [0u32; MAX_DEPTH];
        let mut len = 1;
        let mut tests = 0u64;
        while len > 0 {
            len -= 1;
            let node = &self.nodes[stack[len] as usize];
            tests += 1;
            match frustum.test_aabb(&node.bounds) {
                Containment::Outside => {}
                Containment::Inside => out.extend_from_slice(self.subtree_items(node)),
                Containment::Intersecting if node.is_leaf() => {
                    let ids = self.leaf_items(node);
                    tests += ids.len() as u64;
                    out.extend(
                        ids.iter()
                            .copied()
                            .filter(|&id| frustum.test_aabb(&boxes[id as usize]) != Containment::Outside),
                    );
                }
                Containment::Intersecting => {
                    // At most one pending sibling per level, so depth bounds the stack.
                    stack[len] = node.first + 1;
                    stack[len + 1] = node.first;
                    len += 2;
                }
            }
        }
        tests
    }

    /// Appends the items of every leaf whose bounds intersect `query`: a
    /// superset of the items whose own boxes intersect it (the hierarchy keeps
    /// no per-item boxes), so callers filter the candidates with their boxes.
    /// Order follows the tree.
    pub fn overlapping(&self, query: &Aabb, out: &mut Vec<u32>) {
        if self.nodes.is_empty() || query.is_empty() {
            return;
        }
        let mut stack = [0u32; MAX_DEPTH];
        let mut len = 1;
        while len > 0 {
            len -= 1;
            let node = &self.nodes[stack[len] as usize];
            if !node.bounds.intersects(query) {
                continue;
            }
            if node.is_leaf() {
                out.extend_from_slice(self.leaf_items(node));
            } else {
                stack[len] = node.first + 1;
                stack[len + 1] = node.first;
                len += 2;
            }
        }
    }

    /// Depth-first walk, nearer child first: `visit(index, node, state)` is
    /// called on the root with `root`, and on both children of every visited
    /// inner node for which it returned `Some(child_state)`, with that state.
    /// Of two children, the one nearer to `eye` ([`View::nearness`], ties
    /// broken by the box centre's) is visited, with its whole subtree, before
    /// the other.
    ///
    /// This is the order occlusion cullers want: near nodes are tested (and
    /// their leaves drawn as occluders) before the nodes they may hide. The
    /// state carries what a parent learnt for its children (a frustum
    /// culler's "wholly inside"). For a leaf, the return value is ignored;
    /// use [`Bvh::leaf_items`] to reach its items.
    #[cfg(test)]
    pub fn traverse_front_to_back<S: Copy>(
        &self,
        eye: &Eye,
        root: S,
        mut visit: impl FnMut(u32, &BvhNode, S) -> Option<S>,
    ) {
        self.walk_front_to_back(eye, root, &mut (), |_, i, n, s| visit(i, n, s), |_, _, _| {});
    }

    /// `Bvh::traverse_front_to_back` (tests) that also calls `leave(context, index,
    /// node)` on every inner node it opened (`enter` returned `Some`), once
    /// both of its subtrees are done: a post-order step for state that
    /// children pull up into their parent. Both callbacks get `context`.
    pub fn walk_front_to_back<S: Copy, C>(
        &self,
        eye: &Eye,
        root: S,
        context: &mut C,
        mut enter: impl FnMut(&mut C, u32, &BvhNode, S) -> Option<S>,
        mut leave: impl FnMut(&mut C, u32, &BvhNode),
    ) {
        if self.nodes.is_empty() {
            return;
        }
        /// A node to enter, or an opened one to leave.
        #[derive(Clone, Copy)]
        enum Step<S> {
            Enter(u32, S),
            Leave(u32),
        }
        // Per level at most a pending sibling and a parent to leave.
        let mut stack = [Step::Leave(0); 2 * MAX_DEPTH + 1];
        stack[0] = Step::Enter(0, root);
        let mut len = 1;
        while len > 0 {
            len -= 1;
            let (index, state) = match stack[len] {
                Step::Enter(index, state) => (index, state),
                Step::Leave(index) => {
                    leave(context, index, &self.nodes[index as usize]);
                    continue;
                }
            };
            let node = &self.nodes[index as usize];
            let Some(child) = enter(context, index, node, state) else {
                continue;
            };
            if node.is_leaf() {
                continue;
            }
            let (a, b) = (node.first, node.first + 1);
            let (near, far) = if nearer(eye, &self.nodes[b as usize].bounds, &self.nodes[a as usize].bounds) {
                (b, a)
            } else {
                (a, b)
            };
            stack[len] = Step::Leave(index);
            stack[len + 1] = Step::Enter(far, child);
            stack[len + 2] = Step::Enter(near, child);
            len += 3;
        }
    }

    /// Checks every structural invariant against `boxes` (the boxes of the last
    /// build or refit) and panics with a message naming the first violation:
    /// node bounds that do not hold their children's bounds or their items'
    /// boxes, items missing or repeated, child indices out of range or not after
    /// their parent, nodes with no or two parents, leaves larger than the build's
    /// `max_leaf_size`, subtrees whose items are not contiguous, a wrong depth.
    ///
    /// Meant for tests and debugging: it allocates and is linear in the tree size.
    #[cfg(test)]
    pub fn assert_well_formed(&self, boxes: &[Aabb]) {
        let n_items = self.items.len();
        assert_eq!(
            boxes.len(),
            n_items,
            "BVH has {n_items} items but {} boxes were given",
            boxes.len()
        );
        if self.nodes.is_empty() {
            assert!(n_items == 0, "BVH has no nodes but {n_items} items");
            assert_eq!(self.depth, 0, "empty BVH has depth {}", self.depth);
            return;
        }
        let mut seen = vec![false; n_items];
        for (slot, &id) in self.items.iter().enumerate() {
            assert!(
                (id as usize) < n_items,
                "item slot {slot} holds id {id}, but there are only {n_items} items"
            );
            assert!(!seen[id as usize], "item {id} appears more than once");
            seen[id as usize] = true;
        }
        // n_items distinct ids below n_items: each appears exactly once.

        let n_nodes = self.nodes.len();
        let mut parent = vec![u32::MAX; n_nodes];
        let mut level = vec![0usize; n_nodes];
        level[0] = 1;
        let mut covered = vec![false; n_items];
        for (i, node) in self.nodes.iter().enumerate() {
            // Parents precede children, so by now every non-root node was claimed.
            assert!(
                i == 0 || parent[i] != u32::MAX,
                "node {i} is not a child of any node before it"
            );
            assert!(
                level[i] <= MAX_DEPTH,
                "node {i} is at depth {}, deeper than {MAX_DEPTH}",
                level[i]
            );
            if node.is_leaf() {
                assert!(
                    node.count <= self.max_leaf_size,
                    "leaf {i} holds {} items, more than max_leaf_size {}",
                    node.count,
                    self.max_leaf_size
                );
                let end = node.first as usize + node.count as usize;
                assert!(
                    end <= n_items,
                    "leaf {i} covers item slots {}..{end}, but there are only {n_items}",
                    node.first
                );
                let start = node.first as usize;
                let slots = covered[start..end].iter_mut().zip(&self.items[start..end]);
                for (k, (covered, &id)) in slots.enumerate() {
                    let slot = start + k;
                    assert!(!*covered, "item slot {slot} is in two leaves (second: {i})");
                    *covered = true;
                    let b = &boxes[id as usize];
                    assert!(
                        node.bounds.contains(b),
                        "leaf {i} bounds {:?} do not contain item {id}'s box {b:?}",
                        node.bounds
                    );
                }
            } else {
                let c = node.first as usize;
                assert!(
                    c > i && c + 1 < n_nodes,
                    "inner node {i} has children {c} and {}: must be after it and below {n_nodes}",
                    c + 1
                );
                for child in [c, c + 1] {
                    assert!(
                        parent[child] == u32::MAX,
                        "node {child} is a child of both {} and {i}",
                        parent[child]
                    );
                    parent[child] = i as u32;
                    level[child] = level[i] + 1;
                    let cb = &self.nodes[child].bounds;
                    assert!(
                        node.bounds.contains(cb),
                        "node {i} bounds {:?} do not contain child {child}'s bounds {cb:?}",
                        node.bounds
                    );
                }
            }
        }
        if let Some(slot) = covered.iter().position(|&c| !c) {
            panic!("item slot {slot} is in no leaf");
        }
        let deepest = level.iter().copied().max().unwrap_or(0);
        assert_eq!(
            self.depth as usize, deepest,
            "recorded depth {} but the deepest node is at depth {deepest}",
            self.depth
        );
        // Contiguous subtree items are what make `subtree_items` (and the Inside shortcut) correct.
        let mut ranges = vec![0..0; n_nodes];
        for i in (0..n_nodes).rev() {
            let node = &self.nodes[i];
            ranges[i] = if node.is_leaf() {
                node.first as usize..(node.first + node.count) as usize
            } else {
                let (l, r) = (&ranges[node.first as usize], &ranges[node.first as usize + 1]);
                assert_eq!(
                    l.end, r.start,
                    "inner node {i}: items of its children are not contiguous ({l:?}, {r:?})"
                );
                l.start..r.end
            };
            assert_eq!(
                self.subtree_range(node),
                ranges[i],
                "node {i}: subtree item range is wrong"
            );
        }
        assert_eq!(ranges[0], 0..n_items, "root does not cover every item slot");
    }
}

/// True when box `b` is strictly nearer to `eye` than box `a` (so `b` goes first).
fn nearer(eye: &Eye, b: &Aabb, a: &Aabb) -> bool {
    let (db, da) = (View::nearness(eye, b), View::nearness(eye, a));
    let centre = |x: &Aabb| View::nearness(eye, &Aabb::new(x.center(), x.center()));
    db < da || (db == da && centre(b) < centre(a))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::Camera;
    use proptest::prelude::*;

    fn vec3(r: std::ops::Range<f32>) -> impl Strategy<Value = Vec3> {
        (r.clone(), r.clone(), r).prop_map(|(x, y, z)| Vec3::new(x, y, z))
    }

    /// Mostly ordinary boxes, plus points, flat boxes and many copies of one box.
    fn arb_box() -> impl Strategy<Value = Aabb> {
        prop_oneof![
            6 => (vec3(-50.0..50.0), vec3(0.0..5.0)).prop_map(|(c, h)| Aabb::new(c - h, c + h)),
            1 => vec3(-50.0..50.0).prop_map(|c| Aabb::new(c, c)),
            1 => (vec3(-50.0..50.0), 0.0f32..5.0, 0usize..3).prop_map(|(c, h, axis)| {
                let mut e = Vec3::splat(h);
                e[axis] = 0.0;
                Aabb::new(c - e, c + e)
            }),
            1 => Just(Aabb::new(Vec3::splat(1.0), Vec3::splat(2.0))),
        ]
    }

    fn arb_config() -> impl Strategy<Value = BvhConfig> {
        (0usize..9, 0usize..40).prop_map(|(max_leaf_size, bins)| BvhConfig { max_leaf_size, bins })
    }

    /// Valid cameras anywhere from inside the scene to far enough away to see all of it.
    fn arb_frustum() -> impl Strategy<Value = Frustum> {
        let up = prop_oneof![Just(Vec3::Y), Just(Vec3::Z), vec3(-1.0..1.0)];
        (
            vec3(-200.0..200.0),
            vec3(-60.0..60.0),
            up,
            5.0f32..150.0,
            0.01f32..5.0,
            1.0f32..500.0,
            1u32..300,
            1u32..300,
        )
            .prop_filter_map("invalid camera", |(eye, target, up, fov, near, depth, w, h)| {
                Camera::new(eye, target, up, fov.to_radians(), near, near + depth, w, h).frustum()
            })
    }

    fn linear_scan(boxes: &[Aabb], f: &Frustum) -> Vec<u32> {
        (0..boxes.len() as u32)
            .filter(|&i| f.test_aabb(&boxes[i as usize]) != Containment::Outside)
            .collect()
    }

    fn cull_sorted(bvh: &Bvh, boxes: &[Aabb], f: &Frustum) -> (Vec<u32>, u64) {
        let mut out = vec![u32::MAX]; // must be appended to, not cleared
        let tests = bvh.frustum_cull(boxes, f, &mut out);
        assert_eq!(out.remove(0), u32::MAX);
        out.sort_unstable();
        (out, tests)
    }

    /// Checks the front-to-back contract with an always-true visitor, and
    /// that the walk leaves each inner node once, after its whole subtree.
    fn check_front_to_back(bvh: &Bvh, eye: Vec3) {
        let mut order = Vec::new();
        let mut seen_items = Vec::new();
        bvh.traverse_front_to_back(&Eye::Point(eye), (), |i, node, ()| {
            assert_eq!(bvh.nodes()[i as usize], *node);
            order.push(i);
            seen_items.extend_from_slice(bvh.leaf_items(node));
            Some(())
        });
        // (entered, left) per node, in the order of events.
        let mut events = Vec::new();
        bvh.walk_front_to_back(
            &Eye::Point(eye),
            (),
            &mut events,
            |e, i, _, ()| {
                e.push((i, true));
                Some(())
            },
            |e, i, node| {
                assert!(!node.is_leaf(), "leaves are not left");
                e.push((i, false));
            },
        );
        let entered: Vec<u32> = events.iter().filter(|e| e.1).map(|e| e.0).collect();
        assert_eq!(entered, order, "the walk enters in the traversal's order");
        let at = |i: u32, entering: bool| events.iter().position(|&e| e == (i, entering));
        for (i, node) in bvh.nodes().iter().enumerate() {
            let left = at(i as u32, false);
            assert_eq!(left.is_some(), !node.is_leaf(), "node {i}");
            if let Some(left) = left {
                for c in [node.first, node.first + 1] {
                    let last_below = at(c, false).or(at(c, true)).unwrap();
                    assert!(last_below < left, "node {i} left before its child {c}");
                }
            }
        }
        assert_eq!(order.len(), bvh.nodes().len(), "every node visited once");
        seen_items.sort_unstable();
        assert_eq!(seen_items, (0..bvh.items().len() as u32).collect::<Vec<_>>());
        let mut pos = vec![usize::MAX; bvh.nodes().len()];
        for (k, &i) in order.iter().enumerate() {
            pos[i as usize] = k;
        }
        // Subtree sizes, to check each near subtree is finished before its far sibling starts.
        let mut size = vec![1usize; bvh.nodes().len()];
        for i in (0..bvh.nodes().len()).rev() {
            let n = bvh.nodes()[i];
            if !n.is_leaf() {
                size[i] += size[n.first as usize] + size[n.first as usize + 1];
            }
        }
        for (i, n) in bvh.nodes().iter().enumerate() {
            if n.is_leaf() {
                continue;
            }
            let (a, b) = (n.first as usize, n.first as usize + 1);
            let (ba, bb) = (bvh.nodes()[a].bounds, bvh.nodes()[b].bounds);
            let (da, db) = (ba.distance_squared(eye), bb.distance_squared(eye));
            let b_first =
                db < da || (db == da && (bb.center() - eye).length_squared() < (ba.center() - eye).length_squared());
            let (near, far) = if b_first { (b, a) } else { (a, b) };
            assert_eq!(pos[near], pos[i] + 1, "node {i}: nearer child {near} not visited next");
            assert_eq!(
                pos[far],
                pos[near] + size[near],
                "node {i}: far child {far} not right after the near subtree"
            );
        }
    }

    proptest! {
        #[test]
        fn partition_puts_matching_elements_first(mut v in prop::collection::vec(0u8..10, 0..100), k in 0u8..11) {
            let mut sorted = v.clone();
            sorted.sort_unstable();
            let mid = partition(&mut v, |&x| x < k);
            prop_assert!(v[..mid].iter().all(|&x| x < k) && v[mid..].iter().all(|&x| x >= k));
            v.sort_unstable();
            prop_assert_eq!(v, sorted);
        }

        #[test]
        fn build_is_well_formed(boxes in prop::collection::vec(arb_box(), 0..300), config in arb_config()) {
            let bvh = Bvh::build(&boxes, &config);
            bvh.assert_well_formed(&boxes);
            prop_assert_eq!(bvh.is_empty(), boxes.is_empty());
            prop_assert!(bvh.depth() <= Bvh::MAX_DEPTH);
            if let Some(root) = bvh.nodes().first() {
                let all = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(*b));
                prop_assert_eq!(root.bounds, all, "build bounds are tight");
            }
        }

        #[test]
        fn frustum_cull_matches_linear_scan(
            boxes in prop::collection::vec(arb_box(), 0..300),
            config in arb_config(),
            frusta in prop::collection::vec(arb_frustum(), 1..6),
        ) {
            let bvh = Bvh::build(&boxes, &config);
            for f in &frusta {
                let (got, tests) = cull_sorted(&bvh, &boxes, f);
                prop_assert_eq!(&got, &linear_scan(&boxes, f));
                prop_assert!(tests <= (bvh.nodes().len() + boxes.len()) as u64);
                prop_assert_eq!(tests == 0, boxes.is_empty());
            }
        }

        #[test]
        fn refit_after_motion_matches_linear_scan(
            moving in prop::collection::vec((arb_box(), vec3(-40.0..40.0), 0.2f32..3.0), 0..300),
            frustum in arb_frustum(),
        ) {
            let boxes: Vec<Aabb> = moving.iter().map(|m| m.0).collect();
            let mut bvh = Bvh::build(&boxes, &BvhConfig::default());
            let items = bvh.items().to_vec();
            let moved: Vec<Aabb> = moving
                .iter()
                .map(|(b, d, s)| {
                    let (c, h) = (b.center() + *d, b.half_extent() * *s);
                    Aabb::new(c - h, c + h)
                })
                .collect();
            let before = bvh.nodes().to_vec();
            let mut changed = Vec::new();
            bvh.refit_noting(&moved, |i| changed.push(i));
            bvh.assert_well_formed(&moved);
            changed.sort_unstable();
            let differ: Vec<u32> = (0..before.len() as u32)
                .filter(|&i| before[i as usize].bounds != bvh.nodes()[i as usize].bounds)
                .collect();
            prop_assert_eq!(changed, differ, "refit notes exactly the nodes it changed");
            prop_assert_eq!(bvh.items(), &items[..], "refit keeps the topology");
            if let Some(root) = bvh.nodes().first() {
                let all = moved.iter().fold(Aabb::EMPTY, |a, b| a.union(*b));
                prop_assert_eq!(root.bounds, all, "refit bounds are tight");
            }
            prop_assert_eq!(cull_sorted(&bvh, &moved, &frustum).0, linear_scan(&moved, &frustum));
        }

        #[test]
        fn overlapping_returns_a_superset_of_the_exact_answer(
            boxes in prop::collection::vec(arb_box(), 0..300),
            config in arb_config(),
            query in arb_box(),
        ) {
            let bvh = Bvh::build(&boxes, &config);
            let mut got = Vec::new();
            bvh.overlapping(&query, &mut got);
            got.sort_unstable();
            let n = got.len();
            got.dedup();
            prop_assert_eq!(got.len(), n, "no item reported twice");
            for (i, b) in boxes.iter().enumerate() {
                if b.intersects(&query) {
                    prop_assert!(got.binary_search(&(i as u32)).is_ok(), "item {} missed", i);
                }
            }
            // Candidates come from leaves that touch the query, nothing else.
            for n in bvh.nodes().iter().filter(|n| n.is_leaf() && !n.bounds.intersects(&query)) {
                for id in bvh.leaf_items(n) {
                    prop_assert!(got.binary_search(id).is_err());
                }
            }
        }

        #[test]
        fn front_to_back_visits_every_item_once_nearer_child_first(
            boxes in prop::collection::vec(arb_box(), 0..300),
            config in arb_config(),
            eye in vec3(-80.0..80.0),
        ) {
            let bvh = Bvh::build(&boxes, &config);
            check_front_to_back(&bvh, eye);
        }

        #[test]
        fn empty_and_non_finite_boxes_do_not_break_anything(
            boxes in prop::collection::vec(
                prop_oneof![
                    4 => arb_box(),
                    1 => Just(Aabb::EMPTY),
                    1 => vec3(-50.0..50.0).prop_map(|c| Aabb { min: c + 1.0, max: c }),
                    1 => Just(Aabb { min: Vec3::NAN, max: Vec3::NAN }),
                    1 => vec3(-50.0..50.0).prop_map(|c| Aabb { min: c, max: Vec3::new(c.x, f32::INFINITY, c.z) }),
                ],
                0..200,
            ),
            frustum in arb_frustum(),
            eye in vec3(-80.0..80.0),
        ) {
            let mut bvh = Bvh::build(&boxes, &BvhConfig::default());
            bvh.assert_well_formed(&boxes);
            bvh.refit(&boxes);
            bvh.assert_well_formed(&boxes);
            check_front_to_back(&bvh, eye);
            // Only boxes that hold points have a defined answer.
            let (got, _) = cull_sorted(&bvh, &boxes, &frustum);
            let keep = |v: Vec<u32>| -> Vec<u32> {
                v.into_iter().filter(|&i| !boxes[i as usize].is_empty()).collect()
            };
            prop_assert_eq!(keep(got), keep(linear_scan(&boxes, &frustum)));
        }
    }

    fn grid(n: usize) -> Vec<Aabb> {
        let mut boxes = Vec::new();
        for x in 0..n {
            for y in 0..n {
                for z in 0..n {
                    let c = Vec3::new(x as f32, y as f32, z as f32) * 3.0;
                    boxes.push(Aabb::new(c - 0.5, c + 0.5));
                }
            }
        }
        boxes
    }

    #[test]
    fn sah_depth_on_grid_is_logarithmic() {
        let boxes = grid(10);
        let bvh = Bvh::build(&boxes, &BvhConfig::default());
        bvh.assert_well_formed(&boxes);
        let bound = 2.0 * (boxes.len() as f32).log2() + 4.0;
        assert!(bvh.depth() as f32 <= bound, "depth {} > {bound}", bvh.depth());
        // Separated unit boxes: SAH fills leaves rather than making a node per box.
        let leaves = bvh.nodes().iter().filter(|n| n.is_leaf()).count();
        assert!(leaves <= boxes.len() / 2, "{leaves} leaves for {} boxes", boxes.len());
    }

    #[test]
    fn assert_well_formed_catches_corruption() {
        let boxes = grid(4);
        let good = Bvh::build(&boxes, &BvhConfig::default());
        good.assert_well_formed(&boxes);
        let inner = good.nodes().iter().position(|n| !n.is_leaf()).unwrap();
        let leaf = good.nodes().iter().position(|n| n.is_leaf()).unwrap();
        type Corrupt = Box<dyn Fn(&mut Bvh)>;
        let corruptions: Vec<(&str, Corrupt)> = vec![
            ("duplicate item", Box::new(|b| b.items[1] = b.items[0])),
            ("shrunk leaf", Box::new(move |b| b.nodes[leaf].bounds.max -= 0.25)),
            ("shrunk inner", Box::new(move |b| b.nodes[inner].bounds.max -= 0.25)),
            ("child before parent", Box::new(move |b| b.nodes[inner + 1].first = 0)),
            ("leaf too big", Box::new(|b| b.max_leaf_size = 1)),
            ("wrong depth", Box::new(|b| b.depth += 1)),
        ];
        for (what, corrupt) in corruptions {
            let mut bad = good.clone();
            corrupt(&mut bad);
            let caught = std::panic::catch_unwind(|| bad.assert_well_formed(&boxes));
            assert!(caught.is_err(), "{what} not detected");
        }
        let moved: Vec<Aabb> = boxes.iter().map(|b| Aabb::new(b.min + 1.0, b.max + 1.0)).collect();
        assert!(
            std::panic::catch_unwind(|| good.assert_well_formed(&moved)).is_err(),
            "stale bounds not detected"
        );
    }

    #[test]
    fn empty_input_gives_empty_bvh() {
        let bvh = Bvh::build(&[], &BvhConfig::default());
        assert!(bvh.is_empty());
        assert_eq!(bvh.depth(), 0);
        assert!(bvh.nodes().is_empty() && bvh.items().is_empty());
        bvh.assert_well_formed(&[]);
        let f = Camera::new(Vec3::Z, Vec3::ZERO, Vec3::Y, 1.0, 0.1, 10.0, 8, 8)
            .frustum()
            .unwrap();
        let mut out = Vec::new();
        assert_eq!(bvh.frustum_cull(&[], &f, &mut out), 0);
        assert!(out.is_empty());
        bvh.traverse_front_to_back(&Eye::Point(Vec3::ZERO), (), |_, _, ()| panic!("no nodes to visit"));
        let mut default = Bvh::default();
        default.refit(&[]);
        default.assert_well_formed(&[]);
    }

    #[test]
    fn identical_boxes_are_split_by_count() {
        let boxes = vec![Aabb::new(Vec3::ZERO, Vec3::ONE); 1000];
        let bvh = Bvh::build(&boxes, &BvhConfig::default());
        bvh.assert_well_formed(&boxes);
        assert!(bvh.depth() <= 10, "depth {}", bvh.depth());
        assert!(bvh.nodes().iter().all(|n| !n.is_leaf() || n.count <= 4));
    }

    #[test]
    fn collinear_points_give_a_balanced_tree() {
        // Every SAH cost is 0 here; ties must go to balanced splits, not 1 : n-1.
        let boxes: Vec<Aabb> = (0..4096)
            .map(|i| Aabb::new(Vec3::X * i as f32, Vec3::X * i as f32))
            .collect();
        let bvh = Bvh::build(&boxes, &BvhConfig::default());
        bvh.assert_well_formed(&boxes);
        assert!(bvh.depth() <= 2 * 12 + 4, "depth {}", bvh.depth());
    }

    #[test]
    fn skewed_input_stays_within_max_depth() {
        // Exponential spacing makes SAH peel off one box at a time.
        let boxes: Vec<Aabb> = (0..400)
            .map(|i| {
                let c = Vec3::X * 1.1f32.powi(i);
                Aabb::new(c - 0.01, c + 0.01)
            })
            .collect();
        let bvh = Bvh::build(
            &boxes,
            &BvhConfig {
                max_leaf_size: 1,
                bins: 4,
            },
        );
        bvh.assert_well_formed(&boxes);
        assert!(bvh.depth() <= Bvh::MAX_DEPTH);
        check_front_to_back(&bvh, Vec3::ZERO);
    }

    #[test]
    fn depth_is_capped_on_pathological_input() {
        // Doubling spacing with two bins peels one or two boxes per level: without the cap, depth > 128.
        let boxes: Vec<Aabb> = (-120..127)
            .map(|i| Aabb::new(Vec3::X * 2f32.powi(i), Vec3::X * 2f32.powi(i)))
            .collect();
        let bvh = Bvh::build(
            &boxes,
            &BvhConfig {
                max_leaf_size: 1,
                bins: 2,
            },
        );
        bvh.assert_well_formed(&boxes);
        assert!(
            bvh.depth() > COUNT_SPLIT_DEPTH && bvh.depth() <= COUNT_SPLIT_DEPTH + 6,
            "depth {}",
            bvh.depth()
        );
        check_front_to_back(&bvh, Vec3::ZERO);
        let f = Camera::new(Vec3::new(0.0, 0.0, 10.0), Vec3::ZERO, Vec3::Y, 1.0, 0.1, 1e6, 64, 64)
            .frustum()
            .unwrap();
        assert_eq!(cull_sorted(&bvh, &boxes, &f).0, linear_scan(&boxes, &f));
    }

    #[test]
    fn subtree_wholly_inside_is_emitted_with_one_test() {
        let boxes = grid(6);
        let bvh = Bvh::build(&boxes, &BvhConfig::default());
        let cam = Camera::new(
            Vec3::new(7.5, 7.5, 200.0),
            Vec3::splat(7.5),
            Vec3::Y,
            1.0,
            1.0,
            1000.0,
            64,
            64,
        );
        let f = cam.frustum().unwrap();
        let (got, tests) = cull_sorted(&bvh, &boxes, &f);
        assert_eq!(got, (0..boxes.len() as u32).collect::<Vec<_>>());
        assert_eq!(tests, 1);
        assert_eq!(bvh.subtree_items(&bvh.nodes()[0]), bvh.items());
    }

    #[test]
    fn visitor_returning_false_prunes_the_subtree() {
        let boxes = grid(4);
        let bvh = Bvh::build(&boxes, &BvhConfig::default());
        let mut visited = 0;
        bvh.traverse_front_to_back(&Eye::Point(Vec3::splat(-10.0)), (), |_, _, ()| {
            visited += 1;
            None
        });
        assert_eq!(visited, 1);
        // Near the grid's first corner, the first leaf reached holds the box at that corner.
        let mut first_leaf = None;
        bvh.traverse_front_to_back(&Eye::Point(Vec3::splat(-10.0)), (), |_, n, ()| {
            if n.is_leaf() && first_leaf.is_none() {
                first_leaf = Some(bvh.leaf_items(n).to_vec());
            }
            Some(())
        });
        assert!(first_leaf.unwrap().contains(&0));
    }
}
