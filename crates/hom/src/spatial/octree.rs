//! A loose octree over the scene's *triangles*: the object-space hierarchy of
//! hierarchical visibility (Greene, Kass and Miller 1993).
//!
//! # Layout
//! Every node has a *cell*: the root's is the box around all triangle
//! centroids; an inner node splits its cell at its centre into eight octant
//! cells (octant bit 0 = upper half in x, bit 1 = y, bit 2 = z; a coordinate
//! equal to the split goes to the upper half). A triangle is referenced once,
//! by `(object id, triangle index)`, and lives in the child whose cell holds its
//! *centroid*; a triangle straddling cells is therefore not split, and node
//! *bounds* are **loose**: the box of the node's triangles, which may extend
//! beyond its cell. Culling tests use `bounds`, front-to-back ordering uses the
//! cells (see [`Octree::child_order`]).
//!
//! A node is split while it holds more than `threshold` triangles and is less
//! than `max_depth` deep; an inner node has exactly eight children stored
//! contiguously (empty ones have `count == 0`). With `keep_large` (off by
//! default) a triangle larger than half the longest side of the cell being
//! split stays at that node (its `own` triangles) instead of going down: a
//! hybrid of the loose octree and Greene's "smallest enclosing node", which
//! keeps children's loose boxes close to their cells and lets a traversal draw
//! big triangles (walls, floors: the best occluders) before what lies in the
//! children. Measured on the office, city and machine-room walks it does
//! worse than the plain loose octree (more depth comparisons and time: the big
//! triangles kept high are drawn even where nearer geometry hides them), so it
//! stays an option. The triangles of every subtree are contiguous in
//! [`Octree::triangles`]: the node's own first, then the children's in octant order.
//!
//! # Dynamic objects
//! Only *static* objects are put in the tree; it is built once and never
//! changes. Moving objects are kept out of it: [`Octree::build`] skips them
//! and their users (the HV culler) test them per frame by their own boxes. This
//! keeps the tree trivially correct as objects move, at the price of testing
//! dynamic objects one by one (the built-in scenes have few of them).
//!
//! # World-space boxes
//! Triangle boxes are computed from `Object::transform.transform_point3` and
//! grown by a relative margin of 4e-7 of the coordinates' magnitude (a few ulps):
//! the renderer places vertices in the world by the same `transform_point3`
//! (`geom::object_to_clip`), and the margin keeps boxes safe for any caller
//! that rounds the transform differently.

use crate::geom::Aabb;
use crate::scene::Scene;
use glam::Vec3;

/// Build settings of an [`Octree`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OctreeConfig {
    /// Most triangles a leaf holds, unless it is `max_depth` deep (0 is taken as 1).
    pub threshold: usize,
    /// Deepest level (the root is depth 0); nodes this deep are leaves whatever they hold.
    pub max_depth: u32,
    /// Keep a triangle at a node being split when it is large for the node
    /// (`is_large`: larger than half the cell's longest side) instead of
    /// passing it to a child; HV draws a node's own triangles before its
    /// children, so big occluders come first and children's loose boxes stay tight.
    pub keep_large: bool,
}

impl Default for OctreeConfig {
    fn default() -> OctreeConfig {
        OctreeConfig {
            threshold: 16,
            max_depth: 12,
            keep_large: false,
        }
    }
}

/// A triangle of the scene: triangle `triangle` of object `object`'s mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct TriRef {
    /// Object id.
    pub object: u32,
    /// Index into the object's mesh triangles.
    pub triangle: u32,
}

/// Marks a leaf in [`OctreeNode::children`].
pub const NO_CHILDREN: u32 = u32::MAX;

/// One node of an [`Octree`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OctreeNode {
    /// The node's cell; an inner node splits it at its centre.
    pub cell: Aabb,
    /// Box of every triangle in the subtree (loose: may exceed `cell`);
    /// [`Aabb::EMPTY`] for an empty node.
    pub bounds: Aabb,
    /// First triangle of the subtree in [`Octree::triangles`].
    pub first: u32,
    /// Triangles in the subtree.
    pub count: u32,
    /// Triangles stored at the node itself, the first `own` of its subtree
    /// (all of them for a leaf; the large ones kept by `keep_large` for an inner node).
    pub own: u32,
    /// Index of the first of the eight children (octant order), or `NO_CHILDREN` (`u32::MAX`) for a leaf.
    pub children: u32,
    /// Depth (the root is 0).
    pub depth: u32,
}

impl OctreeNode {
    /// True for a leaf.
    pub fn is_leaf(&self) -> bool {
        self.children == NO_CHILDREN
    }

