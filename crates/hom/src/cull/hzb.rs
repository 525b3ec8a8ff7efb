//! The hierarchical Z-buffer culler (Greene, Kass and Miller 1993), as the
//! variation the HOM paper discusses in section 7.2 (Zhang et al. 1997): the
//! same occluder selection and BVH traversal as [`super::HomCuller`], but the
//! occlusion test uses a Z-pyramid of the occluders' per-sample depth instead
//! of occlusion maps plus a depth estimation buffer, so a comparison of the
//! two isolates the representation.
//!
//! Per frame: select occluders → rasterize their per-sample depth (the
//! renderer's own depth formula, `f32::INFINITY` where uncovered) → build the
//! [`ZPyramid`] (farthest depth per texel) → traverse the BVH front to back,
//! culling a node or object when its screen rectangle is behind the pyramid.
//!
//! # Conservative
//! A box is culled only when every sample of its rectangle holds an occluder
//! triangle nearer than the box's nearest depth (by [`crate::depth::DEPTH_MARGIN`]),
//! with the renderer's sampling and depth; boxes straddling the near plane are
//! never culled. The same caveats as HOM's apply (same resolution and sampling
//! as the final image, stand-ins contained in their objects, opaque occluders).
//!
//! Hole filling (occluder selection's feedback) needs the opacity of screen
//! regions, which the Z-pyramid does not hold: when the selector asks for the
//! worst hole, an opacity pyramid is built from the last frame's depth
//! (covered = finite depth), with HOM's default geometry, and searched with
//! [`super::hom::find_worst_hole`].

use super::frustum::refit_if_dynamic;
use super::hom::find_worst_hole;
use super::traversal::{count_occluders, occluded_share, Traversal};
use super::{CullError, CullOutput, Culler, HomConfig};
use crate::depth::{ZPyramid, ZTestStats};
use crate::geom::{Aabb, Camera, Frustum};
use crate::map::Pyramid;
use crate::occluders::{Hole, OccluderDb, OccluderDbConfig, OccluderSelector, SelectionConfig};
use crate::raster::OccluderRasterizer;
use crate::scene::Scene;
use crate::spatial::{Bvh, BvhConfig};

/// Settings of the HZB culler: HOM's occluder selection and database.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct HzbConfig {
    /// Occluder selection.
    pub selection: SelectionConfig,
    /// Occluder database preprocessing.
    pub occluder_db: OccluderDbConfig,
}

impl HzbConfig {
    /// The selection and occluder database settings of a HOM configuration.
    pub fn from_hom(hom: &HomConfig) -> HzbConfig {
        HzbConfig {
            selection: hom.selection.clone(),
            occluder_db: hom.occluder_db.clone(),
        }
    }

    /// [`HomConfig::for_scene`]'s selection settings.
    pub fn for_scene(scene: &Scene) -> HzbConfig {
        HzbConfig::from_hom(&HomConfig::for_scene(scene))
    }
}

/// The HZB culler; see the module docs for its guarantee.
pub struct HzbCuller {
    config: HzbConfig,
    bvh: Bvh,
    boxes: Vec<Aabb>,
    db: OccluderDb,
    selector: OccluderSelector,
    raster: OccluderRasterizer,
    depth: Vec<f32>,
    viewport: (u32, u32),
    zpyramid: ZPyramid,
    is_occluder: Vec<bool>,
    culled_pct: f32,
}

impl HzbCuller {
    /// Builds the model database (BVH) and the occluder database for `scene`.
    pub fn new(scene: &Scene, config: HzbConfig) -> HzbCuller {
        let boxes: Vec<Aabb> = scene.objects().iter().map(|o| o.aabb).collect();
        let bvh = Bvh::build(&boxes, &BvhConfig::default());
        let db = OccluderDb::build(scene, &config.occluder_db);
        HzbCuller {
            selector: OccluderSelector::new(config.selection.clone()),
            config,
            bvh,
            boxes,
            db,
            raster: OccluderRasterizer::default(),
            depth: Vec::new(),
            viewport: (0, 0),
            zpyramid: ZPyramid::default(),
            is_occluder: vec![false; scene.objects().len()],
            culled_pct: 0.0,
        }
    }

    /// The occluder database.
    pub fn occluder_db(&self) -> &OccluderDb {
        &self.db
    }

    /// Mutable occluder database, to give occluders stand-in meshes.
    pub fn occluder_db_mut(&mut self) -> &mut OccluderDb {
        &mut self.db
    }

