//! The baseline cullers: draw everything, or only what is in the view frustum.

use super::{CullError, CullOutput, Culler};
use crate::geom::{Aabb, Camera, Frustum};
use crate::scene::Scene;
use crate::spatial::{Bvh, BvhConfig};

/// Draws every object: the reference for "no culling at all".
#[derive(Clone, Debug, Default)]
pub struct NoCuller;

impl Culler for NoCuller {
    fn name(&self) -> &'static str {
        "none"
    }

    fn cull(&mut self, scene: &Scene, camera: &Camera, out: &mut CullOutput) -> Result<(), CullError> {
        camera.validate()?;
        out.clear();
        out.visible.extend(0..scene.objects().len() as u32);
        Ok(())
    }
}

/// View-frustum culling over a BVH of object boxes: the baseline every
/// occlusion culler's speedup is measured against.
#[derive(Clone, Debug)]
pub struct FrustumCuller {
    bvh: Bvh,
    boxes: Vec<Aabb>,
}

impl FrustumCuller {
    /// Builds the model database (BVH) for `scene`.
    pub fn new(scene: &Scene) -> FrustumCuller {
        let boxes: Vec<Aabb> = scene.objects().iter().map(|o| o.aabb).collect();
        let bvh = Bvh::build(&boxes, &BvhConfig::default());
        FrustumCuller { bvh, boxes }
    }
}

/// Refits a BVH to the current boxes of a scene's objects when anything moves.
pub(crate) fn refit_if_dynamic(scene: &Scene, bvh: &mut Bvh, boxes: &mut [Aabb]) -> Result<(), CullError> {
    if boxes.len() != scene.objects().len() {
        return Err(CullError::SceneMismatch {
            expected: boxes.len(),
            got: scene.objects().len(),
        });
    }
    if scene.dynamic_count() > 0 {
        for (b, o) in boxes.iter_mut().zip(scene.objects()) {
            *b = o.aabb;
        }
        bvh.refit(boxes);
    }
    Ok(())
}

impl Culler for FrustumCuller {
    fn name(&self) -> &'static str {
        "frustum"
    }

    fn cull(&mut self, scene: &Scene, camera: &Camera, out: &mut CullOutput) -> Result<(), CullError> {
        camera.validate()?;
        out.clear();
        let Self { bvh, boxes } = self;
        out.time("refit", || refit_if_dynamic(scene, bvh, boxes))?;
        let frustum = Frustum::from_view_proj(&camera.view_proj())
            .expect("a validated camera has a finite, non-degenerate frustum");
        let mut visible = std::mem::take(&mut out.visible);
        let tests = out.time("frustum", || {
            let n = bvh.frustum_cull(boxes, &frustum, &mut visible);
            visible.sort_unstable();
            n
        });
        out.visible = visible;
        out.count("node_tests", tests);
        Ok(())
    }
}
