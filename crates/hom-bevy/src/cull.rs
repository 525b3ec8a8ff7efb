//! Each camera's cull: hom's scene culler over [`OcclusionScene`], then
//! the hidden meshes out of the camera's `VisibleEntities`.

use crate::mirror::OcclusionScene;
use crate::{mesh_class, BufferKind, OcclusionCulling, OcclusionDebugView};
use bevy::asset::{Assets, RenderAssetUsages};
use bevy::camera::visibility::{RenderLayers, VisibleEntities};
use bevy::camera::{Camera, Projection};
use bevy::ecs::entity::EntityHashMap;
use bevy::ecs::prelude::*;
use bevy::image::Image;
use bevy::platform::cell::SyncCell;
use bevy::transform::components::GlobalTransform;
use hom::cull::{CullOutput, Culler, HomConfig, HomCuller, HzbCuller, MaskedCuller};
use hom::geom::{ClipConvention, View};
use hom::glam::Mat4;
use hom::occlusion::OcclusionBuffer;
use hom::scene::Scene;
use std::time::Instant;
use wgpu_types::{Extent3d, TextureDimension, TextureFormat};

/// The buffer width when [`OcclusionCulling::resolution`] is `None`.
const DEFAULT_WIDTH: u32 = 512;

/// What the plugin did for one camera in the last frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CameraOcclusionStats {
    /// Meshes bevy's frustum culling kept that hom knows: the candidates.
    pub tested: u32,
    /// Of those, removed as hidden behind occluders.
    pub occluded: u32,
    /// Meshes drawn as occluders.
    pub occluders: u32,
    /// Their triangles.
    pub occluder_triangles: u64,
    /// Milliseconds in hom's cull (selection, raster, traversal, tests).
    pub cull_ms: f64,
    /// Milliseconds of the plugin's own work for this camera around the cull:
    /// the view, and taking the hidden meshes out of its list.
    pub plugin_ms: f64,
    /// The buffer's size in samples.
    pub resolution: (u32, u32),
}

/// What the plugin did in the last frame, per camera.
#[derive(Resource, Clone, Debug, Default)]
pub struct OcclusionStats {
    /// Each culled camera's figures.
    pub cameras: EntityHashMap<CameraOcclusionStats>,
    /// Milliseconds keeping hom's scene in step with the world.
    pub sync_ms: f64,
    /// Entities taking part (hom objects with an entity).
    pub entities: u32,
}

/// Each culled camera's culler.
#[derive(Resource, Default)]
pub(crate) struct Cullers(EntityHashMap<SyncCell<CameraCuller>>);

/// A camera's culler, the settings it was made with, and its reused output.
struct CameraCuller {
    made_with: OcclusionCulling,
    culler: AnyCuller,
    out: CullOutput,
    /// Scratch: `true` for the objects culled this frame (cleared after use).
    hidden: Vec<bool>,
    /// Whether the last cull drew its buffer (not when the view was refused).
    drawn: bool,
}

/// hom's culler for each [`BufferKind`] (typed, for the debug view's buffer).
enum AnyCuller {
    Hom(HomCuller),
    Hzb(HzbCuller),
    Masked(MaskedCuller),
}

impl AnyCuller {
    /// A culler as `settings` asks, for `scene` as it is now.
    fn new(settings: &OcclusionCulling, scene: &Scene) -> AnyCuller {
        let mut config = HomConfig::for_scene(scene);
        if let Some(budget) = settings.budget {
            let selection = &mut config.occluders.selection;
            selection.budget = budget;
            selection.budget_range.0 = selection.budget_range.0.min(budget);
            selection.budget_range.1 = selection.budget_range.1.max(budget);
        }
        // The cost model learns from frame times; bevy draws on the GPU, out of its sight.
        config.cost_model = false;
        config.threads = settings.threads;
        match settings.buffer {
            BufferKind::Hom => AnyCuller::Hom(HomCuller::new(scene, config)),
            BufferKind::Hzb => AnyCuller::Hzb(HzbCuller::new(scene, config.with_buffer(()))),
            BufferKind::Masked => AnyCuller::Masked(MaskedCuller::new(scene, config.with_buffer(()))),
        }
    }

