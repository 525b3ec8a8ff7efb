//! One frame of the viewer, the same in the window and headless: the cull,
//! the visible objects flat shaded, the false-colour overlay, the
//! occlusion buffer's inset and the line of figures.

use crate::gpu::Gpu;
use crate::offscreen::{background, begin_pass, depth_target};
use crate::overlay::{coverage_picture, text_picture, Corner, Overlay};
use crate::scene_gpu::{Pass, SceneGpu};
use crate::ViewError;
use hom::cull::{CullOutput, Culler};
use hom::geom::Camera;
use hom::scene::Scene;
use std::time::Instant;

/// Width of the occlusion buffer's inset, pixels (its height follows the
/// view's aspect). A rectangle test a pixel: 240 wide cost 2.5 ms of a
/// 1280×720 frame on city under lavapipe (32.4 against 34.8 ms without).
const INSET_WIDTH: u32 = 160;
/// Height of the line of figures' letters, pixels.
const TEXT_PX: f32 = 17.0;
/// The overlay's slots.
const FIGURES: usize = 0;
const INSET: usize = 1;

/// What the viewer draws besides the scene (keys F, I and T in the window).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ViewerOptions {
    /// False colour: occluders blue, occlusion-culled objects red through
    /// what hides them (HOM's figure 1).
    pub overlay: bool,
    /// The culler's occlusion buffer as an inset, top right: white where
    /// its occluders cover the view.
    pub inset: bool,
    /// The line of figures, bottom left.
    pub figures: bool,
}

impl Default for ViewerOptions {
    /// The inset and the figures on, the false colour off.
    fn default() -> Self {
        ViewerOptions {
            overlay: false,
            inset: true,
            figures: true,
        }
    }
}

/// What one frame drew and what it cost.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameFigures {
    /// Objects drawn, as the file or engine names them: an object is drawn
    /// when any of its clusters is ([`hom::scene::Object::parent`]).
    pub objects_drawn: usize,
    /// Objects of the scene with a live cluster.
    pub objects: usize,
    /// Clusters drawn: what the cullers test and the renderer draws (an
    /// object not cut is one).
    pub clusters_drawn: usize,
    /// Live clusters of the scene.
    pub clusters: usize,
    /// Triangles drawn.
    pub triangles_drawn: u64,
    /// Triangles of the scene.
    pub triangles: u64,
    /// Clusters culled as occluded.
    pub occluded: usize,
    /// The cull's milliseconds.
    pub cull_ms: f64,
}

impl FrameFigures {
    /// Share of the scene's triangles not drawn, percent.
    pub fn culled_percent(&self) -> f64 {
        if self.triangles == 0 {
            return 0.0;
        }
        100.0 * (1.0 - self.triangles_drawn as f64 / self.triangles as f64)
    }
}

/// The scene on the GPU with what the viewer draws on top, for targets of one format.
pub struct Viewer {
    scene: SceneGpu,
    overlay: Overlay,
    depth: Option<((u32, u32), wgpu::TextureView)>,
    out: CullOutput,
    /// What is drawn besides the scene.
    pub options: ViewerOptions,
}

impl Viewer {
    /// A viewer of `scene` drawing into targets of `format`.
    pub fn new(
        gpu: &Gpu,
        scene: &Scene,
        format: wgpu::TextureFormat,
        options: ViewerOptions,
    ) -> Result<Viewer, ViewError> {
        Ok(Viewer {
            scene: SceneGpu::new(&gpu.device, scene, format)?,
            overlay: Overlay::new(&gpu.device, format),
            depth: None,
            out: CullOutput::default(),
            options,
        })
    }

