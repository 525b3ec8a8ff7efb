//! Coherence in the occlusion traversal (Bittner & Havran 2002), checked
//! against the classical traversal and the oracle: `Exact` reports the
//! classical visible and occluded sets on every frame of random camera paths
//! (with jumps, moving objects, additions and removals); `Skip` never culls
//! what the oracle sees and draws a superset of `Exact`; an object that comes
//! out from behind a wall is drawn in the frame it does, in every mode.

use hom::cull::{Coherence, CullOutput, Culler, HomConfig, HomCuller, PSkip};
use hom::geom::Camera;
use hom::glam::{Mat4, Vec3};
use hom::scene::{Scene, SceneBuilder};
use hom_testkit::{
    assert_no_false_culls, cube, cut_camera_path, occluder_cullers, permissive_hom, random_moving_scene, Rng,
};
use proptest::prelude::*;

/// HOM, HZB and masked with every object an occluder candidate, `budget`
/// occluder triangles and `coherence`.
fn cullers(scene: &Scene, coherence: Coherence, budget: u32) -> Vec<Box<dyn Culler>> {
    occluder_cullers(
        scene,
        &HomConfig {
            coherence,
            ..permissive_hom(budget)
        },
    )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 40, ..ProptestConfig::default() })]
    #[test]
    fn exact_coherence_equals_the_classical_traversal(
        seed in any::<u64>(), n in 1usize..48, dynamic in any::<bool>(), cut in 3usize..12,
    ) {
        let (mut scene, animation) = random_moving_scene(seed, n, dynamic);
        let mut classical = cullers(&scene, Coherence::Off, 40);
        let mut coherent = cullers(&scene, Coherence::Exact, 40);
        let (mut a, mut b) = (CullOutput::default(), CullOutput::default());
        let mut rng = Rng::new(seed ^ 0x5eed);
        for (frame, camera) in cut_camera_path(seed, 24, cut).iter().enumerate() {
            animation.apply(&mut scene, frame as f32 / 10.0);
            if frame == 12 {
                // The engine changes the scene's structure mid-walk (a static object goes).
                let fixed: Vec<u32> = scene.live_objects().filter(|o| !o.1.is_dynamic()).map(|o| o.0).collect();
                if !fixed.is_empty() {
                    scene.remove_object(fixed[rng.below(fixed.len() as u64) as usize]).unwrap();
                }
                let m = scene.add_mesh(cube());
                scene.add_object("late", m, Mat4::from_translation(Vec3::new(0.0, 0.0, -2.0))).unwrap();
            }
            for (x, y) in classical.iter_mut().zip(coherent.iter_mut()) {
                x.cull(&scene, &camera.to_view(), &mut a).unwrap();
                y.cull(&scene, &camera.to_view(), &mut b).unwrap();
                prop_assert_eq!(&a.visible, &b.visible, "{} frame {}: visible", x.name(), frame);
                prop_assert_eq!(&a.occluded, &b.occluded, "{} frame {}: occluded", x.name(), frame);
                prop_assert_eq!(a.stats.tests_skipped().unwrap_or(0), 0);
            }
        }
    }

    #[test]
    fn skip_coherence_never_culls_what_the_oracle_sees(
        seed in any::<u64>(), n in 1usize..40, dynamic in any::<bool>(), cut in 3usize..12, fixed in any::<bool>(),
    ) {
        let (mut scene, animation) = random_moving_scene(seed, n, dynamic);
        let p = if fixed { PSkip::Fixed(0.9) } else { PSkip::Auto };
        let mut exact = cullers(&scene, Coherence::Exact, 40);
        let mut skip = cullers(&scene, Coherence::Skip(p), 40);
        let mut a = CullOutput::default();
        for (frame, camera) in cut_camera_path(seed, 16, cut).iter().enumerate() {
            animation.apply(&mut scene, frame as f32 / 10.0);
            for (x, y) in exact.iter_mut().zip(skip.iter_mut()) {
                x.cull(&scene, &camera.to_view(), &mut a).unwrap();
                let b = assert_no_false_culls(&scene, camera, y.as_mut());
                // Assumed visible: drawn in excess, never culled in excess.
                for id in &a.visible {
                    prop_assert!(b.visible.binary_search(id).is_ok(), "{} frame {}: {} culled", y.name(), frame, id);
                }
            }
        }
    }
}

/// A wall, and a box behind it that moves out sideways from frame `k` on.
fn peek_scene() -> (Scene, u32) {
    let mut b = SceneBuilder::new("peek");
    let m = b.add_mesh(cube());
    let wall = Mat4::from_scale_rotation_translation(Vec3::new(8.0, 6.0, 0.5), Default::default(), Vec3::ZERO);
    b.add_object("wall", m, wall).unwrap();
    for i in 0..6 {
        // Static boxes behind the wall, so its subtree has nodes to reuse.
        let at = Vec3::new(i as f32 - 2.5, 0.0, -6.0);
        b.add_object(format!("hidden{i}"), m, Mat4::from_translation(at))
            .unwrap();
    }
    let mover = b
        .add_dynamic_object("mover", m, Mat4::from_translation(Vec3::new(0.0, 0.0, -3.0)))
        .unwrap();
    (b.build().unwrap(), mover)
}

