//! The occluder database (Zhang et al. 1997, section 5.3.1; RTR excerpt):
//! preprocessing that keeps the objects likely to be good occluders from most
//! viewpoints and drops the rest, saying why.
//!
//! For dynamic objects the occluder database is the model database (section
//! 5.5): their boxes move, so only pose-independent criteria (size, cost,
//! shape) apply to them, never redundancy.

use super::ground::Ground;
use super::virtual_occluder::{NoVirtual, VirtualConfig, VirtualOccluder};
use crate::geom::Aabb;
use crate::occlusion::details::{faces_turned_away, height_field};
use crate::occlusion::{ClipConvention, ClosedMesh, FaceCull};
use crate::scene::{Mesh, Scene};
use glam::Mat4;
use rayon::prelude::*;
use std::ops::Range;
use std::sync::Arc;

/// Which meshes occluders are drawn with. The default is virtual: on the six
/// built-in walks and two Quake 3 maps it culls as much or more (machine
/// room 1.2 -> 38.0 %, city 81.0 -> 86.9 %, ctf_inyard 8.5 -> 11.4 % HOM
/// efficiency; BENCHMARKS, "Virtual occluders").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum OccluderMeshes {
    /// Each occluder's own mesh.
    Original,
    /// Each occluder's virtual occluder where it has one
    /// ([`VirtualOccluder`], baked per mesh at build time), else its own mesh.
    /// Objects over [`OccluderDbConfig::max_triangles`] become occluders
    /// through their virtual occluders.
    #[default]
    Virtual,
}

impl std::fmt::Display for OccluderMeshes {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            OccluderMeshes::Original => "original",
            OccluderMeshes::Virtual => "virtual",
        })
    }
}

/// Thresholds of the occluder database.
#[derive(Clone, Debug, PartialEq)]
pub struct OccluderDbConfig {
    /// Drop an object whose box's second-largest side is below this (metres):
    /// it covers too little of the screen unless the eye is right next to it.
    pub min_size: f32,
    /// Drop an object with more triangles than this: too costly to render as an occluder.
    pub max_triangles: u32,
    /// Rank an object whose surface fills less than this fraction of its
    /// box's surface (a diagonal pipe, a sparse frame, a corner of a room)
    /// after every other occluder: its box badly overstates what it hides,
    /// so it takes only the budget the others leave. A piece of the ground
    /// this ill-shaped is dropped.
    pub min_fill: f32,
    /// Drop an object whose box lies inside a kept closed occluder's box grown
    /// by this margin (metres) — a clock on a solid wall hides nothing the
    /// wall does not. An open mesh's box never drops anything.
    pub redundancy_margin: f32,
    /// Original meshes or virtual occluders.
    pub meshes: OccluderMeshes,
    /// How virtual occluders are baked (with [`OccluderMeshes::Virtual`]).
    pub virtual_config: VirtualConfig,
}

impl Default for OccluderDbConfig {
    fn default() -> Self {
        OccluderDbConfig {
            min_size: 0.5,
            max_triangles: 20_000,
            min_fill: 0.2,
            redundancy_margin: 0.05,
            meshes: OccluderMeshes::Virtual,
            virtual_config: VirtualConfig::default(),
        }
    }
}

/// Why an object is, or is not, an occluder.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Verdict {
    /// Kept.
    Kept,
    /// Its box is too small.
    TooSmall,
    /// It has too many triangles.
    TooCostly,
    /// It fills too little of its box: an occluder ranked after every other
    /// ([`Occluder::ranked_last`]), or dropped when it is a piece of the ground.
    IllShaped,
    /// A kept closed occluder's box already holds it.
    Redundant,
    /// The scene marks it as never an occluder ([`crate::scene::Object::occluder`]
    /// is false: glass, grates, foliage, liquids), whatever its shape.
    NotAnOccluder,
    /// Removed from the scene.
    Removed,
}

