//! [`HomBuffer`]: hierarchical occlusion maps (Zhang et al. 1997, sections
//! 4–5) as an occlusion buffer — occluder coverage at the buffer's
//! resolution ([`CoverageRasterizer`], one bit per sample), the opacity
//! pyramid of exact coverage counts above it ([`Pyramid`]), and a depth test
//! (a depth estimation buffer filled from the rasterized samples by default;
//! the paper's box-based one or a single Z plane on request).
//!
//! A rectangle is occluded when it lies beyond the occluders' depth over it
//! ([`DepthEstimationBuffer::is_behind`], [`SingleZPlane::is_behind`]) and the
//! overlap test finds it opaque ([`rect_covered`]). With
//! [`Opacity::Conservative`] (the default) a map pixel is opaque only when
//! every sample under it is covered, so the answer is as conservative as
//! the HZB's; lower thresholds cull objects seen through small holes, on purpose.

use crate::geom::ScreenRect;
use crate::occlusion_map::{rect_covered, OverlapStats, Pyramid, Thresholds};
use crate::occlusion_map::{CoverageBuffer, CoverageRasterizer};
use crate::occlusion_map::{DepthEstimationBuffer, SingleZPlane};
use crate::raster::setup::Tri;
use crate::{occlusion_buffer, BufferOptions, Front, OcclusionError};

/// How opaque a map pixel must be to hide what lies behind it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Opacity {
    /// Threshold 1.0 at every level: never hides a visible pixel.
    Conservative,
    /// Base-level opacity threshold in `(0, 1]`, raised per level as O(k+1) = (3 + O(k)) / 4.
    Threshold(f32),
    /// Ignore holes of up to this many output samples per base map pixel.
    NegligibleHole(u32),
}

/// How the depth test is done.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DepthMode {
    /// A depth estimation buffer of this many cells (columns, rows), each
    /// holding a bound of the farthest depth of the occluders' *rasterized
    /// samples* in it (those each occluder covered first), lowered to an
    /// occluder's farthest depth over the cell where it covers the whole
    /// cell, gathered during the coverage raster (the default: from the
    /// samples themselves, so long occluders such as street facades do not
    /// push depth far away; `occlusion_map/depth_cells.rs` states the bound).
    Rasterized(u32, u32),
    /// The paper's depth estimation buffer (section 5.2.2): each occluder's
    /// (each `render_*` call's) screen rectangle written with its farthest depth.
    EstimationBuffer(u32, u32),
    /// One plane at the farthest occluder depth (section 5.2.1).
    SingleZPlane,
}

/// The occlusion map's settings.
#[derive(Clone, Debug, PartialEq)]
pub struct MapOptions {
    /// Base map resolution for the larger side (default 256): each map pixel
    /// covers `ceil(side / map_size)` samples a side (at most 64).
    pub map_size: u32,
    /// The pyramid is reduced until both sides are at most this (default 4).
    pub min_level_side: u32,
    /// Opacity thresholds.
    pub opacity: Opacity,
    /// Transparency threshold in `[0, 1)`: the overlap test stops at a pixel this transparent or more.
    pub transparency: f32,
    /// Depth test.
    pub depth: DepthMode,
}

impl Default for MapOptions {
    fn default() -> Self {
        MapOptions {
            map_size: 256,
            min_level_side: 4,
            opacity: Opacity::Conservative,
            transparency: 0.0,
            depth: DepthMode::Rasterized(64, 64),
        }
    }
}

impl MapOptions {
    /// Samples per side of a base map pixel at `width` × `height`: the base
    /// is at most `map_size` pixels a side (block at most 64).
    pub fn map_block(&self, width: u32, height: u32) -> u32 {
        width.max(height).div_ceil(self.map_size.max(1)).clamp(1, 64)
    }

    /// An empty occlusion pyramid of this map geometry over `width` × `height`.
    pub fn new_pyramid(&self, width: u32, height: u32) -> Pyramid {
        Pyramid::new(width, height, self.map_block(width, height), self.min_level_side)
    }
}

/// The depth half of a [`HomBuffer`].
#[derive(Clone, Debug)]
enum Depth {
    /// Cells filled from rasterized samples (`DepthMode::Rasterized`) or from
    /// occluder rectangles (`DepthMode::EstimationBuffer`).
    Buffer(DepthEstimationBuffer),
    Plane(SingleZPlane),
}

/// The hierarchical occlusion map buffer; see the [crate docs](crate).
#[derive(Clone, Debug)]
pub struct HomBuffer {
    front: Front,
    map: MapOptions,
    raster: CoverageRasterizer,
    coverage: CoverageBuffer,
    pyramid: Pyramid,
    thresholds: Thresholds,
    depth: Depth,
    overlap: OverlapStats,
    /// Cleared since the last draw: the representation still holds the old
    /// frame until the next draw or settle empties it.
    cleared: bool,
    /// Draws since the last clear (the rasterizer keeps the last one's triangles).
    draws: u32,
}

