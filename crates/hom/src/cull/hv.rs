//! Hierarchical visibility (Greene, Kass and Miller, "Hierarchical Z-buffer
//! visibility", SIGGRAPH 1993; as the Möller–Haines excerpt describes it): an
//! octree over the scene's triangles traversed front to back, each node's box
//! tested against a Z-pyramid of everything drawn so far, and the triangles of
//! visible leaves rasterized into the depth buffer, with the pyramid kept up to
//! date as they are drawn.
//!
//! # One frame
//! 1. **reset**: the depth buffer (the [`ZPyramid`]'s level 0, one sample per
//!    pixel centre) is cleared to 1.0 and the item buffer to [`NO_OBJECT`],
//!    exactly as the reference renderer clears its framebuffer.
//! 2. **priming** (`HvConfig::priming`; Greene et al.'s temporal coherence,
//!    as Bittner and Havran 2002 recall it: last frame's visible set
//!    initialises the Z-pyramid): last frame's visible nodes still in the frustum
//!    — nodes whose triangles were drawn and whose box was not behind the
//!    final pyramid — are drawn first, node by node in last frame's order, and
//!    so are last frame's visible moving objects. The traversal then tests
//!    nodes against a pyramid that already holds most of this frame's
//!    occluders; a primed node's triangles are not drawn again, and a primed
//!    leaf is not tested (nothing is left to save).
//! 3. **traversal** of the [`Octree`] (static objects' triangles) depth first,
//!    children in front-to-back octant order ([`Octree::child_order`]): a node
//!    outside the frustum is skipped; a node whose loose box is wholly in
//!    front of the near plane has its screen rectangle, at the box's nearest
//!    depth, tested against the pyramid ([`ZPyramid::is_behind`]: coarse to
//!    fine) and is skipped when behind; a node straddling the near plane is
//!    never image-tested. With coherence (`HvConfig::coherence`, Bittner and
//!    Havran 2002, see [`super::Coherence`]) an inner node opened last frame
//!    is not tested — its children are — and after its children its state is
//!    pulled up (invisible when every non-empty child is); leaves, the
//!    termination nodes, are tested, unless `Skip`'s coin assumes a leaf
//!    visible last frame visible. Dynamic objects are not in the octree: each one in
//!    the frustum is handled like a leaf of its own (its oriented box tested
//!    against the pyramid, then its triangles drawn), interleaved with the
//!    octree nodes by the distance of its box from the eye. So are objects
//!    added since the octree was built, and static objects that started to
//!    move (their triangles in the tree are skipped); removed objects are
//!    skipped. When such changes pile up, the octree is rebuilt.
//! 4. **raster** of a visible node's own triangles (all of a leaf's, the
//!    large ones an inner node keeps: `OctreeConfig::keep_large`), before
//!    its children are visited: each triangle is set up by
//!    [`setup_triangle`] exactly as the renderer sets it up (same vertex
//!    transform, `object_to_clip`, same clipping, snapping and fill
//!    rule); each set-up triangle's bounding rectangle (when larger than one
//!    tile) at its smallest depth is first tested against the pyramid, then
//!    each 8×8-sample tile of it where the triangle covers at least two
//!    samples against the tile's level-3 texel (one level of Greene's
//!    hierarchical tiling; both tests are `HvConfig::triangle_tests`; smaller
//!    cases cost more texel reads than sample tests they could save),
//!    and every covered sample of the tiles not rejected is depth-tested with
//!    the renderer's depth ([`Tri::depth_at`]).
//! 5. **pyramid**: after each node's triangles (or dynamic object) the texels above the
//!    samples it changed are recomputed ([`ZPyramid::update_rect`]), so later
//!    nodes are tested against everything drawn so far.
//! 6. **visible set**: from the final item buffer; then (priming on) next
//!    frame's primed nodes, each drawn node's box tested against the final
//!    pyramid (stage `priming`).
//!
//! # Which objects are visible
//! A sample's owner is the object the reference renderer leaves there when it
//! draws every object in id order: the smallest depth wins, and among equal
//! depths the first drawn, i.e. the smallest object id (the renderer's test is
//! a strict `<`, so a depth equal to the cleared 1.0 never writes). HV's item
//! buffer applies that rule at every write (`z < d`, or `z == d` and a smaller
//! id than the current owner), so its final content does not depend on the
//! drawing order. **An object is visible iff it owns at least one sample of
//! HV's final item buffer.** In-frustum objects (by their box, as the frustum
//! culler tests them) that own none are reported occluded.
//!
//! Neither coherence nor priming changes the visible set: a skipped test
//! only draws more, and a triangle drawn early (primed) or twice leaves the
//! buffers as the owner rule says, whatever the order.
//!
//! Why this is the oracle's visible set exactly: the depth buffer only ever
//! holds depths of drawn triangles, so at every sample it is at least the
//! renderer's final depth there. A node or triangle is skipped only when its
//! nearest depth is beyond the pyramid's farthest depth under its rectangle
//! (by [`crate::occlusion::details::DEPTH_MARGIN`]), hence beyond the renderer's final depth
//! at every sample it could cover: it cannot win nor tie a sample. So every
//! triangle that owns a sample in the reference rendering is drawn, with the
//! renderer's own coverage and depth, and the owner rule is order-independent:
//! HV's depth and item buffers equal the renderer's, bit for bit
//! (`hom-walk/tests/hv_conservative.rs` checks both). The assumptions are those
//! of every image-space culler here: the same resolution as the final image,
//! and a box's projected nearest depth (with the margin) not above the depth
//! the renderer computes for a triangle inside it. The triangle and tile tests
//! need no such assumption: the renderer's f32 depth formula is monotone along
//! rows and along columns, so its values at a rectangle's four corners give an
//! exact lower bound of the triangle's depth at every sample of the rectangle
//! (and the tile test, `z > texel`, needs no margin).
//!
//! The looser rule "visible iff one of its triangles passed the depth test
//! (wrote or tied a sample) when drawn" is reported as the counter
//! `objects_passing`: it is a superset (a triangle drawn early may be covered
//! later, since the octree order is front to back only for cells, not for the
//! loose boxes or the triangles inside a node).
//!
//! # Counters
//! `depth_comparisons` = `sample_tests` (covered samples depth-tested) +
//! `pyramid_texel_tests` (texels read by node, object, triangle and tile tests);
//! `zbuffer_depth_comparisons` is what a plain z-buffer does for the same
//! frame: the covered samples of every triangle in the frustum (computed with
//! the same setup; *not* timed, it is instrumentation, and skipped when
//! `HvConfig::count_zbuffer` is off). Pyramid maintenance is counted apart
//! (`pyramid_texels_updated`, a max of four children each).
//!
//! The work is single-threaded.

