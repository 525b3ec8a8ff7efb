//! The per-frame view an engine hands hom: a world-to-clip matrix, a viewport
//! and the clip convention the matrix was built for.
//!
//! Everything inside hom works in one convention, [`ClipConvention::ZeroToOne`]
//! (clip `0 <= z <= w`, depth `z / w` in `[0, 1]`, 0 at the near plane, nearer
//! is smaller). A view in another convention is brought to it by one exact
//! row operation on the matrix ([`ClipConvention::to_zero_to_one`]), so a
//! culler can never silently assume the wrong one.

use super::{Aabb, Frustum};
use glam::{Mat4, Vec3, Vec4};
use thiserror::Error;

/// Largest accepted image side, pixels: larger is almost certainly a typo.
pub const MAX_VIEWPORT_SIDE: u32 = 16_384;

/// Which clip-space depth range a projection matrix produces. NDC x and y are
/// in `[-1, 1]` with y up in every convention (a y-down projection, such as
/// Vulkan's, mirrors the image: answers are unchanged, but it swaps the
/// winding [`crate::FaceCull`] sees).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ClipConvention {
    /// `0 <= z <= w`, z = 0 at the near plane: Vulkan, Direct3D, Metal, wgpu
    /// (glam `camera::rh::proj::directx::perspective`). hom's own.
    #[default]
    ZeroToOne,
    /// `-w <= z <= w`, z = −w at the near plane: OpenGL (glam `camera::rh::proj::opengl::perspective`).
    NegOneToOne,
    /// Reversed Z: `0 <= z <= w` with z = w at the near plane and 0 at the far
    /// plane, finite or infinite (glam `camera::rh::proj::directx::perspective_infinite_reverse`).
    ReversedZ,
}

impl ClipConvention {
    /// The matrix that takes clip coordinates of this convention to
    /// [`ClipConvention::ZeroToOne`] ones: it changes only z (`(z + w) / 2`
    /// for OpenGL, `w − z` for reversed Z), so x, y, w and the image are untouched.
    pub fn to_zero_to_one(self) -> Mat4 {
        match self {
            ClipConvention::ZeroToOne => Mat4::IDENTITY,
            // Columns: x, y, z, w inputs; row 2 is the new z.
            ClipConvention::NegOneToOne => Mat4::from_cols(
                Vec4::new(1.0, 0.0, 0.0, 0.0),
                Vec4::new(0.0, 1.0, 0.0, 0.0),
                Vec4::new(0.0, 0.0, 0.5, 0.0),
                Vec4::new(0.0, 0.0, 0.5, 1.0),
            ),
            ClipConvention::ReversedZ => Mat4::from_cols(
                Vec4::new(1.0, 0.0, 0.0, 0.0),
                Vec4::new(0.0, 1.0, 0.0, 0.0),
                Vec4::new(0.0, 0.0, -1.0, 0.0),
                Vec4::new(0.0, 0.0, 1.0, 1.0),
            ),
        }
    }

    /// A clip-space vertex of this convention in [`ClipConvention::ZeroToOne`].
    #[inline]
    pub fn vertex_to_zero_to_one(self, v: Vec4) -> Vec4 {
        match self {
            ClipConvention::ZeroToOne => v,
            ClipConvention::NegOneToOne => Vec4::new(v.x, v.y, 0.5 * (v.z + v.w), v.w),
            ClipConvention::ReversedZ => Vec4::new(v.x, v.y, v.w - v.z, v.w),
        }
    }

    /// A depth (`z / w`) of this convention as a [`ClipConvention::ZeroToOne`] depth.
    #[inline]
    pub fn depth_to_zero_to_one(self, z: f32) -> f32 {
        match self {
            ClipConvention::ZeroToOne => z,
            ClipConvention::NegOneToOne => 0.5 * (z + 1.0),
            ClipConvention::ReversedZ => 1.0 - z,
        }
    }
}

/// Why a [`View`] cannot be used.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ViewError {
    /// The matrix has a NaN or infinite entry.
    #[error("view-projection matrix has a NaN or infinite entry")]
    NotFinite,
    /// The matrix bounds no frustum (singular, or a clip plane with no direction).
    #[error("view-projection matrix is degenerate: it bounds no view frustum")]
    Degenerate,
    /// Width or height zero or too large.
    #[error("viewport must be 1..={max} pixels a side, got {width}x{height}", max = MAX_VIEWPORT_SIDE)]
    Viewport {
        /// Width.
        width: u32,
        /// Height.
        height: u32,
    },
}

