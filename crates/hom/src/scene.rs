//! The scene model: shared triangle meshes and the objects that place them.
//!
//! An object's id is its index in [`Scene::objects`] (file or generation
//! order, then the order an engine adds them) and never changes; removed
//! objects keep theirs. Meshes are shared: many objects may name one
//! [`MeshId`]. Objects move by [`Scene::set_transform`].

use crate::geom::{Aabb, Obb};
use glam::{Mat4, Vec3};
use thiserror::Error;

/// Index of a mesh in [`Scene::meshes`].
pub type MeshId = u32;

/// Why a mesh, object or scene was rejected.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SceneError {
    /// A vertex coordinate is NaN or infinite.
    #[error("mesh '{mesh}': vertex {vertex} has a non-finite coordinate {value:?}; remove or fix that vertex")]
    NonFiniteVertex {
        /// Mesh name.
        mesh: String,
        /// Vertex index.
        vertex: usize,
        /// The offending position.
        value: [f32; 3],
    },
    /// A triangle names a vertex that does not exist.
    #[error("mesh '{mesh}': triangle {triangle} uses vertex {index}, but the mesh has only {vertex_count} vertices")]
    IndexOutOfRange {
        /// Mesh name.
        mesh: String,
        /// Triangle index.
        triangle: usize,
        /// The bad vertex index.
        index: u32,
        /// Number of vertices in the mesh.
        vertex_count: usize,
    },
    /// A mesh with no triangles.
    #[error("mesh '{mesh}' has no triangles; skip it instead of adding it")]
    EmptyMesh {
        /// Mesh name.
        mesh: String,
    },
    /// More vertices than a `u32` index can address.
    #[error("mesh '{mesh}' has {count} vertices; at most {max} are supported", max = u32::MAX)]
    TooManyVertices {
        /// Mesh name.
        mesh: String,
        /// Vertex count.
        count: usize,
    },
    /// An object names a mesh id that was never added.
    #[error("object '{object}' uses mesh {mesh}, but only {mesh_count} meshes exist")]
    UnknownMesh {
        /// Object name.
        object: String,
        /// The bad mesh id.
        mesh: MeshId,
        /// Number of meshes.
        mesh_count: usize,
    },
    /// An object's transform has a NaN or infinite entry, or is singular.
    #[error("object '{object}': transform is not finite and invertible")]
    BadTransform {
        /// Object name.
        object: String,
    },
    /// An object id that was never added, or was removed.
    #[error("no object {id}: the scene has {count} object ids, and removed objects cannot be changed")]
    UnknownObject {
        /// The id asked for.
        id: u32,
        /// Object ids handed out so far.
        count: usize,
    },
    /// A scene with no objects.
    #[error("scene '{scene}' has no objects (no faces were found)")]
    EmptyScene {
        /// Scene name.
        scene: String,
    },
    /// More objects than a `u32` id can name.
    #[error("scene has {count} objects; at most {max} are supported", max = u32::MAX - 1)]
    TooManyObjects {
        /// Object count.
        count: usize,
    },
    /// Options a mesh cannot be cut into clusters with.
    #[error("mesh '{mesh}': cannot cut into clusters: {source}")]
    BadClusterOptions {
        /// Mesh name.
        mesh: String,
        /// What is wrong with the options.
        source: crate::clusters::ClusterError,
    },
}

/// An indexed triangle mesh in its own (object) space. Triangles are two-sided.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    name: String,
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    bounds: Aabb,
    tight: Obb,
}

impl Mesh {
    /// A validated mesh: every coordinate finite, every index in range, at least one triangle.
    pub fn new(name: impl Into<String>, positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Result<Mesh, SceneError> {
        let name = name.into();
        if let Some((vertex, p)) = positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
            return Err(SceneError::NonFiniteVertex {
                mesh: name,
                vertex,
                value: p.to_array(),
            });
        }
        if positions.len() > u32::MAX as usize {
            return Err(SceneError::TooManyVertices {
                mesh: name,
                count: positions.len(),
            });
        }
        if triangles.is_empty() {
            return Err(SceneError::EmptyMesh { mesh: name });
        }
        let n = positions.len();
        for (triangle, t) in triangles.iter().enumerate() {
            if let Some(&index) = t.iter().find(|&&i| i as usize >= n) {
                return Err(SceneError::IndexOutOfRange {
                    mesh: name,
                    triangle,
                    index,
                    vertex_count: n,
                });
            }
        }
        // Bounds of the vertices actually used, so stray unused vertices do not inflate them.
        let bounds = Aabb::from_points(triangles.iter().flatten().map(|&i| positions[i as usize]));
        let tight = tight_box(&positions, &triangles).unwrap_or_else(|| Obb::from_local(&bounds, &Mat4::IDENTITY));
        Ok(Mesh {
            name,
            positions,
            triangles,
            bounds,
            tight,
        })
    }

