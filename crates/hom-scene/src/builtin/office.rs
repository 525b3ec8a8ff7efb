//! `office`: one floor of an office building in the spirit of the Soda Hall floor used by
//! Bittner & Havran — three rows of rooms along two corridors joined by cross corridors,
//! walls as boxes with door openings (each wall piece and lintel its own object),
//! exterior walls with window openings, and furnished rooms (desks, chairs, computers,
//! bookshelves full of books, meeting tables, plants). The camera walks the corridors
//! and steps into four rooms.

use super::rng::Rng;
use super::shapes::MeshBuilder;
use super::{round_corners, Builtin, Generated};
use crate::camera_path::CameraPath;
use crate::motion::Animation;
use glam::{Mat4, Quat, Vec3};
use hom::scene::{MeshId, SceneBuilder, SceneError};
use std::f32::consts::{FRAC_PI_2, PI};

/// Building length (x) and depth (z).
const LEN: f32 = 72.0;
const DEPTH: f32 = 36.0;
/// Storey height (floor to ceiling).
const STOREY: f32 = 3.0;
/// Exterior and interior wall thickness.
const EXT: f32 = 0.3;
const INT: f32 = 0.15;
/// Corridor width.
const CORRIDOR: f32 = 2.4;
/// Door opening width and height.
const DOOR_W: f32 = 1.1;
const DOOR_H: f32 = 2.1;
/// Eye height.
const EYE: f32 = 1.6;

/// The z bands: row A rooms, corridor 1, row B rooms, corridor 2, row C rooms.
const C1: f32 = 10.8; // corridor 1 spans C1..C1+CORRIDOR
const C2: f32 = 22.8; // corridor 2 spans C2..C2+CORRIDOR
/// Cross corridors through row B (x start of each, width CORRIDOR).
const CROSS: [f32; 3] = [EXT, 34.8, LEN - EXT - CORRIDOR];

/// A room: interior rectangle, the z of its door wall's corridor face, and door centre x.
#[derive(Clone, Copy, Debug)]
struct Room {
    x0: f32,
    x1: f32,
    z0: f32,
    z1: f32,
    /// +1 when the door is on the room's max-z side, -1 on its min-z side.
    door_side: f32,
    door_x: f32,
}

impl Room {
    /// z of the door opening's centre line (in the door wall).
    fn door_z(&self) -> f32 {
        if self.door_side > 0.0 {
            self.z1 + INT * 0.5
        } else {
            self.z0 - INT * 0.5
        }
    }
}

struct Furniture {
    desk: MeshId,
    chair: MeshId,
    computer: MeshId,
    shelves: Vec<MeshId>,
    table: MeshId,
    plant: MeshId,
    cabinet: MeshId,
    light: MeshId,
    whiteboard: MeshId,
}

