//! The masked rasterizer (after Hasselgren, Andersson and Akenine-Möller,
//! "Masked Software Occlusion Culling", HPG 2016): set-up triangles into a
//! [`MaskedZBuffer`] as coverage masks of 32×8-sample tiles with one
//! conservative depth per triangle and 8×4 subtile.
//!
//! Coverage comes from edge events per scan line, not per-sample edge
//! functions: [`crate::raster::scanline`] steps each row's span exactly from the row
//! before, so a row's span is exactly the one [`Tri::row_span`] computes
//! (the renderer's coverage, or the inner rule's when the triangle was set
//! up with it). The eight rows of a tile row step together as eight `i32`
//! lanes ([`TileRows`], vector kernels in [`super::simd`]); a
//! triangle with few rows left steps them one at a time ([`Stepper`]), and a
//! box of at most 8×8 samples takes the per-sample edge test
//! ([`row_masks`]), which needs no division. A tile row's masks are then
//! two shifts of its spans.
//!
//! Depth: per triangle and subtile, the farthest value of the triangle's
//! plane over the covered part of the subtile, plus rounding slack
//! ([`Tri::far_depth_grid`]), so at least the depth the renderer computes at
//! any sample the triangle covers there ([`Tri::depth_at`]).
//!
//! Bands of tile rows are independent and each sees its triangles in order,
//! so the result does not depend on the thread count or on how bands are
//! grouped.

use super::simd::{render_group, RowKernel};
use crate::masked::zbuffer::{MaskTile, MaskedZBuffer, MASK_TILE_H, MASK_TILE_W, SUB_H, SUB_W};
use crate::raster::scanline::{LaneSpans, ScanEdges, Stepper, TileRows, EMPTY};
use crate::raster::setup::Tri;
use crate::raster::simd::{row_masks, RasterBackend};
use rayon::prelude::*;

/// Tile rows per band (each band is filled by one thread).
const BAND_TILES: u32 = 4;
/// Above this many triangles a frame's bands are split into one group per
/// thread, not three: on the 100k MOC inputs at two threads 36.5 against
/// 44.4 ms (`small_100k`, 1080p), 20.2 against 27.8 (`large_100k`, 1080p);
/// the walkthroughs' few thousand occluder triangles, bunched in some rows,
/// need the stealing (masked cull city 2.76 ms with three, 3.27 with one).
const MANY_TRIANGLES: usize = 16_384;

/// Tiles per block (across): a triangle whose nearest depth lies beyond
/// every tile's reference depth in a block skips the block.
const BLOCK_TILES: u32 = 8;

/// Work done by [`MaskedRasterizer::render`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct MaskedStats {
    /// Tiles a triangle's coverage reached.
    pub tiles_drawn: u64,
    /// Of those, tiles the triangle told nothing new (hidden or empty).
    pub tiles_rejected: u64,
    /// Triangle and band pairs skipped whole, before any coverage, because
    /// the triangle lies behind every tile of the blocks it overlaps.
    pub blocks_rejected: u64,
}

/// Draws set-up triangles into a [`MaskedZBuffer`]; keeps its scratch between frames.
#[derive(Clone, Debug, Default)]
pub(crate) struct MaskedRasterizer {
    /// Per triangle, its rows `y0..y1`: what a group of bands reads to skip
    /// the triangles outside it.
    rows: Vec<(u16, u16)>,
    backend: RasterBackend,
}

impl MaskedRasterizer {
    /// An empty rasterizer using `backend`; every backend draws the same buffer.
    ///
    /// # Panics
    /// If the CPU does not support `backend`.
    pub fn with_backend(backend: RasterBackend) -> MaskedRasterizer {
        assert!(
            backend.is_supported(),
            "raster backend {backend:?} is not supported by this CPU"
        );
        MaskedRasterizer {
            rows: Vec::new(),
            backend,
        }
    }