/// An object kept as an occluder.
#[derive(Clone, Debug)]
pub struct Occluder {
    /// The object's id.
    pub object: u32,
    /// A simpler stand-in mesh drawn instead of the object's own (in the
    /// object's space, placed by its transform); `None` draws the object's mesh.
    pub stand_in: Option<Arc<Mesh>>,
    /// Its virtual occluder (with [`OccluderMeshes::Virtual`]), drawn
    /// instead of its mesh from wherever [`VirtualOccluder::usable`] says.
    pub virtual_occluder: Option<Arc<VirtualOccluder>>,
    /// Triangles this occluder costs to draw (its stand-in's or virtual
    /// occluder's, when it has one).
    pub triangles: u32,
    /// Ill-shaped ([`Verdict::IllShaped`]): selected only after every other
    /// candidate in view, with the budget they leave.
    pub ranked_last: bool,
}

/// What an occluder is drawn as this frame ([`OccluderDb::mesh_to_draw`]).
pub(crate) enum ToDraw<'s> {
    /// The object's own mesh.
    Original(&'s Mesh),
    /// A mesh standing in for the object's, with the triangle ranges, in
    /// order, that are boxes (none known for a stand-in set from outside).
    StandIn { mesh: &'s Mesh, boxes: &'s [Range<u32>] },
}

/// The bake of one mesh: not baked (no occluder uses it, or original
/// meshes), a virtual occluder, or why there is none.
pub type MeshBake = Option<Result<Arc<VirtualOccluder>, NoVirtual>>;

/// The preprocessed occluder database.
#[derive(Clone, Debug)]
pub struct OccluderDb {
    occluders: Vec<Occluder>,
    verdicts: Vec<Verdict>,
    config: OccluderDbConfig,
    /// Per mesh id.
    bakes: Vec<MeshBake>,
    /// Per mesh id: whether it is closed or an open height field, and which
    /// way it is turned, checked for the meshes of kept occluders and of
    /// objects that may be pieces of the ground.
    shells: Vec<Shell>,
    /// The ground the opaque height-field objects make, when they make one.
    ground: Option<Ground>,
}

/// What a mesh is as a surface ([`ClosedMesh::of`]), once checked.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
enum Shell {
    /// Not checked yet (no kept occluder has it).
    #[default]
    Unchecked,
    /// Open, or not consistently oriented: drawn two-sided.
    Open,
    /// Closed: drawn without its back faces.
    Closed(ClosedMesh),
    /// An open height field whose triangles all wind counter-clockwise
    /// (`true`) or all clockwise seen from above: drawn without the faces
    /// turned away from the eye.
    HeightField(bool),
}

/// Surface area of a mesh in its own space.
fn mesh_area(mesh: &Mesh) -> f32 {
    let p = mesh.positions();
    mesh.triangles()
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| p[i as usize]);
            (b - a).cross(c - a).length() * 0.5
        })
        .sum()
}

/// Per mesh id, whether some object `verdicts` keeps as an occluder has it.
fn meshes_of_kept(scene: &Scene, verdicts: &[Verdict]) -> Vec<bool> {
    meshes_of(scene, verdicts, |v| v == Verdict::Kept)
}

/// Per mesh id, whether some object whose verdict `wanted` accepts has it.
fn meshes_of(scene: &Scene, verdicts: &[Verdict], wanted: impl Fn(Verdict) -> bool) -> Vec<bool> {
    let mut has = vec![false; scene.meshes().len()];
    for (o, v) in scene.objects().iter().zip(verdicts) {
        has[o.mesh as usize] |= wanted(*v);
    }
    has
}

/// `shells` (by mesh id) with every mesh of a kept occluder checked, in
/// parallel, and every mesh that may be a piece of the ground (`find_ground`).
fn check_shells(scene: &Scene, verdicts: &[Verdict], mut shells: Vec<Shell>) -> Vec<Shell> {
    shells.resize(scene.meshes().len(), Shell::Unchecked);
    shells
        .par_iter_mut()
        .zip(scene.meshes())
        .zip(meshes_of(scene, verdicts, ground_candidate))
        .filter(|((shell, _), wanted)| *wanted && **shell == Shell::Unchecked)
        .for_each(|((shell, mesh), _)| {
            let (p, t) = (mesh.positions(), mesh.triangles());
            *shell = match ClosedMesh::of(p, t) {
                Some(closed) => Shell::Closed(closed),
                None => height_field(p, t).map_or(Shell::Open, Shell::HeightField),
            };
        });
    shells
}

fn second_largest(v: glam::Vec3) -> f32 {
    let mut s = v.to_array();
    s.sort_by(f32::total_cmp);
    s[1]
}

