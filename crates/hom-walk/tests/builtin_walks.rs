//! Every built-in scene's walkthrough, sampled: frustum, HOM, HZB and occlusion-tree
//! culling (default, conservative settings) never drop an object the oracle sees.

use hom_render::Renderer;
use hom_walk::{cullers, walk, WalkOptions};

#[test]
fn sampled_builtin_walks_have_no_false_culls() {
    let renderer = Renderer::new(0).unwrap();
    for (name, _) in hom_scene::BUILTIN_SCENES {
        let built = hom_scene::builtin(name).unwrap();
        let (mut scene, animation) = (built.scene, built.animation);
        // Every 12th frame at a reduced size keeps this quick; `hom bench` walks every frame at full size.
        let mut path = built.path.with_viewport(320, 240);
        path.frames = path.frames.iter().copied().step_by(12).collect();
        for culler_name in ["frustum", "hom", "hzb", "otree"] {
            let mut culler = cullers::make(culler_name, &scene, &cullers::CullerSettings::for_scene(&scene)).unwrap();
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
                    "{name} / {culler_name} frame {}: false culls {:?}",
                    f.frame,
                    oracle.false_culls
                );
            }
            if culler_name != "frustum" && *name == "city" {
                let culled: u64 = result.frames.iter().map(|f| f.objects_occlusion_culled).sum();
                assert!(culled > 0, "{culler_name} culls something on the city walk");
            }
        }
    }
}
