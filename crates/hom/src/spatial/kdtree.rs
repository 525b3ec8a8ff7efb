//! kD-tree with ropes over object boxes: the hierarchy of J. Bittner and
//! V. Havran, "Exploiting coherence in hierarchical visibility algorithms"
//! (Journal of Visualization and Computer Animation 13, 2002), section
//! "Hierarchical Visibility Culling" (each node an axis-aligned box; each
//! leaf refers to every object whose box intersects it), with the neighbour
//! links of V. Havran, J. Bittner and J. Žára, "Ray tracing with rope trees"
//! (Spring Conference on Computer Graphics, 1998) that its section "Visibility
//! Propagation" walks.
//!
//! - **Build**: top-down, binned surface area heuristic over the objects'
//!   boxes clipped to the node (an object straddling the plane goes to both
//!   children), deterministic; a node becomes a leaf at `max_leaf_size`
//!   objects, at `max_depth`, or when no split is cheaper than the leaf (a
//!   node over `max_leaf_size` is split whenever a split separates anything).
//!   Split planes lie strictly inside their node, so no node is flat along its
//!   split axis.
//! - **Ropes**: six per node, one per face (`2 * axis + side`, side 0 the
//!   face at `min`, 1 at `max`): the smallest node whose box contains the
//!   whole face, on the other side of it; [`NONE`] at the scene's boundary.
//!   Built top-down as rope trees are: children inherit their parent's ropes
//!   except on the split face, where they point at each other; then each rope
//!   is pushed down while a child of its target still holds the whole face.
//!   The nodes holding a face form a chain (kD-tree boxes are nested or
//!   disjoint), so this reaches the deepest one.
//!
//! Nodes are stored depth first, children adjacent; a subtree's object
//! references are one contiguous (duplicate-holding) range of [`KdTree::items`].

use crate::geom::{Aabb, Eye};

/// No node: a rope at the scene's boundary, the root's parent.
pub(crate) const NONE: u32 = u32::MAX;

/// SAH bins per axis.
const BINS: usize = 16;

/// SAH cost of visiting an inner node, in object tests.
const TRAVERSAL_COST: f32 = 1.0;

/// Build settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct KdConfig {
    /// Most objects a leaf holds before it is split when a split separates any (0 is taken as 1).
    pub max_leaf_size: usize,
    /// Deepest leaf (root = depth 0); also at most `8 + 1.3 log2(objects)`, the usual
    /// bound that keeps duplication in check.
    pub max_depth: u32,
}

impl Default for KdConfig {
    fn default() -> Self {
        KdConfig {
            max_leaf_size: 4,
            max_depth: 24,
        }
    }
}

/// One node of a [`KdTree`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct KdNode {
    /// The node's region.
    pub bounds: Aabb,
    /// Split axis (0, 1, 2) of an inner node; 3 for a leaf.
    pub axis: u8,
    /// Split plane coordinate (inner nodes), strictly inside `bounds` on `axis`.
    pub split: f32,
    /// First child (the one below the plane); the other is `child + 1`. [`NONE`] for a leaf.
    pub child: u32,
    /// Parent; [`NONE`] for the root.
    pub parent: u32,
    /// This subtree's object references: `items[start..end]`.
    pub start: u32,
    /// End of the subtree's references.
    pub end: u32,
    /// Per face `2 * axis + side`: the deepest node holding the whole face beyond it, or [`NONE`].
    pub ropes: [u32; 6],
    /// Root = 0.
    pub depth: u32,
}

impl KdNode {
    /// True for a leaf.
    pub fn is_leaf(&self) -> bool {
        self.axis == 3
    }

    /// Face `face` (`2 * axis + side`) as a flat box.
    pub fn face(&self, face: usize) -> Aabb {
        face_of(&self.bounds, face)
    }
}

