//! Diagnoses PVS violations: `cargo run --release -p hom-walk --example pvs_probe -- SPEC FRAME`
//! prints the eye, its cluster, the clusters of the near-plane corners and the
//! bounds and clusters of each oracle-visible object the PVS hides.

use hom_render::{Framebuffer, Renderer};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (spec, frame) = (&args[1], args[2].parse::<usize>().unwrap());
    let map = hom_walk::pvs::open_map(spec).unwrap();
    let path = map.camera_path().unwrap();
    let cam = path.camera(frame);
    let c = map.cluster_of(cam.eye);
    println!(
        "eye {:?} cluster {c:?} near {} (prev eye dist {:.3})",
        cam.eye,
        cam.near,
        if frame > 0 {
            path.camera(frame - 1).eye.distance(cam.eye)
        } else {
            0.0
        }
    );
    let inv = cam.view_proj().inverse();
    for (x, y) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0), (0.0, 0.0)] {
        let p = inv.project_point3(glam::Vec3::new(x, y, 0.0));
        println!("near corner {x},{y}: {:?} cluster {:?}", p, map.cluster_of(p));
    }
    let renderer = Renderer::new(0).unwrap();
    let mut fb = Framebuffer::new(cam.width, cam.height);
    let counts = hom_render::oracle_pixel_counts(&renderer, &map.scene, &cam, &mut fb);
    for (id, &n) in counts.iter().enumerate() {
        if n > 0 && c.is_some_and(|c| !map.object_visible_from(id as u32, c)) {
            let o = &map.scene.objects()[id];
            println!(
                "object {id} '{}' {n} px, aabb {:?}..{:?}, clusters {:?}, occluder {}",
                o.name, o.aabb.min, o.aabb.max, map.object_clusters[id], o.occluder
            );
        }
    }
}
