//! The walk's count of the hidden objects a culler leaves drawn, and of the
//! occluders among them (what costs HOM's frames most beside its cull):
//! checked against the frame's own lists, and against the frustum culler,
//! which has no occluders and draws every hidden object in view.

use hom::scene::Scene;
use hom_render::Renderer;
use hom_walk::report::FrameRecord;
use hom_walk::{cullers, walk, WalkOptions, WalkResult};
use std::collections::BTreeSet;

fn run(name: &str, scene: &mut Scene, built: &hom_scene::Builtin, renderer: &Renderer) -> WalkResult {
    let mut path = built.path.clone().with_viewport(128, 96);
    path.frames.truncate(8);
    let mut settings = cullers::CullerSettings::for_scene(scene);
    settings.hom.cost_model = false;
    let mut culler = cullers::make(name, scene, &settings).unwrap();
    let options = WalkOptions {
        oracle: true,
        ..WalkOptions::default()
    };
    walk(
        scene,
        &built.animation,
        &path,
        culler.as_mut(),
        renderer,
        &options,
        |_| {},
    )
    .unwrap()
}

/// The objects a frame drew that own no pixel, and those of them that were occluders.
fn hidden(f: &FrameRecord) -> (BTreeSet<u32>, BTreeSet<u32>) {
    let o = f.oracle.as_ref().expect("walked with the oracle");
    let seen: BTreeSet<u32> = o.oracle_visible.iter().copied().collect();
    let drawn: BTreeSet<u32> = f
        .visible_clusters
        .iter()
        .copied()
        .filter(|id| !seen.contains(id))
        .collect();
    let occluders = drawn.iter().copied().filter(|id| f.occluders.contains(id)).collect();
    (drawn, occluders)
}

#[test]
fn hidden_objects_drawn_are_counted_and_hom_draws_fewer_than_frustum_culling() {
    let renderer = Renderer::new(1).unwrap();
    let built = hom_scene::builtin("office").unwrap();
    let mut scene = built.scene.clone();
    let frustum = run("frustum", &mut scene, &built, &renderer);
    let hom = run("hom", &mut scene, &built, &renderer);
    for (f, h) in frustum.frames.iter().zip(&hom.frames) {
        for r in [f, h] {
            let (drawn, occluders) = hidden(r);
            let o = r.oracle.as_ref().unwrap();
            assert_eq!(o.hidden_drawn, drawn.len() as u64, "frame {}", r.frame);
            assert_eq!(o.hidden_occluders_drawn, occluders.len() as u64, "frame {}", r.frame);
        }
        assert_eq!(
            f.oracle.as_ref().unwrap().hidden_occluders_drawn,
            0,
            "the frustum culler has no occluders"
        );
        // HOM draws a subset of what frustum culling draws.
        assert!(hidden(h).0.is_subset(&hidden(f).0), "frame {}", f.frame);
    }
    let mean = |w: &WalkResult| w.summary.mean_hidden_drawn.unwrap();
    assert!(
        mean(&frustum) > mean(&hom),
        "HOM culls some hidden object of office's first frames"
    );
    let per_frame: f64 = hom
        .frames
        .iter()
        .map(|f| f.oracle.as_ref().unwrap().hidden_occluders_drawn as f64)
        .sum::<f64>()
        / 8.0;
    assert_eq!(hom.summary.mean_hidden_occluders_drawn, Some(per_frame));
}
