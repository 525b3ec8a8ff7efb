//! Cells and portals, and what a cell sees through them (Teller & Séquin
//! 1991, "Visibility preprocessing for interactive walkthroughs", sections
//! 3–4: visibility through portal sequences, bounded by separating planes
//! as the Quake tools' `vis` clips with them).
//!
//! The open space is cut into convex **cells**; a **portal** is a convex
//! polygon where two cells meet, and every other point of a cell's boundary
//! is opaque. A line of sight from an eye in cell `L` to a point outside
//! `L` leaves through one of `L`'s portals, `S`, and then crosses portals
//! `P₁, …, Pₖ` into the point's cell. Two facts bound where it can go:
//!
//! - after crossing a portal a line stays in front of its plane;
//! - a plane with a set `A` behind it and a set `B` in front is a
//!   **separating plane** of `A` and `B`: a line through a point of each
//!   crosses it from back to front, and stays in front past `B`.
//!
//! [`PortalGraph::visible_objects`] follows, for each `S`, every line
//! through `S` at once. Per directed portal `P` it keeps two convex
//! polygons, **windows**: `W(P)` in `P`, holding every such line's crossing
//! with `P`, and `V(P)` in `S`, holding where those lines left `S`.
//! Stepping from `P` into the next portal `Q`:
//!
//! - `Q` is clipped to the front of `S`, of `P`, and of every separating
//!   plane of `V(P)` and `W(P)` (through an edge of one and a corner of the
//!   other, as `vis` builds them); `V(P)` to the back of `Q`'s plane, where
//!   every line crossing `Q` starts. A portal in `P`'s own plane leads back.
//! - What is left is merged into `W(Q)` and `V(Q)` as convex hulls; `Q` is
//!   followed again whenever they grow, until nothing grows.
//!
//! By induction every line through `S` and `P₁, …, Pᵢ` crosses `Pᵢ` within
//! `W(Pᵢ)` having left `S` within `V(Pᵢ)`: windows are hulls of supersets,
//! never subsets. Merging windows of different sequences loses some
//! tightness against following each sequence apart (`vis`, Teller), but
//! the work is bounded by how often windows grow, not by how many
//! sequences there are, which in the slivers of a BSP tree's open space
//! is exponential: on a Quake 3 map sequence by sequence took 80–340 s
//! (with step budgets), the windows 2.5 s, for 36.5 % against 36.9 % of
//! the frustum's triangles. A portal whose windows grew
//! [`MAX_GROWTH`] times is taken whole, with the whole of `S`.
//!
//! An object is visible from `L` when it touches `L` or a cell just past
//! one of `L`'s portals, or when a portal `P` into a cell it touches has
//! windows and its box is not wholly behind `S`, `P`, or a separating
//! plane of `V(P)` and `W(P)`: a line reaching a point of the object in
//! that cell crossed `P` within the windows, and stays in front of all of
//! them. Every clip and test keeps what lies within [`SLACK`] of a plane,
//! so rounding widens, never narrows. What the argument assumes, the caller
//! states: cells and portals tile the open space, every visible point of
//! an object lies in a cell it is said to touch, and the eye is in an open
//! cell.

use crate::geom::Aabb;
use glam::DVec3;
use thiserror::Error;

/// How far (metres) behind a plane a point still counts as in front of it,
/// in every clip and test: far above `f64` rounding, far below a pixel.
pub const SLACK: f64 = 1e-3;

/// A convex polygon where two cells meet.
#[derive(Clone, Debug, PartialEq)]
pub struct Portal {
    /// The cells on either side: `cells[0]` in front of the polygon's plane
    /// (its normal, from the winding's order, points into it), `cells[1]` behind.
    pub cells: [u32; 2],
    /// The polygon's corners, in order (at least three, not collinear).
    pub points: Vec<DVec3>,
}

