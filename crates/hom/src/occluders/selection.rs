//! Dynamic occluder selection (Zhang et al. 1997, sections 5.3.2 and 6.2).
//!
//! Each frame: the occluders in the view frustum, nearest first (distance to
//! the box centre divided by the box's radius, so a big building a little
//! farther away beats a lamp post next to the eye), until the polygon budget
//! L is spent. Or, as the alternative, the single Z plane: the occluders whose
//! farthest depth is smallest, so a plane just beyond them separates them from
//! the rest. Around that:
//! - **adaptive L**: hill-climbing on frame time, nudged by the culled percentage;
//! - **hole filling**: when the last frame culled too little, the worst hole of
//!   the last frame's coarsest map defines a sub-frustum; occluders in it that
//!   were not selected last frame are taken first (nearest first, up to a
//!   fraction of L). If culling then rose markedly, they join a queue of
//!   occluders that are always selected, bounded by a polygon limit, oldest
//!   dropped first;
//! - **temporal coherence**: last frame's occluders win ties.

use super::database::OccluderDb;
use super::OccluderCuts;
use crate::geom::{Aabb, Containment, Eye, Frustum, View};
use crate::occlusion::details::Hole;
use crate::scene::Scene;
use glam::Mat4;
use std::collections::VecDeque;

/// How occluders are chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SelectionMode {
    /// Nearest first, size taken into account, until the budget is spent.
    Nearest,
    /// Nearest farthest-depth first: a single Z plane separates occluders from occludees.
    ZPlane,
}

/// The objects' current boxes and dynamic flags by id, as the model
/// database keeps them (compact: the selection scans every occluder).
#[derive(Clone, Copy, Debug)]
pub(crate) struct ObjectBoxes<'a> {
    /// Each object's box.
    pub boxes: &'a [Aabb],
    /// Whether each object moves (then its oriented box is tested).
    pub dynamic: &'a [bool],
    /// Objects known hidden this frame (a PVS said so; empty for none):
    /// never worth drawing as occluders.
    pub known_hidden: &'a [bool],
}

/// Settings of the selector.
#[derive(Clone, Debug, PartialEq)]
pub struct SelectionConfig {
    /// Ordering of candidates.
    pub mode: SelectionMode,
    /// Polygon budget L (triangles) at the start.
    pub budget: u32,
    /// Adapt L per frame from frame time and culled percentage.
    pub adaptive: bool,
    /// Bounds of the adaptive L.
    pub budget_range: (u32, u32),
    /// Use the hole-filling feedback.
    pub hole_filling: bool,
    /// A coarsest-map pixel below this opacity is a hole.
    pub hole_opacity: f32,
    /// Hole filling runs when the last frame culled less than this percentage of the triangles in the frustum.
    pub hole_trigger_pct: f32,
    /// Share of L hole-filling occluders may take.
    pub hole_share: f32,
    /// Polygon limit of the queue of proven hole fillers.
    pub queue_limit: u32,
    /// Rise in culled percentage (points) that proves hole fillers useful.
    pub queue_gain_pct: f32,
    /// Budget left once every candidate that fits is chosen buys selected
    /// occluders their originals back, nearest first, in place of their
    /// virtual occluders (an original covers what its stand-in covers, and
    /// more): the spheres' walk fits all ten stand-ins and one original.
    pub originals_from_leftover: bool,
    /// Share of L the ill-shaped occluders ([`super::Occluder::ranked_last`])
    /// may take, from what every other use of the budget leaves. Where the
    /// budget is not spent they would all be drawn: ons-reborn's bumpy
    /// ground took 144 -> 2,780 occluder triangles a frame and 0.27 -> 0.55
    /// ms of masked cull for 33 -> 47 % efficiency, a slower frame; at a
    /// tenth, 0.30 ms, while oa_dm2 keeps its 77 -> 90 %.
    pub ill_shaped_share: f32,
}

impl Default for SelectionConfig {
    fn default() -> Self {
        SelectionConfig {
            mode: SelectionMode::Nearest,
            budget: 3_000,
            adaptive: false,
            budget_range: (2_000, 200_000),
            hole_filling: true,
            hole_opacity: 0.5,
            hole_trigger_pct: 90.0,
            hole_share: 0.25,
            queue_limit: 10_000,
            queue_gain_pct: 2.0,
            originals_from_leftover: true,
            ill_shaped_share: 0.1,
        }
    }
}

