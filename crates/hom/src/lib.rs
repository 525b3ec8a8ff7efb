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
//! `crates/hom-occlusion/examples/engine_loop.rs` is the same as a whole game-style
//! loop (`cargo run --release --example engine_loop -p hom-occlusion`).
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
//! The image-space layer is the engine crate `hom-occlusion`, re-exported
//! here as [`occlusion`] (with [`geom`]): the buffers
//! [`occlusion::HomBuffer`] (hierarchical occlusion maps, Zhang et al.
//! 1997), [`occlusion::HzBuffer`] (the hierarchical Z-buffer, Greene, Kass
//! and Miller 1993; RTR §7.2), [`occlusion::MaskedBuffer`] (Hasselgren et
//! al. 2016) and [`occlusion::OcclusionTree`] (Bittner et al. 1998), with
//! their rasterizers, pyramids and the only `unsafe` of the workspace (the
//! vector kernels). This crate holds what needs a [`scene::Scene`]:
//! - the occluder database and selection (`occluders/database.rs`,
//!   `occluders/selection.rs`, Zhang et al. 1997 §6) and virtual occluders
//!   (`occluders/virtual_occluder.rs`, Law and Tan 1999);
//! - the cullers ([`cull`]): HOM, HZB, masked and the occlusion tree are one
//!   culler over their buffers ([`cull::OccluderCuller`],
//!   `cull/occluder_culler.rs`: select occluders, draw them into the buffer,
//!   traverse the BVH front to back, `cull/traversal.rs`), with coherence
//!   (Bittner and Havran 2002, `cull/coherence.rs`) and the cost model
//!   (`cull/governor.rs`); statistics typed per concern ([`cull::CullStats`]);
//!   hierarchical visibility (Greene et al. 1993: the octree
//!   `spatial/octree.rs`, the culler [`cull::HvCuller`], `cull/hv.rs`);
//! - the model database: a binned-SAH BVH (`spatial/bvh.rs`, Wald 2007);
//! - view-cell PVS ([`pvs`], Law and Tan 1999) and level of detail guided by
//!   visibility ([`lod`]).
//!
//! What lost its measurement (the kD-tree traversal with visibility
//! propagation, HV's temporal priming, PVS occluder fusion) is kept under
//! [`experimental`], each item with why.

#![forbid(unsafe_code)]

pub mod cull;
pub mod experimental;
pub mod lod;
pub mod occluders;
pub mod pvs;
pub mod scene;
pub(crate) mod simplify;
pub mod spatial;

pub use glam;
/// The engine crate, `hom-occlusion`: occlusion buffers filled with your own
/// triangles and matrices. Its [`occlusion::geom`] is hom's [`geom`].
pub use hom_occlusion as occlusion;
/// Meshes cut into clusters, the unit of culling for parts of big meshes
/// (Scene-free: positions and indices in, index ranges with bounds out).
pub use hom_occlusion::clusters;
pub use hom_occlusion::geom;

pub(crate) use hom_occlusion::details::vec_bytes;
