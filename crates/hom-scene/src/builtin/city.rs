//! `city`: a street grid of blocks filled with buildings of varied footprint and height
//! (facades with piers, ledges, recessed window bays, roof structures), sidewalks with
//! lamps, trees, benches, bins and hydrants, and parked cars. Ground is tiled per
//! block, street segment and crossing. The camera walks the middle of the streets at
//! eye level (1.7 m), turning corners.

use super::rng::Rng;
use super::shapes::MeshBuilder;
use super::{round_corners, Builtin, Generated};
use crate::camera_path::CameraPath;
use crate::motion::Animation;
use glam::{Mat4, Quat, Vec3};
use hom::scene::{MeshId, SceneBuilder, SceneError};

/// Blocks along x and along z.
const BLOCKS_X: usize = 7;
const BLOCKS_Z: usize = 6;
/// Half width of the roadway (curb to curb / 2).
const ROAD_HALF: f32 = 6.0;
/// Sidewalk width.
const WALK: f32 = 3.5;
/// Curb height of the raised sidewalks / block tiles.
const CURB: f32 = 0.15;
/// Eye height of the walk.
const EYE: f32 = 1.7;

/// Shared street furniture meshes.
pub(super) struct Props {
    pub(super) lamp: MeshId,
    pub(super) tree: [MeshId; 2],
    pub(super) bench: MeshId,
    pub(super) bin: MeshId,
    pub(super) hydrant: MeshId,
    pub(super) cars: [MeshId; 4],
    pub(super) bus_stop: MeshId,
}

