//! What the occluder-based cullers (HOM, HZB) share, so that they differ
//! only in how occlusion is represented: the model database (object boxes in
//! a BVH, refit when objects move), the occluder database, per-frame occluder
//! selection with its feedback, and the occlusion traversal — the BVH front
//! to back, the frustum's three-way test, then an occlusion test of each
//! node's and object's screen rectangle. An occluded node culls its whole
//! subtree; boxes straddling the near plane are never image-tested.
//!
//! This frame's occluders are tested like every other object: an occluder
//! hidden by nearer ones is culled. Sound because an object's own triangles
//! (or its stand-in's, which lie inside it) are never nearer than its box's
//! nearest depth, so they cannot hide it; an object is culled only where
//! other occluders' triangles lie nearer at every sample, and following
//! "hidden by" from a culled object reaches, depth falling strictly at each
//! step, an occluder that is drawn and nearer there. (Drawing every
//! selected occluder, as before, cost office 2 points of efficiency: 93.0 →
//! 95.0 %, city 74.3 → 75.9 %, 60 frames.)

use super::coherence::{combine, Coherence, Step, TemporalState, Vis};
use super::frustum::frustum_visible;
use super::governor::{FrameFacts, Governor};
use super::kd_traversal::{Hierarchy, KdModel};
use super::model_db::{Change, ModelDb};
use super::{CullError, CullOutput};
use crate::geom::{project_points, Containment, Eye, Footprint, Frustum, ScreenRect, View};
use crate::lod::OccluderLod;
use crate::occluders::draw_occluders;
use crate::occluders::{ObjectBoxes, OccluderConfig, OccluderCuts, OccluderDb, OccluderSelector, SelectionStats};
use crate::occlusion::details::Hole;
use crate::occlusion::{BufferOptions, OcclusionBuffer, OcclusionError, Sampling};
use crate::scene::{Object, Scene};
use crate::spatial::bvh::BvhNode;
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
    /// Last frame's share of triangles culled, for the selection's feedback.
    culled_pct: f32,
    /// Classifications kept across frames (coherence).
    temporal: TemporalState,
    /// Whether occlusion culling pays this frame (the cost model).
    governor: Governor,
    /// Whether the last frame ran the occlusion work (it did not rest).
    culled_last: bool,
    /// The hierarchy traversed.
    hierarchy: Hierarchy,
    /// The kD-tree, when it is the hierarchy.
    kd: Option<KdModel>,
    /// Per object: known hidden this frame ([`super::Culler::set_known_hidden`]).
    known_hidden: Vec<bool>,
    /// The ids set in `known_hidden`, to clear them.
    known_hidden_ids: Vec<u32>,
    /// The last frame's world to clip and viewport, while its buffer holds
    /// that frame's occluders (`None` after a resting frame).
    last_frame: Option<(Mat4, u32, u32)>,
    /// Occluders at the frame's level of detail ([`super::Culler::set_occluder_lod`]).
    cuts: OccluderCuts,
}

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
    originals: Vec<u32>,
    stats: SelectionStats,
}

impl OccluderCulling {
    /// Builds the BVH over the objects' boxes and the occluder database; the
    /// traversal reuses last frame's classification as `coherence` says, and
    /// with `cost_model` frames rest (frustum culling only) while occlusion
    /// culling does not pay for itself. With [`Hierarchy::KdTree`] the
    /// occlusion traversal walks a kD-tree too (resting frames and occluder
    /// selection keep the BVH).
    pub fn new(
        scene: &Scene,
        config: &OccluderConfig,
        coherence: Coherence,
        cost_model: bool,
        hierarchy: Hierarchy,
    ) -> OccluderCulling {
        let model = ModelDb::new(scene);
        let kd = match hierarchy {
            Hierarchy::Bvh => None,
            Hierarchy::KdTree { propagation } => Some(KdModel::new(&model, scene, propagation)),
        };
        OccluderCulling {
            model,
            db: OccluderDb::build(scene, &config.occluder_db),
            selector: OccluderSelector::new(config.selection.clone()),
            culled_pct: 0.0,
            temporal: TemporalState::new(coherence),
            governor: Governor::new(cost_model),
            culled_last: false,
            hierarchy,
            kd,
            known_hidden: Vec::new(),
            known_hidden_ids: Vec::new(),
            last_frame: None,
            cuts: OccluderCuts::default(),
        }
    }

    /// Draws occluders at their level of detail from the next frame on
    /// (see [`super::Culler::set_occluder_lod`]); `None`: as their meshes.
    pub fn set_occluder_lod(&mut self, lod: Option<OccluderLod>) {
        self.cuts.set(lod);
    }

    /// This frame's objects known hidden (ascending ids; see
    /// [`super::Culler::set_known_hidden`]): not selected as occluders, and reported
    /// occluded without a test while they stay static. Cleared by the next call.
    pub fn set_known_hidden(&mut self, scene: &Scene, hidden: &[u32]) {
        for &id in &self.known_hidden_ids {
            self.known_hidden[id as usize] = false;
        }
        self.known_hidden_ids.clear();
        self.known_hidden.resize(scene.objects().len(), false);
        for &id in hidden {
            let static_object = scene.get(id).is_some_and(|o| !o.is_dynamic());
            if static_object {
                self.known_hidden[id as usize] = true;
                self.known_hidden_ids.push(id);
            }
        }
    }

