//! Spatial hierarchies: the BVH over object bounds (the model database) and
//! the octree over triangles (hierarchical visibility).

pub(crate) mod bvh;
mod octree;

pub(crate) use bvh::{Bvh, BvhConfig};
pub use octree::{Octree, OctreeConfig, OctreeNode, TriRef};