/// Where the viewer is: a point (perspective) or infinitely far along a
/// direction (orthographic).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Eye {
    /// The centre of projection.
    Point(Vec3),
    /// Parallel projection: unit direction in which depth grows.
    Direction(Vec3),
}

/// One frame's view: world-to-clip matrix, viewport, clip convention.
/// Perspective and orthographic projections both work.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// World-to-clip matrix (column-major), in the convention `clip`.
    pub view_proj: Mat4,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// The convention `view_proj` was built for.
    pub clip: ClipConvention,
}

impl View {
    /// A view from its parts (not validated: see [`View::validate`]).
    pub fn new(view_proj: Mat4, width: u32, height: u32, clip: ClipConvention) -> View {
        View {
            view_proj,
            width,
            height,
            clip,
        }
    }

    /// Checks the matrix and the viewport; cullers call this and refuse
    /// (rather than mis-cull) on error.
    pub fn validate(&self) -> Result<(), ViewError> {
        if !self.view_proj.is_finite() {
            return Err(ViewError::NotFinite);
        }
        if self.width == 0 || self.height == 0 || self.width > MAX_VIEWPORT_SIDE || self.height > MAX_VIEWPORT_SIDE {
            return Err(ViewError::Viewport {
                width: self.width,
                height: self.height,
            });
        }
        if Frustum::from_view_proj(&self.world_to_clip()).is_none() {
            return Err(ViewError::Degenerate);
        }
        Ok(())
    }

    /// The world-to-clip matrix in hom's convention ([`ClipConvention::ZeroToOne`]):
    /// what every culler, rasterizer and depth test uses.
    pub fn world_to_clip(&self) -> Mat4 {
        match self.clip {
            ClipConvention::ZeroToOne => self.view_proj,
            c => c.to_zero_to_one() * self.view_proj,
        }
    }

    /// The view frustum; `None` for a degenerate matrix.
    pub fn frustum(&self) -> Option<Frustum> {
        Frustum::from_view_proj(&self.world_to_clip())
    }

    /// The viewer, from the matrix: the point that projects to clip
    /// `x = y = w = 0` (the null vector of those three rows), or a direction
    /// when that point is at infinity (orthographic).
    pub fn eye(&self) -> Eye {
        let m = self.world_to_clip();
        let (r0, r1, r3) = (m.row(0), m.row(1), m.row(3));
        // The 4D cross product of three rows: orthogonal to all three.
        let e = cross4(r0, r1, r3);
        let xyz = e.truncate();
        if e.w.abs() > 1e-6 * xyz.length() {
            Eye::Point(xyz / e.w)
        } else {
            // Depth grows along +dir when clip z / w (w constant) grows.
            let dir = xyz.normalize_or_zero();
            let r2 = m.row(2).truncate();
            Eye::Direction(if r2.dot(dir) < 0.0 { -dir } else { dir })
        }
    }

    /// A key ordering boxes front to back (smaller is nearer): the squared
    /// distance from the eye, or for a parallel projection the box's nearest
    /// extent along the view direction. Only an order: it decides no visibility.
    #[inline]
    pub fn nearness(eye: &Eye, b: &Aabb) -> f32 {
        match eye {
            Eye::Point(p) => b.distance_squared(*p),
            Eye::Direction(d) => d.dot(b.center()) - d.abs().dot(b.half_extent()),
        }
    }

    /// The distance of a point from the viewer: from the eye point, or along
    /// the view direction (can be negative behind a parallel view's near plane).
    #[inline]
    pub fn distance(eye: &Eye, p: Vec3) -> f32 {
        match eye {
            Eye::Point(e) => (p - *e).length(),
            Eye::Direction(d) => d.dot(p),
        }
    }
}

