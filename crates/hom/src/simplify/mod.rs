//! Mesh simplification by half-edge collapse under quadric error metrics
//! (M. Garland and P. S. Heckbert, "Surface Simplification Using Quadric Error
//! Metrics", SIGGRAPH 1997: the quadrics of §4, the inversion check of §5).
//!
//! Only edges are contracted (no non-edge pairs, unlike §3), and only as
//! half-edge collapses `u -> v` where `v` keeps its position, so a simplified
//! mesh uses a subset of the input's vertices and can share its vertex buffer.
//! The cost of `u -> v` is `(Q_u + Q_v)(v)`, made a squared distance by dividing
//! by the summed triangle area (`quadric.rs`).
//!
//! Each free vertex keeps its cheapest collapse in an indexed binary heap (one
//! entry a vertex, replaced in place). After `u -> v`, the vertices of `u`'s
//! ring offer again and the rest of `v`'s ring re-prices its edge to `v`.
//! Offers are checked only when they reach the top, since most are replaced
//! before then; one that fails gives way to its vertex's cheapest valid collapse.
//!
//! A collapse is valid if it passes the link condition on vertices and edges
//! (T. K. Dey, H. Edelsbrunner, S. Guha and D. V. Nekhayev, "Topology preserving
//! edge contraction", 1999), and no triangle it moves turns too far or loses its
//! area. Border vertices, those of non-manifold edges and those whose triangles
//! form more than one fan are locked, so the border and the topology stay.

mod quadric;

use glam::{DVec3, Vec3};
use quadric::Quadric;
use std::cmp::Ordering;

/// Smallest cosine between a moved triangle's normal before and after a collapse.
/// 0 would only refuse folds; 0.2 (78°) also refuses collapses that stand a
/// triangle almost on its edge, which crumple a surface long before they fold it.
const MIN_NORMAL_COS: f64 = 0.2;

/// Smallest area of a moved triangle, relative to the squared diagonal of the
/// mesh's bounding box: below it a triangle's normal is rounding noise.
const MIN_AREA_REL: f64 = 1e-12;

/// Options of one simplification.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SimplifyOptions {
    /// Stop when at most this many triangles remain.
    pub target_triangles: usize,
    /// Never make a collapse whose quadric error (squared distance, in the mesh's units squared) exceeds this.
    ///
    /// The error of `u -> v` is the area-weighted mean squared distance from `v` to
    /// the planes of the input triangles merged into `u` and `v` so far. 0 allows
    /// only collapses that are exactly in-plane; NaN allows none.
    pub max_error: f32,
}

/// Simplifies `triangles` (indices into `positions`, already welded: one index per distinct position) by
/// half-edge collapses u -> v (u's triangles move to v, which keeps its position), cheapest first.
/// Returns the kept triangles, each with indices into `positions` (a subset of the input vertices),
/// with the winding of the triangle it came from.
///
/// The kept triangles come in the order of the input triangles they came from.
/// Input triangles that repeat an index are dropped, and so are repeats of a
/// triangle with the same winding; two triangles on the same three vertices with
/// opposite windings (a two-sided sheet) are both kept, and stay. Beside
/// `locked`, the vertices of border edges (used by one triangle) and of
/// non-manifold edges (by three or more), and vertices whose triangles form
/// more than one fan, are never removed, so the border edges of the output are
/// those of the input. A manifold mesh stays manifold, a closed one closed,
/// with the same genus.
///
/// A triangle that moves keeps its normal within about 78° of the one it had
/// just before, and an area of at least `1e-12` times the squared diagonal of
/// the mesh's bounding box; input triangles of less area (slivers) have no
/// meaningful normal and are only held to the area floor. Collapses stop when at
/// most `options.target_triangles` remain or no valid collapse within
/// `options.max_error` is left. The result depends only on the input: equal
/// costs go to the collapse that leaves `v` with fewer triangles, then to the
/// shorter edge, then to the lower vertex indices.
///
/// # Panics
/// If `locked.len() != positions.len()`, if a triangle has an index out of range
/// of `positions`, or if there are more than `u32::MAX` triangles.
pub(crate) fn simplify(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    locked: &[bool],
    options: SimplifyOptions,
) -> Vec<[u32; 3]> {
    Simplifier::new(positions, triangles, locked, options.max_error).run(options.target_triangles)
}

/// [`simplify`] for a cluster whose locked vertices are its rim (the
/// vertices it shares with the rest of the mesh): besides, no collapse makes
/// a triangle with all three vertices locked. Such a triangle spans the rim
/// and can fold over the neighbour's side of it where the rim turns inwards:
/// two neighbouring clusters then both cover that corner, and a cut holding
/// both would draw it twice (Law & Tan's crack-free cuts need each cluster
/// to stay on its own side). Every new triangle keeps a free vertex inside.
///
/// # Panics
/// As [`simplify`].
pub(crate) fn simplify_cluster(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    locked: &[bool],
    options: SimplifyOptions,
) -> Vec<[u32; 3]> {
    let mut simplifier = Simplifier::new(positions, triangles, locked, options.max_error);
    simplifier.keep_rims = true;
    simplifier.run(options.target_triangles)
}

/// Work done by one run, for the tests that bound it.
#[derive(Clone, Copy, Debug, Default)]
#[cfg_attr(not(test), allow(dead_code))] // read by the tests only
struct Work {
    /// Collapses taken off the queue, made or not.
    pops: usize,
    /// Triangle visits while evaluating and making collapses: the inner loops' trips.
    visits: usize,
}

/// A queued collapse `u -> v`.
#[derive(Clone, Copy, Debug)]
struct Candidate {
    /// Quadric error of the collapse.
    cost: f64,
    /// Triangles of `u` and `v` when queued. Among equal costs (flat regions,
    /// where all are 0) the collapse that grows `v` least goes first: else flat
    /// regions fan out of a few hubs, and each collapse costs a hub's valence.
    valence: u32,
    /// Squared length of the edge: short edges first, among equal valences.
    length2: f32,
    /// The vertex removed.
    u: u32,
    /// The vertex `u`'s triangles move to.
    v: u32,
}

impl Candidate {
    /// The priority: cheapest first, then the smaller valence, the shorter edge, the lower indices.
    fn key_cmp(&self, other: &Candidate) -> Ordering {
        self.cost
            .total_cmp(&other.cost)
            .then_with(|| self.valence.cmp(&other.valence))
            .then_with(|| self.length2.total_cmp(&other.length2))
            .then_with(|| self.u.cmp(&other.u))
            .then_with(|| self.v.cmp(&other.v))
    }
}

/// A binary min-heap of collapses holding at most one per vertex `u`, which can
/// be replaced or withdrawn in place: the heap never outgrows the vertex count
/// and never holds an outdated entry.
struct CollapseQueue {
    heap: Vec<Candidate>,
    /// For each vertex, the index of its entry in `heap`, or [`CollapseQueue::NONE`].
    slot: Vec<u32>,
}

impl CollapseQueue {
    const NONE: u32 = u32::MAX;

    fn new(vertices: usize) -> CollapseQueue {
        CollapseQueue {
            heap: Vec::new(),
            slot: vec![Self::NONE; vertices],
        }
    }

