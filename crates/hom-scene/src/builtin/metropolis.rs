//! `metropolis`: the scale scene. A grid of 40 × 40 city blocks, each with 16
//! buildings, street lamps, trees and parked cars: over 100,000 objects and
//! over 10 million triangles, made in seconds because the meshes are shared
//! (a library of 48 buildings and the city's street furniture, instanced with
//! a translation and a quarter turn). The camera walks the streets at eye
//! level for about 2 km (400 frames), turning at crossings; the far plane is
//! at 1 km.

use super::city::{building, props};
use super::rng::Rng;
use super::shapes::MeshBuilder;
use super::{round_corners, Builtin, Generated};
use crate::camera_path::CameraPath;
use crate::motion::Animation;
use glam::{Mat4, Quat, Vec3};
use hom::scene::{MeshId, SceneBuilder, SceneError};
use std::f32::consts::{FRAC_PI_2, PI};

/// Blocks along x and along z.
const BLOCKS: usize = 40;
/// Side of a block (sidewalk included), metres.
const BLOCK: f32 = 64.0;
/// Half width of the roadway.
const ROAD_HALF: f32 = 6.0;
/// Street centre line to street centre line.
const PITCH: f32 = BLOCK + 2.0 * ROAD_HALF;
/// Lots per block side (16 buildings a block).
const LOTS: usize = 4;
/// Building meshes in the library.
const LIBRARY: usize = 48;
/// Eye height of the walk.
const EYE: f32 = 1.7;

/// The block whose lower corner is at street crossing (`i`, `j`): its
/// ground, buildings and street furniture.
fn block(
    b: &mut SceneBuilder,
    rng: &mut Rng,
    library: &[MeshId],
    furniture: &Furniture,
    i: usize,
    j: usize,
) -> Result<(), SceneError> {
    let (x0, z0) = (i as f32 * PITCH + ROAD_HALF, j as f32 * PITCH + ROAD_HALF);
    let slab =
        Mat4::from_scale_rotation_translation(Vec3::new(BLOCK, 0.15, BLOCK), Quat::IDENTITY, Vec3::new(x0, -0.15, z0));
    b.add_object(format!("block {i},{j}"), furniture.slab, slab)?;
    // Buildings: a lot grid inside a 4 m sidewalk, taller towards the centre.
    let lot = (BLOCK - 8.0) / LOTS as f32;
    let centre = BLOCKS as f32 * PITCH * 0.5;
    let mid = Vec3::new(x0 + BLOCK * 0.5, 0.0, z0 + BLOCK * 0.5);
    let downtown = 1.0 - (mid - Vec3::new(centre, 0.0, centre)).length() / (centre * 1.42);
    for a in 0..LOTS {
        for c in 0..LOTS {
            let at = Vec3::new(
                x0 + 4.0 + (a as f32 + 0.5) * lot,
                0.0,
                z0 + 4.0 + (c as f32 + 0.5) * lot,
            );
            // The library is sorted by height: downtown draws from its tall end.
            let tall = (rng.range(0.0, 1.0) * (0.4 + downtown)).min(0.999);
            let mesh = library[(tall * LIBRARY as f32) as usize];
            let yaw = rng.index(4) as f32 * FRAC_PI_2;
            let t = Mat4::from_rotation_translation(Quat::from_rotation_y(yaw), at);
            b.add_object(format!("building {i},{j},{a},{c}"), mesh, t)?;
        }
    }
    // Street furniture on the sidewalk, every 8 m around the block: lamps and
    // trees alternating, and a parked car at every other stop.
    for side in 0..4 {
        for k in 0..8 {
            let s = 4.0 + k as f32 * 8.0;
            let (p, out, yaw) = match side {
                0 => (Vec3::new(x0 + s, 0.0, z0 + 1.5), Vec3::new(0.0, 0.0, -1.0), 0.0),
                1 => (
                    Vec3::new(x0 + BLOCK - 1.5, 0.0, z0 + s),
                    Vec3::new(1.0, 0.0, 0.0),
                    FRAC_PI_2,
                ),
                2 => (
                    Vec3::new(x0 + BLOCK - s, 0.0, z0 + BLOCK - 1.5),
                    Vec3::new(0.0, 0.0, 1.0),
                    PI,
                ),
                _ => (
                    Vec3::new(x0 + 1.5, 0.0, z0 + BLOCK - s),
                    Vec3::new(-1.0, 0.0, 0.0),
                    3.0 * FRAC_PI_2,
                ),
            };
            let (mesh, name) = if k % 2 == 0 {
                (furniture.lamp, "lamp")
            } else {
                (furniture.tree[rng.index(2)], "tree")
            };
            let t = Mat4::from_rotation_translation(Quat::from_rotation_y(yaw + FRAC_PI_2), p);
            b.add_object(format!("{name} {i},{j},{side},{k}"), mesh, t)?;
            if k % 2 == 1 {
                // On the road, 3 m out from the curb, parallel to it.
                let car = furniture.cars[rng.index(4)];
                let t = Mat4::from_rotation_translation(Quat::from_rotation_y(yaw), p + out * 4.5);
                b.add_object(format!("car {i},{j},{side},{k}"), car, t)?;
            }
        }
    }
    Ok(())
}

