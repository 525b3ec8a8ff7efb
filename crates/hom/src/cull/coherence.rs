//! Coherence in hierarchical visibility (J. Bittner and V. Havran,
//! "Exploiting coherence in hierarchical visibility algorithms", Journal of
//! Visualization and Computer Animation 13, 2002): what the occlusion
//! traversal keeps of each node's classification from one frame to the next,
//! so it stops classifying the whole hierarchy from the root every frame.
//!
//! - **Hierarchy updating** (section "Hierarchy Updating", Figure 4). A node
//!   opened last frame (partially visible: the traversal went into its
//!   children) is not tested again; the traversal goes straight to its
//!   children. Last frame's termination nodes (invisible nodes, and the
//!   objects) are tested as usual. After its children, a node's state is
//!   pulled up: invisible when every child is, visible when every child is,
//!   else partially visible. A node not visited last frame (below a
//!   termination node) is tested. Skipping a node's test only sends the
//!   traversal to its children, and a child's box lies inside its parent's,
//!   so the classification is the classical one (`Coherence::Exact`).
//! - **Conservative hierarchy updating** (section of that name). A node or
//!   object visible last frame is assumed visible without its occlusion test
//!   with probability `p_skip`, decided by a hash of (node, frame, seed) so a
//!   run is reproducible. The frustum test still runs first (the paper's
//!   order), and an assumed node's objects are frustum-tested, so only
//!   occluded objects are ever drawn in excess. Nothing is classified
//!   invisible without a test this frame: an object that comes out from
//!   behind a wall is drawn in the frame it does.
//! - **Adaptive `p_skip`** (the paper's future work). From each node's
//!   history: `run` counts the consecutive tests that found it visible, and
//!   `p_skip = run / (run + 1)` (at most [`AUTO_P_SKIP_MAX`]): the chance
//!   that it stays visible, estimated from its record. A node that has just
//!   become visible is tested next frame; one visible for a long time is
//!   tested about one frame in ten. Fast walks change visibility often, keep
//!   runs short and so skip less, without any per-scene setting. Measured on
//!   the city walk against fixed values (tests saved, triangles drawn over
//!   `Exact`): auto 65 %, +1.0 %; fixed 0.3 56 %, +5.2 %; 0.5 60 %, +9.0 %;
//!   0.9 74 %, +20 %; `run / (run + 2)` 61 %, +0.8 %.
//!
//! One adaptation to hom's tests: an image-space rectangle test answers
//! "occluded" or "not occluded", never "completely visible", so a node is
//! only ever found visible by pulling up its objects' visibility. A visible
//! node that is not assumed visible is therefore opened (its children are
//! classified) like a partially visible one: testing it first could only
//! cost a test.
//!
//! Objects are the leaves of the classified hierarchy: the BVH's leaves are
//! inner nodes over their objects. Moves ([`ModelDb::moved_nodes`],
//! [`ModelDb::moved_objects`]) demote what they touch: a moved object is
//! tested, a moved node is not assumed visible. A rebuilt hierarchy forgets
//! everything.

use super::model_db::ModelDb;

/// Largest `p_skip` the adaptive rule reaches: a node visible for a long time
/// is still tested about every tenth frame.
pub(crate) const AUTO_P_SKIP_MAX: f32 = 0.9;

/// How much of last frame's classification the occlusion traversal reuses.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Coherence {
    /// Classify from the root every frame (the classical traversal).
    Off,
    /// Hierarchy updating: skip the tests of nodes opened last frame. The
    /// visible and occluded sets are the classical ones. The default: 41-48 %
    /// fewer tests on the built-in walks, nothing drawn in excess.
    #[default]
    Exact,
    /// Hierarchy updating, and nodes and objects visible last frame assumed
    /// visible without a test with probability `p_skip`: fewer tests, a few
    /// more objects drawn, never fewer.
    Skip(PSkip),
}