    fn culler(&mut self) -> &mut dyn Culler {
        match self {
            AnyCuller::Hom(c) => c,
            AnyCuller::Hzb(c) => c,
            AnyCuller::Masked(c) => c,
        }
    }

    fn buffer(&mut self) -> Option<&mut dyn OcclusionBuffer> {
        match self {
            AnyCuller::Hom(c) => c.buffer_mut().map(|b| b as &mut dyn OcclusionBuffer),
            AnyCuller::Hzb(c) => c.buffer_mut().map(|b| b as &mut dyn OcclusionBuffer),
            AnyCuller::Masked(c) => c.buffer_mut().map(|b| b as &mut dyn OcclusionBuffer),
        }
    }
}

/// A camera's parts the cull reads.
type CameraParts<'a> = (
    Entity,
    &'a Camera,
    &'a Projection,
    &'a GlobalTransform,
    &'a OcclusionCulling,
    Option<&'a RenderLayers>,
    &'a mut VisibleEntities,
);

/// Culls every [`OcclusionCulling`] camera's visible meshes.
pub(crate) fn cull_cameras(
    mut cullers: ResMut<Cullers>,
    mirror: Res<OcclusionScene>,
    mut stats: ResMut<OcclusionStats>,
    mut cameras: Query<CameraParts>,
    mut removed: RemovedComponents<OcclusionCulling>,
) {
    for camera in removed.read() {
        cullers.0.remove(&camera);
        stats.cameras.remove(&camera);
    }
    stats.sync_ms = mirror.sync_ms;
    stats.entities = mirror.entity_count() as u32;
    let scene = &mirror.scene;
    for (entity, camera, projection, transform, settings, layers, mut visible) in &mut cameras {
        let start = Instant::now();
        // A camera that leaves out the default layer may not draw the shared occluders.
        if !camera.is_active || layers.is_some_and(|l| !l.intersects(&RenderLayers::default())) {
            stats.cameras.remove(&entity);
            continue;
        }
        let slot = cullers.0.entry(entity).or_insert_with(|| {
            SyncCell::new(CameraCuller {
                made_with: settings.clone(),
                culler: AnyCuller::new(settings, scene),
                out: CullOutput::default(),
                hidden: Vec::new(),
                drawn: false,
            })
        });
        let c = slot.get();
        if c.made_with != *settings {
            c.made_with = settings.clone();
            c.culler = AnyCuller::new(settings, scene);
        }
        let (width, height) = resolution(settings, camera, projection);
        let view = View::new(
            world_to_clip(camera, projection, transform),
            width,
            height,
            ClipConvention::ReversedZ,
        );
        #[cfg(feature = "trace")]
        let span = tracing::info_span!("hom_bevy", stage = "cull").entered();
        let cull_start = Instant::now();
        let culled = c.culler.culler().cull(scene, &view, &mut c.out);
        c.culler.culler().frame_done(None);
        let cull_ms = cull_start.elapsed().as_secs_f64() * 1e3;
        #[cfg(feature = "trace")]
        drop(span);
        c.drawn = culled.is_ok();
        if culled.is_err() {
            // A view hom refuses (a NaN matrix, a window minimized to no
            // pixels): bevy's frustum culling stands alone this frame.
            stats.cameras.remove(&entity);
            continue;
        }
        #[cfg(feature = "trace")]
        let _span = tracing::info_span!("hom_bevy", stage = "filter").entered();
        c.hidden.resize(scene.objects().len(), false);
        for &id in &c.out.occluded {
            c.hidden[id as usize] = true;
        }
        let list = visible.get_mut(mesh_class());
        let before = list.len();
        let mut tested = 0u32;
        // `retain` keeps the order: bevy's lists stay sorted.
        list.retain(|e| match mirror.tracked.get(e) {
            Some(t) => {
                tested += 1;
                !c.hidden[t.object as usize]
            }
            None => true,
        });
        let occluded = (before - list.len()) as u32;
        for &id in &c.out.occluded {
            c.hidden[id as usize] = false;
        }
        let occluder_triangles = c.out.stats.occluders.as_ref().map_or(0, |o| o.triangles);
        let total_ms = start.elapsed().as_secs_f64() * 1e3;
        stats.cameras.insert(
            entity,
            CameraOcclusionStats {
                tested,
                occluded,
                occluders: c.out.occluders.len() as u32,
                occluder_triangles,
                cull_ms,
                plugin_ms: total_ms - cull_ms,
                resolution: (width, height),
            },
        );
    }
}

