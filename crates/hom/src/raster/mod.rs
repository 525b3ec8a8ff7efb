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
//! run time: AVX2 where the CPU has it (faster than AVX-512 on the AVX-512
//! host measured; [`RasterBackend::detect`]), else the widest vector kernel
//! it has (SSE4.1), else the scalar path, which defines the result; all backends cover
//! bit-identical samples. In the environment, `HOM_RASTER_BACKEND=scalar|sse41|avx2|avx512`
//! picks one ([`BACKEND_ENV`]) and `HOM_FORCE_SCALAR=1` forces the scalar path
//! ([`FORCE_SCALAR_ENV`], which wins); in code,
//! [`crate::occlusion::BufferOptions::backend`].

#[forbid(unsafe_code)]
mod coverage;
#[forbid(unsafe_code)]
pub(crate) mod masked;
#[forbid(unsafe_code)]
pub(crate) mod queue;
#[forbid(unsafe_code)]
mod scanline;
#[forbid(unsafe_code)]
mod silhouette;
// The renderer (`hom-render`) shares this setup and sampling rule: public for it, not the front door.
#[doc(hidden)]
#[forbid(unsafe_code)]
pub mod setup;
// The vector kernels: the only `unsafe` in hom (each block says why it is sound).
#[allow(unsafe_code)]
mod simd;
#[allow(unsafe_code)]
mod simd_masked;
#[allow(unsafe_code)]
mod simd_setup;
#[allow(unsafe_code)]
mod simd_tiles;
#[forbid(unsafe_code)]
mod tile_band;
#[forbid(unsafe_code)]
mod tiled;
#[forbid(unsafe_code)]
pub(crate) mod zbuffer;

use rayon::prelude::*;

/// Bands of rows (`(band, parts)`) as parallel jobs, costliest first by
/// `cost(band)` (its triangles), one band a job. Bands cost very unequal
/// amounts (on the city's walk the horizon's 20–30 times the sky's), and
/// rayon's halving split would give each thread a run of neighbouring
/// bands, one of them the horizon (one thread drew 527 of 711 µs of band
/// work). Costliest first, the thread that steals takes the cheaper half and
/// both end on cheap bands. The coverage and tiled rasters share it.
fn costliest_first<T: Send>(
    mut bands: Vec<(usize, T)>,
    cost: impl Fn(usize) -> usize,
) -> impl IndexedParallelIterator<Item = (usize, T)> {
    sort_costliest_first(&mut bands, cost);
    bands.into_par_iter().with_max_len(1)
}

/// Sorts bands (`(band, _)`) costliest first by `cost(band)`, ties in band
/// order: [`costliest_first`]'s order, for a caller that hands bands out itself.
fn sort_costliest_first<T>(bands: &mut [(usize, T)], cost: impl Fn(usize) -> usize) {
    bands.sort_by_key(|&(band, _)| std::cmp::Reverse(cost(band)));
}

pub use coverage::CoverageBuffer;
pub(crate) use coverage::CoverageRasterizer;
pub use simd::{RasterBackend, BACKEND_ENV, FORCE_SCALAR_ENV};
pub(crate) use tiled::TiledRasterizer;