    /// A mesh named `name` of `triangles` (indices into `positions`) that
    /// holds only the vertices they use, in the order they are first used.
    pub fn compact(name: impl Into<String>, positions: &[Vec3], triangles: &[[u32; 3]]) -> Result<Mesh, SceneError> {
        let name = name.into();
        let mut local_of = std::collections::HashMap::new();
        let mut local = Vec::new();
        let mut tris = Vec::with_capacity(triangles.len());
        for (triangle, t) in triangles.iter().enumerate() {
            let mut out = [0u32; 3];
            for (o, &i) in out.iter_mut().zip(t) {
                let Some(&p) = positions.get(i as usize) else {
                    return Err(SceneError::IndexOutOfRange {
                        mesh: name,
                        triangle,
                        index: i,
                        vertex_count: positions.len(),
                    });
                };
                *o = *local_of.entry(i).or_insert_with(|| {
                    local.push(p);
                    (local.len() - 1) as u32
                });
            }
            tris.push(out);
        }
        Mesh::new(name, local, tris)
    }

    /// This mesh cut into clusters ([`crate::clusters::cluster_triangles`]):
    /// one mesh per cluster, in the clusters' order, named `NAME_K`, each
    /// holding only the vertices it uses ([`Mesh::compact`]). A mesh that is
    /// one cluster comes back alone, as it is.
    pub fn cut(&self, options: &crate::clusters::ClusterOptions) -> Result<Vec<Mesh>, SceneError> {
        let clusters =
            crate::clusters::cluster_triangles(&self.positions, &self.triangles, options).map_err(|source| {
                SceneError::BadClusterOptions {
                    mesh: self.name.clone(),
                    source,
                }
            })?;
        if clusters.clusters.len() <= 1 {
            return Ok(vec![self.clone()]);
        }
        let ordered = clusters.reorder(&self.triangles);
        (0..)
            .zip(&clusters.clusters)
            .map(|(k, c)| {
                let tris = &ordered[c.triangles.start as usize..c.triangles.end as usize];
                Mesh::compact(format!("{}_{k}", self.name), &self.positions, tris)
            })
            .collect()
    }

    /// The mesh's name (from the file, or the generator).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Vertex positions in object space.
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// Triangles as vertex index triples.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Object-space bounds of the referenced vertices.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The smaller of [`Mesh::bounds`] and an oriented box along the mesh's
    /// mean normal ([`Obb::fit`]), in object space: thin for a slanted wall,
    /// roof or piece of terrain, where the axis-aligned box is mostly empty.
    pub fn tight_bounds(&self) -> Obb {
        self.tight
    }
}

/// [`Mesh::tight_bounds`] of the referenced vertices: the mean normal is the
/// area-weighted sum of the triangles' normals, each turned to agree with the
/// largest one's (triangles are two-sided, so windings may disagree).
fn tight_box(positions: &[Vec3], triangles: &[[u32; 3]]) -> Option<Obb> {
    let normal = |t: &[u32; 3]| {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        (b - a).cross(c - a)
    };
    let largest = triangles
        .iter()
        .map(normal)
        .max_by(|a, b| a.length_squared().total_cmp(&b.length_squared()))?;
    let mean: Vec3 = triangles
        .iter()
        .map(|t| {
            let n = normal(t);
            if n.dot(largest) < 0.0 {
                -n
            } else {
                n
            }
        })
        .sum();
    let mut used = vec![false; positions.len()];
    let points: Vec<Vec3> = triangles
        .iter()
        .flatten()
        .filter(|&&i| !std::mem::replace(&mut used[i as usize], true))
        .map(|&i| positions[i as usize])
        .collect();
    Obb::fit(&points, mean)
}

