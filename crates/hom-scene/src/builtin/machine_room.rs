//! `machine-room`: a dense CAD-like engine room (in the spirit of a ship's engine room or
//! a power plant): main engines with cylinder heads, crankcase doors and turbochargers,
//! generator sets, pump groups, tanks with ladders, heat exchangers, switchboards,
//! overhead pipe runs built from flanged spools with elbows and bolts, pipe hangers,
//! cable trays, stiffened walls, a beamed deck overhead and floor plates. Tessellation
//! is CAD-fine (round parts have 16–24 sides). The camera walks the aisles at eye level.

use super::rng::Rng;
use super::shapes::MeshBuilder;
use super::{round_corners, Builtin, Generated};
use crate::camera_path::CameraPath;
use crate::motion::Animation;
use glam::{Mat4, Quat, Vec3};
use hom::scene::{MeshId, SceneBuilder, SceneError};
use std::collections::HashMap;
use std::f32::consts::{FRAC_PI_2, TAU};

/// Room size.
const LX: f32 = 60.0;
const LZ: f32 = 30.0;
const H: f32 = 8.0;
/// Nothing but pipes, trays and hangers above this height reaches into an aisle.
const CLEAR: f32 = 3.0;
/// Bays: x ranges and z ranges between the aisles.
const BAY_X: [(f32, f32); 4] = [(2.2, 13.8), (16.2, 28.8), (31.2, 43.8), (46.2, 57.8)];
const BAY_Z: [(f32, f32); 2] = [(3.0, 13.3), (16.7, 27.0)];
/// Aisle centre lines.
const MAIN_Z: f32 = 15.0;
const SIDE_Z: [f32; 2] = [1.6, 28.4];
const CROSS_X: [f32; 3] = [15.0, 30.0, 45.0];
const EYE: f32 = 1.7;
/// Round-part tessellation.
const SEG: u32 = 24;

/// Adds a bolt circle of `n` hex bolts (head + stub) on a flange face at `c`, normal `axis`.
fn bolts(m: &mut MeshBuilder, c: Vec3, axis: Vec3, radius: f32, n: u32, size: f32) {
    let (u, v) = super::shapes::frame(axis);
    let a = axis.normalize();
    for k in 0..n {
        let t = k as f32 / n as f32 * TAU;
        let p = c + (u * t.cos() + v * t.sin()) * radius;
        m.add_cylinder(p, p + a * size * 0.7, size, 6, true);
        m.add_cylinder(p + a * size * 0.7, p + a * size * 1.3, size * 0.45, 6, false);
    }
}

/// A flange pair with bolts at `c` on a pipe of radius `r` along `axis`.
fn flange(m: &mut MeshBuilder, c: Vec3, axis: Vec3, r: f32) {
    let a = axis.normalize();
    let fr = r * 1.8 + 0.03;
    let t = 0.03 + r * 0.15;
    m.add_cylinder(c - a * t, c + a * t, fr, SEG + 4, true);
    let n = if r < 0.08 {
        4
    } else if r < 0.15 {
        8
    } else {
        12
    };
    bolts(m, c + a * t, a, (r + fr) * 0.5 + 0.01, n, 0.012 + r * 0.06);
}

/// A straight pipe spool along +x, `len` long, radius `r`, flanged at both ends.
fn spool(len: f32, r: f32) -> MeshBuilder {
    let mut m = MeshBuilder::new();
    m.add_cylinder(Vec3::ZERO, Vec3::X * len, r, SEG, false);
    flange(&mut m, Vec3::X * 0.05, Vec3::X, r);
    flange(&mut m, Vec3::X * (len - 0.05), -Vec3::X, r);
    m
}

/// A pipe spool along a polyline with bends, flanged at both ends.
fn bent_spool(pts: &[Vec3], r: f32) -> MeshBuilder {
    let mut m = MeshBuilder::new();
    m.add_pipe(pts, r, (r * 3.0).max(0.25), SEG, 6);
    let n = pts.len();
    flange(&mut m, pts[0], pts[1] - pts[0], r);
    flange(&mut m, pts[n - 1], pts[n - 2] - pts[n - 1], r);
    m
}

struct Scene<'a> {
    b: &'a mut SceneBuilder,
    rng: Rng,
    cache: HashMap<String, MeshId>,
}

impl Scene<'_> {
    /// A shared mesh by key, built once.
    fn mesh(&mut self, key: &str, make: impl FnOnce(&mut Rng) -> MeshBuilder) -> MeshId {
        if let Some(&id) = self.cache.get(key) {
            return id;
        }
        let m = make(&mut self.rng);
        let id = self.b.add_mesh(m.build(key));
        self.cache.insert(key.to_string(), id);
        id
    }

    fn put(&mut self, name: &str, mesh: MeshId, at: Vec3, yaw: f32) -> Result<u32, SceneError> {
        self.b.add_object(
            name,
            mesh,
            Mat4::from_rotation_translation(Quat::from_rotation_y(yaw), at),
        )
    }

    /// A unique mesh placed at the origin (geometry already in world space).
    fn unique(&mut self, name: &str, m: MeshBuilder) -> Result<u32, SceneError> {
        let id = self.b.add_mesh(m.build(name));
        self.b.add_object(name, id, Mat4::IDENTITY)
    }
}