#[test]
fn an_object_coming_out_from_behind_a_wall_is_drawn_in_that_frame() {
    let camera = Camera::new(Vec3::new(0.0, 0.0, 10.0), Vec3::ZERO, Vec3::Y, 0.8, 0.1, 100.0, 96, 72);
    let k = 20;
    for coherence in [
        Coherence::Off,
        Coherence::Exact,
        Coherence::Skip(PSkip::Fixed(1.0)),
        Coherence::Skip(PSkip::Auto),
    ] {
        let (mut scene, mover) = peek_scene();
        // Only the wall (12 triangles) occludes.
        for mut culler in cullers(&scene, coherence, 12) {
            for frame in 0..k + 3 {
                // Behind the wall until frame k, then past its edge.
                let x = if frame < k { 0.0 } else { 6.0 };
                scene
                    .set_transform(mover, Mat4::from_translation(Vec3::new(x, 0.0, -3.0)))
                    .unwrap();
                let out = assert_no_false_culls(&scene, &camera, culler.as_mut());
                let seen = out.visible.binary_search(&mover).is_ok();
                if frame < k {
                    assert!(
                        !seen,
                        "{coherence} {}: frame {frame} culls the hidden mover",
                        culler.name()
                    );
                } else if frame >= k {
                    assert!(seen, "{coherence} {}: frame {frame} draws the mover", culler.name());
                }
            }
            // The boxes that stay behind the wall are still culled: the walk had something to reuse.
            let mut out = CullOutput::default();
            culler.cull(&scene, &camera.to_view(), &mut out).unwrap();
            assert_eq!(out.occluded.len(), 6, "{coherence} {}", culler.name());
        }
    }
}

#[test]
fn on_the_city_walk_exact_saves_tests_and_skip_saves_more_drawing_a_superset() {
    let b = hom_scene::builtin("city").unwrap();
    let path = b.path.with_viewport(256, 256);
    let config = |coherence| HomConfig {
        coherence,
        ..HomConfig::for_scene(&b.scene)
    };
    let mut off = HomCuller::new(&b.scene, config(Coherence::Off));
    let mut exact = HomCuller::new(&b.scene, config(Coherence::Exact));
    let mut skip = HomCuller::new(&b.scene, config(Coherence::Skip(PSkip::Auto)));
    let (mut o, mut e, mut s) = (CullOutput::default(), CullOutput::default(), CullOutput::default());
    let tests = |out: &CullOutput| out.stats.node_tests().unwrap_or(0) + out.stats.object_tests().unwrap_or(0);
    let (mut t_off, mut t_exact, mut t_skip) = (0, 0, 0);
    for i in (0..path.frames.len()).take(60) {
        let view = path.camera(i).to_view();
        off.cull(&b.scene, &view, &mut o).unwrap();
        exact.cull(&b.scene, &view, &mut e).unwrap();
        skip.cull(&b.scene, &view, &mut s).unwrap();
        assert_eq!((&o.visible, &o.occluded), (&e.visible, &e.occluded), "frame {i}");
        assert!(
            o.visible.iter().all(|id| s.visible.binary_search(id).is_ok()),
            "frame {i}"
        );
        (t_off, t_exact, t_skip) = (t_off + tests(&o), t_exact + tests(&e), t_skip + tests(&s));
    }
    // Measured: 44 % and 65 % fewer over the whole walk at 1024².
    assert!(t_exact * 10 < t_off * 7, "exact {t_exact} of {t_off}");
    assert!(t_skip * 10 < t_exact * 9, "skip {t_skip} of exact {t_exact}");
}

/// hom's own state (model and occluder databases, selection, temporal state;
/// the occlusion buffer apart) stays within the bound of 256 bytes per
/// object, and the temporal state is 8 bytes per BVH node and per object (a
/// binary BVH has fewer than two nodes per object).
#[test]
fn state_per_object_stays_small() {
    let (scene, _) = random_moving_scene(7, 400, false);
    let n = scene.objects().len() as u64;
    let camera = Camera::new(Vec3::new(0.0, 0.5, 14.0), Vec3::ZERO, Vec3::Y, 1.1, 0.1, 100.0, 64, 48);
    for mut culler in cullers(&scene, Coherence::Exact, 2000) {
        let mut out = CullOutput::default();
        for _ in 0..2 {
            culler.cull(&scene, &camera.to_view(), &mut out).unwrap();
        }
        let memory = out.stats.memory.expect("an occluder culler's frame");
        let (state, temporal) = (memory.state_bytes, memory.temporal_bytes);
        assert!(state <= 256 * n, "{}: {state} bytes for {n} objects", culler.name());
        assert!(
            temporal >= 8 * n && temporal < 8 * 3 * n,
            "{}: {temporal} temporal bytes",
            culler.name()
        );
    }
}
