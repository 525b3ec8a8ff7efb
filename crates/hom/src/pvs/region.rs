//! Full occlusion regions of convex occluders (Law & Tan 1999, section 5.3;
//! the supporting planes are Coorg & Teller's).
//!
//! Law & Tan bound the viewpoints from which an occluder `O` hides an
//! occludee `X` by the supporting planes through an edge of one and a vertex
//! of the other: for convex `O` the full occlusion region is the intersection
//! of their half-spaces, so it is **convex**. hom tests a view cell against
//! that region without building the planes, by the property that makes it
//! convex:
//!
//! - for a fixed viewpoint `v`, the points `x` with segment `vx` crossing `O`
//!   form a convex set (the cone from `v` through `O`, beyond it), so `v` is
//!   in the region iff the segments to the 8 corners of `X`'s box cross `O`;
//! - for a fixed `x`, the viewpoints `v` with `vx` crossing `O` form a
//!   convex set likewise, so a box of viewpoints lies in the region iff its 8
//!   corners do.
//!
//! Hence a cell is fully occluded from `X` by `O` iff the 64 segments from
//! the cell's corners to `X`'s corners all cross `O` — exactly the test of the
//! cell's corners against the supporting planes, in a form with no
//! degenerate plane to construct. It holds for a planar convex polygon (the
//! segment crosses its plane inside it) and for a convex solid (the segment
//! meets its interior) alike. Every test is in `f64`.
//!
//! **Margins, so the renderer agrees.** The truth is pixel-centre samples of
//! snapped triangles with `f32` depth (DESIGN.md, the oracle). A segment must
//! cross `O` at least `lateral` inside its boundary (the polygon's edges, or
//! the solid's faces, pulled in), so a sample ray through it is covered by
//! `O` however its vertices snap; `X`'s box is grown by `gap`, so whatever
//! `X` shows along such a ray lies at least `gap` beyond `O` and wins no
//! depth tie (an occludee within `gap` of the occluder's box is never
//! hidden by it, so no part of it lies inside a solid occluder). [`Margins::for_pair`] scales both with the distance involved.

use super::margins::{box_distance, grown_corners, Margins};
use super::planar_union::PlanarUnion;
use crate::geom::Aabb;
use glam::{DVec3, Vec3};
use std::sync::Arc;

/// A plane `normal · p + d = 0`; "inside" is `normal · p + d <= 0`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct DPlane {
    pub(crate) normal: DVec3,
    pub(crate) d: f64,
}

impl DPlane {
    /// The plane through `a`, `b`, `c`, oriented so `inner` is inside; `None`
    /// when the three points are (nearly) collinear.
    pub(crate) fn through(a: DVec3, b: DVec3, c: DVec3, inner: DVec3) -> Option<DPlane> {
        let n = (b - a).cross(c - a);
        let len = n.length();
        let scale = (b - a).length().max((c - a).length()).max(1e-30);
        if len.is_nan() || len <= 1e-9 * scale * scale {
            return None;
        }
        let normal = n / len;
        let mut p = DPlane {
            normal,
            d: -normal.dot(a),
        };
        if p.eval(inner) > 0.0 {
            p = DPlane {
                normal: -p.normal,
                d: -p.d,
            };
        }
        Some(p)
    }

    pub(crate) fn eval(&self, p: DVec3) -> f64 {
        self.normal.dot(p) + self.d
    }
}

/// What an occluder is made of.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Shape {
    /// A convex solid: the intersection of these planes' insides (inside a
    /// closed original, so a ray through it meets the original first).
    Solid(Vec<DPlane>),
    /// A planar convex polygon: its plane and its edges' planes (normal in
    /// the polygon's plane, pointing out of it).
    Polygon { plane: DPlane, edges: Vec<DPlane> },
    /// Triangles in one axis-aligned plane, joined: not convex
    /// (`pvs/planar_union.rs` has its test).
    Union(Arc<PlanarUnion>),
}

