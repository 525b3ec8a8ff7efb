//! Virtual occluders seen from outside the culler: per object, the original
//! and virtual triangle counts and the coverage kept over six axis views
//! (`hom occluders info`), the guarantee checked on the same views and over
//! the frames of a walk (`--walk-frames`), and the virtual occluders as a
//! scene of their own (`hom occluders export`).

use glam::Vec3;
use hom::geom::{Containment, Eye, Frustum};
use hom::occluders::{OccluderDb, OccluderDbConfig, OccluderMeshes, Verdict};
use hom::scene::{Scene, SceneBuilder, SceneError};
use hom_render::stand_in::{axis_views, compare_virtual_occluder, view_from, StandInComparison};
use hom_render::Renderer;
use hom_scene::{Animation, CameraPath};
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
                            views += compare_virtual_occluder(&renderer, original, v, o.transform, &camera);
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

/// Stand-ins against originals over the frames of a walk.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WalkComparison {
    /// Frames compared.
    pub frames: usize,
    /// (occluder, frame) pairs compared: in the frustum, virtual occluder usable.
    pub compared: u64,
    /// Their samples summed.
    pub total: StandInComparison,
    /// Stand-in ÷ original covered samples per frame, averaged over the
    /// frames where some original covers a sample (1 when none does).
    pub mean_kept: f64,
}

/// Compares, on `frames` frames spread evenly over `path` (all of them when
/// it has no more), every kept occluder of `db` that is in the frustum and
/// whose virtual occluder is usable from the frame's eye, at the path's
/// viewport: the guarantee on the views the cullers meet, and the coverage
/// kept there. `animation` moves the dynamic objects as a walk does;
/// `on_frame` hears each frame index compared.
pub fn walk_comparison(
    scene: &mut Scene,
    animation: &Animation,
    path: &CameraPath,
    db: &OccluderDb,
    frames: usize,
    mut on_frame: impl FnMut(usize),
) -> WalkComparison {
    let n = path.frames.len();
    let frames = frames.min(n);
    let mut result = WalkComparison {
        frames,
        ..WalkComparison::default()
    };
    let (mut kept_sum, mut kept_frames) = (0.0, 0);
    let frame_rate = crate::WalkOptions::default().frame_rate;
    for k in 0..frames {
        // Evenly spread, first and last frame included.
        let i = if frames > 1 { k * (n - 1) / (frames - 1) } else { 0 };
        animation.apply(scene, i as f32 / frame_rate);
        let camera = path.camera(i);
        let frustum = Frustum::from_view_proj(&camera.view_proj()).expect("a validated path has views");
        let eye = Eye::Point(camera.eye);
        let scene = &*scene;
        let add = |(n, mut a): (u64, StandInComparison), (m, c): (u64, StandInComparison)| {
            a += c;
            (n + m, a)
        };
        let (compared, frame) = db
            .occluders()
            .par_iter()
            .filter_map(|occ| {
                let v = occ.virtual_occluder.as_ref()?;
                let o = scene.object(occ.object);
                let in_view = frustum.test_obb(&o.obb) != Containment::Outside;
                (in_view && v.usable(&o.transform, &o.aabb, &eye, &frustum)).then(|| {
                    let renderer = Renderer::new(1).expect("one thread");
                    (
                        1,
                        compare_virtual_occluder(&renderer, scene.mesh_of(o), v, o.transform, &camera),
                    )
                })
            })
            .reduce(|| (0, StandInComparison::default()), add);
        result.compared += compared;
        if frame.original > 0 {
            kept_sum += frame.kept();
            kept_frames += 1;
        }
        result.total += frame;
        on_frame(i);
    }
    result.mean_kept = if kept_frames > 0 {
        kept_sum / kept_frames as f64
    } else {
        1.0
    };
    result
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
/// have a virtual occluder, each from five views (front, side, above, and
/// two oblique ones from above: `view6`, `view7`), in
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
        let axes = axis_views(&o.aabb, side);
        // Front, side and above, then two oblique views from above, where
        // silhouettes are not the box's faces.
        let views = [(0, axes[0]), (4, axes[4]), (2, axes[2])].into_iter().chain(
            [Vec3::new(1.0, 0.8, 1.0), Vec3::new(-1.0, 0.5, -0.6)]
                .into_iter()
                .enumerate()
                .map(|(j, d)| (6 + j, view_from(&o.aabb, d, side))),
        );
        for (k, camera) in views {
            let (original, stand_in) =
                hom_render::stand_in::virtual_occluder_depths(&renderer, scene.mesh_of(o), v, o.transform, &camera);
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
