//! `hom walk`: a camera path through a scene with one culler; the walk itself
//! (with the streamed report) is shared with `hom demo`.

use super::render::write_false_colour;
use super::{busiest_frame, write_stage_chart};
use crate::args::{HomArgs, RendererArg, WalkArgs};
use crate::setup::{
    culler_settings, frame_draw_maker, lod_for, make_culler_after_pvs, open, open_map_view, progress, Walkthrough,
};
use crate::table::print_table;
use anyhow::{bail, Context, Result};
use hom::pvs::Pvs;
use hom_render::Renderer;
use hom_scene::bsp::{BspMap, PortalPvs};
use hom_walk::pvs::{self, PvsSummary};
use hom_walk::report;
use hom_walk::{pictures, FrameDraw, WalkOptions, WalkResult};
use std::io::{BufWriter, Write};
use std::path::Path;
use std::sync::Arc;

/// Runs `hom walk`.
pub fn run(a: WalkArgs) -> Result<()> {
    let map = if a.pvs {
        if !hom_walk::pvs::is_map_spec(&a.view.scene) {
            bail!(
                "--pvs needs a Quake 3 map (.bsp, .pk3 or FILE.pk3:MAP), which carries a PVS; '{}' is not one",
                a.view.scene
            );
        }
        Some(hom_walk::pvs::open_map_with(
            &a.view.scene,
            &a.view.clusters.load_options(),
        )?)
    } else {
        None
    };
    let mut w = match &map {
        Some(m) => open_map_view(&a.view, m)?,
        None => open(&a.view)?,
    };
    if a.pvs && a.pvs_file.is_some() {
        bail!("--pvs (the map's own PVS) and --pvs-file (a baked one) measure one PVS at a time: give one");
    }
    let portals = match (&map, a.pvs_portals) {
        (Some(m), true) => {
            let start = std::time::Instant::now();
            let p = crate::setup::follow_portals(m, &w.path)?;
            eprintln!(
                "leaf portals: {} portals between {} clustered leaves, followed in {:.1} s",
                p.portal_count(),
                p.leaf_count(),
                start.elapsed().as_secs_f64()
            );
            Some(p)
        }
        _ => None,
    };
    let baked = a
        .pvs_file
        .as_deref()
        .map(|p| super::pvs::read_for(p, &w.scene))
        .transpose()?;
    if a.frames == Some(0) {
        bail!("--frames must be at least 1");
    }
    let renderer = Renderer::new(a.view.threads)?;
    if a.renderer != RendererArg::Software && a.lod.lod {
        bail!("--lod draws parts of meshes, which only --renderer software does");
    }
    let mut frame_draw = frame_draw_maker(a.renderer)?
        .map(|make| make(&w.scene))
        .transpose()
        .map_err(|e| anyhow::anyhow!(e))?;
    let options = WalkOptions {
        frames: a.frames,
        oracle: a.oracle || a.pvs,
        lod: lod_for(&a.lod, &w.scene)?,
        self_baseline: a.self_baseline,
        ..WalkOptions::default()
    };
    let mut file = match &a.report {
        Some(p) => Some(create_report(p)?),
        None => None,
    };
    let (result, pvs_summary) = run_walk_pvs(
        &mut w,
        &a.view.culler,
        &a.view.hom,
        &renderer,
        frame_draw.as_deref_mut().map(|d| d as &mut dyn FrameDraw),
        &options,
        file.as_mut().map(|f| f as &mut dyn Write),
        map.as_ref().map(|m| (m, portals.as_ref())),
        baked.clone(),
    )
    .with_context(|| match &a.report {
        Some(p) => format!("walking {} (report {})", a.view.scene, p.display()),
        None => format!("walking {}", a.view.scene),
    })?;
    if let Some(p) = &a.report {
        eprintln!("report: {}", p.display());
    }
    let label = match &a.pvs_file {
        Some(_) if a.view.culler == "frustum" => "pvs".to_string(),
        Some(_) => format!("pvs+{}", a.view.culler),
        None => a.view.culler.clone(),
    };
    print_table(&w.scene, &[(&label, &result)]);
    if let Some(p) = &pvs_summary {
        print!("{}", p.table());
    }
    if let Some(dir) = &a.plots {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let plot = dir.join("frame_times.png");
        pictures::plot_frame_times(&plot, &result.frames, &a.view.culler)?;
        let stages = dir.join("stages.png");
        write_stage_chart(&stages, &[(&a.view.culler, &result)])?;
        let frame = busiest_frame(&result.frames);
        let picture = dir.join(format!("false_colour_frame{frame}.png"));
        let frame_rate = WalkOptions::default().frame_rate;
        let pyramid = write_false_colour(
            &mut w,
            &a.view.culler,
            &a.view.hom,
            frame,
            &renderer,
            &picture,
            frame_rate,
            baked.as_ref(),
        )?;
        if let Some(p) = pyramid {
            let hole = culler_settings(&a.view.hom, &w.scene)?
                .hom
                .occluders
                .selection
                .hole_opacity;
            pictures::write_pyramid_levels(&dir.join(format!("pyramid_frame{frame}.png")), &p, hole)?;
        }
        eprintln!("pictures: {}", dir.display());
    }
    Ok(())
}

