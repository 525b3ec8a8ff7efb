//! The occluder culler: one pipeline over any occlusion buffer. Per frame,
//! select occluders → draw them into the buffer → traverse the model
//! database front to back, testing each node's and object's screen
//! rectangle against the buffer. [`OccluderCuller`] is generic over the
//! buffer ([`CullerBuffer`]); HOM, HZB, masked and the occlusion tree are
//! that culler over their buffers (`culler_buffers.rs`: [`super::HomCuller`],
//! [`super::HzbCuller`], [`super::MaskedCuller`], [`super::OtreeCuller`]).
//! What they share, so that they differ only in how occlusion is
//! represented: the model database (object boxes in a BVH, refit when
//! objects move), the occluder database, per-frame occluder selection with
//! its feedback, coherence, the cost model, and the occlusion traversal —
//! the BVH front to back, the frustum's three-way test, then an occlusion
//! test of each node's and object's screen rectangle. An occluded node culls
//! its whole subtree; boxes straddling the near plane are never image-tested.
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

use super::coherence::{Coherence, TemporalState};
use super::depth_check::{DepthCheck, DepthChecker, SampleDepthQuery};
use super::frustum::frustum_visible;
use super::governor::{FrameFacts, Governor};
use super::kd_traversal::KdModel;
use super::model_db::{Change, ModelDb};
use super::traversal::{Selected, Traversal};
use super::{
    CullError, CullOutput, CullStats, Culler, FrustumStats, MemoryStats, OccluderStats, PropagationStats,
    TraversalStats,
};
use crate::experimental::KdTree;
use crate::geom::{project_points, Footprint, Frustum, ScreenRect, View};
use crate::lod::OccluderLod;
use crate::occluders::draw_occluders;
use crate::occluders::{ObjectBoxes, OccluderConfig, OccluderCuts, OccluderDb, OccluderSelector, SelectionStats};
use crate::occlusion::details::{Hole, RectTest};
use crate::occlusion::{BufferOptions, OcclusionBuffer, OcclusionError, Sampling, Threads};
use crate::scene::Scene;
use glam::{Mat4, Vec3};

/// The hierarchy the occluder cullers traverse (the model database's).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Hierarchy {
    /// The BVH over object boxes, refit when objects move. The default.
    #[default]
    Bvh,
    /// A kD-tree with ropes over the static objects' boxes (dynamic and
    /// added objects tested one by one); with `propagation`, visibility
    /// propagation through the ropes. Experimental: see [`KdTree`] for why.
    KdTree(KdTree),
}

impl std::fmt::Display for Hierarchy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Hierarchy::Bvh => write!(f, "bvh"),
            Hierarchy::KdTree(KdTree { propagation: false }) => write!(f, "kd"),
            Hierarchy::KdTree(KdTree { propagation: true }) => write!(f, "kd-propagate"),
        }
    }
}

/// What [`OccluderCuller`] needs of its buffer besides the front door
/// ([`OcclusionBuffer`]) and the cullers' rectangle test ([`RectTest`]).
pub trait CullerBuffer: OcclusionBuffer + RectTest + SampleDepthQuery + Sized + Send {
    /// The buffer's own settings, [`OccluderCullerConfig::buffer`].
    type Options: Clone + std::fmt::Debug + Default + PartialEq + Send;

    /// The culler's name, as `hom walk --culler` accepts it.
    const NAME: &'static str;

    /// A buffer for a `width` × `height` viewport with the cullers' `buffer`
    /// options (hom's clip convention, exact sampling) and its own `options`.
    fn make(width: u32, height: u32, buffer: BufferOptions, options: &Self::Options) -> Result<Self, OcclusionError>;

    /// The worst hole of the last frame drawn, for occluder selection's hole
    /// filling (holes of opacity below `hole_opacity`).
    fn worst_hole(&self, hole_opacity: f32) -> Option<Hole>;

