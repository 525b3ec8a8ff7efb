//! One mesh's level-of-detail hierarchy (Law & Tan 1999, section 3: "LOD
//! hierarchies … each node corresponds to some part of the scene").
//!
//! A binary tree of triangle clusters. The leaves split the mesh's triangles
//! by the median of their centroids along the longest axis, until at most
//! [`super::LodConfig::leaf_triangles`] are left: a leaf draws its original
//! triangles. An inner node draws the union of its children's triangles
//! simplified to about half (half-edge collapses under quadric error,
//! `crate::simplify`), so every node holds about a leaf's worth, like the
//! cluster hierarchies engines use today.
//!
//! Crack-free cuts by construction: a node locks every vertex it shares with
//! triangles outside it (and the mesh's open borders, where the next tile or
//! wall meets it). Collapses never remove a locked vertex, so the edges on a
//! node's rim are the mesh's own edges at full resolution, and any two nodes
//! of a cut that meet, at whatever level, meet along the same edge chain.
//! Half-edge collapses keep vertices in place, so a node's triangles index
//! the mesh's own positions (no new vertex buffer) and stay inside the box of
//! the original triangles it stands for: a node hidden by its box is hidden
//! at every level of detail.
//!
//! Nodes are numbered in pre-order, and each records its last descendant, so
//! "is `a` below `b`" is `b <= a <= last(b)` (Law & Tan, section 6).

use super::LodConfig;
use crate::geom::Aabb;
use crate::occlusion::details::weld;
use crate::scene::Mesh;
use crate::simplify::{simplify, simplify_cluster, SimplifyOptions};
use glam::Vec3;

/// The chain above the clusters stops at this many triangles.
const MIN_CHAIN_TRIANGLES: usize = 8;

/// A node of a [`LodHierarchy`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LodNode {
    /// Mesh-space box of the original triangles the node stands for; its own
    /// triangles lie inside it.
    pub bounds: Aabb,
    /// Geometric error (mesh units): the largest distance found between the
    /// node's triangles and its children's (both ways, at the children's
    /// vertices and at points of its own triangles) plus the larger child's
    /// error, so it bounds the distance to the original triangles as far as
    /// those samples tell, and is never less than a child's. 0 for a leaf.
    pub error: f32,
    /// The last node of its subtree (pre-order): the node itself for a leaf.
    pub last: u32,
    /// Its parent, or `u32::MAX` for the root.
    pub parent: u32,
    /// Distance from the root (the root is level 0).
    pub depth: u16,
    first_triangle: u32,
    triangle_count: u32,
    /// The original triangles it stands for: `original_range` of the leaves' order.
    original_first: u32,
    original_count: u32,
}

impl LodNode {
    /// Whether the node is a leaf (draws original triangles).
    pub fn is_leaf(&self, id: u32) -> bool {
        self.last == id
    }

    /// Number of triangles the node draws.
    pub fn triangle_count(&self) -> u32 {
        self.triangle_count
    }

    /// Number of original triangles below it.
    pub fn original_count(&self) -> u32 {
        self.original_count
    }
}

/// A mesh's level-of-detail hierarchy: nodes in pre-order, node 0 the root.
#[derive(Clone, Debug, PartialEq)]
pub struct LodHierarchy {
    nodes: Vec<LodNode>,
    /// Every node's triangles, indices into the mesh's positions.
    triangles: Vec<[u32; 3]>,
}

/// Where the original triangles go while the tree is cut.
struct Split<'a> {
    config: &'a LodConfig,
    centroids: Vec<Vec3>,
    nodes: Vec<LodNode>,
}

impl Split<'_> {
    /// Builds the subtree over `order[first..first + order.len()]` in pre-order.
    fn node(&mut self, order: &mut [u32], first: u32, parent: u32, depth: u16) -> u32 {
        let id = self.nodes.len() as u32;
        let bounds = Aabb::from_points(order.iter().map(|&t| self.centroids[t as usize]));
        self.nodes.push(LodNode {
            bounds, // centroids for now; the triangles' box is set later
            error: 0.0,
            last: id,
            parent,
            depth,
            first_triangle: 0,
            triangle_count: 0,
            original_first: first,
            original_count: order.len() as u32,
        });
        if order.len() > self.config.leaf_triangles as usize {
            let extent = bounds.extent();
            let axis = if extent.x >= extent.y && extent.x >= extent.z {
                0
            } else if extent.y >= extent.z {
                1
            } else {
                2
            };
            let mid = order.len() / 2;
            let centroids = &self.centroids;
            // Ties by index: the same mesh always cuts the same way.
            order.select_nth_unstable_by(mid, |&a, &b| {
                centroids[a as usize][axis]
                    .total_cmp(&centroids[b as usize][axis])
                    .then(a.cmp(&b))
            });
            let (left, right) = order.split_at_mut(mid);
            self.node(left, first, id, depth + 1);
            self.node(right, first + mid as u32, id, depth + 1);
            self.nodes[id as usize].last = self.nodes.len() as u32 - 1;
        }
        id
    }
}

