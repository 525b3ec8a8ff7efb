//! Non-convex planar occluders: the drawn triangles that lie exactly in one
//! axis-aligned plane, joined (Law & Tan 1999, section 5.3: a non-convex
//! occluder's occlusion region; here tested directly rather than by their
//! AND/OR substitution of supporting planes).
//!
//! A wall with a doorway, or a row of wall slabs and the posts between
//! them, is no convex polygon: split into convex pieces, no piece hides a
//! statue from a whole cell when the shaft between them spans two pieces.
//! Joined, the test is exact: for a cell `C` and an occludee box `X`
//! strictly on opposite sides of the plane, the points where segments from
//! `C` to `X` cross the plane are the plane's section of `conv(C ∪ X)`
//! (every point of that hull lies on a segment from `C` to `X`), a convex
//! polygon `S`: the hull of the 64 corner segments' crossings. `X` is hidden
//! from `C` by the union `U` iff `S ⊆ U`; with the bake's margin, iff no
//! edge of `U`'s boundary comes within `lateral` of `S` and one point of `S`
//! lies in `U` (`S` is connected, so it cannot then leave `U`).
//!
//! **What counts as joined, so the renderer agrees.** The renderer draws
//! two triangles without a crack between them only along an edge they
//! share exactly (the same two points, after the same transform). So the
//! boundary of `U` is every triangle edge not matched by the same edge,
//! reversed, of another triangle of the plane: shared edges are interior,
//! and anything else — a T-junction where a tessellated slab meets a post,
//! a gap, a crack — stays boundary, which `S` may not come near. The
//! plane is exact: every corner of every triangle has the same `f32`
//! coordinate on the plane's axis, so the 2D coordinates are the other two
//! coordinates, exact, and matching edges is comparing bits.

use super::margins::grown_corners;
use crate::geom::Aabb;
use glam::{DVec2, DVec3, Vec3};
use std::collections::HashMap;

/// Triangles in one axis-aligned plane, joined.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct PlanarUnion {
    /// The plane's axis (0, 1, 2: x, y, z) and coordinate on it.
    axis: usize,
    at: f64,
    /// The triangles, in the plane's 2D coordinates (the other two axes, in
    /// order), counter-clockwise.
    triangles: Vec<[DVec2; 3]>,
    /// The union's boundary: edges no other triangle shares, reversed.
    boundary: Vec<[DVec2; 2]>,
    /// Bounds of the triangles, 3D.
    pub(crate) bounds: Aabb,
    /// The objects the triangles are of (ascending): the union stands while they do.
    pub(crate) objects: Vec<u32>,
}

/// The plane's 2D coordinates of a point.
fn flat(p: DVec3, axis: usize) -> DVec2 {
    DVec2::new(p[(axis + 1) % 3], p[(axis + 2) % 3])
}

