//! The hierarchical occlusion map culler (Zhang et al. 1997): per frame,
//! select occluders → rasterize their coverage → build the opacity pyramid and
//! the depth estimation buffer (or single Z plane) → traverse the BVH front to
//! back with frustum, depth and overlap tests.
//!
//! # Conservative by default
//! With opacity threshold 1.0 (the default) a map pixel is opaque only when
//! every output-resolution sample under it is covered by occluder triangles,
//! rasterized with the reference renderer's exact sampling rule (pixel
//! centres, top-left fill, the same fixed-point snapping). An object is culled
//! only when every map pixel under its screen rectangle is opaque *and* its
//! nearest depth lies beyond the farthest occluder depth over that rectangle;
//! then every sample it could cover is covered by a nearer occluder triangle,
//! so it owns no pixel of the final image.
//!
//! What breaks the guarantee: an opacity threshold below 1.0 (approximate
//! culling: it hides objects seen through small holes, on purpose); rendering
//! the final image at another resolution or with another sampling rule than
//! the camera the culler was given; occluder stand-in meshes that are not
//! contained in the object they stand for; and transparent occluders.

use super::traversal::OccluderCulling;
use super::{CullError, CullOutput, Culler};
use crate::depth::{DepthEstimationBuffer, SingleZPlane};
use crate::geom::{project_box_clipped, Camera, ScreenRect};
use crate::map::{rect_covered, OverlapStats, Pyramid, Thresholds};
use crate::occluders::{Hole, OccluderDb, OccluderDbConfig, SelectionConfig};
use crate::raster::{CoverageBuffer, OccluderRasterizer};
use crate::scene::Scene;

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
    /// holding the farthest depth of the occluders' *rasterized samples* in it,
    /// gathered during the coverage raster (the default: exact per sample, so
    /// long occluders such as street facades do not push depth far away).
    Rasterized(u32, u32),
    /// The paper's depth estimation buffer (section 5.2.2): each occluder's
    /// screen rectangle written with its box's farthest depth.
    EstimationBuffer(u32, u32),
    /// One plane at the farthest occluder depth (section 5.2.1).
    SingleZPlane,
}

/// Settings of the HOM culler.
#[derive(Clone, Debug, PartialEq)]
pub struct HomConfig {
    /// Base occlusion map resolution for the larger viewport side (default 256):
    /// each map pixel covers `ceil(side / map_size)` output samples a side.
    pub map_size: u32,
    /// The pyramid is reduced until both sides are at most this (default 4).
    pub min_level_side: u32,
    /// Opacity thresholds.
    pub opacity: Opacity,
    /// Transparency threshold in `[0, 1)`: the overlap test stops at a pixel this transparent or more.
    pub transparency: f32,
    /// Depth test.
    pub depth: DepthMode,
    /// Occluder selection.
    pub selection: SelectionConfig,
    /// Occluder database preprocessing.
    pub occluder_db: OccluderDbConfig,
}

impl Default for HomConfig {
    fn default() -> Self {
        HomConfig {
            map_size: 256,
            min_level_side: 4,
            opacity: Opacity::Conservative,
            transparency: 0.0,
            depth: DepthMode::Rasterized(64, 64),
            selection: SelectionConfig::default(),
            occluder_db: OccluderDbConfig::default(),
        }
    }
}

enum Depth {
    Buffer(DepthEstimationBuffer),
    Plane(SingleZPlane),
}

impl Depth {
    fn is_behind(&self, r: &ScreenRect) -> bool {
        match self {
            Depth::Buffer(b) => b.is_behind(r),
            Depth::Plane(p) => p.is_behind(r),
        }
    }
}