    /// Frame `index`: culls `scene` from `camera` with `culler`, then draws
    /// the frame on `target` (`camera`'s viewport), with `status` (the
    /// scene, culler, frame time) leading the line of figures; with `None`
    /// the last frame's line stays (the window writes it four times a
    /// second: read, not flicker). Submitted, not waited for.
    #[allow(clippy::too_many_arguments)]
    pub fn frame(
        &mut self,
        gpu: &Gpu,
        scene: &Scene,
        camera: &Camera,
        culler: &mut dyn Culler,
        target: &wgpu::TextureView,
        index: usize,
        status: Option<&str>,
    ) -> Result<FrameFigures, ViewError> {
        let start = Instant::now();
        culler
            .cull(scene, &camera.to_view(), &mut self.out)
            .map_err(|source| ViewError::Cull { frame: index, source })?;
        // The viewer's frame time includes presenting: no signal for the cost model.
        culler.frame_done(None);
        let cull_ms = start.elapsed().as_secs_f64() * 1e3;
        let objects = scene.objects();
        // Parents counted only where some object was cut.
        let (objects_drawn, live_objects) = if scene.parent_count() == objects.len() {
            (self.out.visible.len(), scene.live_count())
        } else {
            let live: Vec<u32> = scene.live_objects().map(|(id, _)| id).collect();
            (scene.parents_of(&self.out.visible).len(), scene.parents_of(&live).len())
        };
        let figures = FrameFigures {
            objects_drawn,
            objects: live_objects,
            clusters_drawn: self.out.visible.len(),
            clusters: scene.live_count(),
            triangles_drawn: self
                .out
                .visible
                .iter()
                .map(|&id| objects[id as usize].triangles as u64)
                .sum(),
            triangles: scene.triangle_count(),
            occluded: self.out.occluded.len(),
            cull_ms,
        };

        let size = (camera.width, camera.height);
        if self.depth.as_ref().is_none_or(|(s, _)| *s != size) {
            self.depth = Some((size, depth_target(&gpu.device, size)));
        }
        let overlay = self.options.overlay.then_some(self.out.occluders.as_slice());
        self.scene.prepare(&gpu.device, &gpu.queue, scene, camera, overlay);
        self.update_pictures(gpu, culler, &figures, status, size);

        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        {
            let depth = &self.depth.as_ref().expect("made").1;
            let mut pass = begin_pass(&mut encoder, target, background(), depth, None);
            self.scene
                .draw(&mut pass, Pass::Colour, scene, &self.out.visible, camera.eye);
            if self.options.overlay {
                self.scene
                    .draw(&mut pass, Pass::Ghost, scene, &self.out.occluded, camera.eye);
            }
        }
        self.overlay.draw(&gpu.queue, &mut encoder, target, size);
        gpu.queue.submit([encoder.finish()]);
        Ok(figures)
    }

    fn update_pictures(
        &mut self,
        gpu: &Gpu,
        culler: &mut dyn Culler,
        figures: &FrameFigures,
        status: Option<&str>,
        (width, height): (u32, u32),
    ) {
        if let (true, Some(status)) = (self.options.figures, status) {
            let clusters = if figures.clusters == figures.objects {
                String::new()
            } else {
                // A line of its own: the figures' line is long already.
                format!(" in {} of {} clusters\n", figures.clusters_drawn, figures.clusters)
            };
            let line = format!(
                "{status}\n{} of {} objects{clusters}{}{} of {} triangles drawn, {:.0} % culled ({} occluded), cull {:.2} ms",
                figures.objects_drawn,
                figures.objects,
                if clusters.is_empty() { ", " } else { "" },
                count(figures.triangles_drawn),
                count(figures.triangles),
                figures.culled_percent(),
                figures.occluded,
                figures.cull_ms,
            );
            let (size, rgba) = text_picture(&line, TEXT_PX);
            self.overlay
                .set(&gpu.device, &gpu.queue, FIGURES, Corner::BottomLeft, size, &rgba);
        } else if !self.options.figures {
            self.overlay.clear(FIGURES);
        }
        let buffer = self.options.inset.then(|| culler.occlusion_buffer()).flatten();
        match buffer {
            Some(buffer) => {
                let inset_w = INSET_WIDTH.min(width);
                let inset_h = ((inset_w as u64 * height as u64) / width.max(1) as u64).max(1) as u32;
                let coverage = hom::occlusion::details::coverage(buffer, inset_w, inset_h);
                self.overlay.set(
                    &gpu.device,
                    &gpu.queue,
                    INSET,
                    Corner::TopRight,
                    (inset_w, inset_h),
                    &coverage_picture(&coverage),
                );
            }
            None => self.overlay.clear(INSET),
        }
    }
}

/// A count in few digits: 950, 18.2k, 1.35M.
fn count(n: u64) -> String {
    match n {
        0..1_000 => n.to_string(),
        1_000..1_000_000 => format!("{:.1}k", n as f64 / 1e3),
        _ => format!("{:.2}M", n as f64 / 1e6),
    }
}

/// The start of the line of figures: scene, culler, frame, and the last
/// frame's time where known.
pub(crate) fn status_line(scene: &str, culler: &str, frame: usize, last_frame_ms: Option<f64>) -> String {
    match last_frame_ms {
        Some(ms) => format!(
            "{scene} | {culler} | frame {frame} | {ms:.1} ms ({:.0} fps)",
            1e3 / ms.max(1e-3)
        ),
        None => format!("{scene} | {culler} | frame {frame}"),
    }
}