impl HomBuffer {
    /// An empty `width` × `height` buffer (each side 1..=16384) with the default map.
    pub fn new(width: u32, height: u32, options: BufferOptions) -> Result<HomBuffer, OcclusionError> {
        HomBuffer::with_map(width, height, options, MapOptions::default())
    }

    /// An empty buffer with the given map settings.
    pub fn with_map(
        width: u32,
        height: u32,
        options: BufferOptions,
        map: MapOptions,
    ) -> Result<HomBuffer, OcclusionError> {
        let front = Front::new(width, height, options)?;
        let pyramid = map.new_pyramid(width, height);
        let mut b = HomBuffer {
            raster: CoverageRasterizer::with_backend(front.backend),
            thresholds: thresholds(&map, &pyramid),
            depth: new_depth(&map, width, height),
            front,
            map,
            coverage: CoverageBuffer::default(),
            pyramid,
            overlap: OverlapStats::default(),
            cleared: true,
            draws: 0,
        };
        b.settle();
        Ok(b)
    }

    /// The map settings.
    pub fn map_options(&self) -> &MapOptions {
        &self.map
    }

    /// The occlusion pyramid of what is drawn so far (draws what is queued first).
    pub fn pyramid(&mut self) -> &Pyramid {
        <Self as crate::OcclusionBuffer>::flush(self);
        &self.pyramid
    }

    /// The depth estimation cells (row-major, `f32::INFINITY` where nothing is
    /// drawn) and their count across and down, unless the depth mode is a
    /// single Z plane. Draws what is queued first.
    pub fn depth_cells(&mut self) -> Option<(&[f32], (u32, u32))> {
        <Self as crate::OcclusionBuffer>::flush(self);
        match &self.depth {
            Depth::Buffer(b) => Some((b.cells(), b.size())),
            Depth::Plane(_) => None,
        }
    }

    /// The coverage of what is drawn so far, one bit per sample (draws what is queued first).
    pub fn coverage(&mut self) -> &CoverageBuffer {
        <Self as crate::OcclusionBuffer>::flush(self);
        &self.coverage
    }

    /// Map pixels read and levels visited by the overlap tests since the last clear.
    pub fn overlap_stats(&self) -> OverlapStats {
        self.overlap
    }

    /// The pyramid as it stands, without drawing what is queued (for the
    /// cullers' hole search of the last frame).
    pub fn last_pyramid(&self) -> &Pyramid {
        &self.pyramid
    }

    /// The occluder triangles drawn since the last clear, as they were set
    /// up (the renderer's rule, or the inner rule where a stand-in or
    /// [`crate::Sampling::Conservative`] asked for it), when they were drawn in one
    /// flush; `None` after several (the rasterizer keeps only the last).
    /// Draws what is queued first.
    pub fn drawn_triangles(&mut self) -> Option<impl Iterator<Item = &Tri>> {
        <Self as crate::OcclusionBuffer>::flush(self);
        match self.draws {
            0 => Some(self.raster.set_up_triangles().take(0)),
            1 => Some(self.raster.set_up_triangles().take(usize::MAX)),
            _ => None,
        }
    }

    /// The depth test alone, for diagnostics (`why_not_culled`); draws what is queued first.
    pub fn depth_is_behind(&mut self, r: &ScreenRect) -> bool {
        <Self as crate::OcclusionBuffer>::flush(self);
        self.depth_behind(r)
    }

    /// The overlap test alone, for diagnostics; draws what is queued first.
    pub fn rect_is_opaque(&mut self, r: &ScreenRect) -> bool {
        <Self as crate::OcclusionBuffer>::flush(self);
        rect_covered(&self.pyramid, &self.thresholds, r, &mut self.overlap)
    }

    fn depth_behind(&self, r: &ScreenRect) -> bool {
        match &self.depth {
            Depth::Buffer(b) => b.is_behind(r),
            Depth::Plane(p) => p.is_behind(r),
        }
    }

    /// Empties the buffer lazily: the work is done by the first draw (or
    /// [`HomBuffer::settle`]), so a cleared frame builds its pyramid once.
    fn reset(&mut self) {
        self.cleared = true;
        self.draws = 0;
        self.overlap = OverlapStats::default();
    }

    /// Makes the representation empty if it was cleared (the pyramid is left
    /// to the caller; with `by_bands`, the coverage and rasterized depth cells
    /// to the raster's bands, which empty their own rows first); returns
    /// whether it was cleared.
    fn empty_if_cleared(&mut self, by_bands: bool) -> bool {
        if !self.cleared {
            return false;
        }
        let (w, h) = (self.front.width, self.front.height);
        if self.pyramid.viewport() != (w, h) {
            self.pyramid = self.map.new_pyramid(w, h);
            self.thresholds = thresholds(&self.map, &self.pyramid);
            self.depth = new_depth(&self.map, w, h);
        }
        let bands_empty_depth = by_bands && matches!(self.map.depth, DepthMode::Rasterized(..));
        if by_bands {
            self.coverage.set_size(w, h);
        } else {
            self.coverage.reset(w, h);
        }
        match &mut self.depth {
            Depth::Buffer(_) if bands_empty_depth => {}
            Depth::Buffer(b) => b.clear(),
            Depth::Plane(p) => *p = SingleZPlane::default(),
        }
        true
    }