    /// A resting frame, when the cost model says occlusion culling does not
    /// pay for itself now: frustum culling alone into `out` (stages `refit`,
    /// `frustum`; counter `rested`). Returns `false`, doing nothing, on a
    /// frame that culls.
    pub fn rest(&mut self, scene: &Scene, view: &View, out: &mut CullOutput) -> Result<bool, CullError> {
        if !self.governor.rests() {
            self.culled_last = true;
            return Ok(false);
        }
        self.culled_last = false;
        self.last_frame = None;
        self.start(scene, view, out)?;
        let frustum = view.frustum().expect("a validated view has a frustum");
        let mut visible = std::mem::take(&mut out.visible);
        let model = &self.model;
        let tests = out.time("frustum", || frustum_visible(model, scene, &frustum, &mut visible));
        self.governor.record(FrameFacts {
            culled: false,
            cull_ms: out.total_ms(),
            drawn: triangles(scene, &visible),
            occluded: 0,
        });
        out.visible = visible;
        out.count("node_tests", tests);
        out.count("rested", 1);
        Ok(true)
    }

    /// What every frame starts with, resting or not: validates the view,
    /// clears `out`, and (timed as `refit`) follows the scene's changes (refit,
    /// or a rebuilt occluder database keeping its stand-ins) and starts the
    /// frame's temporal state.
    fn start(&mut self, scene: &Scene, view: &View, out: &mut CullOutput) -> Result<(), CullError> {
        view.validate()?;
        out.clear();
        let Self {
            model,
            db,
            temporal,
            kd,
            ..
        } = self;
        out.time("refit", || {
            let change = model.sync(scene);
            if change == Change::Structure {
                db.rebuild(scene);
            }
            match kd {
                Some(kd) => {
                    kd.sync(model, scene, change);
                    kd.begin(temporal, model, scene.objects().len());
                }
                None => temporal.begin(model, scene.objects().len()),
            }
        });
        Ok(())
    }

    /// Starts a frame ([`OccluderCulling::start`]), finds last frame's worst
    /// hole with `worst_hole` (only when the selection asks for one) and
    /// selects this frame's occluders; each step timed.
    pub fn select(
        &mut self,
        scene: &Scene,
        view: &View,
        out: &mut CullOutput,
        worst_hole: impl FnOnce() -> Option<Hole>,
    ) -> Result<Selected, CullError> {
        self.start(scene, view, out)?;
        let world_to_clip = view.world_to_clip();
        let frustum = Frustum::from_view_proj(&world_to_clip).expect("a validated view has a frustum");
        let eye = view.eye();
        let hole = if self.selector.wants_hole() {
            out.time("hole", worst_hole)
        } else {
            None
        };
        let mut occluders = std::mem::take(&mut out.occluders);
        let mut originals = Vec::new();
        self.cuts.begin(view);
        let stats = out.time("selection", || {
            self.selector.select(
                &self.db,
                scene,
                ObjectBoxes {
                    boxes: self.model.boxes(),
                    dynamic: self.model.dynamic(),
                    known_hidden: &self.known_hidden,
                },
                &world_to_clip,
                &eye,
                &frustum,
                hole.as_ref(),
                &mut self.cuts,
                &mut occluders,
                &mut originals,
            )
        });
        Ok(Selected {
            frustum,
            world_to_clip,
            eye,
            width: view.width,
            height: view.height,
            occluders,
            originals,
            stats,
        })
    }