/// What selection did this frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SelectionStats {
    /// Candidates in the frustum.
    pub candidates: u32,
    /// Occluders selected.
    pub selected: u32,
    /// Their triangles.
    pub triangles: u64,
    /// Of those, selected to fill a hole.
    pub hole_fillers: u32,
    /// Of those, from the queue.
    pub queued: u32,
    /// Of those, drawn as their originals in place of their virtual
    /// occluders ([`SelectionConfig::originals_from_leftover`]).
    pub originals: u32,
    /// The budget L used.
    pub budget: u32,
}

/// Per-frame occluder selection with feedback; keeps state across frames.
#[derive(Clone, Debug)]
pub struct OccluderSelector {
    config: SelectionConfig,
    budget: u32,
    last_selected: Vec<bool>,
    queue: VecDeque<(u32, u32)>,
    queue_triangles: u64,
    hole_fillers: Vec<u32>,
    last_culled_pct: Option<f32>,
    last_frame_ms: Option<f64>,
    step: f32,
    /// This frame's candidates: ranked last, key, object id, triangles.
    candidates: Vec<(bool, f32, u32, u32)>,
    /// Per object this frame: [`IN_VIEW`], [`CHOSEN`] or 0; all 0 between frames.
    marks: Vec<u8>,
}

/// [`OccluderSelector::marks`]: a candidate (an occluder in the frustum).
const IN_VIEW: u8 = 1;
/// [`OccluderSelector::marks`]: a candidate chosen this frame.
const CHOSEN: u8 = 2;

impl OccluderSelector {
    /// Bytes held on the heap (per-object flags, queue, candidates).
    pub(crate) fn heap_bytes(&self) -> usize {
        use crate::vec_bytes;
        vec_bytes(&self.last_selected)
            + self.queue.capacity() * std::mem::size_of::<(u32, u32)>()
            + vec_bytes(&self.hole_fillers)
            + vec_bytes(&self.candidates)
            + vec_bytes(&self.marks)
    }

    /// A selector with `config`.
    pub fn new(config: SelectionConfig) -> OccluderSelector {
        OccluderSelector {
            budget: config.budget,
            config,
            last_selected: Vec::new(),
            queue: VecDeque::new(),
            queue_triangles: 0,
            hole_fillers: Vec::new(),
            last_culled_pct: None,
            last_frame_ms: None,
            step: 1.25,
            candidates: Vec::new(),
            marks: Vec::new(),
        }
    }

    /// The settings.
    pub fn config(&self) -> &SelectionConfig {
        &self.config
    }

