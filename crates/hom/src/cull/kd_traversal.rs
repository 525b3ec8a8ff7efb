//! The occlusion traversal over a kD-tree with ropes, with visibility
//! propagation: J. Bittner and V. Havran, "Exploiting coherence in
//! hierarchical visibility algorithms" (Journal of Visualization and
//! Computer Animation 13, 2002), section "Visibility Propagation" and its
//! part "Temporal Coherence". The tree is [`crate::spatial::kdtree`]; the
//! option is [`super::Hierarchy::KdTree`] (experimental: [`crate::experimental::KdTree`]) beside the default BVH.
//!
//! The traversal is the BVH one's ([`super::traversal`]): front to back,
//! hierarchy updating and conservative hierarchy updating as
//! [`super::Coherence`] says, the frustum's three-way test, then the
//! occlusion test of the node's screen rectangle. Two differences follow
//! from the kD-tree: a node is a region, not a bound of its objects, and an
//! object is referenced by every leaf its box meets. So an object is tested
//! (with its own box) at most once a frame, in the first leaf that reaches
//! it, and counts as occluded only when no leaf found it visible; a hidden
//! region hides the part of each object inside it, and the parts make the
//! object. Objects the tree does not hold (added after its build, or
//! dynamic: a kD-tree is not refit) are tested one by one after it, as the
//! BVH's additions are; the tree is rebuilt when the model database is.
//!
//! # Visibility propagation
//! Before testing node N (in the frustum, not straddling the near plane),
//! the faces of its box turned towards the eye (at most three) are looked
//! up through their ropes: a face is invisible when its rope neighbour U
//! was found invisible this frame by an occlusion test of its rectangle or
//! by propagation — not by the frustum, which says nothing about occlusion.
//! U not visited this frame lies below a termination node: the lazy rule of
//! the paper's Figure 7 walks up from U to the first node classified this
//! frame and uses that one's classification. U opened this frame: the
//! constrained search of Figure 6 over U's descendants meeting the face,
//! each of which must be invisible (at most [`DFS_BUDGET`] nodes). When
//! every front face is invisible, N is invisible without a test.
//!
//! Why this is conservative in hom's image-space setting: an occlusion
//! test that culls U guarantees that every sample of U's rectangle holds an
//! occluder nearer than U's nearest depth. For an eye outside N, the ray to
//! any point p of N enters N's box through a face turned towards the eye,
//! at a point q of U's box (U holds that whole face), so p's sample lies in
//! U's footprint, and depth(p) ≥ depth(q) ≥ U's nearest depth: the occluder
//! there is nearer than p. Hence no eye inside N or on the plane of one of
//! its faces ([`crate::spatial::kdtree::front_faces`] gives no faces then),
//! and only a real rectangle test (or a propagation built on such tests)
//! counts as invisible.
//!
//! The paper's other side, a node classified *completely visible* from
//! visible faces when no occluder meets it, needs a test that answers
//! "visible": hom's rectangle tests answer only "occluded" or not, so that
//! side is not done.
//!
//! Temporal coherence (the paper's part of that name): propagation is tried
//! only on nodes not partially visible last frame (their own pull-up, kept
//! whatever the coherence mode), and on a node where it failed last frame
//! only with probability [`P_VP`], decided by a hash of (node, frame) as
//! `p_skip` is.
//!
//! Hierarchy updating stays conservative on the kD-tree but is not exactly
//! the classical traversal: an opened leaf tests its objects with their own
//! boxes, which reach beyond the leaf, where the classical traversal might
//! have culled the leaf's region.

use super::coherence::{combine, mix, Step, TemporalState, Vis};
use super::model_db::{Change, ModelDb};
use super::traversal::{Traversal, TraversalCounts, Visit};
use crate::geom::{Containment, Footprint, ScreenRect};
use crate::scene::Scene;
use crate::spatial::kdtree::{front_faces, KdNode, KdTree, NONE};
use crate::spatial::KdConfig;

/// The probability with which propagation is tried on a node where it failed
/// last frame (the paper's setting, method C).
pub const P_VP: f32 = 0.5;

/// Most nodes the constrained search below a partially visible neighbour visits.
pub const DFS_BUDGET: usize = 32;

/// How a node was classified this frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Class {
    /// Outside the frustum (says nothing about occlusion).
    Outside,
    /// Found occluded by its rectangle's test, or by propagation.
    Hidden,
    /// The traversal went into it (children, or a leaf's objects).
    Opened,
    /// Assumed visible (conservative hierarchy updating).
    Assumed,
}

/// A node's marks.
#[derive(Clone, Copy, Debug)]
struct NodeMark {
    /// The frame `class` and `pulled` belong to (0: never).
    frame: u32,
    class: Class,
    /// The pull-up of this frame's classification (partial: children disagree).
    pulled: Vis,
    /// The last frame propagation was tried on it and failed.
    failed: u32,
}

