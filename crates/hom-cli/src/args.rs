//! The command line: every clap type, and nothing that runs.

use clap::{Args, Parser, Subcommand, ValueEnum};
use hom::cull::{Coherence, DepthCheck, Hierarchy, PSkip};
use hom::occluders::{OccluderMeshes, SelectionMode};
use hom::occlusion::DepthMode;
use hom_walk::cullers;
use std::path::PathBuf;

/// The `hom` command.
#[derive(Parser)]
#[command(
    name = "hom",
    version,
    about = "Visibility culling for large 3D scenes: hierarchical occlusion maps and friends"
)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Subcommand)]
pub enum Command {
    /// Walk the built-in city with hom's best culler; print a table and write pictures.
    Demo(DemoArgs),
    /// Walk a camera path through a scene with a culler, optionally checking against the oracle.
    Walk(WalkArgs),
    /// Fly through a scene in a window drawn by wgpu and watch what a culler hides
    /// (keys in `hom view --help`); --headless draws the path's frames into PNGs.
    View(ViewArgs),
    /// Render one frame of a scene's path to a PNG.
    Render(RenderArgs),
    /// Walk scenes with several cullers side by side (oracle on); print one table, write JSON and a stage chart.
    Bench(BenchArgs),
    /// List the built-in scenes with object and triangle counts.
    Scenes,
    /// Scene tools: info, export.
    Scene {
        /// Which tool.
        #[command(subcommand)]
        command: SceneCommand,
    },
    /// Virtual occluders (Law & Tan 1999, section 4): info, export.
    Occluders {
        /// Which tool.
        #[command(subcommand)]
        command: OccludersCommand,
    },
    /// Precomputed visibility (Law & Tan 1999, section 5): bake, merge, info, check.
    Pvs {
        /// Which tool.
        #[command(subcommand)]
        command: PvsCommand,
    },
}

/// `hom pvs` tools.
#[derive(Subcommand)]
pub enum PvsCommand {
    /// Bake a PVS: view cells around the scene's camera path, and per cell the objects hidden from all of it.
    Bake(PvsBakeArgs),
    /// Join the shards of one bake (`bake --shard K/N`) into the whole PVS.
    Merge {
        /// The merged .pvs file.
        #[arg(long)]
        out: PathBuf,
        /// The shard files, in any order.
        #[arg(required = true)]
        shards: Vec<PathBuf>,
    },
    /// Cells, set sizes, bytes and the settings of a .pvs file.
    Info {
        /// The .pvs file.
        file: PathBuf,
        /// Also write a top-down map of the cells coloured by set size (PNG).
        #[arg(long)]
        picture: Option<PathBuf>,
        /// The scene it was baked for: its objects' footprints under the map, and a check it matches.
        #[arg(long)]
        scene: Option<String>,
    },
    /// Check a PVS against the oracle at random viewpoints in its cells: objects seen that it hides
    /// (must be 0), and how its sets compare with the union of exact visible sets.
    Check(PvsCheckArgs),
}

/// `hom pvs bake`.
#[derive(Args)]
pub struct PvsBakeArgs {
    /// Built-in scene name or scene file (.obj, .gltf, .glb, .bsp, .pk3 or FILE.pk3:MAP, or an Extreme Tux Racer course.dim).
    #[arg(long)]
    pub scene: String,
    /// The .pvs file to write.
    #[arg(long)]
    pub out: PathBuf,
    /// Edge of a view cell, metres.
    #[arg(long, default_value_t = 4.0)]
    pub cell_size: f32,
    /// The viewing region: cells around this camera path's eyes (default: the scene's own walk).
    #[arg(long)]
    pub camera_path: Option<PathBuf>,
    /// Bake only shard K of N (the blocks of cells split in N ranges), e.g. `--shard 0/4`; join with
    /// `hom pvs merge`. `auto/N` takes K from the batch system: `JOB_COMPLETION_INDEX` (Kubernetes
    /// Indexed Jobs, from 0), else `SLURM_ARRAY_TASK_ID` − `SLURM_ARRAY_TASK_MIN` (Slurm job arrays).
    #[arg(long, value_parser = parse_shard)]
    pub shard: Option<ShardArg>,
    /// Convex polygons of occluder objects (coplanar adjacent triangles joined) at least this large (m²) are planar occluders; `inf` for none.
    #[arg(long, default_value_t = 1.0)]
    pub min_polygon_area: f32,
    /// How far around each eye of the path cells reach, metres.
    #[arg(long, default_value_t = 1.0)]
    pub pad: f32,
    /// Occluder fusion (experimental, found nothing more on the built-in scenes): sample
    /// points at most this far apart over each cell (metres; 0: off).
    #[arg(long, default_value_t = 0.0)]
    pub fusion_spacing: f32,
    /// Portal cells beside the view cells (Quake 3 maps: the map's leaf portals followed
    /// object by object, a set per cluster; other scenes have none yet). Off by default: where
    /// a map's walls are not covered by drawn faces, sight passes into the solid space behind
    /// them, and following it there takes seconds to minutes and loosens the sets
    /// (docs/decisions/pvs.md).
    #[arg(long, value_enum, default_value_t = OnOff::Off)]
    pub portals: OnOff,
}

