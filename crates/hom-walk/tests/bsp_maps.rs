//! Real Quake 3 maps (fetched by `scripts/fetch-scenes.sh --tests-only`): along the
//! spawn-to-spawn walk, HOM in conservative mode culls nothing the oracle sees, and
//! everything the oracle sees lies in a cluster the map's own PVS marks visible.
//! Skips, saying why, when the cache is missing.

use hom::cull::CullOutput;
use hom_render::{Framebuffer, Renderer};
use hom_scene::bsp::{self, BspOptions};
use hom_walk::cullers::CullerSettings;

#[test]
fn hom_and_the_pvs_agree_with_the_oracle_on_openarena_maps() {
    let Some(pk3) = hom_testkit::openarena_maps() else {
        return;
    };
    let renderer = Renderer::new(0).unwrap();
    for name in ["oa_dm1", "oa_dm4"] {
        let options = BspOptions {
            map: Some(name.into()),
            ..BspOptions::default()
        };
        let map = bsp::load(&pk3, &options).unwrap();
        let scene = &map.scene;
        let path = map.camera_path().unwrap().with_viewport(192, 192);
        let mut culler = hom_walk::cullers::make("hom", scene, &CullerSettings::for_scene(scene)).unwrap();
        let (mut checked, mut outside, mut seen) = (0, 0, 0);
        let mut fb = Framebuffer::new(path.width, path.height);
        for i in (0..path.frames.len()).step_by(4).take(60) {
            let camera = path.camera(i);
            let mut out = CullOutput::default();
            renderer
                .install(|| culler.cull(scene, &camera.to_view(), &mut out))
                .unwrap();
            let counts = hom_render::oracle_pixel_counts(&renderer, scene, &camera, &mut fb);
            let cluster = map.cluster_of(camera.eye);
            for (id, &n) in counts.iter().enumerate() {
                if n == 0 {
                    continue;
                }
                seen += 1;
                assert!(
                    out.visible.binary_search(&(id as u32)).is_ok(),
                    "{name} frame {i}: object {id} owns {n} pixels but HOM culled it"
                );
                if let Some(c) = cluster {
                    assert!(
                        map.object_visible_from(id as u32, c),
                        "{name} frame {i}: object {id} (clusters {:?}) owns {n} pixels but the PVS hides it from cluster {c}",
                        map.object_clusters[id]
                    );
                }
            }
            if cluster.is_some() {
                checked += 1;
            } else {
                outside += 1;
            }
        }
        println!("{name}: {checked} frames checked against the PVS, {outside} with the eye in solid space; {seen} visible objects");
        assert_eq!(outside, 0, "{name}: the walk drops frames in solid space");
    }
}

/// The PVS yardstick (`hom_walk::pvs`) along a real walk: no oracle-visible object
/// outside the PVS, and the triangle counts nest as they must: the oracle's set
/// inside PVS-then-HOM (HOM is conservative and the PVS is right), which lies
/// inside both HOM alone and the PVS alone, which lie inside the frustum.
#[test]
fn pvs_yardstick_on_an_openarena_map() {
    let Some(pk3) = hom_testkit::openarena_maps() else {
        return;
    };
    let spec = format!("{}:oa_dm1", pk3.display());
    let map = hom_walk::pvs::open_map(&spec).unwrap();
    assert!(map.cluster_count() > 1, "oa_dm1 has visibility data");
    let mut scene = map.scene.clone();
    let path = map.camera_path().unwrap().with_viewport(160, 160);
    let renderer = Renderer::new(0).unwrap();
    let mut culler = hom_walk::cullers::make("hom", &scene, &CullerSettings::for_scene(&scene)).unwrap();
    let options = hom_walk::WalkOptions {
        frames: Some(48),
        oracle: true,
        baseline: false,
        ..hom_walk::WalkOptions::default()
    };
    let result = hom_walk::walk(
        &mut scene,
        &hom_scene::Animation::none(),
        &path,
        culler.as_mut(),
        &renderer,
        &options,
        |_| {},
    )
    .unwrap();
    let frames: Vec<_> = result
        .frames
        .iter()
        .map(|r| hom_walk::pvs::pvs_for_record(&map, &map.scene, &path.camera(r.frame), r))
        .collect();
    for (r, f) in result.frames.iter().zip(&frames) {
        let i = r.frame;
        assert!(
            f.pvs_camera_cluster.is_some(),
            "frame {i}: the walk keeps the eye in a cluster"
        );
        assert!(
            f.pvs_violations.is_empty(),
            "frame {i}: the PVS hides {:?}",
            f.pvs_violations
        );
        assert_eq!(f.pvs_triangles_hom, r.triangles_drawn, "frame {i}");
        assert!(f.pvs_triangles_oracle <= f.pvs_triangles_pvs_hom, "frame {i}: {f:?}");
        assert!(
            f.pvs_triangles_pvs_hom <= f.pvs_triangles_hom.min(f.pvs_triangles_pvs),
            "frame {i}: {f:?}"
        );
        assert!(f.pvs_triangles_pvs <= f.pvs_triangles_frustum, "frame {i}: {f:?}");
        assert!(f.pvs_triangles_oracle > 0, "frame {i}: the oracle sees something");
    }
    let s = hom_walk::pvs::summarize_pvs(&frames);
    println!("{}", s.table());
    assert_eq!(s.pvs_violations, 0);
    // The PVS must cull something somewhere on this indoor map, or the test proves nothing.
    assert!(s.pvs_total_triangles[1] < s.pvs_total_triangles[0], "{s:?}");
}
