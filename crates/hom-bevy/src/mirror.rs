//! The world's meshes as a hom [`Scene`]: one object per mesh entity,
//! kept in step with bevy's entities, transforms, meshes and visibility.
//!
//! Which entities take part:
//! - an entity with [`Mesh3d`] whose mesh is a triangle list (or strip) with
//!   positions in the main world (the default [`RenderAssetUsages`]);
//! - not one whose drawn shape may leave its mesh's bounds: skinned meshes,
//!   [`NoFrustumCulling`] and [`NoAutoAabb`] (a hand-made box says the shape
//!   is not the mesh's). These are never culled by occlusion and never occlude.
//!
//! Which of them may occlude (the scene's occluder flag): visible in the
//! hierarchy ([`InheritedVisibility`]), on the default render layer only,
//! drawn at every distance (no [`VisibilityRange`]), not marked [`NeverOccluder`], and marked [`Occluder`] or, with
//! [`OcclusionSettings::auto_occluders`], any mesh. An [`Occluder`] with a
//! stand-in adds the stand-in as a second, occluder-only object; the entity's
//! own mesh is then tested but never drawn as an occluder.
//!
//! [`RenderAssetUsages`]: bevy::asset::RenderAssetUsages

use crate::{NeverOccluder, Occluder, OcclusionSettings};
use bevy::asset::{AssetEvent, AssetId, Assets};
use bevy::camera::visibility::{InheritedVisibility, NoAutoAabb, NoFrustumCulling, RenderLayers, VisibilityRange};
use bevy::ecs::entity::{EntityHashMap, EntityHashSet};
use bevy::ecs::prelude::*;
use bevy::ecs::query::QueryData;
use bevy::ecs::system::SystemParam;
use bevy::mesh::skinning::SkinnedMesh;
use bevy::mesh::{Indices, Mesh, Mesh3d, PrimitiveTopology, VertexAttributeValues};
use bevy::platform::collections::HashMap;
use bevy::transform::components::GlobalTransform;
use hom::glam;
use hom::scene::{MeshId, Scene};
use std::time::Instant;

/// hom's copy of the world's meshes, shared by every camera's culler.
#[derive(Resource)]
pub struct OcclusionScene {
    pub(crate) scene: Scene,
    /// The hom mesh made of each bevy mesh (`None`: it has no triangles hom can use).
    meshes: HashMap<AssetId<Mesh>, Option<MeshId>>,
    /// The objects of each entity that takes part.
    pub(crate) tracked: EntityHashMap<Tracked>,
    /// Entities whose mesh is not loaded yet: tried again each frame.
    pending: EntityHashSet,
    /// Milliseconds the last sync took.
    pub(crate) sync_ms: f64,
}

impl Default for OcclusionScene {
    fn default() -> Self {
        OcclusionScene {
            scene: Scene::new("bevy world"),
            meshes: HashMap::default(),
            tracked: EntityHashMap::default(),
            pending: EntityHashSet::default(),
            sync_ms: 0.0,
        }
    }
}

impl OcclusionScene {
    /// The hom scene the cullers see (read-only: the plugin keeps it in step).
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The hom object id of `entity`'s mesh, if it takes part in occlusion culling.
    pub fn object_of(&self, entity: Entity) -> Option<u32> {
        self.tracked.get(&entity).map(|t| t.object)
    }

    /// How many entities take part.
    pub fn entity_count(&self) -> usize {
        self.tracked.len()
    }
}

/// An entity's objects in the scene.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Tracked {
    /// Its own mesh: tested, and drawn as an occluder unless a stand-in is.
    pub object: u32,
    /// The stand-in [`Occluder::stand_in`] gave: drawn, never reported.
    pub stand_in: Option<u32>,
    /// The bevy meshes they were made of (the stand-in's, when one was given).
    meshes: (AssetId<Mesh>, Option<AssetId<Mesh>>),
}

/// Everything about an entity that decides its part.
#[derive(QueryData)]
pub(crate) struct EntityParts {
    entity: Entity,
    mesh: &'static Mesh3d,
    transform: &'static GlobalTransform,
    occluder: Option<&'static Occluder>,
    never: Has<NeverOccluder>,
    inherited: Option<&'static InheritedVisibility>,
    layers: Option<&'static RenderLayers>,
    ranged: Has<VisibilityRange>,
    skinned: Has<SkinnedMesh>,
    no_frustum: Has<NoFrustumCulling>,
    no_auto_aabb: Has<NoAutoAabb>,
}

/// The changes since the last frame that move an entity in or out, or change what may occlude.
type RoleChanged = Or<(
    Changed<Mesh3d>,
    Changed<Occluder>,
    Changed<InheritedVisibility>,
    Changed<RenderLayers>,
    Changed<VisibilityRange>,
    Added<NeverOccluder>,
    Added<SkinnedMesh>,
    Added<NoFrustumCulling>,
    Added<NoAutoAabb>,
)>;

/// Mesh entities that moved (or were placed) since the last frame.
type Moved = (Changed<GlobalTransform>, With<Mesh3d>);