/// `hom pvs check`.
#[derive(Args)]
pub struct PvsCheckArgs {
    /// The scene the PVS was baked for.
    #[arg(long)]
    pub scene: String,
    /// The .pvs file.
    #[arg(long)]
    pub pvs: PathBuf,
    /// Random viewpoints in all (spread over the cells), each seen in six directions.
    #[arg(long, default_value_t = 1000)]
    pub points: usize,
    /// Side of each of the six square views, pixels.
    #[arg(long, default_value_t = 128)]
    pub side: u32,
    /// Cells to compare with exact visibility (set size against the union of the visible sets
    /// at `--cell-points` stratified points in each).
    #[arg(long, default_value_t = 8)]
    pub cells: usize,
    /// Stratified points per compared cell.
    #[arg(long, default_value_t = 256)]
    pub cell_points: usize,
    /// Seed of the random viewpoints.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

/// `--shard`: shard K of N, or K from the batch system's environment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShardArg {
    /// `K/N`.
    Fixed(hom::pvs::Shard),
    /// `auto/N`: K is read when the bake starts ([`crate::commands::pvs::shard_from_env`]).
    Auto {
        /// N.
        count: u32,
    },
}

/// Parses `K/N` (shard K of N, from 0) or `auto/N`.
fn parse_shard(s: &str) -> Result<ShardArg, String> {
    let (k, n) = s
        .split_once('/')
        .ok_or_else(|| format!("'{s}' is not K/N or auto/N (e.g. 0/4, auto/4)"))?;
    let count: u32 = n
        .trim()
        .parse()
        .map_err(|_| format!("'{n}' in '{s}' is not a shard count"))?;
    if count == 0 {
        return Err(format!("'{s}': the shard count N must be at least 1"));
    }
    if k.trim() == "auto" {
        return Ok(ShardArg::Auto { count });
    }
    let index: u32 = k
        .trim()
        .parse()
        .map_err(|_| format!("'{k}' in '{s}' is not a shard index (a number, or auto)"))?;
    if index >= count {
        return Err(format!("shard {index}/{count}: K must be below N (0/4 .. 3/4)"));
    }
    Ok(ShardArg::Fixed(hom::pvs::Shard { index, count }))
}

/// `hom occluders` tools.
#[derive(Subcommand)]
pub enum OccludersCommand {
    /// Per occluder: original and virtual triangles, coverage kept and guarantee over six axis views.
    Info {
        /// Built-in scene name or scene file (.obj, .gltf, .glb, .bsp, .pk3 or FILE.pk3:MAP, or an Extreme Tux Racer course.dim).
        #[arg(long)]
        scene: String,
        /// Samples per side of each axis view.
        #[arg(long, default_value_t = 96)]
        side: u32,
        /// Print only the summary, not a line per occluder.
        #[arg(long)]
        summary: bool,
        /// Also write pictures of the densest occluders against their stand-ins into this folder.
        #[arg(long)]
        pictures: Option<PathBuf>,
        /// Also compare, on this many frames spread over the scene's camera path (at its
        /// viewport), every occluder in view whose stand-in is usable: violations and
        /// coverage kept on the views the cullers meet (more than the path has: every frame).
        #[arg(long, default_value_t = 0)]
        walk_frames: usize,
    },
    /// Write the virtual occluders in world space as OBJ, one `o` per source object.
    Export {
        /// Built-in scene name or scene file.
        #[arg(long)]
        scene: String,
        /// Output .obj file.
        #[arg(long)]
        out: PathBuf,
    },
}

