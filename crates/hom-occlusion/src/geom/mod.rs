//! Geometry: boxes, planes, frusta, the camera, and conservative screen projection.

mod aabb;
mod camera;
mod frustum;
mod obb;
mod plane;
mod screen;
mod view;

pub use aabb::Aabb;
pub use camera::{Camera, CameraError};
pub use frustum::{Containment, Frustum};
pub use obb::Obb;
pub use plane::Plane;
pub use screen::{project_box_clipped, project_points, Footprint, ScreenRect};
pub use view::{ClipConvention, Eye, View, ViewError, MAX_VIEWPORT_SIDE};

use glam::{Mat4, Vec3, Vec4};

/// Clip coordinates of an object's vertex `p`: placed in the world by
/// `transform` first, then seen through `world_to_clip`. The one vertex
/// transform the renderer and every culler that must match it sample for
/// sample share. World first, not `world_to_clip · transform` once per
/// object: objects that share a world vertex (terrain tiles, map brushes)
/// then share its clip coordinates bit for bit and meet without cracks
/// (the product left 8 samples open along the terrain's tile seams over 30
/// frames at 1024²).
#[inline]
pub fn object_to_clip(world_to_clip: &Mat4, transform: &Mat4, p: Vec3) -> Vec4 {
    *world_to_clip * transform.transform_point3(p).extend(1.0)
}
