//! The occluders' depth at every sample, drawn when first asked, and the
//! question a box test cannot answer: is a set of triangles behind it at
//! every sample it covers?
//!
//! A box test compares one depth, the box's nearest, with the farthest
//! occluder depth over the box's rectangle (HOM's 16×16-sample cells, HZB's
//! pyramid texels). An object close behind its hider fails it twice: its
//! box's nearest corner is nearer than most of its surface, and a sloped
//! hider's depth varies across a cell by more than the gap. Those objects are
//! most of what the cullers draw that owns no pixel, and their area makes
//! them costly (`docs/decisions/occluders.md`). Asked per sample, with the
//! renderer's own setup and depth formula ([`Tri::depth_at`]) on both sides,
//! the question is exact, as a hardware occlusion query's is.
//!
//! [`SampleDepths`] keeps the occluder triangles a buffer without per-sample
//! depth set up (bit for bit the renderer's, or by the inner rule: covering
//! fewer samples, no nearer); the first [`SampleDepths::hidden`] of a frame
//! draws them into a [`TiledZBuffer`] with the hierarchical Z-buffer's own
//! rasterizer, and every query is answered by
//! [`TiledZBuffer::triangles_hidden`], as [`crate::HzBuffer`]'s are.

use crate::hzb::raster::TiledRasterizer;
use crate::hzb::TiledZBuffer;
use crate::raster::setup::Tri;
use crate::RasterBackend;

/// Per-sample occluder depth, drawn on first use (see the module docs).
#[derive(Clone, Debug, Default)]
pub struct SampleDepths {
    occluders: Vec<Tri>,
    zbuffer: TiledZBuffer,
    raster: TiledRasterizer,
    width: u32,
    height: u32,
    parallel: bool,
    /// Whether [`SampleDepths::begin`] was called since the last [`SampleDepths::reset`].
    begun: bool,
    /// Whether this frame's occluders are in `zbuffer`.
    drawn: bool,
    stats: SampleDepthStats,
}

/// What [`SampleDepths`] did since its last [`SampleDepths::begin`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SampleDepthStats {
    /// Queries answered.
    pub queries: u64,
    /// Queries answered hidden.
    pub hidden: u64,
    /// 8×8-sample tiles of occluder depth drawn (0 until the first query).
    pub tiles_drawn: u64,
}

impl SampleDepths {
    /// Empty; nothing is allocated until [`SampleDepths::begin`].
    pub fn new() -> SampleDepths {
        SampleDepths::default()
    }

