//! A masked depth buffer after Hasselgren, Andersson and Akenine-Möller,
//! "Masked Software Occlusion Culling" (HPG 2016): instead of a depth per
//! sample, each tile of 32×8 samples holds a coverage mask, and each of its
//! eight subtiles of 8×4 samples two conservative depth layers — a
//! reference depth `z0` that bounds every sample of the subtile, and a
//! working layer: the subtile's part of the mask with a depth `z1` that
//! bounds the samples in it. Depth is hom's clip `z / w` (nearer is
//! smaller); a bound `z` means every occluder sample it covers lies at `z`
//! or nearer. (A depth per subtile, not per tile, is what the paper's
//! implementation keeps: on `large_10k` at 256² one depth per 32×8 tile
//! found 13.6 % of the hidden rectangles, one per 8×4 subtile finds
//! what the table in BENCHMARKS.md says.)
//!
//! # Updating (hom's own rule, in the spirit of the paper's)
//! A triangle covering mask `m` of a subtile with a conservative far depth
//! `zt` (its plane's farthest value over the covered part of the subtile):
//! - `zt >= z0`: it tells nothing new; skipped (this is also the rejection
//!   of occluders hidden by nearer ones).
//! - if `m` alone covers the subtile, every sample is bounded by `zt`: that
//!   becomes `z0`, and the working layer stays only if it is still nearer;
//! - else if the working layer and `m` together cover the subtile, every
//!   sample is bounded by `max(z1, zt)`: that becomes `z0` (if nearer) and
//!   the working layer empties;
//! - else, when the new triangle is much nearer than the working layer
//!   (`z1 − zt > min(z0, 1) − z1`: the far plane stands in for a `z0` not
//!   known yet), the working layer is replaced by it (its old samples fall
//!   back to `z0`, still a bound); otherwise it is merged (`mask |= m`,
//!   `z1 = max(z1, zt)`).
//!
//! Every rule only ever replaces a bound by another valid bound, so a test
//! against the buffer is conservative whatever the triangle order; occluders
//! drawn nearest first keep the bounds tight.
//!
//! # Testing
//! A rectangle at nearest depth `z` is hidden when, in every subtile it
//! touches, `z` lies beyond `z0` (by [`crate::DEPTH_MARGIN`]), or the
//! rectangle's samples there all lie in the working layer and `z` lies
//! beyond `z1`. Blocks of 4×4 tiles keep the farthest `z0` of their
//! subtiles, so a rectangle over a well-covered region is accepted a block
//! at a time. Samples past the viewport's edge count as covered (nothing
//! there is seen).
//!
//! Triangles are tested per sample against the same bounds
//! ([`MaskedZBuffer::triangles_hidden`], the per-sample depth check): an
//! object close behind a sloped hider lies beyond each subtile's bound
//! where its box's nearest depth does not lie beyond the farthest.

use crate::geom::ScreenRect;
use crate::occlusion_map::hole::worst_hole_of_level;
use crate::occlusion_map::pyramid::level_sides;
use crate::occlusion_map::{worst_hole_of_coverage, Hole, Level};
use crate::raster::scanline::all_tiles_of;
use crate::raster::setup::Tri;
use crate::{MapOptions, DEPTH_MARGIN};

/// Tile width in samples (one `u32` of mask per row).
pub const MASK_TILE_W: u32 = 32;
/// Tile height in samples.
pub const MASK_TILE_H: u32 = 8;
/// Tiles per block side.
const BLOCK: u32 = 4;

/// Subtiles per tile: 4 across (8 samples wide) by 2 down (4 rows high);
/// subtile `k = 4·(j / 4) + i / 8` holds bit `i` of mask rows `j`.
pub(crate) const SUBTILES: usize = 8;
/// Subtile width in samples (a byte of a mask row).
pub(crate) const SUB_W: u32 = 8;
/// Subtile height in samples.
pub(crate) const SUB_H: u32 = 4;

