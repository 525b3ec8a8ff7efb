//! Stage 3 of the virtual-occluder bake (Law & Tan 1999, section 4.2, the
//! stand-in inside the solid): the cells wholly inside a solid. A grid over
//! the mesh's box; a cell no solid's triangle touches is wholly inside or
//! wholly outside each solid, and its centre's parity along a vertical ray
//! says which. Orientation tests whose sign rounding could flip drop the
//! whole column, so no cell is called inside by luck.

use super::solids::Parts;
use crate::scene::Mesh;
use glam::Vec3;
use std::collections::HashMap;

/// The cell grid over a mesh's box: rectilinear, with planes just either
/// side of the mesh's largest axis-aligned faces (so a thin CAD plate gets
/// cells wholly inside it) and the rest split evenly.
pub(super) struct Grid {
    /// Cell boundaries per axis, ascending.
    pub(super) planes: [Vec<f32>; 3],
    /// Cells per axis.
    pub(super) dims: [usize; 3],
    /// How far a triangle may pass outside a cell and still touch it.
    pub(super) margin: Vec3,
}

impl Grid {
    pub(super) fn new(mesh: &Mesh, resolution: u32) -> Option<Grid> {
        let bounds = mesh.bounds();
        let extent = bounds.extent();
        if !(extent.min_element() > 0.0 && extent.is_finite()) {
            return None;
        }
        let gap = extent * 1e-4;
        let n = resolution as usize;
        // Axis-aligned faces by plane, with their area.
        let p = mesh.positions();
        let mut faces: [HashMap<u32, f32>; 3] = Default::default();
        for t in mesh.triangles() {
            let [a, b, c] = t.map(|i| p[i as usize]);
            for (axis, planes) in faces.iter_mut().enumerate() {
                if a[axis] == b[axis] && b[axis] == c[axis] {
                    *planes.entry((a[axis] + 0.0).to_bits()).or_default() += (b - a).cross(c - a).length() * 0.5;
                }
            }
        }
        let planes: [Vec<f32>; 3] = std::array::from_fn(|axis| {
            let (lo, hi, gap) = (bounds.min[axis], bounds.max[axis], gap[axis]);
            let mut chosen: Vec<(f32, f32)> = faces[axis]
                .iter()
                .map(|(&c, &area)| (f32::from_bits(c), area))
                .collect();
            chosen.sort_by(|x, y| y.1.total_cmp(&x.1).then(x.0.total_cmp(&y.0)));
            chosen.truncate(n / 2);
            // Gaps at the bounds too: faces on the box's sides touch only them.
            let mut cuts = vec![lo, lo + gap, hi - gap, hi];
            for (c, _) in chosen {
                cuts.extend([(c - gap).max(lo), (c + gap).min(hi)]);
            }
            cuts.sort_by(f32::total_cmp);
            cuts.dedup_by(|x, y| *x - *y < gap * 0.5);
            *cuts.last_mut().expect("two cuts") = hi;
            // Split the widest cells (never the gaps round a face) until there are `n`.
            while cuts.len() <= n {
                let (w, i) = (0..cuts.len() - 1)
                    .map(|i| (cuts[i + 1] - cuts[i], i))
                    .max_by(|x, y| x.0.total_cmp(&y.0).then(y.1.cmp(&x.1)))
                    .expect("a cell");
                if w < gap * 4.0 {
                    break;
                }
                cuts.insert(i + 1, cuts[i] + w * 0.5);
            }
            cuts
        });
        Some(Grid {
            dims: std::array::from_fn(|a| planes[a].len() - 1),
            planes,
            margin: gap * 0.25,
        })
    }

    pub(super) fn index(&self, i: usize, j: usize, k: usize) -> usize {
        (k * self.dims[1] + j) * self.dims[0] + i
    }

    pub(super) fn len(&self) -> usize {
        self.dims.iter().product()
    }