impl OccluderDb {
    /// Bytes held on the heap: the occluders, verdicts and the baked virtual
    /// occluders; stand-in meshes excluded (they are the caller's, shared
    /// through `Arc`).
    pub(crate) fn heap_bytes(&self) -> usize {
        let baked: usize = self
            .bakes
            .iter()
            .flatten()
            .flatten()
            .map(|v| std::mem::size_of_val(v.mesh().positions()) + std::mem::size_of_val(v.mesh().triangles()))
            .sum();
        crate::vec_bytes(&self.occluders)
            + crate::vec_bytes(&self.verdicts)
            + crate::vec_bytes(&self.bakes)
            + crate::vec_bytes(&self.shells)
            + self.ground.as_ref().map_or(0, Ground::heap_bytes)
            + baked
    }

    /// Preprocesses `scene` with `config`.
    pub fn build(scene: &Scene, config: &OccluderDbConfig) -> OccluderDb {
        OccluderDb::build_reusing(scene, config, Vec::new(), Vec::new())
    }

    /// [`OccluderDb::build`], keeping the virtual occluders already baked
    /// in `bakes` and the meshes already checked in `shells` (by mesh id),
    /// baking and checking the rest in parallel.
    fn build_reusing(
        scene: &Scene,
        config: &OccluderDbConfig,
        mut bakes: Vec<MeshBake>,
        shells: Vec<Shell>,
    ) -> OccluderDb {
        // Per-mesh fill ratio, computed once for meshes shared by many objects.
        let fill: Vec<f32> = scene
            .meshes()
            .iter()
            .map(|m| {
                let box_area = m.bounds().surface_area();
                if box_area > 0.0 {
                    mesh_area(m) / box_area
                } else {
                    0.0
                }
            })
            .collect();
        let mut verdicts: Vec<Verdict> = scene
            .objects()
            .iter()
            .map(|o| {
                // Scale the local box by the transform's axis lengths for the world size.
                let scale = glam::Vec3::new(
                    o.transform.x_axis.truncate().length(),
                    o.transform.y_axis.truncate().length(),
                    o.transform.z_axis.truncate().length(),
                );
                let size = scene.mesh_of(o).bounds().extent() * scale;
                if o.is_removed() {
                    Verdict::Removed
                } else if !o.occluder {
                    Verdict::NotAnOccluder
                } else if second_largest(size) < config.min_size {
                    Verdict::TooSmall
                } else if o.triangles > config.max_triangles && config.meshes == OccluderMeshes::Original {
                    Verdict::TooCostly
                } else if fill[o.mesh as usize] < config.min_fill {
                    Verdict::IllShaped
                } else {
                    Verdict::Kept
                }
            })
            .collect();
        bakes.resize(scene.meshes().len(), None);
        if config.meshes == OccluderMeshes::Virtual {
            bakes
                .par_iter_mut()
                .zip(scene.meshes())
                .zip(meshes_of_kept(scene, &verdicts))
                .filter(|((bake, _), wanted)| *wanted && bake.is_none())
                .for_each(|((bake, mesh), _)| {
                    *bake = Some(VirtualOccluder::bake(mesh, &config.virtual_config).map(Arc::new));
                });
            // An object over the triangle limit is an occluder only through its virtual occluder.
            for (o, v) in scene.objects().iter().zip(verdicts.iter_mut()) {
                let baked = matches!(bakes[o.mesh as usize], Some(Ok(_)));
                if *v == Verdict::Kept && o.triangles > config.max_triangles && !baked {
                    *v = Verdict::TooCostly;
                }
            }
        }
        // Shells first: only a closed occluder's box makes another redundant.
        let shells = check_shells(scene, &verdicts, shells);
        let ground = find_ground(scene, &verdicts, &shells);
        mark_redundant(scene, config.redundancy_margin, &shells, &mut verdicts);
        // Ill-shaped objects are occluders ranked last, but for ground
        // pieces, which stay dropped: ranked last they culled less (masked
        // efficiency on chinese_wall, --no-cost-model: 56.0 % dropped, 52.6 %
        // ranked last), likely because a drawn piece stops its neighbours'
        // walls under the edge between them (`draw.rs`).
        let ground_piece = |id: usize| ground.as_ref().is_some_and(|g| g.has_piece(id as u32));
        let occluders = verdicts
            .iter()
            .enumerate()
            .filter(|&(id, v)| *v == Verdict::Kept || (*v == Verdict::IllShaped && !ground_piece(id)))
            .map(|(id, v)| {
                let o = &scene.objects()[id];
                let virtual_occluder = match &bakes[o.mesh as usize] {
                    Some(Ok(v)) => Some(Arc::clone(v)),
                    _ => None,
                };
                Occluder {
                    object: id as u32,
                    stand_in: None,
                    triangles: virtual_occluder
                        .as_ref()
                        .map_or(o.triangles, |v| v.mesh().triangle_count() as u32),
                    virtual_occluder,
                    ranked_last: *v == Verdict::IllShaped,
                }
            })
            .collect();
        OccluderDb {
            occluders,
            verdicts,
            config: config.clone(),
            bakes,
            shells,
            ground,
        }
    }

