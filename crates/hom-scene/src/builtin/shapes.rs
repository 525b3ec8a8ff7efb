//! Tessellation helpers shared by the generators: boxes, cylinders, cones, spheres,
//! tori, swept pipes with bends, and a mesh builder that appends them.

use glam::{Mat4, Quat, Vec3};
use hom::scene::Mesh;
use std::f32::consts::{PI, TAU};

/// Growing triangle soup that becomes a [`Mesh`].
#[derive(Clone, Debug, Default)]
pub(crate) struct MeshBuilder {
    pub(crate) positions: Vec<Vec3>,
    pub(crate) triangles: Vec<[u32; 3]>,
}

/// Two unit vectors perpendicular to `d` and to each other (a right-handed frame `u, v, d`).
pub(crate) fn frame(d: Vec3) -> (Vec3, Vec3) {
    d.normalize().any_orthonormal_pair()
}

impl MeshBuilder {
    /// An empty builder.
    pub(crate) fn new() -> MeshBuilder {
        MeshBuilder::default()
    }

    /// Triangles so far.
    #[cfg(test)]
    pub(crate) fn tri_count(&self) -> usize {
        self.triangles.len()
    }

    /// Adds a vertex and returns its index.
    pub(crate) fn vertex(&mut self, p: Vec3) -> u32 {
        self.positions.push(p);
        (self.positions.len() - 1) as u32
    }

    /// Adds a triangle of existing vertices.
    pub(crate) fn tri(&mut self, a: u32, b: u32, c: u32) {
        self.triangles.push([a, b, c]);
    }

    /// Adds the quad `a b c d` (in order round its edge) as two triangles.
    pub(crate) fn quad(&mut self, a: u32, b: u32, c: u32, d: u32) {
        self.triangles.push([a, b, c]);
        self.triangles.push([a, c, d]);
    }

    /// Adds a quad from four points.
    pub(crate) fn quad_pts(&mut self, a: Vec3, b: Vec3, c: Vec3, d: Vec3) {
        let i = self.vertex(a);
        self.vertex(b);
        self.vertex(c);
        self.vertex(d);
        self.quad(i, i + 1, i + 2, i + 3);
    }

    /// A horizontal rectangle at height `y` spanning `min..max` in x and z (2 triangles).
    pub(crate) fn floor_quad(&mut self, min: Vec3, max: Vec3, y: f32) {
        self.quad_pts(
            Vec3::new(min.x, y, min.z),
            Vec3::new(max.x, y, min.z),
            Vec3::new(max.x, y, max.z),
            Vec3::new(min.x, y, max.z),
        );
    }

    /// An axis-aligned box (12 triangles).
    pub(crate) fn add_box(&mut self, min: Vec3, max: Vec3) {
        self.add_box_xf(min, max, &Mat4::IDENTITY);
    }

    /// An axis-aligned box without its bottom face (10 triangles), for things standing on a floor.
    pub(crate) fn add_box_open_bottom(&mut self, min: Vec3, max: Vec3) {
        let c = corners(min, max);
        let base = self.positions.len() as u32;
        self.positions.extend_from_slice(&c);
        for f in BOX_FACES.iter().skip(1) {
            self.quad(base + f[0], base + f[1], base + f[2], base + f[3]);
        }
    }

    /// A box given by its local corners `min..max`, placed by `xf` (12 triangles).
    pub(crate) fn add_box_xf(&mut self, min: Vec3, max: Vec3, xf: &Mat4) {
        let c = corners(min, max).map(|p| xf.transform_point3(p));
        let base = self.positions.len() as u32;
        self.positions.extend_from_slice(&c);
        for f in BOX_FACES {
            self.quad(base + f[0], base + f[1], base + f[2], base + f[3]);
        }
    }