impl PlanarUnion {
    /// Joins `triangles` (world space) of the objects `objects`, which must
    /// all lie in the plane `axis = at` exactly; degenerate ones are
    /// dropped. `None` when none is left or a corner is off the plane.
    pub(crate) fn new(axis: usize, at: f32, triangles: &[[Vec3; 3]], mut objects: Vec<u32>) -> Option<PlanarUnion> {
        if triangles.iter().flatten().any(|p| p[axis] != at) {
            return None;
        }
        let mut flat_tris = Vec::with_capacity(triangles.len());
        // Edge (from, to) as bits -> how many triangles have it, net of the reversed.
        let mut edges: HashMap<([u32; 2], [u32; 2]), i32> = HashMap::new();
        let bits = |p: Vec3| [p[(axis + 1) % 3].to_bits(), p[(axis + 2) % 3].to_bits()];
        for t in triangles {
            let q = t.map(|p| flat(p.as_dvec3(), axis));
            // Exact for f32 corners: the differences and products fit a double.
            let area2 = (q[1] - q[0]).perp_dot(q[2] - q[0]);
            if area2 == 0.0 || !area2.is_finite() {
                continue;
            }
            let (t, q) = if area2 > 0.0 {
                (*t, q)
            } else {
                ([t[0], t[2], t[1]], [q[0], q[2], q[1]])
            };
            flat_tris.push(q);
            for k in 0..3 {
                let (a, b) = (bits(t[k]), bits(t[(k + 1) % 3]));
                let key = if a <= b { (a, b) } else { (b, a) };
                *edges.entry(key).or_default() += if a <= b { 1 } else { -1 };
            }
        }
        if flat_tris.is_empty() {
            return None;
        }
        let from_bits = |b: [u32; 2]| DVec2::new(f32::from_bits(b[0]) as f64, f32::from_bits(b[1]) as f64);
        let mut boundary: Vec<[DVec2; 2]> = edges
            .into_iter()
            .filter(|&(_, n)| n != 0)
            .map(|((a, b), _)| [from_bits(a), from_bits(b)])
            .collect();
        // Deterministic order (the map's is not).
        boundary.sort_by(|a, b| {
            (a[0].x, a[0].y, a[1].x, a[1].y)
                .partial_cmp(&(b[0].x, b[0].y, b[1].x, b[1].y))
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        Some(PlanarUnion {
            axis,
            at: at as f64,
            triangles: flat_tris,
            boundary,
            bounds: Aabb::from_points(triangles.iter().flatten().copied()),
            objects: {
                objects.sort_unstable();
                objects.dedup();
                objects
            },
        })
    }

    /// Signed distance of a point from the plane (along the axis).
    pub(crate) fn side(&self, p: DVec3) -> f64 {
        p[self.axis] - self.at
    }

    /// Does the segment `a`–`b` cross the plane strictly, at a point of the
    /// union at least `lateral` inside its boundary?
    pub(crate) fn crossed_by(&self, a: DVec3, b: DVec3, lateral: f64) -> bool {
        let (fa, fb) = (self.side(a), self.side(b));
        if !((fa < 0.0 && fb > 0.0) || (fa > 0.0 && fb < 0.0)) {
            return false;
        }
        let q = flat(a + (b - a) * (fa / (fa - fb)), self.axis);
        self.holds(&[q], lateral)
    }

    /// Is every segment from a point of `cell` to a point of `x` grown by
    /// `gap` crossing the union at least `lateral` inside its boundary?
    pub(crate) fn hides(&self, cell: &Aabb, x: &Aabb, gap: f64, lateral: f64) -> bool {
        let cs = cell.corners().map(|c| c.as_dvec3());
        let xs = grown_corners(x, gap);
        let below = |ps: &[DVec3; 8]| ps.iter().all(|&p| self.side(p) < 0.0);
        let above = |ps: &[DVec3; 8]| ps.iter().all(|&p| self.side(p) > 0.0);
        if !((below(&cs) && above(&xs)) || (above(&cs) && below(&xs))) {
            return false;
        }
        let mut crossings = Vec::with_capacity(64);
        for &c in &cs {
            for &p in &xs {
                let (fc, fp) = (self.side(c), self.side(p));
                crossings.push(flat(c + (p - c) * (fc / (fc - fp)), self.axis));
            }
        }
        self.holds(&convex_hull(crossings), lateral)
    }

    /// Is the convex polygon `s` (corners in order; one point, or two, is a
    /// point or a segment) inside the union, at least `lateral` from its boundary?
    fn holds(&self, s: &[DVec2], lateral: f64) -> bool {
        let Some(&inner) = s.first() else {
            return false;
        };
        let (lo, hi) = s.iter().fold((inner, inner), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        let (lo, hi) = (lo - DVec2::splat(lateral), hi + DVec2::splat(lateral));
        for e in &self.boundary {
            if e[0].max(e[1]).cmplt(lo).any() || e[0].min(e[1]).cmpgt(hi).any() {
                continue;
            }
            if segment_polygon_distance(e[0], e[1], s) <= lateral {
                return false;
            }
        }
        // No boundary meets `s` grown by `lateral`: `s` lies wholly in the
        // union or wholly outside it, so one of its points decides. Rounding
        // can only matter within a hair of an edge; a boundary edge is
        // `lateral` away, so the triangles meeting there share it.
        const HAIR: f64 = 1e-9;
        self.triangles.iter().any(|t| {
            (0..3).all(|k| {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                let len = (b - a).length();
                (b - a).perp_dot(inner - a) >= -HAIR * len
            })
        })
    }
}

/// The convex hull of points, counter-clockwise, collinear points dropped
/// (Andrew's monotone chain); one or two points when all coincide or lie on a line.
fn convex_hull(mut p: Vec<DVec2>) -> Vec<DVec2> {
    p.sort_by(|a, b| (a.x, a.y).partial_cmp(&(b.x, b.y)).unwrap_or(std::cmp::Ordering::Equal));
    p.dedup();
    if p.len() < 3 {
        return p;
    }
    let mut hull: Vec<DVec2> = Vec::with_capacity(2 * p.len());
    for pass in 0..2 {
        let start = hull.len();
        let points: Box<dyn Iterator<Item = &DVec2>> = if pass == 0 {
            Box::new(p.iter())
        } else {
            Box::new(p.iter().rev())
        };
        for &q in points {
            while hull.len() >= start + 2
                && (hull[hull.len() - 1] - hull[hull.len() - 2]).perp_dot(q - hull[hull.len() - 2]) <= 0.0
            {
                hull.pop();
            }
            hull.push(q);
        }
        hull.pop();
    }
    if hull.len() < 3 {
        // All on a line: its two ends.
        return vec![p[0], p[p.len() - 1]];
    }
    hull
}

/// Distance between the segment `a`–`b` and the convex polygon `s`
/// (counter-clockwise; one or two points are a point or a segment): 0 when
/// they meet.
fn segment_polygon_distance(a: DVec2, b: DVec2, s: &[DVec2]) -> f64 {
    if s.len() >= 3 && (inside_convex(a, s) || inside_convex(b, s)) {
        return 0.0;
    }
    let n = s.len();
    let sides = if n >= 3 { n } else { 1 };
    (0..sides)
        .map(|k| segment_distance(a, b, s[k], s[(k + 1) % n]))
        .fold(f64::INFINITY, f64::min)
}

fn inside_convex(p: DVec2, s: &[DVec2]) -> bool {
    (0..s.len()).all(|k| (s[(k + 1) % s.len()] - s[k]).perp_dot(p - s[k]) >= 0.0)
}

/// Distance between two segments (0 when they cross).
fn segment_distance(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> f64 {
    let o = |p: DVec2, q: DVec2, r: DVec2| (q - p).perp_dot(r - p);
    let (d1, d2, d3, d4) = (o(a, b, c), o(a, b, d), o(c, d, a), o(c, d, b));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0)) && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0)) {
        return 0.0;
    }
    point_segment_distance(a, c, d)
        .min(point_segment_distance(b, c, d))
        .min(point_segment_distance(c, a, b))
        .min(point_segment_distance(d, a, b))
}

