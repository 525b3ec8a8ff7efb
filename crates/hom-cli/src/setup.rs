//! What every command sets up: the scene and its camera path with the
//! viewport overridden, the culler, and the progress bar.

use crate::args::{HomArgs, RendererArg, View};
use anyhow::{bail, Context, Result};
use hom::cull::{Coherence, Culler};
use hom::experimental::HvPriming;
use hom::glam::Vec3;
use hom::occlusion::Opacity;
use hom::scene::Scene;
use hom_scene::bsp::BspMap;
use hom_scene::{Animation, CameraPath};
use hom_walk::bench::MakeFrameDraw;
use hom_walk::cullers::{self, CullerSettings};
#[cfg(feature = "view")]
use hom_walk::{DrawError, FrameDraw};
use indicatif::{ProgressBar, ProgressStyle};

/// A scene, the camera path through it and how its objects move.
pub struct Walkthrough {
    /// The scene.
    pub scene: Scene,
    /// The path to walk.
    pub path: CameraPath,
    /// The motion of its dynamic objects.
    pub animation: Animation,
}

impl Walkthrough {
    /// Moves the scene to frame `frame` at `frame_rate` frames per second.
    pub fn go_to(&mut self, frame: usize, frame_rate: f32) {
        self.animation.apply(&mut self.scene, frame as f32 / frame_rate);
    }
}

/// The scene and the path to walk, with the viewport overridden where asked.
pub fn open(view: &View) -> Result<Walkthrough> {
    let mut opened = hom_walk::open_walk_with(&view.scene, &view.clusters.load_options())?;
    if let Some(file) = &view.camera_path {
        opened = opened.along(file)?;
    }
    let hom_walk::OpenedScene {
        scene,
        mut path,
        animation,
        ..
    } = opened;
    adjust_path(view, &mut path);
    path.validate(&view.scene)?;
    Ok(Walkthrough { scene, path, animation })
}

/// [`open`] for a Quake 3 map already loaded (for `--pvs`): its scene and its
/// spawn-to-spawn walk, or the `--camera-path` file, with the viewport overridden.
pub fn open_map_view(view: &View, map: &BspMap) -> Result<Walkthrough> {
    let mut path = match &view.camera_path {
        Some(file) => CameraPath::load(file)?,
        None => match map.camera_path() {
            Some(p) => p,
            None => bail!("{} has no spawn points to walk; give --camera-path", view.scene),
        },
    };
    adjust_path(view, &mut path);
    path.validate(&view.scene)?;
    Ok(Walkthrough {
        scene: map.scene.clone(),
        path,
        animation: Animation::none(),
    })
}

/// The viewport overrides, then the speed and cuts variants of the path.
fn adjust_path(view: &View, path: &mut CameraPath) {
    if let Some(k) = view.speed {
        *path = path.at_speed(k);
    }
    if let Some(n) = view.cuts {
        *path = path.with_cuts(n);
    }
    if let Some(w) = view.width {
        path.width = w;
    }
    if let Some(h) = view.height {
        path.height = h;
    }
}

/// The settings of every culler for `scene`, with the flags applied (all of
/// them are checked, whichever culler runs).
pub fn culler_settings(args: &HomArgs, scene: &Scene) -> Result<CullerSettings> {
    let mut settings = CullerSettings::for_scene(scene);
    let c = &mut settings.hom;
    if let Some(b) = args.budget {
        c.occluders.selection.budget = b;
    }
    c.occluders.selection.adaptive = args.adaptive_budget;
    if let Some(m) = args.occluders {
        c.occluders.occluder_db.meshes = m.meshes();
    }
    c.occluders.selection.hole_filling = !args.no_hole_filling;
    if let Some(o) = args.opacity {
        if !(o > 0.0 && o <= 1.0) {
            bail!("--opacity must be in (0, 1], got {o}");
        }
        c.buffer.opacity = if o == 1.0 {
            Opacity::Conservative
        } else {
            Opacity::Threshold(o)
        };
    }
    if let Some(d) = args.depth {
        c.buffer.depth = d.mode();
    }
    if let Some(m) = args.map_size {
        if !(1..=4096).contains(&m) {
            bail!("--map-size must be 1..=4096, got {m}");
        }
        c.buffer.map_size = m;
    }
    if let Some(s) = args.selection {
        c.occluders.selection.mode = s.mode();
    }
    if let Some(m) = args.coherence {
        c.coherence = m.mode(args.p_skip);
        settings.hv.coherence = c.coherence;
    }
    c.cost_model = !args.no_cost_model;
    if let Some(d) = args.depth_check {
        c.depth_check = d;
    }
    if let Some(h) = args.hierarchy {
        c.hierarchy = h;
    }
    if args.p_skip.is_some() && !matches!(c.coherence, Coherence::Skip(_)) {
        bail!("--p-skip needs --coherence skip");
    }
    let octree = &mut settings.hv.octree;
    if let Some(t) = args.hv_threshold {
        if t == 0 {
            bail!("--hv-threshold must be at least 1");
        }
        octree.threshold = t;
    }
    if let Some(d) = args.hv_max_depth {
        octree.max_depth = d;
    }
    octree.keep_large = args.hv_keep_large;
    settings.hv.priming = args.hv_priming.then_some(HvPriming);
    Ok(settings)
}

