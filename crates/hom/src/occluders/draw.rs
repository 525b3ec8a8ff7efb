//! Handing the selected occluders to an occlusion buffer: each occluder's
//! mesh (its stand-in or virtual occluder where it has a usable one, drawn
//! conservatively, under `world_to_clip · transform`; an original placed in
//! the world first, as the renderer places it), two-sided, nearest occluder
//! first — the order both buffers want (the
//! HZB then skips what is already hidden; HOM's depth cells keep the first,
//! nearest cover).

use super::OccluderDb;
use crate::geom::{Eye, Frustum, View};
use crate::occlusion::{FaceCull, OcclusionBuffer};
use crate::scene::Scene;
use glam::Mat4;

/// Queues the occluders `ids` of `scene` in `buffer` (whose clip convention
/// is hom's, [`crate::geom::ClipConvention::ZeroToOne`]), nearest first as
/// seen from `eye`, those in `originals` (ascending) as their own meshes.
/// Returns the number of occluder triangles submitted.
#[allow(clippy::too_many_arguments)]
pub(crate) fn draw_occluders(
    buffer: &mut impl OcclusionBuffer,
    scene: &Scene,
    db: &OccluderDb,
    ids: &[u32],
    originals: &[u32],
    world_to_clip: &Mat4,
    eye: &Eye,
    frustum: &Frustum,
) -> u64 {
    let mut order: Vec<(f32, u32)> = ids
        .iter()
        .map(|&id| (View::nearness(eye, &scene.object(id).aabb), id))
        .collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let mut submitted = 0;
    let mut world = Vec::new();
    for (_, id) in order {
        let o = scene.object(id);
        let Some((mesh, stands_in)) = db
            .occluder(id)
            .and_then(|occ| db.mesh_to_draw(scene, occ, eye, frustum, originals.binary_search(&id).is_ok()))
        else {
            continue;
        };
        // Scene meshes hold only valid indices and the matrix is finite for a
        // validated view and scene, so a refusal here would be a bug upstream.
        let (p, t) = (mesh.positions(), mesh.triangles());
        let drawn = if stands_in {
            buffer.render_stand_in_triangles(p, t, &(*world_to_clip * o.transform), FaceCull::None)
        } else {
            // World first, as the renderer transforms (`geom::object_to_clip`):
            // an exactly sampled original covers the renderer's samples, no more.
            world.clear();
            world.extend(p.iter().map(|&q| o.transform.transform_point3(q)));
            buffer.render_triangles(&world, t, world_to_clip, FaceCull::None)
        };
        debug_assert!(drawn.is_ok(), "occluder {id}: {drawn:?}");
        submitted += mesh.triangle_count() as u64;
    }
    submitted
}
