//! Level of detail in the walkthrough (`hom walk --lod`): after the culler
//! decides which objects to draw, each visible object's level-of-detail front
//! is moved ([`hom::lod::LodSelector`]), guided by the culler's box test
//! ([`hom::cull::Culler::box_hidden`]) unless guidance is off, and the
//! renderer draws the selected nodes' triangles.
//!
//! Every frame is also selected by the view alone for every object in the
//! frustum (the culler's visible and occluded objects, guidance off): what
//! level of detail without any occlusion culling draws
//! (`lod_view_only_triangles`, the baseline of Law & Tan's comparison). With
//! the oracle on and guidance on, the frame is also selected for the
//! culler's objects without guidance and drawn a second time: the pixels
//! that differ are counted (`lod_guidance_pixels_changed`). Guidance only
//! keeps hidden nodes coarse, so the count should be 0.

use hom::cull::Culler;
use hom::geom::{Camera, View};
use hom::lod::{LodError, LodOptions, LodPart, LodSelector, LodStats, LodView, OccluderLod, SceneLod};
use hom::scene::Scene;
use hom_render::{Framebuffer, Part, RenderOptions, Renderer};
use serde::Serialize;
use std::sync::Arc;
use std::time::Instant;

/// Level of detail for a walk: the hierarchies and how to select from them.
#[derive(Clone, Debug)]
pub struct WalkLod {
    /// A hierarchy per mesh of the walked scene.
    pub hierarchies: Arc<SceneLod>,
    /// Threshold or budget, guidance on or off.
    pub options: LodOptions,
    /// Occluders drawn at the frame's level of detail
    /// ([`hom::cull::Culler::set_occluder_lod`]; threshold mode only: a
    /// budget's cut is not known before the culler runs).
    pub occluders: bool,
}

impl WalkLod {
    /// What the culler is given: the hierarchies and the threshold, when
    /// occluders are drawn at the level of detail and the threshold decides the cut.
    pub fn occluder_lod(&self) -> Option<OccluderLod> {
        (self.occluders && self.options.budget.is_none()).then(|| OccluderLod {
            hierarchies: self.hierarchies.clone(),
            error_px: self.options.error_px,
        })
    }
}

/// The report's level-of-detail fields of one frame.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct LodFrame {
    /// Triangles of the selected nodes (what the renderer drew).
    pub lod_triangles: u64,
    /// Nodes drawn.
    pub lod_nodes_drawn: u64,
    /// Inner nodes refined above the drawn ones.
    pub lod_nodes_refined: u64,
    /// Drawn nodes kept coarse because the culler found them hidden.
    pub lod_nodes_occluded: u64,
    /// Box tests asked of the culler.
    pub lod_hidden_tests: u64,
    /// Largest projected error of a drawn node in the frustum and not hidden, pixels.
    pub lod_max_error_px: f32,
    /// Milliseconds of the selection.
    pub lod_ms: f64,
    /// Triangles of the coarsest cut of the drawn objects (their roots).
    pub lod_coarsest_triangles: u64,
    /// With the oracle and guidance: pixels (colour or item) that differ from
    /// the same frame selected without guidance.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lod_guidance_pixels_changed: Option<u64>,
    /// Triangles the same objects would draw without guidance, where it ran
    /// (with the oracle).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lod_unguided_triangles: Option<u64>,
    /// Triangles of view-only level of detail over every object in the
    /// frustum (no occlusion culling, no guidance).
    pub lod_view_only_triangles: u64,
    /// With the oracle: triangles of view-only level of detail over the
    /// oracle's visible objects — what exact object culling would leave.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lod_oracle_triangles: Option<u64>,
    /// With the oracle: pixels whose owning object differs from the
    /// full-resolution image's (the level of detail's own change, along
    /// silhouettes, within the error threshold).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lod_pixels_differ_from_full: Option<u64>,
    /// With the oracle: pixels (colour or item) that differ from view-only
    /// level of detail of every object in the frustum, nothing occlusion
    /// culled: what culling and guidance together changed in the image the
    /// level of detail shows. 0 expected with occluders at the level of
    /// detail; without, an object hidden by an occluder's full mesh can show
    /// where the occluder's cut lies within its error inside it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lod_culling_pixels_changed: Option<u64>,
}