/// Main engine (or generator set when `cyl` is small) along x centred at `c` (floor level).
fn engine(s: &mut Scene, c: Vec3, cyl: usize, tag: &str) -> Result<(), SceneError> {
    let pitch = 1.05;
    let len = cyl as f32 * pitch + 1.2;
    let key = format!("engine block {cyl}");
    let block = s.mesh(&key, |_| {
        let mut m = MeshBuilder::new();
        m.add_box(
            Vec3::new(-len * 0.5 - 0.3, 0.0, -1.7),
            Vec3::new(len * 0.5 + 0.3, 0.5, 1.7),
        );
        m.add_box(Vec3::new(-len * 0.5, 0.5, -1.3), Vec3::new(len * 0.5, 2.4, 1.3));
        m.add_box(
            Vec3::new(-len * 0.5 + 0.2, 2.4, -1.0),
            Vec3::new(len * 0.5 - 0.2, 3.3, 1.0),
        );
        // Holding-down bolts along the foundation.
        for k in 0..(cyl * 2 + 2) {
            let x = -len * 0.5 + k as f32 * len / (cyl * 2 + 1) as f32;
            for z in [-1.55, 1.55] {
                bolts(&mut m, Vec3::new(x, 0.5, z), Vec3::Y, 0.0, 1, 0.04);
            }
        }
        // Crankcase doors with bolt rings, both sides.
        for k in 0..cyl {
            let x = -len * 0.5 + 0.6 + (k as f32 + 0.5) * pitch;
            for side in [-1.0f32, 1.0] {
                let z = side * 1.3;
                m.add_cylinder(
                    Vec3::new(x, 1.4, z),
                    Vec3::new(x, 1.4, z + side * 0.06),
                    0.36,
                    SEG,
                    true,
                );
                bolts(
                    &mut m,
                    Vec3::new(x, 1.4, z + side * 0.06),
                    Vec3::Z * side,
                    0.3,
                    10,
                    0.02,
                );
            }
        }
        // Camshaft cover and fuel rail along one side.
        m.add_box(
            Vec3::new(-len * 0.5 + 0.3, 2.5, 1.0),
            Vec3::new(len * 0.5 - 0.3, 2.9, 1.2),
        );
        m.add_cylinder(
            Vec3::new(-len * 0.5 + 0.3, 3.0, 1.05),
            Vec3::new(len * 0.5 - 0.3, 3.0, 1.05),
            0.05,
            12,
            true,
        );
        m
    });
    s.put(&format!("{tag} block"), block, c, 0.0)?;
    let head = s.mesh("cylinder head", |_| {
        let mut m = MeshBuilder::new();
        m.add_box(Vec3::new(-0.42, 0.0, -0.5), Vec3::new(0.42, 0.45, 0.5));
        m.add_box(Vec3::new(-0.35, 0.45, -0.4), Vec3::new(0.35, 0.75, 0.4));
        for (x, z) in [
            (-0.32, -0.42),
            (0.32, -0.42),
            (0.32, 0.42),
            (-0.32, 0.42),
            (0.0, -0.45),
            (0.0, 0.45),
        ] {
            m.add_cylinder(Vec3::new(x, 0.45, z), Vec3::new(x, 0.62, z), 0.035, 6, true);
        }
        m.add_cylinder(Vec3::new(0.0, 0.75, 0.0), Vec3::new(0.0, 0.95, 0.0), 0.06, 12, true);
        // Exhaust outlet stub towards -z and indicator valve.
        m.add_cylinder(Vec3::new(0.0, 0.25, -0.5), Vec3::new(0.0, 0.25, -0.8), 0.14, SEG, false);
        flange(&mut m, Vec3::new(0.0, 0.25, -0.8), -Vec3::Z, 0.14);
        m.add_pipe(
            &[
                Vec3::new(0.2, 0.7, 0.3),
                Vec3::new(0.2, 0.7, 0.7),
                Vec3::new(0.2, 0.2, 0.9),
            ],
            0.02,
            0.08,
            8,
            3,
        );
        m
    });
    for k in 0..cyl {
        let x = -len * 0.5 + 0.6 + (k as f32 + 0.5) * pitch;
        s.put(
            &format!("{tag} cylinder head {k}"),
            head,
            c + Vec3::new(x, 3.3, 0.0),
            0.0,
        )?;
    }
    // Exhaust manifold: along the heads' outlets, up into the turbocharger at the end.
    let x0 = c.x - len * 0.5 + 0.3;
    let x1 = c.x + len * 0.5 - 0.2;
    let y = c.y + 3.55;
    let z = c.z - 1.15;
    let mut m = MeshBuilder::new();
    m.add_pipe(
        &[
            Vec3::new(x0, y, z),
            Vec3::new(x1, y, z),
            Vec3::new(x1 + 0.6, y, z),
            Vec3::new(x1 + 0.6, y + 0.8, z),
        ],
        0.3,
        0.6,
        SEG + 4,
        8,
    );
    for k in 0..cyl {
        let x = x0 + 0.3 + (k as f32 + 0.5) * pitch;
        m.add_cylinder(
            Vec3::new(x, y - 0.05, z),
            Vec3::new(x, y + 0.05, z),
            0.34,
            SEG + 4,
            false,
        );
    }
    s.unique(&format!("{tag} exhaust manifold"), m)?;
    let turbo = s.mesh("turbocharger", |_| {
        let mut m = MeshBuilder::new();
        m.add_cylinder(
            Vec3::new(-0.6, 0.0, 0.0),
            Vec3::new(-0.1, 0.0, 0.0),
            0.45,
            SEG + 8,
            true,
        );
        m.add_torus(Vec3::new(-0.35, 0.0, 0.0), Vec3::X, 0.45, 0.12, SEG + 8, 10);
        m.add_cylinder(Vec3::new(-0.1, 0.0, 0.0), Vec3::new(0.2, 0.0, 0.0), 0.25, SEG, false);
        m.add_cylinder(Vec3::new(0.2, 0.0, 0.0), Vec3::new(0.6, 0.0, 0.0), 0.5, SEG + 8, true);
        m.add_torus(Vec3::new(0.4, 0.0, 0.0), Vec3::X, 0.5, 0.14, SEG + 8, 10);
        m.add_cone(
            Vec3::new(0.6, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            0.35,
            0.25,
            SEG,
            true,
        );
        bolts(&mut m, Vec3::new(-0.6, 0.0, 0.0), -Vec3::X, 0.38, 16, 0.02);
        bolts(&mut m, Vec3::new(0.6, 0.0, 0.0), Vec3::X, 0.42, 16, 0.02);
        m
    });
    s.put(
        &format!("{tag} turbocharger"),
        turbo,
        Vec3::new(x1 + 0.6, y + 1.3, z + 0.4),
        FRAC_PI_2,
    )?;
    // Flywheel and coupled generator/gearbox at the other end.
    let fly = s.mesh("flywheel", |_| {
        let mut m = MeshBuilder::new();
        m.add_cylinder(Vec3::new(-0.15, 0.0, 0.0), Vec3::new(0.15, 0.0, 0.0), 1.1, 36, true);
        bolts(&mut m, Vec3::new(0.15, 0.0, 0.0), Vec3::X, 0.5, 12, 0.04);
        m.add_box(Vec3::new(-0.3, -1.3, -1.3), Vec3::new(0.3, -1.0, 1.3));
        m
    });
    s.put(
        &format!("{tag} flywheel"),
        fly,
        c + Vec3::new(-len * 0.5 - 0.35, 1.5, 0.0),
        0.0,
    )?;
    Ok(())
}

/// A pump set along x: base plate, motor with fins, coupling guard, volute casing, stubs.
fn pump_mesh(rng: &mut Rng) -> MeshBuilder {
    let mut m = MeshBuilder::new();
    let r = rng.range(0.25, 0.4);
    m.add_box(Vec3::new(-1.0, 0.0, -0.45), Vec3::new(1.0, 0.15, 0.45));
    for (x, z) in [(-0.9, -0.38), (0.9, -0.38), (0.9, 0.38), (-0.9, 0.38)] {
        bolts(&mut m, Vec3::new(x, 0.15, z), Vec3::Y, 0.0, 1, 0.025);
    }
    let y = 0.2 + r;
    m.add_cylinder(Vec3::new(-0.95, y, 0.0), Vec3::new(0.05, y, 0.0), r, SEG, true);
    for k in 0..8 {
        let x = -0.85 + k as f32 * 0.11;
        m.add_cylinder(Vec3::new(x, y, 0.0), Vec3::new(x + 0.03, y, 0.0), r + 0.04, SEG, false);
    }
    m.add_box(Vec3::new(-0.4, y + r, -0.15), Vec3::new(-0.15, y + r + 0.2, 0.15));
    m.add_box(Vec3::new(0.05, y - 0.15, -0.15), Vec3::new(0.35, y + 0.15, 0.15));
    m.add_cylinder(Vec3::new(0.35, y, 0.0), Vec3::new(0.65, y, 0.0), r * 1.2, SEG + 4, true);
    bolts(&mut m, Vec3::new(0.65, y, 0.0), Vec3::X, r * 1.05, 12, 0.02);
    m.add_cylinder(Vec3::new(0.5, y, 0.0), Vec3::new(0.5, y + 0.9, 0.0), 0.1, SEG, false);
    flange(&mut m, Vec3::new(0.5, y + 0.9, 0.0), Vec3::Y, 0.1);
    m.add_pipe(
        &[
            Vec3::new(0.65, y, 0.0),
            Vec3::new(0.95, y, 0.0),
            Vec3::new(0.95, y, 0.8),
        ],
        0.12,
        0.25,
        SEG,
        6,
    );
    flange(&mut m, Vec3::new(0.95, y, 0.8), Vec3::Z, 0.12);
    m
}

fn valve_mesh(r: f32) -> MeshBuilder {
    let mut m = MeshBuilder::new();
    m.add_sphere(Vec3::ZERO, r * 1.6, SEG, 10);
    m.add_cylinder(
        Vec3::new(-r * 2.5, 0.0, 0.0),
        Vec3::new(r * 2.5, 0.0, 0.0),
        r,
        SEG,
        false,
    );
    flange(&mut m, Vec3::new(-r * 2.5, 0.0, 0.0), -Vec3::X, r);
    flange(&mut m, Vec3::new(r * 2.5, 0.0, 0.0), Vec3::X, r);
    m.add_cylinder(Vec3::ZERO, Vec3::new(0.0, r * 4.0, 0.0), r * 0.2, 8, false);
    m.add_torus(Vec3::new(0.0, r * 4.0, 0.0), Vec3::Y, r * 2.0, r * 0.2, SEG, 6);
    for k in 0..4 {
        let a = k as f32 * FRAC_PI_2;
        m.add_beam(
            Vec3::new(0.0, r * 4.0, 0.0),
            Vec3::new(a.cos() * r * 2.0, r * 4.0, a.sin() * r * 2.0),
            r * 0.12,
            r * 0.12,
        );
    }
    m
}

/// A vertical tank with domed head, legs, ladder and manhole.
fn tank_mesh(r: f32, h: f32) -> MeshBuilder {
    let mut m = MeshBuilder::new();
    m.add_cylinder(Vec3::new(0.0, 0.6, 0.0), Vec3::new(0.0, h, 0.0), r, 32, false);
    m.add_ellipsoid(Vec3::new(0.0, h, 0.0), Vec3::new(r, r * 0.4, r), 32, 12);
    m.add_ellipsoid(Vec3::new(0.0, 0.6, 0.0), Vec3::new(r, r * 0.3, r), 32, 12);
    for k in 0..4 {
        let a = k as f32 * FRAC_PI_2 + 0.4;
        let p = Vec3::new(a.cos(), 0.0, a.sin()) * (r * 0.85);
        m.add_beam(p, p + Vec3::Y * 1.0, 0.15, 0.15);
        m.add_box(p + Vec3::new(-0.2, 0.0, -0.2), p + Vec3::new(0.2, 0.03, 0.2));
    }
    // Ladder on +x side.
    for z in [-0.25, 0.25] {
        m.add_beam(Vec3::new(r + 0.2, 0.0, z), Vec3::new(r + 0.2, h + 0.5, z), 0.05, 0.07);
    }
    let mut y = 0.3;
    while y < h + 0.3 {
        m.add_cylinder(
            Vec3::new(r + 0.2, y, -0.25),
            Vec3::new(r + 0.2, y, 0.25),
            0.015,
            6,
            false,
        );
        y += 0.3;
    }
    // Manhole on -z side.
    let c = Vec3::new(0.0, 1.6, -r);
    m.add_cylinder(c, c - Vec3::Z * 0.25, 0.3, SEG + 4, false);
    m.add_cylinder(c - Vec3::Z * 0.25, c - Vec3::Z * 0.32, 0.38, SEG + 4, true);
    bolts(&mut m, c - Vec3::Z * 0.32, -Vec3::Z, 0.34, 16, 0.02);
    // Nozzles on top.
    for (x, z) in [(0.4, 0.0), (-0.3, 0.3)] {
        let top = Vec3::new(x * r, h + r * 0.35, z * r);
        m.add_cylinder(top, top + Vec3::Y * 0.4, 0.08, 12, false);
        flange(&mut m, top + Vec3::Y * 0.4, Vec3::Y, 0.08);
    }
    m
}

/// A horizontal shell-and-tube heat exchanger on saddles, along x.
fn exchanger_mesh(len: f32, r: f32) -> MeshBuilder {
    let mut m = MeshBuilder::new();
    let y = r + 0.5;
    m.add_cylinder(
        Vec3::new(-len * 0.5, y, 0.0),
        Vec3::new(len * 0.5, y, 0.0),
        r,
        32,
        false,
    );
    for s in [-1.0f32, 1.0] {
        let x = s * len * 0.5;
        m.add_cylinder(
            Vec3::new(x, y, 0.0),
            Vec3::new(x + s * 0.08, y, 0.0),
            r * 1.15,
            32,
            true,
        );
        bolts(&mut m, Vec3::new(x + s * 0.08, y, 0.0), Vec3::X * s, r * 1.07, 20, 0.02);
        m.add_ellipsoid(Vec3::new(x + s * 0.08, y, 0.0), Vec3::new(r * 0.5, r, r), 24, 10);
        let sx = s * len * 0.3;
        m.add_box(
            Vec3::new(sx - 0.15, 0.0, -r * 0.8),
            Vec3::new(sx + 0.15, y - r * 0.6, r * 0.8),
        );
        let n = Vec3::new(s * len * 0.35, y + r, 0.0);
        m.add_cylinder(n - Vec3::Y * 0.1, n + Vec3::Y * 0.3, 0.1, SEG, false);
        flange(&mut m, n + Vec3::Y * 0.3, Vec3::Y, 0.1);
    }
    m
}

fn cabinet_mesh(n: usize) -> MeshBuilder {
    let mut m = MeshBuilder::new();
    for k in 0..n {
        let x = k as f32 * 0.8;
        m.add_box(Vec3::new(x, 0.0, 0.0), Vec3::new(x + 0.78, 2.1, 0.6));
        m.add_box(Vec3::new(x + 0.05, 0.1, -0.02), Vec3::new(x + 0.73, 2.0, 0.0));
        for j in 0..6 {
            let p = Vec3::new(x + 0.2 + (j % 3) as f32 * 0.18, 1.5 - (j / 3) as f32 * 0.2, -0.02);
            m.add_cylinder(p, p - Vec3::Z * 0.04, 0.04, 10, true);
        }
        m.add_box(Vec3::new(x + 0.65, 0.9, -0.06), Vec3::new(x + 0.68, 1.2, -0.02));
    }
    m
}

pub(super) fn generate(seed: u64) -> Generated {
    let mut builder = SceneBuilder::new("machine-room");
    let mut s = Scene {
        b: &mut builder,
        rng: Rng::new(seed, 3),
        cache: HashMap::new(),
    };

    // Floor plates 3 m square, walls in stiffened 6 m panels, a beamed deck overhead.
    let plate = s.mesh("floor plate", |_| {
        let mut m = MeshBuilder::new();
        m.add_box(Vec3::new(0.0, -0.05, 0.0), Vec3::new(3.0, 0.0, 3.0));
        m
    });
    for i in 0..20 {
        for j in 0..10 {
            s.put(
                &format!("floor plate {i},{j}"),
                plate,
                Vec3::new(i as f32 * 3.0, 0.0, j as f32 * 3.0),
                0.0,
            )?;
        }
    }
    let wall = s.mesh("wall panel", |_| {
        let mut m = MeshBuilder::new();
        m.add_box(Vec3::new(0.0, 0.0, -0.02), Vec3::new(6.0, H, 0.0));
        for k in 0..9 {
            let x = 0.35 + k as f32 * 0.7;
            m.add_box(Vec3::new(x - 0.01, 0.0, 0.0), Vec3::new(x + 0.01, H, 0.2));
            m.add_box(Vec3::new(x - 0.06, 0.0, 0.18), Vec3::new(x + 0.06, H, 0.2));
        }
        for y in [2.6, 5.2] {
            m.add_box(Vec3::new(0.0, y - 0.15, 0.0), Vec3::new(6.0, y + 0.15, 0.35));
        }
        m
    });
    for k in 0..10 {
        let x = k as f32 * 6.0;
        s.put(&format!("wall panel s{k}"), wall, Vec3::new(x, 0.0, 0.0), 0.0)?;
        s.put(
            &format!("wall panel n{k}"),
            wall,
            Vec3::new(x + 6.0, 0.0, LZ),
            std::f32::consts::PI,
        )?;
    }
    for k in 0..5 {
        let z = k as f32 * 6.0;
        s.put(
            &format!("wall panel w{k}"),
            wall,
            Vec3::new(0.0, 0.0, z + 6.0),
            FRAC_PI_2,
        )?;
        s.put(&format!("wall panel e{k}"), wall, Vec3::new(LX, 0.0, z), -FRAC_PI_2)?;
    }
    let deck = s.mesh("deck section", |_| {
        let mut m = MeshBuilder::new();
        m.add_box(Vec3::new(0.0, H, 0.0), Vec3::new(6.0, H + 0.03, LZ));
        for k in 0..3 {
            let x = 1.0 + k as f32 * 2.0;
            // I-beam across the room.
            m.add_box(Vec3::new(x - 0.15, H - 0.04, 0.0), Vec3::new(x + 0.15, H, LZ));
            m.add_box(Vec3::new(x - 0.01, H - 0.56, 0.0), Vec3::new(x + 0.01, H - 0.04, LZ));
            m.add_box(Vec3::new(x - 0.15, H - 0.6, 0.0), Vec3::new(x + 0.15, H - 0.56, LZ));
        }
        m
    });
    for k in 0..10 {
        s.put(&format!("deck {k}"), deck, Vec3::new(k as f32 * 6.0, 0.0, 0.0), 0.0)?;
    }

    // Bays: engines, generator sets, pump groups, tanks, exchangers.
    let kinds = [
        "engine",
        "pumps",
        "tanks",
        "genset",
        "exchangers",
        "engine",
        "pumps",
        "tanks",
    ];
    let mut order: Vec<usize> = (0..8).collect();
    for i in (1..8).rev() {
        let j = s.rng.index(i + 1);
        order.swap(i, j);
    }
    for (bay, &k) in order.iter().enumerate() {
        let (x0, x1) = BAY_X[bay % 4];
        let (z0, z1) = BAY_Z[bay / 4];
        let c = Vec3::new((x0 + x1) * 0.5, 0.0, (z0 + z1) * 0.5);
        let tag = format!("bay {bay}");
        match kinds[k] {
            "engine" => {
                engine(&mut s, c, 8, &format!("{tag} main engine"))?;
                let filter = s.mesh("duplex filter", |_| {
                    let mut m = MeshBuilder::new();
                    for x in [-0.35, 0.35] {
                        m.add_cylinder(Vec3::new(x, 0.3, 0.0), Vec3::new(x, 1.3, 0.0), 0.25, SEG, true);
                        m.add_cylinder(Vec3::new(x, 1.3, 0.0), Vec3::new(x, 1.38, 0.0), 0.3, SEG, true);
                        bolts(&mut m, Vec3::new(x, 1.38, 0.0), Vec3::Y, 0.26, 12, 0.015);
                        m.add_beam(Vec3::new(x, 0.0, 0.0), Vec3::new(x, 0.3, 0.0), 0.3, 0.3);
                    }
                    m.add_pipe(
                        &[
                            Vec3::new(-0.35, 1.0, 0.0),
                            Vec3::new(-0.35, 1.0, -0.4),
                            Vec3::new(0.35, 1.0, -0.4),
                            Vec3::new(0.35, 1.0, 0.0),
                        ],
                        0.06,
                        0.15,
                        16,
                        4,
                    );
                    m.append(&valve_mesh(0.06), &Mat4::from_translation(Vec3::new(0.0, 1.0, -0.4)));
                    m
                });
                for (k, dx) in [-4.5f32, -1.5, 1.5, 4.5].into_iter().enumerate() {
                    let z = if c.z < MAIN_Z { z0 + 0.6 } else { z1 - 0.6 };
                    s.put(
                        &format!("{tag} duplex filter {k}"),
                        filter,
                        Vec3::new(c.x + dx, 0.0, z),
                        0.0,
                    )?;
                }
            }
            "genset" => {
                engine(&mut s, c + Vec3::new(-1.5, 0.0, -2.2), 6, &format!("{tag} genset A"))?;
                engine(&mut s, c + Vec3::new(-1.5, 0.0, 2.6), 6, &format!("{tag} genset B"))?;
            }
            "pumps" => {
                for i in 0..4 {
                    for j in 0..3 {
                        let v = s.rng.index(4);
                        let pump = s.mesh(&format!("pump {v}"), pump_mesh);
                        let at = Vec3::new(x0 + 1.6 + i as f32 * 2.8, 0.0, z0 + 1.4 + j as f32 * 3.4);
                        s.put(&format!("{tag} pump {i},{j}"), pump, at, 0.0)?;
                        // Riser from the discharge up to the overhead header.
                        let y = 0.2 + 0.4 + 0.9;
                        let mut m = bent_spool(
                            &[
                                at + Vec3::new(0.5, y, 0.0),
                                at + Vec3::new(0.5, 4.2, 0.0),
                                at + Vec3::new(0.5, 4.2, 1.2),
                            ],
                            0.1,
                        );
                        let valve = valve_mesh(0.1);
                        m.append(
                            &valve,
                            &Mat4::from_rotation_translation(
                                Quat::from_rotation_z(FRAC_PI_2),
                                at + Vec3::new(0.5, 2.6, 0.0),
                            ),
                        );
                        s.unique(&format!("{tag} pump riser {i},{j}"), m)?;
                    }
                }
            }
            "tanks" => {
                for i in 0..3 {
                    let r = s.rng.range(1.3, 1.7);
                    let h = s.rng.range(4.0, 5.5);
                    let tank = s.mesh(&format!("tank {:.1} {:.1}", r, h), |_| tank_mesh(r, h));
                    let at = Vec3::new(
                        x0 + 2.0 + i as f32 * 3.9,
                        0.0,
                        (z0 + z1) * 0.5 + if i % 2 == 0 { -1.5 } else { 1.5 },
                    );
                    s.put(&format!("{tag} tank {i}"), tank, at, 0.0)?;
                }
            }
            _ => {
                for j in 0..3 {
                    let ex = s.mesh("heat exchanger", |_| exchanger_mesh(6.0, 0.55));
                    s.put(
                        &format!("{tag} heat exchanger {j}"),
                        ex,
                        Vec3::new(c.x - 1.0, 0.0, z0 + 1.7 + j as f32 * 3.3),
                        0.0,
                    )?;
                }
                let cab = s.mesh("switchboard", |_| cabinet_mesh(4));
                s.put(
                    &format!("{tag} switchboard"),
                    cab,
                    Vec3::new(x1 - 0.7, 0.0, z0 + 0.6),
                    -FRAC_PI_2,
                )?;
            }
        }
        // Railing along the aisle side of the bay.
        let rz = if bay / 4 == 0 { z1 - 0.1 } else { z0 + 0.1 };
        let mut m = MeshBuilder::new();
        let mut x = x0 + 0.2;
        while x < x1 - 0.1 {
            m.add_cylinder(Vec3::new(x, 0.0, rz), Vec3::new(x, 1.1, rz), 0.025, 8, false);
            x += 1.5;
        }
        for y in [0.55, 1.1] {
            m.add_cylinder(Vec3::new(x0 + 0.2, y, rz), Vec3::new(x1 - 0.2, y, rz), 0.025, 8, false);
        }
        s.unique(&format!("{tag} railing"), m)?;
        // Control cabinets against the side wall for bays next to it.
        let cab = s.mesh("control cabinet", |_| cabinet_mesh(2));
        let (cz, yaw) = if bay / 4 == 0 {
            (z0 + 0.05, 0.0)
        } else {
            (z1 - 0.05, std::f32::consts::PI)
        };
        let _ = cz;
        let _ = yaw;
        let _ = cab;
    }

    // Overhead pipe runs: lines along x made of 6 m spools, hangers every spool.
    let lines: Vec<(f32, f32, f32)> = (0..14)
        .map(|k| {
            let z = 3.5 + k as f32 * 1.8 + if k >= 7 { 1.0 } else { 0.0 };
            let r = [0.08, 0.12, 0.16, 0.2, 0.1, 0.25][k % 6];
            // Each line rests on one of three trapeze bars.
            let y = 5.0 + (k % 3) as f32 * 0.7 + 0.05 + r;
            (z, y, r)
        })
        .collect();
    for (k, &(z, y, r)) in lines.iter().enumerate() {
        let sp = s.mesh(&format!("spool 6 m r{r}"), |_| spool(6.0, r));
        let valve = s.mesh(&format!("gate valve r{r}"), |_| valve_mesh(r));
        for i in 0..9 {
            let x = 2.5 + i as f32 * 6.0;
            if i > 0 && s.rng.chance(0.45) {
                // A valve in place of the first metre of the spool.
                s.put(
                    &format!("pipe line {k} valve {i}"),
                    valve,
                    Vec3::new(x + r * 2.5 + 0.06, y, z),
                    0.0,
                )?;
            }
            s.put(&format!("pipe line {k} spool {i}"), sp, Vec3::new(x, y, z), 0.0)?;
        }
        // Elbow spools turning down at the east end into the bay below.
        let e = bent_spool(
            &[Vec3::new(56.5, y, z), Vec3::new(57.6, y, z), Vec3::new(57.6, 3.4, z)],
            r,
        );
        if !(13.0..17.0).contains(&z) {
            s.unique(&format!("pipe line {k} drop"), e)?;
        }
    }
    // Cross runs along z over the cross aisles, higher up.
    for (k, &x) in CROSS_X.iter().enumerate() {
        for (j, (dx, r)) in [(-0.5, 0.15), (0.5, 0.1)].into_iter().enumerate() {
            let sp = s.mesh(&format!("spool 6 m r{r}"), |_| spool(6.0, r));
            for i in 0..4 {
                let z = 3.0 + i as f32 * 6.0;
                s.put(
                    &format!("cross line {k}.{j} spool {i}"),
                    sp,
                    Vec3::new(x + dx, 7.1, z + 6.0),
                    FRAC_PI_2,
                )?;
            }
        }
    }
    // Hangers: trapezes (rods, three bars, U-bolts round each line) every 3 m per group.
    for g in 0..2 {
        let group: Vec<(f32, f32, f32)> = lines[g * 7..g * 7 + 7].to_vec();
        let z0 = group[0].0 - 0.3;
        let z1 = group[6].0 + 0.3;
        let hanger = s.mesh(&format!("pipe hanger {g}"), |_| {
            let mut m = MeshBuilder::new();
            for z in [z0, z1] {
                m.add_cylinder(Vec3::new(0.0, 4.9, z), Vec3::new(0.0, H - 0.6, z), 0.02, 6, false);
            }
            for k in 0..3 {
                let y = 5.0 + k as f32 * 0.7;
                m.add_box(Vec3::new(-0.05, y - 0.1, z0 - 0.05), Vec3::new(0.05, y, z1 + 0.05));
            }
            for &(z, y, r) in &group {
                m.add_torus(Vec3::new(0.0, y, z), Vec3::X, r + 0.015, 0.01, 16, 4);
            }
            m
        });
        for i in 0..19 {
            let x = 2.0 + i as f32 * 3.0;
            s.put(&format!("pipe hanger {g}.{i}"), hanger, Vec3::new(x, 0.0, 0.0), 0.0)?;
        }
    }
    // Small-bore lines along the long walls on brackets, and junction boxes with glands.
    let bracket = s.mesh("wall bracket", |_| {
        let mut m = MeshBuilder::new();
        m.add_box(Vec3::new(-0.04, 0.0, 0.0), Vec3::new(0.04, 1.3, 0.02));
        for k in 0..4 {
            let y = 0.15 + k as f32 * 0.35;
            m.add_beam(Vec3::new(0.0, y, 0.0), Vec3::new(0.0, y, 0.42), 0.05, 0.05);
            m.add_torus(Vec3::new(0.0, y + 0.09, 0.3), Vec3::X, 0.065, 0.006, 12, 4);
            bolts(&mut m, Vec3::new(0.0, y, 0.02), Vec3::Z, 0.0, 1, 0.012);
        }
        m
    });
    let jbox = s.mesh("junction box", |_| {
        let mut m = MeshBuilder::new();
        m.add_box(Vec3::new(-0.25, -0.3, 0.0), Vec3::new(0.25, 0.3, 0.18));
        for k in 0..4 {
            bolts(
                &mut m,
                Vec3::new(-0.2 + (k % 2) as f32 * 0.4, -0.25 + (k / 2) as f32 * 0.5, 0.18),
                Vec3::Z,
                0.0,
                1,
                0.01,
            );
        }
        for k in 0..5 {
            let x = -0.16 + k as f32 * 0.08;
            m.add_cylinder(Vec3::new(x, -0.3, 0.09), Vec3::new(x, -0.38, 0.09), 0.02, 8, true);
            m.add_cylinder(Vec3::new(x, -0.38, 0.09), Vec3::new(x, -1.4, 0.09), 0.01, 6, false);
        }
        m
    });
    let small = s.mesh("small bore spool", |_| spool(6.0, 0.05));
    for (side, z, yaw) in [(0, 0.35, 0.0), (1, LZ - 0.35, std::f32::consts::PI)] {
        let out = if side == 0 { 1.0 } else { -1.0 };
        for i in 0..38 {
            let x = 1.5 + i as f32 * 1.5;
            s.put(&format!("wall bracket {side}.{i}"), bracket, Vec3::new(x, 2.0, z), yaw)?;
            if i % 2 == 0 {
                s.put(
                    &format!("junction box {side}.{i}"),
                    jbox,
                    Vec3::new(x + 0.75, 1.7, z - out * 0.15),
                    yaw,
                )?;
            }
        }
        for k in 0..4 {
            let y = 2.0 + 0.15 + k as f32 * 0.35 + 0.09;
            for i in 0..9 {
                s.put(
                    &format!("wall line {side}.{k} spool {i}"),
                    small,
                    Vec3::new(1.5 + i as f32 * 6.0, y, z + out * 0.3),
                    0.0,
                )?;
            }
        }
    }
    // Cable trays at 3.3 m along x over each row of bays.
    let tray = s.mesh("cable tray", |_| {
        let mut m = MeshBuilder::new();
        for z in [-0.3, 0.3] {
            m.add_box(Vec3::new(0.0, 0.0, z - 0.01), Vec3::new(6.0, 0.12, z + 0.01));
        }
        let mut x = 0.15;
        while x < 6.0 {
            m.add_box(Vec3::new(x - 0.02, 0.0, -0.3), Vec3::new(x + 0.02, 0.02, 0.3));
            x += 0.3;
        }
        for k in 0..6 {
            let z = -0.25 + k as f32 * 0.1;
            m.add_cylinder(Vec3::new(0.0, 0.05, z), Vec3::new(6.0, 0.05, z), 0.03, 8, false);
        }
        m.add_cylinder(Vec3::new(3.0, 0.12, 0.0), Vec3::new(3.0, H - 3.3, 0.0), 0.015, 6, false);
        m
    });
    for i in 0..9 {
        for (g, z) in [(0, 12.5), (1, 17.5)] {
            s.put(
                &format!("cable tray {g}.{i}"),
                tray,
                Vec3::new(2.5 + i as f32 * 6.0, CLEAR + 0.4, z),
                0.0,
            )?;
        }
    }

    // The walk: main aisle, cross aisles and the side aisles.
    let p = |x: f32, z: f32| Vec3::new(x, EYE, z);
    let pts = [
        p(1.2, MAIN_Z),
        p(CROSS_X[0], MAIN_Z),
        p(CROSS_X[0], SIDE_Z[0]),
        p(CROSS_X[2], SIDE_Z[0]),
        p(CROSS_X[2], SIDE_Z[1]),
        p(CROSS_X[1], SIDE_Z[1]),
        p(CROSS_X[1], MAIN_Z),
        p(56.0, MAIN_Z),
    ];
    let smooth = round_corners(&pts, 1.2, 0.3);
    let path = CameraPath::along(&smooth, 0.55, 4.0);
    Ok(Builtin {
        scene: builder.build()?,
        path,
        animation: Animation::none(),
    })
}
