//! A convex stand-in drawn as its silhouette: the outline of its projection,
//! shrunk by more than the snapping error, as a fan of a few triangles set
//! up by the exact rule (hom's design, for the stand-ins of Law & Tan 1999's
//! virtual occluders, section 4).
//!
//! A stand-in must cover only samples its original covers, and lie behind
//! it. Drawn triangle by triangle it takes the inner rule, which leaves the
//! samples near each edge uncovered; so it is drawn two-sided, and its back
//! faces fill what the front faces' inner edges leave between them (without
//! them sculpture-park's HOM efficiency fell from 83.0 to 70.9 %). A convex
//! solid needs neither: its projection is the convex hull `H` of its
//! projected corners.
//!
//! **Coverage.** The hull's edges move inwards by [`SHRINK`] (5/256 pixel):
//! the shrunk polygon `S` keeps every point at least that far inside `H`.
//! `S`'s corners reach the setup in clip space with `w = 1` (f32 rounding
//! moves them by under 0.1 unit) and snap by at most half a unit (1/512
//! pixel) an axis, so the fan over the snapped corners, covering by the
//! exact rule (watertight between its own triangles), covers only samples
//! more than 4 units inside `H`: inside the true projection even after a
//! unit of projection error, which is the inner rule's guarantee with a
//! margin to spare. `S` is drawn as a fan from the solid's nearest corner
//! when that lies inside the outline (then the fan's triangles lie in the
//! front faces of a box seen across a corner), else from its nearest
//! outline corner.
//!
//! **Depth.** Each corner of `S` lies in some triangle of the fan over `H`
//! from the same apex; that triangle's corners are the solid's, so the
//! triangle lies inside the solid, and its depth (affine on screen, as it is
//! flat) at the corner of `S` is the depth of a point inside the solid. The
//! fan over `S` then spans points inside the solid: at every sample it is
//! at or behind the solid's front. Each triangle moves back as the inner
//! rule moves its triangles (the plane's change over a few units of snapping,
//! f32 rounding and [`INNER_DEPTH_SLACK`]).
//!
//! Anything else (a corner in front of the near plane or beyond the guard
//! band, a projection too thin to shrink, a depth beyond the far plane, more
//! than [`MAX_CORNERS`] corners) gives `None`, and the caller draws the
//! triangles two-sided by the inner rule, as before.
//!
//! On the city's walk a box's 12 triangles become 2 to 6, the occluder
//! triangles drawn a frame fall from 2,109 to 1,364 and HOM's cull from
//! 0.73–0.75 to 0.68–0.70 ms (`cull_time hom city`, two threads); the
//! silhouettes cost about 450 ns a box in the setup (a timing loop over
//! random boxes at 1024²: some thirty f64 divisions and six square roots),
//! against 25 or so a triangle saved. Every scene's culling efficiency is
//! unchanged.

use super::setup::{Viewport, INNER_DEPTH_SLACK, ONE};
use glam::{DVec2, Vec4};
use std::ops::Range;

/// How far the hull's edges move in, in pixels: 5 snapping units, of which
/// the snapped corners can take back at most √2 / 2 and the projection one.
pub(crate) const SHRINK: f64 = 5.0 / ONE as f64;

/// Most corners a silhouette is drawn from: a box's 8. A convex part's hull
/// (`occluders/virtual_occluder/convex.rs` in hom) keeps three corners per triangle (36 for
/// the smallest) and is drawn as its triangles. As silhouettes, hulls of up
/// to 64 corners took HOM's efficiency on sculpture-park from 83.0 to
/// 80.5 % (`hom bench --cullers hom --no-cost-model`, 2026-12-04; HZB's and
/// masked's rose by 0.6 points). The likely cause, not confirmed: a round
/// hull's front is not a fan from one corner, so the fan's triangles run
/// through its inside, behind the front, and HOM's depth cells keep the
/// farthest first cover.
const MAX_CORNERS: usize = 8;

/// Corners farther out than this (pixels from the origin) fall back to the
/// triangles, which are clipped to the guard band.
const MAX_PX: f64 = (1u32 << 18) as f64;

