//! Hierarchical occlusion maps: the opacity pyramid, the overlap test and the hole search.

mod hole;
pub mod overlap;
pub mod pyramid;

pub use hole::{find_worst_hole, worst_hole_of_coverage, Hole};
pub use overlap::{rect_covered, OverlapStats, Thresholds};
pub use pyramid::{Level, Pyramid};