/// `hom scene` tools.
#[derive(Subcommand)]
pub enum SceneCommand {
    /// Object, triangle and bounds information.
    Info {
        /// Built-in scene name or scene file (.obj, .gltf, .glb, .bsp, .pk3 or FILE.pk3:MAP, or an Extreme Tux Racer course.dim).
        #[arg(long)]
        scene: String,
        #[command(flatten)]
        clusters: Clusters,
    },
    /// Write the scene's world-space triangles as OBJ, one `o` per object in id order.
    Export {
        /// Built-in scene name or scene file.
        #[arg(long)]
        scene: String,
        /// Output .obj file.
        #[arg(long)]
        out: PathBuf,
        #[command(flatten)]
        clusters: Clusters,
    },
}

/// What to look at and how: the scene, the path, the viewport and the culler.
#[derive(Args)]
pub struct View {
    /// Built-in scene name (see `hom scenes`) or a scene file (.obj, .gltf, .glb, .bsp, .pk3 or FILE.pk3:MAP, or an Extreme Tux Racer course.dim; a Quake 3 map walks its spawn points, a course runs down its slope).
    #[arg(long)]
    pub scene: String,
    /// Camera path JSON file (default: the scene's own walkthrough: a built-in
    /// scene's walk, NAME.path.json beside a NAME.obj/.gltf/.glb file, a Quake 3
    /// map's spawn points, an Extreme Tux Racer course's run down the slope, else
    /// an orbit around the bounds).
    #[arg(long)]
    pub camera_path: Option<PathBuf>,
    #[command(flatten)]
    pub clusters: Clusters,
    /// Image width (default: the path's).
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height (default: the path's).
    #[arg(long)]
    pub height: Option<u32>,
    /// Walk the path K times as fast (2, 8: frames skipped; 0.25, 0.5: frames interpolated).
    #[arg(long, value_parser = parse_speed)]
    pub speed: Option<f32>,
    /// A cut every N frames: jump a third of the path ahead, turning 180° at every other cut.
    #[arg(long)]
    pub cuts: Option<usize>,
    /// The culler's name (help from `cullers::CULLERS`).
    // A plain string checked by `cullers::make`, not a clap value parser: its
    // error stays the app's one line naming the choices.
    #[arg(long, default_value = cullers::BEST, help = culler_help(), long_help = culler_long_help())]
    pub culler: String,
    /// Renderer threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Culler settings.
    #[command(flatten)]
    pub hom: HomArgs,
}

/// `--culler`'s help, from [`cullers::CULLERS`].
fn culler_help() -> String {
    format!("Culler: {}", cullers::names())
}

/// `--culler`'s long help: each culler with its description, from [`cullers::CULLERS`].
fn culler_long_help() -> String {
    let mut s = String::from("Culler:");
    for (name, description) in cullers::CULLERS {
        s.push_str(&format!("\n- {name}: {description}"));
    }
    s
}

/// Settings of the `hom` culler (and the HZB and HV cullers).
#[derive(Args, Clone, Default)]
pub struct HomArgs {
    /// HOM: occluder polygon budget L (triangles per frame).
    #[arg(long)]
    pub budget: Option<u32>,
    /// HOM, HZB, masked, otree: the meshes occluders are drawn with: `virtual` (default:
    /// occlusion-preserving stand-ins inside the originals, Law & Tan 1999 section 4) or `original`.
    #[arg(long, value_enum)]
    pub occluders: Option<OccludersArg>,
    /// HOM: adapt the budget per frame from frame time and culled percentage.
    #[arg(long)]
    pub adaptive_budget: bool,
    /// HOM: base opacity threshold in (0, 1]; below 1 culls approximately (objects seen through small holes).
    #[arg(long)]
    pub opacity: Option<f32>,
    /// HOM: depth test.
    #[arg(long, value_enum)]
    pub depth: Option<DepthArg>,
    /// HOM: base occlusion map resolution for the larger image side.
    #[arg(long)]
    pub map_size: Option<u32>,
    /// HOM: occluder selection (default: nearest).
    #[arg(long, value_enum)]
    pub selection: Option<SelectionArg>,
    /// HOM: disable the hole-filling feedback.
    #[arg(long)]
    pub no_hole_filling: bool,
    /// HOM, HZB, masked, otree, HV: how much of last frame's classification the traversal
    /// reuses (Bittner & Havran 2002).
    #[arg(long, value_enum)]
    pub coherence: Option<CoherenceArg>,
    /// With --coherence skip: the probability that a node visible last frame is
    /// assumed visible without a test: `auto` (from each node's history) or a number in [0, 1].
    #[arg(long, value_parser = hom_walk::bench::parse_p_skip)]
    pub p_skip: Option<PSkip>,
    /// HOM, HZB, masked, otree: the hierarchy the occlusion traversal walks (resting frames and
    /// occluder selection keep the BVH): `bvh` (default), `kd` (a kD-tree with ropes) or
    /// `kd-propagate` (with visibility propagation, Bittner & Havran 2002); both kD ones experimental.
    #[arg(long, value_parser = hom_walk::bench::parse_hierarchy)]
    pub hierarchy: Option<Hierarchy>,
    /// HOM, HZB, masked, otree: never rest, even where occlusion culling costs more than it saves
    /// (by default, frames are frustum culled only while it does not pay).
    #[arg(long)]
    pub no_cost_model: bool,
    /// HOM, HZB, masked, otree: where each visible object of at most 256 triangles that the
    /// occluders cover is checked, after the traversal, against their depth at every sample it
    /// covers (culled when it lies behind them at every one): `off`, `if-drawn` (default: where
    /// the buffer holds that depth or a bound of it: HZB, masked) or `on` (HOM too, drawing it
    /// for the check).
    #[arg(long, value_parser = hom_walk::bench::parse_depth_check)]
    pub depth_check: Option<DepthCheck>,
    /// HV: most triangles per octree leaf (default 16).
    #[arg(long)]
    pub hv_threshold: Option<usize>,
    /// HV: maximum octree depth (default 12).
    #[arg(long)]
    pub hv_max_depth: Option<u32>,
    /// HV: keep large triangles at the octree node being split instead of passing them down.
    #[arg(long)]
    pub hv_keep_large: bool,
    /// HV: temporal priming: draw last frame's visible nodes first (off by default, experimental:
    /// it saves node tests but not raster work, docs/decisions/hv.md).
    #[arg(long)]
    pub hv_priming: bool,
}

/// `--occluders`: which meshes occluders are drawn with.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum OccludersArg {
    /// Each occluder's own mesh.
    Original,
    /// Virtual occluders: a few boxes inside each occluder's solid parts.
    Virtual,
}

