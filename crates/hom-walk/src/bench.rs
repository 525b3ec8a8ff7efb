//! `hom bench`: several cullers walked side by side over several scenes in one
//! process, with the oracle on, summarised as one table (and JSON).
//!
//! Every culler walks the same path with the same renderer; each walk also
//! times frustum-only culling and rendering of every frame (the baseline) and
//! the render of just the oracle's visible set. The pseudo-row
//! [`ORACLE_ROW`] is that oracle render: the frame time no culler can beat.

use crate::pictures::StageBar;
use crate::report::{fmt_opt, mean, median, Summary};
use crate::{cullers, renderer_name, DrawError, FrameDraw, WalkError, WalkOptions, WalkResult, SOFTWARE_RENDERER};
use hom::cull::{Coherence, CullStats, DepthCheck, Hierarchy, PSkip, PropagationStats};
use hom::experimental::{HvPriming, KdTree};
use hom::occluders::OccluderMeshes;
use hom::scene::Scene;
use hom_render::{RenderError, Renderer};
use hom_scene::{CameraPathError, LoadError};
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::PathBuf;
use thiserror::Error;

/// Name of the pseudo-row that renders only the oracle's visible set.
pub const ORACLE_ROW: &str = "oracle-visible-set";

/// How to bench.
#[derive(Clone, Debug, Serialize)]
pub struct BenchOptions {
    /// Walk only the first `n` frames of each path (all when `None`).
    pub frames: Option<usize>,
    /// Image width override (default: each path's own).
    pub width: Option<u32>,
    /// Image height override (default: each path's own).
    pub height: Option<u32>,
    /// Renderer threads (0 = one per core).
    pub threads: usize,
    /// The traversal coherence modes to walk each of HOM, HZB, masked and otree
    /// with, one row each; empty: their default only.
    #[serde(serialize_with = "coherence_labels")]
    pub coherence: Vec<Coherence>,
    /// The hierarchies to walk each of HOM, HZB and masked with, one row
    /// each (times the coherence modes); empty: the default (BVH) only.
    #[serde(serialize_with = "hierarchy_labels")]
    pub hierarchy: Vec<Hierarchy>,
    /// The occluder meshes to walk each of HOM, HZB, masked and otree with, one
    /// row each (times the hierarchies and coherence modes); empty: the default
    /// ([`OccluderMeshes::Virtual`]) only.
    #[serde(serialize_with = "occluder_labels")]
    pub occluders: Vec<OccluderMeshes>,
    /// Whether HOM, HZB, masked and otree rest while occlusion culling does not pay.
    pub cost_model: bool,
    /// Where HOM, HZB, masked and otree check what they cover sample by
    /// sample after the traversal ([`hom::cull::OccluderCullerConfig::depth_check`]).
    #[serde(serialize_with = "display")]
    pub depth_check: DepthCheck,
    /// Walk each path this many times as fast ([`hom_scene::CameraPath::at_speed`]).
    pub speed: Option<f32>,
    /// A cut every this many frames ([`hom_scene::CameraPath::with_cuts`]).
    pub cuts: Option<usize>,
    /// Whether HV primes its pyramid with last frame's visible nodes.
    pub hv_priming: bool,
    /// The camera path file to walk instead of the scene's own (one scene only).
    pub camera_path: Option<PathBuf>,
    /// HOM's occluder polygon budget (triangles per frame) for every occluder
    /// culler, instead of the scene's default.
    pub budget: Option<u32>,
    /// Whether scene files are cut into cluster-sized objects
    /// ([`hom_scene::LoadOptions`]; `--clusters off` keeps whole objects).
    pub clusters: bool,
}

impl Default for BenchOptions {
    /// Every frame, each path's viewport, all cores, each culler's defaults.
    fn default() -> Self {
        BenchOptions {
            frames: None,
            width: None,
            height: None,
            threads: 0,
            coherence: Vec::new(),
            hierarchy: Vec::new(),
            occluders: Vec::new(),
            cost_model: true,
            depth_check: DepthCheck::default(),
            speed: None,
            cuts: None,
            hv_priming: false,
            camera_path: None,
            budget: None,
            clusters: true,
        }
    }
}

/// The cullers whose traversal takes a [`Coherence`].
const COHERENT_CULLERS: &[&str] = &["hom", "hzb", "masked", "otree", "hv"];

/// The cullers whose occlusion traversal takes a [`Hierarchy`] (HV has its octree),
/// and that draw occluders picked from the [`OccluderMeshes`].
const HIERARCHY_CULLERS: &[&str] = &["hom", "hzb", "masked", "otree"];

/// A coherence mode as `hom bench --coherence` spells it: `off`, `exact`,
/// `skip` (adaptive p_skip) or `skip:P`.
pub fn coherence_label(c: &Coherence) -> String {
    match c {
        Coherence::Off => "off".into(),
        Coherence::Exact => "exact".into(),
        Coherence::Skip(PSkip::Auto) => "skip".into(),
        Coherence::Skip(PSkip::Fixed(p)) => format!("skip:{p}"),
    }
}

