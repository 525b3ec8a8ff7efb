//! The masked rasterizer (after Hasselgren, Andersson and Akenine-Möller,
//! "Masked Software Occlusion Culling", HPG 2016): set-up triangles into a
//! [`MaskedZBuffer`] as coverage masks of 32×8-sample tiles with one
//! conservative depth per triangle and tile.
//!
//! Coverage comes from edge events per scan line, not per-sample edge
//! functions: for each row, each edge's first (or last) covered column is
//! stepped exactly from the row before — a quotient and a remainder, no
//! division after the first row of a band — so a row's span is exactly the
//! one [`Tri::row_span`] computes (the renderer's coverage, or the inner
//! rule's when the triangle was set up with it). A tile row's mask is then
//! two shifts of its span.
//!
//! Depth: per triangle and tile, the farthest value of the triangle's plane
//! over the part of its box in the tile, plus rounding slack, so at least
//! the depth the renderer computes at any sample the triangle covers there
//! ([`Tri::depth_at`]).
//!
//! Bands of tile rows are independent and each sees its triangles in order,
//! so the result does not depend on the thread count.

use super::setup::{Tri, HALF, ONE};
use crate::depth::masked::{row_bits, MaskTile, MaskedZBuffer, MASK_TILE_H, MASK_TILE_W};
use rayon::prelude::*;

/// Tile rows per band (each band is filled by one thread).
const BAND_TILES: u32 = 4;
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

/// One edge stepped row by row: the first or last covered column offset
/// (from the box's `x0`) as `q + (r > 0)` (left) or `q` (right) of the
/// exact quotient of the edge function, and its per-row step.
#[derive(Clone, Copy, Debug)]
enum Edge {
    /// Covered where `k >= ceil(n / d)`; `n = q·d + r`, `0 <= r < d`.
    Left { q: i64, r: i64, d: i64, sq: i64, sr: i64 },
    /// Covered where `k <= floor(e / d)`; `e = q·d + r`.
    Right { q: i64, r: i64, d: i64, sq: i64, sr: i64 },
    /// Horizontal: the whole row or none, as `e >= 0`.
    Flat { e: i64, step: i64 },
}

impl Edge {
    /// Edge `i` of `t` at row `py`, with its per-row step `(sq, sr)` from [`edge_steps`].
    fn new(t: &Tri, i: usize, py: u32, (sq, sr): (i64, i64)) -> Edge {
        let e = t.a[i] * (i64::from(t.x0) * ONE + HALF) + t.b[i] * (i64::from(py) * ONE + HALF) + t.c[i];
        let (d, step) = (t.a[i] * ONE, t.b[i] * ONE);
        match d.signum() {
            // n = -e falls by step per row.
            1 => Edge::Left {
                q: (-e).div_euclid(d),
                r: (-e).rem_euclid(d),
                d,
                sq,
                sr,
            },
            -1 => Edge::Right {
                q: e.div_euclid(-d),
                r: e.rem_euclid(-d),
                d: -d,
                sq,
                sr,
            },
            _ => Edge::Flat { e, step },
        }
    }

    /// Narrows `lo..=hi` (column offsets) to this edge's covered part of the row.
    #[inline]
    fn clip(&self, lo: &mut i64, hi: &mut i64) {
        match *self {
            Edge::Left { q, r, .. } => *lo = (*lo).max(q + i64::from(r > 0)),
            Edge::Right { q, .. } => *hi = (*hi).min(q),
            Edge::Flat { e, .. } => {
                if e < 0 {
                    *hi = -1;
                }
            }
        }
    }

    /// The next row.
    #[inline]
    fn step(&mut self) {
        match self {
            Edge::Left { q, r, d, sq, sr } | Edge::Right { q, r, d, sq, sr } => {
                // Branch-free: whether the remainder carries is data, not pattern.
                let carry = i64::from(*r + *sr >= *d);
                *q += *sq + carry;
                *r += *sr - carry * *d;
            }
            Edge::Flat { e, step } => *e += *step,
        }
    }
}

/// Each edge's per-row step of `t` as quotient and remainder by its
/// divisor: constant per triangle, so computed once, not per band.
fn edge_steps(t: &Tri) -> [(i64, i64); 3] {
    [0, 1, 2].map(|i| {
        let (d, step) = (t.a[i] * ONE, t.b[i] * ONE);
        match d.signum() {
            1 => ((-step).div_euclid(d), (-step).rem_euclid(d)),
            -1 => (step.div_euclid(-d), step.rem_euclid(-d)),
            _ => (0, 0),
        }
    })
}