/// The markers taken off entities since the last frame.
#[derive(SystemParam)]
pub(crate) struct Unmarked<'w, 's> {
    occluder: RemovedComponents<'w, 's, Occluder>,
    never: RemovedComponents<'w, 's, NeverOccluder>,
    layers: RemovedComponents<'w, 's, RenderLayers>,
    ranged: RemovedComponents<'w, 's, VisibilityRange>,
    skinned: RemovedComponents<'w, 's, SkinnedMesh>,
    no_frustum: RemovedComponents<'w, 's, NoFrustumCulling>,
    no_auto_aabb: RemovedComponents<'w, 's, NoAutoAabb>,
}

impl Unmarked<'_, '_> {
    /// Adds the entities that lost a marker to `out`.
    fn read_into(&mut self, out: &mut Vec<Entity>) {
        out.extend(self.occluder.read());
        out.extend(self.never.read());
        out.extend(self.layers.read());
        out.extend(self.ranged.read());
        out.extend(self.skinned.read());
        out.extend(self.no_frustum.read());
        out.extend(self.no_auto_aabb.read());
    }
}

/// Keeps [`OcclusionScene`] in step with the world (the plugin's first system each frame).
#[allow(clippy::too_many_arguments)] // one system: its parameters are its queries
pub(crate) fn sync_scene(
    mut mirror: ResMut<OcclusionScene>,
    settings: Res<OcclusionSettings>,
    meshes: Res<Assets<Mesh>>,
    mut mesh_events: MessageReader<AssetEvent<Mesh>>,
    changed: Query<EntityParts, RoleChanged>,
    all: Query<EntityParts>,
    moved: Query<(Entity, &GlobalTransform), Moved>,
    mut gone: RemovedComponents<Mesh3d>,
    mut unmarked: Unmarked,
) {
    #[cfg(feature = "trace")]
    let _span = tracing::info_span!("hom_bevy", stage = "sync").entered();
    let start = Instant::now();
    let mirror = &mut *mirror;
    for event in mesh_events.read() {
        if let AssetEvent::Modified { id } | AssetEvent::Removed { id } = event {
            mirror.meshes.remove(id);
        }
    }
    for entity in gone.read() {
        mirror.untrack(entity);
        mirror.pending.remove(&entity);
    }
    // Entities to look at again: those whose part changed, those waiting
    // for their mesh, those that lost a marker; all when the settings changed.
    let mut again: Vec<Entity> = if settings.is_changed() {
        all.iter().map(|parts| parts.entity).collect()
    } else {
        changed.iter().map(|parts| parts.entity).collect()
    };
    again.extend(mirror.pending.drain());
    unmarked.read_into(&mut again);
    again.sort_unstable();
    again.dedup();
    let mut added = EntityHashSet::default();
    for entity in again {
        match all.get(entity) {
            Ok(parts) => {
                if mirror.update(parts, &settings, &meshes) {
                    added.insert(entity);
                }
            }
            Err(_) => mirror.untrack(entity),
        }
    }
    for (entity, transform) in &moved {
        if added.contains(&entity) {
            continue; // placed where it was added
        }
        if let Some(t) = mirror.tracked.get(&entity).copied() {
            let m = matrix(transform);
            let placed = std::iter::once(t.object)
                .chain(t.stand_in)
                .all(|id| mirror.scene.set_transform(id, m).is_ok());
            if !placed {
                // A transform hom refuses (not finite): out until it is
                // usable again, never culled where it stood before.
                mirror.untrack(entity);
                mirror.pending.insert(entity);
            }
        }
    }
    mirror.sync_ms = start.elapsed().as_secs_f64() * 1e3;
}

impl OcclusionScene {
    /// Brings `entity`'s objects in step with its parts: only its occluder
    /// flags where its meshes are the same, else removed and added again.
    /// Whether it was added.
    fn update(&mut self, parts: EntityPartsItem, settings: &OcclusionSettings, meshes: &Assets<Mesh>) -> bool {
        let entity = parts.entity;
        let made_of = (parts.mesh.0.id(), stand_in_of(parts.occluder));
        if let Some(t) = self.tracked.get(&entity).copied() {
            let still_made = t.meshes == made_of
                && self.meshes.contains_key(&made_of.0)
                && made_of.1.is_none_or(|id| self.meshes.contains_key(&id));
            if still_made && takes_part(&parts) {
                let may_occlude = may_occlude(&parts, settings);
                let _ = self.scene.set_occluder(t.object, may_occlude && made_of.1.is_none());
                if let Some(id) = t.stand_in {
                    let _ = self.scene.set_occluder(id, may_occlude);
                }
                return false;
            }
        }
        self.untrack(entity);
        self.track(parts, settings, meshes)
    }

    /// Removes `entity`'s objects, if it has any.
    fn untrack(&mut self, entity: Entity) {
        if let Some(t) = self.tracked.remove(&entity) {
            for id in std::iter::once(t.object).chain(t.stand_in) {
                // The id is live: it was added for this entity and not removed.
                let _ = self.scene.remove_object(id);
            }
        }
    }

