//! The kD-tree with ropes and visibility propagation (Bittner & Havran 2002)
//! as the occluder cullers' hierarchy: never a false cull against the oracle
//! (random scenes with moving, added and removed objects, coherence off,
//! exact and skip; built-in walks), propagation does classify nodes on a
//! walk where walls hide streets, and is off without `propagation`.
//!
//! The kD traversal's visible sets are not compared with the BVH's: other
//! boxes make other tests (a kD region may be found occluded where the BVH
//! node around the same objects is not, and the reverse).

use hom::cull::{Coherence, CullStats, Culler, Hierarchy, HomConfig, PSkip};
use hom::experimental::KdTree;
use hom::glam::{Mat4, Vec3};
use hom::scene::Scene;
use hom_render::Renderer;
use hom_testkit::{
    assert_no_false_culls, cube, cut_camera_path, occluder_cullers, permissive_hom, random_moving_scene, Rng,
};
use hom_walk::{cullers, walk, WalkOptions};
use proptest::prelude::*;

const PROPAGATE: Hierarchy = Hierarchy::KdTree(KdTree { propagation: true });

/// HOM, HZB and masked over `hierarchy` with every object an occluder candidate.
fn kd_cullers(scene: &Scene, hierarchy: Hierarchy, coherence: Coherence, budget: u32) -> Vec<Box<dyn Culler>> {
    let hom = HomConfig {
        coherence,
        hierarchy,
        ..permissive_hom(budget)
    };
    occluder_cullers(scene, &hom)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]
    #[test]
    fn kd_propagation_never_culls_what_the_oracle_sees(
        seed in any::<u64>(), n in 1usize..48, dynamic in any::<bool>(), cut in 3usize..12, mode in 0u8..3,
    ) {
        let (mut scene, animation) = random_moving_scene(seed, n, dynamic);
        let coherence = [Coherence::Off, Coherence::Exact, Coherence::Skip(PSkip::Auto)][mode as usize];
        let mut cullers = kd_cullers(&scene, PROPAGATE, coherence, 40);
        let mut rng = Rng::new(seed ^ 0x5eed);
        for (frame, camera) in cut_camera_path(seed, 16, cut).iter().enumerate() {
            animation.apply(&mut scene, frame as f32 / 10.0);
            if frame == 8 {
                // The engine changes the scene's structure mid-walk.
                let fixed: Vec<u32> = scene.live_objects().filter(|o| !o.1.is_dynamic()).map(|o| o.0).collect();
                if !fixed.is_empty() {
                    scene.remove_object(fixed[rng.below(fixed.len() as u64) as usize]).unwrap();
                }
                let m = scene.add_mesh(cube());
                scene.add_object("late", m, Mat4::from_translation(Vec3::new(0.0, 0.0, -2.0))).unwrap();
            }
            for c in cullers.iter_mut() {
                let out = assert_no_false_culls(&scene, camera, c.as_mut());
                // Reported once: ascending and distinct, and never both drawn and occluded.
                prop_assert!(out.visible.windows(2).all(|w| w[0] < w[1]), "{} frame {}", c.name(), frame);
                prop_assert!(out.occluded.windows(2).all(|w| w[0] < w[1]), "{} frame {}", c.name(), frame);
                prop_assert!(out.occluded.iter().all(|id| out.visible.binary_search(id).is_err()));
            }
        }
    }
}

/// Walks `name`'s path (every `step`th frame, at 256×192) with `culler` over
/// `hierarchy`, oracle on; returns the sums of the statistics `stats` after
/// asserting no false culls.
fn walk_builtin(
    name: &str,
    culler: &str,
    hierarchy: Hierarchy,
    step: usize,
    stats: &[fn(&CullStats) -> Option<u64>],
) -> Vec<u64> {
    let built = hom_scene::builtin(name).unwrap();
    let (mut scene, animation) = (built.scene, built.animation);
    let mut path = built.path.with_viewport(256, 192);
    path.frames = path.frames.iter().copied().step_by(step).collect();
    let mut settings = cullers::CullerSettings::for_scene(&scene);
    settings.hom.hierarchy = hierarchy;
    let mut c = cullers::make(culler, &scene, &settings).unwrap();
    let options = WalkOptions {
        oracle: true,
        baseline: false,
        ..WalkOptions::default()
    };
    let renderer = Renderer::new(0).unwrap();
    let result = walk(&mut scene, &animation, &path, c.as_mut(), &renderer, &options, |_| {}).unwrap();
    for f in &result.frames {
        let oracle = f.oracle.as_ref().unwrap();
        assert!(
            oracle.false_culls.is_empty(),
            "{name} / {culler} / {hierarchy} frame {}: false culls {:?}",
            f.frame,
            oracle.false_culls
        );
    }
    stats
        .iter()
        .map(|stat| result.frames.iter().filter_map(|f| stat(&f.stats)).sum())
        .collect()
}

#[test]
fn builtin_walks_over_the_kd_tree_have_no_false_culls() {
    for name in ["city", "machine-room", "dynamic"] {
        for culler in ["hom", "hzb"] {
            walk_builtin(name, culler, PROPAGATE, 16, &[]);
        }
    }
}

#[test]
fn on_the_city_walk_propagation_classifies_nodes_and_is_off_without_it() {
    let counters: [fn(&CullStats) -> Option<u64>; 3] = [
        |s| s.traversal.and_then(|t| t.propagation).map(|p| p.attempts),
        |s| s.traversal.and_then(|t| t.propagation).map(|p| p.propagated),
        CullStats::node_tests,
    ];
    let with = walk_builtin("city", "hzb", PROPAGATE, 4, &counters);
    assert!(
        with[0] > 0 && with[1] > 0,
        "attempts {} propagated {}",
        with[0],
        with[1]
    );
    assert!(with[1] < with[0], "not every attempt succeeds");
    let without = walk_builtin(
        "city",
        "hzb",
        Hierarchy::KdTree(KdTree { propagation: false }),
        4,
        &counters,
    );
    assert_eq!(&without[..2], &[0, 0]);
    assert!(without[2] > 0);
}