/// The buffer size for a camera: its setting, or [`DEFAULT_WIDTH`] wide at
/// the aspect of the camera's viewport (or projection, before it has one).
fn resolution(settings: &OcclusionCulling, camera: &Camera, projection: &Projection) -> (u32, u32) {
    if let Some(r) = settings.resolution {
        return (r.x.max(1), r.y.max(1));
    }
    let aspect = camera
        .physical_viewport_size()
        .filter(|s| s.x > 0 && s.y > 0)
        .map(|s| s.x as f32 / s.y as f32)
        .or(match projection {
            Projection::Perspective(p) => Some(p.aspect_ratio),
            Projection::Orthographic(o) => Some(o.area.width() / o.area.height()),
            Projection::Custom(_) => None,
        })
        .filter(|a| a.is_finite() && *a > 0.0)
        .unwrap_or(16.0 / 9.0);
    let height = (DEFAULT_WIDTH as f32 / aspect).round().clamp(1.0, 4096.0) as u32;
    (DEFAULT_WIDTH, height)
}

/// The camera's world-to-clip matrix in bevy's reversed-Z convention, as hom's matrix.
fn world_to_clip(camera: &Camera, projection: &Projection, transform: &GlobalTransform) -> Mat4 {
    let clip_from_view = match &camera.sub_camera_view {
        Some(sub) => projection.get_clip_from_view_for_sub(sub),
        None => projection.get_clip_from_view(),
    };
    let m = clip_from_view * transform.to_matrix().inverse();
    Mat4::from_cols_array(&m.to_cols_array())
}

/// Writes each [`OcclusionDebugView`]'s image from its camera's buffer.
pub(crate) fn debug_views(
    mut cullers: ResMut<Cullers>,
    images: Option<ResMut<Assets<Image>>>,
    views: Query<(Entity, &OcclusionDebugView)>,
) {
    // No image assets (an app without bevy's `ImagePlugin`): nothing to write into.
    let Some(mut images) = images else {
        return;
    };
    for (entity, debug) in &views {
        let Some(c) = cullers.0.get_mut(&entity).map(SyncCell::get) else {
            continue;
        };
        if !c.drawn {
            continue;
        }
        let Some(buffer) = c.culler.buffer() else {
            continue;
        };
        let Some(mut image) = images.get_mut(&debug.image) else {
            continue;
        };
        *image = coverage_image(buffer);
    }
}

/// White where the buffer's occluders cover a sample (a point just short of
/// the far plane there is hidden), black elsewhere; row 0 at the top.
fn coverage_image(buffer: &mut dyn OcclusionBuffer) -> Image {
    let (w, h) = (buffer.width(), buffer.height());
    let data = hom::occlusion::details::coverage(buffer, w, h)
        .into_iter()
        .flat_map(|v| [v, v, v, 255])
        .collect();
    Image::new(
        Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
        TextureDimension::D2,
        data,
        TextureFormat::Rgba8UnormSrgb,
        RenderAssetUsages::default(),
    )
}
