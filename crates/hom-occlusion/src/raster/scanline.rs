//! Exact scan-line spans without a division per row: each edge's first (or
//! last) covered column of a row is the exact quotient of its edge function,
//! stepped from the row before as a quotient and a remainder. A row's span
//! is exactly the one [`Tri::row_span`] computes (the renderer's coverage,
//! or the inner rule's when the triangle was set up with it), for a few
//! additions a row where `row_span` divides three times.
//!
//! Used by the masked rasterizer for every triangle and by the coverage
//! rasterizer for triangles too wide for its vector row masks.

use super::setup::{Tri, ONE};
use crate::geom::ScreenRect;

/// A triangle's edges arranged for scan-line stepping, computed once per
/// triangle. A sloped edge bounds a row's covered columns from the left
/// (`a > 0`) or from the right (`a < 0`); the three `a` sum to zero, so
/// there are at most two of each, and a missing one is a slope that never
/// binds. A horizontal edge (`a = 0`) only limits the rows.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ScanEdges {
    /// The rows `rows.0..rows.1` (absolute) the horizontal edges allow; empty
    /// when they allow none.
    pub rows: (u32, u32),
    /// Left bounds, then right bounds.
    slopes: [Slope; 4],
}

/// A sloped edge's row-to-row step. A row's bound is the exact quotient of
/// the edge function by `d`: the first covered column offset (from the
/// box's `x0`) is `ceil(n / d)` for a left edge (`n = -e`), the last is
/// `floor(e / d)` for a right edge; stepping a row adds `sq` to the quotient
/// and `sr` to the remainder, with a carry.
#[derive(Clone, Copy, Debug)]
struct Slope {
    /// The edge's index, or `NO_EDGE` for a bound that never binds.
    edge: u8,
    /// Divisor, `|a|·ONE`; 1 for a bound that never binds.
    d: i64,
    /// Per-row quotient step.
    sq: i64,
    /// Per-row remainder step, `0 <= sr < d`.
    sr: i64,
}

/// `Slope::edge` of a bound that never binds.
const NO_EDGE: u8 = 3;

impl ScanEdges {
    /// The scan-line form of `t`.
    pub fn new(t: &Tri) -> ScanEdges {
        let none = Slope {
            edge: NO_EDGE,
            d: 1,
            sq: 0,
            sr: 0,
        };
        let mut slopes = [none; 4];
        let (mut left, mut right) = (0, 2);
        let mut rows = row_limits(t);
        for i in 0..3 {
            let (d, step) = (t.a[i] * ONE, t.b[i] * ONE);
            if d == 0 {
                // Only limits the rows (above).
            } else if (d > 0 && left == 2) || (d < 0 && right == 4) {
                // Impossible for a triangle (the `a` sum to zero); dropping
                // an occluder stays on the safe side.
                rows = (0, 0);
            } else if d > 0 {
                // n = -e falls by step per row.
                let (sq, sr) = div_rem(-step, d);
                slopes[left] = Slope {
                    edge: i as u8,
                    d,
                    sq,
                    sr,
                };
                left += 1;
            } else {
                let (sq, sr) = div_rem(step, -d);
                slopes[right] = Slope {
                    edge: i as u8,
                    d: -d,
                    sq,
                    sr,
                };
                right += 1;
            }
        }
        ScanEdges { rows, slopes }
    }
}