impl LodFrame {
    fn new(stats: &LodStats, lod_ms: f64) -> LodFrame {
        LodFrame {
            lod_triangles: stats.triangles,
            lod_nodes_drawn: stats.nodes_drawn,
            lod_nodes_refined: stats.nodes_refined,
            lod_nodes_occluded: stats.nodes_occluded,
            lod_hidden_tests: stats.hidden_tests,
            lod_max_error_px: stats.max_error_px,
            lod_ms,
            lod_coarsest_triangles: stats.coarsest_triangles,
            lod_guidance_pixels_changed: None,
            lod_unguided_triangles: None,
            lod_view_only_triangles: 0,
            lod_oracle_triangles: None,
            lod_pixels_differ_from_full: None,
            lod_culling_pixels_changed: None,
        }
    }
}

/// The walk's level-of-detail state across frames.
pub(crate) struct LodRun {
    setup: WalkLod,
    selector: LodSelector,
    /// View-only twin, for the image comparison.
    unguided: Option<(LodSelector, Framebuffer)>,
    /// With the oracle: the frame drawn from view-only level of detail of
    /// every object in the frustum.
    unculled: Option<Framebuffer>,
    /// View-only selection over the frustum's objects.
    view_only: LodSelector,
    /// View-only selection over the oracle's objects.
    oracle: LodSelector,
    parts: Vec<LodPart>,
    in_frustum: Vec<u32>,
    /// This frame's refinement view (`None` before a frame, or for a view without a frustum).
    view: Option<LodView>,
}

impl LodRun {
    pub fn new(setup: &WalkLod, scene: &Scene, compare: bool) -> Result<LodRun, LodError> {
        setup.options.validate()?;
        setup.hierarchies.check_scene(scene)?;
        Ok(LodRun {
            setup: setup.clone(),
            selector: LodSelector::default(),
            unguided: (compare && setup.options.guidance).then(|| (LodSelector::default(), Framebuffer::new(1, 1))),
            unculled: compare.then(|| Framebuffer::new(1, 1)),
            view_only: LodSelector::default(),
            oracle: LodSelector::default(),
            parts: Vec::new(),
            in_frustum: Vec::new(),
            view: None,
        })
    }

    /// Selects this frame's nodes of `visible` and draws them into `fb`
    /// (`occluded`: the objects the culler found hidden, for the view-only
    /// count). Returns the frame's fields and the render milliseconds.
    #[allow(clippy::too_many_arguments)]
    pub fn frame(
        &mut self,
        scene: &Scene,
        view: &View,
        camera: &Camera,
        culler: &mut dyn Culler,
        visible: &[u32],
        occluded: &[u32],
        renderer: &Renderer,
        draw: &RenderOptions,
        fb: &mut Framebuffer,
    ) -> Result<(LodFrame, f64), LodError> {
        let lod = &*self.setup.hierarchies;
        let start = Instant::now();
        self.view = LodView::new(view);
        let Some(lod_view) = &self.view else {
            // A view without a frustum draws nothing (the culler refused it first).
            return Ok((LodFrame::default(), 0.0));
        };
        let stats = self.selector.select(
            scene,
            lod,
            visible,
            lod_view,
            &self.setup.options,
            &mut |corners| culler.box_hidden(corners),
            &mut self.parts,
        )?;
        let mut record = LodFrame::new(&stats, ms_since(start));
        let start = Instant::now();
        renderer.render_parts(scene, &draw_parts(scene, lod, &self.parts), camera, draw, fb);
        let render_ms = ms_since(start);
        self.in_frustum.clear();
        self.in_frustum.extend_from_slice(visible);
        self.in_frustum.extend_from_slice(occluded);
        let mut parts = Vec::new();
        record.lod_view_only_triangles = by_view_alone(
            &mut self.view_only,
            &self.setup,
            scene,
            &self.in_frustum,
            lod_view,
            &mut parts,
        )?
        .triangles;
        if let Some(unculled) = self.unculled.as_mut() {
            renderer.render_parts(scene, &draw_parts(scene, lod, &parts), camera, draw, unculled);
            record.lod_culling_pixels_changed = Some(pixels_differ(fb, unculled));
        }
        if let Some((selector, unguided_fb)) = self.unguided.as_mut() {
            let unguided = by_view_alone(selector, &self.setup, scene, visible, lod_view, &mut parts)?;
            renderer.render_parts(scene, &draw_parts(scene, lod, &parts), camera, draw, unguided_fb);
            record.lod_guidance_pixels_changed = Some(pixels_differ(fb, unguided_fb));
            record.lod_unguided_triangles = Some(unguided.triangles);
        }
        Ok((record, render_ms))
    }

