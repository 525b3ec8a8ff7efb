//! The bake: occludee sets per node of the cell hierarchy (Law & Tan 1999,
//! section 5.2).
//!
//! Occluders are the scene's static occluder objects as convex pieces: the
//! inscribed solids of their virtual occluders (boxes and hulls, baked here
//! with no triangle budget to speak of, since a stand-in's size costs the
//! bake little and the run time nothing), and their large convex polygons
//! of coplanar adjacent triangles as planar occluders. Occludees are the nodes of a BVH over the static
//! objects, so a node hidden whole is recorded for all its objects at once.
//!
//! Each block's quadtree is walked top-down, as the paper does: a node
//! records the occludees hidden from its whole box that no ancestor
//! recorded, and hands the rest to its children, so only the highest cells
//! are recorded and the sets along a path are disjoint. An occludee is
//! hidden when one occluder hides it from the whole cell
//! ([`ConvexOccluder::hides`]); the candidates are the occluders the segment
//! between the cell's and the occludee's centres crosses (every segment must
//! cross the one that hides), found in a BVH over the occluders.

use super::margins::Margins;
use super::planar_union::planar_unions;
use super::region::{ConvexOccluder, DPlane, Shape};
use super::solid::{Eroded, SolidSpace, MAX_VOXELS};
use super::PvsError;
use super::{CellGrid, PvsConfig};
use crate::geom::Aabb;
use crate::occluders::{VirtualConfig, VirtualOccluder};
use crate::scene::Scene;
use crate::spatial::{Bvh, BvhConfig};
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::ops::Range;

/// Triangle budget of a mesh's inscribed solids for the bake (40 boxes).
const SOLID_BUDGET: usize = 480;

/// The static objects the bake may use: live, not dynamic, not listed as
/// moving.
pub(crate) fn static_objects(scene: &Scene, moving: &[u32]) -> Vec<bool> {
    scene
        .objects()
        .iter()
        .enumerate()
        .map(|(id, o)| !o.is_removed() && !o.is_dynamic() && moving.binary_search(&(id as u32)).is_err())
        .collect()
}

/// The convex occluders of the static occluder objects, in object order.
pub(crate) fn convex_occluders(scene: &Scene, is_static: &[bool], config: &PvsConfig) -> Vec<ConvexOccluder> {
    let objects = scene.objects();
    let used: Vec<bool> = {
        let mut u = vec![false; scene.meshes().len()];
        for (o, _) in objects.iter().zip(is_static).filter(|(o, &s)| s && o.occluder) {
            u[o.mesh as usize] = true;
        }
        u
    };
    let vconfig = VirtualConfig {
        min_coverage: 0.0,
        ..VirtualConfig::default()
    };
    let solids: Vec<Option<VirtualOccluder>> = scene
        .meshes()
        .par_iter()
        .zip(&used)
        .map(|(m, &u)| {
            if u && config.solids {
                VirtualOccluder::bake_solids(m, &vconfig, SOLID_BUDGET).ok()
            } else {
                None
            }
        })
        .collect();
    let polygons: Vec<Vec<Vec<Vec3>>> = scene
        .meshes()
        .par_iter()
        .zip(&used)
        .map(|(m, &u)| {
            if u && config.min_polygon_area.is_finite() {
                super::polygons::convex_polygons(m)
            } else {
                Vec::new()
            }
        })
        .collect();
    let min_area = config.min_polygon_area as f64;
    let mut occluders: Vec<ConvexOccluder> = objects
        .par_iter()
        .enumerate()
        .filter(|(id, o)| is_static[*id] && o.occluder)
        .flat_map_iter(|(id, o)| {
            let t = o.transform;
            let world = move |p: Vec3| t.transform_point3(p);
            let mut out = Vec::new();
            if let Some(v) = &solids[o.mesh as usize] {
                let m = v.mesh();
                let above = v.floor().map(|f| {
                    // Object-space "y > f", taken to the world through the transform.
                    let p = world(Vec3::new(0.0, f, 0.0)).as_dvec3();
                    let n = t
                        .inverse()
                        .transpose()
                        .transform_vector3(Vec3::Y)
                        .as_dvec3()
                        .normalize();
                    DPlane {
                        normal: -n,
                        d: n.dot(p),
                    }
                });
                for piece in v.convex_pieces() {
                    let tris: Vec<[Vec3; 3]> = m.triangles()[piece.start as usize..piece.end as usize]
                        .iter()
                        .map(|tri| tri.map(|i| world(m.positions()[i as usize])))
                        .collect();
                    out.extend(ConvexOccluder::solid(id as u32, &tris, above));
                }
            }
            for polygon in &polygons[o.mesh as usize] {
                let c: Vec<Vec3> = polygon.iter().map(|&p| world(p)).collect();
                let d: Vec<DVec3> = c.iter().map(|p| p.as_dvec3()).collect();
                let area: f64 = (1..d.len() - 1)
                    .map(|i| 0.5 * (d[i] - d[0]).cross(d[i + 1] - d[0]).length())
                    .sum();
                if area >= min_area {
                    out.extend(ConvexOccluder::polygon(id as u32, &c));
                }
            }
            out
        })
        .collect();
    if config.min_polygon_area.is_finite() {
        occluders.extend(joined_planes(scene, is_static, min_area));
    }
    occluders
}

