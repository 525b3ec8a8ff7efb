//! Level of detail guided by visibility (Law & Tan 1999, sections 3 and 6).
//!
//! Culling removes what is hidden; level of detail thins what is visible but
//! far. Law & Tan join them: a view-dependent LOD hierarchy is refined only
//! where it can be seen, so the hidden parts of a visible object stay coarse
//! instead of being refined and then drawn behind something.
//!
//! - [`LodHierarchy`] (`lod/hierarchy.rs`): one mesh's binary tree of
//!   triangle clusters, leaves at full resolution, each inner node its
//!   children simplified to about half; crack-free cuts by construction;
//!   nodes in pre-order with their last descendant (section 6's IDs).
//! - [`SceneLod`]: a hierarchy per mesh (objects sharing a mesh share it).
//! - [`LodSelector`] (`lod/refine.rs`): per object an active front moved
//!   from frame to frame (refined where a node's projected error exceeds the
//!   threshold, coarsened where its parent's does not), or a triangle budget
//!   spent on the worst errors first; with guidance, a node hidden from the
//!   frame's view (a culler's box test, [`crate::cull::Culler::box_hidden`])
//!   is not refined.
//!
//! ```
//! use hom::geom::{Camera, View};
//! use hom::glam::Vec3;
//! use hom::lod::{LodConfig, LodOptions, LodSelector, LodView, SceneLod};
//! use hom::scene::{Mesh, Scene};
//!
//! // A 32 × 32 grid of quads: 2,048 triangles.
//! let n = 33;
//! let positions: Vec<Vec3> = (0..n * n).map(|i| Vec3::new((i % n) as f32, 0.0, (i / n) as f32)).collect();
//! let mut triangles = Vec::new();
//! for z in 0..n - 1 {
//!     for x in 0..n - 1 {
//!         let i = (z * n + x) as u32;
//!         triangles.push([i, i + n as u32, i + 1]);
//!         triangles.push([i + 1, i + n as u32, i + n as u32 + 1]);
//!     }
//! }
//! let mut scene = Scene::new("ground");
//! let mesh = scene.add_mesh(Mesh::new("grid", positions, triangles)?);
//! let id = scene.add_object("ground", mesh, hom::glam::Mat4::IDENTITY)?;
//! let lod = SceneLod::build(&scene, &LodConfig::default(), &|_, _| {})?;
//!
//! let camera = Camera::new(Vec3::new(16.0, 30.0, -60.0), Vec3::new(16.0, 0.0, 16.0), Vec3::Y,
//!     1.0, 0.1, 1000.0, 640, 480);
//! let view = LodView::new(&camera.to_view()).expect("a perspective view");
//! let mut selector = LodSelector::default();
//! let mut parts = Vec::new();
//! let stats = selector.select(&scene, &lod, &[id], &view, &LodOptions::default(), &mut |_| false, &mut parts)?;
//! // A flat grid needs none of its 2,048 triangles to be within a pixel.
//! assert!(stats.triangles < 2048);
//! assert!(stats.max_error_px <= 1.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod hierarchy;
mod refine;
#[cfg(test)]
mod tests;

pub use hierarchy::{LodHierarchy, LodNode};
pub use refine::{top_down_cut, view_only_cut, LodOptions, LodPart, LodSelector, LodStats, LodView};

use crate::scene::Scene;
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};
use thiserror::Error;

/// How hierarchies are built.
#[derive(Clone, Debug, PartialEq)]
pub struct LodConfig {
    /// A node is split while it stands for more original triangles than this;
    /// every node draws about this many. Default 128.
    pub leaf_triangles: u32,
}

impl Default for LodConfig {
    fn default() -> Self {
        LodConfig { leaf_triangles: 128 }
    }
}

