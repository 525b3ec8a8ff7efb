//! Occluder fusion by point sampling (after Wonka, Wimmer & Schmalstieg 2000,
//! "Visibility preprocessing with occluder fusion for urban walkthroughs"),
//! for what no single occluder hides from a whole cell.
//!
//! **Shrink, then sample.** Erode the solid space (`solid.rs`: the union of
//! the solids, eroded as one) by `ε`. If every ray from a point `p` to every
//! point of an occludee `X` meets the eroded space, then from any viewpoint
//! `v` within `ε` of `p` every ray to `X` meets the original: the ray
//! `p → x` meets the eroded space at `q`, and `v → x` passes within
//! `(1 − s)·|v − p| ≤ ε` of `q` at the same fraction `s` of its length,
//! inside the solid `q` is `ε` deep in. So sample points `ε`-dense in a
//! cell, each hiding `X`, hide it from the cell, and at each point all the
//! solids work together (fusion). A segment into the solid space crosses a
//! drawn triangle first (its contract) when the viewpoint lies outside it,
//! by at least the near clearance so no near plane clips that triangle:
//! fusion's answers hold for such viewpoints.
//!
//! **Conservative sampling.** From each point the directions are six cube
//! faces of `side²` square pixels. A pixel counts as covered up to the
//! distance `t` at which its centre ray meets the space eroded by `ε + δ`
//! ([`PIXEL_SLACK`]) when `t·θ ≤ δ`, `θ` the widest angle between the
//! centre ray and the pixel's (at a corner: the directions within an angle
//! of the centre form a convex cone); every ray of the pixel then meets the
//! space eroded by `ε` by `t`. A pixel whose centre ray meets it farther is
//! split in four, up to [`MAX_SPLITS`] times. `X` is hidden from `p` when
//! every pixel its box touches is covered nearer than `X` by twice its
//! depth gap. Nothing is assumed between sampled rays: no gap, however
//! thin, is missed.
//!
//! Erosion pays `ε + δ` on every side, so walls thinner than twice that
//! vanish: fusion needs thick solid space (city blocks, the rock between a
//! game level's rooms), not thin walls.

use super::margins::{box_distance, Margins};
use super::solid::{CellOpenings, Eroded};
use super::PvsConfig;
use crate::geom::Aabb;
use glam::DVec3;

/// How much more than `ε` the space is eroded for the pixels' sake (metres):
/// a ray within angle `θ` of a pixel's centre ray stays within `t·θ ≤ δ` of
/// it up to `t = δ / θ`, so a centre ray that meets the space eroded by
/// `ε + δ` that near shows every ray of the pixel meeting the space eroded
/// by `ε`.
pub(crate) const PIXEL_SLACK: f64 = 0.1;

/// Pixels are split in four up to this many times when their centre ray
/// meets the space too far away for the slack to cover the whole pixel.
const MAX_SPLITS: u32 = 3;

