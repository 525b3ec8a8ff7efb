//! Building blocks behind the front door, public for the rest of the
//! workspace: hom's cullers (the rectangle test, the hole search, HV's live
//! Z-pyramid), the reference renderer (the triangle setup and sampling rule
//! it shares with every buffer: [`setup`]), the pictures (the pyramids and
//! z-buffers a culler's diagnostic accessors return) and the kernel benches.
//! An engine needs none of it; its shapes may change with the algorithms.

pub use crate::buffer::{RectTest, DEPTH_MARGIN};
pub use crate::closed_mesh::{faces_turned_away, height_field};
pub use crate::hzb::zbuffer::{Dirty, ZDrawStats, ZTarget, NO_OBJECT};
pub use crate::hzb::{TiledZBuffer, ZLevel, ZPyramid, ZTestStats};
pub use crate::masked::MaskedZBuffer;
pub use crate::occlusion_map::{
    find_worst_hole, rect_covered, worst_hole_of_coverage, CoverageBuffer, DepthEstimationBuffer, Hole, Level,
    OverlapStats, Pyramid, SingleZPlane, Thresholds,
};
pub use crate::raster::setup;
pub use crate::sample_depth::{SampleDepthStats, SampleDepths};
pub use crate::weld::{number_welded, weld};

/// Bytes a vector holds on the heap (its capacity), for the memory counters.
pub fn vec_bytes<T>(v: &Vec<T>) -> usize {
    crate::vec_bytes(v)
}