    /// Makes `c` vertex `c.u`'s entry, replacing any it had.
    fn set(&mut self, c: Candidate) {
        let s = self.slot[c.u as usize];
        if s == Self::NONE {
            self.heap.push(c);
            let i = self.heap.len() - 1;
            self.slot[c.u as usize] = i as u32;
            self.sift_up(i);
        } else {
            let i = s as usize;
            let old = std::mem::replace(&mut self.heap[i], c);
            if c.key_cmp(&old) == Ordering::Less {
                self.sift_up(i);
            } else {
                self.sift_down(i);
            }
        }
    }

    /// Vertex `u`'s entry, if it has one.
    fn get(&self, u: u32) -> Option<&Candidate> {
        let s = self.slot[u as usize];
        (s != Self::NONE).then(|| &self.heap[s as usize])
    }

    /// Withdraws vertex `u`'s entry, if it has one.
    fn remove(&mut self, u: u32) {
        let s = self.slot[u as usize];
        if s == Self::NONE {
            return;
        }
        self.slot[u as usize] = Self::NONE;
        let i = s as usize;
        let Some(last) = self.heap.pop() else { return };
        if i < self.heap.len() {
            self.heap[i] = last;
            self.slot[last.u as usize] = s;
            self.sift_up(i);
            let i = self.slot[last.u as usize] as usize;
            self.sift_down(i);
        }
    }

    /// Takes the cheapest entry off.
    fn pop(&mut self) -> Option<Candidate> {
        let top = *self.heap.first()?;
        self.remove(top.u);
        Some(top)
    }

    fn swap(&mut self, i: usize, j: usize) {
        self.heap.swap(i, j);
        self.slot[self.heap[i].u as usize] = i as u32;
        self.slot[self.heap[j].u as usize] = j as u32;
    }

    fn sift_up(&mut self, mut i: usize) {
        while i > 0 {
            let parent = (i - 1) / 2;
            if self.heap[i].key_cmp(&self.heap[parent]) != Ordering::Less {
                break;
            }
            self.swap(i, parent);
            i = parent;
        }
    }

    fn sift_down(&mut self, mut i: usize) {
        loop {
            let left = 2 * i + 1;
            if left >= self.heap.len() {
                break;
            }
            let right = left + 1;
            let child = if right < self.heap.len() && self.heap[right].key_cmp(&self.heap[left]) == Ordering::Less {
                right
            } else {
                left
            };
            if self.heap[child].key_cmp(&self.heap[i]) != Ordering::Less {
                break;
            }
            self.swap(i, child);
            i = child;
        }
    }
}

/// The three vertices of `t`, sorted: the triangle as a set.
fn sorted(t: [u32; 3]) -> [u32; 3] {
    let mut s = t;
    s.sort_unstable();
    s
}

/// Whether `t`, turned to start at its smallest index, goes up next: the same
/// for both triangles of a pair iff they have the same winding.
fn winding(t: [u32; 3]) -> bool {
    let [a, b, c] = t;
    if a < b && a < c {
        b < c
    } else if b < c {
        c < a
    } else {
        a < b
    }
}

/// The three undirected edges of `t`, each as (smaller, larger).
fn edges(t: [u32; 3]) -> [(u32, u32); 3] {
    let [a, b, c] = t;
    [(a.min(b), a.max(b)), (b.min(c), b.max(c)), (c.min(a), c.max(a))]
}

/// `t` with `u` replaced by `v`.
fn replaced(t: [u32; 3], u: u32, v: u32) -> [u32; 3] {
    t.map(|i| if i == u { v } else { i })
}

/// One simplification's working mesh and queue.
struct Simplifier<'a> {
    positions: &'a [Vec3],
    /// The cleaned input triangles, in input order, with collapses applied.
    tris: Vec<[u32; 3]>,
    /// Whether each of `tris` is still in the mesh.
    alive: Vec<bool>,
    /// How many of `alive` are true.
    live: usize,
    /// For each vertex, the live triangles using it (in no particular order).
    vertex_tris: Vec<Vec<u32>>,
    /// Vertices that must stay: the caller's, plus borders and non-manifold spots.
    locked: Vec<bool>,
    quadrics: Vec<Quadric>,
    queue: CollapseQueue,
    max_error: f64,
    /// Smallest length of a moved triangle's cross product (twice its area).
    min_cross: f64,
    /// Scratch, kept to reuse the allocations.
    ring_popped: Vec<u32>,
    ring_u: Vec<u32>,
    ring_v: Vec<u32>,
    ring_w: Vec<u32>,
    wedge: Vec<u32>,
    options: Vec<Candidate>,
    work: Work,
    /// No collapse may make a triangle of three locked vertices ([`simplify_cluster`]).
    keep_rims: bool,
}