/// A `p_skip` as `--p-skip` and `skip:P` spell it: `auto` or a probability in [0, 1].
pub fn parse_p_skip(s: &str) -> Result<PSkip, String> {
    if s == "auto" {
        return Ok(PSkip::Auto);
    }
    match s.parse::<f32>() {
        Ok(p) if (0.0..=1.0).contains(&p) => Ok(PSkip::Fixed(p)),
        _ => Err(format!("expected `auto` or a probability in [0, 1], got `{s}`")),
    }
}

/// The inverse of [`coherence_label`] (also `skip:auto`).
pub fn parse_coherence(s: &str) -> Result<Coherence, String> {
    match s {
        "off" => Ok(Coherence::Off),
        "exact" => Ok(Coherence::Exact),
        "skip" => Ok(Coherence::Skip(PSkip::Auto)),
        _ => match s.strip_prefix("skip:") {
            Some(p) => parse_p_skip(p)
                .map(Coherence::Skip)
                .map_err(|e| format!("after `skip:`, {e}")),
            None => Err(format!("expected off, exact, skip or skip:P, got `{s}`")),
        },
    }
}

/// Occluder meshes as `--occluders` spells them: `original` or `virtual`.
pub fn parse_occluders(s: &str) -> Result<OccluderMeshes, String> {
    match s {
        "original" => Ok(OccluderMeshes::Original),
        "virtual" => Ok(OccluderMeshes::Virtual),
        _ => Err(format!("expected original or virtual, got `{s}`")),
    }
}

/// A hierarchy as `--hierarchy` spells it: `bvh`, `kd` or `kd-propagate`.
pub fn parse_hierarchy(s: &str) -> Result<Hierarchy, String> {
    match s {
        "bvh" => Ok(Hierarchy::Bvh),
        "kd" => Ok(Hierarchy::KdTree(KdTree { propagation: false })),
        "kd-propagate" => Ok(Hierarchy::KdTree(KdTree { propagation: true })),
        _ => Err(format!("expected bvh, kd or kd-propagate, got `{s}`")),
    }
}

/// A `--depth-check` value: off, if-drawn or on.
pub fn parse_depth_check(s: &str) -> Result<DepthCheck, String> {
    match s {
        "off" => Ok(DepthCheck::Off),
        "if-drawn" => Ok(DepthCheck::IfDrawn),
        "on" => Ok(DepthCheck::On),
        _ => Err(format!("expected off, if-drawn or on, got `{s}`")),
    }
}

fn display<S: serde::Serializer>(d: &DepthCheck, s: S) -> Result<S::Ok, S::Error> {
    s.collect_str(d)
}

fn hierarchy_labels<S: serde::Serializer>(h: &[Hierarchy], s: S) -> Result<S::Ok, S::Error> {
    s.collect_seq(h.iter().map(|h| h.to_string()))
}

fn occluder_labels<S: serde::Serializer>(m: &[OccluderMeshes], s: S) -> Result<S::Ok, S::Error> {
    s.collect_seq(m.iter().map(|m| m.to_string()))
}

fn coherence_labels<S: serde::Serializer>(modes: &[Coherence], s: S) -> Result<S::Ok, S::Error> {
    s.collect_seq(modes.iter().map(coherence_label))
}