    /// The culler's report lines ([`Culler::config`]) before the shared ones.
    fn describe(options: &Self::Options) -> Vec<(&'static str, String)>;

    /// The buffer's own statistics of the frame into `stats`, after the
    /// traversal; none by default.
    fn frame_stats(&self, _stats: &mut CullStats) {}
}

/// Settings of an [`OccluderCuller`]: what every occluder culler shares, and
/// its buffer's own options (`O`: [`crate::occlusion::MapOptions`] for HOM,
/// [`super::TreeOptions`] for the occlusion tree, `()` for HZB and masked).
#[derive(Clone, Debug, PartialEq)]
pub struct OccluderCullerConfig<O> {
    /// Which objects occlude, and how each frame's are chosen.
    pub occluders: OccluderConfig,
    /// How much of last frame's classification the traversal reuses.
    pub coherence: Coherence,
    /// Rest (frustum culling only) while occlusion culling costs more than it
    /// saves, learnt from the frame times given to [`Culler::frame_done`].
    pub cost_model: bool,
    /// The hierarchy the occlusion traversal walks: the BVH (default) or a
    /// kD-tree with ropes, with or without visibility propagation.
    pub hierarchy: Hierarchy,
    /// The buffer's own options.
    pub buffer: O,
    /// Where the buffer sets up and draws the occluders: the rayon pool the
    /// cull runs in (default), or the calling thread alone. The culler's own
    /// stages (selection, queueing, traversal) run on the calling thread
    /// either way, so [`Threads::CallingThread`] keeps a frame's whole cull
    /// there (building and rebuilding the occluder database still use the pool).
    pub threads: Threads,
    /// After the traversal, check each visible object the occluders cover
    /// against their depth at every sample (`depth_check.rs`); by default
    /// where the buffer holds that depth or a bound of it (HZB, masked).
    pub depth_check: DepthCheck,
}

impl<O: Default> Default for OccluderCullerConfig<O> {
    /// Default occluders and buffer, exact coherence, the cost model on, the BVH.
    fn default() -> Self {
        OccluderCullerConfig {
            occluders: OccluderConfig::default(),
            coherence: Coherence::default(),
            cost_model: true,
            hierarchy: Hierarchy::Bvh,
            buffer: O::default(),
            threads: Threads::Pool,
            depth_check: DepthCheck::IfDrawn,
        }
    }
}

impl<O: Default> OccluderCullerConfig<O> {
    /// The default buffer with [`OccluderConfig::for_scene`]'s occluders.
    pub fn for_scene(scene: &Scene) -> Self {
        OccluderCullerConfig {
            occluders: OccluderConfig::for_scene(scene),
            ..Self::default()
        }
    }
}

impl<O> OccluderCullerConfig<O> {
    /// The same shared settings over another buffer, with its `buffer` options.
    pub fn with_buffer<P>(&self, buffer: P) -> OccluderCullerConfig<P> {
        OccluderCullerConfig {
            occluders: self.occluders.clone(),
            coherence: self.coherence,
            cost_model: self.cost_model,
            hierarchy: self.hierarchy,
            buffer,
            threads: self.threads,
            depth_check: self.depth_check,
        }
    }
}

/// The occluder culler over buffer `B`; see the module docs, and each
/// buffer's alias ([`super::HomCuller`], …) for its guarantee.
pub struct OccluderCuller<B: CullerBuffer> {
    config: OccluderCullerConfig<B::Options>,
    common: OccluderCulling,
    buffer: Option<B>,
}

impl<B: CullerBuffer> OccluderCuller<B> {
    /// Builds the model database (BVH) and the occluder database for `scene`.
    pub fn new(scene: &Scene, config: OccluderCullerConfig<B::Options>) -> Self {
        OccluderCuller {
            common: OccluderCulling::new(
                scene,
                &config.occluders,
                config.coherence,
                config.cost_model,
                config.hierarchy,
                config.depth_check,
            ),
            config,
            buffer: None,
        }
    }

