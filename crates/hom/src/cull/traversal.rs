//! The occlusion traversal shared by the image-space cullers (HOM, HZB): the
//! BVH front to back, the frustum's three-way test, then an occlusion test of
//! each node's and object's screen rectangle. An occluded node culls its whole
//! subtree; boxes straddling the near plane are never image-tested; this
//! frame's occluders are always drawn.

use super::CullOutput;
use crate::geom::{project_points, Aabb, Containment, Footprint, Frustum, ScreenRect};
use crate::occluders::SelectionStats;
use crate::scene::Scene;
use crate::spatial::Bvh;
use glam::{Mat4, Vec3};

/// What one frame's traversal looks at.
pub(crate) struct Traversal<'a> {
    pub scene: &'a Scene,
    pub bvh: &'a Bvh,
    /// Current object boxes (the BVH's items).
    pub boxes: &'a [Aabb],
    pub frustum: &'a Frustum,
    pub view_proj: Mat4,
    pub width: u32,
    pub height: u32,
    pub eye: Vec3,
    /// This frame's occluders (ascending ids).
    pub occluders: &'a [u32],
}

impl Traversal<'_> {
    /// Fills `visible` and `occluded` (both ascending) using `is_occluded` on
    /// screen rectangles; `is_occluder` is scratch of one flag per object.
    /// Returns the number of box tests (nodes and objects).
    pub fn run(
        &self,
        is_occluder: &mut [bool],
        mut is_occluded: impl FnMut(&ScreenRect) -> bool,
        visible: &mut Vec<u32>,
        occluded: &mut Vec<u32>,
    ) -> u64 {
        let (bvh, frustum, boxes, scene) = (self.bvh, self.frustum, self.boxes, self.scene);
        is_occluder.fill(false);
        for &id in self.occluders {
            is_occluder[id as usize] = true;
        }
        let footprint = |corners: &[Vec3; 8]| project_points(corners, &self.view_proj, self.width, self.height);
        let mut box_tests = 0u64;
        let mut stack: Vec<(u32, bool)> = if bvh.is_empty() { Vec::new() } else { vec![(0, false)] };
        while let Some((index, inside)) = stack.pop() {
            let node = &bvh.nodes()[index as usize];
            box_tests += 1;
            let containment = if inside {
                Containment::Inside
            } else {
                frustum.test_aabb(&node.bounds)
            };
            if containment == Containment::Outside {
                continue;
            }
            let inside = containment == Containment::Inside;
            if let Footprint::Rect(r) = footprint(&node.bounds.corners()) {
                if is_occluded(&r) {
                    // Only objects in the frustum count as occlusion-culled.
                    let items = bvh.subtree_items(node).iter().copied();
                    occluded.extend(items.filter(|&id| {
                        !is_occluder[id as usize]
                            && (inside || frustum.test_aabb(&boxes[id as usize]) != Containment::Outside)
                    }));
                    continue;
                }
            }
            if node.is_leaf() {
                for &id in bvh.leaf_items(node) {
                    let o = scene.object(id);
                    box_tests += 1;
                    if is_occluder[id as usize] {
                        continue; // added below, whatever its subtree's fate
                    }
                    // Dynamic objects are tested with their tighter oriented box.
                    let (c, corners) = if o.is_dynamic() {
                        (frustum.test_obb(&o.obb), o.obb.corners())
                    } else if inside {
                        (Containment::Inside, o.aabb.corners())
                    } else {
                        (frustum.test_aabb(&boxes[id as usize]), o.aabb.corners())
                    };
                    if c == Containment::Outside {
                        continue;
                    }
                    match footprint(&corners) {
                        Footprint::Rect(r) if is_occluded(&r) => occluded.push(id),
                        _ => visible.push(id),
                    }
                }
            } else {
                // Push the farther child first so the nearer one is visited first.
                let (a, b) = (node.first, node.first + 1);
                let da = bvh.nodes()[a as usize].bounds.distance_squared(self.eye);
                let db = bvh.nodes()[b as usize].bounds.distance_squared(self.eye);
                let (near, far) = if da <= db { (a, b) } else { (b, a) };
                stack.push((far, inside));
                stack.push((near, inside));
            }
        }
        // This frame's occluders are drawn (they were selected in the frustum).
        visible.extend_from_slice(self.occluders);
        visible.sort_unstable();
        occluded.sort_unstable();
        box_tests
    }
}

/// Percentage of the triangles in `visible` and `occluded` that are occluded:
/// the culling rate the occluder selection's feedback learns from.
pub(crate) fn occluded_share(scene: &Scene, visible: &[u32], occluded: &[u32]) -> f32 {
    let tris = |ids: &[u32]| ids.iter().map(|&i| scene.object(i).triangles as u64).sum::<u64>();
    let (tv, to) = (tris(visible), tris(occluded));
    if tv + to > 0 {
        100.0 * to as f32 / (tv + to) as f32
    } else {
        0.0
    }
}

/// The counters every occluder-based culler reports about its occluders.
pub(crate) fn count_occluders(out: &mut CullOutput, sel: &SelectionStats, occluder_triangles: u64) {
    out.count("occluders", sel.selected as u64);
    out.count("occluder_triangles", occluder_triangles);
    out.count("hole_fillers", sel.hole_fillers as u64);
    out.count("queued_occluders", sel.queued as u64);
    out.count("budget", sel.budget as u64);
    out.count("candidates", sel.candidates as u64);
}
