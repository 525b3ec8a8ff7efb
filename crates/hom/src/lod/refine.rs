//! Selective refinement guided by visibility (Law & Tan 1999, section 6).
//!
//! Each object keeps its active front (node ids, ascending pre-order) from
//! frame to frame, and each frame moves it: an active node whose parent no
//! longer needs refining is folded into the parent, and one that needs
//! refining is replaced by its children, recursively. A node needs refining
//! when it is not a leaf, meets the frustum, its projected error exceeds the
//! threshold and — with guidance — it is not hidden. Because a node's error
//! is never below a child's and its box holds the child's, "needs refining"
//! only grows towards the root, and the moved front equals the cut found top
//! down from the root ([`top_down_cut`], the reference the tests hold it to).
//!
//! Hidden is asked of the culler that culled the frame, with the node's box
//! (the same rectangle and depth test its objects got). A hidden node is
//! drawn as it stands (coarse), not refined, and not dropped: its triangles
//! lie in its box, so they are hidden as the refined ones would be, and the
//! image does not change. The budget mode spends a triangle count on the
//! worst projected errors first (a max-heap from the roots each frame); a
//! node whose children do not fit stays, and the next worst is tried, so
//! the count comes close to the budget.

use super::{LodError, LodHierarchy, SceneLod};
use crate::geom::{Aabb, Containment, Frustum, View};
use crate::scene::{Object, Scene};
use glam::{Mat4, Vec3};
use std::collections::BinaryHeap;

/// What the selection aims for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LodOptions {
    /// Refine while a node's projected error exceeds this many pixels. Default 1.
    pub error_px: f32,
    /// Instead: draw at most this many triangles (of the objects asked
    /// about), refining the worst projected errors first.
    pub budget: Option<u64>,
    /// Never refine a node the culler finds hidden (Law & Tan's guidance).
    /// Off, refinement depends on the view alone. Default on.
    pub guidance: bool,
}

impl Default for LodOptions {
    fn default() -> Self {
        LodOptions {
            error_px: 1.0,
            budget: None,
            guidance: true,
        }
    }
}

impl LodOptions {
    /// An error unless the threshold is positive and finite and the budget not 0.
    pub fn validate(&self) -> Result<(), LodError> {
        if !(self.error_px.is_finite() && self.error_px > 0.0) {
            return Err(LodError::BadErrorThreshold(self.error_px));
        }
        if self.budget == Some(0) {
            return Err(LodError::BadBudget);
        }
        Ok(())
    }
}

/// A frame's view as refinement sees it: the frustum and how many pixels a
/// length spans at a given depth.
#[derive(Clone, Debug)]
pub struct LodView {
    frustum: Frustum,
    /// The clip `w` row: `w` of a point is `w_row · (p, 1)`.
    w_row: glam::Vec4,
    /// Pixels per unit of length per unit of `w`, an upper bound inside the view.
    px_per_w: f32,
}

impl LodView {
    /// The refinement view of `view`; `None` when the view is unusable (no frustum).
    pub fn new(view: &View) -> Option<LodView> {
        let m = view.world_to_clip();
        let frustum = view.frustum()?;
        let (r0, r1, r3) = (m.row(0), m.row(1), m.row(3));
        let w3 = r3.truncate().length();
        // Screen x is (r0 · p) / w; a step of length L moves it by at most
        // (|r0| + |x/w| |r3|) L / w, and |x/w| <= 1 inside the view.
        let px_per_w = 0.5
            * (view.width as f32 * (r0.truncate().length() + w3))
                .max(view.height as f32 * (r1.truncate().length() + w3));
        Some(LodView {
            frustum,
            w_row: r3,
            px_per_w,
        })
    }

    /// The largest number of pixels a displacement of `error` world units
    /// spans anywhere in `world_box` (infinite where the box reaches the
    /// eye's plane).
    pub fn error_px(&self, error: f32, world_box: &Aabb) -> f32 {
        if error <= 0.0 {
            return 0.0;
        }
        // w is linear: its minimum over the box is at a corner.
        let n = self.w_row.truncate();
        let corner = Vec3::select(n.cmpge(Vec3::ZERO), world_box.min, world_box.max);
        let w_min = n.dot(corner) + self.w_row.w;
        if w_min <= 0.0 {
            return f32::INFINITY;
        }
        error * self.px_per_w / w_min
    }

