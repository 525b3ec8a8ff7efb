//! Spatial hierarchies over object bounds: the model database.

pub mod bvh;

pub use bvh::{Bvh, BvhConfig, BvhNode};
