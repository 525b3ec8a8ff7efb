//! `hom` — visibility culling for large 3D scenes, from the command line.
//!
//! The subcommand names and flags are a contract that scripts depend on.

use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand};
use hom::cull::{CullOutput, Culler, DepthMode, HomConfig, HomCuller, Opacity};
use hom::occluders::SelectionMode;
use hom_render::{Framebuffer, RenderOptions, Renderer};
use hom_scene::CameraPath;
use hom_walk::pvs::{self, PvsSummary};
use hom_walk::report::{self, FrameRecord, Summary};
use hom_walk::{cullers, pictures, WalkOptions, WalkResult};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

#[derive(Parser)]
#[command(
    name = "hom",
    version,
    about = "Visibility culling for large 3D scenes: hierarchical occlusion maps and friends"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Walk the built-in city with hom's best culler; print a table and write pictures.
    Demo(DemoArgs),
    /// Walk a camera path through a scene with a culler, optionally checking against the oracle.
    Walk(WalkArgs),
    /// Render one frame of a scene's path to a PNG.
    Render(RenderArgs),
    /// Walk scenes with several cullers side by side (oracle on); print one table, write JSON and a stage chart.
    Bench(BenchArgs),
    /// List the built-in scenes with object and triangle counts.
    Scenes,
    /// Scene tools: info, export.
    Scene {
        #[command(subcommand)]
        command: SceneCommand,
    },
}

#[derive(Subcommand)]
enum SceneCommand {
    /// Object, triangle and bounds information.
    Info {
        /// Built-in scene name or scene file (.obj, .gltf, .glb, .bsp, .pk3 or FILE.pk3:MAP).
        #[arg(long)]
        scene: String,
    },
    /// Write the scene's world-space triangles as OBJ, one `o` per object in id order.
    Export {
        /// Built-in scene name or scene file.
        #[arg(long)]
        scene: String,
        /// Output .obj file.
        #[arg(long)]
        out: PathBuf,
    },
}

#[derive(Args)]
struct View {
    /// Built-in scene name (see `hom scenes`) or a scene file (.obj, .gltf, .glb, .bsp, .pk3 or FILE.pk3:MAP; a Quake 3 map walks its spawn points).
    #[arg(long)]
    scene: String,
    /// Camera path JSON file (default: the scene's own walkthrough).
    #[arg(long)]
    camera_path: Option<PathBuf>,
    /// Image width (default: the path's).
    #[arg(long)]
    width: Option<u32>,
    /// Image height (default: the path's).
    #[arg(long)]
    height: Option<u32>,
    /// Culler: none, frustum, hom (hierarchical occlusion maps, the default), hzb (hierarchical Z-buffer),
    /// hv (hierarchical visibility: octree + live Z-pyramid).
    #[arg(long, default_value = cullers::BEST)]
    culler: String,
    /// Renderer threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    #[command(flatten)]
    hom: HomArgs,
}

/// Settings of the `hom` culler.
#[derive(Args, Clone, Default)]
struct HomArgs {
    /// HOM: occluder polygon budget L (triangles per frame).
    #[arg(long)]
    budget: Option<u32>,
    /// HOM: adapt the budget per frame from frame time and culled percentage.
    #[arg(long)]
    adaptive_budget: bool,
    /// HOM: base opacity threshold in (0, 1]; below 1 culls approximately (objects seen through small holes).
    #[arg(long)]
    opacity: Option<f32>,
    /// HOM: depth test: rasterized (per-cell depth of occluder samples), box (the paper's estimation buffer), plane (single Z plane).
    #[arg(long)]
    depth: Option<String>,
    /// HOM: base occlusion map resolution for the larger image side.
    #[arg(long)]
    map_size: Option<u32>,
    /// HOM: occluder selection: nearest (default) or zplane.
    #[arg(long)]
    selection: Option<String>,
    /// HOM: disable the hole-filling feedback.
    #[arg(long)]
    no_hole_filling: bool,
    /// HV: most triangles per octree leaf (default 16).
    #[arg(long)]
    hv_threshold: Option<usize>,
    /// HV: maximum octree depth (default 12).
    #[arg(long)]
    hv_max_depth: Option<u32>,
    /// HV: keep large triangles at the octree node being split instead of passing them down.
    #[arg(long)]
    hv_keep_large: bool,
}