    /// Selects this frame's occluders into `out` (ids, ascending), and into
    /// `originals` (ascending) those of them to draw as their originals
    /// though they have a virtual occluder. `hole` is the
    /// worst hole of the last frame's coarsest map, if the caller found one.
    ///
    /// `world_to_clip` is the view in hom's clip convention, `eye` its viewer
    /// ([`crate::geom::View::world_to_clip`], [`crate::geom::View::eye`]);
    /// `cuts` prices an occluder drawn at its level of detail (its cut's
    /// triangles; without level of detail, its own cost).
    #[allow(clippy::too_many_arguments)]
    pub fn select(
        &mut self,
        db: &OccluderDb,
        scene: &Scene,
        objects: ObjectBoxes<'_>,
        world_to_clip: &Mat4,
        eye: &Eye,
        frustum: &Frustum,
        hole: Option<&Hole>,
        cuts: &mut OccluderCuts,
        out: &mut Vec<u32>,
        originals: &mut Vec<u32>,
    ) -> SelectionStats {
        out.clear();
        originals.clear();
        let count = scene.objects().len();
        self.last_selected.resize(count, false);
        self.marks.resize(count, 0);
        let mut stats = SelectionStats {
            budget: self.budget,
            ..SelectionStats::default()
        };
        self.candidates.clear();
        for occ in db.occluders() {
            let id = occ.object as usize;
            if objects.known_hidden.get(id).copied().unwrap_or(false) {
                continue;
            }
            // The compact boxes and flags: the scan touches no object record
            // but the moving ones' (100k objects: 3.3 -> 0.9 ms a frame).
            let aabb = &objects.boxes[id];
            let inside = if objects.dynamic[id] {
                frustum.test_obb(&scene.objects()[id].obb)
            } else {
                frustum.test_aabb(aabb)
            };
            if inside == Containment::Outside {
                continue;
            }
            let key = match self.config.mode {
                SelectionMode::Nearest => {
                    let radius = aabb.half_extent().length().max(1e-6);
                    View::distance(eye, aabb.center()) / radius
                }
                // Clip z before the divide grows with view depth (perspective and parallel alike).
                SelectionMode::ZPlane => aabb
                    .corners()
                    .iter()
                    .map(|c| (*world_to_clip * c.extend(1.0)).z)
                    .fold(f32::MIN, f32::max),
            };
            // Temporal coherence: last frame's occluders win near-ties.
            let key = if self.last_selected[occ.object as usize] {
                key * 0.98
            } else {
                key
            };
            let triangles = cuts.cost(scene, occ);
            self.candidates.push((occ.ranked_last, key, occ.object, triangles));
            self.marks[id] = IN_VIEW;
        }
        stats.candidates = self.candidates.len() as u32;
        // Ill-shaped occluders after every other, then by key: `shaped` the
        // candidates before them.
        self.candidates
            .sort_unstable_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)).then(a.2.cmp(&b.2)));
        let shaped = self.candidates.partition_point(|c| !c.0);

        let mut spent: u64 = 0;
        let budget = self.budget as u64;
        // Every id passed is a candidate's, but the queue's, which may have left the view.
        let take = |marks: &mut [u8], id: u32, tris: u32, limit: u64, spent: &mut u64, out: &mut Vec<u32>| -> bool {
            let mark = marks.get(id as usize).copied().unwrap_or(0);
            if mark != IN_VIEW || *spent + tris as u64 > limit {
                return false;
            }
            marks[id as usize] = CHOSEN;
            *spent += tris as u64;
            out.push(id);
            true
        };
        // 1. The queue of proven hole fillers, if still in view.
        for &(id, tris) in &self.queue {
            if take(&mut self.marks, id, tris, budget, &mut spent, out) {
                stats.queued += 1;
            }
        }
        // 2. Hole fillers: in the hole's sub-frustum, not selected last frame.
        self.hole_fillers.clear();
        if let Some(h) = hole.filter(|_| self.config.hole_filling) {
            if let Some(sub) = Frustum::from_view_proj_ndc_rect(world_to_clip, h.x, h.y) {
                let limit = spent + (budget as f32 * self.config.hole_share) as u64;
                // Not the ill-shaped: as hole fillers they took the budget
                // first and, proven, the queue's (oa_shouse, masked,
                // --no-cost-model: efficiency 50.1 -> 39.0 %).
                for &(_, _, id, tris) in &self.candidates[..shaped] {
                    let aabb = &objects.boxes[id as usize];
                    if self.last_selected[id as usize] || sub.test_aabb(aabb) == Containment::Outside {
                        continue;
                    }
                    if take(&mut self.marks, id, tris, limit, &mut spent, out) {
                        self.hole_fillers.push(id);
                    }
                }
            }
        }
        stats.hole_fillers = self.hole_fillers.len() as u32;
        // 3. The standard criterion for the rest of the budget; the
        //    ill-shaped candidates wait for step 5.
        for &(_, _, id, tris) in &self.candidates[..shaped] {
            take(&mut self.marks, id, tris, budget, &mut spent, out);
        }
        // 4. What is left buys originals back, nearest first.
        if self.config.originals_from_leftover && spent < budget {
            for &(_, _, id, tris) in &self.candidates {
                let occ = match db.occluder(id) {
                    Some(o)
                        if self.marks[id as usize] == CHOSEN
                            && o.stand_in.is_none()
                            && o.virtual_occluder.is_some()
                            && !cuts.has_cut(id) =>
                    {
                        o
                    }
                    _ => continue,
                };
                let full = u64::from(scene.object(occ.object).triangles);
                let extra = full.saturating_sub(u64::from(tris));
                if full <= u64::from(db.config().max_triangles) && spent + extra <= budget {
                    spent += extra;
                    originals.push(id);
                }
            }
            originals.sort_unstable();
        }
        stats.originals = originals.len() as u32;
        // 5. Ill-shaped candidates, with what is left (up to their share):
        //    their boxes overstate what they hide, so they come after every
        //    other use of the budget.
        let limit = budget.min(spent + (budget as f32 * self.config.ill_shaped_share) as u64);
        for &(_, _, id, tris) in &self.candidates[shaped..] {
            take(&mut self.marks, id, tris, limit, &mut spent, out);
        }
        for &(_, _, id, _) in &self.candidates {
            self.marks[id as usize] = 0;
        }
        out.sort_unstable();
        self.last_selected.fill(false);
        for &id in out.iter() {
            self.last_selected[id as usize] = true;
        }
        stats.selected = out.len() as u32;
        stats.triangles = spent;
        stats
    }

    /// True when the last frame culled too little: the caller should look for a hole.
    pub fn wants_hole(&self) -> bool {
        self.config.hole_filling && self.last_culled_pct.is_some_and(|p| p < self.config.hole_trigger_pct)
    }

    /// End-of-frame feedback: the percentage of in-frustum triangles culled as
    /// occluded, and the frame time (culling plus rendering) if known.
    pub fn feedback(&mut self, culled_pct: f32, frame_ms: Option<f64>) {
        // Hole fillers that raised the culling rate join the queue.
        if let Some(last) = self.last_culled_pct {
            if !self.hole_fillers.is_empty() && culled_pct - last >= self.config.queue_gain_pct {
                for &id in &self.hole_fillers {
                    if self.queue.iter().any(|q| q.0 == id) {
                        continue;
                    }
                    let tris = 1u32.max(self.candidates.iter().find(|c| c.2 == id).map_or(1, |c| c.3));
                    self.queue.push_back((id, tris));
                    self.queue_triangles += tris as u64;
                    while self.queue_triangles > self.config.queue_limit as u64 {
                        let Some((_, t)) = self.queue.pop_front() else { break };
                        self.queue_triangles -= t as u64;
                    }
                }
            }
        }
        if self.config.adaptive {
            if let (Some(now), Some(before)) = (frame_ms, self.last_frame_ms) {
                // Hill-climb: keep moving L while frames get faster, turn back when they slow.
                if now > before * 1.02 {
                    self.step = 1.0 / self.step;
                }
                // Much culled already: more occluders rarely pay; lean towards fewer.
                let lean = if culled_pct > 95.0 { 0.97 } else { 1.0 };
                let (lo, hi) = self.config.budget_range;
                self.budget = ((self.budget as f32 * self.step * lean) as u32).clamp(lo, hi);
            }
        }
        self.last_culled_pct = Some(culled_pct);
        if frame_ms.is_some() {
            self.last_frame_ms = frame_ms;
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::cull::{CullOutput, Culler, HomConfig, MaskedCuller};
    use crate::geom::Camera;
    use crate::occluders::database::tests::wall_and_sliver;
    use glam::Vec3;

    /// A wall 11 m away (2 triangles) and, nearer, a sliver that fills almost
    /// none of its box (2 triangles, ill-shaped): with a budget for one, the
    /// wall is drawn though the sliver is nearer; with a budget for both,
    /// both, unless the sliver's share of it is too small.
    #[test]
    fn ill_shaped_candidates_take_what_the_others_leave() {
        let scene = wall_and_sliver();
        let camera = Camera::new(
            Vec3::new(0.0, 1.5, 6.0),
            Vec3::new(0.0, 1.5, 0.0),
            Vec3::Y,
            1.2,
            0.1,
            100.0,
            64,
            64,
        );
        for (budget, share, expected) in [(2, 1.0, vec![0]), (4, 1.0, vec![0, 1]), (4, 0.4, vec![0])] {
            let mut config = HomConfig::for_scene(&scene);
            config.cost_model = false;
            config.occluders.selection.budget = budget;
            config.occluders.selection.ill_shaped_share = share;
            config.occluders.selection.hole_filling = false;
            let db = crate::occluders::OccluderDb::build(&scene, &config.occluders.occluder_db);
            assert!(
                db.occluder(1).is_some_and(|o| o.ranked_last),
                "the sliver is ill-shaped"
            );
            let mut culler = MaskedCuller::new(&scene, config.with_buffer(()));
            let mut out = CullOutput::default();
            culler.cull(&scene, &camera.to_view(), &mut out).unwrap();
            assert_eq!(out.occluders, expected, "budget {budget}, share {share}");
        }
    }
}
