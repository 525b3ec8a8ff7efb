//! [`OcclusionTree`]: hierarchical visibility culling with occlusion trees
//! (Bittner, Havran and Slavík, "Hierarchical visibility culling with
//! occlusion trees", CGI 1998; summarised in Bittner and Havran 2002,
//! "The Node Visibility Test") as an occlusion buffer.
//!
//! The paper merges the selected occluders' shadow frusta — the volumes
//! bounded by the occluder and the planes through the eye and its edges —
//! into a BSP tree whose leaves are *in* (occluded) or *out* (unoccluded), and
//! decides a node of the scene hierarchy by a constrained depth-first search
//! of the tree. Every shadow plane passes through the eye, so after the
//! perspective projection it is a line of the image plane: the same tree is a
//! 2D BSP of the image whose splitting lines are the occluder triangles'
//! projected edges, and a shadow volume's far side is the occluder's depth
//! plane. That is what is built here, after projection, so the tree shares
//! hom's setup and sampling with the rasterizers and the oracle:
//!
//! - A splitting line is a set-up triangle's edge function ([`Tri`]): fixed
//!   point, exact, the fill rule folded in, "inside" where it is `>= 0` at a
//!   sample. Sides of a line are decided per sample in integer arithmetic,
//!   so an edge shared by two triangles leaves no crack and needs no epsilon.
//! - An *in* leaf names the occluder triangle that covers its region: its
//!   depth plane (hom's one depth formula, [`Tri::depth_at`]) bounded over the
//!   samples the search brings there ([`Tri::depth_bounds`]).
//! - Both searches carry a *region* of samples exactly: its rows' spans
//!   (one interval of samples a row, the region being convex) and their
//!   bounding box. A split cuts each row's span at the line's crossing,
//!   decided per sample in the same integer arithmetic, and a side that holds
//!   none of the region's samples is not visited.
//! - Triangles are inserted in submission order (the cullers submit
//!   occluders nearest first). A triangle's samples are filtered down the
//!   tree; where they reach an *out* leaf the leaf becomes the triangle's
//!   edge lines (less those the path to the leaf already implies, so a shared
//!   edge is not split twice) ending in an *in* leaf. Where they reach an
//!   *in* leaf whose triangle lies farther there (its farthest depth over
//!   the box of those samples beyond the new one's), the leaf is split the
//!   same way, the new triangle's *in* leaf inside and the old cover kept
//!   outside (any cover is valid over its region: conservative either way;
//!   this only tightens depths, as the paper's depth merging does).
//! - The node test pushes the rectangle's samples down the tree: an *out*
//!   leaf reached means visible (the search stops); an *in* leaf is hidden
//!   when the rectangle's nearest depth lies beyond the triangle's farthest
//!   depth over the bounding box of the rectangle's samples there by
//!   [`crate::DEPTH_MARGIN`]. A rectangle hidden in every leaf it
//!   reaches is occluded. Tests are counted as the paper classifies them
//!   ([`TreeStats`]): *invisible*, *partially visible* (some leaf reached
//!   was hidden before the search met one that is not) and *visible*.
//!
//! Conservative by construction: a leaf's region holds only samples its
//! triangle covers, and the test reaches exactly the leaves that hold
//! samples of the rectangle, so a rectangle is occluded only when every one
//! of its samples lies behind an occluder sample the renderer draws. (An
//! earlier build carried only the bounding box, which reaches leaves the
//! samples do not, and *out* ones among them: on meshes of small triangles
//! that hid almost nothing.)
//!
//! The tree's size is capped ([`OcclusionTree::with_node_cap`]); a triangle
//! that would grow it beyond the cap is left out where it does not fit
//! (fewer occluders: conservative), so hostile input costs bounded memory.
//! Near-plane clipping, face culling, non-finite vertices and triangles that
//! cover no sample are the setup's ([`crate::raster::setup`]), as for the
//! other buffers.

use crate::geom::ScreenRect;
use crate::raster::setup::{Tri, HALF, ONE};
use crate::DEPTH_MARGIN;
use crate::{occlusion_buffer, BufferOptions, Front, OcclusionError};

/// Default most nodes of a tree: 2^17 (about 12 MiB: 88 bytes a node and 8 of summaries).
pub const DEFAULT_NODE_CAP: usize = 1 << 17;

/// What an [`OcclusionTree`] holds and what its tests found, since its last clear.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TreeStats {
    /// Nodes of the tree (splitting lines and leaves).
    pub nodes: u64,
    /// Of those, *in* leaves.
    pub in_leaves: u64,
    /// Triangles inserted (after setup).
    pub triangles_inserted: u64,
    /// Leaves a triangle reached but was not put in because the tree was full.
    pub leaves_dropped: u64,
    /// Rectangle tests that reached an unhidden leaf before any hidden one.
    pub visible: u64,
    /// Rectangle tests that reached a hidden leaf, then an unhidden one.
    pub partial: u64,
    /// Rectangle tests hidden in every leaf they reached (occluded).
    pub invisible: u64,
}

/// An edge function `a·X + b·Y + c` over fixed-point sample positions
/// (`X = x·ONE + HALF`): the sample is on the line's inner side iff `>= 0`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Line {
    a: i64,
    b: i64,
    c: i64,
}

impl Line {
    /// The other side: `E < 0` iff `−E − 1 >= 0` (edge values are integers).
    fn complement(self) -> Line {
        Line {
            a: -self.a,
            b: -self.b,
            c: -self.c - 1,
        }
    }

    /// The same set of integer points with `gcd(a, b) = 1`: `a·X + b·Y` is a
    /// multiple of `g`, so `E >= 0` iff `(a/g)·X + (b/g)·Y + floor(c/g) >= 0`.
    fn canonical(self) -> Line {
        let g = gcd(self.a.unsigned_abs(), self.b.unsigned_abs()) as i64;
        if g <= 1 {
            return self;
        }
        Line {
            a: self.a / g,
            b: self.b / g,
            c: self.c.div_euclid(g),
        }
    }

    /// Whether every integer point inside `self` (canonical) is inside `e` (canonical).
    fn implies(self, e: Line) -> bool {
        self.a == e.a && self.b == e.b && e.c >= self.c
    }