impl HomArgs {
    fn config(&self, scene: &hom::scene::Scene) -> Result<HomConfig> {
        let mut c = HomConfig::for_scene(scene);
        if let Some(b) = self.budget {
            c.selection.budget = b;
        }
        c.selection.adaptive = self.adaptive_budget;
        c.selection.hole_filling = !self.no_hole_filling;
        if let Some(o) = self.opacity {
            if !(o > 0.0 && o <= 1.0) {
                bail!("--opacity must be in (0, 1], got {o}");
            }
            c.map.opacity = if o == 1.0 {
                Opacity::Conservative
            } else {
                Opacity::Threshold(o)
            };
        }
        if let Some(d) = &self.depth {
            c.map.depth = match d.as_str() {
                "rasterized" => DepthMode::Rasterized(64, 64),
                "box" => DepthMode::EstimationBuffer(64, 64),
                "plane" => DepthMode::SingleZPlane,
                other => bail!("--depth must be rasterized, box or plane, got '{other}'"),
            };
        }
        if let Some(m) = self.map_size {
            if !(1..=4096).contains(&m) {
                bail!("--map-size must be 1..=4096, got {m}");
            }
            c.map.map_size = m;
        }
        if let Some(s) = &self.selection {
            c.selection.mode = match s.as_str() {
                "nearest" => SelectionMode::Nearest,
                "zplane" => SelectionMode::ZPlane,
                other => bail!("--selection must be nearest or zplane, got '{other}'"),
            };
        }
        Ok(c)
    }
}

#[derive(Args)]
struct WalkArgs {
    #[command(flatten)]
    view: View,
    /// Walk only the first N frames.
    #[arg(long)]
    frames: Option<usize>,
    /// Run the oracle every frame: false culls and culling efficiency.
    #[arg(long)]
    oracle: bool,
    /// Write the JSON-lines report here.
    #[arg(long)]
    report: Option<PathBuf>,
    /// Write plots (frame times, % culled) into this folder.
    #[arg(long)]
    plots: Option<PathBuf>,
    /// Quake 3 maps (.bsp, .pk3): measure against the map's own PVS (implies --oracle):
    /// oracle-visible objects the PVS hides, triangles drawn by frustum, PVS, the culler,
    /// PVS then the culler, and the oracle. Adds `pvs_` fields to the report.
    #[arg(long)]
    pvs: bool,
}

#[derive(Args)]
struct RenderArgs {
    #[command(flatten)]
    view: View,
    /// Frame index along the path.
    #[arg(long, default_value_t = 0)]
    frame: usize,
    /// Output PNG.
    #[arg(long)]
    out: PathBuf,
    /// Colour by fate: occluders blue, drawn grey, occlusion-culled red.
    #[arg(long)]
    false_colour: bool,
}

/// What `hom bench` measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
enum BenchKind {
    /// Walkthroughs of scenes with several cullers side by side.
    Walk,
    /// The occluder rasterizer and rectangle tests on the Masked Occlusion Culling inputs.
    Raster,
}

#[derive(Args)]
struct BenchArgs {
    /// `walk` (scenes × cullers) or `raster` (the rasterizer on the MOC inputs in --data).
    #[arg(value_enum, default_value = "walk")]
    kind: BenchKind,
    /// raster: the folder with the .mocscene/.mocrec/.res inputs.
    #[arg(long, default_value = "../shared/bench-data/moc")]
    data: PathBuf,
    /// raster: runs per measurement (the median is reported).
    #[arg(long, default_value_t = 5)]
    runs: usize,
    /// raster: comma-separated thread counts to render with.
    #[arg(long, value_delimiter = ',', default_value = "1,2")]
    raster_threads: Vec<usize>,
    /// Comma-separated built-in scene names or files (default: every built-in scene).
    #[arg(long, value_delimiter = ',')]
    scenes: Vec<String>,
    /// Comma-separated cullers to compare (default: frustum,hom).
    #[arg(long, value_delimiter = ',', default_value = "frustum,hom")]
    cullers: Vec<String>,
    /// Walk only the first N frames of each path.
    #[arg(long)]
    frames: Option<usize>,
    /// Image width (default: each path's).
    #[arg(long)]
    width: Option<u32>,
    /// Image height (default: each path's).
    #[arg(long)]
    height: Option<u32>,
    /// Renderer threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Write the JSON record here.
    #[arg(long, default_value = "hom-out/bench/bench.json")]
    json: PathBuf,
}