    /// The point the node's cell is split at (its centre).
    pub fn split(&self) -> Vec3 {
        self.cell.center()
    }
}

/// Whether a triangle with box `b` stays at a node with cell `cell` that is
/// being split (with `keep_large`): its longest side exceeds half the cell's longest side.
pub fn is_large(b: &Aabb, cell: &Aabb) -> bool {
    b.extent().max_element() > 0.5 * cell.extent().max_element()
}

/// Octant of `p` relative to split point `s`: bit 0 = `p.x >= s.x`, bit 1 = y, bit 2 = z.
pub fn octant(p: Vec3, s: Vec3) -> usize {
    usize::from(p.x >= s.x) | usize::from(p.y >= s.y) << 1 | usize::from(p.z >= s.z) << 2
}

/// The cell of octant `o` of `cell` split at its centre.
pub fn octant_cell(cell: &Aabb, o: usize) -> Aabb {
    let c = cell.center();
    let pick = |bit: usize, lo: f32, mid: f32, hi: f32| if o & bit != 0 { (mid, hi) } else { (lo, mid) };
    let (x0, x1) = pick(1, cell.min.x, c.x, cell.max.x);
    let (y0, y1) = pick(2, cell.min.y, c.y, cell.max.y);
    let (z0, z1) = pick(4, cell.min.z, c.z, cell.max.z);
    Aabb {
        min: Vec3::new(x0, y0, z0),
        max: Vec3::new(x1, y1, z1),
    }
}

/// The order in which to visit the eight octants of a cell split at `split`,
/// front to back for an eye at `eye`: `e ^ 0, e ^ 1, …, e ^ 7` where `e` is the
/// eye's octant.
///
/// Why it is front to back: a ray from the eye crosses each of the three
/// splitting planes at most once, always from the eye's side to the other, so
/// along the ray the set of axes on which the current octant differs from `e`
/// only grows; hence the octants a ray passes through have increasing
/// `octant ^ e`, i.e. appear in this order. So for any two octants A before B
/// in this order, no ray from the eye meets B's cell before A's cell.
pub fn front_to_back(eye: Vec3, split: Vec3) -> [u8; 8] {
    let e = octant(eye, split) as u8;
    std::array::from_fn(|k| e ^ k as u8)
}

/// A loose octree over the triangles of a scene's static objects; see the module docs.
#[derive(Clone, Debug, Default)]
pub struct Octree {
    nodes: Vec<OctreeNode>,
    triangles: Vec<TriRef>,
    config: OctreeConfig,
}

/// A triangle during the build.
#[derive(Clone, Copy)]
struct Record {
    tri: TriRef,
    bounds: Aabb,
    centroid: Vec3,
}

/// World box of a triangle, grown by a few ulps of its coordinates (see the module docs).
pub fn triangle_bounds(scene: &Scene, t: TriRef) -> Aabb {
    let o = scene.object(t.object);
    let mesh = scene.mesh_of(o);
    let idx = mesh.triangles()[t.triangle as usize];
    let b = Aabb::from_points(idx.map(|i| o.transform.transform_point3(mesh.positions()[i as usize])));
    let pad = b.min.abs().max(b.max.abs()).max_element() * 4e-7;
    Aabb {
        min: b.min - pad,
        max: b.max + pad,
    }
}