    /// The occluder database (with its report of what was kept and why).
    pub fn occluder_db(&self) -> &OccluderDb {
        &self.common.db
    }

    /// Mutable occluder database, to give occluders stand-in meshes.
    pub fn occluder_db_mut(&mut self) -> &mut OccluderDb {
        &mut self.common.db
    }

    /// The last frame's occlusion buffer (`None` before the first frame that culled).
    pub fn buffer(&self) -> Option<&B> {
        self.buffer.as_ref()
    }

    /// The last frame's occlusion buffer (for diagnostics: its tests alone).
    pub fn buffer_mut(&mut self) -> Option<&mut B> {
        self.buffer.as_mut()
    }

    /// The current settings.
    pub fn config(&self) -> &OccluderCullerConfig<B::Options> {
        &self.config
    }
}

impl<B: CullerBuffer> Culler for OccluderCuller<B> {
    fn name(&self) -> &'static str {
        B::NAME
    }

    fn occlusion_buffer(&mut self) -> Option<&mut dyn crate::occlusion::OcclusionBuffer> {
        self.buffer
            .as_mut()
            .map(|b| b as &mut dyn crate::occlusion::OcclusionBuffer)
    }

    fn config(&self) -> Vec<(&'static str, String)> {
        B::describe(&self.config.buffer)
            .into_iter()
            .chain(self.common.describe())
            .chain([("depth_check", self.config.depth_check.to_string())])
            .collect()
    }

    fn cull(&mut self, scene: &Scene, view: &View, out: &mut CullOutput) -> Result<(), CullError> {
        if self.common.rest(scene, view, out)? {
            return Ok(()); // occlusion culling does not pay now: frustum culling only
        }
        // 1. Occluder selection (with last frame's worst hole when culling was poor).
        let hole_opacity = self.config.occluders.selection.hole_opacity;
        let last = &self.buffer;
        let frame = self.common.select(scene, view, out, || {
            last.as_ref().and_then(|b| b.worst_hole(hole_opacity))
        })?;
        // 2. The occluders into the buffer (timed as `raster`).
        let (options, threads) = (&self.config.buffer, self.config.threads);
        let buffer = sized(&mut self.buffer, view, |w, h| {
            B::make(w, h, culler_buffer_options(threads), options)
        });
        let common = &mut self.common;
        let drawn = common.draw(scene, &frame, buffer, out);
        // 3. Traversal: frustum → the buffer's test, front to back; then the
        //    per-sample depth check of what the occluders cover.
        common.traverse(scene, out, frame, drawn, buffer);
        buffer.frame_stats(&mut out.stats);
        Ok(())
    }

    fn set_known_hidden(&mut self, scene: &Scene, hidden: &[u32]) {
        self.common.set_known_hidden(scene, hidden);
    }

    fn set_occluder_lod(&mut self, lod: Option<OccluderLod>) -> bool {
        self.common.set_occluder_lod(lod);
        true
    }

    fn box_hidden(&mut self, corners: &[Vec3; 8]) -> bool {
        match (self.common.last_rect(corners), self.buffer.as_mut()) {
            (Some(r), Some(buffer)) => buffer.rect_is_occluded(&r),
            _ => false,
        }
    }

    fn frame_done(&mut self, frame_ms: Option<f64>) {
        self.common.feedback(frame_ms);
    }
}

/// The buffer options of the occluder cullers: hom's own clip convention and
/// the reference renderer's exact sampling (the oracle draws with it), on `threads`.
fn culler_buffer_options(threads: Threads) -> BufferOptions {
    BufferOptions {
        sampling: Sampling::Exact,
        threads,
        ..BufferOptions::default()
    }
}

