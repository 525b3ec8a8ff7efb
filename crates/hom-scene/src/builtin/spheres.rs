//! `spheres`: ten spheres in a line, seen along the line — the first hides the rest
//! (the opening figure of Greene et al.'s hierarchical visibility). The camera first
//! circles off the axis, uncovering the spheres behind, then flies past the line and
//! turns to look back along it from the far end.

use super::rng::Rng;
use super::shapes::MeshBuilder;
use super::{Builtin, Generated};
use crate::camera_path::{CameraPath, PathFrame};
use crate::motion::Animation;
use glam::{Mat4, Vec3};
use hom::scene::SceneBuilder;
use std::f32::consts::TAU;

/// Sphere count.
const COUNT: usize = 10;
/// Distance between sphere centres along -Z.
const SPACING: f32 = 4.0;
/// Height of the line.
const Y: f32 = 2.0;

pub(super) fn generate(seed: u64) -> Generated {
    let mut rng = Rng::new(seed, 2);
    let mut b = SceneBuilder::new("spheres");
    let mut m = MeshBuilder::new();
    m.add_sphere(Vec3::ZERO, 1.0, 48, 24);
    let sphere = b.add_mesh(m.build("sphere"));
    // Equal radii (a hair of seeded jitter so seeds differ but the first still hides the rest).
    for i in 0..COUNT {
        let r = 1.5 * (1.0 + 0.02 * rng.range(-1.0, 1.0));
        let c = Vec3::new(0.0, Y, -(i as f32) * SPACING);
        b.add_object(
            format!("sphere {i}"),
            sphere,
            Mat4::from_scale_rotation_translation(Vec3::splat(r), glam::Quat::IDENTITY, c),
        )?;
    }
    let end = Vec3::new(0.0, Y, -((COUNT - 1) as f32) * SPACING);
    let mut frames = Vec::new();
    // Part 1 (120 frames): on the axis 10 m before the first sphere, spiral out to 3 m
    // off the axis and back, looking at the last sphere.
    let orbit = 120;
    for i in 0..orbit {
        let t = i as f32 / orbit as f32;
        let off = 3.0 * (t * std::f32::consts::PI).sin();
        let a = t * TAU * 1.5;
        let eye = Vec3::new(off * a.cos(), Y + 0.7 * off * a.sin(), 10.0 - 2.0 * t);
        frames.push(PathFrame {
            eye: eye.to_array(),
            target: end.to_array(),
        });
    }
    // Part 2 (90 frames): fly past the line 3.5 m to its side, looking ahead and inward.
    let fly = 90;
    let (z0, z1) = (8.0, end.z - 12.0);
    for i in 0..fly {
        let t = i as f32 / (fly - 1) as f32;
        let z = z0 + (z1 - z0) * t;
        let eye = Vec3::new(4.5 - 3.0 * t, Y + 0.8 - 0.4 * t, z);
        let target = Vec3::new(0.0, Y, (z - 12.0).max(end.z));
        frames.push(PathFrame {
            eye: eye.to_array(),
            target: target.to_array(),
        });
    }
    // Part 3 (50 frames): behind the last sphere, turn round and settle on the axis
    // looking back along the line: now the last sphere hides the rest.
    let turn = 50;
    let last = Vec3::from(frames.last().unwrap().eye);
    let looked = Vec3::from(frames.last().unwrap().target);
    for i in 1..=turn {
        let t = i as f32 / turn as f32;
        let s = t * t * (3.0 - 2.0 * t);
        let eye = last.lerp(Vec3::new(0.0, Y, end.z - 12.0), s);
        let target = looked.lerp(Vec3::new(0.0, Y, 0.0), s);
        frames.push(PathFrame {
            eye: eye.to_array(),
            target: target.to_array(),
        });
    }
    Ok(Builtin {
        scene: b.build()?,
        path: CameraPath::new(frames),
        animation: Animation::none(),
    })
}