/// Why a bench could not run.
#[derive(Debug, Error)]
pub enum BenchError {
    /// A scene could not be opened.
    #[error("scene {scene}")]
    Scene {
        /// The scene as given.
        scene: String,
        /// Cause.
        source: LoadError,
    },
    /// A culler name is not known to [`cullers::make`].
    #[error("unknown culler '{name}'; available: {known}")]
    UnknownCuller {
        /// The name as given.
        name: String,
        /// The known names, comma-separated.
        known: String,
    },
    /// A camera path file was given with several scenes: it belongs to one.
    #[error("--camera-path walks one scene; {0} were given")]
    CameraPathForSeveralScenes(usize),
    /// Nothing to do: no scenes, no cullers, or zero frames.
    #[error("nothing to bench: {0}")]
    Empty(&'static str),
    /// The camera path is not usable at the requested viewport.
    #[error("scene {scene}")]
    Path {
        /// The scene as given.
        scene: String,
        /// Cause.
        source: CameraPathError,
    },
    /// The renderer could not be made.
    #[error(transparent)]
    Render(#[from] RenderError),
    /// The renderer that draws the timed frames could not be made for a scene.
    #[error("scene {scene}: no renderer for its frames")]
    FrameDraw {
        /// Scene name.
        scene: String,
        /// Cause.
        source: DrawError,
    },
    /// A walk stopped.
    #[error("scene {scene}, culler {culler}")]
    Walk {
        /// Scene name.
        scene: String,
        /// Culler name.
        culler: String,
        /// Cause.
        source: WalkError,
    },
}

/// A benched scene.
#[derive(Clone, Debug, Serialize)]
pub struct BenchScene {
    /// The scene as given (built-in name or file).
    pub spec: String,
    /// The scene's own name.
    pub name: String,
    /// Number of objects as the file or generator names them (parents,
    /// [`hom::scene::Object::parent`]).
    pub objects: usize,
    /// Number of what is culled and drawn: the objects' clusters (an object
    /// not cut is one).
    pub cluster_count: usize,
    /// Number of triangles.
    pub triangles: u64,
    /// Number of dynamic objects.
    pub dynamic_objects: usize,
    /// Image width walked.
    pub width: u32,
    /// Image height walked.
    pub height: u32,
    /// Frames walked per culler.
    pub frames: usize,
    /// The camera path walked ([`crate::PathSource`]: `built-in walk`,
    /// `spawn points`, `orbit`, or the path file).
    pub path: String,
    /// Whether the scene file was cut into cluster-sized objects (`--clusters`).
    pub clusters: bool,
    /// Σ frustum-only frame time ÷ Σ oracle-visible-set render time, over the
    /// frames of every culler's walk of this scene.
    pub oracle_speedup: Option<f64>,
}

/// One row of the table: a culler (or [`ORACLE_ROW`]) on a scene.
#[derive(Clone, Debug, Serialize)]
pub struct BenchRow {
    /// Scene name.
    pub scene: String,
    /// Culler name, or [`ORACLE_ROW`].
    pub culler: String,
    /// The camera path walked, as [`BenchScene::path`].
    pub path: String,
    /// The traversal's coherence ([`coherence_label`]) when the bench was
    /// given modes and the culler takes one.
    pub coherence: Option<String>,
    /// The traversal's hierarchy (`bvh`, `kd`, `kd-propagate`) when the bench
    /// was given hierarchies and the culler takes one.
    pub hierarchy: Option<String>,
    /// The occluder meshes (`original`, `virtual`) when the bench was given
    /// several and the culler draws occluders.
    pub occluders: Option<String>,
    /// Mean node tests per frame (`node_tests`).
    pub node_tests_per_frame: Option<f64>,
    /// Mean object tests per frame (`object_tests`).
    pub object_tests_per_frame: Option<f64>,
    /// Mean nodes classified invisible by visibility propagation per frame
    /// (`propagated_invisible`; kD-tree only).
    pub propagated_per_frame: Option<f64>,
    /// Mean nodes propagation was tried on per frame (`propagation_attempts`).
    pub propagation_attempts_per_frame: Option<f64>,
    /// Mean node and object tests per frame (`node_tests + object_tests`),
    /// for the cullers that count them.
    pub tests_per_frame: Option<f64>,
    /// Mean tests skipped per frame by coherence (`tests_skipped`).
    pub tests_skipped_per_frame: Option<f64>,
    /// Frames walked.
    pub frames: usize,
    /// Median frame time (cull + render), ms.
    pub median_frame_ms: f64,
    /// Median culling time, ms (`None` for the oracle row).
    pub median_cull_ms: Option<f64>,
    /// Median render time, ms.
    pub median_render_ms: f64,
    /// Median frustum-only frame time of this walk, ms.
    pub median_baseline_frame_ms: Option<f64>,
    /// Median percentage of all triangles culled (frustum or occlusion).
    pub median_pct_triangles_culled: f64,
    /// Median percentage of all triangles culled as occluded.
    pub median_pct_occlusion_culled: f64,
    /// Median objects drawn per frame (parents: an object is drawn when any
    /// of its clusters is; the oracle row: those it sees).
    pub median_objects_drawn: f64,
    /// Median clusters drawn per frame (the oracle row: those it sees).
    pub median_clusters_drawn: f64,
    /// Occlusion-culled triangles ÷ invisible in-frustum triangles.
    pub efficiency: Option<f64>,
    /// Mean objects drawn per frame that own no pixel.
    pub mean_hidden_drawn: Option<f64>,
    /// Mean of them per frame that are the culler's occluders.
    pub mean_hidden_occluders_drawn: Option<f64>,
    /// Falsely culled objects, summed over frames.
    pub false_culls: Option<u64>,
    /// Frames with at least one false cull.
    pub frames_with_false_culls: Option<u64>,
    /// Σ frustum-only frame time ÷ Σ frame time.
    pub speedup: Option<f64>,
    /// `speedup` ÷ the scene's oracle speedup (1 = as good as culling can get).
    pub share_of_oracle: Option<f64>,
    /// Median milliseconds of each stage (the culler's, then `cull` = their sum, and `render`).
    pub median_stage_ms: BTreeMap<String, f64>,
    /// Mean milliseconds of each stage, as `median_stage_ms`: they add up to
    /// the mean frame, which the stage chart stacks.
    pub mean_stage_ms: BTreeMap<String, f64>,
    /// Mean frustum-only frame time, ms (the stage chart's 100 %).
    pub mean_baseline_frame_ms: Option<f64>,
    /// The culler's configuration (empty for the oracle row).
    pub config: BTreeMap<String, String>,
}

/// Everything a bench measured.
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    /// The options it ran with.
    pub options: BenchOptions,
    /// Renderer threads actually used.
    pub render_threads: usize,
    /// What drew the timed frames ([`crate::report::Header::renderer`]).
    pub renderer: String,
    /// The scenes, in the order given.
    pub scenes: Vec<BenchScene>,
    /// Per scene, one row per culler in the order given, then [`ORACLE_ROW`].
    pub rows: Vec<BenchRow>,
}

/// Walks every scene with every culler (oracle on) and collects one row per
/// culler plus the [`ORACLE_ROW`] pseudo-row per scene. `progress` is told
/// what is being walked before each walk.
pub fn run_bench(
    scenes: &[&str],
    culler_names: &[&str],
    options: &BenchOptions,
    progress: impl FnMut(&str),
) -> Result<BenchReport, BenchError> {
    run_bench_drawn(scenes, culler_names, options, None, progress)
}

/// Makes the renderer of a scene's timed frames ([`FrameDraw`]).
pub type MakeFrameDraw<'a> = &'a dyn Fn(&Scene) -> Result<Box<dyn FrameDraw>, DrawError>;

/// [`run_bench`], each scene's timed frames drawn by the renderer
/// `frame_draw` makes for it where given (`hom bench --renderer wgpu`).
pub fn run_bench_drawn(
    scenes: &[&str],
    culler_names: &[&str],
    options: &BenchOptions,
    frame_draw: Option<MakeFrameDraw>,
    mut progress: impl FnMut(&str),
) -> Result<BenchReport, BenchError> {
    if scenes.is_empty() {
        return Err(BenchError::Empty("no scenes"));
    }
    if culler_names.is_empty() {
        return Err(BenchError::Empty("no cullers"));
    }
    if options.frames == Some(0) {
        return Err(BenchError::Empty("zero frames"));
    }
    if options.camera_path.is_some() && scenes.len() > 1 {
        return Err(BenchError::CameraPathForSeveralScenes(scenes.len()));
    }
    let unknown = |name: &str| BenchError::UnknownCuller {
        name: name.to_string(),
        known: cullers::names(),
    };
    if let Some(name) = culler_names
        .iter()
        .find(|n| !cullers::CULLERS.iter().any(|c| c.0 == **n))
    {
        return Err(unknown(name));
    }
    let renderer = Renderer::new(options.threads)?;
    let walk_options = WalkOptions {
        frames: options.frames,
        oracle: true,
        baseline: true,
        ..WalkOptions::default()
    };
    let mut report = BenchReport {
        options: options.clone(),
        render_threads: renderer.threads(),
        renderer: renderer_name(None),
        scenes: Vec::new(),
        rows: Vec::new(),
    };
    for &spec in scenes {
        let scene_error = |source| BenchError::Scene {
            scene: spec.to_string(),
            source,
        };
        let mut opened = crate::open_walk_with(spec, &crate::load_options(options.clusters)).map_err(scene_error)?;
        if let Some(file) = &options.camera_path {
            opened = opened.along(file).map_err(|source| BenchError::Path {
                scene: spec.to_string(),
                source,
            })?;
        }
        let crate::OpenedScene {
            mut scene,
            mut path,
            animation,
            path_source,
        } = opened;
        let path_label = path_source.to_string();
        if let Some(w) = options.width {
            path.width = w;
        }
        if let Some(h) = options.height {
            path.height = h;
        }
        if let Some(k) = options.speed {
            path = path.at_speed(k);
        }
        if let Some(n) = options.cuts {
            path = path.with_cuts(n);
        }
        path.validate(spec).map_err(|source| BenchError::Path {
            scene: spec.to_string(),
            source,
        })?;
        let frame_count = walk_options.frame_count(&path);
        let mut drawer = frame_draw
            .map(|make| make(&scene))
            .transpose()
            .map_err(|source| BenchError::FrameDraw {
                scene: scene.name().to_string(),
                source,
            })?;
        report.renderer = renderer_name(drawer.as_deref());
        // One run per culler, and per hierarchy and coherence mode for the cullers that take them.
        let runs: Vec<(&str, Mode)> = culler_names
            .iter()
            .flat_map(|&name| {
                let takes = COHERENT_CULLERS.contains(&name);
                let modes: Vec<Option<Coherence>> = if options.coherence.is_empty() || !takes {
                    vec![None]
                } else {
                    options.coherence.iter().copied().map(Some).collect()
                };
                let hierarchies: Vec<Option<Hierarchy>> =
                    if options.hierarchy.is_empty() || !HIERARCHY_CULLERS.contains(&name) {
                        vec![None]
                    } else {
                        options.hierarchy.iter().copied().map(Some).collect()
                    };
                let meshes: Vec<Option<OccluderMeshes>> =
                    if options.occluders.is_empty() || !HIERARCHY_CULLERS.contains(&name) {
                        vec![None]
                    } else {
                        options.occluders.iter().copied().map(Some).collect()
                    };
                hierarchies.into_iter().flat_map(move |hierarchy| {
                    let modes = modes.clone();
                    meshes.clone().into_iter().flat_map(move |occluders| {
                        modes.clone().into_iter().map(move |coherence| {
                            let mode = Mode {
                                coherence,
                                hierarchy,
                                occluders,
                            };
                            (name, mode)
                        })
                    })
                })
            })
            .collect();
        let mut walks: Vec<(String, Mode, WalkResult)> = Vec::new();
        for (i, &(name, mode)) in runs.iter().enumerate() {
            let label = row_label(name, mode.labels());
            progress(&format!(
                "{} ({}/{}): {label} ({}/{}), {frame_count} frames",
                scene.name(),
                report.scenes.len() + 1,
                scenes.len(),
                i + 1,
                runs.len()
            ));
            let mut settings = cullers::CullerSettings::for_scene(&scene);
            if let Some(c) = mode.coherence {
                settings.hom.coherence = c;
                settings.hv.coherence = c;
            }
            if let Some(h) = mode.hierarchy {
                settings.hom.hierarchy = h;
            }
            if let Some(m) = mode.occluders {
                settings.hom.occluders.occluder_db.meshes = m;
            }
            settings.hom.cost_model = options.cost_model;
            settings.hom.depth_check = options.depth_check;
            if let Some(b) = options.budget {
                settings.hom.occluders.selection.budget = b;
            }
            settings.hv.priming = options.hv_priming.then_some(HvPriming);
            let mut culler = cullers::make(name, &scene, &settings).map_err(|_| unknown(name))?;
            let result = crate::walk_drawn(
                &mut scene,
                &animation,
                &path,
                culler.as_mut(),
                &renderer,
                drawer.as_deref_mut().map(|d| d as &mut dyn FrameDraw),
                &walk_options,
                |_| {},
            )
            .map_err(|source| BenchError::Walk {
                scene: scene.name().to_string(),
                culler: name.to_string(),
                source,
            })?;
            walks.push((name.to_string(), mode, result));
        }
        let oracle_speedup = scene_oracle_speedup(&walks);
        for (name, mode, w) in &walks {
            report
                .rows
                .push(culler_row(scene.name(), &path_label, name, mode, w, oracle_speedup));
        }
        report
            .rows
            .push(oracle_row(&scene, &path_label, &walks, oracle_speedup));
        report.scenes.push(BenchScene {
            spec: spec.to_string(),
            name: scene.name().to_string(),
            objects: scene.parent_count(),
            cluster_count: scene.objects().len(),
            triangles: scene.triangle_count(),
            dynamic_objects: scene.dynamic_count(),
            width: path.width,
            height: path.height,
            frames: frame_count,
            path: path_label,
            clusters: options.clusters,
            oracle_speedup,
        });
    }
    Ok(report)
}

/// Σ baseline ÷ Σ oracle-set render time over every frame of every walk.
fn scene_oracle_speedup(walks: &[(String, Mode, WalkResult)]) -> Option<f64> {
    let (mut base, mut oracle) = (0.0, 0.0);
    for f in walks.iter().flat_map(|(_, _, w)| &w.frames) {
        base += f.baseline_frame_ms?;
        oracle += f.oracle.as_ref()?.oracle_set_render_ms;
    }
    (oracle > 0.0).then(|| base / oracle)
}

/// What a run of a culler was walked with, beyond its defaults.
#[derive(Clone, Copy, Debug)]
struct Mode {
    coherence: Option<Coherence>,
    hierarchy: Option<Hierarchy>,
    occluders: Option<OccluderMeshes>,
}

/// A row's labels: hierarchy, occluder meshes, coherence mode (each as its flag spells it).
type Labels = [Option<String>; 3];

impl Mode {
    /// The hierarchy's, occluder meshes' and coherence's labels, as the row shows them.
    fn labels(&self) -> Labels {
        [
            self.hierarchy.map(|h| h.to_string()),
            self.occluders.map(|m| m.to_string()),
            self.coherence.as_ref().map(coherence_label),
        ]
    }
}

/// `culler`, then `/hierarchy`, `/occluders` and `/mode` for those it was
/// walked with (as `--hierarchy` and `--occluders` spell them, mode as
/// [`coherence_label`]).
fn row_label(culler: &str, labels: Labels) -> String {
    let mut s = culler.to_string();
    for part in labels.into_iter().flatten() {
        s.push('/');
        s.push_str(&part);
    }
    s
}

impl BenchRow {
    /// The row's name in the table: `culler`, or `culler/mode` with a coherence mode.
    pub fn label(&self) -> String {
        let labels = [self.hierarchy.clone(), self.occluders.clone(), self.coherence.clone()];
        row_label(&self.culler, labels)
    }
}

/// The mean per frame of `stat` over the frames that have it (`None` when none has).
fn mean_stat(w: &WalkResult, stat: impl Fn(&CullStats) -> Option<u64>) -> Option<f64> {
    mean(w.frames.iter().filter_map(|f| stat(&f.stats)).map(|n| n as f64))
}

/// The propagation statistics of a frame's traversal (kD-tree only).
fn propagation(s: &CullStats) -> Option<PropagationStats> {
    s.traversal.and_then(|t| t.propagation)
}

fn culler_row(
    scene: &str,
    path: &str,
    culler: &str,
    mode: &Mode,
    w: &WalkResult,
    oracle_speedup: Option<f64>,
) -> BenchRow {
    let s: &Summary = &w.summary;
    let [hierarchy, occluders, coherence] = mode.labels();
    BenchRow {
        scene: scene.to_string(),
        culler: culler.to_string(),
        path: path.to_string(),
        coherence,
        hierarchy,
        occluders,
        node_tests_per_frame: mean_stat(w, CullStats::node_tests),
        object_tests_per_frame: mean_stat(w, CullStats::object_tests),
        propagated_per_frame: mean_stat(w, |s| propagation(s).map(|p| p.propagated)),
        propagation_attempts_per_frame: mean_stat(w, |s| propagation(s).map(|p| p.attempts)),
        tests_per_frame: mean_stat(w, |s| match (s.node_tests(), s.object_tests()) {
            (None, None) => None,
            (n, o) => Some(n.unwrap_or(0) + o.unwrap_or(0)),
        }),
        tests_skipped_per_frame: mean_stat(w, CullStats::tests_skipped),
        frames: s.frames,
        median_frame_ms: s.median_frame_ms,
        median_cull_ms: Some(s.median_stage_ms.get("cull").copied().unwrap_or(0.0)),
        median_render_ms: s.median_stage_ms.get("render").copied().unwrap_or(0.0),
        median_baseline_frame_ms: s.median_baseline_frame_ms,
        median_pct_triangles_culled: s.median_pct_triangles_culled,
        median_pct_occlusion_culled: s.median_pct_occlusion_culled,
        median_objects_drawn: s.median_objects_drawn,
        median_clusters_drawn: s.median_clusters_drawn,
        efficiency: s.efficiency,
        mean_hidden_drawn: s.mean_hidden_drawn,
        mean_hidden_occluders_drawn: s.mean_hidden_occluders_drawn,
        false_culls: s.false_culls,
        frames_with_false_culls: s.frames_with_false_culls,
        speedup: s.speedup,
        share_of_oracle: share(s.speedup, oracle_speedup),
        median_stage_ms: s.median_stage_ms.clone(),
        mean_stage_ms: s.mean_stage_ms.clone(),
        mean_baseline_frame_ms: s.mean_baseline_frame_ms,
        config: w.header.config.clone(),
    }
}

fn share(speedup: Option<f64>, oracle_speedup: Option<f64>) -> Option<f64> {
    match (speedup, oracle_speedup) {
        (Some(s), Some(o)) if o > 0.0 => Some(s / o),
        _ => None,
    }
}

/// The pseudo-row: render only what the oracle saw, with a perfect zero-cost culler.
fn oracle_row(
    scene: &hom::scene::Scene,
    path: &str,
    walks: &[(String, Mode, WalkResult)],
    oracle_speedup: Option<f64>,
) -> BenchRow {
    let frames: Vec<_> = walks.iter().flat_map(|(_, _, w)| &w.frames).collect();
    let objects = scene.objects();
    let total = scene.triangle_count().max(1) as f64;
    let oracle_frames: Vec<_> = frames
        .iter()
        .filter_map(|f| f.oracle.as_ref().map(|o| (*f, o)))
        .collect();
    let median_ms = median(oracle_frames.iter().map(|(_, o)| o.oracle_set_render_ms));
    let pct_culled = median(oracle_frames.iter().map(|(_, o)| {
        let drawn: u64 = o
            .oracle_visible
            .iter()
            .map(|&id| objects[id as usize].triangles as u64)
            .sum();
        100.0 * (total - drawn as f64) / total
    }));
    let pct_occluded = median(
        oracle_frames
            .iter()
            .map(|(_, o)| 100.0 * o.triangles_in_frustum_invisible as f64 / total),
    );
    let invisible: u64 = oracle_frames
        .iter()
        .map(|(_, o)| o.triangles_in_frustum_invisible)
        .sum();
    let mut stages = BTreeMap::new();
    stages.insert("render".to_string(), median_ms);
    let mean_ms = mean(oracle_frames.iter().map(|(_, o)| o.oracle_set_render_ms)).unwrap_or(0.0);
    let mean_stages = BTreeMap::from([("render".to_string(), mean_ms)]);
    BenchRow {
        scene: scene.name().to_string(),
        culler: ORACLE_ROW.to_string(),
        path: path.to_string(),
        coherence: None,
        hierarchy: None,
        occluders: None,
        node_tests_per_frame: None,
        object_tests_per_frame: None,
        propagated_per_frame: None,
        propagation_attempts_per_frame: None,
        tests_per_frame: None,
        tests_skipped_per_frame: None,
        frames: walks.first().map_or(0, |(_, _, w)| w.frames.len()),
        median_frame_ms: median_ms,
        median_cull_ms: None,
        median_render_ms: median_ms,
        median_baseline_frame_ms: Some(median(frames.iter().filter_map(|f| f.baseline_frame_ms))),
        median_pct_triangles_culled: pct_culled,
        median_pct_occlusion_culled: pct_occluded,
        median_objects_drawn: median(
            oracle_frames
                .iter()
                .map(|(_, o)| scene.parents_of(&o.oracle_visible).len() as f64),
        ),
        median_clusters_drawn: median(oracle_frames.iter().map(|(_, o)| o.oracle_visible.len() as f64)),
        efficiency: (invisible > 0).then_some(1.0),
        mean_hidden_drawn: Some(0.0),
        mean_hidden_occluders_drawn: Some(0.0),
        false_culls: Some(0),
        frames_with_false_culls: Some(0),
        speedup: oracle_speedup,
        share_of_oracle: oracle_speedup.map(|_| 1.0),
        median_stage_ms: stages,
        mean_stage_ms: mean_stages,
        mean_baseline_frame_ms: mean(oracle_frames.iter().filter_map(|(f, _)| f.baseline_frame_ms)),
        config: BTreeMap::new(),
    }
}

impl BenchReport {
    /// The report as one plain-text table, a line per row, with a legend line.
    pub fn table(&self) -> String {
        let scene_w = self
            .rows
            .iter()
            .map(|r| r.scene.chars().count())
            .max()
            .unwrap_or(0)
            .max(5);
        let culler_w = self
            .rows
            .iter()
            .map(|r| r.label().chars().count())
            .max()
            .unwrap_or(0)
            .max(6);
        let mut s = String::new();
        if self.renderer != SOFTWARE_RENDERER {
            let _ = writeln!(s, "frames drawn by {}", self.renderer);
        }
        for sc in &self.scenes {
            let _ = writeln!(
                s,
                "scene {}: {} objects in {} clusters, {} triangles ({} dynamic), {}x{}, {} frames, path {}",
                sc.name,
                sc.objects,
                sc.cluster_count,
                sc.triangles,
                sc.dynamic_objects,
                sc.width,
                sc.height,
                sc.frames,
                sc.path
            );
        }
        let _ = writeln!(
            s,
            "{:<scene_w$} {:<culler_w$} {:>6} {:>9} {:>8} {:>9} {:>8} {:>8} {:>6} {:>8} {:>8} {:>8}",
            "scene",
            "culler",
            "frames",
            "frame ms",
            "cull ms",
            "render ms",
            "% culled",
            "effic.%",
            "false",
            "speedup",
            "% oracle",
            "tests/fr"
        );
        for r in &self.rows {
            let _ = writeln!(
                s,
                "{:<scene_w$} {:<culler_w$} {:>6} {:>9.2} {:>8} {:>9.2} {:>8.1} {:>8} {:>6} {:>8} {:>8} {:>8}",
                r.scene,
                r.label(),
                r.frames,
                r.median_frame_ms,
                fmt_opt(r.median_cull_ms, 2),
                r.median_render_ms,
                r.median_pct_triangles_culled,
                fmt_opt(r.efficiency.map(|e| 100.0 * e), 1),
                r.false_culls.map_or_else(|| "-".to_string(), |n| n.to_string()),
                fmt_opt(r.speedup, 2),
                fmt_opt(r.share_of_oracle.map(|x| 100.0 * x), 1),
                fmt_opt(r.tests_per_frame, 0),
            );
        }
        s.push_str(
            "(medians over frames; speedup = Σ frustum-only frame time ÷ Σ frame time; \
             % oracle = speedup ÷ the speedup of rendering only the oracle's visible set; \
             tests/fr = mean node and object tests per frame)\n",
        );
        s
    }