/// The culler's buffer in `slot`, made anew by `make(width, height)` when
/// there is none yet or the view's viewport changed.
fn sized<'a, B: OcclusionBuffer>(
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
    /// The per-sample depth check after the traversal, when on.
    depth_check: Option<DepthChecker>,
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
        depth_check: DepthCheck,
    ) -> OccluderCulling {
        let model = ModelDb::new(scene);
        let kd = match hierarchy {
            Hierarchy::Bvh => None,
            Hierarchy::KdTree(KdTree { propagation }) => Some(KdModel::new(&model, scene, propagation)),
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
            depth_check: DepthChecker::new(depth_check),
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
    /// `frustum`; statistics `frustum` and `rested`). Returns `false`, doing nothing, on a
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
        out.stats.frustum = Some(FrustumStats { node_tests: tests });
        out.stats.rested = true;
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
    /// `out.stats.occluders` (the triangles drawn after clipping and culling,
    /// setup and raster time, the tiles drawn and rejected; with occluders at
    /// the level of detail, the cuts drawn).
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
        out.stats.occluders = Some(OccluderStats {
            cuts: self.cuts.is_on().then_some(cuts),
            triangles_drawn: stats.triangles_drawn,
            setup_us: (stats.setup_ms * 1e3) as u64,
            raster_us: (stats.raster_ms * 1e3) as u64,
            tiles_drawn: stats.tiles_drawn,
            tiles_rejected: stats.tiles_rejected,
            ..OccluderStats::default()
        });
        drawn
    }

    /// Ends a frame: the timed traversal with `buffer` deciding each
    /// screen rectangle, the timed per-sample depth check (`depth_check`),
    /// then the visible, occluded and occluder sets and the statistics into
    /// `out`. `occluder_triangles` is what the culler drew.
    pub fn traverse<B: CullerBuffer>(
        &mut self,
        scene: &Scene,
        out: &mut CullOutput,
        frame: Selected,
        occluder_triangles: u64,
        buffer: &mut B,
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
        let is_occluded = |r: &ScreenRect| buffer.rect_is_occluded(r);
        let stats = out.time("traversal", || match kd {
            Some(kd) => traversal.run_kd(kd, temporal, is_occluded, &mut visible, &mut occluded),
            None => traversal.run(temporal, is_occluded, &mut visible, &mut occluded),
        });
        let sight = (frame.world_to_clip, frame.width, frame.height);
        if let Some(check) = &mut self.depth_check {
            out.stats.depth_check = out.time("depth_check", || {
                check.run(scene, buffer, sight, &mut visible, &mut occluded, temporal)
            });
        }
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
        out.stats.traversal = Some(TraversalStats {
            node_tests: stats.node_tests,
            object_tests: stats.object_tests,
            tests_skipped: stats.skipped,
            propagation: self.kd.is_some().then_some(PropagationStats {
                attempts: stats.propagation_attempts,
                propagated: stats.propagated,
            }),
        });
        count_occluders(
            out.stats.occluders.get_or_insert_default(),
            &frame.stats,
            occluder_triangles,
        );
        out.stats.memory = Some(MemoryStats {
            temporal_bytes: self.temporal.heap_bytes() as u64,
            state_bytes: self.state_bytes() as u64,
        });
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
            + self.depth_check.as_ref().map_or(0, DepthChecker::heap_bytes)
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
/// The triangles of the objects `ids`.
fn triangles(scene: &Scene, ids: &[u32]) -> u64 {
    ids.iter().map(|&i| scene.object(i).triangles as u64).sum()
}

/// The selection's part of the statistics every occluder culler reports about its occluders.
fn count_occluders(out: &mut OccluderStats, sel: &SelectionStats, occluder_triangles: u64) {
    out.selected = sel.selected as u64;
    out.triangles = occluder_triangles;
    out.hole_fillers = sel.hole_fillers as u64;
    out.queued = sel.queued as u64;
    out.originals = sel.originals as u64;
    out.budget = sel.budget as u64;
    out.candidates = sel.candidates as u64;
}
