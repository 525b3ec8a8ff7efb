//! `hom view`: a window that flies through a scene (or, `--headless`, the
//! path's frames drawn offscreen into PNGs), drawn by wgpu (`hom-view`).

use crate::args::ViewArgs;
#[cfg(feature = "view")]
use crate::setup::{culler_settings, open, progress};
use anyhow::Result;

/// The window's size where `--width` and `--height` are not given.
#[cfg(feature = "view")]
const DEFAULT_SIZE: (u32, u32) = (1280, 720);

/// Runs `hom view`.
#[cfg(feature = "view")]
pub fn run(mut a: ViewArgs) -> Result<()> {
    use anyhow::{bail, Context};
    use hom_view::{headless, window, ViewerOptions};

    if a.frames == Some(0) {
        bail!("--frames must be at least 1");
    }
    a.view.width.get_or_insert(DEFAULT_SIZE.0);
    a.view.height.get_or_insert(DEFAULT_SIZE.1);
    let view = &a.view;
    let mut w = open(view)?;
    let settings = culler_settings(&view.hom, &w.scene)?;
    // Checked here, so a wrong name is the usual one-line error before any window opens.
    let mut culler = hom_walk::cullers::make(&view.culler, &w.scene, &settings)?;
    let viewer = ViewerOptions {
        overlay: a.false_colour,
        ..ViewerOptions::default()
    };
    let frame_rate = hom_walk::WalkOptions::default().frame_rate;
    if a.headless {
        let out = a.out.clone().context("--headless needs --out DIR")?;
        let count = a.frames.unwrap_or(usize::MAX).min(w.path.frames.len());
        let bar = progress(count, &view.culler);
        let options = headless::HeadlessOptions {
            frames: a.frames,
            out,
            viewer,
            frame_rate,
        };
        let summary = headless::run(
            &mut w.scene,
            &w.animation,
            &w.path,
            culler.as_mut(),
            &view.culler,
            &options,
            |_| bar.inc(1),
        )
        .with_context(|| format!("drawing {} headless", view.scene))?;
        bar.finish_and_clear();
        let mut ms = summary.frame_ms.clone();
        ms.sort_by(f64::total_cmp);
        println!(
            "{} frames of {} at {}x{} into {} on {}; median frame {:.2} ms (cull, draw, read back)",
            summary.pictures.len(),
            view.scene,
            w.path.width,
            w.path.height,
            options.out.display(),
            summary.device,
            ms.get(ms.len() / 2).copied().unwrap_or(0.0),
        );
        return Ok(());
    }
    let options = window::WindowOptions {
        width: w.path.width,
        height: w.path.height,
        viewer,
        frames: a.frames,
        screenshot: a.screenshot.clone(),
        record: a.record.clone(),
        frame_rate,
    };
    let summary = window::run(w.scene, w.animation, w.path, culler, settings, options)
        .with_context(|| format!("viewing {}", view.scene))?;
    let mut ms = summary.frame_ms.clone();
    ms.sort_by(f64::total_cmp);
    if let Some(median) = ms.get(ms.len() / 2) {
        eprintln!(
            "{} frames on {}: median {:.2} ms a frame ({:.0} frames per second)",
            ms.len() + 1,
            summary.device,
            median,
            1e3 / median.max(1e-3)
        );
    }
    if let Some(p) = &summary.screenshot {
        eprintln!("screenshot: {}", p.display());
    }
    Ok(())
}

/// Runs `hom view`: this build has no viewer.
#[cfg(not(feature = "view"))]
pub fn run(_: ViewArgs) -> Result<()> {
    anyhow::bail!("this hom was built without its viewer (hom-cli's `view` feature); build it with default features")
}
