//! Pictures people would rather look at than read: false-colour frames and plots.

use crate::report::FrameRecord;
use hom::cull::CullOutput;
use hom::geom::Camera;
use hom::occlusion::details::{Level, Pyramid};
use hom::scene::Scene;
use hom_render::{Colouring, Framebuffer, RenderOptions, Renderer};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::collections::BTreeMap;
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
    /// Cause, with its own causes.
    pub message: String,
}

fn picture_error(path: &Path, e: impl Into<Box<dyn std::error::Error>>) -> PictureError {
    // The message carries the whole chain (once): the drawing code's errors
    // are boxed without `Send`, so a picture error has no `source` to hold them.
    let e = e.into();
    let mut message = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        message.push_str(&format!(": {c}"));
        cause = c.source();
    }
    PictureError {
        path: path.display().to_string(),
        message,
    }
}

/// A false-colour picture of one culled frame, like figure 1 of the HOM paper:
/// the objects drawn, occluders blue and the rest grey, with the objects
/// culled as occluded shown *through* them in translucent red (they are hidden,
/// so an opaque render would never show them). Frustum-culled objects are not
/// drawn. Returns RGBA pixels, row 0 at the top (`camera.width` × `camera.height`).
pub fn render_false_colour(
    renderer: &Renderer,
    scene: &Scene,
    camera: &Camera,
    cull: &CullOutput,
    fb: &mut Framebuffer,
) -> Vec<[u8; 4]> {
    let mut colours = vec![DRAWN_GREY; scene.objects().len()];
    for &id in &cull.occluders {
        colours[id as usize] = OCCLUDER_BLUE;
    }
    let options = RenderOptions {
        colouring: Colouring::PerObject(&colours),
        ..RenderOptions::default()
    };
    renderer.render(scene, &cull.visible, camera, &options, fb);
    let mut image = fb.color().to_vec();
    // The culled objects alone, blended over the drawn ones where they would project.
    let reds = vec![CULLED_RED; scene.objects().len()];
    let culled = RenderOptions {
        colouring: Colouring::PerObject(&reds),
        ..RenderOptions::default()
    };
    renderer.render(scene, &cull.occluded, camera, &culled, fb);
    for (px, (&item, red)) in image.iter_mut().zip(fb.items().iter().zip(fb.color())) {
        if item != hom_render::NO_OBJECT {
            for c in 0..3 {
                px[c] = ((px[c] as u16 + 2 * red[c] as u16) / 3) as u8;
            }
        }
    }
    image
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

/// A named, coloured line of (x, y) points.
type Series<'a> = (&'a str, RGBColor, Vec<(f64, f64)>);