/// One tile: a mask and, per subtile, two layers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct MaskTile {
    /// Per subtile, a bound of every sample in it (`INFINITY`: nothing known).
    pub z0: [f32; SUBTILES],
    /// Per subtile, a bound of its samples in `mask` (meaningless when only
    /// the samples past the viewport's edge are in it).
    pub z1: [f32; SUBTILES],
    /// Row `j`, bit `i`: sample `(32·tx + i, 8·ty + j)` is in its subtile's working layer.
    pub mask: [u32; 8],
    /// The farthest of `z0`, kept equal to it by every update (blocks read it
    /// often); the vector kernels of the masked rasterizer keep it too.
    pub(crate) far: f32,
}

/// The masked depth buffer; see the module docs.
#[derive(Clone, Debug, Default)]
pub struct MaskedZBuffer {
    width: u32,
    height: u32,
    tiles_x: u32,
    tiles_y: u32,
    tiles: Vec<MaskTile>,
    /// Per tile, the bits of samples past the viewport's edge (always "covered").
    outside: Vec<[u32; 8]>,
    /// The tiles as a clear leaves them.
    fresh: Vec<MaskTile>,
    /// Per block of 4×4 tiles, the farthest `z0` of its tiles (filled by [`MaskedZBuffer::build_blocks`]).
    blocks: Vec<f32>,
    blocks_x: u32,
}

/// Bits `lo..hi` of a 32-bit row (`lo`, `hi` clamped to `0..=32`).
#[inline]
pub(crate) fn row_bits(lo: i64, hi: i64) -> u32 {
    let (lo, hi) = (lo.clamp(0, 32), hi.clamp(0, 32));
    if hi <= lo {
        0
    } else {
        ((1u64 << hi) - (1u64 << lo)) as u32
    }
}

impl MaskedZBuffer {
    /// Clears to "nothing covered" at `width` × `height` (each side 1..=16384).
    ///
    /// # Panics
    /// If a side is 0 or above 16384.
    pub fn clear(&mut self, width: u32, height: u32) {
        assert!(
            (1..=16384).contains(&width) && (1..=16384).contains(&height),
            "viewport {width}x{height}"
        );
        if (width, height) != (self.width, self.height) {
            self.width = width;
            self.height = height;
            self.tiles_x = width.div_ceil(MASK_TILE_W);
            self.tiles_y = height.div_ceil(MASK_TILE_H);
            self.outside = (0..self.tiles_y)
                .flat_map(|ty| (0..self.tiles_x).map(move |tx| (tx, ty)))
                .map(|(tx, ty)| {
                    let inside_cols = row_bits(0, i64::from(width - tx * MASK_TILE_W));
                    let rows = height - ty * MASK_TILE_H;
                    std::array::from_fn(|j| if (j as u32) < rows { !inside_cols } else { u32::MAX })
                })
                .collect();
            self.blocks_x = self.tiles_x.div_ceil(BLOCK);
            // A subtile wholly past the viewport's edge holds no sample: its
            // bound is nearer than anything, so it never holds a block back.
            self.fresh = self
                .outside
                .iter()
                .map(|&mask| {
                    let mut tile = MaskTile {
                        z0: std::array::from_fn(|k| {
                            let byte = 0xFFu32 << ((k % 4) as u32 * SUB_W);
                            let rows = &mask[k / 4 * SUB_H as usize..][..SUB_H as usize];
                            if rows.iter().all(|r| r & byte == byte) {
                                f32::NEG_INFINITY
                            } else {
                                f32::INFINITY
                            }
                        }),
                        z1: [f32::NEG_INFINITY; SUBTILES],
                        mask,
                        far: f32::INFINITY,
                    };
                    tile.refresh_far();
                    tile
                })
                .collect();
        }
        self.tiles.clear();
        self.tiles.extend_from_slice(&self.fresh);
        self.blocks.clear();
    }

    /// Width in samples.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in samples.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Tiles across and down.
    pub fn tiles(&self) -> (u32, u32) {
        (self.tiles_x, self.tiles_y)
    }