/// Why cells and portals do not make a graph.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum PortalError {
    /// A portal names a cell that does not exist, or the same cell twice.
    #[error("portal {portal} joins cells {a} and {b}, but there are {cells} cells and a portal joins two")]
    BadCells {
        /// The portal's index.
        portal: usize,
        /// Its first cell.
        a: u32,
        /// Its second cell.
        b: u32,
        /// How many cells there are.
        cells: usize,
    },
    /// A portal's polygon is degenerate or not finite.
    #[error("portal {portal} is not a polygon: {what}")]
    BadPolygon {
        /// The portal's index.
        portal: usize,
        /// What is wrong.
        what: &'static str,
    },
    /// An object touches a cell that does not exist.
    #[error("object {object} touches cell {cell}, but there are {cells} cells")]
    BadObjectCell {
        /// The object's index.
        object: usize,
        /// The cell.
        cell: u32,
        /// How many cells there are.
        cells: usize,
    },
}

/// A portal crossed one way: into `to`, its plane's normal pointing there.
#[derive(Clone, Debug)]
struct Directed {
    to: u32,
    normal: DVec3,
    d: f64,
    points: Vec<DVec3>,
}

/// Cells and the portals between them.
#[derive(Clone, Debug)]
pub struct PortalGraph {
    cells: usize,
    portals: Vec<Portal>,
    /// Two per portal: `2k` into `cells[0]`, `2k + 1` into `cells[1]`.
    directed: Vec<Directed>,
    /// Per cell, the directed portals leaving it.
    leaving: Vec<Vec<u32>>,
}

/// The objects to find: each object's box and the cells it touches.
#[derive(Clone, Debug)]
pub struct PortalObjects {
    boxes: Vec<(DVec3, DVec3)>,
    /// Per cell, the objects touching it (ascending).
    in_cell: Vec<Vec<u32>>,
}

impl PortalObjects {
    /// Objects by index: each one's box and the cells it touches (any
    /// order, repeats allowed). Boxes are widened by [`SLACK`].
    pub fn new(
        cells: usize,
        objects: impl IntoIterator<Item = (Aabb, Vec<u32>)>,
    ) -> Result<PortalObjects, PortalError> {
        let mut boxes = Vec::new();
        let mut in_cell = vec![Vec::new(); cells];
        for (k, (aabb, mut touches)) in objects.into_iter().enumerate() {
            boxes.push((aabb.min.as_dvec3() - SLACK, aabb.max.as_dvec3() + SLACK));
            touches.sort_unstable();
            touches.dedup();
            for c in touches {
                let list = in_cell.get_mut(c as usize).ok_or(PortalError::BadObjectCell {
                    object: k,
                    cell: c,
                    cells,
                })?;
                if list.last() != Some(&(k as u32)) {
                    list.push(k as u32);
                }
            }
        }
        Ok(PortalObjects { boxes, in_cell })
    }

    /// How many objects.
    pub fn len(&self) -> usize {
        self.boxes.len()
    }

    /// No objects at all.
    pub fn is_empty(&self) -> bool {
        self.boxes.is_empty()
    }
}

fn words(n: usize) -> usize {
    n.div_ceil(64)
}

fn has(bits: &[u64], i: u32) -> bool {
    bits[i as usize / 64] & (1 << (i % 64)) != 0
}

fn set(bits: &mut [u64], i: u32) {
    bits[i as usize / 64] |= 1 << (i % 64);
}

/// The plane of a polygon by Newell's method: unit normal and offset, or
/// `None` when the polygon has no area.
fn polygon_plane(points: &[DVec3]) -> Option<(DVec3, f64)> {
    let mut n = DVec3::ZERO;
    let mut centre = DVec3::ZERO;
    for (i, a) in points.iter().enumerate() {
        let b = points[(i + 1) % points.len()];
        n += DVec3::new(
            (a.y - b.y) * (a.z + b.z),
            (a.z - b.z) * (a.x + b.x),
            (a.x - b.x) * (a.y + b.y),
        );
        centre += *a;
    }
    let len = n.length();
    if len.is_nan() || len <= 1e-12 {
        return None;
    }
    let n = n / len;
    Some((n, n.dot(centre / points.len() as f64)))
}

/// Clips the convex polygon `poly` in place to its part with
/// `n·p − d ≥ −SLACK`, emptied when fewer than 3 corners remain; `scratch`
/// is reused, so the bake's millions of clips allocate nothing.
fn clip(poly: &mut Vec<DVec3>, n: DVec3, d: f64, scratch: &mut Vec<DVec3>) {
    let dist = |p: DVec3| n.dot(p) - d + SLACK;
    if poly.iter().all(|&p| dist(p) >= 0.0) {
        return;
    }
    scratch.clear();
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        let (da, db) = (dist(a), dist(b));
        if da >= 0.0 {
            scratch.push(a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            scratch.push(a + (b - a) * (da / (da - db)));
        }
    }
    if scratch.len() < 3 {
        scratch.clear();
    }
    std::mem::swap(poly, scratch);
}

