//! The ground: a watertight height field over a rectangle, found among the
//! occluders, and the walls hung under its pieces (issue 37, "occluders from
//! any geometry": a height field's one-sided occluder below the surface).
//!
//! A level's terrain is cut into cluster-sized pieces, each an open height
//! field. Drawn as an occluder, a piece covers only its own surface; the
//! pieces chosen in a frame are scattered, and a crest whose near slope lies
//! in a piece not chosen hides nothing. Under the surface is solid, though:
//! every piece gets *walls*, one vertical quad under each edge of its
//! boundary, reaching down by the piece's own width, drawn by the inner rule
//! like every stand-in. A piece then covers what lies under it on screen as
//! well, the crest's silhouette included.
//!
//! **The guarantee.** The ground is found, not declared: the static, opaque
//! objects whose meshes are open height fields (occluders, or dropped from
//! the occluders as too small or ill-shaped: the renderer draws them all),
//! taken together in world space, must be one surface whose triangles all face the same way along
//! +Y, whose edges (vertices matched by position) each meet their reverse
//! once except along the border of the rectangle the surface spans, and
//! whose projected area is the rectangle's (so it covers the rectangle
//! once): the graph of a continuous height over the closed rectangle. A wall
//! point `p` lies on or under that graph, above its own footprint. When the
//! eye `e` is over the rectangle and above the graph, the segment from `e`
//! to `p` stays over the rectangle (it is convex) and so crosses the drawn
//! surface at some `q` no farther than `p`. [`Ground::eye_clear`] asks more:
//! the eye higher by `r` than every ground triangle within `r` of it
//! sideways, where `r` bounds the distance from the eye to the near
//! rectangle, so `q` is beyond the near plane and the renderer draws it.
//! The sample is then covered at `q` or nearer, as for a virtual occluder
//! (`virtual_occluder/mod.rs`), and the inner rule keeps the snapping error
//! on the right side along the wall's top, which is the surface's own edge.
//! From anywhere else (over the edge of the level, under the ground, a
//! parallel projection) the walls are not drawn. A piece that moves makes
//! the scene's structure change, and the database finds the ground again
//! (a moving piece: none). With `--lod` the walls hang under the full
//! meshes, as the occluders are drawn (the cut's image may differ within
//! the level-of-detail error, as for every occluder).
//!
//! Measured at the prototype (`hom bench --cullers frustum,masked
//! --no-cost-model --frames 100`, walls drawn under every ground piece
//! chosen, not in the budget, as now): masked efficiency on Extreme Tux
//! Racer's bunny_hill 25.8 → 37.8 %, wild_ride 34.9 → 55.4 %; walls 2 m
//! deep did as well as 10 m (37.8, 55.5), 50 m or 500 m a little worse and
//! dearer (36.7 / 34.0 %, 55.3 / 54.8 %): the depth is the piece's width,
//! which scales with the level.

use crate::geom::Eye;
use crate::scene::Scene;
use glam::{Mat4, Vec2, Vec3};
use std::ops::Range;

/// A ground piece: one object of the ground.
#[derive(Clone, Debug)]
struct Piece {
    object: u32,
    /// Its world box across (x, z).
    min: Vec2,
    max: Vec2,
    /// Its walls in [`Ground::walls`].
    walls: Range<u32>,
}

impl Piece {
    /// How deep its walls reach: its width, which scales with the level.
    fn wall_depth(&self) -> f32 {
        (self.max - self.min).max_element()
    }
}

/// A wall: a vertical quad under the boundary edge `a`–`b` of a piece,
/// [`Piece::wall_depth`] deep, facing `outward` (horizontal, away from the
/// piece).
#[derive(Clone, Copy, Debug)]
struct Wall {
    a: Vec3,
    b: Vec3,
    /// The object across the edge, [`NO_PIECE`] on the ground's border.
    across: u32,
    outward: Vec3,
}