impl Octree {
    /// Builds the octree over every triangle of every live static object of `scene`.
    pub fn build(scene: &Scene, config: &OctreeConfig) -> Octree {
        let config = OctreeConfig {
            threshold: config.threshold.max(1),
            ..*config
        };
        let mut recs: Vec<Record> = Vec::new();
        for (id, o) in scene.objects().iter().enumerate() {
            if o.is_dynamic() || o.is_removed() {
                continue;
            }
            for k in 0..scene.mesh_of(o).triangle_count() {
                let tri = TriRef {
                    object: id as u32,
                    triangle: k as u32,
                };
                let bounds = triangle_bounds(scene, tri);
                recs.push(Record {
                    tri,
                    bounds,
                    centroid: bounds.center(),
                });
            }
        }
        let mut tree = Octree {
            nodes: Vec::new(),
            triangles: Vec::new(),
            config,
        };
        if recs.is_empty() {
            return tree;
        }
        let root_cell = Aabb::from_points(recs.iter().map(|r| r.centroid));
        tree.nodes.push(OctreeNode {
            cell: root_cell,
            bounds: Aabb::EMPTY,
            first: 0,
            count: recs.len() as u32,
            own: recs.len() as u32,
            children: NO_CHILDREN,
            depth: 0,
        });
        let mut scratch = Vec::with_capacity(recs.len());
        let mut work = vec![0usize];
        while let Some(n) = work.pop() {
            let node = tree.nodes[n];
            let range = node.first as usize..(node.first + node.count) as usize;
            let items = &mut recs[range.clone()];
            tree.nodes[n].bounds = items.iter().fold(Aabb::EMPTY, |b, r| b.union(r.bounds));
            if items.len() <= config.threshold || node.depth >= config.max_depth {
                continue;
            }
            // Counting sort into bucket 0 (stays: large) and 1 + octant of the centroid.
            let split = node.split();
            let bucket = |r: &Record| {
                if config.keep_large && is_large(&r.bounds, &node.cell) {
                    0
                } else {
                    1 + octant(r.centroid, split)
                }
            };
            let mut counts = [0usize; 9];
            for r in items.iter() {
                counts[bucket(r)] += 1;
            }
            if counts[0] == items.len() {
                continue; // every triangle stays: a leaf
            }
            let mut starts = [0usize; 9];
            for o in 1..9 {
                starts[o] = starts[o - 1] + counts[o - 1];
            }
            scratch.clear();
            scratch.extend_from_slice(items);
            let mut at = starts;
            for r in &scratch {
                let b = bucket(r);
                items[at[b]] = *r;
                at[b] += 1;
            }
            let first_child = tree.nodes.len();
            tree.nodes[n].children = first_child as u32;
            tree.nodes[n].own = counts[0] as u32;
            for o in 0..8 {
                tree.nodes.push(OctreeNode {
                    cell: octant_cell(&node.cell, o),
                    bounds: Aabb::EMPTY,
                    first: node.first + starts[o + 1] as u32,
                    count: counts[o + 1] as u32,
                    own: counts[o + 1] as u32,
                    children: NO_CHILDREN,
                    depth: node.depth + 1,
                });
                if counts[o + 1] > 0 {
                    work.push(first_child + o);
                }
            }
        }
        tree.triangles = recs.iter().map(|r| r.tri).collect();
        tree
    }

    /// The nodes; the root is node 0 (none for a scene without static triangles).
    pub fn nodes(&self) -> &[OctreeNode] {
        &self.nodes
    }

    /// Every triangle of the tree, subtrees contiguous.
    pub fn triangles(&self) -> &[TriRef] {
        &self.triangles
    }

    /// The triangles of `node`'s subtree.
    pub fn node_triangles(&self, node: &OctreeNode) -> &[TriRef] {
        &self.triangles[node.first as usize..(node.first + node.count) as usize]
    }

    /// The triangles stored at `node` itself (all of a leaf's; the large ones of an inner node).
    pub fn own_triangles(&self, node: &OctreeNode) -> &[TriRef] {
        &self.triangles[node.first as usize..(node.first + node.own) as usize]
    }

    /// The settings it was built with (threshold at least 1).
    pub fn config(&self) -> OctreeConfig {
        self.config
    }

    /// True when the tree holds no triangle.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Depth of the deepest node (0 for an empty tree or a lone root).
    pub fn depth(&self) -> u32 {
        self.nodes.iter().map(|n| n.depth).max().unwrap_or(0)
    }

    /// Number of leaves holding at least one triangle.
    pub fn leaf_count(&self) -> usize {
        self.nodes.iter().filter(|n| n.is_leaf() && n.count > 0).count()
    }

    /// The children of inner node `node` in front-to-back order from `eye`
    /// (`front_to_back` at the node's split point), as node indices.
    ///
    /// # Panics
    /// If `node` is a leaf.
    pub fn child_order(&self, node: &OctreeNode, eye: Vec3) -> [u32; 8] {
        assert!(!node.is_leaf(), "a leaf has no children");
        front_to_back(eye, node.split()).map(|o| node.children + u32::from(o))
    }