use super::coherence::{Coherence, Step, TemporalState, Vis};
use super::{CullError, CullOutput, Culler, HvStats};
use crate::experimental::HvPriming;
use crate::geom::{object_to_clip, project_points, Containment, Eye, Footprint, Frustum, View};
use crate::occlusion::details::setup::{setup_triangle, Tri, Vertex, Viewport};
use crate::occlusion::details::{Dirty, ZDrawStats, ZTarget};
use crate::occlusion::details::{ZPyramid, ZTestStats};
use crate::scene::Revision;
use crate::scene::Scene;
use crate::spatial::{Octree, OctreeConfig, TriRef};
use glam::Mat4;
use std::time::Instant;

pub use crate::occlusion::details::NO_OBJECT;

/// Settings of the HV culler.
#[derive(Clone, Debug, PartialEq)]
pub struct HvConfig {
    /// The octree: triangles per leaf (`threshold`), maximum depth, large triangles kept high.
    pub octree: OctreeConfig,
    /// Test each set-up triangle's bounding rectangle at its smallest depth
    /// against the pyramid, then each of its 8×8-sample tiles against the
    /// tile's texel, before scanning samples.
    pub triangle_tests: bool,
    /// Count the depth comparisons of a plain z-buffer render of the frame
    /// (counter `zbuffer_depth_comparisons`; untimed, costs about a setup of
    /// every in-frustum triangle).
    pub count_zbuffer: bool,
    /// How much of last frame's node classification the traversal reuses
    /// (hierarchy updating skips the tests of inner nodes opened last frame;
    /// `Skip` also those of nodes visible last frame, leaves included). The
    /// visible set is exact in every mode: a skipped test only draws more.
    pub coherence: Coherence,
    /// Temporal priming (Greene et al.'s temporal coherence), when `Some`:
    /// last frame's visible nodes (and visible moving objects) are drawn
    /// first. Off by default; experimental: see [`HvPriming`] for why.
    pub priming: Option<HvPriming>,
}

