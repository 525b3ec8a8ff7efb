//! Precomputed visibility: view cells and occludee sets (Law & Tan 1999,
//! "Preprocessing occlusion for real-time selective refinement", sections
//! 3 and 5).
//!
//! A [`Pvs`] is baked once for a static scene and a viewing region: the
//! region is cut into view cells ([`CellGrid`], section 5.1), and every node
//! of the cell hierarchy records the objects hidden from *every* viewpoint in
//! it that no ancestor recorded (its occludee set, section 5.2). At run time
//! the eye's cell is found and the sets from its block's root down to it are
//! merged ([`Pvs::hidden_from`], section 6): sorted lists, so a merge.
//!
//! **Conservative, no exceptions.** An object is recorded only when one
//! convex occluder hides its whole box from the whole cell
//! (`region.rs`: the full occlusion region of section 5.3, decided by the
//! 64 segments between the boxes' corners), with margins for the renderer's
//! snapping and depth precision, and with the occluder at least
//! [`PvsConfig::near_clearance`] from the cell so no near plane clips it. A
//! camera outside every cell, or whose near plane is nearer or wider than
//! the bake assumed, gets no PVS culling ([`Pvs::serves`]), never a wrong
//! one. Only static objects take part; objects listed as moving, and any
//! object that has become dynamic or been removed, are never hidden by it.
//!
//! ```
//! use hom::glam::{Mat4, Vec3};
//! use hom::pvs::{Pvs, PvsConfig, Shard};
//! use hom::scene::{Mesh, Scene};
//!
//! // A wall 20 m wide, 8 m high, 1 m thick (a closed box), and a crate behind it.
//! let corners: Vec<Vec3> = (0..8).map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32) - 0.5).collect();
//! let faces = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]];
//! let tris = faces.iter().flat_map(|f| [[f[0], f[1], f[2]], [f[0], f[2], f[3]]]).collect();
//! let mut scene = Scene::new("yard");
//! let cube = scene.add_mesh(Mesh::new("cube", corners, tris)?);
//! let wall = scene.add_object("wall", cube, Mat4::from_translation(Vec3::new(0.0, 4.0, 0.0)) * Mat4::from_scale(Vec3::new(20.0, 8.0, 1.0)))?;
//! let crate_ = scene.add_object("crate", cube, Mat4::from_translation(Vec3::new(0.0, 0.5, -6.0)))?;
//!
//! // Bake for an eye walking in front of the wall (its camera path's eyes).
//! let eyes: Vec<Vec3> = (0..5).map(|i| Vec3::new(i as f32 - 2.0, 1.7, 8.0)).collect();
//! let pvs = Pvs::bake(&scene, &eyes, &[], &PvsConfig::default(), Shard::WHOLE, &|_, _| {})?;
//!
//! // Per frame: what the eye's cell hides (ascending ids; `Pvs::serves` checks a view first).
//! let mut hidden = Vec::new();
//! assert!(pvs.hidden_from(Vec3::new(0.0, 1.7, 8.0), &mut hidden).is_some());
//! assert_eq!(hidden, [crate_]);
//! assert!(!hidden.contains(&wall));
//! // Off the baked region: no cell, nothing hidden (never a wrong answer).
//! assert!(pvs.hidden_from(Vec3::new(0.0, 1.7, -20.0), &mut Vec::new()).is_none());
//! // `Pvs::to_bytes` / `from_bytes` store it; `hom::cull::PvsCuller` puts it in front of a culler.
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! **Portal cells** ([`PortalCells`], [`Pvs::with_portal_cells`]) sit
//! beside the view cells: a tree of planes whose open leaves each hide what
//! no line through the space's portals reaches ([`portals`]: Teller &
//! Séquin's cell-to-object visibility, lines followed as windows). A Quake 3
//! map's BSP tree and leaf portals give them (`hom_scene::bsp`).
//!
//! **Fusion** (many occluders hiding together) is `fusion.rs`'s point
//! sampling of the scene's solid space eroded as one (Wonka et al. 2000;
//! [`SolidSpace`], under [`crate::experimental::pvs_fusion`]), sound and
//! tested, but off by default: it finds nothing more on the built-in
//! scenes, whose solids are thinner than the erosion or tile a building in
//! convex pieces whose seams the voxels open.
//!
//! **Not yet:** a solid space whose voxels cover the union of convex pieces
//! (not one piece each), planar occluders joined as Law & Tan join adjacent
//! ones (section 5.2), non-convex occluders (section 5.3's AND/OR
//! expression), octree cells for multi-storey maps.

