//! What the plugin's test files share.

use bevy::app::App;
use bevy::asset::AssetPlugin;
use bevy::camera::CameraPlugin;
use bevy::mesh::MeshPlugin;
use bevy::prelude::{TaskPoolPlugin, TransformPlugin};
use hom_bevy::HomOcclusionPlugin;

/// A headless app with the plugin: transforms, meshes, cameras and their
/// visibility; no window, no renderer.
pub fn app() -> App {
    let mut app = App::new();
    app.add_plugins((
        TaskPoolPlugin::default(),
        TransformPlugin,
        AssetPlugin::default(),
        MeshPlugin,
        CameraPlugin,
        HomOcclusionPlugin,
    ));
    app
}