    /// Triangles of view-only level of detail over the objects
    /// `oracle_visible`, from the last [`LodRun::frame`]'s view.
    pub fn oracle_triangles(&mut self, scene: &Scene, oracle_visible: &[u32]) -> Result<u64, LodError> {
        let Some(lod_view) = &self.view else {
            return Ok(0);
        };
        let mut parts = Vec::new();
        Ok(by_view_alone(
            &mut self.oracle,
            &self.setup,
            scene,
            oracle_visible,
            lod_view,
            &mut parts,
        )?
        .triangles)
    }
}

/// Pixels whose colour or owning item differ between two frames of one size.
fn pixels_differ(a: &Framebuffer, b: &Framebuffer) -> u64 {
    a.color()
        .iter()
        .zip(b.color())
        .zip(a.items().iter().zip(b.items()))
        .filter(|((a, b), (i, j))| a != b || i != j)
        .count() as u64
}

/// `selector`'s selection of `ids` with `setup`'s threshold or budget and
/// guidance off: refinement by the view alone.
fn by_view_alone(
    selector: &mut LodSelector,
    setup: &WalkLod,
    scene: &Scene,
    ids: &[u32],
    view: &LodView,
    parts: &mut Vec<LodPart>,
) -> Result<LodStats, LodError> {
    let options = LodOptions {
        guidance: false,
        ..setup.options
    };
    selector.select(scene, &setup.hierarchies, ids, view, &options, &mut |_| false, parts)
}

/// The renderer's parts for selected nodes.
pub fn draw_parts<'a>(scene: &Scene, lod: &'a SceneLod, parts: &[LodPart]) -> Vec<Part<'a>> {
    parts
        .iter()
        .map(|p| {
            let mesh = scene.object(p.object).mesh;
            (p.object, lod.hierarchy(mesh).triangles(p.node))
        })
        .collect()
}

fn ms_since(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}

/// The summary's level-of-detail fields.
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct LodSummary {
    /// Median triangles drawn per frame.
    pub median_lod_triangles: f64,
    /// Summed triangles drawn.
    pub lod_triangles: u64,
    /// Summed triangles the same objects would draw without guidance, where it ran.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lod_unguided_triangles: Option<u64>,
    /// Summed triangles of view-only level of detail over the frustum's objects.
    pub lod_view_only_triangles: u64,
    /// Summed triangles of view-only level of detail over the oracle's objects, where it ran.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lod_oracle_triangles: Option<u64>,
    /// Largest projected error of a drawn, visible node over the walk, pixels.
    pub lod_max_error_px: f32,
    /// Summed nodes kept coarse as hidden.
    pub lod_nodes_occluded: u64,
    /// Median selection milliseconds.
    pub median_lod_ms: f64,
    /// Summed pixels whose owner differs from the full-resolution image, where the oracle ran.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lod_pixels_differ_from_full: Option<u64>,
    /// Summed pixels that guidance changed (0 expected), where compared.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lod_guidance_pixels_changed: Option<u64>,
    /// Summed pixels that culling and guidance changed against view-only
    /// level of detail of the whole frustum, where the oracle ran.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lod_culling_pixels_changed: Option<u64>,
    /// Whether occluders were drawn at the level of detail.
    pub lod_occluders: bool,
    /// Budget mode: of the frames where the budget binds (the coarsest cut
    /// fits it and some drawn node in view is still above 0 px of error), the
    /// share within ±5 % of it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lod_frames_within_budget: Option<f64>,
    /// Budget mode: frames where the budget binds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lod_frames_budget_binds: Option<u64>,
}

