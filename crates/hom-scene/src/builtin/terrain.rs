//! `terrain`: rolling hills from a few octaves of value noise, as a height field split
//! into square tiles (one object each), with villages of houses and a few towers
//! standing on it and forests of conifers on the slopes (in the spirit of Law & Tan's
//! city/terrain data sets). The camera flies low over the hills, following the ground.

use super::rng::Rng;
use super::shapes::MeshBuilder;
use super::{Builtin, Generated};
use crate::camera_path::{CameraPath, PathFrame};
use crate::motion::Animation;
use glam::{Mat4, Quat, Vec3};
use hom::scene::SceneBuilder;
use std::f32::consts::TAU;

/// Grid cells per side, cell size, cells per tile side.
const CELLS: usize = 384;
const CELL: f32 = 4.0;
const TILE: usize = 24;
/// Flight height above the highest ground near the eye.
const CLEARANCE: f32 = 14.0;

/// Seeded value noise: smooth-interpolated random values on integer lattices, summed over octaves.
struct Noise {
    seed: u64,
}

impl Noise {
    fn lattice(&self, x: i64, z: i64, octave: u64) -> f32 {
        let mut h = (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
            ^ (z as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
            ^ self.seed.wrapping_add(octave.wrapping_mul(0x1656_67B1_9E37_79F9));
        h ^= h >> 33;
        h = h.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
        h ^= h >> 33;
        (h >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
    }

    fn value(&self, x: f32, z: f32, octave: u64) -> f32 {
        let (xi, zi) = (x.floor(), z.floor());
        let (fx, fz) = (x - xi, z - zi);
        let s = |t: f32| t * t * (3.0 - 2.0 * t);
        let (sx, sz) = (s(fx), s(fz));
        let (xi, zi) = (xi as i64, zi as i64);
        let a = self.lattice(xi, zi, octave);
        let b = self.lattice(xi + 1, zi, octave);
        let c = self.lattice(xi, zi + 1, octave);
        let d = self.lattice(xi + 1, zi + 1, octave);
        let ab = a + (b - a) * sx;
        let cd = c + (d - c) * sx;
        ab + (cd - ab) * sz
    }

    /// Height in metres at world (x, z).
    fn height(&self, x: f32, z: f32) -> f32 {
        let octaves = [(420.0, 55.0), (170.0, 24.0), (70.0, 9.0), (28.0, 3.0)];
        octaves
            .iter()
            .enumerate()
            .map(|(k, &(wave, amp))| amp * self.value(x / wave, z / wave, k as u64))
            .sum::<f32>()
            + 60.0
    }
}

pub(super) fn generate(seed: u64) -> Generated {
    let mut rng = Rng::new(seed, 6);
    let noise = Noise { seed: rng.next_u64() };
    let mut b = SceneBuilder::new("terrain");
    let n = CELLS + 1;
    let heights: Vec<f32> = (0..n * n)
        .map(|i| noise.height((i % n) as f32 * CELL, (i / n) as f32 * CELL))
        .collect();
    let h_at = |x: f32, z: f32| -> f32 {
        // Bilinear in the grid (matches the triangles closely enough for placement).
        let (gx, gz) = (
            (x / CELL).clamp(0.0, CELLS as f32 - 1e-3),
            (z / CELL).clamp(0.0, CELLS as f32 - 1e-3),
        );
        let (i, j) = (gx.floor() as usize, gz.floor() as usize);
        let (fx, fz) = (gx - i as f32, gz - j as f32);
        let h = |i: usize, j: usize| heights[j * n + i];
        let a = h(i, j) + (h(i + 1, j) - h(i, j)) * fx;
        let c = h(i, j + 1) + (h(i + 1, j + 1) - h(i, j + 1)) * fx;
        a + (c - a) * fz
    };
    // Tiles.
    let tiles = CELLS / TILE;
    for tj in 0..tiles {
        for ti in 0..tiles {
            let mut m = MeshBuilder::new();
            for j in 0..=TILE {
                for i in 0..=TILE {
                    let (gi, gj) = (ti * TILE + i, tj * TILE + j);
                    m.positions
                        .push(Vec3::new(i as f32 * CELL, heights[gj * n + gi], j as f32 * CELL));
                }
            }
            let w = (TILE + 1) as u32;
            for j in 0..TILE as u32 {
                for i in 0..TILE as u32 {
                    let a = j * w + i;
                    m.quad(a, a + 1, a + w + 1, a + w);
                }
            }
            let id = b.add_mesh(m.build(format!("terrain tile {ti},{tj}")));
            let origin = Vec3::new((ti * TILE) as f32 * CELL, 0.0, (tj * TILE) as f32 * CELL);
            b.add_object(format!("terrain tile {ti},{tj}"), id, Mat4::from_translation(origin))?;
        }
    }
    let size = CELLS as f32 * CELL;
    let slope = |x: f32, z: f32| {
        ((h_at(x + 3.0, z) - h_at(x - 3.0, z)).abs() + (h_at(x, z + 3.0) - h_at(x, z - 3.0)).abs()) / 6.0
    };

    // Shared meshes: houses (box + gable roof + chimney), towers, conifers.
    let mut houses = Vec::new();
    for (k, &(w, d, h)) in [(8.0, 10.0, 5.0), (10.0, 14.0, 6.0), (7.0, 7.0, 4.5), (12.0, 9.0, 7.0)]
        .iter()
        .enumerate()
    {
        let mut m = MeshBuilder::new();
        let (hw, hd) = (w * 0.5, d * 0.5);
        // Walls reach 6 m below ground so the house sits on slopes without a gap.
        m.add_box_open_bottom(Vec3::new(-hw, -6.0, -hd), Vec3::new(hw, h, hd));
        let ridge = h + w * 0.45;
        let o = 0.4;
        let i = m.positions.len() as u32;
        for p in [
            Vec3::new(-hw - o, h - 0.2, -hd - o),
            Vec3::new(hw + o, h - 0.2, -hd - o),
            Vec3::new(0.0, ridge, -hd - o),
            Vec3::new(-hw - o, h - 0.2, hd + o),
            Vec3::new(hw + o, h - 0.2, hd + o),
            Vec3::new(0.0, ridge, hd + o),
        ] {
            m.vertex(p);
        }
        m.quad(i, i + 2, i + 5, i + 3);
        m.quad(i + 1, i + 2, i + 5, i + 4);
        m.tri(i, i + 1, i + 2);
        m.tri(i + 3, i + 4, i + 5);
        m.add_box(
            Vec3::new(hw * 0.4, h, -hd * 0.5),
            Vec3::new(hw * 0.4 + 0.8, ridge + 0.5, -hd * 0.5 + 0.8),
        );
        // Door and windows as shallow boxes.
        m.add_box(Vec3::new(-0.5, 0.0, -hd - 0.1), Vec3::new(0.5, 2.1, -hd));
        for x in [-hw * 0.6, hw * 0.6] {
            m.add_box(Vec3::new(x - 0.6, 1.2, -hd - 0.08), Vec3::new(x + 0.6, 2.4, -hd));
            m.add_box(Vec3::new(x - 0.6, 1.2, hd), Vec3::new(x + 0.6, 2.4, hd + 0.08));
        }
        houses.push(b.add_mesh(m.build(format!("house {k}"))));
    }
    let mut tower = MeshBuilder::new();
    tower.add_box_open_bottom(Vec3::new(-4.0, -6.0, -4.0), Vec3::new(4.0, 22.0, 4.0));
    for y in [6.0, 12.0, 18.0] {
        tower.add_box(Vec3::new(-4.3, y, -4.3), Vec3::new(4.3, y + 0.5, 4.3));
    }
    tower.add_cone(Vec3::new(0.0, 22.0, 0.0), Vec3::new(0.0, 32.0, 0.0), 5.0, 0.0, 8, true);
    let tower = b.add_mesh(tower.build("tower"));
    let mut conifer = MeshBuilder::new();
    conifer.add_cylinder(Vec3::new(0.0, -1.0, 0.0), Vec3::new(0.0, 2.0, 0.0), 0.3, 5, false);
    conifer.add_cone(Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, 7.0, 0.0), 2.4, 0.8, 8, true);
    conifer.add_cone(Vec3::new(0.0, 5.5, 0.0), Vec3::new(0.0, 11.0, 0.0), 1.8, 0.0, 8, false);
    let conifer = b.add_mesh(conifer.build("conifer"));

    // Villages where the ground is gentle; forests on moderate slopes.
    let mut villages = 0;
    let mut tries = 0;
    while villages < 40 && tries < 4000 {
        tries += 1;
        let c = Vec3::new(rng.range(60.0, size - 60.0), 0.0, rng.range(60.0, size - 60.0));
        if slope(c.x, c.z) > 0.12 {
            continue;
        }
        villages += 1;
        let houses_here = rng.int(12, 30);
        for k in 0..houses_here {
            let a = rng.range(0.0, TAU);
            let d = rng.range(8.0, 70.0);
            let p = c + Vec3::new(a.cos() * d, 0.0, a.sin() * d);
            if slope(p.x, p.z) > 0.35 {
                continue;
            }
            let y = h_at(p.x, p.z);
            let mesh = if k == 0 && rng.chance(0.6) {
                tower
            } else {
                houses[rng.index(houses.len())]
            };
            let yaw = rng.range(0.0, TAU);
            b.add_object(
                format!("village {villages} building {k}"),
                mesh,
                Mat4::from_rotation_translation(Quat::from_rotation_y(yaw), Vec3::new(p.x, y, p.z)),
            )?;
        }
    }
    let mut forests = 0;
    while forests < 60 {
        let c = Vec3::new(rng.range(20.0, size - 20.0), 0.0, rng.range(20.0, size - 20.0));
        forests += 1;
        for k in 0..rng.int(20, 70) {
            let p = c + Vec3::new(rng.range(-60.0, 60.0), 0.0, rng.range(-60.0, 60.0));
            if !(2.0..size - 2.0).contains(&p.x) || !(2.0..size - 2.0).contains(&p.z) {
                continue;
            }
            let s = rng.range(0.7, 1.4);
            b.add_object(
                format!("forest {forests} tree {k}"),
                conifer,
                Mat4::from_scale_rotation_translation(
                    Vec3::splat(s),
                    Quat::from_rotation_y(rng.range(0.0, TAU)),
                    Vec3::new(p.x, h_at(p.x, p.z), p.z),
                ),
            )?;
        }
    }

    // Low flight: a smooth closed loop (a wobbly ellipse) round the middle, eye kept
    // CLEARANCE above the highest ground (and trees) within 30 m, height smoothed.
    let frames_n = 300;
    let mid = size * 0.5;
    let phase = rng.range(0.0, TAU);
    let xz = |t: f32| {
        let a = t * TAU + phase;
        Vec3::new(
            mid + (size * 0.33) * a.cos() + 60.0 * (3.0 * a).sin(),
            0.0,
            mid + (size * 0.28) * a.sin() + 50.0 * (2.0 * a).cos(),
        )
    };
    let ground = |p: Vec3| {
        let mut m = f32::MIN;
        for k in 0..12 {
            let a = k as f32 / 12.0 * TAU;
            for r in [0.0, 15.0, 30.0] {
                m = m.max(h_at(p.x + a.cos() * r, p.z + a.sin() * r));
            }
        }
        m + 12.0
    };
    let raw: Vec<f32> = (0..frames_n).map(|i| ground(xz(i as f32 / frames_n as f32))).collect();
    let smooth: Vec<f32> = (0..frames_n)
        .map(|i| {
            (0..frames_n)
                .filter(|j| {
                    (*j as i64 - i as i64)
                        .rem_euclid(frames_n as i64)
                        .min((i as i64 - *j as i64).rem_euclid(frames_n as i64))
                        <= 6
                })
                .map(|j| raw[j])
                .fold(f32::MIN, f32::max)
        })
        .collect();
    let frames = (0..frames_n)
        .map(|i| {
            let e = xz(i as f32 / frames_n as f32);
            let ahead = xz((i as f32 + 6.0) / frames_n as f32);
            let eye = Vec3::new(e.x, smooth[i] + CLEARANCE - 12.0 + 4.0, e.z);
            let target = Vec3::new(ahead.x, eye.y - 8.0, ahead.z);
            PathFrame {
                eye: eye.to_array(),
                target: target.to_array(),
            }
        })
        .collect();
    let mut path = CameraPath::new(frames);
    path.far = 3000.0;
    Ok(Builtin {
        scene: b.build()?,
        path,
        animation: Animation::none(),
    })
}