/// Triangles of the static occluder objects that lie exactly in one
/// axis-aligned plane, joined per plane (`pvs/planar_union.rs`): walls with
/// doorways, slabs meeting edge to edge. Planes of fewer than three
/// triangles or less than `min_area` are left to the convex polygons.
fn joined_planes(scene: &Scene, is_static: &[bool], min_area: f64) -> Vec<ConvexOccluder> {
    let triangles: Vec<(u32, [Vec3; 3])> = scene
        .objects()
        .par_iter()
        .enumerate()
        .filter(|(id, o)| is_static[*id] && o.occluder)
        .flat_map_iter(|(id, o)| {
            let m = scene.mesh_of(o);
            let t = o.transform;
            m.triangles()
                .iter()
                .map(move |tri| tri.map(|i| t.transform_point3(m.positions()[i as usize])))
                .filter(|w| (0..3).any(|k| w[0][k] == w[1][k] && w[1][k] == w[2][k]))
                .map(move |w| (id as u32, w))
        })
        .collect();
    planar_unions(&triangles, 3, min_area)
        .into_iter()
        .map(ConvexOccluder::union)
        .collect()
}

/// The solid space fusion erodes: `given` (a scene's own) or an empty grid
/// over `reach`, with the inscribed solids among `occluders` added, each
/// voxel wholly inside one of them (a floor cap, open in the original, is
/// declared an opening). Voxels are 0.1 m, or as large as `reach` needs to
/// stay within half of [`MAX_VOXELS`].
pub(crate) fn fusion_space(
    given: Option<&SolidSpace>,
    occluders: &[ConvexOccluder],
    reach: &Aabb,
) -> Result<SolidSpace, PvsError> {
    let mut space = match given {
        Some(s) => s.clone(),
        None => {
            let volume = reach.extent().as_dvec3().to_array().iter().product::<f64>();
            let voxel = (volume / (MAX_VOXELS / 2) as f64).cbrt().max(0.1) as f32;
            SolidSpace::new(reach, voxel)?
        }
    };
    for o in occluders {
        let Shape::Solid(planes) = &o.shape else { continue };
        space.add_convex(planes, &o.bounds);
        if let Some(above) = &o.above {
            // The floor cap is not drawn: an opening, a thin box on a level
            // floor (a segment from a cell above it never crosses it), or
            // the solid's whole box on a tilted one.
            let up = -above.normal;
            let cap = if up.y.abs() > 0.999 {
                let y = (above.d / up.y) as f32;
                Aabb::new(
                    Vec3::new(o.bounds.min.x, y - 1e-3, o.bounds.min.z),
                    Vec3::new(o.bounds.max.x, y + 1e-3, o.bounds.max.z),
                )
            } else {
                o.bounds
            };
            space.add_opening(cap);
        }
    }
    Ok(space)
}