#[derive(Args)]
struct DemoArgs {
    /// Folder for the pictures.
    #[arg(long, default_value = "hom-out/demo")]
    out: PathBuf,
    /// Walk only the first N frames of the city path.
    #[arg(long)]
    frames: Option<usize>,
    /// Image width.
    #[arg(long, default_value_t = 1024)]
    width: u32,
    /// Image height.
    #[arg(long, default_value_t = 1024)]
    height: u32,
}

fn main() {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Demo(a) => demo(a),
        Command::Walk(a) => walk(a),
        Command::Render(a) => render(a),
        Command::Bench(a) => bench(a),
        Command::Scenes => scenes(),
        Command::Scene { command } => match command {
            SceneCommand::Info { scene } => scene_info(&scene),
            SceneCommand::Export { scene, out } => scene_export(&scene, &out),
        },
    };
    if let Err(e) = result {
        // One line naming the problem; no backtrace.
        eprintln!("error: {e:#}");
        std::process::exit(2);
    }
}

/// The scene and the path to walk, with the viewport overridden where asked.
fn open(view: &View) -> Result<(hom::scene::Scene, CameraPath)> {
    let (scene, mut path) = hom_walk::open_scene(&view.scene)?;
    if let Some(file) = &view.camera_path {
        path = CameraPath::load(file)?;
    }
    if let Some(w) = view.width {
        path.width = w;
    }
    if let Some(h) = view.height {
        path.height = h;
    }
    path.validate(&view.scene)?;
    Ok((scene, path))
}

/// [`open`] for a Quake 3 map already loaded (for `--pvs`): its scene and its
/// spawn-to-spawn walk, or the `--camera-path` file, with the viewport overridden.
fn open_map_view(view: &View, map: &hom_scene::bsp::BspMap) -> Result<(hom::scene::Scene, CameraPath)> {
    let mut path = match &view.camera_path {
        Some(file) => CameraPath::load(file)?,
        None => match map.camera_path() {
            Some(p) => p,
            None => bail!("{} has no spawn points to walk; give --camera-path", view.scene),
        },
    };
    if let Some(w) = view.width {
        path.width = w;
    }
    if let Some(h) = view.height {
        path.height = h;
    }
    path.validate(&view.scene)?;
    Ok((map.scene.clone(), path))
}

fn make_culler(name: &str, scene: &hom::scene::Scene, hom: &HomArgs) -> Result<Box<dyn hom::cull::Culler>> {
    if name == "hv" {
        let mut c = hom::cull::HvConfig::default();
        if let Some(t) = hom.hv_threshold {
            if t == 0 {
                bail!("--hv-threshold must be at least 1");
            }
            c.octree.threshold = t;
        }
        if let Some(d) = hom.hv_max_depth {
            c.octree.max_depth = d;
        }
        c.octree.keep_large = hom.hv_keep_large;
        return Ok(Box::new(hom::cull::HvCuller::new(scene, c)));
    }
    match cullers::make_with(name, scene, &hom.config(scene)?) {
        Some(c) => Ok(c),
        None => bail!("unknown culler '{name}'; available: {}", cullers::names()),
    }
}