/// Sums and medians of the frames' level-of-detail fields.
pub fn summarize_lod(frames: &[&LodFrame], budget: Option<u64>, occluders: bool) -> LodSummary {
    let sum_opt = |f: fn(&LodFrame) -> Option<u64>| -> Option<u64> {
        let v: Option<Vec<u64>> = frames.iter().map(|r| f(r)).collect();
        v.filter(|v| !v.is_empty()).map(|v| v.iter().sum())
    };
    LodSummary {
        median_lod_triangles: crate::stats::median(frames.iter().map(|f| f.lod_triangles as f64)),
        lod_triangles: frames.iter().map(|f| f.lod_triangles).sum(),
        lod_unguided_triangles: sum_opt(|f| f.lod_unguided_triangles),
        lod_view_only_triangles: frames.iter().map(|f| f.lod_view_only_triangles).sum(),
        lod_oracle_triangles: sum_opt(|f| f.lod_oracle_triangles),
        lod_pixels_differ_from_full: sum_opt(|f| f.lod_pixels_differ_from_full),
        lod_max_error_px: frames.iter().map(|f| f.lod_max_error_px).fold(0.0, f32::max),
        lod_nodes_occluded: frames.iter().map(|f| f.lod_nodes_occluded).sum(),
        median_lod_ms: crate::stats::median(frames.iter().map(|f| f.lod_ms)),
        lod_guidance_pixels_changed: sum_opt(|f| f.lod_guidance_pixels_changed),
        lod_culling_pixels_changed: sum_opt(|f| f.lod_culling_pixels_changed),
        lod_occluders: occluders,
        lod_frames_within_budget: budget.map(|b| {
            let binding: Vec<_> = frames.iter().filter(|f| budget_binds(f, b)).collect();
            let within = binding
                .iter()
                .filter(|f| (f.lod_triangles as f64 - b as f64).abs() <= 0.05 * b as f64)
                .count();
            within as f64 / binding.len().max(1) as f64
        }),
        lod_frames_budget_binds: budget.map(|b| frames.iter().filter(|f| budget_binds(f, b)).count() as u64),
    }
}

/// Whether a budget of `b` triangles binds on a frame: it holds the coarsest
/// cut, and the view still wants more (a drawn node in view above 0 px).
pub fn budget_binds(frame: &LodFrame, b: u64) -> bool {
    frame.lod_coarsest_triangles <= b && frame.lod_max_error_px > 0.0
}

/// A colour per part by how coarse its node is: the ratio of the original
/// triangles it stands for to the triangles it draws, in halvings — blue at
/// full resolution, then cyan, green, yellow, orange, red from 16× coarser.
pub fn coarseness_colours(scene: &Scene, lod: &SceneLod, parts: &[LodPart]) -> Vec<[u8; 3]> {
    const RAMP: [[u8; 3]; 6] = [
        [60, 110, 230],
        [60, 200, 220],
        [80, 200, 90],
        [230, 220, 60],
        [240, 150, 40],
        [220, 50, 40],
    ];
    parts
        .iter()
        .map(|p| {
            let node = lod.hierarchy(scene.object(p.object).mesh).nodes()[p.node as usize];
            let ratio = node.original_count() as f32 / node.triangle_count().max(1) as f32;
            RAMP[(ratio.log2().round().max(0.0) as usize).min(RAMP.len() - 1)]
        })
        .collect()
}
