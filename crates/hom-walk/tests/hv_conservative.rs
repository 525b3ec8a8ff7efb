//! Hierarchical visibility (`--culler hv`) against the oracle.
//!
//! The relation tested is equality: HV's visible set is exactly the set of
//! objects owning a pixel in the reference renderer's item buffer (no false
//! culls, and every object HV culls owns no pixel), because HV's depth and
//! item buffers equal the renderer's bit for bit (also tested): every triangle
//! that owns a sample is drawn, with the renderer's setup, depth and
//! tie-breaking (see `hom::cull::hv`).

use hom::cull::{CullOutput, Culler, HvConfig, HvCuller};
use hom::geom::Camera;
use hom::glam::Vec3;
use hom::scene::Scene;
use hom::spatial::OctreeConfig;
use hom_render::{Framebuffer, Renderer};
use hom_testkit::{random_moving_scene, random_scene};
use hom_walk::{walk, WalkOptions};
use proptest::prelude::*;

fn counter(out: &CullOutput, name: &str) -> u64 {
    out.counters.iter().find(|c| c.0 == name).map_or(0, |c| c.1)
}

/// Culls with HV and checks, against a full render of every object: the
/// depth and item buffers are the renderer's, the visible set is exactly the
/// objects owning a pixel, and the occluded ones own none.
fn assert_exact(scene: &Scene, camera: &Camera, hv: &mut HvCuller) -> CullOutput {
    let renderer = Renderer::new(1).unwrap();
    let mut out = CullOutput::default();
    hv.cull(scene, &camera.to_view(), &mut out).unwrap();
    let mut fb = Framebuffer::new(camera.width, camera.height);
    let counts = hom_render::oracle_pixel_counts(&renderer, scene, camera, &mut fb);
    for (i, (&a, &b)) in hv.depth().iter().zip(fb.depth()).enumerate() {
        assert!(a == b, "sample {i}: HV depth {a}, renderer {b}");
    }
    assert_eq!(hv.depth().len(), fb.depth().len());
    assert!(hv.items() == fb.items(), "item buffers differ");
    let oracle: Vec<u32> = (0..counts.len() as u32).filter(|&id| counts[id as usize] > 0).collect();
    assert_eq!(out.visible, oracle, "visible set is not the oracle's");
    for &id in &out.occluded {
        assert_eq!(counts[id as usize], 0, "object {id} culled as occluded owns pixels");
    }
    assert!(counter(&out, "objects_passing") >= out.visible.len() as u64);
    out
}

fn config(threshold: usize, max_depth: u32, keep_large: bool, triangle_tests: bool) -> HvConfig {
    HvConfig {
        octree: OctreeConfig {
            threshold,
            max_depth,
            keep_large,
        },
        triangle_tests,
        count_zbuffer: true,
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 120, ..ProptestConfig::default() })]
    #[test]
    fn hv_visible_set_is_the_oracles(
        seed in any::<u64>(), n in 1usize..40, eye in (-14.0f32..14.0, -2.0f32..4.0, -14.0f32..14.0),
        look in (-1.0f32..1.0, -0.3f32..0.3, -1.0f32..1.0), dynamic in any::<bool>(), time in 0.0f32..5.0,
        size in (8u32..120, 8u32..90), threshold in 1usize..20, max_depth in 0u32..8, triangle_tests in any::<bool>(), keep_large in any::<bool>(),
    ) {
        let (mut scene, animation) = random_moving_scene(seed, n, dynamic);
        let eye = Vec3::new(eye.0, eye.1, eye.2);
        let camera = Camera::new(eye, eye + Vec3::new(look.0, look.1, look.2 + 1e-3), Vec3::Y, 1.2, 0.1, 100.0, size.0, size.1);
        prop_assume!(camera.validate().is_ok());
        let mut hv = HvCuller::new(&scene, config(threshold, max_depth, keep_large, triangle_tests));
        hv.octree().assert_well_formed(&scene);
        assert_exact(&scene, &camera, &mut hv);
        // A later frame: dynamic objects have moved, the octree is unchanged.
        animation.apply(&mut scene, time);
        assert_exact(&scene, &camera, &mut hv);
    }
}

/// The property above is only meaningful if HV really skips work: over many
/// random views, nodes and triangles are culled by the pyramid and HV makes
/// fewer depth comparisons than a plain z-buffer.
#[test]
fn random_scenes_are_really_culled() {
    let (mut occluded, mut nodes_occluded, mut hv_cmp, mut zb_cmp) = (0, 0, 0, 0);
    for seed in 0..40u64 {
        let scene = random_scene(seed * 31 + 5, 40, seed % 2 == 0);
        let camera = Camera::new(Vec3::new(0.0, 0.5, 13.0), Vec3::ZERO, Vec3::Y, 1.2, 0.1, 100.0, 80, 60);
        let mut hv = HvCuller::new(&scene, config(4, 8, seed % 3 == 0, true));
        let out = assert_exact(&scene, &camera, &mut hv);
        occluded += out.occluded.len();
        nodes_occluded += counter(&out, "nodes_occluded");
        hv_cmp += counter(&out, "sample_tests");
        zb_cmp += counter(&out, "zbuffer_depth_comparisons");
    }
    assert!(occluded > 100, "only {occluded} objects occluded");
    assert!(nodes_occluded > 100, "only {nodes_occluded} nodes occluded");
    assert!(hv_cmp < zb_cmp, "HV tested {hv_cmp} samples, a z-buffer {zb_cmp}");
}

/// Sampled frames of the built-in walks: the visible set equals the oracle's
/// (so 0 false culls) on every one.
#[test]
fn sampled_builtin_walks_are_exact() {
    let renderer = Renderer::new(0).unwrap();
    for (name, _) in hom_scene::BUILTIN_SCENES {
        let built = hom_scene::builtin(name).unwrap();
        let (mut scene, animation) = (built.scene, built.animation);
        let mut path = built.path.with_viewport(320, 240);
        path.frames = path.frames.iter().copied().step_by(25).collect();
        let mut culler = HvCuller::new(&scene, HvConfig::default());
        culler.octree().assert_well_formed(&scene);
        let options = WalkOptions {
            oracle: true,
            baseline: false,
            ..WalkOptions::default()
        };
        let result = walk(&mut scene, &animation, &path, &mut culler, &renderer, &options, |_| {}).unwrap();
        for f in &result.frames {
            let oracle = f.oracle.as_ref().unwrap();
            assert!(
                oracle.false_culls.is_empty(),
                "{name} frame {}: false culls {:?}",
                f.frame,
                oracle.false_culls
            );
            assert_eq!(f.visible, oracle.oracle_visible, "{name} frame {}", f.frame);
            assert!(f.counters["depth_comparisons"] > 0, "{name} frame {}", f.frame);
        }
    }
}