    /// Whether a world box meets the frustum.
    pub fn meets(&self, world_box: &Aabb) -> bool {
        self.frustum.test_aabb(world_box) != Containment::Outside
    }
}

/// One node to draw: `object`'s hierarchy node `node`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct LodPart {
    /// Object id.
    pub object: u32,
    /// Node id in the object's mesh's hierarchy.
    pub node: u32,
}

/// What one selection did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LodStats {
    /// Triangles of the drawn nodes.
    pub triangles: u64,
    /// Nodes drawn.
    pub nodes_drawn: u64,
    /// Nodes refined (inner nodes above the drawn ones).
    pub nodes_refined: u64,
    /// Drawn nodes left coarse because the culler found them hidden.
    pub nodes_occluded: u64,
    /// Box tests asked of the culler.
    pub hidden_tests: u64,
    /// The largest projected error of a drawn node that is in the frustum and
    /// not hidden, pixels (bounded by the threshold, or by the budget's reach).
    pub max_error_px: f32,
    /// Triangles of the coarsest cut (every object's root): no budget below
    /// it can be held.
    pub coarsest_triangles: u64,
}

/// A node's class this frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Class {
    Unknown,
    /// Drawn as it stands: a leaf, or within the threshold.
    Fine,
    /// Outside the frustum: not refined.
    Outside,
    /// Hidden (guidance): not refined.
    Hidden,
    /// Needs its children.
    Refine,
}

/// Level-of-detail selection state: each object's active front, kept across frames.
#[derive(Clone, Debug, Default)]
pub struct LodSelector {
    fronts: Vec<Vec<u32>>,
    memo: Vec<Class>,
    touched: Vec<u32>,
    scratch: Vec<u32>,
    stack: Vec<u32>,
}

/// The world data of one object during a selection.
struct Eval<'a> {
    h: &'a LodHierarchy,
    transform: Mat4,
    /// The transform's largest axis scale: mesh error to world error
    /// (rotations and axis scales; a shear would need its largest singular value).
    scale: f32,
    view: &'a LodView,
    error_px: f32,
    guided: bool,
}

impl<'a> Eval<'a> {
    /// Object `object`'s hierarchy seen from `view`; `error_px` is the threshold.
    fn of(lod: &'a SceneLod, object: &Object, view: &'a LodView, error_px: f32, guided: bool) -> Eval<'a> {
        let m = &object.transform;
        Eval {
            h: lod.hierarchy(object.mesh),
            transform: *m,
            scale: m
                .x_axis
                .truncate()
                .length()
                .max(m.y_axis.truncate().length())
                .max(m.z_axis.truncate().length()),
            view,
            error_px,
            guided,
        }
    }

    fn world_box(&self, node: u32) -> Aabb {
        self.h.nodes()[node as usize].bounds.transformed(&self.transform)
    }

    fn projected_error(&self, node: u32) -> f32 {
        let n = &self.h.nodes()[node as usize];
        self.view.error_px(n.error * self.scale, &self.world_box(node))
    }

    fn classify(&self, node: u32, hidden: &mut dyn FnMut(&[Vec3; 8]) -> bool, stats: &mut LodStats) -> Class {
        let n = &self.h.nodes()[node as usize];
        if n.is_leaf(node) {
            return Class::Fine;
        }
        let world = self.world_box(node);
        if !self.view.meets(&world) {
            return Class::Outside;
        }
        if self.view.error_px(n.error * self.scale, &world) <= self.error_px {
            return Class::Fine;
        }
        if self.guided && self.is_hidden(node, hidden, stats) {
            return Class::Hidden;
        }
        Class::Refine
    }

    /// Asks `hidden` about the node's box in the world (its eight corners
    /// transformed: tighter than the world box of a rotated object).
    fn is_hidden(&self, node: u32, hidden: &mut dyn FnMut(&[Vec3; 8]) -> bool, stats: &mut LodStats) -> bool {
        stats.hidden_tests += 1;
        let corners = self.h.nodes()[node as usize]
            .bounds
            .corners()
            .map(|p| self.transform.transform_point3(p));
        hidden(&corners)
    }
}

impl LodSelector {
    /// The active front of `object` (ascending node ids); empty before its first selection.
    pub fn front(&self, object: u32) -> &[u32] {
        self.fronts.get(object as usize).map_or(&[], Vec::as_slice)
    }

