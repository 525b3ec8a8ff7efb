//! What the occluder-based cullers (HOM, HZB) share, so that they differ
//! only in how occlusion is represented: the model database (object boxes in
//! a BVH, refit when objects move), the occluder database, per-frame occluder
//! selection with its feedback, and the occlusion traversal — the BVH front
//! to back, the frustum's three-way test, then an occlusion test of each
//! node's and object's screen rectangle. An occluded node culls its whole
//! subtree; boxes straddling the near plane are never image-tested; this
//! frame's occluders are always drawn.

use super::model_db::{Change, ModelDb};
use super::{CullError, CullOutput};
use crate::geom::{project_points, Containment, Eye, Footprint, Frustum, ScreenRect, View};
use crate::map::Hole;
use crate::occluders::draw_occluders;
use crate::occluders::{OccluderConfig, OccluderDb, OccluderSelector, SelectionStats};
use crate::occlusion::{BufferOptions, OcclusionBuffer, OcclusionError, Sampling};
use crate::scene::Scene;
use glam::{Mat4, Vec3};

/// The buffer options of the occluder cullers: hom's own clip convention and
/// the reference renderer's exact sampling (the oracle draws with it).
pub(crate) fn culler_buffer_options() -> BufferOptions {
    BufferOptions {
        sampling: Sampling::Exact,
        ..BufferOptions::default()
    }
}

/// The culler's buffer in `slot`, made anew by `make(width, height)` when
/// there is none yet or the view's viewport changed.
pub(crate) fn sized<'a, B: OcclusionBuffer>(
    slot: &'a mut Option<B>,
    view: &View,
    make: impl FnOnce(u32, u32) -> Result<B, OcclusionError>,
) -> &'a mut B {
    let (w, h) = (view.width, view.height);
    if slot.as_ref().is_none_or(|b| (b.width(), b.height()) != (w, h)) {
        *slot = Some(make(w, h).expect("a validated view has a valid viewport"));
    }
    slot.as_mut().expect("made above")
}

/// The representation-independent state of an occluder-based culler.
pub(crate) struct OccluderCulling {
    model: ModelDb,
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
    /// World to clip, hom's convention.
    pub world_to_clip: Mat4,
    pub eye: Eye,
    pub width: u32,
    pub height: u32,
    /// This frame's occluders (ascending ids): drawn, and rasterized by the culler.
    pub occluders: Vec<u32>,
    stats: SelectionStats,
}

impl OccluderCulling {
    /// Builds the BVH over the objects' boxes and the occluder database.
    pub fn new(scene: &Scene, config: &OccluderConfig) -> OccluderCulling {
        OccluderCulling {
            model: ModelDb::new(scene),
            db: OccluderDb::build(scene, &config.occluder_db),
            selector: OccluderSelector::new(config.selection.clone()),
            is_occluder: Vec::new(),
            culled_pct: 0.0,
        }
    }

    /// Starts a frame: validates the view, clears `out`, follows the scene's
    /// changes (refit, or a rebuilt occluder database keeping its stand-ins),
    /// finds last frame's worst hole with `worst_hole` (only when the
    /// selection asks for one) and selects this frame's occluders; each step timed.
    pub fn select(
        &mut self,
        scene: &Scene,
        view: &View,
        out: &mut CullOutput,
        worst_hole: impl FnOnce() -> Option<Hole>,
    ) -> Result<Selected, CullError> {
        view.validate()?;
        out.clear();
        let Self { model, db, .. } = self;
        out.time("refit", || {
            if model.sync(scene) == Change::Structure {
                db.rebuild(scene);
            }
        });
        let world_to_clip = view.world_to_clip();
        let frustum = Frustum::from_view_proj(&world_to_clip).expect("a validated view has a frustum");
        let eye = view.eye();
        let hole = if self.selector.wants_hole() {
            out.time("hole", worst_hole)
        } else {
            None
        };
        let mut occluders = std::mem::take(&mut out.occluders);
        let stats = out.time("selection", || {
            self.selector.select(
                &self.db,
                scene,
                &world_to_clip,
                &eye,
                &frustum,
                hole.as_ref(),
                &mut occluders,
            )
        });
        Ok(Selected {
            frustum,
            world_to_clip,
            eye,
            width: view.width,
            height: view.height,
            occluders,
            stats,
        })
    }

