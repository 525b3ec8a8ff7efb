//! A city of boxes and props, a flying camera, and a text line with what
//! occlusion culling removed. Needs a window and a GPU (or Mesa's lavapipe).
//!
//! `cargo run --release -p hom-bevy --features example-app --example city`
//!
//! Keys: WASD (and Q/E down/up) to fly, the mouse with the left button held
//! to look; O turns occlusion culling on and off; B switches the buffer
//! (masked, HZB, HOM); V shows the occlusion buffer's coverage in a corner.
//! Untouched, the camera flies down the main street by itself.
//!
//! `HOM_BEVY_FRAMES=N` exits after N frames and prints the last frame's
//! statistics; with `HOM_BEVY_SCREENSHOT=FILE.png` it first saves the
//! window, with the coverage inset shown (the CI's smoke run under Xvfb,
//! `scripts/bevy-example-check.sh`).

use bevy::input::mouse::AccumulatedMouseMotion;
use bevy::prelude::*;
use hom_bevy::{BufferKind, HomOcclusionPlugin, OcclusionCulling, OcclusionDebugView, OcclusionStats};

/// Blocks on a side of the city.
const BLOCKS: i32 = 24;
/// Metres from one block's centre to the next.
const SPACING: f32 = 14.0;

fn main() {
    App::new()
        .add_plugins((
            DefaultPlugins.set(WindowPlugin {
                primary_window: Some(Window {
                    title: "hom-bevy: occlusion culling on the CPU".into(),
                    resolution: (1280, 720).into(),
                    ..default()
                }),
                ..default()
            }),
            HomOcclusionPlugin,
        ))
        .insert_resource(ClearColor(Color::srgb(0.55, 0.7, 0.9)))
        .add_systems(Startup, (city, camera_and_text))
        .add_systems(Update, (fly, keys, show_stats, exit_after_frames))
        .run();
}

/// The flying camera's state: heading, pitch, and whether a person has taken over.
#[derive(Component, Default)]
struct Flight {
    yaw: f32,
    pitch: f32,
    manual: bool,
    frame: u32,
}

#[derive(Component)]
struct StatsLine;

#[derive(Component)]
struct DebugInset;

fn city(mut commands: Commands, mut meshes: ResMut<Assets<Mesh>>, mut materials: ResMut<Assets<StandardMaterial>>) {
    let building = meshes.add(Cuboid::new(1.0, 1.0, 1.0));
    let prop = meshes.add(Cuboid::new(0.8, 1.2, 1.6));
    let ground = meshes.add(
        Plane3d::default()
            .mesh()
            .size(BLOCKS as f32 * SPACING * 1.5, BLOCKS as f32 * SPACING * 1.5),
    );
    let concrete: Vec<_> = (0..6)
        .map(|k| {
            materials.add(Color::srgb(
                0.45 + 0.07 * k as f32,
                0.42 + 0.05 * k as f32,
                0.4 + 0.03 * k as f32,
            ))
        })
        .collect();
    let paint = materials.add(Color::srgb(0.8, 0.2, 0.15));
    commands.spawn((
        Mesh3d(ground),
        MeshMaterial3d(materials.add(Color::srgb(0.3, 0.32, 0.3))),
    ));
    let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
    let mut rand = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 40) as f32 / (1u64 << 24) as f32
    };
    for i in -BLOCKS / 2..BLOCKS / 2 {
        for j in -BLOCKS / 2..BLOCKS / 2 {
            let centre = Vec3::new(i as f32 * SPACING, 0.0, j as f32 * SPACING);
            let size = Vec3::new(8.0 + 2.0 * rand(), 5.0 + 35.0 * rand() * rand(), 8.0 + 2.0 * rand());
            commands.spawn((
                Mesh3d(building.clone()),
                MeshMaterial3d(concrete[(rand() * 6.0) as usize % 6].clone()),
                Transform::from_translation(centre + Vec3::Y * size.y / 2.0).with_scale(size),
            ));
            for _ in 0..6 {
                let (u, v) = (rand() * 2.0 - 1.0, rand() * 2.0 - 1.0);
                let at = centre + Vec3::new(u.signum() * (5.6 + rand()), 0.6, v * 6.0);
                commands.spawn((
                    Mesh3d(prop.clone()),
                    MeshMaterial3d(paint.clone()),
                    Transform::from_translation(at),
                ));
            }
        }
    }
    commands.spawn((
        DirectionalLight {
            illuminance: 8_000.0,
            ..default()
        },
        Transform::from_xyz(1.0, 2.0, 0.5).looking_at(Vec3::ZERO, Vec3::Y),
    ));
}

fn camera_and_text(mut commands: Commands, mut images: ResMut<Assets<Image>>) {
    let coverage = images.add(Image::default());
    commands.spawn((
        Camera3d::default(),
        Transform::from_xyz(SPACING / 2.0, 1.7, -(BLOCKS as f32) * SPACING / 2.0),
        Flight::default(),
        OcclusionCulling::default(),
        OcclusionDebugView {
            image: coverage.clone(),
        },
    ));
    commands.spawn((
        Text::new("occlusion culling: starting"),
        TextFont::from_font_size(18.0),
        Node {
            position_type: PositionType::Absolute,
            top: px(8),
            left: px(8),
            ..default()
        },
        StatsLine,
    ));
    commands.spawn((
        ImageNode::new(coverage),
        Node {
            position_type: PositionType::Absolute,
            bottom: px(8),
            right: px(8),
            width: px(256),
            height: px(144),
            ..default()
        },
        Visibility::Hidden,
        DebugInset,
    ));
}

