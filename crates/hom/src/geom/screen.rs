//! Conservative projection of bounding boxes to screen rectangles with a depth range.
//!
//! Screen space: pixel (0, 0) is the top-left pixel; the renderer samples pixel
//! centres at `(x + 0.5, y + 0.5)`. A [`ScreenRect`] holds every pixel whose
//! centre the projected box may cover, so an image-space test over it is
//! conservative. Depth is clip `z / w` in `[0, 1]` (0 at the near plane), the
//! same value the renderer's z-buffer stores.

use glam::{Mat4, Vec3, Vec4Swizzles};

/// Pixels of slack added on every side of a projected rectangle, so float
/// rounding in the renderer can never put a covered sample outside it.
pub const RECT_SLACK_PX: f32 = 1.0 / 64.0;

/// A box's footprint on screen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Footprint {
    /// The box crosses the near plane or lies partly behind the eye: an
    /// image-space test must treat it as visible.
    Straddles,
    /// The box is wholly in front of the near plane.
    Rect(ScreenRect),
}

/// Pixels `x0..x1` × `y0..y1` (half-open, clamped to the viewport) whose centres
/// the box may cover, and the box's depth range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScreenRect {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
    /// Nearest depth of the box (smallest clip z / w).
    pub z_near: f32,
    /// Farthest depth of the box (largest clip z / w).
    pub z_far: f32,
}

impl ScreenRect {
    /// True when no pixel centre can be covered (the box is off screen or falls between samples).
    pub fn is_empty(&self) -> bool {
        self.x0 >= self.x1 || self.y0 >= self.y1
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.x1.saturating_sub(self.x0)
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.y1.saturating_sub(self.y0)
    }
}

/// Projects world-space points (a box's corners) with `view_proj` onto a
/// `width` × `height` viewport.
///
/// Conservative: any point of the convex hull of `points` that is in front of
/// the near plane lands inside the returned rectangle and depth range.
pub fn project_points(points: &[Vec3], view_proj: &Mat4, width: u32, height: u32) -> Footprint {
    let (w, h) = (width as f32, height as f32);
    let (mut sx0, mut sy0, mut sx1, mut sy1) = (f32::MAX, f32::MAX, f32::MIN, f32::MIN);
    let (mut z0, mut z1) = (f32::MAX, f32::MIN);
    for p in points {
        let c = *view_proj * p.extend(1.0);
        // `!(>=)` also catches NaN: never cull what we cannot project.
        if !(c.z >= 0.0 && c.w > 0.0) {
            return Footprint::Straddles;
        }
        let inv = 1.0 / c.w;
        let ndc = c.xyz() * inv;
        let sx = (ndc.x * 0.5 + 0.5) * w;
        let sy = (0.5 - ndc.y * 0.5) * h;
        sx0 = sx0.min(sx);
        sx1 = sx1.max(sx);
        sy0 = sy0.min(sy);
        sy1 = sy1.max(sy);
        z0 = z0.min(ndc.z);
        z1 = z1.max(ndc.z);
    }
    if !(sx0.is_finite() && sx1.is_finite() && sy0.is_finite() && sy1.is_finite()) {
        return Footprint::Straddles;
    }
    // Pixel x has its centre in [sx0, sx1] iff ceil(sx0 - 0.5) <= x <= floor(sx1 - 0.5).
    let first = |s: f32, limit: f32| (s - 0.5 - RECT_SLACK_PX).ceil().clamp(0.0, limit) as u32;
    let end = |s: f32, limit: f32| ((s - 0.5 + RECT_SLACK_PX).floor() + 1.0).clamp(0.0, limit) as u32;
    Footprint::Rect(ScreenRect {
        x0: first(sx0, w),
        y0: first(sy0, h),
        x1: end(sx1, w),
        y1: end(sy1, h),
        z_near: z0,
        z_far: z1,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{Aabb, Camera};

    fn cam() -> Camera {
        Camera::new(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 90f32.to_radians(), 0.5, 100.0, 100, 50)
    }

    #[test]
    fn box_crossing_near_plane_or_behind_eye_straddles() {
        let c = cam();
        let vp = c.view_proj();
        let around_eye = Aabb::new(Vec3::new(-1.0, -1.0, 4.0), Vec3::new(1.0, 1.0, 6.0));
        assert_eq!(project_points(&around_eye.corners(), &vp, 100, 50), Footprint::Straddles);
        let behind = Aabb::new(Vec3::new(-1.0, -1.0, 8.0), Vec3::new(1.0, 1.0, 9.0));
        assert_eq!(project_points(&behind.corners(), &vp, 100, 50), Footprint::Straddles);
        let nan = [Vec3::new(f32::NAN, 0.0, 0.0)];
        assert_eq!(project_points(&nan, &vp, 100, 50), Footprint::Straddles);
    }

    #[test]
    fn rect_holds_every_pixel_centre_the_box_covers() {
        let c = cam();
        let vp = c.view_proj();
        let b = Aabb::new(Vec3::new(-0.7, -0.3, -1.0), Vec3::new(0.4, 0.9, 0.5));
        let Footprint::Rect(r) = project_points(&b.corners(), &vp, 100, 50) else {
            panic!("box is in front of the camera");
        };
        // Dense samples of the box give a subset of its true screen extent.
        let (mut lo, mut hi) = (glam::Vec2::MAX, glam::Vec2::MIN);
        for i in 0..=20 {
            for j in 0..=20 {
                for k in 0..=20 {
                    let t = Vec3::new(i as f32, j as f32, k as f32) / 20.0;
                    let q = vp.project_point3(b.min + (b.max - b.min) * t);
                    let s = glam::Vec2::new((q.x * 0.5 + 0.5) * 100.0, (0.5 - q.y * 0.5) * 50.0);
                    lo = lo.min(s);
                    hi = hi.max(s);
                    assert!(q.z >= r.z_near - 1e-6 && q.z <= r.z_far + 1e-6);
                }
            }
        }
        for py in 0..50u32 {
            for px in 0..100u32 {
                let centre = glam::Vec2::new(px as f32 + 0.5, py as f32 + 0.5);
                if centre.cmpge(lo).all() && centre.cmple(hi).all() {
                    assert!(px >= r.x0 && px < r.x1 && py >= r.y0 && py < r.y1, "pixel {px},{py} outside {r:?}");
                }
            }
        }
        // And the rect is not wildly larger than the sampled extent.
        assert!((r.x0 as f32) >= lo.x - 1.5 && (r.x1 as f32) <= hi.x + 1.5);
    }
}