/// Planes with `source` behind and `pass` in front (unit normals, pointing
/// to `pass`): through an edge of one polygon and a corner of the other.
fn separators(source: &[DVec3], pass: &[DVec3], out: &mut Vec<(DVec3, f64)>) {
    out.clear();
    // A plane qualifies when no corner is on the wrong side by more than
    // rounding: a line through both then stays within `SLACK` of its front.
    const ON: f64 = 1e-9;
    for (edges, corners, flip) in [(source, pass, false), (pass, source, true)] {
        for i in 0..edges.len() {
            let (a, b) = (edges[i], edges[(i + 1) % edges.len()]);
            for &c in corners {
                let n = (b - a).cross(c - a);
                let len = n.length();
                if len.is_nan() || len <= 1e-12 {
                    continue;
                }
                let mut n = n / len;
                let mut d = n.dot(a);
                // Orient it: the edges' polygon behind when it is the source,
                // in front when it is the pass.
                let side = edges
                    .iter()
                    .map(|p| n.dot(*p) - d)
                    .fold(0.0, |m: f64, s| if s.abs() > m.abs() { s } else { m });
                if (side > 0.0) != flip {
                    n = -n;
                    d = -d;
                }
                if source.iter().all(|p| n.dot(*p) - d <= ON) && pass.iter().all(|p| n.dot(*p) - d >= -ON) {
                    out.push((n, d));
                }
            }
        }
    }
}

/// Is the box wholly more than `SLACK` behind the plane?
fn box_behind(b: &(DVec3, DVec3), n: DVec3, d: f64) -> bool {
    let far = DVec3::new(
        if n.x >= 0.0 { b.1.x } else { b.0.x },
        if n.y >= 0.0 { b.1.y } else { b.0.y },
        if n.z >= 0.0 { b.1.z } else { b.0.z },
    );
    n.dot(far) - d < -SLACK
}

/// A convex polygon's corners in its plane's coordinates: the two axes
/// other than the normal's largest.
fn plane_axes(normal: DVec3) -> (usize, usize) {
    let a = normal.abs();
    if a.x >= a.y && a.x >= a.z {
        (1, 2)
    } else if a.y >= a.z {
        (2, 0)
    } else {
        (0, 1)
    }
}

/// The convex hull of coplanar points (Andrew's monotone chain in the
/// plane's axes), corners in order, collinear ones dropped.
fn hull(points: &[DVec3], normal: DVec3) -> Vec<DVec3> {
    let (u, v) = plane_axes(normal);
    let mut p: Vec<DVec3> = points.to_vec();
    p.sort_by(|a, b| a[u].total_cmp(&b[u]).then(a[v].total_cmp(&b[v])));
    p.dedup();
    if p.len() < 3 {
        return p;
    }
    let cross = |o: DVec3, a: DVec3, b: DVec3| (a[u] - o[u]) * (b[v] - o[v]) - (a[v] - o[v]) * (b[u] - o[u]);
    // The lower chain, then the upper one, each without its last corner.
    let mut out: Vec<DVec3> = Vec::with_capacity(p.len() + 1);
    for chain in [p.clone(), p.into_iter().rev().collect()] {
        let start = out.len();
        for q in chain {
            while out.len() >= start + 2 && cross(out[out.len() - 2], out[out.len() - 1], q) <= 0.0 {
                out.pop();
            }
            out.push(q);
        }
        out.pop();
    }
    out
}

/// Is every point of `inner` within [`SLACK`] of the convex polygon
/// `outer` (both in the plane with `normal`)?
fn contains(outer: &[DVec3], inner: &[DVec3], normal: DVec3) -> bool {
    let centre = outer.iter().copied().sum::<DVec3>() / outer.len() as f64;
    (0..outer.len()).all(|i| {
        let (a, b) = (outer[i], outer[(i + 1) % outer.len()]);
        let mut n = (b - a).cross(normal);
        let len = n.length();
        if len.is_nan() || len <= 1e-12 {
            return true;
        }
        n /= len;
        if n.dot(centre - a) > 0.0 {
            n = -n; // Outward.
        }
        inner.iter().all(|p| n.dot(*p - a) <= SLACK)
    })
}

