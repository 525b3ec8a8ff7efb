//! One group of tile rows drawn by the masked rasterizer: the semantics
//! every backend shares, generic over the per-row kernels ([`RowKernel`];
//! [`Scalar`] defines them, `simd.rs` has the vector ones). Per triangle,
//! the tile rows it reaches in the group, each row's spans exact
//! ([`RowBounds`]: straight from the edge functions in `f64`, no division
//! per triangle; [`TileRows`] or [`Stepper`] for the rare triangle `f64`
//! cannot hold), turned into 32-column masks and inserted into the tiles
//! with the triangle's subtile depths (Hasselgren, Andersson and
//! Akenine-Möller 2016, section 3). A tile row whose tiles all lie nearer
//! than the triangle there is skipped before its spans are made.

use crate::masked::zbuffer::{MaskTile, MASK_TILE_H, MASK_TILE_W, SUBTILES, SUB_H, SUB_W};
use crate::raster::scanline::{row_limits, LaneSpans, RowBounds, ScanEdges, Stepper, TileRows, LANES};
use crate::raster::setup::Tri;

/// Tile rows per band: groups of tile rows are made of whole bands.
pub(super) const BAND_TILES: u32 = 4;

/// Tiles per block across a tile row (see `Group::block_far`).
const BLOCK_TILES: u32 = 8;

/// The largest of a block's eight depths (no `NaN` among them), by
/// halving, in the form vector max instructions take.
#[inline(always)]
fn max_of(v: &[f32; 8]) -> f32 {
    let max = |a: f32, b: f32| if a > b { a } else { b };
    let h: [f32; 4] = std::array::from_fn(|i| max(v[i], v[i + 4]));
    max(max(h[0], h[2]), max(h[1], h[3]))
}

/// Whether every depth of `far` lies at or beyond `z`: eight at a time
/// without a branch each, so it vectorizes.
#[inline(always)]
fn all_at_or_beyond(far: &[f32], z: f32) -> bool {
    let mut eights = far.chunks_exact(8);
    for c in &mut eights {
        if !c.iter().fold(true, |all, &f| all & (z >= f)) {
            return false;
        }
    }
    eights.remainder().iter().all(|&f| z >= f)
}

/// `Tri::depth_bounds`' nearest over the box's part of a tile row's rows
/// `ra..rb`, made from the row term, the box's column term and the whole
/// box's slack (at least each row's, so never farther).
struct RowNearest {
    /// The column term's nearest over the box.
    near_x: f32,
    /// The box's slack.
    box_slack: f32,
}

impl RowNearest {
    #[inline(always)]
    fn new(t: &Tri) -> RowNearest {
        let (x0, x1) = (u32::from(t.x0), u32::from(t.x1));
        RowNearest {
            near_x: (t.dzdx * 0.0).min(t.dzdx * (x1 - 1 - x0) as f32),
            box_slack: t.depth_slack(x1 - 1, u32::from(t.y1) - 1),
        }
    }

    /// The nearest over rows `ra..rb` (`ra < rb`).
    #[inline(always)]
    fn at(&self, t: &Tri, ra: u32, rb: u32) -> f32 {
        let near_y = if t.dzdy > 0.0 { ra } else { rb - 1 };
        (t.zref + self.near_x + t.dzdy * (near_y - u32::from(t.y0)) as f32 - self.box_slack).max(0.0)
    }
}

/// What the masked rasterizer asks of a backend, per tile row.
pub(crate) trait RowKernel: Copy {
    /// [`TileRows::next_scalar`].
    fn next(self, rows: &mut TileRows, ja: u32, jb: u32) -> LaneSpans;
    /// [`RowBounds::next_scalar`].
    fn next_direct(self, rows: &mut RowBounds, ja: u32, jb: u32) -> LaneSpans;
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
    #[inline(always)]
    fn next(self, rows: &mut TileRows, ja: u32, jb: u32) -> LaneSpans {
        rows.next_scalar(ja, jb)
    }

    #[inline(always)]
    fn next_direct(self, rows: &mut RowBounds, ja: u32, jb: u32) -> LaneSpans {
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
    /// Triangle and tile-row pairs skipped whole, before any coverage,
    /// because the triangle lies behind every tile of its box there.
    pub rows_rejected: u64,
}

/// One chunk of the queue set up.
#[derive(Clone, Debug, Default)]
pub(crate) struct SetUp {
    /// The triangles.
    pub tris: Vec<Tri>,
    /// Per triangle, its rows `y0..y1`: what a group of tile rows reads to
    /// skip the triangles outside it without touching them.
    pub rows: Vec<(u16, u16)>,
}

impl SetUp {
    /// Fills `rows` from `tris`.
    pub(crate) fn index_rows(&mut self) {
        self.rows.clear();
        self.rows.extend(self.tris.iter().map(|t| (t.y0, t.y1)));
    }
}

/// A group of bands to draw: the group's first tile row, tiles across, and
/// its tiles with their bits past the viewport's edge.
pub(crate) struct GroupParts<'a> {
    /// The group's first tile row.
    pub ty0: u32,
    /// Tiles across.
    pub tiles_x: u32,
    /// The group's tiles, row-major.
    pub tiles: &'a mut [MaskTile],
    /// Per tile, the bits of samples past the viewport's edge.
    pub outside: &'a [[u32; 8]],
}

