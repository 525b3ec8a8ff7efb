//! Scripted movement for the built-in scenes: each dynamic object drifts
//! inside a box, bouncing off its walls, and spins. The pose at time `t` is a
//! pure function of `t`, so any frame can be rendered alone and every culler
//! sees the same scene. Engines move their own objects with
//! [`Scene::set_transform`]; this is how the generators do it.

use hom::geom::Aabb;
use hom::glam::{Mat3, Mat4, Quat, Vec3};
use hom::scene::{Scene, SceneError};

/// Deterministic motion of a dynamic object: drift that bounces inside a region, plus spin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion {
    /// Drift velocity of the object's origin, metres per second.
    pub velocity: Vec3,
    /// The origin bounces off the walls of this box (it must contain the start position).
    pub region: Aabb,
    /// Spin axis (any length; normalised when used). Zero means no spin.
    pub spin_axis: Vec3,
    /// Spin rate, radians per second, about the object's origin.
    pub spin_rate: f32,
}

impl Motion {
    /// True when every field is finite.
    pub fn is_finite(&self) -> bool {
        self.velocity.is_finite() && self.region.is_finite() && self.spin_axis.is_finite() && self.spin_rate.is_finite()
    }

    /// The world transform at time `t` seconds for an object whose pose at `t = 0` is `base`.
    pub fn transform_at(&self, base: &Mat4, t: f32) -> Mat4 {
        let start = base.w_axis.truncate();
        let moved = start + self.velocity * t;
        let lo = self.region.min;
        let size = self.region.extent();
        // Triangle wave per axis keeps the origin inside the region (reflection at walls).
        let bounce = |p: f32, lo: f32, s: f32| {
            if s <= 0.0 {
                return lo;
            }
            let u = (p - lo).rem_euclid(2.0 * s);
            lo + if u > s { 2.0 * s - u } else { u }
        };
        let pos = Vec3::new(
            bounce(moved.x, lo.x, size.x),
            bounce(moved.y, lo.y, size.y),
            bounce(moved.z, lo.z, size.z),
        );
        let spin = match self.spin_axis.try_normalize() {
            Some(axis) => Quat::from_axis_angle(axis, self.spin_rate * t),
            None => Quat::IDENTITY,
        };
        let mut linear = Mat4::from_quat(spin) * Mat4::from_mat3(Mat3::from_mat4(*base));
        linear.w_axis = pos.extend(1.0);
        linear
    }
}

/// One moving object: its id, its pose at time 0 and its motion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Track {
    /// The object's id.
    pub object: u32,
    /// Its transform at time 0.
    pub base: Mat4,
    /// How it moves.
    pub motion: Motion,
}

/// The scripted motion of a scene's dynamic objects.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Animation {
    tracks: Vec<Track>,
}

impl Animation {
    /// No motion at all (a static scene).
    pub fn none() -> Animation {
        Animation::default()
    }

    /// Adds a track; an error when the motion has a non-finite field.
    pub fn add(&mut self, object: u32, base: Mat4, motion: Motion) -> Result<(), SceneError> {
        if !motion.is_finite() {
            return Err(SceneError::BadTransform {
                object: format!("object {object} (its motion has a non-finite field)"),
            });
        }
        self.tracks.push(Track { object, base, motion });
        Ok(())
    }

    /// The tracks, in the order they were added.
    pub fn tracks(&self) -> &[Track] {
        &self.tracks
    }

    /// True when nothing moves.
    pub fn is_empty(&self) -> bool {
        self.tracks.is_empty()
    }

    /// Moves every tracked object of `scene` to its pose at time `t` seconds.
    ///
    /// # Panics
    /// If a track names an object `scene` does not have (an animation
    /// belongs to the scene it was made with), or a motion yields a singular transform.
    pub fn apply(&self, scene: &mut Scene, t: f32) {
        for tr in &self.tracks {
            scene
                .set_transform(tr.object, tr.motion.transform_at(&tr.base, t))
                .expect("an animation moves the objects of its own scene");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hom::scene::{Mesh, SceneBuilder};

    fn quad() -> Mesh {
        Mesh::new(
            "quad",
            vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
            vec![[0, 1, 2], [0, 2, 3]],
        )
        .unwrap()
    }

    #[test]
    fn dynamic_objects_stay_in_region_and_bounds_follow() {
        let mut b = SceneBuilder::new("s");
        let m = b.add_mesh(quad());
        let motion = Motion {
            velocity: Vec3::new(3.0, -1.0, 7.0),
            region: Aabb::new(Vec3::splat(-2.0), Vec3::splat(2.0)),
            spin_axis: Vec3::Y,
            spin_rate: 1.3,
        };
        let q = b.add_dynamic_object("q", m, Mat4::IDENTITY).unwrap();
        b.add_object("still", m, Mat4::from_translation(Vec3::X * 10.0))
            .unwrap();
        let mut s = b.build().unwrap();
        let mut anim = Animation::none();
        anim.add(q, Mat4::IDENTITY, motion).unwrap();
        let bad = Motion {
            spin_rate: f32::NAN,
            ..motion
        };
        assert!(anim.clone().add(q, Mat4::IDENTITY, bad).is_err());
        for i in 0..200 {
            let t = i as f32 * 0.1;
            anim.apply(&mut s, t);
            let o = s.object(0);
            let origin = o.transform.w_axis.truncate();
            assert!(motion.region.contains_point(origin), "t={t} origin {origin}");
            for c in s.mesh_of(o).positions() {
                let w = o.transform.transform_point3(*c);
                assert!(o.aabb.min.cmple(w + 1e-4).all() && o.aabb.max.cmpge(w - 1e-4).all());
            }
            assert_eq!(s.object(1).transform, Mat4::from_translation(Vec3::X * 10.0));
        }
    }
}