fn furniture(b: &mut SceneBuilder, rng: &mut Rng) -> Furniture {
    // Desk 1.6 x 0.8, front edge towards -z (the user sits at -z), origin at floor centre.
    let mut desk = MeshBuilder::new();
    desk.add_box(Vec3::new(-0.8, 0.72, -0.4), Vec3::new(0.8, 0.75, 0.4));
    desk.add_box(Vec3::new(-0.8, 0.0, -0.38), Vec3::new(-0.77, 0.72, 0.38));
    desk.add_box(Vec3::new(0.77, 0.0, -0.38), Vec3::new(0.8, 0.72, 0.38));
    desk.add_box(Vec3::new(-0.77, 0.3, 0.33), Vec3::new(0.77, 0.72, 0.35));
    desk.add_box(Vec3::new(0.3, 0.0, -0.35), Vec3::new(0.75, 0.68, 0.3));
    for y in [0.2, 0.42, 0.6] {
        desk.add_box(Vec3::new(0.45, y, -0.37), Vec3::new(0.6, y + 0.02, -0.35));
    }
    let desk = b.add_mesh(desk.build("desk"));
    // Office chair facing +z, origin at floor centre.
    let mut chair = MeshBuilder::new();
    chair.add_box(Vec3::new(-0.24, 0.44, -0.24), Vec3::new(0.24, 0.5, 0.22));
    chair.add_box(Vec3::new(-0.22, 0.55, -0.3), Vec3::new(0.22, 1.05, -0.25));
    chair.add_beam(Vec3::new(0.0, 0.5, -0.27), Vec3::new(0.0, 0.6, -0.27), 0.05, 0.03);
    for x in [-0.26, 0.26] {
        chair.add_box(Vec3::new(x - 0.025, 0.62, -0.18), Vec3::new(x + 0.025, 0.65, 0.12));
        chair.add_beam(Vec3::new(x, 0.5, 0.0), Vec3::new(x, 0.62, 0.0), 0.03, 0.03);
    }
    chair.add_cylinder(Vec3::new(0.0, 0.1, 0.0), Vec3::new(0.0, 0.44, 0.0), 0.03, 8, false);
    for k in 0..5 {
        let a = k as f32 / 5.0 * 2.0 * PI;
        let tip = Vec3::new(a.cos() * 0.3, 0.08, a.sin() * 0.3);
        chair.add_beam(Vec3::new(0.0, 0.1, 0.0), tip, 0.04, 0.03);
        chair.add_cylinder(
            tip - Vec3::new(0.0, 0.03, 0.02),
            tip - Vec3::new(0.0, 0.03, -0.02),
            0.03,
            6,
            true,
        );
    }
    let chair = b.add_mesh(chair.build("office chair"));
    let mut pc = MeshBuilder::new();
    pc.add_box(Vec3::new(-0.28, 0.9, 0.12), Vec3::new(0.28, 1.22, 0.15));
    pc.add_box(Vec3::new(-0.04, 0.76, 0.15), Vec3::new(0.04, 0.92, 0.18));
    pc.add_box(Vec3::new(-0.12, 0.75, 0.08), Vec3::new(0.12, 0.76, 0.24));
    pc.add_box(Vec3::new(-0.23, 0.75, -0.25), Vec3::new(0.23, 0.77, -0.08));
    pc.add_box(Vec3::new(0.3, 0.75, -0.2), Vec3::new(0.36, 0.77, -0.1));
    pc.add_box(Vec3::new(-0.7, 0.0, -0.1), Vec3::new(-0.5, 0.45, 0.35));
    let computer = b.add_mesh(pc.build("computer"));
    // Bookshelves 1.0 wide, 0.35 deep, 2.0 tall, front towards -z; books vary per variant.
    let mut shelves = Vec::new();
    for v in 0..6 {
        let mut s = MeshBuilder::new();
        s.add_box(Vec3::new(-0.5, 0.0, -0.17), Vec3::new(-0.48, 2.0, 0.17));
        s.add_box(Vec3::new(0.48, 0.0, -0.17), Vec3::new(0.5, 2.0, 0.17));
        s.add_box(Vec3::new(-0.48, 0.0, 0.15), Vec3::new(0.48, 2.0, 0.17));
        for k in 0..=5 {
            let y = k as f32 * 0.39;
            s.add_box(Vec3::new(-0.48, y, -0.17), Vec3::new(0.48, y + 0.02, 0.15));
            if k == 5 {
                break;
            }
            let mut x = -0.47;
            while x < 0.45 {
                let t = rng.range(0.02, 0.06);
                if x + t > 0.47 {
                    break;
                }
                if rng.chance(0.1 + 0.05 * v as f32) {
                    x += t;
                    continue;
                }
                let h = rng.range(0.18, 0.33);
                let d = rng.range(0.15, 0.26);
                s.add_box(Vec3::new(x, y + 0.02, 0.14 - d), Vec3::new(x + t, y + 0.02 + h, 0.14));
                x += t + 0.002;
            }
        }
        shelves.push(b.add_mesh(s.build(format!("bookshelf {v}"))));
    }
    let mut t = MeshBuilder::new();
    t.add_box(Vec3::new(-1.2, 0.72, -0.6), Vec3::new(1.2, 0.76, 0.6));
    for (x, z) in [(-1.1, -0.5), (1.1, -0.5), (1.1, 0.5), (-1.1, 0.5)] {
        t.add_cylinder(Vec3::new(x, 0.0, z), Vec3::new(x, 0.72, z), 0.03, 8, false);
    }
    let table = b.add_mesh(t.build("meeting table"));
    let mut p = MeshBuilder::new();
    p.add_cone(Vec3::ZERO, Vec3::new(0.0, 0.4, 0.0), 0.15, 0.2, 10, true);
    for k in 0..7 {
        let a = k as f32 / 7.0 * 2.0 * PI;
        let tip = Vec3::new(a.cos() * 0.35, 0.9 + 0.1 * (k % 3) as f32, a.sin() * 0.35);
        p.add_ellipsoid(
            Vec3::new(0.0, 0.4, 0.0).lerp(tip, 0.6),
            Vec3::new(0.12, 0.25, 0.12),
            6,
            4,
        );
    }
    let plant = b.add_mesh(p.build("plant"));
    let mut c = MeshBuilder::new();
    c.add_box(Vec3::new(-0.4, 0.0, -0.25), Vec3::new(0.4, 1.3, 0.25));
    for y in [0.25, 0.65, 1.05] {
        c.add_box(Vec3::new(-0.15, y, -0.27), Vec3::new(0.15, y + 0.03, -0.25));
    }
    let cabinet = b.add_mesh(c.build("filing cabinet"));
    let mut l = MeshBuilder::new();
    l.add_box(Vec3::new(-0.6, -0.08, -0.3), Vec3::new(0.6, 0.0, 0.3));
    let light = b.add_mesh(l.build("ceiling light"));
    let mut w = MeshBuilder::new();
    w.add_box(Vec3::new(-0.9, 0.9, -0.02), Vec3::new(0.9, 2.0, 0.0));
    w.add_box(Vec3::new(-0.9, 0.86, -0.08), Vec3::new(0.9, 0.9, 0.0));
    let whiteboard = b.add_mesh(w.build("whiteboard"));
    Furniture {
        desk,
        chair,
        computer,
        shelves,
        table,
        plant,
        cabinet,
        light,
        whiteboard,
    }
}