    /// Whether no integer point is inside both `self` and `e` (both canonical).
    fn excludes(self, e: Line) -> bool {
        // a·P <= c_self... : inside self is aX+bY >= −c; inside e (= −a, −b) is aX+bY <= c_e.
        self.a == -e.a && self.b == -e.b && e.c < -self.c
    }

    /// The smallest and largest edge value over the samples of `bx` (not empty).
    #[inline]
    fn range(self, bx: &SampleBox) -> (i64, i64) {
        let base = self.a * sample(bx.x0) + self.b * sample(bx.y0) + self.c;
        let dx = self.a * ONE * i64::from(bx.x1 - 1 - bx.x0);
        let dy = self.b * ONE * i64::from(bx.y1 - 1 - bx.y0);
        (base + dx.min(0) + dy.min(0), base + dx.max(0) + dy.max(0))
    }

    /// The bounding box of the samples of `bx` inside the line (exact;
    /// empty when there are none).
    fn tighten(self, bx: &SampleBox) -> SampleBox {
        let mut t = *bx;
        // Columns: the best row for each column, then a·X >= −(b·Y + c).
        let y_best = if self.b >= 0 { bx.y1 - 1 } else { bx.y0 };
        let k = self.b * sample(y_best) + self.c;
        if self.a > 0 {
            t.x0 = t.x0.max(first_index(-k, self.a));
        } else if self.a < 0 {
            t.x1 = t.x1.min(end_index(k, -self.a));
        } else if k < 0 {
            t.x1 = t.x0;
        }
        let x_best = if self.a >= 0 { bx.x1 - 1 } else { bx.x0 };
        let k = self.a * sample(x_best) + self.c;
        if self.b > 0 {
            t.y0 = t.y0.max(first_index(-k, self.b));
        } else if self.b < 0 {
            t.y1 = t.y1.min(end_index(k, -self.b));
        } else if k < 0 {
            t.y1 = t.y0;
        }
        t
    }
}

/// The fixed-point position of sample (pixel centre) `i`.
#[inline]
fn sample(i: u32) -> i64 {
    i64::from(i) * ONE + HALF
}

/// The first index `i` with `q · sample(i) >= p` (`q > 0`), clamped to `0..=u32::MAX`.
fn first_index(p: i64, q: i64) -> u32 {
    // sample(i) >= ceil(p / q)  <=>  i >= ceil((ceil(p / q) − HALF) / ONE).
    let s = -((-p).div_euclid(q));
    let i = -((HALF - s).div_euclid(ONE));
    i.clamp(0, i64::from(u32::MAX)) as u32
}

/// One past the last index `i` with `q · sample(i) <= p` (`q > 0`), clamped.
fn end_index(p: i64, q: i64) -> u32 {
    let s = p.div_euclid(q);
    let i = (s - HALF).div_euclid(ONE) + 1;
    i.clamp(0, i64::from(u32::MAX)) as u32
}

fn gcd(mut a: u64, mut b: u64) -> u64 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// Samples `x0..x1` × `y0..y1` (half-open).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct SampleBox {
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
}

impl SampleBox {
    fn is_empty(&self) -> bool {
        self.x0 >= self.x1 || self.y0 >= self.y1
    }

    fn of_tri(t: &Tri) -> SampleBox {
        SampleBox {
            x0: u32::from(t.x0),
            y0: u32::from(t.y0),
            x1: u32::from(t.x1),
            y1: u32::from(t.y1),
        }
    }

    fn meet(&self, o: &SampleBox) -> SampleBox {
        SampleBox {
            x0: self.x0.max(o.x0),
            y0: self.y0.max(o.y0),
            x1: self.x1.min(o.x1),
            y1: self.y1.min(o.y1),
        }
    }
}

/// A node of the tree.
#[derive(Clone, Copy, Debug)]
enum Node {
    /// Unoccluded.
    Out,
    /// Covered by triangle `.0` of [`OcclusionTree::tris`].
    In(u32),
    /// Split by `line`: `inside` where it is `>= 0`, `outside` elsewhere.
    Split {
        line: Line,
        /// `line.canonical()`, and of its complement: the path constraints.
        canon: [Line; 2],
        inside: u32,
        outside: u32,
    },
}

/// A step of a search: a node, the region of samples that reaches it (its
/// exact bounding box `bx` and its rows' spans at `off` in
/// [`OcclusionTree::spans`], one per row of `bx`), and the path constraint
/// taken to it (`path_len` entries of the path stay below it).
#[derive(Clone, Copy, Debug)]
struct Step {
    node: u32,
    bx: SampleBox,
    off: u32,
    path_len: u32,
    constraint: Option<Line>,
}

impl Step {
    /// One past the last span of this step's region.
    fn end(&self) -> usize {
        self.off as usize + (self.bx.y1 - self.bx.y0) as usize
    }
}

/// A row's samples `x0..x1` (empty when `x0 >= x1`).
type Span = [u32; 2];

/// The parts of row `y`'s span `s` inside and outside `line` (exact: the
/// inner side is `E >= 0` at the sample; a line meets a row in one crossing).
#[inline]
fn split_row(line: Line, y: u32, s: Span) -> (Span, Span) {
    if s[0] >= s[1] {
        return (s, s);
    }
    let k = line.b * sample(y) + line.c;
    let e0 = line.a * sample(s[0]) + k;
    let e1 = line.a * sample(s[1] - 1) + k;
    if e0 >= 0 && e1 >= 0 {
        return (s, [s[1], s[1]]);
    }
    if e0 < 0 && e1 < 0 {
        return ([s[1], s[1]], s);
    }
    if line.a > 0 {
        // Inside from the first x with a·X >= −k on.
        let f = first_index(-k, line.a).clamp(s[0], s[1]);
        ([f, s[1]], [s[0], f])
    } else {
        // a < 0 (a = 0 is one side for the whole row): inside up to a·X >= −k.
        let e = end_index(k, -line.a).clamp(s[0], s[1]);
        ([s[0], e], [e, s[1]])
    }
}

