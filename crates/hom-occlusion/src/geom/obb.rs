//! Oriented bounding boxes: the tight bound of a moving (dynamic) object,
//! and of a static one whose triangles lie along a slanted plane (a wall at
//! an angle, a roof, a piece of terrain on a slope), where the axis-aligned
//! box holds mostly empty space.

use super::Aabb;
use glam::{Mat3, Mat4, Vec3};

/// Turns about the normal tried by [`Obb::fit`] within a quarter turn.
const FIT_TURNS: usize = 16;

/// Metres added to each side when [`Obb::fit`] compares boxes.
const FIT_PAD: f32 = 0.05;

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

    /// A box around `points` in their own space, the smallest of: the
    /// axis-aligned box, and boxes with one axis along `normal` (the mesh's
    /// area-weighted normal; ignored when zero or not finite) turned about it
    /// in 16 steps of a quarter turn. Sizes are compared as volumes
    /// with each side widened by 5 cm, so a flat patch's box is judged
    /// by its area, and the axis-aligned box is kept unless another is smaller
    /// by a tenth (what is axis-aligned stays exactly so). `None` without points.
    pub fn fit(points: &[Vec3], normal: Vec3) -> Option<Obb> {
        let aabb = Aabb::from_points(points.iter().copied());
        if aabb.is_empty() {
            return None;
        }
        let volume = |e: Vec3| (e + Vec3::splat(FIT_PAD)).element_product();
        let mut best = Obb::from_local(&aabb, &Mat4::IDENTITY);
        let limit = volume(aabb.extent()) * 0.9;
        let mut best_volume = limit;
        let Some(n) = normal.try_normalize() else {
            return Some(best);
        };
        let u = n.any_orthonormal_vector();
        let v = n.cross(u);
        for k in 0..FIT_TURNS {
            let a = std::f32::consts::FRAC_PI_2 * k as f32 / FIT_TURNS as f32;
            let (sin, cos) = a.sin_cos();
            let x = u * cos + v * sin;
            let axes = Mat3::from_cols(x, n.cross(x), n);
            let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
            for &p in points {
                let q = axes.transpose() * p;
                lo = lo.min(q);
                hi = hi.max(q);
            }
            let vol = volume(hi - lo);
            if vol < best_volume {
                best_volume = vol;
                best = Obb {
                    center: axes * ((lo + hi) * 0.5),
                    axes,
                    half_extents: (hi - lo) * 0.5,
                };
            }
        }
        Some(best)
    }

    /// This box (in an object's own space) carried by `transform`, as
    /// [`Obb::from_local`] carries an axis-aligned one.
    pub fn transformed(&self, transform: &Mat4) -> Obb {
        let frame = Mat4::from_mat3(self.axes);
        let frame = Mat4::from_translation(self.center) * frame;
        Obb::from_local(&Aabb::new(-self.half_extents, self.half_extents), &(*transform * frame))
    }

    /// Its volume.
    pub fn volume(&self) -> f32 {
        (self.half_extents * 2.0).element_product()
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

    /// Points inside `b`, with a little slack for rounding.
    fn holds(b: &Obb, p: Vec3) -> bool {
        let q = b.axes.transpose() * (p - b.center);
        q.abs().cmple(b.half_extents + Vec3::splat(1e-4)).all()
    }

    #[test]
    fn a_slanted_patch_gets_a_thin_box_holding_it_and_axis_aligned_ones_keep_theirs() {
        // A 4 × 3 m patch tilted 30° about X, with 2 cm bumps.
        let tilt = Quat::from_rotation_x(0.52);
        let points: Vec<Vec3> = (0..40)
            .map(|i| {
                let (x, z) = ((i % 8) as f32 * 0.5, (i / 8) as f32 * 0.75);
                tilt * Vec3::new(x, 0.02 * ((i * 7) % 3) as f32, z) + Vec3::new(5.0, 1.0, -2.0)
            })
            .collect();
        let b = Obb::fit(&points, tilt * Vec3::Y).unwrap();
        assert!(points.iter().all(|&p| holds(&b, p)));
        assert!(b.half_extents.min_element() < 0.05, "{b:?}");
        let aabb = Aabb::from_points(points.iter().copied());
        assert!(b.volume() < 0.2 * aabb.extent().element_product());
        // The same patch laid flat keeps its axis-aligned box exactly.
        let flat: Vec<Vec3> = points.iter().map(|&p| tilt.inverse() * p).collect();
        let b = Obb::fit(&flat, Vec3::Y).unwrap();
        let aabb = Aabb::from_points(flat.iter().copied());
        assert_eq!(b, Obb::from_local(&aabb, &Mat4::IDENTITY));
        // No normal, no points.
        assert_eq!(
            Obb::fit(&points, Vec3::ZERO).unwrap().aabb(),
            Aabb::from_points(points.iter().copied())
        );
        assert!(Obb::fit(&[], Vec3::Y).is_none());
    }

    #[test]
    fn a_fitted_box_carried_by_a_transform_holds_the_carried_points() {
        let tilt = Quat::from_rotation_z(0.8);
        let points: Vec<Vec3> = (0..30)
            .map(|i| tilt * Vec3::new(i as f32 * 0.1, (i % 3) as f32 * 0.01, (i % 5) as f32))
            .collect();
        let b = Obb::fit(&points, tilt * Vec3::Y).unwrap();
        let m = Mat4::from_scale_rotation_translation(
            Vec3::new(2.0, 0.5, 1.5),
            Quat::from_euler(EulerRot::XYZ, 0.3, 1.1, -0.7),
            Vec3::new(4.0, -2.0, 9.0),
        );
        let w = b.transformed(&m);
        for p in &points {
            assert!(holds(&w, m.transform_point3(*p)), "{p}");
        }
    }

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
