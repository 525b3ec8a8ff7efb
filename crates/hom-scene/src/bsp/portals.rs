//! A map's leaf portals, built from its BSP tree (the portal file the map
//! compiler writes is not in the `.bsp`), and the object-level PVS they give.
//!
//! Every node's plane, clipped to the node's region (the half-spaces of its
//! ancestors, inside the world's bounds), is the wall between its two
//! subtrees. Pushed down the front subtree it falls into pieces, one per
//! front leaf it borders; each piece pushed down the back subtree falls into
//! the portals between that front leaf and the back leaves. So a node's
//! portals tile its clipped plane exactly, and the leaves' regions are
//! convex cells whose shared faces are portals. Portals touching a leaf
//! without a cluster (solid space, or the void outside the map) are left
//! out: the map compiler gives a cluster to every leaf a player can see
//! from, and its own `vis` lets sight pass only between clustered leaves.
//!
//! [`BspMap::portal_pvs`] follows lines of sight through them
//! ([`hom::pvs::portals`]) from every clustered leaf to every object's box:
//! per cluster, the objects it may see.

use super::{BspMap, Pvs};
use glam::DVec3;
use hom::geom::Aabb;
use hom::pvs::portals::{Portal, PortalError, PortalGraph, PortalObjects};

/// Half the world's extent, Quake units: q3map2's `MAX_WORLD_COORD`.
const WORLD: f64 = 65536.0;

/// A point this close to a plane (Quake units) lies on it.
const ON: f64 = 1e-3;

/// A convex polygon in Quake units.
type Winding = Vec<DVec3>;

/// Splits `w` by the plane `n·p = d`: the parts in front and behind; a
/// polygon on the plane goes to neither (the caller decides).
fn split(w: &Winding, n: DVec3, d: f64) -> (Winding, Winding) {
    let dist: Vec<f64> = w.iter().map(|p| n.dot(*p) - d).collect();
    let (mut front, mut back) = (Vec::new(), Vec::new());
    for i in 0..w.len() {
        let j = (i + 1) % w.len();
        let (a, da, db) = (w[i], dist[i], dist[j]);
        if da >= -ON {
            front.push(a);
        }
        if da <= ON {
            back.push(a);
        }
        if (da > ON && db < -ON) || (da < -ON && db > ON) {
            let m = a + (w[j] - a) * (da / (da - db));
            front.push(m);
            back.push(m);
        }
    }
    let keep = |v: Winding| if area2(&v) > ON * ON { v } else { Vec::new() };
    (keep(front), keep(back))
}

/// Twice the polygon's area.
fn area2(w: &Winding) -> f64 {
    if w.len() < 3 {
        return 0.0;
    }
    let mut n = DVec3::ZERO;
    for i in 1..w.len() - 1 {
        n += (w[i] - w[0]).cross(w[i + 1] - w[0]);
    }
    n.length()
}

/// A square on the plane `n·p = d`, larger than the world.
fn base_winding(n: DVec3, d: f64) -> Winding {
    let centre = n * d;
    let u = n.any_orthonormal_vector();
    let v = n.cross(u);
    let r = 4.0 * WORLD;
    vec![
        centre - u * r - v * r,
        centre + u * r - v * r,
        centre + u * r + v * r,
        centre - u * r + v * r,
    ]
}

struct Builder<'a> {
    pvs: &'a Pvs,
    portals: Vec<Portal>,
}

