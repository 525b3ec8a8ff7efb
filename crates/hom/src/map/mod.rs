//! Hierarchical occlusion maps: the opacity pyramid, the overlap test and the hole search.

mod hole;
mod overlap;
mod pyramid;

pub(crate) use hole::{find_worst_hole, worst_hole_of_coverage, Hole};
// The overlap test alone, for the kernel benches; the front door is `HomBuffer`.
pub use overlap::OverlapStats;
#[doc(hidden)]
pub use overlap::{rect_covered, Thresholds};
pub(crate) use pyramid::BandBuild;
pub use pyramid::{Level, Pyramid};