fn draw_frame_times(path: &Path, frames: &[FrameRecord], culler: &str) -> Result<(), Box<dyn std::error::Error>> {
    let root = BitMapBackend::new(path, (1100, 760)).into_drawing_area();
    root.fill(&WHITE)?;
    let (top, bottom) = root.split_vertically(430);
    let n = frames.len().max(1) as f64;
    let series: Vec<Series> = [
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
    chart
        .configure_mesh()
        .x_desc("frame")
        .y_desc("% of all triangles")
        .draw()?;
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

/// Colour of hole pixels in [`write_pyramid_levels`].
pub const HOLE_BLUE: [u8; 3] = [25, 80, 255];

/// Side of each level's panel in [`write_pyramid_levels`], pixels.
pub const PYRAMID_PANEL: u32 = 256;

const PANEL_GAP: u32 = 18;
const PANEL_CAPTION: u32 = 46;
const PYRAMID_TITLE: u32 = 56;
const PANELS_PER_ROW: u32 = 4;

/// Display size of a level's panel: its longer side [`PYRAMID_PANEL`], square cells.
fn panel_size(level: &Level) -> (u32, u32) {
    let (lw, lh) = (level.width.max(1), level.height.max(1));
    let longest = lw.max(lh);
    (lw * PYRAMID_PANEL / longest, lh * PYRAMID_PANEL / longest)
}

/// Height of a row of panels: the tallest panel.
fn panel_row_height(pyramid: &Pyramid) -> u32 {
    pyramid
        .levels()
        .iter()
        .map(|l| panel_size(l).1)
        .max()
        .unwrap_or(PYRAMID_PANEL)
}

/// Size in pixels of the picture [`write_pyramid_levels`] draws for `pyramid`.
pub fn pyramid_picture_size(pyramid: &Pyramid) -> (u32, u32) {
    let n = pyramid.levels().len().max(1) as u32;
    let cols = n.min(PANELS_PER_ROW);
    let rows = n.div_ceil(cols);
    (
        cols * (PYRAMID_PANEL + PANEL_GAP) + PANEL_GAP,
        PYRAMID_TITLE + rows * (panel_row_height(pyramid) + PANEL_CAPTION + PANEL_GAP),
    )
}

/// One PNG of every level of the occlusion pyramid (figures 3 and 6 of the HOM
/// paper), base level first, each scaled up with nearest-neighbour to
/// [`PYRAMID_PANEL`] pixels on its longer side: grey is opacity (black =
/// nothing covered, white = opaque). Pixels with opacity below `hole_opacity`
/// are tinted and outlined in [`HOLE_BLUE`] as holes, unless the whole level
/// is holes. Each level is captioned with its index, resolution and opacity
/// statistics. The picture's size is [`pyramid_picture_size`].
pub fn write_pyramid_levels(path: &Path, pyramid: &Pyramid, hole_opacity: f32) -> Result<(), PictureError> {
    register_fonts();
    let (width, height) = pyramid_picture_size(pyramid);
    let mut rgb = vec![255u8; (width * height * 3) as usize];
    draw_pyramid(&mut rgb, (width, height), pyramid, hole_opacity).map_err(|e| picture_error(path, e))?;
    let rgba: Vec<[u8; 4]> = rgb.chunks_exact(3).map(|p| [p[0], p[1], p[2], 255]).collect();
    hom_render::write_png(path, width, height, &rgba).map_err(|e| picture_error(path, e))
}

fn draw_pyramid(
    rgb: &mut [u8],
    (width, height): (u32, u32),
    pyramid: &Pyramid,
    hole_opacity: f32,
) -> Result<(), Box<dyn std::error::Error>> {
    let levels = pyramid.levels();
    let cols = (levels.len() as u32).clamp(1, PANELS_PER_ROW);
    let mut captions = Vec::new();
    for (k, level) in levels.iter().enumerate() {
        let (col, row) = (k as u32 % cols, k as u32 / cols);
        let x0 = PANEL_GAP + col * (PYRAMID_PANEL + PANEL_GAP);
        let y0 = PYRAMID_TITLE + row * (panel_row_height(pyramid) + PANEL_CAPTION + PANEL_GAP);
        let stats = paint_level(rgb, width, (x0, y0), level, hole_opacity);
        let size = pyramid.block() << k;
        captions.push((
            (x0, y0 + panel_size(level).1 + 5),
            format!("level {k}: {}×{}, {size}×{size} samples/px", level.width, level.height),
            format!("opaque {:.1}%, holes {:.1}%", stats.0, stats.1),
        ));
    }
    let root = BitMapBackend::with_buffer(rgb, (width, height)).into_drawing_area();
    let (vw, vh) = pyramid.viewport();
    root.draw(&Text::new(
        format!(
            "Occlusion pyramid, {vw}×{vh} viewport: grey = opacity (white = opaque); blue = hole (opacity < {hole_opacity})"
        ),
        (PANEL_GAP as i32, 16),
        ("sans-serif", 20).into_font().color(&BLACK),
    ))?;
    for ((x, y), line1, line2) in captions {
        let (x, y) = (x as i32, y as i32);
        root.draw(&Text::new(line1, (x, y), ("sans-serif", 16).into_font().color(&BLACK)))?;
        root.draw(&Text::new(
            line2,
            (x, y + 20),
            ("sans-serif", 15).into_font().color(&RGBColor(80, 80, 80)),
        ))?;
    }
    root.present()?;
    Ok(())
}

/// Paints one level into its panel; returns (% opaque pixels, % hole pixels).
fn paint_level(rgb: &mut [u8], stride: u32, (x0, y0): (u32, u32), level: &Level, hole_opacity: f32) -> (f64, f64) {
    let (lw, lh) = (level.width.max(1), level.height.max(1));
    let (dw, dh) = panel_size(level);
    let pixels = (lw * lh) as usize;
    let is_hole: Vec<bool> = (0..pixels as u32)
        .map(|i| level.opacity(i % lw, i / lw) < hole_opacity)
        .collect();
    let holes = is_hole.iter().filter(|&&h| h).count();
    let opaque = level.counts.iter().filter(|&&c| c == level.samples_per_pixel).count();
    let mark = holes > 0 && holes < pixels;
    let hole = |x: i64, y: i64| {
        x >= 0 && y >= 0 && x < lw as i64 && y < lh as i64 && is_hole[(y as u32 * lw + x as u32) as usize]
    };
    // Display pixels per level pixel; outline holes where cells are big enough to show it.
    let cell = dw as f32 / lw as f32;
    let outline = if cell >= 12.0 {
        2
    } else if cell >= 3.0 {
        1
    } else {
        0
    };
    let mut put = |x: u32, y: u32, c: [u8; 3]| {
        let i = (((y0 + y) * stride + x0 + x) * 3) as usize;
        rgb[i..i + 3].copy_from_slice(&c);
    };
    for dy in 0..dh {
        let ly = dy * lh / dh;
        for dx in 0..dw {
            let lx = dx * lw / dw;
            let v = (level.opacity(lx, ly).clamp(0.0, 1.0) * 255.0).round() as u8;
            let mut c = [v, v, v];
            if mark && is_hole[(ly * lw + lx) as usize] {
                c = [0, 1, 2].map(|i| (v as f32 * 0.45 + HOLE_BLUE[i] as f32 * 0.55) as u8);
                if outline > 0 {
                    // Distance in display pixels to this cell's edges, and whether the neighbour there is a hole.
                    let (cx0, cx1) = ((lx * dw).div_ceil(lw), ((lx + 1) * dw).div_ceil(lw));
                    let (cy0, cy1) = ((ly * dh).div_ceil(lh), ((ly + 1) * dh).div_ceil(lh));
                    let (x, y) = (lx as i64, ly as i64);
                    let edge = (dx < cx0 + outline && !hole(x - 1, y))
                        || (dx + outline >= cx1 && !hole(x + 1, y))
                        || (dy < cy0 + outline && !hole(x, y - 1))
                        || (dy + outline >= cy1 && !hole(x, y + 1));
                    if edge {
                        c = HOLE_BLUE;
                    }
                }
            }
            put(dx, dy, c);
        }
    }
    // A thin frame around the panel.
    let frame = [90, 90, 90];
    for dx in 0..dw {
        if y0 > 0 {
            let i = (((y0 - 1) * stride + x0 + dx) * 3) as usize;
            rgb[i..i + 3].copy_from_slice(&frame);
        }
        let i = (((y0 + dh) * stride + x0 + dx) * 3) as usize;
        rgb[i..i + 3].copy_from_slice(&frame);
    }
    for dy in 0..dh {
        let i = (((y0 + dy) * stride + x0 - 1) * 3) as usize;
        rgb[i..i + 3].copy_from_slice(&frame);
        let i = (((y0 + dy) * stride + x0 + dw) * 3) as usize;
        rgb[i..i + 3].copy_from_slice(&frame);
    }
    (
        100.0 * opaque as f64 / pixels as f64,
        100.0 * holes as f64 / pixels as f64,
    )
}

/// One bar of [`plot_stage_breakdown`]: a scene or culler's stage times
/// (the bench gives means, which add up to the mean frame) against its own baseline.
#[derive(Clone, Debug, PartialEq)]
pub struct StageBar {
    /// Label on the bar's axis, e.g. `"city / hom"`.
    pub label: String,
    /// Milliseconds per stage, as in [`crate::report::Summary::mean_stage_ms`];
    /// the sum entry `cull` is ignored.
    pub stages_ms: BTreeMap<String, f64>,
    /// The 100 % mark: frame time rendering everything in the frustum, ms.
    pub baseline_ms: f64,
}

/// Stages in bar order, with their colours; others go after `traversal`.
const STAGES: &[(&str, RGBColor)] = &[
    ("refit", RGBColor(140, 86, 75)),
    ("frustum", RGBColor(127, 127, 127)),
    ("selection", RGBColor(148, 103, 189)),
    ("raster", RGBColor(255, 127, 14)),
    ("pyramid", RGBColor(214, 39, 40)),
    ("depth", RGBColor(23, 190, 207)),
    ("traversal", RGBColor(44, 160, 44)),
    ("render", RGBColor(31, 119, 180)),
];
const OTHER_STAGE_COLOURS: &[RGBColor] = &[
    RGBColor(188, 189, 34),
    RGBColor(227, 119, 194),
    RGBColor(255, 187, 120),
    RGBColor(174, 199, 232),
];

/// Stage names present in `bars`, in bar order, with colours.
fn stage_order(bars: &[StageBar]) -> Vec<(String, RGBColor)> {
    let present: Vec<&String> = {
        let mut v: Vec<&String> = bars
            .iter()
            .flat_map(|b| b.stages_ms.keys())
            .filter(|k| *k != "cull")
            .collect();
        v.sort();
        v.dedup();
        v
    };
    let known = |name: &str| STAGES.iter().find(|s| s.0 == name).map(|s| s.1);
    let mut out: Vec<(String, RGBColor)> = STAGES
        .iter()
        .filter(|s| s.0 != "render" && present.iter().any(|p| *p == s.0))
        .map(|s| (s.0.to_string(), s.1))
        .collect();
    for (i, name) in present.iter().filter(|p| known(p).is_none()).enumerate() {
        out.push(((*name).clone(), OTHER_STAGE_COLOURS[i % OTHER_STAGE_COLOURS.len()]));
    }
    if present.iter().any(|p| *p == "render") {
        out.push(("render".to_string(), known("render").expect("listed")));
    }
    out
}

/// Width of [`plot_stage_breakdown`]'s picture, pixels.
pub const STAGE_PLOT_WIDTH: u32 = 1100;

/// Height of [`plot_stage_breakdown`]'s picture for `bars` bars, pixels.
pub fn stage_plot_height(bars: usize) -> u32 {
    (170 + 46 * bars as u32).max(300)
}

/// The time of each stage of culling and rendering, in percent of each bar's
/// baseline (rendering everything in the frustum = 100 %), as horizontal
/// stacked bars (figure 8 of the HOM paper), one per entry of `bars`, top to
/// bottom, with a legend and the 100 % line. The picture is
/// [`STAGE_PLOT_WIDTH`] × [`stage_plot_height`] pixels.
pub fn plot_stage_breakdown(path: &Path, bars: &[StageBar]) -> Result<(), PictureError> {
    register_fonts();
    draw_stage_breakdown(path, bars).map_err(|e| picture_error(path, e))
}

fn draw_stage_breakdown(path: &Path, bars: &[StageBar]) -> Result<(), Box<dyn std::error::Error>> {
    let root = BitMapBackend::new(path, (STAGE_PLOT_WIDTH, stage_plot_height(bars.len()))).into_drawing_area();
    root.fill(&WHITE)?;
    let (chart_area, legend_area) = root.split_vertically(stage_plot_height(bars.len()) - 48);
    let n = bars.len().max(1) as f64;
    let stages = stage_order(bars);
    let pct = |bar: &StageBar, ms: f64| {
        if bar.baseline_ms > 0.0 {
            100.0 * ms / bar.baseline_ms
        } else {
            0.0
        }
    };
    let totals: Vec<f64> = bars
        .iter()
        .map(|b| {
            stages
                .iter()
                .map(|(s, _)| pct(b, b.stages_ms.get(s).copied().unwrap_or(0.0)))
                .sum()
        })
        .collect();
    let x_max = totals.iter().copied().fold(100.0f64, f64::max) * 1.2;
    let label_chars = bars.iter().map(|b| b.label.chars().count()).max().unwrap_or(0);
    // Bar i (top first) is centred at y = n - i - 0.5: plotters' y grows upwards.
    let centre = |i: usize| n - i as f64 - 0.5;
    let mut chart = ChartBuilder::on(&chart_area)
        .caption("Time per frame by stage, % of frustum culling only", ("sans-serif", 24))
        .margin(14)
        .x_label_area_size(44)
        .y_label_area_size((label_chars as u32 * 9 + 20).clamp(60, 380))
        .build_cartesian_2d(0f64..x_max, 0f64..n)?;
    chart
        .configure_mesh()
        .disable_y_mesh()
        .y_labels(0)
        .x_desc("% of the frame time with frustum culling only (rendering everything in the view frustum)")
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 16))
        .draw()?;
    for (name, colour) in &stages {
        let mut start = vec![0.0f64; bars.len()];
        for (i, bar) in bars.iter().enumerate() {
            start[i] = stages
                .iter()
                .take_while(|(s, _)| s != name)
                .map(|(s, _)| pct(bar, bar.stages_ms.get(s).copied().unwrap_or(0.0)))
                .sum();
        }
        chart.draw_series(bars.iter().enumerate().filter_map(|(i, bar)| {
            let width = pct(bar, bar.stages_ms.get(name).copied().unwrap_or(0.0));
            (width > 0.0).then(|| {
                let y = centre(i);
                Rectangle::new([(start[i], y - 0.32), (start[i] + width, y + 0.32)], colour.filled())
            })
        }))?;
    }
    // The 100 % reference: frustum culling only.
    chart.draw_series(DashedLineSeries::new(
        [(100.0, 0.0), (100.0, n)],
        6,
        4,
        BLACK.stroke_width(2),
    ))?;
    // Totals at the end of each bar, and the labels left of the axis.
    let right = TextStyle::from(("sans-serif", 15).into_font()).pos(Pos::new(HPos::Right, VPos::Center));
    let left = TextStyle::from(("sans-serif", 15).into_font()).pos(Pos::new(HPos::Left, VPos::Center));
    for (i, (bar, total)) in bars.iter().zip(&totals).enumerate() {
        let ms: f64 = stages.iter().filter_map(|(s, _)| bar.stages_ms.get(s)).sum();
        let (x, y) = chart.backend_coord(&(*total, centre(i)));
        root.draw(&Text::new(
            format!("{total:.1}% ({ms:.2} ms)"),
            (x + 8, y),
            left.clone(),
        ))?;
        let (x, y) = chart.backend_coord(&(0.0, centre(i)));
        root.draw(&Text::new(bar.label.clone(), (x - 10, y), right.clone()))?;
    }
    // The legend, in one row under the chart.
    let (mut x, y) = (16, 20);
    let font = TextStyle::from(("sans-serif", 15).into_font()).pos(Pos::new(HPos::Left, VPos::Center));
    for (name, colour) in &stages {
        legend_area.draw(&Rectangle::new([(x, y - 7), (x + 14, y + 7)], colour.filled()))?;
        legend_area.draw(&Text::new(name.clone(), (x + 20, y), font.clone()))?;
        x += 20 + legend_area.estimate_text_size(name, &font)?.0 as i32 + 18;
    }
    let mut dash = x;
    while dash < x + 24 {
        legend_area.draw(&PathElement::new(vec![(dash, y), (dash + 6, y)], BLACK.stroke_width(2)))?;
        dash += 10;
    }
    legend_area.draw(&Text::new("frustum culling only = 100%", (x + 30, y), font))?;
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use hom::cull::{CullOutput, Culler, HomConfig, HomCuller};

    /// Width and height from a PNG's IHDR chunk.
    fn png_size(path: &Path) -> (u32, u32) {
        let bytes = std::fs::read(path).unwrap();
        assert!(bytes.len() > 100, "{} is too small", path.display());
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "not a PNG");
        assert_eq!(&bytes[12..16], b"IHDR");
        let be = |i: usize| u32::from_be_bytes(bytes[i..i + 4].try_into().unwrap());
        (be(16), be(20))
    }

    fn out_dir() -> std::path::PathBuf {
        let dir = std::env::temp_dir().join("hom-walk-pictures-test");
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn pyramid_of_a_city_frame_is_drawn_at_its_size() {
        let b = hom_scene::builtin("city").unwrap();
        let mut culler = HomCuller::new(&b.scene, HomConfig::default());
        let camera = b.path.camera(100);
        let mut out = CullOutput::default();
        culler.cull(&b.scene, &camera.to_view(), &mut out).unwrap();
        let pyramid = culler.pyramid().unwrap();
        let file = out_dir().join("pyramid_city.png");
        write_pyramid_levels(&file, pyramid, 0.5).unwrap();
        assert_eq!(png_size(&file), pyramid_picture_size(pyramid));
    }

    #[test]
    fn pyramid_with_a_hole_and_odd_sizes_is_drawn() {
        // 300x170 viewport, block 4: 75x43 base, non-square and ragged levels.
        let (w, h) = (300u32, 170u32);
        let wpr = (w as usize).div_ceil(64);
        let mut bits = vec![0u64; wpr * h as usize];
        for y in 0..h as usize {
            for x in 0..w as usize {
                let in_hole = (120..180).contains(&x) && (40..90).contains(&y);
                let in_gap = x == 250;
                if !in_hole && !in_gap && y > 10 {
                    bits[y * wpr + x / 64] |= 1 << (x % 64);
                }
            }
        }
        let mut p = Pyramid::new(w, h, 4, 2);
        p.build_from_coverage(&bits, wpr);
        let file = out_dir().join("pyramid_hole.png");
        write_pyramid_levels(&file, &p, 0.75).unwrap();
        assert_eq!(png_size(&file), pyramid_picture_size(&p));
        // An empty pyramid (all holes) still draws.
        let empty = Pyramid::new(64, 64, 8, 1);
        let file = out_dir().join("pyramid_empty.png");
        write_pyramid_levels(&file, &empty, 0.5).unwrap();
        assert_eq!(png_size(&file), pyramid_picture_size(&empty));
    }

    #[test]
    fn stage_breakdown_is_drawn_at_its_size() {
        let stages = |pairs: &[(&str, f64)]| pairs.iter().map(|(k, v)| (k.to_string(), *v)).collect();
        let bars = vec![
            StageBar {
                label: "city / frustum".into(),
                stages_ms: stages(&[("refit", 0.01), ("traversal", 0.3), ("cull", 0.31), ("render", 20.0)]),
                baseline_ms: 20.31,
            },
            StageBar {
                label: "city / hom".into(),
                stages_ms: stages(&[
                    ("refit", 0.01),
                    ("selection", 0.2),
                    ("raster", 1.1),
                    ("pyramid", 0.05),
                    ("depth", 0.02),
                    ("traversal", 0.4),
                    ("cull", 1.78),
                    ("render", 6.0),
                ]),
                baseline_ms: 20.31,
            },
            StageBar {
                label: "city / oracle-visible-set".into(),
                stages_ms: stages(&[("render", 3.5)]),
                baseline_ms: 20.31,
            },
            StageBar {
                label: "office / hom, a new stage".into(),
                stages_ms: stages(&[("selection", 0.3), ("coherence", 0.5), ("render", 30.0)]),
                baseline_ms: 25.0,
            },
        ];
        let file = out_dir().join("stages.png");
        plot_stage_breakdown(&file, &bars).unwrap();
        assert_eq!(png_size(&file), (STAGE_PLOT_WIDTH, stage_plot_height(bars.len())));
        let order: Vec<String> = stage_order(&bars).into_iter().map(|s| s.0).collect();
        assert_eq!(
            order,
            [
                "refit",
                "selection",
                "raster",
                "pyramid",
                "depth",
                "traversal",
                "coherence",
                "render"
            ]
        );
        // No bars at all still draws.
        let file = out_dir().join("stages_empty.png");
        plot_stage_breakdown(&file, &[]).unwrap();
        assert_eq!(png_size(&file), (STAGE_PLOT_WIDTH, stage_plot_height(0)));
    }
}
