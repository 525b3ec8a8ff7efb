//! # hom-walk — the walkthrough harness
//!
//! Runs a [`hom::cull::Culler`] along a camera path through a scene: per frame
//! it culls, renders what the culler keeps with the reference renderer, times
//! every stage, optionally runs the oracle (the item buffer of a full render),
//! and computes the metrics every result in hom is measured with:
//!
//! - **false cull**: an object culled as occluded that owns at least one pixel.
//! - **culling efficiency**: triangles culled as occluded ÷ triangles in the
//!   frustum that the oracle finds invisible.
//! - **speedup**: frame time with frustum culling only ÷ frame time with the
//!   culler (culling included), same renderer, same path, same run.
//! - **oracle speedup**: frame time with frustum culling only ÷ time to render
//!   just the oracle's visible set.
//!
//! Results are [`report`] records, written as JSON lines; [`pictures`] draws
//! false-colour frames and plots; [`pvs`] measures a walk through a Quake 3 map
//! against the map's own potentially visible sets.

#![forbid(unsafe_code)]

pub mod bench;
pub mod cullers;
pub mod lod;
pub mod pictures;
pub mod pvs;
pub mod raster_bench;
pub mod report;
mod stats;
pub mod virtual_occluders;
mod walk;
pub use walk::summarize;

pub use walk::{
    renderer_name, walk, walk_drawn, DrawError, FrameDraw, WalkError, WalkOptions, WalkResult, SOFTWARE_RENDERER,
};

use hom::scene::Scene;
use hom_scene::{Animation, CameraPath, CameraPathError, LoadError};
use std::path::{Path, PathBuf};

/// Where a walk's camera path came from, as the bench names it (its `path`
/// field).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum PathSource {
    /// A built-in scene's own walk.
    Builtin,
    /// A Quake 3 map's walk from spawn point to spawn point.
    SpawnPoints,
    /// A camera path file: `NAME.path.json` beside the scene file
    /// ([`path_file_of`]), or one given with `--camera-path`.
    File(PathBuf),
    /// An orbit around the bounds: a scene file with no path of its own.
    Orbit,
    /// An Extreme Tux Racer course's run down the slope.
    Course,
}

impl std::fmt::Display for PathSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PathSource::Builtin => f.write_str("built-in walk"),
            PathSource::SpawnPoints => f.write_str("spawn points"),
            PathSource::File(p) => write!(f, "{}", p.display()),
            PathSource::Orbit => f.write_str("orbit"),
            PathSource::Course => f.write_str("down the course"),
        }
    }
}

/// A scene opened to be walked: [`open_walk`]'s answer.
pub struct OpenedScene {
    /// The scene.
    pub scene: Scene,
    /// Its default camera path.
    pub path: CameraPath,
    /// How its objects move (files do not move).
    pub animation: Animation,
    /// Where `path` came from.
    pub path_source: PathSource,
}

impl OpenedScene {
    /// The same scene walked along the camera path in `file` instead of its
    /// own (`--camera-path`).
    pub fn along(mut self, file: &Path) -> Result<OpenedScene, CameraPathError> {
        self.path = CameraPath::load(file)?;
        self.path_source = PathSource::File(file.to_path_buf());
        Ok(self)
    }
}

/// The camera path file that comes with a scene file: `DIR/NAME.path.json`
/// for `DIR/NAME.EXT`.
pub fn path_file_of(scene_file: &Path) -> PathBuf {
    scene_file.with_extension("path.json")
}

/// A scene, the camera path to walk it and how its objects move: a built-in
/// scene name or a file (files do not move).
///
/// Files get their own walkthrough where they have one: an OBJ or glTF file
/// `DIR/NAME.EXT` the path in `DIR/NAME.path.json` beside it ([`path_file_of`];
/// an unusable one is an error, not skipped), a Quake 3 map its spawn-to-spawn
/// walk ([`hom_scene::load_with_path`]; `FILE.pk3:MAP` names a map in a pk3);
/// any other file an orbit around its bounds ([`CameraPath::orbit`]).
pub fn open_walk(spec: &str) -> Result<OpenedScene, LoadError> {
    open_walk_with(spec, &hom_scene::LoadOptions::default())
}

/// The load options of `--clusters on|off`: scene files cut into
/// cluster-sized objects, or kept whole.
pub fn load_options(clusters: bool) -> hom_scene::LoadOptions {
    let mut options = hom_scene::LoadOptions::default();
    options.split.enabled = clusters;
    options
}

/// [`open_walk`] with the loaders' options (built-in scenes ignore them).
pub fn open_walk_with(spec: &str, options: &hom_scene::LoadOptions) -> Result<OpenedScene, LoadError> {
    let builtins = || hom_scene::BUILTIN_SCENES.iter().chain(hom_scene::SCALE_SCENES);
    if builtins().any(|(n, _)| *n == spec) {
        let b = hom_scene::builtin(spec)?;
        return Ok(OpenedScene {
            scene: b.scene,
            path: b.path,
            animation: b.animation,
            path_source: PathSource::Builtin,
        });
    }
    let file = Path::new(spec);
    if !hom_scene::split_map_spec(file).0.exists() {
        let known: Vec<&str> = builtins().map(|(n, _)| *n).collect();
        return Err(LoadError::UnknownBuiltin {
            name: spec.to_string(),
            known: known.join(", "),
        });
    }
    let loaded = hom_scene::load_with_options(file, options)?;
    let course = hom_scene::etr::is_course_file(file);
    let beside = path_file_of(file);
    let mesh_file = file
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| ["obj", "gltf", "glb"].contains(&e.to_ascii_lowercase().as_str()));
    let (path, path_source) = match loaded.path {
        Some(p) if course => (p, PathSource::Course),
        Some(p) => (p, PathSource::SpawnPoints),
        None if mesh_file && beside.exists() => (CameraPath::load(&beside)?, PathSource::File(beside)),
        None => (CameraPath::orbit(&loaded.scene.bounds(), 120), PathSource::Orbit),
    };
    Ok(OpenedScene {
        scene: loaded.scene,
        path,
        animation: Animation::none(),
        path_source,
    })
}

/// [`open_walk`] as a tuple, for the callers that need no [`PathSource`].
pub fn open_scene(spec: &str) -> Result<(Scene, CameraPath, Animation), LoadError> {
    open_walk(spec).map(|o| (o.scene, o.path, o.animation))
}

/// The README's Rust examples, compiled as doc tests.
#[doc = include_str!("../../../README.md")]
#[cfg(doctest)]
pub struct ReadmeDoctests;
