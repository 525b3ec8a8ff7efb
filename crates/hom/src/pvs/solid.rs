//! Solid space as voxels, for occluder fusion (`fusion.rs`): the union of
//! a scene's solids, eroded as one (Wonka, Wimmer & Schmalstieg 2000 erode
//! the union; eroding each solid alone opens a slot wherever two touch).
//! A voxel is solid when one solid holds it whole: pieces that tile a
//! volume along seams off the voxel grid leave the seams open.
//!
//! **The contract a [`SolidSpace`] states.** Every segment from a viewpoint
//! outside it to a point inside it crosses an opaque triangle of the scene
//! (drawn on both sides) before it gets there, or passes through one of its
//! *openings* (boxes) first. The inscribed solids of closed meshes keep it
//! with no openings (a segment into one first crosses the mesh's surface),
//! and with their floor caps as openings where the mesh is open below.
//!
//! An opening `H` is paid per cell `C`: a segment from `v ∈ C` through
//! `a ∈ H` to `q` has `q = v + t·(a − v)` with `t ≥ 1`, so the solid points
//! such a segment reaches lie in `R(C, H) = {v + t·(a − v) : v ∈ C, a ∈ H,
//! t ≥ 1}`, and fusion for `C` leaves out every eroded voxel whose erosion
//! neighbourhood meets it ([`Eroded::first_hit`]). For boxes `C`, `H` and a
//! box `Q`, whether `Q` meets `R(C, H)` is exact: per axis the points at
//! parameter `t` form the interval `(1 − t)·C + t·H`, and the axes' sets of
//! `t` must share one.
//!
//! A voxel is solid only when its whole closed box is; erosion by `e` keeps
//! the voxels whose Chebyshev neighbourhood of `⌈e / h⌉` voxels is solid,
//! so a ball of radius `e` around any point of a kept voxel lies in the
//! solid.

use super::region::DPlane;
use super::PvsError;
use crate::geom::Aabb;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// The most voxels a [`SolidSpace`] holds (one byte each).
pub const MAX_VOXELS: usize = 1 << 28;

/// Solid space on a grid of cubic voxels (see the module docs for what
/// "solid" promises).
#[derive(Clone, Debug)]
pub struct SolidSpace {
    origin: DVec3,
    voxel: f64,
    dims: [usize; 3],
    /// 1 where solid, x fastest, then y, then z.
    solid: Vec<u8>,
    /// Boxes through which a segment may enter the solid space unstopped.
    openings: Vec<Aabb>,
}

impl SolidSpace {
    /// An empty grid of voxels of edge `voxel` (metres) covering `bounds`.
    pub fn new(bounds: &Aabb, voxel: f32) -> Result<SolidSpace, PvsError> {
        if !(voxel.is_finite() && voxel > 0.0) {
            return Err(PvsError::BadConfig(
                "the voxel edge must be a positive number of metres",
            ));
        }
        if bounds.is_empty() || !bounds.min.is_finite() || !bounds.max.is_finite() {
            return Err(PvsError::BadConfig("solid space needs finite, non-empty bounds"));
        }
        let v = voxel as f64;
        let origin = bounds.min.as_dvec3();
        let span = bounds.max.as_dvec3() - origin;
        let dims = span.to_array().map(|s| ((s / v).ceil() as usize).max(1));
        let count = dims.iter().try_fold(1usize, |acc, &d| acc.checked_mul(d));
        if count.is_none_or(|c| c > MAX_VOXELS) {
            return Err(PvsError::BadConfig(
                "solid space would need more than 2^28 voxels: use larger voxels",
            ));
        }
        Ok(SolidSpace {
            origin,
            voxel: v,
            dims,
            solid: vec![0; count.unwrap_or(0)],
            openings: Vec::new(),
        })
    }

