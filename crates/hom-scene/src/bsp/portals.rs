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
use hom::pvs::portals::{Portal, PortalError, PortalGraph, PortalObjects};
use hom::pvs::{PortalCells, PvsError};

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
    if dist.iter().all(|s| s.abs() <= ON) {
        return (Vec::new(), Vec::new());
    }
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

/// A square on the plane `n·p = d`, larger than the world. A map's
/// normals are not unit length in `f64`: the square's axes are made
/// orthogonal to `n` itself, or its corners would leave the plane by a
/// hair times the world's size.
fn base_winding(n: DVec3, d: f64) -> Winding {
    let centre = n * (d / n.length_squared());
    let u = n.normalize().any_orthonormal_vector();
    let v = n.normalize().cross(u);
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
                let mut backs = Vec::new();
                self.push(fw, back, n, -1.0, &mut backs, 0);
                for (bl, bw) in backs {
                    if bl != fl {
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

/// The portals between the leaves of `pvs`'s tree that sight may pass
/// through (hom coordinates): clustered leaves, and the solid leaves it may
/// reach behind a face left undrawn in a clustered leaf (`undrawn`, per
/// leaf), through other solid leaves. The loader leaves sky, nodraw and
/// caulk faces undrawn, and the renderer sees through them: so must the
/// portals, though the map compiler's `vis` does not.
fn leaf_portals(pvs: &Pvs, undrawn: &[bool]) -> Vec<Portal> {
    let all = all_leaf_portals(pvs);
    let open = |l: u32| pvs.leaf_cluster.get(l as usize).is_some_and(|&c| c >= 0);
    let mut passable: Vec<bool> = (0..pvs.leaf_cluster.len() as u32).map(open).collect();
    let mut neighbours = vec![Vec::new(); pvs.leaf_cluster.len()];
    for p in &all {
        neighbours[p.cells[0] as usize].push(p.cells[1]);
        neighbours[p.cells[1] as usize].push(p.cells[0]);
    }
    let mut stack: Vec<u32> = Vec::new();
    for l in 0..pvs.leaf_cluster.len() as u32 {
        if open(l) && undrawn.get(l as usize).copied().unwrap_or(true) {
            stack.extend(neighbours[l as usize].iter().copied().filter(|&m| !open(m)));
        }
    }
    while let Some(l) = stack.pop() {
        if passable[l as usize] {
            continue;
        }
        passable[l as usize] = true;
        stack.extend(
            neighbours[l as usize]
                .iter()
                .copied()
                .filter(|&m| !passable[m as usize]),
        );
    }
    all.into_iter()
        .filter(|p| p.cells.iter().all(|&c| passable[c as usize]))
        .collect()
}

/// The portals between every two leaves of `pvs`'s tree (hom coordinates).
fn all_leaf_portals(pvs: &Pvs) -> Vec<Portal> {
    let mut builder = Builder {
        pvs,
        portals: Vec::new(),
    };
    if !pvs.nodes.is_empty() {
        let mut bounds = Vec::new();
        for k in 0..3 {
            let mut n = DVec3::ZERO;
            n[k] = 1.0;
            bounds.push((n, -WORLD));
            bounds.push((-n, -WORLD));
        }
        builder.node(0, &mut bounds);
    }
    builder.portals
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
        PortalGraph::new(self.leaf_count(), leaf_portals(&self.pvs, &self.undrawn))
    }

    /// The objects each cluster may see through the map's leaf portals: a
    /// bit set over object ids per cluster (bit `k` of word `k / 64`). An
    /// object lies in the leaves whose face lists hold its faces
    /// ([`BspMap::object_leaves`]), as the map's own PVS takes it; objects in
    /// no clustered leaf are visible from every cluster. Uses
    /// every thread of the current rayon pool; `progress(done, total)` after
    /// each clustered leaf.
    pub fn portal_pvs(&self, progress: &(dyn Fn(usize, usize) + Sync)) -> Result<PortalPvs, PortalError> {
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
        let per_leaf = graph.visible_objects_from(&sources, &objects, progress);
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

    /// The map's tree as [`PortalCells`] for a `.pvs` file: hom
    /// coordinates, one cell per cluster, each hiding the objects it cannot
    /// see. `map` must be the map this was built from.
    pub fn cells(&self, map: &BspMap) -> Result<PortalCells, PvsError> {
        let planes = map
            .pvs
            .planes
            .iter()
            .map(|&(n, d)| (glam::Vec3::new(n[0], n[2], -n[1]), d * super::INCH))
            .collect();
        let leaf_cell = map.pvs.leaf_cluster.iter().map(|&c| u32::try_from(c).ok()).collect();
        let objects = map.scene.objects().len() as u32;
        let hidden = self
            .visible
            .iter()
            .map(|row| {
                (0..objects)
                    .filter(|&id| row[id as usize / 64] & (1 << (id % 64)) == 0)
                    .collect()
            })
            .collect();
        PortalCells::new(planes, map.pvs.nodes.clone(), leaf_cell, hidden)
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

#[cfg(test)]
mod tests {
    use super::*;
    use hom_testkit::Rng;

    /// A random tree over the cube ±100 (Quake units): planes through random
    /// points in random directions, leaves open (cluster = leaf) or solid.
    fn random_tree(rng: &mut Rng, depth: u32) -> Pvs {
        fn grow(rng: &mut Rng, pvs: &mut Pvs, depth: u32) -> i32 {
            if depth == 0 || (!pvs.nodes.is_empty() && rng.unit() < 0.1) {
                let leaf = pvs.leaf_cluster.len() as i32;
                pvs.leaf_cluster.push(if rng.unit() < 0.75 { leaf } else { -1 });
                return -(leaf + 1);
            }
            if !pvs.planes.is_empty() && rng.unit() < 0.15 {
                // An earlier plane again, either way round: polygons on it.
                let (n, d) = pvs.planes[rng.below(pvs.planes.len() as u64) as usize];
                let s = if rng.unit() < 0.5 { 1.0 } else { -1.0 };
                pvs.planes.push((n.map(|c| c * s), d * s));
            } else {
                let n = loop {
                    let v = rng.vec3(-1.0, 1.0);
                    if v.length() > 0.2 {
                        break v.normalize();
                    }
                };
                let at = rng.vec3(-80.0, 80.0);
                pvs.planes.push((n.to_array(), n.dot(at)));
            }
            let node = pvs.nodes.len();
            pvs.nodes.push((pvs.planes.len() as u32 - 1, 0, 0));
            let front = grow(rng, pvs, depth - 1);
            let back = grow(rng, pvs, depth - 1);
            pvs.nodes[node].1 = front;
            pvs.nodes[node].2 = back;
            node as i32
        }
        let mut pvs = Pvs::default();
        grow(rng, &mut pvs, depth);
        pvs
    }

    /// The leaf holding `q` (Quake units), the map's rule.
    fn leaf_at(pvs: &Pvs, q: DVec3) -> u32 {
        let mut child = if pvs.nodes.is_empty() { -1 } else { 0 };
        while child >= 0 {
            let (plane, front, back) = pvs.nodes[child as usize];
            let (n, d) = pvs.planes[plane as usize];
            let side = n[0] as f64 * q.x + n[1] as f64 * q.y + n[2] as f64 * q.z - d as f64;
            child = if side >= 0.0 { front } else { back };
        }
        (-(child as i64) - 1) as u32
    }

    /// Is `x` (hom coordinates) on the polygon, within `tol` metres?
    fn on_polygon(points: &[DVec3], x: DVec3, tol: f64) -> bool {
        let n = (1..points.len() - 1)
            .map(|i| (points[i] - points[0]).cross(points[i + 1] - points[0]))
            .sum::<DVec3>()
            .normalize();
        (n.dot(x - points[0])).abs() <= tol
            && (0..points.len()).all(|i| {
                let (a, b) = (points[i], points[(i + 1) % points.len()]);
                (b - a).cross(x - a).dot(n) >= -tol * (b - a).length()
            })
    }

    /// Wherever a segment passes from one open leaf into another, a portal
    /// joins the two there, its front leaf on its normal's side: the
    /// portals of random trees tile their planes' open parts.
    #[test]
    fn portals_tile_where_open_leaves_meet() {
        let mut crossings = 0;
        for seed in 0..200u64 {
            let mut rng = Rng::new(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) + 1);
            let pvs = random_tree(&mut rng, 2 + (seed % 5) as u32);
            // Nothing undrawn: the portals join open leaves only.
            let portals = leaf_portals(&pvs, &vec![false; pvs.leaf_cluster.len()]);
            for p in &portals {
                assert_ne!(p.cells[0], p.cells[1]);
                assert!(
                    p.cells.iter().all(|&c| pvs.leaf_cluster[c as usize] >= 0),
                    "seed {seed}: a solid leaf has a portal"
                );
            }
            for _ in 0..200 {
                let a = rng.vec3(-100.0, 100.0).as_dvec3();
                let b = rng.vec3(-100.0, 100.0).as_dvec3();
                let steps = 400;
                let mut prev = (a, leaf_at(&pvs, a));
                for i in 1..=steps {
                    let x = a + (b - a) * (i as f64 / steps as f64);
                    let leaf = leaf_at(&pvs, x);
                    if leaf != prev.1 {
                        // Bisect to the boundary.
                        let (mut lo, mut hi) = (prev.0, x);
                        while (hi - lo).length() > 1e-7 {
                            let mid = (lo + hi) * 0.5;
                            if leaf_at(&pvs, mid) == prev.1 {
                                lo = mid;
                            } else {
                                hi = mid;
                            }
                        }
                        let (from, to) = (prev.1, leaf_at(&pvs, hi));
                        let open = |l: u32| pvs.leaf_cluster[l as usize] >= 0;
                        if open(from) && open(to) && from != to {
                            crossings += 1;
                            let at = quake_to_hom((lo + hi) * 0.5);
                            let portal = portals.iter().find(|p| {
                                (p.cells == [from, to] || p.cells == [to, from]) && on_polygon(&p.points, at, 1e-5)
                            });
                            let Some(portal) = portal else {
                                panic!("seed {seed}: no portal between leaves {from} and {to} at {at}");
                            };
                            // Its front leaf lies on its normal's side.
                            let pts = &portal.points;
                            let n = (1..pts.len() - 1)
                                .map(|i| (pts[i] - pts[0]).cross(pts[i + 1] - pts[0]))
                                .sum::<DVec3>()
                                .normalize();
                            let entered_front = n.dot(quake_to_hom(hi) - quake_to_hom(lo)) > 0.0;
                            let front = if entered_front { to } else { from };
                            assert_eq!(
                                portal.cells[0], front,
                                "seed {seed}: the front leaf is behind the portal"
                            );
                        }
                    }
                    prev = (x, leaf);
                }
            }
        }
        assert!(
            crossings > 1000,
            "the segments should cross open boundaries: {crossings}"
        );
    }

    /// Behind a leaf with an undrawn face, sight enters solid space: the
    /// portals then reach the solid leaves next to it and on through solid
    /// leaves, and only there.
    #[test]
    fn undrawn_faces_open_the_solid_space_behind_them() {
        let mut opened = 0;
        for seed in 0..60u64 {
            let mut rng = Rng::new(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) + 11);
            let pvs = random_tree(&mut rng, 5);
            let leaves = pvs.leaf_cluster.len();
            let open = |l: u32| pvs.leaf_cluster[l as usize] >= 0;
            let undrawn: Vec<bool> = (0..leaves).map(|_| rng.unit() < 0.3).collect();
            let all = all_leaf_portals(&pvs);
            let kept = leaf_portals(&pvs, &undrawn);
            // Solid leaves sight reaches: next to an open leaf with an undrawn face, then on.
            let mut reach = vec![false; leaves];
            let mut changed = true;
            while changed {
                changed = false;
                for p in &all {
                    for (a, b) in [(p.cells[0], p.cells[1]), (p.cells[1], p.cells[0])] {
                        let from = (open(a) && undrawn[a as usize]) || (!open(a) && reach[a as usize]);
                        if from && !open(b) && !reach[b as usize] {
                            reach[b as usize] = true;
                            changed = true;
                        }
                    }
                }
            }
            let passable = |l: u32| open(l) || reach[l as usize];
            let want: Vec<[u32; 2]> = all
                .iter()
                .filter(|p| p.cells.iter().all(|&c| passable(c)))
                .map(|p| p.cells)
                .collect();
            let got: Vec<[u32; 2]> = kept.iter().map(|p| p.cells).collect();
            assert_eq!(got, want, "seed {seed}");
            opened += got.iter().filter(|c| !open(c[0]) || !open(c[1])).count();
        }
        assert!(opened > 20, "some portals should reach into solid space: {opened}");
    }

    /// Every point of a box lies in a leaf the box is said to touch.
    #[test]
    fn boxes_touch_the_leaves_of_their_points() {
        for seed in 0..100u64 {
            let mut rng = Rng::new(seed.wrapping_mul(0x2545_f491_4f6c_dd1d) + 5);
            let pvs = random_tree(&mut rng, 5);
            let (a, b) = (rng.vec3(-100.0, 100.0).as_dvec3(), rng.vec3(-100.0, 100.0).as_dvec3());
            let (lo, hi) = (a.min(b), a.max(b));
            let touching = pvs.leaves_touching(lo, hi, ON).expect("a tree");
            for _ in 0..200 {
                let t = DVec3::new(rng.unit_f64(), rng.unit_f64(), rng.unit_f64());
                let leaf = leaf_at(&pvs, lo + (hi - lo) * t);
                assert!(
                    touching.binary_search(&leaf).is_ok(),
                    "seed {seed}: leaf {leaf} not among {touching:?}"
                );
            }
        }
    }
}
