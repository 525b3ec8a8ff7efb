//! Virtual occluders seen from outside the culler: per object, the original
//! and virtual triangle counts and the coverage kept over six axis views
//! (`hom occluders info`), the guarantee checked on the same views, and the
//! virtual occluders as a scene of their own (`hom occluders export`).

use hom::geom::{Eye, Frustum};
use hom::occluders::{OccluderDb, OccluderDbConfig, OccluderMeshes, Verdict};
use hom::scene::{Scene, SceneBuilder, SceneError};
use hom_render::stand_in::{axis_views, compare_stand_in, StandInComparison};
use hom_render::Renderer;
use rayon::prelude::*;

/// One occluder's virtual occluder, or why it has none.
#[derive(Clone, Debug)]
pub struct VirtualRow {
    /// Object id.
    pub object: u32,
    /// Object name.
    pub name: String,
    /// The original's triangles.
    pub original_triangles: u32,
    /// The virtual occluder's triangles, or why there is none.
    pub outcome: Result<u32, String>,
    /// Over the six axis views it may stand in from: covered samples of
    /// each, and violations.
    pub views: StandInComparison,
}

/// The occluder database of `scene` with virtual occluders (the default
/// thresholds otherwise).
pub fn virtual_db(scene: &Scene) -> OccluderDb {
    OccluderDb::build(
        scene,
        &OccluderDbConfig {
            meshes: OccluderMeshes::Virtual,
            ..OccluderDbConfig::default()
        },
    )
}

/// A row per kept occluder of `db` (built with virtual occluders), with the
/// six axis views at `side`×`side` samples compared.
pub fn virtual_rows(scene: &Scene, db: &OccluderDb, side: u32) -> Vec<VirtualRow> {
    let occluders: Vec<(u32, Verdict)> = db
        .verdicts()
        .iter()
        .enumerate()
        .filter(|(_, v)| **v == Verdict::Kept)
        .map(|(id, v)| (id as u32, *v))
        .collect();
    occluders
        .par_iter()
        .map(|&(id, _)| {
            let o = scene.object(id);
            let original = scene.mesh_of(o);
            let renderer = Renderer::new(1).expect("one thread");
            let (outcome, views) = match db.bake_of_mesh(o.mesh) {
                Some(Ok(v)) => {
                    // The views it may stand in from (not from below a floor cap).
                    let mut views = StandInComparison::default();
                    for camera in axis_views(&o.aabb, side) {
                        let frustum = Frustum::from_view_proj(&camera.view_proj()).expect("a valid view");
                        if v.usable(&o.transform, &o.aabb, &Eye::Point(camera.eye), &frustum) {
                            views += compare_stand_in(&renderer, original, v.mesh(), o.transform, &camera);
                        }
                    }
                    (Ok(v.mesh().triangle_count() as u32), views)
                }
                Some(Err(why)) => (Err(why.to_string()), StandInComparison::default()),
                None => (Err("not baked".to_string()), StandInComparison::default()),
            };
            VirtualRow {
                object: id,
                name: o.name.clone(),
                original_triangles: o.triangles,
                outcome,
                views,
            }
        })
        .collect()
}

/// The virtual occluders of `db`'s occluders as a scene: one object per
/// occluder that has one, with its source object's name and transform.
pub fn virtual_scene(scene: &Scene, db: &OccluderDb) -> Result<Scene, SceneError> {
    let mut b = SceneBuilder::new(format!("{} (virtual occluders)", scene.name()));
    let mut meshes = std::collections::HashMap::new();
    for occ in db.occluders() {
        let Some(v) = &occ.virtual_occluder else { continue };
        let o = scene.object(occ.object);
        let mesh = *meshes.entry(o.mesh).or_insert_with(|| b.add_mesh(v.mesh().clone()));
        b.add_object(o.name.clone(), mesh, o.transform)?;
    }
    b.build()
}