/// How often a portal's windows may grow in one search before they are
/// taken whole (the whole portal, and the whole source): a bound on the
/// work, at the cost of tightness only (16 and 40 gave the same sets on a
/// Quake 3 map).
pub const MAX_GROWTH: u8 = 16;

impl PortalGraph {
    /// The graph of `cells` cells joined by `portals`; checks every portal.
    pub fn new(cells: usize, portals: Vec<Portal>) -> Result<PortalGraph, PortalError> {
        let mut directed = Vec::with_capacity(2 * portals.len());
        let mut leaving = vec![Vec::new(); cells];
        for (k, p) in portals.iter().enumerate() {
            let [a, b] = p.cells;
            if a == b || a as usize >= cells || b as usize >= cells {
                return Err(PortalError::BadCells { portal: k, a, b, cells });
            }
            if p.points.len() < 3 {
                return Err(PortalError::BadPolygon {
                    portal: k,
                    what: "fewer than three corners",
                });
            }
            if !p.points.iter().all(|q| q.is_finite()) {
                return Err(PortalError::BadPolygon {
                    portal: k,
                    what: "a corner is not finite",
                });
            }
            let (n, d) = polygon_plane(&p.points).ok_or(PortalError::BadPolygon {
                portal: k,
                what: "no area",
            })?;
            let reversed: Vec<DVec3> = p.points.iter().rev().copied().collect();
            directed.push(Directed {
                to: a,
                normal: n,
                d,
                points: p.points.clone(),
            });
            directed.push(Directed {
                to: b,
                normal: -n,
                d: -d,
                points: reversed,
            });
            leaving[b as usize].push(2 * k as u32);
            leaving[a as usize].push(2 * k as u32 + 1);
        }
        Ok(PortalGraph {
            cells,
            portals,
            directed,
            leaving,
        })
    }

    /// How many cells.
    pub fn cell_count(&self) -> usize {
        self.cells
    }

    /// The portals, as given.
    pub fn portals(&self) -> &[Portal] {
        &self.portals
    }

    /// [`PortalGraph::visible_objects`] from each of `sources`, on every
    /// thread of the current rayon pool; `progress(done, total)` after each.
    pub fn visible_objects_from(
        &self,
        sources: &[u32],
        objects: &PortalObjects,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Vec<Vec<u64>> {
        use rayon::prelude::*;
        let done = std::sync::atomic::AtomicUsize::new(0);
        sources
            .par_iter()
            .map(|&c| {
                let visible = self.visible_objects(c, objects);
                progress(
                    done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1,
                    sources.len(),
                );
                visible
            })
            .collect()
    }

    /// The objects potentially visible from any point of cell `from`, a bit
    /// set over `objects` (bit `k` of word `k / 64`). See the module docs
    /// for the argument.
    ///
    /// # Panics
    /// If `from` is not a cell of the graph or `objects` was made for
    /// another number of cells.
    pub fn visible_objects(&self, from: u32, objects: &PortalObjects) -> Vec<u64> {
        assert_eq!(objects.in_cell.len(), self.cells, "objects made for another graph");
        let mut visible = vec![0; words(objects.len())];
        let reveal_cell = |visible: &mut Vec<u64>, cell: u32| {
            for &o in &objects.in_cell[cell as usize] {
                set(visible, o);
            }
        };
        reveal_cell(&mut visible, from);
        for &s in &self.leaving[from as usize] {
            reveal_cell(&mut visible, self.directed[s as usize].to);
        }
        let mut search = Search::new(self);
        for &s in &self.leaving[from as usize] {
            search.run(s, objects, &mut visible);
        }
        visible
    }
}

/// What lines from one source portal may do at one portal further on:
/// cross it within `window`, having left the source within `source`.
#[derive(Clone, Debug, Default)]
struct Windows {
    source: Vec<DVec3>,
    window: Vec<DVec3>,
    growth: u8,
    queued: bool,
}

/// The lines through one source portal, followed portal to portal: per
/// directed portal, windows that hold every such line's crossings, grown
/// (convex hulls) until nothing grows.
struct Search<'a> {
    graph: &'a PortalGraph,
    at: Vec<Option<Windows>>,
    touched: Vec<u32>,
    queue: std::collections::VecDeque<u32>,
    separators: Vec<(DVec3, f64)>,
    /// Polygons reused from step to step: the windows being followed, a
    /// step's results, and clipping's scratch.
    polygons: [Vec<DVec3>; 5],
}