/// Face `face` (`2 * axis + side`) of `b` as a flat box.
pub(crate) fn face_of(b: &Aabb, face: usize) -> Aabb {
    let (axis, side) = (face / 2, face % 2);
    let plane = if side == 0 { b.min[axis] } else { b.max[axis] };
    let mut f = *b;
    f.min[axis] = plane;
    f.max[axis] = plane;
    f
}

/// The faces of `b` turned towards `eye` (at most three, as `2 * axis + side`);
/// none when a point eye lies in the closed box or on the plane of any of its
/// faces, where "turned towards" is not robust.
pub(crate) fn front_faces(b: &Aabb, eye: &Eye) -> ([usize; 3], usize) {
    let (mut faces, mut n) = ([0; 3], 0);
    for axis in 0..3 {
        let side = match eye {
            Eye::Point(p) => {
                if p[axis] == b.min[axis] || p[axis] == b.max[axis] {
                    return ([0; 3], 0);
                }
                if p[axis] < b.min[axis] {
                    Some(0)
                } else if p[axis] > b.max[axis] {
                    Some(1)
                } else {
                    None
                }
            }
            // Depth grows along d: the faces it enters through are turned towards the viewer.
            Eye::Direction(d) if d[axis] > 0.0 => Some(0),
            Eye::Direction(d) if d[axis] < 0.0 => Some(1),
            Eye::Direction(_) => None,
        };
        if let Some(s) = side {
            faces[n] = 2 * axis + s;
            n += 1;
        }
    }
    (faces, n)
}

/// A kD-tree with ropes over object boxes; see the module docs.
#[derive(Clone, Debug, Default)]
pub(crate) struct KdTree {
    nodes: Vec<KdNode>,
    items: Vec<u32>,
}

/// One object during the build: its box and id.
#[derive(Clone, Copy)]
struct Item {
    bounds: Aabb,
    id: u32,
}

impl KdTree {
    /// Bytes the tree holds on the heap (nodes with their ropes, item list).
    pub fn heap_bytes(&self) -> usize {
        crate::vec_bytes(&self.nodes) + crate::vec_bytes(&self.items)
    }

    /// The tree over the objects `ids` with boxes `boxes[id]`; ids whose box
    /// is empty or not finite are left out (the caller tests them itself).
    pub fn build(boxes: &[Aabb], ids: impl IntoIterator<Item = u32>, config: &KdConfig) -> KdTree {
        let items: Vec<Item> = ids
            .into_iter()
            .filter_map(|id| {
                let b = *boxes.get(id as usize)?;
                (!b.is_empty() && b.is_finite()).then_some(Item { bounds: b, id })
            })
            .collect();
        let mut tree = KdTree::default();
        if items.is_empty() {
            return tree;
        }
        let bounds = items.iter().fold(Aabb::EMPTY, |a, it| a.union(it.bounds));
        let limit = 8.0 + 1.3 * (items.len() as f32).log2();
        let max_depth = config.max_depth.min(limit as u32);
        let leaf_size = config.max_leaf_size.max(1);
        tree.nodes.push(KdNode {
            bounds,
            axis: 3,
            split: 0.0,
            child: NONE,
            parent: NONE,
            start: 0,
            end: 0,
            ropes: [NONE; 6],
            depth: 0,
        });
        tree.grow(0, items, max_depth, leaf_size);
        tree.optimise_ropes();
        tree
    }

