//! # hom-scene — where scenes come from
//!
//! Loaders for real files (OBJ, glTF 2.0, Quake 3 maps, Extreme Tux Racer
//! courses), OBJ export, the built-in
//! generated scenes with their walkthrough camera paths, and camera path files.
//! Every loader converts to hom's conventions (right-handed, +Y up, metres)
//! and returns a typed error naming the file and the problem. Files that hold
//! one big mesh are split into spatially coherent objects ([`split`]).

#![forbid(unsafe_code)]

pub mod bsp;
pub mod builtin;
pub mod camera_path;
mod error;
pub mod etr;
pub mod export;
pub mod gltf;
pub mod moc;
pub mod motion;
pub mod obj;
pub mod split;

pub use builtin::{builtin, builtin_with_seed, Builtin, BUILTIN_SCENES, DEFAULT_SEED, SCALE_SCENES};
pub use camera_path::{CameraPath, CameraPathError, PathFrame};
pub use error::LoadError;
pub use motion::{Animation, Motion};

use hom::scene::Scene;
use std::path::{Path, PathBuf};

/// A scene loaded from a file, with the walkthrough the file itself suggests.
#[derive(Clone, Debug)]
pub struct LoadedScene {
    /// The scene.
    pub scene: Scene,
    /// The file's own camera path, where it has one (a Quake 3 map's spawn-to-spawn
    /// walk, [`bsp::BspMap::camera_path`]; an Extreme Tux Racer course's run down
    /// the slope, [`etr::EtrCourse::path`]); `None` for OBJ and glTF.
    pub path: Option<CameraPath>,
}

/// Splits a scene spec into the file and the map inside it: `FILE.pk3:MAP`
/// (the part after the last `:` following `.pk3`, case-insensitive) names map
/// `maps/MAP.bsp` inside the archive. Any other spec is the file alone.
/// A file that exists under the whole name is taken whole.
pub fn split_map_spec(spec: &Path) -> (PathBuf, Option<String>) {
    let s = spec.to_string_lossy();
    if !spec.exists() {
        if let Some(i) = s.to_ascii_lowercase().rfind(".pk3:") {
            let (file, map) = s.split_at(i + 4);
            return (PathBuf::from(file), Some(map[1..].to_owned()));
        }
    }
    (spec.to_path_buf(), None)
}

/// Every map a spec names: `FILE.pk3:*` is each map in the archive
/// (`FILE.pk3:MAP`, sorted by name); any other spec is itself. An archive
/// that holds no map is an error, not an empty list.
pub fn expand_map_specs(spec: &str) -> Result<Vec<String>, LoadError> {
    let Some(file) = spec.strip_suffix(":*") else {
        return Ok(vec![spec.to_owned()]);
    };
    if !file.to_ascii_lowercase().ends_with(".pk3") {
        return Err(LoadError::Malformed {
            path: spec.to_owned(),
            line: None,
            message: "':*' (every map) follows a .pk3 archive only".to_owned(),
        });
    }
    let maps = bsp::pk3_maps(Path::new(file))?;
    if maps.is_empty() {
        return Err(LoadError::Bsp {
            path: file.to_owned(),
            source: bsp::BspError::NoMaps,
        });
    }
    Ok(maps.into_iter().map(|m| format!("{file}:{m}")).collect())
}

/// Loads a scene file, choosing the format by extension (`.obj`, `.gltf`, `.glb`,
/// `.bsp`, `.pk3`; a pk3 with several maps needs `FILE.pk3:MAP`, see [`split_map_spec`];
/// an Extreme Tux Racer course by its `course.dim`, or any `.dim`, see [`etr`]).
/// Default options everywhere; see [`load_with_path`] for the file's own camera path.
pub fn load(path: &Path) -> Result<Scene, LoadError> {
    load_with_path(path).map(|l| l.scene)
}

/// [`load`], keeping the camera path the file suggests (Quake 3 maps: spawn to
/// spawn; Extreme Tux Racer courses: down the slope).
pub fn load_with_path(path: &Path) -> Result<LoadedScene, LoadError> {
    load_with_options(path, &LoadOptions::default())
}

/// What every loader is told: how unstructured geometry and meshes that span
/// the level are cut into objects ([`split`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LoadOptions {
    /// The cut into cluster-sized objects (an Extreme Tux Racer course's
    /// terrain takes only `enabled` from it: [`etr::EtrOptions`] sizes its
    /// clusters); `enabled: false` (`--clusters off`)
    /// keeps whole objects: a Quake 3 map is then its opaque world and its
    /// see-through faces, an Extreme Tux Racer course one terrain, an OBJ or
    /// glTF file the objects it names.
    pub split: split::SplitOptions,
}

/// [`load_with_path`] with options.
pub fn load_with_options(path: &Path, options: &LoadOptions) -> Result<LoadedScene, LoadError> {
    let (file, map) = split_map_spec(path);
    let ext = file
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    let plain = |scene| LoadedScene { scene, path: None };
    let split = options.split.clone();
    if map.is_none() && etr::is_course_file(&file) {
        // A course's terrain keeps its own cluster sizes; only on or off is the caller's.
        let mut course_options = etr::EtrOptions::default();
        course_options.split.enabled = split.enabled;
        let course = etr::load(&file, &course_options)?;
        return Ok(LoadedScene {
            scene: course.scene,
            path: Some(course.path),
        });
    }
    match ext.as_deref() {
        Some("obj") if map.is_none() => obj::load_with(&file, &obj::ObjOptions { split }).map(plain),
        Some("gltf") | Some("glb") if map.is_none() => gltf::load_with(&file, &gltf::GltfOptions { split }).map(plain),
        Some("bsp") | Some("pk3") => {
            let options = bsp::BspOptions {
                map,
                split,
                ..bsp::BspOptions::default()
            };
            let m = bsp::load(&file, &options)?;
            let path = m.camera_path();
            Ok(LoadedScene { scene: m.scene, path })
        }
        _ => Err(LoadError::UnknownFormat {
            path: path.display().to_string(),
        }),
    }
}