impl Default for HvConfig {
    fn default() -> HvConfig {
        HvConfig {
            octree: OctreeConfig::default(),
            triangle_tests: true,
            count_zbuffer: true,
            coherence: Coherence::Exact,
            priming: None,
        }
    }
}

/// Changed objects tolerated outside the octree before a rebuild, beyond an eighth of the objects.
const REBUILD_SLACK: usize = 16;

/// The hierarchical visibility culler; see the module docs.
pub struct HvCuller {
    config: HvConfig,
    octree: Octree,
    /// Ids of the live objects drawn outside the octree: dynamic, or added since its build.
    dynamic: Vec<u32>,
    /// Per object: its triangles in the octree are drawn (it is live and still static).
    in_tree: Vec<bool>,
    /// Objects that changed structurally since the octree was built.
    changed: usize,
    seen: Revision,
    /// Octree builds so far: node states belong to one.
    build: u32,
    /// Node classifications kept across frames (coherence).
    temporal: TemporalState,
    /// Frames culled, for the stamps in `node_primed`.
    frame: u32,
    /// Last frame's visible nodes: drawn, and not behind the final pyramid.
    prime_nodes: Vec<u32>,
    /// Per octree node: the frame it was drawn by priming.
    node_primed: Vec<u32>,
    /// Nodes whose own triangles this frame drew.
    drawn_nodes: Vec<u32>,
    /// Last frame's visible set (its moving objects are drawn first with priming).
    last_visible: Vec<u32>,
    /// Per object: drawn by this frame's priming (moving objects only).
    primed: Vec<bool>,
    pyramid: ZPyramid,
    items: Vec<u32>,
    /// This frame's world-to-clip matrix (vertices go through
    /// [`object_to_clip`], as the renderer's do).
    view_proj: Mat4,
    passed: Vec<bool>,
    owned: Vec<bool>,
    tris: Vec<Tri>,
    spans: Vec<Option<(u32, u32)>>,
    stack: Vec<Walk>,
    pending: Vec<(f32, u32)>,
}

/// A step of the depth-first octree walk.
#[derive(Clone, Copy, Debug)]
enum Walk {
    /// Classify node `.0`, wholly inside the frustum when `.1`.
    Visit(u32, bool),
    /// Node `.0`'s children are classified: pull their state up.
    Leave(u32),
}

/// Covered samples of a set-up triangle.
fn covered_samples(t: &Tri) -> u64 {
    (u32::from(t.y0)..u32::from(t.y1))
        .filter_map(|py| t.row_span(py))
        .map(|(lo, hi)| u64::from(hi - lo))
        .sum()
}

/// What drawing needs during one frame.
struct Drawing<'a> {
    scene: &'a Scene,
    viewport: Viewport,
    view_proj: Mat4,
    /// The depth, item buffer and pyramid triangles go into.
    z: ZTarget<'a>,
    passed: &'a mut [bool],
    tris: &'a mut Vec<Tri>,
    /// The frame's counts; the z-buffer's and the pyramid tests' are in `z`.
    stats: HvStats,
    raster_s: f64,
    pyramid_s: f64,
}

