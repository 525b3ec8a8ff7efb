//! Occluder depth into a [`TiledZBuffer`], with hierarchical rejection: the
//! rasterizer of the hierarchical Z-buffer (Greene, Kass and Miller 1993;
//! RTR section 7.2), built so that occluders hidden by what is already drawn
//! cost little. Triangles arrive in any order.
//!
//! Each triangle is set up by [`super::setup`] (the renderer's snapping, fill
//! rule and depth formula), so the depth written at every sample is exactly
//! the renderer's: `max(zref + dzdy·(y − y0) + dzdx·(x − x0), 0)`, the nearest
//! over the triangles covering it. On the way there, per band of rows:
//! - a 32×32 block whose farthest depth is not beyond the triangle's nearest
//!   depth (a conservative bound of its plane over its box) is skipped;
//! - likewise an 8×8 tile, with the bound over the tile; a tile wholly
//!   outside one edge is skipped;
//! - a tile's 64 samples are then tested at once: edge functions in `i32`
//!   (exact: a tile spans a small range of each edge function, and an edge
//!   the tile lies wholly inside is dropped), depth in `f32`.
//!
//! Rejection never changes the result: it skips only samples the triangle
//! cannot make nearer. Bands are independent, so the result is the same for
//! any thread count.

use super::setup::{Tri, HALF, ONE};
use super::simd::RasterBackend;
use super::simd_tiles::{render_band, TileKernel};
use crate::depth::tiled::{TiledZBuffer, TILE, TILE_SAMPLES};
use rayon::prelude::*;

/// Tile rows per band (each band is filled by one thread).
const BAND_TILES: u32 = 4;
/// Tiles per block side: blocks are `BAND_TILES` × `BLOCK_TILES` tiles.
const BLOCK_TILES: u32 = 8;
/// Relative slack on a plane's depth bound: covers the few `f32` roundings
/// of the renderer's formula and of the bound itself.
const PLANE_SLACK: f32 = 1.0 / (1 << 19) as f32;

/// Work done by [`TiledRasterizer::render`].
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

/// Renders set-up triangles' depth into a [`TiledZBuffer`]; keeps its
/// scratch between frames.
#[derive(Clone, Debug, Default)]
pub struct TiledRasterizer {
    /// Per band of rows, copies of the triangles overlapping it (read in order, from cache).
    bins: Vec<Vec<Tri>>,
    backend: RasterBackend,
}

impl TiledRasterizer {
    /// An empty rasterizer using [`RasterBackend::active`].
    pub fn new() -> TiledRasterizer {
        TiledRasterizer::default()
    }

    /// An empty rasterizer using `backend`; every backend writes the same depths.
    ///
    /// # Panics
    /// If the CPU does not support `backend`.
    pub fn with_backend(backend: RasterBackend) -> TiledRasterizer {
        assert!(
            backend.is_supported(),
            "raster backend {backend:?} is not supported by this CPU"
        );
        TiledRasterizer {
            backend,
            ..TiledRasterizer::default()
        }
    }

    /// Renders `tris` (set up for `zb`'s viewport) into `zb`, which keeps
    /// what it holds (clear it first for a new frame), and builds its
    /// pyramid. Uses the current rayon pool; the result does not depend on its size.
    pub fn render(&mut self, tris: &[Tri], zb: &mut TiledZBuffer) -> TiledStats {
        let (tiles_x, tiles_y) = zb.tiles();
        let (width, height) = (zb.width(), zb.height());
        let bands = tiles_y.div_ceil(BAND_TILES) as usize;
        self.bins.resize_with(bands, Vec::new);
        self.bins.truncate(bands);
        for bin in &mut self.bins {
            bin.clear();
        }
        let band_px = BAND_TILES * TILE;
        for t in tris {
            for band in u32::from(t.y0) / band_px..=(u32::from(t.y1) - 1) / band_px {
                self.bins[band as usize].push(*t);
            }
        }
        let backend = self.backend;
        let (samples, maxima, touched) = zb.parts_mut();
        let band_tiles = (tiles_x * BAND_TILES) as usize;
        let stats = samples
            .par_chunks_mut(band_tiles * TILE_SAMPLES)
            .zip(maxima.par_chunks_mut(band_tiles))
            .zip(touched.par_chunks_mut(band_tiles))
            .zip(self.bins.par_iter())
            .enumerate()
            .map(|(band, (((samples, maxima), touched), bin))| {
                let band = Band {
                    ty0: band as u32 * BAND_TILES,
                    tiles_x,
                    width,
                    height,
                };
                render_band(backend, &band, bin, (samples, maxima, touched))
            })
            .reduce(TiledStats::default, |mut a, b| {
                a += b;
                a
            });
        zb.build_pyramid();
        TiledStats {
            triangles: tris.len() as u64,
            ..stats
        }
    }
}