    /// Checks every structural invariant against `scene` (the scene it was built
    /// from); panics with a description on the first violation:
    /// every static triangle is referenced exactly once and no dynamic one is;
    /// every node's bounds hold its triangles' boxes and its children's bounds;
    /// children's cells are the octants of their parent's cell, and each
    /// triangle of a child has its centroid in that child's octant; subtree
    /// ranges nest; leaves hold at most `threshold` triangles unless `max_depth` deep.
    pub fn assert_well_formed(&self, scene: &Scene) {
        let mut seen: Vec<Vec<bool>> = scene
            .objects()
            .iter()
            .map(|o| vec![false; scene.mesh_of(o).triangle_count()])
            .collect();
        for t in &self.triangles {
            let o = scene.object(t.object);
            assert!(
                !o.is_dynamic() && !o.is_removed(),
                "dynamic or removed object {} is in the octree",
                t.object
            );
            let s = &mut seen[t.object as usize][t.triangle as usize];
            assert!(!*s, "triangle {t:?} referenced twice");
            *s = true;
        }
        for (id, (o, s)) in scene.objects().iter().zip(&seen).enumerate() {
            if !o.is_dynamic() && !o.is_removed() {
                assert!(
                    s.iter().all(|&b| b),
                    "object {id}: a triangle is missing from the octree"
                );
            }
        }
        if self.nodes.is_empty() {
            assert!(self.triangles.is_empty());
            return;
        }
        let root = &self.nodes[0];
        assert_eq!(
            (root.first, root.count as usize),
            (0, self.triangles.len()),
            "root range"
        );
        for (i, n) in self.nodes.iter().enumerate() {
            let tris = self.node_triangles(n);
            for &t in tris {
                let b = triangle_bounds(scene, t);
                assert!(
                    n.bounds.contains(&b),
                    "node {i}: bounds {:?} miss {t:?} {b:?}",
                    n.bounds
                );
            }
            if n.count == 0 {
                assert!(n.is_leaf() && n.bounds.is_empty(), "node {i}: empty node");
                continue;
            }
            if n.is_leaf() {
                assert_eq!(n.own, n.count, "node {i}: a leaf owns its triangles");
                let all_large = self.config.keep_large
                    && self
                        .node_triangles(n)
                        .iter()
                        .all(|&t| is_large(&triangle_bounds(scene, t), &n.cell));
                assert!(
                    n.count as usize <= self.config.threshold || n.depth >= self.config.max_depth || all_large,
                    "node {i}: leaf of {} triangles at depth {}",
                    n.count,
                    n.depth
                );
                continue;
            }
            assert!(n.own < n.count, "node {i}: an inner node passes triangles down");
            for &t in self.own_triangles(n) {
                assert!(
                    self.config.keep_large && is_large(&triangle_bounds(scene, t), &n.cell),
                    "node {i}: {t:?} kept but not large"
                );
            }
            assert!(n.depth < self.config.max_depth, "node {i}: split at max depth");
            let c0 = n.children as usize;
            assert!(c0 > i && c0 + 8 <= self.nodes.len(), "node {i}: children out of range");
            let mut next = n.first + n.own;
            for o in 0..8 {
                let c = &self.nodes[c0 + o];
                assert_eq!(c.depth, n.depth + 1, "node {i}: child depth");
                assert_eq!(c.cell, octant_cell(&n.cell, o), "node {i}: child {o} cell");
                assert_eq!(c.first, next, "node {i}: child {o} range");
                next += c.count;
                assert!(n.bounds.contains(&c.bounds), "node {i}: child {o} bounds escape");
                for &t in self.node_triangles(c) {
                    let b = triangle_bounds(scene, t);
                    assert_eq!(octant(b.center(), n.split()), o, "node {i}: {t:?} in the wrong octant");
                    assert!(
                        !(self.config.keep_large && is_large(&b, &n.cell)),
                        "node {i}: large {t:?} passed down"
                    );
                }
            }
            assert_eq!(next, n.first + n.count, "node {i}: children do not cover the range");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Mesh, SceneBuilder};
    use glam::{Mat4, Quat};
    use hom_testkit::Rng;
    use proptest::prelude::*;

    /// A scene of `n` random triangle soups (some dynamic).
    fn soup(seed: u64, n: usize, tris: usize) -> Scene {
        let mut rng = Rng::new(seed);
        let mut r = move || rng.unit();
        let mut b = SceneBuilder::new("soup");
        for i in 0..n {
            let p: Vec<Vec3> = (0..tris * 3)
                .map(|_| Vec3::new(r() * 4.0 - 2.0, r() * 4.0 - 2.0, r() * 4.0 - 2.0))
                .collect();
            let t: Vec<[u32; 3]> = (0..tris as u32).map(|k| [3 * k, 3 * k + 1, 3 * k + 2]).collect();
            let m = b.add_mesh(Mesh::new(format!("m{i}"), p, t).unwrap());
            let pos = Vec3::new(r() * 40.0 - 20.0, r() * 10.0, r() * 40.0 - 20.0);
            let tr =
                Mat4::from_scale_rotation_translation(Vec3::splat(0.5 + r()), Quat::from_rotation_y(r() * 6.0), pos);
            if i % 5 == 4 {
                b.add_dynamic_object(format!("o{i}"), m, tr).unwrap();
            } else {
                b.add_object(format!("o{i}"), m, tr).unwrap();
            }
        }
        b.build().unwrap()
    }

    proptest! {
        #[test]
        fn built_octrees_are_well_formed(seed in any::<u64>(), n in 1usize..30, tris in 1usize..40,
                                         threshold in 1usize..50, max_depth in 0u32..8, keep_large in any::<bool>()) {
            let scene = soup(seed, n, tris);
            let tree = Octree::build(&scene, &OctreeConfig { threshold, max_depth, keep_large });
            tree.assert_well_formed(&scene);
            prop_assert!(tree.depth() <= max_depth);
        }

        /// The octant order is front to back along every ray from the eye: the
        /// octants met by a ray, in the order the ray meets them, have
        /// non-decreasing position in [`front_to_back`].
        #[test]
        fn octant_order_is_front_to_back_along_rays(
            split in (-5.0f32..5.0, -5.0f32..5.0, -5.0f32..5.0),
            eye in (-10.0f32..10.0, -10.0f32..10.0, -10.0f32..10.0),
            dir in (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0),
        ) {
            let split = Vec3::new(split.0, split.1, split.2);
            let eye = Vec3::new(eye.0, eye.1, eye.2);
            let dir = Vec3::new(dir.0, dir.1, dir.2);
            prop_assume!(dir.length() > 1e-3);
            let order = front_to_back(eye, split);
            let mut pos = [0usize; 8];
            for (k, &o) in order.iter().enumerate() {
                pos[o as usize] = k;
            }
            let mut last = 0;
            for s in 0..=2000 {
                let p = eye + dir * (s as f32 * 0.02);
                let k = pos[octant(p, split)];
                prop_assert!(k >= last, "ray meets octant at position {} after {}", k, last);
                last = k;
            }
        }

        /// The whole tree's depth-first, front-to-back leaf order: along any ray
        /// from the eye, the non-empty leaf cells the ray passes through appear
        /// in non-decreasing visiting order. (Cells, not loose bounds: loose
        /// bounds overlap, so no order is front to back for them; HV's result
        /// does not depend on the order, only its efficiency does.)
        #[test]
        fn tree_traversal_is_front_to_back_along_rays(
            seed in any::<u64>(), eye in (-30.0f32..30.0, -5.0f32..15.0, -30.0f32..30.0), keep_large in any::<bool>(),
            dirs in proptest::collection::vec((-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0), 8),
        ) {
            let scene = soup(seed, 25, 12);
            let tree = Octree::build(&scene, &OctreeConfig { threshold: 4, max_depth: 6, keep_large });
            let eye = Vec3::new(eye.0, eye.1, eye.2);
            // Visiting order of every leaf (the HV traversal without culling).
            let mut rank = vec![usize::MAX; tree.nodes().len()];
            let mut stack = vec![0u32];
            let mut k = 0;
            while let Some(i) = stack.pop() {
                let n = &tree.nodes()[i as usize];
                if n.is_leaf() {
                    rank[i as usize] = k;
                    k += 1;
                } else {
                    stack.extend(tree.child_order(n, eye).iter().rev());
                }
            }
            // The leaf whose cell holds a point (descending by octant, as the build does).
            let leaf_at = |p: Vec3| -> Option<usize> {
                let mut i = 0usize;
                if !tree.nodes()[0].cell.contains_point(p) {
                    return None;
                }
                while !tree.nodes()[i].is_leaf() {
                    let n = &tree.nodes()[i];
                    i = n.children as usize + octant(p, n.split());
                }
                Some(i)
            };
            for d in dirs {
                let dir = Vec3::new(d.0, d.1, d.2);
                if dir.length() < 1e-3 {
                    continue;
                }
                let mut last = 0;
                for s in 0..=3000 {
                    let p = eye + dir.normalize() * (s as f32 * 0.03);
                    if let Some(l) = leaf_at(p) {
                        prop_assert!(rank[l] >= last, "leaf {} (rank {}) after rank {}", l, rank[l], last);
                        last = rank[l];
                    }
                }
            }
        }
    }

    #[test]
    fn dynamic_objects_stay_out_and_leaves_split() {
        let scene = soup(7, 20, 30);
        let tree = Octree::build(&scene, &OctreeConfig::default());
        tree.assert_well_formed(&scene);
        let statics: usize = scene.objects().iter().filter(|o| !o.is_dynamic()).count() * 30;
        assert_eq!(tree.triangles().len(), statics);
        assert!(
            tree.leaf_count() > 1,
            "480 static triangles over the default threshold split"
        );
    }
}