/// An object's fate this frame, in the tree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Fate {
    /// Drawn (tested visible, assumed, or an occluder).
    Visible,
    /// Tested with its own box: occluded or outside the frustum.
    Tested,
    /// In a hidden region, not tested yet.
    InHidden,
}

/// The per-frame marks of a kD traversal: split from the tree so the walk can borrow both.
#[derive(Clone, Debug)]
pub(crate) struct Marks {
    frame: u32,
    nodes: Vec<NodeMark>,
    objects: Vec<(u32, Fate)>,
    /// Whether each object id is served by the tree now (in it, live, static).
    served: Vec<bool>,
}

impl Marks {
    fn set(&mut self, i: u32, class: Class) {
        let m = &mut self.nodes[i as usize];
        m.frame = self.frame;
        m.class = class;
        m.pulled = match class {
            Class::Outside | Class::Hidden => Vis::Invisible,
            Class::Opened => Vis::Partial,
            Class::Assumed => Vis::Visible,
        };
    }

    fn fate(&self, id: u32) -> Option<Fate> {
        let (frame, fate) = self.objects[id as usize];
        (frame == self.frame).then_some(fate)
    }

    fn set_fate(&mut self, id: u32, fate: Fate) {
        self.objects[id as usize] = (self.frame, fate);
    }

    /// The coin of propagation's temporal rule, from a hash of (node, frame).
    fn tries(&self, i: u32) -> bool {
        let h = mix(i as u64 ^ mix(0x7f4a_7c15_9e37_79b9 ^ self.frame as u64));
        ((h >> 40) as f32) < P_VP * (1u64 << 24) as f32
    }
}

/// The kD-tree model database: the tree, the objects it does not serve, the marks.
#[derive(Clone, Debug)]
pub(crate) struct KdModel {
    tree: KdTree,
    /// The [`ModelDb::build`] it was built with.
    build: u32,
    propagation: bool,
    /// Whether each object id is referenced by the tree.
    in_tree: Vec<bool>,
    /// Live objects the tree does not serve (added since, or dynamic), ascending.
    outside: Vec<u32>,
    marks: Marks,
}

impl KdModel {
    /// Bytes held on the heap: the tree, the per-object lists and the marks.
    pub fn heap_bytes(&self) -> usize {
        use crate::vec_bytes;
        let m = &self.marks;
        self.tree.heap_bytes()
            + vec_bytes(&self.in_tree)
            + vec_bytes(&self.outside)
            + vec_bytes(&m.nodes)
            + vec_bytes(&m.objects)
            + vec_bytes(&m.served)
    }

    /// The tree over `scene`'s live static objects (boxes from `model`).
    pub fn new(model: &ModelDb, scene: &Scene, propagation: bool) -> KdModel {
        let ids = scene.live_objects().filter(|(_, o)| !o.is_dynamic()).map(|(id, _)| id);
        let tree = KdTree::build(model.boxes(), ids, &KdConfig::default());
        let mut in_tree = vec![false; scene.objects().len()];
        for &id in tree.items() {
            in_tree[id as usize] = true;
        }
        let nodes = tree.nodes().len();
        let mut kd = KdModel {
            tree,
            build: model.build(),
            propagation,
            in_tree,
            outside: Vec::new(),
            marks: Marks {
                frame: 1,
                nodes: vec![
                    NodeMark {
                        frame: 0,
                        class: Class::Outside,
                        pulled: Vis::Partial,
                        failed: 0,
                    };
                    nodes
                ],
                objects: Vec::new(),
                served: Vec::new(),
            },
        };
        kd.serve(scene);
        kd
    }

    /// Which objects the tree serves, and the list of those it does not.
    fn serve(&mut self, scene: &Scene) {
        let served = &mut self.marks.served;
        served.clear();
        self.outside.clear();
        for (id, o) in scene.objects().iter().enumerate() {
            let live = !o.is_removed();
            let s = live && !o.is_dynamic() && self.in_tree.get(id).copied().unwrap_or(false);
            served.push(s);
            if live && !s {
                self.outside.push(id as u32);
            }
        }
    }

    /// Follows `model` after its sync found `change`: rebuilt with it, else
    /// re-sorted between served and outside objects after a structural change.
    pub fn sync(&mut self, model: &ModelDb, scene: &Scene, change: Change) {
        if model.build() != self.build {
            *self = KdModel::new(model, scene, self.propagation);
        } else if change == Change::Structure {
            self.serve(scene);
        }
    }