    /// After a flush: a buffer cleared and never drawn since gets its empty pyramid.
    #[inline]
    fn settle(&mut self) {
        if self.cleared {
            self.empty_if_cleared(false);
            self.pyramid
                .build_from_coverage(self.coverage.bits(), self.coverage.words_per_row());
            self.cleared = false;
        }
    }

    /// Sets the queue up and draws it in one pass
    /// ([`CoverageRasterizer::set_up_and_rasterize`]).
    fn draw_queue(&mut self) {
        let empty_first = self.empty_if_cleared(true);
        self.cleared = false;
        self.draws += 1;
        let gather = match (&mut self.depth, self.map.depth) {
            (Depth::Buffer(b), DepthMode::Rasterized(..)) => Some(b),
            _ => None,
        };
        let s = self.raster.set_up_and_rasterize(
            &self.front.queue,
            self.front.queue_setup(),
            &mut self.coverage,
            gather,
            Some(&mut self.pyramid),
            empty_first,
        );
        let stats = &mut self.front.stats;
        stats.triangles_drawn += s.triangles as u64;
        stats.setup_ms += s.set_up_ms;
        stats.raster_ms += s.total_ms - s.set_up_ms;
        if !matches!(self.map.depth, DepthMode::Rasterized(..)) {
            for r in occluder_rects(self.raster.set_up_triangles()) {
                match &mut self.depth {
                    Depth::Buffer(b) => b.insert_occluder(&r),
                    Depth::Plane(p) => p.insert_occluder(&r),
                }
            }
        }
    }

    fn is_behind(&mut self, r: &ScreenRect) -> bool {
        let mut overlap = std::mem::take(&mut self.overlap);
        let behind = self.behind(r, &mut overlap);
        self.overlap = overlap;
        behind
    }

    /// [`Self::is_behind`] through `&self` ([`crate::SharedBuffer`]): the
    /// same answer, its overlap tests not counted.
    fn is_behind_shared(&self, r: &ScreenRect) -> bool {
        self.behind(r, &mut OverlapStats::default())
    }

    /// Whether `r` is hidden: behind the depth estimate and covered by the map.
    fn behind(&self, r: &ScreenRect, overlap: &mut OverlapStats) -> bool {
        self.depth_behind(r) && rect_covered(&self.pyramid, &self.thresholds, r, overlap)
    }
}

fn thresholds(map: &MapOptions, p: &Pyramid) -> Thresholds {
    match map.opacity {
        Opacity::Conservative => Thresholds::conservative(p, map.transparency),
        Opacity::Threshold(o) => Thresholds::approximate(p, o, map.transparency),
        Opacity::NegligibleHole(n) => Thresholds::negligible_hole(p, n, map.transparency),
    }
}

fn new_depth(map: &MapOptions, width: u32, height: u32) -> Depth {
    match map.depth {
        DepthMode::EstimationBuffer(c, r) | DepthMode::Rasterized(c, r) => {
            Depth::Buffer(DepthEstimationBuffer::new(width, height, c.max(1), r.max(1)))
        }
        DepthMode::SingleZPlane => Depth::Plane(SingleZPlane::default()),
    }
}

/// Each submission's screen rectangle (the union of its triangles' pixel
/// boxes) with its farthest depth (the farthest of each triangle's plane over
/// its box): the occluder rectangles of the paper's depth estimation buffer.
fn occluder_rects<'a>(tris: impl IntoIterator<Item = &'a Tri>) -> Vec<ScreenRect> {
    let mut rects: Vec<(u32, ScreenRect)> = Vec::new();
    for t in tris {
        let (w, h) = (f32::from(t.x1 - t.x0 - 1), f32::from(t.y1 - t.y0 - 1));
        let r = ScreenRect {
            x0: u32::from(t.x0),
            y0: u32::from(t.y0),
            x1: u32::from(t.x1),
            y1: u32::from(t.y1),
            z_near: 0.0,
            z_far: t.zref + (t.dzdx * w).max(0.0) + (t.dzdy * h).max(0.0),
        };
        // Set-up triangles come grouped by submission (`item`), in order.
        match rects.last_mut() {
            Some((item, last)) if *item == t.item => {
                last.x0 = last.x0.min(r.x0);
                last.y0 = last.y0.min(r.y0);
                last.x1 = last.x1.max(r.x1);
                last.y1 = last.y1.max(r.y1);
                last.z_far = last.z_far.max(r.z_far);
            }
            _ => rects.push((t.item, r)),
        }
    }
    rects.into_iter().map(|(_, r)| r).collect()
}

occlusion_buffer!(HomBuffer, draw_queue);
