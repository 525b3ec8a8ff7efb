//! The cost of one culler alone, without rendering: the scene's walk (a
//! built-in scene's, a map's spawn points, a file's path beside it; its
//! first 100 frames) culled three times over on two threads, the first
//! pass a warm-up; prints the mean cull time per frame and the mean of each
//! stage, then the mean of each counter in brackets (occluder triangles,
//! setup and raster microseconds, …). For A/B measurements on a noisy
//! machine, build two binaries and run them alternately.
//!
//! `cargo run --release -p hom-walk --example cull_time -- masked city [PASSES]`
//! (PASSES, default 3, counts the warm-up; more passes give a profiler more
//! cull time to sample beside the occluder bake). `CULL_THREADS=N` sets the
//! pool's thread count (default 2), `CULL_BUDGET=L` the occluder budget;
//! `CULL_NO_COST_MODEL=1` keeps HOM and HZB from resting, `CULL_DEPTH_CHECK=C`
//! sets the per-sample depth check (off, if-drawn, on). Between frames,
//! as a renderer would, `CULL_GAP_US=N` idles N µs (the pool's threads fall
//! asleep) and `CULL_THRASH_MB=M` writes M MiB (the caches lose the
//! culler's data); neither is timed.

use hom::cull::CullOutput;
use hom_walk::cullers::{make, CullerSettings};
use std::collections::BTreeMap;
use std::time::Instant;

fn main() {
    if let Err(e) = run() {
        eprintln!("cull_time: {e}");
        std::process::exit(2);
    }
}

/// The environment variable `name` parsed as a `T`, if set and valid.
fn env<T: std::str::FromStr>(name: &str) -> Option<T> {
    std::env::var(name).ok().and_then(|v| v.parse().ok())
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let (Some(culler), Some(scene_name)) = (args.get(1), args.get(2)) else {
        return Err("usage: cull_time CULLER SCENE [PASSES] (e.g. masked city)".into());
    };
    let passes: usize = match args.get(3) {
        Some(p) => p
            .parse()
            .ok()
            .filter(|&n| n >= 2)
            .ok_or("PASSES must be an integer >= 2")?,
        None => 3,
    };
    let opened = hom_walk::open_walk(scene_name)?;
    let (scene, path) = (opened.scene, opened.path);
    let mut settings = CullerSettings::for_scene(&scene);
    if let Some(b) = env("CULL_BUDGET") {
        settings.hom.occluders.selection.budget = b;
    }
    if std::env::var("CULL_NO_COST_MODEL").is_ok() {
        settings.hom.cost_model = false;
    }
    if let Ok(check) = std::env::var("CULL_DEPTH_CHECK") {
        settings.hom.depth_check = hom_walk::bench::parse_depth_check(&check)?;
    }
    let mut c = make(culler, &scene, &settings)?;
    let threads = env("CULL_THREADS").unwrap_or(2);
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build()?;
    let frames = path.frames.len().min(100);
    if frames == 0 {
        return Err(format!("scene {scene_name} has an empty walk").into());
    }
    let mut out = CullOutput::default();
    let mut stages: BTreeMap<&'static str, f64> = BTreeMap::new();
    let mut counters: BTreeMap<&'static str, f64> = BTreeMap::new();
    let mut timed = 0.0;
    let gap = std::time::Duration::from_micros(env("CULL_GAP_US").unwrap_or(0));
    let mut thrash = vec![0u8; env::<usize>("CULL_THRASH_MB").unwrap_or(0) << 20];
    for pass in 0..passes {
        for i in 0..frames {
            if !gap.is_zero() {
                std::thread::sleep(gap);
            }
            for (k, b) in thrash.iter_mut().enumerate().step_by(64) {
                *b = b.wrapping_add(k as u8);
            }
            let start = Instant::now();
            pool.install(|| c.cull(&scene, &path.camera(i).to_view(), &mut out))?;
            let ms = start.elapsed().as_secs_f64() * 1e3;
            c.frame_done(Some(10.0));
            if pass > 0 {
                timed += ms;
                for (k, v) in &out.stages {
                    *stages.entry(*k).or_insert(0.0) += v;
                }
                for (k, v) in out.stats.counters() {
                    *counters.entry(k).or_insert(0.0) += v as f64;
                }
            }
        }
    }
    std::hint::black_box(&thrash);
    let n = ((passes - 1) * frames) as f64;
    println!("{culler} {scene_name}: {:.3} ms per frame", timed / n);
    for (k, v) in stages {
        println!("  {k}: {:.3} ms", v / n);
    }
    for (k, v) in counters {
        println!("  [{k}] {:.1}", v / n);
    }
    Ok(())
}