/// The probability with which [`Coherence::Skip`] assumes a visible node visible.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum PSkip {
    /// From each node's history (see the module docs).
    #[default]
    Auto,
    /// The same for every node (the paper's setting; it measured 0.5 and 0.6 best).
    Fixed(f32),
}

impl std::fmt::Display for Coherence {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Coherence::Off => write!(f, "off"),
            Coherence::Exact => write!(f, "exact"),
            Coherence::Skip(PSkip::Auto) => write!(f, "skip (p_skip auto)"),
            Coherence::Skip(PSkip::Fixed(p)) => write!(f, "skip (p_skip {p})"),
        }
    }
}

/// A node's or object's classification.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Vis {
    /// Outside the frustum or occluded, or (a node) every child so.
    Invisible,
    /// Opened: the traversal went into its children, which disagreed.
    Partial,
    /// Drawn; for a node, every child visible.
    Visible,
}

/// What the traversal does at a node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Step {
    /// Test it (frustum, then occlusion).
    Test,
    /// Go to its children without a test (hierarchy updating).
    Open,
    /// Frustum-test it, and draw it without an occlusion test when inside
    /// (conservative hierarchy updating).
    Assume,
}

/// One node's or object's state across frames: 8 bytes.
#[derive(Clone, Copy, Debug)]
struct Temporal {
    /// The frame it was last classified in.
    frame: u32,
    vis: Vis,
    /// Consecutive frames it was found visible (saturating).
    run: u8,
}

impl Temporal {
    const NEVER: Temporal = Temporal {
        frame: 0,
        vis: Vis::Partial,
        run: 0,
    };
}

/// Per-node and per-object state kept across frames, and the decisions made from it.
#[derive(Clone, Debug)]
pub(crate) struct TemporalState {
    mode: Coherence,
    /// The current frame; starts at 2 so that frame 0 ([`Temporal::NEVER`])
    /// is never "last frame".
    frame: u32,
    /// The model database's build the node states belong to.
    build: u32,
    nodes: Vec<Temporal>,
    objects: Vec<Temporal>,
    seed: u64,
}

impl TemporalState {
    /// Bytes of state kept across frames: 8 per node and 8 per object.
    pub fn heap_bytes(&self) -> usize {
        crate::vec_bytes(&self.nodes) + crate::vec_bytes(&self.objects)
    }

    /// No state yet; `mode` decides what is kept.
    pub fn new(mode: Coherence) -> TemporalState {
        TemporalState {
            mode,
            frame: 1,
            build: u32::MAX,
            nodes: Vec::new(),
            objects: Vec::new(),
            seed: 0x9e37_79b9_7f4a_7c15,
        }
    }

    /// The mode.
    pub fn mode(&self) -> Coherence {
        self.mode
    }

    /// Whether any state is kept (any mode but [`Coherence::Off`]).
    pub fn is_on(&self) -> bool {
        self.mode != Coherence::Off
    }

    /// Starts a frame over `model` (synced this frame) and `objects` object
    /// ids: forgets everything after a rebuild, demotes what moved.
    pub fn begin(&mut self, model: &ModelDb, objects: usize) {
        let bvh = model.bvh().node_count();
        self.begin_over(model.build(), bvh, model.moved_nodes(), model.moved_objects(), objects);
    }

    /// [`TemporalState::begin`] over any hierarchy: `nodes` nodes of build
    /// `build`, of which `moved_nodes` changed bounds; `moved_objects`
    /// changed boxes; `objects` object ids.
    pub fn begin_over(&mut self, build: u32, nodes: usize, moved_nodes: &[u32], moved_objects: &[u32], objects: usize) {
        if !self.is_on() {
            return;
        }
        self.frame += 1;
        if build != self.build || self.frame == u32::MAX {
            self.build = build;
            self.frame = 2;
            self.nodes.clear();
            self.objects.clear();
        }
        self.nodes.resize(nodes, Temporal::NEVER);
        self.objects.resize(objects, Temporal::NEVER);
        for &i in moved_nodes {
            let s = &mut self.nodes[i as usize];
            if s.vis == Vis::Visible {
                s.vis = Vis::Partial;
            }
        }
        for &id in moved_objects {
            self.objects[id as usize] = Temporal::NEVER;
        }
    }