fn create_report(path: &Path) -> Result<BufWriter<std::fs::File>> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let f = std::fs::File::create(path).with_context(|| format!("creating report {}", path.display()))?;
    Ok(BufWriter::new(f))
}

/// Walks with progress on a terminal; with `report`, streams the JSON-lines
/// report (header, frames, summary) as it goes.
pub fn run_walk(
    w: &mut Walkthrough,
    culler_name: &str,
    hom: &HomArgs,
    renderer: &Renderer,
    options: &WalkOptions,
    mut report: Option<&mut dyn Write>,
) -> Result<WalkResult> {
    run_walk_pvs(w, culler_name, hom, renderer, None, options, report.take(), None, None).map(|(r, _)| r)
}

/// [`run_walk`], measuring each frame against `pvs` (a Quake 3 map whose scene is
/// `scene`, with the PVS its leaf portals give where that is given, else its own)
/// where given: the report's frame and summary lines gain `pvs_` fields.
/// With `baked`, the culler is that PVS then `culler_name`, and with the oracle
/// the frames are measured against it the same way.
#[allow(clippy::too_many_arguments)]
fn run_walk_pvs(
    w: &mut Walkthrough,
    culler_name: &str,
    hom: &HomArgs,
    renderer: &Renderer,
    frame_draw: Option<&mut dyn FrameDraw>,
    options: &WalkOptions,
    mut report: Option<&mut dyn Write>,
    pvs: Option<(&BspMap, Option<&PortalPvs>)>,
    baked: Option<Arc<Pvs>>,
) -> Result<(WalkResult, Option<PvsSummary>)> {
    let Walkthrough { scene, path, animation } = w;
    let (scene, path, animation) = (scene, &*path, &*animation);
    let mut culler = make_culler_after_pvs(culler_name, scene, hom, baked.as_ref())?;
    let measure_baked = baked.as_ref().filter(|_| options.oracle);
    // The yardstick reads the scene while the walk moves it: a copy as it
    // starts (the bake left moving objects out, so their motion changes nothing).
    let start_scene = measure_baked.map(|_| scene.clone());
    if let Some(out) = report.as_deref_mut() {
        let header = report::Header::new(
            scene,
            path,
            culler.as_ref(),
            renderer.threads(),
            &hom_walk::renderer_name(frame_draw.as_deref()),
            options.frame_count(path),
            options.oracle,
        );
        report::write_line(out, &header).context("writing the report")?;
    }
    let bar = progress(options.frame_count(path), culler_name);
    let mut io_error = None;
    let mut pvs_frames = Vec::new();
    let result = hom_walk::walk_drawn(
        scene,
        animation,
        path,
        culler.as_mut(),
        renderer,
        frame_draw,
        options,
        |record| {
            bar.inc(1);
            // The map's scene is the walked one (Quake 3 maps are static).
            let camera = path.camera(record.frame);
            let frame = match (pvs, measure_baked) {
                (Some((map, None)), _) => Some(pvs::pvs_for_record(map, &map.scene, &camera, record)),
                (Some((map, Some(portals))), _) => {
                    let view = pvs::PortalPvsView { map, portals };
                    Some(pvs::pvs_for_record(&view, &map.scene, &camera, record))
                }
                (None, Some(baked)) => {
                    let start = start_scene.as_ref().expect("copied when measuring");
                    let view = pvs::BakedPvsView::new(baked, start, &camera.to_view());
                    Some(pvs::pvs_for_record(&view, start, &camera, record))
                }
                (None, None) => None,
            };
            if let Some(out) = report.as_deref_mut() {
                let written = match &frame {
                    Some(f) => report::write_line(out, &pvs::FrameWithPvs { record, pvs: f }),
                    None => report::write_line(out, record),
                };
                if let Err(e) = written {
                    io_error.get_or_insert(e);
                }
            }
            pvs_frames.extend(frame);
        },
    );
    bar.finish_and_clear();
    let result = result?;
    let pvs_summary = (pvs.is_some() || measure_baked.is_some()).then(|| pvs::summarize_pvs(&pvs_frames));
    if let Some(out) = report {
        if let Some(e) = io_error {
            return Err(e).context("writing the report");
        }
        match &pvs_summary {
            Some(p) => report::write_line(
                out,
                &pvs::SummaryWithPvs {
                    summary: &result.summary,
                    pvs: p,
                },
            ),
            None => report::write_line(out, &result.summary),
        }
        .context("writing the report")?;
        out.flush().context("writing the report")?;
    }
    Ok((result, pvs_summary))
}
