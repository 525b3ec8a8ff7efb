//! Hierarchical occlusion maps (Zhang, Manocha, Hudson and Hoff 1997): the
//! buffer ([`HomBuffer`]), its coverage raster (`coverage.rs`: exact
//! coverage bits, the depth cells, the band schedule and the pyramid build),
//! the opacity pyramid (`pyramid.rs`), the overlap test (`overlap.rs`,
//! section 5.1), the hole search (`hole.rs`, section 6.2), and the depth
//! estimation buffer and single Z plane (`estimation_buffer.rs`, section 4.3).

#[forbid(unsafe_code)]
mod buffer;
#[forbid(unsafe_code)]
mod coverage;
#[forbid(unsafe_code)]
mod depth_cells;
#[forbid(unsafe_code)]
mod estimation_buffer;
#[forbid(unsafe_code)]
pub(crate) mod hole;
#[forbid(unsafe_code)]
mod overlap;
#[forbid(unsafe_code)]
pub(crate) mod pyramid;
#[forbid(unsafe_code)]
pub(crate) mod raster;

pub use buffer::{DepthMode, HomBuffer, MapOptions, Opacity};
pub use coverage::CoverageBuffer;
pub use estimation_buffer::{DepthEstimationBuffer, SingleZPlane};
pub use hole::{find_worst_hole, worst_hole_of_coverage, Hole};
pub use overlap::{rect_covered, OverlapStats, Thresholds};
pub(crate) use pyramid::BandBuild;
pub use pyramid::{Level, Pyramid};
pub(crate) use raster::CoverageRasterizer;