/// The exact bounding box and first span of the rows `y0 + i` of `rows`
/// that hold samples; `None` when none do.
fn trim(rows: &[Span], y0: u32) -> Option<(SampleBox, usize)> {
    let first = rows.iter().position(|s| s[0] < s[1])?;
    let last = rows.iter().rposition(|s| s[0] < s[1])?;
    let (mut x0, mut x1) = (u32::MAX, 0);
    for s in &rows[first..=last] {
        if s[0] < s[1] {
            x0 = x0.min(s[0]);
            x1 = x1.max(s[1]);
        }
    }
    let bx = SampleBox {
        x0,
        y0: y0 + first as u32,
        x1,
        y1: y0 + last as u32 + 1,
    };
    Some((bx, first))
}

/// Splits the region of `s` (its spans in `spans`) by `line`: the inside's
/// and the outside's regions as (box, offset), `None` for a side that holds
/// none of its samples. A side the whole region lies in shares its spans.
fn split_region(spans: &mut Vec<Span>, s: &Step, line: Line) -> [Option<(SampleBox, u32)>; 2] {
    let (lo, hi) = line.range(&s.bx);
    if lo >= 0 {
        return [Some((s.bx, s.off)), None];
    }
    if hi < 0 {
        return [None, Some((s.bx, s.off))];
    }
    let n = (s.bx.y1 - s.bx.y0) as usize;
    let base = spans.len();
    spans.resize(base + 2 * n, [0, 0]);
    for i in 0..n {
        let (inside, outside) = split_row(line, s.bx.y0 + i as u32, spans[s.off as usize + i]);
        spans[base + i] = inside;
        spans[base + n + i] = outside;
    }
    let side = |spans: &[Span], at: usize| trim(&spans[at..at + n], s.bx.y0).map(|(b, f)| (b, (at + f) as u32));
    [side(spans, base), side(spans, base + n)]
}

/// The occlusion tree of Bittner, Havran & Slavík (1998), built after
/// projection: a BSP tree of the image whose splitting lines are the set-up
/// occluder triangles' edge functions (fill rule included) and whose *in*
/// leaves name the triangle covering them; a test is a constrained
/// depth-first search carrying the rectangle's samples exactly. Conservative:
/// a rectangle is occluded only when every one of its samples holds a nearer
/// occluder triangle (with the renderer's sampling and depth). Triangles that
/// do not fit under the node cap are left out, never half-inserted.
#[derive(Clone, Debug)]
pub struct OcclusionTree {
    front: Front,
    nodes: Vec<Node>,
    /// Per node: the farthest depth of the covers of its subtree's leaves
    /// (each cover's farthest over its own box), infinite where an *out* leaf
    /// is below. A triangle nearest at or beyond it cannot improve the
    /// subtree and is not filtered into it.
    far: Vec<f32>,
    /// Per node: its parent (`u32::MAX` for the root).
    parent: Vec<u32>,
    /// The triangles the *in* leaves name.
    tris: Vec<Tri>,
    node_cap: usize,
    tree: TreeStats,
    /// Cleared since the last draw.
    cleared: bool,
    /// Scratch for the searches.
    stack: Vec<Step>,
    /// The searches' regions: each step's rows of samples (see [`Step`]).
    spans: Vec<Span>,
    path: Vec<Line>,
}

impl OcclusionTree {
    /// An empty tree for a `width` × `height` image (each side 1..=16384),
    /// holding at most [`DEFAULT_NODE_CAP`] nodes.
    pub fn new(width: u32, height: u32, options: BufferOptions) -> Result<OcclusionTree, OcclusionError> {
        Ok(OcclusionTree {
            front: Front::new(width, height, options)?,
            nodes: vec![Node::Out],
            far: vec![f32::INFINITY],
            parent: vec![u32::MAX],
            tris: Vec::new(),
            node_cap: DEFAULT_NODE_CAP,
            tree: TreeStats {
                nodes: 1,
                ..TreeStats::default()
            },
            cleared: false,
            stack: Vec::new(),
            spans: Vec::new(),
            path: Vec::new(),
        })
    }

    /// The same with at most `cap` nodes (at least 1): beyond it, triangles are
    /// left out where they do not fit.
    pub fn with_node_cap(mut self, cap: usize) -> OcclusionTree {
        self.node_cap = cap.max(1);
        self
    }

    /// The tree's size and its tests' classes since the last clear (draws what is queued first).
    pub fn tree_stats(&mut self) -> TreeStats {
        <Self as crate::OcclusionBuffer>::flush(self);
        self.tree
    }

    /// [`OcclusionTree::tree_stats`] as it stands, without drawing what is queued.
    pub fn last_tree_stats(&self) -> TreeStats {
        self.tree
    }

    /// The samples the tree covers as of its last draw (the union of its
    /// *in* leaves' triangles' samples), as a mask: bit `x % 64` of word
    /// `y * ceil(width / 64) + x / 64`, the layout occluder selection's hole
    /// search reads. For hole filling.
    pub fn coverage_bits(&self, bits: &mut Vec<u64>) {
        let (w, h) = (self.front.width, self.front.height);
        let wpr = (w as usize).div_ceil(64);
        bits.clear();
        bits.resize(wpr * h as usize, 0);
        if self.cleared {
            return;
        }
        for t in &self.tris {
            for y in u32::from(t.y0)..u32::from(t.y1).min(h) {
                let mut r = [u32::from(t.x0), u32::from(t.x1).min(w)];
                for i in 0..3 {
                    let e = Line {
                        a: t.a[i],
                        b: t.b[i],
                        c: t.c[i],
                    };
                    r = split_row(e, y, r).0;
                }
                let row = &mut bits[y as usize * wpr..(y as usize + 1) * wpr];
                for x in r[0]..r[1] {
                    row[x as usize / 64] |= 1 << (x % 64);
                }
            }
        }
    }

