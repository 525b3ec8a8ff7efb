//! `sculpture-park`: a scene whose good occluders are dense, for virtual occluders
//! (Law & Tan 1999, section 4) — and a forest of small ones, for occluder fusion
//! (Zhang et al. 1997, figure 6).
//!
//! Three by three walled courtyards: every wall is a finely tessellated slab (a few
//! thousand triangles where a box would do), each courtyard holds high-poly statues
//! on tessellated plinths, and the middle one two monuments of over 20,000
//! triangles. The walls hide nearly everything outside the courtyard the camera is
//! in, but drawn as they are, one or two of them fill HOM's polygon budget. Beyond
//! the last courtyard lies a grove of several hundred small conifers (about 50
//! triangles each, none a good occluder alone) with houses behind it that only the
//! trees together hide. The camera snakes through the courtyards' doorways, then
//! walks along the grove's edge and up a lane through it.

use super::rng::Rng;
use super::shapes::MeshBuilder;
use super::{round_corners, Builtin, Generated};
use crate::camera_path::{CameraPath, PathFrame};
use crate::motion::Animation;
use glam::{Mat4, Quat, Vec3};
use hom::scene::{MeshId, SceneBuilder, SceneError};

/// Courtyards per side.
const YARDS: usize = 3;
/// Wall pitch (centre to centre), thickness and height.
const PITCH: f32 = 19.0;
const THICK: f32 = 0.6;
const HEIGHT: f32 = 4.5;
/// Doorway width and height.
const DOOR_W: f32 = 2.4;
const DOOR_H: f32 = 3.2;
/// Side of the squares walls and plinths are tessellated into.
const WALL_STEP: f32 = 0.3;
/// Eye height of the walk.
const EYE: f32 = 1.7;
/// The grove: its near edge beyond the courtyards, depth, tree spacing and the lane.
const GROVE_GAP: f32 = 8.0;
const GROVE_DEPTH: f32 = 40.0;
const TREE_SPACING: f32 = 1.8;
const LANE_HALF: f32 = 1.6;

/// Where the walls run: wall line `k` is centred at `k * PITCH`.
fn line(k: usize) -> f32 {
    k as f32 * PITCH
}

/// Centre of courtyard `i` along an axis.
fn yard_centre(i: usize) -> f32 {
    (i as f32 + 0.5) * PITCH
}

pub(super) fn generate(seed: u64) -> Generated {
    let mut rng = Rng::new(seed, 8);
    let mut b = SceneBuilder::new("sculpture-park");
    let span = line(YARDS);
    let grove_z = (span + GROVE_GAP, span + GROVE_GAP + GROVE_DEPTH);

    // Ground: four tiles under the courtyards and the grove.
    let (g0, g1) = (
        Vec3::new(-20.0, 0.0, -20.0),
        Vec3::new(span + 20.0, 0.0, grove_z.1 + 30.0),
    );
    let mid = (g0 + g1) * 0.5;
    for (k, (lo, hi)) in [
        (g0, mid),
        (Vec3::new(mid.x, 0.0, g0.z), Vec3::new(g1.x, 0.0, mid.z)),
        (Vec3::new(g0.x, 0.0, mid.z), Vec3::new(mid.x, 0.0, g1.z)),
        (mid, g1),
    ]
    .into_iter()
    .enumerate()
    {
        let mut m = MeshBuilder::new();
        m.floor_quad(lo, hi, 0.0);
        let id = b.add_mesh(m.build(format!("ground {k}")));
        b.add_object(format!("ground {k}"), id, Mat4::IDENTITY)?;
    }

    walls(&mut b, &mut rng)?;
    statues(&mut b, &mut rng)?;
    let lane_x = yard_centre(0);
    grove(&mut b, &mut rng, grove_z, lane_x)?;

    Ok(Builtin {
        scene: b.build()?,
        path: walk(lane_x, grove_z),
        animation: Animation::none(),
    })
}

