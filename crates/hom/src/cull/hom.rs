//! The hierarchical occlusion map culler (Zhang et al. 1997): per frame,
//! select occluders → draw them into a [`HomBuffer`] (coverage, opacity
//! pyramid, depth estimation buffer or single Z plane) → traverse the BVH
//! front to back with frustum, depth and overlap tests.
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

use super::occluder_culler::{culler_buffer_options, sized, OccluderCulling};
use super::{Coherence, CullError, CullOutput, Culler, Hierarchy};
use crate::geom::View;
use crate::occluders::{OccluderConfig, OccluderDb};
use crate::occlusion::details::RectTest;
use crate::occlusion::details::{find_worst_hole, Pyramid};
use crate::occlusion::{HomBuffer, MapOptions};
use crate::scene::Scene;

pub use crate::occlusion::{DepthMode, Opacity};

/// Settings of the HOM culler.
#[derive(Clone, Debug, PartialEq)]
pub struct HomConfig {
    /// The occlusion map: resolution, opacity thresholds, depth test.
    pub map: MapOptions,
    /// Which objects occlude, and how each frame's are chosen (shared with HZB).
    pub occluders: OccluderConfig,
    /// How much of last frame's classification the traversal reuses (shared with HZB).
    pub coherence: Coherence,
    /// Rest (frustum culling only) while occlusion culling costs more than it
    /// saves, learnt from the frame times given to [`Culler::frame_done`] (shared with HZB).
    pub cost_model: bool,
    /// The hierarchy the occlusion traversal walks: the BVH (default) or a
    /// kD-tree with ropes, with or without visibility propagation (shared with HZB).
    pub hierarchy: Hierarchy,
}

impl Default for HomConfig {
    /// The default map and occluders, exact coherence, the cost model on, the BVH.
    fn default() -> Self {
        HomConfig {
            map: MapOptions::default(),
            occluders: OccluderConfig::default(),
            coherence: Coherence::default(),
            cost_model: true,
            hierarchy: Hierarchy::Bvh,
        }
    }
}

impl HomConfig {
    /// The default map with [`OccluderConfig::for_scene`]'s occluders.
    pub fn for_scene(scene: &Scene) -> HomConfig {
        HomConfig {
            occluders: OccluderConfig::for_scene(scene),
            ..HomConfig::default()
        }
    }
}

/// The HOM culler; see the module docs for its guarantee.
pub struct HomCuller {
    config: HomConfig,
    common: OccluderCulling,
    buffer: Option<HomBuffer>,
}

impl HomCuller {
    /// Builds the model database (BVH) and the occluder database for `scene`.
    pub fn new(scene: &Scene, config: HomConfig) -> HomCuller {
        HomCuller {
            common: OccluderCulling::new(
                scene,
                &config.occluders,
                config.coherence,
                config.cost_model,
                config.hierarchy,
            ),
            config,
            buffer: None,
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
        self.buffer.as_ref().map(|b| b.last_pyramid())
    }

    /// The last frame's occlusion buffer (for diagnostics: its depth and overlap tests alone).
    pub fn buffer_mut(&mut self) -> Option<&mut HomBuffer> {
        self.buffer.as_mut()
    }

    /// The current settings.
    pub fn config(&self) -> &HomConfig {
        &self.config
    }
}

impl Culler for HomCuller {
    fn name(&self) -> &'static str {
        "hom"
    }

    fn config(&self) -> Vec<(&'static str, String)> {
        let c = &self.config.map;
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

    fn cull(&mut self, scene: &Scene, view: &View, out: &mut CullOutput) -> Result<(), CullError> {
        if self.common.rest(scene, view, out)? {
            return Ok(()); // occlusion culling does not pay now: frustum culling only
        }
        // 1. Occluder selection (with last frame's worst hole when culling was poor).
        let hole_opacity = self.config.occluders.selection.hole_opacity;
        let last = &self.buffer;
        let frame = self.common.select(scene, view, out, || {
            last.as_ref()
                .and_then(|b| find_worst_hole(b.last_pyramid(), hole_opacity))
        })?;
        // 2. The occluders into the buffer: coverage, pyramid, depth.
        let map = &self.config.map;
        let buffer = sized(&mut self.buffer, view, |w, h| {
            HomBuffer::with_map(w, h, culler_buffer_options(), map.clone())
        });
        let common = &mut self.common;
        let drawn = common.draw(scene, &frame, buffer, out);

        // 3. Traversal: frustum → depth → overlap, front to back.
        common.traverse(scene, out, frame, drawn, |r| buffer.rect_is_occluded(r));
        let overlap = buffer.overlap_stats();
        out.count("overlap_pixels", overlap.pixels);
        out.count("levels_visited", overlap.levels);
        Ok(())
    }

    fn set_known_hidden(&mut self, scene: &Scene, hidden: &[u32]) {
        self.common.set_known_hidden(scene, hidden);
    }

    fn set_occluder_lod(&mut self, lod: Option<crate::lod::OccluderLod>) -> bool {
        self.common.set_occluder_lod(lod);
        true
    }

    fn box_hidden(&mut self, corners: &[glam::Vec3; 8]) -> bool {
        match (self.common.last_rect(corners), self.buffer.as_mut()) {
            (Some(r), Some(buffer)) => buffer.rect_is_occluded(&r),
            _ => false,
        }
    }

    fn frame_done(&mut self, frame_ms: Option<f64>) {
        self.common.feedback(frame_ms);
    }
}
