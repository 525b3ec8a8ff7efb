//! Occluder depth into a [`TiledZBuffer`], with hierarchical rejection: the
//! rasterizer of the hierarchical Z-buffer (Greene, Kass and Miller 1993;
//! RTR section 7.2), built so that occluders hidden by what is already drawn
//! cost little. Triangles arrive in any order.
//!
//! Each triangle is set up by [`crate::raster::setup`] (the renderer's snapping, fill
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

use super::simd::render_band;
use super::tile_band::{Band, TiledStats};
use crate::hzb::tiled::{TiledZBuffer, TILE, TILE_SAMPLES};
use crate::raster::costliest_first;
use crate::raster::setup::Tri;
use crate::raster::simd::RasterBackend;
use rayon::prelude::*;

/// Tile rows per band (each band is filled by one thread).
const BAND_TILES: u32 = 4;

/// Renders set-up triangles' depth into a [`TiledZBuffer`]; keeps its
/// scratch between frames.
#[derive(Clone, Debug, Default)]
pub struct TiledRasterizer {
    /// Per band of rows, copies of the triangles overlapping it (read in order, from cache).
    bins: Vec<Vec<Tri>>,
    backend: RasterBackend,
}

/// A band's samples, tile maxima and touched flags, as the band split hands them out.
type BandSlices<'a> = ((&'a mut [f32], &'a mut [f32]), &'a mut [bool]);

impl TiledRasterizer {
    /// An empty rasterizer using [`RasterBackend::active`].
    #[cfg(test)]
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

    /// The backend it draws with.
    pub fn backend(&self) -> RasterBackend {
        self.backend
    }

    /// Bytes of scratch held on the heap.
    pub fn heap_bytes(&self) -> usize {
        crate::vec_bytes(&self.bins) + self.bins.iter().map(crate::vec_bytes).sum::<usize>()
    }

    /// Renders `tris` (set up for `zb`'s viewport) into `zb`, which keeps
    /// what it holds (clear it first for a new frame), and builds its
    /// pyramid. Uses the current rayon pool; the result does not depend on its size.
    #[cfg(test)]
    pub fn render(&mut self, tris: &[Tri], zb: &mut TiledZBuffer) -> TiledStats {
        self.render_with(tris, zb, true)
    }

    /// Renders `tris` as `render` does, on the current rayon pool where
    /// `parallel`, else on the calling thread: the same result.
    pub fn render_with(&mut self, tris: &[Tri], zb: &mut TiledZBuffer, parallel: bool) -> TiledStats {
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
        let bins = &self.bins;
        let bands: Vec<_> = samples
            .chunks_mut(band_tiles * TILE_SAMPLES)
            .zip(maxima.chunks_mut(band_tiles))
            .zip(touched.chunks_mut(band_tiles))
            .enumerate()
            .collect();
        let draw = |(band, ((samples, maxima), touched)): (usize, BandSlices)| {
            let bin = &bins[band];
            let band = Band {
                ty0: band as u32 * BAND_TILES,
                tiles_x,
                width,
                height,
            };
            render_band(backend, &band, bin, (samples, maxima, touched))
        };
        let sum = |mut a: TiledStats, b: TiledStats| {
            a += b;
            a
        };
        let stats = if parallel {
            costliest_first(bands, |band| bins[band].len())
                .map(draw)
                .reduce(TiledStats::default, sum)
        } else {
            bands.into_iter().map(draw).fold(TiledStats::default(), sum)
        };
        zb.build_pyramid();
        TiledStats {
            triangles: tris.len() as u64,
            ..stats
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::queue::TriangleQueue;
    use crate::raster::setup::{FaceCull, Viewport};
    use glam::Vec4;
    use hom_testkit::Rng;
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
                for x in u32::from(t.x0)..u32::from(t.x1) {
                    if t.covers(x, y) {
                        let z = t.depth_at(x, y);
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
        let mut rng = Rng::new(seed);
        let mut rnd = move || rng.unit();
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