/// [`Wall::across`] on the ground's border.
const NO_PIECE: u32 = u32::MAX;

/// The scene's ground, when its height-field occluders make one.
#[derive(Clone, Debug)]
pub(crate) struct Ground {
    /// The rectangle the ground spans across (x, z).
    min: Vec2,
    max: Vec2,
    /// By object id.
    pieces: Vec<Piece>,
    walls: Vec<Wall>,
}

/// A position's bits, `-0.0` made `+0.0`: vertices matched by position.
fn key(p: Vec3) -> [u32; 3] {
    (p + Vec3::ZERO).to_array().map(f32::to_bits)
}

impl Ground {
    /// The ground made of the objects `candidates` (static occluders whose
    /// meshes are open height fields), or `None` when they do not make one
    /// watertight height field over a rectangle (see the module docs).
    ///
    /// Vertices are matched and edges paired by sorting, not hashing: a
    /// course of 660,000 triangles is checked in a fraction of its load.
    pub(crate) fn find(scene: &Scene, candidates: &[u32]) -> Option<Ground> {
        // Every candidate's vertices in world space, piece after piece, and
        // its triangles as indices into them.
        let mut points: Vec<Vec3> = Vec::new();
        let mut corners: Vec<[u32; 3]> = Vec::new();
        let mut pieces = Vec::with_capacity(candidates.len());
        // Where each piece's triangles end in `corners`.
        let mut ends = Vec::with_capacity(candidates.len());
        let (mut min, mut max) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
        let mut area = 0.0f64;
        let mut up = None;
        for &id in candidates {
            let o = scene.get(id)?;
            if o.is_dynamic() || o.is_removed() {
                return None;
            }
            let mesh = scene.mesh_of(o);
            let base = points.len() as u32;
            points.extend(mesh.positions().iter().map(|&p| o.transform.transform_point3(p)));
            let (mut piece_min, mut piece_max) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
            for t in mesh.triangles() {
                let [a, b, c] = t.map(|i| points[(base + i) as usize]);
                if !(a.is_finite() && b.is_finite() && c.is_finite()) {
                    return None;
                }
                let cross_y = (b - a).cross(c - a).y;
                if cross_y == 0.0 || *up.get_or_insert(cross_y > 0.0) != (cross_y > 0.0) {
                    return None;
                }
                area += f64::from(cross_y.abs()) * 0.5;
                let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
                piece_min = piece_min.min(Vec2::new(lo.x, lo.z));
                piece_max = piece_max.max(Vec2::new(hi.x, hi.z));
                corners.push(t.map(|i| base + i));
            }
            min = min.min(piece_min);
            max = max.max(piece_max);
            pieces.push(Piece {
                object: id,
                min: piece_min,
                max: piece_max,
                walls: 0..0,
            });
            ends.push(corners.len() as u32);
        }
        let rectangle = f64::from(max.x - min.x) * f64::from(max.y - min.y);
        // Covered once: the projected area is the rectangle's, not twice it.
        if pieces.is_empty() || !(rectangle > 0.0 && area > 0.5 * rectangle && area < 1.5 * rectangle) {
            return None;
        }
        // Vertices matched by position: each point's welded id.
        let mut order: Vec<u32> = (0..points.len() as u32).collect();
        order.sort_unstable_by_key(|&i| key(points[i as usize]));
        let mut welded = vec![0u32; points.len()];
        let mut id = 0;
        for k in 0..order.len() {
            if k > 0 && key(points[order[k] as usize]) != key(points[order[k - 1] as usize]) {
                id += 1;
            }
            welded[order[k] as usize] = id;
        }
        drop(order);
        // Directed edges (welded ends) with their triangle, sorted.
        let edge = |from: u32, to: u32| (u64::from(welded[from as usize]) << 32) | u64::from(welded[to as usize]);
        let mut edges: Vec<(u64, u32)> = Vec::with_capacity(corners.len() * 3);
        for (t, c) in corners.iter().enumerate() {
            for j in 0..3 {
                edges.push((edge(c[j], c[(j + 1) % 3]), t as u32));
            }
        }
        edges.sort_unstable();
        if edges.windows(2).any(|w| w[0].0 == w[1].0) {
            return None; // two triangles on one side of an edge: not a surface
        }
        let piece_of = |triangle: u32| ends.partition_point(|&end| end <= triangle);
        let on_border = |p: Vec3, q: Vec3| {
            (p.x == min.x && q.x == min.x)
                || (p.x == max.x && q.x == max.x)
                || (p.z == min.y && q.z == min.y)
                || (p.z == max.y && q.z == max.y)
        };
        // Walls under each piece's own boundary: its edges whose reverse is
        // not in the piece (another piece's, or none: the ground's border),
        // in the order of its mesh's triangles (the order they are drawn in
        // changes the masked buffer's layers a little).
        let mut walls_of: Vec<Vec<Wall>> = vec![Vec::new(); pieces.len()];
        for (triangle, c) in corners.iter().enumerate() {
            let piece = piece_of(triangle as u32);
            for j in 0..3 {
                let reverse = edge(c[(j + 1) % 3], c[j]);
                let (a, b, other) = (
                    points[c[j] as usize],
                    points[c[(j + 1) % 3] as usize],
                    points[c[(j + 2) % 3] as usize],
                );
                let across = match edges.binary_search_by_key(&reverse, |e| e.0) {
                    Ok(k) if piece_of(edges[k].1) == piece => continue,
                    Ok(k) => pieces[piece_of(edges[k].1)].object,
                    Err(_) if !on_border(a, b) => return None, // a hole or a cut inside the rectangle
                    Err(_) => NO_PIECE,
                };
                let along = b - a;
                let mut outward = Vec3::new(along.z, 0.0, -along.x).normalize_or_zero();
                if outward.dot(other - a) > 0.0 {
                    outward = -outward;
                }
                walls_of[piece].push(Wall { a, b, across, outward });
            }
        }
        let mut walls = Vec::new();
        for (p, w) in pieces.iter_mut().zip(walls_of) {
            let first = walls.len() as u32;
            walls.extend(w);
            p.walls = first..walls.len() as u32;
        }
        pieces.sort_by_key(|p| p.object);
        Some(Ground {
            min,
            max,
            pieces,
            walls,
        })
    }