fn progress(len: usize, what: &str) -> ProgressBar {
    // Draws only on a terminal; quiet when piped.
    let bar = ProgressBar::new(len as u64);
    bar.set_style(
        ProgressStyle::with_template("{prefix:>12} [{bar:40}] {pos}/{len} frames, {eta} left")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar.set_prefix(what.to_string());
    bar
}

/// Walks with progress on a terminal; with `report`, streams the JSON-lines
/// report (header, frames, summary) as it goes.
fn run_walk(
    scene: &mut hom::scene::Scene,
    path: &CameraPath,
    culler_name: &str,
    hom: &HomArgs,
    renderer: &Renderer,
    options: &WalkOptions,
    mut report: Option<&mut dyn Write>,
) -> Result<WalkResult> {
    run_walk_pvs(scene, path, culler_name, hom, renderer, options, report.take(), None).map(|(r, _)| r)
}

/// [`run_walk`], measuring each frame against `pvs` (a Quake 3 map whose scene is
/// `scene`) where given: the report's frame and summary lines gain `pvs_` fields.
#[allow(clippy::too_many_arguments)]
fn run_walk_pvs(
    scene: &mut hom::scene::Scene,
    path: &CameraPath,
    culler_name: &str,
    hom: &HomArgs,
    renderer: &Renderer,
    options: &WalkOptions,
    mut report: Option<&mut dyn Write>,
    pvs: Option<&hom_scene::bsp::BspMap>,
) -> Result<(WalkResult, Option<PvsSummary>)> {
    let mut culler = make_culler(culler_name, scene, hom)?;
    if let Some(out) = report.as_deref_mut() {
        let header = report::Header::new(
            scene,
            path,
            culler.as_ref(),
            renderer.threads(),
            options.frame_count(path),
            options.oracle,
        );
        report::write_line(out, &header).context("writing the report")?;
    }
    let bar = progress(options.frame_count(path), culler_name);
    let mut io_error = None;
    let mut pvs_frames = Vec::new();
    let result = hom_walk::walk(scene, path, culler.as_mut(), renderer, options, |record| {
        bar.inc(1);
        // The map's scene is the walked one (Quake 3 maps are static).
        let frame = pvs.map(|map| pvs::pvs_for_record(map, &map.scene, &path.camera(record.frame), record));
        if let Some(out) = report.as_deref_mut() {
            let written = match &frame {
                Some(f) => report::write_line(out, &pvs::FrameWithPvs { record, pvs: f }),
                None => report::write_line(out, record),
            };
            if let Err(e) = written {
                io_error.get_or_insert(e);
            }
        }
        pvs_frames.extend(frame);
    });
    bar.finish_and_clear();
    let result = result?;
    let pvs_summary = pvs.map(|_| pvs::summarize_pvs(&pvs_frames));
    if let Some(out) = report {
        if let Some(e) = io_error {
            return Err(e).context("writing the report");
        }
        match &pvs_summary {
            Some(p) => report::write_line(
                out,
                &pvs::SummaryWithPvs {
                    summary: &result.summary,
                    pvs: p,
                },
            ),
            None => report::write_line(out, &result.summary),
        }
        .context("writing the report")?;
        out.flush().context("writing the report")?;
    }
    Ok((result, pvs_summary))
}

fn walk(a: WalkArgs) -> Result<()> {
    let map = if a.pvs {
        let (file, _) = hom_scene::split_map_spec(Path::new(&a.view.scene));
        let ext = file.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        if !matches!(ext.as_deref(), Some("bsp") | Some("pk3")) {
            bail!(
                "--pvs needs a Quake 3 map (.bsp, .pk3 or FILE.pk3:MAP), which carries a PVS; '{}' is not one",
                a.view.scene
            );
        }
        Some(hom_walk::pvs::open_map(&a.view.scene)?)
    } else {
        None
    };
    let (mut scene, path) = match &map {
        Some(m) => open_map_view(&a.view, m)?,
        None => open(&a.view)?,
    };
    if a.frames == Some(0) {
        bail!("--frames must be at least 1");
    }
    let renderer = Renderer::new(a.view.threads)?;
    let options = WalkOptions {
        frames: a.frames,
        oracle: a.oracle || a.pvs,
        ..WalkOptions::default()
    };
    let mut file = match &a.report {
        Some(p) => Some(create_report(p)?),
        None => None,
    };
    let (result, pvs_summary) = run_walk_pvs(
        &mut scene,
        &path,
        &a.view.culler,
        &a.view.hom,
        &renderer,
        &options,
        file.as_mut().map(|f| f as &mut dyn Write),
        map.as_ref(),
    )
    .with_context(|| match &a.report {
        Some(p) => format!("walking {} (report {})", a.view.scene, p.display()),
        None => format!("walking {}", a.view.scene),
    })?;
    if let Some(p) = &a.report {
        eprintln!("report: {}", p.display());
    }
    print_table(&scene, &[(&a.view.culler, &result)]);
    if let Some(p) = &pvs_summary {
        print!("{}", p.table());
    }
    if let Some(dir) = &a.plots {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let plot = dir.join("frame_times.png");
        pictures::plot_frame_times(&plot, &result.frames, &a.view.culler)?;
        let stages = dir.join("stages.png");
        write_stage_chart(&stages, &[(&a.view.culler, &result)])?;
        let frame = busiest_frame(&result.frames);
        let picture = dir.join(format!("false_colour_frame{frame}.png"));
        let frame_rate = WalkOptions::default().frame_rate;
        let pyramid = write_false_colour(
            &mut scene,
            &path,
            &a.view.culler,
            &a.view.hom,
            frame,
            &renderer,
            &picture,
            frame_rate,
        )?;
        if let Some(p) = pyramid {
            let hole = a.view.hom.config(&scene)?.selection.hole_opacity;
            pictures::write_pyramid_levels(&dir.join(format!("pyramid_frame{frame}.png")), &p, hole)?;
        }
        eprintln!("pictures: {}", dir.display());
    }
    Ok(())
}

fn create_report(path: &Path) -> Result<BufWriter<std::fs::File>> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let f = std::fs::File::create(path).with_context(|| format!("creating report {}", path.display()))?;
    Ok(BufWriter::new(f))
}

