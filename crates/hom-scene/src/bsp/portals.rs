//! A map's leaf portals, built from its BSP tree (the portal file the map
//! compiler writes is not in the `.bsp`), and the object-level PVS they give.
//!
//! Every node's plane, clipped to the node's region (the half-spaces of its
//! ancestors, inside the world's bounds), is the wall between its two
//! subtrees. Pushed down the front subtree it falls into pieces, one per
//! front leaf it borders; each piece pushed down the back subtree falls into
//! the portals between that front leaf and the back leaves. So a node's
//! portals tile its clipped plane exactly, and the leaves' regions are
//! convex cells whose shared faces are portals.
//!
//! **Where sight passes.** The map compiler's `vis` lets sight pass only
//! between clustered leaves. The renderer (the truth) sees wherever no
//! drawn triangle is, from both sides, and a map has places where that is
//! not the compiler's view: sides it kept no face for (caulk facing open
//! space, the bottom of a brush over a hollow), leaves it filled for its
//! `vis` alone (antiportals), sky left open ([`super::SkyFaces::Open`]).
//! So sight passes:
//! - between clustered leaves;
//! - from a clustered leaf into solid space through a wall (a portal to a
//!   leaf without a cluster) that the drawn triangles on its plane do not
//!   cover ([`covered`]; faces within [`ON_FACE`] of it, seams narrower
//!   than [`SEAM`] ignored), and through a leaf filled for `vis` alone
//!   ([`vis_only_leaves`]: the compiler dropped the faces of the brushes
//!   around it too); then through all solid space joined to there;
//! - from solid space into a clustered leaf through a wall that is not
//!   covered; through a covered one only up to its faces (the portal leads
//!   to a *sink* standing for the leaf: its objects are reached, nothing
//!   beyond).
//!
//! Sight starts in the clustered leaves a camera reaches: those the portals
//! between clustered leaves join to a leaf holding an eye of the camera
//! path. A cluster with a leaf no eye reaches sees every object: a pocket
//! sealed inside the walls (the compiler keeps one open when an entity
//! sits in it) is bounded by the backs of brushes whose faces it dropped.
//!
//! [`BspMap::portal_pvs`] follows lines of sight through these portals
//! ([`hom::pvs::portals`]) from every reached clustered leaf to every
//! object's box: per cluster, the objects it may see.

use super::{BspMap, LeafBrushes, Pvs};
use glam::DVec3;
use hom::pvs::portals::{Portal, PortalError, PortalGraph, PortalObjects};
use hom::pvs::{PortalCells, PvsError};

/// Half the world's extent, Quake units: q3map2's `MAX_WORLD_COORD`.
const WORLD: f64 = 65536.0;

/// A point this close to a plane (Quake units) lies on it.
const ON: f64 = 1e-3;

/// A leaf's corner this far past a brush's side (Quake units: a quarter
/// of a millimetre) still lies inside the brush: the corners are made by
/// clipping, each within [`ON`] of its planes.
const INSIDE: f64 = 1e-2;

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

/// A map's portals for sight ([`BspMap::leaf_portals`]).
struct Sight {
    /// The portals, between leaves and sinks.
    graph: PortalGraph,
    /// Per sink (cells from the leaf count on), the leaf it stands for.
    sinks: Vec<u32>,
    /// Per leaf, whether a camera reaches it.
    reached: Vec<bool>,
}

/// The portals sight may pass through (see [`leaf_portals`]), and the
/// leaves sight reaches only up to their faces.
struct SightPortals {
    /// Portals between cells: a leaf, or `leaves + k` for `sinks[k]`.
    portals: Vec<Portal>,
    /// Per sink cell, the open leaf it stands for: sight from solid space
    /// meets the faces on that leaf's side and stops there.
    sinks: Vec<u32>,
}

