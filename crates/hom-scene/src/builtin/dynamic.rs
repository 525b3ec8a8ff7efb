//! `dynamic`: about a million triangles of moving objects — Utah teapots, tori, spheres
//! and boxes — each drifting inside its own cell of a grid (bouncing off the cell walls)
//! and spinning, above a static tiled floor. The cells are separated by lanes kept free
//! of objects at all times, and the camera flies along those lanes, so it looks through
//! a crowd of moving occluders without ever entering one.

use super::rng::Rng;
use super::shapes::MeshBuilder;
use super::teapot::teapot;
use super::{round_corners, Builtin, Generated};
use crate::camera_path::CameraPath;
use crate::motion::{Animation, Motion};
use glam::{Mat4, Quat, Vec3};
use hom::geom::Aabb;
use hom::scene::SceneBuilder;

/// Cells per side, cell pitch (cell + lane) and lane width.
const CELLS: usize = 8;
const PITCH: f32 = 16.0;
const LANE: f32 = 4.0;
/// Height the objects may use.
const TOP: f32 = 14.0;
/// Camera height.
const EYE: f32 = 6.0;

pub(super) fn generate(seed: u64) -> Generated {
    let mut rng = Rng::new(seed, 4);
    let mut b = SceneBuilder::new("dynamic");
    let mut animation = Animation::none();
    // Shapes, each with the radius of a sphere round its origin that holds it.
    let mut shapes = Vec::new();
    let mut tp = teapot(5, 1.0);
    // Centre the teapot on its origin so it spins about its middle.
    let centre = Vec3::new(0.15, 0.5, 0.0);
    for p in &mut tp.positions {
        *p -= centre;
    }
    let tp = tp.build("utah teapot");
    let r_tp = tp.positions().iter().map(|p| p.length()).fold(0.0, f32::max);
    let teapot_id = b.add_mesh(tp);
    let mut torus = MeshBuilder::new();
    torus.add_torus(Vec3::ZERO, Vec3::Y, 0.7, 0.25, 40, 16);
    let torus_id = b.add_mesh(torus.build("torus"));
    let mut sphere = MeshBuilder::new();
    sphere.add_sphere(Vec3::ZERO, 0.6, 32, 16);
    let sphere_id = b.add_mesh(sphere.build("sphere"));
    let mut cube = MeshBuilder::new();
    cube.add_box(Vec3::splat(-0.5), Vec3::splat(0.5));
    let cube_id = b.add_mesh(cube.build("box"));
    shapes.push(("teapot", teapot_id, r_tp));
    shapes.push(("torus", torus_id, 0.95));
    shapes.push(("sphere", sphere_id, 0.6));
    shapes.push(("box", cube_id, 0.87));

    // Static floor: one tile per cell and lane crossing strip.
    let mut tile = MeshBuilder::new();
    tile.add_box(Vec3::new(0.0, -0.1, 0.0), Vec3::new(PITCH, 0.0, PITCH));
    let tile = b.add_mesh(tile.build("floor tile"));
    for i in 0..CELLS {
        for j in 0..CELLS {
            let at = Vec3::new(i as f32 * PITCH - LANE * 0.5, 0.0, j as f32 * PITCH - LANE * 0.5);
            b.add_object(format!("floor {i},{j}"), tile, Mat4::from_translation(at))?;
        }
    }

    // Each cell: the object's whole bounding sphere stays inside the cell box.
    let cell = PITCH - LANE;
    for i in 0..CELLS {
        for j in 0..CELLS {
            let (x0, z0) = (i as f32 * PITCH + LANE * 0.5, j as f32 * PITCH + LANE * 0.5);
            let counts = [(0usize, 7usize), (1, 2), (2, 2), (3, 3)];
            for (s, n) in counts {
                let (kind, mesh, r0) = shapes[s];
                for k in 0..n {
                    let scale = match kind {
                        "teapot" => rng.range(1.2, 2.4),
                        "box" => rng.range(0.6, 1.8),
                        _ => rng.range(0.7, 1.6),
                    };
                    let r = r0 * scale + 0.05;
                    let region = Aabb::new(
                        Vec3::new(x0 + r, r + 0.05, z0 + r),
                        Vec3::new(x0 + cell - r, TOP - r, z0 + cell - r),
                    );
                    let start = Vec3::new(
                        rng.range(region.min.x, region.max.x),
                        rng.range(region.min.y, region.max.y),
                        rng.range(region.min.z, region.max.z),
                    );
                    let rot = Quat::from_axis_angle(rng.unit_vec3(), rng.range(0.0, std::f32::consts::TAU));
                    let base = Mat4::from_scale_rotation_translation(Vec3::splat(scale), rot, start);
                    let motion = Motion {
                        velocity: rng.unit_vec3() * rng.range(0.5, 2.5),
                        region,
                        spin_axis: rng.unit_vec3(),
                        spin_rate: rng.range(0.2, 1.5),
                    };
                    let id = b.add_dynamic_object(format!("{kind} {i},{j}.{k}"), mesh, base)?;
                    animation.add(id, base, motion)?;
                }
            }
        }
    }

    // Fly along the lanes (lane centres lie at multiples of PITCH), turning at crossings.
    let l = |k: usize| k as f32 * PITCH;
    let p = |x: usize, z: usize, y: f32| Vec3::new(l(x), y, l(z));
    let pts = [
        p(0, 1, EYE) + Vec3::new(-6.0, 0.0, 0.0),
        p(3, 1, EYE),
        p(3, 4, EYE + 2.0),
        p(6, 4, EYE + 4.0),
        p(6, 7, EYE + 2.0),
        p(2, 7, EYE),
        p(2, 5, EYE),
    ];
    let smooth = round_corners(&pts, 1.6, 0.5);
    let path = CameraPath::along(&smooth, 1.0, 5.0);
    Ok(Builtin {
        scene: b.build()?,
        path,
        animation,
    })
}
