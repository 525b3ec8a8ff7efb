//! Bounding volume hierarchy over object boxes. (Being written.)
use crate::geom::{Aabb, Frustum};
use glam::Vec3;
/// Build settings.
#[derive(Clone, Debug)]
pub struct BvhConfig {
    /// Most items per leaf.
    pub max_leaf_size: usize,
    /// SAH bins per axis.
    pub bins: usize,
}
impl Default for BvhConfig {
    fn default() -> Self {
        BvhConfig { max_leaf_size: 4, bins: 16 }
    }
}
/// A node.
#[derive(Clone, Copy, Debug)]
pub struct BvhNode {
    /// Bounds.
    pub bounds: Aabb,
    /// Inner: first child index (second is first+1). Leaf: first index into items.
    pub first: u32,
    /// Items in a leaf; 0 for an inner node.
    pub count: u32,
}
/// The hierarchy.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    nodes: Vec<BvhNode>,
    items: Vec<u32>,
}
impl Bvh {
    /// Builds over `boxes`; item i is box i.
    pub fn build(boxes: &[Aabb], _config: &BvhConfig) -> Bvh {
        let bounds = boxes.iter().fold(Aabb::EMPTY, |b, x| b.union(*x));
        Bvh { nodes: vec![BvhNode { bounds, first: 0, count: boxes.len() as u32 }], items: (0..boxes.len() as u32).collect() }
    }
    /// Refit.
    pub fn refit(&mut self, boxes: &[Aabb]) {
        self.nodes[0].bounds = boxes.iter().fold(Aabb::EMPTY, |b, x| b.union(*x));
    }
    /// Frustum cull.
    pub fn frustum_cull(&self, boxes: &[Aabb], frustum: &Frustum, out: &mut Vec<u32>) -> u64 {
        out.extend(self.items.iter().copied().filter(|&i| frustum.test_aabb(&boxes[i as usize]) != crate::geom::Containment::Outside));
        self.items.len() as u64
    }
    /// Nodes.
    pub fn nodes(&self) -> &[BvhNode] { &self.nodes }
    /// Front to back.
    pub fn traverse_front_to_back(&self, _eye: Vec3, _visit: impl FnMut(u32, &BvhNode) -> bool) {}
}