/// The triangles of `chunks` that overlap the group's tile rows, in order,
/// with kernels `k`.
#[inline(always)]
pub(crate) fn draw_group<K: RowKernel>(k: K, chunks: &[SetUp], parts: GroupParts) -> MaskedStats {
    let GroupParts {
        ty0,
        tiles_x,
        tiles,
        outside,
    } = parts;
    let tiles_y = tiles.len() as u32 / tiles_x.max(1);
    let (gy0, gy1) = (ty0 * MASK_TILE_H, (ty0 + tiles_y) * MASK_TILE_H);
    let mut stats = MaskedStats::default();
    let blocks_x = tiles_x.div_ceil(BLOCK_TILES) as usize;
    // Each tile row's far depths padded to whole blocks (with `-inf`, which
    // never holds a block's farthest up).
    let stride = blocks_x * BLOCK_TILES as usize;
    let mut far = vec![f32::NEG_INFINITY; stride * tiles_y as usize];
    for (row, tiles) in far.chunks_mut(stride).zip(tiles.chunks(tiles_x.max(1) as usize)) {
        row.iter_mut().zip(tiles).for_each(|(f, t)| *f = t.far());
    }
    let block_far: Vec<f32> = far
        .chunks_exact(BLOCK_TILES as usize)
        .map(|b| max_of(b.try_into().expect("a block's eight")))
        .collect();

    let mut group = Group {
        ty0,
        tiles_x,
        tiles,
        outside,
        far,
        blocks_x,
        block_far,
    };
    // The triangles in the group's rows found first, in a tight loop over
    // their rows alone: with a few groups per thread most triangles lie in
    // another group, and the drawing loop is costly to enter.
    let mut mine = Vec::new();
    for c in chunks {
        mine.clear();
        mine.extend((0..c.rows.len() as u32).filter(|&i| {
            let (ya, yb) = c.rows[i as usize];
            u32::from(yb) > gy0 && u32::from(ya) < gy1
        }));
        for &i in &mine {
            group.draw(k, &c.tris[i as usize], (gy0, gy1), &mut stats);
        }
    }
    stats
}

/// Where a triangle's row spans come from, a tile row at a time.
trait RowSource<K: RowKernel> {
    /// The spans of the next tile row's rows `ja..jb` (the others empty),
    /// then the source moved down a tile row.
    fn next(&mut self, k: K, ja: u32, jb: u32) -> LaneSpans;
    /// Moves the source down a tile row without making its spans.
    fn skip(&mut self, k: K) {
        self.next(k, 0, 0);
    }
}

impl<K: RowKernel> RowSource<K> for RowBounds {
    #[inline(always)]
    fn next(&mut self, k: K, ja: u32, jb: u32) -> LaneSpans {
        k.next_direct(self, ja, jb)
    }

    #[inline(always)]
    fn skip(&mut self, _: K) {
        self.skip_tile_row();
    }
}

/// The exact `i64` forms, for the triangles [`RowBounds`] cannot hold:
/// eight rows at a time in `i32` lanes where they fit, else a row at a time.
enum Stepped {
    Lanes(TileRows),
    Rows(Stepper, u32),
}

impl Stepped {
    /// `t`'s bounds at the tile row from `y`, to be moved down to `end`.
    #[cold]
    fn new(t: &Tri, y: u32, end: u32) -> Stepped {
        let edges = ScanEdges::new(t);
        match TileRows::new(t, &edges, y, end) {
            Some(l) => Stepped::Lanes(l),
            None => Stepped::Rows(Stepper::new(t, &edges, y), u32::from(t.x0)),
        }
    }
}

impl<K: RowKernel> RowSource<K> for Stepped {
    #[inline(always)]
    fn next(&mut self, k: K, ja: u32, jb: u32) -> LaneSpans {
        match self {
            Stepped::Lanes(l) => k.next(l, ja, jb),
            Stepped::Rows(s, x0) => {
                let mut spans = [(0u32, 0u32); LANES];
                s.rows(&mut spans);
                for (j, span) in spans.iter_mut().enumerate() {
                    if !(ja..jb).contains(&(j as u32)) {
                        *span = (0, 0);
                    }
                }
                LaneSpans::from_spans(&spans, *x0)
            }
        }
    }
}