mod bake;
mod cells;
mod file;
mod fusion;
mod margins;
mod planar_union;
mod polygons;
mod portal_cells;
pub mod portals;
mod region;
pub(crate) mod solid;

pub use cells::CellGrid;
pub use file::PvsFileError;
pub use portal_cells::PortalCells;
use solid::SolidSpace;

use crate::geom::{Aabb, View};
use crate::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;
use thiserror::Error;

/// How a PVS is baked. Stored in the file: a PVS says what it assumed.
#[derive(Clone, Debug, PartialEq)]
pub struct PvsConfig {
    /// Edge of a view cell (a leaf of the hierarchy), metres.
    pub cell_size: f32,
    /// Quadtree levels above the cells in a block (a block is
    /// `2^levels × 2^levels` cells).
    pub levels: u32,
    /// How far around each eye of the viewing region cells reach, metres
    /// (in x, z and height).
    pub pad: f32,
    /// Absolute margin added to the distance-scaled ones (metres).
    pub margin: f32,
    /// The nearest near plane (view-space distance) the PVS serves: depth
    /// precision is measured against it.
    pub near: f32,
    /// An occluder hides nothing from a cell closer than this (metres); a
    /// view whose near rectangle's farthest corner lies farther from the eye
    /// is not served (its near plane could clip an occluder).
    pub near_clearance: f32,
    /// Convex polygons of occluder objects' coplanar adjacent triangles
    /// (`polygons.rs`) at least this large (m²) are planar occluders;
    /// `f32::INFINITY` for none.
    pub min_polygon_area: f32,
    /// Use the inscribed solids of occluder objects (their virtual occluders).
    pub solids: bool,
    /// Occluder fusion at the cells (`fusion.rs`): sample points at most this
    /// far apart (metres) over each cell, the solid space eroded by half a
    /// grid box's diagonal and a pixel slack; 0 (the default) for none: it
    /// found nothing more on the built-in scenes (experimental:
    /// [`crate::experimental::pvs_fusion`]).
    pub fusion_spacing: f32,
    /// Fusion: pixels along a side of each of the six cube faces seen from a sample point.
    pub fusion_side: u32,
    /// Fusion: solids within this distance of a cell take part (metres).
    pub fusion_radius: f32,
}

impl Default for PvsConfig {
    fn default() -> Self {
        PvsConfig {
            cell_size: 4.0,
            levels: 3,
            pad: 1.0,
            margin: 1e-3,
            near: 0.1,
            near_clearance: 0.4,
            min_polygon_area: 1.0,
            solids: true,
            fusion_spacing: 0.0,
            fusion_side: 64,
            fusion_radius: 80.0,
        }
    }
}

impl PvsConfig {
    fn validate(&self) -> Result<(), PvsError> {
        let positive = |v: f32| v.is_finite() && v > 0.0;
        let non_negative = |v: f32| v.is_finite() && v >= 0.0;
        if !positive(self.cell_size) {
            return Err(PvsError::BadConfig("cell size must be a positive number of metres"));
        }
        if self.levels > 8 {
            return Err(PvsError::BadConfig("at most 8 quadtree levels above a cell"));
        }
        if !non_negative(self.pad) || !non_negative(self.margin) {
            return Err(PvsError::BadConfig("pad and margin must be finite and not negative"));
        }
        if !positive(self.near) || !non_negative(self.near_clearance - self.near) {
            return Err(PvsError::BadConfig(
                "near must be positive and the near clearance at least the near distance",
            ));
        }
        if !non_negative(self.fusion_spacing) || !non_negative(self.fusion_radius) || self.fusion_side > 1024 {
            return Err(PvsError::BadConfig(
                "fusion spacing and radius must be finite and not negative, and at most 1024 pixels a side",
            ));
        }
        if self.fusion_spacing > 0.0 && self.fusion_side == 0 {
            return Err(PvsError::BadConfig("fusion needs at least one pixel a side"));
        }
        if self.min_polygon_area.is_nan() || self.min_polygon_area < 0.0 {
            return Err(PvsError::BadConfig(
                "min polygon area must be a non-negative number (or infinite)",
            ));
        }
        Ok(())
    }
}

