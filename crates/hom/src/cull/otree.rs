//! The occlusion-tree culler (Bittner, Havran and Slavík, "Hierarchical
//! visibility culling with occlusion trees", CGI 1998; the culler Bittner
//! and Havran 2002 measure their coherence methods with): the same occluder
//! selection, BVH traversal and coherence as [`super::HomCuller`] and
//! [`super::HzbCuller`], with the occluders' shadow frusta merged into an
//! [`OcclusionTree`] — an object-space representation beside the two
//! image-space ones, so a comparison of the three isolates the representation.
//!
//! Per frame: select occluders → insert their triangles, nearest occluder
//! first, into the tree (a BSP of the image plane over their projected edges,
//! *in* leaves naming the covering triangle) → traverse the BVH front to
//! back, culling a node or object when the constrained depth-first search of
//! its screen rectangle finds it hidden in every leaf it reaches.
//!
//! # Conservative
//! By construction: a leaf's region holds only samples its triangle covers
//! (exact fixed-point edge functions, the renderer's setup and fill rule),
//! and a rectangle is culled only when it lies beyond the triangle's farthest
//! depth over the samples that reach each leaf (by
//! [`crate::occlusion::details::DEPTH_MARGIN`]). The same caveats as HOM's apply (same
//! resolution and sampling as the final image, stand-ins contained in their
//! objects, opaque occluders).
//!
//! Hole filling (occluder selection's feedback) needs the opacity of screen
//! regions, which the tree does not keep: as HZB does from its depth, an
//! opacity pyramid is built from the samples last frame's tree covered (its
//! *in* leaves' triangles, [`OcclusionTree::coverage_bits`]) and searched
//! ([`crate::occlusion::details::worst_hole_of_coverage`]).
//!
//! Counters besides the traversal's: `otree_nodes`, `otree_in_leaves` (the
//! tree's size), `otree_dropped` (out leaves left out at the node cap), and
//! the tests' classes `otree_visible`, `otree_partial`, `otree_invisible`.

use super::occluder_culler::{culler_buffer_options, sized, OccluderCulling};
use super::{Coherence, CullError, CullOutput, Culler, Hierarchy, HomConfig};
use crate::geom::View;
use crate::occluders::{OccluderConfig, OccluderDb};
use crate::occlusion::details::worst_hole_of_coverage;
use crate::occlusion::details::RectTest;
use crate::occlusion::{MapOptions, OcclusionBuffer, OcclusionTree, DEFAULT_NODE_CAP};
use crate::scene::Scene;

/// Settings of the occlusion-tree culler: HOM's occluder selection and database, and the tree's size cap.
#[derive(Clone, Debug, PartialEq)]
pub struct OtreeConfig {
    /// Which objects occlude, and how each frame's are chosen (shared with HOM).
    pub occluders: OccluderConfig,
    /// How much of last frame's classification the traversal reuses (shared with HOM).
    pub coherence: Coherence,
    /// Rest while occlusion culling does not pay (shared with HOM; see [`HomConfig::cost_model`]).
    pub cost_model: bool,
    /// The hierarchy the occlusion traversal walks (shared with HOM; see [`HomConfig::hierarchy`]).
    pub hierarchy: Hierarchy,
    /// Most nodes of the tree; occluder triangles that do not fit are left out.
    pub node_cap: usize,
}

impl Default for OtreeConfig {
    /// Default occluders, exact coherence, the cost model on, [`DEFAULT_NODE_CAP`].
    fn default() -> Self {
        OtreeConfig::from_hom(&HomConfig::default())
    }
}

impl OtreeConfig {
    /// The occluder settings of a HOM configuration, [`DEFAULT_NODE_CAP`].
    pub fn from_hom(hom: &HomConfig) -> OtreeConfig {
        OtreeConfig {
            occluders: hom.occluders.clone(),
            coherence: hom.coherence,
            cost_model: hom.cost_model,
            hierarchy: hom.hierarchy,
            node_cap: DEFAULT_NODE_CAP,
        }
    }

