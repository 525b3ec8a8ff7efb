//! Built-in scenes. (Being written.)
use crate::{CameraPath, LoadError};
use hom::scene::Scene;
/// A generated scene with the camera path that exercises it.
pub struct Builtin {
    /// The scene.
    pub scene: Scene,
    /// Its walkthrough.
    pub path: CameraPath,
}
/// Names and one-line descriptions of the built-in scenes.
pub const BUILTIN_SCENES: &[(&str, &str)] = &[];
/// Generates the built-in scene `name`.
pub fn builtin(name: &str) -> Result<Builtin, LoadError> {
    Err(LoadError::UnknownBuiltin { name: name.into(), known: String::new() })
}