pub(super) fn props(b: &mut SceneBuilder) -> Props {
    let mut lamp = MeshBuilder::new();
    lamp.add_cone(Vec3::ZERO, Vec3::new(0.0, 0.4, 0.0), 0.18, 0.14, 6, false);
    lamp.add_cone(Vec3::new(0.0, 0.4, 0.0), Vec3::new(0.0, 6.5, 0.0), 0.09, 0.06, 6, false);
    lamp.add_beam(Vec3::new(0.0, 6.3, 0.0), Vec3::new(0.0, 6.6, 1.6), 0.08, 0.08);
    lamp.add_box(Vec3::new(-0.22, 6.45, 1.4), Vec3::new(0.22, 6.65, 2.1));
    let lamp = b.add_mesh(lamp.build("street lamp"));
    let mut trees = [0; 2];
    for (k, t) in trees.iter_mut().enumerate() {
        let mut m = MeshBuilder::new();
        m.add_cone(Vec3::ZERO, Vec3::new(0.0, 2.6, 0.0), 0.2, 0.14, 7, false);
        if k == 0 {
            m.add_ellipsoid(Vec3::new(0.0, 4.4, 0.0), Vec3::new(2.2, 2.4, 2.2), 10, 6);
            m.add_ellipsoid(Vec3::new(0.6, 5.6, 0.3), Vec3::new(1.4, 1.3, 1.4), 8, 4);
        } else {
            m.add_cone(Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, 5.0, 0.0), 1.9, 1.2, 10, true);
            m.add_cone(Vec3::new(0.0, 5.0, 0.0), Vec3::new(0.0, 7.5, 0.0), 1.5, 0.0, 10, false);
        }
        *t = b.add_mesh(m.build(if k == 0 { "tree (round)" } else { "tree (conifer)" }));
    }
    let mut bench = MeshBuilder::new();
    bench.add_box(Vec3::new(-0.9, 0.42, -0.22), Vec3::new(0.9, 0.48, 0.22));
    bench.add_box(Vec3::new(-0.9, 0.55, 0.18), Vec3::new(0.9, 0.9, 0.24));
    for x in [-0.75, 0.75] {
        bench.add_box(Vec3::new(x - 0.04, 0.0, -0.2), Vec3::new(x + 0.04, 0.42, 0.2));
    }
    let bench = b.add_mesh(bench.build("bench"));
    let mut bin = MeshBuilder::new();
    bin.add_cone(Vec3::ZERO, Vec3::new(0.0, 0.9, 0.0), 0.25, 0.3, 10, true);
    bin.add_cone(Vec3::new(0.0, 0.9, 0.0), Vec3::new(0.0, 1.0, 0.0), 0.32, 0.2, 10, true);
    let bin = b.add_mesh(bin.build("litter bin"));
    let mut hyd = MeshBuilder::new();
    hyd.add_cylinder(Vec3::ZERO, Vec3::new(0.0, 0.6, 0.0), 0.13, 8, false);
    hyd.add_cone(Vec3::new(0.0, 0.6, 0.0), Vec3::new(0.0, 0.75, 0.0), 0.14, 0.04, 8, true);
    hyd.add_cylinder(Vec3::new(-0.22, 0.42, 0.0), Vec3::new(0.22, 0.42, 0.0), 0.05, 6, true);
    let hydrant = b.add_mesh(hyd.build("hydrant"));
    // Cars along +X: length, width, body height, cabin (start, end, height).
    let specs = [
        ("car (sedan)", 4.5, 1.8, 0.75, 1.2, 3.5, 1.45),
        ("car (hatchback)", 3.9, 1.7, 0.8, 1.0, 3.6, 1.5),
        ("car (van)", 5.0, 1.95, 1.0, 0.9, 4.9, 2.1),
        ("car (pickup)", 5.3, 1.9, 0.9, 1.6, 3.2, 1.8),
    ];
    let mut cars = [0; 4];
    for (k, &(name, l, w, h, c0, c1, ch)) in specs.iter().enumerate() {
        let mut m = MeshBuilder::new();
        let (hl, hw) = (l * 0.5, w * 0.5);
        m.add_box(Vec3::new(-hl, 0.3, -hw), Vec3::new(hl, h, hw));
        // Cabin as a tapered box (greenhouse).
        let (x0, x1) = (c0 - hl, c1 - hl);
        let i = m.positions.len() as u32;
        for (x, y, z) in [
            (x0, h, -hw + 0.05),
            (x1, h, -hw + 0.05),
            (x1, h, hw - 0.05),
            (x0, h, hw - 0.05),
            (x0 + 0.45, ch, -hw + 0.2),
            (x1 - 0.3, ch, -hw + 0.2),
            (x1 - 0.3, ch, hw - 0.2),
            (x0 + 0.45, ch, hw - 0.2),
        ] {
            m.vertex(Vec3::new(x, y, z));
        }
        for f in [[0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7], [4, 5, 6, 7]] {
            m.quad(i + f[0], i + f[1], i + f[2], i + f[3]);
        }
        for x in [-hl + 0.8, hl - 0.8] {
            for z in [-hw + 0.05, hw - 0.05] {
                let dz = if z < 0.0 { -0.22 } else { 0.22 };
                m.add_cylinder(Vec3::new(x, 0.33, z), Vec3::new(x, 0.33, z + dz), 0.33, 6, true);
            }
        }
        cars[k] = b.add_mesh(m.build(name));
    }
    let mut stop = MeshBuilder::new();
    stop.add_box(Vec3::new(-2.0, 2.4, -0.8), Vec3::new(2.0, 2.5, 0.8));
    for x in [-1.9, 1.9] {
        stop.add_box(Vec3::new(x - 0.05, 0.0, 0.65), Vec3::new(x + 0.05, 2.4, 0.75));
        stop.add_box(Vec3::new(x - 0.03, 0.1, -0.6), Vec3::new(x + 0.03, 2.3, 0.65));
    }
    stop.add_box(Vec3::new(-1.9, 0.1, 0.7), Vec3::new(1.9, 2.3, 0.74));
    stop.add_box(Vec3::new(-1.5, 0.45, 0.3), Vec3::new(1.5, 0.5, 0.65));
    let bus_stop = b.add_mesh(stop.build("bus shelter"));
    Props {
        lamp,
        tree: trees,
        bench,
        bin,
        hydrant,
        cars,
        bus_stop,
    }
}