/// A band's samples, tile maxima and touched flags.
pub(crate) type BandParts<'a> = (&'a mut [f32], &'a mut [f32], &'a mut [bool]);

/// One band of tile rows being filled.
pub(crate) struct Band {
    /// First tile row.
    ty0: u32,
    tiles_x: u32,
    width: u32,
    height: u32,
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
/// rows `ya..=yb` (within its box), minus slack for rounding; at least 0, as
/// the renderer clamps.
#[inline]
fn plane_floor(t: &Tri, xa: u32, xb: u32, ya: u32, yb: u32) -> f32 {
    let (x0, y0) = (u32::from(t.x0), u32::from(t.y0));
    let (dxa, dxb) = ((xa - x0) as f32, (xb - x0) as f32);
    let (dya, dyb) = ((ya - y0) as f32, (yb - y0) as f32);
    let low = t.zref + (t.dzdx * dxa).min(t.dzdx * dxb) + (t.dzdy * dya).min(t.dzdy * dyb);
    let size = t.zref.abs() + t.dzdx.abs() * dxb + t.dzdy.abs() * dyb;
    (low - size * PLANE_SLACK).max(0.0)
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
    /// point (`simd_tiles::render_band`), which compiles it with its features.
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

/// A tile with `i64` edge functions, for triangles too large for `i32`.
fn draw_tile_wide(t: &Tri, px: u32, py: u32, width: u32, height: u32, tile: &mut [f32; TILE_SAMPLES]) -> Option<f32> {
    let (x0, y0) = (u32::from(t.x0), u32::from(t.y0));
    let mut changed = false;
    for j in 0..(height - py).min(TILE) {
        let y = py + j;
        let zr = t.zref + t.dzdy * y.wrapping_sub(y0) as i32 as f32;
        for i in 0..(width - px).min(TILE) {
            let x = px + i;
            if !t.covers(x, y) {
                continue;
            }
            let z = (zr + t.dzdx * x.wrapping_sub(x0) as i32 as f32).max(0.0);
            let d = &mut tile[(j * TILE + i) as usize];
            if z < *d {
                *d = z;
                changed = true;
            }
        }
    }
    changed.then(|| tile.iter().fold(f32::NEG_INFINITY, |m, &d| m.max(d)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::queue::TriangleQueue;
    use crate::raster::setup::{FaceCull, Viewport};
    use glam::Vec4;
    use proptest::prelude::*;

    /// `t` over `v` set up for a `w` × `h` viewport under `rule`.
    fn set_up(v: &[Vec4], t: &[[u32; 3]], cull: FaceCull, inner: bool, w: u32, h: u32) -> Vec<Tri> {
        let mut q = TriangleQueue::default();
        q.push_clip(v, t, |v| v, cull).unwrap();
        let mut out = Vec::new();
        q.set_up(&Viewport::new(w, h), inner, &mut out);
        out
    }

    /// The obvious reference: every triangle, every sample of its box, the
    /// renderer's formula, nearest wins; row-major, `INFINITY` where uncovered.
    fn brute_force(tris: &[Tri], w: u32, h: u32) -> Vec<f32> {
        let mut d = vec![f32::INFINITY; (w * h) as usize];
        for t in tris {
            for y in u32::from(t.y0)..u32::from(t.y1) {
                let zr = t.depth_row(y);
                for x in u32::from(t.x0)..u32::from(t.x1) {
                    if t.covers(x, y) {
                        let z = (zr + t.dzdx * (x - u32::from(t.x0)) as f32).max(0.0);
                        let s = &mut d[(y * w + x) as usize];
                        *s = s.min(z);
                    }
                }
            }
        }
        d
    }

    /// Random clip-space triangles: tiny to screen-filling, slivers, some
    /// crossing the near plane or the screen edges, depths spread or stacked.
    fn soup(seed: u64, n: usize) -> (Vec<Vec4>, Vec<[u32; 3]>) {
        let mut s = seed | 1;
        let mut rnd = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f32 / (1u64 << 53) as f32
        };
        let mut v = Vec::new();
        let mut t = Vec::new();
        for i in 0..n {
            let size = [0.01, 0.05, 0.3, 1.5, 6.0][(rnd() * 5.0) as usize % 5];
            let (cx, cy) = (rnd() * 2.6 - 1.3, rnd() * 2.6 - 1.3);
            let w = 1.0 + rnd() * 20.0;
            for _ in 0..3 {
                let wv = (w * (0.6 + rnd() * 0.8)).max(0.05);
                let x = (cx + (rnd() - 0.5) * size) * wv;
                let y = (cy + (rnd() - 0.5) * size) * wv;
                // z = w - near (depth 1 - near / w), some vertices in front of near.
                v.push(Vec4::new(x, y, wv - 0.5, wv));
            }
            let b = 3 * i as u32;
            t.push([b, b + 1, b + 2]);
        }
        (v, t)
    }

    proptest! {
        #[test]
        fn depth_equals_the_brute_force_z_buffer(
            seed in any::<u64>(), n in 1usize..120, w in 1u32..150, h in 1u32..110, cull in 0u8..3,
        ) {
            let cull = [FaceCull::None, FaceCull::Clockwise, FaceCull::CounterClockwise][cull as usize];
            let (v, t) = soup(seed, n);
            // Stale samples from another frame must not leak through the lazy clear.
            let mut zb = TiledZBuffer::default();
            let (sv, st) = soup(!seed, 60);
            zb.clear(w, h);
            TiledRasterizer::new().render(&set_up(&sv, &st, FaceCull::None, false, w, h), &mut zb);
            let tris = set_up(&v, &t, cull, seed % 2 == 0, w, h);
            let expect = brute_force(&tris, w, h);
            for backend in RasterBackend::supported() {
            zb.clear(w, h);
            TiledRasterizer::with_backend(backend).render(&tris, &mut zb);
            let mut got = Vec::new();
            zb.to_row_major(&mut got);
            for (i, (g, e)) in got.iter().zip(&expect).enumerate() {
                prop_assert!(g == e, "{:?} sample {},{}: tiled {} brute force {}", backend, i as u32 % w, i as u32 / w, g, e);
            }
            }
            // Every tile's maximum is its farthest sample.
            let (tx, _) = zb.tiles();
            for (k, &m) in zb.tile_max().iter().enumerate() {
                let (x0, y0) = (k as u32 % tx * TILE, k as u32 / tx * TILE);
                let mut far = f32::NEG_INFINITY;
                for y in y0..(y0 + TILE).min(h) {
                    for x in x0..(x0 + TILE).min(w) {
                        far = far.max(zb.depth(x, y));
                    }
                }
                prop_assert_eq!(m, far, "tile {}", k);
            }
        }
    }

    #[test]
    fn thread_count_does_not_change_the_result() {
        let (v, t) = soup(99, 3000);
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| {
                let tris = set_up(&v, &t, FaceCull::None, false, 333, 257);
                let mut zb = TiledZBuffer::default();
                zb.clear(333, 257);
                let stats = TiledRasterizer::new().render(&tris, &mut zb);
                let mut d = Vec::new();
                zb.to_row_major(&mut d);
                (d, stats)
            })
        };
        let (one, s1) = run(1);
        let (three, s3) = run(3);
        assert!(one == three);
        // Rejection does happen on a deep soup (else it is untested).
        assert!(s1.blocks_rejected + s1.tiles_rejected > 0, "{s1:?}");
        assert_eq!(s1.triangles, s3.triangles);
    }
}