impl OccludersArg {
    /// The occluder database's setting.
    pub fn meshes(self) -> OccluderMeshes {
        match self {
            OccludersArg::Original => OccluderMeshes::Original,
            OccludersArg::Virtual => OccluderMeshes::Virtual,
        }
    }
}

/// `--coherence`: what the occlusion traversal reuses from the last frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum CoherenceArg {
    /// Classify the hierarchy from the root every frame.
    Off,
    /// Hierarchy updating: skip the tests of nodes opened last frame; the same result as off.
    Exact,
    /// Also assume nodes visible last frame visible with probability --p-skip: fewer tests, a few more objects drawn.
    Skip,
}

impl CoherenceArg {
    /// The traversal's coherence, with `p_skip` for `skip` (default auto).
    pub fn mode(self, p_skip: Option<PSkip>) -> Coherence {
        match self {
            CoherenceArg::Off => Coherence::Off,
            CoherenceArg::Exact => Coherence::Exact,
            CoherenceArg::Skip => Coherence::Skip(p_skip.unwrap_or_default()),
        }
    }
}

/// `--speed`: a finite number above 0.
pub fn parse_speed(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(k) if k.is_finite() && k > 0.0 && k <= 1000.0 => Ok(k),
        _ => Err(format!("expected a speed above 0 and at most 1000, got `{s}`")),
    }
}

/// `--depth`: how HOM bounds the occluders' depth.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DepthArg {
    /// Per-cell depth of occluder samples.
    Rasterized,
    /// The paper's estimation buffer.
    Box,
    /// Single Z plane.
    Plane,
}

impl DepthArg {
    /// The culler's depth mode.
    pub fn mode(self) -> DepthMode {
        match self {
            DepthArg::Rasterized => DepthMode::Rasterized(64, 64),
            DepthArg::Box => DepthMode::EstimationBuffer(64, 64),
            DepthArg::Plane => DepthMode::SingleZPlane,
        }
    }
}

/// `--selection`: how HOM picks its occluders.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SelectionArg {
    /// Nearest first, by distance over box radius.
    Nearest,
    /// The single-Z-plane order.
    Zplane,
}

impl SelectionArg {
    /// The occluder database's selection mode.
    pub fn mode(self) -> SelectionMode {
        match self {
            SelectionArg::Nearest => SelectionMode::Nearest,
            SelectionArg::Zplane => SelectionMode::ZPlane,
        }
    }
}