/// The culler called `name` for `scene`, with the flags applied.
pub fn make_culler(name: &str, scene: &Scene, args: &HomArgs) -> Result<Box<dyn Culler>> {
    Ok(cullers::make(name, scene, &culler_settings(args, scene)?)?)
}

/// The culler `name`, behind the baked PVS `pvs` where given (PVS then the culler).
pub fn make_culler_after_pvs(
    name: &str,
    scene: &Scene,
    args: &HomArgs,
    pvs: Option<&std::sync::Arc<hom::pvs::Pvs>>,
) -> Result<Box<dyn Culler>> {
    let culler = make_culler(name, scene, args)?;
    Ok(match pvs {
        Some(p) => Box::new(hom::cull::PvsCuller::new(scene, p.clone(), culler)?),
        None => culler,
    })
}

/// A progress bar over `len` frames, labelled `what`.
pub fn progress(len: usize, what: &str) -> ProgressBar {
    progress_of(len, what, "frames")
}

/// A progress bar over `len` `units` (frames, meshes, blocks), labelled `what`.
pub fn progress_of(len: usize, what: &str, units: &str) -> ProgressBar {
    // Draws only on a terminal; quiet when piped.
    let bar = ProgressBar::new(len as u64);
    bar.set_style(
        ProgressStyle::with_template(&format!(
            "{{prefix:>12}} [{{bar:40}}] {{pos}}/{{len}} {units}, {{eta}} left"
        ))
        .expect("valid template")
        .progress_chars("=> "),
    );
    bar.set_prefix(what.to_string());
    bar
}

/// What a Quake 3 map's clusters see through its leaf portals from the
/// space `path` reaches ([`BspMap::portal_pvs`]), with a progress bar over
/// its leaves.
pub fn follow_portals(map: &BspMap, path: &CameraPath) -> Result<hom_scene::bsp::PortalPvs> {
    let bar = progress_of(0, "portals", "leaves");
    let eyes: Vec<Vec3> = path.frames.iter().map(|f| Vec3::from_array(f.eye)).collect();
    let portals = map
        .portal_pvs(&eyes, &|done, total| {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
        })
        .context("following the map's leaf portals")?;
    bar.finish_and_clear();
    Ok(portals)
}

/// The walk's level of detail from `--lod` and its options: every mesh's
/// hierarchy built (with a progress bar), or `None` without `--lod`.
pub fn lod_for(args: &crate::args::LodArgs, scene: &Scene) -> Result<Option<hom_walk::lod::WalkLod>> {
    use crate::args::OnOff;
    use hom::lod::{LodConfig, LodOptions, SceneLod};
    if !args.lod {
        if args.lod_budget.is_some() {
            bail!("--lod-budget needs --lod");
        }
        return Ok(None);
    }
    let options = LodOptions {
        error_px: args.lod_error,
        budget: args.lod_budget,
        guidance: args.lod_guidance == OnOff::On,
    };
    options.validate()?;
    let bar = progress_of(scene.meshes().len(), "lod", "meshes");
    let start = std::time::Instant::now();
    let hierarchies = SceneLod::build(scene, &LodConfig::default(), &|_, _| bar.inc(1))?;
    bar.finish_and_clear();
    eprintln!(
        "lod: {} meshes in {:.1} s, {:.1} MiB",
        hierarchies.len(),
        start.elapsed().as_secs_f64(),
        hierarchies.heap_bytes() as f64 / (1u64 << 20) as f64
    );
    Ok(Some(hom_walk::lod::WalkLod {
        hierarchies: std::sync::Arc::new(hierarchies),
        options,
        occluders: args.lod_occluders == OnOff::On,
    }))
}

/// What makes `--renderer`'s renderer of a scene's timed frames: `None` for
/// hom's software renderer.
pub fn frame_draw_maker(renderer: RendererArg) -> Result<Option<MakeFrameDraw<'static>>> {
    match renderer {
        RendererArg::Software => Ok(None),
        #[cfg(feature = "view")]
        RendererArg::Wgpu => Ok(Some(&wgpu_draw)),
        #[cfg(not(feature = "view"))]
        RendererArg::Wgpu => {
            bail!("--renderer wgpu needs hom's viewer, and this hom was built without it (hom-cli's `view` feature)")
        }
    }
}

/// `--renderer wgpu`'s renderer for `scene`.
#[cfg(feature = "view")]
fn wgpu_draw(scene: &Scene) -> Result<Box<dyn FrameDraw>, DrawError> {
    Ok(Box::new(hom_view::WgpuDraw::new(scene)?))
}