    /// The virtual occluder baked for mesh `mesh`, why there is none, or
    /// `None` when it was not baked (original meshes, or no occluder uses it).
    pub fn bake_of_mesh(&self, mesh: u32) -> Option<Result<&VirtualOccluder, &NoVirtual>> {
        match self.bakes.get(mesh as usize)? {
            Some(Ok(v)) => Some(Ok(v)),
            Some(Err(e)) => Some(Err(e)),
            None => None,
        }
    }

    /// The mesh drawn for occluder `occluder`: its stand-in, or its virtual
    /// occluder when usable from `eye` through `frustum` (unless `original`
    /// asks for the object's own), or the object's own; `None` when nothing
    /// should be drawn (an object over the triangle limit whose virtual
    /// occluder is not usable from here).
    pub(crate) fn mesh_to_draw<'s>(
        &'s self,
        scene: &'s Scene,
        occluder: &'s Occluder,
        eye: &crate::geom::Eye,
        frustum: &crate::geom::Frustum,
        original: bool,
    ) -> Option<ToDraw<'s>> {
        let o = scene.object(occluder.object);
        if let Some(mesh) = &occluder.stand_in {
            return Some(ToDraw::StandIn { mesh, boxes: &[] });
        }
        match &occluder.virtual_occluder {
            Some(v) if !original && v.usable(&o.transform, &o.aabb, eye, frustum) => Some(ToDraw::StandIn {
                mesh: v.mesh(),
                boxes: v.box_pieces(),
            }),
            _ if o.triangles > self.config.max_triangles => None,
            _ => Some(ToDraw::Original(scene.mesh_of(o))),
        }
    }

    /// The faces to drop when drawing the kept occluder `object` as its own
    /// mesh, placed by `model_to_clip` (hom's clip convention): its back
    /// faces when the mesh is closed ([`ClosedMesh::back_faces`]) or an
    /// open height field (`occlusion/closed_mesh.rs`), else none.
    pub(crate) fn faces_to_drop(&self, scene: &Scene, object: u32, model_to_clip: &Mat4) -> FaceCull {
        match self.shells.get(scene.object(object).mesh as usize) {
            Some(Shell::Closed(closed)) => closed.back_faces(model_to_clip, ClipConvention::ZeroToOne),
            Some(Shell::HeightField(up_ccw)) => faces_turned_away(*up_ccw, model_to_clip, ClipConvention::ZeroToOne),
            _ => FaceCull::None,
        }
    }

    /// The ground the scene's opaque height-field objects make, when they
    /// make one (`occluders/ground.rs`).
    pub(crate) fn ground(&self) -> Option<&Ground> {
        self.ground.as_ref()
    }

    /// The walls the cullers draw under `object` of `scene` (the scene this
    /// database was built for) in a view from `eye`
    /// through `world_to_clip` (hom's clip convention), by the inner rule
    /// ([`crate::occlusion::OcclusionBuffer::render_stand_in_triangles`]):
    /// world positions and triangles. Empty unless `object` is a piece of
    /// the ground the scene's height-field occluders make and the eye is
    /// above it, clear of it by more than the near plane's reach
    /// (`occluders/ground.rs` says why that is safe).
    pub fn ground_walls(
        &self,
        scene: &Scene,
        object: u32,
        eye: &crate::geom::Eye,
        world_to_clip: &Mat4,
    ) -> (Vec<glam::Vec3>, Vec<[u32; 3]>) {
        let (mut positions, mut triangles) = (Vec::new(), Vec::new());
        if let Some((ground, e)) = self
            .ground
            .as_ref()
            .and_then(|g| Some((g, g.eye_for(scene, eye, world_to_clip)?)))
        {
            ground.walls_facing(object, e, &[], &mut positions, &mut triangles);
        }
        (positions, triangles)
    }

    /// How many objects make the scene's ground (0 when its height-field
    /// occluders make none): pieces that get walls.
    pub fn ground_pieces(&self) -> usize {
        self.ground.as_ref().map_or(0, Ground::pieces)
    }

    /// The kept occluder `object`, when it is one.
    pub fn occluder(&self, object: u32) -> Option<&Occluder> {
        let i = self.occluders.binary_search_by_key(&object, |o| o.object).ok()?;
        Some(&self.occluders[i])
    }

    /// Every object as an occluder, no preprocessing (for tests and tiny scenes),
    /// except objects the scene marks as never occluders ([`Verdict::NotAnOccluder`]).
    pub fn all(scene: &Scene) -> OccluderDb {
        let mut db = OccluderDb {
            occluders: scene
                .objects()
                .iter()
                .enumerate()
                .filter(|(_, o)| o.occluder)
                .map(|(id, o)| Occluder {
                    object: id as u32,
                    stand_in: None,
                    virtual_occluder: None,
                    triangles: o.triangles,
                    ranked_last: false,
                })
                .collect(),
            verdicts: scene
                .objects()
                .iter()
                .map(|o| {
                    if o.occluder {
                        Verdict::Kept
                    } else {
                        Verdict::NotAnOccluder
                    }
                })
                .collect(),
            config: OccluderDbConfig::default(),
            bakes: Vec::new(),
            shells: Vec::new(),
            ground: None,
        };
        db.shells = check_shells(scene, &db.verdicts, Vec::new());
        db.ground = find_ground(scene, &db.verdicts, &db.shells);
        db
    }

    /// The kept occluders, in object id order.
    pub fn occluders(&self) -> &[Occluder] {
        &self.occluders
    }

    /// The verdict for every object, indexed by id.
    pub fn verdicts(&self) -> &[Verdict] {
        &self.verdicts
    }

    /// The configuration it was built with.
    pub fn config(&self) -> &OccluderDbConfig {
        &self.config
    }

    /// Rebuilds the database for `scene` as it is now (after objects were
    /// added, removed, made dynamic or re-flagged) with its configuration,
    /// keeping the stand-ins of objects that are still occluders.
    pub fn rebuild(&mut self, scene: &Scene) {
        let config = self.config.clone();
        let (bakes, shells) = (std::mem::take(&mut self.bakes), std::mem::take(&mut self.shells));
        let old = std::mem::replace(self, OccluderDb::build_reusing(scene, &config, bakes, shells));
        for o in old.occluders {
            if let Some(mesh) = o.stand_in {
                self.set_stand_in(o.object, mesh);
            }
        }
    }

    /// The stand-in mesh of `object`, when it is an occluder that has one.
    pub fn stand_in(&self, object: u32) -> Option<&Mesh> {
        let i = self.occluders.binary_search_by_key(&object, |o| o.object).ok()?;
        self.occluders[i].stand_in.as_deref()
    }

    /// Replaces an occluder's stand-in mesh (for example a simplified one).
    /// Returns false when `object` is not an occluder.
    pub fn set_stand_in(&mut self, object: u32, mesh: Arc<Mesh>) -> bool {
        match self.occluders.binary_search_by_key(&object, |o| o.object) {
            Ok(i) => {
                self.occluders[i].triangles = mesh.triangle_count() as u32;
                self.occluders[i].stand_in = Some(mesh);
                true
            }
            Err(_) => false,
        }
    }

    /// A one-line account: how many kept, how many ranked last, and how
    /// many dropped for each reason.
    pub fn report(&self) -> String {
        let count = |v: Verdict| self.verdicts.iter().filter(|&&x| x == v).count();
        let last = self.occluders.iter().filter(|o| o.ranked_last).count();
        format!(
            "{} of {} objects kept as occluders, and {} ill-shaped ones (fill < {}) ranked after them; dropped: {} too small (< {} m), {} too costly (> {} triangles), {} ill-shaped ground pieces, {} redundant, {} never occluders (see-through)",
            count(Verdict::Kept),
            self.verdicts.len(),
            last,
            self.config.min_fill,
            count(Verdict::TooSmall),
            self.config.min_size,
            count(Verdict::TooCostly),
            self.config.max_triangles,
            count(Verdict::IllShaped) - last,
            count(Verdict::Redundant),
            count(Verdict::NotAnOccluder),
        ) + &self.ground.as_ref().map_or(String::new(), |g| {
            format!("; {} ground pieces with {} walls", g.pieces(), g.walls())
        })
            + &self.virtual_report()
    }

    /// With virtual occluders: how many occluders have one, and their size.
    fn virtual_report(&self) -> String {
        if self.config.meshes != OccluderMeshes::Virtual {
            return String::new();
        }
        let with: Vec<&Occluder> = self.occluders.iter().filter(|o| o.virtual_occluder.is_some()).collect();
        let triangles: u64 = with.iter().map(|o| u64::from(o.triangles)).sum();
        format!(
            "; {} with virtual occluders ({} triangles, {:.1} on average)",
            with.len(),
            triangles,
            triangles as f64 / with.len().max(1) as f64
        )
    }
}

