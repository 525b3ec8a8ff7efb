//! The table `hom walk` and `hom demo` print: one row per culler's walk.

use hom::scene::Scene;
use hom_walk::report::{fmt_opt, Summary};
use hom_walk::WalkResult;

/// Prints the scene's counts, then one row of medians per (culler name, walk).
pub fn print_table(scene: &Scene, rows: &[(&str, &WalkResult)]) {
    println!(
        "scene {}: {} objects in {} clusters, {} triangles ({} dynamic)",
        scene.name(),
        scene.parent_count(),
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
    for (name, r) in rows {
        let Some(l) = &r.summary.lod else { continue };
        let fewer = |than: u64| 100.0 * (1.0 - l.lod_triangles as f64 / than.max(1) as f64);
        let unguided = l
            .lod_unguided_triangles
            .map(|u| format!(", {:.1} % fewer than without guidance", fewer(u)))
            .unwrap_or_default();
        let oracle = l
            .lod_oracle_triangles
            .map(|o| {
                let exact = 100.0 * (1.0 - o as f64 / l.lod_view_only_triangles.max(1) as f64);
                format!(", exact object culling would give {exact:.1} % fewer")
            })
            .unwrap_or_default();
        let pixels = l
            .lod_guidance_pixels_changed
            .map(|p| format!(", {p} pixels changed by guidance"))
            .unwrap_or_default();
        let culling = l
            .lod_culling_pixels_changed
            .map(|p| {
                let occluders = if l.lod_occluders { "at" } else { "not at" };
                format!(", {p} pixels changed by culling (occluders {occluders} the level of detail)")
            })
            .unwrap_or_default();
        let full = l
            .lod_pixels_differ_from_full
            .map(|p| {
                let per_frame = p as f64 / r.summary.frames.max(1) as f64;
                format!(", {per_frame:.0} pixels a frame owned by another object than at full resolution")
            })
            .unwrap_or_default();
        let budget = l
            .lod_frames_within_budget
            .zip(l.lod_frames_budget_binds)
            .map(|(b, n)| {
                format!(
                    ", {:.1} % of the {n} frames where the budget binds within 5 % of it",
                    b * 100.0
                )
            })
            .unwrap_or_default();
        println!(
            "{name} lod: {:.0} triangles drawn (median), {:.1} % fewer than view-only level of detail of the frustum's objects, max error {:.2} px, {} nodes kept coarse as hidden, {:.3} ms selection (median){unguided}{oracle}{pixels}{culling}{full}{budget}",
            l.median_lod_triangles,
            fewer(l.lod_view_only_triangles),
            l.lod_max_error_px,
            l.lod_nodes_occluded,
            l.median_lod_ms
        );
    }
}