/// Adds a box-shaped object (a wall piece, slab…) using the shared unit cube scaled into place.
fn add_box(b: &mut SceneBuilder, cube: MeshId, name: String, min: Vec3, max: Vec3) -> Result<u32, SceneError> {
    b.add_object(
        name,
        cube,
        Mat4::from_scale_rotation_translation(max - min, Quat::IDENTITY, min),
    )
}

fn place(b: &mut SceneBuilder, name: &str, mesh: MeshId, at: Vec3, yaw: f32) -> Result<u32, SceneError> {
    b.add_object(
        name,
        mesh,
        Mat4::from_rotation_translation(Quat::from_rotation_y(yaw), at),
    )
}

/// A row of rooms: its letter, z range, and the x spans it is cut into.
type Row = (char, f32, f32, Vec<(f32, f32)>);

/// Splits `x0..x1` into room widths on a 1.2 m grid.
fn cut_rooms(rng: &mut Rng, x0: f32, x1: f32) -> Vec<(f32, f32)> {
    let mut out = Vec::new();
    let mut x = x0;
    while x1 - x > 8.4 {
        let w = 1.2 * rng.int(3, 7) as f32;
        out.push((x, x + w));
        x += w;
    }
    if x1 - x > 4.8 && rng.chance(0.5) {
        let m = x + ((x1 - x) / 2.4).floor() * 1.2;
        out.push((x, m));
        x = m;
    }
    out.push((x, x1));
    out
}