impl HomConfig {
    /// The default settings with the polygon budget L scaled to the scene: 1 %
    /// of its triangles, at least 3,000 and at most 20,000. (Sweeps on the
    /// built-in scenes: the best fixed L ranged from 3k on the city to 25k on
    /// the machine room, roughly following scene size.)
    pub fn for_scene(scene: &Scene) -> HomConfig {
        let mut c = HomConfig::default();
        c.selection.budget = (scene.triangle_count() / 100).clamp(3_000, 20_000) as u32;
        c
    }

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

/// The HOM culler; see the module docs for its guarantee.
pub struct HomCuller {
    config: HomConfig,
    common: OccluderCulling,
    raster: OccluderRasterizer,
    coverage: CoverageBuffer,
    pyramid: Option<Pyramid>,
    thresholds: Option<Thresholds>,
    depth: Option<Depth>,
}

impl HomCuller {
    /// Builds the model database (BVH) and the occluder database for `scene`.
    pub fn new(scene: &Scene, config: HomConfig) -> HomCuller {
        HomCuller {
            common: OccluderCulling::new(scene, &config.selection, &config.occluder_db),
            config,
            raster: OccluderRasterizer::default(),
            coverage: CoverageBuffer::default(),
            pyramid: None,
            thresholds: None,
            depth: None,
        }
    }

    /// The occluder database (with its report of what was kept and why).
    pub fn occluder_db(&self) -> &OccluderDb {
        &self.common.db
    }

    /// Mutable occluder database, to give occluders stand-in meshes.
    pub fn occluder_db_mut(&mut self) -> &mut OccluderDb {
        &mut self.common.db
    }

    /// The last frame's occlusion pyramid (for pictures).
    pub fn pyramid(&self) -> Option<&Pyramid> {
        self.pyramid.as_ref()
    }

    /// The last frame's depth estimation buffer, when that depth mode is used.
    pub fn depth_buffer(&self) -> Option<&DepthEstimationBuffer> {
        match &self.depth {
            Some(Depth::Buffer(b)) => Some(b),
            _ => None,
        }
    }

    /// The current settings.
    pub fn config(&self) -> &HomConfig {
        &self.config
    }

    fn ensure_buffers(&mut self, camera: &Camera) {
        let (w, h) = (camera.width, camera.height);
        let block = self.config.map_block(w, h);
        let fits = self
            .pyramid
            .as_ref()
            .is_some_and(|p| p.viewport() == (w, h) && p.block() == block);
        if !fits {
            let p = self.config.new_pyramid(w, h);
            self.thresholds = Some(match self.config.opacity {
                Opacity::Conservative => Thresholds::conservative(&p, self.config.transparency),
                Opacity::Threshold(o) => Thresholds::approximate(&p, o, self.config.transparency),
                Opacity::NegligibleHole(n) => Thresholds::negligible_hole(&p, n, self.config.transparency),
            });
            self.pyramid = Some(p);
        }
        let depth_fits = match (&self.depth, self.config.depth) {
            (Some(Depth::Buffer(_)), DepthMode::EstimationBuffer(..) | DepthMode::Rasterized(..)) => fits,
            (Some(Depth::Plane(_)), DepthMode::SingleZPlane) => true,
            _ => false,
        };
        if !depth_fits {
            self.depth = Some(match self.config.depth {
                DepthMode::EstimationBuffer(c, r) | DepthMode::Rasterized(c, r) => {
                    Depth::Buffer(DepthEstimationBuffer::new(w, h, c.max(1), r.max(1)))
                }
                DepthMode::SingleZPlane => Depth::Plane(SingleZPlane::default()),
            });
        }
    }
}

/// The coarsest-level region of lowest opacity below `hole_opacity`, grown
/// greedily over neighbouring hole pixels, as an NDC rectangle.
pub fn find_worst_hole(p: &Pyramid, hole_opacity: f32) -> Option<Hole> {
    let top = p.levels().last()?;
    let hole = |x: u32, y: u32| top.opacity(x, y) < hole_opacity;
    let (mut sx, mut sy, mut worst) = (0, 0, f32::MAX);
    for y in 0..top.height {
        for x in 0..top.width {
            let o = top.opacity(x, y);
            if hole(x, y) && o < worst {
                (sx, sy, worst) = (x, y, o);
            }
        }
    }
    if worst == f32::MAX {
        return None;
    }
    // Grow right, then down while every pixel of the new row is a hole.
    let mut x1 = sx + 1;
    while x1 < top.width && hole(x1, sy) {
        x1 += 1;
    }
    let mut x0 = sx;
    while x0 > 0 && hole(x0 - 1, sy) {
        x0 -= 1;
    }
    let mut y1 = sy + 1;
    while y1 < top.height && (x0..x1).all(|x| hole(x, y1)) {
        y1 += 1;
    }
    let mut y0 = sy;
    while y0 > 0 && (x0..x1).all(|x| hole(x, y0 - 1)) {
        y0 -= 1;
    }
    let mut sum = 0.0;
    for y in y0..y1 {
        for x in x0..x1 {
            sum += top.opacity(x, y);
        }
    }
    let n = ((x1 - x0) * (y1 - y0)) as f32;
    let size = (p.block() << (p.levels().len() - 1)) as f32;
    let (w, h) = (p.viewport().0 as f32, p.viewport().1 as f32);
    let ndc_x = |px: f32| (px * size / w).min(1.0) * 2.0 - 1.0;
    let ndc_y = |py: f32| 1.0 - (py * size / h).min(1.0) * 2.0;
    Some(Hole {
        x: (ndc_x(x0 as f32), ndc_x(x1 as f32)),
        y: (ndc_y(y1 as f32), ndc_y(y0 as f32)),
        opacity: sum / n,
    })
}

impl Culler for HomCuller {
    fn name(&self) -> &'static str {
        "hom"
    }