/// The walls: along x at z = line(k) and along z at x = line(k), one slab per
/// courtyard side, with a doorway in every inner side and in the last
/// courtyard's far side (the way out to the grove). Corner posts fill the crossings.
fn walls(b: &mut SceneBuilder, rng: &mut Rng) -> Result<(), SceneError> {
    let h = THICK * 0.5;
    let mut n = 0;
    let mut slab = |b: &mut SceneBuilder, min: Vec3, max: Vec3| -> Result<(), SceneError> {
        let mut m = MeshBuilder::new();
        // A hair of seeded jitter in the height so seeds differ.
        let top = max.y * (1.0 + 0.01 * rng.range(-1.0, 1.0));
        m.add_tessellated_box(min, Vec3::new(max.x, top, max.z), WALL_STEP);
        let id = b.add_mesh(m.build(format!("wall {n}")));
        b.add_object(format!("wall {n}"), id, Mat4::IDENTITY)?;
        n += 1;
        Ok(())
    };
    for along_x in [true, false] {
        for k in 0..=YARDS {
            for i in 0..YARDS {
                let (a, c) = (line(i) + h, line(i + 1) - h);
                let inner = k > 0 && k < YARDS;
                let exit = along_x && k == YARDS && i == YARDS - 1;
                // The slab's extent as (along, across) ranges, mapped to (x, z).
                let place = |s0: f32, s1: f32, y0: f32, y1: f32| -> (Vec3, Vec3) {
                    let (t0, t1) = (line(k) - h, line(k) + h);
                    if along_x {
                        (Vec3::new(s0, y0, t0), Vec3::new(s1, y1, t1))
                    } else {
                        (Vec3::new(t0, y0, s0), Vec3::new(t1, y1, s1))
                    }
                };
                if inner || exit {
                    let mid = (a + c) * 0.5;
                    let (d0, d1) = (mid - DOOR_W * 0.5, mid + DOOR_W * 0.5);
                    for (s0, s1, y0) in [(a, d0, 0.0), (d1, c, 0.0), (d0, d1, DOOR_H)] {
                        let (lo, hi) = place(s0, s1, y0, HEIGHT);
                        slab(b, lo, hi)?;
                    }
                } else {
                    let (lo, hi) = place(a, c, 0.0, HEIGHT);
                    slab(b, lo, hi)?;
                }
            }
        }
    }
    let mut post = MeshBuilder::new();
    post.add_tessellated_box(Vec3::new(-h, 0.0, -h), Vec3::new(h, HEIGHT, h), WALL_STEP);
    let post = b.add_mesh(post.build("post"));
    for i in 0..=YARDS {
        for j in 0..=YARDS {
            b.add_object(
                format!("post {i} {j}"),
                post,
                Mat4::from_translation(Vec3::new(line(i), 0.0, line(j))),
            )?;
        }
    }
    Ok(())
}

/// Statue meshes: a tessellated plinth, a squarish high-poly torso, a round head.
fn statue_meshes(b: &mut SceneBuilder, rng: &mut Rng) -> Vec<MeshId> {
    (0..4)
        .map(|k| {
            let mut m = MeshBuilder::new();
            let w = rng.range(0.55, 0.75);
            let plinth = rng.range(0.9, 1.3);
            m.add_tessellated_box(Vec3::new(-w, 0.0, -w), Vec3::new(w, plinth, w), 0.1);
            let r = Vec3::new(rng.range(0.35, 0.5), rng.range(0.7, 1.0), rng.range(0.25, 0.4));
            let torso = plinth + r.y;
            m.add_superellipsoid(Vec3::new(0.0, torso, 0.0), r, rng.range(4.0, 8.0), 40, 20);
            m.add_sphere(Vec3::new(0.0, torso + r.y + 0.24, 0.0), 0.24, 24, 12);
            b.add_mesh(m.build(format!("statue {k}")))
        })
        .collect()
}

/// A stepped obelisk of tessellated blocks (over 20,000 triangles).
fn monument_mesh(b: &mut SceneBuilder) -> MeshId {
    let mut m = MeshBuilder::new();
    let mut y = 0.0;
    for (w, h) in [(2.4, 1.0), (1.8, 1.2), (1.2, 1.6), (0.7, 4.0)] {
        m.add_tessellated_box(Vec3::new(-w, y, -w), Vec3::new(w, y + h, w), 0.1);
        y += h;
    }
    b.add_mesh(m.build("monument"))
}

/// Four statues per courtyard, one in each quadrant clear of the walk (which runs
/// through the courtyards' centre lines); the middle courtyard has two monuments
/// in its near quadrants instead.
fn statues(b: &mut SceneBuilder, rng: &mut Rng) -> Result<(), SceneError> {
    let meshes = statue_meshes(b, rng);
    let monument = monument_mesh(b);
    let q = PITCH * 0.25;
    for i in 0..YARDS {
        for j in 0..YARDS {
            let c = Vec3::new(yard_centre(i), 0.0, yard_centre(j));
            for (k, (sx, sz)) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)]
                .into_iter()
                .enumerate()
            {
                let at = c + Vec3::new(sx * q + rng.range(-1.0, 1.0), 0.0, sz * q + rng.range(-1.0, 1.0));
                let turn = Quat::from_rotation_y(rng.range(0.0, std::f32::consts::TAU));
                let middle = i == YARDS / 2 && j == YARDS / 2;
                let (name, mesh) = if middle && sz < 0.0 {
                    (format!("monument {k}"), monument)
                } else {
                    (format!("statue {i} {j} {k}"), meshes[rng.index(meshes.len())])
                };
                b.add_object(name, mesh, Mat4::from_rotation_translation(turn, at))?;
            }
        }
    }
    Ok(())
}