    /// Draws `tris` (set up for `zb`'s viewport) into `zb`, which keeps what
    /// it holds, and builds its blocks. Uses the current rayon pool; the
    /// result does not depend on its size.
    ///
    /// Work is split into groups of bands of tile rows; each group walks the
    /// whole triangle list in order (streaming it, where a bin of indices per
    /// band would jump through memory) and draws what overlaps its bands.
    pub fn render(&mut self, tris: &[Tri], zb: &mut MaskedZBuffer) -> MaskedStats {
        let (tiles_x, tiles_y) = zb.tiles();
        let bands = tiles_y.div_ceil(BAND_TILES);
        // A few groups per thread, so stealing evens out unequal bands; but
        // every group walks every triangle and sets up again the ones that
        // cross into it, so many triangles get one group per thread.
        let per_thread = if tris.len() > MANY_TRIANGLES { 1 } else { 3 };
        let groups = (rayon::current_num_threads() as u32 * per_thread).clamp(1, bands);
        let group_bands = bands.div_ceil(groups);
        self.rows.clear();
        self.rows.extend(tris.iter().map(|t| (t.y0, t.y1)));
        let rows = &self.rows;
        let (tiles, outside, _) = zb.rows_mut();
        let group_tiles = (tiles_x * BAND_TILES * group_bands) as usize;
        let backend = self.backend;
        let stats = tiles
            .par_chunks_mut(group_tiles)
            .zip(outside.par_chunks(group_tiles))
            .enumerate()
            .map(|(g, (tiles, outside))| {
                let parts = GroupParts {
                    rows,
                    ty0: g as u32 * group_bands * BAND_TILES,
                    tiles_x,
                    tiles,
                    outside,
                };
                render_group(backend, tris, parts)
            })
            .reduce(MaskedStats::default, |a, b| MaskedStats {
                tiles_drawn: a.tiles_drawn + b.tiles_drawn,
                tiles_rejected: a.tiles_rejected + b.tiles_rejected,
                blocks_rejected: a.blocks_rejected + b.blocks_rejected,
            });
        zb.build_blocks();
        stats
    }
}

/// A group of bands to draw: the triangles' rows, the group's first tile
/// row, tiles across, and its tiles with their bits past the viewport's edge.
pub(crate) struct GroupParts<'a> {
    /// Per triangle, its rows `y0..y1`.
    pub rows: &'a [(u16, u16)],
    /// The group's first tile row.
    pub ty0: u32,
    /// Tiles across.
    pub tiles_x: u32,
    /// The group's tiles, row-major.
    pub tiles: &'a mut [MaskTile],
    /// Per tile, the bits of samples past the viewport's edge.
    pub outside: &'a [[u32; 8]],
}

/// The triangles of `tris` that overlap the group's tile rows, in order,
/// band by band, with kernels `k`.
#[inline(always)]
pub(crate) fn draw_group<K: RowKernel>(k: K, tris: &[Tri], parts: GroupParts) -> MaskedStats {
    let GroupParts {
        rows,
        ty0,
        tiles_x,
        tiles,
        outside,
    } = parts;
    let band_tiles = (tiles_x * BAND_TILES) as usize;
    let mut bands: Vec<Band> = tiles
        .chunks_mut(band_tiles)
        .zip(outside.chunks(band_tiles))
        .enumerate()
        .map(|(b, (tiles, outside))| Band::new(ty0 + b as u32 * BAND_TILES, tiles_x, tiles, outside))
        .collect();
    let band_px = i64::from(BAND_TILES * MASK_TILE_H);
    let y0 = i64::from(ty0 * MASK_TILE_H);
    let n = bands.len() as i64;
    let mut stats = MaskedStats::default();
    for (t, &(ya, yb)) in tris.iter().zip(rows) {
        let (a, b) = (
            (i64::from(ya) - y0).div_euclid(band_px),
            (i64::from(yb) - 1 - y0).div_euclid(band_px),
        );
        if b < 0 || a >= n {
            continue;
        }
        // The scan-line form and the row bounds down the triangle's rows
        // through the group's bands, made at the first band that is not skipped.
        let mut scan = None;
        for band in &mut bands[a.max(0) as usize..=b.min(n - 1) as usize] {
            band.draw(k, t, &mut scan, &mut stats);
        }
    }
    stats
}

