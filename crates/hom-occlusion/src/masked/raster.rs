//! The masked rasterizer (after Hasselgren, Andersson and Akenine-Möller,
//! "Masked Software Occlusion Culling", HPG 2016): set-up triangles into a
//! [`MaskedZBuffer`] as coverage masks of 32×8-sample tiles with one
//! conservative depth per triangle and 8×4 subtile.
//!
//! Coverage comes from edge events per scan line, not per-sample edge
//! functions: each row's first and last covered column straight from the
//! edge functions ([`crate::raster::scanline::RowBounds`], eight rows in
//! `f64` lanes, exact), so a row's span is exactly the one [`Tri::row_span`](crate::raster::setup::Tri::row_span)
//! computes (the renderer's coverage, or the inner rule's when the triangle
//! was set up with it). A tile row's masks are then two shifts of its spans.
//!
//! Depth: per triangle and subtile, the plane's farthest value over the
//! subtile's part of the tile row's covered rectangle (at its far corner),
//! plus rounding slack, so at least the depth the renderer computes at any
//! sample the triangle covers there ([`Tri::depth_at`](crate::raster::setup::Tri::depth_at)).
//!
//! Bands of tile rows are independent and each sees its triangles in order,
//! so the result does not depend on the thread count or on how bands are
//! grouped.

use super::group::{GroupParts, MaskedStats, SetUp, BAND_TILES};
use super::simd::render_group;
use crate::masked::zbuffer::{MaskTile, MaskedZBuffer};
use crate::raster::queue::{QueueSetup, TriangleQueue};
#[cfg(test)]
use crate::raster::setup::Tri;
use crate::raster::simd::RasterBackend;
use rayon::prelude::*;
use std::time::Instant;

/// Above this many triangles a frame's bands are split into one group per
/// thread, not three: on the 100k MOC inputs at two threads 36.5 against
/// 44.4 ms (`small_100k`, 1080p), 20.2 against 27.8 (`large_100k`, 1080p);
/// the walkthroughs' few thousand occluder triangles, bunched in some rows,
/// need the stealing (masked cull city 2.76 ms with three, 3.27 with one).
const MANY_TRIANGLES: usize = 16_384;

/// Draws set-up triangles into a [`MaskedZBuffer`]; keeps its scratch between frames.
#[derive(Clone, Debug, Default)]
pub(crate) struct MaskedRasterizer {
    /// The triangles set up, one list per chunk of the queue, in order
    /// (each set up on a thread of its own, drawn where they lie: no copy
    /// into one list).
    chunks: Vec<SetUp>,
    backend: RasterBackend,
}