/// The rows `rows.0..rows.1` (absolute) of `t`'s box that its horizontal
/// edges allow (the whole box when it has none); empty `(0, 0)` when they
/// allow none. A division per horizontal edge.
#[inline]
pub(crate) fn row_limits(t: &Tri) -> (u32, u32) {
    if t.a.iter().all(|&a| a != 0) {
        return (u32::from(t.y0), u32::from(t.y1));
    }
    let (mut ya, mut yb) = (i64::from(t.y0), i64::from(t.y1));
    for i in 0..3 {
        if t.a[i] == 0 {
            // Covered rows: e0 + k·step >= 0 at row y0 + k.
            let (e0, step) = (t.edges_at_row(u32::from(t.y0))[i], t.b[i] * ONE);
            let (k_lo, k_hi) = match step.signum() {
                1 => ((-e0).div_euclid(step) + i64::from((-e0).rem_euclid(step) > 0), i64::MAX),
                -1 => (0, e0.div_euclid(-step) + 1),
                _ if e0 >= 0 => (0, i64::MAX),
                _ => (0, 0),
            };
            ya = ya.max(i64::from(t.y0).saturating_add(k_lo));
            yb = yb.min(i64::from(t.y0).saturating_add(k_hi));
        }
    }
    if ya < yb {
        (ya as u32, yb as u32)
    } else {
        (0, 0)
    }
}

/// `(n.div_euclid(d), n.rem_euclid(d))` for `d > 0`, one division. (An
/// `f64` estimate with integer correction measured slower: its correction
/// branches mispredict.)
#[inline]
fn div_rem(n: i64, d: i64) -> (i64, i64) {
    (n.div_euclid(d), n.rem_euclid(d))
}

/// A triangle's row bounds stepped down its rows: the covered columns of
/// each row, exactly, from the row before (a quotient and a remainder per
/// bound, no division after the first row).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Stepper {
    /// Per bound (two left, two right), the quotient.
    q: [i64; 4],
    /// Per bound, the remainder, `0 <= r < d`.
    r: [i64; 4],
    /// Per bound, the divisor.
    d: [i64; 4],
    /// Per bound, the per-row steps of `q` and `r`.
    sq: [i64; 4],
    /// See `sq`.
    sr: [i64; 4],
    /// The box's first column.
    x0: u32,
    /// The last column offset in the box.
    last: i64,
    /// The row the bounds are at.
    pub py: u32,
}

impl Stepper {
    /// `t`'s bounds (with its [`ScanEdges`]) at row `py` (within the box); a
    /// bound that never binds sits at the box's edge.
    pub fn new(t: &Tri, edges: &ScanEdges, py: u32) -> Stepper {
        let last = i64::from(t.x1 - t.x0) - 1;
        let e = t.edges_at_row(py);
        let mut q = [0, 0, last, last];
        let mut r = [0i64; 4];
        for (k, s) in edges.slopes.iter().enumerate() {
            if s.edge != NO_EDGE {
                let n = if k < 2 {
                    -e[usize::from(s.edge)]
                } else {
                    e[usize::from(s.edge)]
                };
                (q[k], r[k]) = div_rem(n, s.d);
            }
        }
        Stepper {
            q,
            r,
            d: edges.slopes.map(|s| s.d),
            sq: edges.slopes.map(|s| s.sq),
            sr: edges.slopes.map(|s| s.sr),
            x0: u32::from(t.x0),
            last,
            py,
        }
    }

    /// The covered columns `lo..hi` (absolute) of the next `spans.len()`
    /// rows, into `spans`; an empty row is `(0, 0)`.
    pub fn rows(&mut self, spans: &mut [(u32, u32)]) {
        for span in spans.iter_mut() {
            let (q, r) = (&self.q, &self.r);
            let lo = (q[0] + i64::from(r[0] > 0)).max(q[1] + i64::from(r[1] > 0)).max(0);
            let hi = q[2].min(q[3]).min(self.last);
            *span = if lo <= hi {
                (self.x0 + lo as u32, self.x0 + hi as u32 + 1)
            } else {
                (0, 0)
            };
            self.step();
        }
    }

    /// Moves the bounds down one row.
    #[inline(always)]
    fn step(&mut self) {
        for k in 0..4 {
            // Branch-free: whether the remainder carries is data, not pattern.
            let carry = i64::from(self.r[k] + self.sr[k] >= self.d[k]);
            self.q[k] += self.sq[k] + carry;
            self.r[k] += self.sr[k] - carry * self.d[k];
        }
        self.py += 1;
    }
}

