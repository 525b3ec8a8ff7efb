//! # hom-bevy — CPU occlusion culling for bevy
//!
//! [`HomOcclusionPlugin`] removes, from each camera's
//! [`VisibleEntities`](bevy::camera::visibility::VisibleEntities),
//! the meshes hidden behind other meshes, after bevy's own frustum culling
//! ([`VisibilitySystems::CheckVisibility`] in `PostUpdate`). It runs on the
//! CPU, so it works where bevy's GPU occlusion culling does not (WebGL2,
//! mobile GPUs without compute, software renderers), and it never hides a
//! mesh that owns a sample of its occlusion buffer.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use hom_bevy::{HomOcclusionPlugin, OcclusionCulling};
//!
//! fn setup(mut commands: Commands) {
//!     // Every camera with `OcclusionCulling` is culled; the others are left alone.
//!     commands.spawn((Camera3d::default(), OcclusionCulling::default()));
//! }
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, HomOcclusionPlugin))
//!     .add_systems(Startup, setup)
//!     .run();
//! ```
//!
//! ## What it does each frame
//! 1. **Sync** ([`OcclusionSystems::Sync`]): the meshes of the world become
//!    objects of a hom [`Scene`](hom::scene::Scene) ([`OcclusionScene`]):
//!    added, moved, re-meshed and removed as their entities are. Which
//!    entities take part, and which may occlude, is in the `mirror` module's
//!    rules (below).
//! 2. **Cull** ([`OcclusionSystems::Cull`]), per camera with
//!    [`OcclusionCulling`]: hom's scene culler of the chosen buffer (HOM, HZB
//!    or masked) picks this frame's occluders among the meshes in view,
//!    nearest first until the triangle budget is spent (Zhang et al. 1997,
//!    §5.3.2; the selection every hom culler uses), draws them, tests the
//!    others with coherence, and removes the ones it proved hidden from the
//!    camera's `VisibleEntities` (the `Mesh3d` class). It never adds an
//!    entity bevy culled. Statistics go to [`OcclusionStats`].
//!
//! ## Which meshes take part
//! - A [`Mesh3d`] entity whose mesh is a triangle list or strip with its
//!   positions kept in the main world (the default `RenderAssetUsages`).
//! - Not skinned meshes, nor entities with `NoFrustumCulling` or
//!   `NoAutoAabb`: their drawn shape may leave their mesh's own bounds, so
//!   they are never culled by occlusion and never occlude.
//! - Occluders: meshes visible in the hierarchy, on the default render layer
//!   only, not marked [`NeverOccluder`]; every such mesh with
//!   [`OcclusionSettings::auto_occluders`] (the default), else only those
//!   marked [`Occluder`]. An [`Occluder`] may bring a stand-in mesh (a
//!   simpler shape that lies inside the mesh's own volume, as the occluder
//!   meshes Masked Occlusion Culling's users author): it is drawn in the
//!   mesh's place.
//! - A camera whose render layers leave out the default layer is not culled
//!   (the shared occluders might not be drawn by it).
//!
//! ## The guarantee
//! Conservative at the buffer's resolution ([`OcclusionCulling::resolution`]):
//! a mesh any sample of the buffer sees is kept. The buffer may be coarser
//! than the screen; a mesh seen only through a gap narrower than the
//! buffer's samples may then be culled. Give the camera's physical size as
//! the resolution for the screen's own guarantee. Clip space is bevy's:
//! reversed Z, infinite far plane for perspective projections.
//!
//! Occlusion removes a mesh from the camera's list only: it stays in the
//! world, keeps its `ViewVisibility` and casts shadows as before (lights
//! keep their own lists).
//!
//! ## Profiling
//! The `trace` feature puts `tracing` spans around each stage: the plugin's
//! `hom_bevy` spans (`stage` = `sync`, `cull`, `filter`) and, inside the
//! cull, hom's own `hom_cull` spans (selection, raster, traversal, …), which
//! bevy's `trace_tracy` or `trace_chrome` show.

#![forbid(unsafe_code)]

mod cull;
mod mirror;

pub use cull::{CameraOcclusionStats, OcclusionStats};
pub use hom;
pub use mirror::OcclusionScene;

use bevy::app::{App, Plugin, PostUpdate};
use bevy::asset::Handle;
use bevy::camera::visibility::VisibilitySystems;
use bevy::ecs::prelude::*;
use bevy::image::Image;
use bevy::math::UVec2;
use bevy::mesh::{Mesh, Mesh3d};
use bevy::transform::TransformSystems;

