//! Why did HOM not cull what the oracle says is hidden? For one frame of a
//! built-in scene, sorts the triangles of in-frustum objects that own no pixel
//! by what stopped HOM: culled, box straddling the near plane, rectangle not
//! covered by the occlusion map, not behind the depth estimation buffer,
//! neither, or both tests passing and yet drawn; the selected occluders
//! among them are counted apart, with the same reasons (occluders are
//! tested too).
//!
//! `cargo run --release -p hom-walk --example why_not_culled -- city 56`

use hom::cull::{CullOutput, Culler, HomConfig, HomCuller};
use hom::geom::{project_points, Containment, Footprint, Frustum};
use hom_render::{Framebuffer, Renderer};
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (Some(scene_name), Some(frame)) = (args.get(1), args.get(2).and_then(|f| f.parse::<usize>().ok())) else {
        eprintln!("usage: why_not_culled SCENE FRAME");
        std::process::exit(2);
    };
    let b = hom_walk::open_walk(scene_name).unwrap();
    let mut scene = b.scene;
    b.animation.apply(&mut scene, frame as f32 / 30.0);
    let cam = b.path.camera(frame);
    let mut c = HomCuller::new(&scene, HomConfig::for_scene(&scene));
    let mut out = CullOutput::default();
    c.cull(&scene, &cam.to_view(), &mut out).unwrap();
    let r = Renderer::new(0).unwrap();
    let mut fb = Framebuffer::new(cam.width, cam.height);
    let counts = hom_render::oracle_pixel_counts(&r, &scene, &cam, &mut fb);
    let vp = cam.view_proj();
    let f = Frustum::from_view_proj(&vp).unwrap();
    // The culler's own occlusion buffer of this frame, asked its two tests separately.
    let buf = c.buffer_mut().unwrap();
    let (mut straddle, mut occl, mut occluder) = (0u64, 0u64, 0u64);
    // Not covered, not behind, neither, both (and yet drawn).
    let (mut why, mut occluder_why) = ([0u64; 4], [0u64; 4]);
    for (id, o) in scene.objects().iter().enumerate() {
        if counts[id] > 0 || f.test_aabb(&o.aabb) == Containment::Outside {
            continue;
        }
        let t = o.triangles as u64;
        if out.occluded.binary_search(&(id as u32)).is_ok() {
            occl += t;
            continue;
        }
        let is_occluder = out.occluders.binary_search(&(id as u32)).is_ok();
        if is_occluder {
            occluder += t;
        }
        match project_points(&o.aabb.corners(), &vp, cam.width, cam.height) {
            Footprint::Straddles => straddle += t,
            Footprint::Rect(rect) => {
                let cov = buf.rect_is_opaque(&rect);
                let beh = buf.depth_is_behind(&rect);
                let tally = if is_occluder { &mut occluder_why } else { &mut why };
                match (cov, beh) {
                    (false, true) => tally[0] += t,
                    (true, false) => tally[1] += t,
                    (false, false) => tally[2] += t,
                    _ => tally[3] += t,
                }
            }
        }
    }
    let [not_cov, not_behind, both, passes] = why;
    let hidden = occl + occluder + straddle + why.iter().sum::<u64>() - occluder_why.iter().sum::<u64>();
    println!("hidden in-frustum triangles: {hidden}");
    println!("invisible-in-frustum tris: occluded {occl}, selected occluders {occluder}, straddle {straddle}, not covered {not_cov}, not behind {not_behind}, neither {both}, both tests pass {passes}");
    let [not_cov, not_behind, both, passes] = occluder_why;
    println!("  of the selected occluders': not covered {not_cov}, not behind {not_behind}, neither {both}, both tests pass {passes}");
}