/// Working space for [`silhouette`], kept between calls.
#[derive(Debug, Default)]
pub(crate) struct Scratch {
    /// Projected corners: screen position (pixels) and depth.
    pts: Vec<(DVec2, f64)>,
    hull: Vec<(DVec2, f64)>,
    /// Per hull edge, its inward unit normal.
    normal: Vec<DVec2>,
    shrunk: Vec<(DVec2, f64)>,
    fan: Vec<[Vec4; 3]>,
}

/// The silhouette of the convex solid whose corners (hom's clip
/// convention, `0 <= z <= w`) are `corners`, as a fan of at most as many
/// triangles as the outline has corners, in clip space with `w = 1` (so
/// that any setup takes them as they are: depth `z`, no clipping); empty
/// when the shrunk silhouette covers no sample. `None` when the caller must
/// draw the solid's triangles instead.
pub(crate) fn silhouette<'s>(corners: &[Vec4], vp: &Viewport, scratch: &'s mut Scratch) -> Option<&'s [[Vec4; 3]]> {
    if corners.len() < 3 || corners.len() > MAX_CORNERS {
        return None;
    }
    let Scratch {
        pts,
        hull,
        normal,
        shrunk,
        fan,
    } = scratch;
    pts.clear();
    for c in corners {
        let c = c.as_dvec4();
        // In front of the near plane, beyond the far one, or not finite: not here.
        if !(c.w > 0.0 && c.z >= 0.0 && c.z <= c.w && c.is_finite()) {
            return None;
        }
        let iw = 1.0 / c.w;
        let s = DVec2::new(
            (c.x * iw * 0.5 + 0.5) * f64::from(vp.width),
            (0.5 - c.y * iw * 0.5) * f64::from(vp.height),
        );
        if s.x.abs() > MAX_PX || s.y.abs() > MAX_PX {
            return None;
        }
        pts.push((s, c.z * iw));
    }
    fan.clear();
    // Wholly beyond a side of the viewport: no sample, no outline to find
    // (a quarter of sculpture-park's boxes drawn, a twentieth of the city's).
    let (lo, hi) = pts
        .iter()
        .fold((DVec2::MAX, DVec2::MIN), |(lo, hi), p| (lo.min(p.0), hi.max(p.0)));
    if hi.x <= 0.0 || hi.y <= 0.0 || lo.x >= f64::from(vp.width) || lo.y >= f64::from(vp.height) {
        return Some(fan);
    }
    convex_hull(pts, hull);
    let n = hull.len();
    if n < 3 {
        return Some(fan); // no area: the inner rule covers nothing either
    }
    // Inward unit normals (the hull runs counter-clockwise in these axes).
    normal.clear();
    normal.extend((0..n).map(|i| {
        let d = hull[wrap(i + 1, n)].0 - hull[i].0;
        DVec2::new(-d.y, d.x).normalize()
    }));
    // The shrunk corners: where the edges before and after each corner meet, moved in.
    shrunk.clear();
    for i in 0..n {
        let (a, b) = (normal[wrap(i + n - 1, n)], normal[i]);
        let (ca, cb) = (a.dot(hull[wrap(i + n - 1, n)].0) + SHRINK, b.dot(hull[i].0) + SHRINK);
        let det = a.perp_dot(b);
        if det <= 0.0 {
            return None;
        }
        shrunk.push((DVec2::new(ca * b.y - cb * a.y, a.x * cb - b.x * ca) / det, 0.0));
    }
    // The shrunk edges run as the hull's do, or one vanished and the polygon
    // folded (a convex polygon's edges moved in meet at its erosion's
    // corners as long as none turns round).
    if (0..n).any(|i| (shrunk[wrap(i + 1, n)].0 - shrunk[i].0).dot(hull[wrap(i + 1, n)].0 - hull[i].0) <= 0.0) {
        return None;
    }
    // The fan's apex: the solid's nearest corner. Inside the outline (a box
    // seen across a corner), the hull's fan from it lies in the front faces;
    // on the outline, its shrunk corner.
    let nearest = pts
        .iter()
        .copied()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap_or(hull[0]);
    let inside = (0..n).all(|j| normal[j].dot(nearest.0 - hull[j].0) >= 2.0 * SHRINK);
    let apex = if inside {
        Apex::Inside(nearest)
    } else {
        Apex::Corner((0..n).min_by(|&i, &j| hull[i].1.total_cmp(&hull[j].1)).unwrap_or(0))
    };
    // Each shrunk corner's depth in the hull's fan from the apex.
    for (i, s) in shrunk.iter_mut().enumerate() {
        s.1 = depth_in_fan(hull, apex, i, s.0)?;
    }
    let (tip, from, triangles) = apex.fan(shrunk);
    for k in triangles {
        fan.push(behind(
            [tip, shrunk[wrap(from + k, n)], shrunk[wrap(from + k + 1, n)]],
            vp,
        )?);
    }
    Some(fan)
}