    /// Fills node `i` (its bounds, parent and depth set) with `items`: a leaf or a split.
    fn grow(&mut self, i: u32, items: Vec<Item>, max_depth: u32, leaf_size: usize) {
        let node = self.nodes[i as usize];
        self.nodes[i as usize].start = self.items.len() as u32;
        let split = if node.depth >= max_depth {
            None
        } else {
            best_split(&node.bounds, &items, leaf_size)
        };
        let Some((axis, plane)) = split else {
            self.items.extend(items.iter().map(|it| it.id));
            self.nodes[i as usize].end = self.items.len() as u32;
            return;
        };
        let left: Vec<Item> = items
            .iter()
            .copied()
            .filter(|it| goes_left(&it.bounds, axis, plane))
            .collect();
        let right: Vec<Item> = items
            .iter()
            .copied()
            .filter(|it| goes_right(&it.bounds, axis, plane))
            .collect();
        drop(items);
        let child = self.nodes.len() as u32;
        let (mut lo, mut hi) = (node.bounds, node.bounds);
        lo.max[axis] = plane;
        hi.min[axis] = plane;
        // Ropes: inherited, except on the split face, where the children meet.
        let (mut lo_ropes, mut hi_ropes) = (node.ropes, node.ropes);
        lo_ropes[2 * axis + 1] = child + 1;
        hi_ropes[2 * axis] = child;
        for (b, ropes) in [(lo, lo_ropes), (hi, hi_ropes)] {
            self.nodes.push(KdNode {
                bounds: b,
                axis: 3,
                split: 0.0,
                child: NONE,
                parent: i,
                start: 0,
                end: 0,
                ropes,
                depth: node.depth + 1,
            });
        }
        let n = &mut self.nodes[i as usize];
        n.axis = axis as u8;
        n.split = plane;
        n.child = child;
        self.grow(child, left, max_depth, leaf_size);
        self.grow(child + 1, right, max_depth, leaf_size);
        self.nodes[i as usize].end = self.items.len() as u32;
    }

    /// Pushes every rope down to the deepest node holding its whole face,
    /// parents before children (a child's inherited rope starts where its
    /// parent's ended).
    fn optimise_ropes(&mut self) {
        for i in 0..self.nodes.len() {
            let parent = self.nodes[i].parent;
            for face in 0..6 {
                // An inherited rope (every face but the parent's split face)
                // starts from the parent's optimised one: it holds the
                // parent's face, so this smaller one too.
                let inherited = parent != NONE && {
                    let p = &self.nodes[parent as usize];
                    let lower = i as u32 == p.child;
                    face != 2 * p.axis as usize + lower as usize
                };
                let target = if inherited {
                    self.nodes[parent as usize].ropes[face]
                } else {
                    self.nodes[i].ropes[face]
                };
                self.nodes[i].ropes[face] = self.descend(target, &self.nodes[i].face(face), face);
            }
        }
    }

    /// From `target` (which holds `face`, of a node on the other side), the
    /// deepest descendant that still holds all of it.
    fn descend(&self, mut target: u32, face: &Aabb, index: usize) -> u32 {
        let (axis, side) = (index / 2, index % 2);
        while target != NONE {
            let t = &self.nodes[target as usize];
            if t.is_leaf() {
                break;
            }
            let a = t.axis as usize;
            target = if a == axis {
                // The child touching the face: the lower one for a face at the node's max side.
                if side == 1 {
                    t.child
                } else {
                    t.child + 1
                }
            } else if face.max[a] <= t.split {
                t.child
            } else if face.min[a] >= t.split {
                t.child + 1
            } else {
                break;
            };
        }
        target
    }

    /// Every node, the root first, children after their parent and adjacent.
    pub fn nodes(&self) -> &[KdNode] {
        &self.nodes
    }

    /// Node `i`.
    pub fn node(&self, i: u32) -> &KdNode {
        &self.nodes[i as usize]
    }

    /// The object references, subtree by subtree (an object may appear in several leaves).
    pub fn items(&self) -> &[u32] {
        &self.items
    }

    /// The object references of `node`'s subtree (a leaf's own objects for a leaf).
    pub fn subtree_items(&self, node: &KdNode) -> &[u32] {
        &self.items[node.start as usize..node.end as usize]
    }

