//! What lost its measurement: sound, tested and reachable, but not how hom
//! is meant to be used. Each part says why, with the numbers
//! (`docs/decisions/` has the runs).

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