    /// The bound the buffer holds for sample `(x, y)`: every occluder sample
    /// drawn there lies at this depth or nearer (`INFINITY`: none known).
    ///
    /// # Panics
    /// If `(x, y)` is outside the viewport.
    pub fn bound(&self, x: u32, y: u32) -> f32 {
        assert!(
            x < self.width && y < self.height,
            "sample {x},{y} outside {}x{}",
            self.width,
            self.height
        );
        let t = &self.tiles[((y / MASK_TILE_H) * self.tiles_x + x / MASK_TILE_W) as usize];
        let (i, j) = (x % MASK_TILE_W, y % MASK_TILE_H);
        let k = subtile(i, j);
        if t.mask[j as usize] >> i & 1 == 1 {
            t.z0[k].min(t.z1[k])
        } else {
            t.z0[k]
        }
    }

    /// One bit per sample with a finite bound (covered by something): bit
    /// `x % 64` of word `y * ceil(width / 64) + x / 64`, as
    /// [`crate::occlusion_map::CoverageBuffer`] lays its bits out.
    pub fn coverage_bits(&self, bits: &mut Vec<u64>) {
        let wpr = (self.width as usize).div_ceil(64);
        bits.clear();
        bits.resize(wpr * self.height as usize, 0);
        for k in 0..self.tiles.len() {
            let (tx, ty) = (k as u32 % self.tiles_x, k as u32 / self.tiles_x);
            for (j, row) in self.covered_rows(k).into_iter().enumerate() {
                let (x, y) = (tx * MASK_TILE_W, ty as usize * MASK_TILE_H as usize + j);
                if y < self.height as usize {
                    // Tiles are 32 wide: a tile row never straddles two words.
                    bits[y * wpr + x as usize / 64] |= u64::from(row) << (x % 64);
                }
            }
        }
    }

    /// How many of tile `(tx, ty)`'s samples inside the viewport have a finite bound.
    #[inline]
    fn covered_count(&self, tx: u32, ty: u32) -> u32 {
        let k = (ty * self.tiles_x + tx) as usize;
        // A finite farthest reference depth: every subtile is covered whole
        // (most tiles of a frame full of walls), no rows needed (oa_dm1's
        // search 5 % faster for this alone).
        if self.tiles[k].far.is_finite() {
            let past_edge = if tx + 1 < self.tiles_x && ty + 1 < self.tiles_y {
                0
            } else {
                self.outside[k].iter().map(|r| r.count_ones()).sum()
            };
            MASK_TILE_W * MASK_TILE_H - past_edge
        } else {
            self.covered_rows(k).iter().map(|r| r.count_ones()).sum()
        }
    }

    /// Tile `k`'s samples inside the viewport with a finite bound, a row of bits each.
    #[inline]
    fn covered_rows(&self, k: usize) -> [u32; MASK_TILE_H as usize] {
        let t = &self.tiles[k];
        // Per half of the tile (subtile row), the bytes whose subtile has
        // a finite reference depth, and those with a finite working layer.
        let bytes = |z: &[f32; SUBTILES], sy: usize| {
            (0..4).fold(0u32, |b, sx| {
                b | (u32::from(z[sy * 4 + sx].is_finite()) * (0xFF << (sx * 8)))
            })
        };
        let all = [bytes(&t.z0, 0), bytes(&t.z0, 1)];
        let layer = [bytes(&t.z1, 0), bytes(&t.z1, 1)];
        std::array::from_fn(|j| {
            let sy = j / SUB_H as usize;
            !self.outside[k][j] & (all[sy] | (t.mask[j] & layer[sy]))
        })
    }