/// Which occlusion buffer a camera's culler draws its occluders into.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BufferKind {
    /// Hierarchical occlusion maps (Zhang et al. 1997): coverage pyramid and depth cells.
    Hom,
    /// The hierarchical Z-buffer: per-sample depth.
    Hzb,
    /// Masked occlusion culling: a coverage mask and two depth layers per
    /// tile. hom's default culler: the fastest on the real levels measured.
    #[default]
    Masked,
}

/// Occlusion culling for this camera: add it to a camera entity.
#[derive(Component, Clone, Debug, PartialEq)]
pub struct OcclusionCulling {
    /// The buffer the occluders are drawn into.
    pub buffer: BufferKind,
    /// Occluder triangles drawn per frame; `None`: hom's default for the
    /// scene when the culler is made (1 % of its triangles, 3,000 to 20,000).
    pub budget: Option<u32>,
    /// The buffer's size in samples; `None`: 512 wide, as tall as the
    /// projection's aspect ratio makes it.
    pub resolution: Option<UVec2>,
    /// Where the buffer draws: rayon's pool (the default) or the calling
    /// thread alone (the cull then stays on the bevy thread that runs it).
    pub threads: hom::occlusion::Threads,
}

impl Default for OcclusionCulling {
    fn default() -> Self {
        OcclusionCulling {
            buffer: BufferKind::default(),
            budget: None,
            resolution: None,
            threads: hom::occlusion::Threads::Pool,
        }
    }
}

/// Marks a mesh entity as an occluder (with or without
/// [`OcclusionSettings::auto_occluders`]), optionally drawn as a stand-in.
#[derive(Component, Clone, Debug, Default, PartialEq)]
pub struct Occluder {
    /// A simpler mesh drawn in the entity's place, in its local space. It
    /// must lie inside the volume the entity's own mesh hides (else meshes
    /// seen past the entity may be culled).
    pub stand_in: Option<Handle<Mesh>>,
}

/// Marks a mesh entity that never occludes (glass, foliage, grates); it is still culled when hidden.
#[derive(Component, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NeverOccluder;

/// Writes a camera's occlusion buffer into an image each frame: white where
/// the occluders cover the buffer's samples, black where they do not.
/// The image is resized to the buffer's resolution. For looking, not for
/// speed (one test per sample).
#[derive(Component, Clone, Debug, PartialEq)]
pub struct OcclusionDebugView {
    /// The image written.
    pub image: Handle<Image>,
}

/// Settings shared by every camera.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct OcclusionSettings {
    /// Every mesh may occlude (the selection picks among them each frame);
    /// `false`: only meshes marked [`Occluder`].
    pub auto_occluders: bool,
}

impl Default for OcclusionSettings {
    fn default() -> Self {
        OcclusionSettings { auto_occluders: true }
    }
}

/// The plugin's systems, in `PostUpdate`, after bevy's frustum culling.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum OcclusionSystems {
    /// Keeps [`OcclusionScene`] in step with the world.
    Sync,
    /// Culls each [`OcclusionCulling`] camera's visible meshes.
    Cull,
}

/// Occlusion culling on every camera with [`OcclusionCulling`]; see the crate docs.
#[derive(Clone, Debug, Default)]
pub struct HomOcclusionPlugin;

impl Plugin for HomOcclusionPlugin {
    fn build(&self, app: &mut App) {
        app.init_resource::<OcclusionSettings>()
            .init_resource::<OcclusionScene>()
            .init_resource::<OcclusionStats>()
            .init_resource::<cull::Cullers>()
            .configure_sets(
                PostUpdate,
                (
                    // After the hierarchy's visibility: hidden meshes must not occlude.
                    OcclusionSystems::Sync
                        .after(TransformSystems::Propagate)
                        .after(VisibilitySystems::VisibilityPropagate),
                    OcclusionSystems::Cull
                        .after(OcclusionSystems::Sync)
                        .after(VisibilitySystems::CheckVisibility)
                        .before(VisibilitySystems::MarkNewlyHiddenEntitiesInvisible),
                ),
            )
            .add_systems(
                PostUpdate,
                (
                    mirror::sync_scene.in_set(OcclusionSystems::Sync),
                    (cull::cull_cameras, cull::debug_views)
                        .chain()
                        .in_set(OcclusionSystems::Cull),
                ),
            );
    }
}

/// The class of entities the plugin culls in [`bevy::camera::visibility::VisibleEntities`].
fn mesh_class() -> std::any::TypeId {
    std::any::TypeId::of::<Mesh3d>()
}