/// A convex occluder in world space, from one static object.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct ConvexOccluder {
    /// The object whose original encloses (or is) it: it never hides itself.
    pub(crate) object: u32,
    pub(crate) bounds: Aabb,
    pub(crate) shape: Shape,
    /// For a solid closed by a floor cap: the eye must lie strictly inside
    /// this half-space (above the floor), or rays could enter through the cap.
    pub(crate) above: Option<DPlane>,
}

impl ConvexOccluder {
    /// The objects whose triangles it stands for (one but for a union).
    pub(crate) fn objects(&self) -> &[u32] {
        match &self.shape {
            Shape::Union(u) => &u.objects,
            _ => std::slice::from_ref(&self.object),
        }
    }

    /// A convex solid from triangles bounding it (any winding: each plane is
    /// oriented by the corners' centroid, which lies inside a convex body).
    pub(crate) fn solid(object: u32, triangles: &[[Vec3; 3]], above: Option<DPlane>) -> Option<ConvexOccluder> {
        let corners: Vec<DVec3> = triangles.iter().flatten().map(|p| p.as_dvec3()).collect();
        if corners.is_empty() {
            return None;
        }
        let centroid = corners.iter().sum::<DVec3>() / corners.len() as f64;
        let planes: Vec<DPlane> = triangles
            .iter()
            .filter_map(|t| DPlane::through(t[0].as_dvec3(), t[1].as_dvec3(), t[2].as_dvec3(), centroid))
            .collect();
        // A solid needs at least a tetrahedron's faces, and its centroid strictly inside.
        if planes.len() < 4 || planes.iter().any(|p| p.eval(centroid) >= 0.0) {
            return None;
        }
        Some(ConvexOccluder {
            object,
            bounds: Aabb::from_points(triangles.iter().flatten().copied()),
            shape: Shape::Solid(planes),
            above,
        })
    }

    /// A triangle as a planar occluder (two-sided, as the renderer draws it).
    #[cfg(test)]
    pub(crate) fn triangle(object: u32, t: [Vec3; 3]) -> Option<ConvexOccluder> {
        Self::polygon(object, &t)
    }

    /// A planar convex polygon (its corners in order, either way round) as
    /// an occluder; `None` when it is degenerate or not flat within 1e-6 of
    /// its size (its triangles, drawn two-sided, are what a ray meets).
    pub(crate) fn polygon(object: u32, corners: &[Vec3]) -> Option<ConvexOccluder> {
        let p: Vec<DVec3> = corners.iter().map(|c| c.as_dvec3()).collect();
        if p.len() < 3 {
            return None;
        }
        let centroid = p.iter().sum::<DVec3>() / p.len() as f64;
        // Newell's normal: robust for any simple polygon.
        let newell: DVec3 = (0..p.len()).map(|i| p[i].cross(p[(i + 1) % p.len()])).sum();
        let size = p.iter().map(|q| q.distance(centroid)).fold(0.0, f64::max);
        if newell.length().is_nan() || newell.length() <= 1e-12 * size * size {
            return None;
        }
        let normal = newell.normalize();
        let plane = DPlane {
            normal,
            d: -normal.dot(centroid),
        };
        if p.iter().any(|&q| plane.eval(q).abs() > 1e-6 * size) {
            return None;
        }
        let mut edges = Vec::with_capacity(p.len());
        for i in 0..p.len() {
            let (a, b) = (p[i], p[(i + 1) % p.len()]);
            let n = (b - a).cross(normal);
            if n.length() <= 1e-12 * size {
                continue;
            }
            let n = n.normalize();
            let e = DPlane {
                normal: n,
                d: -n.dot(a),
            };
            edges.push(if e.eval(centroid) > 0.0 {
                DPlane {
                    normal: -n,
                    d: n.dot(a),
                }
            } else {
                e
            });
        }
        // Convex: every corner on or inside every edge's plane.
        if edges.len() < 3 || p.iter().any(|&q| edges.iter().any(|e| e.eval(q) > 1e-6 * size)) {
            return None;
        }
        Some(ConvexOccluder {
            object,
            bounds: Aabb::from_points(corners.iter().copied()),
            shape: Shape::Polygon { plane, edges },
            above: None,
        })
    }

