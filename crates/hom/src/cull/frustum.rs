//! The baseline cullers: draw everything, or only what is in the view frustum.

use super::model_db::ModelDb;
use super::{CullError, CullOutput, Culler, FrustumStats};
use crate::geom::{Containment, Frustum, View};
use crate::scene::Scene;

/// Draws every object: the reference for "no culling at all".
#[derive(Clone, Debug, Default)]
pub struct NoCuller;

impl Culler for NoCuller {
    fn name(&self) -> &'static str {
        "none"
    }

    fn cull(&mut self, scene: &Scene, view: &View, out: &mut CullOutput) -> Result<(), CullError> {
        view.validate()?;
        out.clear();
        out.visible.extend(scene.live_objects().map(|(id, _)| id));
        Ok(())
    }
}

/// View-frustum culling over a BVH of object boxes: the baseline every
/// occlusion culler's speedup is measured against.
#[derive(Clone, Debug)]
pub struct FrustumCuller {
    model: ModelDb,
}

impl FrustumCuller {
    /// Builds the model database (BVH) for `scene`.
    pub fn new(scene: &Scene) -> FrustumCuller {
        FrustumCuller {
            model: ModelDb::new(scene),
        }
    }
}

impl Culler for FrustumCuller {
    fn name(&self) -> &'static str {
        "frustum"
    }

    fn cull(&mut self, scene: &Scene, view: &View, out: &mut CullOutput) -> Result<(), CullError> {
        view.validate()?;
        out.clear();
        let model = &mut self.model;
        out.time("refit", || model.sync(scene));
        let frustum = view.frustum().expect("a validated view has a frustum");
        let mut visible = std::mem::take(&mut out.visible);
        let tests = out.time("frustum", || frustum_visible(model, scene, &frustum, &mut visible));
        out.visible = visible;
        out.stats.frustum = Some(FrustumStats { node_tests: tests });
        Ok(())
    }
}

/// Appends to `visible`, ascending, every live object of `model` whose box
/// meets `frustum`; returns the box tests made.
pub(crate) fn frustum_visible(model: &ModelDb, scene: &Scene, frustum: &Frustum, visible: &mut Vec<u32>) -> u64 {
    let (bvh, boxes) = (model.bvh(), model.boxes());
    let mut n = bvh.frustum_cull(&boxes[..bvh.items().len()], frustum, visible);
    // Removed objects have empty boxes: a wholly inside subtree still lists them.
    visible.retain(|&id| scene.get(id).is_some());
    for &id in model.extra() {
        n += 1;
        if frustum.test_aabb(&boxes[id as usize]) != Containment::Outside {
            visible.push(id);
        }
    }
    visible.sort_unstable();
    n
}
