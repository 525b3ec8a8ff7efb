//! Level of detail in the walkthrough, against the full-resolution truth:
//! guidance changes no pixel, every drawn node is within the pixel
//! threshold, culling stays conservative, the finest cut draws exactly the
//! meshes, and the budget is held.

use hom::lod::{LodConfig, LodOptions, LodSelector, LodView, SceneLod};
use hom_render::{Framebuffer, RenderOptions, Renderer};
use hom_walk::lod::{budget_binds, draw_parts, WalkLod};
use hom_walk::{cullers, walk, WalkOptions};
use std::sync::Arc;

fn lod_walk(scene: &str, culler: &str, options: LodOptions, step: usize) -> hom_walk::WalkResult {
    lod_walk_with(scene, culler, options, step, false, true)
}

/// [`lod_walk`] with occluders at the level of detail or not, and the cost model on or off.
fn lod_walk_with(
    scene: &str,
    culler: &str,
    options: LodOptions,
    step: usize,
    occluders: bool,
    cost_model: bool,
) -> hom_walk::WalkResult {
    let built = hom_scene::builtin(scene).unwrap();
    let (mut scene, animation) = (built.scene, built.animation);
    let mut path = built.path.with_viewport(400, 300);
    path.frames = path.frames.iter().copied().step_by(step).collect();
    let hierarchies = Arc::new(SceneLod::build(&scene, &LodConfig::default(), &|_, _| {}).unwrap());
    let mut settings = cullers::CullerSettings::for_scene(&scene);
    settings.hom.cost_model = cost_model;
    let mut culler = cullers::make(culler, &scene, &settings).unwrap();
    let walk_options = WalkOptions {
        oracle: true,
        baseline: false,
        lod: Some(WalkLod {
            hierarchies,
            options,
            occluders,
        }),
        ..WalkOptions::default()
    };
    let renderer = Renderer::new(0).unwrap();
    walk(
        &mut scene,
        &animation,
        &path,
        culler.as_mut(),
        &renderer,
        &walk_options,
        |_| {},
    )
    .unwrap()
}

#[test]
fn guidance_changes_no_pixel_and_every_node_is_within_the_threshold() {
    for (scene, culler) in [("terrain", "hom"), ("city", "hzb")] {
        let result = lod_walk(scene, culler, LodOptions::default(), 15);
        let mut saved = 0;
        for f in &result.frames {
            let oracle = f.oracle.as_ref().unwrap();
            assert!(oracle.false_culls.is_empty(), "{scene} frame {}: false culls", f.frame);
            let lod = f.lod.as_ref().unwrap();
            assert_eq!(
                lod.lod_guidance_pixels_changed,
                Some(0),
                "{scene} frame {}: guidance changed the image",
                f.frame
            );
            assert!(
                lod.lod_max_error_px <= 1.0,
                "{scene} frame {}: {} px",
                f.frame,
                lod.lod_max_error_px
            );
            // Within a pixel of the full meshes: only silhouette pixels may change owner.
            let differ = lod.lod_pixels_differ_from_full.unwrap();
            assert!(
                differ * 100 < u64::from(f.width * f.height),
                "{scene} frame {}: {differ} pixels",
                f.frame
            );
            let unguided = lod.lod_unguided_triangles.unwrap();
            assert!(
                lod.lod_triangles <= unguided,
                "{scene} frame {}: guidance drew more",
                f.frame
            );
            assert!(unguided <= lod.lod_view_only_triangles, "{scene} frame {}", f.frame);
            assert!(
                lod.lod_triangles <= f.triangles_drawn,
                "{scene} frame {}: lod drew more than the meshes",
                f.frame
            );
            saved += lod.lod_nodes_occluded;
        }
        let summary = result.summary.lod.as_ref().unwrap();
        assert!(
            summary.lod_triangles < summary.lod_view_only_triangles,
            "{scene}: no saving"
        );
        if scene == "terrain" {
            assert!(saved > 0, "terrain: guidance kept no hidden node coarse");
        }
    }
}