    /// A grid over `bounds` whose voxels are solid where `inside(voxel box)`
    /// says the whole box is (called in parallel).
    pub fn from_fn(bounds: &Aabb, voxel: f32, inside: impl Fn(&Aabb) -> bool + Sync) -> Result<SolidSpace, PvsError> {
        let mut s = SolidSpace::new(bounds, voxel)?;
        let [nx, ny, _] = s.dims;
        let this = &s;
        let cells: Vec<u8> = (0..s.solid.len())
            .into_par_iter()
            .map(|i| inside(&this.voxel_box([i % nx, (i / nx) % ny, i / (nx * ny)])) as u8)
            .collect();
        s.solid = cells;
        Ok(s)
    }

    /// Voxels along x, y and z.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// The voxel edge, metres.
    pub fn voxel_size(&self) -> f32 {
        self.voxel as f32
    }

    /// The box of voxel `v`.
    pub fn voxel_box(&self, v: [usize; 3]) -> Aabb {
        let lo = self.origin + DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64) * self.voxel;
        Aabb::new(lo.as_vec3(), (lo + DVec3::splat(self.voxel)).as_vec3())
    }

    /// The voxel holding `p`, if the grid does.
    pub fn voxel_of(&self, p: Vec3) -> Option<[usize; 3]> {
        let q = (p.as_dvec3() - self.origin) / self.voxel;
        let v = q.to_array();
        (0..3)
            .all(|k| v[k] >= 0.0 && v[k] < self.dims[k] as f64)
            .then(|| v.map(|c| c as usize))
    }

    fn index(&self, v: [usize; 3]) -> usize {
        v[0] + self.dims[0] * (v[1] + self.dims[1] * v[2])
    }

    /// Is voxel `v` solid?
    pub fn is_solid(&self, v: [usize; 3]) -> bool {
        self.solid[self.index(v)] != 0
    }

    /// Marks voxel `v` solid or not.
    pub fn set(&mut self, v: [usize; 3], solid: bool) {
        let i = self.index(v);
        self.solid[i] = solid as u8;
    }

    /// Declares an opening: a box through which a segment may enter the
    /// solid space without crossing a drawn triangle (see the module docs).
    pub fn add_opening(&mut self, bounds: Aabb) {
        self.openings.push(bounds);
    }

    /// The openings declared.
    pub fn openings(&self) -> &[Aabb] {
        &self.openings
    }

    /// How many voxels are solid.
    pub fn solid_count(&self) -> usize {
        self.solid.par_iter().filter(|&&s| s != 0).count()
    }

    /// Marks solid every voxel whose whole box lies inside the convex solid
    /// bounded by `planes` (outward normals, inside where `eval ≤ 0`).
    pub(crate) fn add_convex(&mut self, planes: &[DPlane], bounds: &Aabb) {
        let lo = self.voxel_of_clamped(bounds.min);
        let hi = self.voxel_of_clamped(bounds.max);
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                for x in lo[0]..=hi[0] {
                    let b = self.voxel_box([x, y, z]);
                    let inside = b
                        .corners()
                        .iter()
                        .all(|c| planes.iter().all(|p| p.eval(c.as_dvec3()) <= 0.0));
                    if inside {
                        self.set([x, y, z], true);
                    }
                }
            }
        }
    }

    fn voxel_of_clamped(&self, p: Vec3) -> [usize; 3] {
        let q = ((p.as_dvec3() - self.origin) / self.voxel).to_array();
        [0, 1, 2].map(|k| (q[k].max(0.0) as usize).min(self.dims[k] - 1))
    }

    /// The space eroded by `e` metres, ready for ray casts.
    pub(crate) fn eroded(&self, e: f64) -> Eroded {
        let k = (e / self.voxel).ceil().max(0.0) as usize;
        let mut cells = self.solid.clone();
        for axis in 0..3 {
            erode_axis(&mut cells, self.dims, axis, k);
        }
        Eroded {
            origin: self.origin,
            voxel: self.voxel,
            dims: self.dims,
            clear: chessboard_distance(&cells, self.dims),
            reach: k as f64 * self.voxel,
            openings: self.openings.clone(),
        }
    }
}