/// The ground made by the static, opaque objects not dropped for their cost
/// whose meshes are open height fields (`shells`, by mesh id), when they
/// make one. A piece dropped as too small, or ill-shaped (no occluder,
/// unlike other ill-shaped objects), is still part of the ground (the
/// renderer draws it) but gets no walls. Keeping the ill-shaped pieces as
/// occluders was tried and culled less, the budget going to them (`hom
/// bench --cullers frustum,masked --frames 100 --no-cost-model`, masked
/// efficiency with them kept / not: chinese_wall 40.4 / 56.9 %, wild_ride
/// 52.7 / 55.4 %, bunny_hill 37.0 / 37.7 %), and so was ranking them last
/// (chinese_wall 52.6 / 56.0 %).
fn find_ground(scene: &Scene, verdicts: &[Verdict], shells: &[Shell]) -> Option<Ground> {
    let candidates: Vec<u32> = scene
        .objects()
        .iter()
        .enumerate()
        .filter(|(id, o)| {
            ground_candidate(verdicts[*id])
                && !o.is_dynamic()
                && matches!(shells.get(o.mesh as usize), Some(Shell::HeightField(_)))
        })
        .map(|(id, _)| id as u32)
        .collect();
    if candidates.is_empty() {
        return None;
    }
    Ground::find(scene, &candidates)
}

