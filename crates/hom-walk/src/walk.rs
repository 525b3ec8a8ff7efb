//! The walkthrough loop.

use crate::lod::{summarize_lod, LodRun, WalkLod};
use crate::report::{mean, median, FrameRecord, Header, OracleFrame, Summary};
use hom::cull::{CullError, CullOutput, Culler, FrustumCuller};
use hom::geom::{Camera, Containment, Frustum};
use hom::scene::Scene;
use hom_render::{Framebuffer, RenderOptions, Renderer};
use hom_scene::{Animation, CameraPath};
use std::collections::BTreeMap;
use std::time::Instant;
use thiserror::Error;

/// Why a walkthrough stopped.
#[derive(Debug, Error)]
pub enum WalkError {
    /// The culler refused a frame.
    #[error("frame {frame}")]
    Cull {
        /// Frame index.
        frame: usize,
        /// Cause.
        source: CullError,
    },
    /// The path's frames do not make valid cameras.
    #[error(transparent)]
    Path(#[from] hom_scene::CameraPathError),
    /// Level of detail refused the scene or its options.
    #[error("level of detail")]
    Lod(#[from] hom::lod::LodError),
    /// The renderer that draws the timed frames failed.
    #[error("frame {frame}: the {renderer} renderer failed")]
    Draw {
        /// Frame index.
        frame: usize,
        /// The renderer, as [`FrameDraw::describe`] names it.
        renderer: String,
        /// Cause.
        source: DrawError,
    },
    /// Level of detail draws parts of meshes, which only hom's software renderer does.
    #[error("level of detail draws with hom's software renderer only, not with {0}")]
    LodNeedsSoftware(String),
}

/// Why a [`FrameDraw`] could not draw a frame.
pub type DrawError = Box<dyn std::error::Error + Send + Sync>;

/// A renderer other than hom's software renderer that draws a walk's timed
/// frames (the culler's, the baseline's, the oracle's set), so that the
/// speedups say what that renderer gains: `hom walk --renderer wgpu`
/// (`hom_view::WgpuDraw`). The oracle's item buffer stays the software
/// renderer's, and so does the thread pool the cull runs on.
pub trait FrameDraw {
    /// The renderer, its device and how it times a frame, for reports
    /// ([`Header::renderer`]).
    fn describe(&self) -> String;
    /// Draws objects `ids` of `scene`, in that order, each with its current
    /// transform, as `camera` sees them; the milliseconds the frame took,
    /// as this renderer measures them.
    fn draw(&mut self, scene: &Scene, ids: &[u32], camera: &Camera) -> Result<f64, DrawError>;
}

/// What draws a walk's timed frames: hom's software renderer into the
/// walk's framebuffer, or a [`FrameDraw`].
enum Drawer<'a> {
    Software(&'a Renderer),
    Other(&'a mut dyn FrameDraw),
}

impl Drawer<'_> {
    /// Draws `ids` as `camera` sees them; its milliseconds.
    fn draw(
        &mut self,
        scene: &Scene,
        ids: &[u32],
        camera: &Camera,
        draw: &RenderOptions,
        fb: &mut Framebuffer,
        frame: usize,
    ) -> Result<f64, WalkError> {
        match self {
            Drawer::Software(renderer) => {
                let start = Instant::now();
                renderer.render(scene, ids, camera, draw, fb);
                Ok(ms_since(start))
            }
            Drawer::Other(d) => d.draw(scene, ids, camera).map_err(|source| WalkError::Draw {
                frame,
                renderer: d.describe(),
                source,
            }),
        }
    }

    fn describe(&self) -> String {
        renderer_name(match self {
            Drawer::Software(_) => None,
            Drawer::Other(d) => Some(&**d),
        })
    }
}

/// What [`Header::renderer`] says of hom's software renderer.
pub const SOFTWARE_RENDERER: &str = "software";

/// What [`Header::renderer`] says drew a walk's frames: the `frame_draw`
/// given to [`walk_drawn`], or hom's software renderer.
pub fn renderer_name(frame_draw: Option<&dyn FrameDraw>) -> String {
    frame_draw.map_or_else(|| SOFTWARE_RENDERER.to_string(), |d| d.describe())
}

/// How to walk.
#[derive(Clone, Debug)]
pub struct WalkOptions {
    /// Walk only the first `n` frames of the path (all when `None`).
    pub frames: Option<usize>,
    /// Run the oracle every frame (a full item-buffer render): false culls, efficiency.
    pub oracle: bool,
    /// Also time frustum-only culling and rendering of every frame, for the speedup.
    pub baseline: bool,
    /// Frames per second of scene time (moves dynamic objects).
    pub frame_rate: f32,
    /// Draw each visible object's level-of-detail cut instead of its mesh.
    pub lod: Option<WalkLod>,
    /// An A/A check of the timing: the frustum culler's baseline is a second
    /// frustum culler's frames, not its own frame time again, so its speedup
    /// shows the measurement's bias and noise alone.
    pub self_baseline: bool,
}

impl Default for WalkOptions {
    fn default() -> Self {
        WalkOptions {
            frames: None,
            oracle: false,
            baseline: true,
            frame_rate: 30.0,
            lod: None,
            self_baseline: false,
        }
    }
}

impl WalkOptions {
    /// How many frames of `path` these options walk.
    pub fn frame_count(&self, path: &CameraPath) -> usize {
        self.frames.unwrap_or(usize::MAX).min(path.frames.len())
    }
}

/// Everything a walk measured.
#[derive(Clone, Debug)]
pub struct WalkResult {
    /// The report header.
    pub header: Header,
    /// One record per frame.
    pub frames: Vec<FrameRecord>,
    /// Medians and ratios.
    pub summary: Summary,
}

fn ms_since(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}

/// The renders a walk times each frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Timed {
    /// The culler's frame: its cull, then its render.
    Culler,
    /// The baseline's frame: frustum culling, then its render.
    Baseline,
    /// The oracle's visible set, rendered.
    OracleSet,
}

/// The order of frame `i`'s timed renders: the culler's frame, then the
/// baseline's and the oracle's set where timed, rotated by `i`, so that
/// each takes each place once in as many frames as there are renders.
fn timed_order(i: usize, baseline: bool, oracle: bool) -> Vec<Timed> {
    let mut order = vec![Timed::Culler];
    if baseline {
        order.push(Timed::Baseline);
    }
    if oracle {
        order.push(Timed::OracleSet);
    }
    let turn = i % order.len();
    order.rotate_left(turn);
    order
}

/// The baseline's frame `i`: frustum culling, then rendering what it keeps
/// into `fb`; its milliseconds.
#[allow(clippy::too_many_arguments)]
fn baseline_frame(
    baseline: &mut FrustumCuller,
    scene: &Scene,
    camera: &Camera,
    draw: &RenderOptions,
    drawer: &mut Drawer,
    out: &mut CullOutput,
    fb: &mut Framebuffer,
    i: usize,
) -> Result<f64, WalkError> {
    baseline
        .cull(scene, &camera.to_view(), out)
        .map_err(|source| WalkError::Cull { frame: i, source })?;
    let render_ms = drawer.draw(scene, &out.visible, camera, draw, fb, i)?;
    Ok(out.total_ms() + render_ms)
}

/// Walks `path` through `scene` with `culler`, rendering with `renderer`;
/// `animation` moves the scene's dynamic objects each frame (the culler sees
/// them through [`Scene::set_transform`], as an engine's would).
/// `on_frame` sees each record as it is made (for progress and streaming reports).
pub fn walk(
    scene: &mut Scene,
    animation: &Animation,
    path: &CameraPath,
    culler: &mut dyn Culler,
    renderer: &Renderer,
    options: &WalkOptions,
    on_frame: impl FnMut(&FrameRecord),
) -> Result<WalkResult, WalkError> {
    walk_drawn(scene, animation, path, culler, renderer, None, options, on_frame)
}

/// [`walk`], with the timed frames drawn by `frame_draw` where given
/// (hom's software renderer still draws the oracle's item buffer, and the
/// cull runs on its threads). Level of detail needs the software renderer.
#[allow(clippy::too_many_arguments)]
pub fn walk_drawn(
    scene: &mut Scene,
    animation: &Animation,
    path: &CameraPath,
    culler: &mut dyn Culler,
    renderer: &Renderer,
    frame_draw: Option<&mut dyn FrameDraw>,
    options: &WalkOptions,
    mut on_frame: impl FnMut(&FrameRecord),
) -> Result<WalkResult, WalkError> {
    path.validate(scene.name())?;
    let mut drawer = match frame_draw {
        Some(d) if options.lod.is_some() => return Err(WalkError::LodNeedsSoftware(d.describe())),
        Some(d) => Drawer::Other(d),
        None => Drawer::Software(renderer),
    };
    let frame_count = options.frame_count(path);
    let header = Header::new(
        scene,
        path,
        culler,
        renderer.threads(),
        &drawer.describe(),
        frame_count,
        options.oracle,
    );
    // The frustum culler drawing whole meshes is its own baseline: time it
    // once (unless the walk checks the timing against itself).
    let own_baseline = culler.name() == "frustum" && options.lod.is_none() && !options.self_baseline;
    let mut baseline = (options.baseline && !own_baseline).then(|| FrustumCuller::new(scene));
    let mut fb = Framebuffer::new(path.width, path.height);
    let mut out = CullOutput::default();
    let mut base_out = CullOutput::default();
    let draw = RenderOptions::default();
    let mut lod = options
        .lod
        .as_ref()
        .map(|l| LodRun::new(l, scene, options.oracle))
        .transpose()?;
    // Occluders at the level of detail, where the culler draws occluders.
    let occluder_lod = options.lod.as_ref().and_then(WalkLod::occluder_lod);
    let asked = occluder_lod.is_some();
    let lod_occluders = culler.set_occluder_lod(occluder_lod) && asked;
    // The renderer's first frame runs cold (first touches of its buffers):
    // warm it with the baseline's first frame, untimed, so that the cold
    // start is charged to neither side (it was to the culler, whose frame
    // came first: frustum against itself, 1.4 % of dynamic's speedup).
    if let (Some(b), true) = (baseline.as_mut(), frame_count > 0) {
        animation.apply(scene, 0.0);
        baseline_frame(b, scene, &path.camera(0), &draw, &mut drawer, &mut base_out, &mut fb, 0)?;
    }
    let mut frames = Vec::with_capacity(frame_count);
    for i in 0..frame_count {
        let time_s = i as f32 / options.frame_rate;
        animation.apply(scene, time_s);
        let camera = path.camera(i);
        let view = camera.to_view();
        // The oracle's item buffer first (untimed), then the timed renders
        // (the culler's frame, the baseline's, the oracle's visible set) in
        // an order that rotates frame to frame, so that none always has the
        // warmest or the coldest place. With the baseline always after the
        // culler's frame, the frustum culler timed against itself came out
        // 0.2-2.4 % slower (frames 1-99; the baseline faster in 62-74 of 99
        // frames on office, dynamic and machine-room), a bias charged to
        // every culler; the oracle's set, always drawn right after the item
        // buffer, always had the coldest place.
        let counts = options
            .oracle
            .then(|| hom_render::oracle_pixel_counts(renderer, scene, &camera, &mut fb));
        let oracle_visible: Option<Vec<u32>> = counts
            .as_ref()
            .map(|c| (0..c.len() as u32).filter(|&id| c[id as usize] > 0).collect());
        // Per object, whether its box meets the frustum (the exact per-object
        // test): for the warm render below and the oracle's efficiency.
        let in_frustum: Option<Vec<bool>> = counts.is_some().then(|| {
            let frustum = Frustum::from_view_proj(&camera.view_proj()).expect("validated camera");
            scene
                .objects()
                .iter()
                .map(|o| frustum.test_aabb(&o.aabb) != Containment::Outside)
                .collect()
        });
        if let Some(in_frustum) = &in_frustum {
            // The item buffer draws every live object and leaves the caches
            // cold for whichever render comes next (city: the culler's frame
            // 22 % slower first than second or third, office's baseline 14 %):
            // the view's frustum set once more, untimed, makes every timed
            // render follow a render of its view (then each within 1.3 % on city
            // and 5 % on office, whatever its place).
            let in_view: Vec<u32> = scene
                .live_objects()
                .filter(|&(id, _)| in_frustum[id as usize])
                .map(|(id, _)| id)
                .collect();
            drawer.draw(scene, &in_view, &camera, &draw, &mut fb, i)?;
        }
        let order = timed_order(i, baseline.is_some(), oracle_visible.is_some());
        let (mut culled, mut baseline_frame_ms, mut oracle_set_render_ms, mut oracle_items) = (None, None, None, None);
        for timed in order {
            match timed {
                Timed::Culler => {
                    // On the renderer's threads: one pool, no two pools fighting for the cores.
                    renderer
                        .install(|| culler.cull(scene, &view, &mut out))
                        .map_err(|source| WalkError::Cull { frame: i, source })?;
                    let cull_ms = out.total_ms();
                    let (render_ms, lod_frame) = match lod.as_mut() {
                        Some(run) => {
                            let (record, render_ms) = run.frame(
                                scene,
                                &view,
                                &camera,
                                culler,
                                &out.visible,
                                &out.occluded,
                                renderer,
                                &draw,
                                &mut fb,
                            )?;
                            (render_ms, Some(record))
                        }
                        None => (drawer.draw(scene, &out.visible, &camera, &draw, &mut fb, i)?, None),
                    };
                    // The level-of-detail frame's owners, to compare with the full meshes' below.
                    let lod_items = (options.oracle && lod.is_some()).then(|| fb.items().to_vec());
                    // Selecting the cut is part of the frame's cost.
                    let lod_ms = lod_frame.as_ref().map_or(0.0, |l| l.lod_ms);
                    let frame_ms = cull_ms + lod_ms + render_ms;
                    culler.frame_done(Some(frame_ms));
                    culled = Some((cull_ms, render_ms, lod_frame, lod_items, frame_ms));
                }
                Timed::Baseline => {
                    if let Some(b) = baseline.as_mut() {
                        baseline_frame_ms = Some(baseline_frame(
                            b,
                            scene,
                            &camera,
                            &draw,
                            &mut drawer,
                            &mut base_out,
                            &mut fb,
                            i,
                        )?);
                    }
                }
                Timed::OracleSet => {
                    let visible = oracle_visible.as_deref().unwrap_or_default();
                    oracle_set_render_ms = Some(drawer.draw(scene, visible, &camera, &draw, &mut fb, i)?);
                    // The oracle's visible objects drawn whole: the owners of
                    // the full-resolution image, for the level of detail.
                    oracle_items = lod.is_some().then(|| fb.items().to_vec());
                }
            }
        }
        let Some((cull_ms, render_ms, lod_frame, lod_items, frame_ms)) = culled else {
            unreachable!("every frame times the culler");
        };
        let baseline_frame_ms = match baseline {
            Some(_) => baseline_frame_ms,
            None if options.baseline => Some(frame_ms),
            None => None,
        };

        let objects = scene.objects();
        let tris = |ids: &[u32]| ids.iter().map(|&id| objects[id as usize].triangles as u64).sum::<u64>();
        let triangles_drawn = tris(&out.visible);
        let triangles_occlusion_culled = tris(&out.occluded);
        let objects_frustum_culled = (objects.len() - out.visible.len() - out.occluded.len()) as u64;
        let triangles_frustum_culled = scene.triangle_count() - triangles_drawn - triangles_occlusion_culled;

        let oracle = counts
            .zip(oracle_visible)
            .zip(in_frustum)
            .map(|((counts, oracle_visible), in_frustum)| {
                let mut kept = vec![false; objects.len()];
                for &id in &out.visible {
                    kept[id as usize] = true;
                }
                let false_culls: Vec<u32> = oracle_visible
                    .iter()
                    .copied()
                    .filter(|&id| !kept[id as usize])
                    .collect();
                let false_cull_pixels = false_culls.iter().map(|&id| counts[id as usize] as u64).sum();
                let hidden_drawn: Vec<u32> = out
                    .visible
                    .iter()
                    .copied()
                    .filter(|&id| counts[id as usize] == 0)
                    .collect();
                let hidden_occluders_drawn = hidden_drawn
                    .iter()
                    .filter(|id| out.occluders.binary_search(id).is_ok())
                    .count() as u64;
                let triangles_in_frustum_invisible = objects
                    .iter()
                    .zip(&counts)
                    .zip(&in_frustum)
                    .filter(|&((_, &c), &inside)| c == 0 && inside)
                    .map(|((o, _), _)| o.triangles as u64)
                    .sum();
                OracleFrame {
                    efficiency: (triangles_in_frustum_invisible > 0)
                        .then(|| triangles_occlusion_culled as f64 / triangles_in_frustum_invisible as f64),
                    oracle_visible,
                    false_culls,
                    false_cull_pixels,
                    triangles_in_frustum_invisible,
                    hidden_drawn: hidden_drawn.len() as u64,
                    hidden_occluders_drawn,
                    oracle_set_render_ms: oracle_set_render_ms.unwrap_or(0.0),
                }
            });

        let mut lod_frame = lod_frame;
        if let (Some(run), Some(o), Some(l)) = (lod.as_mut(), &oracle, lod_frame.as_mut()) {
            l.lod_oracle_triangles = Some(run.oracle_triangles(scene, &o.oracle_visible)?);
        }
        if let (Some(items), Some(full), Some(l)) = (&lod_items, &oracle_items, lod_frame.as_mut()) {
            let differ = items.iter().zip(full).filter(|(a, b)| a != b).count();
            l.lod_pixels_differ_from_full = Some(differ as u64);
        }
        let mut stages_ms: BTreeMap<String, f64> = BTreeMap::new();
        for (name, ms) in &out.stages {
            *stages_ms.entry(name.to_string()).or_default() += ms;
        }
        stages_ms.insert("cull".into(), cull_ms);
        if let Some(l) = &lod_frame {
            stages_ms.insert("lod".into(), l.lod_ms);
        }
        stages_ms.insert("render".into(), render_ms);
        let visible = scene.parents_of(&out.visible);
        let record = FrameRecord {
            kind: "frame",
            frame: i,
            time_s,
            view_proj: camera.view_proj().to_cols_array(),
            width: camera.width,
            height: camera.height,
            objects_drawn: visible.len() as u64,
            visible,
            visible_clusters: out.visible.clone(),
            clusters_drawn: out.visible.len() as u64,
            occluders: out.occluders.clone(),
            triangles_drawn,
            objects_frustum_culled,
            triangles_frustum_culled,
            objects_occlusion_culled: out.occluded.len() as u64,
            triangles_occlusion_culled,
            stages_ms,
            frame_ms,
            baseline_frame_ms,
            stats: out.stats.clone(),
            oracle,
            lod: lod_frame,
        };
        on_frame(&record);
        frames.push(record);
    }
    let mut summary = summarize(&frames, scene.triangle_count());
    if let Some(l) = &options.lod {
        let records: Vec<_> = frames.iter().filter_map(|f| f.lod.as_ref()).collect();
        summary.lod = Some(summarize_lod(&records, l.options.budget, lod_occluders));
    }
    Ok(WalkResult {
        header,
        frames,
        summary,
    })
}

/// Medians and ratios over a walk's frames.
pub fn summarize(frames: &[FrameRecord], total_triangles: u64) -> Summary {
    let mut stage_names: Vec<&String> = frames.iter().flat_map(|f| f.stages_ms.keys()).collect();
    stage_names.sort();
    stage_names.dedup();
    let mean_stage_ms = stage_names
        .iter()
        .map(|&name| {
            let sum: f64 = frames.iter().filter_map(|f| f.stages_ms.get(name)).sum();
            (name.clone(), sum / frames.len().max(1) as f64)
        })
        .collect();
    let median_stage_ms = stage_names
        .into_iter()
        .map(|name| {
            (
                name.clone(),
                // A stage a frame did not run took no time: a culler that rests
                // (cost model) on most frames has a median raster stage of 0, and
                // the stages' medians stay comparable with the frame's.
                median(frames.iter().map(|f| f.stages_ms.get(name).copied().unwrap_or(0.0))),
            )
        })
        .collect();
    let total = total_triangles.max(1) as f64;
    let sum_frame: f64 = frames.iter().map(|f| f.frame_ms).sum();
    let baselines: Option<Vec<f64>> = frames.iter().map(|f| f.baseline_frame_ms).collect();
    let oracles: Option<Vec<&crate::report::OracleFrame>> = frames.iter().map(|f| f.oracle.as_ref()).collect();
    let oracles = oracles.filter(|o| !o.is_empty());
    let sum_baseline = baselines.as_ref().map(|b| b.iter().sum::<f64>());
    let sum_oracle_set = oracles
        .as_ref()
        .map(|o| o.iter().map(|f| f.oracle_set_render_ms).sum::<f64>());
    let ratio = |a: Option<f64>, b: Option<f64>| match (a, b) {
        (Some(a), Some(b)) if b > 0.0 => Some(a / b),
        _ => None,
    };
    Summary {
        kind: "summary",
        frames: frames.len(),
        median_stage_ms,
        mean_stage_ms,
        median_frame_ms: median(frames.iter().map(|f| f.frame_ms)),
        median_baseline_frame_ms: baselines.as_ref().map(|b| median(b.iter().copied())),
        mean_baseline_frame_ms: sum_baseline.map(|b| b / frames.len().max(1) as f64),
        median_oracle_set_ms: oracles
            .as_ref()
            .map(|o| median(o.iter().map(|f| f.oracle_set_render_ms))),
        speedup: ratio(sum_baseline, Some(sum_frame)),
        oracle_speedup: ratio(sum_baseline, sum_oracle_set),
        median_pct_triangles_culled: median(
            frames
                .iter()
                .map(|f| 100.0 * (f.triangles_frustum_culled + f.triangles_occlusion_culled) as f64 / total),
        ),
        median_pct_occlusion_culled: median(
            frames
                .iter()
                .map(|f| 100.0 * f.triangles_occlusion_culled as f64 / total),
        ),
        median_triangles_drawn: median(frames.iter().map(|f| f.triangles_drawn as f64)),
        median_objects_drawn: median(frames.iter().map(|f| f.objects_drawn as f64)),
        median_clusters_drawn: median(frames.iter().map(|f| f.clusters_drawn as f64)),
        false_culls: oracles
            .as_ref()
            .map(|o| o.iter().map(|f| f.false_culls.len() as u64).sum()),
        frames_with_false_culls: oracles
            .as_ref()
            .map(|o| o.iter().filter(|f| !f.false_culls.is_empty()).count() as u64),
        false_cull_pixels: oracles.as_ref().map(|o| o.iter().map(|f| f.false_cull_pixels).sum()),
        efficiency: oracles.as_ref().and_then(|o| {
            let invisible: u64 = o.iter().map(|f| f.triangles_in_frustum_invisible).sum();
            let culled: u64 = frames.iter().map(|f| f.triangles_occlusion_culled).sum();
            (invisible > 0).then(|| culled as f64 / invisible as f64)
        }),
        mean_hidden_drawn: oracles
            .as_ref()
            .and_then(|o| mean(o.iter().map(|f| f.hidden_drawn as f64))),
        mean_hidden_occluders_drawn: oracles
            .as_ref()
            .and_then(|o| mean(o.iter().map(|f| f.hidden_occluders_drawn as f64))),
        lod: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(stages: &[(&str, f64)]) -> FrameRecord {
        FrameRecord {
            kind: "frame",
            frame: 0,
            time_s: 0.0,
            view_proj: [0.0; 16],
            width: 1,
            height: 1,
            visible: Vec::new(),
            visible_clusters: Vec::new(),
            objects_drawn: 0,
            clusters_drawn: 0,
            occluders: Vec::new(),
            triangles_drawn: 0,
            objects_frustum_culled: 0,
            triangles_frustum_culled: 0,
            objects_occlusion_culled: 0,
            triangles_occlusion_culled: 0,
            stages_ms: stages.iter().map(|&(k, v)| (k.to_string(), v)).collect(),
            frame_ms: stages.iter().map(|s| s.1).sum(),
            baseline_frame_ms: None,
            stats: Default::default(),
            oracle: None,
            lod: None,
        }
    }

    /// Every timed render takes every place equally often, the culler's
    /// frame first on frame 0 and always timed.
    #[test]
    fn timed_renders_take_every_place_in_turn() {
        for (baseline, oracle) in [(false, false), (true, false), (false, true), (true, true)] {
            let n = 1 + usize::from(baseline) + usize::from(oracle);
            let mut places: BTreeMap<(usize, String), usize> = BTreeMap::new();
            for i in 0..6 * n {
                let order = timed_order(i, baseline, oracle);
                assert_eq!(order.len(), n);
                assert!(order.contains(&Timed::Culler));
                assert_eq!(order.contains(&Timed::Baseline), baseline);
                assert_eq!(order.contains(&Timed::OracleSet), oracle);
                for (place, t) in order.iter().enumerate() {
                    *places.entry((place, format!("{t:?}"))).or_default() += 1;
                }
            }
            assert_eq!(places.len(), n * n, "{places:?}");
            assert!(places.values().all(|&c| c == 6), "{places:?}");
            assert_eq!(timed_order(0, baseline, oracle)[0], Timed::Culler);
        }
    }

    /// A stage that ran on one frame in three has a median of 0, not of the
    /// frames it ran on (the stage chart stacks these medians).
    #[test]
    fn stage_medians_count_frames_the_stage_did_not_run() {
        let frames = [
            frame(&[("render", 2.0)]),
            frame(&[("render", 3.0), ("raster", 0.5)]),
            frame(&[("render", 4.0)]),
        ];
        let s = summarize(&frames, 10);
        assert_eq!(s.median_stage_ms["render"], 3.0);
        assert_eq!(s.median_stage_ms["raster"], 0.0);
        assert_eq!(s.mean_stage_ms["raster"], 0.5 / 3.0);
        assert_eq!(s.mean_stage_ms["render"], 3.0);
    }
}
