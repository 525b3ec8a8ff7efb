//! Software rasterization shared by the reference renderer and the occluder
//! rasterizer: one triangle setup, one sampling rule.
//!
//! Sampling rule: one sample at each pixel centre `(x + 0.5, y + 0.5)`; vertices
//! snapped to 1/256 pixel; exact integer edge functions with the top-left fill
//! rule, so triangles sharing an edge never both cover, and never both miss, a
//! sample on it. Triangles are clipped against the near plane in homogeneous
//! space, and against a guard band only where fixed point would overflow.

//!
//! The occluder rasterizer fills rows with a [`RasterBackend`] chosen once at
//! run time: the widest vector kernel the CPU has (AVX-512, AVX2, SSE4.1),
//! else the scalar path, which defines the result; all backends cover
//! bit-identical samples. In the environment, `HOM_RASTER_BACKEND=scalar|sse41|avx2|avx512`
//! picks one ([`BACKEND_ENV`]) and `HOM_FORCE_SCALAR=1` forces the scalar path
//! ([`FORCE_SCALAR_ENV`], which wins); in code,
//! [`CoverageRasterizer::with_backend`].

mod coverage;
pub(crate) mod queue;
pub mod setup;
mod simd;
mod simd_tiles;
mod tiled;

pub use coverage::{CoverageBuffer, CoverageRasterizer};
pub use simd::{RasterBackend, BACKEND_ENV, FORCE_SCALAR_ENV, MASK_MAX};
pub use tiled::{TiledRasterizer, TiledStats};
