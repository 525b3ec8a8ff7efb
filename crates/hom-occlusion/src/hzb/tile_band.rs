//! One band of 8×8-sample tiles being filled by the tiled depth rasterizer
//! ([`super::raster`]): the semantics every backend shares. Per triangle, a
//! block of tiles or a tile whose farthest depth is not beyond a conservative
//! floor of the triangle's plane over it is skipped (rejection never changes
//! the result: it skips only samples the triangle cannot make nearer); a tile
//! wholly outside an edge is skipped; the rest get exact `i32` edge values
//! and go to a tile kernel. [`TileKernel::run_scalar`] defines the result;
//! the vector kernels of [`super::simd`] equal it bit for bit.

use crate::hzb::tiled::{TiledZBuffer, TILE, TILE_SAMPLES};
use crate::raster::setup::{Tri, HALF, ONE};

/// Tiles per block side: blocks are a band's tile rows × `BLOCK_TILES` tiles.
const BLOCK_TILES: u32 = 8;

/// Work done by [`super::raster::TiledRasterizer::render_with`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TiledStats {
    /// Triangles set up (after clipping and face culling).
    pub triangles: u64,
    /// Blocks skipped because everything in them is nearer than the triangle.
    pub blocks_rejected: u64,
    /// Tiles skipped by depth.
    pub tiles_rejected: u64,
    /// Tiles whose samples were tested.
    pub tiles_drawn: u64,
}

impl std::ops::AddAssign for TiledStats {
    fn add_assign(&mut self, o: TiledStats) {
        self.triangles += o.triangles;
        self.blocks_rejected += o.blocks_rejected;
        self.tiles_rejected += o.tiles_rejected;
        self.tiles_drawn += o.tiles_drawn;
    }
}

/// A band's samples, tile maxima and touched flags.
pub(crate) type BandParts<'a> = (&'a mut [f32], &'a mut [f32], &'a mut [bool]);

/// One band of tile rows being filled.
pub(crate) struct Band {
    /// First tile row.
    pub ty0: u32,
    /// Tiles across.
    pub tiles_x: u32,
    /// Viewport width.
    pub width: u32,
    /// Viewport height.
    pub height: u32,
}

/// An edge function over a tile: value at the tile's first sample and steps,
/// in `i32` (exact; see [`tile_edges`]).
#[derive(Clone, Copy)]
struct TileEdges {
    e: [i32; 3],
    step_x: [i32; 3],
    step_y: [i32; 3],
}

/// The edge functions of `t` over the 8×8 tile whose first sample is
/// `(px, py)`: `None` when the tile lies wholly outside an edge; an edge the
/// tile lies wholly inside becomes the constant 0 (inside). `Err` when an
/// edge's range over the tile does not fit `i32` (only for huge triangles).
#[inline]
fn tile_edges(t: &Tri, px: u32, py: u32) -> Result<Option<TileEdges>, ()> {
    let sx = i64::from(px) * ONE + HALF;
    let sy = i64::from(py) * ONE + HALF;
    let span = i64::from(TILE - 1);
    let mut out = TileEdges {
        e: [0; 3],
        step_x: [0; 3],
        step_y: [0; 3],
    };
    for i in 0..3 {
        let (ax, by) = (t.a[i] * ONE, t.b[i] * ONE);
        let e = t.a[i] * sx + t.b[i] * sy + t.c[i];
        let lo = e + (ax * span).min(0) + (by * span).min(0);
        let hi = e + (ax * span).max(0) + (by * span).max(0);
        if hi < 0 {
            return Ok(None);
        }
        if lo >= 0 {
            continue; // inside this edge everywhere in the tile
        }
        // lo < 0 <= hi, so every value in the tile is within ±(hi - lo).
        if hi - lo >= 1 << 30 {
            return Err(());
        }
        out.e[i] = e as i32;
        out.step_x[i] = ax as i32;
        out.step_y[i] = by as i32;
    }
    Ok(Some(out))
}

/// Nearest depth `t`'s plane can give at any sample of columns `xa..=xb`,
/// rows `ya..=yb` (within its box).
#[inline]
fn plane_floor(t: &Tri, xa: u32, xb: u32, ya: u32, yb: u32) -> f32 {
    t.depth_bounds(xa, xb, ya, yb).0
}