/// One axis of a box erosion: a voxel stays solid when the `k` voxels on
/// each side of it along `axis` are (outside the grid counts as open).
fn erode_axis(cells: &mut [u8], dims: [usize; 3], axis: usize, k: usize) {
    if k == 0 {
        return;
    }
    let stride = [1, dims[0], dims[0] * dims[1]][axis];
    let n = dims[axis];
    let lines: Vec<usize> = (0..cells.len()).filter(|&i| (i / stride).is_multiple_of(n)).collect();
    let mut line = vec![0u8; n];
    let mut run = vec![0usize; n];
    for start in lines {
        for (j, c) in line.iter_mut().enumerate() {
            *c = cells[start + j * stride];
        }
        // run[j]: solid voxels ending at j (inclusive).
        let mut r = 0;
        for j in 0..n {
            r = if line[j] != 0 { r + 1 } else { 0 };
            run[j] = r;
        }
        for j in 0..n {
            let keep = j >= k && j + k < n && run[j + k] > 2 * k;
            cells[start + j * stride] = keep as u8;
        }
    }
}

/// Per voxel, the Chebyshev distance in voxels to the nearest solid one
/// (0 on solid voxels), capped at 255: two chamfer passes over the 26
/// neighbours, exact for this metric.
fn chessboard_distance(cells: &[u8], dims: [usize; 3]) -> Vec<u8> {
    let [nx, ny, nz] = dims;
    let mut d: Vec<u8> = cells.iter().map(|&c| if c != 0 { 0 } else { 255 }).collect();
    let idx = |x: usize, y: usize, z: usize| x + nx * (y + ny * z);
    for forward in [true, false] {
        let order: Box<dyn Iterator<Item = usize>> = if forward {
            Box::new(0..nx * ny * nz)
        } else {
            Box::new((0..nx * ny * nz).rev())
        };
        for i in order {
            if d[i] == 0 {
                continue;
            }
            let (x, y, z) = (i % nx, (i / nx) % ny, i / (nx * ny));
            let mut best = d[i];
            // The 13 neighbours visited before this voxel in this pass.
            for dz in -1i64..=1 {
                for dy in -1i64..=1 {
                    for dx in -1i64..=1 {
                        let before = (dz, dy, dx) < (0, 0, 0);
                        if before != forward || (dx, dy, dz) == (0, 0, 0) {
                            continue;
                        }
                        let (qx, qy, qz) = (x as i64 + dx, y as i64 + dy, z as i64 + dz);
                        if qx < 0 || qy < 0 || qz < 0 || qx >= nx as i64 || qy >= ny as i64 || qz >= nz as i64 {
                            continue;
                        }
                        let n = d[idx(qx as usize, qy as usize, qz as usize)];
                        best = best.min(n.saturating_add(1));
                    }
                }
            }
            d[i] = best;
        }
    }
    d
}

/// A [`SolidSpace`] eroded, with each voxel's distance to the nearest
/// eroded-solid voxel, so rays skip open space.
pub(crate) struct Eroded {
    origin: DVec3,
    voxel: f64,
    dims: [usize; 3],
    /// Chebyshev distance (voxels) to the nearest solid voxel; 0 on one.
    clear: Vec<u8>,
    /// How far (metres, per axis) a kept voxel's erosion neighbourhood reaches.
    reach: f64,
    openings: Vec<Aabb>,
}

/// What one cell's viewpoints may see through the openings: per opening
/// that matters, the opening and a box around `R(C, H)`.
pub(crate) struct CellOpenings {
    cell: Aabb,
    regions: Vec<(Aabb, Aabb)>,
}

