//! What a culler did in one frame, typed: a struct per concern, gathered in
//! [`CullStats`] on [`super::CullOutput`] (in the spirit of MOC's
//! `OcclusionCullingStatistics`). A part is `Some` only for the cullers and
//! frames that do that work; [`CullStats::counters`] is the one place that
//! names each field, under the counter names reports have always used.

use crate::occlusion::details::{OverlapStats, ZDrawStats};
use crate::occlusion::TreeStats;

/// One frame's statistics, by concern; `None` (or `false`) where the
/// culler did not do that work this frame.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct CullStats {
    /// Frustum culling alone: [`super::FrustumCuller`], and an occluder
    /// culler's resting frames.
    pub frustum: Option<FrustumStats>,
    /// The cost model rested this frame (frustum culling only).
    pub rested: bool,
    /// An occluder culler's occlusion traversal (HOM, HZB, masked, otree).
    pub traversal: Option<TraversalStats>,
    /// An occluder culler's occluder selection and drawing.
    pub occluders: Option<OccluderStats>,
    /// An occluder culler's memory.
    pub memory: Option<MemoryStats>,
    /// HOM's overlap tests against the occlusion map (`overlap_pixels`,
    /// `levels_visited`).
    pub map: Option<OverlapStats>,
    /// The occlusion tree's size and its tests' classes (`otree_nodes`,
    /// `otree_in_leaves`, `otree_dropped`, `otree_visible`, `otree_partial`,
    /// `otree_invisible`; its triangles inserted are not reported).
    pub otree: Option<TreeStats>,
    /// An occluder culler's per-sample depth check after the traversal.
    pub depth_check: Option<DepthCheckStats>,
    /// Hierarchical visibility's ([`super::HvCuller`]).
    pub hv: Option<HvStats>,
    /// A precomputed visibility set in front of a culler ([`super::PvsCuller`]).
    pub pvs: Option<PvsStats>,
}

/// Frustum culling alone.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrustumStats {
    /// Box tests against the frustum (counter `node_tests`).
    pub node_tests: u64,
}

/// An occluder culler's occlusion traversal.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TraversalStats {
    /// Nodes classified by a test: found outside the frustum, or tested
    /// against the buffer (`node_tests`).
    pub node_tests: u64,
    /// Objects classified by a test (`object_tests`).
    pub object_tests: u64,
    /// Nodes in view opened without their buffer test, and nodes and
    /// objects assumed visible (`tests_skipped`).
    pub tests_skipped: u64,
    /// Visibility propagation's work, on the kD-tree only.
    pub propagation: Option<PropagationStats>,
}

impl TraversalStats {
    /// Node and object tests (`box_tests`).
    pub fn box_tests(&self) -> u64 {
        self.node_tests + self.object_tests
    }
}

/// Visibility propagation through the kD-tree's ropes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PropagationStats {
    /// Nodes propagation was tried on (`propagation_attempts`).
    pub attempts: u64,
    /// Nodes it classified invisible without a test (`propagated_invisible`).
    pub propagated: u64,
}

/// An occluder culler's occluders: their selection, then their drawing
/// (the buffer's own account of it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OccluderStats {
    /// Occluders selected (`occluders`).
    pub selected: u64,
    /// Occluder triangles submitted to the buffer (`occluder_triangles`).
    pub triangles: u64,
    /// Of the selected, chosen to fill last frame's worst hole (`hole_fillers`).
    pub hole_fillers: u64,
    /// Of the selected, taken from the queue (`queued_occluders`).
    pub queued: u64,
    /// Occluders drawn as their originals though they have a virtual
    /// occluder (`occluder_originals`).
    pub originals: u64,
    /// The frame's triangle budget (`budget`).
    pub budget: u64,
    /// Occluder candidates in the frustum (`candidates`).
    pub candidates: u64,
    /// With occluders at the level of detail: those drawn as a cut
    /// (`occluder_cuts`).
    pub cuts: Option<u64>,
    /// Triangles the buffer drew after clipping and culling
    /// (`occluder_triangles_drawn`).
    pub triangles_drawn: u64,
    /// Microseconds of triangle setup (`occluder_setup_us`; timing).
    pub setup_us: u64,
    /// Microseconds of rasterization (`occluder_raster_us`; timing).
    pub raster_us: u64,
    /// Tiles drawn, as the buffer counts them (`occluder_tiles_drawn`).
    pub tiles_drawn: u64,
    /// Tiles and blocks skipped because everything there was nearer
    /// (`occluder_tiles_rejected`).
    pub tiles_rejected: u64,
}