/// `hom walk`.
#[derive(Args)]
pub struct WalkArgs {
    /// Scene, path, viewport, culler.
    #[command(flatten)]
    pub view: View,
    /// Walk only the first N frames.
    #[arg(long)]
    pub frames: Option<usize>,
    /// Run the oracle every frame: false culls and culling efficiency.
    #[arg(long)]
    pub oracle: bool,
    /// Write the JSON-lines report here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write plots (frame times, % culled) into this folder.
    #[arg(long)]
    pub plots: Option<PathBuf>,
    /// An A/A check of the timing: with `--culler frustum`, time the baseline as a second
    /// frustum culler's frames instead of reusing its own, so the speedup measures only
    /// the measurement's bias and noise (1.00 when fair).
    #[arg(long)]
    pub self_baseline: bool,
    /// Quake 3 maps (.bsp, .pk3): measure against the map's own PVS (implies --oracle):
    /// oracle-visible objects the PVS hides, triangles drawn by frustum, PVS, the culler,
    /// PVS then the culler, and the oracle. Adds `pvs_` fields to the report.
    #[arg(long)]
    pub pvs: bool,
    /// With --pvs: measure the PVS the map's leaf portals give instead of the map's own
    /// (built from the BSP tree at load, object by object, per cluster; its build time is
    /// printed; up to minutes, see `hom pvs bake --portals`).
    #[arg(long, requires = "pvs")]
    pub pvs_portals: bool,
    /// A PVS baked by `hom pvs bake` for this scene: objects its cell hides are not drawn, after
    /// `--culler` (frustum: the PVS alone; hom: PVS then HOM). With --oracle the report gains
    /// `pvs_` fields as with --pvs.
    #[arg(long)]
    pub pvs_file: Option<PathBuf>,
    /// What draws the timed frames: `software` (hom's renderer) or `wgpu` (a vertex and
    /// index buffer per scene, one draw per visible object, on the first Vulkan adapter:
    /// a GPU, or Mesa's lavapipe), timed by GPU timestamps where the adapter has them,
    /// else from submit to done. The oracle's item buffer stays the software renderer's.
    #[arg(long, value_enum, default_value = "software")]
    pub renderer: RendererArg,
    /// Level of detail.
    #[command(flatten)]
    pub lod: LodArgs,
}

/// `--renderer`: what draws a walk's timed frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum RendererArg {
    /// hom's multi-threaded software z-buffer renderer.
    Software,
    /// wgpu on the first Vulkan adapter.
    Wgpu,
}

/// `hom view`: keys Space play/pause the path (paused: W A S D fly, Q down, E up, Shift
/// faster, left mouse button held to look), 1-5 culler (none, frustum, hom, hzb, masked),
/// V virtual/original occluders, F false colour, I the occlusion buffer's inset, T the
/// line of figures, R record the camera's path (again: stop and write it), Escape close.
#[derive(Args)]
pub struct ViewArgs {
    /// Scene, path, viewport (default 1280x720), culler.
    #[command(flatten)]
    pub view: View,
    /// Draw the path's frames offscreen into PNGs (DIR/frame_00000.png, …): no window,
    /// no display needed.
    #[arg(long, requires = "out")]
    pub headless: bool,
    /// --headless: the folder the pictures go to.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// --headless: only the first N frames. In the window: play the path's first N
    /// frames, then close.
    #[arg(long)]
    pub frames: Option<usize>,
    /// In the window with --frames: write the last frame to this PNG.
    #[arg(long, requires = "frames")]
    pub screenshot: Option<PathBuf>,
    /// Start with the false colour on: occluders blue, occlusion-culled objects red,
    /// seen through what hides them.
    #[arg(long)]
    pub false_colour: bool,
    /// Where key R writes the recorded camera path (a second recording: NAME-2.json, …).
    #[arg(long, default_value = "hom-view-path.json")]
    pub record: PathBuf,
}