/// Boxes at most this wide get their rows' coverage from the per-sample
/// edge test: for small triangles that costs less than the divisions of a
/// scan-line setup.
const MASKS_MAX_W: u32 = 8;

/// Triangles with fewer rows left than this step them one at a time: making
/// the lanes costs eight scalar steps.
const LANES_MIN_ROWS: u32 = 16;

/// A triangle's row bounds, as the masked raster steps them: eight rows at
/// a time in `i32` lanes where they fit, else a row at a time.
enum Bounds {
    Lanes(TileRows),
    Rows(Stepper),
}

/// Where a triangle's row coverage comes from, made at the first band that
/// is not skipped.
// One per triangle on the stack: boxing the large variant would allocate per triangle.
#[allow(clippy::large_enum_variant)]
enum Scan {
    /// A box of at most [`MASKS_MAX_W`] × [`MASKS_MAX_W`] samples: row masks
    /// from the per-sample edge test ([`row_masks`]), no division.
    Masks,
    /// Its scan-line form, and its bounds at some row (`None`: not made yet).
    Steps { edges: ScanEdges, bounds: Option<Bounds> },
}

impl Scan {
    /// `t`'s scan form (bounds are made at the first tile row drawn).
    fn new(t: &Tri) -> Scan {
        if u32::from(t.x1 - t.x0) <= MASKS_MAX_W && u32::from(t.y1 - t.y0) <= MASKS_MAX_W {
            Scan::Masks
        } else {
            Scan::Steps {
                edges: ScanEdges::new(t),
                bounds: None,
            }
        }
    }

    /// The rows `t` may cover, `rows.0..rows.1`.
    fn rows(&self, t: &Tri) -> (u32, u32) {
        match self {
            Scan::Masks => (u32::from(t.y0), u32::from(t.y1)),
            Scan::Steps { edges, .. } => edges.rows,
        }
    }

    /// The coverage of the tile row at `y` (rows `y + ja .. y + jb` of it),
    /// with the bounds moved to the next tile row.
    #[inline(always)]
    fn tile_row<K: RowKernel>(&mut self, k: K, t: &Tri, y: u32, ja: u32, jb: u32) -> TileRowCover {
        let (edges, bounds) = match self {
            Scan::Masks => {
                let mut masks = [0u64; 8];
                row_masks(K::BACKEND, t, y + ja, &mut masks[ja as usize..jb as usize]);
                // Covered columns are contiguous in every row, so in their union and intersection too.
                let range = |m: u64| {
                    if m == 0 {
                        (EMPTY, -EMPTY)
                    } else {
                        (m.trailing_zeros() as i32, 64 - m.leading_zeros() as i32)
                    }
                };
                return TileRowCover {
                    any: range(masks.iter().fold(0, |a, &m| a | m)),
                    all: range(masks.iter().fold(u64::MAX, |a, &m| a & m)),
                    rows: RowCover::Masks(masks),
                };
            }
            Scan::Steps { edges, bounds } => (edges, bounds),
        };
        let at = match bounds {
            None => false,
            Some(Bounds::Lanes(l)) => l.row == y,
            Some(Bounds::Rows(s)) => s.py == y + ja,
        };
        if !at {
            // The bands between were skipped (or this is the first).
            let (first, end) = edges.rows;
            let lanes = end - first.max(y) >= LANES_MIN_ROWS;
            *bounds = Some(match lanes.then(|| TileRows::new(t, edges, y, end)).flatten() {
                Some(l) => Bounds::Lanes(l),
                None => Bounds::Rows(Stepper::new(t, edges, y + ja)),
            });
        }
        let spans = match bounds.as_mut().expect("made above") {
            Bounds::Lanes(l) => k.next(l, ja, jb),
            Bounds::Rows(s) => {
                let mut spans = [(0u32, 0u32); 8];
                s.rows(&mut spans[ja as usize..jb as usize]);
                LaneSpans::from_spans(&spans, u32::from(t.x0))
            }
        };
        TileRowCover {
            any: spans.any,
            all: spans.all,
            rows: RowCover::Spans(spans),
        }
    }
}