/// The vector orthogonal to `a`, `b` and `c` (cofactor expansion).
fn cross4(a: Vec4, b: Vec4, c: Vec4) -> Vec4 {
    let det3 = |p: [f32; 3], q: [f32; 3], r: [f32; 3]| {
        p[0] * (q[1] * r[2] - q[2] * r[1]) - p[1] * (q[0] * r[2] - q[2] * r[0]) + p[2] * (q[0] * r[1] - q[1] * r[0])
    };
    let (a, b, c) = (a.to_array(), b.to_array(), c.to_array());
    let minor = |skip: usize| {
        let pick = |v: [f32; 4]| {
            let mut o = [0.0; 3];
            let mut k = 0;
            for (i, x) in v.into_iter().enumerate() {
                if i != skip {
                    o[k] = x;
                    k += 1;
                }
            }
            o
        };
        det3(pick(a), pick(b), pick(c))
    };
    Vec4::new(minor(0), -minor(1), minor(2), -minor(3))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::camera::rh::proj::{directx, opengl};
    use glam::camera::rh::view::look_at_mat4;

    #[test]
    fn every_convention_maps_to_the_same_clip_space() {
        let view = look_at_mat4(Vec3::new(1.0, 2.0, 3.0), Vec3::ZERO, Vec3::Y);
        let (fov, aspect, near, far) = (1.1, 1.5, 0.3, 80.0);
        let dx = directx::perspective(fov, aspect, near, far) * view;
        let gl = opengl::perspective(fov, aspect, near, far) * view;
        let gl = ClipConvention::NegOneToOne.to_zero_to_one() * gl;
        for p in [Vec3::ZERO, Vec3::new(0.5, -0.2, 1.0), Vec3::new(-3.0, 0.0, -20.0)] {
            let (a, b) = (dx * p.extend(1.0), gl * p.extend(1.0));
            assert!((a - b).abs().max_element() < 1e-4 * a.abs().max_element(), "{a} {b}");
        }
        // Reversed infinite: z / w = 1 − near / distance.
        let rev = directx::perspective_infinite_reverse(fov, aspect, near) * view;
        let v = View::new(rev, 64, 64, ClipConvention::ReversedZ);
        let c = v.world_to_clip() * Vec3::ZERO.extend(1.0);
        let d = Vec3::new(1.0, 2.0, 3.0).length();
        assert!((c.z / c.w - (1.0 - near / d)).abs() < 1e-5);
        assert!(v.validate().is_ok(), "an infinite far plane is a frustum");
        assert!((ClipConvention::ReversedZ.depth_to_zero_to_one(1.0)).abs() < 1e-7);
        assert_eq!(ClipConvention::NegOneToOne.depth_to_zero_to_one(-1.0), 0.0);
        let w = Vec4::new(0.1, 0.2, 0.3, 0.7);
        for conv in [ClipConvention::NegOneToOne, ClipConvention::ReversedZ] {
            let (m, f) = (conv.to_zero_to_one() * w, conv.vertex_to_zero_to_one(w));
            assert!((m - f).abs().max_element() < 1e-7, "{conv:?}");
        }
    }

    #[test]
    fn eye_of_perspective_and_orthographic_views() {
        let eye = Vec3::new(4.0, 1.0, -2.0);
        let view = look_at_mat4(eye, Vec3::ZERO, Vec3::Y);
        let p = View::new(
            directx::perspective(1.0, 1.0, 0.1, 50.0) * view,
            8,
            8,
            ClipConvention::ZeroToOne,
        );
        match p.eye() {
            Eye::Point(e) => assert!((e - eye).length() < 1e-3, "{e}"),
            e => panic!("{e:?}"),
        }
        let o = View::new(
            directx::orthographic(-5.0, 5.0, -5.0, 5.0, 0.1, 50.0) * view,
            8,
            8,
            ClipConvention::ZeroToOne,
        );
        match o.eye() {
            Eye::Direction(d) => assert!((d + eye.normalize()).length() < 1e-4, "{d}"),
            e => panic!("{e:?}"),
        }
        assert!(o.validate().is_ok());
    }

    #[test]
    fn bad_views_name_the_problem() {
        let ok = View::new(
            directx::perspective(1.0, 1.0, 0.1, 50.0),
            8,
            8,
            ClipConvention::ZeroToOne,
        );
        assert!(ok.validate().is_ok());
        let mut nan = ok;
        nan.view_proj.x_axis.x = f32::NAN;
        assert!(matches!(nan.validate(), Err(ViewError::NotFinite)));
        assert!(matches!(
            View { width: 0, ..ok }.validate(),
            Err(ViewError::Viewport { .. })
        ));
        assert!(matches!(
            View {
                view_proj: Mat4::ZERO,
                ..ok
            }
            .validate(),
            Err(ViewError::Degenerate)
        ));
    }
}