    /// Starts the frame's temporal state over this tree (its regions never move).
    pub fn begin(&self, temporal: &mut TemporalState, model: &ModelDb, objects: usize) {
        temporal.begin_over(self.build, self.tree.nodes().len(), &[], model.moved_objects(), objects);
    }
}

/// The mutable side of a kD traversal: the shared visit and the marks.
struct KdVisit<'a, 'b, F> {
    v: &'a mut Visit<'b, F>,
    marks: &'a mut Marks,
}

impl Traversal<'_> {
    /// [`Traversal::run`] over the kD-tree `kd`; `stats` also counts
    /// propagation's attempts and successes.
    pub fn run_kd(
        &self,
        kd: &mut KdModel,
        temporal: &mut TemporalState,
        is_occluded: impl FnMut(&ScreenRect) -> bool,
        visible: &mut Vec<u32>,
        occluded: &mut Vec<u32>,
    ) -> TraversalCounts {
        let (scene, f) = (self.scene, self.frame);
        let KdModel {
            tree,
            marks,
            outside,
            propagation,
            ..
        } = kd;
        marks.frame += 1;
        if marks.frame == u32::MAX {
            marks.frame = 2;
            marks.nodes.iter_mut().for_each(|m| (m.frame, m.failed) = (0, 0));
            marks.objects.iter_mut().for_each(|m| m.0 = 0);
        }
        marks.objects.resize(scene.objects().len(), (0, Fate::Tested));
        let v = &mut Visit {
            temporal,
            is_occluded,
            visible,
            occluded,
            stats: TraversalCounts::default(),
        };
        let c = &mut KdVisit { v, marks };
        let propagation = *propagation;
        tree.walk_front_to_back(
            &f.eye,
            false,
            c,
            |c, i, node, inside| self.kd_node(tree, i, node, inside, propagation, c),
            |c, i, node| {
                let (a, b) = (node.child, node.child + 1);
                let (pa, pb) = (c.marks.nodes[a as usize].pulled, c.marks.nodes[b as usize].pulled);
                c.marks.nodes[i as usize].pulled = if pa == pb { pa } else { Vis::Partial };
                c.v.temporal.pull_up(i, a, b);
            },
        );
        let KdVisit { v, marks } = c;
        for &id in outside.iter() {
            self.object(id, false, v);
        }
        // Hidden in one region, but seen through another: visible.
        v.occluded.retain(|&id| marks.fate(id) != Some(Fate::Visible));
        v.occluded.sort_unstable();
        v.occluded.dedup();
        v.visible.sort_unstable();
        v.stats
    }

    /// Classifies node `i` (wholly inside the frustum when `inside`); returns
    /// the state for its children when the traversal goes into them.
    #[allow(clippy::too_many_arguments)]
    fn kd_node<F: FnMut(&ScreenRect) -> bool>(
        &self,
        tree: &KdTree,
        i: u32,
        node: &KdNode,
        inside: bool,
        propagation: bool,
        c: &mut KdVisit<'_, '_, F>,
    ) -> Option<bool> {
        let f = self.frame;
        let before = c.marks.nodes[i as usize];
        let step = c.v.temporal.node_step(i);
        let containment = if inside {
            Containment::Inside
        } else {
            f.frustum.test_aabb(&node.bounds)
        };
        if containment == Containment::Outside {
            c.v.stats.node_tests += 1;
            c.marks.set(i, Class::Outside);
            c.v.temporal.set_node(i, Vis::Invisible);
            return None;
        }
        let inside = containment == Containment::Inside;
        if step == Step::Open {
            c.v.stats.skipped += 1;
            c.marks.set(i, Class::Opened);
            if node.is_leaf() {
                self.kd_leaf(tree, i, node, inside, c);
            }
            return Some(inside);
        }
        if step == Step::Assume {
            c.v.stats.skipped += 1;
            for &id in tree.subtree_items(node) {
                let fate = c.marks.fate(id);
                if !c.marks.served[id as usize] || fate == Some(Fate::Visible) {
                    continue;
                }
                if self.scene.get(id).is_some_and(|o| self.meets_frustum(o, inside)) {
                    c.v.visible.push(id);
                    c.marks.set_fate(id, Fate::Visible);
                }
            }
            c.marks.set(i, Class::Assumed);
            c.v.temporal.assume_node(i);
            return None;
        }
        if let Footprint::Rect(r) = self.footprint(&node.bounds.corners()) {
            let frame = c.marks.frame;
            let partial_last = before.frame == frame - 1 && before.pulled == Vis::Partial;
            if propagation && !partial_last && (before.failed != frame - 1 || c.marks.tries(i)) {
                c.v.stats.propagation_attempts += 1;
                if self.propagates(tree, node, c.marks) {
                    c.v.stats.propagated += 1;
                    self.kd_hide(tree, i, node, inside, c);
                    return None;
                }
                c.marks.nodes[i as usize].failed = frame;
            }
            c.v.stats.node_tests += 1;
            if (c.v.is_occluded)(&r) {
                self.kd_hide(tree, i, node, inside, c);
                return None;
            }
        } else {
            c.v.stats.node_tests += 1; // straddles the near plane: never culled
        }
        c.marks.set(i, Class::Opened);
        if node.is_leaf() {
            self.kd_leaf(tree, i, node, inside, c);
        }
        Some(inside)
    }

    /// Node `i` hidden (by its test or by propagation): the served objects
    /// of its subtree in the frustum not yet decided are occluded unless
    /// another region shows them.
    fn kd_hide<F>(&self, tree: &KdTree, i: u32, node: &KdNode, inside: bool, c: &mut KdVisit<'_, '_, F>) {
        for &id in tree.subtree_items(node) {
            if !c.marks.served[id as usize] || c.marks.fate(id).is_some() {
                continue;
            }
            if self.scene.get(id).is_some_and(|o| self.meets_frustum(o, inside)) {
                c.v.occluded.push(id);
                c.marks.set_fate(id, Fate::InHidden);
            }
        }
        c.marks.set(i, Class::Hidden);
        c.v.temporal.set_node(i, Vis::Invisible);
    }

    /// The served objects of leaf `i`, each tested once a frame, then the leaf's pull-up.
    fn kd_leaf<F: FnMut(&ScreenRect) -> bool>(
        &self,
        tree: &KdTree,
        i: u32,
        node: &KdNode,
        inside: bool,
        c: &mut KdVisit<'_, '_, F>,
    ) {
        let (mut seen, mut unseen) = (0, 0);
        for &id in tree.subtree_items(node) {
            if !c.marks.served[id as usize] {
                continue;
            }
            match c.marks.fate(id) {
                Some(Fate::Visible) => seen += 1,
                Some(Fate::Tested) => unseen += 1,
                None | Some(Fate::InHidden) => match self.object(id, inside, c.v) {
                    Some(Vis::Invisible) => {
                        unseen += 1;
                        c.marks.set_fate(id, Fate::Tested);
                    }
                    Some(_) => {
                        seen += 1;
                        c.marks.set_fate(id, Fate::Visible);
                    }
                    None => {}
                },
            }
        }
        let vis = combine(seen, unseen);
        c.marks.nodes[i as usize].pulled = vis;
        c.v.temporal.set_node(i, vis);
    }

    /// Visibility propagation: whether every face of `node` turned towards
    /// the eye is invisible through its rope (see the module docs).
    fn propagates(&self, tree: &KdTree, node: &KdNode, marks: &Marks) -> bool {
        let (faces, n) = front_faces(&node.bounds, &self.frame.eye);
        n > 0 && faces[..n].iter().all(|&face| face_hidden(tree, node, face, marks))
    }
}