    /// Checks the tree's structure: every child index in range, each node
    /// reached once from the root, every *in* leaf naming a stored triangle,
    /// and the counts in [`TreeStats`] right.
    ///
    /// # Panics
    /// When one of these fails.
    pub fn assert_well_formed(&mut self) {
        <Self as crate::OcclusionBuffer>::flush(self);
        let mut seen = vec![false; self.nodes.len()];
        let mut stack = vec![0u32];
        let mut in_leaves = 0;
        while let Some(n) = stack.pop() {
            assert!(!seen[n as usize], "node {n} reached twice");
            seen[n as usize] = true;
            match self.nodes[n as usize] {
                Node::Out => assert_eq!(self.far[n as usize], f32::INFINITY),
                Node::In(t) => {
                    assert!((t as usize) < self.tris.len(), "leaf {n} names triangle {t}");
                    in_leaves += 1;
                }
                Node::Split {
                    line,
                    canon,
                    inside,
                    outside,
                } => {
                    assert!(line.a != 0 || line.b != 0, "node {n}: degenerate line");
                    assert_eq!(canon, [line.canonical(), line.complement().canonical()]);
                    assert_eq!([self.parent[inside as usize], self.parent[outside as usize]], [n, n]);
                    let v = self.far[inside as usize].max(self.far[outside as usize]);
                    assert_eq!(self.far[n as usize], v, "node {n}: subtree far");
                    stack.extend([inside, outside]);
                }
            }
        }
        assert!(seen.iter().all(|&s| s), "unreachable nodes");
        assert_eq!(self.tree.nodes, self.nodes.len() as u64);
        assert_eq!(self.tree.in_leaves, in_leaves);
        assert!(self.nodes.len() <= self.node_cap.max(1));
    }

    /// Empties the tree lazily (the first draw or settle does it).
    fn reset(&mut self) {
        self.cleared = true;
    }

    /// After a flush: a tree cleared and not drawn since is emptied.
    #[inline]
    fn settle(&mut self) {
        if self.cleared {
            self.empty();
        }
    }

    fn empty(&mut self) {
        self.nodes.clear();
        self.nodes.push(Node::Out);
        self.far.clear();
        self.far.push(f32::INFINITY);
        self.parent.clear();
        self.parent.push(u32::MAX);
        self.tris.clear();
        self.tree = TreeStats {
            nodes: 1,
            ..TreeStats::default()
        };
        self.cleared = false;
    }

    fn draw(&mut self) {
        if self.cleared {
            self.empty();
        }
        let tris = std::mem::take(&mut self.front.tris);
        for t in &tris {
            self.insert(t);
        }
        self.front.tris = tris;
    }

    /// Filters `t` down the tree; see the module docs.
    fn insert(&mut self, t: &Tri) {
        let edges: [Line; 3] = std::array::from_fn(|i| Line {
            a: t.a[i],
            b: t.b[i],
            c: t.c[i],
        });
        let canon = edges.map(Line::canonical);
        let index = self.tris.len() as u32;
        let mut used = false;
        self.stack.clear();
        self.spans.clear();
        self.path.clear();
        // The triangle's samples, row by row.
        let tb = SampleBox::of_tri(t);
        if tb.is_empty() {
            return;
        }
        for y in tb.y0..tb.y1 {
            let mut r = [tb.x0, tb.x1];
            for e in &edges {
                r = split_row(*e, y, r).0;
            }
            self.spans.push(r);
        }
        let Some((bx, first)) = trim(&self.spans, tb.y0) else {
            return;
        };
        let (near, far) = t.depth_bounds(tb.x0, tb.x1 - 1, tb.y0, tb.y1 - 1);
        let far = if far.is_nan() { f32::INFINITY } else { far };
        self.stack.push(Step {
            node: 0,
            bx,
            off: first as u32,
            path_len: 0,
            constraint: None,
        });
        while let Some(s) = self.stack.pop() {
            self.spans.truncate(s.end());
            self.path.truncate(s.path_len as usize);
            self.path.extend(s.constraint);
            if near >= self.far[s.node as usize] {
                continue; // covered throughout by nearer triangles
            }
            match self.nodes[s.node as usize] {
                Node::In(old) => {
                    // A nearer cover where the triangle's samples are: split
                    // the leaf by its edges, the rest keeps the old cover.
                    let o = &self.tris[old as usize];
                    let b = s.bx.meet(&SampleBox::of_tri(o));
                    if !b.is_empty() {
                        let new_far = t.depth_bounds(b.x0, b.x1 - 1, b.y0, b.y1 - 1).1;
                        let old_far = o.depth_bounds(b.x0, b.x1 - 1, b.y0, b.y1 - 1).1;
                        if new_far < old_far {
                            used |= self.fill(s.node, &edges, &canon, (index, far), Node::In(old));
                        }
                    }
                }
                Node::Split {
                    line,
                    canon: lc,
                    inside,
                    outside,
                } => {
                    let path_len = self.path.len() as u32;
                    let sides = split_region(&mut self.spans, &s, line);
                    // Inside first: the regions' spans end in stack order.
                    for ((side, child), c) in sides.into_iter().zip([inside, outside]).zip(lc) {
                        if let Some((bx, off)) = side {
                            self.stack.push(Step {
                                node: child,
                                bx,
                                off,
                                path_len,
                                constraint: Some(c),
                            });
                        }
                    }
                }
                Node::Out => used |= self.fill(s.node, &edges, &canon, (index, far), Node::Out),
            }
        }
        if used {
            self.tris.push(*t);
            self.tree.triangles_inserted += 1;
        }
    }