    /// Walls of object `object`: how many (each two triangles, half of them
    /// facing any eye), 0 when it is not a ground piece. They are not in the
    /// occluder's triangle count, which the budget spends: the built-in
    /// terrain's budget buys three of its 1,152-triangle tiles, and with
    /// their walls counted two (`hom bench --cullers frustum,masked
    /// --frames 100 --no-cost-model`: masked efficiency 48.1 → 10.3 %).
    #[cfg(test)]
    pub(crate) fn wall_count(&self, object: u32) -> u32 {
        self.piece(object).map_or(0, |p| p.walls.len() as u32)
    }

    /// Walls of the whole ground.
    pub(crate) fn walls(&self) -> usize {
        self.walls.len()
    }

    /// Whether object `object` is a piece of the ground.
    pub(crate) fn has_piece(&self, object: u32) -> bool {
        self.piece(object).is_some()
    }

    fn piece(&self, object: u32) -> Option<&Piece> {
        let i = self.pieces.binary_search_by_key(&object, |p| p.object).ok()?;
        Some(&self.pieces[i])
    }

    /// The eye the walls may be drawn for in a view from `eye` through
    /// `world_to_clip` (hom's clip convention), when they may be.
    pub(crate) fn eye_for(&self, scene: &Scene, eye: &Eye, world_to_clip: &Mat4) -> Option<Vec3> {
        match eye {
            Eye::Point(e) if near_reach(world_to_clip, *e).is_some_and(|r| self.eye_clear(scene, *e, r)) => Some(*e),
            _ => None,
        }
    }