#[test]
fn the_finest_cut_draws_exactly_the_meshes() {
    let built = hom_scene::builtin("terrain").unwrap();
    let scene = built.scene;
    let lod = SceneLod::build(&scene, &LodConfig::default(), &|_, _| {}).unwrap();
    let renderer = Renderer::new(0).unwrap();
    let camera = built.path.with_viewport(320, 240).camera(40);
    let ids: Vec<u32> = (0..scene.objects().len() as u32).collect();
    let mut selector = LodSelector::default();
    let mut parts = Vec::new();
    let finest = LodOptions {
        error_px: f32::MIN_POSITIVE,
        guidance: false,
        budget: None,
    };
    let view = LodView::new(&camera.to_view()).unwrap();
    selector
        .select(&scene, &lod, &ids, &view, &finest, &mut |_| false, &mut parts)
        .unwrap();
    let (mut whole, mut cut) = (Framebuffer::new(1, 1), Framebuffer::new(1, 1));
    let draw = RenderOptions::default();
    renderer.render(&scene, &ids, &camera, &draw, &mut whole);
    renderer.render_parts(&scene, &draw_parts(&scene, &lod, &parts), &camera, &draw, &mut cut);
    // Leaves are the original triangles; objects out of the frustum stay coarse but are not seen.
    assert_eq!(whole.items(), cut.items());
    assert_eq!(whole.color(), cut.color());
}

#[test]
fn the_budget_is_held_on_the_city_walk() {
    let budget = 12_000;
    let options = LodOptions {
        budget: Some(budget),
        ..LodOptions::default()
    };
    let result = lod_walk("city", "hom", options, 10);
    let mut binding = 0;
    for f in &result.frames {
        let lod = f.lod.as_ref().unwrap();
        if lod.lod_coarsest_triangles <= budget {
            assert!(
                lod.lod_triangles <= budget,
                "frame {}: {} triangles",
                f.frame,
                lod.lod_triangles
            );
        }
        if budget_binds(lod, budget) {
            binding += 1;
            assert!(
                lod.lod_triangles * 20 >= budget * 19,
                "frame {}: {} triangles",
                f.frame,
                lod.lod_triangles
            );
        }
    }
    assert!(
        binding * 2 > result.frames.len(),
        "the budget binds on {binding} frames only"
    );
    let summary = result.summary.lod.as_ref().unwrap();
    assert_eq!(summary.lod_frames_within_budget, Some(1.0));
}

/// Occluders drawn at the level of detail the frame shows: what they hide
/// is hidden in the image of the cuts (no pixel of the frame differs from
/// view-only level of detail of the whole frustum, nothing culled), and on
/// the terrain, whose tiles are big meshes seen far, the same budget buys
/// more occluders that hide more.
#[test]
fn occluders_at_the_level_of_detail_change_no_pixel_and_hide_more_on_terrain() {
    let run = |occluders: bool| lod_walk_with("terrain", "hom", LodOptions::default(), 15, occluders, false);
    let (whole, cut) = (run(false), run(true));
    assert!(!whole.summary.lod.as_ref().unwrap().lod_occluders);
    assert!(cut.summary.lod.as_ref().unwrap().lod_occluders);
    let mut cuts = 0;
    for f in &cut.frames {
        let lod = f.lod.as_ref().unwrap();
        assert_eq!(
            lod.lod_culling_pixels_changed,
            Some(0),
            "frame {}: culling changed the image",
            f.frame
        );
        assert_eq!(lod.lod_guidance_pixels_changed, Some(0), "frame {}", f.frame);
        cuts += f.stats.occluders.and_then(|o| o.cuts).unwrap_or(0);
    }
    assert!(cuts > 0, "no occluder was drawn as a cut");
    let occluded = |r: &hom_walk::WalkResult| r.frames.iter().map(|f| f.triangles_occlusion_culled).sum::<u64>();
    assert!(
        occluded(&cut) > occluded(&whole),
        "cuts hid {} triangles, whole meshes {}",
        occluded(&cut),
        occluded(&whole)
    );
}
