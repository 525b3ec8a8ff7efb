//! The depth cells of HOM's draw (Zhang et al. 1997, section 4.3: the depth
//! estimation buffer, filled as the coverage is): each cell keeps the
//! farthest depth of the occluder samples first covered in it, raised once
//! per run of fresh words without a division per column.

use crate::raster::setup::Tri;
use std::ops::Range;

/// A column's depth cell without a division: `x / w` as a multiply and a
/// shift, exact for every column `x < 2^16` and width `1 <= w < 2^16` (the
/// product's error is below `x / 2^32 < 1 / w`, less than the distance from
/// `x / w` to the next integer).
#[derive(Clone, Copy, Debug)]
pub(super) struct CellOf {
    pub(super) w: u32,
    pub(super) recip: u64,
}

impl CellOf {
    pub(super) fn new(w: u32) -> CellOf {
        debug_assert!((1..1 << 16).contains(&w));
        CellOf {
            w,
            recip: (1u64 << 32) / u64::from(w) + 1,
        }
    }

    #[inline(always)]
    pub(super) fn of(self, x: u32) -> u32 {
        debug_assert!(x < 1 << 16);
        ((u64::from(x) * self.recip) >> 32) as u32
    }
}

/// The depth cells' grid, for finding the cells a triangle covers whole: a
/// triangle that covers every sample of a cell bounds the nearest depth of
/// each, so the cell can fall to the triangle's farthest depth over it.
#[derive(Clone, Copy, Debug)]
pub(super) struct CellGrid {
    /// The column of cells of a column.
    pub(super) col_of: CellOf,
    /// The row of cells of a row (counted from a band's first).
    pub(super) row_of: CellOf,
    /// The viewport's width (the last column of cells may be cut by it).
    pub(super) width: u32,
    /// Cells across.
    pub(super) cols: u32,
}

impl CellGrid {
    /// The cells whose samples all lie in columns `xa..xb`.
    #[inline]
    pub(super) fn cols_within(self, xa: u32, xb: u32) -> Range<u32> {
        let first = self.col_of.of(xa + self.col_of.w - 1);
        let end = if xb >= self.width {
            self.cols
        } else {
            self.col_of.of(xb)
        };
        first..end.max(first)
    }

    /// Lowers each cell of a band (rows `band.0..band.1`, cells `cells`) that
    /// `t` covers whole, within its rows `rows` there, to `t`'s farthest depth
    /// over it, if nearer.
    #[inline(always)]
    pub(super) fn lower_whole(self, cells: &mut [f32], t: &Tri, band: (u32, u32), rows: (u32, u32)) {
        // Only the viewport's last row and column of cells are smaller than a cell.
        let tall = rows.1 - rows.0 >= self.row_of.w || rows.1 >= band.1;
        let wide = u32::from(t.x1 - t.x0) >= self.col_of.w || u32::from(t.x1) >= self.width;
        if tall && wide {
            self.lower_whole_cells(cells, t, band, rows);
        }
    }

    /// [`CellGrid::lower_whole`] past its size test.
    #[inline(never)]
    pub(super) fn lower_whole_cells(self, cells: &mut [f32], t: &Tri, band: (u32, u32), rows: (u32, u32)) {
        let (h, cols) = (self.row_of.w, self.cols as usize);
        let first = self.row_of.of(rows.0 - band.0 + h - 1);
        let end = if rows.1 >= band.1 {
            self.row_of.of(band.1 - band.0 + h - 1)
        } else {
            self.row_of.of(rows.1 - band.0)
        };
        let across = self.cols_within(t.x0.into(), t.x1.into());
        if first >= end || across.is_empty() {
            return;
        }
        // Most triangles lie behind every cell they could cover whole.
        let near = t.depth_bounds(t.x0.into(), u32::from(t.x1) - 1, rows.0, rows.1 - 1).0;
        let (ca, cb) = (across.start as usize, across.end as usize);
        if !(first..end).any(|r| cells[r as usize * cols..][ca..cb].iter().any(|&c| c > near)) {
            return;
        }
        for r in first..end {
            // The last row of cells may be cut by the viewport (the band's end).
            let (ya, yb) = (band.0 + r * h, (band.0 + (r + 1) * h).min(band.1));
            let Some((xa, xb)) = t.columns_in_every_row(ya, yb) else {
                continue;
            };
            let row = &mut cells[r as usize * cols..][..cols];
            for c in self.cols_within(xa, xb) {
                if row[c as usize] <= near {
                    continue;
                }
                let (xa, xb) = (c * self.col_of.w, ((c + 1) * self.col_of.w).min(self.width));
                let far = t.depth_bounds(xa, xb - 1, ya, yb - 1).1;
                let cell = &mut row[c as usize];
                *cell = cell.min(far);
            }
        }
    }
}

/// Raises the depth cells over a triangle's first-covered samples in one
/// run of rows, and empties the run's scratch: `fresh` holds the samples
/// (bit `i` of word `k` is sample `base + 64k + i`, OR-ed over the rows) and
/// `rows[k]` the first and last rows where word `k` took any. Each cell's
/// part of a word rises to triangle `t`'s depth at its farthest such
/// column — its last when the depth rises along rows, its first otherwise —
/// in the farther of those two rows: the depth formula is monotone in the
/// column and in the row (its roundings are), so that is at least the depth
/// at every sample concerned.
#[inline]
pub(super) fn raise_fresh_cells(
    cells: &mut [f32],
    cell_of: CellOf,
    fresh: &mut [u64],
    rows: &mut [(u32, u32)],
    base: u32,
    t: &Tri,
) {
    let (x0, rising) = (u32::from(t.x0), t.dzdx >= 0.0);
    let depth_in_row = |zr: f32, x: u32| t.depth_in_row(zr, (x - x0) as i32);
    for (k, (word, r)) in fresh.iter_mut().zip(rows.iter_mut()).enumerate() {
        let mut m = std::mem::take(word);
        let (ra, rb) = std::mem::replace(r, (u32::MAX, 0));
        if m == 0 {
            continue;
        }
        let (za, zb) = (t.depth_row(ra), t.depth_row(rb));
        let base = base + 64 * k as u32;
        while m != 0 {
            let first = base + m.trailing_zeros();
            let cell = cell_of.of(first);
            let upto = ((cell + 1) * cell_of.w).min(base + 64) - base;
            let in_cell = if upto == 64 { m } else { m & ((1u64 << upto) - 1) };
            let far = if rising {
                base + 63 - in_cell.leading_zeros()
            } else {
                first
            };
            let c = &mut cells[cell as usize];
            *c = c.max(depth_in_row(za, far).max(depth_in_row(zb, far)));
            m &= !in_cell;
        }
    }
}
