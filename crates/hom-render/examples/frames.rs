//! Renders the first frames of built-in walkthroughs (frustum culled, flat
//! shading) and prints a hash of every frame's buffers plus the median render
//! time: a bit-exactness and speed check for renderer changes.
//!
//! `cargo run --release -p hom-render --example frames -- [frames] [reps] [scene...]`
//!
//! Environment: `THREADS` (renderer threads, default all cores), `STATS`
//! (print per-frame counters), `EMPTY` (draw nothing: the fixed per-frame cost).
//! Timings are the per-frame minimum over `reps`, flat shading only.

use hom::cull::{CullOutput, Culler, FrustumCuller};
use hom_render::{Framebuffer, RenderOptions, Renderer, Shading};
use std::hash::{Hash, Hasher};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let frames: usize = args.first().and_then(|a| a.parse().ok()).unwrap_or(60);
    let reps: usize = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(3);
    let names: Vec<&str> = if args.len() > 2 {
        args[2..].iter().map(|s| s.as_str()).collect()
    } else {
        vec!["city", "machine-room", "dynamic"]
    };
    let threads = std::env::var("THREADS").ok().and_then(|t| t.parse().ok()).unwrap_or(0);
    let renderer = Renderer::new(threads).expect("renderer");
    for name in names {
        let b = hom_scene::builtin(name).expect("scene");
        let (mut scene, path, animation) = (b.scene, b.path, b.animation);
        let mut culler = FrustumCuller::new(&scene);
        let mut out = CullOutput::default();
        let mut fb = Framebuffer::new(path.width, path.height);
        let mut hasher = std::collections::hash_map::DefaultHasher::new();
        let mut item_hasher = std::collections::hash_map::DefaultHasher::new();
        let mut times = Vec::new();
        for shading in [Shading::Flat, Shading::ItemOnly] {
            let options = RenderOptions {
                shading,
                ..RenderOptions::default()
            };
            for i in 0..frames.min(path.frames.len()) {
                animation.apply(&mut scene, i as f32 / 30.0);
                let camera = path.camera(i);
                culler.cull(&scene, &camera.to_view(), &mut out).expect("cull");
                if std::env::var_os("EMPTY").is_some() {
                    out.visible.clear();
                }
                let mut best = f64::INFINITY;
                for _ in 0..reps {
                    let start = Instant::now();
                    let stats = renderer.render(&scene, &out.visible, &camera, &options, &mut fb);
                    best = best.min(start.elapsed().as_secs_f64() * 1e3);
                    std::hint::black_box(stats);
                }
                if shading == Shading::Flat {
                    times.push(best);
                }
                let stats = renderer.render(&scene, &out.visible, &camera, &options, &mut fb);
                (stats.triangles_rasterized, stats.fragments_written).hash(&mut hasher);
                if std::env::var_os("STATS").is_some() && shading == Shading::Flat {
                    println!(
                        "frame {i}: {} tris, {} fragments",
                        stats.triangles_rasterized, stats.fragments_written
                    );
                }
                fb.color().hash(&mut hasher);
                fb.depth().iter().map(|d| d.to_bits()).for_each(|d| d.hash(&mut hasher));
                fb.items().hash(&mut hasher);
                fb.items().hash(&mut item_hasher);
            }
        }
        times.sort_by(f64::total_cmp);
        println!(
            "{name:14} median-of-min {:7.3} ms  mean-of-min {:7.3}  hash {:016x}  items {:016x}",
            times[times.len() / 2],
            times.iter().sum::<f64>() / times.len() as f64,
            hasher.finish(),
            item_hasher.finish()
        );
    }
}