/// A tile row's coverage by a triangle, in column offsets from its box's
/// first column: the columns some row covers (`any`, empty when
/// `any.0 >= any.1`), those every row covers (`all`), and each row's.
struct TileRowCover {
    any: (i32, i32),
    all: (i32, i32),
    rows: RowCover,
}

/// Each row's covered columns, as spans or as masks (bit `k`: offset `k`).
enum RowCover {
    Spans(LaneSpans),
    Masks([u64; 8]),
}

impl TileRowCover {
    /// Per row, the bits of columns `xt..xt + 32` (offsets) it covers.
    #[inline(always)]
    fn masks<K: RowKernel>(&self, k: K, xt: i32) -> [u32; 8] {
        match &self.rows {
            RowCover::Spans(s) => k.masks(s, xt),
            // The tile overlaps the box: -32 < xt < 64.
            RowCover::Masks(m) if xt >= 0 => m.map(|r| (r >> xt) as u32),
            RowCover::Masks(m) => m.map(|r| (r << -xt) as u32),
        }
    }
}

/// One band of tile rows being drawn: its tiles and, per block of tiles
/// across it, the farthest reference depth.
struct Band<'a> {
    /// First tile row.
    ty0: u32,
    /// Tiles across.
    tiles_x: u32,
    /// The band's tiles, row-major.
    tiles: &'a mut [MaskTile],
    /// Per tile, the bits of samples outside the viewport.
    outside: &'a [[u32; 8]],
    /// Per block, the farthest `z0` of its tiles, or at least it (a block
    /// whose farthest tile fell is only marked `stale`).
    blocks: Vec<f32>,
    /// Per block, whether `blocks` is to be recomputed before it is used:
    /// once per triangle at most, not once per tile that falls.
    stale: Vec<bool>,
}