impl<'a> Search<'a> {
    fn new(graph: &'a PortalGraph) -> Search<'a> {
        Search {
            graph,
            at: vec![None; graph.directed.len()],
            touched: Vec::new(),
            queue: Default::default(),
            separators: Vec::new(),
            polygons: Default::default(),
        }
    }

    /// Merges windows for portal `t` (lines leaving the source within
    /// `source`, crossing `t` within `window`); queues `t` when they grew.
    fn offer(&mut self, t: u32, source: &[DVec3], window: &[DVec3], source_normal: DVec3) {
        let target = &self.graph.directed[t as usize];
        let slot = &mut self.at[t as usize];
        let grew = match slot {
            None => {
                self.touched.push(t);
                *slot = Some(Windows {
                    source: source.to_vec(),
                    window: window.to_vec(),
                    growth: 0,
                    queued: false,
                });
                true
            }
            Some(w) if w.growth == u8::MAX => false,
            Some(w) => {
                let source_in = contains(&w.source, source, source_normal);
                let window_in = contains(&w.window, window, target.normal);
                if source_in && window_in {
                    false
                } else {
                    w.growth += 1;
                    if w.growth > MAX_GROWTH {
                        // Whole: what could grow further is bounded by these.
                        w.window = target.points.clone();
                        w.growth = u8::MAX;
                    } else if !window_in {
                        w.window.extend_from_slice(window);
                        w.window = hull(&w.window, target.normal);
                    }
                    if !source_in && w.growth != u8::MAX {
                        w.source.extend_from_slice(source);
                        w.source = hull(&w.source, source_normal);
                    }
                    true
                }
            }
        };
        if grew {
            let w = self.at[t as usize].as_mut().expect("just set");
            if !w.queued {
                w.queued = true;
                self.queue.push_back(t);
            }
        }
    }

    /// Follows lines through directed portal `s`; marks the objects they
    /// may reach in `visible`.
    fn run(&mut self, s: u32, objects: &PortalObjects, visible: &mut [u64]) {
        let graph = self.graph;
        let source = &graph.directed[s as usize];
        for t in self.touched.drain(..) {
            self.at[t as usize] = None;
        }
        let [mut src, mut win, mut s2, mut w2, mut scratch] = std::mem::take(&mut self.polygons);
        for &t in &graph.leaving[source.to as usize] {
            let target = &graph.directed[t as usize];
            if step(
                source,
                source,
                &source.points,
                &[],
                target,
                (&mut w2, &mut s2),
                &mut scratch,
            ) {
                self.offer(t, &s2, &w2, source.normal);
            }
        }
        while let Some(t) = self.queue.pop_front() {
            let target = &graph.directed[t as usize];
            let windows = self.at[t as usize].as_mut().expect("queued portals have windows");
            windows.queued = false;
            src.clear();
            src.extend_from_slice(if windows.growth == u8::MAX {
                &source.points
            } else {
                &windows.source
            });
            win.clear();
            win.extend_from_slice(&windows.window);
            // The planes every line through the source and the window
            // stays in front of, past the window.
            let mut seps = std::mem::take(&mut self.separators);
            separators(&src, &win, &mut seps);
            seps.push((source.normal, source.d));
            seps.push((target.normal, target.d));
            for &o in &objects.in_cell[target.to as usize] {
                if !has(visible, o) && !seps.iter().any(|&(n, d)| box_behind(&objects.boxes[o as usize], n, d)) {
                    set(visible, o);
                }
            }
            for &next in &graph.leaving[target.to as usize] {
                let after = &graph.directed[next as usize];
                if (next ^ 1) == t {
                    continue; // Back through the same portal.
                }
                if step(source, target, &src, &seps, after, (&mut w2, &mut s2), &mut scratch) {
                    self.offer(next, &s2, &w2, source.normal);
                }
            }
            self.separators = seps;
        }
        self.polygons = [src, win, s2, w2, scratch];
    }
}

/// What is left of `target` for lines leaving the source portal within
/// `source` and crossing `pass` (the last portal crossed; `planes` separate
/// the two), into `window`, and of `source` for lines that cross `target`,
/// into `left`: `false` when either is clipped away.
#[allow(clippy::too_many_arguments)]
fn step(
    source_portal: &Directed,
    pass: &Directed,
    source: &[DVec3],
    planes: &[(DVec3, f64)],
    target: &Directed,
    (window, left): (&mut Vec<DVec3>, &mut Vec<DVec3>),
    scratch: &mut Vec<DVec3>,
) -> bool {
    window.clear();
    window.extend_from_slice(&target.points);
    // A line that crossed a portal stays in front of it.
    clip(window, source_portal.normal, source_portal.d, scratch);
    if window.len() >= 3 && !std::ptr::eq(pass, source_portal) {
        clip(window, pass.normal, pass.d, scratch);
    }
    // A portal in the pass's plane leads back where the line came from.
    if window.len() < 3 || window.iter().all(|p| (pass.normal.dot(*p) - pass.d).abs() <= SLACK) {
        return false;
    }
    for &(n, d) in planes {
        clip(window, n, d, scratch);
        if window.len() < 3 {
            return false;
        }
    }
    // Lines crossing the target start behind its plane.
    left.clear();
    left.extend_from_slice(source);
    clip(left, -target.normal, -target.d, scratch);
    left.len() >= 3
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use hom_testkit::Rng;

    /// A maze of unit cubes, `dims` of them, some solid: the open cubes are
    /// the cells, their shared faces the portals.
    struct Maze {
        dims: [i32; 3],
        solid: Vec<bool>,
        /// Grid index → cell (open cubes only).
        cell: Vec<Option<u32>>,
    }

    impl Maze {
        fn new(dims: [i32; 3], solid: Vec<bool>) -> Maze {
            let mut next = 0;
            let cell = solid
                .iter()
                .map(|&s| {
                    (!s).then(|| {
                        next += 1;
                        next - 1
                    })
                })
                .collect();
            Maze { dims, solid, cell }
        }

        fn index(&self, p: [i32; 3]) -> Option<usize> {
            let [x, y, z] = p;
            let [nx, ny, nz] = self.dims;
            ((0..nx).contains(&x) && (0..ny).contains(&y) && (0..nz).contains(&z))
                .then(|| (x + nx * (y + ny * z)) as usize)
        }

        fn open(&self, p: [i32; 3]) -> bool {
            self.index(p).is_some_and(|i| !self.solid[i])
        }

        fn graph(&self) -> PortalGraph {
            let mut portals = Vec::new();
            let [nx, ny, nz] = self.dims;
            for z in 0..nz {
                for y in 0..ny {
                    for x in 0..nx {
                        let p = [x, y, z];
                        for axis in 0..3 {
                            let mut q = p;
                            q[axis] += 1;
                            if !(self.open(p) && self.open(q)) {
                                continue;
                            }
                            // The face at q[axis], its normal +axis (into q).
                            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                            let corner = |du: i32, dv: i32| {
                                let mut c = [x as f64, y as f64, z as f64];
                                c[axis] += 1.0;
                                c[u] += du as f64;
                                c[v] += dv as f64;
                                DVec3::from_array(c)
                            };
                            let a = self.cell[self.index(q).unwrap()].unwrap();
                            let b = self.cell[self.index(p).unwrap()].unwrap();
                            portals.push(Portal {
                                cells: [a, b],
                                points: vec![corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)],
                            });
                        }
                    }
                }
            }
            let cells = self.cell.iter().flatten().count();
            PortalGraph::new(cells, portals).unwrap()
        }

        /// Does the segment stay in open cubes? Walked cube by cube (a
        /// random segment passes an edge or a corner with probability 0).
        fn sees(&self, a: DVec3, b: DVec3) -> bool {
            let d = b - a;
            let mut cube = [a.x.floor() as i32, a.y.floor() as i32, a.z.floor() as i32];
            let end = [b.x.floor() as i32, b.y.floor() as i32, b.z.floor() as i32];
            let (mut t_next, mut t_step, mut step) = ([f64::INFINITY; 3], [f64::INFINITY; 3], [0i32; 3]);
            for k in 0..3 {
                if d[k] != 0.0 {
                    step[k] = if d[k] > 0.0 { 1 } else { -1 };
                    let boundary = cube[k] as f64 + if d[k] > 0.0 { 1.0 } else { 0.0 };
                    t_next[k] = (boundary - a[k]) / d[k];
                    t_step[k] = 1.0 / d[k].abs();
                }
            }
            loop {
                if !self.open(cube) {
                    return false;
                }
                if cube == end {
                    return true;
                }
                let k = (0..3).min_by(|&i, &j| t_next[i].total_cmp(&t_next[j])).unwrap();
                if t_next[k] > 1.0 {
                    return true;
                }
                cube[k] += step[k];
                t_next[k] += t_step[k];
            }
        }

        /// The open cubes a box touches.
        fn touching(&self, lo: DVec3, hi: DVec3) -> Vec<u32> {
            let mut out = Vec::new();
            for z in lo.z.floor() as i32..=hi.z.floor() as i32 {
                for y in lo.y.floor() as i32..=hi.y.floor() as i32 {
                    for x in lo.x.floor() as i32..=hi.x.floor() as i32 {
                        if let Some(i) = self.index([x, y, z]) {
                            out.extend(self.cell[i]);
                        }
                    }
                }
            }
            out
        }
    }