    /// Pieces of the ground.
    pub(crate) fn pieces(&self) -> usize {
        self.pieces.len()
    }

    /// Whether the walls may be drawn for an eye at `eye` whose near
    /// rectangle lies within `near_reach` of it: the eye over the ground's
    /// rectangle, and higher by more than `near_reach` than every ground
    /// triangle that comes within `near_reach` of it across (x, z).
    pub(crate) fn eye_clear(&self, scene: &Scene, eye: Vec3, near_reach: f32) -> bool {
        let e = Vec2::new(eye.x, eye.z);
        if !(e.cmpge(self.min).all() && e.cmple(self.max).all() && near_reach.is_finite() && eye.y.is_finite()) {
            return false;
        }
        let (lo, hi) = (e - near_reach, e + near_reach);
        let overlaps = |min: Vec2, max: Vec2| min.cmple(hi).all() && max.cmpge(lo).all();
        let mut top = f32::NEG_INFINITY;
        for p in self.pieces.iter().filter(|p| overlaps(p.min, p.max)) {
            let o = scene.object(p.object);
            let mesh = scene.mesh_of(o);
            for t in mesh.triangles() {
                let [a, b, c] = t.map(|i| o.transform.transform_point3(mesh.positions()[i as usize]));
                let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
                if overlaps(Vec2::new(lo.x, lo.z), Vec2::new(hi.x, hi.z)) {
                    top = top.max(hi.y);
                }
            }
        }
        eye.y - near_reach > top
    }

    /// Appends the walls of `object` that face `eye` to `positions` and
    /// `triangles` (two triangles each, world space), but not those under an
    /// edge whose piece across is drawn too (`drawn`, object ids ascending):
    /// a wall facing the eye faces that piece, whose own surface covers
    /// nearly all the wall would.
    pub(crate) fn walls_facing(
        &self,
        object: u32,
        eye: Vec3,
        drawn: &[u32],
        positions: &mut Vec<Vec3>,
        triangles: &mut Vec<[u32; 3]>,
    ) {
        let Some(p) = self.piece(object) else {
            return;
        };
        let down = Vec3::new(0.0, p.wall_depth(), 0.0);
        for w in &self.walls[p.walls.start as usize..p.walls.end as usize] {
            if (eye - w.a).dot(w.outward) <= 0.0 || drawn.binary_search(&w.across).is_ok() {
                continue;
            }
            let n = positions.len() as u32;
            positions.extend([w.a, w.b, w.b - down, w.a - down]);
            triangles.extend([[n, n + 1, n + 2], [n, n + 2, n + 3]]);
        }
    }

    /// Bytes held on the heap.
    pub(crate) fn heap_bytes(&self) -> usize {
        crate::vec_bytes(&self.pieces) + crate::vec_bytes(&self.walls)
    }
}

