//! The per-sample depth check after the occluder cullers' traversal
//! (`hom::cull::DepthCheck`): it never culls what the oracle sees, on
//! random scenes, moving or not, and slanted; and it culls an object close
//! behind a sloped hider, which the box tests cannot.

use hom::cull::{CullOutput, Culler, DepthCheck, HomConfig, HomCuller, HzbCuller, MaskedCuller};
use hom::geom::Camera;
use hom::glam::{Mat4, Quat, Vec3};
use hom::scene::{Scene, SceneBuilder};
use hom_testkit::{
    assert_no_false_culls, cube, occluder_cullers, permissive_hom, random_moving_scene, random_slanted_scene,
};
use proptest::prelude::*;

/// Every object may be an occluder, and the check runs in every buffer that can.
fn checking(depth_check: DepthCheck) -> HomConfig {
    HomConfig {
        depth_check,
        cost_model: false,
        ..permissive_hom(60)
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]
    #[test]
    fn the_depth_check_never_culls_what_the_oracle_sees(
        seed in any::<u64>(), n in 1usize..40, eye in (-14.0f32..14.0, -2.0f32..4.0, -14.0f32..14.0),
        look in (-1.0f32..1.0, -0.3f32..0.3, -1.0f32..1.0), dynamic in any::<bool>(), time in 0.0f32..5.0,
        slanted in any::<bool>(),
    ) {
        let scene = if slanted {
            random_slanted_scene(seed, n)
        } else {
            let (mut scene, animation) = random_moving_scene(seed, n, dynamic);
            animation.apply(&mut scene, time);
            scene
        };
        let eye = Vec3::new(eye.0, eye.1, eye.2);
        let camera = Camera::new(eye, eye + Vec3::new(look.0, look.1, look.2 + 1e-3), Vec3::Y, 1.2, 0.1, 100.0, 80, 60);
        prop_assume!(camera.validate().is_ok());
        for mut culler in occluder_cullers(&scene, &checking(DepthCheck::On)) {
            // Two frames: the second classifies with the first's coherence.
            assert_no_false_culls(&scene, &camera, culler.as_mut());
            assert_no_false_culls(&scene, &camera, culler.as_mut());
        }
    }
}

/// Two parallel walls turned 60° from the view, taller than the view, the
/// second `behind` metres behind the first and narrower, seen from the
/// origin at `width` × `height`: the scene, the camera, the near and the far wall.
fn sloped_walls(behind: f32, width: u32, height: u32) -> (Scene, Camera, u32, u32) {
    let mut b = SceneBuilder::new("sloped walls");
    let turn = Quat::from_rotation_y(60f32.to_radians());
    let normal = turn * Vec3::Z;
    let wall = |b: &mut SceneBuilder, behind: f32, s: f32| {
        let m = b.add_mesh(cube());
        let at = Vec3::new(0.0, 0.0, -8.0) - normal * behind;
        b.add_object(
            "wall",
            m,
            Mat4::from_scale_rotation_translation(Vec3::new(s, 40.0, 0.1), turn, at),
        )
        .unwrap()
    };
    let near = wall(&mut b, 0.0, 10.0);
    let far = wall(&mut b, behind, 6.0);
    let camera = Camera::new(Vec3::ZERO, -Vec3::Z, Vec3::Y, 1.0, 0.1, 100.0, width, height);
    (b.build().unwrap(), camera, near, far)
}

/// The far wall 0.3 m behind: its box's nearest corner lies in front of
/// much of the first wall, so no box test culls it; the per-sample check
/// does, in HOM (drawing its occluders' depth for it) and in HZB, and only
/// when on.
#[test]
fn a_wall_close_behind_a_sloped_wall_is_culled_by_the_check_alone() {
    let (scene, camera, near, far) = sloped_walls(0.3, 96, 72);
    let culled = |culler: &mut dyn Culler| -> CullOutput {
        let out = assert_no_false_culls(&scene, &camera, culler);
        assert!(out.visible.contains(&near), "{}: the near wall is seen", culler.name());
        out
    };
    for check in [DepthCheck::Off, DepthCheck::IfDrawn, DepthCheck::On] {
        let config = checking(check);
        let hom = culled(&mut HomCuller::new(&scene, config.clone()));
        let hzb = culled(&mut HzbCuller::new(&scene, config.with_buffer(())));
        let stats = hom.stats.depth_check;
        assert_eq!(
            hom.occluded.contains(&far),
            check == DepthCheck::On,
            "HOM, check {check}: {stats:?}"
        );
        assert_eq!(
            hzb.occluded.contains(&far),
            check != DepthCheck::Off,
            "HZB, check {check}"
        );
        if check == DepthCheck::On {
            let stats = stats.expect("HOM ran the check");
            assert!(
                stats.checked >= 1 && stats.culled >= 1 && stats.tiles_drawn > 0,
                "{stats:?}"
            );
        }
    }
}

/// The masked buffer asks its own layers: a bound per 8×4 subtile, too
/// coarse for 0.3 m at 96 × 72 but enough for 1 m at 384 × 288, where its
/// box test still fails (the near wall's bound across the far wall's
/// rectangle spans metres). Culled by the check, in both modes, and only then.
#[test]
fn the_masked_buffer_checks_against_its_subtile_bounds() {
    let (scene, camera, near, far) = sloped_walls(1.0, 384, 288);
    for check in [DepthCheck::Off, DepthCheck::IfDrawn, DepthCheck::On] {
        let mut culler = MaskedCuller::new(&scene, checking(check).with_buffer(()));
        let out = assert_no_false_culls(&scene, &camera, &mut culler);
        assert!(out.visible.contains(&near), "check {check}: the near wall is seen");
        assert_eq!(out.occluded.contains(&far), check != DepthCheck::Off, "check {check}");
        let stats = out.stats.depth_check;
        assert_eq!(
            stats.is_some_and(|s| s.culled >= 1),
            check != DepthCheck::Off,
            "{stats:?}"
        );
    }
}

/// On every second frame, an object drawn in the frame before is not
/// checked (it stays visible); the others are, and what the check culls
/// stays culled.
#[test]
fn what_was_drawn_rests_every_other_frame() {
    let (scene, camera, near, far) = sloped_walls(1.0, 384, 288);
    let mut culler = MaskedCuller::new(&scene, checking(DepthCheck::IfDrawn).with_buffer(()));
    let stats: Vec<_> = (0..4)
        .map(|frame| {
            let out = assert_no_false_culls(&scene, &camera, &mut culler);
            assert!(out.visible.contains(&near), "frame {frame}: the near wall is seen");
            assert!(out.occluded.contains(&far), "frame {frame}: the far wall is culled");
            out.stats.depth_check.expect("the check ran")
        })
        .collect();
    assert_eq!(stats[0].rested, 0, "{stats:?}");
    assert!(
        stats[0].checked >= 2,
        "the near wall checked and found visible: {stats:?}"
    );
    assert!(stats[1].rested >= 1, "the near wall rests: {stats:?}");
    assert!(
        stats[1].checked >= 1,
        "the far wall, culled, is checked again: {stats:?}"
    );
    assert_eq!(stats[1].checked + stats[1].rested, stats[0].checked, "{stats:?}");
    assert_eq!((stats[2].checked, stats[2].rested), (stats[0].checked, 0), "{stats:?}");
    assert_eq!(
        (stats[3].checked, stats[3].rested),
        (stats[1].checked, stats[1].rested),
        "{stats:?}"
    );
}