/// One placed instance of a mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    /// Name from the file or generator (not necessarily unique).
    pub name: String,
    /// The mesh it places.
    pub mesh: MeshId,
    /// Current object-to-world transform.
    pub transform: Mat4,
    /// Current world-space axis-aligned bounds.
    pub aabb: Aabb,
    /// Current world-space oriented bounds: the mesh's [`Mesh::tight_bounds`]
    /// carried by the transform (tight for moving, rotated objects, and for
    /// slanted ones). See [`Object::test_corners`].
    pub obb: Obb,
    /// Triangle count of its mesh (cached); 0 once removed.
    pub triangles: u32,
    /// May it hide other objects? False for see-through surfaces (glass, grates,
    /// foliage, liquids, fog): they are drawn and tested like any object but never
    /// selected as occluders. True unless set with [`Scene::set_occluder`].
    pub occluder: bool,
    dynamic: bool,
    removed: bool,
    /// The scene's structure revision when this object last changed structurally.
    changed: u64,
    parent: u32,
}

impl Object {
    /// The corners whose screen footprint the occlusion tests use: the
    /// oriented box's when the object moves or the oriented box is the
    /// smaller (slanted walls, roofs, terrain on a slope), else the
    /// axis-aligned box's. Both hold the object's triangles.
    pub fn test_corners(&self) -> [Vec3; 8] {
        if self.dynamic || self.obb.volume() < self.aabb.extent().element_product() {
            self.obb.corners()
        } else {
            self.aabb.corners()
        }
    }

    /// True for an object that moves: added with [`Scene::add_dynamic_object`],
    /// or moved by [`Scene::set_transform`] since. Cullers test it by its
    /// oriented box and keep it out of structures built for static geometry.
    pub fn is_dynamic(&self) -> bool {
        self.dynamic
    }

    /// True once [`Scene::remove_object`] removed it: it owns no triangles and is never drawn.
    pub fn is_removed(&self) -> bool {
        self.removed
    }

    /// The id of the object this one is part of, as the file or the engine
    /// named it ([`Scene::parent_name`]): itself, numbered among the parents,
    /// unless it is one cluster of an object cut by [`Scene::add_clusters`].
    /// Reports list parents as `visible` and objects as `visible_clusters`.
    pub fn parent(&self) -> u32 {
        self.parent
    }

    /// The scene's [`Revision::structure`] at which this object was added,
    /// removed, became dynamic or changed its occluder flag.
    pub fn changed_at(&self) -> u64 {
        self.changed
    }
}

/// Where a scene stands, so that cullers built for it know what to update:
/// `structure` counts additions, removals, objects becoming dynamic and
/// occluder-flag changes; `transforms` counts [`Scene::set_transform`] calls.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Revision {
    /// A number unique to this scene value (clones get their own).
    pub scene: u64,
    /// Structural changes so far.
    pub structure: u64,
    /// Transform changes so far.
    pub transforms: u64,
}

/// A scene: meshes and the objects that place them. An engine keeps it in
/// step with its own world — [`Scene::add_object`], [`Scene::set_transform`],
/// [`Scene::remove_object`] — and the cullers built for it follow.
///
/// **Objects and clusters.** An [`Object`] is what the cullers test and the
/// renderer draws. A loader that cuts a big mesh into clusters
/// ([`Scene::add_clusters`]) adds one object per cluster; each knows the
/// object it is part of ([`Object::parent`]), whose id — the index among
/// parents, in the order they were added — is the id the same file has
/// loaded whole (`--clusters off`). An object added whole is its own and
/// only cluster.
#[derive(Debug)]
pub struct Scene {
    name: String,
    meshes: Vec<Mesh>,
    objects: Vec<Object>,
    /// The parents' names, by parent id.
    parents: Vec<String>,
    triangle_count: u64,
    dynamic_count: usize,
    live_count: usize,
    revision: Revision,
}

