//! `hom bench`: `walk` (scenes × cullers side by side) or `raster` (the
//! occluder rasterizer on the Masked Occlusion Culling inputs).

use crate::args::{BenchArgs, BenchKind, OnOff};
use anyhow::{Context, Result};
use hom_walk::pictures;
use std::path::Path;

/// Runs `hom bench`; `given` is the subcommand's matches (which flags were given).
pub fn run(a: BenchArgs, given: &clap::ArgMatches) -> Result<()> {
    let foreign = a.foreign_flags(given);
    if !foreign.is_empty() {
        let (kind, other) = match a.kind {
            BenchKind::Walk => ("walk", "raster"),
            BenchKind::Raster => ("raster", "walk"),
        };
        anyhow::bail!(
            "`hom bench {kind}` does not take {}: {} belong{} to `hom bench {other}`",
            foreign.join(", "),
            if foreign.len() == 1 { "it" } else { "they" },
            if foreign.len() == 1 { "s" } else { "" },
        );
    }
    if a.kind == BenchKind::Raster {
        return raster(a);
    }
    let scenes: Vec<String> = if a.scenes.is_empty() {
        hom_scene::BUILTIN_SCENES.iter().map(|(n, _)| n.to_string()).collect()
    } else {
        let mut all = Vec::new();
        for spec in &a.scenes {
            all.extend(hom_scene::expand_map_specs(spec)?);
        }
        all
    };
    let scene_refs: Vec<&str> = scenes.iter().map(String::as_str).collect();
    let culler_refs: Vec<&str> = a.cullers.iter().map(String::as_str).collect();
    let options = hom_walk::bench::BenchOptions {
        frames: a.frames,
        width: a.width,
        height: a.height,
        threads: a.threads,
        coherence: a.coherence.clone(),
        hierarchy: a.hierarchy.clone(),
        occluders: a.occluders.clone(),
        cost_model: !a.no_cost_model,
        depth_check: a.depth_check.unwrap_or_default(),
        hv_priming: a.hv_priming,
        speed: a.speed,
        cuts: a.cuts,
        camera_path: a.camera_path.clone(),
        budget: a.budget,
        clusters: a.clusters.switch == OnOff::On,
    };
    let make = crate::setup::frame_draw_maker(a.renderer)?;
    let report = hom_walk::bench::run_bench_drawn(&scene_refs, &culler_refs, &options, make, progress)?;
    print!("{}", report.table());
    let json_path = a.json_path();
    create_parent(&json_path)?;
    let json = serde_json::to_string_pretty(&report).context("serializing the bench report")?;
    std::fs::write(&json_path, json).with_context(|| format!("writing {}", json_path.display()))?;
    let chart = json_path.with_file_name("stages.png");
    pictures::plot_stage_breakdown(&chart, &report.stage_bars())?;
    println!("json: {}\nstage chart: {}", json_path.display(), chart.display());
    Ok(())
}

fn raster(a: BenchArgs) -> Result<()> {
    let json = a.json_path();
    let options = hom_walk::raster_bench::RasterBenchOptions {
        data: a.data,
        runs: a.runs,
        threads: a.raster_threads,
    };
    let report = hom_walk::raster_bench::run_raster_bench(&options, progress)?;
    print!("{}", report.table());
    create_parent(&json)?;
    let text = serde_json::to_string_pretty(&report).context("serializing the raster bench report")?;
    std::fs::write(&json, text).with_context(|| format!("writing {}", json.display()))?;
    println!("json: {}", json.display());
    Ok(())
}

/// Says what is being measured, on a terminal only (piped output stays the table).
fn progress(what: &str) {
    if std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        eprintln!("{what}");
    }
}

fn create_parent(file: &Path) -> Result<()> {
    if let Some(dir) = file.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    Ok(())
}