/// The portals between the leaves of `pvs`'s tree (`all`, from
/// [`all_leaf_portals`]) that sight may pass through (hom coordinates):
/// between clustered leaves; through leaves the compiler filled for its
/// `vis` alone (`vis_only`, per leaf: see [`vis_only_leaves`]); and through
/// the solid space sight enters where a portal between a clustered leaf it
/// starts from or crosses (`seen_from`, per leaf) and a solid one is not
/// covered by the drawn faces on it (`walled`, per portal of `all`: see
/// [`covered`]) or from a leaf filled for `vis` alone
/// (the compiler dropped the faces of the brushes there), then through
/// every solid leaf joined to it. From solid space sight reaches a
/// clustered leaf through a walled portal only up to its faces, which the
/// renderer draws from both sides: that portal leads to a sink standing for
/// the leaf, from which sight goes nowhere.
fn leaf_portals(pvs: &Pvs, all: Vec<Portal>, walled: &[bool], vis_only: &[bool], seen_from: &[bool]) -> SightPortals {
    let leaves = pvs.leaf_cluster.len();
    let open = |l: u32| pvs.leaf_cluster.get(l as usize).is_some_and(|&c| c >= 0);
    let is = |flags: &[bool], l: u32| flags.get(l as usize).copied().unwrap_or(false);
    // Solid space sight enters, and all of it joined to there.
    let mut doors: Vec<u32> = (0..leaves as u32).filter(|&l| is(vis_only, l) && !open(l)).collect();
    for (k, p) in all.iter().enumerate() {
        let [a, b] = p.cells;
        let (from, to) = if open(a) { (a, b) } else { (b, a) };
        if open(from) && !open(to) && is(seen_from, from) && !is(walled, k as u32) {
            doors.push(to);
        }
    }
    let entered = reached_leaves(&all, leaves, doors, |l| !open(l));
    // Solid leaves whose sides hold the faces the compiler kept.
    let filled = |l: u32| entered[l as usize] && !is(vis_only, l);
    let mut sink_of = vec![u32::MAX; leaves];
    let mut sinks = Vec::new();
    let mut portals = Vec::new();
    for (k, mut p) in all.into_iter().enumerate() {
        if !p.cells.iter().all(|&c| open(c) || entered[c as usize]) {
            continue;
        }
        let cells = p.cells;
        for side in 0..2 {
            let (from, to) = (cells[1 - side], cells[side]);
            if filled(from) && open(to) && is(walled, k as u32) {
                if sink_of[to as usize] == u32::MAX {
                    sink_of[to as usize] = (leaves + sinks.len()) as u32;
                    sinks.push(to);
                }
                p.cells[side] = sink_of[to as usize];
            }
        }
        portals.push(p);
    }
    SightPortals { portals, sinks }
}

/// The normal (unit) of a convex polygon's plane, by its winding; zero
/// for a degenerate one.
fn winding_normal(w: &[DVec3]) -> DVec3 {
    let mut n = DVec3::ZERO;
    for i in 1..w.len().saturating_sub(1) {
        n += (w[i] - w[0]).cross(w[i + 1] - w[0]);
    }
    n.normalize_or_zero()
}

/// Drawn triangles by their plane, to find those on a portal's plane. A
/// leaf's face list does not do: the compiler lists a face lying on a
/// node's plane in one of the leaves beside it, not always the one it
/// walls.
struct FacePlanes {
    /// By quantized plane (either way round): the triangles on it.
    by_plane: std::collections::HashMap<[i64; 4], Vec<[DVec3; 3]>>,
}

/// Plane quantization: normals in steps of 1/64, distances of 5 cm.
const NORMAL_STEP: f64 = 1.0 / 64.0;
const DISTANCE_STEP: f64 = 0.05;