/// The farthest a point of the near rectangle of `world_to_clip` (hom's
/// clip convention: the near plane at clip z = 0) lies from `eye`; `None`
/// for a matrix that cannot be inverted.
fn near_reach(world_to_clip: &Mat4, eye: Vec3) -> Option<f32> {
    let inverse = world_to_clip.inverse();
    let mut reach = 0.0f32;
    for (x, y) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
        let p = inverse.project_point3(Vec3::new(x, y, 0.0));
        if !p.is_finite() {
            return None;
        }
        reach = reach.max(p.distance(eye));
    }
    // A hair more for the rounding of the inverse.
    Some(reach * 1.001 + 1e-4)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Mesh, SceneBuilder};
    use hom_testkit::Rng;

    /// A `cells` × `cells` grid of 1 m cells from the origin with random
    /// heights, cut into `pieces` × `pieces` objects, the piece at
    /// `(skip, skip)` left out when `skip` is some.
    fn ground_scene(rng: &mut Rng, cells: u32, pieces: u32, skip: Option<u32>) -> Scene {
        let heights: Vec<f32> = (0..(cells + 1) * (cells + 1)).map(|_| rng.range(0.0, 3.0)).collect();
        let mut b = SceneBuilder::new("ground");
        for (p, t) in hom_testkit::height_field_pieces(&heights, cells, pieces, skip) {
            let mesh = b.add_mesh(Mesh::new("piece", p, t).unwrap());
            b.add_object("piece", mesh, Mat4::IDENTITY).unwrap();
        }
        b.build().unwrap()
    }

    fn all(scene: &Scene) -> Vec<u32> {
        (0..scene.objects().len() as u32).collect()
    }

    #[test]
    fn a_grid_in_pieces_is_a_ground_with_walls_under_every_piece_edge() {
        let mut rng = Rng::new(3);
        let scene = ground_scene(&mut rng, 8, 4, None);
        let ground = Ground::find(&scene, &all(&scene)).expect("a watertight height field over a square");
        assert_eq!(ground.pieces(), 16);
        // A piece of 2 × 2 cells has 8 boundary edges; every one gets a wall.
        for id in 0..16 {
            assert_eq!(ground.wall_count(id), 8, "piece {id}");
        }
        for piece in &ground.pieces {
            let centre = (piece.min + piece.max) * 0.5;
            for w in &ground.walls[piece.walls.start as usize..piece.walls.end as usize] {
                // Horizontal outward, the piece's width deep, facing away from its centre.
                assert_eq!(w.outward.y, 0.0);
                assert_eq!(piece.wall_depth(), 2.0);
                let mid = (w.a + w.b) * 0.5;
                assert!(w.outward.dot(Vec3::new(mid.x - centre.x, 0.0, mid.z - centre.y)) > 0.0);
            }
        }
    }

    #[test]
    fn holes_overlaps_turned_pieces_and_slopes_make_no_ground() {
        let mut rng = Rng::new(4);
        let holed = ground_scene(&mut rng, 8, 4, Some(1));
        assert!(Ground::find(&holed, &all(&holed)).is_none(), "a piece missing inside");
        // The border's piece missing leaves an L: its inner corner is a hole too.
        let corner = ground_scene(&mut rng, 8, 4, Some(0));
        assert!(Ground::find(&corner, &all(&corner)).is_none(), "not a rectangle");
        let whole = ground_scene(&mut rng, 8, 2, None);
        let twice: Vec<u32> = all(&whole).into_iter().chain([0]).collect();
        assert!(Ground::find(&whole, &twice).is_none(), "a piece twice over");
        // A second layer above the first: covered twice.
        let mut b = SceneBuilder::new("two layers");
        for (k, lift) in [0.0, 5.0].into_iter().enumerate() {
            let p = vec![
                Vec3::new(0.0, lift, 0.0),
                Vec3::new(1.0, lift, 0.0),
                Vec3::new(0.0, lift, 1.0 + k as f32),
            ];
            let mesh = b.add_mesh(Mesh::new("layer", p, vec![[0, 2, 1]]).unwrap());
            b.add_object("layer", mesh, Mat4::IDENTITY).unwrap();
        }
        let layers = b.build().unwrap();
        assert!(Ground::find(&layers, &all(&layers)).is_none());
        // A piece turned upside down (clockwise from above) among the rest.
        let mut b = SceneBuilder::new("turned");
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Z, Vec3::new(1.0, 0.0, 1.0)];
        let up = b.add_mesh(Mesh::new("up", p.clone(), vec![[0, 2, 1]]).unwrap());
        let down = b.add_mesh(Mesh::new("down", p, vec![[1, 3, 2]]).unwrap());
        b.add_object("up", up, Mat4::IDENTITY).unwrap();
        b.add_object("down", down, Mat4::IDENTITY).unwrap();
        let turned = b.build().unwrap();
        assert!(Ground::find(&turned, &all(&turned)).is_none());
        // Tilted on its side by its placement: not a height field in the world.
        let mut b = SceneBuilder::new("tilted");
        let mesh = b.add_mesh(Mesh::new("sheet", vec![Vec3::ZERO, Vec3::X, Vec3::Z], vec![[0, 2, 1]]).unwrap());
        b.add_object("sheet", mesh, Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2))
            .unwrap();
        let tilted = b.build().unwrap();
        assert!(Ground::find(&tilted, &all(&tilted)).is_none());
    }

    #[test]
    fn walls_hold_only_for_an_eye_over_the_ground_and_clear_of_it() {
        let mut rng = Rng::new(5);
        let scene = ground_scene(&mut rng, 8, 4, None);
        let ground = Ground::find(&scene, &all(&scene)).unwrap();
        // Heights are below 3 m.
        assert!(ground.eye_clear(&scene, Vec3::new(4.0, 3.5, 4.0), 0.1));
        assert!(
            !ground.eye_clear(&scene, Vec3::new(4.0, -1.0, 4.0), 0.1),
            "under the ground"
        );
        assert!(!ground.eye_clear(&scene, Vec3::new(-0.5, 10.0, 4.0), 0.1), "beside it");
        assert!(!ground.eye_clear(&scene, Vec3::new(4.0, f32::NAN, 4.0), 0.1));
        // Above the triangles within reach across, but not by the reach.
        let near = |t: &[Vec3; 3]| {
            let (lo, hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
            lo.x <= 4.1 && lo.z <= 4.1 && hi.x >= 3.9 && hi.z >= 3.9
        };
        let world: Vec<[Vec3; 3]> = (0..16)
            .flat_map(|id| {
                let mesh = scene.mesh_of(scene.object(id));
                mesh.triangles()
                    .iter()
                    .map(|t| t.map(|i| mesh.positions()[i as usize]))
                    .collect::<Vec<_>>()
            })
            .collect();
        let local = world
            .iter()
            .filter(|t| near(t))
            .flat_map(|t| t.map(|p| p.y))
            .fold(f32::MIN, f32::max);
        assert!(!ground.eye_clear(&scene, Vec3::new(4.0, local + 0.05, 4.0), 0.1));
        assert!(ground.eye_clear(&scene, Vec3::new(4.0, local + 0.15, 4.0), 0.1));
        let top = world.iter().flat_map(|t| t.map(|p| p.y)).fold(f32::MIN, f32::max);
        // A perspective view from above: its near rectangle reaches a little
        // farther than the near distance, and the walls face the eye.
        let eye = Vec3::new(4.0, top + 2.0, 7.5);
        let view =
            crate::geom::Camera::new(eye, Vec3::new(4.0, 0.0, 4.0), Vec3::Y, 1.0, 0.1, 100.0, 64, 64).view_proj();
        let reach = near_reach(&view, eye).unwrap();
        assert!(reach > 0.1 && reach < 0.2, "{reach}");
        assert_eq!(ground.eye_for(&scene, &Eye::Point(eye), &view), Some(eye));
        assert_eq!(
            ground.eye_for(&scene, &Eye::Direction(Vec3::NEG_Y), &view),
            None,
            "parallel projections draw no walls"
        );
        let (mut p, mut t) = (Vec::new(), Vec::new());
        for id in 0..16 {
            ground.walls_facing(id, eye, &[], &mut p, &mut t);
        }
        assert!(
            !t.is_empty() && t.len() < 2 * ground.walls.len(),
            "some walls, not all of them"
        );
        for w in t.chunks(2) {
            let [a, b, c] = w[0].map(|i| p[i as usize]);
            // Each drawn wall faces the eye: the eye on its outward side.
            let n = (b - a).cross(c - a);
            assert!(n.y.abs() < 1e-4, "vertical");
        }
    }
}