    /// One bar per row for [`crate::pictures::plot_stage_breakdown`], labelled
    /// `scene / culler` (just `culler` when one scene was benched): the mean
    /// stage times against the row's mean frustum-only frame time, so a bar's
    /// length is 1 ÷ the row's speedup (medians of stages do not add up: a
    /// culler resting on most frames would show its probes' raster in full).
    pub fn stage_bars(&self) -> Vec<StageBar> {
        self.rows
            .iter()
            .map(|r| StageBar {
                label: if self.scenes.len() > 1 {
                    format!("{} / {}", r.scene, r.label())
                } else {
                    r.label()
                },
                stages_ms: r.mean_stage_ms.clone(),
                baseline_ms: r.mean_baseline_frame_ms.unwrap_or(0.0),
            })
            .collect()
    }

    /// The rows of one scene.
    pub fn scene_rows<'a>(&'a self, scene: &'a str) -> impl Iterator<Item = &'a BenchRow> + 'a {
        self.rows.iter().filter(move |r| r.scene == scene)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small() -> BenchOptions {
        BenchOptions {
            frames: Some(3),
            width: Some(64),
            height: Some(64),
            threads: 1,
            ..BenchOptions::default()
        }
    }

    #[test]
    fn hierarchies_are_parsed_and_labelled_as_the_flag_spells_them() {
        for h in ["bvh", "kd", "kd-propagate"] {
            assert_eq!(parse_hierarchy(h).unwrap().to_string(), h);
        }
        assert_eq!(
            parse_hierarchy("kd-propagate"),
            Ok(Hierarchy::KdTree(KdTree { propagation: true }))
        );
        assert!(parse_hierarchy("octree").is_err());
        let mode = Mode {
            coherence: Some(Coherence::Exact),
            hierarchy: Some(Hierarchy::KdTree(KdTree { propagation: false })),
            occluders: None,
        };
        assert_eq!(row_label("hom", mode.labels()), "hom/kd/exact");
        let all = Mode {
            occluders: Some(OccluderMeshes::Original),
            ..mode
        };
        assert_eq!(row_label("hom", all.labels()), "hom/kd/original/exact");
        let plain = Mode {
            coherence: None,
            hierarchy: None,
            occluders: None,
        };
        assert_eq!(row_label("hom", plain.labels()), "hom");
    }