/// A fresh [`Revision::scene`] number.
fn next_scene_number() -> u64 {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
    NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

impl Clone for Scene {
    /// A copy with its own [`Revision::scene`] number, so a culler built for
    /// one never mistakes the other (which may change differently) for it.
    fn clone(&self) -> Scene {
        Scene {
            name: self.name.clone(),
            meshes: self.meshes.clone(),
            objects: self.objects.clone(),
            parents: self.parents.clone(),
            triangle_count: self.triangle_count,
            dynamic_count: self.dynamic_count,
            live_count: self.live_count,
            revision: Revision {
                scene: next_scene_number(),
                ..self.revision
            },
        }
    }
}

/// Collects meshes and objects, validating each, then builds a [`Scene`];
/// unlike [`Scene::new`], refuses to build an empty one (what loaders want).
#[derive(Debug)]
pub struct SceneBuilder {
    scene: Scene,
}

impl SceneBuilder {
    /// An empty builder for a scene called `name`.
    pub fn new(name: impl Into<String>) -> SceneBuilder {
        SceneBuilder {
            scene: Scene::new(name),
        }
    }

    /// Adds a mesh and returns its id.
    pub fn add_mesh(&mut self, mesh: Mesh) -> MeshId {
        self.scene.add_mesh(mesh)
    }

    /// Number of meshes added so far.
    pub fn mesh_count(&self) -> usize {
        self.scene.meshes.len()
    }

    /// Number of objects added so far (the id the next object gets).
    pub fn object_count(&self) -> usize {
        self.scene.objects.len()
    }

    /// Adds a static object and returns its id.
    pub fn add_object(&mut self, name: impl Into<String>, mesh: MeshId, transform: Mat4) -> Result<u32, SceneError> {
        self.scene.add_object(name, mesh, transform)
    }

    /// Adds an object that will move and returns its id.
    pub fn add_dynamic_object(
        &mut self,
        name: impl Into<String>,
        mesh: MeshId,
        transform: Mat4,
    ) -> Result<u32, SceneError> {
        self.scene.add_dynamic_object(name, mesh, transform)
    }

    /// Adds object `name` cut into clusters; see [`Scene::add_clusters`].
    pub fn add_clusters(
        &mut self,
        name: impl Into<String>,
        clusters: impl IntoIterator<Item = (String, MeshId)>,
        transform: Mat4,
    ) -> Result<std::ops::Range<u32>, SceneError> {
        self.scene.add_clusters(name, clusters, transform)
    }

    /// Number of parents added so far (the id the next one gets).
    pub fn parent_count(&self) -> usize {
        self.scene.parents.len()
    }

    /// Marks object `id` as one that may (`true`, the default) or must never (`false`)
    /// be used as an occluder, for example a see-through surface. Returns false when
    /// no object has this id.
    pub fn set_occluder(&mut self, id: u32, occluder: bool) -> bool {
        self.scene.set_occluder(id, occluder).is_ok()
    }

    /// The finished scene; an error if it has no objects.
    pub fn build(self) -> Result<Scene, SceneError> {
        if self.scene.objects.is_empty() {
            return Err(SceneError::EmptyScene { scene: self.scene.name });
        }
        Ok(self.scene)
    }
}

impl Scene {
    /// An empty scene called `name`: an engine adds its objects as they appear.
    pub fn new(name: impl Into<String>) -> Scene {
        Scene {
            name: name.into(),
            meshes: Vec::new(),
            objects: Vec::new(),
            parents: Vec::new(),
            triangle_count: 0,
            dynamic_count: 0,
            live_count: 0,
            revision: Revision {
                scene: next_scene_number(),
                ..Revision::default()
            },
        }
    }

    /// The scene's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Adds a mesh and returns its id; objects place it by id (many may share one).
    pub fn add_mesh(&mut self, mesh: Mesh) -> MeshId {
        self.meshes.push(mesh);
        (self.meshes.len() - 1) as MeshId
    }

    /// Adds a static object placing `mesh` with `transform` and returns its
    /// id (ids are never reused).
    pub fn add_object(&mut self, name: impl Into<String>, mesh: MeshId, transform: Mat4) -> Result<u32, SceneError> {
        self.push(name.into(), mesh, transform, false)
    }

    /// Adds an object that will move ([`Scene::set_transform`]) and returns its id.
    pub fn add_dynamic_object(
        &mut self,
        name: impl Into<String>,
        mesh: MeshId,
        transform: Mat4,
    ) -> Result<u32, SceneError> {
        self.push(name.into(), mesh, transform, true)
    }

    /// Adds the static object `name` cut into clusters: one object per
    /// `(cluster name, mesh)`, each placing its mesh with `transform`, all
    /// with one new parent called `name` ([`Object::parent`]). Returns the
    /// clusters' ids (consecutive). Nothing is added when a mesh id is
    /// unknown or the transform is bad; no clusters add nothing.
    pub fn add_clusters(
        &mut self,
        name: impl Into<String>,
        clusters: impl IntoIterator<Item = (String, MeshId)>,
        transform: Mat4,
    ) -> Result<std::ops::Range<u32>, SceneError> {
        let clusters: Vec<(String, MeshId)> = clusters.into_iter().collect();
        if clusters.is_empty() {
            let next = self.objects.len() as u32;
            return Ok(next..next);
        }
        self.add_parent(name.into(), clusters, transform, false)
    }

    /// Adds the static object `name` placing mesh `mesh` with `transform`,
    /// cut into clusters ([`Mesh::cut`]: their meshes are added, then
    /// [`Scene::add_clusters`]), so that the cullers test and the renderer
    /// draws its parts while reports keep one object ([`Object::parent`]).
    /// For a big mesh an engine would draw whole (a ground, a track, a
    /// block of buildings); a mesh that is one cluster is added as it is.
    /// Returns the clusters' ids. To move the object, move each cluster.
    pub fn add_clustered_object(
        &mut self,
        name: impl Into<String>,
        mesh: MeshId,
        transform: Mat4,
        options: &crate::clusters::ClusterOptions,
    ) -> Result<std::ops::Range<u32>, SceneError> {
        let name = name.into();
        // Checked before the cut's meshes are added, so that nothing is added on an error.
        self.check(&name, &[(name.clone(), mesh)], &transform)?;
        let parts = self.meshes[mesh as usize].cut(options)?;
        let clusters: Vec<(String, MeshId)> = if parts.len() == 1 {
            vec![(name.clone(), mesh)]
        } else {
            parts
                .into_iter()
                .map(|m| (m.name().to_owned(), self.add_mesh(m)))
                .collect()
        };
        self.add_clusters(name, clusters, transform)
    }

    fn push(&mut self, name: String, mesh: MeshId, transform: Mat4, dynamic: bool) -> Result<u32, SceneError> {
        let ids = self.add_parent(name.clone(), vec![(name, mesh)], transform, dynamic)?;
        Ok(ids.start)
    }

    /// Adds parent `name` and its `clusters` (at least one), each placing
    /// its mesh with `transform`; checked first, so nothing is added on an
    /// error. Returns the clusters' ids.
    fn add_parent(
        &mut self,
        name: String,
        clusters: Vec<(String, MeshId)>,
        transform: Mat4,
        dynamic: bool,
    ) -> Result<std::ops::Range<u32>, SceneError> {
        self.check(&name, &clusters, &transform)?;
        let first = self.objects.len() as u32;
        let parent = self.parents.len() as u32;
        self.parents.push(name);
        for (cluster, mesh) in clusters {
            self.push_checked(cluster, mesh, transform, dynamic, parent);
        }
        Ok(first..self.objects.len() as u32)
    }

    /// Whether object `name`'s `clusters` may be added with `transform`:
    /// every mesh known, the transform finite and invertible, ids left.
    fn check(&self, name: &str, clusters: &[(String, MeshId)], transform: &Mat4) -> Result<(), SceneError> {
        if let Some((cluster, mesh)) = clusters.iter().find(|(_, m)| self.meshes.get(*m as usize).is_none()) {
            return Err(SceneError::UnknownMesh {
                object: cluster.clone(),
                mesh: *mesh,
                mesh_count: self.meshes.len(),
            });
        }
        check_transform(name, transform)?;
        let adding = clusters.len();
        if self.objects.len().saturating_add(adding) > (u32::MAX - 1) as usize {
            return Err(SceneError::TooManyObjects {
                count: self.objects.len() + adding,
            });
        }
        Ok(())
    }

    /// Adds an object [`Scene::check`] accepted.
    fn push_checked(&mut self, name: String, mesh: MeshId, transform: Mat4, dynamic: bool, parent: u32) -> u32 {
        let m = &self.meshes[mesh as usize];
        let bounds = m.bounds();
        let triangles = m.triangle_count() as u32;
        self.revision.structure += 1;
        self.objects.push(Object {
            name,
            mesh,
            transform,
            aabb: bounds.transformed(&transform),
            obb: m.tight_bounds().transformed(&transform),
            triangles,
            occluder: true,
            dynamic,
            removed: false,
            changed: self.revision.structure,
            parent,
        });
        self.triangle_count += u64::from(triangles);
        self.dynamic_count += usize::from(dynamic);
        self.live_count += 1;
        (self.objects.len() - 1) as u32
    }

    /// The live object `id`, mutably, for the changes below.
    fn live_mut(&mut self, id: u32) -> Result<&mut Object, SceneError> {
        let count = self.objects.len();
        match self.objects.get_mut(id as usize) {
            Some(o) if !o.removed => Ok(o),
            _ => Err(SceneError::UnknownObject { id, count }),
        }
    }

    /// Moves object `id` to `transform` (object to world). The object is
    /// dynamic from then on (tested by its oriented box); the cullers refit
    /// their hierarchies at the next frame.
    pub fn set_transform(&mut self, id: u32, transform: Mat4) -> Result<(), SceneError> {
        let name = &self.live_mut(id)?.name;
        check_transform(name, &transform)?;
        let mesh = &self.meshes[self.objects[id as usize].mesh as usize];
        let (bounds, tight) = (mesh.bounds(), mesh.tight_bounds());
        self.revision.transforms += 1;
        let o = &mut self.objects[id as usize];
        o.transform = transform;
        o.aabb = bounds.transformed(&transform);
        o.obb = tight.transformed(&transform);
        if !o.dynamic {
            o.dynamic = true;
            self.dynamic_count += 1;
            self.revision.structure += 1;
            o.changed = self.revision.structure;
        }
        Ok(())
    }

    /// Removes object `id`: it keeps its id (never reused) but owns nothing
    /// and is never drawn or tested again.
    pub fn remove_object(&mut self, id: u32) -> Result<(), SceneError> {
        let structure = self.revision.structure + 1;
        let o = self.live_mut(id)?;
        let (triangles, dynamic) = (o.triangles, o.dynamic);
        o.removed = true;
        o.triangles = 0;
        o.occluder = false;
        o.changed = structure;
        self.revision.structure = structure;
        self.triangle_count -= u64::from(triangles);
        self.dynamic_count -= usize::from(dynamic);
        self.live_count -= 1;
        Ok(())
    }

    /// Marks object `id` as one that may (`true`, the default) or must never
    /// (`false`) hide other objects, for example a see-through surface.
    pub fn set_occluder(&mut self, id: u32, occluder: bool) -> Result<(), SceneError> {
        let structure = self.revision.structure + 1;
        let o = self.live_mut(id)?;
        if o.occluder != occluder {
            o.occluder = occluder;
            o.changed = structure;
            self.revision.structure = structure;
        }
        Ok(())
    }

    /// All meshes; an object's `mesh` indexes this.
    pub fn meshes(&self) -> &[Mesh] {
        &self.meshes
    }

    /// Every object ever added, removed ones included ([`Object::is_removed`]);
    /// an object's id is its index here.
    pub fn objects(&self) -> &[Object] {
        &self.objects
    }

    /// The objects not removed, with their ids.
    pub fn live_objects(&self) -> impl Iterator<Item = (u32, &Object)> + '_ {
        (0u32..).zip(&self.objects).filter(|(_, o)| !o.removed)
    }

    /// Number of objects not removed.
    pub fn live_count(&self) -> usize {
        self.live_count
    }

    /// The object with id `id` (removed ones too).
    ///
    /// # Panics
    /// If `id` is not an object id of this scene.
    pub fn object(&self, id: u32) -> &Object {
        &self.objects[id as usize]
    }

    /// The live object with id `id`, if there is one.
    pub fn get(&self, id: u32) -> Option<&Object> {
        self.objects.get(id as usize).filter(|o| !o.removed)
    }

    /// Number of parents ([`Object::parent`]): the objects as the file or
    /// the engine named them, before any was cut into clusters.
    pub fn parent_count(&self) -> usize {
        self.parents.len()
    }

    /// The name of parent `parent`, if there is one.
    pub fn parent_name(&self, parent: u32) -> Option<&str> {
        self.parents.get(parent as usize).map(String::as_str)
    }

    /// The sorted, distinct parents of objects `ids` (an object is visible
    /// when any of its clusters is).
    ///
    /// # Panics
    /// If an id is not an object id of this scene.
    pub fn parents_of(&self, ids: &[u32]) -> Vec<u32> {
        let mut parents: Vec<u32> = ids.iter().map(|&id| self.objects[id as usize].parent).collect();
        parents.sort_unstable();
        parents.dedup();
        parents
    }

    /// The mesh an object places.
    pub fn mesh_of(&self, object: &Object) -> &Mesh {
        &self.meshes[object.mesh as usize]
    }

    /// Total triangles over the live objects (instances counted each time).
    pub fn triangle_count(&self) -> u64 {
        self.triangle_count
    }

    /// Number of live dynamic objects.
    pub fn dynamic_count(&self) -> usize {
        self.dynamic_count
    }

    /// Where the scene stands (for cullers to follow it).
    pub fn revision(&self) -> Revision {
        self.revision
    }

    /// World bounds of every live object.
    pub fn bounds(&self) -> Aabb {
        self.live_objects().fold(Aabb::EMPTY, |b, (_, o)| b.union(o.aabb))
    }
}