    fn point_in(rng: &mut Rng, lo: DVec3, hi: DVec3) -> DVec3 {
        lo + (hi - lo) * DVec3::new(rng.unit_f64(), rng.unit_f64(), rng.unit_f64())
    }

    /// No object that a sampled line from the source cell reaches is called
    /// hidden, on random mazes (the brute-force twin of the flow).
    #[test]
    fn never_hides_what_a_line_reaches() {
        let mut hidden_total = 0;
        for seed in 0..12u64 {
            let mut rng = Rng::new(seed * 0x9e37_79b9 + 1);
            let dims = [7, 3 + (seed % 3) as i32, 7];
            let n = (dims[0] * dims[1] * dims[2]) as usize;
            let solid = (0..n).map(|_| rng.unit() < 0.4).collect();
            let maze = Maze::new(dims, solid);
            let graph = maze.graph();
            let size = DVec3::new(dims[0] as f64, dims[1] as f64, dims[2] as f64);
            // Boxes anywhere in the maze, touching what they touch.
            let boxes: Vec<(DVec3, DVec3)> = (0..40)
                .map(|_| {
                    let c = point_in(&mut rng, DVec3::ZERO, size);
                    let h = DVec3::new(rng.unit_f64(), rng.unit_f64(), rng.unit_f64()) * 0.6 + 0.02;
                    ((c - h).max(DVec3::ZERO), (c + h).min(size - 1e-9))
                })
                .collect();
            let objects = PortalObjects::new(
                graph.cell_count(),
                boxes
                    .iter()
                    .map(|&(lo, hi)| (Aabb::new(lo.as_vec3(), hi.as_vec3()), maze.touching(lo, hi))),
            )
            .unwrap();
            for (grid, cell) in maze.cell.iter().enumerate() {
                let Some(cell) = *cell else { continue };
                let g = grid as i32;
                let origin = DVec3::new(
                    (g % dims[0]) as f64,
                    ((g / dims[0]) % dims[1]) as f64,
                    (g / (dims[0] * dims[1])) as f64,
                );
                let visible = graph.visible_objects(cell, &objects);
                for (k, &(lo, hi)) in boxes.iter().enumerate() {
                    if has(&visible, k as u32) {
                        continue;
                    }
                    hidden_total += 1;
                    for _ in 0..60 {
                        let eye = point_in(&mut rng, origin, origin + 1.0);
                        let at = point_in(&mut rng, lo, hi);
                        // Only the part of the box in open space can be seen.
                        if maze.open([at.x.floor() as i32, at.y.floor() as i32, at.z.floor() as i32]) {
                            assert!(
                                !maze.sees(eye, at),
                                "seed {seed}: cell {cell} hides box {k} ({lo}..{hi}), but {eye} sees {at}"
                            );
                        }
                    }
                }
            }
        }
        assert!(hidden_total > 200, "the flow should hide something: {hidden_total}");
        eprintln!("{hidden_total} hidden");
    }

