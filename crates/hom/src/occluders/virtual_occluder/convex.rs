//! Stage 2 of the virtual-occluder bake, convex parts: inscribed hulls (Law
//! & Tan 1999, section 4.2's first option, specialised to convex solids).
//!
//! The cell boxes of `boxes.rs` keep about 55 % of a sphere's
//! coverage; a round part deserves better. When a closed component is convex,
//! the convex hull of *any* subset of its vertices lies inside it, so a hull
//! of a few dozen of its vertices is an inscribed stand-in that keeps close
//! to 90 % of its silhouette (a UV sphere's 48-point hull: 88 % along the
//! axes), at a handful of triangles.
//!
//! **Convex, proven locally.** A component is taken as convex when it is a
//! closed, consistently oriented 2-manifold of genus 0 (every edge used once
//! in each direction, V − E + F = 2, positive volume) whose every edge is
//! convex: each triangle's neighbour across an edge lies on or behind the
//! triangle's plane (within `TOLERANCE` of the part's extent). A closed
//! locally convex polyhedral sphere bounds a convex body (van Heijenoort
//! 1952), so no global test is needed.
//!
//! **Safe by construction.** Every stand-in triangle has hull vertices of the
//! part for corners, so it lies in the convex body whether or not the hull
//! routine got every degenerate case right; a bad hull can only lose coverage.
//! The tolerance the convexity test allows is paid back by shrinking the
//! hull towards the vertices' centroid, by several times the tolerance plus
//! the rounding of the shrunk corners.

use super::solids::Parts;
use glam::{DVec3, Vec3};

/// Local convexity allowed: a neighbour may lie this far (times the part's
/// extent) in front of a triangle's plane. Tessellated spheres and cylinders
/// put a quad's fourth corner about 1e-7 off its first triangle's plane.
const TOLERANCE: f64 = 1e-6;

/// The hulls a convex part offers, of increasing size: support vertices
/// along this many directions each.
const LEVELS: [usize; 4] = [8, 14, 26, 48];

/// One hull of a convex part.
pub(crate) struct Hull {
    /// Triangles, wound outward, already shrunk inside the part.
    pub(crate) triangles: Vec<[Vec3; 3]>,
    /// Half the surface area: the area shown along the three axes for an
    /// axis-aligned box, and twice the mean over all views for any convex
    /// body (Cauchy's formula). Not the axis projection itself: a box with a
    /// corner cut off shows the same along every axis, and less from
    /// anywhere else.
    pub(crate) value: f32,
}

/// A convex closed component's hulls, smallest first (each a superset of the
/// previous one's vertices, so each shows at least as much).
pub(crate) struct ConvexPart {
    pub(crate) hulls: Vec<Hull>,
}