/// What every block's bake shares.
pub(crate) struct BakeContext<'a> {
    pub(crate) grid: &'a CellGrid,
    pub(crate) config: &'a PvsConfig,
    pub(crate) occluders: &'a [ConvexOccluder],
    pub(crate) occluder_bvh: Bvh,
    /// Object boxes (empty for objects the bake does not use).
    pub(crate) boxes: Vec<Aabb>,
    pub(crate) object_bvh: Bvh,
    /// The solid space eroded for fusion (`fusion.rs`), when fusion is on.
    pub(crate) fused: Option<Eroded>,
    /// Per object: its index in `object_bvh.items()`.
    pub(crate) item_pos: Vec<u32>,
}

impl<'a> BakeContext<'a> {
    pub(crate) fn new(
        grid: &'a CellGrid,
        config: &'a PvsConfig,
        occluders: &'a [ConvexOccluder],
        scene: &Scene,
        is_static: &[bool],
        fused: Option<Eroded>,
    ) -> BakeContext<'a> {
        let occluder_boxes: Vec<Aabb> = occluders.iter().map(|o| o.bounds).collect();
        let occluder_bvh = Bvh::build(&occluder_boxes, &BvhConfig::default());
        let boxes: Vec<Aabb> = scene
            .objects()
            .iter()
            .zip(is_static)
            .map(|(o, &s)| if s { o.aabb } else { Aabb::EMPTY })
            .collect();
        let object_bvh = Bvh::build(&boxes, &BvhConfig::default());
        let mut item_pos = vec![u32::MAX; boxes.len()];
        for (i, &item) in object_bvh.items().iter().enumerate() {
            item_pos[item as usize] = i as u32;
        }
        BakeContext {
            grid,
            config,
            occluders,
            occluder_bvh,
            boxes,
            object_bvh,
            item_pos,
            fused,
        }
    }

    /// Does one occluder, not of the objects in `items` (a range of the
    /// object BVH's items), hide `x` from the whole `cell`?
    fn hidden(&self, cell: &Aabb, x: &Aabb, items: Range<usize>, stack: &mut Vec<u32>) -> bool {
        let margins = Margins::for_pair(cell, x, self.config.margin as f64, self.config.near as f64);
        let (a, b) = (cell.center().as_dvec3(), x.center().as_dvec3());
        let nodes = self.occluder_bvh.nodes();
        if nodes.is_empty() {
            return false;
        }
        stack.clear();
        stack.push(0);
        while let Some(n) = stack.pop() {
            let node = &nodes[n as usize];
            if !segment_meets_box(a, b, &node.bounds) {
                continue;
            }
            if !node.is_leaf() {
                stack.push(node.first + 1);
                stack.push(node.first);
                continue;
            }
            for &o in self.occluder_bvh.leaf_items(node) {
                let occ = &self.occluders[o as usize];
                let own = items.contains(&(self.item_pos[occ.object as usize] as usize));
                if own || occ.too_near(cell, self.config.near_clearance) || !occ.crossed_by(a, b, margins.lateral) {
                    continue;
                }
                if occ.hides(cell, x, margins) {
                    return true;
                }
            }
        }
        false
    }

    /// Bakes one block: the sets of its nodes, in node order.
    pub(crate) fn bake_block(&self, block: usize) -> Vec<Vec<u32>> {
        let mut sets = vec![Vec::new(); self.grid.nodes_per_block()];
        if self.object_bvh.nodes().is_empty() {
            return sets;
        }
        let mut flagged = vec![false; self.boxes.len()];
        let mut stack = Vec::new();
        self.visit(
            block,
            0,
            0,
            0,
            vec![Occludee::Node(0)],
            &mut flagged,
            &mut sets,
            &mut stack,
        );
        sets
    }

    #[allow(clippy::too_many_arguments)]
    fn visit(
        &self,
        block: usize,
        level: u32,
        x: usize,
        z: usize,
        occludees: Vec<Occludee>,
        flagged: &mut [bool],
        sets: &mut [Vec<u32>],
        stack: &mut Vec<u32>,
    ) {
        let Some(cell) = self.grid.node_box(block, level, x, z) else {
            return;
        };
        let items = self.object_bvh.items();
        let mut hidden = Vec::new();
        let mut pass = Vec::new();
        for root in occludees {
            let mut all_hidden = true;
            let mut work = vec![root];
            while let Some(o) = work.pop() {
                match o {
                    Occludee::Node(n) => {
                        let node = self.object_bvh.nodes()[n as usize];
                        let range = self.object_bvh.subtree_range(&node);
                        let members = &items[range.clone()];
                        if members.iter().all(|&i| flagged[i as usize]) {
                            continue;
                        }
                        if self.hidden(&cell, &node.bounds, range, stack) {
                            hidden.extend(members.iter().copied().filter(|&i| !flagged[i as usize]));
                        } else if node.is_leaf() {
                            work.extend(
                                self.object_bvh
                                    .leaf_items(&node)
                                    .iter()
                                    .filter(|&&i| !flagged[i as usize] && !self.boxes[i as usize].is_empty())
                                    .map(|&i| Occludee::Object(i)),
                            );
                        } else {
                            work.push(Occludee::Node(node.first + 1));
                            work.push(Occludee::Node(node.first));
                        }
                    }
                    Occludee::Object(i) => {
                        if flagged[i as usize] {
                            continue;
                        }
                        let p = self.item_pos[i as usize] as usize;
                        if self.hidden(&cell, &self.boxes[i as usize], p..p + 1, stack) {
                            hidden.push(i);
                        } else {
                            all_hidden = false;
                        }
                    }
                }
            }
            if !all_hidden {
                pass.push(root);
            }
        }
        hidden.retain(|&i| !self.boxes[i as usize].is_empty());
        hidden.sort_unstable();
        hidden.dedup();
        if let Some(space) = self.fused.as_ref().filter(|_| level == self.grid.levels) {
            // What no single occluder hides from the whole cell, the solid
            // space may hide as one.
            let candidates: Vec<u32> = (0..self.boxes.len() as u32)
                .filter(|&i| !flagged[i as usize] && !self.boxes[i as usize].is_empty())
                .filter(|i| hidden.binary_search(i).is_err())
                .collect();
            let fused = super::fusion::fused_hidden(space, &self.boxes, &cell, &candidates, self.config);
            hidden.extend(fused);
            hidden.sort_unstable();
        }
        for &i in &hidden {
            flagged[i as usize] = true;
        }
        if level < self.grid.levels && !pass.is_empty() {
            for cz in 0..2 {
                for cx in 0..2 {
                    self.visit(
                        block,
                        level + 1,
                        2 * x + cx,
                        2 * z + cz,
                        pass.clone(),
                        flagged,
                        sets,
                        stack,
                    );
                }
            }
        }
        for &i in &hidden {
            flagged[i as usize] = false;
        }
        let local = self.grid.node_id(block, level, x, z) - block * self.grid.nodes_per_block();
        sets[local] = hidden;
    }
}

