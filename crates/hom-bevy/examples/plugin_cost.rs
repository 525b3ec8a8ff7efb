//! What the plugin costs a frame: a headless bevy app (no window, no GPU)
//! with a city of 10,000 mesh entities, a camera walking down its streets,
//! run with and without occlusion culling on the camera.
//!
//! `cargo run --release -p hom-bevy --example plugin_cost [-- FRAMES [BUFFER [MOVING]]]`
//! (BUFFER: hom, hzb or masked, masked by default; MOVING: how many of the
//! props drive along the streets each frame, 0 by default).
//!
//! Prints, as medians over the frames: `app.update()` without the plugin
//! and with it, hom's cull, the plugin's own work around it (keeping hom's
//! scene in step, the view, taking hidden meshes out of the camera's list),
//! and the meshes bevy's frustum culling keeps and the plugin removes.

use bevy::app::App;
use bevy::asset::{AssetPlugin, Assets};
use bevy::camera::visibility::VisibleEntities;
use bevy::camera::{Camera3d, CameraPlugin, PerspectiveProjection, Projection};
use bevy::math::primitives::Cuboid;
use bevy::math::{UVec2, Vec3};
use bevy::mesh::{Mesh, Mesh3d, MeshPlugin};
use bevy::prelude::{TaskPoolPlugin, Transform, TransformPlugin};
use hom_bevy::{BufferKind, HomOcclusionPlugin, OcclusionCulling, OcclusionStats};
use std::any::TypeId;
use std::time::Instant;

/// Blocks on a side of the city; each block holds one building and its props.
const BLOCKS: usize = 50;
/// Metres from one block's centre to the next.
const SPACING: f32 = 12.0;
/// Props per block (benches, lamps, cars): 50 × 50 × (1 + 3) = 10,000 entities.
const PROPS: usize = 3;

fn main() {
    let mut args = std::env::args().skip(1);
    let frames: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(300);
    let buffer = match args.next().as_deref() {
        Some("hom") => BufferKind::Hom,
        Some("hzb") => BufferKind::Hzb,
        None | Some("masked") => BufferKind::Masked,
        Some(other) => {
            eprintln!("plugin_cost: unknown buffer {other:?} (hom, hzb or masked)");
            std::process::exit(2);
        }
    };
    let moving: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(0);
    let without = run(frames, None, moving);
    let with = run(frames, Some(buffer), moving);
    let entities = BLOCKS * BLOCKS * (1 + PROPS);
    println!(
        "{entities} mesh entities ({moving} moving), {frames} frames, buffer {buffer:?}, one camera at 512 x 288 samples"
    );
    println!("medians (ms):");
    println!("  app.update() without the plugin   {:8.3}", median(&without.update_ms));
    println!("  app.update() with it              {:8.3}", median(&with.update_ms));
    println!(
        "  difference                        {:8.3}",
        median(&with.update_ms) - median(&without.update_ms)
    );
    println!("  hom's cull                        {:8.3}", median(&with.cull_ms));
    println!("  the plugin around it              {:8.3}", median(&with.plugin_ms));
    println!("    of which keeping the scene      {:8.3}", median(&with.sync_ms));
    println!(
        "meshes kept by bevy's frustum culling {:.0}, of them removed as occluded {:.0} (median per frame)",
        median(&without.kept),
        median(&with.occluded)
    );
}

/// Per-frame figures of one run.
#[derive(Default)]
struct Run {
    update_ms: Vec<f64>,
    cull_ms: Vec<f64>,
    sync_ms: Vec<f64>,
    plugin_ms: Vec<f64>,
    kept: Vec<f64>,
    occluded: Vec<f64>,
}