/// A building mesh with its footprint centred on the origin, standing on y = 0:
/// a recessed core, vertical piers and floor ledges framing window bays, a plinth,
/// a parapet and roof structures. `style` varies the facade rhythm.
pub(super) fn building(rng: &mut Rng, w: f32, d: f32, h: f32) -> MeshBuilder {
    let mut m = MeshBuilder::new();
    let (hw, hd) = (w * 0.5, d * 0.5);
    let floor = rng.range(3.2, 4.0);
    let floors = (h / floor).floor().max(1.0) as i32;
    let h = floors as f32 * floor;
    let inset = 0.25;
    // Core (glass line), recessed behind piers and ledges.
    m.add_box_open_bottom(
        Vec3::new(-hw + inset, 0.0, -hd + inset),
        Vec3::new(hw - inset, h, hd - inset),
    );
    // Plinth (ground floor base).
    m.add_box_open_bottom(Vec3::new(-hw, 0.0, -hd), Vec3::new(hw, 0.9, hd));
    // Floor ledges: every `every` floors a band wrapping the building.
    let every = if floors > 12 {
        3
    } else if floors > 5 {
        2
    } else {
        1
    };
    let band = rng.range(0.3, 0.6);
    let mut f = every;
    while f < floors {
        let y = f as f32 * floor;
        m.add_box(Vec3::new(-hw, y - band, -hd), Vec3::new(hw, y, hd));
        f += every;
    }
    // Piers: full-height vertical strips along every facade at bay spacing.
    let bay = rng.range(5.0, 8.0);
    let pier = rng.range(0.35, 0.7);
    for (len, along_x) in [(w, true), (d, false)] {
        let n = (len / bay).round().max(1.0) as i32;
        let step = len / n as f32;
        for k in 0..=n {
            let c = -len * 0.5 + k as f32 * step;
            let c = c.clamp(-len * 0.5 + pier * 0.5, len * 0.5 - pier * 0.5);
            for side in [-1.0f32, 1.0] {
                let (min, max) = if along_x {
                    let z = side * hd;
                    (
                        Vec3::new(c - pier * 0.5, 0.9, z - inset),
                        Vec3::new(c + pier * 0.5, h, z + 0.02 * side),
                    )
                } else {
                    let x = side * hw;
                    (
                        Vec3::new(x - inset, 0.9, c - pier * 0.5),
                        Vec3::new(x + 0.02 * side, h, c + pier * 0.5),
                    )
                };
                m.add_box_open_bottom(min.min(max), min.max(max));
            }
        }
    }
    // Parapet.
    let p = 1.1;
    let t = 0.3;
    m.add_box(Vec3::new(-hw, h, -hd), Vec3::new(hw, h + p, -hd + t));
    m.add_box(Vec3::new(-hw, h, hd - t), Vec3::new(hw, h + p, hd));
    m.add_box(Vec3::new(-hw, h, -hd + t), Vec3::new(-hw + t, h + p, hd - t));
    m.add_box(Vec3::new(hw - t, h, -hd + t), Vec3::new(hw, h + p, hd - t));
    // Roof structures: stair/elevator housing, plant boxes, sometimes a water tank.
    let sx = (w * 0.25).min(5.0);
    let sz = (d * 0.25).min(4.0);
    let cx = rng.range(-hw + sx + 0.5, hw - sx - 0.5);
    let cz = rng.range(-hd + sz + 0.5, hd - sz - 0.5);
    m.add_box_open_bottom(
        Vec3::new(cx - sx * 0.5, h, cz - sz * 0.5),
        Vec3::new(cx + sx * 0.5, h + 3.2, cz + sz * 0.5),
    );
    for _ in 0..rng.int(1, 4) {
        let (ax, az) = (rng.range(0.8, 2.0), rng.range(0.8, 2.0));
        let x = rng.range(-hw + ax + 0.4, hw - ax - 0.4);
        let z = rng.range(-hd + az + 0.4, hd - az - 0.4);
        m.add_box_open_bottom(
            Vec3::new(x - ax * 0.5, h, z - az * 0.5),
            Vec3::new(x + ax * 0.5, h + rng.range(0.8, 1.8), z + az * 0.5),
        );
    }
    if rng.chance(0.35) && w > 10.0 && d > 10.0 {
        let x = rng.range(-hw + 3.0, hw - 3.0);
        let z = rng.range(-hd + 3.0, hd - 3.0);
        for (dx, dz) in [(-0.9, -0.9), (0.9, -0.9), (0.9, 0.9), (-0.9, 0.9)] {
            m.add_beam(
                Vec3::new(x + dx, h, z + dz),
                Vec3::new(x + dx * 0.8, h + 2.5, z + dz * 0.8),
                0.15,
                0.15,
            );
        }
        m.add_cylinder(Vec3::new(x, h + 2.5, z), Vec3::new(x, h + 5.0, z), 1.4, 12, false);
        m.add_cone(Vec3::new(x, h + 5.0, z), Vec3::new(x, h + 5.8, z), 1.45, 0.0, 12, false);
    }
    m
}