    /// A box from `a` to `b` (its axis), `w` wide and `h` thick: beams, struts, rails.
    pub(crate) fn add_beam(&mut self, a: Vec3, b: Vec3, w: f32, h: f32) {
        let d = b - a;
        let len = d.length();
        if len <= 1e-6 {
            return;
        }
        let dir = d / len;
        let up = if dir.y.abs() > 0.9 { Vec3::X } else { Vec3::Y };
        let side = dir.cross(up).normalize();
        let up = side.cross(dir);
        let xf = Mat4::from_cols(side.extend(0.0), up.extend(0.0), dir.extend(0.0), a.extend(1.0));
        self.add_box_xf(
            Vec3::new(-w * 0.5, -h * 0.5, 0.0),
            Vec3::new(w * 0.5, h * 0.5, len),
            &xf,
        );
    }

    /// A truncated cone (frustum) from `a` (radius `ra`) to `b` (radius `rb`), `seg` sides,
    /// with end caps when `caps` is true. `ra == rb` makes a cylinder.
    pub(crate) fn add_cone(&mut self, a: Vec3, b: Vec3, ra: f32, rb: f32, seg: u32, caps: bool) {
        let d = b - a;
        if d.length_squared() <= 1e-12 {
            return;
        }
        let (u, v) = frame(d);
        let base = self.positions.len() as u32;
        for i in 0..seg {
            let t = i as f32 / seg as f32 * TAU;
            let r = u * t.cos() + v * t.sin();
            self.positions.push(a + r * ra);
            self.positions.push(b + r * rb);
        }
        for i in 0..seg {
            let j = (i + 1) % seg;
            let (a0, b0, a1, b1) = (base + 2 * i, base + 2 * i + 1, base + 2 * j, base + 2 * j + 1);
            if ra > 0.0 && rb > 0.0 {
                self.quad(a0, a1, b1, b0);
            } else if ra > 0.0 {
                self.tri(a0, a1, b0);
            } else {
                self.tri(a0, b1, b0);
            }
        }
        if caps {
            for (off, r) in [(0, ra), (1, rb)] {
                if r > 0.0 {
                    for i in 1..seg.saturating_sub(1) {
                        self.tri(base + off, base + 2 * i + off, base + 2 * (i + 1) + off);
                    }
                }
            }
        }
    }

    /// A cylinder from `a` to `b`.
    pub(crate) fn add_cylinder(&mut self, a: Vec3, b: Vec3, r: f32, seg: u32, caps: bool) {
        self.add_cone(a, b, r, r, seg, caps);
    }

    /// A UV sphere (`slices` around, `stacks` pole to pole).
    pub(crate) fn add_sphere(&mut self, c: Vec3, r: f32, slices: u32, stacks: u32) {
        self.add_ellipsoid(c, Vec3::splat(r), slices, stacks);
    }

    /// A UV ellipsoid with radii `r` along x, y, z.
    pub(crate) fn add_ellipsoid(&mut self, c: Vec3, r: Vec3, slices: u32, stacks: u32) {
        let base = self.positions.len() as u32;
        self.positions.push(c + Vec3::new(0.0, r.y, 0.0));
        for s in 1..stacks {
            let phi = s as f32 / stacks as f32 * PI;
            let (sp, cp) = phi.sin_cos();
            for i in 0..slices {
                let t = i as f32 / slices as f32 * TAU;
                self.positions.push(c + Vec3::new(sp * t.cos(), cp, sp * t.sin()) * r);
            }
        }
        let south = self.vertex(c - Vec3::new(0.0, r.y, 0.0));
        let ring = |s: u32, i: u32| base + 1 + (s - 1) * slices + i % slices;
        for i in 0..slices {
            self.tri(base, ring(1, i + 1), ring(1, i));
            self.tri(south, ring(stacks - 1, i), ring(stacks - 1, i + 1));
        }
        for s in 1..stacks - 1 {
            for i in 0..slices {
                self.quad(ring(s, i), ring(s, i + 1), ring(s + 1, i + 1), ring(s + 1, i));
            }
        }
    }