fn check_transform(object: &str, transform: &Mat4) -> Result<(), SceneError> {
    let det = transform.determinant();
    if !transform.is_finite() || !det.is_finite() || det == 0.0 {
        return Err(SceneError::BadTransform {
            object: object.to_string(),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> Mesh {
        Mesh::new(
            "quad",
            vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
            vec![[0, 1, 2], [0, 2, 3]],
        )
        .unwrap()
    }

    #[test]
    fn mesh_rejects_nan_and_bad_indices() {
        let nan = Mesh::new("m", vec![Vec3::new(f32::NAN, 0.0, 0.0)], vec![[0, 0, 0]]);
        assert!(matches!(nan, Err(SceneError::NonFiniteVertex { vertex: 0, .. })));
        let oob = Mesh::new("m", vec![Vec3::ZERO], vec![[0, 0, 1]]);
        assert!(matches!(oob, Err(SceneError::IndexOutOfRange { index: 1, .. })));
        assert!(matches!(
            Mesh::new("m", vec![], vec![]),
            Err(SceneError::EmptyMesh { .. })
        ));
    }

    #[test]
    fn empty_scene_is_an_error() {
        let b = SceneBuilder::new("nothing");
        assert!(matches!(b.build(), Err(SceneError::EmptyScene { .. })));
    }

    #[test]
    fn objects_move_appear_and_disappear_and_revisions_say_so() {
        let mut s = Scene::new("engine");
        assert_eq!((s.live_count(), s.triangle_count()), (0, 0), "an engine starts empty");
        let m = s.add_mesh(quad());
        let a = s.add_object("a", m, Mat4::IDENTITY).unwrap();
        let b = s.add_object("b", m, Mat4::from_translation(Vec3::X * 10.0)).unwrap();
        let r0 = s.revision();
        let to = Mat4::from_translation(Vec3::new(0.0, 3.0, 0.0));
        s.set_transform(a, to).unwrap();
        let r1 = s.revision();
        assert!(s.object(a).is_dynamic() && r1.transforms == r0.transforms + 1);
        assert_eq!(r1.structure, r0.structure + 1, "becoming dynamic is structural");
        for p in s.mesh_of(s.object(a)).positions() {
            assert!(s.object(a).aabb.contains_point(to.transform_point3(*p)));
        }
        s.set_transform(a, Mat4::IDENTITY).unwrap();
        assert_eq!(s.revision().structure, r1.structure, "moving a dynamic object is not");
        s.remove_object(b).unwrap();
        assert!(s.object(b).is_removed() && s.get(b).is_none());
        assert_eq!((s.live_count(), s.triangle_count(), s.dynamic_count()), (1, 2, 1));
        assert!(matches!(
            s.set_transform(b, to),
            Err(SceneError::UnknownObject { id: 1, .. })
        ));
        assert!(matches!(
            s.remove_object(7),
            Err(SceneError::UnknownObject { id: 7, .. })
        ));
        let c = s.add_object("c", m, Mat4::IDENTITY).unwrap();
        assert_eq!(c, 2, "ids are never reused");
        assert_eq!(s.live_objects().map(|(id, _)| id).collect::<Vec<_>>(), vec![0, 2]);
        assert!(s.object(c).changed_at() > s.object(a).changed_at());
        let bad = Mat4::from_scale(Vec3::ZERO);
        assert!(matches!(s.set_transform(a, bad), Err(SceneError::BadTransform { .. })));
        assert_ne!(
            s.clone().revision().scene,
            s.revision().scene,
            "a clone is another scene"
        );
    }

    #[test]
    fn clusters_share_their_parent_and_whole_objects_are_their_own() {
        let mut s = Scene::new("cut");
        let m = s.add_mesh(quad());
        let n = s.add_mesh(quad());
        let lamp = s.add_object("lamp", m, Mat4::IDENTITY).unwrap();
        let parts = vec![("road_0".to_string(), m), ("road_1".to_string(), n)];
        let road = s.add_clusters("road", parts, Mat4::from_translation(Vec3::X)).unwrap();
        let car = s.add_dynamic_object("car", n, Mat4::IDENTITY).unwrap();
        assert_eq!((lamp, road.clone(), car), (0, 1..3, 3));
        let parents: Vec<u32> = s.objects().iter().map(Object::parent).collect();
        assert_eq!(parents, vec![0, 1, 1, 2]);
        assert_eq!(s.parent_count(), 3);
        let names: Vec<&str> = (0..3).filter_map(|p| s.parent_name(p)).collect();
        assert_eq!(names, vec!["lamp", "road", "car"]);
        assert_eq!((s.object(2).name.as_str(), s.parent_name(3)), ("road_1", None));
        assert_eq!(s.parents_of(&[3, 2, 1]), vec![1, 2], "one road, one car");
        assert_eq!((s.live_count(), s.triangle_count()), (4, 8));

        let bad = vec![("a".to_string(), m), ("b".to_string(), 9)];
        assert!(matches!(
            s.add_clusters("bad", bad, Mat4::IDENTITY),
            Err(SceneError::UnknownMesh { mesh: 9, .. })
        ));
        let nan = Mat4::from_scale(Vec3::NAN);
        assert!(matches!(
            s.add_clusters("nan", vec![("a".to_string(), m)], nan),
            Err(SceneError::BadTransform { .. })
        ));
        assert_eq!(s.add_clusters("none", Vec::new(), Mat4::IDENTITY).unwrap(), 4..4);
        assert_eq!(
            (s.objects().len(), s.parent_count()),
            (4, 3),
            "a refused object adds nothing"
        );
    }

    /// A row of `n` unit quads along +x (2 triangles each, shared vertices).
    fn strip(n: u32) -> Mesh {
        let p = (0..=n).flat_map(|i| [Vec3::new(i as f32, 0.0, 0.0), Vec3::new(i as f32, 1.0, 0.0)]);
        let t = (0..n).flat_map(|i| [[2 * i, 2 * i + 2, 2 * i + 3], [2 * i, 2 * i + 3, 2 * i + 1]]);
        Mesh::new("strip", p.collect(), t.collect()).unwrap()
    }

    /// A mesh's triangles as corner positions, sorted (bit patterns).
    fn corners(meshes: &[&Mesh]) -> Vec<[[u32; 3]; 3]> {
        let mut all: Vec<[[u32; 3]; 3]> = meshes
            .iter()
            .flat_map(|m| {
                m.triangles()
                    .iter()
                    .map(|t| t.map(|i| m.positions()[i as usize].to_array().map(f32::to_bits)))
            })
            .collect();
        all.sort_unstable();
        all
    }

    #[test]
    fn an_engines_big_mesh_is_added_cut_under_one_parent() {
        let mut s = Scene::new("engine");
        let long = s.add_mesh(strip(100));
        let short = s.add_mesh(strip(2));
        let at = Mat4::from_translation(Vec3::new(0.0, 0.0, -5.0));
        let options = crate::clusters::ClusterOptions::default();
        let ids = s.add_clustered_object("road", long, at, &options).unwrap();
        assert!(ids.len() >= 25, "100 m in clusters of 3 m of centroids: {ids:?}");
        let clusters: Vec<&Mesh> = ids.clone().map(|id| s.mesh_of(s.object(id))).collect();
        assert_eq!(
            corners(&clusters),
            corners(&[&s.meshes()[long as usize]]),
            "the same triangles"
        );
        for id in ids.clone() {
            let o = s.object(id);
            assert_eq!((o.parent(), o.transform), (0, at));
            assert!(o.triangles <= 64 && o.aabb.extent().x <= 4.0, "{}", o.name);
            assert!(
                s.mesh_of(o).positions().len() <= 2 * o.triangles as usize + 2,
                "only the vertices it uses"
            );
        }
        assert_eq!(
            (s.object(ids.start).name.as_str(), s.parent_name(0)),
            ("strip_0", Some("road"))
        );
        // One cluster: added as it is, placing the engine's own mesh.
        let meshes = s.meshes().len();
        let kerb = s.add_clustered_object("kerb", short, at, &options).unwrap();
        assert_eq!(
            (kerb.len(), s.object(kerb.start).mesh, s.meshes().len()),
            (1, short, meshes)
        );
        assert_eq!(s.parent_name(1), Some("kerb"));
        // Bad options: an error naming them, nothing added.
        let none = crate::clusters::ClusterOptions {
            max_triangles: 0,
            ..options
        };
        let count = (s.objects().len(), s.meshes().len(), s.parent_count());
        assert!(matches!(
            s.add_clustered_object("bad", long, at, &none),
            Err(SceneError::BadClusterOptions { .. })
        ));
        assert!(matches!(
            s.add_clustered_object("bad", 99, at, &options),
            Err(SceneError::UnknownMesh { mesh: 99, .. })
        ));
        assert_eq!((s.objects().len(), s.meshes().len(), s.parent_count()), count);
        assert!(matches!(
            Mesh::compact("c", &[Vec3::ZERO], &[[0, 0, 1]]),
            Err(SceneError::IndexOutOfRange {
                index: 1,
                triangle: 0,
                ..
            })
        ));
    }
}
