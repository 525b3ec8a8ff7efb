//! # hom-occlusion — occlusion buffers for engines
//!
//! Clear a buffer, draw occluder triangles, test boxes — three calls a frame,
//! with the engine's own meshes and matrices:
//!
//! ```
//! use hom_occlusion::glam::{Mat4, Vec3};
//! use hom_occlusion::geom::Aabb;
//! use hom_occlusion::{BufferOptions, ClipConvention, FaceCull, HzBuffer, OcclusionBuffer, Visibility};
//!
//! let proj = hom_occlusion::glam::camera::rh::proj::directx::perspective_infinite_reverse(1.0, 16.0 / 9.0, 0.1);
//! let view = hom_occlusion::glam::camera::rh::view::look_at_mat4(Vec3::new(0.0, 1.0, 10.0), Vec3::ZERO, Vec3::Y);
//! let view_proj = proj * view;
//! let options = BufferOptions { clip: ClipConvention::ReversedZ, ..Default::default() };
//! let mut buf = HzBuffer::new(320, 180, options)?;
//!
//! // A 20 m × 10 m wall at z = 0, two triangles.
//! let wall = [Vec3::new(-10.0, -5.0, 0.0), Vec3::new(10.0, -5.0, 0.0), Vec3::new(10.0, 5.0, 0.0), Vec3::new(-10.0, 5.0, 0.0)];
//! let behind = Aabb::new(Vec3::new(-1.0, 0.0, -5.0), Vec3::new(1.0, 2.0, -3.0));
//! let in_front = Aabb::new(Vec3::new(-1.0, 0.0, 3.0), Vec3::new(1.0, 2.0, 5.0));
//! let off_screen = Aabb::new(Vec3::new(-1.0, 0.0, 30.0), Vec3::new(1.0, 2.0, 32.0));
//! for _frame in 0..3 {
//!     buf.clear();
//!     buf.render_triangles(&wall, &[[0, 1, 2], [0, 2, 3]], &view_proj, FaceCull::None)?;
//!     assert_eq!(buf.test_aabb(&behind, &view_proj), Visibility::Occluded);
//!     assert_eq!(buf.test_aabb(&in_front, &view_proj), Visibility::Visible);
//!     assert_eq!(buf.test_aabb(&off_screen, &view_proj), Visibility::ViewCulled);
//! }
//! # Ok::<(), hom_occlusion::OcclusionError>(())
//! ```
//!
//! ## Conventions
//! - Matrices are column-major [`glam::Mat4`]; `model_to_clip` maps the
//!   vertices (or box) you pass to clip space in the buffer's
//!   [`ClipConvention`] (`BufferOptions::clip`): pass `view_proj * model`.
//!   Perspective and orthographic projections both work.
//! - NDC x and y are in `[-1, 1]`, y up; pixel (0, 0) is the top-left of the
//!   buffer and samples sit at pixel centres.
//! - Depths passed to [`OcclusionBuffer::test_rect`] are `z / w` in the
//!   buffer's convention (reversed Z: larger is nearer).
//! - A box or rectangle that reaches in front of the near plane is never
//!   [`Visibility::Occluded`]. Non-finite vertices are skipped; a NaN box is
//!   [`Visibility::Visible`].
//! - Answers are exact for an image of the buffer's own size. A box is
//!   `Occluded` when no sample of the buffer sees any part of it; an engine
//!   that renders at a higher resolution than the buffer may see it through a
//!   gap narrower than a buffer pixel, as with any point-sampled occlusion
//!   buffer (Masked Occlusion Culling included).
//! - Submit occluders nearest first: it costs nothing and makes both buffers
//!   tighter (HZB skips what is already hidden; HOM's depth cells keep the
//!   first, nearest cover).
//! - With [`Sampling::Exact`], drop the back faces of closed occluder
//!   meshes: check each mesh once with [`ClosedMesh::of`], then pass
//!   [`ClosedMesh::back_faces`] as the `FaceCull` of each draw. A closed
//!   mesh covers the same samples without them, with half the triangles,
//!   and HOM's depth cells keep the front faces' nearer depth. Open meshes,
//!   meshes that reach in front of the near plane, and any mesh under the
//!   default [`Sampling::Conservative`] stay [`FaceCull::None`] (there the
//!   back faces cover the samples the inner rule takes off the edges
//!   between front faces).
//! - Draw a stand-in that is one convex solid (a box inside a building,
//!   using its corners only) with
//!   [`OcclusionBuffer::render_convex_stand_in`]: its outline, shrunk by
//!   more than the snapping error, as a fan of a few triangles at or behind
//!   its front (a box: 2–6 where its 12 would be drawn two-sided), in
//!   either sampling. A solid that is not convex goes through
//!   [`OcclusionBuffer::render_stand_in_triangles`].
//!
//! ## The four buffers
//! - [`HzBuffer`]: the hierarchical Z-buffer (Greene, Kass and Miller 1993) —
//!   per-sample occluder depth in 8×8 tiles with a pyramid of farthest
//!   depths. Finds every hidden box the samples can prove hidden.
//! - [`HomBuffer`]: hierarchical occlusion maps (Zhang et al. 1997) — an
//!   opacity pyramid of exact coverage counts plus a depth estimation buffer;
//!   optionally approximate ([`Opacity::Threshold`]).
//! - [`MaskedBuffer`]: masked software occlusion culling (Hasselgren et al.
//!   2016) — per 32×8 tile a coverage mask and two conservative depth
//!   layers: far less work per occluder, fewer hidden boxes found where small
//!   occluders at mixed depths share a tile.
//! - [`OcclusionTree`]: occlusion trees (Bittner, Havran and Slavík 1998) —
//!   the occluders' shadow frusta merged into a BSP tree of the image plane
//!   (their projected edges) with *in* and *out* leaves, tested by a
//!   constrained depth-first search: object space, no image to clear.
//!
//! Triangles are queued by `render_*` and set up and drawn, in parallel on
//! the current rayon pool, at the first test after them (or at
//! [`OcclusionBuffer::flush`]); rendering and testing may be interleaved.
//!
//! `examples/engine_loop.rs` is the same as a whole game-style loop
//! (`cargo run --release --example engine_loop -p hom-occlusion`).
//!
//! ## What is here
//! This crate is hom's image-space layer: it knows no scene, only triangles,
//! matrices and boxes. The crate `hom` builds whole-scene cullers on it
//! (re-exported there as `hom::occlusion` and `hom::geom`).
//! - [`geom`]: boxes, planes, the frustum, cameras and views, screen rectangles.
//! - [`clusters`]: a mesh's triangles cut into clusters, to cull parts of
//!   big meshes (index ranges with their bounds).
//! - `raster/`: the one triangle setup and sampling rule shared with the
//!   reference renderer (`raster/setup.rs`), exact scan-line spans, the
//!   triangle queue, and the row-coverage kernels with their backend choice
//!   ([`RasterBackend`]).
//! - `occlusion_map/`: hierarchical occlusion maps ([`HomBuffer`]).
//! - `hzb/`: the hierarchical Z-buffer ([`HzBuffer`]) and the Z-pyramid.
//! - `masked/`: masked software occlusion culling ([`MaskedBuffer`]).
//! - `otree.rs`: occlusion trees ([`OcclusionTree`]).
//! - [`details`]: the building blocks hom's cullers, the reference renderer,
//!   the pictures and the tests reach; not the front door.
//!
//! The only `unsafe` of the workspace is here, in the vector kernels
//! (`raster/simd.rs`, `raster/simd_setup.rs`, `hzb/simd.rs`,
//! `masked/simd.rs`); every block says why it is sound, and each kernel has
//! a scalar twin it is tested against bit for bit.