    /// Triangles in one axis-aligned plane, joined, as an occluder; its
    /// `object` is the least of its objects (it hides nothing that reaches
    /// its plane, so none of them).
    pub(crate) fn union(union: PlanarUnion) -> ConvexOccluder {
        ConvexOccluder {
            object: union.objects[0],
            bounds: union.bounds,
            shape: Shape::Union(Arc::new(union)),
            above: None,
        }
    }

    /// Whether some eye in `cell` may come nearer than `clearance` to the
    /// occluder's surface (then the near plane could cut it open): its box
    /// that near, or for a union, the cell that near its plane.
    pub(crate) fn too_near(&self, cell: &Aabb, clearance: f32) -> bool {
        match &self.shape {
            Shape::Union(u) => {
                let (lo, hi) = cell
                    .corners()
                    .iter()
                    .map(|c| u.side(c.as_dvec3()))
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), d| (lo.min(d), hi.max(d)));
                // A cell across the plane is as near as can be.
                lo <= 0.0 && hi >= 0.0 || lo.abs().min(hi.abs()) < clearance as f64
            }
            _ => box_distance(&self.bounds, cell) < clearance,
        }
    }

    /// Does the segment `a`–`b` cross the occluder at least `lateral` inside
    /// its boundary?
    pub(crate) fn crossed_by(&self, a: DVec3, b: DVec3, lateral: f64) -> bool {
        match &self.shape {
            Shape::Union(u) => u.crossed_by(a, b, lateral),
            Shape::Solid(planes) => {
                // Cyrus–Beck against the planes pulled in by `lateral`.
                let (mut t0, mut t1) = (0.0f64, 1.0f64);
                let dir = b - a;
                for p in planes {
                    let fa = p.eval(a) + lateral;
                    let fd = p.normal.dot(dir);
                    if fd.abs() < 1e-300 {
                        if fa >= 0.0 {
                            return false;
                        }
                        continue;
                    }
                    let t = -fa / fd;
                    if fd > 0.0 {
                        t1 = t1.min(t);
                    } else {
                        t0 = t0.max(t);
                    }
                    if t0 >= t1 {
                        return false;
                    }
                }
                t0 < t1
            }
            Shape::Polygon { plane, edges } => {
                let (fa, fb) = (plane.eval(a), plane.eval(b));
                // Strictly on opposite sides (a segment in the plane hides nothing).
                if !((fa < 0.0 && fb > 0.0) || (fa > 0.0 && fb < 0.0)) {
                    return false;
                }
                let q = a + (b - a) * (fa / (fa - fb));
                edges.iter().all(|e| e.eval(q) + lateral <= 0.0)
            }
        }
    }

    /// Is every viewpoint in `cell` fully occluded from every point of `x`
    /// (grown by `margins.gap`) by this occluder, with `margins.lateral`?
    /// The 64 corner segments decide (see the module docs).
    pub(crate) fn hides(&self, cell: &Aabb, x: &Aabb, margins: Margins) -> bool {
        if let Shape::Union(u) = &self.shape {
            // Grown by `gap` and strictly beyond the plane, `x` lies `gap`
            // beyond every triangle of the union.
            return u.hides(cell, x, margins.gap, margins.lateral);
        }
        // An occludee reaching into the occluder's box could reach into the
        // solid, and lie there closer to the surface than depth resolves;
        // apart from it, every point of `x` lies `gap` beyond the occluder.
        if box_distance(&self.bounds, x) <= margins.gap as f32 {
            return false;
        }
        if let Some(above) = &self.above {
            if cell.corners().iter().any(|c| above.eval(c.as_dvec3()) >= 0.0) {
                return false;
            }
        }
        let xs = grown_corners(x, margins.gap);
        cell.corners()
            .iter()
            .all(|c| xs.iter().all(|&p| self.crossed_by(c.as_dvec3(), p, margins.lateral)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use hom_testkit::Rng;

    fn point_in(b: &Aabb, seed: &mut Rng) -> DVec3 {
        let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
        lo + (hi - lo) * DVec3::new(seed.unit_f64(), seed.unit_f64(), seed.unit_f64())
    }

    fn unit_box_solid(lo: Vec3, hi: Vec3) -> ConvexOccluder {
        let (mut p, mut t) = (Vec::new(), Vec::new());
        crate::occluders::push_box(&mut p, &mut t, lo, hi);
        let tris: Vec<[Vec3; 3]> = t.iter().map(|t| t.map(|i| p[i as usize])).collect();
        ConvexOccluder::solid(0, &tris, None).unwrap()
    }

    /// Brute force: does any sampled segment from the cell to the box miss
    /// the occluder (no margin)?
    fn some_segment_misses(o: &ConvexOccluder, cell: &Aabb, x: &Aabb, seed: &mut Rng) -> bool {
        (0..4000).any(|_| !o.crossed_by(point_in(cell, seed), point_in(x, seed), 0.0))
    }

    fn random_box(seed: &mut Rng, centre: DVec3, spread: f64, size: f64) -> Aabb {
        let c = centre + (DVec3::new(seed.unit_f64(), seed.unit_f64(), seed.unit_f64()) - 0.5) * spread;
        let h = DVec3::new(seed.unit_f64(), seed.unit_f64(), seed.unit_f64()) * size + 0.01;
        Aabb::new((c - h).as_vec3(), (c + h).as_vec3())
    }

    #[test]
    fn a_wall_hides_what_is_behind_it_from_a_cell_in_front() {
        let wall = unit_box_solid(Vec3::new(-10.0, 0.0, -0.5), Vec3::new(10.0, 10.0, 0.5));
        let cell = Aabb::new(Vec3::new(-1.0, 1.0, 3.0), Vec3::new(1.0, 2.0, 5.0));
        let behind = Aabb::new(Vec3::new(-1.0, 1.0, -4.0), Vec3::new(1.0, 3.0, -2.0));
        let m = Margins::for_pair(&cell, &behind, 1e-3, 0.1);
        assert!(wall.hides(&cell, &behind, m));
        // Taller than the wall: seen over it.
        let tall = Aabb::new(Vec3::new(-1.0, 1.0, -4.0), Vec3::new(1.0, 30.0, -2.0));
        assert!(!wall.hides(&cell, &tall, m));
        // On the cell's side: not hidden.
        let front = Aabb::new(Vec3::new(-1.0, 1.0, 1.0), Vec3::new(1.0, 2.0, 2.0));
        assert!(!wall.hides(&cell, &front, m));
        // Touching the wall from behind: the gap margin refuses it.
        let touching = Aabb::new(Vec3::new(-1.0, 1.0, -2.0), Vec3::new(1.0, 2.0, -0.5));
        assert!(!wall.hides(&cell, &touching, m));
    }

    /// The region test against brute force: whenever it says hidden, no
    /// sampled segment from the cell to the box misses the occluder (box and
    /// triangle occluders, random cells and boxes on either side).
    #[test]
    fn hidden_means_every_sampled_segment_crosses() {
        let mut seed = Rng::new(0x9E37_79B9_7F4A_7C15);
        let (mut hidden, mut cases) = (0, 0);
        for case in 0..600 {
            let o = if case % 2 == 0 {
                let b = random_box(&mut seed, DVec3::ZERO, 2.0, 3.0);
                unit_box_solid(b.min, b.max)
            } else {
                let p = |s: &mut Rng| ((DVec3::new(s.unit_f64(), s.unit_f64(), s.unit_f64()) - 0.5) * 12.0).as_vec3();
                let t = [p(&mut seed), p(&mut seed), p(&mut seed)];
                let made = if case % 4 == 1 {
                    ConvexOccluder::triangle(0, t)
                } else {
                    // A parallelogram: a convex quad.
                    ConvexOccluder::polygon(0, &[t[0], t[1], t[1] + t[2] - t[0], t[2]])
                };
                match made {
                    Some(o) => o,
                    None => continue,
                }
            };
            let dir = (DVec3::new(seed.unit_f64(), seed.unit_f64(), seed.unit_f64()) - 0.5).normalize() * 8.0;
            let cell = random_box(&mut seed, dir, 2.0, 1.0);
            let x = random_box(&mut seed, -dir, 4.0, 1.5);
            let m = Margins { lateral: 0.0, gap: 0.0 };
            cases += 1;
            if o.hides(&cell, &x, m) {
                hidden += 1;
                assert!(
                    !some_segment_misses(&o, &cell, &x, &mut seed),
                    "case {case}: a segment misses"
                );
            }
        }
        // The test must be able to fail: enough cases are hidden.
        assert!(hidden > cases / 20, "{hidden} of {cases} hidden");
    }

    /// And it is tight for boxes of viewpoints: when it says not hidden with
    /// no margin, some segment between the two boxes' corners misses.
    #[test]
    fn not_hidden_means_some_corner_segment_misses() {
        let mut seed = Rng::new(77);
        let zero = Margins { lateral: 0.0, gap: 0.0 };
        for _ in 0..300 {
            let b = random_box(&mut seed, DVec3::ZERO, 2.0, 3.0);
            let o = unit_box_solid(b.min, b.max);
            let cell = random_box(&mut seed, DVec3::new(0.0, 0.0, 8.0), 3.0, 1.0);
            let x = random_box(&mut seed, DVec3::new(0.0, 0.0, -8.0), 3.0, 1.0);
            let missing = cell.corners().iter().any(|c| {
                x.corners()
                    .iter()
                    .any(|p| !o.crossed_by(c.as_dvec3(), p.as_dvec3(), 0.0))
            });
            assert_eq!(o.hides(&cell, &x, zero), !missing);
        }
    }

    #[test]
    fn polygons_must_be_flat_and_convex() {
        let sq = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        assert!(ConvexOccluder::polygon(0, &sq).is_some());
        let dart = [Vec3::ZERO, Vec3::X, Vec3::new(0.3, 0.3, 0.0), Vec3::Y];
        assert!(ConvexOccluder::polygon(0, &dart).is_none());
        let bent = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.1), Vec3::Y];
        assert!(ConvexOccluder::polygon(0, &bent).is_none());
        assert!(ConvexOccluder::polygon(0, &[Vec3::ZERO, Vec3::X, Vec3::X * 2.0]).is_none());
    }

    #[test]
    fn a_floor_capped_solid_hides_nothing_from_below_its_floor() {
        let mut o = unit_box_solid(Vec3::new(-10.0, 0.0, -0.5), Vec3::new(10.0, 10.0, 0.5));
        o.above = Some(DPlane {
            normal: DVec3::NEG_Y,
            d: 0.0,
        });
        let behind = Aabb::new(Vec3::new(-1.0, 1.0, -4.0), Vec3::new(1.0, 3.0, -2.0));
        let m = Margins::for_pair(&behind, &behind, 1e-3, 0.1);
        assert!(o.hides(
            &Aabb::new(Vec3::new(-1.0, 1.0, 3.0), Vec3::new(1.0, 2.0, 5.0)),
            &behind,
            m
        ));
        assert!(!o.hides(
            &Aabb::new(Vec3::new(-1.0, -1.0, 3.0), Vec3::new(1.0, 2.0, 5.0)),
            &behind,
            m
        ));
    }
}
