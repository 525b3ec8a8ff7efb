//! Walkthrough report records: one JSON object per line — a header, one line
//! per frame, then a summary. Field names are a stable contract: add, never rename.

use hom::cull::CullStats;
use serde::Serialize;
use std::collections::BTreeMap;
use std::io::Write;

pub use crate::stats::{fmt_opt, mean, median};

/// First line: what was walked, with what.
#[derive(Clone, Debug, Serialize)]
pub struct Header {
    /// Always `"header"`.
    #[serde(rename = "type")]
    pub kind: &'static str,
    /// Scene name.
    pub scene: String,
    /// Number of objects as the file or generator names them (parents,
    /// [`hom::scene::Object::parent`]): the ids `visible` lists.
    pub objects: usize,
    /// Number of what is culled and drawn: the objects' clusters (an object
    /// not cut is one), the ids `visible_clusters` lists.
    pub cluster_count: usize,
    /// Number of triangles (all objects).
    pub triangles: u64,
    /// Number of dynamic objects.
    pub dynamic_objects: usize,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Frames walked.
    pub frames: usize,
    /// Culler name.
    pub culler: String,
    /// Culler configuration.
    pub config: BTreeMap<String, String>,
    /// Renderer threads (the software renderer's pool, where the cull runs too).
    pub render_threads: usize,
    /// What drew the timed frames: `software` (hom's renderer) or, for
    /// `--renderer wgpu`, `wgpu` with the adapter and how frames are timed.
    pub renderer: String,
    /// Whether the oracle ran.
    pub oracle: bool,
}

impl Header {
    /// The header of a walk of `frames` frames of `path` through `scene` with `culler`.
    pub fn new(
        scene: &hom::scene::Scene,
        path: &hom_scene::CameraPath,
        culler: &dyn hom::cull::Culler,
        render_threads: usize,
        renderer: &str,
        frames: usize,
        oracle: bool,
    ) -> Header {
        Header {
            kind: "header",
            scene: scene.name().to_string(),
            objects: scene.parent_count(),
            cluster_count: scene.objects().len(),
            triangles: scene.triangle_count(),
            dynamic_objects: scene.dynamic_count(),
            width: path.width,
            height: path.height,
            frames,
            culler: culler.name().to_string(),
            config: culler.config().into_iter().map(|(k, v)| (k.to_string(), v)).collect(),
            render_threads,
            renderer: renderer.to_string(),
            oracle,
        }
    }
}

/// What the oracle found for one frame. It works per cluster: every id here
/// is a cluster's (`visible_clusters`), and so is every count.
#[derive(Clone, Debug, Default, Serialize)]
pub struct OracleFrame {
    /// Sorted ids of clusters owning at least one pixel.
    pub oracle_visible: Vec<u32>,
    /// Sorted ids culled by the culler (either reason) that own at least one pixel.
    pub false_culls: Vec<u32>,
    /// Pixels owned by falsely culled objects (pixels wrong in the image).
    pub false_cull_pixels: u64,
    /// Triangles of objects in the view frustum that own no pixel.
    pub triangles_in_frustum_invisible: u64,
    /// Objects drawn that own no pixel.
    pub hidden_drawn: u64,
    /// Of those, the culler's occluders: few in triangles but large on
    /// screen, they cost the renderer most of what HOM leaves
    /// (ARCHITECTURE.md, "Most of HOM's render excess is its own hidden
    /// occluders").
    pub hidden_occluders_drawn: u64,
    /// Culling efficiency this frame (`None` when nothing in the frustum is invisible).
    pub efficiency: Option<f64>,
    /// Milliseconds to render only the oracle's visible set.
    pub oracle_set_render_ms: f64,
}

