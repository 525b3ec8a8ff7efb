//! Depth for occlusion tests: the depth estimation buffer, the single Z plane,
//! and the hierarchical Z-buffer's Z-pyramid.

pub mod estimation_buffer;
pub mod hzb;
pub mod tiled;

pub use estimation_buffer::{DepthEstimationBuffer, SingleZPlane, DEPTH_MARGIN};
pub use hzb::{ZLevel, ZPyramid, ZTestStats};
pub use tiled::TiledZBuffer;