    /// Selects the nodes to draw for the objects `visible` (ascending or not)
    /// of `scene`, from `view`, into `parts` (cleared first; grouped by object
    /// in the order of `visible`, nodes ascending). `hidden(corners)` answers
    /// whether the world-space box with these corners is hidden this frame;
    /// it is asked only with guidance on, and only of nodes that would
    /// otherwise be refined.
    ///
    /// # Panics
    /// If an id in `visible` is not an object of `scene`.
    #[allow(clippy::too_many_arguments)]
    pub fn select(
        &mut self,
        scene: &Scene,
        lod: &SceneLod,
        visible: &[u32],
        view: &LodView,
        options: &LodOptions,
        hidden: &mut dyn FnMut(&[Vec3; 8]) -> bool,
        parts: &mut Vec<LodPart>,
    ) -> Result<LodStats, LodError> {
        options.validate()?;
        lod.check_scene(scene)?;
        parts.clear();
        if self.fronts.len() < scene.objects().len() {
            self.fronts.resize_with(scene.objects().len(), Vec::new);
        }
        let mut stats = LodStats::default();
        match options.budget {
            None => {
                for &id in visible {
                    let object = scene.object(id);
                    if object.is_removed() {
                        continue;
                    }
                    let eval = Eval::of(lod, object, view, options.error_px, options.guidance);
                    stats.coarsest_triangles += u64::from(eval.h.nodes()[0].triangle_count());
                    self.move_front(id, &eval, hidden, &mut stats);
                    self.draw_front(id, &eval, parts, &mut stats);
                }
            }
            Some(budget) => self.spend_budget(scene, lod, visible, view, options, budget, hidden, parts, &mut stats),
        }
        Ok(stats)
    }

    /// Moves `id`'s front to this frame's cut.
    fn move_front(&mut self, id: u32, eval: &Eval, hidden: &mut dyn FnMut(&[Vec3; 8]) -> bool, stats: &mut LodStats) {
        let h = eval.h;
        if self.memo.len() < h.nodes().len() {
            self.memo.resize(h.nodes().len(), Class::Unknown);
        }
        let mut front = std::mem::take(&mut self.fronts[id as usize]);
        if front.is_empty() || front.iter().any(|&n| n as usize >= h.nodes().len()) {
            front = vec![0];
        }
        let mut class = |node: u32, memo: &mut Vec<Class>, touched: &mut Vec<u32>| {
            let c = memo[node as usize];
            if c != Class::Unknown {
                return c;
            }
            let c = eval.classify(node, hidden, stats);
            memo[node as usize] = c;
            touched.push(node);
            c
        };
        let next = &mut self.scratch;
        next.clear();
        let stack = &mut self.stack;
        let mut i = 0;
        while i < front.len() {
            let a = front[i];
            // Fold into the highest ancestor reached while parents need no refining.
            let mut top = a;
            loop {
                let p = h.nodes()[top as usize].parent;
                if p == u32::MAX || class(p, &mut self.memo, &mut self.touched) == Class::Refine {
                    break;
                }
                top = p;
            }
            if top != a {
                // Nodes of `top`'s subtree already placed (a predicate that is
                // not monotone could leave some) go too.
                while next.last().is_some_and(|&n| n >= top) {
                    next.pop();
                }
                next.push(top);
                let last = h.nodes()[top as usize].last;
                while i < front.len() && front[i] <= last {
                    i += 1;
                }
                continue;
            }
            // Refine `a` as far as needed (depth first keeps pre-order).
            stack.clear();
            stack.push(a);
            while let Some(n) = stack.pop() {
                if class(n, &mut self.memo, &mut self.touched) == Class::Refine {
                    let at = stack.len();
                    stack.extend(h.children(n));
                    stack[at..].reverse();
                } else {
                    next.push(n);
                }
            }
            i += 1;
        }
        front.clear();
        front.extend_from_slice(next);
        self.fronts[id as usize] = front;
    }