    /// The last frame's Z-pyramid.
    pub fn zpyramid(&self) -> &ZPyramid {
        &self.zpyramid
    }

    /// The current settings.
    pub fn config(&self) -> &HzbConfig {
        &self.config
    }

    /// The worst hole of the last frame's occluder coverage (see the module docs).
    fn worst_hole(&self) -> Option<Hole> {
        let (w, h) = self.viewport;
        if w == 0 || h == 0 || self.depth.len() != (w * h) as usize {
            return None;
        }
        let defaults = HomConfig::default();
        let block = w.max(h).div_ceil(defaults.map_size.max(1)).clamp(1, 64);
        let wpr = (w as usize).div_ceil(64);
        let mut bits = vec![0u64; wpr * h as usize];
        for (y, row) in self.depth.chunks(w as usize).enumerate() {
            for (x, &d) in row.iter().enumerate() {
                if d.is_finite() {
                    bits[y * wpr + x / 64] |= 1 << (x % 64);
                }
            }
        }
        let mut p = Pyramid::new(w, h, block, defaults.min_level_side);
        p.build_from_coverage(&bits, wpr);
        find_worst_hole(&p, self.config.selection.hole_opacity)
    }
}

impl Culler for HzbCuller {
    fn name(&self) -> &'static str {
        "hzb"
    }

    fn config(&self) -> Vec<(&'static str, String)> {
        let c = &self.config;
        vec![
            ("depth", "per-sample Z-pyramid (max of 2x2)".to_string()),
            ("selection", format!("{:?}", c.selection.mode)),
            ("budget", c.selection.budget.to_string()),
            ("adaptive_budget", c.selection.adaptive.to_string()),
            ("hole_filling", c.selection.hole_filling.to_string()),
            ("occluders", self.db.report()),
        ]
    }

    fn cull(&mut self, scene: &Scene, camera: &Camera, out: &mut CullOutput) -> Result<(), CullError> {
        camera.validate()?;
        out.clear();
        {
            let Self { bvh, boxes, .. } = self;
            out.time("refit", || refit_if_dynamic(scene, bvh, boxes))?;
        }
        let view_proj = camera.view_proj();
        let frustum = Frustum::from_view_proj(&view_proj).expect("a validated camera has a frustum");
        let (w, h) = (camera.width, camera.height);

        // 1. Occluder selection (with last frame's worst hole when culling was poor).
        let hole = if self.selector.wants_hole() {
            self.worst_hole()
        } else {
            None
        };
        let mut occluders = std::mem::take(&mut out.occluders);
        let sel = out.time("selection", || {
            self.selector
                .select(&self.db, scene, camera, &frustum, hole.as_ref(), &mut occluders)
        });

        // 2. Occluder depth per output sample.
        self.viewport = (w, h);
        let Self {
            raster,
            depth,
            db,
            zpyramid,
            bvh,
            is_occluder,
            boxes,
            ..
        } = self;
        let drawn = out.time("raster", || {
            raster.rasterize_depth(depth, scene, db, &occluders, camera)
        });

        // 3. The Z-pyramid.
        out.time("zpyramid", || zpyramid.build(w, h, depth));

        // 4. Traversal: frustum → Z-pyramid, front to back.
        let mut visible = std::mem::take(&mut out.visible);
        let mut occluded = std::mem::take(&mut out.occluded);
        let mut stats = ZTestStats::default();
        let zpyramid = &*zpyramid;
        let traversal = Traversal {
            scene,
            bvh,
            boxes,
            frustum: &frustum,
            view_proj,
            width: w,
            height: h,
            eye: camera.eye,
            occluders: &occluders,
        };
        let box_tests = out.time("traversal", || {
            traversal.run(
                is_occluder,
                |r| zpyramid.is_behind(r, &mut stats),
                &mut visible,
                &mut occluded,
            )
        });
        self.culled_pct = occluded_share(scene, &visible, &occluded);
        out.visible = visible;
        out.occluded = occluded;
        out.occluders = occluders;
        out.count("box_tests", box_tests);
        out.count("zpyramid_texels", stats.texels);
        out.count("zpyramid_descents", stats.descents);
        count_occluders(out, &sel, drawn);
        Ok(())
    }

    fn frame_done(&mut self, frame_ms: Option<f64>) {
        self.selector.feedback(self.culled_pct, frame_ms);
    }
}