    /// The worst hole of the coverage (the samples with a finite bound) in
    /// an occlusion pyramid of `map`'s geometry: what
    /// [`crate::occlusion_map::worst_hole_of_coverage`] finds from
    /// [`MaskedZBuffer::coverage_bits`], without the bits or the levels
    /// below the coarsest where its pixels are whole tiles (sides multiples
    /// of 32 samples, at 1024² 256): each pixel's count is its tiles' covered
    /// samples plus those past the viewport's edge, which count as covered.
    pub fn worst_hole(&self, map: &MapOptions, hole_opacity: f32) -> Option<Hole> {
        let (w, h) = (self.width, self.height);
        if w == 0 || h == 0 {
            return None;
        }
        let block = map.map_block(w, h);
        let (k, (tw, th)) = level_sides(w, h, block, map.min_level_side).enumerate().last()?;
        let size = block << k;
        if !size.is_multiple_of(MASK_TILE_W) {
            let mut bits = Vec::new();
            self.coverage_bits(&mut bits);
            return worst_hole_of_coverage(&bits, w, h, map, hole_opacity);
        }
        let mut top = Level {
            width: tw,
            height: th,
            samples_per_pixel: size * size,
            counts: vec![0; (tw * th) as usize],
        };
        let (per_x, per_y) = (size / MASK_TILE_W, size / MASK_TILE_H);
        // A top pixel's run of tiles at a time: no division per tile (the
        // three there were took suspended's search from 0.028 to 0.062 ms a
        // frame at 1024², masked, `--no-cost-model`).
        for ty in 0..self.tiles_y {
            let row = (ty / per_y * tw) as usize;
            for (px, tx0) in (0..self.tiles_x).step_by(per_x as usize).enumerate() {
                let tiles = tx0..(tx0 + per_x).min(self.tiles_x);
                top.counts[row + px] += tiles.map(|tx| self.covered_count(tx, ty)).sum::<u32>();
            }
        }
        for (i, c) in top.counts.iter_mut().enumerate() {
            let (x, y) = (i as u32 % tw * size, i as u32 / tw * size);
            *c += size * size - size.min(w - x) * size.min(h - y);
        }
        worst_hole_of_level(&top, size, (w, h), hole_opacity)
    }

    /// The tiles and their bits past the viewport's edge, for the rasterizer's bands.
    pub(crate) fn rows_mut(&mut self) -> (&mut [MaskTile], &[[u32; 8]], u32) {
        self.blocks.clear();
        (&mut self.tiles, &self.outside, self.tiles_x)
    }

    /// Builds the block maxima (after drawing, before testing).
    pub fn build_blocks(&mut self) {
        let blocks_y = self.tiles_y.div_ceil(BLOCK);
        self.blocks.clear();
        self.blocks
            .resize((self.blocks_x * blocks_y) as usize, f32::NEG_INFINITY);
        for ty in 0..self.tiles_y {
            for tx in 0..self.tiles_x {
                let b = &mut self.blocks[((ty / BLOCK) * self.blocks_x + tx / BLOCK) as usize];
                *b = b.max(self.tiles[(ty * self.tiles_x + tx) as usize].far());
            }
        }
    }

    /// True when every sample of `r` holds an occluder nearer than
    /// `r.z_near` by more than [`DEPTH_MARGIN`] (see the module docs). An
    /// empty rectangle is behind. `r` must lie within the viewport.
    ///
    /// # Panics
    /// If the blocks were not built since the last draw ([`MaskedZBuffer::build_blocks`]).
    pub fn is_behind(&self, r: &ScreenRect) -> bool {
        if r.is_empty() {
            return true;
        }
        assert!(!self.blocks.is_empty(), "MaskedZBuffer::build_blocks was not called");
        let z = r.z_near;
        // Most visible rectangles are visible at their centre.
        let (cx, cy) = ((r.x0 + r.x1 - 1) / 2, (r.y0 + r.y1 - 1) / 2);
        if z <= self.bound(cx, cy) + DEPTH_MARGIN {
            return false;
        }
        let (tx0, ty0) = (r.x0 / MASK_TILE_W, r.y0 / MASK_TILE_H);
        let (tx1, ty1) = ((r.x1 - 1) / MASK_TILE_W, (r.y1 - 1) / MASK_TILE_H);
        for by in ty0 / BLOCK..=ty1 / BLOCK {
            for bx in tx0 / BLOCK..=tx1 / BLOCK {
                if z > self.blocks[(by * self.blocks_x + bx) as usize] + DEPTH_MARGIN {
                    continue; // every sample of the block is bounded nearer
                }
                for ty in (by * BLOCK).max(ty0)..=((by + 1) * BLOCK - 1).min(ty1) {
                    for tx in (bx * BLOCK).max(tx0)..=((bx + 1) * BLOCK - 1).min(tx1) {
                        if !self.tile_behind(tx, ty, r) {
                            return false;
                        }
                    }
                }
            }
        }
        true
    }