    /// [`OccluderConfig::for_scene`]'s occluders.
    pub fn for_scene(scene: &Scene) -> OtreeConfig {
        OtreeConfig::from_hom(&HomConfig::for_scene(scene))
    }
}

/// The occlusion-tree culler; see the module docs for its guarantee.
pub struct OtreeCuller {
    config: OtreeConfig,
    common: OccluderCulling,
    tree: Option<OcclusionTree>,
}

impl OtreeCuller {
    /// Builds the model database (BVH) and the occluder database for `scene`.
    pub fn new(scene: &Scene, config: OtreeConfig) -> OtreeCuller {
        OtreeCuller {
            common: OccluderCulling::new(
                scene,
                &config.occluders,
                config.coherence,
                config.cost_model,
                config.hierarchy,
            ),
            tree: None,
            config,
        }
    }

    /// The occluder database.
    pub fn occluder_db(&self) -> &OccluderDb {
        &self.common.db
    }

    /// Mutable occluder database, to give occluders stand-in meshes.
    pub fn occluder_db_mut(&mut self) -> &mut OccluderDb {
        &mut self.common.db
    }

    /// The current settings.
    pub fn config(&self) -> &OtreeConfig {
        &self.config
    }
}

impl Culler for OtreeCuller {
    fn name(&self) -> &'static str {
        "otree"
    }

    fn config(&self) -> Vec<(&'static str, String)> {
        let tree = format!(
            "occlusion tree: 2D BSP of the occluders' projected edges, at most {} nodes",
            self.config.node_cap
        );
        std::iter::once(("depth", tree)).chain(self.common.describe()).collect()
    }

    fn cull(&mut self, scene: &Scene, view: &View, out: &mut CullOutput) -> Result<(), CullError> {
        if self.common.rest(scene, view, out)? {
            return Ok(()); // occlusion culling does not pay now: frustum culling only
        }
        // 1. Occluder selection, with last frame's worst hole (from the
        // samples the tree covered) when culling was poor.
        let hole_opacity = self.config.occluders.selection.hole_opacity;
        let last = &self.tree;
        let frame = self.common.select(scene, view, out, || {
            let t = last.as_ref()?;
            let (w, h) = (t.width(), t.height());
            let mut bits = Vec::new();
            t.coverage_bits(&mut bits);
            worst_hole_of_coverage(&bits, w, h, &MapOptions::default(), hole_opacity)
        })?;
        let cap = self.config.node_cap;
        let tree = sized(&mut self.tree, view, |w, h| {
            OcclusionTree::new(w, h, culler_buffer_options()).map(|t| t.with_node_cap(cap))
        });
        // 2. The tree (timed as `raster`, like the buffers' drawing).
        let drawn = self.common.draw(scene, &frame, tree, out);
        // 3. Traversal: frustum → the tree's search, front to back.
        self.common
            .traverse(scene, out, frame, drawn, |r| tree.rect_is_occluded(r));
        let s = tree.last_tree_stats();
        out.count("otree_nodes", s.nodes);
        out.count("otree_in_leaves", s.in_leaves);
        out.count("otree_dropped", s.leaves_dropped);
        out.count("otree_visible", s.visible);
        out.count("otree_partial", s.partial);
        out.count("otree_invisible", s.invisible);
        Ok(())
    }

    fn set_known_hidden(&mut self, scene: &Scene, hidden: &[u32]) {
        self.common.set_known_hidden(scene, hidden);
    }

    fn set_occluder_lod(&mut self, lod: Option<crate::lod::OccluderLod>) -> bool {
        self.common.set_occluder_lod(lod);
        true
    }

    fn box_hidden(&mut self, corners: &[glam::Vec3; 8]) -> bool {
        match (self.common.last_rect(corners), self.tree.as_mut()) {
            (Some(r), Some(tree)) => tree.rect_is_occluded(&r),
            _ => false,
        }
    }

    fn frame_done(&mut self, frame_ms: Option<f64>) {
        self.common.feedback(frame_ms);
    }
}