impl Band {
    /// The farthest of block `b`'s tile maxima (`rows` tile rows). A method,
    /// not a closure, so that it inlines into each backend's band loop.
    #[inline(always)]
    fn block_max(&self, maxima: &[f32], rows: u32, b: u32) -> f32 {
        let (x0, x1) = (b * BLOCK_TILES, ((b + 1) * BLOCK_TILES).min(self.tiles_x));
        let mut lanes = [f32::NEG_INFINITY; BLOCK_TILES as usize];
        for ty in 0..rows {
            let row = &maxima[(ty * self.tiles_x + x0) as usize..(ty * self.tiles_x + x1) as usize];
            // Maxima are never NaN, so plain comparisons (which vectorize) give the max.
            for (m, &v) in lanes.iter_mut().zip(row) {
                *m = if v > *m { v } else { *m };
            }
        }
        lanes
            .into_iter()
            .fold(f32::NEG_INFINITY, |a, v| if v > a { v } else { a })
    }

    /// Draws the triangles `bin` (indices into `tris`) into this band's tiles,
    /// testing each tile with `kernel`. Inlined into each backend's entry
    /// point (`hzb/simd.rs`'s `render_band`), which compiles it with its features.
    #[inline(always)]
    pub(crate) fn render(
        &self,
        bin: &[Tri],
        (samples, maxima, touched): BandParts,
        kernel: impl Fn(&TileKernel, &mut [f32; TILE_SAMPLES]) -> Option<f32>,
    ) -> TiledStats {
        let mut stats = TiledStats::default();
        let rows = (maxima.len() as u32) / self.tiles_x;
        let blocks_x = self.tiles_x.div_ceil(BLOCK_TILES);
        let mut blocks: Vec<f32> = (0..blocks_x).map(|b| self.block_max(maxima, rows, b)).collect();
        let (py_band0, py_band1) = (self.ty0 * TILE, ((self.ty0 + rows) * TILE).min(self.height));
        for t in bin {
            let (ya, yb) = (u32::from(t.y0).max(py_band0), (u32::from(t.y1)).min(py_band1) - 1);
            let (xa, xb) = (u32::from(t.x0), u32::from(t.x1) - 1);
            let floor = plane_floor(t, xa, xb, ya, yb);
            let (ty_a, ty_b) = (ya / TILE - self.ty0, yb / TILE - self.ty0);
            let (tx_a, tx_b) = (xa / TILE, xb / TILE);
            for b in tx_a / BLOCK_TILES..=tx_b / BLOCK_TILES {
                if blocks[b as usize] <= floor {
                    stats.blocks_rejected += 1;
                    continue;
                }
                let mut changed = false;
                for ty in ty_a..=ty_b {
                    for tx in tx_a.max(b * BLOCK_TILES)..=tx_b.min((b + 1) * BLOCK_TILES - 1) {
                        let ti = (ty * self.tiles_x + tx) as usize;
                        let (px, py) = (tx * TILE, (self.ty0 + ty) * TILE);
                        // The part of the tile inside the triangle's box (and the viewport).
                        let (cx0, cx1) = (px.max(xa), (px + TILE - 1).min(xb));
                        let (cy0, cy1) = (py.max(ya), (py + TILE - 1).min(yb));
                        if maxima[ti] <= plane_floor(t, cx0, cx1, cy0, cy1) {
                            stats.tiles_rejected += 1;
                            continue;
                        }
                        let tile: &mut [f32; TILE_SAMPLES] = (&mut samples[ti * TILE_SAMPLES..][..TILE_SAMPLES])
                            .try_into()
                            .expect("tile");
                        let edges = tile_edges(t, px, py);
                        if let Ok(None) = edges {
                            continue;
                        }
                        if !touched[ti] {
                            TiledZBuffer::blank(self.width, self.height, tx, self.ty0 + ty, tile);
                            touched[ti] = true;
                        }
                        let far = match edges {
                            Ok(Some(e)) => {
                                kernel(&tile_kernel(t, &e, (px, py), (cy0, cy1), self.width, self.height), tile)
                            }
                            _ => draw_tile_wide(t, px, py, self.width, self.height, tile),
                        };
                        stats.tiles_drawn += 1;
                        if let Some(far) = far {
                            // Maxima only fall: the block's changes only if this tile held it.
                            changed |= maxima[ti] == blocks[b as usize];
                            maxima[ti] = far;
                        }
                    }
                }
                if changed {
                    blocks[b as usize] = self.block_max(maxima, rows, b);
                }
            }
        }
        stats
    }
}

/// The kernel inputs of the tile at `(px, py)` with `i32` edge functions.
#[inline]
fn tile_kernel(t: &Tri, e: &TileEdges, (px, py): (u32, u32), rows: (u32, u32), width: u32, height: u32) -> TileKernel {
    // Offsets before the box are negative; those samples are outside an edge
    // anyway, so only the exact formula for covered ones matters.
    TileKernel {
        e: e.e,
        step_x: e.step_x,
        step_y: e.step_y,
        cols: (width - px).min(TILE) as i32,
        rows: (height - py).min(TILE) as usize,
        row0: (rows.0 - py) as usize,
        row1: (rows.1 + 1 - py) as usize,
        dx0: px as i32 - i32::from(t.x0),
        dy0: py as i32 - i32::from(t.y0),
        zref: t.zref,
        dzdx: t.dzdx,
        dzdy: t.dzdy,
    }
}

