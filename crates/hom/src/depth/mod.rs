//! Depth for occlusion tests: the depth estimation buffer and the single Z plane.

pub mod estimation_buffer;

pub use estimation_buffer::{DepthEstimationBuffer, SingleZPlane, DEPTH_MARGIN};