/// The tiles of a group of tile rows being drawn.
struct Group<'a> {
    /// First tile row.
    ty0: u32,
    /// Tiles across.
    tiles_x: u32,
    /// The group's tiles, row-major.
    tiles: &'a mut [MaskTile],
    /// Per tile, the bits of samples outside the viewport.
    outside: &'a [[u32; 8]],
    /// Per tile, its farthest reference depth ([`MaskTile::far`]), each tile
    /// row padded to whole blocks (`-inf`), side by
    /// side: a tile row's tiles in one or two cache lines for the test that
    /// skips it (the tiles' own lie 100 bytes apart: `large_100k` at 1080p,
    /// 25.4–26.0 against 27.8–29.3 ms, three alternating runs, 2026-12-06).
    far: Vec<f32>,
    /// Blocks per tile row.
    blocks_x: usize,
    /// Per block of [`BLOCK_TILES`] tiles of a tile row, the farthest of
    /// their `far`: a triangle behind every block of its box is skipped
    /// whole, before any tile row is looked at. Made again once per tile row
    /// where a triangle told some tile something (once per tile that fell
    /// cost 9 % of the group loop's instructions on oa_dm5's walk).
    block_far: Vec<f32>,
}

impl Group<'_> {
    /// Draws the part of `t` in rows `gy.0..gy.1` (the group's) with kernels `k`.
    #[inline(always)]
    fn draw<K: RowKernel>(&mut self, k: K, t: &Tri, gy: (u32, u32), stats: &mut MaskedStats) {
        let rows = row_limits(t);
        let (ya, yb) = (rows.0.max(gy.0), rows.1.min(gy.1));
        if ya >= yb {
            return;
        }
        let near = RowNearest::new(t);
        // Behind every block of its box (on `large_100k`, most triangles):
        // skipped whole, a compare per block of eight tiles and tile row.
        let (first, last) = (ya / MASK_TILE_H, (yb - 1) / MASK_TILE_H);
        let nearest = near.at(t, ya, yb);
        let (bx0, bx1) = (
            (u32::from(t.x0) / MASK_TILE_W / BLOCK_TILES) as usize,
            ((u32::from(t.x1) - 1) / MASK_TILE_W / BLOCK_TILES) as usize,
        );
        if (first..=last).all(|ty| {
            let row = (ty - self.ty0) as usize * self.blocks_x;
            self.block_far[row + bx0..=row + bx1].iter().all(|&far| nearest >= far)
        }) {
            stats.rows_rejected += u64::from(last - first + 1);
            return;
        }
        // Then the tile rows it lies behind, by its nearest in each, up to the
        // first it may tell something: its spans are set up from there.
        let mut ty = first;
        while self.row_behind(
            t,
            ty,
            near.at(t, ya.max(ty * MASK_TILE_H), yb.min((ty + 1) * MASK_TILE_H)),
        ) {
            stats.rows_rejected += 1;
            if ty == last {
                return;
            }
            ty += 1;
        }
        let ya = ya.max(ty * MASK_TILE_H);
        match RowBounds::new(t, ty * MASK_TILE_H, yb) {
            Some(b) => self.draw_rows(k, t, &near, b, (ya, yb), stats),
            None => self.draw_rows(k, t, &near, Stepped::new(t, ty * MASK_TILE_H, yb), (ya, yb), stats),
        }
    }

    /// Makes again the farthest of the blocks holding tiles `txa..=txb` of tile row `ty`.
    #[inline(always)]
    fn refresh_blocks(&mut self, ty: u32, txa: u32, txb: u32) {
        let row = (ty - self.ty0) as usize * self.blocks_x;
        for b in row + (txa / BLOCK_TILES) as usize..=row + (txb / BLOCK_TILES) as usize {
            let far = &self.far[b * BLOCK_TILES as usize..][..BLOCK_TILES as usize];
            self.block_far[b] = max_of(far.try_into().expect("a block's eight"));
        }
    }

    /// Whether every tile of `t`'s box in tile row `ty` lies nearer than
    /// `nearest` (`t`'s nearest there): then it tells them nothing.
    #[inline(always)]
    fn row_behind(&self, t: &Tri, ty: u32, nearest: f32) -> bool {
        let row = (ty - self.ty0) as usize * self.blocks_x * BLOCK_TILES as usize;
        let (xa, xb) = (u32::from(t.x0) / MASK_TILE_W, (u32::from(t.x1) - 1) / MASK_TILE_W);
        all_at_or_beyond(&self.far[row + xa as usize..=row + xb as usize], nearest)
    }

    /// Draws `t`'s rows `ya..yb`, their spans from `src` (at `ya`'s tile row).
    #[inline(always)]
    fn draw_rows<K: RowKernel>(
        &mut self,
        k: K,
        t: &Tri,
        near: &RowNearest,
        mut src: impl RowSource<K>,
        (ya, yb): (u32, u32),
        stats: &mut MaskedStats,
    ) {
        let (x0, y0) = (u32::from(t.x0), u32::from(t.y0));
        let box_slack = near.box_slack;
        for ty in ya / MASK_TILE_H..=(yb - 1) / MASK_TILE_H {
            let y_tile0 = ty * MASK_TILE_H;
            let (ra, rb) = (ya.max(y_tile0), yb.min(y_tile0 + MASK_TILE_H));
            let row = ((ty - self.ty0) * self.tiles_x) as usize;
            let far_row = (ty - self.ty0) as usize * self.blocks_x * BLOCK_TILES as usize;
            // Behind every tile of the box's part of the row: skipped before any span is made.
            let nearest = near.at(t, ra, rb);
            if y_tile0 > ya && self.row_behind(t, ty, nearest) {
                stats.rows_rejected += 1;
                src.skip(k);
                continue;
            }
            let spans = src.next(k, ra - y_tile0, rb - y_tile0);
            if spans.any.0 >= spans.any.1 {
                continue;
            }
            let (lo, hi) = ((x0 as i32 + spans.any.0) as u32, (x0 as i32 + spans.any.1) as u32);
            // Columns every row of the tile row covers: the tiles wholly
            // inside take the fast path (no masks to build).
            let (full_lo, full_hi) = (x0 as i32 + spans.all.0, x0 as i32 + spans.all.1);
            let rb = rb - 1;
            // Per subtile, the plane's farthest over its part of the covered
            // rectangle `lo..hi` × `ra..=rb`: at the far corner, clamped into it
            // (a linear function, and rounding is monotone: the farthest of
            // `Tri::depth_bounds` there), with the box's slack (at least the
            // rectangle's). The row's `nearest` above is never farther.
            let (cx, cy) = (u32::from(t.dzdx > 0.0), u32::from(t.dzdy > 0.0));
            let fy: [f32; 2] = std::array::from_fn(|sy| {
                let corner = y_tile0 + sy as u32 * SUB_H + cy * (SUB_H - 1);
                t.dzdy * (corner.clamp(ra, rb) - y0) as f32
            });
            // Per subtile lane, the row's terms, and its far column from a
            // tile's first, clamped to the covered columns (offsets from the box's).
            let z_row: [f32; SUBTILES] = std::array::from_fn(|s| t.zref + fy[s / 4] + box_slack);
            let corner: [i32; SUBTILES] = std::array::from_fn(|s| ((s % 4) as u32 * SUB_W + cx * (SUB_W - 1)) as i32);
            let (first, last) = (spans.any.0, spans.any.1 - 1);
            let mut row_told = false;
            for tx in lo / MASK_TILE_W..=(hi - 1) / MASK_TILE_W {
                let x_tile0 = tx * MASK_TILE_W;
                let k_tile = row + tx as usize;
                stats.tiles_drawn += 1;
                // Never farther than any subtile's far depth below: a tile
                // whose every reference depth is nearer than it learns nothing.
                let k_far = far_row + tx as usize;
                if nearest >= self.far[k_far] {
                    stats.tiles_rejected += 1;
                    continue;
                }
                let xt = x_tile0 as i32 - x0 as i32;
                let zt: [f32; SUBTILES] = std::array::from_fn(|s| {
                    let z = z_row[s] + t.dzdx * (xt + corner[s]).clamp(first, last) as f32;
                    // `z.max(0.0)` in the form vector max instructions take.
                    if z > 0.0 {
                        z
                    } else {
                        0.0
                    }
                });
                let tile = &mut self.tiles[k_tile];
                if !k.nearer(tile, &zt) {
                    stats.tiles_rejected += 1;
                    continue;
                }
                let told = if full_lo <= x_tile0 as i32 && x_tile0 as i32 + MASK_TILE_W as i32 <= full_hi {
                    k.insert_full(tile, &zt, &self.outside[k_tile])
                } else {
                    let m = k.masks(&spans, x_tile0 as i32 - x0 as i32);
                    k.insert(tile, &m, &zt, &self.outside[k_tile])
                };
                if told {
                    self.far[k_far] = self.tiles[k_tile].far();
                    row_told = true;
                } else {
                    stats.tiles_rejected += 1;
                }
            }
            if row_told {
                self.refresh_blocks(ty, lo / MASK_TILE_W, (hi - 1) / MASK_TILE_W);
            }
        }
    }
}
