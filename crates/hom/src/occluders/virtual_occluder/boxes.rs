//! Stage 4 of the virtual-occluder bake (Law & Tan 1999, section 4.2, the
//! stand-in inside the solid): boxes of inside cells. The greedy pick grows
//! a box from seed cells through inside cells, scored by the uncovered
//! surface area it adds; a 3D prefix sum counts the inside cells of any box.
//! Each picked box becomes twelve triangles at the cells' outer boundaries.

use super::cells::Grid;
use glam::Vec3;

/// A box of cells, half-open index ranges.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct CellBox {
    pub(super) lo: [usize; 3],
    pub(super) hi: [usize; 3],
}

impl CellBox {
    fn cells(&self) -> usize {
        (0..3).map(|a| self.hi[a] - self.lo[a]).product()
    }
}

impl Grid {
    /// The box of inside cells that adds the most uncovered area, grown
    /// from at most 128 uncovered seed cells spread evenly in index order
    /// (deterministic), with that area.
    pub(super) fn best_box(&self, inside: &PrefixSum, uncovered: &[bool]) -> Option<(f32, CellBox)> {
        let seeds: Vec<usize> = (0..uncovered.len()).filter(|&c| uncovered[c]).collect();
        let stride = seeds.len().div_ceil(128).max(1);
        let mut best: Option<(f32, CellBox)> = None;
        // Seeds in one region mostly grow the same box: measure each once.
        let mut seen = std::collections::HashSet::new();
        let lines = self.line_sums(uncovered);
        for &s in seeds.iter().step_by(stride) {
            let b = self.grow(inside, s);
            if !seen.insert((b.lo, b.hi)) {
                continue;
            }
            let gain = self.uncovered_area(&b, &lines);
            if best.is_none_or(|(g, _)| gain > g) {
                best = Some((gain, b));
            }
        }
        best
    }

    /// Marks the cells of `b` covered.
    pub(super) fn cover(&self, uncovered: &mut [bool], b: &CellBox) {
        for k in b.lo[2]..b.hi[2] {
            for j in b.lo[1]..b.hi[1] {
                for i in b.lo[0]..b.hi[0] {
                    uncovered[self.index(i, j, k)] = false;
                }
            }
        }
    }

    /// The box grown from cell `seed` one layer at a time, round robin over
    /// the six sides, while the new layer is wholly inside.
    fn grow(&self, inside: &PrefixSum, seed: usize) -> CellBox {
        let [nx, ny, _] = self.dims;
        let (i, j, k) = (seed % nx, seed / nx % ny, seed / (nx * ny));
        let mut b = CellBox {
            lo: [i, j, k],
            hi: [i + 1, j + 1, k + 1],
        };
        let mut open = [true; 6];
        while open.iter().any(|&o| o) {
            for (side, open) in open.iter_mut().enumerate() {
                if !*open {
                    continue;
                }
                let axis = side / 2;
                let mut layer = b;
                if side % 2 == 0 {
                    if b.lo[axis] == 0 {
                        *open = false;
                        continue;
                    }
                    layer.lo[axis] -= 1;
                    layer.hi[axis] = b.lo[axis];
                } else {
                    if b.hi[axis] == self.dims[axis] {
                        *open = false;
                        continue;
                    }
                    layer.lo[axis] = b.hi[axis];
                    layer.hi[axis] += 1;
                }
                if inside.count(&layer) == layer.cells() {
                    if side % 2 == 0 {
                        b.lo[axis] -= 1;
                    } else {
                        b.hi[axis] += 1;
                    }
                } else {
                    *open = false;
                }
            }
        }
        b
    }

    /// Per axis, per line of cells along it, the running count of
    /// uncovered cells: `lines[a][line * (dims[a] + 1) + c]` counts those
    /// before `c`, a line being `cu * dims[v] + cv` for the other axes `u, v`.
    fn line_sums(&self, uncovered: &[bool]) -> [Vec<u32>; 3] {
        std::array::from_fn(|axis| {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let n = self.dims[axis] + 1;
            let mut sums = vec![0u32; self.dims[u] * self.dims[v] * n];
            for cu in 0..self.dims[u] {
                for cv in 0..self.dims[v] {
                    let line = (cu * self.dims[v] + cv) * n;
                    for ca in 0..self.dims[axis] {
                        let mut c = [0; 3];
                        (c[axis], c[u], c[v]) = (ca, cu, cv);
                        let fresh = u32::from(uncovered[self.index(c[0], c[1], c[2])]);
                        sums[line + ca + 1] = sums[line + ca] + fresh;
                    }
                }
            }
            sums
        })
    }

