//! The table `hom walk` and `hom demo` print: one row per culler's walk.

use hom::scene::Scene;
use hom_walk::report::Summary;
use hom_walk::WalkResult;

fn fmt_opt(v: Option<f64>, digits: usize) -> String {
    v.map(|x| format!("{x:.digits$}")).unwrap_or_else(|| "-".into())
}

/// Prints the scene's counts, then one row of medians per (culler name, walk).
pub fn print_table(scene: &Scene, rows: &[(&str, &WalkResult)]) {
    println!(
        "scene {}: {} objects, {} triangles ({} dynamic objects)",
        scene.name(),
        scene.objects().len(),
        scene.triangle_count(),
        scene.dynamic_count()
    );
    println!(
        "{:<10} {:>6} {:>10} {:>9} {:>11} {:>9} {:>10} {:>10} {:>10} {:>8} {:>8}",
        "culler",
        "frames",
        "tris drawn",
        "% culled",
        "false culls",
        "effic. %",
        "cull ms",
        "render ms",
        "frame ms",
        "speedup",
        "oracle×"
    );
    for (name, r) in rows {
        let s: &Summary = &r.summary;
        println!(
            "{:<10} {:>6} {:>10.0} {:>9.1} {:>11} {:>9} {:>10.2} {:>10.2} {:>10.2} {:>8} {:>8}",
            name,
            s.frames,
            s.median_triangles_drawn,
            s.median_pct_triangles_culled,
            s.false_culls.map(|n| n.to_string()).unwrap_or_else(|| "-".into()),
            fmt_opt(s.efficiency.map(|e| e * 100.0), 1),
            s.median_stage_ms.get("cull").copied().unwrap_or(0.0),
            s.median_stage_ms.get("render").copied().unwrap_or(0.0),
            s.median_frame_ms,
            fmt_opt(s.speedup, 2),
            fmt_opt(s.oracle_speedup, 2),
        );
    }
    println!("(medians over frames; speedup = frustum-only frame time ÷ frame time; oracle× = the best any culler could reach)");
}
