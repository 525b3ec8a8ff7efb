//! Occluders: the preprocessed occluder database, per-frame selection, and
//! handing the selected ones to an occlusion buffer.

mod cuts;
mod database;
mod draw;
mod ground;
mod selection;
mod virtual_occluder;

pub(crate) use cuts::OccluderCuts;
pub use database::{Occluder, OccluderDb, OccluderDbConfig, OccluderMeshes, Verdict};
pub(crate) use draw::draw_occluders;
pub(crate) use selection::{ObjectBoxes, OccluderSelector, SelectionStats};
pub use selection::{SelectionConfig, SelectionMode};
#[cfg(test)]
pub(crate) use virtual_occluder::push_box;
pub use virtual_occluder::{NoVirtual, VirtualConfig, VirtualOccluder};

use crate::scene::Scene;

/// What the occluder-based cullers (HOM, HZB) share: which objects may
/// occlude, and how each frame's occluders are chosen.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct OccluderConfig {
    /// Per-frame selection: budget, order, hole filling.
    pub selection: SelectionConfig,
    /// Which objects are occluders at all.
    pub occluder_db: OccluderDbConfig,
}

impl OccluderConfig {
    /// The defaults with the polygon budget L scaled to the scene: 1 % of its
    /// triangles, at least 3,000 and at most 20,000. (Sweeps on the built-in
    /// scenes: the best fixed L ranged from 3k on the city to 25k on the
    /// machine room, roughly following scene size.)
    pub fn for_scene(scene: &Scene) -> OccluderConfig {
        let mut c = OccluderConfig::default();
        c.selection.budget = (scene.triangle_count() / 100).clamp(3_000, 20_000) as u32;
        c
    }
}
