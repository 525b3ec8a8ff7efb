//! Spatial hierarchies: the BVH over object bounds (the model database) and
//! the octree over triangles (hierarchical visibility).

pub mod bvh;
pub mod octree;

pub use bvh::{Bvh, BvhConfig, BvhNode};
pub use octree::{Octree, OctreeConfig, OctreeNode, TriRef};
