//! `hom view --headless`: the viewer's frames along a path, drawn by wgpu
//! offscreen into PNG files (no window, no display needed).

use crate::gpu::Gpu;
use crate::offscreen::{read_texture, texture, COLOUR_FORMAT, READ_BACK};
use crate::viewer::{status_line, FrameFigures, Viewer, ViewerOptions};
use crate::ViewError;
use hom::cull::Culler;
use hom::scene::Scene;
use hom_scene::{Animation, CameraPath};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What to draw, and where.
#[derive(Clone, Debug)]
pub struct HeadlessOptions {
    /// Draw only the first `n` frames of the path (all when `None`).
    pub frames: Option<usize>,
    /// The folder the pictures go to (`frame_00000.png`, …), made if missing.
    pub out: PathBuf,
    /// What is drawn besides the scene.
    pub viewer: ViewerOptions,
    /// Frames per second of scene time (moves dynamic objects), as `hom walk`.
    pub frame_rate: f32,
}

/// What a headless run drew.
#[derive(Clone, Debug)]
pub struct HeadlessSummary {
    /// The adapter that drew the frames.
    pub device: String,
    /// The pictures written, in frame order.
    pub pictures: Vec<PathBuf>,
    /// Each frame's figures.
    pub figures: Vec<FrameFigures>,
    /// Each frame's milliseconds: the cull, the draw and its read-back.
    pub frame_ms: Vec<f64>,
}

/// The picture of frame `index` in `dir`.
pub fn picture_path(dir: &Path, index: usize) -> PathBuf {
    dir.join(format!("frame_{index:05}.png"))
}

/// Draws the frames of `path` through `scene` (moved by `animation`) with
/// `culler` (`culler_name` on the line of figures) into PNGs; `on_frame`
/// sees each frame's index as it is written (for progress).
pub fn run(
    scene: &mut Scene,
    animation: &Animation,
    path: &CameraPath,
    culler: &mut dyn Culler,
    culler_name: &str,
    options: &HeadlessOptions,
    mut on_frame: impl FnMut(usize),
) -> Result<HeadlessSummary, ViewError> {
    path.validate(scene.name())?;
    std::fs::create_dir_all(&options.out).map_err(|e| ViewError::Write {
        path: options.out.clone(),
        source: e.into(),
    })?;
    let gpu = Gpu::headless()?;
    let mut viewer = Viewer::new(&gpu, scene, COLOUR_FORMAT, options.viewer)?;
    // The frame's colour target, made again where the viewport changes.
    let mut target: Option<((u32, u32), wgpu::Texture)> = None;
    let count = options.frames.unwrap_or(usize::MAX).min(path.frames.len());
    let mut summary = HeadlessSummary {
        device: gpu.describe(),
        pictures: Vec::with_capacity(count),
        figures: Vec::with_capacity(count),
        frame_ms: Vec::with_capacity(count),
    };
    let mut last_ms = None;
    for i in 0..count {
        animation.apply(scene, i as f32 / options.frame_rate);
        let camera = path.camera(i);
        let start = Instant::now();
        let size = (camera.width, camera.height);
        if target.as_ref().is_none_or(|(s, _)| *s != size) {
            target = Some((
                size,
                texture(&gpu.device, "hom-view frame", size, COLOUR_FORMAT, READ_BACK),
            ));
        }
        let colour = &target.as_ref().expect("made").1;
        let view = colour.create_view(&Default::default());
        let status = status_line(scene.name(), culler_name, i, last_ms);
        let figures = viewer.frame(&gpu, scene, &camera, culler, &view, i, Some(&status))?;
        let rgba = read_texture(&gpu, colour, size.0, size.1)?;
        let ms = start.elapsed().as_secs_f64() * 1e3;
        let file = picture_path(&options.out, i);
        let pixels: Vec<[u8; 4]> = rgba.chunks_exact(4).map(|p| [p[0], p[1], p[2], 255]).collect();
        hom_render::write_png(&file, size.0, size.1, &pixels).map_err(|e| ViewError::Write {
            path: file.clone(),
            source: e.into(),
        })?;
        summary.pictures.push(file);
        summary.figures.push(figures);
        summary.frame_ms.push(ms);
        last_ms = Some(ms);
        on_frame(i);
    }
    Ok(summary)
}
