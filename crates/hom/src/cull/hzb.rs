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
//! behind the pyramid. (The row-major [`crate::occlusion::details::ZPyramid`] is the
//! reference the tiled buffer is tested against.)
//!
//! # Conservative
//! A box is culled only when every sample of its rectangle holds an occluder
//! triangle nearer than the box's nearest depth (by [`crate::occlusion::details::DEPTH_MARGIN`]),
//! with the renderer's sampling and depth; boxes straddling the near plane are
//! never culled. The same caveats as HOM's apply (same resolution and sampling
//! as the final image, stand-ins contained in their objects, opaque occluders).
//!
//! # Two depth representations
//! [`ZDepth::PerSample`] (the default) draws into an [`HzBuffer`]: the
//! renderer's exact depth at every sample. [`ZDepth::Masked`] draws into a
//! [`MaskedBuffer`] (masked software occlusion culling, Hasselgren et al.
//! 2016): a coverage mask and two conservative depth layers per 32×8 tile,
//! far cheaper to draw, coarser to test. Both are conservative; the culler
//! reports itself as `hzb` or `masked`.
//!
//! Hole filling (occluder selection's feedback) needs the opacity of screen
//! regions, which the Z-pyramid does not hold: when the selector asks for the
//! worst hole, an opacity pyramid is built from the last frame's depth
//! (covered = finite depth), with HOM's default geometry, and searched
//! ([`crate::occlusion::details::worst_hole_of_coverage`]).

use super::occluder_culler::{culler_buffer_options, sized, OccluderCulling};
use super::traversal::Selected;
use super::{Coherence, CullError, CullOutput, Culler, Hierarchy, HomConfig};
use crate::geom::View;
use crate::occluders::{OccluderConfig, OccluderDb};
use crate::occlusion::details::worst_hole_of_coverage;
use crate::occlusion::details::RectTest;
use crate::occlusion::details::TiledZBuffer;
use crate::occlusion::{HzBuffer, MapOptions, MaskedBuffer, OcclusionBuffer};
use crate::scene::Scene;

/// Which depth the HZB culler keeps of its occluders.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ZDepth {
    /// Exact per-sample depth ([`HzBuffer`]).
    #[default]
    PerSample,
    /// Coverage masks and two depth layers per 32×8 tile ([`MaskedBuffer`]).
    Masked,
}

/// Settings of the HZB culler: HOM's occluder selection and database, and the depth representation.
#[derive(Clone, Debug, PartialEq)]
pub struct HzbConfig {
    /// Which objects occlude, and how each frame's are chosen (shared with HOM).
    pub occluders: OccluderConfig,
    /// The occluders' depth: per sample or masked.
    pub depth: ZDepth,
    /// How much of last frame's classification the traversal reuses (shared with HOM).
    pub coherence: Coherence,
    /// Rest while occlusion culling does not pay (shared with HOM; see [`HomConfig::cost_model`]).
    pub cost_model: bool,
    /// The hierarchy the occlusion traversal walks (shared with HOM; see [`HomConfig::hierarchy`]).
    pub hierarchy: Hierarchy,
}

impl Default for HzbConfig {
    /// Default occluders, per-sample depth, exact coherence, the cost model on.
    fn default() -> Self {
        HzbConfig::from_hom(&HomConfig::default())
    }
}

impl HzbConfig {
    /// The occluder settings of a HOM configuration, per-sample depth.
    pub fn from_hom(hom: &HomConfig) -> HzbConfig {
        HzbConfig {
            occluders: hom.occluders.clone(),
            depth: ZDepth::PerSample,
            coherence: hom.coherence,
            cost_model: hom.cost_model,
            hierarchy: hom.hierarchy,
        }
    }

    /// [`OccluderConfig::for_scene`]'s occluders, per-sample depth.
    pub fn for_scene(scene: &Scene) -> HzbConfig {
        HzbConfig::from_hom(&HomConfig::for_scene(scene))
    }
}