    /// Cells wholly inside some solid.
    pub(super) fn inside_cells(&self, mesh: &Mesh, solids: &Parts) -> Vec<bool> {
        let [nx, ny, nz] = self.dims;
        let p = mesh.positions();
        let tri = |t: u32| mesh.triangles()[t as usize].map(|i| p[i as usize]);
        // Surface cells: touched by a solid's triangle (cells grown by a margin).
        let mut surface = vec![false; self.len()];
        for &(t, _) in &solids.solid {
            let v = tri(t);
            let lo = v[0].min(v[1]).min(v[2]) - self.margin;
            let hi = v[0].max(v[1]).max(v[2]) + self.margin;
            let [i0, j0, k0] = self.cell_of(lo);
            let [i1, j1, k1] = self.cell_of(hi);
            for k in k0..=k1 {
                for j in j0..=j1 {
                    for i in i0..=i1 {
                        let c = self.index(i, j, k);
                        if !surface[c] {
                            let (lo, hi) = self.cell_bounds(i, j, k);
                            let half = ((hi - lo) * 0.5 + self.margin).as_dvec3();
                            surface[c] = triangle_touches_box(&v, ((lo + hi) * 0.5).as_dvec3(), half);
                        }
                    }
                }
            }
        }
        // Crossings of each column's vertical line through the cell centres.
        let mut columns: Vec<Vec<(f32, u32)>> = vec![Vec::new(); nx * nz];
        let mut doubtful = vec![false; nx * nz];
        for &(t, s) in &solids.solid {
            let v = tri(t);
            let lo = v[0].min(v[1]).min(v[2]);
            let hi = v[0].max(v[1]).max(v[2]);
            let [i0, _, k0] = self.cell_of(lo);
            let [i1, _, k1] = self.cell_of(hi);
            for k in k0..=k1 {
                for i in i0..=i1 {
                    let c = self.centre(i, 0, k);
                    match vertical_crossing(&v, c.x, c.z) {
                        Crossing::None => {}
                        Crossing::At(y) => columns[k * nx + i].push((y, s)),
                        Crossing::Doubtful => doubtful[k * nx + i] = true,
                    }
                }
            }
        }
        let mut inside = vec![false; self.len()];
        let mut odd = vec![false; solids.count as usize];
        for k in 0..nz {
            for i in 0..nx {
                let column = &mut columns[k * nx + i];
                if doubtful[k * nx + i] || column.is_empty() {
                    continue;
                }
                // Top down: parity of the crossings above each cell centre.
                column.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
                odd.iter_mut().for_each(|o| *o = false);
                let (mut odd_count, mut next) = (0usize, 0);
                for j in (0..ny).rev() {
                    let y = self.centre(i, j, k).y;
                    while next < column.len() && column[next].0 > y {
                        let s = column[next].1 as usize;
                        odd[s] = !odd[s];
                        odd_count = if odd[s] { odd_count + 1 } else { odd_count - 1 };
                        next += 1;
                    }
                    let c = self.index(i, j, k);
                    inside[c] = odd_count > 0 && !surface[c];
                }
            }
        }
        inside
    }

    /// A cell's corners.
    pub(super) fn cell_bounds(&self, i: usize, j: usize, k: usize) -> (Vec3, Vec3) {
        let [x, y, z] = &self.planes;
        (Vec3::new(x[i], y[j], z[k]), Vec3::new(x[i + 1], y[j + 1], z[k + 1]))
    }

    pub(super) fn centre(&self, i: usize, j: usize, k: usize) -> Vec3 {
        let (lo, hi) = self.cell_bounds(i, j, k);
        (lo + hi) * 0.5
    }

    /// The cell holding `p`, clamped to the grid.
    pub(super) fn cell_of(&self, p: Vec3) -> [usize; 3] {
        std::array::from_fn(|a| {
            let i = self.planes[a].partition_point(|&b| b <= p[a]);
            i.saturating_sub(1).min(self.dims[a] - 1)
        })
    }
}

/// Where a vertical line meets a triangle.
enum Crossing {
    None,
    At(f32),
    /// Too close to an edge or vertex for the rounded signs to be trusted.
    Doubtful,
}

/// The line `(x, ·, z)` against triangle `v`: the orientations of the point
/// against the three projected edges, in f64 with a bound on their rounding.
fn vertical_crossing(v: &[Vec3; 3], x: f32, z: f32) -> Crossing {
    let (x, z) = (f64::from(x), f64::from(z));
    let mut signs = [0i8; 3];
    for e in 0..3 {
        let (a, b) = (v[e].as_dvec3(), v[(e + 1) % 3].as_dvec3());
        let (l, r) = ((b.x - a.x) * (z - a.z), (b.z - a.z) * (x - a.x));
        let det = l - r;
        // Each input difference is exact or within one rounding; the bound
        // covers them and the products (a few ulps of the terms' size).
        let bound = (l.abs() + r.abs()) * 1e-12;
        if det.abs() <= bound {
            return Crossing::Doubtful;
        }
        signs[e] = if det > 0.0 { 1 } else { -1 };
    }
    if signs[0] != signs[1] || signs[1] != signs[2] {
        return Crossing::None;
    }
    // The plane's height at (x, z).
    let (a, b, c) = (v[0].as_dvec3(), v[1].as_dvec3(), v[2].as_dvec3());
    let n = (b - a).cross(c - a);
    if n.y.abs() <= 1e-300 {
        return Crossing::Doubtful;
    }
    let y = a.y - (n.x * (x - a.x) + n.z * (z - a.z)) / n.y;
    Crossing::At(y as f32)
}

/// Whether triangle `v` touches the box `centre ± half` (the separating-axis
/// test of Akenine-Möller 2001, in f64).
fn triangle_touches_box(v: &[Vec3; 3], centre: glam::DVec3, half: glam::DVec3) -> bool {
    let p = v.map(|q| q.as_dvec3() - centre);
    let e = [p[1] - p[0], p[2] - p[1], p[0] - p[2]];
    let separated = |axis: glam::DVec3| {
        let d = p.map(|q| q.dot(axis));
        let r = half.dot(axis.abs());
        d[0].min(d[1]).min(d[2]) > r || d[0].max(d[1]).max(d[2]) < -r
    };
    // The triangle's plane first: it rejects most cells of a big triangle's box.
    let normal = e[0].cross(e[1]);
    if normal != glam::DVec3::ZERO && separated(normal) {
        return false;
    }
    let units = [glam::DVec3::X, glam::DVec3::Y, glam::DVec3::Z];
    if units.iter().any(|&u| separated(u)) {
        return false;
    }
    for edge in e {
        for u in units {
            let axis = edge.cross(u);
            if axis != glam::DVec3::ZERO && separated(axis) {
                return false;
            }
        }
    }
    true
}
