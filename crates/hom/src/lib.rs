//! # hom — visibility culling for large 3D scenes
//!
//! Every frame, hom finds the objects a camera cannot see — outside the view
//! frustum, or hidden behind other objects — so a renderer never draws them.
//! This crate holds the algorithms only: no file I/O, no rendering.
//!
//! ## Conventions (obeyed everywhere)
//! - World: right-handed, +Y up, metres.
//! - Camera: view = `look_at_rh`; projection = `perspective_rh` (clip z in `[0, w]`);
//!   matrices are column-major 4×4 ([`glam::Mat4`]).
//! - Screen: pixel (0, 0) is the top-left; pixel centres at +0.5; depth is clip `z / w`.
//! - Object ids: `u32`, the object's index in the [`scene::Scene`], in file order; stable.
//! - A box that crosses the near plane or lies partly behind the eye is never
//!   culled by an image-space test ([`geom::Footprint::Straddles`]).
//! - Triangles are two-sided.
//!
//! ## Map
//! - [`geom`]: boxes, planes, frusta, the camera, conservative screen projection.
//! - [`scene`]: meshes, objects (static and dynamic), scenes.
//! - [`spatial`]: the model database (BVH over object bounds).
//! - [`cull`]: the [`cull::Culler`] interface and the basic cullers.

pub mod cull;
pub mod depth;
pub mod geom;
pub mod map;
pub mod occluders;
pub mod occlusion;
pub mod raster;
pub mod scene;
pub mod spatial;

pub use glam;
