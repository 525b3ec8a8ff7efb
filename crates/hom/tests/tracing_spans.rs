//! With the `tracing` feature, every stage of a cull runs inside a
//! `hom_cull` span named by its `stage` field, in the order `CullOutput`
//! records them (hom's own tests turn `tracing` on: `cargo test -p hom`).
#![cfg(feature = "tracing")]

use hom::cull::{CullOutput, Culler, HomConfig, HomCuller};
use hom::geom::Camera;
use hom::glam::Vec3;
use std::sync::{Arc, Mutex};
use tracing::field::{Field, Visit};
use tracing::span::{Attributes, Id, Record};
use tracing::{Event, Metadata, Subscriber};

/// Records each entered span's name and `stage` field.
#[derive(Clone, Default)]
struct Stages {
    spans: Arc<Mutex<Vec<(String, String)>>>,
    entered: Arc<Mutex<Vec<String>>>,
}

struct StageField(String);
impl Visit for StageField {
    fn record_str(&mut self, field: &Field, value: &str) {
        if field.name() == "stage" {
            self.0 = value.to_string();
        }
    }
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
        spans.push((span.metadata().name().to_string(), stage.0));
        Id::from_u64(spans.len() as u64)
    }
    fn record(&self, _: &Id, _: &Record<'_>) {}
    fn record_follows_from(&self, _: &Id, _: &Id) {}
    fn event(&self, _: &Event<'_>) {}
    fn enter(&self, id: &Id) {
        let (name, stage) = self.spans.lock().unwrap()[id.into_u64() as usize - 1].clone();
        self.entered.lock().unwrap().push(format!("{name}:{stage}"));
    }
    fn exit(&self, _: &Id) {}
}

#[test]
fn each_stage_of_a_cull_is_a_span() {
    let scene = hom_testkit::random_scene(7, 30, false);
    let camera = Camera::new(
        Vec3::new(0.0, 1.5, 14.0),
        Vec3::ZERO,
        Vec3::Y,
        1.2,
        0.1,
        100.0,
        160,
        120,
    );
    let mut culler = HomCuller::new(
        &scene,
        HomConfig {
            cost_model: false,
            ..HomConfig::for_scene(&scene)
        },
    );
    let stages = Stages::default();
    let mut out = CullOutput::default();
    tracing::subscriber::with_default(stages.clone(), || {
        culler.cull(&scene, &camera.to_view(), &mut out).expect("a valid view");
    });
    let want: Vec<String> = out.stages.iter().map(|(name, _)| format!("hom_cull:{name}")).collect();
    let entered = stages.entered.lock().unwrap().clone();
    assert!(want.len() >= 4, "a culling frame has its stages: {want:?}");
    assert_eq!(entered, want);
}
