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

/// Pictures of the `count` occluders with the most original triangles that
/// have a virtual occluder, each from three views (front, side, above), in
/// `dir`: the original grey, the part of it the stand-in covers blue, and
/// any violation red (Law & Tan's figure 2: the stand-in's silhouette inside
/// the original's). Returns the files written.
pub fn write_pictures(
    scene: &Scene,
    db: &OccluderDb,
    dir: &std::path::Path,
    count: usize,
    side: u32,
) -> Result<Vec<std::path::PathBuf>, hom_render::RenderError> {
    let mut with: Vec<&hom::occluders::Occluder> =
        db.occluders().iter().filter(|o| o.virtual_occluder.is_some()).collect();
    with.sort_by_key(|o| (std::cmp::Reverse(scene.object(o.object).triangles), o.object));
    // One per mesh: instances of a mesh look alike.
    let mut meshes = std::collections::HashSet::new();
    with.retain(|o| meshes.insert(scene.object(o.object).mesh));
    let renderer = Renderer::new(0).expect("threads");
    let mut files = Vec::new();
    for occ in with.into_iter().take(count) {
        let o = scene.object(occ.object);
        let v = occ.virtual_occluder.as_ref().expect("filtered");
        for (k, camera) in axis_views(&o.aabb, side)
            .iter()
            .enumerate()
            .filter(|(k, _)| [0, 4, 2].contains(k))
        {
            let (original, stand_in) =
                hom_render::stand_in::stand_in_depths(&renderer, scene.mesh_of(o), v.mesh(), o.transform, camera);
            let rgba: Vec<[u8; 4]> = original
                .iter()
                .zip(&stand_in)
                .map(|(&a, &b)| match (a < 1.0, b < 1.0) {
                    (_, true) if a >= 1.0 || b < a => [220, 30, 30, 255],
                    (true, true) => [70, 110, 220, 255],
                    (true, false) => [150, 150, 150, 255],
                    _ => [255, 255, 255, 255],
                })
                .collect();
            let name: String = o
                .name
                .chars()
                .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
                .collect();
            let file = dir.join(format!("virtual_{}_{name}_view{k}.png", occ.object));
            hom_render::write_png(&file, side, side, &rgba)?;
            files.push(file);
        }
    }
    Ok(files)
}
