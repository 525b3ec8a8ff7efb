//! # hom-scene — where scenes come from
//!
//! Loaders for real files (OBJ, glTF 2.0), OBJ export, the built-in generated
//! scenes with their walkthrough camera paths, and camera path files.
//! Every loader converts to hom's conventions (right-handed, +Y up, metres)
//! and returns a typed error naming the file and the problem.

pub mod builtin;
pub mod camera_path;
mod error;
pub mod export;
pub mod gltf;
pub mod moc;
pub mod obj;

pub use builtin::{builtin, builtin_with_seed, Builtin, BUILTIN_SCENES, DEFAULT_SEED};
pub use camera_path::{CameraPath, CameraPathError, PathFrame};
pub use error::LoadError;

use hom::scene::Scene;
use std::path::Path;

/// Loads a scene file, choosing the format by extension (`.obj`, `.gltf`, `.glb`).
pub fn load(path: &Path) -> Result<Scene, LoadError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    match ext.as_deref() {
        Some("obj") => obj::load(path),
        Some("gltf") | Some("glb") => gltf::load(path),
        _ => Err(LoadError::UnknownFormat {
            path: path.display().to_string(),
        }),
    }
}