/// The covered columns `lo..hi` (absolute) of rows `py0..py0 + spans.len()`
/// of `t` (all within its box), into `spans`; an empty row is `(0, 0)`.
/// `steps` is [`edge_steps`] of `t`.
fn spans(t: &Tri, steps: &[(i64, i64); 3], py0: u32, spans: &mut [(u32, u32)]) {
    let mut edges = [0, 1, 2].map(|i| Edge::new(t, i, py0, steps[i]));
    let last = i64::from(t.x1 - t.x0) - 1;
    let x0 = u32::from(t.x0);
    for s in spans.iter_mut() {
        let (mut lo, mut hi) = (0i64, last);
        for e in &mut edges {
            e.clip(&mut lo, &mut hi);
            e.step();
        }
        *s = if lo <= hi {
            (x0 + lo as u32, x0 + hi as u32 + 1)
        } else {
            (0, 0)
        };
    }
}

/// Draws set-up triangles into a [`MaskedZBuffer`]; keeps its scratch between frames.
#[derive(Clone, Debug, Default)]
pub(crate) struct MaskedRasterizer {
    /// Per band, the indices of the triangles overlapping it, in order.
    bins: Vec<Vec<u32>>,
    /// Per triangle, [`edge_steps`].
    steps: Vec<[(i64, i64); 3]>,
}