/// The per-sample depth check's walk over one triangle, shared by the
/// buffers that answer it (`TiledZBuffer::triangles_hidden`,
/// `MaskedZBuffer::triangles_hidden`): `true` when `t` covers no sample of
/// the `width` × `height` viewport, when `whole` holds for its box at its
/// nearest depth (most hidden triangles lie wholly behind what hides them),
/// or when `tile(row, spans, x, end)` holds for every tile of `tile_w` ×
/// `tile_h` samples (`tile_h` at most 8) it covers: columns `x..end` of rows
/// `row..row + spans.len()`, `spans` their covered columns. Stops at the
/// first tile that does not.
#[inline(always)] // the callers pass constant tile sizes: their divisions become shifts
pub(crate) fn all_tiles_of(
    t: &Tri,
    (width, height): (u32, u32),
    (tile_w, tile_h): (u32, u32),
    whole: impl FnOnce(&ScreenRect) -> bool,
    mut tile: impl FnMut(u32, &[(u32, u32)], u32, u32) -> bool,
) -> bool {
    debug_assert!((1..=8).contains(&tile_h), "tile height {tile_h}");
    let edges = ScanEdges::new(t);
    let (ra, rb) = (edges.rows.0, edges.rows.1.min(height));
    let (xa, xb) = (u32::from(t.x0), u32::from(t.x1).min(width));
    if ra >= rb || xa >= xb {
        return true;
    }
    let rect = ScreenRect {
        x0: xa,
        y0: ra,
        x1: xb,
        y1: rb,
        z_near: t.depth_bounds(xa, xb - 1, ra, rb - 1).0,
        z_far: 1.0,
    };
    if whole(&rect) {
        return true;
    }
    let mut stepper = Stepper::new(t, &edges, ra);
    let mut spans = [(0u32, 0u32); 8];
    let mut row = ra;
    while row < rb {
        let band_end = rb.min((row / tile_h + 1) * tile_h);
        let spans = &mut spans[..(band_end - row) as usize];
        stepper.rows(spans);
        let (lo, hi) = spans
            .iter()
            .filter(|s| s.0 < s.1)
            .fold((u32::MAX, 0), |(lo, hi), s| (lo.min(s.0), hi.max(s.1.min(width))));
        let mut x = lo;
        while x < hi {
            let end = hi.min((x / tile_w + 1) * tile_w);
            if !tile(row, spans, x, end) {
                return false;
            }
            x = end;
        }
        row = band_end;
    }
    true
}

/// Rows a [`TileRows`] steps at once: the eight rows of a masked tile row.
pub(crate) const LANES: usize = 8;

/// An empty lane's `lo` (and `-EMPTY` its `hi`): beyond every column, and
/// safe to subtract a column from.
pub(crate) const EMPTY: i32 = 1 << 30;

/// The covered columns of the eight rows of a tile row, as offsets from the
/// triangle box's first column: lane `j` covers `lo[j]..hi[j]`; an empty
/// lane is `(EMPTY, -EMPTY)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct LaneSpans {
    /// Per lane, the first covered column offset.
    pub lo: [i32; LANES],
    /// Per lane, one past the last.
    pub hi: [i32; LANES],
    /// The columns some lane covers, `(min lo, max hi)`.
    pub any: (i32, i32),
    /// The columns every lane covers, `(max lo, min hi)` (empty when a lane is).
    pub all: (i32, i32),
}

impl LaneSpans {
    /// Lanes from absolute spans (`(0, 0)`: empty) of a box starting at column `x0`.
    #[inline(always)]
    pub fn from_spans(spans: &[(u32, u32); LANES], x0: u32) -> LaneSpans {
        let (mut lo, mut hi) = ([EMPTY; LANES], [-EMPTY; LANES]);
        for (j, &(a, b)) in spans.iter().enumerate() {
            if a < b {
                (lo[j], hi[j]) = (a as i32 - x0 as i32, b as i32 - x0 as i32);
            }
        }
        LaneSpans::reduced(lo, hi)
    }