fn point_segment_distance(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let ab = b - a;
    let len2 = ab.length_squared();
    let t = if len2 > 0.0 {
        ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + ab * t).distance(p)
}

/// Triangles (each with its object) that lie exactly in an axis-aligned
/// plane, grouped by plane and joined; only planes holding at least
/// `min_triangles` triangles whose area reaches `min_area`. Planes in order
/// of axis and coordinate.
pub(crate) fn planar_unions(triangles: &[(u32, [Vec3; 3])], min_triangles: usize, min_area: f64) -> Vec<PlanarUnion> {
    type Plane = (Vec<u32>, Vec<[Vec3; 3]>);
    let mut planes: HashMap<(usize, u32), Plane> = HashMap::new();
    for &(object, t) in triangles {
        for axis in 0..3 {
            let at = t[0][axis];
            if t[1][axis] == at && t[2][axis] == at && at.is_finite() {
                let (objects, tris) = planes.entry((axis, at.to_bits())).or_default();
                objects.push(object);
                tris.push(t);
                break;
            }
        }
    }
    let mut keys: Vec<(usize, u32)> = planes.keys().copied().collect();
    keys.sort_unstable_by(|a, b| {
        (a.0, f32::from_bits(a.1))
            .partial_cmp(&(b.0, f32::from_bits(b.1)))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    keys.into_iter()
        .filter_map(|key| {
            let (objects, tris) = planes.remove(&key)?;
            if tris.len() < min_triangles {
                return None;
            }
            let area: f64 = tris
                .iter()
                .map(|t| {
                    let (a, b, c) = (t[0].as_dvec3(), t[1].as_dvec3(), t[2].as_dvec3());
                    0.5 * (b - a).cross(c - a).length()
                })
                .sum();
            if area < min_area {
                return None;
            }
            PlanarUnion::new(key.0, f32::from_bits(key.1), &tris, objects)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use hom_testkit::Rng;

    /// A wall in the plane z = 0: an `n × m` grid of squares of side `s`
    /// from the origin, two triangles each (sharing edges exactly), without
    /// the squares `hole` picks.
    fn wall(n: usize, m: usize, s: f32, hole: impl Fn(usize, usize) -> bool) -> Vec<[Vec3; 3]> {
        let p = |i: usize, j: usize| Vec3::new(i as f32 * s, j as f32 * s, 0.0);
        let mut tris = Vec::new();
        for i in 0..n {
            for j in 0..m {
                if !hole(i, j) {
                    tris.push([p(i, j), p(i + 1, j), p(i + 1, j + 1)]);
                    tris.push([p(i, j), p(i + 1, j + 1), p(i, j + 1)]);
                }
            }
        }
        tris
    }

    /// Brute force: does the segment cross the plane z = 0 inside a triangle?
    fn crosses(tris: &[[Vec3; 3]], a: DVec3, b: DVec3) -> bool {
        if (a.z < 0.0) == (b.z < 0.0) {
            return false;
        }
        let q = a + (b - a) * (a.z / (a.z - b.z));
        tris.iter().any(|t| {
            let c = t.map(|p| p.as_dvec3());
            let s = |u: DVec3, v: DVec3| (v.x - u.x) * (q.y - u.y) - (v.y - u.y) * (q.x - u.x);
            let (d0, d1, d2) = (s(c[0], c[1]), s(c[1], c[2]), s(c[2], c[0]));
            (d0 >= 0.0 && d1 >= 0.0 && d2 >= 0.0) || (d0 <= 0.0 && d1 <= 0.0 && d2 <= 0.0)
        })
    }

    fn union_of(tris: &[[Vec3; 3]]) -> PlanarUnion {
        PlanarUnion::new(2, 0.0, tris, vec![0]).expect("a union")
    }

    fn point_in(b: &Aabb, rng: &mut Rng) -> DVec3 {
        let t = Vec3::new(rng.unit(), rng.unit(), rng.unit());
        (b.min + (b.max - b.min) * t).as_dvec3()
    }

    #[test]
    fn a_wall_with_a_doorway_hides_what_the_doorway_does_not_show() {
        // 12 m × 4 m of 0.5 m squares, a doorway 1 m wide and 2.5 m high at x 5.5..6.5.
        let tris = wall(24, 8, 0.5, |i, j| (11..13).contains(&i) && j < 5);
        let u = union_of(&tris);
        let cell = Aabb::new(Vec3::new(5.0, 1.5, -6.0), Vec3::new(7.0, 2.0, -4.0));
        // Behind the wall, off to the side: every segment crosses the wall left of the doorway.
        let aside = Aabb::new(Vec3::new(0.5, 0.5, 3.0), Vec3::new(1.5, 1.5, 4.0));
        assert!(u.hides(&cell, &aside, 1e-3, 1e-3));
        // Behind the doorway: seen through it.
        let behind = Aabb::new(Vec3::new(5.8, 0.5, 3.0), Vec3::new(6.2, 1.5, 4.0));
        assert!(!u.hides(&cell, &behind, 1e-3, 1e-3));
        // High behind the doorway: the shaft crosses the lintel and the wall either side
        // of it, which no convex piece of the wall holds alone.
        let high = Aabb::new(Vec3::new(5.0, 3.6, 3.0), Vec3::new(7.0, 3.9, 3.5));
        assert!(u.hides(&cell, &high, 1e-3, 1e-3), "the wall around the lintel hides it");
        // Nothing on the cell's side of the plane, nor across it, is hidden.
        let near = Aabb::new(Vec3::new(0.5, 0.5, -3.0), Vec3::new(1.5, 1.5, -2.0));
        assert!(!u.hides(&cell, &near, 1e-3, 1e-3));
        let across = Aabb::new(Vec3::new(0.5, 0.5, -1.0), Vec3::new(1.5, 1.5, 1.0));
        assert!(!u.hides(&cell, &across, 1e-3, 1e-3));
    }

    #[test]
    fn a_t_junction_is_a_seam_and_a_shared_edge_is_not() {
        // Two 2 m squares meeting at x = 0; the right one split at y = 1 (a vertex on
        // the left one's edge: a T-junction the renderer may crack open).
        let left = wall(1, 1, 2.0, |_, _| false)
            .into_iter()
            .map(|t| t.map(|p| p - Vec3::new(2.0, 0.0, 0.0)))
            .collect::<Vec<_>>();
        let right = wall(2, 2, 1.0, |_, _| false);
        let cell = Aabb::new(Vec3::new(-0.3, 0.8, -3.0), Vec3::new(0.3, 1.2, -2.5));
        let x = Aabb::new(Vec3::new(-0.2, 0.9, 2.5), Vec3::new(0.2, 1.1, 3.0));
        let t_junction = union_of(&[left.clone(), right.clone()].concat());
        assert!(!t_junction.hides(&cell, &x, 1e-3, 1e-3), "hidden across a T-junction");
        // The left square split the same way: the edges match, the seam is interior.
        let left_split = wall(2, 2, 1.0, |_, _| false)
            .into_iter()
            .map(|t| t.map(|p| p - Vec3::new(2.0, 0.0, 0.0)))
            .collect::<Vec<_>>();
        let shared = union_of(&[left_split, right].concat());
        assert!(shared.hides(&cell, &x, 1e-3, 1e-3), "not hidden across a shared edge");
    }

    #[test]
    fn hidden_means_every_sampled_segment_crosses_a_triangle() {
        let mut rng = Rng::new(13);
        let (mut hidden, mut shown) = (0, 0);
        for case in 0..300 {
            let (n, m) = (2 + rng.below(10) as usize, 2 + rng.below(8) as usize);
            let holes: Vec<bool> = (0..n * m).map(|_| rng.unit() < 0.15).collect();
            let tris = wall(n, m, 0.5, |i, j| holes[i * m + j]);
            let Some(u) = PlanarUnion::new(2, 0.0, &tris, vec![0]) else {
                continue;
            };
            let span = Vec3::new(n as f32 * 0.5, m as f32 * 0.5, 0.0);
            let at = |rng: &mut Rng, z0: f32, z1: f32, size: f32| {
                let c = Vec3::new(rng.range(0.0, span.x), rng.range(0.0, span.y), rng.range(z0, z1));
                let h = Vec3::new(rng.range(0.01, size), rng.range(0.01, size), rng.range(0.01, size));
                Aabb::new(c - h, c + h)
            };
            let cell = at(&mut rng, -4.0, -1.0, 0.6);
            let x = at(&mut rng, 1.0, 4.0, 0.4);
            let (gap, lateral) = (1e-3, 1e-3);
            if u.hides(&cell, &x, gap, lateral) {
                hidden += 1;
                for _ in 0..200 {
                    let (a, b) = (point_in(&cell, &mut rng), point_in(&x, &mut rng));
                    assert!(crosses(&tris, a, b), "case {case}: a segment misses the wall");
                }
            } else {
                shown += 1;
            }
        }
        assert!(
            hidden > 20 && shown > 20,
            "hidden {hidden}, shown {shown}: the cases test little"
        );
    }

    #[test]
    fn planes_group_exactly_and_keep_their_objects() {
        let mut tris: Vec<(u32, [Vec3; 3])> = wall(2, 2, 1.0, |_, _| false).into_iter().map(|t| (4, t)).collect();
        tris.extend(
            wall(2, 2, 1.0, |_, _| false)
                .into_iter()
                .map(|t| (2, t.map(|p| p + Vec3::new(2.0, 0.0, 0.0)))),
        );
        // A hair off the plane: its own plane, too small to keep.
        tris.push((
            9,
            [
                Vec3::new(0.0, 0.0, 1e-6),
                Vec3::new(1.0, 0.0, 1e-6),
                Vec3::new(0.0, 1.0, 1e-6),
            ],
        ));
        let unions = planar_unions(&tris, 3, 0.5);
        assert_eq!(unions.len(), 1);
        assert_eq!(unions[0].objects, vec![2, 4]);
        assert_eq!((unions[0].axis, unions[0].at), (2, 0.0));
        // The two grids share the edge x = 2 exactly: one 4 m × 2 m rectangle's boundary.
        let length: f64 = unions[0].boundary.iter().map(|e| e[0].distance(e[1])).sum();
        assert_eq!(length, 12.0);
    }

    #[test]
    fn the_hull_holds_every_point_with_its_corners_among_them() {
        let mut rng = Rng::new(5);
        for _ in 0..200 {
            let n = 1 + rng.below(40) as usize;
            let p: Vec<DVec2> = (0..n)
                .map(|_| DVec2::new(rng.range(-1.0, 1.0) as f64, rng.range(-1.0, 1.0) as f64))
                .collect();
            let h = convex_hull(p.clone());
            assert!(h.iter().all(|c| p.contains(c)));
            if h.len() >= 3 {
                assert!(p
                    .iter()
                    .all(|&q| inside_convex(q, &h) || h.iter().any(|&c| c.distance(q) < 1e-12)));
            }
        }
    }
}