impl MaskedRasterizer {
    /// Draws `tris` (set up for `zb`'s viewport) into `zb`, which keeps what
    /// it holds, and builds its blocks. Uses the current rayon pool; the
    /// result does not depend on its size.
    pub fn render(&mut self, tris: &[Tri], zb: &mut MaskedZBuffer) -> MaskedStats {
        let (tiles_x, tiles_y) = zb.tiles();
        let bands = tiles_y.div_ceil(BAND_TILES) as usize;
        self.bins.resize_with(bands, Vec::new);
        self.bins.truncate(bands);
        for bin in &mut self.bins {
            bin.clear();
        }
        let band_px = BAND_TILES * MASK_TILE_H;
        for (i, t) in tris.iter().enumerate() {
            for band in u32::from(t.y0) / band_px..=(u32::from(t.y1) - 1) / band_px {
                self.bins[band as usize].push(i as u32);
            }
        }
        tris.par_iter().map(edge_steps).collect_into_vec(&mut self.steps);
        let steps = &self.steps;
        let (tiles, outside, _) = zb.rows_mut();
        let band_tiles = (tiles_x * BAND_TILES) as usize;
        let stats = tiles
            .par_chunks_mut(band_tiles)
            .zip(outside.par_chunks(band_tiles))
            .zip(self.bins.par_iter())
            .enumerate()
            .map(|(band, ((tiles, outside), bin))| {
                let ty0 = band as u32 * BAND_TILES;
                draw_band(tris, steps, bin, ty0, tiles_x, tiles, outside)
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

/// The triangles `bin` of `tris` (with their [`edge_steps`]) into one band
/// of tile rows from `ty0`.
fn draw_band(
    tris: &[Tri],
    steps: &[[(i64, i64); 3]],
    bin: &[u32],
    ty0: u32,
    tiles_x: u32,
    tiles: &mut [MaskTile],
    outside: &[[u32; 8]],
) -> MaskedStats {
    let mut stats = MaskedStats::default();
    let rows = tiles.len() as u32 / tiles_x;
    let (band_y0, band_y1) = (ty0 * MASK_TILE_H, (ty0 + rows) * MASK_TILE_H);
    // Per block of tiles across the band, the farthest reference depth.
    let blocks_x = tiles_x.div_ceil(BLOCK_TILES);
    let block_max = |tiles: &[MaskTile], b: u32| {
        let (x0, x1) = (b * BLOCK_TILES, ((b + 1) * BLOCK_TILES).min(tiles_x));
        (0..rows)
            .flat_map(|ty| (x0..x1).map(move |tx| (ty * tiles_x + tx) as usize))
            .fold(f32::NEG_INFINITY, |m, k| m.max(tiles[k].z0))
    };
    let mut blocks: Vec<f32> = (0..blocks_x).map(|b| block_max(tiles, b)).collect();
    // The spans of the band's rows, (0, 0) outside the triangle's.
    let mut span = [(0u32, 0u32); (BAND_TILES * MASK_TILE_H) as usize];
    for &i in bin {
        let t = &tris[i as usize];
        let (ya, yb) = (u32::from(t.y0).max(band_y0), u32::from(t.y1).min(band_y1));
        // Nothing to do where the triangle lies behind every tile's reference depth.
        let (xa, xb) = (u32::from(t.x0), u32::from(t.x1) - 1);
        let nearest = t.depth_bounds(xa, xb, ya, yb - 1).0;
        let (ba, bb) = (xa / MASK_TILE_W / BLOCK_TILES, xb / MASK_TILE_W / BLOCK_TILES);
        if (ba..=bb).all(|b| nearest >= blocks[b as usize]) {
            stats.blocks_rejected += 1;
            continue;
        }
        span.fill((0, 0));
        spans(
            t,
            &steps[i as usize],
            ya,
            &mut span[(ya - band_y0) as usize..(yb - band_y0) as usize],
        );
        for ty in (ya - band_y0) / MASK_TILE_H..=(yb - 1 - band_y0) / MASK_TILE_H {
            let rows = &span[(ty * MASK_TILE_H) as usize..][..MASK_TILE_H as usize];
            let (lo, hi) = rows
                .iter()
                .filter(|s| s.0 < s.1)
                .fold((u32::MAX, 0), |(a, b), s| (a.min(s.0), b.max(s.1)));
            if lo >= hi {
                continue;
            }
            let y_tile0 = band_y0 + ty * MASK_TILE_H;
            let (ra, rb) = (ya.max(y_tile0), yb.min(y_tile0 + MASK_TILE_H) - 1);
            for tx in lo / MASK_TILE_W..=(hi - 1) / MASK_TILE_W {
                let x_tile0 = tx * MASK_TILE_W;
                let k = (ty * tiles_x + tx) as usize;
                stats.tiles_drawn += 1;
                // The covered part of this tile lies in these columns and rows.
                let (ca, cb) = (lo.max(x_tile0), hi.min(x_tile0 + MASK_TILE_W) - 1);
                let zt = t.depth_bounds(ca, cb, ra, rb).1;
                if zt.is_nan() || zt >= tiles[k].z0 {
                    stats.tiles_rejected += 1;
                    continue;
                }
                let m: [u32; 8] = std::array::from_fn(|j| {
                    let (a, b) = rows[j];
                    row_bits(i64::from(a) - i64::from(x_tile0), i64::from(b) - i64::from(x_tile0))
                });
                let z0 = tiles[k].z0;
                if !tiles[k].insert(&m, zt, &outside[k]) {
                    stats.tiles_rejected += 1;
                } else if tiles[k].z0 < z0 {
                    // A reference depth only falls: the block's falls if this tile held it.
                    let b = (tx / BLOCK_TILES) as usize;
                    if z0 == blocks[b] {
                        blocks[b] = block_max(tiles, b as u32);
                    }
                }
            }
        }
    }
    stats
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::queue::TriangleQueue;
    use crate::raster::setup::{FaceCull, Viewport};
    use glam::Vec4;
    use hom_testkit::Rng;
    use proptest::prelude::*;

    /// Random clip-space triangles, tiny to screen-filling, some crossing the
    /// near plane or the screen edges, at spread depths.
    fn soup(seed: u64, n: usize, w: u32, h: u32, inner: bool) -> Vec<Tri> {
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
        let mut out = Vec::new();
        q.set_up(&Viewport::new(w, h), inner, &mut out);
        out
    }

    proptest! {
        /// Every row's span equals `Tri::row_span` (the renderer's coverage).
        #[test]
        fn spans_are_the_exact_row_spans(seed in any::<u64>(), w in 1u32..300, h in 1u32..200, inner in any::<bool>()) {
            for t in soup(seed, 40, w, h, inner) {
                let n = usize::from(t.y1 - t.y0);
                let mut s = vec![(0, 0); n];
                spans(&t, &edge_steps(&t), u32::from(t.y0), &mut s);
                for (k, got) in s.iter().enumerate() {
                    let py = u32::from(t.y0) + k as u32;
                    let want = t.row_span(py).unwrap_or((0, 0));
                    prop_assert_eq!(*got, want, "row {} of {:?}", py, t);
                }
            }
        }

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
        let tris = soup(99, 3000, 333, 257, false);
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