    /// Appends `id`'s front to `parts`, with its statistics; forgets the memo.
    fn draw_front(&mut self, id: u32, eval: &Eval, parts: &mut Vec<LodPart>, stats: &mut LodStats) {
        let front = &self.fronts[id as usize];
        stats.nodes_refined += front.len() as u64 - 1;
        for &n in front {
            parts.push(LodPart { object: id, node: n });
            stats.nodes_drawn += 1;
            stats.triangles += u64::from(eval.h.nodes()[n as usize].triangle_count());
            match self.memo[n as usize] {
                Class::Hidden => stats.nodes_occluded += 1,
                Class::Outside => {}
                _ => stats.max_error_px = stats.max_error_px.max(eval.projected_error(n)),
            }
        }
        for &n in &self.touched {
            self.memo[n as usize] = Class::Unknown;
        }
        self.touched.clear();
    }

    /// Budget mode: from every object's root, refine the node with the
    /// largest projected error while the budget holds.
    #[allow(clippy::too_many_arguments)]
    fn spend_budget(
        &mut self,
        scene: &Scene,
        lod: &SceneLod,
        visible: &[u32],
        view: &LodView,
        options: &LodOptions,
        budget: u64,
        hidden: &mut dyn FnMut(&[Vec3; 8]) -> bool,
        parts: &mut Vec<LodPart>,
        stats: &mut LodStats,
    ) {
        #[derive(PartialEq)]
        struct Entry {
            error_px: f32,
            object: u32,
            node: u32,
        }
        impl Eq for Entry {}
        impl PartialOrd for Entry {
            fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
                Some(self.cmp(o))
            }
        }
        impl Ord for Entry {
            fn cmp(&self, o: &Self) -> std::cmp::Ordering {
                // Largest error first; ties by smaller ids first (deterministic).
                self.error_px
                    .total_cmp(&o.error_px)
                    .then(o.object.cmp(&self.object))
                    .then(o.node.cmp(&self.node))
            }
        }
        let evals: Vec<(u32, Eval)> = visible
            .iter()
            .filter(|&&id| !scene.object(id).is_removed())
            .map(|&id| (id, Eval::of(lod, scene.object(id), view, 0.0, options.guidance)))
            .collect();
        let mut heap = BinaryHeap::new();
        let mut total = 0u64;
        let mut drawn: Vec<(usize, u32, Class)> = Vec::new();
        // Priority of a node: its projected error, 0 when it may not be refined.
        let priority = |k: usize, n: u32| -> f32 {
            let e = &evals[k].1;
            if e.h.nodes()[n as usize].is_leaf(n) || !e.view.meets(&e.world_box(n)) {
                0.0
            } else {
                e.projected_error(n)
            }
        };
        for (k, (_, e)) in evals.iter().enumerate() {
            total += u64::from(e.h.nodes()[0].triangle_count());
            stats.coarsest_triangles += u64::from(e.h.nodes()[0].triangle_count());
            heap.push(Entry {
                error_px: priority(k, 0),
                object: k as u32,
                node: 0,
            });
        }
        while let Some(top) = heap.pop() {
            let (k, n) = (top.object as usize, top.node);
            let e = &evals[k].1;
            let leave = |class| (k, n, class);
            if top.error_px <= 0.0 {
                drawn.push(leave(Class::Fine));
                continue;
            }
            if e.guided && e.is_hidden(n, hidden, stats) {
                drawn.push(leave(Class::Hidden));
                continue;
            }
            let count = |n: u32| u64::from(e.h.nodes()[n as usize].triangle_count());
            let grown = total - count(n) + e.h.children(n).map(count).sum::<u64>();
            if grown > budget {
                // Too big for what is left: it stays, and the next worst may still fit.
                drawn.push(leave(Class::Fine));
                continue;
            }
            total = grown;
            stats.nodes_refined += 1;
            for c in e.h.children(n) {
                heap.push(Entry {
                    error_px: priority(k, c),
                    object: k as u32,
                    node: c,
                });
            }
        }
        drawn.extend(heap.into_iter().map(|e| (e.object as usize, e.node, Class::Fine)));
        // Grouped by object in the order of `visible`, nodes ascending.
        drawn.sort_unstable_by_key(|d| (d.0, d.1));
        for &(k, n, class) in &drawn {
            let (id, e) = (evals[k].0, &evals[k].1);
            parts.push(LodPart { object: id, node: n });
            stats.nodes_drawn += 1;
            stats.triangles += u64::from(e.h.nodes()[n as usize].triangle_count());
            match class {
                Class::Hidden => stats.nodes_occluded += 1,
                _ if e.view.meets(&e.world_box(n)) => {
                    stats.max_error_px = stats.max_error_px.max(e.projected_error(n));
                }
                _ => {}
            }
        }
        // The budget's cut becomes the fronts threshold mode moves from.
        for &(k, _, _) in &drawn {
            self.fronts[evals[k].0 as usize].clear();
        }
        for &(k, n, _) in &drawn {
            self.fronts[evals[k].0 as usize].push(n);
        }
    }
}

