//! What the occluder-based cullers (HOM, HZB) share, so that they differ
//! only in how occlusion is represented: the model database (object boxes in
//! a BVH, refit when objects move), the occluder database, per-frame occluder
//! selection with its feedback, and the occlusion traversal — the BVH front
//! to back, the frustum's three-way test, then an occlusion test of each
//! node's and object's screen rectangle. An occluded node culls its whole
//! subtree; boxes straddling the near plane are never image-tested; this
//! frame's occluders are always drawn.

use super::frustum::refit_if_dynamic;
use super::{CullError, CullOutput};
use crate::geom::{project_points, Aabb, Camera, Containment, Footprint, Frustum, ScreenRect};
use crate::map::Hole;
use crate::occluders::{OccluderDb, OccluderDbConfig, OccluderSelector, SelectionConfig, SelectionStats};
use crate::scene::Scene;
use crate::spatial::{Bvh, BvhConfig};
use glam::{Mat4, Vec3};

/// The representation-independent state of an occluder-based culler.
pub(crate) struct OccluderCulling {
    bvh: Bvh,
    /// Current object boxes (the BVH's items).
    boxes: Vec<Aabb>,
    /// The occluder database.
    pub db: OccluderDb,
    selector: OccluderSelector,
    /// Scratch: one flag per object.
    is_occluder: Vec<bool>,
    /// Last frame's share of triangles culled, for the selection's feedback.
    culled_pct: f32,
}

/// One frame after occluder selection.
pub(crate) struct Selected {
    pub frustum: Frustum,
    pub view_proj: Mat4,
    /// This frame's occluders (ascending ids): drawn, and rasterized by the culler.
    pub occluders: Vec<u32>,
    stats: SelectionStats,
}

impl OccluderCulling {
    /// Builds the BVH over the objects' boxes and the occluder database.
    pub fn new(scene: &Scene, selection: &SelectionConfig, db: &OccluderDbConfig) -> OccluderCulling {
        let boxes: Vec<Aabb> = scene.objects().iter().map(|o| o.aabb).collect();
        OccluderCulling {
            bvh: Bvh::build(&boxes, &BvhConfig::default()),
            boxes,
            db: OccluderDb::build(scene, db),
            selector: OccluderSelector::new(selection.clone()),
            is_occluder: vec![false; scene.objects().len()],
            culled_pct: 0.0,
        }
    }

    /// Starts a frame: validates the camera, clears `out`, refits the BVH to
    /// moved objects, finds last frame's worst hole with `worst_hole` (only
    /// when the selection asks for one) and selects this frame's occluders;
    /// each step timed.
    pub fn select(
        &mut self,
        scene: &Scene,
        camera: &Camera,
        out: &mut CullOutput,
        worst_hole: impl FnOnce() -> Option<Hole>,
    ) -> Result<Selected, CullError> {
        camera.validate()?;
        out.clear();
        let Self { bvh, boxes, .. } = self;
        out.time("refit", || refit_if_dynamic(scene, bvh, boxes))?;
        let view_proj = camera.view_proj();
        let frustum = Frustum::from_view_proj(&view_proj).expect("a validated camera has a frustum");
        let hole = if self.selector.wants_hole() {
            out.time("hole", worst_hole)
        } else {
            None
        };
        let mut occluders = std::mem::take(&mut out.occluders);
        let stats = out.time("selection", || {
            self.selector
                .select(&self.db, scene, camera, &frustum, hole.as_ref(), &mut occluders)
        });
        Ok(Selected {
            frustum,
            view_proj,
            occluders,
            stats,
        })
    }

    /// Ends a frame: the timed traversal with `is_occluded` deciding each
    /// screen rectangle, then the visible, occluded and occluder sets and the
    /// counters into `out`. `occluder_triangles` is what the culler drew.
    pub fn traverse(
        &mut self,
        scene: &Scene,
        camera: &Camera,
        out: &mut CullOutput,
        frame: Selected,
        occluder_triangles: u64,
        is_occluded: impl FnMut(&ScreenRect) -> bool,
    ) {
        let mut visible = std::mem::take(&mut out.visible);
        let mut occluded = std::mem::take(&mut out.occluded);
        let traversal = Traversal {
            scene,
            bvh: &self.bvh,
            boxes: &self.boxes,
            frustum: &frame.frustum,
            view_proj: frame.view_proj,
            width: camera.width,
            height: camera.height,
            eye: camera.eye,
            occluders: &frame.occluders,
        };
        let is_occluder = &mut self.is_occluder;
        let box_tests = out.time("traversal", || {
            traversal.run(is_occluder, is_occluded, &mut visible, &mut occluded)
        });
        self.culled_pct = occluded_share(scene, &visible, &occluded);
        out.visible = visible;
        out.occluded = occluded;
        out.occluders = frame.occluders;
        out.count("box_tests", box_tests);
        count_occluders(out, &frame.stats, occluder_triangles);
    }

    /// The configuration entries every occluder-based culler reports: its
    /// selection settings and the occluder database's report.
    pub fn describe(&self) -> [(&'static str, String); 5] {
        let c = self.selector.config();
        [
            ("selection", format!("{:?}", c.mode)),
            ("budget", c.budget.to_string()),
            ("adaptive_budget", c.adaptive.to_string()),
            ("hole_filling", c.hole_filling.to_string()),
            ("occluders", self.db.report()),
        ]
    }

    /// Feeds the frame's outcome back into occluder selection.
    pub fn feedback(&mut self, frame_ms: Option<f64>) {
        self.selector.feedback(self.culled_pct, frame_ms);
    }
}

/// What one frame's traversal looks at.
struct Traversal<'a> {
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
fn occluded_share(scene: &Scene, visible: &[u32], occluded: &[u32]) -> f32 {
    let tris = |ids: &[u32]| ids.iter().map(|&i| scene.object(i).triangles as u64).sum::<u64>();
    let (tv, to) = (tris(visible), tris(occluded));
    if tv + to > 0 {
        100.0 * to as f32 / (tv + to) as f32
    } else {
        0.0
    }
}

/// The counters every occluder-based culler reports about its occluders.
fn count_occluders(out: &mut CullOutput, sel: &SelectionStats, occluder_triangles: u64) {
    out.count("occluders", sel.selected as u64);
    out.count("occluder_triangles", occluder_triangles);
    out.count("hole_fillers", sel.hole_fillers as u64);
    out.count("queued_occluders", sel.queued as u64);
    out.count("budget", sel.budget as u64);
    out.count("candidates", sel.candidates as u64);
}
