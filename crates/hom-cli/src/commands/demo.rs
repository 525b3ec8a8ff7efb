//! `hom demo`: the built-in city walked with frustum culling and with hom's
//! best culler, one table and the pictures.

use super::render::write_false_colour;
use super::walk::run_walk;
use super::{busiest_frame, write_stage_chart};
use crate::args::{Clusters, DemoArgs, HomArgs, View};
use crate::setup::open;
use crate::table::print_table;
use anyhow::{Context, Result};
use hom::cull::HomConfig;
use hom_render::Renderer;
use hom_walk::{cullers, pictures, WalkOptions, WalkResult};

/// Runs `hom demo`.
pub fn run(a: DemoArgs) -> Result<()> {
    let view = View {
        scene: "city".into(),
        camera_path: None,
        clusters: Clusters::ON,
        width: Some(a.width),
        height: Some(a.height),
        speed: None,
        cuts: None,
        culler: cullers::BEST.into(),
        threads: 0,
        hom: HomArgs::default(),
    };
    let mut w = open(&view)?;
    let renderer = Renderer::new(0)?;
    let options = WalkOptions {
        frames: a.frames,
        oracle: true,
        ..WalkOptions::default()
    };
    let mut names = vec!["frustum"];
    if cullers::BEST != "frustum" {
        names.push(cullers::BEST);
    }
    let mut results = Vec::new();
    for name in &names {
        results.push(run_walk(&mut w, name, &view.hom, &renderer, &options, None)?);
    }
    let rows: Vec<(&str, &WalkResult)> = names.iter().copied().zip(results.iter()).collect();
    print_table(&w.scene, &rows);

    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    let best = results.last().expect("at least one walk");
    let plot = a.out.join("frame_times.png");
    pictures::plot_frame_times(&plot, &best.frames, cullers::BEST)?;
    // The frame where the best culler culled the most as occluded shows it best.
    let frame = busiest_frame(&best.frames);
    let picture = a.out.join(format!("false_colour_frame{frame}.png"));
    let pyramid = write_false_colour(
        &mut w,
        cullers::BEST,
        &view.hom,
        frame,
        &renderer,
        &picture,
        options.frame_rate,
        None,
    )?;
    let stages = a.out.join("stages.png");
    write_stage_chart(&stages, &rows)?;
    println!("pictures in {}:", a.out.display());
    println!(
        "  {} (occluders blue, drawn grey, occlusion-culled red)",
        picture.display()
    );
    println!(
        "  {} (frame time and % culled per frame, with and without occlusion culling)",
        plot.display()
    );
    println!("  {} (time per stage, % of frustum-only frame time)", stages.display());
    if let Some(p) = pyramid {
        let levels = a.out.join(format!("pyramid_frame{frame}.png"));
        pictures::write_pyramid_levels(&levels, &p, HomConfig::default().occluders.selection.hole_opacity)?;
        println!("  {} (the occlusion map pyramid, holes in blue)", levels.display());
    }
    Ok(())
}