    /// Replaces leaf `leaf` (reached along `self.path`; `rest` is what it
    /// was: *out*, or *in* naming the cover it keeps outside the triangle) by
    /// the triangle's edges ending in an *in* leaf naming triangle `index`
    /// (farthest depth `far`), their outsides `rest`. False when the
    /// triangle has no sample there or the tree has no room.
    fn fill(&mut self, leaf: u32, edges: &[Line; 3], canon: &[Line; 3], (index, far): (u32, f32), rest: Node) -> bool {
        let mut keep = [false; 3];
        // Only the path may make an edge redundant: the leaf's region is the
        // path's samples, the box only bounds them (an edge the whole box is
        // inside may still cut the region elsewhere).
        for i in 0..3 {
            if self.path.iter().any(|p| p.excludes(canon[i])) {
                return false; // the leaf's region and the triangle share no sample
            }
            keep[i] = !self.path.iter().any(|p| p.implies(canon[i]));
        }
        let splits = keep.iter().filter(|&&k| k).count();
        if self.nodes.len() + 2 * splits > self.node_cap {
            self.tree.leaves_dropped += 1;
            return false;
        }
        // The chain: each kept edge's outside is a new out leaf, its inside the
        // next edge; the last inside is the in leaf. `leaf` becomes the first.
        let mut at = leaf;
        let rest_far = self.far[leaf as usize];
        let first_new = self.nodes.len() as u32;
        for i in (0..3).filter(|&i| keep[i]) {
            let (inside, outside) = (self.nodes.len() as u32, self.nodes.len() as u32 + 1);
            self.nodes.push(Node::Out);
            self.nodes.push(rest);
            self.far.extend([f32::INFINITY, rest_far]);
            self.parent.extend([at, at]);
            self.nodes[at as usize] = Node::Split {
                line: edges[i],
                canon: [canon[i], edges[i].complement().canonical()],
                inside,
                outside,
            };
            at = inside;
        }
        self.nodes[at as usize] = Node::In(index);
        self.far[at as usize] = far;
        // The subtree summaries up the chain, then up the path while they change.
        let mut n = self.parent[at as usize];
        while n != u32::MAX {
            let Node::Split { inside, outside, .. } = self.nodes[n as usize] else {
                unreachable!("a parent splits")
            };
            let v = self.far[inside as usize].max(self.far[outside as usize]);
            if v == self.far[n as usize] && n != leaf && n < first_new {
                break;
            }
            self.far[n as usize] = v;
            n = self.parent[n as usize];
        }
        self.tree.nodes = self.nodes.len() as u64;
        if matches!(rest, Node::In(_)) {
            // The leaf was in already; each kept edge's outside is a copy.
            self.tree.in_leaves += splits as u64;
        } else {
            self.tree.in_leaves += 1;
        }
        true
    }

    /// The constrained depth-first search of the module docs: whether every
    /// sample of `r` is hidden.
    fn is_behind(&mut self, r: &ScreenRect) -> bool {
        let (mut stack, mut spans, mut tree) = (
            std::mem::take(&mut self.stack),
            std::mem::take(&mut self.spans),
            self.tree,
        );
        let behind = self.search(r, &mut stack, &mut spans, &mut tree);
        (self.stack, self.spans, self.tree) = (stack, spans, tree);
        behind
    }

    /// [`Self::is_behind`] through `&self` ([`crate::SharedBuffer`]): the
    /// same answer, with scratch of its own, its outcome not counted.
    fn is_behind_shared(&self, r: &ScreenRect) -> bool {
        self.search(r, &mut Vec::new(), &mut Vec::new(), &mut TreeStats::default())
    }

    /// The search of [`Self::is_behind`] with the scratch `stack` and
    /// `spans`, counting its outcome in `tree`.
    fn search(&self, r: &ScreenRect, stack: &mut Vec<Step>, spans: &mut Vec<Span>, tree: &mut TreeStats) -> bool {
        let (w, h) = (self.front.width, self.front.height);
        let bx = SampleBox {
            x0: r.x0,
            y0: r.y0,
            x1: r.x1.min(w),
            y1: r.y1.min(h),
        };
        if bx.is_empty() {
            return true;
        }
        let z = r.z_near;
        let mut hidden_some = false;
        stack.clear();
        spans.clear();
        spans.extend((bx.y0..bx.y1).map(|_| [bx.x0, bx.x1]));
        stack.push(Step {
            node: 0,
            bx,
            off: 0,
            path_len: 0,
            constraint: None,
        });
        while let Some(s) = stack.pop() {
            spans.truncate(s.end());
            let seen = match self.nodes[s.node as usize] {
                Node::Out => true,
                Node::In(t) => {
                    let t = &self.tris[t as usize];
                    // The leaf's region lies in the triangle: its box bounds
                    // the rectangle's samples there (tightening only helps).
                    let mut b = s.bx.meet(&SampleBox::of_tri(t));
                    for i in 0..3 {
                        if b.is_empty() {
                            break;
                        }
                        b = Line {
                            a: t.a[i],
                            b: t.b[i],
                            c: t.c[i],
                        }
                        .tighten(&b);
                    }
                    if b.is_empty() {
                        continue; // no sample of the rectangle reaches this leaf
                    }
                    let far = t.depth_bounds(b.x0, b.x1 - 1, b.y0, b.y1 - 1).1;
                    // Seen unless behind; a NaN depth is seen.
                    let behind = z > far + DEPTH_MARGIN;
                    !behind
                }
                Node::Split {
                    line, inside, outside, ..
                } => {
                    // Only sides holding samples of the rectangle; the outside
                    // pushed last, on the stack's top: out leaves end the search.
                    let sides = split_region(spans, &s, line);
                    for (side, child) in sides.into_iter().zip([inside, outside]) {
                        if let Some((bx, off)) = side {
                            stack.push(Step {
                                node: child,
                                bx,
                                off,
                                path_len: 0,
                                constraint: None,
                            });
                        }
                    }
                    continue;
                }
            };
            if seen {
                if hidden_some {
                    tree.partial += 1;
                } else {
                    tree.visible += 1;
                }
                return false;
            }
            hidden_some = true;
        }
        tree.invisible += 1;
        true
    }
}