fn fmt_opt(v: Option<f64>, digits: usize) -> String {
    v.map(|x| format!("{x:.digits$}")).unwrap_or_else(|| "-".into())
}

fn print_table(scene: &hom::scene::Scene, rows: &[(&str, &WalkResult)]) {
    println!(
        "scene {}: {} objects, {} triangles ({} dynamic objects)",
        scene.name(),
        scene.objects().len(),
        scene.triangle_count(),
        scene.dynamic_count()
    );
    println!(
        "{:<10} {:>6} {:>10} {:>9} {:>11} {:>9} {:>10} {:>10} {:>10} {:>8} {:>8}",
        "culler",
        "frames",
        "tris drawn",
        "% culled",
        "false culls",
        "effic. %",
        "cull ms",
        "render ms",
        "frame ms",
        "speedup",
        "oracle×"
    );
    for (name, r) in rows {
        let s: &Summary = &r.summary;
        println!(
            "{:<10} {:>6} {:>10.0} {:>9.1} {:>11} {:>9} {:>10.2} {:>10.2} {:>10.2} {:>8} {:>8}",
            name,
            s.frames,
            s.median_triangles_drawn,
            s.median_pct_triangles_culled,
            s.false_culls.map(|n| n.to_string()).unwrap_or_else(|| "-".into()),
            fmt_opt(s.efficiency.map(|e| e * 100.0), 1),
            s.median_stage_ms.get("cull").copied().unwrap_or(0.0),
            s.median_stage_ms.get("render").copied().unwrap_or(0.0),
            s.median_frame_ms,
            fmt_opt(s.speedup, 2),
            fmt_opt(s.oracle_speedup, 2),
        );
    }
    println!("(medians over frames; speedup = frustum-only frame time ÷ frame time; oracle× = the best any culler could reach)");
}

fn demo(a: DemoArgs) -> Result<()> {
    let view = View {
        scene: "city".into(),
        camera_path: None,
        width: Some(a.width),
        height: Some(a.height),
        culler: cullers::BEST.into(),
        threads: 0,
        hom: HomArgs::default(),
    };
    let (mut scene, path) = open(&view)?;
    let renderer = Renderer::new(0)?;
    let options = WalkOptions {
        frames: a.frames,
        oracle: true,
        ..WalkOptions::default()
    };
    let mut names = vec!["frustum"];
    if cullers::BEST != "frustum" {
        names.push(cullers::BEST);
    }
    let mut results = Vec::new();
    for name in &names {
        results.push(run_walk(&mut scene, &path, name, &view.hom, &renderer, &options, None)?);
    }
    let rows: Vec<(&str, &WalkResult)> = names.iter().copied().zip(results.iter()).collect();
    print_table(&scene, &rows);

    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    let best = results.last().expect("at least one walk");
    let plot = a.out.join("frame_times.png");
    pictures::plot_frame_times(&plot, &best.frames, cullers::BEST)?;
    // The frame where the best culler culled the most as occluded shows it best.
    let frame = busiest_frame(&best.frames);
    let picture = a.out.join(format!("false_colour_frame{frame}.png"));
    let pyramid = write_false_colour(
        &mut scene,
        &path,
        cullers::BEST,
        &view.hom,
        frame,
        &renderer,
        &picture,
        options.frame_rate,
    )?;
    let stages = a.out.join("stages.png");
    write_stage_chart(&stages, &rows)?;
    println!("pictures in {}:", a.out.display());
    println!(
        "  {} (occluders blue, drawn grey, occlusion-culled red)",
        picture.display()
    );
    println!(
        "  {} (frame time and % culled per frame, with and without occlusion culling)",
        plot.display()
    );
    println!("  {} (time per stage, % of frustum-only frame time)", stages.display());
    if let Some(p) = pyramid {
        let levels = a.out.join(format!("pyramid_frame{frame}.png"));
        pictures::write_pyramid_levels(&levels, &p, HomConfig::default().selection.hole_opacity)?;
        println!("  {} (the occlusion map pyramid, holes in blue)", levels.display());
    }
    Ok(())
}