fn fly(
    time: Res<Time>,
    keys: Res<ButtonInput<KeyCode>>,
    buttons: Res<ButtonInput<MouseButton>>,
    motion: Res<AccumulatedMouseMotion>,
    mut camera: Query<(&mut Transform, &mut Flight)>,
) {
    let Ok((mut transform, mut flight)) = camera.single_mut() else {
        return;
    };
    flight.frame += 1;
    let dt = time.delta_secs().min(0.1);
    let mut go = Vec3::ZERO;
    for (key, dir) in [
        (KeyCode::KeyW, Vec3::NEG_Z),
        (KeyCode::KeyS, Vec3::Z),
        (KeyCode::KeyA, Vec3::NEG_X),
        (KeyCode::KeyD, Vec3::X),
        (KeyCode::KeyQ, Vec3::NEG_Y),
        (KeyCode::KeyE, Vec3::Y),
    ] {
        if keys.pressed(key) {
            go += dir;
            flight.manual = true;
        }
    }
    if buttons.pressed(MouseButton::Left) && motion.delta != Vec2::ZERO {
        flight.yaw -= motion.delta.x * 0.003;
        flight.pitch = (flight.pitch - motion.delta.y * 0.003).clamp(-1.5, 1.5);
        flight.manual = true;
    }
    if !flight.manual {
        // Down the main street (+Z), looking a little left and right.
        flight.yaw = std::f32::consts::PI + 0.5 * (flight.frame as f32 * 0.01).sin();
        transform.rotation = Quat::from_rotation_y(flight.yaw);
        transform.translation.z += 12.0 * dt;
        let half = BLOCKS as f32 * SPACING / 2.0;
        if transform.translation.z > half {
            transform.translation.z = -half;
        }
        return;
    }
    transform.rotation = Quat::from_euler(EulerRot::YXZ, flight.yaw, flight.pitch, 0.0);
    let step = transform.rotation * go * 20.0 * dt;
    transform.translation += step;
}

fn keys(
    keys: Res<ButtonInput<KeyCode>>,
    mut commands: Commands,
    mut cameras: Query<(Entity, Option<&mut OcclusionCulling>), With<Camera3d>>,
    mut inset: Query<&mut Visibility, With<DebugInset>>,
) {
    for (entity, culling) in &mut cameras {
        if keys.just_pressed(KeyCode::KeyO) {
            match culling {
                Some(_) => {
                    commands.entity(entity).remove::<OcclusionCulling>();
                }
                None => {
                    commands.entity(entity).insert(OcclusionCulling::default());
                }
            }
        } else if let (true, Some(mut culling)) = (keys.just_pressed(KeyCode::KeyB), culling) {
            culling.buffer = match culling.buffer {
                BufferKind::Masked => BufferKind::Hzb,
                BufferKind::Hzb => BufferKind::Hom,
                BufferKind::Hom => BufferKind::Masked,
            };
        }
    }
    if keys.just_pressed(KeyCode::KeyV) {
        for mut v in &mut inset {
            v.toggle_visible_hidden();
        }
    }
}

fn show_stats(
    stats: Res<OcclusionStats>,
    cameras: Query<(Entity, Option<&OcclusionCulling>), With<Camera3d>>,
    mut line: Query<&mut Text, With<StatsLine>>,
) {
    let (Ok((camera, culling)), Ok(mut text)) = (cameras.single(), line.single_mut()) else {
        return;
    };
    text.0 = match (culling, stats.cameras.get(&camera)) {
        (Some(c), Some(s)) => format!(
            "{:?}: {} meshes in view, {} occluded ({:.0} %), {} occluders ({} triangles), cull {:.2} ms (+{:.2} ms plugin)",
            c.buffer,
            s.tested,
            s.occluded,
            100.0 * f64::from(s.occluded) / f64::from(s.tested.max(1)),
            s.occluders,
            s.occluder_triangles,
            s.cull_ms,
            s.plugin_ms + stats.sync_ms,
        ),
        _ => "occlusion culling off (O turns it on)".to_string(),
    };
}

fn exit_after_frames(
    mut frames: Local<u32>,
    mut commands: Commands,
    stats: Res<OcclusionStats>,
    line: Query<&Text, With<StatsLine>>,
    mut inset: Query<&mut Visibility, With<DebugInset>>,
    mut exit: MessageWriter<AppExit>,
) {
    let Some(limit) = std::env::var("HOM_BEVY_FRAMES")
        .ok()
        .and_then(|v| v.parse::<u32>().ok())
    else {
        return;
    };
    *frames += 1;
    let screenshot = std::env::var("HOM_BEVY_SCREENSHOT").ok();
    // The inset shown some frames before the shot, so the picture has it.
    if screenshot.is_some() && *frames + 20 == limit {
        for mut v in &mut inset {
            *v = Visibility::Visible;
        }
    }
    if let (Some(path), true) = (screenshot, *frames + 10 == limit) {
        commands
            .spawn(bevy::render::view::screenshot::Screenshot::primary_window())
            .observe(bevy::render::view::screenshot::save_to_disk(path));
    }
    if *frames >= limit {
        if let Ok(text) = line.single() {
            println!("after {limit} frames: {}", text.0);
        }
        let culled: u32 = stats.cameras.values().map(|s| s.occluded).sum();
        println!("entities {}, occluded {culled}", stats.entities);
        exit.write(AppExit::Success);
    }
}
