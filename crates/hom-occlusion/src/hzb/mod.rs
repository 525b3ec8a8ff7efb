//! The hierarchical Z-buffer (Greene, Kass and Miller 1993; RTR §7.2 in
//! `shared/papers`): the occluders' per-sample depth in 8×8 tiles with a
//! pyramid of farthest depths above ([`HzBuffer`], storage in `tiled.rs`),
//! its rasterizer (`raster.rs`, one band of tiles in `tile_band.rs`, the
//! vector kernels in `simd.rs`), and the row-major Z-pyramid (`z_pyramid.rs`)
//! with the z-buffer rasterizer of hierarchical visibility (`zbuffer.rs`):
//! the live pyramid of hom's HV culler and the reference the tiled buffer is
//! tested against.

#[forbid(unsafe_code)]
mod buffer;
#[forbid(unsafe_code)]
pub(crate) mod raster;
#[allow(unsafe_code)]
mod simd;
#[forbid(unsafe_code)]
mod tile_band;
#[forbid(unsafe_code)]
pub(crate) mod tiled;
#[forbid(unsafe_code)]
mod z_pyramid;
#[forbid(unsafe_code)]
pub(crate) mod zbuffer;

pub use buffer::HzBuffer;
pub use tiled::TiledZBuffer;
pub use z_pyramid::{ZLevel, ZPyramid, ZTestStats};