    /// A torus around `axis` through `c`: ring radius `major`, tube radius `minor`.
    pub(crate) fn add_torus(&mut self, c: Vec3, axis: Vec3, major: f32, minor: f32, seg: u32, tube: u32) {
        let (u, v) = frame(axis);
        let n = axis.normalize();
        let base = self.positions.len() as u32;
        for i in 0..seg {
            let a = i as f32 / seg as f32 * TAU;
            let radial = u * a.cos() + v * a.sin();
            for j in 0..tube {
                let b = j as f32 / tube as f32 * TAU;
                self.positions
                    .push(c + radial * (major + minor * b.cos()) + n * (minor * b.sin()));
            }
        }
        for i in 0..seg {
            for j in 0..tube {
                let i1 = (i + 1) % seg;
                let j1 = (j + 1) % tube;
                self.quad(
                    base + i * tube + j,
                    base + i1 * tube + j,
                    base + i1 * tube + j1,
                    base + i * tube + j1,
                );
            }
        }
    }

    /// A tube of radius `r` swept along the polyline `pts`, corners rounded with bend
    /// radius `bend` (elbows of `arc_steps` segments per quarter turn). Open ends.
    pub(crate) fn add_pipe(&mut self, pts: &[Vec3], r: f32, bend: f32, seg: u32, arc_steps: u32) {
        if pts.len() < 2 {
            return;
        }
        // Centre-line samples with tangents: straight parts need only their end rings.
        let mut samples: Vec<(Vec3, Vec3)> = vec![(pts[0], (pts[1] - pts[0]).normalize())];
        for k in 1..pts.len() - 1 {
            let d0 = (pts[k] - pts[k - 1]).normalize();
            let d1 = (pts[k + 1] - pts[k]).normalize();
            let cos = d0.dot(d1).clamp(-1.0, 1.0);
            let theta = cos.acos();
            if theta < 1e-3 {
                continue;
            }
            let room = ((pts[k] - pts[k - 1]).length() * 0.5).min((pts[k + 1] - pts[k]).length() * 0.5);
            let rad = bend.min(room / (theta * 0.5).tan().max(1e-3));
            let t = rad * (theta * 0.5).tan();
            let start = pts[k] - d0 * t;
            let toward = (d1 - d0 * cos).normalize();
            let centre = start + toward * rad;
            let axis = d0.cross(d1).normalize();
            let steps = ((arc_steps as f32 * theta / (PI * 0.5)).ceil() as u32).max(1);
            for s in 0..=steps {
                let q = Quat::from_axis_angle(axis, theta * s as f32 / steps as f32);
                samples.push((centre + q * (start - centre), q * d0));
            }
        }
        let n = pts.len();
        samples.push((pts[n - 1], (pts[n - 1] - pts[n - 2]).normalize()));
        // Rings by parallel transport of a reference direction (no twist).
        let (mut u, _) = frame(samples[0].1);
        let base = self.positions.len() as u32;
        for (p, t) in &samples {
            u = (u - *t * u.dot(*t)).normalize_or(frame(*t).0);
            let v = t.cross(u);
            for i in 0..seg {
                let a = i as f32 / seg as f32 * TAU;
                self.positions.push(*p + (u * a.cos() + v * a.sin()) * r);
            }
        }
        for k in 0..samples.len() as u32 - 1 {
            for i in 0..seg {
                let j = (i + 1) % seg;
                let a = base + k * seg;
                let b = a + seg;
                self.quad(a + i, a + j, b + j, b + i);
            }
        }
    }

