//! The culler interface every algorithm implements, and the basic cullers.
//!
//! A [`Culler`] is built for one scene, then asked once per frame which objects
//! to draw, given the frame's [`View`] (a `view_proj` matrix, a viewport and a
//! clip convention). The scene may change between frames — objects added,
//! moved, removed — and the culler follows it. It reports what it culled and
//! why, and how long each of its stages took, so the walkthrough harness can
//! compare cullers on equal terms.

mod coherence;
mod culler_buffers;
mod depth_check;
mod frustum;
mod governor;
mod hv;
pub(crate) mod kd_traversal;
mod model_db;
mod occluder_culler;
mod pvs;
mod stats;
mod traversal;

pub use coherence::{Coherence, PSkip};
pub use culler_buffers::{
    HomConfig, HomCuller, HzbConfig, HzbCuller, MaskedConfig, MaskedCuller, OtreeConfig, OtreeCuller, TreeOptions,
};
pub use depth_check::{DepthCheck, SampleDepthQuery, DEPTH_CHECK_MAX_TRIANGLES};
pub use frustum::{FrustumCuller, NoCuller};
pub use hv::{HvConfig, HvCuller};
pub use occluder_culler::{CullerBuffer, Hierarchy, OccluderCuller, OccluderCullerConfig};
pub use pvs::PvsCuller;
pub use stats::{
    CullStats, DepthCheckStats, FrustumStats, HvStats, MemoryStats, OccluderStats, PropagationStats, PvsStats,
    TraversalStats,
};

use crate::geom::{View, ViewError};
use crate::scene::Scene;
use std::time::Instant;
use thiserror::Error;

/// Why a culler could not process a frame.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CullError {
    /// The view is unusable (NaN matrix, no frustum, bad viewport…).
    #[error("invalid view")]
    View(#[from] ViewError),
}

/// What a culler decided for one frame. Reused across frames to avoid allocation.
#[derive(Clone, Debug, Default)]
pub struct CullOutput {
    /// Ids to render, ascending.
    pub visible: Vec<u32>,
    /// Ids culled as occluded (inside the frustum), ascending.
    pub occluded: Vec<u32>,
    /// Ids selected as occluders this frame, ascending: rasterized into the
    /// occlusion buffer, and in `visible` or `occluded` like every object
    /// (an occluder hidden by nearer ones is culled).
    pub occluders: Vec<u32>,
    /// Milliseconds per stage, in execution order.
    pub stages: Vec<(&'static str, f64)>,
    /// What the culler did, by concern ([`CullStats::counters`] names them
    /// for reports).
    pub stats: CullStats,
}

impl CullOutput {
    /// Empties every list, keeping capacity.
    pub fn clear(&mut self) {
        self.visible.clear();
        self.occluded.clear();
        self.occluders.clear();
        self.stages.clear();
        self.stats = CullStats::default();
    }

    /// Runs `f`, recording its wall time as stage `name` (and, with the
    /// `tracing` feature, inside a `hom_cull` span whose `stage` is `name`).
    pub fn time<T>(&mut self, name: &'static str, f: impl FnOnce() -> T) -> T {
        #[cfg(feature = "tracing")]
        let _span = tracing::info_span!("hom_cull", stage = name).entered();
        let start = Instant::now();
        let r = f();
        self.stages.push((name, start.elapsed().as_secs_f64() * 1e3));
        r
    }

    /// Total milliseconds over all stages.
    pub fn total_ms(&self) -> f64 {
        self.stages.iter().map(|s| s.1).sum()
    }
}

/// A visibility culler: built for one scene, asked per frame.
///
/// Contract: every object that owns a pixel of the full rendering of the
/// scene from `view` (at its resolution, with hom's sampling rule) must be in
/// `out.visible` — unless the culler was configured to approximate, and says
/// so in [`Culler::config`]. Removed objects are never reported.
pub trait Culler: Send {
    /// Short name, as accepted by `hom walk --culler`.
    fn name(&self) -> &'static str;

    /// Configuration as key/value pairs, for report headers.
    fn config(&self) -> Vec<(&'static str, String)> {
        Vec::new()
    }

    /// Decides this frame's visible set. `scene` is the scene the culler was
    /// built for, as it stands this frame (the culler follows additions,
    /// removals and moves since the last call).
    fn cull(&mut self, scene: &Scene, view: &View, out: &mut CullOutput) -> Result<(), CullError>;

    /// Feedback after the frame was drawn: its total time (culling plus
    /// rendering) when the caller measured it. Cullers that adapt (HOM's
    /// polygon budget, hole filling) learn from it; the default ignores it.
    fn frame_done(&mut self, _frame_ms: Option<f64>) {}

    /// Objects known hidden from the next frame's view (ascending ids of
    /// `scene`), e.g. by a precomputed visibility set: a culler may report
    /// them occluded without testing them and skip them as occluders. Objects
    /// that move are not hidden by it. The default ignores the hint; a
    /// caller must still not draw them (as [`PvsCuller`] does).
    fn set_known_hidden(&mut self, _scene: &Scene, _hidden: &[u32]) {}

    /// After [`Culler::cull`]: whether the world-space box with these
    /// `corners` (a part of a visible object, such as a level-of-detail node)
    /// is hidden from that frame's view by what the culler drew, by the same
    /// test its objects got. `false` when the culler keeps no such answer:
    /// frustum culling, a frame the cost model rested, a box crossing the
    /// near plane.
    fn box_hidden(&mut self, _corners: &[glam::Vec3; 8]) -> bool {
        false
    }

    /// Draws occluders at the level of detail the frames are rendered at
    /// (`None`: as their meshes, the default): from the next frame, an
    /// occluder whose view-only cut is coarser than its mesh is drawn as
    /// that cut and costs the budget its triangles. The guarantee is then
    /// the image of every object's view-only cut at `lod.error_px`
    /// ([`crate::lod::OccluderLod`]), which is what a caller that draws
    /// [`crate::lod::LodSelector`]'s selection at that threshold shows.
    /// Returns whether the culler draws occluders this way (the occluder
    /// cullers: HOM, HZB, masked, otree; not frustum or HV culling).
    /// Hierarchies built for another scene than the one culled are not
    /// used: its occluders are then drawn as their meshes.
    fn set_occluder_lod(&mut self, _lod: Option<crate::lod::OccluderLod>) -> bool {
        false
    }

    /// The occlusion buffer the last frame that culled by occlusion drew,
    /// for debug views (`hom view`'s inset); its tests alone. `None` for
    /// cullers without one (frustum, HV) and before the first such frame.
    fn occlusion_buffer(&mut self) -> Option<&mut dyn crate::occlusion::OcclusionBuffer> {
        None
    }
}