    #[test]
    fn occluder_meshes_get_a_row_each_for_the_cullers_that_draw_occluders() {
        let options = BenchOptions {
            occluders: ["original", "virtual"].map(|m| parse_occluders(m).unwrap()).to_vec(),
            ..small()
        };
        let report = run_bench(&["machine-room"], &["frustum", "hom", "hv"], &options, |_| {}).unwrap();
        let labels: Vec<String> = report.rows.iter().map(|r| r.label()).collect();
        assert_eq!(labels, ["frustum", "hom/original", "hom/virtual", "hv", ORACLE_ROW]);
        // The walk header records the meshes each row drew its occluders with.
        for (row, meshes) in [(1, "original"), (2, "virtual")] {
            assert_eq!(report.rows[row].config["occluder_meshes"], meshes);
        }
        let json = serde_json::to_value(&report).unwrap();
        assert_eq!(json["options"]["occluders"][1], "virtual");
        assert_eq!(json["rows"][1]["occluders"], "original");
        assert!(parse_occluders("simplified").is_err());
    }

    #[test]
    fn coherence_modes_get_a_row_each_for_the_cullers_that_take_them() {
        let modes = ["off", "exact", "skip", "skip:0.5"].map(|m| parse_coherence(m).unwrap());
        let options = BenchOptions {
            frames: Some(6),
            coherence: modes.to_vec(),
            ..small()
        };
        let report = run_bench(&["city"], &["frustum", "hom"], &options, |_| {}).unwrap();
        let labels: Vec<String> = report.rows.iter().map(|r| r.label()).collect();
        assert_eq!(
            labels,
            [
                "frustum",
                "hom/off",
                "hom/exact",
                "hom/skip",
                "hom/skip:0.5",
                ORACLE_ROW
            ]
        );
        let (off, exact) = (&report.rows[1], &report.rows[2]);
        assert_eq!(off.median_pct_triangles_culled, exact.median_pct_triangles_culled);
        assert!(exact.tests_per_frame.unwrap() < off.tests_per_frame.unwrap());
        assert_eq!(off.tests_skipped_per_frame, Some(0.0));
        assert_eq!(
            report.rows[0].tests_skipped_per_frame, None,
            "frustum culling keeps no state"
        );
        let json = serde_json::to_value(&report).unwrap();
        assert_eq!(json["options"]["coherence"][3], "skip:0.5");
        assert!(parse_coherence("skip:2").is_err() && parse_coherence("sometimes").is_err());
    }