/// The cut refinement by the view alone draws for `object` at the threshold
/// `error_px` (no guidance): the front [`LodSelector`] moves to with
/// guidance off, found from the root. Node ids ascending (pre-order). What
/// an occluder is drawn as when the frame renders at this level of detail
/// ([`crate::lod::OccluderLod`]).
pub fn view_only_cut(lod: &SceneLod, object: &Object, view: &LodView, error_px: f32) -> Vec<u32> {
    let eval = Eval::of(lod, object, view, error_px, false);
    let mut stats = LodStats::default();
    top_down_cut(eval.h, |n| {
        eval.classify(n, &mut |_| false, &mut stats) == Class::Refine
    })
}

/// The cut found top down: from the root, a node is refined iff
/// `refine(node)` (asked only of inner nodes whose ancestors were refined).
/// The reference the moved front is tested against.
pub fn top_down_cut(h: &LodHierarchy, mut refine: impl FnMut(u32) -> bool) -> Vec<u32> {
    let mut cut = Vec::new();
    let mut stack = vec![0u32];
    while let Some(n) = stack.pop() {
        if !h.nodes()[n as usize].is_leaf(n) && refine(n) {
            let at = stack.len();
            stack.extend(h.children(n));
            stack[at..].reverse();
        } else {
            cut.push(n);
        }
    }
    cut
}

#[cfg(test)]
mod tests {
    use super::super::tests::{camera, ground_scene};
    use super::super::LodConfig;
    use super::*;
    use hom_testkit::Rng;

    /// Frame after frame, from wherever last frame left it, the moved front
    /// is the cut found from the root with the same classification; with
    /// guidance off, it is [`view_only_cut`].
    #[test]
    fn the_moved_front_is_the_top_down_cut() {
        let scene = ground_scene(6);
        let lod = SceneLod::build(&scene, &LodConfig { leaf_triangles: 48 }, &|_, _| {}).expect("built");
        let ids: Vec<u32> = (0..6).collect();
        let mut selector = LodSelector::default();
        let mut parts = Vec::new();
        let mut seed = Rng::new(42);
        let mut coarse_view_only = 0;
        for frame in 0..80 {
            let view = LodView::new(&camera(&mut seed).to_view()).expect("valid view");
            // Monotone, as the buffers' tests are: a box inside a hidden box is hidden.
            let plane = 10.0 + (frame % 7) as f32 * 12.0;
            let mut hidden = |c: &[Vec3; 8]| c.iter().all(|p| p.x > plane);
            let options = LodOptions {
                error_px: [0.5, 1.0, 4.0][frame % 3],
                guidance: frame % 4 != 0,
                budget: (frame % 9 == 8).then_some(3_000),
            };
            selector
                .select(&scene, &lod, &ids, &view, &options, &mut hidden, &mut parts)
                .expect("valid selection");
            if options.budget.is_some() {
                continue; // the budget's cut is not a threshold cut; the next frame moves from it
            }
            for &id in &ids {
                let eval = Eval::of(&lod, scene.object(id), &view, options.error_px, options.guidance);
                let mut stats = LodStats::default();
                let want = top_down_cut(eval.h, |n| eval.classify(n, &mut hidden, &mut stats) == Class::Refine);
                assert_eq!(selector.front(id), want.as_slice(), "frame {frame}, object {id}");
                if !options.guidance {
                    let cut = view_only_cut(&lod, scene.object(id), &view, options.error_px);
                    assert_eq!(selector.front(id), cut.as_slice(), "frame {frame}, object {id}");
                    coarse_view_only += cut.iter().any(|&n| !eval.h.nodes()[n as usize].is_leaf(n)) as u32;
                }
            }
            let drawn: Vec<LodPart> = ids
                .iter()
                .flat_map(|&id| selector.front(id).iter().map(move |&node| LodPart { object: id, node }))
                .collect();
            assert_eq!(parts, drawn, "frame {frame}: parts are not the fronts");
        }
        assert!(coarse_view_only > 0, "no view-only cut was coarser than its mesh");
    }
}
