//! The scene model: shared triangle meshes and the objects that place them.
//!
//! An object's id is its index in [`Scene::objects`] (file or generation order) and
//! never changes. Meshes are shared: many objects may name one [`MeshId`].
//! Dynamic objects carry a [`Motion`]; [`Scene::set_time`] moves them.

use crate::geom::{Aabb, Obb};
use glam::{Mat4, Quat, Vec3};
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
    /// An object's motion has a NaN or infinite field.
    #[error("object '{object}': motion has a non-finite field")]
    BadMotion {
        /// Object name.
        object: String,
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
}

/// An indexed triangle mesh in its own (object) space. Triangles are two-sided.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    name: String,
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    bounds: Aabb,
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
        Ok(Mesh {
            name,
            positions,
            triangles,
            bounds,
        })
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
}

/// Deterministic motion of a dynamic object: drift that bounces inside a region, plus spin.
///
/// The pose at time `t` is a pure function of `t`, so any frame can be rendered
/// alone and every culler sees the same scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion {
    /// Drift velocity of the object's origin, metres per second.
    pub velocity: Vec3,
    /// The origin bounces off the walls of this box (it must contain the start position).
    pub region: Aabb,
    /// Spin axis (any length; normalised when used). Zero means no spin.
    pub spin_axis: Vec3,
    /// Spin rate, radians per second, about the object's origin.
    pub spin_rate: f32,
}

impl Motion {
    fn is_finite(&self) -> bool {
        self.velocity.is_finite() && self.region.is_finite() && self.spin_axis.is_finite() && self.spin_rate.is_finite()
    }

    /// The world transform at time `t` seconds for an object whose pose at `t = 0` is `base`.
    pub fn transform_at(&self, base: &Mat4, t: f32) -> Mat4 {
        let start = base.w_axis.truncate();
        let moved = start + self.velocity * t;
        let lo = self.region.min;
        let size = self.region.extent();
        // Triangle wave per axis keeps the origin inside the region (reflection at walls).
        let bounce = |p: f32, lo: f32, s: f32| {
            if s <= 0.0 {
                return lo;
            }
            let u = (p - lo).rem_euclid(2.0 * s);
            lo + if u > s { 2.0 * s - u } else { u }
        };
        let pos = Vec3::new(
            bounce(moved.x, lo.x, size.x),
            bounce(moved.y, lo.y, size.y),
            bounce(moved.z, lo.z, size.z),
        );
        let spin = match self.spin_axis.try_normalize() {
            Some(axis) => Quat::from_axis_angle(axis, self.spin_rate * t),
            None => Quat::IDENTITY,
        };
        let mut linear = Mat4::from_quat(spin) * Mat4::from_mat3(glam::Mat3::from_mat4(*base));
        linear.w_axis = pos.extend(1.0);
        linear
    }
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
    /// Pose at time 0 (equals `transform` for static objects).
    pub base_transform: Mat4,
    /// `Some` for a dynamic object.
    pub motion: Option<Motion>,
    /// Current world-space axis-aligned bounds.
    pub aabb: Aabb,
    /// Current world-space oriented bounds (tight for moving, rotated objects).
    pub obb: Obb,
    /// Triangle count of its mesh (cached).
    pub triangles: u32,
    /// May it hide other objects? False for see-through surfaces (glass, grates,
    /// foliage, liquids, fog): they are drawn and tested like any object but never
    /// selected as occluders. True unless set with [`SceneBuilder::set_occluder`].
    pub occluder: bool,
}

impl Object {
    /// True for an object that moves ([`Motion`] set).
    pub fn is_dynamic(&self) -> bool {
        self.motion.is_some()
    }
}

/// A scene: meshes, objects, and the running time of its dynamic objects.
#[derive(Clone, Debug)]
pub struct Scene {
    name: String,
    meshes: Vec<Mesh>,
    objects: Vec<Object>,
    time: f32,
    triangle_count: u64,
    dynamic_count: usize,
}

/// Collects meshes and objects, validating each, then builds a [`Scene`].
#[derive(Debug, Default)]
pub struct SceneBuilder {
    name: String,
    meshes: Vec<Mesh>,
    objects: Vec<Object>,
}

impl SceneBuilder {
    /// An empty builder for a scene called `name`.
    pub fn new(name: impl Into<String>) -> SceneBuilder {
        SceneBuilder {
            name: name.into(),
            ..SceneBuilder::default()
        }
    }

    /// Adds a mesh and returns its id.
    pub fn add_mesh(&mut self, mesh: Mesh) -> MeshId {
        self.meshes.push(mesh);
        (self.meshes.len() - 1) as MeshId
    }

    /// Number of meshes added so far.
    pub fn mesh_count(&self) -> usize {
        self.meshes.len()
    }

    /// Number of objects added so far (the id the next object gets).
    pub fn object_count(&self) -> usize {
        self.objects.len()
    }

    /// Adds a static object and returns its id.
    pub fn add_object(&mut self, name: impl Into<String>, mesh: MeshId, transform: Mat4) -> Result<u32, SceneError> {
        self.push(name.into(), mesh, transform, None)
    }

    /// Adds a dynamic object that moves with `motion` and returns its id.
    pub fn add_dynamic_object(
        &mut self,
        name: impl Into<String>,
        mesh: MeshId,
        transform: Mat4,
        motion: Motion,
    ) -> Result<u32, SceneError> {
        self.push(name.into(), mesh, transform, Some(motion))
    }

