//! A precomputed visibility set in front of another culler (Law & Tan 1999,
//! section 6: the eye's cell is located, its occludee sets merged, and what
//! they name is not drawn).
//!
//! [`PvsCuller`] looks the eye's cell up, hands what it hides to the culler
//! it wraps ([`Culler::set_known_hidden`]: HOM, HZB, masked and otree then
//! neither test those objects nor draw them as occluders), runs it (frustum
//! culling, or an occlusion culler: "PVS then HOM"), and takes out of the
//! visible set whatever the cell hides that it kept. It uses the PVS only where that is sound: the view
//! is served ([`Pvs::serves`]: the eye in a cell, a near plane the bake
//! allowed for), the object hidden is still static and present, and every
//! object whose occluders the sets rely on is still static and present
//! (checked again whenever the scene's revision moves).

use super::{CullError, CullOutput, Culler, PvsStats};
use crate::geom::View;
use crate::pvs::{Pvs, PvsError};
use crate::scene::{Revision, Scene};
use std::sync::Arc;

/// A PVS lookup in front of another culler.
pub struct PvsCuller {
    pvs: Arc<Pvs>,
    inner: Box<dyn Culler>,
    hidden: Vec<u32>,
    revision: Option<Revision>,
    occluders_in_place: bool,
}

impl PvsCuller {
    /// Wraps `inner` (built for `scene`) with `pvs`; an error when the PVS
    /// was baked for another scene, or is only a shard.
    pub fn new(scene: &Scene, pvs: Arc<Pvs>, inner: Box<dyn Culler>) -> Result<PvsCuller, PvsError> {
        pvs.check_scene(scene)?;
        if pvs.shard() != crate::pvs::Shard::WHOLE {
            return Err(PvsError::Merge(format!(
                "this is shard {}/{} of a bake: merge the shards first (hom pvs merge)",
                pvs.shard().index,
                pvs.shard().count
            )));
        }
        Ok(PvsCuller {
            pvs,
            inner,
            hidden: Vec::new(),
            revision: None,
            occluders_in_place: true,
        })
    }

    /// The PVS it uses.
    pub fn pvs(&self) -> &Pvs {
        &self.pvs
    }
}

impl Culler for PvsCuller {
    fn name(&self) -> &'static str {
        match self.inner.name() {
            "frustum" => "pvs",
            "hom" => "pvs+hom",
            "hzb" => "pvs+hzb",
            "masked" => "pvs+masked",
            "otree" => "pvs+otree",
            _ => "pvs+culler",
        }
    }

    fn config(&self) -> Vec<(&'static str, String)> {
        let c = self.pvs.config();
        let mut v = vec![
            ("pvs_cell_size", c.cell_size.to_string()),
            ("pvs_cells", self.pvs.cells().cell_count().to_string()),
            ("pvs_then", self.inner.name().to_string()),
        ];
        v.extend(self.inner.config());
        v
    }

    fn cull(&mut self, scene: &Scene, view: &View, out: &mut CullOutput) -> Result<(), CullError> {
        let start = std::time::Instant::now();
        if self.revision != Some(scene.revision()) {
            self.revision = Some(scene.revision());
            self.occluders_in_place = self
                .pvs
                .occluder_objects()
                .iter()
                .all(|&id| scene.get(id).is_some_and(|o| !o.is_dynamic() && !o.is_removed()));
        }
        self.hidden.clear();
        let cell = if self.occluders_in_place {
            self.pvs.hidden_in(scene, view, &mut self.hidden)
        } else {
            None
        };
        let lookup_ms = start.elapsed().as_secs_f64() * 1e3;
        // The inner culler may skip what the PVS hides (tests, occluders).
        self.inner.set_known_hidden(scene, &self.hidden);
        self.inner.cull(scene, view, out)?;
        let start = std::time::Instant::now();
        let mut culled = 0u64;
        if !self.hidden.is_empty() {
            // Both lists ascending: one merge pass splits `visible`.
            let (mut h, mut kept) = (0, 0);
            let mut moved = Vec::new();
            for i in 0..out.visible.len() {
                let id = out.visible[i];
                while h < self.hidden.len() && self.hidden[h] < id {
                    h += 1;
                }
                let hide = h < self.hidden.len() && self.hidden[h] == id;
                if hide {
                    moved.push(id);
                } else {
                    out.visible[kept] = id;
                    kept += 1;
                }
            }
            out.visible.truncate(kept);
            culled = moved.len() as u64;
            if !moved.is_empty() {
                out.occluded.extend(moved);
                out.occluded.sort_unstable();
            }
        }
        out.stages
            .push(("pvs", lookup_ms + start.elapsed().as_secs_f64() * 1e3));
        out.stats.pvs = Some(PvsStats {
            served: cell.is_some(),
            hidden: self.hidden.len() as u64,
            culled,
        });
        Ok(())
    }

    fn frame_done(&mut self, frame_ms: Option<f64>) {
        self.inner.frame_done(frame_ms);
    }

    fn box_hidden(&mut self, corners: &[glam::Vec3; 8]) -> bool {
        self.inner.box_hidden(corners)
    }

    fn set_occluder_lod(&mut self, lod: Option<crate::lod::OccluderLod>) -> bool {
        self.inner.set_occluder_lod(lod)
    }
}
