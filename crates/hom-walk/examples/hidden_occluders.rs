//! What do the hidden objects a culler draws cost the renderer, and how many
//! of them are its own occluders? (Few in triangles but large on screen;
//! what keeps HOM from culling them is the depth test, the box's one nearest
//! depth against a cell's farthest first cover: docs/decisions/occluders.md,
//! "Most of HOM's render excess is its own hidden occluders"; for masked,
//! its subtiles' bounds.) Over any scene's walk (a built-in name or a file,
//! as `hom walk --scene` takes it; the culler, HOM by default, without the
//! cost model, its default depth check), every fifth frame: the objects it
//! draws, the oracle's, the hidden occluders among its objects and how many
//! of those the other occluders alone hide (drawn by the renderer), then
//! the render time of its set, of its set without its hidden occluders, of
//! that set without the hidden objects whose boxes cross the near plane,
//! and of the oracle's set (five timed renders each, interleaved, after one
//! untimed).
//!
//! `cargo run --release -p hom-walk --example hidden_occluders -- office`
//! (or `-- FILE.pk3:oa_dm1 masked`)

use hom::cull::CullOutput;
use hom_render::{Framebuffer, RenderOptions, Renderer};
use hom_walk::cullers::{make, CullerSettings, BEST};
use std::time::Instant;

fn main() {
    let Some(name) = std::env::args().nth(1) else {
        eprintln!("usage: hidden_occluders SCENE [CULLER]");
        std::process::exit(2);
    };
    let culler_name = std::env::args().nth(2).unwrap_or_else(|| "hom".to_string());
    let b = hom_walk::open_walk(&name).unwrap_or_else(|e| {
        eprintln!("{e}");
        std::process::exit(2);
    });
    let scene = b.scene;
    let mut settings = CullerSettings::for_scene(&scene);
    settings.hom.cost_model = false;
    let mut culler = make(&culler_name, &scene, &settings).unwrap_or_else(|e| {
        eprintln!("{e} ({BEST} is the default culler)");
        std::process::exit(2);
    });
    let renderer = Renderer::new(0).expect("a render pool");
    let options = RenderOptions::default();
    let mut out = CullOutput::default();
    let (mut objects, mut hidden_occluders, mut by_occluders) = ([0usize; 4], 0usize, 0usize);
    let mut render_ms = [0.0f64; 4];
    let mut sampled = 0;
    for f in 0..b.path.frames.len().min(100) {
        let cam = b.path.camera(f);
        culler.cull(&scene, &cam.to_view(), &mut out).expect("a valid view");
        if f % 5 != 0 {
            continue;
        }
        sampled += 1;
        let mut fb = Framebuffer::new(cam.width, cam.height);
        let pixels = hom_render::oracle_pixel_counts(&renderer, &scene, &cam, &mut fb);
        let is_occluder = |id: &u32| out.occluders.binary_search(id).is_ok();
        renderer.render(&scene, &out.occluders, &cam, &options, &mut fb);
        let occluder_pixels = fb.visible_pixel_counts(scene.objects().len());
        for id in out
            .visible
            .iter()
            .filter(|&id| pixels[*id as usize] == 0 && is_occluder(id))
        {
            hidden_occluders += 1;
            by_occluders += usize::from(occluder_pixels[*id as usize] == 0);
        }
        let vp = cam.view_proj();
        let straddles = |id: &u32| {
            let corners = scene.object(*id).test_corners();
            matches!(
                hom::geom::project_points(&corners, &vp, cam.width, cam.height),
                hom::geom::Footprint::Straddles
            )
        };
        let sets: [Vec<u32>; 4] = [
            out.visible.clone(),
            out.visible
                .iter()
                .copied()
                .filter(|id| pixels[*id as usize] > 0 || !is_occluder(id))
                .collect(),
            out.visible
                .iter()
                .copied()
                .filter(|id| pixels[*id as usize] > 0 || (!is_occluder(id) && !straddles(id)))
                .collect(),
            out.visible
                .iter()
                .copied()
                .filter(|id| pixels[*id as usize] > 0)
                .collect(),
        ];
        for rep in 0..6 {
            for (k, set) in sets.iter().enumerate() {
                let start = Instant::now();
                renderer.render(&scene, set, &cam, &options, &mut fb);
                if rep > 0 {
                    render_ms[k] += start.elapsed().as_secs_f64() * 1e3 / 5.0;
                }
            }
        }
        for (n, set) in objects.iter_mut().zip(&sets) {
            *n += set.len();
        }
    }
    let per_frame = |x: f64| x / sampled as f64;
    println!("{name}, {culler_name}, {sampled} frames (every fifth of the walk), means per frame:");
    println!(
        "objects drawn: {culler_name} {:.1}, without its hidden occluders {:.1}, nor hidden boxes across the near plane {:.1}, oracle {:.1}",
        per_frame(objects[0] as f64),
        per_frame(objects[1] as f64),
        per_frame(objects[2] as f64),
        per_frame(objects[3] as f64)
    );
    println!(
        "hidden occluders {culler_name} draws: {:.1}, {:.1} of them hidden by the other occluders alone",
        per_frame(hidden_occluders as f64),
        per_frame(by_occluders as f64)
    );
    println!(
        "render ms: {culler_name} {:.3}, without its hidden occluders {:.3}, nor hidden boxes across the near plane {:.3}, oracle {:.3}",
        per_frame(render_ms[0]),
        per_frame(render_ms[1]),
        per_frame(render_ms[2]),
        per_frame(render_ms[3])
    );
}
