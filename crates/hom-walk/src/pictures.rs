//! Pictures people would rather look at than read: false-colour frames and plots.

use crate::report::FrameRecord;
use hom::cull::CullOutput;
use hom::geom::Camera;
use hom::scene::Scene;
use hom_render::{Colouring, Framebuffer, RenderOptions, Renderer};
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

/// False colour of an occluder (figure 1 of the HOM paper).
pub const OCCLUDER_BLUE: [u8; 3] = [70, 110, 235];
/// False colour of an object drawn because it was not culled.
pub const DRAWN_GREY: [u8; 3] = [185, 185, 185];
/// False colour of an object culled as occluded.
pub const CULLED_RED: [u8; 3] = [225, 45, 35];

/// Why a picture could not be drawn or written.
#[derive(Debug, thiserror::Error)]
#[error("cannot draw {path}: {message}")]
pub struct PictureError {
    /// Output file.
    pub path: String,
    /// Cause.
    pub message: String,
}

fn picture_error(path: &Path, e: impl std::fmt::Display) -> PictureError {
    PictureError {
        path: path.display().to_string(),
        message: e.to_string(),
    }
}

/// Renders every object the culler kept or culled as occluded, coloured by
/// its fate: occluders blue, other drawn objects grey, occlusion-culled red.
/// Frustum-culled objects are not drawn.
pub fn render_false_colour(
    renderer: &Renderer,
    scene: &Scene,
    camera: &Camera,
    cull: &CullOutput,
    fb: &mut Framebuffer,
) {
    let mut colours = vec![DRAWN_GREY; scene.objects().len()];
    for &id in &cull.occluded {
        colours[id as usize] = CULLED_RED;
    }
    for &id in &cull.occluders {
        colours[id as usize] = OCCLUDER_BLUE;
    }
    let mut ids: Vec<u32> = cull.visible.iter().chain(&cull.occluded).copied().collect();
    ids.sort_unstable();
    let options = RenderOptions {
        colouring: Colouring::PerObject(&colours),
        ..RenderOptions::default()
    };
    renderer.render(scene, &ids, camera, &options, fb);
}

fn register_fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // A font shipped inside a crate, so plots need no system font library.
        let font = epaint_default_fonts::UBUNTU_LIGHT;
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, font);
    });
}

/// Per-frame frame time and % of triangles culled, with and without the
/// culler (figure 7 of the HOM paper), as a PNG.
pub fn plot_frame_times(path: &Path, frames: &[FrameRecord], culler: &str) -> Result<(), PictureError> {
    register_fonts();
    draw_frame_times(path, frames, culler).map_err(|e| picture_error(path, e))
}

fn draw_frame_times(path: &Path, frames: &[FrameRecord], culler: &str) -> Result<(), Box<dyn std::error::Error>> {
    let root = BitMapBackend::new(path, (1100, 760)).into_drawing_area();
    root.fill(&WHITE)?;
    let (top, bottom) = root.split_vertically(430);
    let n = frames.len().max(1) as f64;
    let series: Vec<(&str, RGBColor, Vec<(f64, f64)>)> = [
        (
            "frustum only",
            RGBColor(120, 120, 120),
            frames
                .iter()
                .filter_map(|f| f.baseline_frame_ms.map(|ms| (f.frame as f64, ms)))
                .collect::<Vec<_>>(),
        ),
        (
            culler,
            RGBColor(30, 90, 200),
            frames.iter().map(|f| (f.frame as f64, f.frame_ms)).collect(),
        ),
        (
            "oracle visible set",
            RGBColor(40, 160, 60),
            frames
                .iter()
                .filter_map(|f| f.oracle.as_ref().map(|o| (f.frame as f64, o.oracle_set_render_ms)))
                .collect(),
        ),
    ]
    .into_iter()
    .filter(|s| !s.2.is_empty())
    .collect();
    let y_max = series
        .iter()
        .flat_map(|s| s.2.iter().map(|p| p.1))
        .fold(1.0f64, f64::max)
        * 1.1;
    let mut chart = ChartBuilder::on(&top)
        .caption("Frame time (culling + rendering)", ("sans-serif", 24))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(60)
        .build_cartesian_2d(0f64..n, 0f64..y_max)?;
    chart.configure_mesh().x_desc("frame").y_desc("ms").draw()?;
    for (label, colour, points) in series {
        chart
            .draw_series(LineSeries::new(points, colour.stroke_width(2)))?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], colour.stroke_width(3)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 16))
        .draw()?;

    let total_culled = |f: &FrameRecord| {
        let all = (f.triangles_drawn + f.triangles_frustum_culled + f.triangles_occlusion_culled).max(1) as f64;
        (
            100.0 * (f.triangles_frustum_culled + f.triangles_occlusion_culled) as f64 / all,
            100.0 * f.triangles_frustum_culled as f64 / all,
        )
    };
    let mut chart = ChartBuilder::on(&bottom)
        .caption("Triangles culled", ("sans-serif", 24))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(60)
        .build_cartesian_2d(0f64..n, 0f64..100f64)?;
    chart.configure_mesh().x_desc("frame").y_desc("% of all triangles").draw()?;
    let frustum_colour = RGBColor(120, 120, 120);
    let culler_colour = RGBColor(30, 90, 200);
    chart
        .draw_series(LineSeries::new(
            frames.iter().map(|f| (f.frame as f64, total_culled(f).1)),
            frustum_colour.stroke_width(2),
        ))?
        .label("frustum only")
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], frustum_colour.stroke_width(3)));
    chart
        .draw_series(LineSeries::new(
            frames.iter().map(|f| (f.frame as f64, total_culled(f).0)),
            culler_colour.stroke_width(2),
        ))?
        .label(culler)
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], culler_colour.stroke_width(3)));
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 16))
        .draw()?;
    root.present()?;
    Ok(())
}