/// The grove: conifers on a jittered grid with a lane at `lane_x`, and houses
/// behind it.
fn grove(b: &mut SceneBuilder, rng: &mut Rng, z: (f32, f32), lane_x: f32) -> Result<(), SceneError> {
    let trees: Vec<MeshId> = (0..3)
        .map(|k| {
            let mut m = MeshBuilder::new();
            let h = 4.0 + k as f32;
            m.add_cylinder(Vec3::ZERO, Vec3::new(0.0, 1.6, 0.0), 0.15, 6, false);
            m.add_cone(Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, h, 0.0), 1.1, 0.0, 10, true);
            m.add_cone(
                Vec3::new(0.0, 2.2, 0.0),
                Vec3::new(0.0, h + 0.8, 0.0),
                0.8,
                0.0,
                8,
                true,
            );
            b.add_mesh(m.build(format!("conifer {k}")))
        })
        .collect();
    let (x0, x1) = (-15.0, line(YARDS) + 15.0);
    let (nx, nz) = (
        ((x1 - x0) / TREE_SPACING) as usize,
        ((z.1 - z.0) / TREE_SPACING) as usize,
    );
    let mut n = 0;
    for i in 0..=nx {
        for j in 0..=nz {
            let x = x0 + i as f32 * TREE_SPACING + rng.range(-0.5, 0.5);
            let zz = z.0 + j as f32 * TREE_SPACING + rng.range(-0.5, 0.5);
            let keep = rng.chance(0.8);
            if !keep || (x - lane_x).abs() < LANE_HALF + 1.1 {
                continue;
            }
            let xf = Mat4::from_rotation_translation(
                Quat::from_rotation_y(rng.range(0.0, std::f32::consts::TAU)),
                Vec3::new(x, 0.0, zz),
            );
            b.add_object(format!("conifer {n}"), trees[rng.index(trees.len())], xf)?;
            n += 1;
        }
    }
    let mut house = MeshBuilder::new();
    house.add_tessellated_box(Vec3::new(-3.0, 0.0, -3.0), Vec3::new(3.0, 5.0, 3.0), 0.5);
    house.add_cone(Vec3::new(0.0, 5.0, 0.0), Vec3::new(0.0, 7.5, 0.0), 4.2, 0.0, 4, true);
    let house = b.add_mesh(house.build("house"));
    for k in 0..8 {
        let x = x0 + 8.0 + k as f32 * (x1 - x0 - 16.0) / 7.0;
        let at = Vec3::new(x, 0.0, z.1 + 10.0 + rng.range(0.0, 8.0));
        b.add_object(format!("house {k}"), house, Mat4::from_translation(at))?;
    }
    Ok(())
}

/// The walk: through the courtyards' doorways in a snake (along x in the first
/// row, back in the second, along again in the third), out through the far wall,
/// west along the grove's edge looking into it, and up the lane at `lane_x`. The view sways a
/// little either side of the way ahead, so it takes in walls and statues too.
fn walk(lane_x: f32, grove_z: (f32, f32)) -> CameraPath {
    let mut pts = Vec::new();
    for j in 0..YARDS {
        let row: Vec<usize> = if j % 2 == 0 {
            (0..YARDS).collect()
        } else {
            (0..YARDS).rev().collect()
        };
        for i in row {
            pts.push(Vec3::new(yard_centre(i), EYE, yard_centre(j)));
        }
    }
    let out = *pts.last().unwrap();
    let edge = grove_z.0 - 3.0;
    pts.push(Vec3::new(out.x, EYE, edge));
    pts.push(Vec3::new(lane_x, EYE, edge));
    pts.push(Vec3::new(lane_x, EYE, grove_z.1 - 2.0));
    let smooth = round_corners(&pts, 2.5, 0.5);
    let path = CameraPath::along(&smooth, 0.75, 8.0);
    let n = path.frames.len();
    let frames = path
        .frames
        .iter()
        .enumerate()
        .map(|(i, f)| {
            let (eye, target) = (Vec3::from(f.eye), Vec3::from(f.target));
            // Along the grove's edge (walking -x) the view turns half right, into the
            // trees, easing in and out over 4 m at either end.
            let ramp = |d: f32| (d / 4.0).clamp(0.0, 1.0);
            let on_edge = if (eye.z - edge).abs() < 0.5 {
                ramp(eye.x - lane_x - 1.0) * ramp(out.x - 1.0 - eye.x)
            } else {
                0.0
            };
            let yaw = (1.0 - on_edge) * 0.5 * (i as f32 / n as f32 * 37.0).sin() + on_edge * 0.7;
            let sway = Quat::from_rotation_y(yaw);
            PathFrame {
                eye: f.eye,
                target: (eye + sway * (target - eye)).to_array(),
            }
        })
        .collect();
    CameraPath { frames, ..path }
}