    #[test]
    fn every_culler_gets_a_row_plus_the_oracle_and_json_serializes() {
        let names: Vec<&str> = cullers::CULLERS.iter().map(|c| c.0).collect();
        let mut messages = Vec::new();
        let report = run_bench(&["spheres"], &names, &small(), |m| messages.push(m.to_string())).unwrap();
        assert_eq!(messages.len(), names.len());
        assert_eq!(report.scenes.len(), 1);
        let sc = &report.scenes[0];
        assert_eq!((sc.width, sc.height, sc.frames), (64, 64, 3));
        let rows: Vec<&BenchRow> = report.scene_rows(&sc.name).collect();
        assert_eq!(rows.len(), names.len() + 1);
        for (row, name) in rows.iter().zip(names.iter().chain([&ORACLE_ROW])) {
            assert_eq!(row.culler, *name);
            assert_eq!(row.frames, 3);
            assert!(row.median_frame_ms >= 0.0 && row.median_frame_ms.is_finite());
            assert!(row.false_culls.is_some(), "oracle ran for {name}");
        }
        let oracle = rows.last().unwrap();
        assert_eq!(oracle.speedup, sc.oracle_speedup);
        assert!(oracle.median_cull_ms.is_none());
        // The frustum culler is its own baseline: speedup exactly 1.
        let frustum = rows.iter().find(|r| r.culler == "frustum").unwrap();
        assert_eq!(frustum.speedup, Some(1.0));
        assert_eq!(frustum.false_culls, Some(0));

        let json = serde_json::to_value(&report).unwrap();
        assert_eq!(json["rows"].as_array().unwrap().len(), names.len() + 1);
        assert_eq!(json["rows"][names.len()]["culler"], ORACLE_ROW);
        assert!(json["rows"][0]["median_stage_ms"]["render"].is_number());

        let table = report.table();
        for name in names.iter().chain([&ORACLE_ROW]) {
            assert!(table.lines().any(|l| l.contains(name)), "{name} missing from\n{table}");
        }
        assert_eq!(table.lines().count(), 1 + 1 + rows.len() + 1, "{table}");
    }

    #[test]
    fn bad_input_is_a_typed_error() {
        let err = run_bench(&["spheres"], &["nope"], &small(), |_| {}).unwrap_err();
        assert!(matches!(err, BenchError::UnknownCuller { .. }), "{err}");
        let err = run_bench(&["no-such-scene"], &["frustum"], &small(), |_| {}).unwrap_err();
        assert!(matches!(err, BenchError::Scene { .. }), "{err}");
        let zero = BenchOptions {
            frames: Some(0),
            ..small()
        };
        assert!(matches!(
            run_bench(&["spheres"], &["frustum"], &zero, |_| {}),
            Err(BenchError::Empty(_))
        ));
        assert!(matches!(
            run_bench(&[], &["frustum"], &small(), |_| {}),
            Err(BenchError::Empty(_))
        ));
    }
}