    /// Starts a frame of a `width` × `height` viewport (each side
    /// 1..=16384) whose occluders are `occluders`, set up for that viewport
    /// (by the renderer's rule or the inner rule), to be drawn with
    /// `backend` on the current rayon pool where `parallel`. Nothing is
    /// drawn until the first query.
    pub fn begin<'a>(
        &mut self,
        width: u32,
        height: u32,
        occluders: impl IntoIterator<Item = &'a Tri>,
        backend: RasterBackend,
        parallel: bool,
    ) {
        (self.width, self.height, self.parallel) = (width, height, parallel);
        self.occluders.clear();
        self.occluders.extend(occluders.into_iter().copied());
        if self.raster.backend() != backend {
            self.raster = TiledRasterizer::with_backend(backend);
        }
        self.begun = true;
        self.drawn = false;
        self.stats = SampleDepthStats::default();
    }

    /// Forgets the frame: [`SampleDepths::is_begun`] is false until the next begin.
    pub fn reset(&mut self) {
        self.begun = false;
    }

    /// Whether a frame's occluders were given since the last reset.
    pub fn is_begun(&self) -> bool {
        self.begun
    }

    /// What was done since the last [`SampleDepths::begin`].
    pub fn stats(&self) -> SampleDepthStats {
        self.stats
    }

    /// Bytes held on the heap (the z-buffer's samples included).
    pub fn heap_bytes(&self) -> usize {
        crate::vec_bytes(&self.occluders) + self.zbuffer.heap_bytes() + self.raster.heap_bytes()
    }

    /// Whether `tris` (set up for this viewport by the renderer's rule) lie
    /// behind the occluders at every sample they cover, by more than
    /// [`crate::DEPTH_MARGIN`] ([`TiledZBuffer::triangles_hidden`]). The
    /// first query of a frame draws the occluders.
    ///
    /// # Panics
    /// Before [`SampleDepths::begin`].
    pub fn hidden(&mut self, tris: &[Tri]) -> bool {
        assert!(self.begun, "SampleDepths::hidden before begin");
        if !self.drawn {
            self.zbuffer.clear(self.width, self.height);
            let s = self
                .raster
                .render_with(&self.occluders, &mut self.zbuffer, self.parallel);
            self.stats.tiles_drawn = s.tiles_drawn;
            self.drawn = true;
        }
        self.stats.queries += 1;
        let hidden = self.zbuffer.triangles_hidden(tris);
        self.stats.hidden += u64::from(hidden);
        hidden
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::setup::{setup_triangle, Vertex, Viewport};
    use crate::DEPTH_MARGIN;
    use glam::Vec4;
    use hom_testkit::Rng;

    /// `n` random triangles in clip space, a few of them crossing the near
    /// plane or the viewport's sides, set up for `vp`.
    fn random_tris(rng: &mut Rng, n: usize, vp: &Viewport, depth: (f32, f32), size: f32) -> Vec<Tri> {
        let mut out = Vec::new();
        for _ in 0..n {
            let (cx, cy) = (rng.unit() * 2.4 - 1.2, rng.unit() * 2.4 - 1.2);
            let v = [0, 1, 2].map(|_| {
                let w = 1.0 + rng.unit() * 4.0;
                let z = depth.0 + rng.unit() * (depth.1 - depth.0);
                let near = if rng.unit() < 0.03 { -0.5 } else { z };
                Vec4::new(
                    (cx + (rng.unit() - 0.5) * size) * w,
                    (cy + (rng.unit() - 0.5) * size) * w,
                    near * w,
                    w,
                )
            });
            let v = v.map(|c| Vertex::new(c, vp));
            setup_triangle([&v[0], &v[1], &v[2]], vp, 0, [0; 4], &mut out);
        }
        out
    }

    /// The slow reference: the occluders' nearest depth at every sample by
    /// [`Tri::covers`] and [`Tri::depth_at`], and the query's samples against it.
    fn hidden_reference(occluders: &[Tri], query: &[Tri], w: u32, h: u32) -> bool {
        let mut z = vec![f32::INFINITY; (w * h) as usize];
        for t in occluders {
            for y in t.y0..t.y1 {
                for x in t.x0..t.x1 {
                    let (x, y) = (u32::from(x), u32::from(y));
                    if t.covers(x, y) {
                        let s = &mut z[(y * w + x) as usize];
                        *s = s.min(t.depth_at(x, y));
                    }
                }
            }
        }
        query.iter().all(|t| {
            (t.y0..t.y1).all(|y| {
                (t.x0..t.x1).all(|x| {
                    let (x, y) = (u32::from(x), u32::from(y));
                    !t.covers(x, y) || t.depth_at(x, y) > z[(y * w + x) as usize] + DEPTH_MARGIN
                })
            })
        })
    }

    /// The answers equal the reference's, on odd viewports, with queries in
    /// front of, among and behind the occluders: [`SampleDepths`]'s, and the
    /// hierarchical Z-buffer's own ([`crate::hzb::TiledZBuffer::triangles_hidden`],
    /// with its tile skip) drawn by its tiled rasterizer on the pool.
    #[test]
    fn hidden_equals_the_full_z_buffer() {
        let mut rng = Rng::new(0x9e37_79b9_7f4a_7c15);
        let mut depths = SampleDepths::new();
        let mut raster = crate::hzb::raster::TiledRasterizer::new();
        let mut zb = crate::hzb::TiledZBuffer::default();
        let (mut hidden, mut seen) = (0, 0);
        for case in 0..300 {
            let (w, h) = (40 + (rng.unit() * 200.0) as u32, 30 + (rng.unit() * 100.0) as u32);
            let vp = Viewport::new(w, h);
            let occluders = random_tris(&mut rng, 1 + case % 12, &vp, (0.3, 0.6), 2.5);
            depths.begin(w, h, &occluders, RasterBackend::active(), false);
            zb.clear(w, h);
            raster.render_with(&occluders, &mut zb, true);
            for _ in 0..4 {
                let far = rng.unit() < 0.5;
                let range = if far { (0.6, 0.9) } else { (0.1, 0.9) };
                let n = 1 + (rng.unit() * 3.0) as usize;
                let query = random_tris(&mut rng, n, &vp, range, 0.6);
                let want = hidden_reference(&occluders, &query, w, h);
                assert_eq!(depths.hidden(&query), want, "case {case}");
                assert_eq!(zb.triangles_hidden(&query), want, "case {case}");
                hidden += usize::from(want);
                seen += usize::from(!want);
            }
        }
        // Both answers occur often enough to test something.
        assert!(hidden > 100 && seen > 100, "hidden {hidden}, seen {seen}");
    }

    /// The masked buffer's answer ([`crate::masked::MaskedZBuffer::triangles_hidden`],
    /// with its subtile skip) equals the same question asked sample by sample
    /// of its bounds ([`crate::masked::MaskedZBuffer::bound`]), and is
    /// conservative: never hidden where the full z-buffer sees the query.
    #[test]
    fn masked_hidden_is_its_bounds_and_conservative() {
        let mut rng = Rng::new(0x51ed_270b_a4f3_c3d1);
        let mut raster = crate::masked::raster::MaskedRasterizer::with_backend(RasterBackend::active());
        let mut zb = crate::masked::MaskedZBuffer::default();
        let (mut hidden, mut found) = (0, 0);
        for case in 0..300 {
            let (w, h) = (40 + (rng.unit() * 200.0) as u32, 30 + (rng.unit() * 100.0) as u32);
            let vp = Viewport::new(w, h);
            let occluders = random_tris(&mut rng, 1 + case % 12, &vp, (0.3, 0.6), 2.5);
            zb.clear(w, h);
            raster.render(&occluders, &mut zb);
            for _ in 0..4 {
                let range = if rng.unit() < 0.5 { (0.6, 0.9) } else { (0.1, 0.9) };
                let n = 1 + (rng.unit() * 3.0) as usize;
                let query = random_tris(&mut rng, n, &vp, range, 0.6);
                let by_bounds = query.iter().all(|t| {
                    (t.y0..t.y1).all(|y| {
                        (t.x0..t.x1).all(|x| {
                            let (x, y) = (u32::from(x), u32::from(y));
                            !t.covers(x, y) || t.depth_at(x, y) > zb.bound(x, y) + DEPTH_MARGIN
                        })
                    })
                });
                let got = zb.triangles_hidden(&query);
                assert_eq!(got, by_bounds, "case {case}");
                let want = hidden_reference(&occluders, &query, w, h);
                assert!(!got || want, "case {case}: masked hides a query the z-buffer sees");
                hidden += usize::from(want);
                found += usize::from(got);
            }
        }
        // The layers find most of what is hidden, so the equalities test something.
        assert!(found * 2 > hidden && hidden > 100, "found {found} of {hidden}");
    }

    /// A query behind a full-screen occluder is hidden; moved in front of it,
    /// or beside it where no occluder is, it is seen; an empty query is hidden.
    #[test]
    fn simple_cases() {
        let vp = Viewport::new(100, 80);
        let tri = |pts: [(f32, f32); 3], z: f32| {
            let v = pts.map(|(x, y)| Vertex::new(Vec4::new(x, y, z, 1.0), &vp));
            let mut out = Vec::new();
            setup_triangle([&v[0], &v[1], &v[2]], &vp, 0, [0; 4], &mut out);
            out
        };
        let mut wall = tri([(-1.0, -1.0), (3.0, -1.0), (-1.0, 3.0)], 0.5);
        wall.extend(tri([(-1.0, -1.0), (3.0, -1.0), (-1.0, 3.0)], 0.5));
        let mut depths = SampleDepths::new();
        depths.begin(100, 80, &wall, RasterBackend::active(), false);
        assert!(depths.hidden(&tri([(-0.5, -0.5), (0.5, -0.5), (0.0, 0.5)], 0.7)));
        assert!(!depths.hidden(&tri([(-0.5, -0.5), (0.5, -0.5), (0.0, 0.5)], 0.3)));
        assert!(depths.hidden(&[]));
        let half = tri([(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0)], 0.5);
        depths.begin(100, 80, &half, RasterBackend::active(), false);
        assert!(!depths.hidden(&tri([(0.5, 0.5), (0.9, 0.5), (0.9, 0.9)], 0.7)));
        assert_eq!(depths.stats().queries, 1);
    }
}
