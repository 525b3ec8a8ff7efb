//! OBJ loading. (Being written.)
use crate::LoadError;
use hom::scene::Scene;
use std::path::Path;
/// Loads an OBJ file.
pub fn load(path: &Path) -> Result<Scene, LoadError> {
    Err(LoadError::UnknownFormat { path: path.display().to_string() })
}