impl FacePlanes {
    fn new(tris: impl IntoIterator<Item = [glam::Vec3; 3]>) -> FacePlanes {
        let mut by_plane: std::collections::HashMap<[i64; 4], Vec<[DVec3; 3]>> = Default::default();
        for t in tris {
            let t = t.map(|p| p.as_dvec3());
            let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
            if n != DVec3::ZERO {
                by_plane.entry(Self::key(n, n.dot(t[0]))).or_default().push(t);
            }
        }
        FacePlanes { by_plane }
    }

    /// The plane `n·p = d` quantized.
    fn raw(n: DVec3, d: f64) -> [i64; 4] {
        [
            (n.x / NORMAL_STEP).round() as i64,
            (n.y / NORMAL_STEP).round() as i64,
            (n.z / NORMAL_STEP).round() as i64,
            (d / DISTANCE_STEP).round() as i64,
        ]
    }

    /// A quantized plane turned so that its first nonzero normal step is
    /// positive: the same key either way round (rounding is symmetric).
    fn canonical(k: [i64; 4]) -> [i64; 4] {
        let first = k[..3].iter().copied().find(|&c| c != 0).unwrap_or(0);
        if first < 0 {
            k.map(|c| -c)
        } else {
            k
        }
    }

    fn key(n: DVec3, d: f64) -> [i64; 4] {
        Self::canonical(Self::raw(n, d))
    }

    /// Candidates for the triangles on the plane of polygon `w` (a superset:
    /// [`covered`] keeps those within [`ON_FACE`] of it).
    fn on_plane_of(&self, w: &[DVec3]) -> Vec<[DVec3; 3]> {
        let n = winding_normal(w);
        let mut out = Vec::new();
        if n == DVec3::ZERO {
            return out;
        }
        // Every key a plane within rounding of this one may have.
        let [x, y, z, d] = Self::raw(n, n.dot(w[0]));
        let mut keys = Vec::new();
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    for dd in -1..=1 {
                        keys.push(Self::canonical([x + dx, y + dy, z + dz, d + dd]));
                    }
                }
            }
        }
        keys.sort_unstable();
        keys.dedup();
        // Only those reaching the polygon's box.
        let lo = w.iter().fold(DVec3::INFINITY, |a, &p| a.min(p)) - ON_FACE;
        let hi = w.iter().fold(DVec3::NEG_INFINITY, |a, &p| a.max(p)) + ON_FACE;
        for k in keys {
            if let Some(tris) = self.by_plane.get(&k) {
                out.extend(tris.iter().filter(|t| {
                    let (tlo, thi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
                    tlo.cmple(hi).all() && thi.cmpge(lo).all()
                }));
            }
        }
        out
    }
}

/// A face this far from a wall's plane (metres) lies on it: the compiler
/// snaps the corners of faces on slanted planes by up to a millimetre off
/// the plane its tree keeps.
const ON_FACE: f64 = 2e-3;

/// What is left of a portal narrower than this (metres) is taken as
/// covered: the seams between faces that meet, as the float corners and
/// the compiler's snapping (see [`ON_FACE`]) leave them along the wall's
/// edges.
const SEAM: f64 = 2e-3;

/// Most pieces a portal is cut into while the faces are taken away; past
/// it the portal counts as open.
const MAX_PIECES: usize = 256;

