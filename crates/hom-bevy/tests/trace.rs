//! With the `trace` feature, each stage of the plugin's frame runs inside a
//! `hom_bevy` span, and hom's cull inside it shows its own `hom_cull`
//! stages (the crate's own tests turn `trace` on: `cargo test -p hom-bevy`).
#![cfg(feature = "trace")]

use bevy::asset::Assets;
use bevy::camera::Camera3d;
use bevy::math::primitives::Cuboid;
use bevy::math::{UVec2, Vec3};
use bevy::mesh::{Mesh, Mesh3d};
use bevy::prelude::Transform;
use hom_bevy::OcclusionCulling;
use hom_testkit::SpanRecorder;

mod common;

#[test]
fn each_stage_of_the_plugins_frame_is_a_span() {
    let mut app = common::app();
    let wall = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(Cuboid::new(40.0, 30.0, 1.0));
    app.world_mut()
        .spawn((Mesh3d(wall), Transform::from_xyz(0.0, 0.0, -10.0)));
    app.world_mut().spawn((
        Camera3d::default(),
        OcclusionCulling {
            resolution: Some(UVec2::new(64, 48)),
            threads: hom_bevy::hom::occlusion::Threads::CallingThread,
            ..Default::default()
        },
        Transform::from_translation(Vec3::ZERO).looking_at(Vec3::NEG_Z, Vec3::Y),
    ));
    let stages = SpanRecorder::default();
    // Global (this file's one test): bevy may run its systems on other threads.
    tracing::subscriber::set_global_default(stages.clone()).expect("the only subscriber");
    app.update();
    let entered = stages.entered();
    let at = |s: &str| {
        entered
            .iter()
            .position(|e| e == s)
            .unwrap_or_else(|| panic!("no {s} in {entered:?}"))
    };
    let (sync, cull, filter) = (at("hom_bevy:sync"), at("hom_bevy:cull"), at("hom_bevy:filter"));
    let selection = at("hom_cull:selection");
    assert!(sync < cull && cull < selection && selection < filter, "{entered:?}");
}