/// Does the box `q` meet `R(c, h)` (module docs)?
fn meets_region(c: &Aabb, h: &Aabb, q: &Aabb) -> bool {
    let (mut lo, mut hi) = (1.0f64, f64::INFINITY);
    for k in 0..3 {
        let (c0, c1) = (c.min[k] as f64, c.max[k] as f64);
        let (h0, h1) = (h.min[k] as f64, h.max[k] as f64);
        let (q0, q1) = (q.min[k] as f64, q.max[k] as f64);
        // (1 − t)·c1 + t·h0 ≤ q1  and  (1 − t)·c0 + t·h1 ≥ q0, as a·t ≤ b.
        for (a, b) in [(h0 - c1, q1 - c1), (c0 - h1, c0 - q0)] {
            if a > 0.0 {
                hi = hi.min(b / a);
            } else if a < 0.0 {
                lo = lo.max(b / a);
            } else if b < 0.0 {
                return false;
            }
        }
    }
    lo <= hi
}

impl Eroded {
    /// The openings that matter for viewpoints in `cell`, with boxes
    /// around their regions (clipped to the grid).
    pub(crate) fn cell_openings(&self, cell: &Aabb) -> CellOpenings {
        let grid_lo = self.origin.as_vec3();
        let grid_hi = (self.origin
            + DVec3::new(self.dims[0] as f64, self.dims[1] as f64, self.dims[2] as f64) * self.voxel)
            .as_vec3();
        let regions = self
            .openings
            .iter()
            .filter_map(|h| {
                let mut lo = grid_lo;
                let mut hi = grid_hi;
                for k in 0..3 {
                    // At t = 1 the region is H; it runs on to infinity along
                    // k where H reaches past C.
                    if h.min[k] >= cell.max[k] {
                        lo[k] = lo[k].max(h.min[k]);
                    }
                    if h.max[k] <= cell.min[k] {
                        hi[k] = hi[k].min(h.max[k]);
                    }
                }
                // A grown voxel's centre lies within this of the region.
                let r = (self.reach + self.voxel) as f32;
                lo.cmple(hi).all().then(|| (*h, Aabb::new(lo - r, hi + r)))
            })
            .collect();
        CellOpenings { cell: *cell, regions }
    }