#![deny(unsafe_code)]

#[forbid(unsafe_code)]
mod buffer;
#[forbid(unsafe_code)]
mod closed_mesh;
#[forbid(unsafe_code)]
pub mod clusters;
#[forbid(unsafe_code)]
pub mod details;
#[forbid(unsafe_code)]
pub mod geom;
mod hzb;
mod masked;
mod occlusion_map;
#[forbid(unsafe_code)]
mod otree;
mod raster;
#[forbid(unsafe_code)]
mod sample_depth;
mod weld;

pub use buffer::{
    BufferOptions, BufferStats, OcclusionBuffer, OcclusionError, Sampling, SharedBuffer, Threads, Visibility,
};
pub use closed_mesh::ClosedMesh;
pub use geom::ClipConvention;
pub use glam;
pub use hzb::HzBuffer;
pub use masked::MaskedBuffer;
pub use occlusion_map::{DepthMode, HomBuffer, MapOptions, Opacity};
pub use otree::{OcclusionTree, TreeStats, DEFAULT_NODE_CAP};
pub use raster::setup::FaceCull;
pub use raster::{RasterBackend, BACKEND_ENV, FORCE_SCALAR_ENV};

pub(crate) use buffer::{occlusion_buffer, Front, Placement, RectTest, DEPTH_MARGIN};

/// Bytes a vector holds on the heap (its capacity), for the memory counters.
pub(crate) fn vec_bytes<T>(v: &Vec<T>) -> usize {
    v.capacity() * std::mem::size_of::<T>()
}