/// Is the convex polygon `poly` (on its plane, hom coordinates) covered by
/// those of `tris` that lie on its plane? The triangles are taken away from
/// it in the plane, piece by convex piece, up to seams narrower than
/// [`SEAM`]. Sight may pass where it is not: an undrawn face, a side the
/// compiler kept no face for, a face off the plane.
fn covered(poly: &[DVec3], tris: &[[DVec3; 3]]) -> bool {
    let n = winding_normal(poly);
    if n == DVec3::ZERO {
        return true;
    }
    let d = n.dot(poly[0]);
    let u = n.any_orthonormal_vector();
    let v = n.cross(u);
    let flat = |p: DVec3| glam::DVec2::new(p.dot(u), p.dot(v));
    let mut pieces = vec![poly.iter().map(|&p| flat(p)).collect::<Vec<_>>()];
    for t in tris
        .iter()
        .filter(|t| t.iter().all(|p| (n.dot(*p) - d).abs() <= ON_FACE))
    {
        let mut t = t.map(flat);
        if (t[1] - t[0]).perp_dot(t[2] - t[0]) < 0.0 {
            t.swap(1, 2);
        }
        let mut left = Vec::new();
        for mut piece in pieces {
            // Outside each edge in turn: kept; inside all three: taken away.
            for e in 0..3 {
                let (a, b) = (t[e], t[(e + 1) % 3]);
                let (outside, inside) = cut(&piece, a, b);
                if !is_seam(&outside) {
                    left.push(outside);
                }
                piece = inside;
                if is_seam(&piece) {
                    break;
                }
            }
        }
        if left.len() > MAX_PIECES {
            return false;
        }
        pieces = left;
        if pieces.is_empty() {
            return true;
        }
    }
    false
}

/// Cuts the convex polygon `w` by the line through `a` and `b`: the parts
/// to its right and to its left.
fn cut(w: &[glam::DVec2], a: glam::DVec2, b: glam::DVec2) -> (Vec<glam::DVec2>, Vec<glam::DVec2>) {
    let dir = (b - a).normalize_or_zero();
    let side: Vec<f64> = w.iter().map(|&p| dir.perp_dot(p - a)).collect();
    let (mut right, mut left) = (Vec::new(), Vec::new());
    for i in 0..w.len() {
        let j = (i + 1) % w.len();
        let (si, sj) = (side[i], side[j]);
        if si <= 0.0 {
            right.push(w[i]);
        }
        if si >= 0.0 {
            left.push(w[i]);
        }
        if (si < 0.0 && sj > 0.0) || (si > 0.0 && sj < 0.0) {
            let m = w[i] + (w[j] - w[i]) * (si / (si - sj));
            right.push(m);
            left.push(m);
        }
    }
    (right, left)
}

/// Is the convex polygon `w` empty or narrower than [`SEAM`] (its area
/// under half its perimeter times the width)?
fn is_seam(w: &[glam::DVec2]) -> bool {
    if w.len() < 3 {
        return true;
    }
    // About its first corner: the products stay as small as the polygon.
    let (mut area2, mut perimeter) = (0.0, 0.0);
    for i in 0..w.len() {
        let j = (i + 1) % w.len();
        area2 += (w[i] - w[0]).perp_dot(w[j] - w[0]);
        perimeter += (w[j] - w[i]).length();
    }
    area2.abs() <= perimeter * SEAM
}

/// Per leaf: did the map compiler fill it for its `vis` alone? Such a leaf
/// has no cluster and lists an antiportal (`leaf_brushes`), and no opaque
/// brush it lists (planes in `brush_planes`, of `pvs`) holds every corner
/// of its portals (`all`, from [`all_leaf_portals`]): sight passes
/// through it, and on into the brushes around it, whose faces the compiler
/// dropped there.
fn vis_only_leaves(pvs: &Pvs, all: &[Portal], leaf_brushes: &[LeafBrushes], brush_planes: &[Vec<u32>]) -> Vec<bool> {
    let mut corners: Vec<Vec<DVec3>> = vec![Vec::new(); pvs.leaf_cluster.len()];
    for p in all {
        for &c in &p.cells {
            if leaf_brushes.get(c as usize).is_some_and(|b| b.antiportal) {
                corners[c as usize].extend(p.points.iter().map(|&h| hom_to_quake(h)));
            }
        }
    }
    (0..pvs.leaf_cluster.len())
        .map(|l| {
            let Some(listed) = leaf_brushes.get(l).filter(|b| b.antiportal && pvs.leaf_cluster[l] < 0) else {
                return false;
            };
            !listed.opaque.iter().any(|&b| {
                brush_planes[b as usize].iter().all(|&k| {
                    let (n, d) = pvs.planes[k as usize];
                    let n = DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64);
                    corners[l].iter().all(|&c| n.dot(c) - d as f64 <= INSIDE)
                })
            })
        })
        .collect()
}