/// Level of detail guided by visibility (Law & Tan 1999, section 6).
#[derive(Args, Clone, Debug)]
pub struct LodArgs {
    /// Draw each visible object's level-of-detail cut instead of its whole mesh: a
    /// hierarchy of triangle clusters per mesh (built at start), refined where a node's
    /// projected error exceeds --lod-error. Reports gain `lod_` fields.
    #[arg(long)]
    pub lod: bool,
    /// --lod: refine while a node's projected error exceeds this many pixels.
    #[arg(long, default_value_t = 1.0)]
    pub lod_error: f32,
    /// --lod: instead of the threshold, hold this many triangles a frame, refining the
    /// worst projected errors first.
    #[arg(long)]
    pub lod_budget: Option<u64>,
    /// --lod: `on` never refines a node the culler finds hidden (needs an occlusion
    /// culler; with the oracle each frame is also drawn without guidance and the pixels
    /// that differ are counted); `off` refines by the view alone.
    #[arg(long, value_enum, default_value = "on")]
    pub lod_guidance: OnOff,
    /// --lod with the threshold: `on` draws each occluder whose cut is coarser than its
    /// mesh as that cut, so the occluder budget buys more of them; what is culled is then
    /// hidden in the level-of-detail image, which may differ from the full meshes' within
    /// --lod-error along silhouettes. `off` draws occluders as their meshes.
    #[arg(long, value_enum, default_value = "on")]
    pub lod_occluders: OnOff,
}

/// `--clusters`, for every command that loads a scene file.
#[derive(Args, Clone, Copy, Debug, PartialEq, Eq)]
pub struct Clusters {
    /// `on` (default; `--clusters` alone too): scene files are cut into
    /// cluster-sized objects (a Quake 3 map's faces, an ETR course's terrain,
    /// a one-object OBJ file, any OBJ or glTF object that spans the level),
    /// `hom scene export` writing one `o` each in id order; `off` keeps whole objects.
    #[arg(long = "clusters", value_name = "CLUSTERS", value_enum, default_value = "on", num_args = 0..=1, default_missing_value = "on")]
    pub switch: OnOff,
}

impl Clusters {
    /// Cut into cluster-sized objects (the default).
    pub const ON: Clusters = Clusters { switch: OnOff::On };

    /// The loaders' options this asks for.
    pub fn load_options(self) -> hom_scene::LoadOptions {
        hom_walk::load_options(self.switch == OnOff::On)
    }
}

/// A switch.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum OnOff {
    /// On.
    On,
    /// Off.
    Off,
}

/// `hom render`.
#[derive(Args)]
pub struct RenderArgs {
    /// Scene, path, viewport, culler.
    #[command(flatten)]
    pub view: View,
    /// Frame index along the path.
    #[arg(long, default_value_t = 0)]
    pub frame: usize,
    /// Output PNG.
    #[arg(long)]
    pub out: PathBuf,
    /// Colour by fate: occluders blue, drawn grey, occlusion-culled red.
    #[arg(long)]
    pub false_colour: bool,
    /// A PVS baked by `hom pvs bake` in front of the culler: with --false-colour, what the
    /// frame's cell hides is red too (the frustum culler then shows the PVS alone).
    #[arg(long)]
    pub pvs_file: Option<PathBuf>,
    /// Level of detail: with --lod the frame is drawn coloured by how coarse each node is
    /// (blue full resolution … red 16× coarser), and the same cut is drawn again from above
    /// and behind the eye into OUT-above.png, where the nodes guidance kept coarse show.
    #[command(flatten)]
    pub lod: LodArgs,
}

/// What `hom bench` measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum BenchKind {
    /// Walkthroughs of scenes with several cullers side by side.
    Walk,
    /// The occluder rasterizer and rectangle tests on the Masked Occlusion Culling inputs.
    Raster,
}

/// The flags of `hom bench` only one kind reads: argument id, flag, kind.
const BENCH_KIND_FLAGS: [(&str, &str, BenchKind); 21] = [
    ("renderer", "--renderer", BenchKind::Walk),
    ("data", "--data", BenchKind::Raster),
    ("runs", "--runs", BenchKind::Raster),
    ("raster_threads", "--raster-threads", BenchKind::Raster),
    ("scenes", "--scenes", BenchKind::Walk),
    ("camera_path", "--camera-path", BenchKind::Walk),
    ("budget", "--budget", BenchKind::Walk),
    ("switch", "--clusters", BenchKind::Walk),
    ("cullers", "--cullers", BenchKind::Walk),
    ("frames", "--frames", BenchKind::Walk),
    ("speed", "--speed", BenchKind::Walk),
    ("cuts", "--cuts", BenchKind::Walk),
    ("coherence", "--coherence", BenchKind::Walk),
    ("hierarchy", "--hierarchy", BenchKind::Walk),
    ("occluders", "--occluders", BenchKind::Walk),
    ("no_cost_model", "--no-cost-model", BenchKind::Walk),
    ("depth_check", "--depth-check", BenchKind::Walk),
    ("hv_priming", "--hv-priming", BenchKind::Walk),
    ("width", "--width", BenchKind::Walk),
    ("height", "--height", BenchKind::Walk),
    ("threads", "--threads", BenchKind::Walk),
];