/// One frame.
#[derive(Clone, Debug, Serialize)]
pub struct FrameRecord {
    /// Always `"frame"`.
    #[serde(rename = "type")]
    pub kind: &'static str,
    /// Frame index along the path.
    pub frame: usize,
    /// Scene time, seconds (moves dynamic objects).
    pub time_s: f32,
    /// World-to-clip matrix, column-major.
    pub view_proj: [f32; 16],
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Sorted ids of the objects drawn, as the file or generator names them
    /// (parents, [`hom::scene::Object::parent`]): an object is drawn when
    /// any of its clusters is. Equal to `visible_clusters` where nothing was cut.
    pub visible: Vec<u32>,
    /// Sorted ids of the clusters sent to the renderer: what the cullers
    /// test and the renderer draws; the ids every other list here uses.
    pub visible_clusters: Vec<u32>,
    /// Objects drawn (`visible`'s length).
    pub objects_drawn: u64,
    /// Clusters drawn (`visible_clusters`' length).
    pub clusters_drawn: u64,
    /// Cluster ids of this frame's occluders.
    pub occluders: Vec<u32>,
    /// Triangles sent to the renderer.
    pub triangles_drawn: u64,
    /// Clusters culled by the view frustum.
    pub objects_frustum_culled: u64,
    /// Triangles culled by the view frustum.
    pub triangles_frustum_culled: u64,
    /// Clusters culled as occluded.
    pub objects_occlusion_culled: u64,
    /// Triangles culled as occluded.
    pub triangles_occlusion_culled: u64,
    /// Per-stage milliseconds of the culler, then `cull` (their sum) and `render`.
    pub stages_ms: BTreeMap<String, f64>,
    /// Culling plus rendering, milliseconds.
    pub frame_ms: f64,
    /// Frustum-only culling plus rendering of the same frame, milliseconds (the baseline).
    pub baseline_frame_ms: Option<f64>,
    /// What the culler did; in the report, the `counters` object (each
    /// statistic under its name, [`CullStats::counters`]).
    #[serde(rename = "counters", serialize_with = "serialize_counters")]
    pub stats: CullStats,
    /// Present where the oracle ran.
    #[serde(flatten)]
    pub oracle: Option<OracleFrame>,
    /// Present with level of detail (`lod_` fields).
    #[serde(flatten)]
    pub lod: Option<crate::lod::LodFrame>,
}

/// A frame's statistics as the report's `counters` object: name → value,
/// the names in order.
fn serialize_counters<S: serde::Serializer>(stats: &CullStats, s: S) -> Result<S::Ok, S::Error> {
    let counters: BTreeMap<&str, u64> = stats.counters().into_iter().collect();
    serde::Serialize::serialize(&counters, s)
}

/// Last line: medians and ratios over the walk.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Summary {
    /// Always `"summary"`.
    #[serde(rename = "type")]
    pub kind: &'static str,
    /// Frames walked.
    pub frames: usize,
    /// Median milliseconds of each stage over every frame (0 on a frame the
    /// stage did not run).
    pub median_stage_ms: BTreeMap<String, f64>,
    /// Mean milliseconds of each stage over every frame (0 on a frame the
    /// stage did not run): unlike medians these add up, to the mean frame.
    pub mean_stage_ms: BTreeMap<String, f64>,
    /// Mean frustum-only frame time, milliseconds (Σ of it ÷ Σ frame time is
    /// the speedup).
    pub mean_baseline_frame_ms: Option<f64>,
    /// Median frame time (cull + render), milliseconds.
    pub median_frame_ms: f64,
    /// Median frustum-only frame time, milliseconds.
    pub median_baseline_frame_ms: Option<f64>,
    /// Median oracle-visible-set render time, milliseconds.
    pub median_oracle_set_ms: Option<f64>,
    /// Summed baseline frame time ÷ summed frame time.
    pub speedup: Option<f64>,
    /// Summed baseline frame time ÷ summed oracle-set render time.
    pub oracle_speedup: Option<f64>,
    /// Median percentage of all triangles culled (frustum or occlusion).
    pub median_pct_triangles_culled: f64,
    /// Median percentage of all triangles culled as occluded.
    pub median_pct_occlusion_culled: f64,
    /// Median triangles drawn per frame.
    pub median_triangles_drawn: f64,
    /// Median objects drawn per frame (`objects_drawn`).
    pub median_objects_drawn: f64,
    /// Median clusters drawn per frame (`clusters_drawn`).
    pub median_clusters_drawn: f64,
    /// Falsely culled objects, summed over frames.
    pub false_culls: Option<u64>,
    /// Frames with at least one false cull.
    pub frames_with_false_culls: Option<u64>,
    /// Pixels owned by falsely culled objects, summed over frames.
    pub false_cull_pixels: Option<u64>,
    /// Summed occlusion-culled triangles ÷ summed in-frustum invisible triangles.
    pub efficiency: Option<f64>,
    /// Mean objects drawn per frame that own no pixel.
    pub mean_hidden_drawn: Option<f64>,
    /// Mean of them per frame that are the culler's occluders.
    pub mean_hidden_occluders_drawn: Option<f64>,
    /// Present with level of detail (`lod_` fields).
    #[serde(flatten)]
    pub lod: Option<crate::lod::LodSummary>,
}

/// Writes one record as a JSON line.
pub fn write_line<W: Write + ?Sized>(out: &mut W, record: &impl Serialize) -> std::io::Result<()> {
    serde_json::to_writer(&mut *out, record)?;
    out.write_all(b"\n")
}