impl<'a> Simplifier<'a> {
    /// Cleans the input, locks what must stay and sums the quadrics.
    fn new(positions: &'a [Vec3], triangles: &[[u32; 3]], locked: &[bool], max_error: f32) -> Simplifier<'a> {
        let n = positions.len();
        assert_eq!(locked.len(), n, "simplify needs one locked flag per position");
        assert!(
            u32::try_from(triangles.len()).is_ok(),
            "simplify takes at most u32::MAX triangles"
        );
        for t in triangles {
            for &i in t {
                assert!((i as usize) < n, "triangle index {i} out of range of {n} positions");
            }
        }
        let mut locked = locked.to_vec();

        // Keep the first of each (vertex set, winding). A vertex set with both
        // windings is a two-sided sheet: its edges are non-manifold if anything
        // else touches them, and else the link condition leaves it whole.
        let mut keyed: Vec<([u32; 3], bool, u32)> = triangles
            .iter()
            .enumerate()
            .filter(|(_, t)| t[0] != t[1] && t[1] != t[2] && t[2] != t[0])
            .map(|(i, &t)| (sorted(t), winding(t), i as u32))
            .collect();
        keyed.sort_unstable();
        let mut keep = vec![false; triangles.len()];
        for group in keyed.chunk_by(|a, b| a.0 == b.0) {
            keep[group[0].2 as usize] = true;
            if let Some(other) = group.iter().find(|k| k.1 != group[0].1) {
                keep[other.2 as usize] = true;
            }
        }
        let tris: Vec<[u32; 3]> = triangles
            .iter()
            .zip(&keep)
            .filter(|(_, &k)| k)
            .map(|(&t, _)| t)
            .collect();

        // Border edges (one triangle) and non-manifold ones (three or more).
        let mut all_edges: Vec<(u32, u32)> = tris.iter().flat_map(|&t| edges(t)).collect();
        all_edges.sort_unstable();
        for run in all_edges.chunk_by(|a, b| a == b) {
            if run.len() != 2 {
                locked[run[0].0 as usize] = true;
                locked[run[0].1 as usize] = true;
            }
        }

        let mut vertex_tris = vec![Vec::new(); n];
        let mut quadrics = vec![Quadric::default(); n];
        let mut lo = DVec3::INFINITY;
        let mut hi = DVec3::NEG_INFINITY;
        for (t, tri) in tris.iter().enumerate() {
            let p = tri.map(|i| positions[i as usize].as_dvec3());
            let q = Quadric::of_triangle(p[0], p[1], p[2]);
            for (&i, &pi) in tri.iter().zip(&p) {
                vertex_tris[i as usize].push(t as u32);
                quadrics[i as usize] += q;
                lo = lo.min(pi);
                hi = hi.max(pi);
            }
        }
        let diagonal2 = if tris.is_empty() {
            0.0
        } else {
            (hi - lo).length_squared()
        };

        let live = tris.len();
        let mut simplifier = Simplifier {
            positions,
            alive: vec![true; live],
            live,
            tris,
            vertex_tris,
            locked,
            quadrics,
            queue: CollapseQueue::new(n),
            max_error: f64::from(max_error),
            min_cross: 2.0 * MIN_AREA_REL * diagonal2,
            ring_popped: Vec::new(),
            ring_u: Vec::new(),
            ring_v: Vec::new(),
            ring_w: Vec::new(),
            wedge: Vec::new(),
            options: Vec::new(),
            work: Work::default(),
            keep_rims: false,
        };
        // With all edges manifold, a vertex's triangles form one or more closed
        // fans; past two fans meeting at a point, a collapse would drag the other fan along.
        for u in 0..n as u32 {
            if !simplifier.locked[u as usize] && !simplifier.is_single_fan(u) {
                simplifier.locked[u as usize] = true;
            }
        }
        simplifier
    }

    /// Whether the triangles of `u`, all of whose edges have two triangles, form
    /// one cycle around it (true for an unused vertex).
    fn is_single_fan(&self, u: u32) -> bool {
        let around = &self.vertex_tris[u as usize];
        let Some(&first) = around.first() else {
            return true;
        };
        let others = |t: u32| {
            let [a, b, c] = self.tris[t as usize];
            if a == u {
                (b, c)
            } else if b == u {
                (c, a)
            } else {
                (a, b)
            }
        };
        // (neighbour, triangle) for both neighbours of each triangle, sorted, so
        // a walk step is a search even around a vertex of huge valence.
        let mut spokes: Vec<(u32, u32)> = around
            .iter()
            .flat_map(|&t| {
                let (a, b) = others(t);
                [(a, t), (b, t)]
            })
            .collect();
        spokes.sort_unstable();
        let (mut current, mut next) = (first, others(first).1);
        for seen in 1..=around.len() {
            // The other triangle on edge u-next (every edge here has two).
            let k = spokes.partition_point(|&(w, _)| w < next);
            let t = match spokes.get(k..k + 2) {
                Some(&[(w0, t0), (w1, t1)]) if w0 == next && w1 == next => {
                    if t0 == current {
                        t1
                    } else {
                        t0
                    }
                }
                _ => return false,
            };
            if t == first {
                return seen == around.len();
            }
            let (a, b) = others(t);
            next = if a == next { b } else { a };
            current = t;
        }
        false
    }

    /// Collapses cheapest first until at most `target` triangles are left;
    /// returns the live triangles in input order.
    fn run(&mut self, target: usize) -> Vec<[u32; 3]> {
        if self.live > target {
            for u in 0..self.positions.len() as u32 {
                if !self.locked[u as usize] && !self.vertex_tris[u as usize].is_empty() {
                    self.offer(u);
                }
            }
        }
        while self.live > target {
            let Some(c) = self.queue.pop() else { break };
            self.work.pops += 1;
            let mut ring_u = std::mem::take(&mut self.ring_popped);
            self.ring(c.u, &mut ring_u);
            // `collapse` keeps every queued cost current; checking it again keeps
            // `max_error` a promise whatever that bookkeeping misses.
            let current = self
                .candidate(c.u, c.v)
                .is_some_and(|now| now.cost.total_cmp(&c.cost) == Ordering::Equal);
            if current && self.can_collapse(c.u, c.v, &ring_u) {
                self.collapse(c.u, c.v, &ring_u);
            } else {
                // A queued key is the cost of its vertex's cheapest collapse,
                // checked or not, so never more than that of its cheapest valid
                // one (see `collapse`): u's takes its place in order.
                self.offer_checked(c.u);
            }
            self.ring_popped = ring_u;
        }
        self.tris
            .iter()
            .zip(&self.alive)
            .filter(|(_, &a)| a)
            .map(|(&t, _)| t)
            .collect()
    }

    /// The position of vertex `i`, in `f64`.
    fn point(&self, i: u32) -> DVec3 {
        self.positions[i as usize].as_dvec3()
    }

    /// The collapse `u -> v`, unchecked, if its error is within the bound.
    fn candidate(&self, u: u32, v: u32) -> Option<Candidate> {
        let pv = self.point(v);
        let cost = self.quadrics[u as usize].mean_error_with(&self.quadrics[v as usize], pv);
        // Written so that a NaN cost fails.
        if cost <= self.max_error {
            let valence = self.vertex_tris[u as usize].len() + self.vertex_tris[v as usize].len();
            Some(Candidate {
                cost,
                valence: valence as u32,
                length2: self.point(u).distance_squared(pv) as f32,
                u,
                v,
            })
        } else {
            None
        }
    }

    /// The vertices sharing a triangle with `u`, sorted, into `out`.
    fn ring(&mut self, u: u32, out: &mut Vec<u32>) {
        out.clear();
        let around = &self.vertex_tris[u as usize];
        self.work.visits += around.len();
        for &t in around {
            out.extend(self.tris[t as usize].iter().filter(|&&i| i != u));
        }
        out.sort_unstable();
        out.dedup();
    }

    /// Queues `u`'s cheapest collapse within the error bound, unchecked (most
    /// offers are replaced before they come up), or withdraws `u` if it has none.
    fn offer(&mut self, u: u32) {
        let mut ring_u = std::mem::take(&mut self.ring_u);
        self.ring(u, &mut ring_u);
        let mut best: Option<Candidate> = None;
        for &v in &ring_u {
            if let Some(c) = self.candidate(u, v) {
                if best.is_none_or(|b| c.key_cmp(&b) == Ordering::Less) {
                    best = Some(c);
                }
            }
        }
        self.ring_u = ring_u;
        match best {
            Some(c) => self.queue.set(c),
            None => self.queue.remove(u),
        }
    }

    /// Queues `u`'s cheapest valid collapse within the error bound, or withdraws
    /// `u` if it has none.
    fn offer_checked(&mut self, u: u32) {
        let mut ring_u = std::mem::take(&mut self.ring_u);
        let mut options = std::mem::take(&mut self.options);
        self.ring(u, &mut ring_u);
        options.clear();
        options.extend(ring_u.iter().filter_map(|&v| self.candidate(u, v)));
        options.sort_unstable_by(Candidate::key_cmp);
        match options.iter().find(|c| self.can_collapse(u, c.v, &ring_u)) {
            Some(&c) => self.queue.set(c),
            None => self.queue.remove(u),
        }
        self.ring_u = ring_u;
        self.options = options;
    }

    /// Whether `u -> v` keeps the mesh's topology and no moved triangle folds or
    /// flattens. `ring_u` is `u`'s ring.
    fn can_collapse(&mut self, u: u32, v: u32, ring_u: &[u32]) -> bool {
        let mut wedge = std::mem::take(&mut self.wedge);
        let mut ring_v = std::mem::take(&mut self.ring_v);
        let ok = self.can_collapse_with(u, v, ring_u, &mut wedge, &mut ring_v);
        self.wedge = wedge;
        self.ring_v = ring_v;
        ok
    }

    /// [`Simplifier::can_collapse`] with its scratch passed in.
    fn can_collapse_with(
        &mut self,
        u: u32,
        v: u32,
        ring_u: &[u32],
        wedge: &mut Vec<u32>,
        ring_v: &mut Vec<u32>,
    ) -> bool {
        // Cheapest tests first: most refusals are geometric, and those need
        // only u's triangles, while the link condition needs v's whole ring.
        let around_u = &self.vertex_tris[u as usize];
        self.work.visits += around_u.len();
        wedge.clear();
        let pv = self.point(v);
        for &t in around_u {
            let tri = self.tris[t as usize];
            if tri.contains(&v) {
                wedge.extend(tri.iter().filter(|&&i| i != u && i != v));
                continue;
            }
            if self.keep_rims && self.locked[v as usize] && tri.iter().all(|&i| i == u || self.locked[i as usize]) {
                return false;
            }
            // §5: refuse the collapse if it flips (or nearly stands up) a triangle.
            let p = tri.map(|i| self.point(i));
            let old = (p[1] - p[0]).cross(p[2] - p[0]);
            let q = tri.map(|i| if i == u { pv } else { self.point(i) });
            let new = (q[1] - q[0]).cross(q[2] - q[0]);
            let (old_len, new_len) = (old.length(), new.length());
            let big_enough = new_len > self.min_cross;
            let upright = old_len <= self.min_cross || old.dot(new) > MIN_NORMAL_COS * old_len * new_len;
            if !(big_enough && upright) {
                return false;
            }
        }
        wedge.sort_unstable();
        // u is free, so its edges are interior: two triangles each, with two
        // distinct third vertices (collapses keep it so). Anything else: leave it.
        if wedge.len() != 2 || wedge[0] == wedge[1] {
            return false;
        }

        // Link condition on vertices: the common neighbours of u and v are
        // exactly the third vertices of the triangles on uv (which are common
        // neighbours, so it is enough that there are two).
        self.ring(v, ring_v);
        let (mut i, mut j, mut common) = (0, 0, 0);
        while i < ring_u.len() && j < ring_v.len() {
            match ring_u[i].cmp(&ring_v[j]) {
                Ordering::Less => i += 1,
                Ordering::Greater => j += 1,
                Ordering::Equal => {
                    common += 1;
                    i += 1;
                    j += 1;
                }
            }
        }
        if common != 2 {
            return false;
        }

        // Link condition on edges: were u a b and v a b both triangles (edge a b
        // in both links), the collapse would stack two triangles on a b. Then a
        // and b are common neighbours, so the wedge: only u w0 w1 can.
        let around_v = &self.vertex_tris[v as usize];
        let stacked = sorted([v, wedge[0], wedge[1]]);
        let u_has = self.vertex_tris[u as usize]
            .iter()
            .any(|&t| wedge.iter().all(|w| self.tris[t as usize].contains(w)));
        self.work.visits += around_v.len();
        !(u_has && around_v.iter().any(|&t| sorted(self.tris[t as usize]) == stacked))
    }

    /// Moves `u`'s triangles to `v`, drops the two on edge uv, and updates the
    /// offers that this changed. `ring_u` is `u`'s ring.
    fn collapse(&mut self, u: u32, v: u32, ring_u: &[u32]) {
        let around = std::mem::take(&mut self.vertex_tris[u as usize]);
        self.work.visits += around.len();
        for &t in &around {
            let tri = self.tris[t as usize];
            if tri.contains(&v) {
                self.alive[t as usize] = false;
                self.live -= 1;
                for w in tri {
                    if w != u {
                        let list = &mut self.vertex_tris[w as usize];
                        self.work.visits += list.len();
                        if let Some(k) = list.iter().position(|&s| s == t) {
                            list.swap_remove(k);
                        }
                    }
                }
            } else {
                self.tris[t as usize] = replaced(tri, u, v);
                self.vertex_tris[v as usize].push(t);
            }
        }
        let qu = self.quadrics[u as usize];
        self.quadrics[v as usize] += qu;
        self.queue.remove(u);

        // u's ring, v included, has new triangles: any of its collapses may have changed.
        for &w in ring_u {
            if !self.locked[w as usize] {
                self.offer(w);
            }
        }
        // The rest of v's ring kept its triangles, and v's changed only by ones
        // holding u, which none of them touches: their collapses can have become
        // invalid (caught when they come up), never valid, and only their edge
        // to v changed cost (Q_v grew), up or down (the mean is per unit area).
        let mut ring_v = std::mem::take(&mut self.ring_w);
        self.ring(v, &mut ring_v);
        for &w in &ring_v {
            if self.locked[w as usize] || ring_u.binary_search(&w).is_ok() {
                continue;
            }
            let entry = self.queue.get(w).copied();
            if entry.is_some_and(|e| e.v == v) {
                self.offer(w);
            } else if let Some(c) = self.candidate(w, v) {
                if entry.is_none_or(|e| c.key_cmp(&e) == Ordering::Less) {
                    self.queue.set(c);
                }
            }
        }
        self.ring_w = ring_v;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::occlusion::details::weld;
    use hom_testkit::Rng;
    use std::collections::{BTreeMap, BTreeSet};

    const FREE: SimplifyOptions = SimplifyOptions {
        target_triangles: 0,
        max_error: f32::INFINITY,
    };

    /// An `n`×`n`-quad grid on x, z in [0, n], y = `height(x, z)`, normals +y when flat.
    fn grid(n: u32, height: impl Fn(f32, f32) -> f32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let mut positions = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let (x, z) = (i as f32, j as f32);
                positions.push(Vec3::new(x, height(x, z), z));
            }
        }
        let at = |i: u32, j: u32| j * (n + 1) + i;
        let mut tris = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1));
                tris.push([a, c, b]);
                tris.push([b, c, d]);
            }
        }
        (positions, tris)
    }

    /// A UV sphere of radius 1, its seam and poles welded and the pole slivers dropped.
    fn sphere(rings: u32, segments: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        use std::f32::consts::PI;
        let mut positions = Vec::new();
        for r in 0..=rings {
            for s in 0..=segments {
                let theta = PI * r as f32 / rings as f32;
                let phi = 2.0 * PI * (s % segments) as f32 / segments as f32;
                positions.push(if r == 0 {
                    Vec3::Y
                } else if r == rings {
                    Vec3::NEG_Y
                } else {
                    Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin())
                });
            }
        }
        let canonical = weld(&positions);
        let at = |r: u32, s: u32| canonical[(r * (segments + 1) + s) as usize];
        let mut tris = Vec::new();
        for r in 0..rings {
            for s in 0..segments {
                let (a, b, c, d) = (at(r, s), at(r, s + 1), at(r + 1, s), at(r + 1, s + 1));
                for t in [[a, c, b], [b, c, d]] {
                    if t[0] != t[1] && t[1] != t[2] && t[2] != t[0] {
                        tris.push(t);
                    }
                }
            }
        }
        (positions, tris)
    }

    /// A torus of `n`×`n` quads (2n² triangles), its surface rippled, nothing welded needed.
    fn bumpy_torus(n: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        use std::f32::consts::TAU;
        let mut positions = Vec::new();
        for i in 0..n {
            for j in 0..n {
                let (a, b) = (TAU * i as f32 / n as f32, TAU * j as f32 / n as f32);
                let r = 1.0 + 0.05 * (7.0 * a).sin() * (5.0 * b).cos();
                positions.push(Vec3::new(
                    (3.0 + r * b.cos()) * a.cos(),
                    r * b.sin(),
                    (3.0 + r * b.cos()) * a.sin(),
                ));
            }
        }
        let at = |i: u32, j: u32| (i % n) * n + (j % n);
        let mut tris = Vec::new();
        for i in 0..n {
            for j in 0..n {
                let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1));
                tris.push([a, c, b]);
                tris.push([b, c, d]);
            }
        }
        (positions, tris)
    }

    fn edge_counts(tris: &[[u32; 3]]) -> BTreeMap<(u32, u32), usize> {
        let mut counts = BTreeMap::new();
        for &t in tris {
            for e in edges(t) {
                *counts.entry(e).or_insert(0) += 1;
            }
        }
        counts
    }

    fn border_edges(tris: &[[u32; 3]]) -> BTreeSet<(u32, u32)> {
        edge_counts(tris)
            .into_iter()
            .filter(|&(_, c)| c == 1)
            .map(|(e, _)| e)
            .collect()
    }

    fn used(tris: &[[u32; 3]]) -> BTreeSet<u32> {
        tris.iter().flatten().copied().collect()
    }

    fn normal(positions: &[Vec3], t: [u32; 3]) -> DVec3 {
        let p = t.map(|i| positions[i as usize].as_dvec3());
        (p[1] - p[0]).cross(p[2] - p[0])
    }

    fn area(positions: &[Vec3], tris: &[[u32; 3]]) -> f64 {
        tris.iter().map(|&t| 0.5 * normal(positions, t).length()).sum()
    }

    /// No triangle repeats an index, and no two use the same three vertices.
    fn assert_clean(tris: &[[u32; 3]]) {
        for t in tris {
            assert!(t[0] != t[1] && t[1] != t[2] && t[2] != t[0], "degenerate {t:?}");
        }
        let sets: BTreeSet<[u32; 3]> = tris.iter().map(|&t| sorted(t)).collect();
        assert_eq!(sets.len(), tris.len(), "duplicate triangles");
    }

    /// Every edge in exactly two triangles, once each way (consistent winding).
    fn assert_closed(tris: &[[u32; 3]]) {
        assert!(
            edge_counts(tris).values().all(|&c| c == 2),
            "an edge not in exactly two triangles"
        );
        let mut directed = BTreeSet::new();
        for &[a, b, c] in tris {
            for e in [(a, b), (b, c), (c, a)] {
                assert!(directed.insert(e), "directed edge {e:?} twice: winding broken");
            }
        }
    }

    fn run(positions: &[Vec3], tris: &[[u32; 3]], locked: &[bool], options: SimplifyOptions) -> (Vec<[u32; 3]>, Work) {
        let mut simplifier = Simplifier::new(positions, tris, locked, options.max_error);
        let out = simplifier.run(options.target_triangles);
        (out, simplifier.work)
    }

    #[test]
    fn flat_grid_collapses_to_few_triangles_without_error_or_flips() {
        let n = 16;
        let (positions, tris) = grid(n, |_, _| 0.0);
        let input_area = area(&positions, &tris);
        let on_border = |i: usize| {
            let (x, z) = (i as u32 % (n + 1), i as u32 / (n + 1));
            x == 0 || z == 0 || x == n || z == n
        };
        let explicit: Vec<bool> = (0..positions.len()).map(on_border).collect();
        // The border is locked by the caller, or found by simplify: the same result.
        let implicit = vec![false; positions.len()];
        // max_error 0: a flat grid simplifies with exactly zero quadric error.
        let zero = SimplifyOptions {
            target_triangles: 0,
            max_error: 0.0,
        };
        let out = simplify(&positions, &tris, &explicit, zero);
        assert_eq!(out, simplify(&positions, &tris, &implicit, zero));
        assert_clean(&out);
        assert_eq!(border_edges(&out), border_edges(&tris));
        // No interior vertex survives: the border's 4n vertices, 4n - 2 triangles.
        assert!(used(&out).iter().all(|&i| on_border(i as usize)));
        assert_eq!(out.len(), 4 * n as usize - 2, "of {} triangles", tris.len());
        let out_area = area(&positions, &out);
        assert!(
            ((out_area - input_area) / input_area).abs() < 1e-4,
            "area {out_area} vs {input_area}"
        );
        for &t in &out {
            let nrm = normal(&positions, t);
            assert!(nrm.x == 0.0 && nrm.z == 0.0 && nrm.y > 0.0, "{t:?} has normal {nrm}");
        }
    }

    #[test]
    fn closed_sphere_stays_closed_and_keeps_its_genus() {
        let (positions, tris) = sphere(16, 32);
        assert_eq!(tris.len(), 960);
        assert_closed(&tris);
        let locked = vec![false; positions.len()];
        let target = tris.len() / 10;
        let out = simplify(
            &positions,
            &tris,
            &locked,
            SimplifyOptions {
                target_triangles: target,
                max_error: f32::INFINITY,
            },
        );
        assert!(out.len() <= target && out.len() + 2 > target, "{} triangles", out.len());
        assert_clean(&out);
        assert_closed(&out);
        let (v, e, f) = (used(&out).len(), edge_counts(&out).len(), out.len());
        assert_eq!(v as i64 - e as i64 + f as i64, 2, "Euler characteristic of a sphere");
        assert!(used(&out).is_subset(&used(&tris)));
        // A tetrahedron is as far as a closed mesh goes.
        let tiny = simplify(&positions, &tris, &locked, FREE);
        assert_eq!(tiny.len(), 4);
        assert_closed(&tiny);
    }

    /// A cluster's new triangles each keep a free vertex; plain simplify
    /// makes triangles of three rim vertices on the same input.
    #[test]
    fn clusters_make_no_triangle_of_three_locked_vertices() {
        let (positions, tris) = grid(24, |x, z| (0.7 * x).sin() * (0.5 * z).cos());
        // The rim: the border and a zigzag through the middle.
        let locked: Vec<bool> = positions
            .iter()
            .map(|p| p.x == 0.0 || p.z == 0.0 || p.x == 24.0 || p.z == 24.0 || (p.x - 12.0 - (p.z % 2.0)).abs() < 0.5)
            .collect();
        let options = SimplifyOptions {
            target_triangles: 0,
            max_error: f32::INFINITY,
        };
        let input: BTreeSet<[u32; 3]> = tris.iter().map(|&t| sorted(t)).collect();
        let all_locked = |out: &[[u32; 3]]| {
            out.iter()
                .filter(|t| t.iter().all(|&i| locked[i as usize]) && !input.contains(&sorted(**t)))
                .count()
        };
        let cluster = simplify_cluster(&positions, &tris, &locked, options);
        assert_clean(&cluster);
        assert_eq!(all_locked(&cluster), 0);
        assert_eq!(border_edges(&cluster), border_edges(&tris));
        assert!(cluster.len() < tris.len() / 2, "{} triangles", cluster.len());
        assert!(all_locked(&simplify(&positions, &tris, &locked, options)) > 0);
    }

    #[test]
    fn locked_vertices_and_borders_survive_on_a_bumpy_field() {
        for seed in 1..=8u64 {
            let mut rng = Rng::new(0x9e37_79b9_7f4a_7c15 ^ seed);
            let noise: Vec<f32> = (0..25 * 25).map(|_| rng.unit()).collect();
            let (positions, tris) = grid(24, |x, z| {
                (0.7 * x).sin() * (0.5 * z).cos() + 0.1 * noise[(z as usize) * 25 + x as usize]
            });
            let locked: Vec<bool> = (0..positions.len()).map(|_| rng.below(100) < 15).collect();
            let target = rng.below(200) as usize;
            let options = SimplifyOptions {
                target_triangles: target,
                max_error: f32::INFINITY,
            };
            let (out, _) = run(&positions, &tris, &locked, options);
            assert!(out.len() < tris.len() / 2, "seed {seed}: {} triangles", out.len());
            assert_clean(&out);
            let kept = used(&out);
            for i in used(&tris) {
                assert!(
                    !locked[i as usize] || kept.contains(&i),
                    "seed {seed}: locked vertex {i} removed"
                );
            }
            assert_eq!(border_edges(&out), border_edges(&tris), "seed {seed}");
            assert!(
                edge_counts(&out).values().all(|&c| c <= 2),
                "seed {seed}: non-manifold edge"
            );
        }
    }

    #[test]
    fn everything_locked_returns_the_input() {
        let (positions, tris) = sphere(8, 12);
        let out = simplify(&positions, &tris, &vec![true; positions.len()], FREE);
        assert_eq!(out, tris);
        let (positions, tris) = grid(6, |x, z| x * z);
        let out = simplify(&positions, &tris, &vec![true; positions.len()], FREE);
        assert_eq!(out, tris);
    }

    #[test]
    fn stops_at_the_target() {
        let (positions, tris) = bumpy_torus(20);
        let locked = vec![false; positions.len()];
        for target in [tris.len(), tris.len() - 1, 500, 101] {
            let options = SimplifyOptions {
                target_triangles: target,
                max_error: f32::INFINITY,
            };
            let out = simplify(&positions, &tris, &locked, options);
            // Each collapse on a closed mesh takes two triangles.
            assert!(
                out.len() <= target && out.len() + 2 > target,
                "target {target}: {}",
                out.len()
            );
            assert_closed(&out);
        }
        // As far as it goes, the torus stays a torus (Euler characteristic 0).
        let out = simplify(&positions, &tris, &locked, FREE);
        assert_closed(&out);
        assert_eq!(used(&out).len() + out.len(), edge_counts(&out).len());
    }

    #[test]
    fn max_error_zero_keeps_the_bump() {
        let bump = |x: f32, z: f32| {
            let r2 = (x - 8.0).powi(2) + (z - 8.0).powi(2);
            if r2 < 9.0 {
                1.0 + (r2 / 9.0 * std::f32::consts::PI).cos()
            } else {
                0.0
            }
        };
        let (positions, tris) = grid(16, bump);
        let locked = vec![false; positions.len()];
        let bumped: BTreeSet<u32> = (0..positions.len() as u32)
            .filter(|&i| positions[i as usize].y != 0.0)
            .collect();
        assert!(bumped.len() > 20);
        let zero = SimplifyOptions {
            target_triangles: 0,
            max_error: 0.0,
        };
        let out = simplify(&positions, &tris, &locked, zero);
        assert!(out.len() < tris.len() / 2, "flat part not simplified: {}", out.len());
        assert!(bumped.is_subset(&used(&out)), "a bump vertex went");
        assert_clean(&out);
        // A loose bound does flatten it: the test above is not vacuous.
        let loose = simplify(&positions, &tris, &locked, FREE);
        assert!(!bumped.is_subset(&used(&loose)));
        // And a tight one lets through only collapses within it.
        let small = SimplifyOptions {
            target_triangles: 0,
            max_error: 1e-3,
        };
        let (positions2, tris2) = grid(16, |x, z| 0.01 * ((x * 1.3).sin() + (z * 0.7).cos()));
        let some = simplify(&positions2, &tris2, &locked, small);
        assert!(some.len() > simplify(&positions2, &tris2, &locked, FREE).len());
    }

    #[test]
    fn quadrics_accumulate_onto_the_kept_vertex() {
        // Q_v += Q_u moves all of u's weight to v: the kept vertices end up
        // holding every input triangle's area three times (once per corner).
        let (positions, tris) = bumpy_torus(24);
        let mut simplifier = Simplifier::new(&positions, &tris, &vec![false; positions.len()], f32::INFINITY);
        let out = simplifier.run(100);
        assert!(out.len() <= 100);
        let held: f64 = used(&out)
            .iter()
            .map(|&i| simplifier.quadrics[i as usize].weight())
            .sum();
        let input = 3.0 * area(&positions, &tris);
        assert!(((held - input) / input).abs() < 1e-9, "{held} vs {input}");
    }

    #[test]
    fn cheapest_first() {
        // Every flat collapse costs 0 and every collapse on the bump more, so
        // stopping a free run where the zero-error run ends must give exactly
        // what that run gave: all zero-cost collapses came first, in the same order.
        let (positions, tris) = grid(16, |x, z| {
            let r2 = (x - 5.0).powi(2) + (z - 9.0).powi(2);
            (3.0 - r2).max(0.0)
        });
        let locked = vec![false; positions.len()];
        let zero = simplify(
            &positions,
            &tris,
            &locked,
            SimplifyOptions {
                target_triangles: 0,
                max_error: 0.0,
            },
        );
        let options = SimplifyOptions {
            target_triangles: zero.len(),
            max_error: f32::INFINITY,
        };
        assert_eq!(simplify(&positions, &tris, &locked, options), zero);
        assert!(simplify(&positions, &tris, &locked, FREE).len() < zero.len());
    }

    /// A torus whose tube has a triangular cross-section, one corner of which
    /// nearly touches another: each ring is a triangle that is no face.
    fn pinched_tube(rings: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        use std::f32::consts::TAU;
        let mut positions = Vec::new();
        for i in 0..rings {
            let (s, c) = (TAU * i as f32 / rings as f32).sin_cos();
            for (r, y) in [(3.0, 0.0), (3.0, 0.001), (3.5, 0.5)] {
                positions.push(Vec3::new(r * c, y, r * s));
            }
        }
        let at = |i: u32, j: u32| (i % rings) * 3 + j % 3;
        let mut tris = Vec::new();
        for i in 0..rings {
            for j in 0..3 {
                let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1));
                tris.push([a, c, b]);
                tris.push([b, c, d]);
            }
        }
        (positions, tris)
    }

    #[test]
    fn link_condition_keeps_a_thin_tube_a_torus() {
        // Collapsing a near-zero edge of a ring would pinch the tube shut while
        // barely moving a triangle: only the link condition refuses it.
        for rings in [8, 12, 20] {
            let (positions, tris) = pinched_tube(rings);
            assert_closed(&tris);
            let out = simplify(&positions, &tris, &vec![false; positions.len()], FREE);
            assert!(out.len() < tris.len());
            assert_clean(&out);
            assert_closed(&out);
            assert_eq!(
                used(&out).len() + out.len(),
                edge_counts(&out).len(),
                "{rings} rings: genus changed"
            );
        }
    }

    #[test]
    fn a_moved_sliver_must_gain_area() {
        // Collinear p m q v (v between p and m) with the sliver p q m: moving m
        // to v turns no triangle over but leaves p q v with no area.
        let positions = [
            Vec3::new(0.0, 0.0, 0.0),  // p
            Vec3::new(1.0, 0.0, 0.0),  // m
            Vec3::new(2.0, 0.0, 0.0),  // q
            Vec3::new(2.5, 0.0, 1.0),  // s
            Vec3::new(0.5, 0.0, 0.0),  // v
            Vec3::new(0.5, 0.0, -1.0), // t
        ];
        let tris = [[0, 2, 1], [1, 2, 3], [1, 3, 4], [1, 4, 5], [1, 5, 0]];
        let mut simplifier = Simplifier::new(&positions, &tris, &[false; 6], f32::INFINITY);
        assert!(!simplifier.locked[1], "m should be free");
        let mut ring = Vec::new();
        simplifier.ring(1, &mut ring);
        assert!(!simplifier.can_collapse(1, 4, &ring));
        // The same collapse with v just off the line is fine.
        let mut moved = positions;
        moved[4].z = 0.01;
        let mut simplifier = Simplifier::new(&moved, &tris, &[false; 6], f32::INFINITY);
        assert!(simplifier.can_collapse(1, 4, &ring));
    }

    /// The same simplification the slow way: every step, every free vertex's
    /// every collapse is costed and checked, and the cheapest made.
    fn brute_force(positions: &[Vec3], tris: &[[u32; 3]], locked: &[bool], target: usize) -> Vec<[u32; 3]> {
        let mut s = Simplifier::new(positions, tris, locked, f32::INFINITY);
        let mut ring = Vec::new();
        while s.live > target {
            let mut best: Option<Candidate> = None;
            for u in 0..positions.len() as u32 {
                if s.locked[u as usize] {
                    continue;
                }
                s.ring(u, &mut ring);
                for &v in &ring {
                    if let Some(c) = s.candidate(u, v) {
                        let cheaper = best.is_none_or(|b| (c.cost, c.u, c.v) < (b.cost, b.u, b.v));
                        if cheaper && s.can_collapse(u, v, &ring) {
                            best = Some(c);
                        }
                    }
                }
            }
            let Some(c) = best else { break };
            s.ring(c.u, &mut ring);
            s.collapse(c.u, c.v, &ring);
        }
        s.tris
            .iter()
            .zip(&s.alive)
            .filter(|(_, &a)| a)
            .map(|(&t, _)| t)
            .collect()
    }

    #[test]
    fn cheapest_collapse_first_like_the_brute_force() {
        // Random heights: no two costs tie, so the order is the costs' alone.
        for seed in 1..=4u64 {
            let mut rng = Rng::new(seed.wrapping_mul(0x2545_f491_4f6c_dd1d));
            let noise: Vec<f32> = (0..13 * 13).map(|_| rng.unit()).collect();
            let (positions, tris) = grid(12, |x, z| 0.3 * noise[(z as usize) * 13 + x as usize]);
            let locked: Vec<bool> = (0..positions.len()).map(|_| rng.below(8) == 0).collect();
            for target in [200, 100, 0] {
                let options = SimplifyOptions {
                    target_triangles: target,
                    max_error: f32::INFINITY,
                };
                let fast = simplify(&positions, &tris, &locked, options);
                assert_eq!(
                    fast,
                    brute_force(&positions, &tris, &locked, target),
                    "seed {seed}, target {target}"
                );
            }
        }
        let (positions, tris) = bumpy_torus(10);
        let locked = vec![false; positions.len()];
        let options = SimplifyOptions {
            target_triangles: 30,
            max_error: f32::INFINITY,
        };
        assert_eq!(
            simplify(&positions, &tris, &locked, options),
            brute_force(&positions, &tris, &locked, 30)
        );
    }

    #[test]
    fn deterministic() {
        let mut rng = Rng::new(7);
        let noise: Vec<f32> = (0..41 * 41).map(|_| rng.unit()).collect();
        let (positions, tris) = grid(40, |x, z| noise[(z as usize) * 41 + x as usize]);
        let locked: Vec<bool> = (0..positions.len()).map(|_| rng.below(10) == 0).collect();
        let options = SimplifyOptions {
            target_triangles: 300,
            max_error: 0.5,
        };
        let a = simplify(&positions, &tris, &locked, options);
        let b = simplify(&positions, &tris, &locked, options);
        assert_eq!(a, b);
        let (positions, tris) = sphere(12, 20);
        let locked = vec![false; positions.len()];
        let options = SimplifyOptions {
            target_triangles: 40,
            max_error: f32::INFINITY,
        };
        assert_eq!(
            simplify(&positions, &tris, &locked, options),
            simplify(&positions, &tris, &locked, options)
        );
    }

    #[test]
    fn non_manifold_edges_and_pinched_vertices_stay() {
        use std::f32::consts::TAU;
        // A book: three 4×4-quad pages sharing the spine x = y = 0, z in [0, 4].
        let mut positions: Vec<Vec3> = (0..5).map(|j| Vec3::new(0.0, 0.0, j as f32)).collect();
        let mut tris = Vec::new();
        for page in 0..3u32 {
            let dir = Vec3::new((TAU * page as f32 / 3.0).cos(), (TAU * page as f32 / 3.0).sin(), 0.0);
            let base = positions.len() as u32;
            for i in 1..=4 {
                for j in 0..5 {
                    positions.push(dir * i as f32 + Vec3::Z * j as f32);
                }
            }
            let at = |i: u32, j: u32| if i == 0 { j } else { base + (i - 1) * 5 + j };
            for i in 0..4 {
                for j in 0..4 {
                    let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1));
                    tris.push([a, c, b]);
                    tris.push([b, c, d]);
                }
            }
        }
        let out = simplify(&positions, &tris, &vec![false; positions.len()], FREE);
        assert!(out.len() < tris.len(), "nothing simplified");
        assert_clean(&out);
        let counts = edge_counts(&out);
        for j in 0..4 {
            assert_eq!(counts.get(&(j, j + 1)), Some(&3), "spine edge {j}");
        }
        assert_eq!(border_edges(&out), border_edges(&tris));

        // A pinch: two hexagonal fans, one in y = 0 and one in x = 0, sharing only their centre.
        let mut positions = vec![Vec3::ZERO];
        let mut tris = Vec::new();
        for fan in 0..2u32 {
            for k in 0..6u32 {
                let (s, c) = (TAU * k as f32 / 6.0).sin_cos();
                positions.push(if fan == 0 {
                    Vec3::new(c, 0.0, s)
                } else {
                    Vec3::new(0.0, c, s)
                });
                tris.push([0, 1 + fan * 6 + k, 1 + fan * 6 + (k + 1) % 6]);
            }
        }
        let out = simplify(&positions, &tris, &vec![false; positions.len()], FREE);
        assert_eq!(out, tris);
    }

    #[test]
    fn bad_input_triangles_are_dropped_or_kept_whole() {
        // A tetrahedron cannot lose a triangle without stacking two on one face.
        let positions = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
        let tetra = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        let locked = [false; 4];
        assert_eq!(simplify(&positions, &tetra, &locked, FREE), tetra);
        // A two-sided sheet (one triangle, both windings) is kept whole.
        let sheet = [[0, 1, 2], [0, 2, 1]];
        assert_eq!(simplify(&positions, &sheet, &locked, FREE), sheet);
        // Repeated indices and repeats with the same winding go; the rest simplifies.
        let (positions, mut tris) = grid(8, |_, _| 0.0);
        let clean = tris.clone();
        tris.push(clean[7]);
        tris.push([clean[9][1], clean[9][2], clean[9][0]]);
        tris.push([3, 3, 4]);
        let locked = vec![false; positions.len()];
        let out = simplify(&positions, &tris, &locked, FREE);
        assert_clean(&out);
        assert_eq!(out, simplify(&positions, &clean, &locked, FREE));
        assert_eq!(border_edges(&out), border_edges(&clean));
    }

    /// Replays a run one collapse at a time (a run to `target` makes a prefix of
    /// the collapses of a run to a lower one) and checks each: one vertex `u`
    /// goes, the two triangles on `uv` go, `u`'s others stay in their slots with
    /// `u` replaced by `v` (winding kept), and none of those turns over.
    fn check_each_collapse(positions: &[Vec3], tris: &[[u32; 3]], locked: &[bool]) -> usize {
        let options = |target_triangles| SimplifyOptions {
            target_triangles,
            max_error: f32::INFINITY,
        };
        let mut before = simplify(positions, tris, locked, options(tris.len()));
        let mut collapses = 0;
        loop {
            let after = simplify(positions, tris, locked, options(before.len() - 2));
            if after == before {
                return collapses;
            }
            assert_eq!(after.len() + 2, before.len());
            let gone: Vec<u32> = used(&before).difference(&used(&after)).copied().collect();
            assert_eq!(gone.len(), 1, "collapse {collapses}: vertices {gone:?} went");
            let u = gone[0];
            assert!(!locked[u as usize]);
            // The v that explains `after`: drop the triangles on uv, replace u by v.
            let explains = |v: u32| {
                let moved: Vec<[u32; 3]> = before
                    .iter()
                    .filter(|t| !(t.contains(&u) && t.contains(&v)))
                    .map(|&t| replaced(t, u, v))
                    .collect();
                moved == after
            };
            let ring: BTreeSet<u32> = before.iter().filter(|t| t.contains(&u)).flatten().copied().collect();
            // Two targets can explain the same result (u of valence 4, moving to
            // either side); one of them must have kept every moved triangle's facing.
            let upright = |v: u32| {
                before
                    .iter()
                    .filter(|t| t.contains(&u) && !t.contains(&v))
                    .all(|&t| normal(positions, t).dot(normal(positions, replaced(t, u, v))) > 0.0)
            };
            let targets: Vec<u32> = ring.into_iter().filter(|&v| v != u && explains(v)).collect();
            assert!(
                !targets.is_empty(),
                "collapse {collapses}: not a half-edge collapse of {u}"
            );
            assert!(
                targets.iter().any(|&v| upright(v)),
                "collapse {collapses}: moving {u} to {targets:?} turned a triangle over"
            );
            for &v in &targets {
                assert_eq!(before.iter().filter(|t| t.contains(&u) && t.contains(&v)).count(), 2);
            }
            before = after;
            collapses += 1;
        }
    }

    #[test]
    fn each_collapse_moves_triangles_without_turning_them_over() {
        for seed in 1..=3u64 {
            let mut rng = Rng::new(seed * 0x1234_5678_9abc_def1);
            let noise: Vec<f32> = (0..11 * 11).map(|_| rng.unit()).collect();
            // Steep random heights: many collapses here would fold the sheet.
            let (positions, tris) = grid(10, |x, z| 0.5 * noise[(z as usize) * 11 + x as usize]);
            let locked: Vec<bool> = (0..positions.len()).map(|_| rng.below(10) == 0).collect();
            assert!(check_each_collapse(&positions, &tris, &locked) > 20);
        }
        let (positions, tris) = sphere(6, 8);
        assert!(check_each_collapse(&positions, &tris, &vec![false; positions.len()]) > 10);
    }

    #[test]
    fn hundred_thousand_triangles_to_a_thousand() {
        let (positions, tris) = bumpy_torus(224);
        assert_eq!(tris.len(), 100_352);
        let locked = vec![false; positions.len()];
        let options = SimplifyOptions {
            target_triangles: 1000,
            max_error: f32::INFINITY,
        };
        let start = std::time::Instant::now();
        let (out, work) = run(&positions, &tris, &locked, options);
        let elapsed = start.elapsed();
        println!(
            "simplify: bumpy torus {} -> {} triangles in {:.1} ms ({} pops, {} triangle visits)",
            tris.len(),
            out.len(),
            elapsed.as_secs_f64() * 1e3,
            work.pops,
            work.visits
        );
        assert!(out.len() <= 1000 && out.len() > 990);
        assert_closed(&out);
        // Work linear in the input (the heap adds the log): a bound on the inner
        // loops' trips, not a stopwatch.
        assert!(work.pops < 2 * tris.len(), "{} pops", work.pops);
        assert!(work.visits < 100 * tris.len(), "{} visits", work.visits);

        // A flat grid, where every collapse costs 0: without the valence tie-break
        // it fans out of hubs and the work grows with their valence.
        let (positions, tris) = grid(200, |_, _| 0.0);
        let locked = vec![false; positions.len()];
        let start = std::time::Instant::now();
        let (out, work) = run(&positions, &tris, &locked, FREE);
        let elapsed = start.elapsed();
        println!(
            "simplify: flat grid {} -> {} triangles in {:.1} ms ({} pops, {} triangle visits)",
            tris.len(),
            out.len(),
            elapsed.as_secs_f64() * 1e3,
            work.pops,
            work.visits
        );
        // The 800 border vertices in a strip, no interior vertex left.
        assert_eq!(out.len(), 798);
        assert!(work.pops < 2 * tris.len(), "{} pops", work.pops);
        assert!(work.visits < 100 * tris.len(), "{} visits", work.visits);
    }
}