    /// Whether `tris` (set up for this viewport by the renderer's rule) lie
    /// beyond the buffer's bound ([`MaskedZBuffer::bound`]) by more than
    /// [`DEPTH_MARGIN`] at every sample they cover: the per-sample depth
    /// check, asked of the masked layers. Coarse levels first: a triangle's
    /// box at its nearest depth against the blocks (when built), then per
    /// tile its nearest depth over its rows there against the tile's
    /// farthest bound, per subtile against its reference depth, and only
    /// then sample by sample. An empty list is hidden.
    pub fn triangles_hidden(&self, tris: &[Tri]) -> bool {
        tris.iter().all(|t| self.triangle_hidden(t))
    }

    /// One triangle, a tile row (8 rows) at a time.
    fn triangle_hidden(&self, t: &Tri) -> bool {
        all_tiles_of(
            t,
            (self.width, self.height),
            (MASK_TILE_W, MASK_TILE_H),
            |rect| !self.blocks.is_empty() && self.is_behind(rect),
            |row, spans, x, end| self.tile_rows_hidden(t, row, spans, x, end),
        )
    }

    /// Whether `t`'s samples in columns `x..end` (one tile's) of rows
    /// `row..row + spans.len()` (one tile row's; `spans` their covered
    /// columns) all lie beyond their bounds.
    #[inline]
    fn tile_rows_hidden(&self, t: &Tri, row: u32, spans: &[(u32, u32)], x: u32, end: u32) -> bool {
        let tile = &self.tiles[((row / MASK_TILE_H) * self.tiles_x + x / MASK_TILE_W) as usize];
        let last_row = row + spans.len() as u32 - 1;
        if t.depth_bounds(x, end - 1, row, last_row).0 > tile.far + DEPTH_MARGIN {
            return true;
        }
        // The subtile rows (4 samples high) the band holds, then their subtiles.
        let mut r = row;
        while r <= last_row {
            let sub_end = (last_row + 1).min((r / SUB_H + 1) * SUB_H);
            let sub_spans = &spans[(r - row) as usize..(sub_end - row) as usize];
            let mut sx = x;
            while sx < end {
                let s_end = end.min((sx / SUB_W + 1) * SUB_W);
                if !Self::subtile_hidden(tile, t, r, sub_spans, sx, s_end) {
                    return false;
                }
                sx = s_end;
            }
            r = sub_end;
        }
        true
    }

    /// Whether `t`'s samples in columns `x..end` (one subtile's) of rows
    /// `row..row + spans.len()` (one subtile row's) all lie beyond their bounds.
    #[inline]
    fn subtile_hidden(tile: &MaskTile, t: &Tri, row: u32, spans: &[(u32, u32)], x: u32, end: u32) -> bool {
        if spans.iter().all(|&(lo, hi)| lo.max(x) >= hi.min(end)) {
            return true; // the triangle covers none of it
        }
        let k = subtile(x % MASK_TILE_W, row % MASK_TILE_H);
        let last_row = row + spans.len() as u32 - 1;
        let z0 = tile.z0[k];
        if t.depth_bounds(x, end - 1, row, last_row).0 > z0 + DEPTH_MARGIN {
            return true;
        }
        let z1 = z0.min(tile.z1[k]);
        for (py, &(lo, hi)) in (row..).zip(spans) {
            let (lo, hi) = (lo.max(x), hi.min(end));
            if lo >= hi {
                continue;
            }
            let zr = t.depth_row(py);
            let mask = tile.mask[(py % MASK_TILE_H) as usize];
            let seen = (lo..hi).any(|px| {
                let bound = if mask >> (px % MASK_TILE_W) & 1 == 1 { z1 } else { z0 };
                t.depth_in_row(zr, px as i32 - i32::from(t.x0)) <= bound + DEPTH_MARGIN
            });
            if seen {
                return false;
            }
        }
        true
    }