    /// The timed stage `raster`: clears `buffer`, queues this frame's
    /// occluders nearest first and draws them. Returns the occluder
    /// triangles submitted; the buffer's own account of the work goes to
    /// the counters (`occluder_triangles_drawn` after clipping and culling,
    /// `occluder_setup_us` and `occluder_raster_us`, the tiles drawn and
    /// rejected; with occluders at the level of detail, `occluder_cuts`).
    pub fn draw(
        &self,
        scene: &Scene,
        frame: &Selected,
        buffer: &mut impl OcclusionBuffer,
        out: &mut CullOutput,
    ) -> u64 {
        let (drawn, cuts) = out.time("raster", || {
            buffer.clear();
            let n = draw_occluders(
                buffer,
                scene,
                &self.db,
                &self.cuts,
                &frame.occluders,
                &frame.originals,
                &frame.world_to_clip,
                &frame.eye,
                &frame.frustum,
            );
            buffer.flush();
            n
        });
        let stats = buffer.stats();
        if self.cuts.is_on() {
            out.count("occluder_cuts", cuts);
        }
        out.count("occluder_triangles_drawn", stats.triangles_drawn);
        out.count("occluder_setup_us", (stats.setup_ms * 1e3) as u64);
        out.count("occluder_raster_us", (stats.raster_ms * 1e3) as u64);
        out.count("occluder_tiles_drawn", stats.tiles_drawn);
        out.count("occluder_tiles_rejected", stats.tiles_rejected);
        drawn
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
            known_hidden: &self.known_hidden,
        };
        let temporal = &mut self.temporal;
        let kd = &mut self.kd;
        let stats = out.time("traversal", || match kd {
            Some(kd) => traversal.run_kd(kd, temporal, is_occluded, &mut visible, &mut occluded),
            None => traversal.run(temporal, is_occluded, &mut visible, &mut occluded),
        });
        let (drawn, hidden) = (triangles(scene, &visible), triangles(scene, &occluded));
        self.culled_pct = if drawn + hidden > 0 {
            100.0 * hidden as f32 / (drawn + hidden) as f32
        } else {
            0.0
        };
        self.governor.record(FrameFacts {
            culled: true,
            cull_ms: out.total_ms(),
            drawn,
            occluded: hidden,
        });
        out.visible = visible;
        out.occluded = occluded;
        self.last_frame = Some((frame.world_to_clip, frame.width, frame.height));
        out.occluders = frame.occluders;
        out.count("box_tests", stats.node_tests + stats.object_tests);
        out.count("node_tests", stats.node_tests);
        out.count("object_tests", stats.object_tests);
        out.count("tests_skipped", stats.skipped);
        if self.kd.is_some() {
            out.count("propagation_attempts", stats.propagation_attempts);
            out.count("propagated_invisible", stats.propagated);
        }
        count_occluders(out, &frame.stats, occluder_triangles);
        out.count("temporal_bytes", self.temporal.heap_bytes() as u64);
        out.count("state_bytes", self.state_bytes() as u64);
    }

    /// The screen rectangle of a world-space box's corners in the last frame
    /// that ran the occlusion work, for [`super::Culler::box_hidden`]:
    /// `None` after a resting frame or for a box crossing the near plane.
    pub fn last_rect(&self, corners: &[Vec3; 8]) -> Option<ScreenRect> {
        let (world_to_clip, width, height) = self.last_frame?;
        match project_points(corners, &world_to_clip, width, height) {
            Footprint::Rect(r) => Some(r),
            _ => None,
        }
    }

    /// Bytes of the culler's own state, the occlusion buffer excluded: the
    /// model and occluder databases, selection, flags and the temporal state.
    fn state_bytes(&self) -> usize {
        self.model.heap_bytes()
            + self.db.heap_bytes()
            + self.selector.heap_bytes()
            + self.temporal.heap_bytes()
            + self.kd.as_ref().map_or(0, KdModel::heap_bytes)
            + self.cuts.heap_bytes()
    }

    /// The configuration entries every occluder-based culler reports: its
    /// selection settings and the occluder database's report.
    pub fn describe(&self) -> [(&'static str, String); 9] {
        let c = self.selector.config();
        [
            ("hierarchy", self.hierarchy.to_string()),
            ("coherence", self.temporal.mode().to_string()),
            ("cost_model", self.governor.is_enabled().to_string()),
            ("selection", format!("{:?}", c.mode)),
            ("budget", c.budget.to_string()),
            ("adaptive_budget", c.adaptive.to_string()),
            ("hole_filling", c.hole_filling.to_string()),
            ("occluders", self.db.report()),
            ("occluder_meshes", self.db.config().meshes.to_string()),
        ]
    }

    /// Feeds the frame's outcome back into the cost model and (after a frame
    /// that culled) occluder selection.
    pub fn feedback(&mut self, frame_ms: Option<f64>) {
        self.governor.feedback(frame_ms);
        if self.culled_last {
            self.selector.feedback(self.culled_pct, frame_ms);
        }
    }
}

/// What one frame's traversal looks at.
pub(super) struct Traversal<'a> {
    pub scene: &'a Scene,
    model: &'a ModelDb,
    pub frame: &'a Selected,
    /// Per object: known hidden this frame (may be shorter than the objects).
    known_hidden: &'a [bool],
}

/// What a traversal did, for the counters.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct TraversalStats {
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
    pub stats: TraversalStats,
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
    ) -> TraversalStats {
        let (bvh, f) = (self.model.bvh(), self.frame);
        let v = &mut Visit {
            temporal,
            is_occluded,
            visible,
            occluded,
            stats: TraversalStats::default(),
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
            let corners = if o.is_dynamic() {
                o.obb.corners()
            } else {
                o.aabb.corners()
            };
            match self.footprint(&corners) {
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

/// The triangles of the objects `ids`.
fn triangles(scene: &Scene, ids: &[u32]) -> u64 {
    ids.iter().map(|&i| scene.object(i).triangles as u64).sum()
}

/// The counters every occluder-based culler reports about its occluders.
fn count_occluders(out: &mut CullOutput, sel: &SelectionStats, occluder_triangles: u64) {
    out.count("occluders", sel.selected as u64);
    out.count("occluder_triangles", occluder_triangles);
    out.count("hole_fillers", sel.hole_fillers as u64);
    out.count("queued_occluders", sel.queued as u64);
    out.count("occluder_originals", sel.originals as u64);
    out.count("budget", sel.budget as u64);
    out.count("candidates", sel.candidates as u64);
}