impl<'a> Band<'a> {
    fn new(ty0: u32, tiles_x: u32, tiles: &'a mut [MaskTile], outside: &'a [[u32; 8]]) -> Band<'a> {
        let n = tiles_x.div_ceil(BLOCK_TILES) as usize;
        Band {
            ty0,
            tiles_x,
            tiles,
            outside,
            blocks: vec![f32::INFINITY; n],
            stale: vec![true; n],
        }
    }

    /// The farthest reference depth of block `b`'s tiles.
    fn block_max(&self, b: u32) -> f32 {
        let rows = self.tiles.len() as u32 / self.tiles_x;
        let (x0, x1) = (b * BLOCK_TILES, ((b + 1) * BLOCK_TILES).min(self.tiles_x));
        (0..rows)
            .flat_map(|ty| (x0..x1).map(move |tx| (ty * self.tiles_x + tx) as usize))
            .fold(f32::NEG_INFINITY, |m, k| m.max(self.tiles[k].far()))
    }

    /// Draws the part of `t` in the band with kernels `k`. `scan` is its
    /// [`ScanEdges`] and bounds, made here when first needed (a triangle
    /// hidden in every band it reaches needs neither: no division).
    #[inline(always)]
    fn draw<K: RowKernel>(&mut self, k: K, t: &Tri, scan: &mut Option<Scan>, stats: &mut MaskedStats) {
        let tiles_x = self.tiles_x;
        let band_rows = self.tiles.len() as u32 / tiles_x;
        let (band_y0, band_y1) = (self.ty0 * MASK_TILE_H, (self.ty0 + band_rows) * MASK_TILE_H);
        let (ya, yb) = (u32::from(t.y0).max(band_y0), u32::from(t.y1).min(band_y1));
        if ya >= yb {
            return;
        }
        // Nothing to do where the triangle lies behind every tile's reference depth.
        let (xa, xb) = (u32::from(t.x0), u32::from(t.x1) - 1);
        let nearest = t.depth_bounds(xa, xb, ya, yb - 1).0;
        let (ba, bb) = (xa / MASK_TILE_W / BLOCK_TILES, xb / MASK_TILE_W / BLOCK_TILES);
        for b in ba..=bb {
            if self.stale[b as usize] {
                self.blocks[b as usize] = self.block_max(b);
                self.stale[b as usize] = false;
            }
        }
        if (ba..=bb).all(|b| nearest >= self.blocks[b as usize]) {
            stats.blocks_rejected += 1;
            return;
        }
        let scan = scan.get_or_insert_with(|| Scan::new(t));
        let rows = scan.rows(t);
        let (ya, yb) = (ya.max(rows.0), yb.min(rows.1));
        if ya >= yb {
            return;
        }
        let x0 = u32::from(t.x0);
        for ty in (ya - band_y0) / MASK_TILE_H..=(yb - 1 - band_y0) / MASK_TILE_H {
            let y_tile0 = band_y0 + ty * MASK_TILE_H;
            let (ra, rb) = (ya.max(y_tile0), yb.min(y_tile0 + MASK_TILE_H));
            let cover = scan.tile_row(k, t, y_tile0, ra - y_tile0, rb - y_tile0);
            if cover.any.0 >= cover.any.1 {
                continue;
            }
            let (lo, hi) = ((x0 as i32 + cover.any.0) as u32, (x0 as i32 + cover.any.1) as u32);
            // Columns every row of the tile row covers: the tiles wholly
            // inside take the fast path (no masks to build).
            let (full_lo, full_hi) = (x0 as i32 + cover.all.0, x0 as i32 + cover.all.1);
            let rb = rb - 1;
            // Never farther than any subtile's far depth below (`far_depth_grid`
            // over parts of these rows and columns): a tile whose every reference
            // depth is nearer than it learns nothing, as `nearer` would find.
            let nearest = t.depth_bounds(lo, hi - 1, ra, rb).0;
            for tx in lo / MASK_TILE_W..=(hi - 1) / MASK_TILE_W {
                let x_tile0 = tx * MASK_TILE_W;
                let k_tile = (ty * tiles_x + tx) as usize;
                stats.tiles_drawn += 1;
                if nearest >= self.tiles[k_tile].far() {
                    stats.tiles_rejected += 1;
                    continue;
                }
                // The covered part of this tile lies in these columns and rows.
                let (ca, cb) = (lo.max(x_tile0), hi.min(x_tile0 + MASK_TILE_W) - 1);
                // Per subtile, its part of that (an empty part: any cell, unused).
                let part = |a: u32, b: u32, lo: u32, hi: u32| {
                    if a.max(lo) <= b.min(hi) {
                        (a.max(lo), b.min(hi))
                    } else {
                        (a, a)
                    }
                };
                let cols: [(u32, u32); 4] = std::array::from_fn(|sx| {
                    let c0 = x_tile0 + sx as u32 * SUB_W;
                    part(ca, cb, c0, c0 + SUB_W - 1)
                });
                let subrows: [(u32, u32); 2] = std::array::from_fn(|sy| {
                    let r0 = y_tile0 + sy as u32 * SUB_H;
                    part(ra, rb, r0, r0 + SUB_H - 1)
                });
                let zt = t.far_depth_grid(&cols, &subrows);
                let tile = &mut self.tiles[k_tile];
                if !k.nearer(tile, &zt) {
                    stats.tiles_rejected += 1;
                    continue;
                }
                let far = tile.far();
                let told = if full_lo <= x_tile0 as i32 && x_tile0 as i32 + MASK_TILE_W as i32 <= full_hi {
                    k.insert_full(tile, &zt, &self.outside[k_tile])
                } else {
                    let m = cover.masks(k, x_tile0 as i32 - x0 as i32);
                    k.insert(tile, &m, &zt, &self.outside[k_tile])
                };
                if !told {
                    stats.tiles_rejected += 1;
                } else if self.tiles[k_tile].far() < far {
                    // A reference depth only falls: the block's falls if this tile held it.
                    let b = (tx / BLOCK_TILES) as usize;
                    if far == self.blocks[b] {
                        self.stale[b] = true;
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::queue::TriangleQueue;
    use crate::raster::scanline::tests::soup;
    use crate::raster::setup::{FaceCull, Viewport};
    use glam::Vec4;
    use hom_testkit::Rng;
    use proptest::prelude::*;

    proptest! {
        /// The masked buffer never bounds a sample nearer than the nearest
        /// triangle covering it (the renderer's depth there), and its
        /// rectangle test never hides a sample the triangles leave visible.
        #[test]
        fn the_masked_buffer_is_conservative(seed in any::<u64>(), n in 1usize..150, w in 1u32..200, h in 1u32..120) {
            let tris = soup(seed, n, w, h, false);
            let mut zb = MaskedZBuffer::default();
            zb.clear(w, h);
            MaskedRasterizer::default().render(&tris, &mut zb);
            let mut truth = vec![f32::INFINITY; (w * h) as usize];
            for t in &tris {
                for y in u32::from(t.y0)..u32::from(t.y1) {
                    for x in u32::from(t.x0)..u32::from(t.x1) {
                        if t.covers(x, y) {
                            let s = &mut truth[(y * w + x) as usize];
                            *s = s.min(t.depth_at(x, y));
                        }
                    }
                }
            }
            for y in 0..h {
                for x in 0..w {
                    let (b, t) = (zb.bound(x, y), truth[(y * w + x) as usize]);
                    prop_assert!(b >= t, "sample {},{}: bound {} nearer than the depth {}", x, y, b, t);
                }
            }
            let mut rng = Rng::new(!seed);
            for _ in 0..200 {
                let (x0, y0) = (rng.below(u64::from(w)) as u32, rng.below(u64::from(h)) as u32);
                let r = crate::geom::ScreenRect {
                    x0,
                    y0,
                    x1: (x0 + 1 + rng.below(64) as u32).min(w),
                    y1: (y0 + 1 + rng.below(24) as u32).min(h),
                    z_near: rng.range(0.0, 1.1),
                    z_far: 1.0,
                };
                if zb.is_behind(&r) {
                    for y in r.y0..r.y1 {
                        for x in r.x0..r.x1 {
                            prop_assert!(r.z_near > truth[(y * w + x) as usize], "{:?} behind at {},{}", r, x, y);
                        }
                    }
                }
            }
        }
    }

    proptest! {
        /// One triangle at a time, each span path (row masks, lanes, rows)
        /// covers exactly the samples the triangle covers, with every backend.
        #[test]
        fn one_triangle_covers_exactly_its_samples(seed in any::<u64>(), w in 1u32..300, h in 1u32..150, inner in any::<bool>()) {
            let mut bits = Vec::new();
            let wpr = (w as usize).div_ceil(64);
            for t in soup(seed, 12, w, h, inner) {
                for backend in RasterBackend::supported() {
                    let mut zb = MaskedZBuffer::default();
                    zb.clear(w, h);
                    MaskedRasterizer::with_backend(backend).render(std::slice::from_ref(&t), &mut zb);
                    zb.coverage_bits(&mut bits);
                    for y in 0..h {
                        for x in 0..w {
                            let got = bits[y as usize * wpr + x as usize / 64] >> (x % 64) & 1 == 1;
                            prop_assert_eq!(got, t.covers(x, y), "{:?} sample {},{} of {:?}", backend, x, y, t);
                        }
                    }
                }
            }
        }

        /// Every backend draws the same buffer, bit for bit.
        #[test]
        fn backends_draw_the_same_buffer(seed in any::<u64>(), n in 1usize..300, w in 1u32..300, h in 1u32..150) {
            let tris = soup(seed, n, w, h, false);
            let draw = |backend| {
                let mut zb = MaskedZBuffer::default();
                zb.clear(w, h);
                let stats = MaskedRasterizer::with_backend(backend).render(&tris, &mut zb);
                let bounds: Vec<u32> = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).map(|(x, y)| zb.bound(x, y).to_bits()).collect();
                (bounds, stats)
            };
            let want = draw(RasterBackend::Scalar);
            for backend in RasterBackend::supported() {
                prop_assert!(draw(backend) == want, "{:?} differs from scalar", backend);
            }
        }
    }

    #[test]
    fn slivers_too_steep_for_lanes_step_row_by_row() {
        // Nearly horizontal edges across a wide box: their column bounds
        // leave i32 over the rows, so the lanes refuse them and the
        // row-at-a-time stepper draws them, exactly.
        let (w, h) = (120u32, 60u32);
        let at = |sx: f32, sy: f32| Vec4::new(sx / w as f32 * 2.0 - 1.0, 1.0 - sy / h as f32 * 2.0, 0.5, 1.0);
        let mut refused = 0;
        for k in 0..8 {
            let y = 5.0 + k as f32 * 0.37;
            let v = [at(-3.0e5, y), at(3.0e5, y + 1.0 / 256.0), at(60.0 + k as f32, 55.0)];
            let mut q = TriangleQueue::default();
            q.push_clip(&v, &[[0, 1, 2]], |v| v, FaceCull::None).unwrap();
            let mut tris = Vec::new();
            q.set_up(&Viewport::new(w, h), false, &mut tris);
            for t in &tris {
                let edges = ScanEdges::new(t);
                refused += usize::from(TileRows::new(t, &edges, edges.rows.0 / 8 * 8, edges.rows.1).is_none());
                let mut zb = MaskedZBuffer::default();
                zb.clear(w, h);
                MaskedRasterizer::default().render(std::slice::from_ref(t), &mut zb);
                let mut bits = Vec::new();
                zb.coverage_bits(&mut bits);
                for y in 0..h {
                    for x in 0..w {
                        let got = bits[y as usize * 2 + x as usize / 64] >> (x % 64) & 1 == 1;
                        assert_eq!(got, t.covers(x, y), "sample {x},{y} of {t:?}");
                    }
                }
            }
        }
        assert!(refused > 0, "no sliver was refused by the lanes");
    }

    #[test]
    fn a_near_wall_hides_and_rejects_what_is_behind() {
        // Two screen-filling quads, the nearer drawn first: the farther one is
        // rejected everywhere, and rectangles between them are hidden.
        let quad = |z: f32| {
            let p = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
            p.map(|(x, y)| Vec4::new(x, y, z, 1.0))
        };
        let (near, far) = (quad(0.3), quad(0.7));
        let mut q = TriangleQueue::default();
        let idx = [[0, 1, 2], [0, 2, 3]];
        q.push_clip(&near, &idx, |v| v, FaceCull::None).unwrap();
        q.push_clip(&far, &idx, |v| v, FaceCull::None).unwrap();
        let mut tris = Vec::new();
        q.set_up(&Viewport::new(100, 40), false, &mut tris);
        let mut zb = MaskedZBuffer::default();
        zb.clear(100, 40);
        let stats = MaskedRasterizer::default().render(&tris, &mut zb);
        // The far quad's two triangles are skipped whole in both bands.
        assert_eq!(stats.blocks_rejected, 4, "{stats:?}");
        let rect = |z: f32| crate::geom::ScreenRect {
            x0: 3,
            y0: 5,
            x1: 97,
            y1: 33,
            z_near: z,
            z_far: z,
        };
        assert!(zb.is_behind(&rect(0.5)));
        assert!(!zb.is_behind(&rect(0.2)));
        for y in 0..40 {
            for x in 0..100 {
                assert!(zb.bound(x, y) < 0.31, "sample {x},{y}: {}", zb.bound(x, y));
            }
        }
    }

    #[test]
    fn thread_count_does_not_change_the_result() {
        // Fewer and more than MANY_TRIANGLES: three groups per thread, and one.
        for n in [3000, MANY_TRIANGLES + 1000] {
            thread_count_does_not_change(soup(99, n, 333, 257, false));
        }
    }

    fn thread_count_does_not_change(tris: Vec<Tri>) {
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| {
                let mut zb = MaskedZBuffer::default();
                zb.clear(333, 257);
                let stats = MaskedRasterizer::default().render(&tris, &mut zb);
                let bounds: Vec<u32> = (0..257)
                    .flat_map(|y| (0..333).map(move |x| (x, y)))
                    .map(|(x, y)| zb.bound(x, y).to_bits())
                    .collect();
                (bounds, stats)
            })
        };
        assert!(run(1) == run(3));
    }
}