/// The per-sample depth check after an occluder culler's traversal
/// (`cull/depth_check.rs`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DepthCheckStats {
    /// Visible objects the occluders cover, checked sample by sample (`depth_checks`).
    pub checked: u64,
    /// Of them, behind the occluders at every sample, and culled (`depth_check_culled`).
    pub culled: u64,
    /// Not checked this frame, resting: drawn in the frame checked before
    /// (`depth_check_rested`).
    pub rested: u64,
    /// HOM: tiles of 8×8 samples of occluder depth drawn for the check
    /// (`depth_check_tiles`); HZB's z-buffer is already drawn.
    pub tiles_drawn: u64,
}

/// An occluder culler's memory, in bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MemoryStats {
    /// The classifications kept across frames (`temporal_bytes`).
    pub temporal_bytes: u64,
    /// The culler's own state, the buffer excluded (`state_bytes`).
    pub state_bytes: u64,
}

/// Hierarchical visibility's work in one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HvStats {
    /// Octree nodes visited (`nodes_visited`).
    pub nodes_visited: u64,
    /// Nodes classified by a test: outside the frustum, or against the
    /// pyramid (`node_tests`).
    pub node_tests: u64,
    /// Nodes in view whose pyramid test coherence skipped (`tests_skipped`).
    pub tests_skipped: u64,
    /// Moving objects drawn first by priming (`objects_primed`).
    pub objects_primed: u64,
    /// Nodes drawn first by priming (`nodes_primed`).
    pub nodes_primed: u64,
    /// Node boxes tested against the pyramid (`node_box_tests`).
    pub node_box_tests: u64,
    /// Nodes found behind the pyramid (`nodes_occluded`).
    pub nodes_occluded: u64,
    /// Nodes whose own triangles were drawn (`nodes_drawn`).
    pub nodes_drawn: u64,
    /// Moving and added objects tested one by one (`dynamic_tested`, and
    /// `object_tests`).
    pub dynamic_tested: u64,
    /// Of those, found behind the pyramid (`dynamic_occluded`).
    pub dynamic_occluded: u64,
    /// Triangles submitted (`triangles_submitted`).
    pub triangles_submitted: u64,
    /// What drawing into the pyramid did (`triangles_occluded`,
    /// `triangles_rasterized`, `sample_tests`, `samples_written`,
    /// `tile_tests`, `tiles_skipped`).
    pub draw: ZDrawStats,
    /// Pyramid texels read by box tests (`pyramid_texel_tests`).
    pub pyramid_texel_tests: u64,
    /// Pyramid texels updated (`pyramid_texels_updated`).
    pub pyramid_texels_updated: u64,
    /// The depth comparisons of a plain z-buffer render of the frame, when
    /// counted ([`super::HvConfig::count_zbuffer`]; `zbuffer_depth_comparisons`).
    pub zbuffer_depth_comparisons: Option<u64>,
    /// Objects with a sample that passed the depth test (`objects_passing`).
    pub objects_passing: u64,
}

impl HvStats {
    /// Sample tests plus pyramid texel tests (`depth_comparisons`).
    pub fn depth_comparisons(&self) -> u64 {
        self.draw.sample_tests + self.pyramid_texel_tests
    }
}

/// A precomputed visibility set in front of a culler.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PvsStats {
    /// The camera's cell had a set (`pvs_served`: 1 or 0).
    pub served: bool,
    /// Objects the set hides (`pvs_hidden`).
    pub hidden: u64,
    /// Objects the culler kept that the set culled (`pvs_culled`).
    pub culled: u64,
}

impl CullStats {
    /// Box tests of the frame, from whichever part ran: the frustum's, the
    /// traversal's or HV's (`node_tests`).
    pub fn node_tests(&self) -> Option<u64> {
        (self.frustum.map(|f| f.node_tests))
            .or(self.traversal.map(|t| t.node_tests))
            .or(self.hv.map(|h| h.node_tests))
    }

    /// Objects classified by a test: the traversal's or HV's (`object_tests`).
    pub fn object_tests(&self) -> Option<u64> {
        (self.traversal.map(|t| t.object_tests)).or(self.hv.map(|h| h.dynamic_tested))
    }

    /// Tests coherence skipped: the traversal's or HV's (`tests_skipped`).
    pub fn tests_skipped(&self) -> Option<u64> {
        (self.traversal.map(|t| t.tests_skipped)).or(self.hv.map(|h| h.tests_skipped))
    }