occlusion_buffer!(OcclusionTree);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{FaceCull, OcclusionBuffer, Sampling, Visibility};
    use glam::{Mat4, Vec2, Vec3, Vec4};

    fn exact() -> BufferOptions {
        BufferOptions {
            sampling: Sampling::Exact,
            ..BufferOptions::default()
        }
    }

    fn view_proj() -> Mat4 {
        crate::geom::Camera::new(Vec3::new(0.0, 0.0, 10.0), Vec3::ZERO, Vec3::Y, 1.0, 0.1, 100.0, 64, 64).view_proj()
    }

    fn quad(x0: f32, y0: f32, x1: f32, y1: f32, z: f32) -> [Vec3; 4] {
        [
            Vec3::new(x0, y0, z),
            Vec3::new(x1, y0, z),
            Vec3::new(x1, y1, z),
            Vec3::new(x0, y1, z),
        ]
    }

    fn tree_with(quads: &[[Vec3; 4]]) -> OcclusionTree {
        let mut t = OcclusionTree::new(64, 64, exact()).unwrap();
        for q in quads {
            t.render_triangles(q, &[[0, 1, 2], [0, 2, 3]], &view_proj(), FaceCull::None)
                .unwrap();
        }
        t.assert_well_formed();
        t
    }

    fn cube(centre: Vec3, half: f32) -> crate::geom::Aabb {
        crate::geom::Aabb::new(centre - Vec3::splat(half), centre + Vec3::splat(half))
    }

    #[test]
    fn a_quad_over_the_screen_hides_what_is_behind_it_not_what_is_in_front() {
        let mut t = tree_with(&[quad(-50.0, -50.0, 50.0, 50.0, 0.0)]);
        let vp = view_proj();
        assert_eq!(
            t.test_aabb(&cube(Vec3::new(0.0, 0.0, -5.0), 1.0), &vp),
            Visibility::Occluded
        );
        assert_eq!(
            t.test_aabb(&cube(Vec3::new(1.0, 1.0, 3.0), 1.0), &vp),
            Visibility::Visible
        );
        // Touching the quad's plane is not behind it.
        assert_eq!(
            t.test_aabb(&cube(Vec3::new(0.0, 0.0, -1.0), 1.0), &vp),
            Visibility::Visible
        );
        let s = t.tree_stats();
        assert_eq!((s.invisible, s.triangles_inserted), (1, 2));
        assert!(s.visible + s.partial == 2);
    }

    #[test]
    fn two_triangles_sharing_an_edge_leave_no_crack() {
        // The quad's diagonal runs through the middle of the box's rectangle.
        let mut t = tree_with(&[quad(-3.0, -3.0, 3.0, 3.0, 0.0)]);
        let vp = view_proj();
        assert_eq!(
            t.test_aabb(&cube(Vec3::new(0.0, 0.0, -4.0), 1.0), &vp),
            Visibility::Occluded
        );
        // Both triangles' in leaves were reached.
        let mut one = tree_with(&[quad(-3.0, -3.0, 3.0, 3.0, 0.0)]);
        assert!(one.tree_stats().in_leaves >= 2);
        // A strip of four quads (eight triangles) hides a box behind its middle.
        let strip: Vec<[Vec3; 4]> = (0..4)
            .map(|i| quad(-4.0 + 2.0 * i as f32, -2.0, -2.0 + 2.0 * i as f32, 2.0, 0.0))
            .collect();
        let mut t = tree_with(&strip);
        assert_eq!(
            t.test_aabb(&cube(Vec3::new(0.0, 0.0, -3.0), 1.0), &vp),
            Visibility::Occluded
        );
    }

    #[test]
    fn a_nearer_later_triangle_takes_over_where_it_covers() {
        // A far wall drawn first, then a nearer small quad: a box between the
        // two, behind the quad, is hidden by the quad's depth.
        let mut t = tree_with(&[quad(-50.0, -50.0, 50.0, 50.0, -8.0), quad(-3.0, -3.0, 3.0, 3.0, 0.0)]);
        let vp = view_proj();
        assert_eq!(
            t.test_aabb(&cube(Vec3::new(0.0, 0.0, -3.0), 1.0), &vp),
            Visibility::Occluded
        );
        // Past the quad's edge only the wall is there: visible in front of it, hidden behind.
        assert_eq!(
            t.test_aabb(&cube(Vec3::new(5.0, 0.0, -3.0), 1.0), &vp),
            Visibility::Visible
        );
        assert_eq!(
            t.test_aabb(&cube(Vec3::new(7.0, 0.0, -12.0), 1.0), &vp),
            Visibility::Occluded
        );
        // A farther later triangle changes nothing.
        let mut t = tree_with(&[quad(-3.0, -3.0, 3.0, 3.0, 0.0), quad(-50.0, -50.0, 50.0, 50.0, -8.0)]);
        assert_eq!(
            t.test_aabb(&cube(Vec3::new(0.0, 0.0, -3.0), 1.0), &vp),
            Visibility::Occluded
        );
    }

    #[test]
    fn a_box_peeking_past_an_edge_is_visible() {
        let mut t = tree_with(&[quad(-3.0, -3.0, 3.0, 3.0, 0.0)]);
        let vp = view_proj();
        // Behind, but wider than the quad to the right.
        let b = crate::geom::Aabb::new(Vec3::new(-1.0, -1.0, -5.0), Vec3::new(4.5, 1.0, -4.0));
        assert_eq!(t.test_aabb(&b, &vp), Visibility::Visible);
        // Just inside: hidden.
        let b = crate::geom::Aabb::new(Vec3::new(-1.0, -1.0, -5.0), Vec3::new(2.0, 1.0, -4.0));
        assert_eq!(t.test_aabb(&b, &vp), Visibility::Occluded);
        // A rectangle test reaching one pixel column past the quad's right edge.
        let edge = vp.project_point3(Vec3::new(3.0, 0.0, 0.0)).x;
        let z = vp.project_point3(Vec3::new(0.0, 0.0, -4.0)).z;
        assert_eq!(
            t.test_rect(Vec2::new(0.0, -0.1), Vec2::new(edge + 2.0 / 64.0, 0.1), z),
            Visibility::Visible
        );
        assert_eq!(
            t.test_rect(Vec2::new(0.0, -0.1), Vec2::new(edge - 2.0 / 64.0, 0.1), z),
            Visibility::Occluded
        );
    }

    #[test]
    fn occluders_through_the_near_plane_and_nan_vertices_stay_conservative() {
        let vp = view_proj();
        let mut t = OcclusionTree::new(64, 64, exact()).unwrap();
        // A floor from behind the eye to far in front, a triangle with a NaN vertex.
        let floor = [
            Vec3::new(-20.0, -1.0, 30.0),
            Vec3::new(20.0, -1.0, 30.0),
            Vec3::new(20.0, -1.0, -50.0),
            Vec3::new(-20.0, -1.0, -50.0),
        ];
        t.render_triangles(&floor, &[[0, 1, 2], [0, 2, 3]], &vp, FaceCull::None)
            .unwrap();
        let nan = [
            Vec3::new(f32::NAN, 0.0, 0.0),
            Vec3::new(50.0, -50.0, 0.0),
            Vec3::new(50.0, 50.0, 0.0),
        ];
        t.render_triangles(&nan, &[[0, 1, 2]], &vp, FaceCull::None).unwrap();
        t.render_clip_triangles(
            &[
                Vec4::new(0.0, 0.0, 0.5, 1.0),
                Vec4::new(f32::NAN, 1.0, 0.5, 1.0),
                Vec4::new(1.0, 1.0, 0.5, 1.0),
            ],
            &[[0, 1, 2]],
            FaceCull::None,
        )
        .unwrap();
        t.assert_well_formed();
        // The floor: inserted (clipped), the NaN triangles not.
        assert!(t.tree_stats().triangles_inserted >= 2);
        // Above the floor: visible; below it: hidden; a box around the eye: visible.
        assert_eq!(
            t.test_aabb(&cube(Vec3::new(0.0, 0.5, -5.0), 0.5), &vp),
            Visibility::Visible
        );
        assert_eq!(
            t.test_aabb(&cube(Vec3::new(0.0, -3.0, -5.0), 0.5), &vp),
            Visibility::Occluded
        );
        assert_eq!(
            t.test_aabb(&cube(Vec3::new(0.0, 0.0, 10.0), 1.0), &vp),
            Visibility::Visible
        );
        // Nothing occludes where the NaN triangle would have been.
        assert_eq!(
            t.test_aabb(&cube(Vec3::new(2.0, 0.5, -5.0), 0.5), &vp),
            Visibility::Visible
        );
    }

    #[test]
    fn face_culling_drops_the_named_winding() {
        let vp = view_proj();
        let q = quad(-3.0, -3.0, 3.0, 3.0, 0.0);
        let behind = cube(Vec3::new(0.0, 0.0, -4.0), 1.0);
        for (cull, hidden) in [(FaceCull::CounterClockwise, false), (FaceCull::Clockwise, true)] {
            let mut t = OcclusionTree::new(64, 64, exact()).unwrap();
            t.render_triangles(&q, &[[0, 1, 2], [0, 2, 3]], &vp, cull).unwrap();
            assert_eq!(t.test_aabb(&behind, &vp) == Visibility::Occluded, hidden, "{cull:?}");
        }
    }

    #[test]
    fn a_full_tree_drops_occluders_and_stays_conservative() {
        let vp = view_proj();
        let quads: Vec<[Vec3; 4]> = (0..8)
            .map(|i| quad(-4.0 + i as f32, -4.0, -3.0 + i as f32, 4.0, 0.0))
            .collect();
        let mut t = OcclusionTree::new(64, 64, exact()).unwrap().with_node_cap(12);
        for q in &quads {
            t.render_triangles(q, &[[0, 1, 2], [0, 2, 3]], &vp, FaceCull::None)
                .unwrap();
        }
        t.assert_well_formed();
        let s = t.tree_stats();
        assert!(s.leaves_dropped > 0 && s.nodes <= 12, "{s:?}");
        assert_eq!(
            t.test_aabb(&cube(Vec3::new(0.0, 0.0, -4.0), 2.0), &vp),
            Visibility::Visible
        );
        // Without the cap the same box is hidden.
        let mut t = tree_with(&quads);
        assert_eq!(
            t.test_aabb(&cube(Vec3::new(0.0, 0.0, -4.0), 2.0), &vp),
            Visibility::Occluded
        );
    }

    #[test]
    fn clear_empties_the_tree() {
        let vp = view_proj();
        let mut t = tree_with(&[quad(-50.0, -50.0, 50.0, 50.0, 0.0)]);
        let behind = cube(Vec3::new(0.0, 0.0, -5.0), 1.0);
        assert_eq!(t.test_aabb(&behind, &vp), Visibility::Occluded);
        t.clear();
        assert_eq!(t.test_aabb(&behind, &vp), Visibility::Visible);
        t.assert_well_formed();
        assert_eq!(t.tree_stats().nodes, 1);
    }

    #[test]
    fn tighten_is_the_bounding_box_of_the_inside_samples() {
        let mut rng = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = |m: i64| {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng % (2 * m as u64 + 1)) as i64 - m
        };
        for _ in 0..2000 {
            let l = Line {
                a: next(600),
                b: next(600),
                c: next(600 * 20 * ONE),
            };
            let x0 = next(10).unsigned_abs() as u32;
            let y0 = next(10).unsigned_abs() as u32;
            let bx = SampleBox {
                x0,
                y0,
                x1: x0 + 1 + next(8).unsigned_abs() as u32,
                y1: y0 + 1 + next(8).unsigned_abs() as u32,
            };
            let inside = |x: u32, y: u32| l.a * sample(x) + l.b * sample(y) + l.c >= 0;
            let pts: Vec<(u32, u32)> = (bx.y0..bx.y1)
                .flat_map(|y| (bx.x0..bx.x1).map(move |x| (x, y)))
                .filter(|&(x, y)| inside(x, y))
                .collect();
            let t = l.tighten(&bx);
            let (lo, hi) = l.range(&bx);
            assert_eq!(hi >= 0, !pts.is_empty(), "{l:?} {bx:?}");
            assert_eq!(lo >= 0, pts.len() as u32 == bx.width() * bx.height());
            if pts.is_empty() {
                assert!(t.is_empty(), "{l:?} {bx:?} {t:?}");
                continue;
            }
            let brute = SampleBox {
                x0: pts.iter().map(|p| p.0).min().unwrap(),
                y0: pts.iter().map(|p| p.1).min().unwrap(),
                x1: pts.iter().map(|p| p.0).max().unwrap() + 1,
                y1: pts.iter().map(|p| p.1).max().unwrap() + 1,
            };
            assert_eq!(t, brute, "{l:?} {bx:?}");
            // The complement holds exactly the other samples.
            let c = l.complement();
            assert!((bx.y0..bx.y1)
                .all(|y| (bx.x0..bx.x1).all(|x| (c.a * sample(x) + c.b * sample(y) + c.c >= 0) != inside(x, y))));
            // The canonical line holds the same integer points.
            let k = l.canonical();
            assert!((bx.y0..bx.y1)
                .all(|y| (bx.x0..bx.x1).all(|x| (k.a * sample(x) + k.b * sample(y) + k.c >= 0) == inside(x, y))));
        }
    }

    /// A region split down a chain of random lines keeps exactly the samples
    /// on each side (brute force), with exact boxes; an empty side is `None`.
    #[test]
    fn split_region_keeps_exactly_the_samples_of_each_side() {
        let mut rng = 0x51_7cc1_b727_220au64;
        let mut next = |m: i64| {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng % (2 * m as u64 + 1)) as i64 - m
        };
        for _ in 0..300 {
            let x0 = next(6).unsigned_abs() as u32;
            let y0 = next(6).unsigned_abs() as u32;
            let bx = SampleBox {
                x0,
                y0,
                x1: x0 + 1 + next(12).unsigned_abs() as u32,
                y1: y0 + 1 + next(12).unsigned_abs() as u32,
            };
            let mut spans: Vec<Span> = (bx.y0..bx.y1).map(|_| [bx.x0, bx.x1]).collect();
            let mut s = Step {
                node: 0,
                bx,
                off: 0,
                path_len: 0,
                constraint: None,
            };
            let mut lines: Vec<(Line, bool)> = Vec::new();
            for _ in 0..6 {
                let l = Line {
                    a: next(600),
                    b: next(600),
                    c: next(600 * 20 * ONE),
                };
                let sides = split_region(&mut spans, &s, l);
                let member = |x: u32, y: u32, lines: &[(Line, bool)]| {
                    (bx.x0..bx.x1).contains(&x)
                        && (bx.y0..bx.y1).contains(&y)
                        && lines
                            .iter()
                            .all(|&(l, inside)| (l.a * sample(x) + l.b * sample(y) + l.c >= 0) == inside)
                };
                for (k, side) in sides.iter().enumerate() {
                    let mut path = lines.clone();
                    path.push((l, k == 0));
                    let pts: Vec<(u32, u32)> = (0..24)
                        .flat_map(|y| (0..24).map(move |x| (x, y)))
                        .filter(|&(x, y)| member(x, y, &path))
                        .collect();
                    match side {
                        None => assert!(pts.is_empty(), "{path:?}"),
                        Some((b, off)) => {
                            let got: Vec<(u32, u32)> = (b.y0..b.y1)
                                .flat_map(|y| {
                                    let r = spans[*off as usize + (y - b.y0) as usize];
                                    (r[0]..r[1].max(r[0])).map(move |x| (x, y))
                                })
                                .collect();
                            let mut got = got;
                            got.sort_by_key(|p| (p.1, p.0));
                            assert_eq!(got, pts, "{path:?}");
                            assert!(got.iter().all(|&(x, y)| x >= b.x0 && x < b.x1 && y >= b.y0 && y < b.y1));
                            assert!(got.iter().any(|p| p.0 == b.x0) && got.iter().any(|p| p.0 == b.x1 - 1));
                            assert!(got.iter().any(|p| p.1 == b.y0) && got.iter().any(|p| p.1 == b.y1 - 1));
                        }
                    }
                }
                // Descend into a random non-empty side, as a search does.
                let k = next(1).unsigned_abs() as usize;
                let Some(k) = [k, 1 - k].into_iter().find(|&k| sides[k].is_some()) else {
                    break;
                };
                let (b, off) = sides[k].unwrap();
                s = Step {
                    node: 0,
                    bx: b,
                    off,
                    path_len: 0,
                    constraint: None,
                };
                lines.push((l, k == 0));
            }
        }
    }

    impl SampleBox {
        fn width(&self) -> u32 {
            self.x1 - self.x0
        }
        fn height(&self) -> u32 {
            self.y1 - self.y0
        }
    }
}