impl Builder<'_> {
    fn plane(&self, node: usize) -> (DVec3, f64) {
        let (n, d) = self.pvs.planes[self.pvs.nodes[node].0 as usize];
        (DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64), d as f64)
    }

    fn open(&self, leaf: u32) -> bool {
        self.pvs.leaf_cluster.get(leaf as usize).is_some_and(|&c| c >= 0)
    }

    /// The pieces of `w` in the leaves of the subtree `child`, which lies on
    /// the side `toward` (+1 front, −1 back) of the plane with normal `n`
    /// that `w` lies on.
    fn push(&self, w: Winding, child: i32, n: DVec3, toward: f64, out: &mut Vec<(u32, Winding)>, depth: usize) {
        if child < 0 {
            out.push(((-(child as i64) - 1) as u32, w));
            return;
        }
        if depth > self.pvs.nodes.len() {
            return; // A cyclic tree (checked at load; never here).
        }
        let (_, front, back) = self.pvs.nodes[child as usize];
        let (m, e) = self.plane(child as usize);
        let (f, b) = split(&w, m, e);
        if f.is_empty() && b.is_empty() {
            // On this node's plane too: the subtree's region lies on `toward`'s side of it.
            let side = if m.dot(n) * toward >= 0.0 { front } else { back };
            return self.push(w, side, n, toward, out, depth + 1);
        }
        if !f.is_empty() {
            self.push(f, front, n, toward, out, depth + 1);
        }
        if !b.is_empty() {
            self.push(b, back, n, toward, out, depth + 1);
        }
    }

    fn node(&mut self, node: usize, bounds: &mut Vec<(DVec3, f64)>) {
        if bounds.len() > self.pvs.nodes.len() + 6 {
            return; // A cyclic tree (checked at load; never here).
        }
        let (n, d) = self.plane(node);
        let mut w = base_winding(n, d);
        for &(m, e) in bounds.iter() {
            w = split(&w, m, e).0;
            if w.is_empty() {
                break;
            }
        }
        let (_, front, back) = self.pvs.nodes[node];
        if !w.is_empty() {
            let mut fronts = Vec::new();
            self.push(w, front, n, 1.0, &mut fronts, 0);
            for (fl, fw) in fronts {
                if !self.open(fl) {
                    continue;
                }
                let mut backs = Vec::new();
                self.push(fw, back, n, -1.0, &mut backs, 0);
                for (bl, bw) in backs {
                    if self.open(bl) && bl != fl {
                        let points = bw.iter().map(|p| quake_to_hom(*p)).collect();
                        self.portals.push(Portal {
                            cells: [fl, bl],
                            points,
                        });
                    }
                }
            }
        }
        for (child, sign) in [(front, 1.0), (back, -1.0)] {
            if child >= 0 {
                bounds.push((n * sign, d * sign));
                self.node(child as usize, bounds);
                bounds.pop();
            }
        }
    }
}

/// [`super::to_hom`] in `f64`.
fn quake_to_hom(q: DVec3) -> DVec3 {
    DVec3::new(q.x, q.z, -q.y) * super::INCH as f64
}

impl BspMap {
    /// Leaves in the map's BSP tree: the cells of [`BspMap::leaf_portals`].
    pub fn leaf_count(&self) -> usize {
        self.pvs.leaf_cluster.len()
    }

    /// The cluster of a leaf, `None` for solid space, the void, or a leaf
    /// that does not exist.
    pub fn leaf_cluster(&self, leaf: u32) -> Option<i32> {
        self.pvs.leaf_cluster.get(leaf as usize).copied().filter(|&c| c >= 0)
    }

    /// The portals between the map's clustered leaves (cells are leaf
    /// indices; hom coordinates), built from its BSP tree as the module docs
    /// say.
    pub fn leaf_portals(&self) -> Result<PortalGraph, PortalError> {
        let mut builder = Builder {
            pvs: &self.pvs,
            portals: Vec::new(),
        };
        if !self.pvs.nodes.is_empty() {
            let mut bounds = Vec::new();
            for k in 0..3 {
                let mut n = DVec3::ZERO;
                n[k] = 1.0;
                bounds.push((n, -WORLD));
                bounds.push((-n, -WORLD));
            }
            builder.node(0, &mut bounds);
        }
        PortalGraph::new(self.leaf_count(), builder.portals)
    }