/// An occludee: a node of the object BVH, or one object.
#[derive(Clone, Copy, Debug)]
enum Occludee {
    Node(u32),
    Object(u32),
}

/// Does the segment `a`–`b` meet the box (slab test)?
pub(crate) fn segment_meets_box(a: DVec3, b: DVec3, bounds: &Aabb) -> bool {
    line_in_box(a, b, bounds, (0.0, 1.0)).is_some()
}

/// The parameters `t` within `range` at which `a + t·(b − a)` lies in the
/// box (slab test), or `None` when there are none.
pub(crate) fn line_in_box(a: DVec3, b: DVec3, bounds: &Aabb, range: (f64, f64)) -> Option<(f64, f64)> {
    if bounds.is_empty() {
        return None;
    }
    let (lo, hi) = (bounds.min.as_dvec3(), bounds.max.as_dvec3());
    let d = b - a;
    let (mut t0, mut t1) = range;
    for k in 0..3 {
        if d[k].abs() < 1e-300 {
            if a[k] < lo[k] || a[k] > hi[k] {
                return None;
            }
            continue;
        }
        let (u, v) = ((lo[k] - a[k]) / d[k], (hi[k] - a[k]) / d[k]);
        t0 = t0.max(u.min(v));
        t1 = t1.min(u.max(v));
        if t0 > t1 {
            return None;
        }
    }
    Some((t0, t1))
}
