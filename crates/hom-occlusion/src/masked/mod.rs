//! Masked software occlusion culling (Hasselgren, Andersson and
//! Akenine-Möller 2016): per 32×8 tile a coverage mask and two conservative
//! depth layers ([`MaskedBuffer`], storage in `zbuffer.rs`), its rasterizer
//! (`raster.rs`) and the rasterizer's vector kernels (`simd.rs`).

#[forbid(unsafe_code)]
mod buffer;
#[forbid(unsafe_code)]
mod group;
#[forbid(unsafe_code)]
pub(crate) mod raster;
#[allow(unsafe_code)]
mod simd;
#[forbid(unsafe_code)]
pub(crate) mod zbuffer;

pub use buffer::MaskedBuffer;
pub use zbuffer::MaskedZBuffer;
