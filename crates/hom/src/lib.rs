//! # hom — CPU occlusion culling for large 3D scenes
//!
//! Every frame, hom finds the objects a camera cannot see — outside the view
//! frustum, or hidden behind other objects — so a renderer never draws them.
//! This crate holds the algorithms only: no file I/O, no rendering.
//!
//! ## The front door: an occlusion buffer a frame
//!
//! Clear, draw the occluders you choose, test boxes — with your own meshes
//! and matrices ([`occlusion`]):
//!
//! ```
//! use hom::geom::Aabb;
//! use hom::glam::{camera::rh::{proj::directx, view}, Vec3};
//! use hom::occlusion::{BufferOptions, ClipConvention, FaceCull, HzBuffer, OcclusionBuffer, Visibility};
//!
//! let proj = directx::perspective_infinite_reverse(1.0, 16.0 / 9.0, 0.1);
//! let view_proj = proj * view::look_at_mat4(Vec3::new(0.0, 1.7, 10.0), Vec3::ZERO, Vec3::Y);
//! let options = BufferOptions { clip: ClipConvention::ReversedZ, ..Default::default() };
//! let mut buf = HzBuffer::new(640, 360, options)?;
//! let wall = [Vec3::new(-10.0, 0.0, 0.0), Vec3::new(10.0, 0.0, 0.0), Vec3::new(10.0, 8.0, 0.0), Vec3::new(-10.0, 8.0, 0.0)];
//! for _frame in 0..3 {
//!     buf.clear();
//!     buf.render_triangles(&wall, &[[0, 1, 2], [0, 2, 3]], &view_proj, FaceCull::None)?;
//!     let crate_behind = Aabb::new(Vec3::new(-1.0, 0.0, -6.0), Vec3::new(1.0, 1.0, -4.0));
//!     assert_eq!(buf.test_aabb(&crate_behind, &view_proj), Visibility::Occluded);
//! }
//! # Ok::<(), hom::occlusion::OcclusionError>(())
//! ```
//!
//! `crates/hom/examples/engine_loop.rs` is the same as a whole game-style
//! loop (`cargo run --release --example engine_loop -p hom`).
//!
//! For a whole scene, the [`cull`] module's cullers do the rest: an engine
//! keeps a [`scene::Scene`] in step with its world (add, move with
//! `set_transform`, remove) and asks a [`cull::Culler`] each frame for the
//! visible set from a [`geom::View`] (`view_proj`, viewport, clip convention).
//!
//! ## Conventions (obeyed everywhere)
//! - World: right-handed, +Y up, metres. Matrices are column-major
//!   [`glam::Mat4`]; vectors are columns (`view_proj * model * p`).
//! - Clip space: any [`geom::ClipConvention`] at the door (`ZeroToOne`:
//!   Vulkan/D3D/wgpu; `NegOneToOne`: OpenGL; `ReversedZ`, finite or infinite
//!   far plane); inside, hom's own `ZeroToOne` (depth `z / w` in `[0, 1]`, 0
//!   at the near plane, nearer is smaller). NDC y points up. Perspective and
//!   orthographic projections alike.
//! - Screen: pixel (0, 0) is the top-left; samples at pixel centres
//!   (`x + 0.5`, `y + 0.5`), vertices snapped to 1/256 pixel, top-left fill rule.
//! - Object ids: `u32`, the object's index in the [`scene::Scene`]; stable,
//!   never reused (removed objects keep theirs).
//! - A box that crosses the near plane or lies partly behind the eye is never
//!   culled by an image-space test ([`geom::Footprint::Straddles`]).
//! - Triangles are two-sided unless a [`occlusion::FaceCull`] says otherwise.
//! - Conservative by default: nothing that owns a sample of the image is
//!   culled; approximate modes say so in their names.
//!
//! ## One algorithm per file, named after its paper
//! - [`occlusion`]: the buffers, [`occlusion::HzBuffer`] and [`occlusion::HomBuffer`].
//! - Hierarchical occlusion maps (Zhang et al. 1997): [`map::Pyramid`] (`map/pyramid.rs`),
//!   the overlap test (`map/overlap.rs`), the hole search (`map/hole.rs`), the depth
//!   estimation buffer and single Z plane (`depth/estimation_buffer.rs`), the
//!   occluder database and selection (`occluders/database.rs`, `occluders/selection.rs`),
//!   the culler ([`cull::HomCuller`], `cull/hom.rs`).
//! - Hierarchical Z-buffer (Greene, Kass and Miller 1993; RTR §7.2): the tiled z-buffer
//!   ([`depth::TiledZBuffer`], `depth/tiled.rs`), its rasterizer (`raster/tiled.rs`),
//!   the culler ([`cull::HzbCuller`], `cull/hzb.rs`).
//! - Hierarchical visibility (Greene et al. 1993): the octree (`spatial/octree.rs`),
//!   the live Z-pyramid (`depth/z_pyramid.rs`), the culler ([`cull::HvCuller`], `cull/hv.rs`).
//! - The model database: a binned-SAH BVH (`spatial/bvh.rs`, Wald 2007).
//! - The one triangle setup and sampling rule shared with the reference renderer
//!   (`raster/setup.rs`), and the vector kernels with their scalar twins
//!   (`raster/simd.rs`, `raster/simd_tiles.rs`: the only `unsafe` in hom).

#![deny(unsafe_code)]

#[forbid(unsafe_code)]
pub mod cull;
#[forbid(unsafe_code)]
pub mod depth;
#[forbid(unsafe_code)]
pub mod geom;
#[forbid(unsafe_code)]
pub mod lod;
#[forbid(unsafe_code)]
pub mod map;
#[forbid(unsafe_code)]
pub mod occluders;
#[forbid(unsafe_code)]
pub mod occlusion;
#[forbid(unsafe_code)]
pub mod pvs;
pub mod raster;
#[forbid(unsafe_code)]
pub mod scene;
#[forbid(unsafe_code)]
pub(crate) mod simplify;
#[forbid(unsafe_code)]
pub mod spatial;

pub use glam;

/// Bytes a vector holds on the heap (its capacity), for the memory counters.
pub(crate) fn vec_bytes<T>(v: &Vec<T>) -> usize {
    v.capacity() * std::mem::size_of::<T>()
}
