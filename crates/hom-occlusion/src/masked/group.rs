//! One group of tile-row bands drawn by the masked rasterizer: the
//! semantics every backend shares, generic over the per-row kernels
//! ([`RowKernel`]; [`Scalar`] defines them, `simd.rs` has the vector ones).
//! Per band and triangle: the tile rows the triangle reaches, each row's
//! spans stepped exactly ([`TileRows`], or [`Stepper`] when few rows are
//! left, or the per-sample edge test for small boxes), turned into 32-column
//! masks and inserted into the tiles with the triangle's subtile depths
//! (Hasselgren, Andersson and Akenine-Möller 2016, section 3).

use crate::masked::zbuffer::{MaskTile, MASK_TILE_H, MASK_TILE_W, SUBTILES, SUB_H, SUB_W};
use crate::raster::scanline::{LaneSpans, ScanEdges, Stepper, TileRows, EMPTY, LANES};
use crate::raster::setup::Tri;
use crate::raster::simd::{row_masks, RasterBackend};

/// Tile rows per band (each band is filled by one thread).
pub(super) const BAND_TILES: u32 = 4;

/// Tiles per block (across): a triangle whose nearest depth lies beyond
/// every tile's reference depth in a block skips the block.
const BLOCK_TILES: u32 = 8;

/// What the masked rasterizer asks of a backend, per tile row.
pub(crate) trait RowKernel: Copy {
    /// The backend of [`crate::raster::simd::row_masks`] for narrow boxes.
    const BACKEND: RasterBackend;
    /// [`TileRows::next_scalar`].
    fn next(self, rows: &mut TileRows, ja: u32, jb: u32) -> LaneSpans;
    /// [`LaneSpans::masks`].
    fn masks(self, spans: &LaneSpans, xt: i32) -> [u32; LANES];
    /// Whether some `zt[k]` lies nearer than the tile's `z0[k]` (else the
    /// triangle tells the tile nothing).
    fn nearer(self, tile: &MaskTile, zt: &[f32; SUBTILES]) -> bool;
    /// [`MaskTile::insert`].
    fn insert(self, tile: &mut MaskTile, m: &[u32; 8], zt: &[f32; SUBTILES], outside: &[u32; 8]) -> bool;
    /// [`MaskTile::insert_full`].
    fn insert_full(self, tile: &mut MaskTile, zt: &[f32; SUBTILES], outside: &[u32; 8]) -> bool;
}

/// The scalar kernels: the semantics.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Scalar;

impl RowKernel for Scalar {
    const BACKEND: RasterBackend = RasterBackend::Scalar;

    #[inline(always)]
    fn next(self, rows: &mut TileRows, ja: u32, jb: u32) -> LaneSpans {
        rows.next_scalar(ja, jb)
    }

    #[inline(always)]
    fn masks(self, spans: &LaneSpans, xt: i32) -> [u32; LANES] {
        spans.masks(xt)
    }

    #[inline(always)]
    fn nearer(self, tile: &MaskTile, zt: &[f32; SUBTILES]) -> bool {
        zt.iter().zip(&tile.z0).any(|(z, z0)| z < z0)
    }

    #[inline(always)]
    fn insert(self, tile: &mut MaskTile, m: &[u32; 8], zt: &[f32; SUBTILES], outside: &[u32; 8]) -> bool {
        tile.insert(m, zt, outside)
    }

    #[inline(always)]
    fn insert_full(self, tile: &mut MaskTile, zt: &[f32; SUBTILES], outside: &[u32; 8]) -> bool {
        tile.insert_full(zt, outside)
    }
}

/// Work done by [`super::raster::MaskedRasterizer::render`].
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