fn bench(a: BenchArgs) -> Result<()> {
    if a.kind == BenchKind::Raster {
        return bench_raster(a);
    }
    let scenes: Vec<String> = if a.scenes.is_empty() {
        hom_scene::BUILTIN_SCENES.iter().map(|(n, _)| n.to_string()).collect()
    } else {
        a.scenes.clone()
    };
    let scene_refs: Vec<&str> = scenes.iter().map(String::as_str).collect();
    let culler_refs: Vec<&str> = a.cullers.iter().map(String::as_str).collect();
    let options = hom_walk::bench::BenchOptions {
        frames: a.frames,
        width: a.width,
        height: a.height,
        threads: a.threads,
    };
    let report = hom_walk::bench::run_bench(&scene_refs, &culler_refs, &options, |what| {
        if std::io::IsTerminal::is_terminal(&std::io::stderr()) {
            eprintln!("{what}");
        }
    })?;
    print!("{}", report.table());
    if let Some(dir) = a.json.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let json = serde_json::to_string_pretty(&report).context("serializing the bench report")?;
    std::fs::write(&a.json, json).with_context(|| format!("writing {}", a.json.display()))?;
    let chart = a.json.with_file_name("stages.png");
    pictures::plot_stage_breakdown(&chart, &report.stage_bars())?;
    println!("json: {}\nstage chart: {}", a.json.display(), chart.display());
    Ok(())
}

fn bench_raster(a: BenchArgs) -> Result<()> {
    let options = hom_walk::raster_bench::RasterBenchOptions {
        data: a.data,
        runs: a.runs,
        threads: a.raster_threads,
    };
    let report = hom_walk::raster_bench::run_raster_bench(&options, |what| {
        if std::io::IsTerminal::is_terminal(&std::io::stderr()) {
            eprintln!("{what}");
        }
    })?;
    print!("{}", report.table());
    let json = a.json.with_file_name("raster.json");
    if let Some(dir) = json.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let text = serde_json::to_string_pretty(&report).context("serializing the raster bench report")?;
    std::fs::write(&json, text).with_context(|| format!("writing {}", json.display()))?;
    println!("json: {}", json.display());
    Ok(())
}

fn busiest_frame(frames: &[FrameRecord]) -> usize {
    frames
        .iter()
        .max_by_key(|f| (f.triangles_occlusion_culled, std::cmp::Reverse(f.frame)))
        .map_or(0, |f| f.frame)
}

/// Culls frame `frame` with the named culler and writes it in false colour to
/// `out`. With HOM, also returns that frame's occlusion pyramid (for pictures).
#[allow(clippy::too_many_arguments)]
fn write_false_colour(
    scene: &mut hom::scene::Scene,
    path: &CameraPath,
    culler_name: &str,
    hom: &HomArgs,
    frame: usize,
    renderer: &Renderer,
    out: &Path,
    frame_rate: f32,
) -> Result<Option<hom::map::Pyramid>> {
    scene.set_time(frame as f32 / frame_rate);
    let camera = path.camera(frame);
    let mut cull = CullOutput::default();
    let pyramid = if culler_name == "hom" {
        let mut culler = HomCuller::new(scene, hom.config(scene)?);
        renderer.install(|| culler.cull(scene, &camera, &mut cull))?;
        culler.pyramid().cloned()
    } else {
        let mut culler = make_culler(culler_name, scene, hom)?;
        renderer.install(|| culler.cull(scene, &camera, &mut cull))?;
        None
    };
    let mut fb = Framebuffer::new(camera.width, camera.height);
    let image = pictures::render_false_colour(renderer, scene, &camera, &cull, &mut fb);
    hom_render::write_png(out, camera.width, camera.height, &image)?;
    Ok(pyramid)
}