#[cfg(test)]
mod sample_tests {
    use super::*;
    use crate::{FaceCull, OcclusionBuffer, Sampling};
    use glam::Vec4;

    /// One-sample rectangles far behind everything: hidden exactly where a
    /// set-up triangle covers the sample (the tree's regions are the triangles' samples).
    #[test]
    fn single_samples_are_hidden_exactly_where_a_triangle_covers_them() {
        let options = BufferOptions {
            sampling: Sampling::Exact,
            ..BufferOptions::default()
        };
        let mut rng = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 11) as f32 / (1u64 << 53) as f32 * 2.4 - 1.2
        };
        for case in 0..200 {
            let (w, h) = (24, 16);
            let mut t = OcclusionTree::new(w, h, options).unwrap();
            let n = 1 + case % 6;
            let verts: Vec<Vec4> = (0..3 * n)
                .map(|_| Vec4::new(next(), next(), 0.3 + 0.1 * next(), 1.0))
                .collect();
            let idx: Vec<[u32; 3]> = (0..n as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
            t.render_clip_triangles(&verts, &idx, FaceCull::None).unwrap();
            t.flush();
            t.assert_well_formed();
            let tris = t.tris.clone();
            let all = t.front.tris.clone();
            // The coverage mask is the same set (no triangle was dropped).
            let mut bits = Vec::new();
            t.coverage_bits(&mut bits);
            for y in 0..h {
                for x in 0..w {
                    let covered = all.iter().any(|tr| tr.covers(x, y));
                    assert_eq!(bits[y as usize] >> x & 1 == 1, covered, "case {case} sample {x},{y}");
                }
            }
            for y in 0..h {
                for x in 0..w {
                    let r = ScreenRect {
                        x0: x,
                        y0: y,
                        x1: x + 1,
                        y1: y + 1,
                        z_near: 0.99,
                        z_far: 0.99,
                    };
                    let covered = all.iter().any(|tr| tr.covers(x, y));
                    assert_eq!(
                        t.is_behind(&r),
                        covered,
                        "case {case} sample {x},{y}; {} tris",
                        tris.len()
                    );
                }
            }
        }
    }
}