impl Drawing<'_> {
    /// Draws triangles (timed as raster), then brings the pyramid up to date (timed as pyramid).
    fn draw(&mut self, tris: impl Iterator<Item = TriRef>) {
        let start = Instant::now();
        for t in tris {
            self.draw_triangle(t);
        }
        let mid = Instant::now();
        self.raster_s += (mid - start).as_secs_f64();
        let d = std::mem::replace(&mut self.z.dirty, Dirty::NONE);
        self.stats.pyramid_texels_updated += self.z.pyramid.update_rect(d.x0, d.y0, d.x1, d.y1);
        self.pyramid_s += mid.elapsed().as_secs_f64();
    }

    fn draw_triangle(&mut self, t: TriRef) {
        let o = self.scene.object(t.object);
        let mesh = self.scene.mesh_of(o);
        let p = mesh.positions();
        let v = mesh.triangles()[t.triangle as usize].map(|i| {
            Vertex::new(
                object_to_clip(&self.view_proj, &o.transform, p[i as usize]),
                &self.viewport,
            )
        });
        self.stats.triangles_submitted += 1;
        self.tris.clear();
        setup_triangle(
            [&v[0], &v[1], &v[2]],
            &self.viewport,
            t.object,
            [0, 0, 0, 255],
            self.tris,
        );
        for tri in self.tris.iter() {
            if self.z.draw(tri) {
                self.passed[t.object as usize] = true;
            }
        }
    }

    /// A dynamic object: frustum test, box test against the pyramid, then its triangles.
    fn dynamic(&mut self, id: u32, frustum: &Frustum, world_to_clip: &Mat4, primed: &[bool]) {
        if primed[id as usize] {
            return; // drawn already
        }
        let o = self.scene.object(id);
        if frustum.test_obb(&o.obb) == Containment::Outside {
            return;
        }
        self.stats.dynamic_tested += 1;
        let (w, h) = (self.viewport.width, self.viewport.height);
        if let Footprint::Rect(r) = project_points(&o.obb.corners(), world_to_clip, w, h) {
            if self.z.pyramid.is_behind(&r, &mut self.z.zstats) {
                self.stats.dynamic_occluded += 1;
                return;
            }
        }
        let n = self.scene.mesh_of(o).triangle_count() as u32;
        self.draw((0..n).map(|triangle| TriRef { object: id, triangle }));
    }
}

impl HvCuller {
    /// Builds the octree over `scene`'s static triangles.
    pub fn new(scene: &Scene, config: HvConfig) -> HvCuller {
        let temporal = TemporalState::new(config.coherence);
        let mut hv = HvCuller {
            config,
            octree: Octree::default(),
            dynamic: Vec::new(),
            in_tree: Vec::new(),
            changed: 0,
            seen: scene.revision(),
            build: 0,
            frame: 0,
            prime_nodes: Vec::new(),
            node_primed: Vec::new(),
            drawn_nodes: Vec::new(),
            temporal,
            last_visible: Vec::new(),
            primed: Vec::new(),
            pyramid: ZPyramid::default(),
            items: Vec::new(),
            view_proj: Mat4::IDENTITY,
            passed: Vec::new(),
            owned: Vec::new(),
            tris: Vec::new(),
            spans: Vec::new(),
            stack: Vec::new(),
            pending: Vec::new(),
        };
        hv.rebuild(scene);
        hv
    }

    /// The octree over the live static objects, and the list of the others.
    fn rebuild(&mut self, scene: &Scene) {
        self.octree = Octree::build(scene, &self.config.octree);
        self.in_tree = scene
            .objects()
            .iter()
            .map(|o| !o.is_dynamic() && !o.is_removed())
            .collect();
        self.dynamic = scene
            .live_objects()
            .filter(|(_, o)| o.is_dynamic())
            .map(|(id, _)| id)
            .collect();
        self.changed = 0;
        self.seen = scene.revision();
        self.build = self.build.wrapping_add(1);
        self.prime_nodes.clear();
        self.node_primed.clear();
        self.node_primed.resize(self.octree.nodes().len(), 0);
    }

    /// Follows the scene's structural changes since the last frame (see the module docs).
    fn sync(&mut self, scene: &Scene) {
        let now = scene.revision();
        if now.scene != self.seen.scene {
            return self.rebuild(scene);
        }
        if now.structure != self.seen.structure {
            let n = scene.objects().len();
            self.in_tree.resize(n, false);
            for (id, o) in scene.objects().iter().enumerate() {
                if o.changed_at() <= self.seen.structure {
                    continue;
                }
                self.changed += 1;
                let id = id as u32;
                self.in_tree[id as usize] &= !o.is_dynamic() && !o.is_removed();
                let listed = self.dynamic.binary_search(&id);
                match (o.is_removed() || self.in_tree[id as usize], listed) {
                    (true, Ok(k)) => {
                        self.dynamic.remove(k);
                    }
                    (false, Err(k)) => self.dynamic.insert(k, id),
                    _ => {}
                }
            }
            if self.changed > REBUILD_SLACK + n / 8 {
                return self.rebuild(scene);
            }
        }
        self.seen = now;
    }