/// The stage chart of walks: each culler's median stages against frustum-only frames.
fn write_stage_chart(out: &Path, rows: &[(&str, &WalkResult)]) -> Result<()> {
    let bars: Vec<pictures::StageBar> = rows
        .iter()
        .filter_map(|(name, r)| {
            Some(pictures::StageBar {
                label: name.to_string(),
                stages_ms: r.summary.median_stage_ms.clone(),
                baseline_ms: r.summary.median_baseline_frame_ms?,
            })
        })
        .collect();
    pictures::plot_stage_breakdown(out, &bars)?;
    Ok(())
}

fn render(a: RenderArgs) -> Result<()> {
    let (mut scene, path) = open(&a.view)?;
    if a.frame >= path.frames.len() {
        bail!(
            "--frame {} is past the end of the path ({} frames)",
            a.frame,
            path.frames.len()
        );
    }
    let renderer = Renderer::new(a.view.threads)?;
    let frame_rate = WalkOptions::default().frame_rate;
    if a.false_colour {
        write_false_colour(
            &mut scene,
            &path,
            &a.view.culler,
            &a.view.hom,
            a.frame,
            &renderer,
            &a.out,
            frame_rate,
        )?;
    } else {
        scene.set_time(a.frame as f32 / frame_rate);
        let camera = path.camera(a.frame);
        let mut culler = make_culler(&a.view.culler, &scene, &a.view.hom)?;
        let mut cull = CullOutput::default();
        culler.cull(&scene, &camera, &mut cull)?;
        let mut fb = Framebuffer::new(camera.width, camera.height);
        renderer.render(&scene, &cull.visible, &camera, &RenderOptions::default(), &mut fb);
        fb.save_png(&a.out)?;
    }
    println!("wrote {}", a.out.display());
    Ok(())
}

fn scenes() -> Result<()> {
    println!(
        "{:<14} {:>8} {:>10} {:>8}  description",
        "name", "objects", "triangles", "frames"
    );
    for (name, description) in hom_scene::BUILTIN_SCENES {
        let b = hom_scene::builtin(name)?;
        println!(
            "{:<14} {:>8} {:>10} {:>8}  {}",
            name,
            b.scene.objects().len(),
            b.scene.triangle_count(),
            b.path.frames.len(),
            description
        );
    }
    Ok(())
}

fn scene_info(spec: &str) -> Result<()> {
    let (scene, path) = hom_walk::open_scene(spec)?;
    let b = scene.bounds();
    let dynamic = scene.dynamic_count();
    let max_tris = scene.objects().iter().map(|o| o.triangles).max().unwrap_or(0);
    println!("scene:      {}", scene.name());
    println!("objects:    {} ({dynamic} dynamic)", scene.objects().len());
    println!("meshes:     {}", scene.meshes().len());
    println!("triangles:  {}", scene.triangle_count());
    println!(
        "per object: {:.0} triangles on average, {max_tris} at most",
        scene.triangle_count() as f64 / scene.objects().len() as f64
    );
    println!("bounds:     {:?} .. {:?}", b.min.to_array(), b.max.to_array());
    println!(
        "path:       {} frames at {}x{}",
        path.frames.len(),
        path.width,
        path.height
    );
    Ok(())
}

fn scene_export(spec: &str, out: &Path) -> Result<()> {
    let (scene, _) = hom_walk::open_scene(spec)?;
    hom_scene::export::write_obj(&scene, out)?;
    println!(
        "wrote {} ({} objects, {} triangles)",
        out.display(),
        scene.objects().len(),
        scene.triangle_count()
    );
    Ok(())
}