/// The hulls of the component with triangles `tris` over welded vertex
/// positions `p`, or `None` when it is not provably convex (or too thin for
/// the shrink to pay for the tolerance).
pub(crate) fn convex_part(p: &[Vec3], tris: &[[u32; 3]]) -> Option<ConvexPart> {
    let mut used: Vec<u32> = tris.iter().flatten().copied().collect();
    used.sort_unstable();
    used.dedup();
    let (lo, hi) = used.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &i| {
        (lo.min(p[i as usize]), hi.max(p[i as usize]))
    });
    let extent = f64::from((hi - lo).max_element());
    if extent.is_nan() || extent <= 0.0 || tris.len() < 4 {
        return None;
    }
    let tol = TOLERANCE * extent;
    let q = |i: u32| p[i as usize].as_dvec3();
    // Every directed edge once, and its reverse once: closed, oriented, manifold.
    let mut directed: std::collections::HashMap<(u32, u32), usize> = std::collections::HashMap::new();
    for (t, v) in tris.iter().enumerate() {
        for k in 0..3 {
            if directed.insert((v[k], v[(k + 1) % 3]), t).is_some() {
                return None;
            }
        }
    }
    let edges = directed.len() / 2;
    if directed.keys().any(|&(a, b)| !directed.contains_key(&(b, a))) || used.len() + tris.len() != edges + 2 {
        return None;
    }
    let normals: Vec<DVec3> = tris
        .iter()
        .map(|v| (q(v[1]) - q(v[0])).cross(q(v[2]) - q(v[0])))
        .collect();
    if normals.iter().any(|n| n.length() <= 1e-12 * extent * extent) {
        return None;
    }
    // Each edge convex: the far corner of the neighbour across it on or behind the plane.
    for (t, v) in tris.iter().enumerate() {
        for k in 0..3 {
            let across = directed[&(v[(k + 1) % 3], v[k])];
            let far = tris[across].iter().copied().find(|w| !v.contains(w))?;
            if (q(far) - q(v[0])).dot(normals[t]) > tol * normals[t].length() {
                return None;
            }
        }
    }
    let volume: f64 = tris.iter().map(|v| q(v[0]).dot(q(v[1]).cross(q(v[2])))).sum::<f64>() / 6.0;
    if volume.is_nan() || volume <= 0.0 {
        return None;
    }
    // Shrink towards the centroid by enough to cover the tolerance, the
    // rounding of the shrunk corners, and the hull's own rounding.
    let centre = used.iter().map(|&i| q(i)).sum::<DVec3>() / used.len() as f64;
    let inner = tris
        .iter()
        .zip(&normals)
        .map(|(v, n)| (q(v[0]) - centre).dot(*n) / n.length())
        .fold(f64::INFINITY, f64::min);
    let rounding = f64::from(f32::EPSILON) * (centre.abs().max_element() + extent);
    let shrink = 4.0 * (tol + rounding) / inner;
    if !(shrink > 0.0 && shrink <= 0.01) {
        return None;
    }
    let hulls = LEVELS
        .iter()
        .filter_map(|&n| {
            let points = support_points(p, &used, n);
            let faces = hull(&points)?;
            let place = |x: DVec3| (centre + (x - centre) * (1.0 - shrink)).as_vec3();
            let triangles: Vec<[Vec3; 3]> = faces.iter().map(|f| f.map(|i| place(points[i]))).collect();
            let value = triangles
                .iter()
                .map(|[a, b, c]| (*b - *a).cross(*c - *a).length() * 0.25)
                .sum();
            Some(Hull { triangles, value })
        })
        .collect::<Vec<_>>();
    (!hulls.is_empty()).then_some(ConvexPart { hulls })
}

/// The vertices of `used` furthest along `n` directions spread over the
/// sphere (a Fibonacci spiral, tilted off the axes so a box's faces never
/// tie), without repeats, in first-found order.
fn support_points(p: &[Vec3], used: &[u32], n: usize) -> Vec<DVec3> {
    let tilt = glam::DQuat::from_euler(glam::EulerRot::XYZ, 0.3, 0.7, 0.1);
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let mut out: Vec<u32> = Vec::new();
    for k in 0..n {
        let y = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
        let r = (1.0 - y * y).sqrt();
        let d = tilt * DVec3::new(r * (golden * k as f64).cos(), y, r * (golden * k as f64).sin());
        let best = used
            .iter()
            .copied()
            .max_by(|&a, &b| {
                let (da, db) = (p[a as usize].as_dvec3().dot(d), p[b as usize].as_dvec3().dot(d));
                da.total_cmp(&db).then(b.cmp(&a))
            })
            .expect("a part has vertices");
        if !out.contains(&best) {
            out.push(best);
        }
    }
    out.iter().map(|&i| p[i as usize].as_dvec3()).collect()
}

/// The convex hull of `points` as outward-wound triangles (incremental: a
/// first tetrahedron, then each point replaces the faces that see it). A
/// point in the plane of a face is not seen by it and may be left out; the
/// hull is then smaller, never larger. `None` when the points are (nearly)
/// coplanar.
fn hull(points: &[DVec3]) -> Option<Vec<[usize; 3]>> {
    let n = points.len();
    if n < 4 {
        return None;
    }
    let size = points.iter().fold(0.0f64, |m, p| m.max((*p - points[0]).length()));
    let orient = |a: usize, b: usize, c: usize, d: usize| {
        (points[b] - points[a])
            .cross(points[c] - points[a])
            .dot(points[d] - points[a])
    };
    let eps = 1e-9 * size * size * size;
    // A first tetrahedron of well-spread points.
    let far = |from: &dyn Fn(usize) -> f64| (0..n).max_by(|&i, &j| from(i).total_cmp(&from(j)).then(j.cmp(&i)));
    let a = 0;
    let b = far(&|i| (points[i] - points[a]).length())?;
    let c = far(&|i| (points[i] - points[a]).cross(points[b] - points[a]).length())?;
    let d = far(&|i| orient(a, b, c, i).abs())?;
    if orient(a, b, c, d).abs() <= eps {
        return None;
    }
    let mut faces: Vec<[usize; 3]> = if orient(a, b, c, d) < 0.0 {
        vec![[a, b, c], [a, d, b], [b, d, c], [c, d, a]]
    } else {
        vec![[a, c, b], [a, b, d], [b, c, d], [c, a, d]]
    };
    for p in 0..n {
        if [a, b, c, d].contains(&p) {
            continue;
        }
        let sees: Vec<bool> = faces.iter().map(|f| orient(f[0], f[1], f[2], p) > eps).collect();
        if !sees.contains(&true) {
            continue;
        }
        // The horizon: edges of seeing faces whose reverse belongs to no seeing face.
        let seen_edges: std::collections::HashSet<(usize, usize)> = faces
            .iter()
            .zip(&sees)
            .filter(|(_, &s)| s)
            .flat_map(|(f, _)| (0..3).map(move |k| (f[k], f[(k + 1) % 3])))
            .collect();
        let horizon: Vec<(usize, usize)> = seen_edges
            .iter()
            .copied()
            .filter(|&(u, v)| !seen_edges.contains(&(v, u)))
            .collect();
        let mut kept: Vec<[usize; 3]> = faces.iter().zip(&sees).filter(|(_, &s)| !s).map(|(f, _)| *f).collect();
        kept.extend(horizon.into_iter().map(|(u, v)| [u, v, p]));
        faces = kept;
    }
    // Deterministic order (the horizon came out of a hash set).
    faces.sort_unstable();
    Some(faces)
}