/// How far the space is eroded for fusion with `config`: `ε` (half the
/// diagonal of the sample grid's box), the pixel slack, the absolute margin
/// and the snap at the farthest distance fusion looks.
pub(crate) fn erosion(config: &PvsConfig) -> f64 {
    let eps = 0.5 * 3f64.sqrt() * config.fusion_spacing as f64;
    let far = config.fusion_radius as f64 + 2.0 * config.cell_size as f64;
    eps + PIXEL_SLACK + config.margin as f64 + 1e-4 * far
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
/// seen from `p` may touch, or `None` when it touches none. A direction
/// `d` lies in the face when `s·d[a] ≥ |d[u]|, |d[v]|`, so only the box's
/// points at depth `s·(x − p)[a]` at least their Chebyshev distance `m`
/// from the axis matter: the box is clipped to depths from `m` before its
/// corners are projected (`u / z` is monotone in `u` and in `z`).
fn face_rect(p: DVec3, b: &Aabb, k: usize, side: usize) -> Option<[usize; 4]> {
    let (a, s, u, v) = face_axes(k);
    let (lo, hi) = (b.min.as_dvec3() - p, b.max.as_dvec3() - p);
    let (z0, z1) = if s > 0.0 { (lo[a], hi[a]) } else { (-hi[a], -lo[a]) };
    let off = |w: usize| (lo[w].max(0.0) + (-hi[w]).max(0.0)).max(0.0);
    let m = off(u).max(off(v));
    if z1 <= 0.0 || z1 < m {
        return None;
    }
    let last = side - 1;
    let z_lo = z0.max(m);
    if z_lo <= 1e-9 {
        return Some([0, last, 0, last]);
    }
    let range = |w: usize| {
        let q = [lo[w] / z_lo, lo[w] / z1, hi[w] / z_lo, hi[w] / z1];
        (
            q.iter().copied().fold(f64::INFINITY, f64::min),
            q.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        )
    };
    let (ul, uh) = range(u);
    let (vl, vh) = range(v);
    if ul > 1.0 || vl > 1.0 || uh < -1.0 || vh < -1.0 {
        return None;
    }
    let px = |w: f64| (((w + 1.0) * 0.5 * side as f64).floor().max(0.0) as usize).min(last);
    Some([px(ul), px(uh), px(vl), px(vh)])
}

/// The unit direction through the point `(x, y)` of face `k` (face
/// coordinates in `[-1, 1]`).
fn face_dir(k: usize, x: f64, y: f64) -> DVec3 {
    let (a, s, u, v) = face_axes(k);
    let mut d = DVec3::ZERO;
    d[a] = s;
    d[u] = x;
    d[v] = y;
    d.normalize()
}

/// From one sample point: how near every ray of a pixel is sure to have
/// met the eroded-by-`ε` space, pixel by pixel, computed on demand.
struct PointView<'a> {
    space: &'a Eroded,
    openings: CellOpenings,
    p: DVec3,
    side: usize,
    /// Per pixel of the six faces: (distance, the limit it was computed for).
    cache: Vec<(f64, f64)>,
}

impl PointView<'_> {
    /// A distance within which every ray of pixel `(i, j)` of face `k` meets
    /// the space, if one below `limit` was found; else infinity.
    fn pixel(&mut self, k: usize, i: usize, j: usize, limit: f64) -> f64 {
        let slot = (k * self.side + j) * self.side + i;
        let (got, for_limit) = self.cache[slot];
        if got < f64::INFINITY || for_limit >= limit {
            return got;
        }
        let w = 2.0 / self.side as f64;
        let (x0, y0) = (-1.0 + i as f64 * w, -1.0 + j as f64 * w);
        let d = self.cone(k, [x0, x0 + w, y0, y0 + w], 0, limit);
        self.cache[slot] = (d, limit);
        d
    }

    /// The same for the cone of face `k` over `[x0, x1] × [y0, y1]`.
    fn cone(&self, k: usize, r: [f64; 4], splits: u32, limit: f64) -> f64 {
        let (xm, ym) = (0.5 * (r[0] + r[1]), 0.5 * (r[2] + r[3]));
        let centre = face_dir(k, xm, ym);
        // The widest angle to the centre is at a corner (module docs).
        let cos = [(r[0], r[2]), (r[1], r[2]), (r[0], r[3]), (r[1], r[3])]
            .iter()
            .map(|&(x, y)| face_dir(k, x, y).dot(centre))
            .fold(1.0f64, f64::min);
        let theta = cos.clamp(-1.0, 1.0).acos().max(1e-12);
        // Rounding in the ray's points is far below this shave.
        let reach = (PIXEL_SLACK - 1e-6) / theta;
        let Some(t) = self.space.first_hit(self.p, centre, limit, &self.openings) else {
            return f64::INFINITY;
        };
        if t <= reach {
            return t;
        }
        if splits == MAX_SPLITS {
            return f64::INFINITY;
        }
        let mut worst = 0.0f64;
        for (x0, x1) in [(r[0], xm), (xm, r[1])] {
            for (y0, y1) in [(r[2], ym), (ym, r[3])] {
                worst = worst.max(self.cone(k, [x0, x1, y0, y1], splits + 1, limit));
                if worst == f64::INFINITY {
                    return worst;
                }
            }
        }
        worst
    }

    /// Does every ray from the point to `b` meet the space nearer than
    /// `limit` (a lower bound of the distance to `b` along any ray)?
    fn hides(&mut self, b: &Aabb, limit: f64) -> bool {
        (0..6).all(|k| match face_rect(self.p, b, k, self.side) {
            None => true,
            Some([x0, x1, y0, y1]) => (y0..=y1).all(|j| (x0..=x1).all(|i| self.pixel(k, i, j, limit) < limit)),
        })
    }
}

