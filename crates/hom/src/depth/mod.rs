//! Depth for occlusion tests: the depth estimation buffer, the single Z plane,
//! and the hierarchical Z-buffer's Z-pyramid.

mod estimation_buffer;
pub(crate) mod masked;
pub(crate) mod tiled;
mod z_pyramid;

pub use estimation_buffer::{DepthEstimationBuffer, SingleZPlane, DEPTH_MARGIN};
pub use masked::MaskedZBuffer;
pub use tiled::TiledZBuffer;
pub use z_pyramid::{ZLevel, ZPyramid, ZTestStats};
