//! The model database (Zhang et al. 1997, section 5.1): the objects' boxes
//! in a BVH that every culler walks, kept in step with a scene an engine
//! changes between frames.
//!
//! - Objects that moved ([`Scene::set_transform`]): the BVH is refit, a
//!   linear pass, in any frame after a move.
//! - Objects added since the last build wait in a short list, tested one by
//!   one; removed ones stay in the tree with an empty box (they grow no node)
//!   and are skipped. When those exceed `REBUILD_SLACK` plus an eighth of the
//!   tree, the BVH is rebuilt: an engine adding or removing a few objects a
//!   frame pays a list scan, not a rebuild.
//! - Another scene (or a clone) than the one last seen: rebuilt.
//!
//! Each sync also notes what per-node and per-object state kept across
//! frames (the coherent traversal's) must forget: the nodes whose bounds the
//! refit changed, the objects whose boxes changed, and a new build number
//! after every rebuild (node indices then mean other nodes).

use crate::geom::Aabb;
use crate::scene::{Revision, Scene};
use crate::spatial::{Bvh, BvhConfig};

/// Added and removed objects tolerated before a rebuild, beyond an eighth of the tree.
const REBUILD_SLACK: usize = 16;

/// What [`ModelDb::sync`] found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Change {
    /// Nothing since the last frame.
    None,
    /// Only transforms.
    Moved,
    /// Objects added, removed, made dynamic or re-flagged: whatever else the
    /// culler derives from the scene's structure must follow.
    Structure,
}

/// The objects' boxes in a BVH; see the module docs.
#[derive(Clone, Debug)]
pub(crate) struct ModelDb {
    bvh: Bvh,
    /// Current box per object id: [`Aabb::EMPTY`] for removed objects.
    boxes: Vec<Aabb>,
    /// Whether each object id moves (is tested by its oriented box).
    dynamic: Vec<bool>,
    /// Live objects not in the BVH (added since its build), ascending.
    extra: Vec<u32>,
    /// Objects in the BVH that were removed since its build.
    removed: usize,
    seen: Revision,
    /// Bumped by every (re)build.
    build: u32,
    /// Nodes whose bounds the last sync's refit changed.
    moved_nodes: Vec<u32>,
    /// Objects whose boxes the last sync changed (moved, removed or re-flagged).
    moved_objects: Vec<u32>,
}

impl ModelDb {
    /// Bytes held on the heap: the BVH, the boxes and the per-object lists.
    pub fn heap_bytes(&self) -> usize {
        use crate::vec_bytes;
        self.bvh.heap_bytes()
            + vec_bytes(&self.boxes)
            + vec_bytes(&self.dynamic)
            + vec_bytes(&self.extra)
            + vec_bytes(&self.moved_nodes)
            + vec_bytes(&self.moved_objects)
    }

    /// The BVH over `scene`'s live objects.
    pub fn new(scene: &Scene) -> ModelDb {
        let boxes = current_boxes(scene);
        ModelDb {
            bvh: Bvh::build(&boxes, &BvhConfig::default()),
            boxes,
            dynamic: dynamic_flags(scene),
            extra: Vec::new(),
            removed: 0,
            seen: scene.revision(),
            build: 0,
            moved_nodes: Vec::new(),
            moved_objects: Vec::new(),
        }
    }

    /// A fresh database over `scene` whose build number follows this one's.
    fn rebuilt(&self, scene: &Scene) -> ModelDb {
        ModelDb {
            build: self.build.wrapping_add(1),
            ..ModelDb::new(scene)
        }
    }