impl LodHierarchy {
    /// Builds the hierarchy of `mesh` (deterministic: the same mesh and
    /// config give the same hierarchy).
    pub fn build(mesh: &Mesh, config: &LodConfig) -> LodHierarchy {
        let positions = mesh.positions();
        let originals = mesh.triangles();
        let centroids = originals
            .iter()
            .map(|t| (positions[t[0] as usize] + positions[t[1] as usize] + positions[t[2] as usize]) / 3.0)
            .collect();
        let mut order: Vec<u32> = (0..originals.len() as u32).collect();
        let mut split = Split {
            config,
            centroids,
            nodes: Vec::new(),
        };
        split.node(&mut order, 0, u32::MAX, 0);
        let mut nodes = split.nodes;
        // Leaves' order of the original triangles, welded for simplification.
        let canonical = weld(positions);
        let welded: Vec<[u32; 3]> = order
            .iter()
            .map(|&t| originals[t as usize].map(|i| canonical[i as usize]))
            .collect();
        // Per welded vertex: the first and last position in `order` of the
        // triangles using it, and whether it is on an open border.
        let mut span = vec![(u32::MAX, 0u32); positions.len()];
        for (k, t) in welded.iter().enumerate() {
            for &v in t {
                let s = &mut span[v as usize];
                s.0 = s.0.min(k as u32);
                s.1 = s.1.max(k as u32);
            }
        }
        let border = border_vertices(&welded, positions.len());

        // Bottom up (reverse pre-order visits children before parents).
        let mut node_tris: Vec<Vec<[u32; 3]>> = vec![Vec::new(); nodes.len()];
        let children_of = |nodes: &[LodNode], id: usize| [id + 1, nodes[id + 1].last as usize + 1];
        for id in (0..nodes.len()).rev() {
            let n = nodes[id];
            let (a, b) = (n.original_first, n.original_first + n.original_count);
            let own = &order[a as usize..b as usize];
            let box_of_originals = Aabb::from_points(
                own.iter()
                    .flat_map(|&t| originals[t as usize].map(|i| positions[i as usize])),
            );
            nodes[id].bounds = box_of_originals;
            if n.is_leaf(id as u32) {
                node_tris[id] = own.iter().map(|&t| originals[t as usize]).collect();
                continue;
            }
            let [c0, c1] = children_of(&nodes, id);
            let input: Vec<[u32; 3]> = node_tris[c0]
                .iter()
                .chain(&node_tris[c1])
                .map(|t| t.map(|i| canonical[i as usize]))
                .collect();
            let locked: Vec<bool> = span
                .iter()
                .zip(&border)
                .map(|(&(lo, hi), &on_border)| on_border || lo < a || hi >= b)
                .collect();
            let target = (input.len() / 2).max(1);
            let kept = simplify_cluster(
                positions,
                &input,
                &locked,
                SimplifyOptions {
                    target_triangles: target,
                    max_error: f32::INFINITY,
                },
            );
            // Distances add up (the triangle inequality): the children stand
            // within their errors of the originals, the node within `measured`
            // of the children. Measuring against the children is what keeps
            // the bake linear in the mesh.
            let measured = surface_distance(positions, &kept, &input);
            nodes[id].error = measured + nodes[c0].error.max(nodes[c1].error);
            node_tris[id] = kept;
        }
        // Above the root, a chain of single-child nodes halves it again while
        // that pays: a mesh of a leaf or two, or a root held up by the
        // clusters' count, still has coarse levels for distance and budgets.
        let mesh_locked: Vec<bool> = border.clone();
        let mut chain: Vec<(Vec<[u32; 3]>, f32)> = Vec::new();
        loop {
            let (finer, finer_error) = match chain.last() {
                Some((t, e)) => (t, *e),
                None => (&node_tris[0], nodes[0].error),
            };
            if finer.len() <= MIN_CHAIN_TRIANGLES {
                break;
            }
            let input: Vec<[u32; 3]> = finer.iter().map(|t| t.map(|i| canonical[i as usize])).collect();
            let kept = simplify(
                positions,
                &input,
                &mesh_locked,
                SimplifyOptions {
                    target_triangles: input.len() / 2,
                    max_error: f32::INFINITY,
                },
            );
            if kept.len() * 4 > input.len() * 3 {
                break; // less than a quarter fewer: not a level worth a node
            }
            let error = surface_distance(positions, &kept, &input) + finer_error;
            chain.push((kept, error));
        }
        if !chain.is_empty() {
            let k = chain.len() as u32;
            let total = nodes.len() as u32 + k;
            for n in &mut nodes {
                n.last += k;
                n.parent = if n.parent == u32::MAX { k - 1 } else { n.parent + k };
                n.depth += k as u16;
            }
            let root = nodes[0];
            let mut top = Vec::with_capacity(chain.len());
            let mut top_tris = Vec::with_capacity(chain.len());
            for (level, (tris, error)) in chain.into_iter().rev().enumerate() {
                top.push(LodNode {
                    error,
                    last: total - 1,
                    parent: if level == 0 { u32::MAX } else { level as u32 - 1 },
                    depth: level as u16,
                    ..root
                });
                top_tris.push(tris);
            }
            top.extend(nodes);
            nodes = top;
            top_tris.extend(node_tris);
            node_tris = top_tris;
        }
        let mut triangles = Vec::with_capacity(node_tris.iter().map(Vec::len).sum());
        for (n, t) in nodes.iter_mut().zip(&node_tris) {
            n.first_triangle = triangles.len() as u32;
            n.triangle_count = t.len() as u32;
            triangles.extend_from_slice(t);
        }
        LodHierarchy { nodes, triangles }
    }