/// Why level of detail cannot be built or selected.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum LodError {
    /// `leaf_triangles` is 0.
    #[error("leaf_triangles must be at least 1 (got 0)")]
    BadLeafSize,
    /// The pixel error threshold is not a positive finite number.
    #[error("the level-of-detail error threshold must be a positive number of pixels (got {0})")]
    BadErrorThreshold(f32),
    /// The triangle budget is 0.
    #[error("the level-of-detail triangle budget must be at least 1")]
    BadBudget,
    /// The hierarchies were built for another scene (mesh count differs).
    #[error("level of detail built for {built} meshes, the scene has {scene}: build it for this scene")]
    WrongScene {
        /// Meshes the hierarchies were built for.
        built: usize,
        /// Meshes of the scene.
        scene: usize,
    },
}

/// Occluders drawn at the level of detail the frame is rendered at
/// ([`crate::cull::Culler::set_occluder_lod`]): an occluder whose view-only
/// cut ([`view_only_cut`]) at `error_px` is coarser than its mesh is drawn
/// as that cut, and costs the occluder budget the cut's triangles, so the
/// budget buys more occluders where meshes are big and far (terrain tiles).
///
/// The guarantee moves with it: an object the culler hides is hidden in the
/// image of every object's view-only cut (what [`LodSelector`] draws, with
/// or without guidance), not in the full-resolution image, where it may
/// show along an occluder's silhouette by up to `error_px`.
#[derive(Clone, Debug)]
pub struct OccluderLod {
    /// A hierarchy per mesh of the culled scene.
    pub hierarchies: std::sync::Arc<SceneLod>,
    /// The threshold the frame is refined to, pixels.
    pub error_px: f32,
}

/// A level-of-detail hierarchy for every mesh of a scene.
#[derive(Clone, Debug)]
pub struct SceneLod {
    hierarchies: Vec<LodHierarchy>,
    config: LodConfig,
}

impl SceneLod {
    /// Builds every mesh's hierarchy (in parallel, on rayon's pool);
    /// `progress(done, total)` is called as meshes finish, from any thread.
    pub fn build(
        scene: &Scene,
        config: &LodConfig,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<SceneLod, LodError> {
        if config.leaf_triangles == 0 {
            return Err(LodError::BadLeafSize);
        }
        let meshes = scene.meshes();
        let done = AtomicUsize::new(0);
        // Largest first, so one big mesh does not finish last on one core.
        let mut order: Vec<usize> = (0..meshes.len()).collect();
        order.sort_by_key(|&m| std::cmp::Reverse(meshes[m].triangle_count()));
        let mut built: Vec<(usize, LodHierarchy)> = order
            .par_iter()
            .map(|&m| {
                let h = LodHierarchy::build(&meshes[m], config);
                progress(done.fetch_add(1, Ordering::Relaxed) + 1, meshes.len());
                (m, h)
            })
            .collect();
        built.sort_by_key(|b| b.0);
        Ok(SceneLod {
            hierarchies: built.into_iter().map(|b| b.1).collect(),
            config: config.clone(),
        })
    }

    /// The hierarchy of mesh `mesh`.
    ///
    /// # Panics
    /// If `mesh` is not a mesh of the scene it was built for.
    pub fn hierarchy(&self, mesh: crate::scene::MeshId) -> &LodHierarchy {
        &self.hierarchies[mesh as usize]
    }

    /// The configuration it was built with.
    pub fn config(&self) -> &LodConfig {
        &self.config
    }

    /// Number of hierarchies (the scene's meshes).
    pub fn len(&self) -> usize {
        self.hierarchies.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.hierarchies.is_empty()
    }

    /// Bytes of every hierarchy.
    pub fn heap_bytes(&self) -> usize {
        self.hierarchies.iter().map(LodHierarchy::heap_bytes).sum()
    }

    /// An error unless it was built for a scene with `scene`'s meshes.
    pub fn check_scene(&self, scene: &Scene) -> Result<(), LodError> {
        if self.hierarchies.len() != scene.meshes().len() {
            return Err(LodError::WrongScene {
                built: self.hierarchies.len(),
                scene: scene.meshes().len(),
            });
        }
        Ok(())
    }
}