/// The HZB culler's buffer, of the configured representation.
enum Buffer {
    PerSample(Option<HzBuffer>),
    Masked(Option<MaskedBuffer>),
}

/// The HZB culler; see the module docs for its guarantee.
pub struct HzbCuller {
    config: HzbConfig,
    common: OccluderCulling,
    buffer: Buffer,
}

impl HzbCuller {
    /// Builds the model database (BVH) and the occluder database for `scene`.
    pub fn new(scene: &Scene, config: HzbConfig) -> HzbCuller {
        HzbCuller {
            common: OccluderCulling::new(
                scene,
                &config.occluders,
                config.coherence,
                config.cost_model,
                config.hierarchy,
            ),
            buffer: match config.depth {
                ZDepth::PerSample => Buffer::PerSample(None),
                ZDepth::Masked => Buffer::Masked(None),
            },
            config,
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

    /// The last frame's per-sample occluder depth and its pyramid (per-sample depth only).
    pub fn zbuffer(&self) -> Option<&TiledZBuffer> {
        match &self.buffer {
            Buffer::PerSample(b) => b.as_ref().map(|b| b.last_zbuffer()),
            Buffer::Masked(_) => None,
        }
    }

    /// The current settings.
    pub fn config(&self) -> &HzbConfig {
        &self.config
    }

    /// Steps 2 and 3 of a frame with `buffer`.
    fn draw_and_traverse<B: OcclusionBuffer + RectTest>(
        common: &mut OccluderCulling,
        scene: &Scene,
        frame: Selected,
        buffer: &mut B,
        out: &mut CullOutput,
    ) {
        // 2. Occluder depth (the render also builds the hierarchy above the tiles).
        let drawn = common.draw(scene, &frame, buffer, out);
        // 3. Traversal: frustum → the buffer, front to back.
        common.traverse(scene, out, frame, drawn, |r| buffer.rect_is_occluded(r));
    }
}

impl Culler for HzbCuller {
    fn name(&self) -> &'static str {
        match self.config.depth {
            ZDepth::PerSample => "hzb",
            ZDepth::Masked => "masked",
        }
    }

    fn config(&self) -> Vec<(&'static str, String)> {
        let depth = match self.config.depth {
            ZDepth::PerSample => "per-sample tiled z-buffer, pyramid of farthest depth",
            ZDepth::Masked => "masked: coverage mask and two depth layers per 32x8 tile",
        };
        std::iter::once(("depth", depth.to_string()))
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
            let mut bits = Vec::new();
            let (w, h) = match last {
                Buffer::PerSample(b) => {
                    let zb = b.as_ref()?.last_zbuffer();
                    zb.coverage_bits(&mut bits);
                    (zb.width(), zb.height())
                }
                Buffer::Masked(b) => {
                    let zb = b.as_ref()?.last_zbuffer();
                    zb.coverage_bits(&mut bits);
                    (zb.width(), zb.height())
                }
            };
            worst_hole_of_coverage(&bits, w, h, &MapOptions::default(), hole_opacity)
        })?;
        let common = &mut self.common;
        match &mut self.buffer {
            Buffer::PerSample(slot) => {
                let buffer = sized(slot, view, |w, h| HzBuffer::new(w, h, culler_buffer_options()));
                Self::draw_and_traverse(common, scene, frame, buffer, out);
            }
            Buffer::Masked(slot) => {
                let buffer = sized(slot, view, |w, h| MaskedBuffer::new(w, h, culler_buffer_options()));
                Self::draw_and_traverse(common, scene, frame, buffer, out);
            }
        }
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
        let Some(r) = self.common.last_rect(corners) else {
            return false;
        };
        match &mut self.buffer {
            Buffer::PerSample(Some(b)) => b.rect_is_occluded(&r),
            Buffer::Masked(Some(b)) => b.rect_is_occluded(&r),
            _ => false,
        }
    }

    fn frame_done(&mut self, frame_ms: Option<f64>) {
        self.common.feedback(frame_ms);
    }
}