    /// From many cells at once: each cell's set as from it alone, and the
    /// progress reaches the total.
    #[test]
    fn many_sources_report_progress() {
        let mut rng = Rng::new(5);
        let solid = (0..5 * 2 * 5).map(|_| rng.unit() < 0.3).collect();
        let maze = Maze::new([5, 2, 5], solid);
        let graph = maze.graph();
        let objects = PortalObjects::new(
            graph.cell_count(),
            (0..graph.cell_count() as u32).map(|c| (Aabb::new(Vec3::ZERO, Vec3::ONE), vec![c])),
        )
        .unwrap();
        let sources: Vec<u32> = (0..graph.cell_count() as u32).collect();
        let calls = std::sync::atomic::AtomicUsize::new(0);
        let most = std::sync::atomic::AtomicUsize::new(0);
        let all = graph.visible_objects_from(&sources, &objects, &|done, total| {
            assert_eq!(total, sources.len());
            calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            most.fetch_max(done, std::sync::atomic::Ordering::Relaxed);
        });
        assert_eq!(calls.into_inner(), sources.len());
        assert_eq!(most.into_inner(), sources.len());
        for (&c, v) in sources.iter().zip(&all) {
            assert_eq!(v, &graph.visible_objects(c, &objects));
        }
    }

    /// A corridor that turns twice: what lies past the second turn is hidden
    /// from its start, what lies past the first is not.
    #[test]
    fn a_second_turn_hides() {
        // z = 0 row x = 0..6, then up x = 5 to z = 5, then back along z = 5.
        let dims = [7, 1, 7];
        let mut solid = vec![true; 49];
        let mut open = |x: i32, z: i32| solid[(x + 7 * z) as usize] = false;
        for x in 0..6 {
            open(x, 0);
            open(x, 5);
        }
        for z in 0..6 {
            open(5, z);
        }
        let maze = Maze::new(dims, solid);
        let graph = maze.graph();
        // A box filling most of the cube at x, z.
        let at = |x: f64, z: f64| {
            let c = DVec3::new(x + 0.5, 0.5, z + 0.5);
            (
                Aabb::new((c - 0.45).as_vec3(), (c + 0.45).as_vec3()),
                maze.touching(c - 0.45, c + 0.45),
            )
        };
        let objects = PortalObjects::new(
            graph.cell_count(),
            [at(4.0, 0.0), at(5.0, 1.0), at(5.0, 3.0), at(0.0, 5.0)],
        )
        .unwrap();
        let visible = graph.visible_objects(maze.cell[0].unwrap(), &objects);
        assert!(has(&visible, 0), "down the same corridor");
        assert!(
            has(&visible, 1),
            "just round the first turn: a line from the start's corner reaches it"
        );
        assert!(!has(&visible, 2), "further round the first turn");
        assert!(!has(&visible, 3), "past the second turn");
    }

    #[test]
    fn bad_input_is_named() {
        let square = vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y];
        let bad =
            |cells: [u32; 2], points: Vec<DVec3>| PortalGraph::new(2, vec![Portal { cells, points }]).unwrap_err();
        assert!(matches!(bad([0, 0], square.clone()), PortalError::BadCells { .. }));
        assert!(matches!(bad([0, 2], square.clone()), PortalError::BadCells { .. }));
        assert!(matches!(
            bad([0, 1], square[..2].to_vec()),
            PortalError::BadPolygon { .. }
        ));
        assert!(matches!(
            bad([0, 1], vec![DVec3::ZERO, DVec3::X, DVec3::X * 2.0]),
            PortalError::BadPolygon { .. }
        ));
        let mut nan = square.clone();
        nan[1].y = f64::NAN;
        assert!(matches!(bad([0, 1], nan), PortalError::BadPolygon { .. }));
        let e = PortalObjects::new(2, [(Aabb::new(Vec3::ZERO, Vec3::ONE), vec![3])]).unwrap_err();
        assert_eq!(e.to_string(), "object 0 touches cell 3, but there are 2 cells");
    }
}