/// The cells (`cells` of them) that `portals` between cells `walk` allows
/// join to one of `from` (those `walk` refuses, or out of range, are
/// ignored), as flags by cell: where a camera goes from there, or sight
/// through solid space.
fn reached_leaves(
    portals: &[Portal],
    cells: usize,
    from: impl IntoIterator<Item = u32>,
    walk: impl Fn(u32) -> bool,
) -> Vec<bool> {
    let mut neighbours = vec![Vec::new(); cells];
    for p in portals.iter().filter(|p| p.cells.iter().all(|&c| walk(c))) {
        neighbours[p.cells[0] as usize].push(p.cells[1]);
        neighbours[p.cells[1] as usize].push(p.cells[0]);
    }
    let mut reached = vec![false; cells];
    let mut stack: Vec<u32> = from
        .into_iter()
        .filter(|&l| (l as usize) < reached.len() && walk(l))
        .collect();
    while let Some(l) = stack.pop() {
        if !std::mem::replace(&mut reached[l as usize], true) {
            stack.extend(neighbours[l as usize].iter().copied().filter(|&m| !reached[m as usize]));
        }
    }
    reached
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

/// [`quake_to_hom`]'s inverse.
fn hom_to_quake(h: DVec3) -> DVec3 {
    DVec3::new(h.x, -h.z, h.y) / super::INCH as f64
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

    /// The portals sight may pass through between the map's leaves (cells
    /// are leaf indices, then sinks: cells from [`BspMap::leaf_count`] on,
    /// each standing for a clustered leaf that sight from solid space meets
    /// only up to its faces; hom coordinates), built from its BSP tree as the
    /// module docs say.
    pub fn leaf_portals(&self) -> Result<PortalGraph, PortalError> {
        Ok(self.sight_portals(None)?.graph)
    }

    /// [`BspMap::leaf_portals`] for sight from the clustered leaves a camera
    /// reaches from `eyes` (every clustered leaf without them).
    fn sight_portals(&self, eyes: Option<&[glam::Vec3]>) -> Result<Sight, PortalError> {
        let all = all_leaf_portals(&self.pvs);
        let open = |l: u32| self.leaf_cluster(l).is_some();
        let reached = match eyes {
            Some(eyes) => reached_leaves(
                &all,
                self.leaf_count(),
                eyes.iter().filter_map(|&e| self.leaf_of(e)),
                open,
            ),
            None => (0..self.leaf_count() as u32).map(open).collect(),
        };
        let vis_only = vis_only_leaves(&self.pvs, &all, &self.leaf_brushes, &self.brush_planes);
        // Per portal between a clustered leaf and a solid one: is it covered
        // by the drawn faces on its plane?
        // The scene's triangles are the drawn faces, in world positions.
        let faces = FacePlanes::new(self.scene.objects().iter().flat_map(|o| {
            let mesh = self.scene.mesh_of(o);
            mesh.triangles().iter().map(|t| t.map(|i| mesh.positions()[i as usize]))
        }));
        let walled: Vec<bool> = all
            .iter()
            .map(|p| open(p.cells[0]) != open(p.cells[1]) && covered(&p.points, &faces.on_plane_of(&p.points)))
            .collect();
        let sight = leaf_portals(&self.pvs, all, &walled, &vis_only, &reached);
        let graph = PortalGraph::new(self.leaf_count() + sight.sinks.len(), sight.portals)?;
        Ok(Sight {
            graph,
            sinks: sight.sinks,
            reached,
        })
    }

    /// The objects each cluster may see through the map's leaf portals: a
    /// bit set over object ids per cluster (bit `k` of word `k / 64`). An
    /// object lies in the leaves whose face lists hold its faces
    /// ([`BspMap::object_leaves`]), as the map's own PVS takes it; objects in
    /// no clustered leaf are visible from every cluster.
    ///
    /// Sight is followed from the space the camera reaches: the clustered
    /// leaves the portals between clustered leaves join to a leaf holding
    /// one of `eyes` (the camera path's). A
    /// cluster with a leaf outside it sees every object: a pocket sealed
    /// inside the walls (the map compiler keeps one open when an entity sits
    /// in it) is bounded by the backs of brushes whose faces it removed, and
    /// the renderer sees through them. Uses every thread of the current
    /// rayon pool; `progress(done, total)` after each leaf followed.
    pub fn portal_pvs(
        &self,
        eyes: &[glam::Vec3],
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<PortalPvs, PortalError> {
        let Sight { graph, sinks, reached } = self.sight_portals(Some(eyes))?;
        let mut sink_of: Vec<Vec<u32>> = vec![Vec::new(); self.leaf_count()];
        for (k, &leaf) in sinks.iter().enumerate() {
            sink_of[leaf as usize].push((self.leaf_count() + k) as u32);
        }
        let scene_objects = self.scene.objects();
        let touching = &self.object_leaves;
        // An object lies in its clustered leaves, their sinks, and the leaves
        // without a cluster sight may reach (no window enters the others).
        let objects = PortalObjects::new(
            graph.cell_count(),
            scene_objects
                .iter()
                .zip(touching.iter().zip(&self.object_solid_leaves))
                .map(|(o, (t, s))| {
                    let sinks = t.iter().flat_map(|&l| sink_of[l as usize].iter().copied());
                    (o.aabb, t.iter().chain(s).copied().chain(sinks).collect())
                }),
        )?;
        let sources: Vec<u32> = (0..self.leaf_count() as u32)
            .filter(|&l| reached[l as usize] && self.leaf_cluster(l).is_some())
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
        // Clusters with a leaf no eye reaches: everything.
        let mut unreached = 0;
        for l in 0..self.leaf_count() as u32 {
            if let Some(c) = self.leaf_cluster(l).filter(|_| !reached[l as usize]) {
                unreached += usize::from(visible[c as usize].iter().any(|&w| w != !0));
                visible[c as usize].fill(!0);
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
            unreached,
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
    unreached: usize,
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

    /// Clustered leaves followed (the sources: those the eyes reach).
    pub fn leaf_count(&self) -> usize {
        self.leaves
    }

    /// Clusters that see every object because no eye reaches one of their
    /// leaves.
    pub fn unreached_clusters(&self) -> usize {
        self.unreached
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
            // Every wall covered: the portals join open leaves only.
            let n = pvs.leaf_cluster.len();
            let all = all_leaf_portals(&pvs);
            let walls = vec![true; all.len()];
            let portals = leaf_portals(&pvs, all, &walls, &vec![false; n], &vec![true; n]).portals;
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

    /// A leaf without a cluster that lists an antiportal is filled for `vis`
    /// alone unless one of its opaque brushes holds all of it.
    #[test]
    fn leaves_filled_for_vis_alone() {
        // x ≥ 0: leaf 0 (open); x < 0 and z ≥ 100: leaf 1; x < 0 and z < 100: leaf 2.
        let pvs = Pvs {
            planes: vec![
                ([1.0, 0.0, 0.0], 0.0),
                ([0.0, 0.0, 1.0], 100.0),
                ([-1.0, 0.0, 0.0], WORLD as f32),
            ],
            nodes: vec![(0, -1, 1), (1, -2, -3)],
            leaf_cluster: vec![0, -1, -1],
            ..Pvs::default()
        };
        let all = all_leaf_portals(&pvs);
        // One opaque brush: x in [−WORLD, 0], z below 100, all y (the world's bounds).
        let brush_planes = vec![vec![0, 1, 2]];
        let listed = |antiportal| LeafBrushes {
            opaque: vec![0],
            antiportal,
        };
        let leaf_brushes = vec![LeafBrushes::default(), listed(true), listed(true)];
        assert_eq!(
            vis_only_leaves(&pvs, &all, &leaf_brushes, &brush_planes),
            [false, true, false]
        );
        // Without the antiportal the compiler had a brush of its own there.
        let leaf_brushes = vec![LeafBrushes::default(), listed(false), listed(true)];
        assert_eq!(
            vis_only_leaves(&pvs, &all, &leaf_brushes, &brush_planes),
            [false, false, false]
        );
    }

    /// The leaves the portals join to the start, and no others.
    #[test]
    fn reached_leaves_follow_the_portals() {
        let square = |x: f64| {
            vec![
                DVec3::new(x, 0.0, 0.0),
                DVec3::new(x, 1.0, 0.0),
                DVec3::new(x, 1.0, 1.0),
            ]
        };
        let portals = vec![
            Portal {
                cells: [0, 1],
                points: square(1.0),
            },
            Portal {
                cells: [1, 2],
                points: square(2.0),
            },
            Portal {
                cells: [3, 4],
                points: square(4.0),
            },
        ];
        let all = |_| true;
        assert_eq!(reached_leaves(&portals, 5, [2], all), [true, true, true, false, false]);
        assert_eq!(
            reached_leaves(&portals, 5, [4, 9], all),
            [false, false, false, true, true]
        );
        assert_eq!(reached_leaves(&portals, 5, [], all), [false; 5]);
        // Not through cell 1.
        assert_eq!(
            reached_leaves(&portals, 5, [2], |c| c != 1),
            [false, false, true, false, false]
        );
    }

    /// Through a wall the drawn faces do not cover, sight enters solid
    /// space: the portals then reach the solid leaves there and on through
    /// solid leaves, and only there; from solid space a covered wall leads
    /// to a sink standing for the leaf behind it.
    #[test]
    fn open_walls_let_sight_into_the_solid_space_behind_them() {
        let (mut opened, mut sunk_portals) = (0, 0);
        for seed in 0..60u64 {
            let mut rng = Rng::new(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) + 11);
            let pvs = random_tree(&mut rng, 5);
            let leaves = pvs.leaf_cluster.len();
            let open = |l: u32| pvs.leaf_cluster[l as usize] >= 0;
            let vis_only: Vec<bool> = (0..leaves as u32).map(|l| !open(l) && rng.unit() < 0.1).collect();
            let all = all_leaf_portals(&pvs);
            let walled: Vec<bool> = all.iter().map(|_| rng.unit() < 0.8).collect();
            let seen_from: Vec<bool> = (0..leaves).map(|_| rng.unit() < 0.8).collect();
            let kept = leaf_portals(&pvs, all.clone(), &walled, &vis_only, &seen_from);
            // Solid leaves sight reaches: those filled for `vis` alone, and
            // those behind an open leaf's wall that is not covered; then on.
            let mut reach = vis_only.clone();
            let mut changed = true;
            while changed {
                changed = false;
                for (k, p) in all.iter().enumerate() {
                    for (a, b) in [(p.cells[0], p.cells[1]), (p.cells[1], p.cells[0])] {
                        let from = (open(a) && seen_from[a as usize] && !walled[k]) || (!open(a) && reach[a as usize]);
                        if from && !open(b) && !reach[b as usize] {
                            reach[b as usize] = true;
                            changed = true;
                        }
                    }
                }
            }
            let passable = |l: u32| open(l) || reach[l as usize];
            // From solid space (not filled for `vis` alone) into a clustered
            // leaf through a covered wall: a sink standing for it.
            let sunk = |k: usize, from: u32, to: u32| {
                reach[from as usize] && !vis_only[from as usize] && open(to) && walled[k]
            };
            let mut sinks: Vec<u32> = Vec::new();
            let mut want: Vec<[u32; 2]> = Vec::new();
            for (k, p) in all
                .iter()
                .enumerate()
                .filter(|(_, p)| p.cells.iter().all(|&c| passable(c)))
            {
                let mut cells = p.cells;
                for (side, cell) in cells.iter_mut().enumerate() {
                    let to = p.cells[side];
                    if sunk(k, p.cells[1 - side], to) {
                        let at = sinks.iter().position(|&s| s == to).unwrap_or_else(|| {
                            sinks.push(to);
                            sinks.len() - 1
                        });
                        *cell = (leaves + at) as u32;
                    }
                }
                want.push(cells);
            }
            let got: Vec<[u32; 2]> = kept.portals.iter().map(|p| p.cells).collect();
            assert_eq!(got, want, "seed {seed}");
            assert_eq!(kept.sinks, sinks, "seed {seed}");
            let solid = |l: u32| (l as usize) < leaves && !open(l);
            opened += got.iter().filter(|c| solid(c[0]) || solid(c[1])).count();
            sunk_portals += got.iter().filter(|c| c.iter().any(|&x| x as usize >= leaves)).count();
        }
        assert!(opened > 20, "some portals should reach into solid space: {opened}");
        assert!(
            sunk_portals > 5,
            "some should meet faces from solid space: {sunk_portals}"
        );
    }

    /// A portal is covered where drawn triangles on its plane tile it, up
    /// to seams; not where one is missing, off the plane, or a gap is wider
    /// than a seam.
    #[test]
    fn walls_are_covered_by_the_faces_on_them() {
        let p = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
        let square = [p(0.0, 0.0, 1.0), p(1.0, 0.0, 1.0), p(1.0, 1.0, 1.0), p(0.0, 1.0, 1.0)];
        let halves = [
            [p(0.0, 0.0, 1.0), p(1.0, 0.0, 1.0), p(1.0, 1.0, 1.0)],
            [p(0.0, 0.0, 1.0), p(1.0, 1.0, 1.0), p(0.0, 1.0, 1.0)],
        ];
        assert!(covered(&square, &halves));
        assert!(!covered(&square, &halves[..1]));
        // One face bigger than the portal, wound the other way.
        let big = [[p(-5.0, -5.0, 1.0), p(-5.0, 9.0, 1.0), p(9.0, -5.0, 1.0)]];
        assert!(covered(&square, &big));
        // Off the plane by a millimetre: on it; by 5 mm: no cover.
        for (lift, want) in [(1e-3, true), (5e-3, false)] {
            let lifted = halves.map(|t| t.map(|q| q + DVec3::Z * lift));
            assert_eq!(covered(&square, &lifted), want, "lift {lift}");
        }
        // A seam of a millimetre between the halves is covered; a gap of 1 cm is not.
        for (gap, want) in [(1e-3, true), (1e-2, false)] {
            let shifted = [halves[0], halves[1].map(|q| q + DVec3::new(-gap, gap, 0.0))];
            assert_eq!(covered(&square, &shifted), want, "gap {gap}");
        }
        // A random fan of triangles from an inner point covers it; less one, not.
        let mut rng = Rng::new(7);
        for _ in 0..50 {
            let c = p(0.05 + 0.9 * rng.unit() as f64, 0.05 + 0.9 * rng.unit() as f64, 1.0);
            let fan: Vec<[DVec3; 3]> = (0..4).map(|i| [c, square[i], square[(i + 1) % 4]]).collect();
            assert!(covered(&square, &fan), "{c} {fan:?}");
            let skip = rng.below(4) as usize;
            let less: Vec<[DVec3; 3]> = fan
                .iter()
                .enumerate()
                .filter(|(i, _)| *i != skip)
                .map(|(_, t)| *t)
                .collect();
            assert!(!covered(&square, &less));
        }
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