    /// Adds `entity`'s objects when it takes part and its meshes are loaded; whether it did.
    fn track(&mut self, parts: EntityPartsItem, settings: &OcclusionSettings, meshes: &Assets<Mesh>) -> bool {
        let entity = parts.entity;
        if !takes_part(&parts) {
            return false;
        }
        let made_of = (parts.mesh.0.id(), stand_in_of(parts.occluder));
        let mesh = match self.mesh(made_of.0, meshes) {
            Loaded::Yes(m) => m,
            Loaded::NotYet => {
                self.pending.insert(entity);
                return false;
            }
            Loaded::Unusable => return false,
        };
        let stand_in = match made_of.1 {
            None => None,
            Some(id) => match self.mesh(id, meshes) {
                Loaded::Yes(m) => Some(m),
                Loaded::NotYet => {
                    self.pending.insert(entity);
                    return false;
                }
                // A stand-in with no triangles occludes nothing.
                Loaded::Unusable => None,
            },
        };
        let may_occlude = may_occlude(&parts, settings);
        let m = matrix(parts.transform);
        let Ok(object) = self.scene.add_object("entity", mesh, m) else {
            // A transform hom refuses (not finite): tried again each frame.
            self.pending.insert(entity);
            return false;
        };
        let _ = self.scene.set_occluder(object, may_occlude && made_of.1.is_none());
        let stand_in = stand_in.and_then(|mesh| {
            let id = self.scene.add_object("stand-in", mesh, m).ok()?;
            let _ = self.scene.set_occluder(id, may_occlude);
            Some(id)
        });
        self.tracked.insert(
            entity,
            Tracked {
                object,
                stand_in,
                meshes: made_of,
            },
        );
        true
    }

    /// The hom mesh of bevy mesh `id`, made on first use.
    fn mesh(&mut self, id: AssetId<Mesh>, meshes: &Assets<Mesh>) -> Loaded {
        if let Some(made) = self.meshes.get(&id) {
            return made.map_or(Loaded::Unusable, Loaded::Yes);
        }
        let Some(mesh) = meshes.get(id) else {
            return Loaded::NotYet;
        };
        let made = triangles(mesh)
            .and_then(|(positions, tris)| hom::scene::Mesh::new("bevy mesh", positions, tris).ok())
            .map(|m| self.scene.add_mesh(m));
        self.meshes.insert(id, made);
        made.map_or(Loaded::Unusable, Loaded::Yes)
    }
}

/// Whether an entity takes part at all: not when its drawn shape may leave its mesh's bounds.
fn takes_part(parts: &EntityPartsItem) -> bool {
    !(parts.skinned || parts.no_frustum || parts.no_auto_aabb)
}

/// Whether an entity that takes part may occlude (the module docs' rule).
fn may_occlude(parts: &EntityPartsItem, settings: &OcclusionSettings) -> bool {
    parts.inherited.is_none_or(|v| v.get())
        && parts.layers.is_none_or(|l| *l == RenderLayers::default())
        && !parts.ranged
        && !parts.never
        && (parts.occluder.is_some() || settings.auto_occluders)
}

/// The stand-in mesh an [`Occluder`] brings, if any.
fn stand_in_of(occluder: Option<&Occluder>) -> Option<AssetId<Mesh>> {
    occluder.and_then(|o| o.stand_in.as_ref()).map(|h| h.id())
}

/// Whether a bevy mesh has become a hom mesh.
#[derive(Clone, Copy, Debug)]
enum Loaded {
    Yes(MeshId),
    /// Not in `Assets<Mesh>` yet (loading).
    NotYet,
    /// No triangles hom can use: lines, points, no positions, positions
    /// gone to the render world, a NaN vertex.
    Unusable,
}

/// A bevy mesh's positions and triangles, if it is made of triangles.
pub(crate) fn triangles(mesh: &Mesh) -> Option<(Vec<glam::Vec3>, Vec<[u32; 3]>)> {
    let Ok(VertexAttributeValues::Float32x3(positions)) = mesh.try_attribute(Mesh::ATTRIBUTE_POSITION) else {
        return None;
    };
    let positions: Vec<glam::Vec3> = positions.iter().map(|p| glam::Vec3::from_array(*p)).collect();
    let indices: Vec<u32> = match mesh.try_indices_option().ok()? {
        Some(Indices::U16(i)) => i.iter().map(|&i| u32::from(i)).collect(),
        Some(Indices::U32(i)) => i.clone(),
        None => (0..positions.len() as u32).collect(),
    };
    let tris = match mesh.primitive_topology() {
        PrimitiveTopology::TriangleList => indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
        // Winding does not matter: hom's triangles are two-sided.
        PrimitiveTopology::TriangleStrip => indices.windows(3).map(|t| [t[0], t[1], t[2]]).collect(),
        _ => return None,
    };
    Some((positions, tris))
}

/// A bevy transform as hom's matrix (the same column-major numbers; bevy's glam is another version).
pub(crate) fn matrix(transform: &GlobalTransform) -> glam::Mat4 {
    glam::Mat4::from_cols_array(&transform.to_matrix().to_cols_array())
}