/// Furnishes a room. `visit` keeps the door half clear for the camera.
fn furnish(b: &mut SceneBuilder, f: &Furniture, rng: &mut Rng, r: &Room, name: &str) -> Result<(), SceneError> {
    let (w, d) = (r.x1 - r.x0, r.z1 - r.z0);
    // Local frame: u along the room's width (x), "in" from the door into the room.
    let inward = -r.door_side; // +1: room extends towards +z from its door wall
    let far_z = if inward > 0.0 { r.z1 } else { r.z0 };
    let near_z = if inward > 0.0 { r.z0 } else { r.z1 };
    let face_door = if inward > 0.0 { PI } else { 0.0 }; // yaw turning local -z to face the door
    let at = |x: f32, depth: f32| Vec3::new(x, 0.0, near_z + inward * depth);
    let _ = far_z;
    // Desks along the far wall, users facing the wall.
    let n = ((w - 0.6) / 1.9).floor().max(1.0) as usize;
    for k in 0..n {
        let x = r.x0 + (w - (n as f32 - 1.0) * 1.9) * 0.5 + k as f32 * 1.9;
        let desk_yaw = face_door + PI; // front (-z local) faces away from the far wall
        place(b, &format!("{name} desk"), f.desk, at(x, d - 0.45), desk_yaw)?;
        place(b, &format!("{name} computer"), f.computer, at(x, d - 0.45), desk_yaw)?;
        let jitter = rng.range(-0.4, 0.4);
        place(
            b,
            &format!("{name} chair"),
            f.chair,
            at(x + rng.range(-0.15, 0.15), d - 1.3),
            desk_yaw + PI + jitter,
        )?;
    }
    // Bookshelves and cabinets along both side walls, away from the door lane.
    for (wall_x, yaw) in [(r.x0 + 0.2, FRAC_PI_2), (r.x1 - 0.2, -FRAC_PI_2)] {
        if (wall_x - r.door_x).abs() < 2.6 {
            continue;
        }
        let mut depth = 0.8;
        while depth < d - 1.8 {
            let mesh = if rng.chance(0.8) {
                f.shelves[rng.index(f.shelves.len())]
            } else {
                f.cabinet
            };
            let kind = if mesh == f.cabinet {
                "filing cabinet"
            } else {
                "bookshelf"
            };
            place(b, &format!("{name} {kind}"), mesh, at(wall_x, depth + 0.5), yaw)?;
            depth += 1.05;
        }
    }
    // A pair of facing desks in the middle of narrower rooms (clear of the first 4.5 m).
    if w < 5.9 && d >= 8.0 {
        let x = (r.x0 + r.x1) * 0.5;
        for (depth, yaw) in [(5.6, face_door), (6.4, face_door + PI)] {
            place(b, &format!("{name} desk"), f.desk, at(x, depth), yaw)?;
            place(b, &format!("{name} computer"), f.computer, at(x, depth), yaw)?;
            let back = if yaw == face_door { -0.85 } else { 0.85 };
            place(
                b,
                &format!("{name} chair"),
                f.chair,
                at(x + rng.range(-0.2, 0.2), depth + back),
                yaw + PI + rng.range(-0.4, 0.4),
            )?;
        }
    }
    // A meeting table in the middle of wide rooms, chairs round it.
    if w >= 5.9 && d >= 8.0 {
        let c = Vec3::new(
            (r.x0 + r.x1) * 0.5 + if r.door_x < (r.x0 + r.x1) * 0.5 { 1.0 } else { -1.0 },
            0.0,
            near_z + inward * (d * 0.5 + 0.6),
        );
        place(b, &format!("{name} meeting table"), f.table, c, 0.0)?;
        for (dx, dz, yaw) in [(-0.6, -0.95, 0.0), (0.6, -0.95, 0.0), (-0.6, 0.95, PI), (0.6, 0.95, PI)] {
            place(
                b,
                &format!("{name} chair"),
                f.chair,
                c + Vec3::new(dx, 0.0, dz),
                yaw + rng.range(-0.3, 0.3),
            )?;
        }
        place(
            b,
            &format!("{name} whiteboard"),
            f.whiteboard,
            Vec3::new(if r.door_x < (r.x0 + r.x1) * 0.5 { r.x1 } else { r.x0 }, 0.0, c.z),
            if r.door_x < (r.x0 + r.x1) * 0.5 {
                -FRAC_PI_2
            } else {
                FRAC_PI_2
            },
        )?;
    }
    // A plant in a near corner away from the door.
    let px = if r.door_x - r.x0 > r.x1 - r.door_x {
        r.x0 + 0.4
    } else {
        r.x1 - 0.4
    };
    place(b, &format!("{name} plant"), f.plant, at(px, 0.4), 0.0)?;
    // Ceiling lights.
    let lights = ((d / 3.0).floor() as usize).max(1);
    for k in 0..lights {
        let z = near_z + inward * ((k as f32 + 0.5) * d / lights as f32);
        place(
            b,
            &format!("{name} ceiling light"),
            f.light,
            Vec3::new((r.x0 + r.x1) * 0.5, STOREY, z),
            0.0,
        )?;
    }
    Ok(())
}