    /// May the solid voxel `v` be used for viewpoints in the cell: does no
    /// segment from the cell through an opening reach its erosion
    /// neighbourhood?
    fn usable(&self, v: [usize; 3], openings: &CellOpenings) -> bool {
        if openings.regions.is_empty() {
            return true;
        }
        let lo = self.origin + DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64) * self.voxel - self.reach;
        let hi = lo + self.voxel + 2.0 * self.reach;
        let q = Aabb::new(lo.as_vec3(), hi.as_vec3());
        let c = q.center();
        openings
            .regions
            .iter()
            .all(|(h, bound)| !bound.contains_point(c) || !meets_region(&openings.cell, h, &q))
    }

    /// Is the point `q` in a solid voxel of the eroded space?
    #[cfg(test)]
    pub(crate) fn contains(&self, q: DVec3) -> bool {
        self.clear_at(q) == Some(0)
    }

    fn clear_at(&self, q: DVec3) -> Option<u8> {
        let v = ((q - self.origin) / self.voxel).to_array();
        if (0..3).any(|k| !(v[k] >= 0.0 && v[k] < self.dims[k] as f64)) {
            return None;
        }
        let [x, y, z] = v.map(|c| c as usize);
        Some(self.clear[x + self.dims[0] * (y + self.dims[1] * z)])
    }

    /// The first parameter `t ≤ t_max` found along the ray `p + t·dir`
    /// (unit `dir`) at which the point lies in a solid voxel usable for the
    /// cell whose `openings` these are, or `None`. Sound, not exhaustive: a
    /// returned `t` is always such a point (it is tested, not derived), and
    /// a ray that grazes a voxel's corner may be stepped past it.
    pub(crate) fn first_hit(&self, p: DVec3, dir: DVec3, t_max: f64, openings: &CellOpenings) -> Option<f64> {
        // Clip the ray to the grid.
        let lo = self.origin;
        let hi = self.origin + DVec3::new(self.dims[0] as f64, self.dims[1] as f64, self.dims[2] as f64) * self.voxel;
        let (mut t0, mut t1) = (0.0f64, t_max);
        for k in 0..3 {
            if dir[k].abs() < 1e-300 {
                if p[k] < lo[k] || p[k] >= hi[k] {
                    return None;
                }
                continue;
            }
            let (a, b) = ((lo[k] - p[k]) / dir[k], (hi[k] - p[k]) / dir[k]);
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
        if t0 > t1 {
            return None;
        }
        let nudge = 1e-7 * self.voxel;
        let mut t = t0 + nudge;
        while t <= t1 {
            let q = p + dir * t;
            let Some(c) = self.clear_at(q) else {
                // Rounding at the grid's faces: step on.
                t += nudge;
                continue;
            };
            let v = ((q - self.origin) / self.voxel).floor();
            if c == 0 && self.usable(v.to_array().map(|x| x as usize), openings) {
                return Some(t);
            }
            if c >= 2 {
                // Every voxel within c − 1 of this one is open.
                t += (c - 1) as f64 * self.voxel;
                continue;
            }
            // Next to (or in an unusable) solid voxel: step to this voxel's exit.
            let mut exit = f64::INFINITY;
            for k in 0..3 {
                if dir[k] > 1e-300 {
                    exit = exit.min((self.origin[k] + (v[k] + 1.0) * self.voxel - p[k]) / dir[k]);
                } else if dir[k] < -1e-300 {
                    exit = exit.min((self.origin[k] + v[k] * self.voxel - p[k]) / dir[k]);
                }
            }
            t = exit.max(t) + nudge;
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hom_testkit::Rng;

    /// Random solid boxes on a 16³ grid of 0.25 m voxels.
    fn random_space(seed: &mut Rng) -> SolidSpace {
        let bounds = Aabb::new(Vec3::ZERO, Vec3::splat(4.0));
        let mut s = SolidSpace::new(&bounds, 0.25).unwrap();
        for _ in 0..6 {
            let a = [0, 1, 2].map(|_| (seed.unit_f64() * 16.0) as usize);
            let e = [0, 1, 2].map(|_| 1 + (seed.unit_f64() * 8.0) as usize);
            for z in a[2]..(a[2] + e[2]).min(16) {
                for y in a[1]..(a[1] + e[1]).min(16) {
                    for x in a[0]..(a[0] + e[0]).min(16) {
                        s.set([x, y, z], true);
                    }
                }
            }
        }
        s
    }

    /// Erosion against brute force: a voxel stays solid iff every voxel
    /// within Chebyshev distance k is solid (and in the grid).
    #[test]
    fn erosion_keeps_what_a_solid_neighbourhood_surrounds() {
        let mut seed = Rng::new(0x9E37_79B9_7F4A_7C15);
        for _ in 0..20 {
            let s = random_space(&mut seed);
            for k in 0..3usize {
                let e = s.eroded(k as f64 * 0.25 - 1e-9);
                for z in 0..16usize {
                    for y in 0..16usize {
                        for x in 0..16usize {
                            let mut want = true;
                            for dz in -(k as i64)..=k as i64 {
                                for dy in -(k as i64)..=k as i64 {
                                    for dx in -(k as i64)..=k as i64 {
                                        let q = [x as i64 + dx, y as i64 + dy, z as i64 + dz];
                                        want &= q.iter().all(|&c| (0..16).contains(&c))
                                            && s.is_solid(q.map(|c| c as usize));
                                    }
                                }
                            }
                            let c = s.voxel_box([x, y, z]).center().as_dvec3();
                            assert_eq!(e.contains(c), want, "voxel {x},{y},{z}, k {k}");
                        }
                    }
                }
            }
        }
    }

    /// Ray casts against fine stepping: a hit is a solid point, and a ray
    /// whose fine steps find a solid point well inside a voxel is hit no
    /// later than that point.
    #[test]
    fn ray_casts_find_the_solid_that_fine_steps_find() {
        let mut seed = Rng::new(0x2545_F491_4F6C_DD1D);
        let mut hits = 0;
        for _ in 0..20 {
            let s = random_space(&mut seed);
            let e = s.eroded(0.0);
            for _ in 0..500 {
                let p = DVec3::new(seed.unit_f64(), seed.unit_f64(), seed.unit_f64()) * 6.0 - 1.0;
                let dir = (DVec3::new(seed.unit_f64(), seed.unit_f64(), seed.unit_f64()) * 2.0 - 1.0).normalize();
                let got = e.first_hit(p, dir, 8.0, &e.cell_openings(&Aabb::new(Vec3::ZERO, Vec3::ONE)));
                if let Some(t) = got {
                    assert!(e.contains(p + dir * t) && t <= 8.0);
                    hits += 1;
                }
                // Fine steps, counting only points a little inside a voxel.
                let first = (0..8000).map(|i| i as f64 * 1e-3).find(|&t| {
                    let q = p + dir * t;
                    let f = ((q - e.origin) / e.voxel).to_array().map(|c| c - c.floor());
                    e.contains(q) && f.iter().all(|&c| c > 0.01 && c < 0.99)
                });
                if let Some(t) = first {
                    assert!(got.is_some_and(|g| g <= t + 1e-6), "missed a solid at {t}: {got:?}");
                }
            }
        }
        assert!(hits > 1000, "only {hits} hits: the test proves little");
    }

    /// `meets_region` against sampling: a point `v + t·(a − v)` (v in C, a
    /// in H, t ≥ 1) inside Q means Q meets the region; and the test says
    /// yes often enough for that to prove something.
    #[test]
    fn region_through_an_opening_against_sampled_segments() {
        let mut seed = Rng::new(0x1234_5678_9ABC_DEF1);
        let mut rnd = move || seed.unit_f64() as f32;
        let mut random_box = |scale: f32| {
            let c = Vec3::new(rnd(), rnd(), rnd()) * 20.0 - 10.0;
            let h = Vec3::new(rnd(), rnd(), rnd()) * scale + 0.05;
            Aabb::new(c - h, c + h)
        };
        let (mut met, mut sampled_in) = (0, 0);
        for _ in 0..2000 {
            let (c, h, q) = (random_box(2.0), random_box(1.0), random_box(3.0));
            let meets = meets_region(&c, &h, &q);
            met += meets as usize;
            let mut s2 = Rng::new(seed_from(&c, &h));
            for _ in 0..200 {
                let mut r = || s2.unit_f64() as f32;
                let v = c.min + (c.max - c.min) * Vec3::new(r(), r(), r());
                let a = h.min + (h.max - h.min) * Vec3::new(r(), r(), r());
                let t = 1.0 + r() * r() * 20.0;
                let p = v + (a - v) * t;
                if q.contains_point(p) {
                    sampled_in += 1;
                    assert!(meets, "{p} on a segment from {c:?} through {h:?} lies in {q:?}");
                }
            }
        }
        assert!(
            met > 50 && sampled_in > 50,
            "met {met}, sampled {sampled_in}: too few to tell"
        );
    }

    fn seed_from(c: &Aabb, h: &Aabb) -> u64 {
        (c.min.x.to_bits() as u64) << 32 | h.max.y.to_bits() as u64 | 1
    }

    #[test]
    fn refuses_absurd_grids() {
        let b = Aabb::new(Vec3::ZERO, Vec3::splat(1e4));
        assert!(SolidSpace::new(&b, 0.01).is_err());
        assert!(SolidSpace::new(&b, f32::NAN).is_err());
        assert!(SolidSpace::new(&Aabb::EMPTY, 1.0).is_err());
    }
}