    /// Depth-first walk, the child on the viewer's side of the split plane
    /// first: `enter(context, index, node, state)` on the root with `root`,
    /// and on both children of every inner node it returned `Some` for;
    /// `leave(context, index, node)` on every such opened inner node after
    /// both its subtrees. As [`crate::spatial::Bvh::walk_front_to_back`].
    pub fn walk_front_to_back<S: Copy, C>(
        &self,
        eye: &Eye,
        root: S,
        context: &mut C,
        mut enter: impl FnMut(&mut C, u32, &KdNode, S) -> Option<S>,
        mut leave: impl FnMut(&mut C, u32, &KdNode),
    ) {
        if self.nodes.is_empty() {
            return;
        }
        #[derive(Clone, Copy)]
        enum Step<S> {
            Enter(u32, S),
            Leave(u32),
        }
        let mut stack = vec![Step::Enter(0, root)];
        while let Some(step) = stack.pop() {
            let (index, state) = match step {
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
            let a = node.axis as usize;
            let lower_first = match eye {
                Eye::Point(p) => p[a] < node.split,
                Eye::Direction(d) => d[a] >= 0.0,
            };
            let (near, far) = if lower_first {
                (node.child, node.child + 1)
            } else {
                (node.child + 1, node.child)
            };
            stack.push(Step::Leave(index));
            stack.push(Step::Enter(far, child));
            stack.push(Step::Enter(near, child));
        }
    }

    /// Checks the tree's invariants against the `boxes` it was built from
    /// and panics naming the first violation: children partition their
    /// parent at its split plane, strictly inside it; parents, depths and
    /// item ranges agree; every leaf holds exactly the built objects whose
    /// boxes meet it (an object reaches every leaf it intersects, closed
    /// boxes, but for one touching the plane from one side only).
    #[cfg(test)]
    pub fn assert_well_formed(&self, boxes: &[Aabb]) {
        for (i, n) in self.nodes.iter().enumerate() {
            assert!(
                n.start <= n.end && n.end as usize <= self.items.len(),
                "node {i}: item range"
            );
            if n.is_leaf() {
                continue;
            }
            let a = n.axis as usize;
            assert!(
                n.bounds.min[a] < n.split && n.split < n.bounds.max[a],
                "node {i}: split not inside"
            );
            let (l, r) = (&self.nodes[n.child as usize], &self.nodes[n.child as usize + 1]);
            let (mut lo, mut hi) = (n.bounds, n.bounds);
            lo.max[a] = n.split;
            hi.min[a] = n.split;
            assert_eq!((l.bounds, r.bounds), (lo, hi), "node {i}: children do not split it");
            assert!(
                l.parent == i as u32 && r.parent == i as u32,
                "node {i}: children's parent"
            );
            assert!(l.depth == n.depth + 1 && r.depth == n.depth + 1, "node {i}: depth");
            assert!(
                l.start == n.start && l.end == r.start && r.end == n.end,
                "node {i}: subtree ranges not contiguous"
            );
            for &id in self.subtree_items(l) {
                let b = &boxes[id as usize];
                assert!(b.intersects(&l.bounds), "object {id} in node {} it misses", n.child);
            }
            for &id in self.subtree_items(r) {
                let b = &boxes[id as usize];
                assert!(b.intersects(&r.bounds), "object {id} in node {} it misses", n.child + 1);
            }
        }
    }
}

/// Whether an object box goes to the child below `plane` (it reaches below it,
/// or lies wholly at or below it).
fn goes_left(b: &Aabb, axis: usize, plane: f32) -> bool {
    b.min[axis] < plane || b.max[axis] <= plane
}

/// Whether an object box goes to the child above `plane`.
fn goes_right(b: &Aabb, axis: usize, plane: f32) -> bool {
    b.max[axis] > plane || b.min[axis] >= plane
}

/// The cheapest SAH split of a node over `items` as (axis, plane), or `None`
/// when a leaf is better (always split above `leaf_size` objects when a plane
/// separates anything). Binned on each axis; ties keep the lowest axis and plane.
fn best_split(bounds: &Aabb, items: &[Item], leaf_size: usize) -> Option<(usize, f32)> {
    let n = items.len();
    if n <= 1 {
        return None;
    }
    let area = bounds.surface_area();
    let mut best: Option<(f32, usize, f32, usize, usize)> = None;
    for axis in 0..3 {
        let (lo, hi) = (bounds.min[axis], bounds.max[axis]);
        let extent = hi - lo;
        if extent.is_nan() || extent <= 0.0 {
            continue;
        }
        let scale = BINS as f32 / extent;
        let bin = |x: f32| (((x - lo) * scale) as usize).min(BINS - 1);
        let (mut mins, mut maxs) = ([0usize; BINS], [0usize; BINS]);
        for it in items {
            mins[bin(it.bounds.min[axis])] += 1;
            maxs[bin(it.bounds.max[axis])] += 1;
        }
        // Plane k (1..BINS) at the start of bin k: left = boxes starting
        // below it, right = boxes ending at or above it (an estimate: the
        // partition compares exactly).
        let mut left = 0;
        let mut right = n;
        for k in 1..BINS {
            left += mins[k - 1];
            right -= maxs[k - 1];
            let plane = lo + extent * k as f32 / BINS as f32;
            if plane <= lo || plane >= hi {
                continue;
            }
            let (mut l, mut r) = (*bounds, *bounds);
            l.max[axis] = plane;
            r.min[axis] = plane;
            let cost = if area > 0.0 {
                TRAVERSAL_COST + (l.surface_area() * left as f32 + r.surface_area() * right as f32) / area
            } else {
                TRAVERSAL_COST + (left + right) as f32 * 0.5
            };
            if best.is_none_or(|b| cost < b.0) {
                best = Some((cost, axis, plane, left, right));
            }
        }
    }
    let (cost, axis, plane, left, right) = best?;
    let separates = left < n || right < n;
    (separates && (cost < n as f32 || n > leaf_size)).then_some((axis, plane))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use proptest::prelude::*;

    fn arb_box() -> impl Strategy<Value = Aabb> {
        let v = || (-20.0f32..20.0, -20.0f32..20.0, -20.0f32..20.0);
        (v(), (0.1f32..6.0, 0.1f32..6.0, 0.1f32..6.0))
            .prop_map(|((x, y, z), (w, h, d))| Aabb::new(Vec3::new(x, y, z), Vec3::new(x + w, y + h, z + d)))
    }

    /// Whether `b` holds all of `face` and lies beyond it (on the far side from the face's node).
    fn covers(b: &Aabb, face: &Aabb, index: usize) -> bool {
        let (axis, side) = (index / 2, index % 2);
        let beyond = if side == 1 {
            b.min[axis] == face.max[axis]
        } else {
            b.max[axis] == face.min[axis]
        };
        beyond
            && (0..3)
                .filter(|&a| a != axis)
                .all(|a| b.min[a] <= face.min[a] && face.max[a] <= b.max[a])
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]
        #[test]
        fn ropes_reach_the_deepest_node_holding_each_face(
            boxes in prop::collection::vec(arb_box(), 1..80), leaf in 1usize..6,
        ) {
            let config = KdConfig { max_leaf_size: leaf, max_depth: 24 };
            let tree = KdTree::build(&boxes, 0..boxes.len() as u32, &config);
            tree.assert_well_formed(&boxes);
            for (i, n) in tree.nodes().iter().enumerate() {
                for face in 0..6 {
                    let f = n.face(face);
                    // Brute force: every node holding the face beyond it; the deepest.
                    let deepest = tree
                        .nodes()
                        .iter()
                        .enumerate()
                        .filter(|(_, u)| covers(&u.bounds, &f, face))
                        .max_by_key(|(_, u)| u.depth)
                        .map(|(j, _)| j as u32);
                    prop_assert_eq!(Some(n.ropes[face]).filter(|&r| r != NONE), deepest, "node {} face {}", i, face);
                    if let Some(d) = deepest {
                        // The holders form a chain: no two of the same depth.
                        let at = tree.node(d).depth;
                        let same = tree.nodes().iter().filter(|u| u.depth == at && covers(&u.bounds, &f, face)).count();
                        prop_assert_eq!(same, 1);
                    }
                }
            }
        }

        #[test]
        fn every_object_reaches_every_leaf_it_enters(boxes in prop::collection::vec(arb_box(), 1..80)) {
            let tree = KdTree::build(&boxes, 0..boxes.len() as u32, &KdConfig::default());
            tree.assert_well_formed(&boxes);
            let root = tree.node(0).bounds;
            for (id, b) in boxes.iter().enumerate() {
                prop_assert!(root.contains(b));
                for n in tree.nodes().iter().filter(|n| n.is_leaf()) {
                    // Overlap with positive volume: the leaf must hold the object.
                    let inner = (0..3).all(|a| b.min[a] < n.bounds.max[a] && n.bounds.min[a] < b.max[a]);
                    if inner {
                        prop_assert!(tree.subtree_items(n).contains(&(id as u32)), "object {} missing", id);
                    }
                }
            }
        }
    }