impl Parts {
    /// Takes the provably convex solids out of [`Parts::solid`] (the grid
    /// need not find their inside cells) and returns their hulls.
    pub(super) fn take_convex(&mut self) -> Vec<ConvexPart> {
        let mut of_solid: Vec<Vec<[u32; 3]>> = vec![Vec::new(); self.count as usize];
        for &(t, s) in &self.solid {
            of_solid[s as usize].push(self.welded[t as usize]);
        }
        let convex: Vec<Option<ConvexPart>> = of_solid
            .iter()
            .map(|tris| convex_part(&self.welded_positions, tris))
            .collect();
        self.solid.retain(|&(_, s)| convex[s as usize].is_none());
        convex.into_iter().flatten().collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::occluders::virtual_occluder::{push_box, uv_sphere};

    /// The box 0..2 with corner bit 0 picking x = 2, bit 1 y, bit 2 z.
    fn unit_box() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let (mut p, mut t) = (Vec::new(), Vec::new());
        push_box(&mut p, &mut t, Vec3::ZERO, Vec3::splat(2.0));
        (p, t)
    }

    #[test]
    fn a_box_is_its_own_hull_shrunk_a_hair() {
        let (p, t) = unit_box();
        let part = convex_part(&p, &t).expect("a box is convex");
        let big = part.hulls.last().unwrap();
        assert_eq!(big.triangles.len(), 12);
        // Half of six faces of 4 m², less the shrink.
        assert!(big.value > 11.9 && big.value < 12.0, "{}", big.value);
        for v in big.triangles.iter().flatten() {
            assert!(v.cmpgt(Vec3::ZERO).all() && v.cmplt(Vec3::splat(2.0)).all(), "{v}");
        }
    }

    #[test]
    fn concave_open_and_inside_out_parts_are_not_convex() {
        let (p, t) = unit_box();
        // Inside out.
        let flipped: Vec<[u32; 3]> = t.iter().map(|v| [v[0], v[2], v[1]]).collect();
        assert!(convex_part(&p, &flipped).is_none());
        // Open: one triangle missing.
        assert!(convex_part(&p, &t[1..]).is_none());
        // A dent: the top face's corner 7 pushed down inside.
        let mut dented = p.clone();
        dented[7].y = 1.0;
        assert!(convex_part(&dented, &t).is_none());
    }

    #[test]
    fn hulls_grow_with_their_level_and_stay_inside_a_sphere() {
        let (p, t) = uv_sphere(24);
        let part = convex_part(&p, &t).expect("a UV sphere is convex");
        let values: Vec<f32> = part.hulls.iter().map(|h| h.value).collect();
        assert!(values.windows(2).all(|w| w[0] <= w[1]), "{values:?}");
        // Half the sphere's area is 2π; the 48-point hull has most of it.
        let full = 2.0 * std::f32::consts::PI;
        assert!(values[values.len() - 1] > 0.8 * full, "{values:?}");
        let big = part.hulls.last().unwrap();
        assert!(big.triangles.len() <= 2 * 48 - 4);
        // Inside: every corner within the unit sphere by more than the tessellation's sag.
        for v in big.triangles.iter().flatten() {
            assert!(v.length() < 1.0, "{v}");
        }
    }
}