/// What [`MaskedRasterizer::set_up_and_render`] did.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct MaskedRender {
    /// The raster's work.
    pub stats: MaskedStats,
    /// Triangles set up (after clipping, face culling and empty boxes).
    pub triangles: usize,
    /// Time setting up, ms.
    pub set_up_ms: f64,
    /// Time drawing, ms.
    pub draw_ms: f64,
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
            chunks: Vec::new(),
            backend,
        }
    }

    /// Sets up `queue` as `setup` says, its chunks in parallel, each into a
    /// list of its own, then draws them in order into `zb` (as
    /// [`MaskedRasterizer::render`] draws one list).
    pub fn set_up_and_render(
        &mut self,
        queue: &TriangleQueue,
        setup: &QueueSetup,
        zb: &mut MaskedZBuffer,
    ) -> MaskedRender {
        let start = Instant::now();
        self.chunks.resize_with(queue.chunks(), SetUp::default);
        let set_up = |(k, c): (usize, &mut SetUp)| {
            c.tris.clear();
            queue.set_up_chunk(k, setup, &mut c.tris);
            c.index_rows();
        };
        if setup.parallel {
            self.chunks.par_iter_mut().enumerate().for_each(set_up);
        } else {
            self.chunks.iter_mut().enumerate().for_each(set_up);
        }
        let set_up_ms = start.elapsed().as_secs_f64() * 1e3;
        let stats = self.draw(zb, setup.parallel);
        MaskedRender {
            stats,
            triangles: self.chunks.iter().map(|c| c.tris.len()).sum(),
            set_up_ms,
            draw_ms: start.elapsed().as_secs_f64() * 1e3 - set_up_ms,
        }
    }

    /// Draws `tris` (set up for `zb`'s viewport) into `zb`, which keeps what
    /// it holds, and builds its blocks. Uses the current rayon pool; the
    /// result does not depend on its size.
    #[cfg(test)]
    pub fn render(&mut self, tris: &[Tri], zb: &mut MaskedZBuffer) -> MaskedStats {
        self.chunks.resize_with(1, SetUp::default);
        self.chunks[0].tris.clear();
        self.chunks[0].tris.extend_from_slice(tris);
        self.chunks[0].index_rows();
        self.draw(zb, true)
    }

    /// Draws the chunks into `zb` and builds its blocks: on the current
    /// rayon pool where `parallel`, else on the calling thread.
    ///
    /// Work is split into groups of bands of tile rows; each group walks the
    /// whole triangle list in order (streaming it, where a bin of indices per
    /// band would jump through memory) and draws what overlaps its bands.
    fn draw(&mut self, zb: &mut MaskedZBuffer, parallel: bool) -> MaskedStats {
        let (tiles_x, tiles_y) = zb.tiles();
        let bands = tiles_y.div_ceil(BAND_TILES);
        let triangles: usize = self.chunks.iter().map(|c| c.tris.len()).sum();
        // A few groups per thread, so stealing evens out unequal bands; but
        // every group walks every triangle and sets up again the ones that
        // cross into it, so many triangles get one group per thread.
        // One thread has nothing to even out: one group, every triangle read once.
        let threads = if parallel {
            rayon::current_num_threads() as u32
        } else {
            1
        };
        let per_thread = if triangles > MANY_TRIANGLES || threads == 1 {
            1
        } else {
            3
        };
        let groups = (threads * per_thread).clamp(1, bands);
        let group_bands = bands.div_ceil(groups);
        let chunks = &self.chunks;
        let (tiles, outside, _) = zb.rows_mut();
        let group_tiles = (tiles_x * BAND_TILES * group_bands) as usize;
        let backend = self.backend;
        let group = |(g, (tiles, outside)): (usize, (&mut [MaskTile], &[[u32; 8]]))| {
            let parts = GroupParts {
                ty0: g as u32 * group_bands * BAND_TILES,
                tiles_x,
                tiles,
                outside,
            };
            render_group(backend, chunks, parts)
        };
        let sum = |a: MaskedStats, b: MaskedStats| MaskedStats {
            tiles_drawn: a.tiles_drawn + b.tiles_drawn,
            tiles_rejected: a.tiles_rejected + b.tiles_rejected,
            rows_rejected: a.rows_rejected + b.rows_rejected,
        };
        let stats = if parallel {
            tiles
                .par_chunks_mut(group_tiles)
                .zip(outside.par_chunks(group_tiles))
                .enumerate()
                .map(group)
                .reduce(MaskedStats::default, sum)
        } else {
            tiles
                .chunks_mut(group_tiles)
                .zip(outside.chunks(group_tiles))
                .enumerate()
                .map(group)
                .fold(MaskedStats::default(), sum)
        };
        zb.build_blocks();
        stats
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::queue::TriangleQueue;
    use crate::raster::scanline::tests::soup;
    use crate::raster::scanline::{ScanEdges, TileRows};
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
        // The far quad's two triangles are skipped in each of the five tile
        // rows, before any span is made.
        assert_eq!(stats.rows_rejected, 10, "{stats:?}");
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

    /// The queue set up chunk by chunk and drawn from the chunks gives the
    /// buffer and the work that its one set-up list drawn at once gives.
    #[test]
    fn chunks_draw_what_one_list_draws() {
        let (w, h) = (301, 203);
        for (seed, n) in [(5, 700), (6, 2600)] {
            let queue = crate::raster::scanline::tests::soup_queue(seed, n);
            let setup = QueueSetup {
                backend: RasterBackend::active(),
                viewport: Viewport::new(w, h),
                inner: false,
                parallel: true,
            };
            assert!(queue.chunks() > 1, "{n} triangles make one chunk");
            let mut tris = Vec::new();
            queue.set_up_with(&setup, &mut tris);
            let bounds = |zb: &MaskedZBuffer| -> Vec<u32> {
                (0..h)
                    .flat_map(|y| (0..w).map(move |x| (x, y)))
                    .map(|(x, y)| zb.bound(x, y).to_bits())
                    .collect()
            };
            let (mut one, mut chunked) = (MaskedZBuffer::default(), MaskedZBuffer::default());
            one.clear(w, h);
            chunked.clear(w, h);
            let want = MaskedRasterizer::default().render(&tris, &mut one);
            let got = MaskedRasterizer::default().set_up_and_render(&queue, &setup, &mut chunked);
            assert_eq!(got.stats, want, "seed {seed}");
            assert_eq!(got.triangles, tris.len());
            assert!(bounds(&chunked) == bounds(&one), "seed {seed}: the buffers differ");
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
