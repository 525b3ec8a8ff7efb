//! The error quadric of Garland and Heckbert 1997, §4: a sum of planes, each a
//! symmetric 4×4 matrix `K_p = p pᵀ` for `p = (a, b, c, d)`, `ax + by + cz + d = 0`.
//!
//! Held in `f64`: sums of thousands of planes lose the millimetres that decide
//! which collapse comes first when stored in `f32`. Each plane is weighted by its
//! triangle's area, so a flat region counts the same however finely it happens to
//! be tessellated; the weights are summed too, so that
//! [`Quadric::mean_error_with`] is a squared distance, not an area times one.

use glam::DVec3;

/// A sum of area-weighted plane quadrics, and the sum of their weights.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Quadric {
    /// Upper triangle of the symmetric matrix, row by row:
    /// `xx xy xz xw yy yz yw zz zw ww`.
    m: [f64; 10],
    /// Sum of the weights (areas) of the planes.
    weight: f64,
}

impl Quadric {
    /// The quadric of the plane through triangle `p0 p1 p2`, weighted by its area.
    /// Zero (no plane, no weight) when the triangle has no area.
    pub(super) fn of_triangle(p0: DVec3, p1: DVec3, p2: DVec3) -> Quadric {
        let cross = (p1 - p0).cross(p2 - p0);
        let len = cross.length();
        // Checked this way round so a NaN length also gives the zero quadric.
        if len > 0.0 && len.is_finite() {
            let n = cross / len;
            let d = -n.dot(p0);
            let area = 0.5 * len;
            let m = [
                n.x * n.x,
                n.x * n.y,
                n.x * n.z,
                n.x * d,
                n.y * n.y,
                n.y * n.z,
                n.y * d,
                n.z * n.z,
                n.z * d,
                d * d,
            ];
            Quadric {
                m: m.map(|x| x * area),
                weight: area,
            }
        } else {
            Quadric::default()
        }
    }

    /// Sum of the weights of the planes.
    #[cfg(test)]
    pub(super) fn weight(&self) -> f64 {
        self.weight
    }

    /// `vᵀ Q v` for `v = (p, 1)`: the area-weighted sum of squared distances from
    /// `p` to the planes. Rounding can make it slightly negative; it is clamped to 0
    /// (a NaN stays NaN, so that it fails every error bound).
    pub(super) fn error(&self, p: DVec3) -> f64 {
        let [xx, xy, xz, xw, yy, yz, yw, zz, zw, ww] = self.m;
        let (x, y, z) = (p.x, p.y, p.z);
        let r = x * (xx * x + 2.0 * (xy * y + xz * z + xw))
            + y * (yy * y + 2.0 * (yz * z + yw))
            + z * (zz * z + 2.0 * zw)
            + ww;
        if r <= 0.0 {
            0.0
        } else {
            r
        }
    }

    /// `(self + other)(p)` divided by the summed weight: the area-weighted mean
    /// squared distance from `p` to all planes of both, in the mesh's units
    /// squared. 0 when neither holds a plane.
    pub(super) fn mean_error_with(&self, other: &Quadric, p: DVec3) -> f64 {
        let weight = self.weight + other.weight;
        let sum = self.error(p) + other.error(p);
        if weight > 0.0 {
            sum / weight
        } else {
            sum
        }
    }
}

impl std::ops::AddAssign for Quadric {
    fn add_assign(&mut self, rhs: Quadric) {
        for (a, b) in self.m.iter_mut().zip(rhs.m) {
            *a += b;
        }
        self.weight += rhs.weight;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn error_is_area_weighted_squared_distance() {
        // Triangle of area 2 in the plane y = 1.
        let q = Quadric::of_triangle(
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(0.0, 1.0, 2.0),
            DVec3::new(2.0, 1.0, 0.0),
        );
        assert_eq!(q.weight(), 2.0);
        assert_eq!(q.error(DVec3::new(5.0, 1.0, -3.0)), 0.0);
        assert!((q.error(DVec3::new(0.3, 4.0, 7.0)) - 2.0 * 9.0).abs() < 1e-9);
        let mut sum = q;
        sum += Quadric::of_triangle(DVec3::ZERO, DVec3::Z, DVec3::X);
        // Mean over weights 2 and 0.5 of squared distances 9 and 16 from (0, 4, 0).
        let mean = q.mean_error_with(
            &Quadric::of_triangle(DVec3::ZERO, DVec3::Z, DVec3::X),
            DVec3::new(0.0, 4.0, 0.0),
        );
        assert!((mean - (2.0 * 9.0 + 0.5 * 16.0) / 2.5).abs() < 1e-9);
        assert!((sum.error(DVec3::new(0.0, 4.0, 0.0)) - (2.0 * 9.0 + 0.5 * 16.0)).abs() < 1e-9);
    }

    #[test]
    fn degenerate_triangle_adds_nothing() {
        let q = Quadric::of_triangle(DVec3::ZERO, DVec3::X, DVec3::X * 2.0);
        assert_eq!(q, Quadric::default());
        assert_eq!(q.mean_error_with(&q, DVec3::splat(3.0)), 0.0);
    }
}
