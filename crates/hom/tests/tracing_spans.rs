//! With the `tracing` feature, every stage of a cull runs inside a
//! `hom_cull` span named by its `stage` field, in the order `CullOutput`
//! records them (hom's own tests turn `tracing` on: `cargo test -p hom`).
#![cfg(feature = "tracing")]

use hom::cull::{CullOutput, Culler, HomConfig, HomCuller};
use hom::geom::Camera;
use hom::glam::Vec3;
use hom_testkit::SpanRecorder;

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
    let stages = SpanRecorder::default();
    let mut out = CullOutput::default();
    tracing::subscriber::with_default(stages.clone(), || {
        culler.cull(&scene, &camera.to_view(), &mut out).expect("a valid view");
    });
    let want: Vec<String> = out.stages.iter().map(|(name, _)| format!("hom_cull:{name}")).collect();
    let entered = stages.entered();
    assert!(want.len() >= 4, "a culling frame has its stages: {want:?}");
    assert_eq!(entered, want);
}