/// The convex hull of `pts` (sorted in place) into `hull`, counter-clockwise
/// with x right and y down taken as a right-handed plane, without repeated
/// or collinear corners.
fn convex_hull(pts: &mut [(DVec2, f64)], hull: &mut Vec<(DVec2, f64)>) {
    pts.sort_by(|a, b| a.0.x.total_cmp(&b.0.x).then(a.0.y.total_cmp(&b.0.y)));
    // Monotone chain (Andrew 1979): the lower chain left to right, then the
    // upper right to left, dropping every corner that is not a strict left turn.
    hull.clear();
    let add = |p: (DVec2, f64), start: usize, hull: &mut Vec<(DVec2, f64)>| {
        while let [.., a, b] = hull[start..] {
            if (b.0 - a.0).perp_dot(p.0 - a.0) > 0.0 {
                break;
            }
            hull.pop();
        }
        hull.push(p);
    };
    for &p in pts.iter() {
        add(p, 0, hull);
    }
    hull.pop(); // the rightmost point starts the upper chain
    let start = hull.len();
    for &p in pts.iter().rev() {
        add(p, start, hull);
    }
    hull.pop(); // the leftmost point ended it
}

/// `i % n` for `i < 2n`, without a division (a few dozen a silhouette).
#[inline(always)]
fn wrap(i: usize, n: usize) -> usize {
    if i >= n {
        i - n
    } else {
        i
    }
}

/// Where a fan over the hull starts.
#[derive(Clone, Copy)]
enum Apex {
    /// A corner of the solid inside the outline: one triangle per hull edge.
    Inside((DVec2, f64)),
    /// Hull corner `c`: a triangle per hull edge not at `c`.
    Corner(usize),
}

impl Apex {
    /// The fan from this apex over `ring` (the hull or its shrunk outline,
    /// corner for corner): its tip, the corner it counts from, and its
    /// triangles `k`, each `tip, ring[from + k], ring[from + k + 1]`.
    fn fan(self, ring: &[(DVec2, f64)]) -> ((DVec2, f64), usize, Range<usize>) {
        match self {
            Apex::Inside(q) => (q, 0, 0..ring.len()),
            Apex::Corner(c) => (ring[c], c, 1..ring.len() - 1),
        }
    }
}

/// The depth at `p`, near hull corner `i`, of the hull's fan from `apex`;
/// `None` when `p` is in none of its triangles (it left the hull).
fn depth_in_fan(hull: &[(DVec2, f64)], apex: Apex, i: usize, p: DVec2) -> Option<f64> {
    let n = hull.len();
    let (tip, from, edges) = apex.fan(hull);
    // Triangle k's smallest barycentric weight at p, and its depth there.
    let weights = |k: usize| {
        let (b, c) = (hull[wrap(from + k, n)], hull[wrap(from + k + 1, n)]);
        let inv = 1.0 / (b.0 - tip.0).perp_dot(c.0 - tip.0);
        let wb = (p - tip.0).perp_dot(c.0 - tip.0) * inv;
        let wc = (b.0 - tip.0).perp_dot(p - tip.0) * inv;
        let wa = 1.0 - wb - wc;
        (wa.min(wb).min(wc), wa * tip.1 + wb * b.1 + wc * c.1)
    };
    // The triangle at corner i on p's side of the chord to it (p lies near
    // the corner), else the one of all holding p best (its smallest weight largest).
    let left = (hull[i].0 - tip.0).perp_dot(p - tip.0) >= 0.0;
    let k = wrap(i + n - from - usize::from(!left), n);
    if edges.contains(&k) {
        let (w, z) = weights(k);
        if w >= 0.0 {
            return Some(z);
        }
    }
    let (w, z) = edges
        .map(weights)
        .filter(|(w, _)| w.is_finite())
        .max_by(|a, b| a.0.total_cmp(&b.0))?;
    (w >= -1e-9).then_some(z)
}