    /// The lanes with their `any` and `all`.
    #[inline(always)]
    pub(crate) fn reduced(lo: [i32; LANES], hi: [i32; LANES]) -> LaneSpans {
        let (mut any, mut all) = ((EMPTY, -EMPTY), (-EMPTY, EMPTY));
        for j in 0..LANES {
            any = (any.0.min(lo[j]), any.1.max(hi[j]));
            all = (all.0.max(lo[j]), all.1.min(hi[j]));
        }
        LaneSpans { lo, hi, any, all }
    }

    /// Lane `j`'s span as absolute columns of a box at `x0` (`(0, 0)`: empty).
    #[cfg(test)]
    pub fn span(&self, j: usize, x0: u32) -> (u32, u32) {
        if self.lo[j] < self.hi[j] {
            ((x0 as i32 + self.lo[j]) as u32, (x0 as i32 + self.hi[j]) as u32)
        } else {
            (0, 0)
        }
    }

    /// Per lane, the bits of columns `xt..xt + 32` (offsets) it covers: bit
    /// `i` is column `xt + i`. The scalar twin of the vector kernels' masks:
    /// a shift by 32 or more (or by a negative count) gives 0, as `vpsllvd` does.
    #[inline(always)]
    pub fn masks(&self, xt: i32) -> [u32; LANES] {
        let shl = |n: i32| if (n as u32) < 32 { u32::MAX << n } else { 0 };
        std::array::from_fn(|j| shl((self.lo[j] - xt).max(0)) & !shl((self.hi[j] - xt).max(0)))
    }
}

/// A triangle's four row bounds (a [`Stepper`]'s) at the eight rows of a
/// tile row, one row per `i32` lane, stepped a tile row at a time: where a
/// [`Stepper`] walks eight rows one after the other, this does the eight in
/// parallel lanes (the vector kernels' form; the scalar
/// [`TileRows::next_scalar`] defines them). `i32` holds the quotients and
/// remainders only for triangles whose bounds stay within `±2^29` columns
/// over their rows and whose divisors stay below `2^30`;
/// [`TileRows::new`] refuses the others, which take a [`Stepper`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct TileRows {
    /// Per bound (two left, two right), per lane, the quotient.
    pub q: [[i32; LANES]; 4],
    /// Per bound, per lane, the remainder, `0 <= r < d`.
    pub r: [[i32; LANES]; 4],
    /// Per bound, the divisor.
    pub d: [i32; 4],
    /// Per bound, the tile-row step of `q`.
    pub q8: [i32; 4],
    /// Per bound, the tile-row step of `r`, `0 <= r8 < d`.
    pub r8: [i32; 4],
    /// The last column offset in the box.
    pub last: i32,
    /// The absolute row of lane 0.
    pub row: u32,
}

impl TileRows {
    /// `t`'s bounds (with its [`ScanEdges`]) at rows `row..row + 8`, to be
    /// stepped down to rows below `end`; `None` when `i32` lanes cannot hold them.
    pub fn new(t: &Tri, edges: &ScanEdges, row: u32, end: u32) -> Option<TileRows> {
        const LIMIT: i64 = 1 << 29;
        let mut s = Stepper::new(t, edges, row);
        // Quotients move by at most |sq| + 1 a row: bound them over every row stepped.
        let rows = i64::from(end.saturating_sub(row)) + 2 * LANES as i64;
        let fits = (0..4)
            .all(|k| s.d[k] < 2 * LIMIT && s.q[k].abs().saturating_add(rows.saturating_mul(s.sq[k].abs() + 1)) < LIMIT);
        if !fits || s.last >= LIMIT {
            return None;
        }
        let (mut q, mut r) = ([[0; LANES]; 4], [[0; LANES]; 4]);
        let (q0, r0) = (s.q, s.r);
        for j in 0..LANES {
            for k in 0..4 {
                (q[k][j], r[k][j]) = (s.q[k] as i32, s.r[k] as i32);
            }
            s.step();
        }
        // Eight rows on: the tile-row step, with the remainder brought into 0..d.
        let (mut q8, mut r8) = ([0; 4], [0; 4]);
        for k in 0..4 {
            let (dq, dr) = (s.q[k] - q0[k], s.r[k] - r0[k]);
            (q8[k], r8[k]) = if dr < 0 { (dq - 1, dr + s.d[k]) } else { (dq, dr) };
        }
        Some(TileRows {
            q,
            r,
            d: s.d.map(|d| d as i32),
            q8: q8.map(|v| v as i32),
            r8: r8.map(|v| v as i32),
            last: s.last as i32,
            row,
        })
    }

