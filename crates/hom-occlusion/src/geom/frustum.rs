//! View frusta as six planes, and the three-way box test.

use super::{Aabb, Obb, Plane};
use glam::{Mat4, Vec3};

/// Where a box lies relative to a frustum. The three-way answer lets a
/// hierarchy skip the tests of a subtree that is wholly inside.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Containment {
    /// Entirely outside (safe to cull).
    Outside,
    /// Partly inside, or not decided (conservative).
    Intersecting,
    /// Entirely inside.
    Inside,
}

/// The six inward-facing planes of a view frustum: left, right, bottom, top, near, far.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frustum {
    /// Planes in the order left, right, bottom, top, near, far.
    pub planes: [Plane; 6],
}

impl Frustum {
    /// The frustum of a view-projection matrix whose clip space has `-w <= x, y <= w`
    /// and `0 <= z <= w` (glam's `perspective_rh`; Gribb & Hartmann's extraction;
    /// other conventions go through [`super::View::world_to_clip`] first).
    ///
    /// Returns `None` when the matrix is degenerate or not finite.
    /// An infinite far plane (`perspective_infinite`, reversed-Z infinite) is
    /// kept as a plane every point is inside.
    pub fn from_view_proj(m: &Mat4) -> Option<Frustum> {
        let (r0, r1, r2, r3) = (m.row(0), m.row(1), m.row(2), m.row(3));
        Frustum::from_plane_rows([r3 + r0, r3 - r0, r3 + r1, r3 - r1, r2, r3 - r2])
    }

    fn from_plane_rows(planes: [glam::Vec4; 6]) -> Option<Frustum> {
        let mut out = [Plane::from_point_normal(Vec3::ZERO, Vec3::X); 6];
        for (i, (o, p)) in out.iter_mut().zip(planes).enumerate() {
            *o = match Plane::from_coefficients(p) {
                Some(plane) => plane,
                // The far plane at infinity: `0 x + 0 y + 0 z + d >= 0` with d > 0.
                None if i == 5 && p.truncate() == Vec3::ZERO && p.w > 0.0 && p.w.is_finite() => Plane::EVERYWHERE,
                None => return None,
            };
        }
        Some(Frustum { planes: out })
    }

    /// The sub-frustum through the normalized-device rectangle `x = (left, right)`,
    /// `y = (bottom, top)` of a view-projection matrix (same near and far planes).
    /// Returns `None` for an empty or non-finite rectangle or a degenerate matrix.
    pub fn from_view_proj_ndc_rect(m: &Mat4, x: (f32, f32), y: (f32, f32)) -> Option<Frustum> {
        if !(x.0 < x.1 && y.0 < y.1) {
            return None;
        }
        let (r0, r1, r2, r3) = (m.row(0), m.row(1), m.row(2), m.row(3));
        // x/w >= left  <=>  x - left * w >= 0 (w > 0 inside the frustum), and so on.
        Frustum::from_plane_rows([r0 - r3 * x.0, r3 * x.1 - r0, r1 - r3 * y.0, r3 * y.1 - r1, r2, r3 - r2])
    }

    /// Whether the whole box lies beyond the near plane (nothing of it is
    /// clipped there).
    pub fn beyond_near(&self, b: &Aabb) -> bool {
        let near = &self.planes[4];
        near.signed_distance(Vec3::select(near.normal.cmpge(Vec3::ZERO), b.min, b.max)) > 0.0
    }

    /// Three-way test of an axis-aligned box.
    pub fn test_aabb(&self, b: &Aabb) -> Containment {
        let mut result = Containment::Inside;
        for p in &self.planes {
            // The corner farthest along the normal decides "outside"; the nearest, "inside".
            let far = Vec3::select(p.normal.cmpge(Vec3::ZERO), b.max, b.min);
            if p.signed_distance(far) < 0.0 {
                return Containment::Outside;
            }
            let near = Vec3::select(p.normal.cmpge(Vec3::ZERO), b.min, b.max);
            if p.signed_distance(near) < 0.0 {
                result = Containment::Intersecting;
            }
        }
        result
    }

    /// Three-way test of an oriented box.
    pub fn test_obb(&self, b: &Obb) -> Containment {
        let mut result = Containment::Inside;
        for p in &self.planes {
            let r = p.normal.dot(b.axes.x_axis).abs() * b.half_extents.x
                + p.normal.dot(b.axes.y_axis).abs() * b.half_extents.y
                + p.normal.dot(b.axes.z_axis).abs() * b.half_extents.z;
            let d = p.signed_distance(b.center);
            if d < -r {
                return Containment::Outside;
            }
            if d < r {
                result = Containment::Intersecting;
            }
        }
        result
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::Camera;

    #[test]
    fn boxes_in_front_inside_behind_outside() {
        let cam = Camera::new(Vec3::ZERO, -Vec3::Z, Vec3::Y, 60f32.to_radians(), 0.1, 100.0, 640, 480);
        let f = cam.frustum().unwrap();
        let unit = |c: Vec3| Aabb::new(c - 0.5, c + 0.5);
        assert_eq!(f.test_aabb(&unit(Vec3::new(0.0, 0.0, -10.0))), Containment::Inside);
        assert_eq!(f.test_aabb(&unit(Vec3::new(0.0, 0.0, 10.0))), Containment::Outside);
        assert_eq!(f.test_aabb(&unit(Vec3::new(0.0, 0.0, 0.0))), Containment::Intersecting);
        assert_eq!(f.test_aabb(&unit(Vec3::new(0.0, 0.0, -200.0))), Containment::Outside);
        assert_eq!(
            f.test_aabb(&unit(Vec3::new(0.0, 0.0, -100.0))),
            Containment::Intersecting
        );
        // The whole NDC square gives the same frustum; its right half excludes the left.
        let vp = cam.view_proj();
        let whole = Frustum::from_view_proj_ndc_rect(&vp, (-1.0, 1.0), (-1.0, 1.0)).unwrap();
        for (a, b) in whole.planes.iter().zip(&f.planes) {
            assert!((a.normal - b.normal).length() < 1e-5 && (a.d - b.d).abs() < 1e-4);
        }
        let right = Frustum::from_view_proj_ndc_rect(&vp, (0.0, 1.0), (-1.0, 1.0)).unwrap();
        assert_eq!(
            right.test_aabb(&unit(Vec3::new(-8.0, 0.0, -10.0))),
            Containment::Outside
        );
        assert_ne!(right.test_aabb(&unit(Vec3::new(3.0, 0.0, -10.0))), Containment::Outside);
    }
}