    /// The timed stage `raster`: clears `buffer`, queues this frame's
    /// occluders nearest first and draws them. Returns the occluder
    /// triangles submitted.
    pub fn draw(
        &self,
        scene: &Scene,
        frame: &Selected,
        buffer: &mut impl OcclusionBuffer,
        out: &mut CullOutput,
    ) -> u64 {
        out.time("raster", || {
            buffer.clear();
            let n = draw_occluders(
                buffer,
                scene,
                &self.db,
                &frame.occluders,
                &frame.world_to_clip,
                &frame.eye,
            );
            buffer.flush();
            n
        })
    }

    /// Ends a frame: the timed traversal with `is_occluded` deciding each
    /// screen rectangle, then the visible, occluded and occluder sets and the
    /// counters into `out`. `occluder_triangles` is what the culler drew.
    pub fn traverse(
        &mut self,
        scene: &Scene,
        out: &mut CullOutput,
        frame: Selected,
        occluder_triangles: u64,
        is_occluded: impl FnMut(&ScreenRect) -> bool,
    ) {
        let mut visible = std::mem::take(&mut out.visible);
        let mut occluded = std::mem::take(&mut out.occluded);
        let traversal = Traversal {
            scene,
            model: &self.model,
            frame: &frame,
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
    scene: &'a Scene,
    model: &'a ModelDb,
    frame: &'a Selected,
}

impl Traversal<'_> {
    /// Fills `visible` and `occluded` (both ascending) using `is_occluded` on
    /// screen rectangles; `is_occluder` is scratch of one flag per object.
    /// Returns the number of box tests (nodes and objects).
    pub fn run(
        &self,
        is_occluder: &mut Vec<bool>,
        mut is_occluded: impl FnMut(&ScreenRect) -> bool,
        visible: &mut Vec<u32>,
        occluded: &mut Vec<u32>,
    ) -> u64 {
        let (bvh, boxes, scene, f) = (self.model.bvh(), self.model.boxes(), self.scene, self.frame);
        is_occluder.clear();
        is_occluder.resize(scene.objects().len(), false);
        for &id in &f.occluders {
            is_occluder[id as usize] = true;
        }
        let footprint = |corners: &[Vec3; 8]| project_points(corners, &f.world_to_clip, f.width, f.height);
        let mut box_tests = 0u64;
        bvh.traverse_front_to_back(&f.eye, false, |_, node, inside| {
            box_tests += 1;
            let containment = if inside {
                Containment::Inside
            } else {
                f.frustum.test_aabb(&node.bounds)
            };
            if containment == Containment::Outside {
                return None;
            }
            let inside = containment == Containment::Inside;
            if let Footprint::Rect(r) = footprint(&node.bounds.corners()) {
                if is_occluded(&r) {
                    // Only live objects in the frustum count as occlusion-culled.
                    let items = bvh.subtree_items(node).iter().copied();
                    occluded.extend(items.filter(|&id| {
                        scene.get(id).is_some()
                            && !is_occluder[id as usize]
                            && (inside || f.frustum.test_aabb(&boxes[id as usize]) != Containment::Outside)
                    }));
                    return None;
                }
            }
            for &id in bvh.leaf_items(node) {
                box_tests += self.object(id, inside, is_occluder, &mut is_occluded, visible, occluded);
            }
            Some(inside)
        });
        // Objects added since the BVH was built.
        for &id in self.model.extra() {
            box_tests += self.object(id, false, is_occluder, &mut is_occluded, visible, occluded);
        }
        // This frame's occluders are drawn (they were selected in the frustum).
        visible.extend_from_slice(&f.occluders);
        visible.sort_unstable();
        occluded.sort_unstable();
        box_tests
    }

    /// Tests one object: frustum (its oriented box when it moves; none when
    /// its node was wholly `inside`), then its rectangle. Returns the box tests made.
    fn object(
        &self,
        id: u32,
        inside: bool,
        is_occluder: &[bool],
        is_occluded: &mut impl FnMut(&ScreenRect) -> bool,
        visible: &mut Vec<u32>,
        occluded: &mut Vec<u32>,
    ) -> u64 {
        let f = self.frame;
        let Some(o) = self.scene.get(id) else {
            return 0; // removed
        };
        if is_occluder[id as usize] {
            return 1; // added at the end, whatever its subtree's fate
        }
        let (c, corners) = if o.is_dynamic() {
            (f.frustum.test_obb(&o.obb), o.obb.corners())
        } else if inside {
            (Containment::Inside, o.aabb.corners())
        } else {
            (f.frustum.test_aabb(&o.aabb), o.aabb.corners())
        };
        if c != Containment::Outside {
            match project_points(&corners, &f.world_to_clip, f.width, f.height) {
                Footprint::Rect(r) if is_occluded(&r) => occluded.push(id),
                _ => visible.push(id),
            }
        }
        1
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