    /// The spans of the current eight rows, lanes outside `ja..jb` empty,
    /// then the bounds moved down a tile row. Scalar; the semantics of the
    /// vector kernels.
    #[inline(always)]
    pub fn next_scalar(&mut self, ja: u32, jb: u32) -> LaneSpans {
        let mut lo = [0; LANES];
        let mut hi = [0; LANES];
        for j in 0..LANES {
            let (q, r) = (&self.q, &self.r);
            let a = (q[0][j] + i32::from(r[0][j] > 0))
                .max(q[1][j] + i32::from(r[1][j] > 0))
                .max(0);
            let b = q[2][j].min(q[3][j]).min(self.last) + 1;
            let live = (ja..jb).contains(&(j as u32)) && a < b;
            (lo[j], hi[j]) = if live { (a, b) } else { (EMPTY, -EMPTY) };
        }
        for k in 0..4 {
            for j in 0..LANES {
                let t = self.r[k][j] + self.r8[k];
                let carry = i32::from(t >= self.d[k]);
                self.q[k][j] += self.q8[k] + carry;
                self.r[k][j] = t - carry * self.d[k];
            }
        }
        self.row += LANES as u32;
        LaneSpans::reduced(lo, hi)
    }
}

/// A triangle's covered columns eight rows at a time, exactly, without a
/// division per triangle or a stepped remainder: each row's bound straight
/// from its edge function in `f64`. With `x = −E` at the box's first column
/// and `d = |a|·ONE`, an edge with `a > 0` bounds a row from the left at
/// column offset `ceil(x / d)`, one with `a < 0` from the right at
/// `−ceil(x / d)`. `f64` holds every `x` over the rows exactly below `2^53`
/// ([`RowBounds::new`] refuses a triangle whose `x` leave `±2^51`); the
/// quotient estimated with `d`'s reciprocal is off by less than one, and
/// the exact product `c·d` says which way. So a row's span is exactly
/// [`Tri::row_span`]'s, like [`TileRows`]'s, for a few multiply-adds per
/// edge and row where `TileRows` keeps 64 stepped `i32` per triangle.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RowBounds {
    /// Per edge, `x` at the next tile row's first row.
    pub x: [f64; 3],
    /// Per edge, the change of `x` per row.
    pub s: [f64; 3],
    /// Per edge, `d` (1 for a horizontal edge, whose `x` is 0: it never binds).
    pub d: [f64; 3],
    /// Per edge, `1 / d`.
    pub inv: [f64; 3],
    /// Per edge, what its bound adds before it joins the left bounds (0) or
    /// the right ones (−∞): the lanes take every edge the same way, no branch.
    pub to_left: [f64; 3],
    /// See `to_left`: −∞ for a left bound, 0 for a right one.
    pub to_right: [f64; 3],
    /// The last column offset in the box.
    pub last: f64,
}

