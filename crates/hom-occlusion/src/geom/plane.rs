//! Planes in Hessian normal form.

use glam::{Vec3, Vec4};

/// The plane `normal · p + d = 0`; points with a positive value are on the inside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// Unit normal, pointing to the inside half-space.
    pub normal: Vec3,
    /// Offset: `-normal · p` for any point `p` on the plane.
    pub d: f32,
}

impl Plane {
    /// The "plane" every point is inside (signed distance 1 everywhere): an
    /// infinite far plane.
    pub const EVERYWHERE: Plane = Plane {
        normal: Vec3::ZERO,
        d: 1.0,
    };

    /// A plane from `(a, b, c, d)` with `a x + b y + c z + d >= 0` inside, normalised.
    ///
    /// Returns `None` when `(a, b, c)` has no length or a coefficient is not finite.
    pub fn from_coefficients(v: Vec4) -> Option<Plane> {
        let n = v.truncate();
        let len = n.length();
        if !(len.is_finite() && len > 0.0 && v.w.is_finite()) {
            return None;
        }
        Some(Plane {
            normal: n / len,
            d: v.w / len,
        })
    }

    /// A plane through `point` with unit-length `normal` pointing inside.
    pub fn from_point_normal(point: Vec3, normal: Vec3) -> Plane {
        Plane {
            normal,
            d: -normal.dot(point),
        }
    }

    /// Signed distance of `p`: positive inside.
    pub fn signed_distance(&self, p: Vec3) -> f32 {
        self.normal.dot(p) + self.d
    }
}