/// The objects of `candidates` (ids into `boxes`) that the solid space,
/// eroded by [`erosion`] (`space`), hides from every point of `cell` (see
/// the module docs), for viewpoints outside the solid space by at least
/// the near clearance.
pub(crate) fn fused_hidden(
    space: &Eroded,
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
    // Every point of the cell lies within half a grid box's diagonal of a
    // sample, at most `erosion`'s ε.
    let eps = 0.5 * step.length();
    let near_plane = config.near as f64;
    let r = config.fusion_radius;
    let reach = Aabb::new(cell.min - r, cell.max + r);
    // (id, box grown by its depth gap, the gap)
    let mut alive: Vec<(u32, Aabb, f64)> = candidates
        .iter()
        .map(|&id| {
            let b = boxes[id as usize];
            let gap = Margins::for_pair(cell, &b, config.margin as f64, near_plane).gap;
            let g = gap as f32;
            (id, Aabb::new(b.min - g, b.max + g), gap)
        })
        .filter(|(_, b, _)| box_distance(b, cell) as f64 > 2.0 * eps && b.intersects(&reach))
        .collect();
    let mut view = PointView {
        space,
        openings: space.cell_openings(cell),
        p: DVec3::ZERO,
        side,
        cache: vec![(f64::INFINITY, f64::NEG_INFINITY); 6 * side * side],
    };
    for p in sample_points(cell, counts, step) {
        if alive.is_empty() {
            break;
        }
        view.p = p;
        view.cache.fill((f64::INFINITY, f64::NEG_INFINITY));
        alive.retain(|(_, b, gap)| {
            let dist = (b.distance_squared(p.as_vec3()) as f64).sqrt();
            dist > 2.0 * eps && view.hides(b, dist - 2.0 * gap)
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
    use crate::pvs::bake::{line_in_box, segment_meets_box};
    use crate::pvs::solid::SolidSpace;
    use glam::Vec3;

    fn config() -> PvsConfig {
        PvsConfig {
            fusion_spacing: 0.5,
            fusion_side: 32,
            fusion_radius: 100.0,
            ..PvsConfig::default()
        }
    }

    /// Solid space of 0.2 m voxels over `bounds` holding the boxes `solids`
    /// (all on the 0.2 m lattice, compared in lattice steps so rounding in
    /// the voxels' corners opens no seam).
    fn space_of(bounds: Aabb, solids: &[Aabb]) -> SolidSpace {
        let q = |v: Vec3| (v * 5.0).round();
        SolidSpace::from_fn(&bounds, 0.2, |v| {
            solids
                .iter()
                .any(|s| q(s.min).cmple(q(v.min)).all() && q(v.max).cmple(q(s.max)).all())
        })
        .unwrap()
    }

    /// Two deep walls side by side on solid ground: a box behind their seam
    /// is hidden by the two together when they touch (the union is eroded,
    /// not each wall), not when a slot between them lets a ray from the cell
    /// through.
    #[test]
    fn two_walls_hide_what_neither_hides_alone_but_not_through_a_gap() {
        let cell = Aabb::new(Vec3::new(-1.0, 1.0, 8.0), Vec3::new(1.0, 2.0, 10.0));
        let behind = Aabb::new(Vec3::new(-0.5, 1.0, -6.0), Vec3::new(0.5, 2.0, -5.0));
        let boxes = vec![behind];
        let bounds = Aabb::new(Vec3::new(-22.0, -1.0, -14.0), Vec3::new(22.0, 12.0, 12.0));
        for (gap, hidden) in [(0.0, true), (0.2, false), (0.6, false)] {
            let h = gap * 0.5;
            let walls = [
                Aabb::new(Vec3::new(-20.0, -1.0, -4.0), Vec3::new(-h, 10.0, 0.0)),
                Aabb::new(Vec3::new(h, -1.0, -4.0), Vec3::new(20.0, 10.0, 0.0)),
                Aabb::new(Vec3::new(-22.0, -1.0, -14.0), Vec3::new(22.0, 0.0, 12.0)),
            ];
            let space = space_of(bounds, &walls).eroded(erosion(&config()));
            let got = fused_hidden(&space, &boxes, &cell, &[0], &config());
            assert_eq!(got == [0], hidden, "slot {gap} m");
        }
    }

    /// A wall that hides a box behind it hides nothing through an opening
    /// declared in it (a face the renderer does not draw), while the rest of
    /// the wall still hides what no segment through the opening reaches.
    #[test]
    fn an_opening_lets_segments_through() {
        let cell = Aabb::new(Vec3::new(-1.0, 1.0, 8.0), Vec3::new(1.0, 2.0, 10.0));
        let behind = Aabb::new(Vec3::new(-0.5, 1.0, -6.0), Vec3::new(0.5, 2.0, -5.0));
        let aside = Aabb::new(Vec3::new(-14.5, 1.0, -6.0), Vec3::new(-13.5, 2.0, -5.0));
        let bounds = Aabb::new(Vec3::new(-22.0, -1.0, -14.0), Vec3::new(22.0, 12.0, 12.0));
        let wall = [
            Aabb::new(Vec3::new(-20.0, -1.0, -4.0), Vec3::new(20.0, 10.0, 0.0)),
            Aabb::new(Vec3::new(-22.0, -1.0, -14.0), Vec3::new(22.0, 0.0, 12.0)),
        ];
        let mut space = space_of(bounds, &wall);
        let e = space.eroded(erosion(&config()));
        assert_eq!(fused_hidden(&e, &[behind, aside], &cell, &[0, 1], &config()), [0, 1]);
        // An undrawn patch of the wall's front, straight ahead of the cell.
        space.add_opening(Aabb::new(Vec3::new(-1.0, 1.0, 0.0), Vec3::new(1.0, 2.0, 0.0)));
        let e = space.eroded(erosion(&config()));
        assert_eq!(fused_hidden(&e, &[behind, aside], &cell, &[0, 1], &config()), [1]);
    }

    /// Random scenes against brute force: six walls on the 0.2 m lattice (so
    /// the voxels are exactly the walls), `openings` cut in them, thirty
    /// boxes behind. For every box fusion hides from the cell, `tries`
    /// segments from viewpoints clear of the walls to points of the box
    /// must be `blocked`. Returns how many boxes fusion hid.
    fn check_random_walls(
        seed: u64,
        tries: usize,
        openings: impl Fn(&[Aabb], &mut dyn FnMut() -> f32) -> Vec<Aabb>,
        blocked: impl Fn(DVec3, DVec3, &[Aabb], &[Aabb]) -> bool,
    ) -> usize {
        let mut rng = hom_testkit::Rng::new(seed);
        let mut rnd = move || rng.unit_f64() as f32;
        let mut found = 0;
        let bounds = Aabb::new(Vec3::new(-16.0, -4.0, -16.0), Vec3::new(16.0, 10.0, 16.0));
        let snap = |v: Vec3| (v * 5.0).round() / 5.0;
        for case in 0..12 {
            let walls: Vec<Aabb> = (0..6)
                .map(|_| {
                    let c = Vec3::new(rnd() * 16.0 - 8.0, rnd() * 4.0, rnd() * 4.0 - 2.0);
                    let h = Vec3::new(rnd() * 3.0 + 0.8, rnd() * 3.0 + 1.0, rnd() * 2.0 + 0.8);
                    Aabb::new(snap(c - h), snap(c + h))
                })
                .collect();
            let openings = openings(&walls, &mut rnd);
            let mut space = space_of(bounds, &walls);
            for o in &openings {
                space.add_opening(*o);
            }
            let eroded = space.eroded(erosion(&config()));
            let cell = Aabb::new(Vec3::new(-1.0, 1.0, 9.0), Vec3::new(1.0, 2.0, 11.0));
            let boxes: Vec<Aabb> = (0..30)
                .map(|_| {
                    let c = Vec3::new(rnd() * 20.0 - 10.0, rnd() * 3.0, -6.0 - rnd() * 6.0);
                    Aabb::new(c - 0.4, c + 0.4)
                })
                .collect();
            let ids: Vec<u32> = (0..30).collect();
            for &id in &fused_hidden(&eroded, &boxes, &cell, &ids, &config()) {
                found += 1;
                let x = boxes[id as usize];
                let mut tried = 0;
                while tried < tries {
                    let a = (cell.min + (cell.max - cell.min) * Vec3::new(rnd(), rnd(), rnd())).as_dvec3();
                    let clear = config().near_clearance;
                    if walls.iter().any(|w| w.distance_squared(a.as_vec3()) < clear * clear) {
                        continue;
                    }
                    tried += 1;
                    let b = (x.min + (x.max - x.min) * Vec3::new(rnd(), rnd(), rnd())).as_dvec3();
                    assert!(blocked(a, b, &walls, &openings), "case {case}: object {id} seen");
                }
            }
        }
        found
    }

    /// Whenever fusion hides a box, no sampled segment from a viewpoint of
    /// the cell outside the solids to the box misses every solid.
    #[test]
    fn fused_means_every_sampled_segment_meets_a_solid() {
        let found = check_random_walls(
            0x2545_F491_4F6C_DD1D,
            3000,
            |_, _| Vec::new(),
            |a, b, walls, _| walls.iter().any(|w| segment_meets_box(a, b, w)),
        );
        assert!(
            found > 20,
            "fusion hid only {found} boxes: the check would prove nothing"
        );
    }

    /// With openings: the walls' surfaces are drawn except inside the
    /// opening boxes (tunnels through the walls), and whenever fusion hides a
    /// box, every sampled segment from the cell to it crosses a drawn
    /// surface: its entry into or exit from a wall, outside every opening.
    #[test]
    fn fused_through_openings_means_every_sampled_segment_crosses_a_drawn_surface() {
        let tunnels = |walls: &[Aabb], rnd: &mut dyn FnMut() -> f32| {
            walls
                .iter()
                .map(|w| {
                    let (x, y) = (
                        w.min.x + (w.max.x - w.min.x) * rnd(),
                        w.min.y + (w.max.y - w.min.y) * rnd(),
                    );
                    let (hx, hy) = (rnd() * 2.0 + 0.5, rnd() * 2.0 + 0.5);
                    Aabb::new(
                        Vec3::new(x - hx, y - hy, w.min.z - 0.01),
                        Vec3::new(x + hx, y + hy, w.max.z + 0.01),
                    )
                })
                .collect()
        };
        let drawn = |a: DVec3, b: DVec3, walls: &[Aabb], openings: &[Aabb]| {
            walls.iter().any(|w| {
                let Some((t0, t1)) = line_in_box(a, b, w, (f64::NEG_INFINITY, f64::INFINITY)) else {
                    return false;
                };
                [t0, t1].into_iter().filter(|t| *t > 0.0 && *t < 1.0).any(|t| {
                    let p = (a + (b - a) * t).as_vec3();
                    !openings.iter().any(|o| o.contains_point(p))
                })
            })
        };
        let found = check_random_walls(0x0DDB_1A5E_5BAD_5EED, 2000, tunnels, drawn);
        assert!(
            found > 10,
            "fusion hid only {found} boxes: the check would prove nothing"
        );
    }
}