/// Positions of the street centre lines along one axis, starting at 0.
fn street_lines(rng: &mut Rng, blocks: usize) -> Vec<f32> {
    let mut v = vec![0.0];
    for _ in 0..blocks {
        let block = rng.range(62.0, 96.0);
        v.push(v.last().unwrap() + block + 2.0 * ROAD_HALF);
    }
    v
}

/// A lot: min and max corners in (x, z).
type Lot = ((f32, f32), (f32, f32));

/// Splits a lot into parcels no wider than `max` on either side (random guillotine cuts).
fn split_lots(rng: &mut Rng, min: (f32, f32), max: (f32, f32), limit: f32, out: &mut Vec<Lot>) {
    let (w, d) = (max.0 - min.0, max.1 - min.1);
    if w <= limit && d <= limit {
        out.push((min, max));
        return;
    }
    let t = rng.range(0.35, 0.65);
    if w >= d {
        let x = min.0 + w * t;
        split_lots(rng, min, (x, max.1), limit, out);
        split_lots(rng, (x, min.1), max, limit, out);
    } else {
        let z = min.1 + d * t;
        split_lots(rng, min, (max.0, z), limit, out);
        split_lots(rng, (min.0, z), max, limit, out);
    }
}

fn add(b: &mut SceneBuilder, name: impl Into<String>, mesh: MeshId, at: Vec3, yaw: f32) -> Result<u32, SceneError> {
    b.add_object(
        name,
        mesh,
        Mat4::from_rotation_translation(Quat::from_rotation_y(yaw), at),
    )
}