    /// Every statistic of the frame as `(name, value)`, under the counter
    /// names of the walk reports (their `counters` object): the one place
    /// that names them. Only the parts present are listed.
    pub fn counters(&self) -> Vec<(&'static str, u64)> {
        let mut c = Vec::new();
        if let Some(f) = &self.frustum {
            c.push(("node_tests", f.node_tests));
        }
        if self.rested {
            c.push(("rested", 1));
        }
        if let Some(t) = &self.traversal {
            c.extend([
                ("box_tests", t.box_tests()),
                ("node_tests", t.node_tests),
                ("object_tests", t.object_tests),
                ("tests_skipped", t.tests_skipped),
            ]);
            if let Some(p) = &t.propagation {
                c.extend([
                    ("propagation_attempts", p.attempts),
                    ("propagated_invisible", p.propagated),
                ]);
            }
        }
        if let Some(o) = &self.occluders {
            if let Some(cuts) = o.cuts {
                c.push(("occluder_cuts", cuts));
            }
            c.extend([
                ("occluders", o.selected),
                ("occluder_triangles", o.triangles),
                ("hole_fillers", o.hole_fillers),
                ("queued_occluders", o.queued),
                ("occluder_originals", o.originals),
                ("budget", o.budget),
                ("candidates", o.candidates),
                ("occluder_triangles_drawn", o.triangles_drawn),
                ("occluder_setup_us", o.setup_us),
                ("occluder_raster_us", o.raster_us),
                ("occluder_tiles_drawn", o.tiles_drawn),
                ("occluder_tiles_rejected", o.tiles_rejected),
            ]);
        }
        if let Some(d) = &self.depth_check {
            c.extend([
                ("depth_checks", d.checked),
                ("depth_check_culled", d.culled),
                ("depth_check_rested", d.rested),
                ("depth_check_tiles", d.tiles_drawn),
            ]);
        }
        if let Some(m) = &self.memory {
            c.extend([("temporal_bytes", m.temporal_bytes), ("state_bytes", m.state_bytes)]);
        }
        if let Some(m) = &self.map {
            c.extend([("overlap_pixels", m.pixels), ("levels_visited", m.levels)]);
        }
        if let Some(t) = &self.otree {
            c.extend([
                ("otree_nodes", t.nodes),
                ("otree_in_leaves", t.in_leaves),
                ("otree_dropped", t.leaves_dropped),
                ("otree_visible", t.visible),
                ("otree_partial", t.partial),
                ("otree_invisible", t.invisible),
            ]);
        }
        if let Some(h) = &self.hv {
            c.extend([
                ("nodes_visited", h.nodes_visited),
                ("node_tests", h.node_tests),
                ("object_tests", h.dynamic_tested),
                ("tests_skipped", h.tests_skipped),
                ("objects_primed", h.objects_primed),
                ("nodes_primed", h.nodes_primed),
                ("node_box_tests", h.node_box_tests),
                ("nodes_occluded", h.nodes_occluded),
                ("nodes_drawn", h.nodes_drawn),
                ("dynamic_tested", h.dynamic_tested),
                ("dynamic_occluded", h.dynamic_occluded),
                ("triangles_submitted", h.triangles_submitted),
                ("triangles_occluded", h.draw.triangles_occluded),
                ("triangles_rasterized", h.draw.triangles_rasterized),
                ("sample_tests", h.draw.sample_tests),
                ("samples_written", h.draw.samples_written),
                ("tile_tests", h.draw.tile_tests),
                ("tiles_skipped", h.draw.tiles_skipped),
                ("pyramid_texel_tests", h.pyramid_texel_tests),
                ("pyramid_texels_updated", h.pyramid_texels_updated),
                ("depth_comparisons", h.depth_comparisons()),
            ]);
            if let Some(z) = h.zbuffer_depth_comparisons {
                c.push(("zbuffer_depth_comparisons", z));
            }
            c.push(("objects_passing", h.objects_passing));
        }
        if let Some(p) = &self.pvs {
            c.extend([
                ("pvs_served", u64::from(p.served)),
                ("pvs_hidden", p.hidden),
                ("pvs_culled", p.culled),
            ]);
        }
        c
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// No two parts that can be present in one frame name the same counter.
    #[test]
    fn names_are_unique_within_a_frame() {
        let occluder_frame = CullStats {
            traversal: Some(TraversalStats {
                propagation: Some(PropagationStats::default()),
                ..TraversalStats::default()
            }),
            occluders: Some(OccluderStats {
                cuts: Some(0),
                ..OccluderStats::default()
            }),
            memory: Some(MemoryStats::default()),
            depth_check: Some(DepthCheckStats::default()),
            map: Some(OverlapStats::default()),
            otree: Some(TreeStats::default()),
            pvs: Some(PvsStats::default()),
            ..CullStats::default()
        };
        let hv_frame = CullStats {
            hv: Some(HvStats {
                zbuffer_depth_comparisons: Some(0),
                ..HvStats::default()
            }),
            pvs: Some(PvsStats::default()),
            ..CullStats::default()
        };
        let rest_frame = CullStats {
            frustum: Some(FrustumStats::default()),
            rested: true,
            pvs: Some(PvsStats::default()),
            ..CullStats::default()
        };
        for s in [occluder_frame, hv_frame, rest_frame] {
            let names: Vec<_> = s.counters().into_iter().map(|c| c.0).collect();
            let mut unique = names.clone();
            unique.sort_unstable();
            unique.dedup();
            assert_eq!(unique.len(), names.len(), "{names:?}");
        }
        assert!(CullStats::default().counters().is_empty());
    }
}