    /// An axis-aligned box whose faces are grids of squares about `step` wide
    /// (closed; corners and edges shared exactly between faces): a dense
    /// occluder that a 12-triangle box stands in for.
    pub(crate) fn add_tessellated_box(&mut self, min: Vec3, max: Vec3, step: f32) {
        // One coordinate list per axis, so faces meeting at an edge share its points bit for bit.
        let ticks = |a: f32, b: f32| -> Vec<f32> {
            let n = ((b - a) / step).ceil().max(1.0) as usize;
            (0..=n)
                .map(|i| if i == n { b } else { a + (b - a) * i as f32 / n as f32 })
                .collect()
        };
        let axes = [ticks(min.x, max.x), ticks(min.y, max.y), ticks(min.z, max.z)];
        // Each face: the axis it faces, which side, and the two axes it spans (u × v outward).
        for (n, hi) in [(0, false), (0, true), (1, false), (1, true), (2, false), (2, true)] {
            let (mut u, mut v) = ((n + 1) % 3, (n + 2) % 3);
            if !hi {
                std::mem::swap(&mut u, &mut v);
            }
            let at = |i: usize, j: usize| {
                let mut p = [0.0; 3];
                p[n] = if hi { axes[n][axes[n].len() - 1] } else { axes[n][0] };
                p[u] = axes[u][i];
                p[v] = axes[v][j];
                Vec3::from(p)
            };
            let (nu, nv) = (axes[u].len(), axes[v].len());
            let base = self.positions.len() as u32;
            for i in 0..nu {
                for j in 0..nv {
                    self.positions.push(at(i, j));
                }
            }
            let id = |i: usize, j: usize| base + (i * nv + j) as u32;
            for i in 0..nu - 1 {
                for j in 0..nv - 1 {
                    self.quad(id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
                }
            }
        }
    }

    /// A superellipsoid: |x/rx|^p + |y/ry|^p + |z/rz|^p = 1 (p = 2 is an ellipsoid,
    /// larger p squarer), tessellated like [`MeshBuilder::add_ellipsoid`].
    pub(crate) fn add_superellipsoid(&mut self, c: Vec3, r: Vec3, p: f32, slices: u32, stacks: u32) {
        let e = 2.0 / p;
        let pow = |x: f32| x.signum() * x.abs().powf(e);
        let first = self.positions.len();
        self.add_ellipsoid(Vec3::ZERO, Vec3::ONE, slices, stacks);
        for q in &mut self.positions[first..] {
            // Map the unit sphere's (cos, sin) pairs through the signed power, per axis.
            *q = c + Vec3::new(pow(q.x), pow(q.y), pow(q.z)) * r;
        }
    }

    /// Appends another builder's triangles transformed by `xf`.
    pub(crate) fn append(&mut self, other: &MeshBuilder, xf: &Mat4) {
        let base = self.positions.len() as u32;
        self.positions
            .extend(other.positions.iter().map(|p| xf.transform_point3(*p)));
        self.triangles
            .extend(other.triangles.iter().map(|t| t.map(|i| i + base)));
    }

    /// The finished mesh. Degenerate (zero-area) triangles are dropped.
    ///
    /// # Panics
    /// If nothing was added or a coordinate is not finite (generator bugs).
    pub(crate) fn build(mut self, name: impl Into<String>) -> Mesh {
        let p = &self.positions;
        self.triangles.retain(|t| {
            let (a, b, c) = (p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]);
            (b - a).cross(c - a).length_squared() > 1e-14
        });
        Mesh::new(name, self.positions, self.triangles).expect("generated mesh is valid")
    }
}

/// Corners of `min..max`: bit 0 picks max.x, bit 1 max.y, bit 2 max.z.
fn corners(min: Vec3, max: Vec3) -> [Vec3; 8] {
    std::array::from_fn(|i| {
        Vec3::new(
            if i & 1 != 0 { max.x } else { min.x },
            if i & 2 != 0 { max.y } else { min.y },
            if i & 4 != 0 { max.z } else { min.z },
        )
    })
}

