//! Spatial hierarchies: the BVH over object bounds (the model database), the
//! kD-tree with ropes over object bounds (its alternative, for visibility
//! propagation) and the octree over triangles (hierarchical visibility).

pub(crate) mod bvh;
pub(crate) mod kdtree;
mod octree;

pub(crate) use bvh::{Bvh, BvhConfig};
pub(crate) use kdtree::KdConfig;
pub use octree::{Octree, OctreeConfig, OctreeNode, TriRef};
