//! What lost its measurement: kept working, tested and reachable from the
//! CLI for experiments, but not what hom recommends. Each item says why, with
//! its numbers; the measurements are in `docs/decisions/`.
//!
//! - [`KdTree`]: the occluder cullers' traversal over a kD-tree with ropes,
//!   with or without visibility propagation (`--hierarchy kd`,
//!   `--hierarchy kd-propagate`), as [`crate::cull::Hierarchy::KdTree`].
//! - [`HvPriming`]: hierarchical visibility's temporal priming
//!   (`--hv-priming`), as [`crate::cull::HvConfig::priming`].
//! - [`pvs_fusion`]: PVS occluder fusion by point sampling
//!   (`hom pvs bake --fusion-spacing`).

pub use crate::cull::kd_traversal::{DFS_BUDGET, P_VP};

/// The kD-tree with ropes under the occluder cullers' traversal, with
/// visibility propagation (Bittner & Havran 2002) when `propagation`.
/// Experimental: 2.7× the BVH's node tests and twice its traversal time for
/// the same culled set (city, HOM, 512×384: 1499 vs 544 tests a frame, 0.62
/// vs 0.32 ms, efficiency 80.4 % both), and propagation succeeds on about
/// 1 % of its attempts, costing more than the 0.4-2.6 % of tests it saves
/// (`docs/decisions/kd-tree.md`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct KdTree {
    /// Try to classify nodes invisible from their rope neighbours before
    /// testing them (visibility propagation).
    pub propagation: bool,
}

/// Hierarchical visibility's temporal priming (Greene et al.'s temporal
/// coherence): last frame's visible nodes (and visible moving objects) are
/// drawn first, so the traversal tests nodes against a pyramid that already
/// holds most of this frame's occluders. Experimental: it saves 30-63 % of
/// the node tests but no raster work (triangles submitted -15..+2 %, sample
/// tests +0..+10 %, the six built-in walks, 100 frames): the octree's own
/// front-to-back order leaves it little (`docs/decisions/hv.md`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HvPriming;

/// PVS occluder fusion by point sampling (Wonka, Wimmer & Schmalstieg 2000;
/// `pvs/fusion.rs`): the solid space a bake erodes and samples, for
/// [`Pvs::bake_with_solids`](crate::pvs::Pvs::bake_with_solids) with
/// [`PvsConfig::fusion_spacing`](crate::pvs::PvsConfig::fusion_spacing) on
/// (`hom pvs bake --fusion-spacing`). Off by default: it finds 0 more hidden
/// objects on the city, office and sculpture park at 1 m spacing, because a
/// building stands on drawn ground, not solid space, and erosion opens a
/// slot under it (city: 15.3 million solid voxels of 0.59 m, 10.2 million
/// after erosion; `docs/decisions/pvs.md`).
pub mod pvs_fusion {
    pub use crate::pvs::solid::{SolidSpace, MAX_VOXELS};
}
