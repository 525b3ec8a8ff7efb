//! Occluder fusion by point sampling (after Wonka, Wimmer & Schmalstieg 2000,
//! "Visibility preprocessing with occluder fusion for urban walkthroughs"),
//! for what no single occluder hides from a whole cell.
//!
//! **Shrink, then sample.** Erode every solid occluder by `ε`. If every ray
//! from a point `p` to every point of an occludee `X` meets the union of the
//! eroded solids, then from any viewpoint `v` within `ε` of `p` every ray to
//! `X` meets the union of the originals: the ray `p → x` meets an eroded
//! solid at `q`, and `v → x` passes within `(1 − s)·|v − p| ≤ ε` of `q` at
//! the same fraction `s` of its length, inside the solid `q` is `ε` deep in.
//! So sample points `ε`-dense in a cell, each hiding `X`, hide it from the
//! cell — and at each point all the solids work together (fusion).
//!
//! **Conservative sampling.** From each point the directions are six cube
//! faces of `side²` square pixels. The directions that meet a convex solid
//! from outside it form a convex cone, so a pixel lies wholly in it iff its
//! four corner rays meet the solid; and the entry distance over such a pixel
//! is largest at a corner (a convex body bulges towards an outside viewer,
//! so its front has no interior maximum). A pixel is covered when one
//! eroded solid covers it wholly, at that solid's largest corner entry
//! distance (the nearest such solid). `X` is hidden from `p` when every
//! pixel its box touches is covered nearer than `X` by twice its depth gap.
//! Nothing is assumed between pixel centres: no gap, however thin, is missed.
//!
//! Only solids (inscribed boxes and hulls) fuse; planar occluders still hide
//! one at a time (`region.rs`). Erosion pays `ε` on every side, so thin
//! solids vanish, and two solids that touch open a slot `2ε` wide where
//! they met: through it a sample point sees what the pair hides. On the
//! built-in scenes that leaves fusion nothing to add (0 objects over the
//! city's and the sculpture park's cells at 1 m spacing), so it is off by
//! default; it needs the union eroded, not each solid (ARCHITECTURE.md).

use super::region::{box_distance, ConvexOccluder, DPlane, Margins, Shape};
use super::PvsConfig;
use crate::geom::Aabb;
use crate::spatial::Bvh;
use glam::DVec3;

/// A solid occluder eroded for one cell.
struct Eroded {
    planes: Vec<DPlane>,
    bounds: Aabb,
}

impl Eroded {
    /// The distance along the unit direction `dir` from `p` (outside) at
    /// which the ray enters the solid, or `None` when it misses.
    fn entry(&self, p: DVec3, dir: DVec3) -> Option<f64> {
        let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
        for pl in &self.planes {
            let f = pl.eval(p);
            let g = pl.normal.dot(dir);
            if g.abs() < 1e-300 {
                if f > 0.0 {
                    return None;
                }
                continue;
            }
            let t = -f / g;
            if g < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
            if t0 > t1 {
                return None;
            }
        }
        (t1 > 0.0 && t0 <= t1).then_some(t0)
    }
}

/// The cube face `k`: axis `k / 2`, looking along `+` for even `k`.
fn face_axes(k: usize) -> (usize, f64, usize, usize) {
    let a = k / 2;
    (
        a,
        if k.is_multiple_of(2) { 1.0 } else { -1.0 },
        (a + 1) % 3,
        (a + 2) % 3,
    )
}