/// `hom bench`.
#[derive(Args)]
pub struct BenchArgs {
    /// `walk` (scenes × cullers) or `raster` (the rasterizer on the MOC inputs in --data).
    #[arg(value_enum, default_value = "walk")]
    pub kind: BenchKind,
    /// walk: what draws the timed frames (as `hom walk --renderer`): `software` or `wgpu`.
    #[arg(long, value_enum, default_value = "software")]
    pub renderer: RendererArg,
    /// raster: the folder with the .mocscene/.mocrec/.res inputs.
    #[arg(long, default_value = "../shared/bench-data/moc")]
    pub data: PathBuf,
    /// raster: runs per measurement (the median is reported).
    #[arg(long, default_value_t = 5)]
    pub runs: usize,
    /// raster: comma-separated thread counts to render with.
    #[arg(long, value_delimiter = ',', default_value = "1,2")]
    pub raster_threads: Vec<usize>,
    /// Comma-separated built-in scene names or files (default: every built-in scene); `FILE.pk3:*` is every map in the archive.
    #[arg(long, value_delimiter = ',')]
    pub scenes: Vec<String>,
    /// Camera path JSON file to walk the one scene of --scenes along (default:
    /// the scene's own walkthrough, as `hom walk`'s --camera-path says).
    #[arg(long)]
    pub camera_path: Option<PathBuf>,
    /// HOM, HZB, masked, otree: occluder polygon budget L (triangles per frame;
    /// default 1 % of the scene's triangles, within 3,000–20,000).
    #[arg(long)]
    pub budget: Option<u32>,
    #[command(flatten)]
    pub clusters: Clusters,
    /// Comma-separated cullers to compare (default: frustum,hom,masked: the paper's and the default).
    #[arg(long, value_delimiter = ',', default_value = "frustum,hom,masked")]
    pub cullers: Vec<String>,
    /// Walk only the first N frames of each path.
    #[arg(long)]
    pub frames: Option<usize>,
    /// Walk each path K times as fast (2, 8: frames skipped; 0.25, 0.5: frames interpolated).
    #[arg(long, value_parser = parse_speed)]
    pub speed: Option<f32>,
    /// A cut every N frames: jump a third of the path ahead, turning 180° at every other cut.
    #[arg(long)]
    pub cuts: Option<usize>,
    /// Comma-separated traversal coherence modes to walk HOM, HZB, masked, otree and HV with, a row each:
    /// off, exact, skip (adaptive p_skip) or skip:P (default: each culler's default only).
    #[arg(long, value_delimiter = ',', value_parser = hom_walk::bench::parse_coherence)]
    pub coherence: Vec<Coherence>,
    /// Comma-separated hierarchies to walk HOM, HZB, masked and otree with, a row each (times the
    /// coherence modes): bvh, kd, kd-propagate (default: the BVH only; the kD ones experimental).
    #[arg(long, value_delimiter = ',', value_parser = hom_walk::bench::parse_hierarchy)]
    pub hierarchy: Vec<Hierarchy>,
    /// Comma-separated occluder meshes to walk HOM, HZB, masked and otree with, a row each:
    /// original, virtual (default: virtual only).
    #[arg(long, value_delimiter = ',', value_parser = hom_walk::bench::parse_occluders)]
    pub occluders: Vec<OccluderMeshes>,
    /// HOM, HZB, masked, otree: never rest where occlusion culling costs more than it saves.
    #[arg(long)]
    pub no_cost_model: bool,
    /// HOM, HZB, masked, otree: where the per-sample depth check runs after the traversal:
    /// `off`, `if-drawn` (default: where the buffer holds per-sample depth or a bound of it: HZB,
    /// masked) or `on` (HOM too).
    #[arg(long, value_parser = hom_walk::bench::parse_depth_check)]
    pub depth_check: Option<DepthCheck>,
    /// HV: temporal priming (last frame's visible nodes drawn first).
    #[arg(long)]
    pub hv_priming: bool,
    /// Image width (default: each path's).
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height (default: each path's).
    #[arg(long)]
    pub height: Option<u32>,
    /// Renderer threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Write the JSON record to exactly this file (default: hom-out/bench/bench.json for walk,
    /// hom-out/bench/raster.json for raster); walk writes its stage chart beside it as stages.png.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

impl BenchArgs {
    /// The flags given on the command line (`bench`: the subcommand's
    /// matches) that this kind of bench does not read: an error, not
    /// silently ignored. Asked of clap, so a flag given at its default value
    /// counts and a default changed in one place cannot drift.
    pub fn foreign_flags(&self, bench: &clap::ArgMatches) -> Vec<&'static str> {
        BENCH_KIND_FLAGS
            .iter()
            .filter(|&&(id, _, kind)| {
                kind != self.kind && bench.value_source(id) == Some(clap::parser::ValueSource::CommandLine)
            })
            .map(|&(_, flag, _)| flag)
            .collect()
    }

    /// The JSON file to write: `--json` as given, else the kind's default.
    pub fn json_path(&self) -> PathBuf {
        match (&self.json, self.kind) {
            (Some(p), _) => p.clone(),
            (None, BenchKind::Walk) => PathBuf::from("hom-out/bench/bench.json"),
            (None, BenchKind::Raster) => PathBuf::from("hom-out/bench/raster.json"),
        }
    }
}

/// `hom demo`.
#[derive(Args)]
pub struct DemoArgs {
    /// Folder for the pictures.
    #[arg(long, default_value = "hom-out/demo")]
    pub out: PathBuf,
    /// Walk only the first N frames of the city path.
    #[arg(long)]
    pub frames: Option<usize>,
    /// Image width.
    #[arg(long, default_value_t = 1024)]
    pub width: u32,
    /// Image height.
    #[arg(long, default_value_t = 1024)]
    pub height: u32,
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;
    use std::path::Path;

