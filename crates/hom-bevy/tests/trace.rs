//! With the `trace` feature, each stage of the plugin's frame runs inside a
//! `hom_bevy` span, and hom's cull inside it shows its own `hom_cull`
//! stages (the crate's own tests turn `trace` on: `cargo test -p hom-bevy`).
#![cfg(feature = "trace")]

use bevy::app::App;
use bevy::asset::{AssetPlugin, Assets};
use bevy::camera::{Camera3d, CameraPlugin};
use bevy::math::primitives::Cuboid;
use bevy::math::{UVec2, Vec3};
use bevy::mesh::{Mesh, Mesh3d, MeshPlugin};
use bevy::prelude::{TaskPoolPlugin, Transform, TransformPlugin};
use hom_bevy::{HomOcclusionPlugin, OcclusionCulling};
use std::sync::{Arc, Mutex};
use tracing::field::{Field, Visit};
use tracing::span::{Attributes, Id, Record};
use tracing::{Event, Metadata, Subscriber};

/// Records each entered span as `name:stage`.
#[derive(Clone, Default)]
struct Stages {
    spans: Arc<Mutex<Vec<String>>>,
    entered: Arc<Mutex<Vec<String>>>,
}

struct StageField(String);
impl Visit for StageField {
    fn record_debug(&mut self, field: &Field, value: &dyn std::fmt::Debug) {
        if field.name() == "stage" {
            self.0 = format!("{value:?}").trim_matches('"').to_string();
        }
    }
}

impl Subscriber for Stages {
    fn enabled(&self, _: &Metadata<'_>) -> bool {
        true
    }
    fn new_span(&self, span: &Attributes<'_>) -> Id {
        let mut stage = StageField(String::new());
        span.record(&mut stage);
        let mut spans = self.spans.lock().unwrap();
        spans.push(format!("{}:{}", span.metadata().name(), stage.0));
        Id::from_u64(spans.len() as u64)
    }
    fn record(&self, _: &Id, _: &Record<'_>) {}
    fn record_follows_from(&self, _: &Id, _: &Id) {}
    fn event(&self, _: &Event<'_>) {}
    fn enter(&self, id: &Id) {
        let span = self.spans.lock().unwrap()[id.into_u64() as usize - 1].clone();
        self.entered.lock().unwrap().push(span);
    }
    fn exit(&self, _: &Id) {}
}

#[test]
fn each_stage_of_the_plugins_frame_is_a_span() {
    let mut app = App::new();
    app.add_plugins((
        TaskPoolPlugin::default(),
        TransformPlugin,
        AssetPlugin::default(),
        MeshPlugin,
        CameraPlugin,
        HomOcclusionPlugin,
    ));
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
    let stages = Stages::default();
    // Global (this file's one test): bevy may run its systems on other threads.
    tracing::subscriber::set_global_default(stages.clone()).expect("the only subscriber");
    app.update();
    let entered = stages.entered.lock().unwrap().clone();
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