    fn push(&mut self, name: String, mesh: MeshId, transform: Mat4, motion: Option<Motion>) -> Result<u32, SceneError> {
        let Some(m) = self.meshes.get(mesh as usize) else {
            return Err(SceneError::UnknownMesh {
                object: name,
                mesh,
                mesh_count: self.meshes.len(),
            });
        };
        let det = transform.determinant();
        if !transform.is_finite() || !det.is_finite() || det == 0.0 {
            return Err(SceneError::BadTransform { object: name });
        }
        if motion.is_some_and(|m| !m.is_finite()) {
            return Err(SceneError::BadMotion { object: name });
        }
        if self.objects.len() >= (u32::MAX - 1) as usize {
            return Err(SceneError::TooManyObjects {
                count: self.objects.len() + 1,
            });
        }
        let bounds = m.bounds();
        self.objects.push(Object {
            name,
            mesh,
            transform,
            base_transform: transform,
            motion,
            aabb: bounds.transformed(&transform),
            obb: Obb::from_local(&bounds, &transform),
            triangles: m.triangle_count() as u32,
            occluder: true,
        });
        Ok((self.objects.len() - 1) as u32)
    }

    /// Marks object `id` as one that may (`true`, the default) or must never (`false`)
    /// be used as an occluder, for example a see-through surface. Returns false when
    /// no object has this id.
    pub fn set_occluder(&mut self, id: u32, occluder: bool) -> bool {
        match self.objects.get_mut(id as usize) {
            Some(o) => {
                o.occluder = occluder;
                true
            }
            None => false,
        }
    }

    /// The finished scene; an error if it has no objects.
    pub fn build(self) -> Result<Scene, SceneError> {
        if self.objects.is_empty() {
            return Err(SceneError::EmptyScene { scene: self.name });
        }
        let triangle_count = self.objects.iter().map(|o| o.triangles as u64).sum();
        let dynamic_count = self.objects.iter().filter(|o| o.is_dynamic()).count();
        Ok(Scene {
            name: self.name,
            meshes: self.meshes,
            objects: self.objects,
            time: 0.0,
            triangle_count,
            dynamic_count,
        })
    }
}

impl Scene {
    /// The scene's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// All meshes; an object's `mesh` indexes this.
    pub fn meshes(&self) -> &[Mesh] {
        &self.meshes
    }

    /// All objects; an object's id is its index here.
    pub fn objects(&self) -> &[Object] {
        &self.objects
    }

    /// The object with id `id`.
    ///
    /// # Panics
    /// If `id` is not an object id of this scene.
    pub fn object(&self, id: u32) -> &Object {
        &self.objects[id as usize]
    }

    /// The mesh an object places.
    pub fn mesh_of(&self, object: &Object) -> &Mesh {
        &self.meshes[object.mesh as usize]
    }

    /// Total triangles over all objects (instances counted each time).
    pub fn triangle_count(&self) -> u64 {
        self.triangle_count
    }

    /// Number of dynamic objects.
    pub fn dynamic_count(&self) -> usize {
        self.dynamic_count
    }

    /// The current time of the dynamic objects, seconds.
    pub fn time(&self) -> f32 {
        self.time
    }

    /// World bounds of every object at the current time.
    pub fn bounds(&self) -> Aabb {
        self.objects.iter().fold(Aabb::EMPTY, |b, o| b.union(o.aabb))
    }

    /// Moves every dynamic object to its pose at time `t` seconds (static ones stay).
    pub fn set_time(&mut self, t: f32) {
        self.time = t;
        if self.dynamic_count == 0 {
            return;
        }
        let meshes = &self.meshes;
        for o in self.objects.iter_mut() {
            if let Some(m) = o.motion {
                let bounds = meshes[o.mesh as usize].bounds();
                o.transform = m.transform_at(&o.base_transform, t);
                o.aabb = bounds.transformed(&o.transform);
                o.obb = Obb::from_local(&bounds, &o.transform);
            }
        }
    }
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
    fn dynamic_objects_stay_in_region_and_bounds_follow() {
        let mut b = SceneBuilder::new("s");
        let m = b.add_mesh(quad());
        let motion = Motion {
            velocity: Vec3::new(3.0, -1.0, 7.0),
            region: Aabb::new(Vec3::splat(-2.0), Vec3::splat(2.0)),
            spin_axis: Vec3::Y,
            spin_rate: 1.3,
        };
        b.add_dynamic_object("q", m, Mat4::IDENTITY, motion).unwrap();
        b.add_object("still", m, Mat4::from_translation(Vec3::X * 10.0))
            .unwrap();
        assert!(b.set_occluder(1, false));
        assert!(!b.set_occluder(2, false));
        let mut s = b.build().unwrap();
        assert!(s.object(0).occluder && !s.object(1).occluder);
        for i in 0..200 {
            s.set_time(i as f32 * 0.1);
            let o = s.object(0);
            let origin = o.transform.w_axis.truncate();
            assert!(motion.region.contains_point(origin), "t={} origin {origin}", s.time());
            for c in s.mesh_of(o).positions() {
                let w = o.transform.transform_point3(*c);
                assert!(o.aabb.min.cmple(w + 1e-4).all() && o.aabb.max.cmpge(w - 1e-4).all());
            }
            assert_eq!(s.object(1).transform, Mat4::from_translation(Vec3::X * 10.0));
        }
    }
}
