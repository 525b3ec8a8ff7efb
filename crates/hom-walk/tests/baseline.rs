//! The frustum-only baseline a walk times beside its culler: the frustum
//! culler reuses its own frame time, unless asked to time a second frustum
//! culler against it (the A/A check of `hom walk --self-baseline`).

use hom_render::Renderer;
use hom_walk::{cullers, walk, WalkOptions};

#[test]
fn the_frustum_culler_is_its_own_baseline_unless_checked_against_itself() {
    let renderer = Renderer::new(1).unwrap();
    let built = hom_scene::builtin("spheres").unwrap();
    let (mut scene, animation) = (built.scene, built.animation);
    let mut path = built.path.with_viewport(64, 48);
    path.frames.truncate(6);
    let run = |scene: &mut hom::scene::Scene, self_baseline: bool| {
        let mut culler = cullers::make("frustum", scene, &cullers::CullerSettings::for_scene(scene)).unwrap();
        let options = WalkOptions {
            self_baseline,
            ..WalkOptions::default()
        };
        walk(scene, &animation, &path, culler.as_mut(), &renderer, &options, |_| {}).unwrap()
    };
    let own = run(&mut scene, false);
    assert_eq!(own.frames.len(), 6);
    assert!(own.frames.iter().all(|f| f.baseline_frame_ms == Some(f.frame_ms)));
    assert_eq!(own.summary.speedup, Some(1.0));

    // Two cullers' frames, timed apart: some frame differs, and every frame has both.
    let checked = run(&mut scene, true);
    assert!(checked
        .frames
        .iter()
        .all(|f| f.baseline_frame_ms.is_some_and(|b| b > 0.0)));
    assert!(checked.frames.iter().any(|f| f.baseline_frame_ms != Some(f.frame_ms)));
    assert!(checked.summary.speedup.is_some_and(f64::is_finite));
}