/// The range of pixels (inclusive, x then y) of face `k` that the box `b`
/// seen from `p` may touch, or `None` when it lies wholly behind the face.
fn face_rect(p: DVec3, b: &Aabb, k: usize, side: usize) -> Option<[usize; 4]> {
    let (a, s, u, v) = face_axes(k);
    let corners = b.corners().map(|c| c.as_dvec3() - p);
    if corners.iter().all(|c| s * c[a] <= 0.0) {
        return None;
    }
    let last = side - 1;
    if corners.iter().any(|c| s * c[a] <= 1e-9) {
        return Some([0, last, 0, last]);
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for c in &corners {
        let z = s * c[a];
        for (i, w) in [c[u] / z, c[v] / z].into_iter().enumerate() {
            lo[i] = lo[i].min(w);
            hi[i] = hi[i].max(w);
        }
    }
    if lo[0] > 1.0 || lo[1] > 1.0 || hi[0] < -1.0 || hi[1] < -1.0 {
        return None;
    }
    let px = |w: f64| (((w + 1.0) * 0.5 * side as f64).floor().max(0.0) as usize).min(last);
    Some([px(lo[0]), px(hi[0]), px(lo[1]), px(hi[1])])
}

/// The unit direction through corner `(i, j)` of face `k`'s pixel grid.
fn corner_dir(k: usize, i: usize, j: usize, side: usize) -> DVec3 {
    let (a, s, u, v) = face_axes(k);
    let mut d = DVec3::ZERO;
    d[a] = s;
    d[u] = -1.0 + 2.0 * i as f64 / side as f64;
    d[v] = -1.0 + 2.0 * j as f64 / side as f64;
    d.normalize()
}

/// The objects of `candidates` (ids into `boxes`) that the solids of
/// `occluders` within `config.fusion_radius` of `cell` hide together from
/// every point of `cell` (see the module docs).
pub(crate) fn fused_hidden(
    occluders: &[ConvexOccluder],
    occluder_bvh: &Bvh,
    boxes: &[Aabb],
    cell: &Aabb,
    candidates: &[u32],
    config: &PvsConfig,
) -> Vec<u32> {
    let side = config.fusion_side as usize;
    if candidates.is_empty() || config.fusion_spacing <= 0.0 || side == 0 {
        return Vec::new();
    }
    let extent = cell.extent().as_dvec3();
    let spacing = config.fusion_spacing as f64;
    let counts = extent.to_array().map(|e| (e / spacing).ceil().max(1.0) as usize + 1);
    let step = DVec3::new(
        extent.x / (counts[0] - 1) as f64,
        extent.y / (counts[1] - 1) as f64,
        extent.z / (counts[2] - 1) as f64,
    );
    // Every point of the cell lies within half a grid box's diagonal of a sample.
    let eps = 0.5 * step.length();
    let r = config.fusion_radius;
    let reach = Aabb::new(cell.min - r, cell.max + r);
    let mut near = Vec::new();
    occluder_bvh.overlapping(&reach, &mut near);
    let corners = cell.corners();
    let solids: Vec<Eroded> = near
        .iter()
        .filter_map(|&o| {
            let occ = &occluders[o as usize];
            let Shape::Solid(planes) = &occ.shape else { return None };
            if box_distance(&occ.bounds, cell) < config.near_clearance {
                return None;
            }
            if let Some(above) = &occ.above {
                if corners.iter().any(|c| above.eval(c.as_dvec3()) >= 0.0) {
                    return None;
                }
            }
            // Snapping is paid at the occluder's distance, as in `region.rs`.
            let far = cell.union(occ.bounds).extent().as_dvec3().length();
            let erode = eps + config.margin as f64 + 1e-4 * far;
            let planes: Vec<DPlane> = planes
                .iter()
                .map(|p| DPlane {
                    normal: p.normal,
                    d: p.d + erode,
                })
                .collect();
            // Keep it only when it is not eroded away (its box centre inside).
            let c = occ.bounds.center().as_dvec3();
            planes.iter().all(|p| p.eval(c) < 0.0).then_some(Eroded {
                planes,
                bounds: occ.bounds,
            })
        })
        .collect();
    if solids.is_empty() {
        return Vec::new();
    }
    let near_plane = config.near as f64;
    // (id, box grown by its depth gap, the gap)
    let mut alive: Vec<(u32, Aabb, f64)> = candidates
        .iter()
        .map(|&id| {
            let b = boxes[id as usize];
            let gap = Margins::for_pair(cell, &b, config.margin as f64, near_plane).gap;
            let g = gap as f32;
            (id, Aabb::new(b.min - g, b.max + g), gap)
        })
        .filter(|(_, b, _)| box_distance(b, cell) as f64 > 2.0 * eps)
        .collect();
    let n = side * side;
    let mut depth = vec![f64::INFINITY; 6 * n];
    let mut corner_entry = Vec::new();
    let points = sample_points(cell, counts, step);
    for p in points {
        if alive.is_empty() {
            break;
        }
        depth.fill(f64::INFINITY);
        for s in &solids {
            for k in 0..6 {
                let Some([x0, x1, y0, y1]) = face_rect(p, &s.bounds, k, side) else {
                    continue;
                };
                let w = x1 - x0 + 2;
                corner_entry.clear();
                for j in y0..=y1 + 1 {
                    for i in x0..=x1 + 1 {
                        corner_entry.push(s.entry(p, corner_dir(k, i, j, side)));
                    }
                }
                let face = &mut depth[k * n..(k + 1) * n];
                for j in 0..=y1 - y0 {
                    for i in 0..=x1 - x0 {
                        let c = [
                            corner_entry[j * w + i],
                            corner_entry[j * w + i + 1],
                            corner_entry[(j + 1) * w + i],
                            corner_entry[(j + 1) * w + i + 1],
                        ];
                        if let [Some(a), Some(b), Some(c), Some(d)] = c {
                            let far = a.max(b).max(c).max(d);
                            let px = &mut face[(y0 + j) * side + x0 + i];
                            *px = px.min(far);
                        }
                    }
                }
            }
        }
        alive.retain(|(_, b, gap)| {
            let dist = (b.distance_squared(p.as_vec3()) as f64).sqrt();
            if dist <= 2.0 * eps {
                return false;
            }
            (0..6).all(|k| match face_rect(p, b, k, side) {
                None => true,
                Some([x0, x1, y0, y1]) => {
                    let face = &depth[k * n..(k + 1) * n];
                    (y0..=y1).all(|y| {
                        face[y * side + x0..=y * side + x1]
                            .iter()
                            .all(|&d| d + 2.0 * gap < dist)
                    })
                }
            })
        });
    }
    let mut hidden: Vec<u32> = alive.into_iter().map(|a| a.0).collect();
    hidden.sort_unstable();
    hidden
}

/// The sample grid over `cell`, its eight corners first (they differ most,
/// so the candidates thin out fastest).
fn sample_points(cell: &Aabb, counts: [usize; 3], step: DVec3) -> Vec<DVec3> {
    let lo = cell.min.as_dvec3();
    let mut corners = Vec::new();
    let mut rest = Vec::new();
    for z in 0..counts[2] {
        for y in 0..counts[1] {
            for x in 0..counts[0] {
                let p = lo + DVec3::new(x as f64, y as f64, z as f64) * step;
                let edge = [
                    x == 0 || x == counts[0] - 1,
                    y == 0 || y == counts[1] - 1,
                    z == 0 || z == counts[2] - 1,
                ];
                if edge.iter().all(|&e| e) {
                    corners.push(p);
                } else {
                    rest.push(p);
                }
            }
        }
    }
    corners.extend(rest);
    corners
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spatial::BvhConfig;
    use glam::Vec3;

    fn solid_box(object: u32, lo: Vec3, hi: Vec3) -> ConvexOccluder {
        let (mut p, mut t) = (Vec::new(), Vec::new());
        crate::occluders::push_box(&mut p, &mut t, lo, hi);
        let tris: Vec<[Vec3; 3]> = t.iter().map(|t| t.map(|i| p[i as usize])).collect();
        ConvexOccluder::solid(object, &tris, None).unwrap()
    }

    fn config() -> PvsConfig {
        PvsConfig {
            fusion_spacing: 0.5,
            fusion_side: 48,
            fusion_radius: 100.0,
            ..PvsConfig::default()
        }
    }

    /// Two deep walls side by side: a box behind their seam is hidden by the
    /// two together when they touch, not when a slot between them lets a
    /// ray from the cell through.
    #[test]
    fn two_walls_hide_what_neither_hides_alone_but_not_through_a_gap() {
        let cell = Aabb::new(Vec3::new(-1.0, 1.0, 8.0), Vec3::new(1.0, 2.0, 10.0));
        let behind = Aabb::new(Vec3::new(-0.5, 1.0, -6.0), Vec3::new(0.5, 2.0, -5.0));
        let boxes = vec![Aabb::EMPTY, Aabb::EMPTY, behind];
        for (gap, deep, hidden) in [(0.0, 4.0, false), (0.3, 4.0, false), (0.05, 12.0, false)] {
            let h = gap * 0.5;
            let walls = vec![
                solid_box(0, Vec3::new(-20.0, 0.0, -deep), Vec3::new(-h, 10.0, 0.0)),
                solid_box(1, Vec3::new(h, 0.0, -deep), Vec3::new(20.0, 10.0, 0.0)),
            ];
            let bvh = Bvh::build(
                &walls.iter().map(|w| w.bounds).collect::<Vec<_>>(),
                &BvhConfig::default(),
            );
            let zero = Margins { lateral: 0.0, gap: 0.0 };
            // Neither wall alone hides it from the whole cell.
            assert!(walls.iter().all(|w| !w.hides(&cell, &behind, zero)));
            let got = fused_hidden(&walls, &bvh, &boxes, &cell, &[2], &config());
            assert_eq!(got == [2], hidden, "slot {gap} m, walls {deep} m deep");
        }
    }

    /// Against brute force: whenever fusion hides a box, no sampled segment
    /// from the cell to it misses every original solid.
    #[test]
    fn fused_means_every_sampled_segment_meets_a_solid() {
        let mut seed = 0x2545_F491_4F6C_DD1Du64;
        let mut rnd = move || crate::pvs::test_rng(&mut seed) as f32;
        let mut found = 0;
        for case in 0..40 {
            let walls: Vec<ConvexOccluder> = (0..6)
                .map(|i| {
                    let c = Vec3::new(rnd() * 16.0 - 8.0, rnd() * 4.0, rnd() * 4.0 - 2.0);
                    let h = Vec3::new(rnd() * 3.0 + 0.8, rnd() * 3.0 + 1.0, rnd() * 2.0 + 0.8);
                    solid_box(i, c - h, c + h)
                })
                .collect();
            let bvh = Bvh::build(
                &walls.iter().map(|w| w.bounds).collect::<Vec<_>>(),
                &BvhConfig::default(),
            );
            let cell = Aabb::new(Vec3::new(-1.0, 1.0, 9.0), Vec3::new(1.0, 2.0, 11.0));
            let boxes: Vec<Aabb> = (0..30)
                .map(|_| {
                    let c = Vec3::new(rnd() * 20.0 - 10.0, rnd() * 3.0, -6.0 - rnd() * 6.0);
                    Aabb::new(c - 0.4, c + 0.4)
                })
                .collect();
            let ids: Vec<u32> = (0..30).collect();
            let got = fused_hidden(&walls, &bvh, &boxes, &cell, &ids, &config());
            for &id in &got {
                found += 1;
                let x = boxes[id as usize];
                for _ in 0..3000 {
                    let a = (cell.min + (cell.max - cell.min) * Vec3::new(rnd(), rnd(), rnd())).as_dvec3();
                    let b = (x.min + (x.max - x.min) * Vec3::new(rnd(), rnd(), rnd())).as_dvec3();
                    assert!(
                        walls.iter().any(|w| w.crossed_by(a, b, 0.0)),
                        "case {case}: object {id} seen between the walls"
                    );
                }
            }
        }
        assert!(
            found > 20,
            "fusion hid only {found} boxes: the check would prove nothing"
        );
    }
}