/// Whether face `face` of `node` is invisible this frame through its rope.
fn face_hidden(tree: &KdTree, node: &KdNode, face: usize, marks: &Marks) -> bool {
    let u = node.ropes[face];
    if u == NONE {
        return false; // the scene's boundary: nothing classified beyond
    }
    // The lazy rule: up from the rope's target to the first node classified this frame.
    let mut t = u;
    while marks.nodes[t as usize].frame != marks.frame {
        t = tree.node(t).parent;
        if t == NONE {
            return false;
        }
    }
    match marks.nodes[t as usize].class {
        Class::Hidden => true,
        Class::Opened if t == u && !tree.node(u).is_leaf() => {
            // The constrained search: every descendant meeting the face invisible.
            let f = node.face(face);
            let mut stack = [0u32; DFS_BUDGET];
            let mut len = 0;
            let mut budget = DFS_BUDGET;
            let push = |stack: &mut [u32; DFS_BUDGET], len: &mut usize, n: &KdNode| {
                for ch in [n.child, n.child + 1] {
                    if tree.node(ch).bounds.intersects(&f) {
                        if *len == DFS_BUDGET {
                            return false;
                        }
                        stack[*len] = ch;
                        *len += 1;
                    }
                }
                true
            };
            if !push(&mut stack, &mut len, tree.node(u)) {
                return false;
            }
            while len > 0 {
                if budget == 0 {
                    return false;
                }
                budget -= 1;
                len -= 1;
                let ch = stack[len];
                let m = marks.nodes[ch as usize];
                if m.frame != marks.frame {
                    return false;
                }
                let n = tree.node(ch);
                match m.class {
                    Class::Hidden => {}
                    Class::Opened if !n.is_leaf() => {
                        if !push(&mut stack, &mut len, n) {
                            return false;
                        }
                    }
                    _ => return false,
                }
            }
            true
        }
        _ => false,
    }
}