    fn config(&self) -> Vec<(&'static str, String)> {
        let c = &self.config;
        [
            ("map_size", c.map_size.to_string()),
            ("min_level_side", c.min_level_side.to_string()),
            ("opacity", format!("{:?}", c.opacity)),
            ("transparency", c.transparency.to_string()),
            ("depth", format!("{:?}", c.depth)),
        ]
        .into_iter()
        .chain(self.common.describe())
        .collect()
    }

    fn cull(&mut self, scene: &Scene, camera: &Camera, out: &mut CullOutput) -> Result<(), CullError> {
        // 1. Occluder selection (with last frame's worst hole when culling was poor).
        let hole_opacity = self.config.selection.hole_opacity;
        let last = &self.pyramid;
        let frame = self.common.select(scene, camera, out, || {
            last.as_ref().and_then(|p| find_worst_hole(p, hole_opacity))
        })?;
        self.ensure_buffers(camera);
        let (w, h, view_proj) = (camera.width, camera.height, frame.view_proj);
        let occluders = &frame.occluders;

        // 2. Occluder coverage at output resolution.
        let depth_mode = self.config.depth;
        let Self {
            raster,
            coverage,
            common,
            pyramid,
            depth,
            thresholds,
            ..
        } = self;
        let depth = depth.as_mut().expect("ensured");
        let rasterized_depth = matches!(depth_mode, DepthMode::Rasterized(..));
        let drawn = out.time("raster", || {
            let gather = match depth {
                Depth::Buffer(b) if rasterized_depth => Some(b),
                _ => None,
            };
            raster.rasterize(coverage, scene, &common.db, occluders, camera, gather)
        });

        // 3. The pyramid.
        let pyramid = pyramid.as_mut().expect("ensured");
        out.time("pyramid", || {
            pyramid.build_from_coverage(coverage.bits(), coverage.words_per_row())
        });

        // 4. Depth of the occluders from their boxes (the rasterized buffer is already filled).
        if !rasterized_depth {
            out.time("depth", || {
                match depth {
                    Depth::Buffer(b) => b.clear(),
                    Depth::Plane(p) => *p = SingleZPlane::default(),
                }
                for &id in occluders {
                    let o = scene.object(id);
                    let corners = if o.is_dynamic() {
                        o.obb.corners()
                    } else {
                        o.aabb.corners()
                    };
                    if let Some(r) = project_box_clipped(&corners, &view_proj, w, h) {
                        match depth {
                            Depth::Buffer(b) => b.insert_occluder(&r),
                            Depth::Plane(p) => p.insert_occluder(&r),
                        }
                    }
                }
            });
        }

        // 5. Traversal: frustum → depth → overlap, front to back.
        let thresholds = thresholds.as_ref().expect("ensured");
        let mut overlap = OverlapStats::default();
        common.traverse(scene, camera, out, frame, drawn, |r| {
            depth.is_behind(r) && rect_covered(pyramid, thresholds, r, &mut overlap)
        });
        out.count("overlap_pixels", overlap.pixels);
        out.count("levels_visited", overlap.levels);
        Ok(())
    }

    fn frame_done(&mut self, frame_ms: Option<f64>) {
        self.common.feedback(frame_ms);
    }
}
