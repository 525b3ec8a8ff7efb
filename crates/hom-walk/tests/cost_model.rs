//! The occluder cullers' cost model (after Guthe et al. 2006): with frame
//! times fed back, a culler whose occlusion work finds nothing rests
//! (frustum culling only, the frustum culler's exact answer), and one whose
//! occlusion work pays never does.

use hom::cull::{CullOutput, Culler, FrustumCuller, HomConfig, HomCuller};
use hom::geom::Camera;
use hom::glam::{Mat4, Vec3};
use hom::scene::{Scene, SceneBuilder};
use hom_testkit::cube;

/// A row of boxes apart, none behind another; with `wall`, a wall in front
/// hides them all.
fn scene(wall: bool) -> Scene {
    let mut b = SceneBuilder::new("row");
    let m = b.add_mesh(cube());
    if wall {
        let t = Mat4::from_scale_rotation_translation(Vec3::new(30.0, 8.0, 0.5), Default::default(), Vec3::ZERO);
        b.add_object("wall", m, t).unwrap();
    }
    // In view from every camera of the walk, 1.5 m apart: nothing can hide a box.
    for i in 0..9 {
        let at = Vec3::new((i as f32 - 4.0) * 2.5, 0.0, -4.0);
        b.add_object(format!("box{i}"), m, Mat4::from_translation(at)).unwrap();
    }
    b.build().unwrap()
}

/// The cullers with the cost model on, budget for the wall alone.
fn cullers(scene: &Scene) -> Vec<Box<dyn Culler>> {
    let mut hom = HomConfig::for_scene(scene);
    hom.occluders.selection.budget = 12;
    hom.occluders.occluder_db = hom_testkit::permissive_occluders();
    hom_testkit::occluder_cullers(scene, &hom)
}

/// Walks 60 frames, feeding back the culler's time plus a renderer costing
/// 1 ms and 0.1 ms per triangle drawn (the wall saves 10.8 ms a frame, far
/// above any cull time); returns the frames that rested.
fn walk(scene: &Scene, culler: &mut dyn Culler, frustum: &mut FrustumCuller) -> Vec<usize> {
    let (mut out, mut reference) = (CullOutput::default(), CullOutput::default());
    let mut rested = Vec::new();
    for frame in 0..60 {
        let x = (frame as f32 * 0.05).sin();
        let camera = Camera::new(
            Vec3::new(x, 0.0, 12.0),
            Vec3::new(x, 0.0, 0.0),
            Vec3::Y,
            1.0,
            0.1,
            100.0,
            96,
            64,
        );
        culler.cull(scene, &camera.to_view(), &mut out).unwrap();
        if out.stats.rested {
            frustum.cull(scene, &camera.to_view(), &mut reference).unwrap();
            assert_eq!(out.visible, reference.visible, "{} frame {frame}", culler.name());
            assert!(out.occluded.is_empty());
            rested.push(frame);
        }
        let drawn: u64 = out.visible.iter().map(|&id| scene.object(id).triangles as u64).sum();
        culler.frame_done(Some(out.total_ms() + 1.0 + drawn as f64 * 0.1));
    }
    rested
}

#[test]
fn occlusion_that_finds_nothing_rests_and_occlusion_that_pays_never_does() {
    for wall in [false, true] {
        let scene = scene(wall);
        let mut frustum = FrustumCuller::new(&scene);
        for mut culler in cullers(&scene) {
            let rested = walk(&scene, culler.as_mut(), &mut frustum);
            if wall {
                assert!(
                    rested.is_empty(),
                    "{}: the wall hides 480 triangles a frame",
                    culler.name()
                );
            } else {
                assert!(rested.len() > 30, "{}: rested only in frames {rested:?}", culler.name());
            }
        }
    }
}

#[test]
fn without_frame_times_or_with_the_cost_model_off_no_frame_rests() {
    let scene = scene(false);
    let camera = Camera::new(Vec3::new(0.0, 0.0, 12.0), Vec3::ZERO, Vec3::Y, 1.0, 0.1, 100.0, 96, 64);
    let mut off = HomConfig::for_scene(&scene);
    off.cost_model = false;
    let mut cullers: Vec<(Box<dyn Culler>, bool)> = vec![
        (Box::new(HomCuller::new(&scene, HomConfig::for_scene(&scene))), false),
        (Box::new(HomCuller::new(&scene, off)), true),
    ];
    let mut out = CullOutput::default();
    for (culler, timed) in cullers.iter_mut() {
        for _ in 0..40 {
            culler.cull(&scene, &camera.to_view(), &mut out).unwrap();
            assert!(!out.stats.rested);
            culler.frame_done(timed.then_some(100.0));
        }
    }
}
