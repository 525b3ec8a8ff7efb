//! The occlusion traversal of the occluder cullers: the BVH front to back,
//! the frustum's three-way test, then an occlusion test of each node's and
//! object's screen rectangle. An occluded node culls its whole subtree;
//! boxes straddling the near plane are never image-tested. The frame it
//! walks is [`Selected`], made by [`super::occluder_culler`].

use super::coherence::{combine, Step, TemporalState, Vis};
use super::model_db::ModelDb;
use crate::geom::{project_points, Containment, Eye, Footprint, Frustum, ScreenRect};
use crate::occluders::SelectionStats;
use crate::scene::{Object, Scene};
use crate::spatial::bvh::BvhNode;
use glam::{Mat4, Vec3};

/// One frame after occluder selection.
pub(crate) struct Selected {
    pub frustum: Frustum,
    /// World to clip, hom's convention.
    pub world_to_clip: Mat4,
    pub eye: Eye,
    pub width: u32,
    pub height: u32,
    /// This frame's occluders (ascending ids), rasterized by the culler.
    pub occluders: Vec<u32>,
    /// Those of them drawn as their originals though they have a virtual occluder.
    pub originals: Vec<u32>,
    pub stats: SelectionStats,
}
/// What one frame's traversal looks at.
pub(super) struct Traversal<'a> {
    pub scene: &'a Scene,
    pub model: &'a ModelDb,
    pub frame: &'a Selected,
    /// Per object: known hidden this frame (may be shorter than the objects).
    pub known_hidden: &'a [bool],
}

/// What a traversal did, for the counters.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct TraversalCounts {
    /// Nodes classified by a test: found outside the frustum, or tested
    /// against the buffer.
    pub node_tests: u64,
    /// Objects classified by a test.
    pub object_tests: u64,
    /// Nodes in view opened without their buffer test, and nodes and objects
    /// assumed visible.
    pub skipped: u64,
    /// Nodes visibility propagation was tried on (kD-tree only).
    pub propagation_attempts: u64,
    /// Nodes it classified invisible without a test.
    pub propagated: u64,
}

/// The mutable side of a traversal: the state kept across frames, the
/// buffer's test, the output lists and the counters.
pub(super) struct Visit<'a, F> {
    pub temporal: &'a mut TemporalState,
    pub is_occluded: F,
    pub visible: &'a mut Vec<u32>,
    pub occluded: &'a mut Vec<u32>,
    pub stats: TraversalCounts,
}