    #[test]
    fn the_walk_visits_nearer_children_first_and_builds_are_deterministic() {
        let boxes: Vec<Aabb> = (0..40)
            .map(|i| {
                let p = Vec3::new((i % 8) as f32 * 3.0, 0.0, (i / 8) as f32 * 3.0);
                Aabb::new(p, p + Vec3::ONE)
            })
            .collect();
        let a = KdTree::build(&boxes, 0..40, &KdConfig::default());
        let b = KdTree::build(&boxes, 0..40, &KdConfig::default());
        assert_eq!(a.nodes(), b.nodes());
        assert_eq!(a.items(), b.items());
        assert!(a.nodes().len() > 7, "the tree splits");
        let eye = Eye::Point(Vec3::new(-5.0, 0.5, -5.0));
        let mut order = Vec::new();
        a.walk_front_to_back(
            &eye,
            (),
            &mut order,
            |o, i, _, _| {
                o.push(i);
                Some(())
            },
            |_, _, _| {},
        );
        assert_eq!(order.len(), a.nodes().len(), "every node once");
        // A leaf's box is never entered after a leaf lying wholly between it and the eye... simpler:
        // the first leaf reached holds the eye's nearest object.
        let first_leaf = order.iter().find(|&&i| a.node(i).is_leaf()).unwrap();
        assert!(a.subtree_items(a.node(*first_leaf)).contains(&0));
        // Faces towards the eye: min x and min z of a box beyond it.
        let (faces, n) = front_faces(&boxes[9], &eye);
        assert_eq!(&faces[..n], &[0, 4]);
        assert_eq!(
            front_faces(&boxes[0], &Eye::Point(Vec3::new(0.5, 0.5, 0.5))).1,
            0,
            "eye inside"
        );
        assert_eq!(
            front_faces(&boxes[0], &Eye::Point(Vec3::new(1.0, 3.0, 3.0))).1,
            0,
            "eye on a face plane"
        );
        let (faces, n) = front_faces(&boxes[0], &Eye::Direction(Vec3::new(0.0, -1.0, 0.0)));
        assert_eq!(&faces[..n], &[3]);
    }

    #[test]
    fn nothing_to_build_is_an_empty_tree() {
        let boxes = [
            Aabb::EMPTY,
            Aabb {
                min: Vec3::NAN,
                max: Vec3::ONE,
            },
        ];
        let t = KdTree::build(&boxes, 0..2, &KdConfig::default());
        assert!(t.nodes().is_empty() && t.items().is_empty());
        let mut n = 0;
        t.walk_front_to_back(
            &Eye::Point(Vec3::ZERO),
            (),
            &mut n,
            |n, _, _, _| {
                *n += 1;
                None
            },
            |_, _, _| {},
        );
        assert_eq!(n, 0);
    }
}