/// A tile with `i64` edge functions, for triangles too large for `i32`
/// (edges across thousands of pixels of the guard band): each row's edge
/// values at its first sample, stepped by a column's increment, the same
/// values [`Tri::covers`] computes.
fn draw_tile_wide(t: &Tri, px: u32, py: u32, width: u32, height: u32, tile: &mut [f32; TILE_SAMPLES]) -> Option<f32> {
    let (x0, y0) = (u32::from(t.x0), u32::from(t.y0));
    let step = [0, 1, 2].map(|i| t.a[i] * ONE);
    let mut changed = false;
    for j in 0..(height - py).min(TILE) {
        let y = py + j;
        let zr = t.zref + t.dzdy * y.wrapping_sub(y0) as i32 as f32;
        let (sx, sy) = (i64::from(px) * ONE + HALF, i64::from(y) * ONE + HALF);
        let mut e = [0, 1, 2].map(|i| t.a[i] * sx + t.b[i] * sy + t.c[i]);
        for i in 0..(width - px).min(TILE) {
            if (e[0] | e[1] | e[2]) >= 0 {
                let z = t.depth_in_row(zr, (px + i).wrapping_sub(x0) as i32);
                let d = &mut tile[(j * TILE + i) as usize];
                if z < *d {
                    *d = z;
                    changed = true;
                }
            }
            for k in 0..3 {
                e[k] += step[k];
            }
        }
    }
    changed.then(|| tile.iter().fold(f32::NEG_INFINITY, |m, &d| m.max(d)))
}

/// One tile's inputs: the triangle's planes relative to the tile's first sample.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TileKernel {
    /// Edge values at the tile's first sample (exact `i32`, see `tiled.rs`).
    pub e: [i32; 3],
    /// Edge steps per column.
    pub step_x: [i32; 3],
    /// Edge steps per row.
    pub step_y: [i32; 3],
    /// Columns inside the viewport (1..=8).
    pub cols: i32,
    /// Rows inside the viewport (1..=8).
    pub rows: usize,
    /// The rows the triangle's box covers in this tile: `row0..row1` (within `0..rows`);
    /// no sample outside them can be covered.
    pub row0: usize,
    /// See `row0`.
    pub row1: usize,
    /// Column of the tile's first sample minus the triangle's first column.
    pub dx0: i32,
    /// Row of the tile's first sample minus the triangle's first row.
    pub dy0: i32,
    /// The triangle's depth plane: `zref + dzdy·dy + dzdx·dx`, rounded as the renderer rounds.
    pub zref: f32,
    /// Depth step per column.
    pub dzdx: f32,
    /// Depth step per row.
    pub dzdy: f32,
}

impl TileKernel {
    /// Panics unless the rows and columns lie within an 8×8 tile: what the
    /// vector kernels' unaligned loads and stores rely on to stay in the tile.
    #[inline(always)]
    pub(crate) fn assert_in_tile(&self) {
        assert!(
            self.row0 <= self.row1 && self.row1 <= self.rows && self.rows <= 8 && (1..=8).contains(&self.cols),
            "tile kernel rows {}..{} of {}, {} columns",
            self.row0,
            self.row1,
            self.rows,
            self.cols
        );
    }

    /// Depth at row `j` of the tile, column 0 of the triangle (the renderer's `depth_row`).
    #[inline(always)]
    pub(crate) fn zr(&self, j: usize) -> f32 {
        self.zref + self.dzdy * (self.dy0 + j as i32) as f32
    }

    /// The scalar kernel: the semantics. When a sample changed, the tile's new
    /// farthest depth (over its rows inside the viewport; the rest hold
    /// `NEG_INFINITY`).
    #[inline(always)]
    pub(crate) fn run_scalar(&self, tile: &mut [f32; 64]) -> Option<f32> {
        let mut changed = false;
        for j in self.row0..self.row1 {
            let zr = self.zr(j);
            for i in 0..self.cols as usize {
                let at = |q: usize| self.e[q] + self.step_x[q] * i as i32 + self.step_y[q] * j as i32;
                let z = (zr + self.dzdx * (self.dx0 + i as i32) as f32).max(0.0);
                let d = &mut tile[j * 8 + i];
                if (at(0) | at(1) | at(2)) >= 0 && z < *d {
                    *d = z;
                    changed = true;
                }
            }
        }
        changed.then(|| tile[..self.rows * 8].iter().fold(f32::NEG_INFINITY, |m, &d| m.max(d)))
    }
}