/// The shared meshes besides the buildings.
struct Furniture {
    slab: MeshId,
    lamp: MeshId,
    tree: [MeshId; 2],
    cars: [MeshId; 4],
}

pub(super) fn generate(seed: u64) -> Generated {
    let mut rng = Rng::new(seed, 7);
    let mut b = SceneBuilder::new("metropolis");
    let city = props(&mut b);
    let mut slab = MeshBuilder::new();
    slab.add_box(Vec3::ZERO, Vec3::ONE);
    let furniture = Furniture {
        slab: b.add_mesh(slab.build("block slab (unit)")),
        lamp: city.lamp,
        tree: city.tree,
        cars: city.cars,
    };
    // The building library, lowest to tallest, footprints up to the lot (13 m).
    let mut heights: Vec<f32> = (0..LIBRARY).map(|_| 8.0 + rng.range(0.0, 1.0).powi(2) * 80.0).collect();
    heights.sort_by(f32::total_cmp);
    let library: Vec<MeshId> = heights
        .iter()
        .enumerate()
        .map(|(k, &h)| {
            let (w, d) = (rng.range(8.0, 13.0), rng.range(8.0, 13.0));
            b.add_mesh(building(&mut rng, w, d, h).build(format!("building {k}")))
        })
        .collect();
    let mut ground = MeshBuilder::new();
    ground.floor_quad(Vec3::ZERO, Vec3::ONE, 0.0);
    let road = b.add_mesh(ground.build("road (unit)"));
    let span = BLOCKS as f32 * PITCH;
    for i in 0..=BLOCKS {
        // One road strip per street line and direction.
        let at = i as f32 * PITCH - ROAD_HALF;
        let x = Mat4::from_scale_rotation_translation(
            Vec3::new(2.0 * ROAD_HALF, 1.0, span),
            Quat::IDENTITY,
            Vec3::new(at, 0.0, 0.0),
        );
        let z = Mat4::from_scale_rotation_translation(
            Vec3::new(span, 1.0, 2.0 * ROAD_HALF),
            Quat::IDENTITY,
            Vec3::new(0.0, 0.0, at),
        );
        b.add_object(format!("street x{i}"), road, x)?;
        b.add_object(format!("street z{i}"), road, z)?;
    }
    for i in 0..BLOCKS {
        for j in 0..BLOCKS {
            block(&mut b, &mut rng, &library, &furniture, i, j)?;
        }
    }
    // The walk: down the middle of the streets, turning at crossings, in
    // the lane between the parked cars.
    let route: [(usize, usize); 5] = [(12, 4), (12, 12), (18, 12), (18, 18), (24, 18)];
    let pts: Vec<Vec3> = route
        .iter()
        .map(|&(i, j)| Vec3::new(i as f32 * PITCH, EYE, j as f32 * PITCH))
        .collect();
    let smooth = round_corners(&pts, 4.5, 1.0);
    let mut path = CameraPath::along(&smooth, 5.0, 12.0);
    path.far = 1000.0;
    Ok(Builtin {
        scene: b.build()?,
        path,
        animation: Animation::none(),
    })
}