    /// The octree over the static triangles.
    pub fn octree(&self) -> &Octree {
        &self.octree
    }

    /// The settings.
    pub fn settings(&self) -> &HvConfig {
        &self.config
    }

    /// The last frame's Z-pyramid; its level 0 is the depth buffer.
    pub fn zpyramid(&self) -> &ZPyramid {
        &self.pyramid
    }

    /// The last frame's depth buffer (row-major, one sample per pixel; 1.0 where nothing was drawn).
    pub fn depth(&self) -> &[f32] {
        self.pyramid.levels().first().map_or(&[], |l| l.texels())
    }

    /// The last frame's item buffer: the owner of each sample, [`NO_OBJECT`] where none.
    pub fn items(&self) -> &[u32] {
        &self.items
    }

    /// Depth comparisons a plain z-buffer makes drawing every triangle in the
    /// frustum: the covered samples of each, with the renderer's setup.
    fn zbuffer_comparisons(&mut self, scene: &Scene, frustum: &Frustum, viewport: &Viewport) -> u64 {
        let mut total = 0u64;
        let count = |tris: &mut Vec<Tri>, view_proj: &Mat4, t: TriRef| {
            let o = scene.object(t.object);
            let mesh = scene.mesh_of(o);
            let p = mesh.positions();
            let v = mesh.triangles()[t.triangle as usize]
                .map(|i| Vertex::new(object_to_clip(view_proj, &o.transform, p[i as usize]), viewport));
            tris.clear();
            setup_triangle([&v[0], &v[1], &v[2]], viewport, t.object, [0; 4], tris);
            tris.iter().map(covered_samples).sum::<u64>()
        };
        let Self {
            octree,
            tris,
            view_proj,
            stack,
            dynamic,
            in_tree,
            ..
        } = self;
        stack.clear();
        if !octree.is_empty() {
            stack.push(Walk::Visit(0, false));
        }
        while let Some(Walk::Visit(i, inside)) = stack.pop() {
            let node = &octree.nodes()[i as usize];
            let c = if inside {
                Containment::Inside
            } else {
                frustum.test_aabb(&node.bounds)
            };
            if c == Containment::Outside || node.count == 0 {
                continue;
            }
            for &t in octree.own_triangles(node).iter().filter(|t| in_tree[t.object as usize]) {
                total += count(tris, view_proj, t);
            }
            if !node.is_leaf() {
                let first = node.children;
                stack.extend((first..first + 8).map(|k| Walk::Visit(k, c == Containment::Inside)));
            }
        }
        for &id in dynamic.iter() {
            let o = scene.object(id);
            if frustum.test_obb(&o.obb) != Containment::Outside {
                for triangle in 0..scene.mesh_of(o).triangle_count() as u32 {
                    total += count(tris, view_proj, TriRef { object: id, triangle });
                }
            }
        }
        total
    }
}

/// Hierarchy updating's pull-up at inner node `i` after its children: the
/// common classification of its non-empty children (and of its own drawn
/// triangles, which count as visible), else partially visible.
fn pull_up(temporal: &mut TemporalState, octree: &Octree, i: u32) {
    if !temporal.is_on() {
        return;
    }
    let node = &octree.nodes()[i as usize];
    let children = (node.children..node.children + 8).filter(|&k| octree.nodes()[k as usize].count > 0);
    let mut votes = children.filter_map(|k| temporal.node_now(k));
    let own = (node.own > 0).then_some(Vis::Visible);
    let first = own.or_else(|| votes.next()).unwrap_or(Vis::Invisible);
    let vis = if votes.all(|v| v == first) { first } else { Vis::Partial };
    temporal.set_node(i, vis);
}

