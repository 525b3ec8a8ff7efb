//! Oriented bounding boxes: the tight bound of a moving (dynamic) object.

use super::Aabb;
use glam::{Mat3, Mat4, Vec3};

/// A box with its own orthonormal axes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Obb {
    /// Centre in world space.
    pub center: Vec3,
    /// Unit axes (columns), right-handed.
    pub axes: Mat3,
    /// Half the size along each of `axes`.
    pub half_extents: Vec3,
}

impl Obb {
    /// The box `local` (in an object's own space) carried by `transform`.
    ///
    /// Exact for rotation, translation and per-axis scale; a sheared transform
    /// gets a box that still holds the sheared one (axes re-orthogonalised, extents grown).
    pub fn from_local(local: &Aabb, transform: &Mat4) -> Obb {
        let center = transform.transform_point3(local.center());
        let h = local.half_extent();
        let cols = [
            transform.x_axis.truncate(),
            transform.y_axis.truncate(),
            transform.z_axis.truncate(),
        ];
        // Gram-Schmidt so the axes are orthonormal even for slightly sheared input.
        let x = cols[0].try_normalize().unwrap_or(Vec3::X);
        let y = (cols[1] - x * x.dot(cols[1]))
            .try_normalize()
            .unwrap_or_else(|| x.any_orthonormal_vector());
        let z = x.cross(y);
        let axes = Mat3::from_cols(x, y, z);
        // Each transformed half-axis projected on each new axis bounds the extent.
        let half = Vec3::new(
            (cols[0] * h.x).dot(x).abs() + (cols[1] * h.y).dot(x).abs() + (cols[2] * h.z).dot(x).abs(),
            (cols[0] * h.x).dot(y).abs() + (cols[1] * h.y).dot(y).abs() + (cols[2] * h.z).dot(y).abs(),
            (cols[0] * h.x).dot(z).abs() + (cols[1] * h.y).dot(z).abs() + (cols[2] * h.z).dot(z).abs(),
        );
        Obb {
            center,
            axes,
            half_extents: half,
        }
    }

    /// The eight corners; bit 0 of the index picks +x, bit 1 +y, bit 2 +z.
    pub fn corners(&self) -> [Vec3; 8] {
        let [ax, ay, az] = [
            self.axes.x_axis * self.half_extents.x,
            self.axes.y_axis * self.half_extents.y,
            self.axes.z_axis * self.half_extents.z,
        ];
        std::array::from_fn(|i| {
            let sx = if i & 1 != 0 { 1.0 } else { -1.0 };
            let sy = if i & 2 != 0 { 1.0 } else { -1.0 };
            let sz = if i & 4 != 0 { 1.0 } else { -1.0 };
            self.center + ax * sx + ay * sy + az * sz
        })
    }

    /// The world axis-aligned box around this box.
    pub fn aabb(&self) -> Aabb {
        let r = self.axes.x_axis.abs() * self.half_extents.x
            + self.axes.y_axis.abs() * self.half_extents.y
            + self.axes.z_axis.abs() * self.half_extents.z;
        Aabb {
            min: self.center - r,
            max: self.center + r,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{EulerRot, Quat};

    #[test]
    fn obb_corners_are_the_transformed_local_corners() {
        let local = Aabb::new(Vec3::new(-1.0, 0.0, 2.0), Vec3::new(3.0, 1.0, 5.0));
        let m = Mat4::from_scale_rotation_translation(
            Vec3::new(2.0, 0.5, 1.5),
            Quat::from_euler(EulerRot::XYZ, 0.3, 1.1, -0.7),
            Vec3::new(4.0, -2.0, 9.0),
        );
        let obb = Obb::from_local(&local, &m);
        let mut want = local.corners().map(|c| m.transform_point3(c));
        let mut got = obb.corners();
        let key = |v: &Vec3| (v.x * 1e3) as i64 * 1_000_000 + (v.y * 1e3) as i64 * 1000 + (v.z * 1e3) as i64;
        want.sort_by_key(key);
        got.sort_by_key(key);
        for (a, b) in want.iter().zip(&got) {
            assert!((*a - *b).length() < 1e-3, "{a} vs {b}");
        }
        let aabb = obb.aabb();
        for c in want {
            assert!(aabb.min.cmple(c + 1e-4).all() && aabb.max.cmpge(c - 1e-4).all());
        }
    }
}
