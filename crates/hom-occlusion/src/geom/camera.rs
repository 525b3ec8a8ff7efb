//! The pinhole camera every culler and the renderer share.

use super::{ClipConvention, Frustum, View, MAX_VIEWPORT_SIDE};
use glam::{Mat4, Vec3};
use thiserror::Error;

/// Why a camera cannot be used.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CameraError {
    /// A position or direction has a NaN or infinite coordinate.
    #[error("camera {field} is not finite: {value:?}")]
    NotFinite {
        /// Which field.
        field: &'static str,
        /// The value.
        value: [f32; 3],
    },
    /// Eye and target coincide, or up is parallel to the view direction.
    #[error("camera has no view direction: eye {eye:?}, target {target:?}, up {up:?} (eye must differ from target, up must not be parallel to the view direction)")]
    Degenerate {
        /// Eye.
        eye: [f32; 3],
        /// Target.
        target: [f32; 3],
        /// Up.
        up: [f32; 3],
    },
    /// Field of view outside (0°, 180°).
    #[error("vertical field of view must be between 0 and 180 degrees, got {0} degrees")]
    FieldOfView(f32),
    /// Clip distances not `0 < near < far`, both finite.
    #[error("clip distances must satisfy 0 < near < far (finite), got near {near}, far {far}")]
    ClipRange {
        /// Near distance.
        near: f32,
        /// Far distance.
        far: f32,
    },
    /// Width or height zero or too large.
    #[error("viewport must be 1..={max} pixels a side, got {width}x{height}", max = MAX_VIEWPORT_SIDE)]
    Viewport {
        /// Width.
        width: u32,
        /// Height.
        height: u32,
    },
}

/// A perspective camera: world is right-handed +Y up; view = `look_at_rh`,
/// projection = `perspective_rh` (clip z in `[0, w]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub eye: Vec3,
    /// Point looked at.
    pub target: Vec3,
    /// Up direction (need not be orthogonal to the view direction).
    pub up: Vec3,
    /// Vertical field of view, radians.
    pub fov_y: f32,
    /// Near clip distance.
    pub near: f32,
    /// Far clip distance.
    pub far: f32,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
}

impl Camera {
    /// A camera from its parts (not validated: see [`Camera::validate`]).
    #[allow(clippy::too_many_arguments)]
    pub fn new(eye: Vec3, target: Vec3, up: Vec3, fov_y: f32, near: f32, far: f32, width: u32, height: u32) -> Camera {
        Camera {
            eye,
            target,
            up,
            fov_y,
            near,
            far,
            width,
            height,
        }
    }

    /// Checks every field; cullers call this and refuse (rather than mis-cull) on error.
    pub fn validate(&self) -> Result<(), CameraError> {
        for (field, v) in [("eye", self.eye), ("target", self.target), ("up", self.up)] {
            if !v.is_finite() {
                return Err(CameraError::NotFinite {
                    field,
                    value: v.to_array(),
                });
            }
        }
        let dir = self.target - self.eye;
        let cross = dir.normalize_or_zero().cross(self.up.normalize_or_zero());
        if dir.length_squared() == 0.0 || cross.length_squared() < 1e-10 {
            return Err(CameraError::Degenerate {
                eye: self.eye.to_array(),
                target: self.target.to_array(),
                up: self.up.to_array(),
            });
        }
        let fov_deg = self.fov_y.to_degrees();
        if !(fov_deg > 0.0 && fov_deg < 180.0) {
            return Err(CameraError::FieldOfView(fov_deg));
        }
        if !(self.near > 0.0 && self.far > self.near && self.far.is_finite()) {
            return Err(CameraError::ClipRange {
                near: self.near,
                far: self.far,
            });
        }
        if self.width == 0 || self.height == 0 || self.width > MAX_VIEWPORT_SIDE || self.height > MAX_VIEWPORT_SIDE {
            return Err(CameraError::Viewport {
                width: self.width,
                height: self.height,
            });
        }
        Ok(())
    }

    /// Width over height.
    pub fn aspect(&self) -> f32 {
        self.width as f32 / self.height as f32
    }

    /// World-to-view matrix.
    pub fn view(&self) -> Mat4 {
        glam::camera::rh::view::look_at_mat4(self.eye, self.target, self.up)
    }

    /// View-to-clip matrix.
    pub fn projection(&self) -> Mat4 {
        // Right-handed, Y-up NDC, depth in [0, 1]: the classic `perspective_rh`.
        glam::camera::rh::proj::directx::perspective(self.fov_y, self.aspect(), self.near, self.far)
    }

    /// World-to-clip matrix.
    pub fn view_proj(&self) -> Mat4 {
        self.projection() * self.view()
    }

    /// The frame's [`View`], what cullers take: `view_proj`, the
    /// viewport and [`ClipConvention::ZeroToOne`].
    pub fn to_view(&self) -> View {
        View::from(self)
    }

    /// The view frustum; `None` for an invalid camera.
    pub fn frustum(&self) -> Option<Frustum> {
        self.validate().ok()?;
        Frustum::from_view_proj(&self.view_proj())
    }

    /// Unit view direction.
    pub fn forward(&self) -> Vec3 {
        (self.target - self.eye).normalize_or_zero()
    }
}

impl From<&Camera> for View {
    /// The camera's view: its `view_proj`, viewport, [`ClipConvention::ZeroToOne`].
    fn from(c: &Camera) -> View {
        View::new(c.view_proj(), c.width, c.height, ClipConvention::ZeroToOne)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validate_names_the_problem() {
        let ok = Camera::new(Vec3::ZERO, -Vec3::Z, Vec3::Y, 1.0, 0.1, 10.0, 64, 64);
        assert!(ok.validate().is_ok());
        let nan = Camera {
            eye: Vec3::new(f32::NAN, 0.0, 0.0),
            ..ok
        };
        assert!(matches!(
            nan.validate(),
            Err(CameraError::NotFinite { field: "eye", .. })
        ));
        let parallel = Camera { up: -Vec3::Z, ..ok };
        assert!(matches!(parallel.validate(), Err(CameraError::Degenerate { .. })));
        let clip = Camera {
            near: 10.0,
            far: 1.0,
            ..ok
        };
        assert!(matches!(clip.validate(), Err(CameraError::ClipRange { .. })));
        let vp = Camera { width: 0, ..ok };
        assert!(matches!(vp.validate(), Err(CameraError::Viewport { .. })));
        assert!(nan.frustum().is_none());
    }
}