impl Traversal<'_> {
    /// Fills `visible` and `occluded` (both ascending) using `is_occluded` on
    /// screen rectangles, reusing and updating `temporal` as its mode says.
    pub fn run(
        &self,
        temporal: &mut TemporalState,
        is_occluded: impl FnMut(&ScreenRect) -> bool,
        visible: &mut Vec<u32>,
        occluded: &mut Vec<u32>,
    ) -> TraversalCounts {
        let (bvh, f) = (self.model.bvh(), self.frame);
        let v = &mut Visit {
            temporal,
            is_occluded,
            visible,
            occluded,
            stats: TraversalCounts::default(),
        };
        bvh.walk_front_to_back(
            &f.eye,
            false,
            v,
            |v, i, node, inside| self.node(i, node, inside, v),
            |v, i, node| v.temporal.pull_up(i, node.first, node.first + 1),
        );
        // Objects added since the BVH was built.
        for &id in self.model.extra() {
            self.object(id, false, v);
        }
        v.visible.sort_unstable();
        v.occluded.sort_unstable();
        v.stats
    }

    /// Classifies node `i`, wholly inside the frustum when `inside`; returns
    /// the state for its children when the traversal goes into them.
    fn node<F: FnMut(&ScreenRect) -> bool>(
        &self,
        i: u32,
        node: &BvhNode,
        inside: bool,
        v: &mut Visit<'_, F>,
    ) -> Option<bool> {
        let (f, bvh) = (self.frame, self.model.bvh());
        let step = v.temporal.node_step(i);
        // The frustum first, in every step: it is cheap, and after a turn or
        // a cut it ends, at the top, a subtree opened last frame that is now
        // out of view (without it a cut frame made up to 2x the classical tests).
        let containment = if inside {
            Containment::Inside
        } else {
            f.frustum.test_aabb(&node.bounds)
        };
        if containment == Containment::Outside {
            v.stats.node_tests += 1;
            v.temporal.set_node(i, Vis::Invisible);
            return None;
        }
        let inside = containment == Containment::Inside;
        if step == Step::Open {
            v.stats.skipped += 1;
            if node.is_leaf() {
                self.leaf(i, node, inside, v);
            }
            return Some(inside);
        }
        if step == Step::Assume {
            v.stats.skipped += 1;
            self.assume_visible(node, inside, v.visible);
            v.temporal.assume_node(i);
            return None;
        }
        v.stats.node_tests += 1;
        if let Footprint::Rect(r) = self.footprint(&node.bounds.corners()) {
            if (v.is_occluded)(&r) {
                // Only live objects in the frustum count as occlusion-culled.
                let items = bvh.subtree_items(node).iter().copied();
                v.occluded
                    .extend(items.filter(|&id| self.scene.get(id).is_some_and(|o| self.meets_frustum(o, inside))));
                v.temporal.set_node(i, Vis::Invisible);
                return None;
            }
        }
        if node.is_leaf() {
            self.leaf(i, node, inside, v);
        }
        Some(inside)
    }

    /// The objects of leaf `i`, then (coherence on) the leaf's pull-up from them.
    fn leaf<F: FnMut(&ScreenRect) -> bool>(&self, i: u32, node: &BvhNode, inside: bool, v: &mut Visit<'_, F>) {
        let (mut seen, mut unseen) = (0, 0);
        for &id in self.model.bvh().leaf_items(node) {
            match self.object(id, inside, v) {
                Some(Vis::Invisible) => unseen += 1,
                Some(_) => seen += 1,
                None => {}
            }
        }
        v.temporal.set_node(i, combine(seen, unseen));
    }

    /// Classifies one object: frustum (its oriented box when it moves; none
    /// when its node was wholly `inside`), then its rectangle, unless assumed
    /// visible. `None` for a removed object.
    pub(super) fn object<F: FnMut(&ScreenRect) -> bool>(
        &self,
        id: u32,
        inside: bool,
        v: &mut Visit<'_, F>,
    ) -> Option<Vis> {
        let o = self.scene.get(id)?;
        let vis = if !self.meets_frustum(o, inside) {
            Vis::Invisible
        } else if self.known_hidden.get(id as usize).copied().unwrap_or(false) {
            v.stats.skipped += 1;
            v.occluded.push(id);
            v.temporal.set_object(id, Vis::Invisible);
            return Some(Vis::Invisible);
        } else if v.temporal.object_assumed(id) {
            v.stats.skipped += 1;
            v.temporal.assume_object(id);
            v.visible.push(id);
            return Some(Vis::Visible);
        } else {
            match self.footprint(&o.test_corners()) {
                Footprint::Rect(r) if (v.is_occluded)(&r) => {
                    v.occluded.push(id);
                    Vis::Invisible
                }
                _ => {
                    v.visible.push(id);
                    Vis::Visible
                }
            }
        };
        v.stats.object_tests += 1;
        v.temporal.set_object(id, vis);
        Some(vis)
    }

    /// Conservative hierarchy updating: every live object of `node`'s subtree
    /// that meets the frustum (all of them when the node is wholly `inside`)
    /// into `visible`, without an occlusion test.
    fn assume_visible(&self, node: &BvhNode, inside: bool, visible: &mut Vec<u32>) {
        for &id in self.model.bvh().subtree_items(node) {
            let Some(o) = self.scene.get(id) else { continue };
            if self.meets_frustum(o, inside) {
                visible.push(id);
            }
        }
    }

    /// The frustum test of an object: its oriented box when it moves, else
    /// its box, which needs no test when its node was wholly `inside`.
    pub(super) fn meets_frustum(&self, o: &Object, inside: bool) -> bool {
        let frustum = &self.frame.frustum;
        if o.is_dynamic() {
            frustum.test_obb(&o.obb) != Containment::Outside
        } else {
            inside || frustum.test_aabb(&o.aabb) != Containment::Outside
        }
    }

    /// The screen footprint of a box's corners.
    pub(super) fn footprint(&self, corners: &[Vec3; 8]) -> Footprint {
        let f = self.frame;
        project_points(corners, &f.world_to_clip, f.width, f.height)
    }
}
