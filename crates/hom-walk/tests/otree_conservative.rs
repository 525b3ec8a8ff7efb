//! The occlusion-tree culler (Bittner et al. 1998) never culls an object the
//! oracle sees: random static and dynamic scenes with every object a
//! possible occluder (the built-in walks: `builtin_walks.rs`).

use hom::cull::{Culler, OtreeConfig, OtreeCuller, TreeOptions};
use hom::geom::Camera;
use hom::glam::Vec3;
use hom_testkit::{assert_culls_a_fair_share, assert_no_false_culls, permissive_hom, random_moving_scene};
use proptest::prelude::*;

/// Every object may be an occluder: the strongest test of the tree.
fn permissive() -> OtreeConfig {
    permissive_hom(60).with_buffer(TreeOptions::default())
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