/// A wall along x at `z0..z1` (thickness), from `x0` to `x1`, with door gaps (centre x).
fn wall_x(
    b: &mut SceneBuilder,
    cube: MeshId,
    name: &str,
    (x0, x1): (f32, f32),
    (z0, z1): (f32, f32),
    doors: &[f32],
) -> Result<(), SceneError> {
    let mut doors = doors.to_vec();
    doors.sort_by(f32::total_cmp);
    let mut x = x0;
    for (k, &dx) in doors.iter().enumerate() {
        let (a, c) = (dx - DOOR_W * 0.5, dx + DOOR_W * 0.5);
        if a > x {
            add_box(
                b,
                cube,
                format!("{name} wall {k}"),
                Vec3::new(x, 0.0, z0),
                Vec3::new(a, STOREY, z1),
            )?;
        }
        add_box(
            b,
            cube,
            format!("{name} lintel {k}"),
            Vec3::new(a, DOOR_H, z0),
            Vec3::new(c, STOREY, z1),
        )?;
        x = c;
    }
    if x1 > x {
        add_box(
            b,
            cube,
            format!("{name} wall {}", doors.len()),
            Vec3::new(x, 0.0, z0),
            Vec3::new(x1, STOREY, z1),
        )?;
    }
    Ok(())
}

/// An exterior wall section mesh `len` long along local +x, `EXT` thick towards +z,
/// with windows every 1.8 m (sill 0.9 m, head 2.4 m).
fn facade_mesh(len: f32) -> MeshBuilder {
    let mut m = MeshBuilder::new();
    let n = (len / 1.8).floor().max(1.0) as usize;
    let step = len / n as f32;
    let pier = 0.5;
    m.add_box(Vec3::new(0.0, 0.0, 0.0), Vec3::new(len, 0.9, EXT));
    m.add_box(Vec3::new(0.0, 2.4, 0.0), Vec3::new(len, STOREY, EXT));
    for k in 0..=n {
        let x = (k as f32 * step - pier * 0.5).clamp(0.0, len - pier);
        m.add_box(Vec3::new(x, 0.9, 0.0), Vec3::new(x + pier, 2.4, EXT));
        if k < n {
            // Window frame mullion and sill.
            m.add_box(
                Vec3::new(x + step * 0.5 - 0.03 + pier * 0.5, 0.9, EXT * 0.4),
                Vec3::new(x + step * 0.5 + 0.03 + pier * 0.5, 2.4, EXT * 0.6),
            );
            m.add_box(Vec3::new(x + pier, 0.86, -0.12), Vec3::new(x + step, 0.9, EXT));
        }
    }
    m
}