impl RowBounds {
    /// `t`'s bounds at rows `row..row + 8`, to be moved down to rows below
    /// `end`; `None` where `f64` cannot hold them exactly.
    #[inline(always)]
    pub fn new(t: &Tri, row: u32, end: u32) -> Option<RowBounds> {
        const EXACT: f64 = (1u64 << 51) as f64;
        let e = t.edges_at_row(row);
        let rows = f64::from(end.saturating_sub(row) + 2 * LANES as u32);
        let mut b = RowBounds {
            x: [0.0; 3],
            s: [0.0; 3],
            d: [1.0; 3],
            inv: [1.0; 3],
            to_left: [0.0; 3],
            to_right: [f64::NEG_INFINITY; 3],
            last: f64::from(t.x1 - t.x0) - 1.0,
        };
        for (i, (&a, &e)) in t.a.iter().zip(&e).enumerate() {
            if a == 0 {
                continue; // limits the rows only (`row_limits`)
            }
            // Finite: both come from integers.
            let (x, s) = ((-e) as f64, (-t.b[i] * ONE) as f64);
            if x.abs() + rows * s.abs() >= EXACT {
                return None;
            }
            let d = (a.abs() * ONE) as f64;
            (b.x[i], b.s[i], b.d[i], b.inv[i]) = (x, s, d, 1.0 / d);
            if a < 0 {
                (b.to_left[i], b.to_right[i]) = (f64::NEG_INFINITY, 0.0);
            }
        }
        Some(b)
    }

    /// The bounds moved down a tile row, as [`RowBounds::next_scalar`] moves them.
    #[inline(always)]
    pub fn skip_tile_row(&mut self) {
        for i in 0..3 {
            self.x[i] += self.s[i] * LANES as f64;
        }
    }