/// Box faces as corner quads; the first is the bottom (-Y).
const BOX_FACES: [[u32; 4]; 6] = [
    [0, 1, 5, 4], // -Y
    [2, 6, 7, 3], // +Y
    [0, 4, 6, 2], // -X
    [1, 3, 7, 5], // +X
    [0, 2, 3, 1], // -Z
    [4, 5, 7, 6], // +Z
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shapes_have_expected_triangle_counts_and_bounds() {
        let mut b = MeshBuilder::new();
        b.add_box(Vec3::ZERO, Vec3::ONE);
        assert_eq!(b.tri_count(), 12);
        b.add_cylinder(Vec3::ZERO, Vec3::Y, 0.5, 8, true);
        assert_eq!(b.tri_count(), 12 + 16 + 12);
        let mut s = MeshBuilder::new();
        s.add_sphere(Vec3::ZERO, 2.0, 16, 8);
        assert_eq!(s.tri_count(), 2 * 16 + 16 * 6 * 2);
        let m = s.build("s");
        assert!((m.bounds().max.y - 2.0).abs() < 1e-5);
        let mut p = MeshBuilder::new();
        p.add_pipe(
            &[Vec3::ZERO, Vec3::new(0.0, 0.0, 5.0), Vec3::new(5.0, 0.0, 5.0)],
            0.2,
            1.0,
            8,
            4,
        );
        let m = p.build("pipe");
        // The bend is rounded: the corner itself is not reached.
        assert!(m.bounds().max.z < 5.0 + 0.21 && m.bounds().max.x > 4.99);
        assert!(m
            .positions()
            .iter()
            .all(|q| (q - Vec3::new(0.0, 0.0, 5.0)).length() > 0.2));
    }

    /// Signed volume of a triangle soup (positive for a closed, outward-wound mesh).
    fn signed_volume(b: &MeshBuilder) -> f32 {
        let p = &b.positions;
        b.triangles
            .iter()
            .map(|t| p[t[0] as usize].dot(p[t[1] as usize].cross(p[t[2] as usize])) / 6.0)
            .sum()
    }

    /// Edges (as welded position pairs) used by other than exactly two triangles.
    fn open_edges(b: &MeshBuilder) -> usize {
        let canonical = hom::occlusion::details::weld(&b.positions);
        let key = |i: u32| canonical[i as usize];
        let mut edges = std::collections::HashMap::new();
        for t in &b.triangles {
            for k in 0..3 {
                let (a, c) = (key(t[k]), key(t[(k + 1) % 3]));
                *edges.entry(if a < c { (a, c) } else { (c, a) }).or_insert(0) += 1;
            }
        }
        edges.values().filter(|&&n| n != 2).count()
    }

    #[test]
    fn dense_solids_are_closed_and_wound_outward() {
        let mut b = MeshBuilder::new();
        let (min, max) = (Vec3::new(-1.0, 0.0, 0.5), Vec3::new(2.0, 0.7, 1.1));
        b.add_tessellated_box(min, max, 0.1);
        // 30 x 7, 30 x 6 and 7 x 6 squares on opposite face pairs.
        assert_eq!(b.tri_count(), 2 * 2 * (30 * 7 + 30 * 6 + 7 * 6));
        assert_eq!(open_edges(&b), 0);
        let v = (max - min).x * (max - min).y * (max - min).z;
        assert!((signed_volume(&b) - v).abs() < 1e-4 * v, "{}", signed_volume(&b));
        let m = b.build("box");
        assert_eq!((m.bounds().min, m.bounds().max), (min, max));

        let mut s = MeshBuilder::new();
        s.add_superellipsoid(Vec3::Y, Vec3::new(1.0, 2.0, 0.5), 6.0, 32, 16);
        assert_eq!(open_edges(&s), 0);
        // Squarer than the ellipsoid (4/3 pi abc), inside the box (8abc).
        let vol = signed_volume(&s);
        assert!(vol > 4.0 / 3.0 * PI * 1.0 && vol < 8.0 * 1.0, "{vol}");
        let m = s.build("blob");
        assert!((m.bounds().max - Vec3::new(1.0, 3.0, 0.5)).abs().max_element() < 1e-5);
    }
}