    /// What a box adds: the area its uncovered cells show along the three
    /// axes (their projections, each counted once per axis line of cells).
    fn uncovered_area(&self, b: &CellBox, lines: &[Vec<u32>; 3]) -> f32 {
        let mut area = 0.0;
        for (axis, sums) in lines.iter().enumerate() {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let n = self.dims[axis] + 1;
            let w = |a: usize, i: usize| self.planes[a][i + 1] - self.planes[a][i];
            for cu in b.lo[u]..b.hi[u] {
                for cv in b.lo[v]..b.hi[v] {
                    let line = (cu * self.dims[v] + cv) * n;
                    if sums[line + b.hi[axis]] > sums[line + b.lo[axis]] {
                        area += w(u, cu) * w(v, cv);
                    }
                }
            }
        }
        area
    }
}

/// Counts of set cells in any box, from a 3D prefix sum.
pub(super) struct PrefixSum {
    dims: [usize; 3],
    sum: Vec<u32>,
}

impl PrefixSum {
    pub(super) fn new(dims: [usize; 3], cells: &[bool]) -> PrefixSum {
        let [nx, ny, nz] = dims;
        let (mx, my) = (nx + 1, ny + 1);
        let mut sum = vec![0u32; mx * my * (nz + 1)];
        let at = |i: usize, j: usize, k: usize| (k * my + j) * mx + i;
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let c = u32::from(cells[(k * ny + j) * nx + i]);
                    sum[at(i + 1, j + 1, k + 1)] =
                        c + sum[at(i, j + 1, k + 1)] + sum[at(i + 1, j, k + 1)] + sum[at(i + 1, j + 1, k)]
                            - sum[at(i, j, k + 1)]
                            - sum[at(i, j + 1, k)]
                            - sum[at(i + 1, j, k)]
                            + sum[at(i, j, k)];
                }
            }
        }
        PrefixSum { dims, sum }
    }

    pub(super) fn count(&self, b: &CellBox) -> usize {
        let (mx, my) = (self.dims[0] + 1, self.dims[1] + 1);
        let s = |i: usize, j: usize, k: usize| i64::from(self.sum[(k * my + j) * mx + i]);
        let ([x0, y0, z0], [x1, y1, z1]) = (b.lo, b.hi);
        (s(x1, y1, z1) - s(x0, y1, z1) - s(x1, y0, z1) - s(x1, y1, z0) + s(x0, y0, z1) + s(x0, y1, z0) + s(x1, y0, z0)
            - s(x0, y0, z0)) as usize
    }
}

/// Twelve triangles a box, at the cells' outer boundaries.
pub(super) fn box_meshes(grid: &Grid, boxes: &[CellBox]) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut positions = Vec::with_capacity(boxes.len() * 8);
    let mut triangles = Vec::with_capacity(boxes.len() * 12);
    for b in boxes {
        let lo = Vec3::from_array(std::array::from_fn(|a| grid.planes[a][b.lo[a]]));
        let hi = Vec3::from_array(std::array::from_fn(|a| grid.planes[a][b.hi[a]]));
        push_box(&mut positions, &mut triangles, lo, hi);
    }
    (positions, triangles)
}

/// Appends the box `lo..hi`: eight corners (bit 0 picks `hi.x`, bit 1
/// `hi.y`, bit 2 `hi.z`), two triangles a face, the -y face third.
pub(crate) fn push_box(positions: &mut Vec<Vec3>, triangles: &mut Vec<[u32; 3]>, lo: Vec3, hi: Vec3) {
    const FACES: [[u32; 4]; 6] = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let base = positions.len() as u32;
    for c in 0..8 {
        positions.push(Vec3::select(
            glam::BVec3::new(c & 1 != 0, c & 2 != 0, c & 4 != 0),
            hi,
            lo,
        ));
    }
    for f in FACES {
        triangles.push([base + f[0], base + f[1], base + f[2]]);
        triangles.push([base + f[0], base + f[2], base + f[3]]);
    }
}