    /// The leaves whose regions `aabb` (hom coordinates) may touch (a hair
    /// wide), each once, ascending.
    pub fn leaves_touching(&self, aabb: &Aabb) -> Vec<u32> {
        let pvs = &self.pvs;
        let (a, b) = (super::to_quake(aabb.min), super::to_quake(aabb.max));
        let (lo, hi) = (
            [0, 1, 2].map(|k| a[k].min(b[k]) as f64),
            [0, 1, 2].map(|k| a[k].max(b[k]) as f64),
        );
        let mut out = Vec::new();
        let mut stack = vec![if pvs.nodes.is_empty() { -1 } else { 0i32 }];
        let mut steps = 0usize;
        while let Some(child) = stack.pop() {
            steps += 1;
            if steps > 4 * pvs.nodes.len() + 8 {
                break; // A cyclic tree (checked at load; never here).
            }
            if child < 0 {
                let leaf = (-(child as i64) - 1) as u32;
                if (leaf as usize) < pvs.leaf_cluster.len() {
                    out.push(leaf);
                }
                continue;
            }
            let (plane, front, back) = pvs.nodes[child as usize];
            let (n, d) = pvs.planes[plane as usize];
            let (mut smin, mut smax) = (-(d as f64), -(d as f64));
            for k in 0..3 {
                let (p, q) = (n[k] as f64 * lo[k], n[k] as f64 * hi[k]);
                smin += p.min(q);
                smax += p.max(q);
            }
            if smax >= -0.1 {
                stack.push(front);
            }
            if smin <= 0.1 {
                stack.push(back);
            }
        }
        out.sort_unstable();
        out.dedup();
        out
    }

    /// The objects each cluster may see through the map's leaf portals: a
    /// bit set over object ids per cluster (bit `k` of word `k / 64`). An
    /// object lies in the leaves whose face lists hold its faces
    /// ([`BspMap::object_leaves`]), as the map's own PVS takes it; objects in
    /// no clustered leaf are visible from every cluster. Uses
    /// every thread of the current rayon pool.
    pub fn portal_pvs(&self) -> Result<PortalPvs, PortalError> {
        let graph = self.leaf_portals()?;
        let scene_objects = self.scene.objects();
        let touching = &self.object_leaves;
        let objects = PortalObjects::new(
            graph.cell_count(),
            scene_objects.iter().zip(touching).map(|(o, t)| (o.aabb, t.clone())),
        )?;
        let sources: Vec<u32> = (0..self.leaf_count() as u32)
            .filter(|&l| self.leaf_cluster(l).is_some())
            .collect();
        let per_leaf = graph.visible_objects_from(&sources, &objects);
        let clusters = self.pvs.clusters.max(
            sources
                .iter()
                .filter_map(|&l| self.leaf_cluster(l))
                .max()
                .map_or(0, |c| c as usize + 1),
        );
        let words = scene_objects.len().div_ceil(64);
        let mut visible = vec![vec![0u64; words]; clusters];
        for (&leaf, bits) in sources.iter().zip(per_leaf) {
            let c = self.leaf_cluster(leaf).expect("sources are clustered") as usize;
            for (v, b) in visible[c].iter_mut().zip(bits) {
                *v |= b;
            }
        }
        // Objects no clustered leaf holds: the portals say nothing about them.
        for (id, t) in touching.iter().enumerate() {
            if t.is_empty() {
                for row in &mut visible {
                    row[id / 64] |= 1 << (id % 64);
                }
            }
        }
        Ok(PortalPvs {
            visible,
            portals: graph.portals().len(),
            leaves: sources.len(),
        })
    }
}

/// Per cluster, the objects it may see through the leaf portals
/// ([`BspMap::portal_pvs`]).
#[derive(Clone, Debug)]
pub struct PortalPvs {
    visible: Vec<Vec<u64>>,
    portals: usize,
    leaves: usize,
}

impl PortalPvs {
    /// May cluster `from` see object `id`? A cluster outside the map's
    /// clusters sees everything.
    pub fn object_visible_from(&self, id: u32, from: i32) -> bool {
        let Some(row) = usize::try_from(from).ok().and_then(|c| self.visible.get(c)) else {
            return true;
        };
        row.get(id as usize / 64).is_none_or(|w| w & (1 << (id % 64)) != 0)
    }

    /// Portals between clustered leaves.
    pub fn portal_count(&self) -> usize {
        self.portals
    }

    /// Clustered leaves (the sources).
    pub fn leaf_count(&self) -> usize {
        self.leaves
    }
}