    /// The nodes in pre-order; node 0 is the root.
    pub fn nodes(&self) -> &[LodNode] {
        &self.nodes
    }

    /// The triangles node `id` draws (indices into the mesh's positions).
    ///
    /// # Panics
    /// If `id` is not a node.
    pub fn triangles(&self, id: u32) -> &[[u32; 3]] {
        let n = &self.nodes[id as usize];
        &self.triangles[n.first_triangle as usize..(n.first_triangle + n.triangle_count) as usize]
    }

    /// The children of node `id`, in order: none for a leaf, one for a
    /// level of the chain above the clusters, else two.
    pub fn children(&self, id: u32) -> impl Iterator<Item = u32> + '_ {
        let last = self.nodes[id as usize].last;
        let mut next = id + 1;
        std::iter::from_fn(move || {
            (next <= last).then(|| {
                let c = next;
                next = self.nodes[c as usize].last + 1;
                c
            })
        })
    }

    /// Whether `a` is `b` or below it.
    pub fn is_within(&self, a: u32, b: u32) -> bool {
        b <= a && a <= self.nodes[b as usize].last
    }

    /// Bytes of the hierarchy.
    pub fn heap_bytes(&self) -> usize {
        crate::vec_bytes(&self.nodes) + crate::vec_bytes(&self.triangles)
    }

    /// Checks the structure: pre-order with correct `last` and `parent`,
    /// binary, the leaves' originals partitioning the mesh's triangles, every
    /// node's triangles inside its box, errors not below the children's.
    ///
    /// # Panics
    /// On the first violation, naming it.
    pub fn assert_well_formed(&self, mesh: &Mesh) {
        let nodes = &self.nodes;
        assert!(!nodes.is_empty(), "no root");
        assert_eq!(nodes[0].parent, u32::MAX, "the root has a parent");
        let mut covered = 0u64;
        for (i, n) in nodes.iter().enumerate() {
            let id = i as u32;
            assert!(
                n.last >= id && (n.last as usize) < nodes.len(),
                "node {id}: last {}",
                n.last
            );
            let children: Vec<u32> = self.children(id).collect();
            if !children.is_empty() {
                assert!(children.len() <= 2, "node {id} has {} children", children.len());
                assert_eq!(
                    nodes[*children.last().unwrap() as usize].last,
                    n.last,
                    "node {id}'s subtree"
                );
                for &c in &children {
                    let child = &nodes[c as usize];
                    assert_eq!(child.parent, id, "node {c}'s parent");
                    assert_eq!(child.depth, n.depth + 1, "node {c}'s depth");
                    assert!(child.error <= n.error, "node {c}'s error above its parent's");
                    assert!(n.bounds.contains(&child.bounds), "node {c}'s box outside its parent's");
                }
                let below: u32 = children.iter().map(|&c| nodes[c as usize].original_count).sum();
                assert_eq!(
                    below, n.original_count,
                    "node {id}'s children stand for other triangles"
                );
            } else {
                assert_eq!(n.original_first as u64, covered, "leaves out of order at {id}");
                covered += u64::from(n.original_count);
                assert_eq!(n.error, 0.0, "leaf {id} has an error");
                assert_eq!(n.triangle_count, n.original_count, "leaf {id} is not the original");
            }
            for t in self.triangles(id) {
                for &v in t {
                    let p = mesh.positions()[v as usize];
                    assert!(n.bounds.contains_point(p), "node {id}: vertex {v} outside its box");
                }
            }
        }
        assert_eq!(covered, mesh.triangle_count() as u64, "the leaves miss triangles");
    }
}