/// Which part of a bake this is: shard `index` of `count` takes the blocks
/// `index * B / count .. (index + 1) * B / count` of the `B` blocks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// This shard, from 0.
    pub index: u32,
    /// How many shards the bake is split into.
    pub count: u32,
}

impl Shard {
    /// The whole bake in one piece.
    pub const WHOLE: Shard = Shard { index: 0, count: 1 };

    fn blocks(&self, total: usize) -> std::ops::Range<usize> {
        let (k, n) = (self.index as usize, self.count as usize);
        k * total / n..(k + 1) * total / n
    }
}

/// Why a PVS could not be baked, merged or used.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum PvsError {
    /// Unusable settings.
    #[error("PVS settings: {0}")]
    BadConfig(&'static str),
    /// No viewpoint to bake for.
    #[error("the viewing region is empty: give a camera path with at least one frame")]
    NoViewpoints,
    /// A viewpoint is not a finite point.
    #[error("viewpoint {index} of the viewing region is not finite ({eye})")]
    BadViewpoint {
        /// Its index.
        index: usize,
        /// The point.
        eye: Vec3,
    },
    /// The shard is not one of the bake's.
    #[error("shard {index}/{count}: the index must be below the count, and the count at least 1")]
    BadShard {
        /// The index given.
        index: u32,
        /// The count given.
        count: u32,
    },
    /// The region needs more cells than a PVS holds.
    #[error("the viewing region needs {nodes} cell-hierarchy nodes (at most {max}): use a larger cell size")]
    TooManyCells {
        /// Nodes needed.
        nodes: usize,
        /// The most allowed.
        max: usize,
    },
    /// The PVS was baked for another scene.
    #[error("this PVS was baked for another scene (fingerprint {baked:016x}, this scene's {scene:016x}): bake it again for this scene")]
    WrongScene {
        /// The fingerprint in the PVS.
        baked: u64,
        /// The scene's.
        scene: u64,
    },
    /// Shards that do not make one bake.
    #[error("cannot merge these shards: {0}")]
    Merge(String),
    /// Portal cells that do not make a tree, or name objects the scene lacks.
    #[error("portal cells: {0}")]
    BadPortalCells(&'static str),
}

/// The most nodes a PVS may hold (a cell hierarchy over 16 km² at 8 m cells).
pub const MAX_NODES: usize = 1 << 22;

/// A baked potentially visible set: cells and their occludee sets.
#[derive(Clone, Debug, PartialEq)]
pub struct Pvs {
    pub(crate) grid: CellGrid,
    pub(crate) config: PvsConfig,
    pub(crate) fingerprint: u64,
    pub(crate) object_count: u32,
    /// Objects kept out of the bake because they move (sorted).
    pub(crate) moving: Vec<u32>,
    /// Objects whose occluders the sets rely on (sorted): the PVS stands
    /// while they stay where they were.
    pub(crate) occluder_objects: Vec<u32>,
    pub(crate) shard: Shard,
    /// Per node of the baked blocks (all blocks once whole): sorted ids.
    pub(crate) sets: Vec<Vec<u32>>,
    /// What the portals hide from each cell of the space's own tree
    /// ([`Pvs::with_portal_cells`]).
    pub(crate) portal_cells: Option<PortalCells>,
}

impl Pvs {
    /// Bakes the PVS of `scene` for viewpoints around `eyes` (a camera
    /// path's eye positions, see [`CellGrid`]), leaving `moving` (objects
    /// that will move) out. `progress` is called once per block baked.
    pub fn bake(
        scene: &Scene,
        eyes: &[Vec3],
        moving: &[u32],
        config: &PvsConfig,
        shard: Shard,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Pvs, PvsError> {
        Pvs::bake_with_solids(scene, eyes, moving, config, None, shard, progress)
    }

    /// [`Pvs::bake`], with the scene's own solid space for fusion (when
    /// [`PvsConfig::fusion_spacing`] is on): space that every segment from
    /// outside enters across an opaque triangle of the scene or through one
    /// of its declared openings (see [`SolidSpace`]), such as the volume a
    /// level editor knows its walls enclose. The inscribed solids of the
    /// scene's closed meshes are added to it. What fusion hides holds for
    /// viewpoints outside the solid space by at least
    /// [`PvsConfig::near_clearance`] (a camera inside a wall sees through it).
    pub fn bake_with_solids(
        scene: &Scene,
        eyes: &[Vec3],
        moving: &[u32],
        config: &PvsConfig,
        solids: Option<&SolidSpace>,
        shard: Shard,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Pvs, PvsError> {
        config.validate()?;
        if shard.count == 0 || shard.index >= shard.count {
            return Err(PvsError::BadShard {
                index: shard.index,
                count: shard.count,
            });
        }
        if eyes.is_empty() {
            return Err(PvsError::NoViewpoints);
        }
        if let Some((index, &eye)) = eyes.iter().enumerate().find(|(_, e)| !e.is_finite()) {
            return Err(PvsError::BadViewpoint { index, eye });
        }
        let (_, blocks) = CellGrid::extent(eyes, config.cell_size, config.levels, config.pad);
        let nodes = CellGrid::nodes_for(blocks, config.levels);
        if nodes > MAX_NODES {
            return Err(PvsError::TooManyCells { nodes, max: MAX_NODES });
        }
        let samples = densify(eyes, config.cell_size / 4.0);
        let grid = CellGrid::around(&samples, config.cell_size, config.levels, config.pad);
        let mut moving = moving.to_vec();
        moving.sort_unstable();
        moving.dedup();
        let is_static = bake::static_objects(scene, &moving);
        let occluders = bake::convex_occluders(scene, &is_static, config);
        let mut occluder_objects: Vec<u32> = occluders.iter().flat_map(|o| o.objects()).copied().collect();
        occluder_objects.sort_unstable();
        occluder_objects.dedup();
        let fused = if config.fusion_spacing > 0.0 {
            // Without a space of the scene's own, the inscribed solids fill a
            // grid over what fusion reaches from the cells, inside the scene.
            let (r, cells, b) = (config.fusion_radius, grid.bounds(), scene.bounds());
            let reach = Aabb::new((cells.min - r).max(b.min), (cells.max + r).min(b.max));
            match (solids, reach.is_empty()) {
                (None, true) => None,
                _ => Some(bake::fusion_space(solids, &occluders, &reach)?.eroded(fusion::erosion(config))),
            }
        } else {
            None
        };
        let ctx = bake::BakeContext::new(&grid, config, &occluders, scene, &is_static, fused);
        let blocks = shard.blocks(grid.block_count());
        let total = blocks.len();
        let done = std::sync::atomic::AtomicUsize::new(0);
        let per_block: Vec<Vec<Vec<u32>>> = blocks
            .into_par_iter()
            .map(|b| {
                let sets = ctx.bake_block(b);
                let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                progress(n, total);
                sets
            })
            .collect();
        Ok(Pvs {
            fingerprint: fingerprint(scene, &moving),
            object_count: scene.objects().len() as u32,
            grid,
            config: config.clone(),
            moving,
            occluder_objects,
            shard,
            sets: per_block.into_iter().flatten().collect(),
            portal_cells: None,
        })
    }

    /// This PVS with portal cells beside its view cells (see
    /// [`PortalCells`]: both sets are hidden). Moving objects are taken out
    /// of the cells' sets. Every shard of a bake takes the same cells.
    pub fn with_portal_cells(mut self, mut cells: PortalCells) -> Result<Pvs, PvsError> {
        if cells.hidden.iter().flatten().any(|&id| id >= self.object_count) {
            return Err(PvsError::BadPortalCells(
                "a cell hides an object the scene does not have",
            ));
        }
        for set in &mut cells.hidden {
            set.retain(|id| self.moving.binary_search(id).is_err());
        }
        self.portal_cells = Some(cells);
        Ok(self)
    }

    /// The portal cells, when the PVS has them.
    pub fn portal_cells(&self) -> Option<&PortalCells> {
        self.portal_cells.as_ref()
    }

    /// The cell hierarchy.
    pub fn cells(&self) -> &CellGrid {
        &self.grid
    }

    /// The settings it was baked with.
    pub fn config(&self) -> &PvsConfig {
        &self.config
    }

    /// The fingerprint of the scene it was baked for ([`fingerprint`]).
    pub fn scene_fingerprint(&self) -> u64 {
        self.fingerprint
    }

    /// Which part of a bake this is ([`Shard::WHOLE`] for a usable PVS).
    pub fn shard(&self) -> Shard {
        self.shard
    }

    /// Objects in the scene it was baked for.
    pub fn object_count(&self) -> usize {
        self.object_count as usize
    }

    /// Objects left out because they move.
    pub fn moving(&self) -> &[u32] {
        &self.moving
    }

    /// Objects whose occluders the sets rely on.
    pub fn occluder_objects(&self) -> &[u32] {
        &self.occluder_objects
    }

    /// Checks that `scene` is the scene this PVS was baked for.
    pub fn check_scene(&self, scene: &Scene) -> Result<(), PvsError> {
        let f = fingerprint(scene, &self.moving);
        if f != self.fingerprint {
            return Err(PvsError::WrongScene {
                baked: self.fingerprint,
                scene: f,
            });
        }
        Ok(())
    }

    fn node_range(&self) -> std::ops::Range<usize> {
        let per = self.grid.nodes_per_block();
        let b = self.shard.blocks(self.grid.block_count());
        b.start * per..b.end * per
    }

    /// The sets of the nodes this PVS holds, in node order, with their node ids.
    pub fn node_sets(&self) -> impl Iterator<Item = (usize, &[u32])> + '_ {
        self.node_range().zip(self.sets.iter().map(Vec::as_slice))
    }

    /// Does this PVS serve `view`: a perspective view whose near rectangle
    /// lies within [`PvsConfig::near_clearance`] of the eye and no nearer
    /// than [`PvsConfig::near`]? Returns the eye when it does.
    pub fn serves(&self, view: &View) -> Option<Vec3> {
        let crate::geom::Eye::Point(eye) = view.eye() else {
            return None;
        };
        let inverse = view.world_to_clip().inverse();
        let mut nearest = f32::INFINITY;
        let mut farthest = 0.0f32;
        for (x, y) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
            let p = inverse.project_point3(Vec3::new(x, y, 0.0));
            let d = p.distance(eye);
            nearest = nearest.min(d);
            farthest = farthest.max(d);
        }
        // The near rectangle's centre is its nearest point to the eye.
        let centre = inverse.project_point3(Vec3::ZERO).distance(eye);
        nearest = nearest.min(centre);
        (self.shard == Shard::WHOLE
            && eye.is_finite()
            && farthest.is_finite()
            && farthest <= self.config.near_clearance
            // Unprojecting through an `f32` inverse is good to ~1e-3 here;
            // the depth margins scale with 1 / near, so 1 % matters little.
            && nearest >= self.config.near * 0.99)
            .then_some(eye)
    }

    /// What this PVS hides from `view` in `scene` as it stands now, into
    /// `out` (cleared, then sorted): nothing unless it [`Pvs::serves`] the
    /// view, and only objects still static and present (the bake used no
    /// other). Returns the eye's leaf cell, as [`Pvs::hidden_from`] does.
    pub fn hidden_in(&self, scene: &Scene, view: &View, out: &mut Vec<u32>) -> Option<usize> {
        out.clear();
        let cell = self.hidden_from(self.serves(view)?, out);
        out.retain(|&id| scene.get(id).is_some_and(|o| !o.is_dynamic()));
        cell
    }

    /// Appends to `out` (sorted) the objects hidden from `eye`, and returns
    /// the leaf cell's node id, or `None` (appending nothing) when `eye` lies
    /// in no cell or this is only a shard. Callers check [`Pvs::serves`] for
    /// the view first. With portal cells, what the eye's portal cell hides
    /// is hidden too, where [`PortalCells::cell_for`] gives one.
    pub fn hidden_from(&self, eye: Vec3, out: &mut Vec<u32>) -> Option<usize> {
        if self.shard != Shard::WHOLE {
            return None;
        }
        let path = self.grid.path_to(eye)?;
        let start = out.len();
        for &node in &path {
            let set = &self.sets[node];
            if set.is_empty() {
                continue;
            }
            // The sets along a path are disjoint: merge the next one in.
            let mid = out.len();
            out.extend_from_slice(set);
            merge_in_place(&mut out[start..], mid - start);
        }
        let portal = self
            .portal_cells
            .as_ref()
            .and_then(|p| Some(p.hidden(p.cell_for(eye, self.config.near_clearance)?)));
        if let Some(set) = portal.filter(|s| !s.is_empty()) {
            // Not disjoint from the view cells' sets: a sorted union.
            let mut tail = out.split_off(start);
            tail.extend_from_slice(set);
            tail.sort_unstable();
            tail.dedup();
            out.extend(tail);
        }
        path.last().copied()
    }

    /// Joins shards of one bake into the whole PVS (byte-identical to
    /// baking it on one machine).
    pub fn merge(shards: Vec<Pvs>) -> Result<Pvs, PvsError> {
        let Some(first) = shards.first() else {
            return Err(PvsError::Merge("no shard given".into()));
        };
        let count = first.shard.count;
        let mut slots: Vec<Option<Pvs>> = vec![None; count as usize];
        for s in &shards {
            let same = s.grid == first.grid
                && s.config == first.config
                && s.fingerprint == first.fingerprint
                && s.object_count == first.object_count
                && s.moving == first.moving
                && s.occluder_objects == first.occluder_objects
                && s.portal_cells == first.portal_cells
                && s.shard.count == count;
            if !same {
                return Err(PvsError::Merge(format!(
                    "shard {}/{} was baked with other settings, for another scene, or into another number of shards than shard {}/{}",
                    s.shard.index, s.shard.count, first.shard.index, count
                )));
            }
            let slot = &mut slots[s.shard.index as usize];
            if slot.is_some() {
                return Err(PvsError::Merge(format!("shard {}/{count} given twice", s.shard.index)));
            }
            *slot = Some(s.clone());
        }
        if let Some(missing) = slots.iter().position(Option::is_none) {
            return Err(PvsError::Merge(format!("shard {missing}/{count} is missing")));
        }
        let mut whole = first.clone();
        whole.shard = Shard::WHOLE;
        whole.sets = slots.into_iter().flatten().flat_map(|s| s.sets).collect();
        Ok(whole)
    }

    /// Set sizes per cell (the merged set along its path), with each cell's
    /// box: what `hom pvs info` and the pictures show.
    pub fn cell_set_sizes(&self) -> Vec<(Aabb, usize)> {
        let mut out = Vec::new();
        self.grid
            .cells()
            .map(|(_, b)| {
                out.clear();
                self.hidden_from(b.center(), &mut out);
                (b, out.len())
            })
            .collect()
    }
}

/// Merges the sorted runs `v[..mid]` and `v[mid..]` (disjoint values).
fn merge_in_place(v: &mut [u32], mid: usize) {
    if mid == 0 || mid == v.len() || v[mid - 1] < v[mid] {
        return;
    }
    let right = v[mid..].to_vec();
    let (mut i, mut j, mut k) = (mid, right.len(), v.len());
    while j > 0 {
        if i > 0 && v[i - 1] > right[j - 1] {
            v[k - 1] = v[i - 1];
            i -= 1;
        } else {
            v[k - 1] = right[j - 1];
            j -= 1;
        }
        k -= 1;
    }
}

/// Points along the polyline `eyes`, no two consecutive farther apart than
/// `step` (so every cell the path passes through holds one).
fn densify(eyes: &[Vec3], step: f32) -> Vec<Vec3> {
    let mut out = vec![eyes[0]];
    for w in eyes.windows(2) {
        let n = ((w[1] - w[0]).length() / step).ceil().clamp(1.0, 1e5) as usize;
        out.extend((1..=n).map(|i| w[0].lerp(w[1], i as f32 / n as f32)));
    }
    out
}

/// FNV-1a over 32-bit words.
#[derive(Clone, Copy)]
pub(crate) struct Fnv(pub(crate) u64);

impl Fnv {
    pub(crate) const NEW: Fnv = Fnv(0xcbf2_9ce4_8422_2325);

    pub(crate) fn word(&mut self, w: u32) {
        for b in w.to_le_bytes() {
            self.0 ^= b as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    pub(crate) fn bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= b as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
}

/// The fingerprint a PVS is tied to: the object count, and every static
/// object not in `moving` (sorted) — its id, occluder flag, transform and
/// mesh. Moving, dynamic and removed objects count by id only: they are
/// never baked.
pub fn fingerprint(scene: &Scene, moving: &[u32]) -> u64 {
    let meshes: Vec<u64> = scene
        .meshes()
        .par_iter()
        .map(|m| {
            let mut h = Fnv::NEW;
            for p in m.positions() {
                p.to_array().iter().for_each(|c| h.word(c.to_bits()));
            }
            for t in m.triangles() {
                t.iter().for_each(|&i| h.word(i));
            }
            h.0
        })
        .collect();
    let mut h = Fnv::NEW;
    h.word(scene.objects().len() as u32);
    for (id, o) in scene.objects().iter().enumerate() {
        h.word(id as u32);
        if moving.binary_search(&(id as u32)).is_ok() || o.is_dynamic() || o.is_removed() {
            h.word(u32::MAX);
            continue;
        }
        h.word(o.occluder as u32);
        o.transform.to_cols_array().iter().for_each(|c| h.word(c.to_bits()));
        let m = meshes[o.mesh as usize];
        h.word(m as u32);
        h.word((m >> 32) as u32);
    }
    h.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Mesh;
    use glam::Mat4;

    /// Two walls (closed boxes, separate objects) side by side with a crate
    /// behind the seam, and a cell in front; the bake's figure of what the
    /// cell's eye at (0, 1.7, 8) finds hidden.
    fn seam(walls: &[Aabb; 2], config: &PvsConfig, solids: Option<&SolidSpace>) -> bool {
        let crate_box = Aabb::new(Vec3::new(-0.5, 1.5, -8.5), Vec3::new(0.5, 2.5, -7.5));
        let mut scene = Scene::new("seam");
        let mut add_box = |name: String, b: &Aabb| {
            let (mut p, mut t) = (Vec::new(), Vec::new());
            crate::occluders::push_box(&mut p, &mut t, b.min, b.max);
            let mesh = scene.add_mesh(Mesh::new(name.clone(), p, t).unwrap());
            scene.add_object(name, mesh, Mat4::IDENTITY).unwrap()
        };
        for (i, w) in walls.iter().enumerate() {
            add_box(format!("wall{i}"), w);
        }
        let crate_ = add_box("crate".into(), &crate_box);
        let eyes: Vec<Vec3> = (0..3).map(|i| Vec3::new(i as f32 - 1.0, 1.7, 8.0)).collect();
        let pvs = Pvs::bake_with_solids(&scene, &eyes, &[], config, solids, Shard::WHOLE, &|_, _| {}).unwrap();
        let mut hidden = Vec::new();
        pvs.hidden_from(Vec3::new(0.0, 1.7, 8.0), &mut hidden).unwrap();
        hidden.contains(&crate_)
    }

    /// Walls whose front faces lie in one plane and share their edge there
    /// exactly hide the crate behind their seam together, as one planar
    /// occluder; moved a hair apart (a T-junction's gap), they do not.
    #[test]
    fn walls_whose_faces_share_an_edge_hide_together() {
        let config = PvsConfig {
            solids: false,
            ..PvsConfig::default()
        };
        let left = Aabb::new(Vec3::new(-20.0, -4.0, -4.0), Vec3::new(0.0, 8.0, 0.0));
        let right = |x0: f32| Aabb::new(Vec3::new(x0, -4.0, -4.0), Vec3::new(20.0, 8.0, 0.0));
        assert!(seam(&[left, right(0.0)], &config, None));
        assert!(!seam(&[left, right(1e-3)], &config, None));
    }

    /// Two walls (closed boxes, separate objects) meeting at a seam where
    /// their front faces are not in one plane: no single wall hides the
    /// crate behind the seam from a cell in front, the solid space the two
    /// fill hides it, given to the bake as the scene's own.
    #[test]
    fn a_given_solid_space_fuses_walls_that_meet() {
        let walls = [
            Aabb::new(Vec3::new(-20.0, -4.0, -4.0), Vec3::new(0.0, 8.0, 0.0)),
            Aabb::new(Vec3::new(0.0, -4.0, -4.5), Vec3::new(20.0, 8.0, -0.5)),
        ];
        let config = PvsConfig {
            solids: false,
            fusion_spacing: 1.0,
            fusion_radius: 30.0,
            ..PvsConfig::default()
        };
        let without = PvsConfig {
            fusion_spacing: 0.0,
            ..config.clone()
        };
        assert!(!seam(&walls, &without, None));
        let bounds = Aabb::new(Vec3::new(-24.0, -6.0, -12.0), Vec3::new(24.0, 10.0, 12.0));
        let space = SolidSpace::from_fn(&bounds, 0.25, |v| {
            walls
                .iter()
                .any(|w| w.min.cmple(v.min + 1e-4).all() && (v.max - 1e-4).cmple(w.max).all())
        })
        .unwrap();
        assert!(seam(&walls, &config, Some(&space)));
    }

    #[test]
    fn merging_sorted_runs() {
        let mut v = vec![1, 4, 9, 2, 3, 10];
        merge_in_place(&mut v, 3);
        assert_eq!(v, [1, 2, 3, 4, 9, 10]);
        let mut w = vec![5, 6, 1];
        merge_in_place(&mut w, 2);
        assert_eq!(w, [1, 5, 6]);
    }
}