/// Whether an object with this verdict may be a piece of the ground: drawn
/// opaque by the renderer, whatever its size or fill.
fn ground_candidate(v: Verdict) -> bool {
    matches!(v, Verdict::Kept | Verdict::IllShaped | Verdict::TooSmall)
}

/// Fewest objects a closed occluder's box holds, besides half the others,
/// to be the level's enclosure (see [`mark_redundant`]).
const ENCLOSURE_HOLDS: usize = 16;

/// Marks static kept objects whose box sits inside the box of a larger,
/// static, kept and closed occluder (`shells`, by mesh id) that does not
/// enclose the level (its box holding half the others, and at least
/// [`ENCLOSURE_HOLDS`]). Only a closed
/// mesh's box stands for what it hides: the box of an open one (terrain, a
/// road, a level's floor, a sky) holds everything standing on or under it
/// and hides none of it (ctf_inyard, cut into objects of at most 64
/// triangles: 438 of 2,803 objects were absorbed, every one by an open
/// mesh's box; HOM efficiency 82.2 -> 84.6 %).
fn mark_redundant(scene: &Scene, margin: f32, shells: &[Shell], verdicts: &mut [Verdict]) {
    let objects = scene.objects();
    let mut kept: Vec<u32> = (0..objects.len() as u32)
        .filter(|&i| verdicts[i as usize] == Verdict::Kept && !objects[i as usize].is_dynamic())
        .collect();
    // Largest first, so a box is only ever absorbed by a bigger, still-kept one.
    kept.sort_by(|&a, &b| {
        let va = objects[a as usize].aabb.surface_area();
        let vb = objects[b as usize].aabb.surface_area();
        vb.total_cmp(&va).then(a.cmp(&b))
    });
    let boxes: Vec<Aabb> = kept.iter().map(|&i| objects[i as usize].aabb).collect();
    let bvh = crate::spatial::Bvh::build(&boxes, &crate::spatial::BvhConfig::default());
    let grown = |b: &Aabb| Aabb::new(b.min - margin, b.max + margin);
    // A closed mesh whose box holds half the others is the level's
    // enclosure (a sky box, a room as one mesh), not a solid among them:
    // the eye is inside it, where it hides nothing (ctf_compromise's sky
    // box held 1,270 of its 1,271 occluders).
    let mut hits = Vec::new();
    let closed: Vec<bool> = kept
        .iter()
        .enumerate()
        .map(|(k, &i)| {
            if !matches!(shells.get(objects[i as usize].mesh as usize), Some(Shell::Closed(_))) {
                return false;
            }
            let around = grown(&boxes[k]);
            hits.clear();
            bvh.overlapping(&around, &mut hits);
            let held = hits
                .iter()
                .filter(|&&j| j as usize != k && around.contains(&boxes[j as usize]))
                .count();
            held < ENCLOSURE_HOLDS || 2 * held < kept.len() - 1
        })
        .collect();
    let mut absorbed = vec![false; kept.len()];
    for (k, &id) in kept.iter().enumerate() {
        let b = boxes[k];
        hits.clear();
        bvh.overlapping(&grown(&b), &mut hits);
        let inside_bigger = hits.iter().any(|&j| {
            let j = j as usize;
            j < k && !absorbed[j] && closed[j] && grown(&boxes[j]).contains(&b)
        });
        if inside_bigger {
            absorbed[k] = true;
            verdicts[id as usize] = Verdict::Redundant;
        }
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::scene::SceneBuilder;
    use glam::{Mat4, Vec3};

    /// Two big walls, the second marked see-through.
    fn two_walls() -> Scene {
        let mut b = SceneBuilder::new("walls");
        let wall = crate::scene::Mesh::new(
            "wall",
            vec![
                Vec3::ZERO,
                Vec3::new(4.0, 0.0, 0.0),
                Vec3::new(4.0, 3.0, 0.0),
                Vec3::new(0.0, 3.0, 0.0),
                Vec3::new(0.0, 0.0, 0.2),
                Vec3::new(4.0, 3.0, 0.2),
            ],
            vec![[0, 1, 2], [0, 2, 3], [4, 1, 5]],
        )
        .unwrap();
        let m = b.add_mesh(wall);
        b.add_object("opaque", m, Mat4::IDENTITY).unwrap();
        b.add_object("glass", m, Mat4::from_translation(Vec3::new(10.0, 0.0, 0.0)))
            .unwrap();
        assert!(b.set_occluder(1, false));
        b.build().unwrap()
    }

    /// `hom_testkit::cube()` (the unit cube about the origin), without its
    /// top face (y = 0.5) when `open`.
    fn cube(open: bool) -> crate::scene::Mesh {
        let kit = hom_testkit::cube();
        let p = kit.positions().to_vec();
        let mut t = kit.triangles().to_vec();
        if open {
            t.retain(|tri| !tri.iter().all(|&i| p[i as usize].y > 0.0));
        }
        assert_eq!(t.len(), if open { 10 } else { 12 });
        crate::scene::Mesh::new("cube", p, t).unwrap()
    }

    /// A closed occluder whose box holds half the level is its enclosure:
    /// it makes nothing redundant.
    #[test]
    fn a_closed_enclosure_makes_nothing_redundant() {
        // A closed box around twenty small cubes (a level within its sky
        // box): the eye is inside it, so every cube stays an occluder; a
        // closed box around one cube among twenty still absorbs it.
        for around_all in [true, false] {
            let mut b = SceneBuilder::new("enclosed");
            let cube_mesh = b.add_mesh(cube(false));
            let (centre, scale) = if around_all {
                (Vec3::splat(10.0), 30.0)
            } else {
                (Vec3::ZERO, 3.0)
            };
            b.add_object(
                "enclosure",
                cube_mesh,
                Mat4::from_translation(centre) * Mat4::from_scale(Vec3::splat(scale)),
            )
            .unwrap();
            for k in 0..20 {
                let at = Vec3::new((k % 5) as f32 * 4.0, (k / 5) as f32 * 4.0, 0.0);
                b.add_object(format!("cube{k}"), cube_mesh, Mat4::from_translation(at))
                    .unwrap();
            }
            let scene = b.build().unwrap();
            let db = OccluderDb::build(&scene, &OccluderDbConfig::default());
            let redundant = db.verdicts().iter().filter(|&&v| v == Verdict::Redundant).count();
            assert_eq!(redundant, usize::from(!around_all), "around all: {around_all}");
        }
    }

    /// Only a closed occluder's box makes the objects inside it redundant:
    /// an open mesh (a courtyard's walls, terrain, a sky) hides nothing by
    /// holding it.
    #[test]
    fn only_closed_boxes_make_others_redundant() {
        for open in [false, true] {
            let mut b = SceneBuilder::new("boxes");
            let big = b.add_mesh(cube(open));
            let small = b.add_mesh(cube(false));
            b.add_object("big", big, Mat4::from_scale(Vec3::splat(10.0))).unwrap();
            b.add_object("small", small, Mat4::from_translation(Vec3::splat(4.0)))
                .unwrap();
            let scene = b.build().unwrap();
            let db = OccluderDb::build(&scene, &OccluderDbConfig::default());
            let inner = if open { Verdict::Kept } else { Verdict::Redundant };
            assert_eq!(db.verdicts(), &[Verdict::Kept, inner], "open: {open}");
        }
    }

    /// A wall filling its box as a floor does (0.5), 5 m down -z, and a
    /// thin sliver along a diagonal of a 4 m box about the origin, which
    /// fills almost none of it (objects 0 and 1).
    pub(in crate::occluders) fn wall_and_sliver() -> Scene {
        let mut b = SceneBuilder::new("wall and sliver");
        let wall = crate::scene::Mesh::new(
            "wall",
            vec![
                Vec3::new(-2.0, 0.0, 0.0),
                Vec3::new(2.0, 0.0, 0.0),
                Vec3::new(2.0, 3.0, 0.0),
                Vec3::new(-2.0, 3.0, 0.0),
            ],
            vec![[0, 1, 2], [0, 2, 3]],
        )
        .unwrap();
        let sliver = crate::scene::Mesh::new(
            "sliver",
            vec![
                Vec3::new(-2.0, 0.0, -2.0),
                Vec3::new(2.0, 4.0, 2.0),
                Vec3::new(-1.9, 0.0, -2.0),
                Vec3::new(2.0, 4.0, 1.9),
            ],
            vec![[0, 1, 2], [2, 1, 3]],
        )
        .unwrap();
        let (wall, sliver) = (b.add_mesh(wall), b.add_mesh(sliver));
        b.add_object("wall", wall, Mat4::from_translation(Vec3::new(0.0, 0.0, -5.0)))
            .unwrap();
        b.add_object("sliver", sliver, Mat4::IDENTITY).unwrap();
        b.build().unwrap()
    }

    /// An ill-shaped object is an occluder ranked after the others, not
    /// dropped: its box overstates what it hides, not what it is.
    #[test]
    fn ill_shaped_objects_are_occluders_ranked_last() {
        let scene = wall_and_sliver();
        let db = OccluderDb::build(&scene, &OccluderDbConfig::default());
        assert_eq!(db.verdicts(), &[Verdict::Kept, Verdict::IllShaped]);
        let ranks: Vec<(u32, bool)> = db.occluders().iter().map(|o| (o.object, o.ranked_last)).collect();
        assert_eq!(ranks, vec![(0, false), (1, true)]);
        let report = db.report();
        assert!(
            report.contains("1 of 2 objects kept as occluders, and 1 ill-shaped ones (fill < 0.2) ranked after them"),
            "{report}"
        );
        assert!(report.contains("0 ill-shaped ground pieces"), "{report}");
    }

    #[test]
    fn see_through_objects_are_never_occluders() {
        let scene = two_walls();
        let config = OccluderDbConfig {
            min_fill: 0.0,
            ..OccluderDbConfig::default()
        };
        for db in [OccluderDb::build(&scene, &config), OccluderDb::all(&scene)] {
            assert_eq!(db.verdicts(), &[Verdict::Kept, Verdict::NotAnOccluder]);
            let ids: Vec<u32> = db.occluders().iter().map(|o| o.object).collect();
            assert_eq!(ids, vec![0]);
        }
        assert!(OccluderDb::build(&scene, &config)
            .report()
            .contains("1 never occluders"));
    }
}
