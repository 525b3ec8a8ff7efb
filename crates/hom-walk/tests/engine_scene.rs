//! The cullers on a scene an engine drives: objects moved with
//! `set_transform`, added and removed between frames. Every culler follows:
//! no object the oracle sees is ever culled, no removed object is ever
//! reported, and frustum culling equals a linear scan of the live objects.

use hom::cull::{CullOutput, Culler, FrustumCuller, HvConfig, HvCuller};
use hom::geom::{Camera, Containment};
use hom::glam::{Mat4, Quat, Vec3};
use hom::scene::Scene;
use hom_testkit::{assert_no_false_culls, cube, occluder_cullers, permissive_hom, random_scene, Rng};
use proptest::prelude::*;

/// The cullers under test, built for `scene`, with an occluder budget of `budget` triangles.
fn cullers(scene: &Scene, budget: u32) -> Vec<Box<dyn Culler>> {
    let hom = permissive_hom(budget);
    let mut all: Vec<Box<dyn Culler>> = vec![Box::new(FrustumCuller::new(scene))];
    all.extend(occluder_cullers(scene, &hom));
    all.push(Box::new(HvCuller::new(scene, HvConfig::default())));
    all
}

/// A random change: move, add or remove objects.
fn change(scene: &mut Scene, rnd: &mut impl FnMut() -> f32) {
    let live: Vec<u32> = scene.live_objects().map(|(id, _)| id).collect();
    let pick = |r: f32| live[((r * live.len() as f32) as usize).min(live.len() - 1)];
    let place = |rnd: &mut dyn FnMut() -> f32| {
        let pos = Vec3::new(rnd() * 20.0 - 10.0, rnd() * 6.0 - 3.0, rnd() * 20.0 - 10.0);
        let scale = Vec3::new(0.2 + rnd() * 5.0, 0.2 + rnd() * 4.0, 0.2 + rnd() * 5.0);
        Mat4::from_scale_rotation_translation(scale, Quat::from_rotation_y(rnd() * 3.0), pos)
    };
    match (rnd() * 4.0) as u32 {
        0 | 1 if !live.is_empty() => {
            let id = pick(rnd());
            let t = place(rnd);
            scene.set_transform(id, t).unwrap();
        }
        2 => {
            let mesh = scene.add_mesh(cube());
            let t = place(rnd);
            scene.add_object("spawned", mesh, t).unwrap();
        }
        _ if live.len() > 1 => scene.remove_object(pick(rnd())).unwrap(),
        _ => {}
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]
    #[test]
    fn cullers_follow_moves_additions_and_removals(seed in any::<u64>(), n in 1usize..30, changes in 1usize..6) {
        let mut rng = Rng::new(seed);
        let mut rnd = move || rng.unit();
        let mut scene = random_scene(seed, n, false);
        let mut all = cullers(&scene, 60);
        let camera = Camera::new(Vec3::new(0.0, 0.5, 14.0), Vec3::ZERO, Vec3::Y, 1.2, 0.1, 100.0, 72, 54);
        let frustum = camera.frustum().unwrap();
        for _frame in 0..10 {
            for _ in 0..changes {
                change(&mut scene, &mut rnd);
            }
            for culler in all.iter_mut() {
                let out = assert_no_false_culls(&scene, &camera, culler.as_mut());
                for &id in out.visible.iter().chain(&out.occluded) {
                    prop_assert!(scene.get(id).is_some(), "{}: removed object {} reported", culler.name(), id);
                }
                if culler.name() == "frustum" {
                    let linear: Vec<u32> = scene
                        .live_objects()
                        .filter(|(_, o)| frustum.test_aabb(&o.aabb) != Containment::Outside)
                        .map(|(id, _)| id)
                        .collect();
                    prop_assert_eq!(&out.visible, &linear, "the frustum culler lost a moved or added object");
                }
            }
        }
    }
}

#[test]
fn an_empty_scene_culls_to_nothing_and_fills_up() {
    let mut scene = Scene::new("engine");
    let camera = Camera::new(Vec3::new(0.0, 0.5, 14.0), Vec3::ZERO, Vec3::Y, 1.2, 0.1, 100.0, 64, 48);
    // Budget 12: the wall alone is an occluder.
    let mut all = cullers(&scene, 12);
    for culler in all.iter_mut() {
        let mut out = CullOutput::default();
        culler.cull(&scene, &camera.to_view(), &mut out).unwrap();
        assert!(out.visible.is_empty() && out.occluded.is_empty(), "{}", culler.name());
    }
    let mesh = scene.add_mesh(cube());
    // A wall in front of a small box: after the additions the box is hidden.
    let wall = scene
        .add_object(
            "wall",
            mesh,
            Mat4::from_scale_rotation_translation(Vec3::new(20.0, 20.0, 0.5), Quat::IDENTITY, Vec3::ZERO),
        )
        .unwrap();
    let small = scene
        .add_object("small", mesh, Mat4::from_translation(Vec3::new(0.0, 0.0, -5.0)))
        .unwrap();
    for culler in all.iter_mut() {
        let out = assert_no_false_culls(&scene, &camera, culler.as_mut());
        assert!(out.visible.contains(&wall), "{}", culler.name());
        if culler.name() != "frustum" {
            assert_eq!(out.occluded, vec![small], "{}: the box behind the wall", culler.name());
        }
    }
    // The wall is removed: the box must come back.
    scene.remove_object(wall).unwrap();
    for culler in all.iter_mut() {
        let out = assert_no_false_culls(&scene, &camera, culler.as_mut());
        assert_eq!(out.visible, vec![small], "{}", culler.name());
    }
}

/// The occluder cullers with their buffers on the calling thread alone
/// (`Threads::CallingThread`) cull exactly as with the pool, frame after frame.
#[test]
fn occluder_cullers_on_the_calling_thread_cull_as_on_the_pool() {
    let scene = random_scene(11, 40, false);
    let mut hom = permissive_hom(200);
    let mut pool = occluder_cullers(&scene, &hom);
    hom.threads = hom::occlusion::Threads::CallingThread;
    let mut alone = occluder_cullers(&scene, &hom);
    let mut occluded = 0;
    for camera in hom_testkit::cut_camera_path(3, 24, 8) {
        let view = camera.to_view();
        for (a, b) in pool.iter_mut().zip(&mut alone) {
            let (mut want, mut got) = (CullOutput::default(), CullOutput::default());
            a.cull(&scene, &view, &mut want).unwrap();
            b.cull(&scene, &view, &mut got).unwrap();
            assert_eq!(
                (&got.visible, &got.occluded),
                (&want.visible, &want.occluded),
                "{}",
                a.name()
            );
            occluded += want.occluded.len();
        }
    }
    assert!(occluded > 0, "nothing was occluded on the walk");
}