    /// Starts a frame over a hierarchy of `nodes` nodes without objects (HV's
    /// octree: its leaves are the termination nodes), from its `build`: a new
    /// build forgets everything.
    pub fn begin_tree(&mut self, build: u32, nodes: usize) {
        self.begin_over(build, nodes, &[], &[], 0);
    }

    /// Node `i`'s classification this frame, if it has one yet (coherence on).
    pub fn node_now(&self, i: u32) -> Option<Vis> {
        let s = self.nodes.get(i as usize)?;
        (self.is_on() && s.frame == self.frame).then_some(s.vis)
    }

    /// Node `i`'s step this frame ([`Step::Test`] with coherence off).
    pub fn node_step(&self, i: u32) -> Step {
        if !self.is_on() {
            return Step::Test;
        }
        let s = self.nodes[i as usize];
        if s.frame != self.frame - 1 {
            return Step::Test; // below last frame's termination nodes, or new
        }
        match (s.vis, self.mode) {
            (Vis::Invisible, _) | (_, Coherence::Off) => Step::Test,
            (Vis::Visible, Coherence::Skip(p)) if self.skips(p, s.run, i as u64) => Step::Assume,
            (Vis::Partial | Vis::Visible, _) => Step::Open,
        }
    }

    /// Whether object `id`, inside the frustum, is assumed visible without its occlusion test.
    pub fn object_assumed(&self, id: u32) -> bool {
        let Coherence::Skip(p) = self.mode else {
            return false;
        };
        let s = self.objects[id as usize];
        s.frame == self.frame - 1 && s.vis == Vis::Visible && self.skips(p, s.run, (1 << 32) | id as u64)
    }

    /// The coin of conservative hierarchy updating, from a hash of (`key`, frame, seed).
    fn skips(&self, p: PSkip, run: u8, key: u64) -> bool {
        let p = match p {
            PSkip::Fixed(p) => p,
            PSkip::Auto => (run as f32 / (run as f32 + 1.0)).min(AUTO_P_SKIP_MAX),
        };
        let h = mix(key ^ mix(self.seed ^ self.frame as u64));
        ((h >> 40) as f32) < p * (1u64 << 24) as f32
    }

    /// Node `i` classified `vis` this frame by a test (or its objects');
    /// nothing is kept with coherence off.
    pub fn set_node(&mut self, i: u32, vis: Vis) {
        if self.is_on() {
            let frame = self.frame;
            classify(&mut self.nodes[i as usize], vis, frame);
        }
    }

    /// Node `i` assumed visible this frame: its history is kept, not extended.
    pub fn assume_node(&mut self, i: u32) {
        self.nodes[i as usize].frame = self.frame;
    }

    /// Object `id` classified `vis` this frame by a test; nothing is kept
    /// with coherence off.
    pub fn set_object(&mut self, id: u32, vis: Vis) {
        if self.is_on() {
            let frame = self.frame;
            classify(&mut self.objects[id as usize], vis, frame);
        }
    }

    /// Object `id` assumed visible this frame.
    pub fn assume_object(&mut self, id: u32) {
        self.objects[id as usize].frame = self.frame;
    }

    /// The pull-up: inner node `i` after its children `a` and `b` were classified this frame.
    pub fn pull_up(&mut self, i: u32, a: u32, b: u32) {
        if !self.is_on() {
            return;
        }
        let (a, b) = (self.nodes[a as usize].vis, self.nodes[b as usize].vis);
        self.set_node(i, if a == b { a } else { Vis::Partial });
    }
}

/// `state` classified `vis` in `frame`: a visible run grows when it was
/// visible the frame before, else starts again.
fn classify(state: &mut Temporal, vis: Vis, frame: u32) {
    let continued = state.frame == frame - 1 && state.vis == Vis::Visible && vis == Vis::Visible;
    state.run = if continued { state.run.saturating_add(1) } else { 0 };
    state.vis = vis;
    state.frame = frame;
}