    /// Whether the samples of `r` in tile `(tx, ty)` are all bounded nearer than `r.z_near`.
    #[inline]
    fn tile_behind(&self, tx: u32, ty: u32, r: &ScreenRect) -> bool {
        let t = &self.tiles[(ty * self.tiles_x + tx) as usize];
        let z = r.z_near;
        let (x0, y0) = (tx * MASK_TILE_W, ty * MASK_TILE_H);
        let cols = row_bits(i64::from(r.x0) - i64::from(x0), i64::from(r.x1) - i64::from(x0));
        let (j0, j1) = (r.y0.max(y0) - y0, r.y1.min(y0 + MASK_TILE_H) - y0);
        for sy in j0 / SUB_H..=(j1 - 1) / SUB_H {
            let rows = j0.max(sy * SUB_H)..j1.min((sy + 1) * SUB_H);
            for sx in 0..4 {
                let sel = cols & 0xFF << (sx * SUB_W);
                if sel == 0 {
                    continue;
                }
                let k = (sy * 4 + sx) as usize;
                if z > t.z0[k] + DEPTH_MARGIN {
                    continue;
                }
                if z.is_nan() || z <= t.z1[k] + DEPTH_MARGIN {
                    return false;
                }
                if rows.clone().any(|j| sel & !t.mask[j as usize] != 0) {
                    return false;
                }
            }
        }
        true
    }
}

/// The subtile of bit `i` of mask row `j`.
#[inline]
pub(crate) fn subtile(i: u32, j: u32) -> usize {
    ((j / SUB_H) * 4 + i / SUB_W) as usize
}

impl MaskTile {
    /// The farthest reference depth of the tile's subtiles.
    #[inline]
    pub(crate) fn far(&self) -> f32 {
        self.far
    }

    /// Recomputes `far` after a reference depth fell.
    #[inline]
    fn refresh_far(&mut self) {
        self.far = self.z0.iter().fold(f32::NEG_INFINITY, |m, &z| m.max(z));
    }

    /// Folds in a triangle covering `m` (within the viewport) with far depth
    /// `zt[k]` over its part of subtile `k` (see the module docs); `outside`
    /// is the tile's samples past the viewport's edge. Returns false when the
    /// triangle told the tile nothing new.
    #[inline(always)]
    pub(crate) fn insert(&mut self, m: &[u32; 8], zt: &[f32; SUBTILES], outside: &[u32; 8]) -> bool {
        let (mut told, mut fell) = (false, false);
        for sy in 0..2 {
            let rows = sy * SUB_H as usize..(sy + 1) * SUB_H as usize;
            // Per subtile (a byte of each row): whether m reaches it, covers
            // it with the samples outside, covers it with the working layer,
            // and whether the working layer holds anything.
            let (mut reach, mut alone, mut merged, mut held) = (0u32, u32::MAX, u32::MAX, 0u32);
            for j in rows.clone() {
                reach |= m[j];
                alone &= m[j] | outside[j];
                merged &= self.mask[j] | m[j];
                held |= self.mask[j] ^ outside[j];
            }
            // Bytes to set to `outside`, to `m | outside`, to `mask | m`.
            let (mut clear, mut replace, mut merge) = (0u32, 0u32, 0u32);
            // Only the subtiles m reaches (a small triangle: one or two).
            let mut reached = reach;
            while reached != 0 {
                let sx = (reached.trailing_zeros() / SUB_W) as usize;
                let byte = 0xFFu32 << (sx as u32 * SUB_W);
                reached &= !byte;
                let (k, z) = (sy * 4 + sx, zt[sy * 4 + sx]);
                if z.is_nan() || z >= self.z0[k] {
                    continue;
                }
                told = true;
                let empty = held & byte == 0;
                if alone & byte == byte {
                    fell = true;
                    self.z0[k] = z;
                    if self.z1[k] >= z {
                        clear |= byte;
                        self.z1[k] = f32::NEG_INFINITY;
                    }
                } else if merged & byte == byte {
                    let far = if empty { z } else { self.z1[k].max(z) };
                    fell |= far < self.z0[k];
                    self.z0[k] = self.z0[k].min(far);
                    clear |= byte;
                    self.z1[k] = f32::NEG_INFINITY;
                } else if !empty && z < self.z1[k] && self.z1[k] - z > self.z0[k].min(1.0) - self.z1[k] {
                    // Much nearer than the working layer: start a new one.
                    replace |= byte;
                    self.z1[k] = z;
                } else {
                    self.z1[k] = if empty { z } else { self.z1[k].max(z) };
                    merge |= byte;
                }
            }
            if clear | replace | merge != 0 {
                for j in rows {
                    let (r, o) = (self.mask[j], outside[j]);
                    self.mask[j] = r & !(clear | replace) | o & clear | (m[j] | o) & replace | m[j] & merge;
                }
            }
        }
        if fell {
            self.refresh_far();
        }
        told
    }