/// Welded vertices on an edge used by one triangle only, or by three or more.
fn border_vertices(triangles: &[[u32; 3]], vertex_count: usize) -> Vec<bool> {
    let mut edges: Vec<(u32, u32)> = triangles
        .iter()
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .map(|(a, b)| (a.min(b), a.max(b)))
        .collect();
    edges.sort_unstable();
    let mut border = vec![false; vertex_count];
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j] == edges[i] {
            j += 1;
        }
        if j - i != 2 {
            border[edges[i].0 as usize] = true;
            border[edges[i].1 as usize] = true;
        }
        i = j;
    }
    border
}

/// The largest distance found between the simplified triangles `coarse` and
/// the originals `fine`: from every original vertex to the coarse surface,
/// and from the centroid and edge midpoints of every coarse triangle to the
/// fine surface. (Coarse vertices are original vertices: distance 0.)
pub(crate) fn surface_distance(positions: &[Vec3], coarse: &[[u32; 3]], fine: &[[u32; 3]]) -> f32 {
    let tri = |t: &[u32; 3]| t.map(|i| positions[i as usize]);
    let coarse_tris: Vec<[Vec3; 3]> = coarse.iter().map(tri).collect();
    let fine_tris: Vec<[Vec3; 3]> = fine.iter().map(tri).collect();
    let nearest = |p: Vec3, surface: &[[Vec3; 3]]| {
        surface
            .iter()
            .map(|t| point_triangle_distance_squared(p, t))
            .fold(f32::INFINITY, f32::min)
    };
    let mut vertices: Vec<u32> = fine.iter().flatten().copied().collect();
    vertices.sort_unstable();
    vertices.dedup();
    let mut worst = 0.0f32;
    for &v in &vertices {
        worst = worst.max(nearest(positions[v as usize], &coarse_tris));
    }
    for t in &coarse_tris {
        let samples = [
            (t[0] + t[1] + t[2]) / 3.0,
            (t[0] + t[1]) * 0.5,
            (t[1] + t[2]) * 0.5,
            (t[2] + t[0]) * 0.5,
        ];
        for p in samples {
            worst = worst.max(nearest(p, &fine_tris));
        }
    }
    worst.sqrt()
}

/// Squared distance from `p` to the triangle `t` (Ericson, Real-Time
/// Collision Detection, 5.1.5: the closest point by Voronoi regions).
pub(crate) fn point_triangle_distance_squared(p: Vec3, t: &[Vec3; 3]) -> f32 {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return ap.length_squared();
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return bp.length_squared();
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (p - (a + ab * v)).length_squared();
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return cp.length_squared();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (p - (a + ac * w)).length_squared();
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (p - (b + (c - b) * w)).length_squared();
    }
    let denom = va + vb + vc;
    if denom.abs() <= f32::MIN_POSITIVE {
        // Degenerate triangle: its edges.
        return [(a, b), (b, c), (c, a)]
            .iter()
            .map(|&(s, e)| segment_distance_squared(p, s, e))
            .fold(f32::INFINITY, f32::min);
    }
    let (v, w) = (vb / denom, vc / denom);
    (p - (a + ab * v + ac * w)).length_squared()
}

fn segment_distance_squared(p: Vec3, a: Vec3, b: Vec3) -> f32 {
    let ab = b - a;
    let len = ab.length_squared();
    let t = if len > 0.0 {
        ((p - a).dot(ab) / len).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - (a + ab * t)).length_squared()
}
