//! The occlusion-tree culler (Bittner et al. 1998) never culls an object the
//! oracle sees: random static and dynamic scenes with every object a
//! possible occluder, and a few frames of every built-in walk.

use hom::cull::{Culler, OccluderConfig, OtreeConfig, OtreeCuller};
use hom::geom::Camera;
use hom::glam::Vec3;
use hom_render::Renderer;
use hom_testkit::{assert_culls_a_fair_share, assert_no_false_culls, permissive_occluders, random_moving_scene};
use hom_walk::{cullers, walk, WalkOptions};
use proptest::prelude::*;

/// Every object may be an occluder: the strongest test of the tree.
fn permissive() -> OtreeConfig {
    let mut c = OtreeConfig {
        occluders: OccluderConfig {
            occluder_db: permissive_occluders(),
            ..OccluderConfig::default()
        },
        ..OtreeConfig::default()
    };
    c.occluders.selection.budget = 60;
    c
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]
    #[test]
    fn otree_never_culls_what_the_oracle_sees(
        seed in any::<u64>(), n in 1usize..40, eye in (-14.0f32..14.0, -2.0f32..4.0, -14.0f32..14.0),
        look in (-1.0f32..1.0, -0.3f32..0.3, -1.0f32..1.0), dynamic in any::<bool>(), time in 0.0f32..5.0,
        size in (8u32..120, 8u32..90),
    ) {
        let (mut scene, animation) = random_moving_scene(seed, n, dynamic);
        animation.apply(&mut scene, time);
        let eye = Vec3::new(eye.0, eye.1, eye.2);
        let camera = Camera::new(eye, eye + Vec3::new(look.0, look.1, look.2 + 1e-3), Vec3::Y, 1.2, 0.1, 100.0, size.0, size.1);
        prop_assume!(camera.validate().is_ok());
        let mut culler = OtreeCuller::new(&scene, permissive());
        // Two frames, so the second runs after the feedback of the first.
        assert_no_false_culls(&scene, &camera, &mut culler);
        culler.frame_done(Some(1.0));
        assert_no_false_culls(&scene, &camera, &mut culler);
    }
}

/// The property test above is only meaningful if culling happens.
#[test]
fn random_scenes_are_really_culled() {
    assert_culls_a_fair_share(|scene| Box::new(OtreeCuller::new(scene, permissive())));
}

/// A few frames of every built-in walk (default settings) at a reduced
/// size, against the oracle; and it culls on the city walk.
#[test]
fn sampled_builtin_walks_have_no_false_culls() {
    let renderer = Renderer::new(0).unwrap();
    for (name, _) in hom_scene::BUILTIN_SCENES {
        let built = hom_scene::builtin(name).unwrap();
        let (mut scene, animation) = (built.scene, built.animation);
        let mut path = built.path.with_viewport(240, 180);
        path.frames = path.frames.iter().copied().step_by(30).collect();
        let mut culler = cullers::make("otree", &scene, &cullers::CullerSettings::for_scene(&scene)).unwrap();
        assert_eq!(culler.name(), "otree");
        let options = WalkOptions {
            oracle: true,
            baseline: false,
            ..WalkOptions::default()
        };
        let result = walk(
            &mut scene,
            &animation,
            &path,
            culler.as_mut(),
            &renderer,
            &options,
            |_| {},
        )
        .unwrap();
        for f in &result.frames {
            let oracle = f.oracle.as_ref().unwrap();
            assert!(
                oracle.false_culls.is_empty(),
                "{name} frame {}: false culls {:?}",
                f.frame,
                oracle.false_culls
            );
        }
        if *name == "city" {
            let culled: u64 = result.frames.iter().map(|f| f.objects_occlusion_culled).sum();
            assert!(culled > 0, "the occlusion tree culls something on the city walk");
        }
    }
}