    /// Brings the database up to `scene` (see the module docs) and says what changed.
    pub fn sync(&mut self, scene: &Scene) -> Change {
        let now = scene.revision();
        self.moved_nodes.clear();
        self.moved_objects.clear();
        if now == self.seen {
            return Change::None;
        }
        if now.scene != self.seen.scene {
            *self = self.rebuilt(scene);
            return Change::Structure;
        }
        let structural = now.structure != self.seen.structure;
        if structural {
            let in_tree = self.bvh.items().len();
            for (id, o) in scene.objects().iter().enumerate() {
                if o.changed_at() <= self.seen.structure {
                    continue;
                }
                let id = id as u32;
                let listed = self.extra.binary_search(&id);
                match (o.is_removed(), (id as usize) < in_tree, listed) {
                    (true, true, _) if self.boxes[id as usize] != Aabb::EMPTY => self.removed += 1,
                    (true, false, Ok(k)) => {
                        self.extra.remove(k);
                    }
                    (false, false, Err(k)) => self.extra.insert(k, id),
                    _ => {} // made dynamic or re-flagged: the box is refit below
                }
            }
            if self.extra.len() + self.removed > REBUILD_SLACK + in_tree / 8 {
                *self = self.rebuilt(scene);
                return Change::Structure;
            }
        }
        let boxes = current_boxes(scene);
        let moved = (0..boxes.len()).filter(|&i| self.boxes.get(i) != Some(&boxes[i]));
        self.moved_objects.extend(moved.map(|i| i as u32));
        self.boxes = boxes;
        if structural {
            self.dynamic = dynamic_flags(scene);
        }
        let in_tree = self.bvh.items().len();
        let moved_nodes = &mut self.moved_nodes;
        self.bvh.refit_noting(&self.boxes[..in_tree], |i| moved_nodes.push(i));
        self.seen = now;
        if structural {
            Change::Structure
        } else {
            Change::Moved
        }
    }

    /// The hierarchy (its items are object ids; removed ones have empty boxes).
    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// Current boxes by object id.
    pub fn boxes(&self) -> &[Aabb] {
        &self.boxes
    }

    /// Whether each object id moves, as [`crate::scene::Object::is_dynamic`]
    /// (compact, for scans over many objects).
    pub fn dynamic(&self) -> &[bool] {
        &self.dynamic
    }

    /// Bumped by every (re)build of the hierarchy: node indices from another
    /// build number mean other nodes.
    pub fn build(&self) -> u32 {
        self.build
    }

    /// Nodes whose bounds the last [`ModelDb::sync`] changed (refit).
    pub fn moved_nodes(&self) -> &[u32] {
        &self.moved_nodes
    }

    /// Objects whose boxes the last [`ModelDb::sync`] changed.
    pub fn moved_objects(&self) -> &[u32] {
        &self.moved_objects
    }

    /// Live objects outside the hierarchy, to be tested one by one.
    pub fn extra(&self) -> &[u32] {
        &self.extra
    }
}

/// Every object's dynamic flag.
fn dynamic_flags(scene: &Scene) -> Vec<bool> {
    scene.objects().iter().map(|o| o.is_dynamic()).collect()
}

