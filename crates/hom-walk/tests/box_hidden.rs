//! `Culler::box_hidden`, the test level of detail asks of a frame's culler,
//! against the renderer: a box it calls hidden, added to the scene as a
//! solid, owns no pixel of that frame.

use hom::geom::Aabb;
use hom::glam::{Mat4, Vec3};
use hom_render::{oracle_pixel_counts, Framebuffer, Renderer};
use hom_testkit::{cube, cut_camera_path, occluder_cullers, permissive_hom, random_scene, Rng};

#[test]
fn a_box_called_hidden_owns_no_pixel() {
    let renderer = Renderer::new(0).unwrap();
    let mut fb = Framebuffer::new(1, 1);
    let mut rng = Rng::new(77);
    for seed in 0..3u64 {
        let scene = random_scene(seed, 60, false);
        let bounds = scene.bounds();
        for mut culler in occluder_cullers(&scene, &permissive_hom(100_000)) {
            let (mut hidden, mut asked) = (0, 0);
            for camera in cut_camera_path(seed, 12, 4) {
                let mut out = hom::cull::CullOutput::default();
                culler.cull(&scene, &camera.to_view(), &mut out).unwrap();
                for _ in 0..40 {
                    let centre = Vec3::new(
                        rng.range(bounds.min.x, bounds.max.x),
                        rng.range(bounds.min.y, bounds.max.y),
                        rng.range(bounds.min.z, bounds.max.z),
                    );
                    let size = Vec3::new(rng.range(0.1, 2.0), rng.range(0.1, 2.0), rng.range(0.1, 2.0));
                    let b = Aabb::new(centre - size * 0.5, centre + size * 0.5);
                    asked += 1;
                    if !culler.box_hidden(&b.corners()) {
                        continue;
                    }
                    hidden += 1;
                    let mut with_box = scene.clone();
                    let mesh = with_box.add_mesh(cube());
                    let id = with_box
                        .add_object("probe", mesh, Mat4::from_translation(centre) * Mat4::from_scale(size))
                        .unwrap();
                    let owned = oracle_pixel_counts(&renderer, &with_box, &camera, &mut fb)[id as usize];
                    assert_eq!(
                        owned,
                        0,
                        "{}: seed {seed}, a box called hidden owns {owned} pixels",
                        culler.name()
                    );
                }
            }
            assert!(hidden > 0, "{}: none of {asked} boxes hidden", culler.name());
        }
    }
}
