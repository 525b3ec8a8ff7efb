//! Every built-in scene's walkthrough, sampled: frustum, HOM, HZB, masked and
//! occlusion-tree culling (default, conservative settings: virtual occluders)
//! and HOM with the original occluder meshes never drop an object the oracle
//! sees; on the scenes built for it, every occlusion culler culls something.

use hom::occluders::OccluderMeshes;
use hom_render::Renderer;
use hom_walk::{cullers, walk, WalkOptions};

/// Scenes where every occlusion culler must cull something, with either occluder meshes.
const MUST_CULL: &[&str] = &["city", "machine-room", "sculpture-park"];

#[test]
fn sampled_builtin_walks_have_no_false_culls() {
    let renderer = Renderer::new(0).unwrap();
    for (name, _) in hom_scene::BUILTIN_SCENES {
        let built = hom_scene::builtin(name).unwrap();
        let (mut scene, animation) = (built.scene, built.animation);
        // Every 12th frame at a reduced size keeps this quick; `hom bench` walks every frame at full size.
        let mut path = built.path.with_viewport(320, 240);
        path.frames = path.frames.iter().copied().step_by(12).collect();
        let runs = ["frustum", "hom", "hzb", "masked", "otree"]
            .map(|c| (c, OccluderMeshes::Virtual))
            .into_iter()
            .chain([("hom", OccluderMeshes::Original)]);
        for (culler_name, meshes) in runs {
            let mut settings = cullers::CullerSettings::for_scene(&scene);
            settings.hom.occluders.occluder_db.meshes = meshes;
            let mut culler = cullers::make(culler_name, &scene, &settings).unwrap();
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
                    "{name} / {culler_name} with {meshes} occluders, frame {}: false culls {:?}",
                    f.frame,
                    oracle.false_culls
                );
            }
            if culler_name != "frustum" && MUST_CULL.contains(name) {
                let culled: u64 = result.frames.iter().map(|f| f.objects_occlusion_culled).sum();
                assert!(
                    culled > 0,
                    "{name} / {culler_name} with {meshes} occluders culls something"
                );
            }
        }
    }
}
