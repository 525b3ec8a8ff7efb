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
//! [`crate::BufferOptions::backend`].

#[forbid(unsafe_code)]
pub(crate) mod queue;
#[forbid(unsafe_code)]
pub(crate) mod scanline;
#[forbid(unsafe_code)]
mod silhouette;
// The renderer (`hom-render`) shares this setup and sampling rule: public for
// it through `details::setup`, not the front door.
#[forbid(unsafe_code)]
pub mod setup;
// The vector kernels: with `hzb/simd.rs` and `masked/simd.rs`, the only
// `unsafe` of the workspace (each block says why it is sound).
#[allow(unsafe_code)]
pub(crate) mod simd;
#[allow(unsafe_code)]
mod simd_setup;

use rayon::prelude::*;

/// Bands of rows (`(band, parts)`) as parallel jobs, costliest first by
/// `cost(band)` (its triangles), one band a job. Bands cost very unequal
/// amounts (on the city's walk the horizon's 20–30 times the sky's), and
/// rayon's halving split would give each thread a run of neighbouring
/// bands, one of them the horizon (one thread drew 527 of 711 µs of band
/// work). Costliest first, the thread that steals takes the cheaper half and
/// both end on cheap bands. The coverage and tiled rasters share it.
pub(crate) fn costliest_first<T: Send>(
    mut bands: Vec<(usize, T)>,
    cost: impl Fn(usize) -> usize,
) -> impl IndexedParallelIterator<Item = (usize, T)> {
    sort_costliest_first(&mut bands, cost);
    bands.into_par_iter().with_max_len(1)
}

/// Sorts bands (`(band, _)`) costliest first by `cost(band)`, ties in band
/// order: [`costliest_first`]'s order, for a caller that hands bands out itself.
pub(crate) fn sort_costliest_first<T>(bands: &mut [(usize, T)], cost: impl Fn(usize) -> usize) {
    bands.sort_by_key(|&(band, _)| std::cmp::Reverse(cost(band)));
}

pub use simd::{RasterBackend, BACKEND_ENV, FORCE_SCALAR_ENV};
pub use simd_setup::setup_triangles;