fn run(frames: usize, buffer: Option<BufferKind>, moving: usize) -> Run {
    let mut app = App::new();
    app.add_plugins((
        TaskPoolPlugin::default(),
        TransformPlugin,
        AssetPlugin::default(),
        MeshPlugin,
        CameraPlugin,
    ));
    if buffer.is_some() {
        app.add_plugins(HomOcclusionPlugin);
    }
    city(&mut app, moving);
    app.add_systems(bevy::app::Update, drive);
    let resolution = UVec2::new(512, 288);
    let mut camera = app.world_mut().spawn((
        Camera3d::default(),
        Projection::Perspective(PerspectiveProjection {
            aspect_ratio: 16.0 / 9.0,
            ..Default::default()
        }),
        Transform::default(),
    ));
    if let Some(buffer) = buffer {
        camera.insert(OcclusionCulling {
            buffer,
            resolution: Some(resolution),
            ..Default::default()
        });
    }
    let camera = camera.id();
    let mut out = Run::default();
    // A few frames to settle (first cull builds hom's hierarchy), then the measured walk.
    let warm = 10;
    for frame in 0..frames + warm {
        *app.world_mut().get_mut::<Transform>(camera).unwrap() = walk(frame);
        let start = Instant::now();
        app.update();
        let ms = start.elapsed().as_secs_f64() * 1e3;
        if frame < warm {
            continue;
        }
        out.update_ms.push(ms);
        let kept = app
            .world()
            .get::<VisibleEntities>(camera)
            .unwrap()
            .len(TypeId::of::<Mesh3d>());
        out.kept.push(kept as f64);
        let stats = app.world().get_resource::<OcclusionStats>();
        if let Some((s, sync)) = stats.and_then(|st| Some((st.cameras.get(&camera)?, st.sync_ms))) {
            out.cull_ms.push(s.cull_ms);
            out.sync_ms.push(sync);
            out.plugin_ms.push(s.plugin_ms + sync);
            out.occluded.push(f64::from(s.occluded));
        }
    }
    out
}

/// A prop that drives along its street, in metres a frame.
#[derive(bevy::ecs::component::Component)]
struct Drive(f32);

fn drive(mut props: bevy::ecs::system::Query<(&mut Transform, &Drive)>) {
    let half = BLOCKS as f32 * SPACING / 2.0;
    for (mut t, d) in &mut props {
        t.translation.z += d.0;
        if t.translation.z.abs() > half {
            t.translation.z = -t.translation.z.signum() * half;
        }
    }
}

/// Buildings of one unit cube scaled, and props of another, on a grid of
/// blocks; the first `moving` props drive.
fn city(app: &mut App, moving: usize) {
    let mut meshes = app.world_mut().resource_mut::<Assets<Mesh>>();
    let building = meshes.add(Cuboid::new(1.0, 1.0, 1.0));
    let prop = meshes.add(Cuboid::new(0.8, 1.2, 1.6));
    let mut seed = 0x2545_f491_4f6c_dd1d_u64;
    let mut rand = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 40) as f32 / (1u64 << 24) as f32
    };
    let half = BLOCKS as f32 * SPACING / 2.0;
    let mut batch = Vec::with_capacity(BLOCKS * BLOCKS * (1 + PROPS));
    for i in 0..BLOCKS {
        for j in 0..BLOCKS {
            let centre = Vec3::new(i as f32 * SPACING - half, 0.0, j as f32 * SPACING - half);
            let size = Vec3::new(7.0 + 2.0 * rand(), 6.0 + 30.0 * rand(), 7.0 + 2.0 * rand());
            let t = Transform::from_translation(centre + Vec3::Y * size.y / 2.0).with_scale(size);
            batch.push((Mesh3d(building.clone()), t));
            for _ in 0..PROPS {
                // On the street around the block.
                let (u, v) = (rand() * 2.0 - 1.0, rand() * 2.0 - 1.0);
                let at = centre + Vec3::new(u.signum() * (5.0 + rand()), 0.6, v * 5.5);
                batch.push((Mesh3d(prop.clone()), Transform::from_translation(at)));
            }
        }
    }
    let props: Vec<_> = batch.iter().filter(|(m, _)| m.0 == prop).map(|(_, t)| *t).collect();
    batch.retain(|(m, _)| m.0 != prop);
    app.world_mut().spawn_batch(batch);
    for (k, t) in props.into_iter().enumerate() {
        let mut e = app.world_mut().spawn((Mesh3d(prop.clone()), t));
        if k < moving {
            e.insert(Drive(if k % 2 == 0 { 0.3 } else { -0.3 }));
        }
    }
}

/// The camera at eye height down a street, turning slowly to look along and across it.
fn walk(frame: usize) -> Transform {
    let half = BLOCKS as f32 * SPACING / 2.0;
    let along = -half + 10.0 + frame as f32 * 0.5;
    let eye = Vec3::new(SPACING / 2.0, 1.7, along);
    let look = 0.6 * (frame as f32 * 0.02).sin();
    let target = eye + Vec3::new(look.sin(), 0.0, look.cos());
    Transform::from_translation(eye).looking_at(target, Vec3::Y)
}

fn median(v: &[f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}