    /// [`MaskTile::insert`] of a triangle that covers the whole tile (within
    /// the viewport): every sample of subtile `k` lies at `zt[k]` or nearer,
    /// whatever the layers held, so that becomes its reference depth; the
    /// working layer stays where it is still nearer.
    #[inline(always)]
    pub(crate) fn insert_full(&mut self, zt: &[f32; SUBTILES], outside: &[u32; 8]) -> bool {
        let mut told = false;
        let mut clear = [0u32; 2];
        for k in 0..SUBTILES {
            if zt[k] < self.z0[k] {
                told = true;
                self.z0[k] = zt[k];
                if self.z1[k] >= zt[k] {
                    clear[k / 4] |= 0xFF << ((k % 4) as u32 * SUB_W);
                    self.z1[k] = f32::NEG_INFINITY;
                }
            }
        }
        if clear != [0; 2] {
            for (j, row) in self.mask.iter_mut().enumerate() {
                let c = clear[j / SUB_H as usize];
                *row = *row & !c | outside[j] & c;
            }
        }
        if told {
            self.refresh_far();
        }
        told
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hom_testkit::Rng;

    #[test]
    fn row_bits_are_the_range() {
        for lo in -3..36i64 {
            for hi in -3..36i64 {
                let b = row_bits(lo, hi);
                for i in 0..32 {
                    assert_eq!(b >> i & 1 == 1, i >= lo && i < hi, "{lo}..{hi} bit {i}");
                }
            }
        }
    }

    /// Random inserts of random masks and depths, in any order: every
    /// sample's bound stays at or beyond its truth (the nearest depth of the
    /// inserts covering it), and the rectangle test never calls a rectangle
    /// behind where a sample's truth is not nearer.
    /// Inserts the samples `x0..x1` × `y0..y1` (within the viewport) at depth `z`, as a triangle would.
    fn insert_rect(zb: &mut MaskedZBuffer, (x0, x1): (u32, u32), (y0, y1): (u32, u32), z: f32) {
        let (tiles_x, _) = zb.tiles();
        let (tiles, outside, _) = zb.rows_mut();
        for ty in y0 / 8..=(y1 - 1) / 8 {
            for tx in x0 / 32..=(x1 - 1) / 32 {
                let m: [u32; 8] = std::array::from_fn(|j| {
                    let y = ty * 8 + j as u32;
                    if y >= y0 && y < y1 {
                        row_bits(i64::from(x0) - i64::from(tx * 32), i64::from(x1) - i64::from(tx * 32))
                    } else {
                        0
                    }
                });
                let k = (ty * tiles_x + tx) as usize;
                tiles[k].insert(&m, &[z; SUBTILES], &outside[k]);
            }
        }
    }

    /// The worst hole counted straight from the tiles equals the one found
    /// from the coverage bits through a whole pyramid, on viewports whose
    /// coarsest pixels are whole tiles and on the others (the bits path).
    #[test]
    fn worst_hole_equals_the_pyramid_of_the_coverage_bits() {
        let mut rng = Rng::new(11);
        let map = MapOptions::default();
        let (mut direct, mut holes) = (0, 0);
        for case in 0..300 {
            let (w, h) = (1 + rng.below(400) as u32, 1 + rng.below(300) as u32);
            let mut zb = MaskedZBuffer::default();
            zb.clear(w, h);
            for _ in 0..rng.below(60) {
                let (x0, y0) = (rng.below(u64::from(w)) as u32, rng.below(u64::from(h)) as u32);
                let x1 = (x0 + 1 + rng.below(u64::from(w)) as u32).min(w);
                let y1 = (y0 + 1 + rng.below(u64::from(h)) as u32).min(h);
                insert_rect(&mut zb, (x0, x1), (y0, y1), rng.unit());
            }
            let block = map.map_block(w, h);
            let k = level_sides(w, h, block, map.min_level_side).count() - 1;
            direct += usize::from((block << k).is_multiple_of(MASK_TILE_W));
            let mut want_bits = Vec::new();
            zb.coverage_bits(&mut want_bits);
            for opacity in [0.25, 0.6, 1.0] {
                let want = worst_hole_of_coverage(&want_bits, w, h, &map, opacity);
                assert_eq!(zb.worst_hole(&map, opacity), want, "case {case}: {w}x{h}, {opacity}");
                holes += usize::from(want.is_some());
            }
        }
        assert!(direct > 100 && direct < 290, "{direct} of 300 counted from the tiles");
        assert!(holes > 200 && holes < 850, "{holes} holes of 900");
    }

    #[test]
    fn bounds_stay_conservative_whatever_the_order() {
        let mut rng = Rng::new(5);
        for case in 0..400 {
            let (w, h) = (1 + rng.below(100) as u32, 1 + rng.below(30) as u32);
            let mut zb = MaskedZBuffer::default();
            zb.clear(w, h);
            // The truth: per sample, the nearest depth of any triangle covering it.
            let mut truth = vec![f32::INFINITY; (w * h) as usize];
            for _ in 0..(1 + rng.below(40)) {
                // A random rectangle of samples at a random depth, as a "triangle".
                let (x0, x1) = (rng.below(u64::from(w)) as u32, rng.below(u64::from(w)) as u32);
                let (y0, y1) = (rng.below(u64::from(h)) as u32, rng.below(u64::from(h)) as u32);
                let (x0, x1, y0, y1) = (x0.min(x1), x0.max(x1) + 1, y0.min(y1), y0.max(y1) + 1);
                let z = rng.unit();
                for y in y0..y1 {
                    for x in x0..x1 {
                        let t = &mut truth[(y * w + x) as usize];
                        *t = t.min(z);
                    }
                }
                insert_rect(&mut zb, (x0, x1), (y0, y1), z);
            }
            zb.build_blocks();
            for t in &zb.tiles {
                assert_eq!(
                    t.far(),
                    t.z0.iter().fold(f32::NEG_INFINITY, |m, &z| m.max(z)),
                    "case {case}: kept far"
                );
            }
            for y in 0..h {
                for x in 0..w {
                    let t = truth[(y * w + x) as usize];
                    assert!(
                        zb.bound(x, y) >= t,
                        "case {case}: sample {x},{y} bound {} nearer than {t}",
                        zb.bound(x, y)
                    );
                }
            }
            // And the rectangle test agrees with the bounds, conservatively.
            for _ in 0..50 {
                let (x0, y0) = (rng.below(u64::from(w)) as u32, rng.below(u64::from(h)) as u32);
                let r = ScreenRect {
                    x0,
                    y0,
                    x1: (x0 + 1 + rng.below(40) as u32).min(w),
                    y1: (y0 + 1 + rng.below(12) as u32).min(h),
                    z_near: rng.unit() * 1.2,
                    z_far: 1.0,
                };
                if zb.is_behind(&r) {
                    for y in r.y0..r.y1 {
                        for x in r.x0..r.x1 {
                            assert!(
                                r.z_near > truth[(y * w + x) as usize],
                                "case {case}: {r:?} called behind at {x},{y}"
                            );
                        }
                    }
                }
            }
        }
    }
}