/// The pull-up rule over a leaf's objects: the common classification of
/// `visible` and `invisible` counts (invisible when there are none).
pub(crate) fn combine(visible: usize, invisible: usize) -> Vis {
    match (visible, invisible) {
        (0, _) => Vis::Invisible,
        (_, 0) => Vis::Visible,
        _ => Vis::Partial,
    }
}

/// SplitMix64's finalizer: a well-mixed 64-bit hash of `x`.
pub(crate) fn mix(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9e37_79b9_7f4a_7c15);
    x = (x ^ (x >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn temporal_state_is_eight_bytes_per_node() {
        assert_eq!(std::mem::size_of::<Temporal>(), 8);
    }

    #[test]
    fn the_coin_follows_p_skip_and_is_reproducible() {
        let mut t = TemporalState::new(Coherence::Skip(PSkip::Fixed(0.3)));
        t.frame = 7;
        let hits = (0..100_000u64).filter(|&k| t.skips(PSkip::Fixed(0.3), 0, k)).count();
        assert!((29_000..31_000).contains(&hits), "{hits}");
        let again = (0..100_000u64).filter(|&k| t.skips(PSkip::Fixed(0.3), 0, k)).count();
        assert_eq!(hits, again);
        assert!(!(0..1000).any(|k| t.skips(PSkip::Fixed(0.0), 0, k)));
        assert!((0..1000).all(|k| t.skips(PSkip::Fixed(1.0), 0, k)));
        // Auto: never on a run of 0, about half on a run of 1.
        assert!(!(0..1000).any(|k| t.skips(PSkip::Auto, 0, k)));
        let half = (0..100_000u64).filter(|&k| t.skips(PSkip::Auto, 1, k)).count();
        assert!((49_000..51_000).contains(&half), "{half}");
    }

    #[test]
    fn runs_grow_only_on_consecutive_visible_frames() {
        let mut s = Temporal::NEVER;
        classify(&mut s, Vis::Visible, 2);
        assert_eq!(s.run, 0);
        classify(&mut s, Vis::Visible, 3);
        classify(&mut s, Vis::Visible, 4);
        assert_eq!(s.run, 2);
        classify(&mut s, Vis::Visible, 6); // a frame unvisited
        assert_eq!(s.run, 0);
        classify(&mut s, Vis::Visible, 7);
        classify(&mut s, Vis::Invisible, 8);
        assert_eq!((s.run, s.vis), (0, Vis::Invisible));
    }

    #[test]
    fn steps_follow_the_paper() {
        let mut t = TemporalState::new(Coherence::Exact);
        t.frame = 10;
        t.nodes = vec![Temporal::NEVER; 4];
        let at = |frame, vis| Temporal { frame, vis, run: 5 };
        t.nodes[0] = at(9, Vis::Partial);
        t.nodes[1] = at(9, Vis::Invisible);
        t.nodes[2] = at(9, Vis::Visible);
        t.nodes[3] = at(8, Vis::Partial); // not visited last frame
        let steps = |t: &TemporalState| (0..4).map(|i| t.node_step(i)).collect::<Vec<_>>();
        assert_eq!(steps(&t), [Step::Open, Step::Test, Step::Open, Step::Test]);
        t.mode = Coherence::Skip(PSkip::Fixed(1.0));
        assert_eq!(steps(&t), [Step::Open, Step::Test, Step::Assume, Step::Test]);
        t.mode = Coherence::Skip(PSkip::Fixed(0.0));
        assert_eq!(steps(&t), [Step::Open, Step::Test, Step::Open, Step::Test]);
        assert_eq!(combine(0, 0), Vis::Invisible);
        assert_eq!(combine(2, 0), Vis::Visible);
        assert_eq!(combine(0, 3), Vis::Invisible);
        assert_eq!(combine(1, 1), Vis::Partial);
    }
}
