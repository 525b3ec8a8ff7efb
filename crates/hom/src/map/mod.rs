//! Hierarchical occlusion maps: the opacity pyramid and the overlap test.

pub mod overlap;
pub mod pyramid;

pub use overlap::{rect_covered, OverlapStats, Thresholds};
pub use pyramid::{Level, Pyramid};