pub(super) fn generate(seed: u64) -> Generated {
    let mut rng = Rng::new(seed, 1);
    let mut b = SceneBuilder::new("city");
    let xs = street_lines(&mut rng, BLOCKS_X);
    let zs = street_lines(&mut rng, BLOCKS_Z);
    let props = props(&mut b);
    let (x_end, z_end) = (*xs.last().unwrap(), *zs.last().unwrap());
    let centre = Vec3::new(x_end * 0.5, 0.0, z_end * 0.5);
    let radius = centre.length();

    // Ground: crossings, street segments, and a raised tile (sidewalk + lots) per block.
    let mut unit = MeshBuilder::new();
    unit.floor_quad(Vec3::ZERO, Vec3::ONE, 0.0);
    let ground = b.add_mesh(unit.build("ground tile (unit)"));
    let mut slab = MeshBuilder::new();
    slab.add_box(Vec3::new(0.0, -CURB, 0.0), Vec3::ONE);
    let block_slab = b.add_mesh(slab.build("block slab (unit)"));
    let tile = |b: &mut SceneBuilder, name: String, mesh: MeshId, x0: f32, z0: f32, x1: f32, z1: f32, h: f32| {
        b.add_object(
            name,
            mesh,
            Mat4::from_scale_rotation_translation(
                Vec3::new(x1 - x0, h, z1 - z0),
                Quat::IDENTITY,
                Vec3::new(x0, 0.0, z0),
            ),
        )
    };
    for (i, &x) in xs.iter().enumerate() {
        for (j, &z) in zs.iter().enumerate() {
            tile(
                &mut b,
                format!("crossing {i},{j}"),
                ground,
                x - ROAD_HALF,
                z - ROAD_HALF,
                x + ROAD_HALF,
                z + ROAD_HALF,
                1.0,
            )?;
            if j + 1 < zs.len() {
                tile(
                    &mut b,
                    format!("street x{i} {j}"),
                    ground,
                    x - ROAD_HALF,
                    z + ROAD_HALF,
                    x + ROAD_HALF,
                    zs[j + 1] - ROAD_HALF,
                    1.0,
                )?;
            }
            if i + 1 < xs.len() {
                tile(
                    &mut b,
                    format!("street z{j} {i}"),
                    ground,
                    x + ROAD_HALF,
                    z - ROAD_HALF,
                    xs[i + 1] - ROAD_HALF,
                    z + ROAD_HALF,
                    1.0,
                )?;
            }
        }
    }

    for i in 0..BLOCKS_X {
        for j in 0..BLOCKS_Z {
            let (bx0, bx1) = (xs[i] + ROAD_HALF, xs[i + 1] - ROAD_HALF);
            let (bz0, bz1) = (zs[j] + ROAD_HALF, zs[j + 1] - ROAD_HALF);
            tile(&mut b, format!("block {i},{j}"), block_slab, bx0, bz0, bx1, bz1, CURB)?;
            let park = rng.chance(0.08);
            let mut lots = Vec::new();
            let limit = rng.range(26.0, 40.0);
            split_lots(
                &mut rng,
                (bx0 + WALK, bz0 + WALK),
                (bx1 - WALK, bz1 - WALK),
                limit,
                &mut lots,
            );
            // Taller towards the centre.
            let mid = Vec3::new((bx0 + bx1) * 0.5, 0.0, (bz0 + bz1) * 0.5);
            let downtown = 1.0 - (mid - centre).length() / radius;
            for (k, &(lo, hi)) in lots.iter().enumerate() {
                let gap = rng.range(0.0, 1.5);
                let (x0, z0, x1, z1) = (lo.0 + gap, lo.1 + gap, hi.0 - gap, hi.1 - gap);
                let (w, d) = (x1 - x0, z1 - z0);
                let c = Vec3::new((x0 + x1) * 0.5, CURB, (z0 + z1) * 0.5);
                if park || w < 6.0 || d < 6.0 {
                    // A little park: trees and benches on the lot.
                    for _ in 0..((w * d / 60.0) as usize).min(6) {
                        let p = Vec3::new(rng.range(x0 + 2.0, x1 - 2.0), CURB, rng.range(z0 + 2.0, z1 - 2.0));
                        add(&mut b, "park tree", props.tree[rng.index(2)], p, rng.range(0.0, 6.3))?;
                    }
                    continue;
                }
                let h = (6.0 + rng.range(0.0, 1.0).powi(2) * 60.0 * (0.3 + downtown * 1.4)).max(7.0);
                let mesh = building(&mut rng, w, d, h);
                let id = b.add_mesh(mesh.build(format!("building {i},{j},{k}")));
                b.add_object(format!("building {i},{j},{k}"), id, Mat4::from_translation(c))?;
            }
        }
    }

    // Street furniture along both sidewalks of every street segment.
    let curb_line = ROAD_HALF + 0.6;
    let furnish = |b: &mut SceneBuilder,
                   rng: &mut Rng,
                   a: f32,
                   bnd: f32,
                   fixed: f32,
                   along_x: bool,
                   avenue: bool|
     -> Result<(), SceneError> {
        // `a..bnd` along the street, `fixed` the centre line across it.
        let at = |s: f32, off: f32, y: f32| {
            if along_x {
                Vec3::new(s, y, fixed + off)
            } else {
                Vec3::new(fixed + off, y, s)
            }
        };
        let yaw_out = |side: f32| {
            if along_x {
                if side > 0.0 {
                    0.0
                } else {
                    std::f32::consts::PI
                }
            } else if side > 0.0 {
                -std::f32::consts::FRAC_PI_2
            } else {
                std::f32::consts::FRAC_PI_2
            }
        };
        for side in [-1.0f32, 1.0] {
            let (s0, s1) = (a + 3.0, bnd - 3.0);
            // Lamps every ~30 m.
            let n = ((s1 - s0) / 30.0).ceil() as usize;
            for k in 0..=n {
                let s = s0 + (s1 - s0) * k as f32 / n as f32;
                add(
                    b,
                    "street lamp",
                    props.lamp,
                    at(s, side * curb_line, CURB),
                    yaw_out(-side),
                )?;
            }
            // Trees between lamps on avenues.
            if avenue {
                for k in 0..n {
                    let s = s0 + (s1 - s0) * (k as f32 + 0.5) / n as f32;
                    add(
                        b,
                        "street tree",
                        props.tree[rng.index(2)],
                        at(s, side * (curb_line + 0.6), CURB),
                        rng.range(0.0, 6.3),
                    )?;
                }
            }
            // Benches, bins, hydrants at random spots near the building side.
            let inner = ROAD_HALF + WALK - 0.6;
            let mut s = s0 + rng.range(4.0, 12.0);
            while s < s1 - 2.0 {
                let p = at(s, side * inner, CURB);
                match rng.index(5) {
                    0 | 1 => add(
                        b,
                        "bench",
                        props.bench,
                        p,
                        yaw_out(-side) + std::f32::consts::FRAC_PI_2 * 0.0,
                    )?,
                    2 => add(b, "litter bin", props.bin, p, 0.0)?,
                    3 => add(b, "hydrant", props.hydrant, at(s, side * (curb_line - 0.1), CURB), 0.0)?,
                    _ => add(
                        b,
                        "bus shelter",
                        props.bus_stop,
                        at(s, side * (ROAD_HALF + 1.6), CURB),
                        yaw_out(side) + std::f32::consts::FRAC_PI_2,
                    )?,
                };
                s += rng.range(10.0, 26.0);
            }
            // Parked cars in the curb lane, with gaps.
            let mut s = s0 + rng.range(0.0, 6.0);
            while s < s1 - 3.0 {
                if rng.chance(0.3) {
                    let heading = if side > 0.0 { 0.0 } else { std::f32::consts::PI };
                    let yaw = if along_x {
                        heading
                    } else {
                        heading - std::f32::consts::FRAC_PI_2
                    };
                    add(
                        b,
                        "parked car",
                        props.cars[rng.index(4)],
                        at(s + 2.6, side * (ROAD_HALF - 1.3), 0.0),
                        yaw + rng.range(-0.04, 0.04),
                    )?;
                }
                s += rng.range(6.0, 7.5);
            }
        }
        Ok(())
    };
    for (i, &x) in xs.iter().enumerate() {
        let avenue = i % 3 == 1;
        for j in 0..BLOCKS_Z {
            furnish(
                &mut b,
                &mut rng,
                zs[j] + ROAD_HALF,
                zs[j + 1] - ROAD_HALF,
                x,
                false,
                avenue,
            )?;
        }
    }
    for (j, &z) in zs.iter().enumerate() {
        let avenue = j % 3 == 1;
        for i in 0..BLOCKS_X {
            furnish(
                &mut b,
                &mut rng,
                xs[i] + ROAD_HALF,
                xs[i + 1] - ROAD_HALF,
                z,
                true,
                avenue,
            )?;
        }
    }

    // The walk: down the middle of the streets through a fixed sequence of crossings.
    let route: [(usize, usize); 7] = [(1, 0), (1, 2), (3, 2), (3, 4), (6, 4), (6, 5), (4, 5)];
    let pts: Vec<Vec3> = route.iter().map(|&(i, j)| Vec3::new(xs[i], EYE, zs[j])).collect();
    let mut pts = pts;
    pts[0].z += ROAD_HALF + 4.0;
    let smooth = round_corners(&pts, 4.5, 1.0);
    let path = CameraPath::along(&smooth, 3.6, 12.0);
    Ok(Builtin {
        scene: b.build()?,
        path,
        animation: Animation::none(),
    })
}
