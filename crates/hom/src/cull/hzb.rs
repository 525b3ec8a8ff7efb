//! The hierarchical Z-buffer culler (Greene, Kass and Miller 1993), as the
//! variation the HOM paper discusses in section 7.2 (Zhang et al. 1997): the
//! same occluder selection and BVH traversal as [`super::HomCuller`], but the
//! occlusion test uses a Z-pyramid of the occluders' per-sample depth instead
//! of occlusion maps plus a depth estimation buffer, so a comparison of the
//! two isolates the representation.
//!
//! Per frame: select occluders → draw them into an [`HzBuffer`]: per-sample
//! depth in a tiled z-buffer (the renderer's own depth formula, `f32::INFINITY` where
//! uncovered; occluders hidden by nearer ones are rejected a tile or a block
//! at a time) with its pyramid of farthest depths above → traverse the BVH
//! front to back, culling a node or object when its screen rectangle is
//! behind the pyramid. (The row-major [`crate::depth::ZPyramid`] is the
//! reference the tiled buffer is tested against.)
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
//! (covered = finite depth), with HOM's default geometry, and searched
//! ([`crate::map::worst_hole_of_coverage`]).

use super::traversal::{culler_buffer_options, sized, OccluderCulling};
use super::{CullError, CullOutput, Culler, HomConfig};
use crate::depth::TiledZBuffer;
use crate::geom::View;
use crate::map::worst_hole_of_coverage;
use crate::occluders::{OccluderConfig, OccluderDb};
use crate::occlusion::{HzBuffer, MapOptions};
use crate::scene::Scene;

/// Settings of the HZB culler: HOM's occluder selection and database.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct HzbConfig {
    /// Which objects occlude, and how each frame's are chosen (shared with HOM).
    pub occluders: OccluderConfig,
}

impl HzbConfig {
    /// The occluder settings of a HOM configuration.
    pub fn from_hom(hom: &HomConfig) -> HzbConfig {
        HzbConfig {
            occluders: hom.occluders.clone(),
        }
    }

    /// [`OccluderConfig::for_scene`]'s occluders.
    pub fn for_scene(scene: &Scene) -> HzbConfig {
        HzbConfig {
            occluders: OccluderConfig::for_scene(scene),
        }
    }
}

/// The HZB culler; see the module docs for its guarantee.
pub struct HzbCuller {
    config: HzbConfig,
    common: OccluderCulling,
    buffer: Option<HzBuffer>,
}

impl HzbCuller {
    /// Builds the model database (BVH) and the occluder database for `scene`.
    pub fn new(scene: &Scene, config: HzbConfig) -> HzbCuller {
        HzbCuller {
            common: OccluderCulling::new(scene, &config.occluders),
            config,
            buffer: None,
        }
    }

    /// The occluder database.
    pub fn occluder_db(&self) -> &OccluderDb {
        &self.common.db
    }

    /// Mutable occluder database, to give occluders stand-in meshes.
    pub fn occluder_db_mut(&mut self) -> &mut OccluderDb {
        &mut self.common.db
    }

    /// The last frame's occluder depth and its pyramid.
    pub fn zbuffer(&self) -> Option<&TiledZBuffer> {
        self.buffer.as_ref().map(|b| b.last_zbuffer())
    }

    /// The current settings.
    pub fn config(&self) -> &HzbConfig {
        &self.config
    }
}

impl Culler for HzbCuller {
    fn name(&self) -> &'static str {
        "hzb"
    }

    fn config(&self) -> Vec<(&'static str, String)> {
        let depth = (
            "depth",
            "per-sample tiled z-buffer, pyramid of farthest depth".to_string(),
        );
        std::iter::once(depth).chain(self.common.describe()).collect()
    }

    fn cull(&mut self, scene: &Scene, view: &View, out: &mut CullOutput) -> Result<(), CullError> {
        // 1. Occluder selection (with last frame's worst hole when culling was poor).
        let hole_opacity = self.config.occluders.selection.hole_opacity;
        let last = &self.buffer;
        let frame = self.common.select(scene, view, out, || {
            let zb = last.as_ref()?.last_zbuffer();
            let mut bits = Vec::new();
            zb.coverage_bits(&mut bits);
            worst_hole_of_coverage(&bits, zb.width(), zb.height(), &MapOptions::default(), hole_opacity)
        })?;
        // 2. Occluder depth per output sample (the render also builds the pyramid above the tiles).
        let buffer = sized(&mut self.buffer, view, |w, h| {
            HzBuffer::new(w, h, culler_buffer_options())
        });
        let common = &mut self.common;
        let drawn = common.draw(scene, &frame, buffer, out);

        // 3. Traversal: frustum → Z-pyramid, front to back.
        common.traverse(scene, out, frame, drawn, |r| buffer.rect_is_occluded(r));
        Ok(())
    }

    fn frame_done(&mut self, frame_ms: Option<f64>) {
        self.common.feedback(frame_ms);
    }
}