    fn bench(args: &[&str]) -> BenchArgs {
        let cli = Cli::try_parse_from(["hom", "bench"].iter().chain(args)).unwrap();
        match cli.command {
            Command::Bench(a) => a,
            _ => unreachable!("parsed a bench command"),
        }
    }

    #[test]
    fn the_command_line_is_well_formed() {
        Cli::command().debug_assert();
    }

    /// The flags `hom bench ARGS` was given that its kind does not read.
    fn foreign(args: &[&str]) -> Vec<&'static str> {
        let matches = Cli::command()
            .try_get_matches_from(["hom", "bench"].iter().chain(args))
            .unwrap();
        let bench_matches = matches.subcommand_matches("bench").unwrap();
        bench(args).foreign_flags(bench_matches)
    }

    #[test]
    fn bench_flags_of_the_other_kind_are_named() {
        assert_eq!(foreign(&[]), Vec::<&str>::new());
        assert_eq!(foreign(&["raster", "--runs", "3", "--data", "d"]), Vec::<&str>::new());
        assert_eq!(
            foreign(&["raster", "--scenes", "city", "--frames", "5", "--cullers", "hom"]),
            ["--scenes", "--cullers", "--frames"]
        );
        // At its default value, still named.
        assert_eq!(foreign(&["raster", "--cullers", "frustum,hom,masked"]), ["--cullers"]);
        assert_eq!(
            foreign(&["walk", "--raster-threads", "1", "--runs", "5"]),
            ["--runs", "--raster-threads"]
        );
        // Each call above asks clap for every id of the other kind, and clap
        // panics on an id that is not one of the command's.
    }

    #[test]
    fn bench_json_is_the_given_file_or_the_kind_default() {
        assert_eq!(bench(&[]).json_path(), Path::new("hom-out/bench/bench.json"));
        assert_eq!(bench(&["raster"]).json_path(), Path::new("hom-out/bench/raster.json"));
        assert_eq!(
            bench(&["raster", "--json", "x/y.json"]).json_path(),
            Path::new("x/y.json")
        );
        assert_eq!(
            bench(&["walk", "--json", "x/y.json"]).json_path(),
            Path::new("x/y.json")
        );
    }

    #[test]
    fn depth_and_selection_take_their_documented_names() {
        let cli =
            Cli::try_parse_from(["hom", "walk", "--scene", "s", "--depth", "box", "--selection", "zplane"]).unwrap();
        let Command::Walk(a) = cli.command else {
            unreachable!("parsed a walk command")
        };
        assert_eq!(a.view.hom.depth, Some(DepthArg::Box));
        assert_eq!(a.view.hom.selection, Some(SelectionArg::Zplane));
        assert_eq!(a.view.culler, cullers::BEST);
        let err = Cli::try_parse_from(["hom", "walk", "--scene", "s", "--depth", "fuzzy"])
            .err()
            .expect("unknown depth");
        let text = err.to_string();
        assert!(text.contains("rasterized") && text.contains("plane"), "{text}");
    }
}
