//! Geometry: boxes, planes, frusta, the camera, and conservative screen projection.

mod aabb;
mod camera;
mod frustum;
mod obb;
mod plane;
mod screen;
mod view;

pub use aabb::Aabb;
pub use camera::{Camera, CameraError, MAX_VIEWPORT_SIDE};
pub use frustum::{Containment, Frustum};
pub use obb::Obb;
pub use plane::Plane;
pub use screen::{project_box_clipped, project_points, Footprint, ScreenRect};
pub use view::{ClipConvention, Eye, View, ViewError};
