//! The hierarchical Z-buffer culler (Greene et al. 1993; the HOM paper's
//! section 7.2 variation) never culls an object the oracle sees, with either
//! depth representation (per sample, or masked), and the occluder
//! rasterizer's per-sample depth is the reference renderer's depth.

use hom::cull::{Culler, HzbCuller, MaskedCuller};
use hom::geom::Camera;
use hom::glam::Vec3;
use hom::occlusion::HzBuffer;
use hom::scene::Scene;
use hom_render::{Framebuffer, Renderer, NO_OBJECT};
use hom_testkit::{
    assert_culls_a_fair_share, assert_no_false_culls, draw_objects, exact, occluder_raster_case, permissive_hom,
    random_moving_scene,
};
use proptest::prelude::*;

/// The HZB culler (per-sample depth), or the masked culler when `masked`,
/// with every object an occluder: the strongest test of the depth logic.
fn permissive(scene: &Scene, masked: bool) -> Box<dyn Culler> {
    let config = permissive_hom(60).with_buffer(());
    if masked {
        Box::new(MaskedCuller::new(scene, config))
    } else {
        Box::new(HzbCuller::new(scene, config))
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 160, ..ProptestConfig::default() })]
    #[test]
    fn hzb_never_culls_what_the_oracle_sees(
        seed in any::<u64>(), n in 1usize..40, eye in (-14.0f32..14.0, -2.0f32..4.0, -14.0f32..14.0),
        look in (-1.0f32..1.0, -0.3f32..0.3, -1.0f32..1.0), dynamic in any::<bool>(), time in 0.0f32..5.0,
        size in (8u32..120, 8u32..90), masked in any::<bool>(),
    ) {
        let (mut scene, animation) = random_moving_scene(seed, n, dynamic);
        animation.apply(&mut scene, time);
        let eye = Vec3::new(eye.0, eye.1, eye.2);
        let camera = Camera::new(eye, eye + Vec3::new(look.0, look.1, look.2 + 1e-3), Vec3::Y, 1.2, 0.1, 100.0, size.0, size.1);
        prop_assume!(camera.validate().is_ok());
        let mut culler = permissive(&scene, masked);
        // Two frames, so the second uses the feedback (hole filling) of the first.
        assert_no_false_culls(&scene, &camera, culler.as_mut());
        culler.frame_done(Some(1.0));
        assert_no_false_culls(&scene, &camera, culler.as_mut());
    }
}

/// The property test above is only meaningful if culling happens.
#[test]
fn random_scenes_are_really_culled() {
    for masked in [false, true] {
        assert_culls_a_fair_share(|scene| permissive(scene, masked));
    }
}

/// The rasterizer's per-sample depth equals the renderer's depth buffer
/// wherever the renderer drew an occluder, and is infinite elsewhere.
#[test]
fn per_sample_depth_equals_the_renderers_depth_buffer() {
    for seed in 0..20u64 {
        let (scene, camera, ids) = occluder_raster_case(seed);
        // The HZB culler's buffer (tiled rasterizer: rejection, vector kernels).
        let mut buf = HzBuffer::new(camera.width, camera.height, exact()).unwrap();
        draw_objects(&mut buf, &scene, &ids, &camera);
        let mut depth = Vec::new();
        buf.zbuffer().to_row_major(&mut depth);
        assert_eq!(depth.len(), (camera.width * camera.height) as usize);
        let renderer = Renderer::new(2).unwrap();
        let mut fb = Framebuffer::new(camera.width, camera.height);
        let item_only = hom_render::RenderOptions {
            shading: hom_render::Shading::ItemOnly,
            ..Default::default()
        };
        renderer.render(&scene, &ids, &camera, &item_only, &mut fb);
        let mut drawn = 0;
        for (i, &d) in depth.iter().enumerate() {
            if fb.items()[i] == NO_OBJECT {
                // Not drawn: uncovered (or only covered at or beyond the far plane).
                assert!(d >= 1.0, "seed {seed} sample {i}: depth {d} where nothing was drawn");
                continue;
            }
            assert_eq!(d, fb.depth()[i], "seed {seed} sample {i}");
            drawn += 1;
        }
        assert!(drawn > 0, "seed {seed}: the occluders cover something");
    }
}