impl Culler for HvCuller {
    fn name(&self) -> &'static str {
        "hv"
    }

    fn config(&self) -> Vec<(&'static str, String)> {
        let c = &self.config;
        vec![
            ("threshold", c.octree.threshold.to_string()),
            ("max_depth", c.octree.max_depth.to_string()),
            ("keep_large", c.octree.keep_large.to_string()),
            (
                "octree",
                format!(
                    "{} nodes, {} non-empty leaves, depth {}, {} static triangles, {} dynamic objects",
                    self.octree.nodes().len(),
                    self.octree.leaf_count(),
                    self.octree.depth(),
                    self.octree.triangles().len(),
                    self.dynamic.len()
                ),
            ),
            ("triangle_tests", c.triangle_tests.to_string()),
            ("count_zbuffer", c.count_zbuffer.to_string()),
            ("coherence", c.coherence.to_string()),
            ("priming", c.priming.is_some().to_string()),
        ]
    }

    fn cull(&mut self, scene: &Scene, view: &View, out: &mut CullOutput) -> Result<(), CullError> {
        view.validate()?;
        out.clear();
        let view_proj = view.world_to_clip();
        let frustum = Frustum::from_view_proj(&view_proj).expect("a validated view has a frustum");
        let (w, h) = (view.width, view.height);
        let viewport = Viewport::new(w, h);
        let eye = view.eye();
        // The octant order needs a point: a parallel view's eye is far along its direction.
        let order_eye = match eye {
            Eye::Point(p) => p,
            Eye::Direction(d) => {
                let b = scene.bounds();
                b.center() - d * (b.extent().length() * 1e3 + 1.0)
            }
        };

        // 1. Follow the scene; clear the buffers; this frame's object matrices.
        out.time("reset", || {
            self.sync(scene);
            let n = scene.objects().len();
            self.pyramid.reset(w, h, 1.0);
            self.items.clear();
            self.items.resize(w as usize * h as usize, NO_OBJECT);
            self.view_proj = view_proj;
            self.passed.clear();
            self.passed.resize(n, false);
            self.owned.resize(n, false);
            self.primed.clear();
            self.primed.resize(n, false);
            self.frame += 1;
            self.drawn_nodes.clear();
            self.temporal.begin_tree(self.build, self.octree.nodes().len());
        });

        // 2-4. Priming, then the front-to-back traversal drawing visible nodes.
        let start = Instant::now();
        let Self {
            config,
            octree,
            dynamic,
            pyramid,
            items,
            view_proj: frame_view_proj,
            passed,
            tris,
            spans,
            stack,
            pending,
            in_tree,
            temporal,
            last_visible,
            primed,
            frame,
            prime_nodes,
            node_primed,
            drawn_nodes,
            ..
        } = self;
        let frame = *frame;
        pending.clear();
        pending.extend(
            dynamic
                .iter()
                .map(|&id| (View::nearness(&eye, &scene.object(id).aabb), id)),
        );
        // Nearest last, so `pop` takes the nearest.
        pending.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
        let in_tree: &[bool] = in_tree;
        let mut d = Drawing {
            scene,
            viewport,
            view_proj: *frame_view_proj,
            z: ZTarget {
                pyramid,
                items,
                spans,
                width: w,
                triangle_tests: config.triangle_tests,
                stats: ZDrawStats::default(),
                zstats: ZTestStats::default(),
                dirty: Dirty::NONE,
            },
            passed,
            tris,
            stats: HvStats::default(),
            raster_s: 0.0,
            pyramid_s: 0.0,
        };
        if config.priming.is_some() {
            // Last frame's visible nodes and moving objects still in view,
            // then the pyramid once over what they changed.
            prime_nodes.retain(|&i| frustum.test_aabb(&octree.nodes()[i as usize].bounds) != Containment::Outside);
            for &i in prime_nodes.iter() {
                node_primed[i as usize] = frame;
            }
            for &id in last_visible.iter() {
                let Some(o) = scene.get(id) else { continue };
                primed[id as usize] =
                    dynamic.binary_search(&id).is_ok() && frustum.test_obb(&o.obb) != Containment::Outside;
            }
            let moving = last_visible.iter().copied().filter(|&id| primed[id as usize]);
            d.stats.objects_primed = moving.clone().count() as u64;
            d.stats.nodes_primed = prime_nodes.len() as u64;
            // Node by node, nearest first as last frame drew them, so each
            // node's triangles meet the pyramid of those before (its tile tests).
            for &i in prime_nodes.iter() {
                let own = octree.own_triangles(&octree.nodes()[i as usize]);
                d.draw(own.iter().copied().filter(|t| in_tree[t.object as usize]));
            }
            for id in moving {
                let n = scene.mesh_of(scene.object(id)).triangle_count() as u32;
                d.draw((0..n).map(|triangle| TriRef { object: id, triangle }));
            }
            drawn_nodes.extend_from_slice(prime_nodes);
        }
        let primed: &[bool] = primed;
        stack.clear();
        if !octree.is_empty() {
            stack.push(Walk::Visit(0, false));
        }
        while let Some(walk) = stack.pop() {
            let (i, inside) = match walk {
                Walk::Visit(i, inside) => (i, inside),
                Walk::Leave(i) => {
                    pull_up(temporal, octree, i);
                    continue;
                }
            };
            let node = &octree.nodes()[i as usize];
            let dist = View::nearness(&eye, &node.bounds);
            while pending.last().is_some_and(|p| p.0 <= dist) {
                let (_, id) = pending.pop().expect("checked");
                d.dynamic(id, &frustum, &view_proj, primed);
            }
            d.stats.nodes_visited += 1;
            let c = if inside {
                Containment::Inside
            } else {
                frustum.test_aabb(&node.bounds)
            };
            if c == Containment::Outside {
                d.stats.node_tests += 1;
                temporal.set_node(i, Vis::Invisible);
                continue;
            }
            // Hierarchy updating skips an inner node opened last frame (its
            // children are tested; leaves are the termination nodes and are
            // tested); conservative hierarchy updating also skips, by its
            // coin, a node visible last frame, leaves too.
            let is_primed = node_primed[i as usize] == frame;
            let skip = match temporal.node_step(i) {
                _ if is_primed && node.is_leaf() => true, // drawn already: a test cannot save anything
                Step::Test => false,
                Step::Open => !node.is_leaf(),
                Step::Assume => true,
            };
            if skip {
                d.stats.tests_skipped += 1;
            } else {
                d.stats.node_tests += 1;
                if let Footprint::Rect(r) = project_points(&node.bounds.corners(), &view_proj, w, h) {
                    d.stats.node_box_tests += 1;
                    if d.z.pyramid.is_behind(&r, &mut d.z.zstats) {
                        d.stats.nodes_occluded += 1;
                        temporal.set_node(i, Vis::Invisible);
                        continue;
                    }
                }
            }
            // The node's own triangles (a leaf's all, an inner node's large
            // ones) before its children, unless priming drew them.
            if node.own > 0 && !is_primed {
                d.stats.nodes_drawn += 1;
                drawn_nodes.push(i);
                d.draw(
                    octree
                        .own_triangles(node)
                        .iter()
                        .copied()
                        .filter(|t| in_tree[t.object as usize]),
                );
            }
            if node.is_leaf() {
                temporal.set_node(i, Vis::Visible);
            } else {
                stack.push(Walk::Leave(i));
                let order = octree.child_order(node, order_eye);
                let inside = c == Containment::Inside;
                for &k in order.iter().rev() {
                    if octree.nodes()[k as usize].count > 0 {
                        stack.push(Walk::Visit(k, inside));
                    }
                }
            }
        }
        while let Some((_, id)) = pending.pop() {
            d.dynamic(id, &frustum, &view_proj, primed);
        }
        let (stats, raster, zstats, raster_s, pyramid_s) = (d.stats, d.z.stats, d.z.zstats, d.raster_s, d.pyramid_s);
        let total_s = start.elapsed().as_secs_f64();
        out.stages
            .push(("traversal", (total_s - raster_s - pyramid_s).max(0.0) * 1e3));
        out.stages.push(("raster", raster_s * 1e3));
        out.stages.push(("pyramid", pyramid_s * 1e3));

        // 5. The visible set: owners of the final item buffer.
        let mut visible = std::mem::take(&mut out.visible);
        let mut occluded = std::mem::take(&mut out.occluded);
        out.time("visible_set", || {
            let owned = &mut self.owned;
            owned.fill(false);
            for &id in &self.items {
                if id != NO_OBJECT {
                    owned[id as usize] = true;
                }
            }
            for (id, o) in scene.objects().iter().enumerate() {
                if o.is_removed() {
                    continue;
                } else if owned[id] {
                    visible.push(id as u32);
                } else {
                    let c = if o.is_dynamic() {
                        frustum.test_obb(&o.obb)
                    } else {
                        frustum.test_aabb(&o.aabb)
                    };
                    if c != Containment::Outside {
                        occluded.push(id as u32);
                    }
                }
            }
        });
        self.last_visible.clone_from(&visible);
        if self.config.priming.is_some() {
            // Next frame's priming: the nodes drawn whose box is not behind
            // the final pyramid (the others' triangles own no sample now).
            let (pyramid, octree, nodes) = (&self.pyramid, &self.octree, &mut self.prime_nodes);
            out.time("priming", || {
                let mut zstats = ZTestStats::default();
                nodes.clear();
                nodes.extend(self.drawn_nodes.iter().copied().filter(|&i| {
                    let b = &octree.nodes()[i as usize].bounds;
                    match project_points(&b.corners(), &view_proj, w, h) {
                        Footprint::Rect(r) => !pyramid.is_behind(&r, &mut zstats),
                        _ => true,
                    }
                }));
            });
        }
        out.visible = visible;
        out.occluded = occluded;

        let zbuffer = self
            .config
            .count_zbuffer
            .then(|| self.zbuffer_comparisons(scene, &frustum, &viewport));
        out.stats.hv = Some(HvStats {
            draw: raster,
            pyramid_texel_tests: zstats.texels,
            zbuffer_depth_comparisons: zbuffer,
            objects_passing: self.passed.iter().filter(|&&p| p).count() as u64,
            ..stats
        });
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Mesh, SceneBuilder};
    use glam::Vec3;

    /// A quad of two triangles at `z`, spanning `[-s, s]²`.
    fn wall(b: &mut SceneBuilder, z: f32, s: f32) -> u32 {
        let p = vec![
            Vec3::new(-s, -s, z),
            Vec3::new(s, -s, z),
            Vec3::new(s, s, z),
            Vec3::new(-s, s, z),
        ];
        let m = b.add_mesh(Mesh::new("wall", p, vec![[0, 1, 2], [0, 2, 3]]).unwrap());
        b.add_object("wall", m, Mat4::IDENTITY).unwrap()
    }

    #[test]
    fn a_wall_hides_what_is_behind_it_and_counts_add_up() {
        let mut b = SceneBuilder::new("walls");
        let near = wall(&mut b, -5.0, 10.0);
        let far = wall(&mut b, -20.0, 3.0);
        let scene = b.build().unwrap();
        let camera = crate::geom::Camera::new(Vec3::ZERO, -Vec3::Z, Vec3::Y, 1.0, 0.1, 100.0, 64, 48);
        let mut hv = HvCuller::new(
            &scene,
            HvConfig {
                octree: OctreeConfig {
                    threshold: 1,
                    max_depth: 4,
                    keep_large: true,
                },
                ..HvConfig::default()
            },
        );
        let mut out = CullOutput::default();
        hv.cull(&scene, &camera.to_view(), &mut out).unwrap();
        assert_eq!(out.visible, vec![near]);
        assert_eq!(out.occluded, vec![far]);
        let s = out.stats.hv.unwrap();
        assert_eq!(s.depth_comparisons(), s.draw.sample_tests + s.pyramid_texel_tests);
        // The near wall covers the whole 64x48 frame: every sample tested once by
        // it; the far wall is culled before any of its samples is tested.
        assert_eq!(s.draw.sample_tests, 64 * 48);
        assert!(s.zbuffer_depth_comparisons.unwrap() > s.draw.sample_tests);
        assert!(hv.items().iter().all(|&i| i == near));
    }
}
