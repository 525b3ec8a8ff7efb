//! Axis-aligned bounding boxes.

use glam::{Mat4, Vec3};

/// An axis-aligned box, `min <= max` on every axis when non-empty.
///
/// [`Aabb::EMPTY`] (min = +inf, max = -inf) is the identity of [`Aabb::union`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Smallest corner.
    pub min: Vec3,
    /// Largest corner.
    pub max: Vec3,
}

impl Aabb {
    /// The empty box: contains nothing, grows to whatever is added.
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// A box from two corners (in any order).
    pub fn new(a: Vec3, b: Vec3) -> Aabb {
        Aabb {
            min: a.min(b),
            max: a.max(b),
        }
    }

    /// The smallest box holding every point; [`Aabb::EMPTY`] for none.
    pub fn from_points(points: impl IntoIterator<Item = Vec3>) -> Aabb {
        points.into_iter().fold(Aabb::EMPTY, |b, p| b.grow(p))
    }

    /// True when the box holds no point.
    pub fn is_empty(&self) -> bool {
        !(self.min.cmple(self.max).all())
    }

    /// True when every coordinate is finite.
    pub fn is_finite(&self) -> bool {
        self.min.is_finite() && self.max.is_finite()
    }

    /// This box grown to hold `p`.
    pub fn grow(self, p: Vec3) -> Aabb {
        Aabb {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// The smallest box holding both.
    pub fn union(self, o: Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// Centre point.
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Size along each axis.
    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }

    /// Half the size along each axis.
    pub fn half_extent(&self) -> Vec3 {
        self.extent() * 0.5
    }

    /// Surface area (0 for an empty box), the SAH cost measure.
    pub fn surface_area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let e = self.extent();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// True when `p` is inside or on the boundary.
    pub fn contains_point(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// True when `o` lies entirely inside this box (boundaries included).
    pub fn contains(&self, o: &Aabb) -> bool {
        o.is_empty() || (o.min.cmpge(self.min).all() && o.max.cmple(self.max).all())
    }

    /// True when the boxes share at least one point.
    pub fn intersects(&self, o: &Aabb) -> bool {
        self.min.cmple(o.max).all() && o.min.cmple(self.max).all()
    }

    /// The eight corners; bit 0 of the index picks max.x, bit 1 max.y, bit 2 max.z.
    pub fn corners(&self) -> [Vec3; 8] {
        std::array::from_fn(|i| {
            Vec3::new(
                if i & 1 != 0 { self.max.x } else { self.min.x },
                if i & 2 != 0 { self.max.y } else { self.min.y },
                if i & 4 != 0 { self.max.z } else { self.min.z },
            )
        })
    }

    /// The box around this box's eight corners after an affine transform.
    pub fn transformed(&self, m: &Mat4) -> Aabb {
        if self.is_empty() {
            return *self;
        }
        // Arvo's method: per axis, add the smaller and larger of each column's two contributions.
        let t = m.w_axis.truncate();
        let (mut lo, mut hi) = (t, t);
        for (column, lo_c, hi_c) in [
            (m.x_axis.truncate(), self.min.x, self.max.x),
            (m.y_axis.truncate(), self.min.y, self.max.y),
            (m.z_axis.truncate(), self.min.z, self.max.z),
        ] {
            let (a, b) = (column * lo_c, column * hi_c);
            lo += a.min(b);
            hi += a.max(b);
        }
        Aabb { min: lo, max: hi }
    }

    /// Squared distance from `p` to the nearest point of the box (0 inside).
    pub fn distance_squared(&self, p: Vec3) -> f32 {
        let d = (self.min - p).max(p - self.max).max(Vec3::ZERO);
        d.length_squared()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn transformed_box_holds_every_transformed_corner() {
        let b = Aabb::new(Vec3::new(-1.0, 0.0, 2.0), Vec3::new(3.0, 1.0, 5.0));
        let m = Mat4::from_scale_rotation_translation(
            Vec3::new(2.0, 0.5, 1.0),
            glam::Quat::from_euler(glam::EulerRot::XYZ, 0.3, 1.1, -0.7),
            Vec3::new(4.0, -2.0, 9.0),
        );
        let t = b.transformed(&m);
        let exact = Aabb::from_points(b.corners().map(|c| m.transform_point3(c)));
        assert!((t.min - exact.min).abs().max_element() < 1e-4);
        assert!((t.max - exact.max).abs().max_element() < 1e-4);
    }

    #[test]
    fn empty_box_is_union_identity() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        assert!(Aabb::EMPTY.is_empty());
        assert_eq!(Aabb::EMPTY.union(b), b);
        assert_eq!(Aabb::EMPTY.surface_area(), 0.0);
    }
}
