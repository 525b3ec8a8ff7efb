//! Hierarchical visibility (`--culler hv`) against the oracle.
//!
//! The relation tested is equality: HV's visible set is exactly the set of
//! objects owning a pixel in the reference renderer's item buffer (no false
//! culls, and every object HV culls owns no pixel), because HV's depth and
//! item buffers equal the renderer's bit for bit (also tested): every triangle
//! that owns a sample is drawn, with the renderer's setup, depth and
//! tie-breaking (see `hom::cull::hv`).

use hom::cull::{Coherence, CullOutput, Culler, HvConfig, HvCuller, HvStats, PSkip};
use hom::experimental::HvPriming;
use hom::geom::Camera;
use hom::glam::Vec3;
use hom::scene::Scene;
use hom::spatial::OctreeConfig;
use hom_render::{Framebuffer, Renderer};
use hom_testkit::{random_moving_scene, random_scene};
use hom_walk::{walk, WalkOptions};
use proptest::prelude::*;

/// HV's statistics of the frame in `out`.
fn hv_stats(out: &CullOutput) -> HvStats {
    out.stats.hv.expect("HV reports its statistics")
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
    assert!(hv_stats(&out).objects_passing >= out.visible.len() as u64);
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
        ..HvConfig::default()
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

fn mode(k: u8) -> Coherence {
    match k % 4 {
        0 => Coherence::Off,
        1 => Coherence::Exact,
        2 => Coherence::Skip(PSkip::Auto),
        _ => Coherence::Skip(PSkip::Fixed(0.9)),
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 40, ..ProptestConfig::default() })]
    /// Coherence and temporal priming reuse last frame's state; the visible
    /// set stays exact on every frame of a random walk with jumps and moving
    /// objects, in every mode, with and without priming.
    #[test]
    fn hv_stays_exact_over_frames_with_coherence_and_priming(
        seed in any::<u64>(), n in 1usize..40, dynamic in any::<bool>(), k in 0u8..4, priming in any::<bool>(),
        steps in proptest::collection::vec((-1.0f32..1.0, -1.0f32..1.0, 0u8..6), 2..6),
    ) {
        let (mut scene, animation) = random_moving_scene(seed, n, dynamic);
        let config = HvConfig { coherence: mode(k), priming: priming.then_some(HvPriming), ..config(4, 6, seed % 2 == 0, true) };
        let mut hv = HvCuller::new(&scene, config);
        let mut eye = Vec3::new(0.0, 0.5, 12.0);
        let mut look = Vec3::ZERO;
        for (t, &(dx, dz, jump)) in steps.iter().enumerate() {
            if jump == 0 {
                // A cut: the other side of the scene, looking back.
                eye = Vec3::new(-eye.x, eye.y, -eye.z);
            } else {
                eye += Vec3::new(dx, 0.0, dz) * 0.5;
            }
            look += Vec3::new(dz, 0.0, dx) * 0.3;
            let camera = Camera::new(eye, look + Vec3::new(0.0, 0.0, 1e-3), Vec3::Y, 1.2, 0.1, 100.0, 64, 48);
            prop_assume!(camera.validate().is_ok());
            animation.apply(&mut scene, t as f32 * 0.3);
            let out = assert_exact(&scene, &camera, &mut hv);
            if !priming || t == 0 {
                prop_assert_eq!(hv_stats(&out).nodes_primed + hv_stats(&out).objects_primed, 0);
            }
        }
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
        let s = hv_stats(&out);
        nodes_occluded += s.nodes_occluded;
        hv_cmp += s.draw.sample_tests;
        zb_cmp += s.zbuffer_depth_comparisons.unwrap_or(0);
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
            assert_eq!(f.visible_clusters, oracle.oracle_visible, "{name} frame {}", f.frame);
            assert!(f.stats.hv.unwrap().depth_comparisons() > 0, "{name} frame {}", f.frame);
        }
    }
}

/// Hierarchy updating saves pyramid tests on a walk without changing the
/// visible set, and priming (drawing last frame's visible nodes first) saves
/// more without drawing much more.
#[test]
fn coherence_and_priming_save_work_on_the_city_walk() {
    let renderer = Renderer::new(0).unwrap();
    let built = hom_scene::builtin("city").unwrap();
    let path = {
        let mut p = built.path.with_viewport(320, 240);
        p.frames.truncate(40);
        p
    };
    let run = |coherence, priming: bool| {
        let mut scene = built.scene.clone();
        let config = HvConfig {
            coherence,
            priming: priming.then_some(HvPriming),
            count_zbuffer: false,
            ..HvConfig::default()
        };
        let mut culler = HvCuller::new(&scene, config);
        let options = WalkOptions {
            oracle: false,
            baseline: false,
            ..WalkOptions::default()
        };
        walk(
            &mut scene,
            &built.animation,
            &path,
            &mut culler,
            &renderer,
            &options,
            |_| {},
        )
        .unwrap()
    };
    let sum = |w: &hom_walk::WalkResult, c: fn(&HvStats) -> u64| {
        w.frames.iter().map(|f| c(&f.stats.hv.unwrap())).sum::<u64>()
    };
    let classical = run(Coherence::Off, false);
    let exact = run(Coherence::Exact, false);
    let primed = run(Coherence::Exact, true);
    for ((a, b), c) in classical.frames.iter().zip(&exact.frames).zip(&primed.frames) {
        assert_eq!(a.visible_clusters, b.visible_clusters, "frame {}", a.frame);
        assert_eq!(a.visible_clusters, c.visible_clusters, "frame {}", a.frame);
    }
    let (off, on) = (sum(&classical, |s| s.node_tests), sum(&exact, |s| s.node_tests));
    assert!(on * 100 < off * 95, "exact made {on} node tests, classical {off}");
    // Primed leaves are drawn without a test, and their triangles are not drawn twice.
    assert!(sum(&primed, |s| s.nodes_primed) > 0);
    assert!(sum(&primed, |s| s.node_tests) < on, "priming saved no node tests");
    let submitted = |w| sum(w, |s| s.triangles_submitted);
    assert!(
        submitted(&primed) <= submitted(&exact) * 21 / 20,
        "priming drew {} triangles, exact {}",
        submitted(&primed),
        submitted(&exact)
    );
}
