//! Occluders at the frame's level of detail (Law & Tan 1999, section 6,
//! turned around: level of detail makes the occluders cheaper, not only the
//! occludees). With [`OccluderLod`] set, an occluder whose view-only cut is
//! coarser than its mesh costs the budget the cut's triangles and is drawn
//! as the cut; the others cost and draw as before. The cut is what the
//! renderer draws of a visible object at that threshold, so what it hides is
//! hidden in the image of the cuts.

use crate::geom::View;
use crate::lod::{view_only_cut, LodView, OccluderLod};
use crate::scene::Scene;

use super::Occluder;

/// Occluders of fewer triangles are drawn as their meshes, never cut.
pub(crate) const MIN_CUT_TRIANGLES: u32 = 256;

/// This frame's cuts of the occluders asked about.
#[derive(Debug, Default)]
pub(crate) struct OccluderCuts {
    lod: Option<OccluderLod>,
    /// The frame's refinement view (`None`: off, or no frustum).
    view: Option<LodView>,
    /// Frame counter from 1; `stamp[id] == frame` when `nodes[id]` is this frame's (0: never).
    frame: u32,
    stamp: Vec<u32>,
    /// Per object: its cut's nodes when coarser than its mesh, else empty.
    nodes: Vec<Vec<u32>>,
    /// Per object: its cut's triangles (when `nodes` is not empty).
    triangles: Vec<u32>,
}

impl OccluderCuts {
    /// Draws occluders at their level of detail from now on (`None`: as their meshes).
    pub fn set(&mut self, lod: Option<OccluderLod>) {
        self.lod = lod;
        self.view = None;
    }

    /// Whether occluders are drawn at their level of detail.
    pub fn is_on(&self) -> bool {
        self.lod.is_some()
    }

    /// Starts a frame seen from `view`.
    pub fn begin(&mut self, view: &View) {
        self.view = self.lod.as_ref().and_then(|_| LodView::new(view));
        self.frame = self.frame.wrapping_add(1);
        if self.frame == 0 {
            // After 2^32 frames an old stamp could look current: forget them.
            self.stamp.fill(0);
            self.frame = 1;
        }
    }

    /// Triangles occluder `occ` of `scene` costs this frame: its cut's when
    /// the cut is coarser than its mesh, else what it costs as its mesh or
    /// stand-in. Computes the cut on the first call of a frame.
    ///
    /// Only occluders drawn as their own meshes of at least
    /// [`MIN_CUT_TRIANGLES`] get a cut: a stand-in or virtual occluder is
    /// already cheap, and a small mesh's cut saves a few dozen triangles at
    /// the price of a cut each frame (the city, 711 candidates of a few
    /// dozen triangles: selection 0.07 → 0.27 ms a frame with every
    /// candidate cut, no occluder more in the budget).
    pub fn cost(&mut self, scene: &Scene, occ: &Occluder) -> u32 {
        let (Some(lod), Some(view)) = (&self.lod, &self.view) else {
            return occ.triangles;
        };
        let (id, otherwise) = (occ.object, occ.triangles);
        // Hierarchies built for another scene (or before a mesh was added) are not used.
        if occ.stand_in.is_some()
            || occ.virtual_occluder.is_some()
            || otherwise < MIN_CUT_TRIANGLES
            || lod.hierarchies.check_scene(scene).is_err()
        {
            return otherwise;
        }
        let i = id as usize;
        if self.stamp.len() <= i {
            let n = scene.objects().len().max(i + 1);
            self.stamp.resize(n, 0);
            self.nodes.resize_with(n, Vec::new);
            self.triangles.resize(n, 0);
        }
        if self.stamp[i] != self.frame {
            self.stamp[i] = self.frame;
            let object = scene.object(id);
            let h = lod.hierarchies.hierarchy(object.mesh);
            let cut = view_only_cut(&lod.hierarchies, object, view, lod.error_px);
            let coarse = cut.iter().any(|&n| !h.nodes()[n as usize].is_leaf(n));
            self.triangles[i] = cut.iter().map(|&n| h.nodes()[n as usize].triangle_count()).sum();
            self.nodes[i] = if coarse { cut } else { Vec::new() };
        }
        if self.nodes[i].is_empty() {
            otherwise
        } else {
            self.triangles[i]
        }
    }

    /// The triangles of occluder `id`'s cut this frame, appended to `out`,
    /// when [`OccluderCuts::cost`] found it coarser than its mesh; `false`
    /// (and nothing appended) when it is drawn as before.
    pub fn cut_triangles(&self, scene: &Scene, id: u32, out: &mut Vec<[u32; 3]>) -> bool {
        let i = id as usize;
        let Some(lod) = &self.lod else {
            return false;
        };
        if self.view.is_none() || self.stamp.get(i) != Some(&self.frame) || self.nodes[i].is_empty() {
            return false;
        }
        let h = lod.hierarchies.hierarchy(scene.object(id).mesh);
        for &n in &self.nodes[i] {
            out.extend_from_slice(h.triangles(n));
        }
        true
    }

    /// Whether occluder `id` is drawn as its cut this frame.
    pub fn has_cut(&self, id: u32) -> bool {
        self.view.is_some() && self.stamp.get(id as usize) == Some(&self.frame) && !self.nodes[id as usize].is_empty()
    }

    /// Bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.stamp.capacity() * 4
            + self.triangles.capacity() * 4
            + self.nodes.iter().map(|v| v.capacity() * 4 + 24).sum::<usize>()
    }
}