pub(super) fn generate(seed: u64) -> Generated {
    let mut rng = Rng::new(seed, 5);
    let mut b = SceneBuilder::new("office");
    let mut cube = MeshBuilder::new();
    cube.add_box(Vec3::ZERO, Vec3::ONE);
    let cube = b.add_mesh(cube.build("unit box"));
    let f = furniture(&mut b, &mut rng);

    // Rooms per row. Row A: z EXT..C1-INT (door +z); row C: C2+CORRIDOR+INT..DEPTH-EXT (door -z);
    // row B between the corridors, split by the cross corridors, door on either side.
    let mut rooms: Vec<(String, Room)> = Vec::new();
    let mut partitions: Vec<(f32, f32, f32)> = Vec::new(); // x centre, z0, z1
    let rows: [Row; 3] = [
        ('A', EXT, C1 - INT, vec![(EXT, LEN - EXT)]),
        (
            'B',
            C1 + CORRIDOR + INT,
            C2 - INT,
            vec![
                (CROSS[0] + CORRIDOR + INT, CROSS[1] - INT),
                (CROSS[1] + CORRIDOR + INT, CROSS[2] - INT),
            ],
        ),
        ('C', C2 + CORRIDOR + INT, DEPTH - EXT, vec![(EXT, LEN - EXT)]),
    ];
    for (row, z0, z1, spans) in &rows {
        let mut k = 0;
        for &(sx0, sx1) in spans {
            let cuts = cut_rooms(&mut rng, sx0, sx1);
            for (i, &(a, c)) in cuts.iter().enumerate() {
                let x0 = if i == 0 { a } else { a + INT * 0.5 };
                let x1 = if i + 1 == cuts.len() { c } else { c - INT * 0.5 };
                if i + 1 < cuts.len() {
                    partitions.push((c, *z0, *z1));
                }
                let door_side = match row {
                    'A' => 1.0,
                    'C' => -1.0,
                    _ => {
                        if k % 2 == 0 {
                            -1.0
                        } else {
                            1.0
                        }
                    }
                };
                let door_x = rng.range(x0 + 0.5 + DOOR_W * 0.5, x1 - 0.5 - DOOR_W * 0.5);
                rooms.push((
                    format!("room {row}{k}"),
                    Room {
                        x0,
                        x1,
                        z0: *z0,
                        z1: *z1,
                        door_side,
                        door_x,
                    },
                ));
                k += 1;
            }
        }
    }

    // Exterior walls with windows, one object per ~7 m section.
    for (along_x, fixed, len) in [
        (true, 0.0, LEN),
        (true, DEPTH - EXT, LEN),
        (false, 0.0, DEPTH),
        (false, LEN - EXT, DEPTH),
    ] {
        let n = (len / 7.2).round() as usize;
        let sec = len / n as f32;
        let mesh = b.add_mesh(facade_mesh(sec).build(format!("facade section {sec:.1} m")));
        for k in 0..n {
            let s = k as f32 * sec;
            let xf = if along_x {
                Mat4::from_translation(Vec3::new(s, 0.0, fixed))
            } else {
                // Local +x → world +z, local +z (thickness) → world -x: shift by EXT.
                Mat4::from_rotation_translation(Quat::from_rotation_y(-FRAC_PI_2), Vec3::new(fixed + EXT, 0.0, s))
            };
            b.add_object(
                format!("exterior wall {}{k}", if along_x { "x" } else { "z" }),
                mesh,
                xf,
            )?;
        }
    }
    // Corridor walls with doors.
    let doors_on = |side: f32, row: char| -> Vec<f32> {
        rooms
            .iter()
            .filter(|(n, r)| n.starts_with(&format!("room {row}")) && r.door_side == side)
            .map(|(_, r)| r.door_x)
            .collect()
    };
    wall_x(
        &mut b,
        cube,
        "corridor 1 north",
        (EXT, LEN - EXT),
        (C1 - INT, C1),
        &doors_on(1.0, 'A'),
    )?;
    wall_x(
        &mut b,
        cube,
        "corridor 2 south",
        (EXT, LEN - EXT),
        (C2 + CORRIDOR, C2 + CORRIDOR + INT),
        &doors_on(-1.0, 'C'),
    )?;
    for (k, &(sx0, sx1)) in rows[1].3.iter().enumerate() {
        let d1: Vec<f32> = doors_on(-1.0, 'B')
            .into_iter()
            .filter(|x| (sx0..sx1).contains(x))
            .collect();
        let d2: Vec<f32> = doors_on(1.0, 'B')
            .into_iter()
            .filter(|x| (sx0..sx1).contains(x))
            .collect();
        wall_x(
            &mut b,
            cube,
            &format!("corridor 1 south {k}"),
            (sx0 - INT, sx1 + INT),
            (C1 + CORRIDOR, C1 + CORRIDOR + INT),
            &d1,
        )?;
        wall_x(
            &mut b,
            cube,
            &format!("corridor 2 north {k}"),
            (sx0 - INT, sx1 + INT),
            (C2 - INT, C2),
            &d2,
        )?;
        // Row B end walls along the cross corridors.
        for x in [sx0 - INT, sx1] {
            add_box(
                &mut b,
                cube,
                format!("cross corridor wall {k}"),
                Vec3::new(x, 0.0, C1 + CORRIDOR + INT),
                Vec3::new(x + INT, STOREY, C2 - INT),
            )?;
        }
    }
    for (k, &(x, z0, z1)) in partitions.iter().enumerate() {
        add_box(
            &mut b,
            cube,
            format!("partition {k}"),
            Vec3::new(x - INT * 0.5, 0.0, z0),
            Vec3::new(x + INT * 0.5, STOREY, z1),
        )?;
    }
    // Floors and ceilings: one slab each per room, corridor pieces of ≤ 12 m.
    for (name, r) in &rooms {
        add_box(
            &mut b,
            cube,
            format!("{name} floor"),
            Vec3::new(r.x0, -0.2, r.z0),
            Vec3::new(r.x1, 0.0, r.z1),
        )?;
        add_box(
            &mut b,
            cube,
            format!("{name} ceiling"),
            Vec3::new(r.x0, STOREY, r.z0),
            Vec3::new(r.x1, STOREY + 0.2, r.z1),
        )?;
    }
    let mut corridor_rects = Vec::new();
    for z in [C1, C2] {
        let n = 6;
        for k in 0..n {
            let x0 = EXT + (LEN - 2.0 * EXT) * k as f32 / n as f32;
            let x1 = EXT + (LEN - 2.0 * EXT) * (k + 1) as f32 / n as f32;
            corridor_rects.push((x0, z, x1, z + CORRIDOR));
        }
    }
    for &x in &CROSS {
        corridor_rects.push((x, C1 + CORRIDOR, x + CORRIDOR, C2));
    }
    for (k, &(x0, z0, x1, z1)) in corridor_rects.iter().enumerate() {
        add_box(
            &mut b,
            cube,
            format!("corridor floor {k}"),
            Vec3::new(x0, -0.2, z0),
            Vec3::new(x1, 0.0, z1),
        )?;
        add_box(
            &mut b,
            cube,
            format!("corridor ceiling {k}"),
            Vec3::new(x0, STOREY, z0),
            Vec3::new(x1, STOREY + 0.2, z1),
        )?;
        let lights = ((x1 - x0).max(z1 - z0) / 4.0).floor() as usize;
        for i in 0..lights {
            let t = (i as f32 + 0.5) / lights as f32;
            let c = Vec3::new(
                x0 + (x1 - x0) * if x1 - x0 > z1 - z0 { t } else { 0.5 },
                STOREY,
                z0 + (z1 - z0) * if x1 - x0 > z1 - z0 { 0.5 } else { t },
            );
            place(
                &mut b,
                "corridor light",
                f.light,
                c,
                if x1 - x0 > z1 - z0 { 0.0 } else { FRAC_PI_2 },
            )?;
        }
    }

    // Which rooms the camera visits: near chosen x positions along its loop.
    let pick = |row: char, side: f32, x: f32| -> Room {
        rooms
            .iter()
            .filter(|(n, r)| n.starts_with(&format!("room {row}")) && r.door_side == side && r.x1 - r.x0 >= 3.5)
            .min_by(|a, b| (a.1.door_x - x).abs().total_cmp(&(b.1.door_x - x).abs()))
            .expect("row has rooms")
            .1
    };
    let visits = [
        pick('A', 1.0, 18.0),
        pick('B', -1.0, 52.0),
        pick('C', -1.0, 62.0),
        pick('B', 1.0, 45.0),
    ];
    for (name, r) in &rooms {
        furnish(&mut b, &f, &mut rng, r, name)?;
    }

    // The walk: corridor 1 eastwards, cross corridor east, corridor 2 westwards, middle
    // cross corridor, corridor 1 westwards; stepping into the four rooms on the way.
    let c1 = C1 + CORRIDOR * 0.5;
    let c2 = C2 + CORRIDOR * 0.5;
    let xm = CROSS[1] + CORRIDOR * 0.5;
    let xe = CROSS[2] + CORRIDOR * 0.5;
    let p = |x: f32, z: f32| Vec3::new(x, EYE, z);
    let visit = |r: &Room, corridor_z: f32, east: bool| -> Vec<Vec3> {
        let inward = -r.door_side;
        let dz = r.door_z();
        let side = if (r.door_x - r.x0) > (r.x1 - r.door_x) {
            -1.0
        } else {
            1.0
        };
        let before = if east { -1.0 } else { 1.0 };
        vec![
            p(r.door_x + before * 1.0, corridor_z),
            p(r.door_x, corridor_z - inward * 0.2),
            p(r.door_x, dz),
            p(r.door_x, dz + inward * 2.6),
            p(r.door_x + side * 1.2, dz + inward * 3.6),
            p(r.door_x + side * 0.3, dz + inward * 1.5),
            p(r.door_x, dz),
            p(r.door_x, corridor_z - inward * 0.2),
            p(r.door_x - before * 1.0, corridor_z),
        ]
    };
    let mut pts = vec![p(4.0, c1)];
    pts.extend(visit(&visits[0], c1, true));
    pts.extend(visit(&visits[1], c1, true));
    pts.push(p(xe, c1));
    pts.push(p(xe, c2));
    pts.extend(visit(&visits[2], c2, false));
    pts.extend(visit(&visits[3], c2, false));
    pts.push(p(xm, c2));
    pts.push(p(xm, c1));
    pts.push(p(6.0, c1));
    let smooth = round_corners(&pts, 0.9, 0.25);
    let path = CameraPath::along(&smooth, 0.85, 3.0);
    Ok(Builtin {
        scene: b.build()?,
        path,
        animation: Animation::none(),
    })
}