/// Every object's current box; removed objects get [`Aabb::EMPTY`].
fn current_boxes(scene: &Scene) -> Vec<Aabb> {
    scene
        .objects()
        .iter()
        .map(|o| if o.is_removed() { Aabb::EMPTY } else { o.aabb })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{Containment, Frustum};
    use crate::scene::Mesh;
    use glam::{Mat4, Vec3};
    use hom_testkit::Rng;

    fn unit() -> Mesh {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z];
        Mesh::new("t", p, vec![[0, 1, 2], [0, 2, 3]]).unwrap()
    }

    /// The live objects whose boxes meet `f`, by the BVH and the extra list.
    fn found(db: &ModelDb, scene: &Scene, f: &Frustum) -> Vec<u32> {
        let mut out = Vec::new();
        db.bvh()
            .frustum_cull(&db.boxes()[..db.bvh().items().len()], f, &mut out);
        out.extend(
            db.extra()
                .iter()
                .filter(|&&id| f.test_aabb(&db.boxes()[id as usize]) != Containment::Outside),
        );
        out.retain(|&id| scene.get(id).is_some());
        out.sort_unstable();
        out
    }

    #[test]
    fn adds_moves_and_removals_are_never_lost() {
        let mut scene = Scene::new("s");
        let m = scene.add_mesh(unit());
        let at = |x: f32, z: f32| Mat4::from_translation(Vec3::new(x, 0.0, z));
        for i in 0..40 {
            scene.add_object(format!("o{i}"), m, at(i as f32 * 2.0, -10.0)).unwrap();
        }
        let mut db = ModelDb::new(&scene);
        let mut rng = Rng::new(12345);
        let mut next = move |n: u64| rng.below(n);
        for frame in 0..300 {
            // A few changes a frame: moves, additions and removals.
            for _ in 0..3 {
                let ids: Vec<u32> = scene.live_objects().map(|(id, _)| id).collect();
                match next(4) {
                    0 | 1 if !ids.is_empty() => {
                        let id = ids[next(ids.len() as u64) as usize];
                        scene
                            .set_transform(id, at(next(100) as f32 - 20.0, -(next(30) as f32)))
                            .unwrap();
                    }
                    2 => {
                        scene.add_object("new", m, at(next(100) as f32 - 20.0, -5.0)).unwrap();
                    }
                    _ if ids.len() > 1 => scene.remove_object(ids[next(ids.len() as u64) as usize]).unwrap(),
                    _ => {}
                }
            }
            db.sync(&scene);
            db.bvh().assert_well_formed(&db.boxes()[..db.bvh().items().len()]);
            let f = Frustum::from_view_proj(
                &(glam::camera::rh::proj::directx::perspective(1.2, 1.5, 0.1, 200.0)
                    * glam::camera::rh::view::look_at_mat4(
                        Vec3::new(frame as f32 % 60.0, 2.0, 10.0),
                        Vec3::new(10.0, 0.0, -10.0),
                        Vec3::Y,
                    )),
            )
            .unwrap();
            let linear: Vec<u32> = scene
                .live_objects()
                .filter(|(_, o)| f.test_aabb(&o.aabb) != Containment::Outside)
                .map(|(id, _)| id)
                .collect();
            assert_eq!(found(&db, &scene, &f), linear, "frame {frame}");
        }
        assert!(scene.objects().len() > 100, "the scene grew past rebuilds");
    }

    #[test]
    fn sync_notes_what_moved_and_counts_rebuilds() {
        let mut scene = Scene::new("s");
        let m = scene.add_mesh(unit());
        let at = |x: f32| Mat4::from_translation(Vec3::new(x, 0.0, -10.0));
        for i in 0..40 {
            scene.add_object(format!("o{i}"), m, at(i as f32 * 2.0)).unwrap();
        }
        let mut db = ModelDb::new(&scene);
        assert_eq!(db.sync(&scene), Change::None);
        assert!(db.moved_objects().is_empty() && db.moved_nodes().is_empty());
        scene.set_transform(7, at(200.0)).unwrap();
        assert_eq!(db.sync(&scene), Change::Structure, "object 7 becomes dynamic");
        scene.set_transform(7, at(300.0)).unwrap();
        assert_eq!(db.sync(&scene), Change::Moved);
        assert_eq!(db.moved_objects(), [7]);
        // The moved object's leaf and every node above it, the root last.
        assert!(db.moved_nodes().len() >= 2);
        assert_eq!(db.moved_nodes().last(), Some(&0));
        assert_eq!(db.build(), 0);
        assert_eq!(db.sync(&scene), Change::None);
        assert!(
            db.moved_objects().is_empty() && db.moved_nodes().is_empty(),
            "noted per sync"
        );
        for i in 0..30 {
            scene.add_object(format!("new{i}"), m, at(-(i as f32))).unwrap();
        }
        assert_eq!(db.sync(&scene), Change::Structure);
        assert_eq!(db.build(), 1, "so many additions rebuild the tree");
    }
}
