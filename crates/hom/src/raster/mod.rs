//! Software rasterization shared by the reference renderer and the occluder
//! rasterizer: one triangle setup, one sampling rule.
//!
//! Sampling rule: one sample at each pixel centre `(x + 0.5, y + 0.5)`; vertices
//! snapped to 1/256 pixel; exact integer edge functions with the top-left fill
//! rule, so triangles sharing an edge never both cover, and never both miss, a
//! sample on it. Triangles are clipped against the near plane in homogeneous
//! space, and against a guard band only where fixed point would overflow.

mod coverage;
pub mod setup;

pub use coverage::{CoverageBuffer, OccluderRasterizer};