    /// The spans of the next eight rows, lanes outside `ja..jb` empty, then
    /// the bounds moved down a tile row. Scalar; the semantics of the vector
    /// kernels.
    #[inline(always)]
    pub fn next_scalar(&mut self, ja: u32, jb: u32) -> LaneSpans {
        // Per lane: the left bound, and the largest −(right bound).
        let (mut lo, mut neg_hi) = ([0.0f64; LANES], [-self.last; LANES]);
        for i in 0..3 {
            let (x0, s, d, inv) = (self.x[i], self.s[i], self.d[i], self.inv[i]);
            let c: [f64; LANES] = std::array::from_fn(|j| {
                let x = x0 + s * j as f64;
                let c = (x * inv).ceil();
                // ceil(x / d) is the c with (c − 1)·d < x <= c·d; the estimate is off by at most one.
                let r = c * d - x;
                if r < 0.0 {
                    c + 1.0
                } else if r >= d {
                    c - 1.0
                } else {
                    c
                }
            });
            lo = std::array::from_fn(|j| lo[j].max(c[j] + self.to_left[i]));
            neg_hi = std::array::from_fn(|j| neg_hi[j].max(c[j] + self.to_right[i]));
        }
        self.skip_tile_row();
        let (mut a, mut b) = ([EMPTY; LANES], [-EMPTY; LANES]);
        for j in 0..LANES {
            // Both within 0..=last + 1 before the conversion.
            let (l, h) = (lo[j].min(self.last + 1.0), (1.0 - neg_hi[j]).max(0.0));
            if (ja..jb).contains(&(j as u32)) && l < h {
                (a[j], b[j]) = (l as i32, h as i32);
            }
        }
        LaneSpans::reduced(a, b)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::raster::queue::TriangleQueue;
    use crate::raster::setup::{FaceCull, Viewport};
    use glam::Vec4;
    use hom_testkit::Rng;
    use proptest::prelude::*;

    /// Random clip-space triangles, tiny to screen-filling, some crossing the
    /// near plane or the screen edges, at spread depths.
    pub(crate) fn soup(seed: u64, n: usize, w: u32, h: u32, inner: bool) -> Vec<Tri> {
        let mut out = Vec::new();
        soup_queue(seed, n).set_up(&Viewport::new(w, h), inner, &mut out);
        out
    }

    /// The clip-space triangles of [`soup`], queued.
    pub(crate) fn soup_queue(seed: u64, n: usize) -> TriangleQueue {
        let mut rng = Rng::new(seed);
        let mut v = Vec::new();
        let mut t = Vec::new();
        for i in 0..n {
            let size = [0.01, 0.05, 0.3, 1.5, 6.0][rng.below(5) as usize];
            let (cx, cy) = (rng.range(-1.3, 1.3), rng.range(-1.3, 1.3));
            let w0 = rng.range(1.0, 21.0);
            for _ in 0..3 {
                let wv = (w0 * rng.range(0.6, 1.4)).max(0.05);
                let x = (cx + rng.range(-0.5, 0.5) * size) * wv;
                let y = (cy + rng.range(-0.5, 0.5) * size) * wv;
                v.push(Vec4::new(x, y, wv - 0.5, wv));
            }
            let b = 3 * i as u32;
            t.push([b, b + 1, b + 2]);
        }
        let mut q = TriangleQueue::default();
        q.push_clip(&v, &t, |v| v, FaceCull::None).unwrap();
        q
    }

    proptest! {
        /// `RowBounds` gives every row's exact span, `Tri::row_span`, tile
        /// row after tile row (some skipped), for every triangle it holds.
        #[test]
        fn row_bounds_are_the_exact_row_spans(seed in any::<u64>(), w in 1u32..400, h in 1u32..300, inner in any::<bool>()) {
            let tris = soup(seed, 40, w, h, inner);
            let mut held = 0;
            for t in &tris {
                let (ya, yb) = row_limits(t);
                if ya >= yb {
                    continue;
                }
                let first = ya / LANES as u32 * LANES as u32;
                let Some(mut b) = RowBounds::new(t, first, yb) else { continue };
                held += 1;
                for (k, y) in (first..yb).step_by(LANES).enumerate() {
                    if (seed >> (k % 64)) & 3 == 0 {
                        b.skip_tile_row();
                        continue;
                    }
                    let spans = b.next_scalar(0, LANES as u32);
                    for j in 0..LANES {
                        let py = y + j as u32;
                        let want = if (ya..yb).contains(&py) { t.row_span(py).unwrap_or((0, 0)) } else { (0, 0) };
                        let got = spans.span(j, u32::from(t.x0));
                        // Rows outside the horizontal edges' limits are never asked for.
                        if (ya..yb).contains(&py) {
                            prop_assert_eq!(got, want, "row {} of {:?}", py, t);
                        }
                    }
                }
            }
            // Only triangles far beyond the screen are left to the i64 forms.
            prop_assert!(held * 10 >= tris.len() * 7 || tris.len() < 5, "{} of {} held", held, tris.len());
        }
    }

    proptest! {
        /// Every row's span equals `Tri::row_span` (the renderer's coverage).
        #[test]
        fn spans_are_the_exact_row_spans(seed in any::<u64>(), w in 1u32..300, h in 1u32..200, inner in any::<bool>()) {
            for t in soup(seed, 40, w, h, inner) {
                let edges = ScanEdges::new(&t);
                let (ya, yb) = edges.rows;
                for py in u32::from(t.y0)..u32::from(t.y1) {
                    if !(ya..yb).contains(&py) {
                        prop_assert_eq!(t.row_span(py), None, "row {} of {:?} outside {:?}", py, t, edges.rows);
                    }
                }
                let mut s = vec![(0, 0); (yb - ya) as usize];
                if ya < yb {
                    // In pieces, some skipped, as bands do.
                    let mut stepper = Stepper::new(&t, &edges, ya);
                    let mut k = 0;
                    while k < s.len() {
                        let n = (1 + (seed >> (k % 60)) as usize % 13).min(s.len() - k);
                        if (seed >> (k % 50)) & 3 == 0 {
                            // Skipped rows: a fresh stepper after them, as a band does.
                            for (j, got) in s[k..k + n].iter_mut().enumerate() {
                                *got = t.row_span(ya + (k + j) as u32).unwrap_or((0, 0));
                            }
                            if k + n < s.len() {
                                stepper = Stepper::new(&t, &edges, ya + (k + n) as u32);
                            }
                        } else {
                            stepper.rows(&mut s[k..k + n]);
                        }
                        k += n;
                    }
                }
                for (k, got) in s.iter().enumerate() {
                    let py = ya + k as u32;
                    let want = t.row_span(py).unwrap_or((0, 0));
                    prop_assert_eq!(*got, want, "row {} of {:?}", py, t);
                }
            }
        }
    }
}