/// A fan triangle's corners (screen pixels, depth) in clip space with
/// `w = 1`, each moved back by the inner rule's depth allowance for the
/// triangle's plane; `None` when a depth would lie beyond the far plane.
fn behind(tri: [(DVec2, f64); 3], vp: &Viewport) -> Option<[Vec4; 3]> {
    let [(p0, z0), (p1, z1), (p2, z2)] = tri;
    let (d1, d2) = (p1 - p0, p2 - p0);
    let det = d1.perp_dot(d2);
    let (dzdx, dzdy) = if det != 0.0 {
        (
            ((z1 - z0) * d2.y - (z2 - z0) * d1.y) / det,
            ((z2 - z0) * d1.x - (z1 - z0) * d2.x) / det,
        )
    } else {
        (0.0, 0.0)
    };
    let slope = (dzdx.abs() + dzdy.abs()) * (4.0 / ONE as f64);
    let (sx, sy) = (2.0 / f64::from(vp.width), 2.0 / f64::from(vp.height));
    let mut out = [Vec4::ZERO; 3];
    for (o, (p, z)) in out.iter_mut().zip(tri) {
        let z = z + slope + (z.abs() * 4.0 + INNER_DEPTH_SLACK) * f64::from(f32::EPSILON);
        // Rounded up to f32, so never nearer.
        let mut zf = z as f32;
        if f64::from(zf) < z {
            zf = zf.next_up();
        }
        if zf.is_nan() || zf > 1.0 {
            return None;
        }
        *o = Vec4::new((p.x * sx - 1.0) as f32, (1.0 - p.y * sy) as f32, zf, 1.0);
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::Camera;
    use crate::raster::setup::{setup_triangle_with, SetupRule, Tri, Vertex};
    use glam::{DVec2, Mat4, Quat, Vec3};
    use hom_testkit::Rng;
    use proptest::prelude::*;

    /// The silhouette set up by the exact rule, as a queue sets it up.
    fn set_up(corners: &[Vec4], vp: &Viewport) -> Option<Vec<Tri>> {
        let mut out = Vec::new();
        for t in silhouette(corners, vp, &mut Scratch::default())? {
            let [a, b, c] = t.map(|v| Vertex::new(v, vp));
            setup_triangle_with([&a, &b, &c], vp, SetupRule::default(), 0, [0; 4], &mut out);
        }
        Some(out)
    }

    /// Per sample, whether any of `tris` covers it and the nearest depth there.
    fn draw(tris: &[Tri], w: u32, h: u32) -> Vec<Option<f32>> {
        let mut px = vec![None; (w * h) as usize];
        for t in tris {
            for y in u32::from(t.y0)..u32::from(t.y1) {
                for x in u32::from(t.x0)..u32::from(t.x1) {
                    if t.covers(x, y) {
                        let d = &mut px[(y * w + x) as usize];
                        let z = t.depth_at(x, y);
                        *d = Some(d.map_or(z, |e: f32| e.min(z)));
                    }
                }
            }
        }
        px
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]
        /// A box (turned, stretched, mirrored, from any side): its silhouette
        /// covers only samples the renderer covers with the box's own
        /// triangles, at or behind the renderer's depth there, and every
        /// sample the renderer covers with all eight neighbours.
        #[test]
        fn a_box_silhouette_lies_inside_and_behind_the_box(seed in any::<u64>(), size in (8u32..160, 8u32..160)) {
            let mut rng = Rng::new(seed);
            let (w, h) = size;
            let turn = Quat::from_euler(glam::EulerRot::XYZ, rng.range(-3.2, 3.2), rng.range(-3.2, 3.2), rng.range(-3.2, 3.2));
            let mut scale = rng.vec3(0.2, 3.0);
            if rng.below(4) == 0 {
                scale.x = -scale.x;
            }
            let model = Mat4::from_scale_rotation_translation(scale, turn, rng.vec3(-1.0, 1.0));
            let eye = rng.vec3(-1.0, 1.0).normalize_or(Vec3::X) * rng.range(3.0, 40.0);
            let camera = Camera::new(eye, rng.vec3(-1.0, 1.0), Vec3::Y, rng.range(0.4, 1.6), 0.1, 100.0, w, h);
            prop_assume!(camera.validate().is_ok());
            let cube = hom_testkit::cube();
            let m = camera.view_proj() * model;
            let corners: Vec<Vec4> = cube.positions().iter().map(|p| m * p.extend(1.0)).collect();
            let vp = Viewport::new(w, h);
            let mut want = Vec::new();
            for t in cube.triangles() {
                let [a, b, c] = t.map(|i| Vertex::new(corners[i as usize], &vp));
                setup_triangle_with([&a, &b, &c], &vp, SetupRule::default(), 0, [0; 4], &mut want);
            }
            let fan = set_up(&corners, &vp);
            prop_assume!(fan.is_some());
            let fan = fan.unwrap();
            prop_assert!(fan.len() <= 6, "{} triangles", fan.len());
            let (want, got) = (draw(&want, w, h), draw(&fan, w, h));
            for y in 0..h {
                for x in 0..w {
                    let k = (y * w + x) as usize;
                    if let Some(z) = got[k] {
                        let truth = want[k];
                        prop_assert!(truth.is_some(), "({}, {}) covered outside the box", x, y);
                        prop_assert!(z >= truth.unwrap(), "({}, {}) in front: {} < {:?}", x, y, z, truth);
                    }
                    let inside = x > 0 && y > 0 && x + 1 < w && y + 1 < h
                        && (y - 1..=y + 1).all(|v| (x - 1..=x + 1).all(|u| want[(v * w + u) as usize].is_some()));
                    prop_assert!(!inside || got[k].is_some(), "({}, {}) deep inside, not covered", x, y);
                }
            }
        }
    }

    #[test]
    fn boxes_in_view_are_drawn_as_silhouettes() {
        let mut rng = Rng::new(5);
        let cube = hom_testkit::cube();
        let (mut drawn, mut tries) = (0, 0);
        for _ in 0..200 {
            let eye = rng.vec3(-1.0, 1.0).normalize_or(Vec3::X) * rng.range(4.0, 30.0);
            let camera = Camera::new(eye, Vec3::ZERO, Vec3::Y, 1.0, 0.1, 100.0, 200, 150);
            let m = camera.view_proj() * Mat4::from_scale(rng.vec3(0.3, 2.0));
            let corners: Vec<Vec4> = cube.positions().iter().map(|p| m * p.extend(1.0)).collect();
            tries += 1;
            if let Some(fan) = set_up(&corners, &Viewport::new(200, 150)) {
                assert!((1..=6).contains(&fan.len()), "{} triangles", fan.len());
                drawn += 1;
            }
        }
        assert_eq!(drawn, tries, "every box wholly in view has a silhouette");
    }

    #[test]
    fn the_hull_drops_repeated_and_collinear_corners() {
        let square = [(0.0, 0.0), (4.0, 0.0), (4.0, 4.0), (0.0, 4.0)];
        let mut pts: Vec<(DVec2, f64)> = square
            .iter()
            .chain(&[(2.0, 0.0), (4.0, 2.0), (1.0, 1.0), (0.0, 0.0), (4.0, 4.0), (2.0, 4.0)])
            .map(|&(x, y)| (DVec2::new(x, y), 0.5))
            .collect();
        let mut hull = Vec::new();
        convex_hull(&mut pts, &mut hull);
        let got: Vec<(f64, f64)> = hull.iter().map(|p| (p.0.x, p.0.y)).collect();
        assert_eq!(got, [(0.0, 0.0), (4.0, 0.0), (4.0, 4.0), (0.0, 4.0)]);
        // A needle too thin to shrink falls back to the triangles.
        let needle = [
            Vec4::new(-0.5, 0.0, 0.5, 1.0),
            Vec4::new(0.5, 0.0, 0.5, 1.0),
            Vec4::new(0.5, 0.0001, 0.5, 1.0),
        ];
        assert!(silhouette(&needle, &Viewport::new(64, 64), &mut Scratch::default()).is_none());
    }
}
