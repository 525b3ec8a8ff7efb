//! Virtual occluders: occlusion-preserving stand-ins for dense occluders
//! (Law & Tan 1999, section 4; Zhang et al. 1997, sections 6–7, name the
//! problem).
//!
//! Law & Tan's condition (section 4.1): from every viewpoint the stand-in may
//! hide only what the original hides. hom meets it with the first of their
//! section 4.2 options, a stand-in *inside the solid the original encloses*,
//! because it is the one with a proof that also bounds depth (their edge
//! error correction keeps the silhouette inside but lets a polygon's interior
//! bulge in front of a concave original; ARCHITECTURE.md, "Virtual
//! occluders", gives the argument and the numbers):
//!
//! 1. **Solids** (`solids.rs`). Vertices are welded by position and the mesh split into
//!    connected components. A component whose every edge has an even number
//!    of triangles is a closed surface (mod 2) and bounds a solid by parity;
//!    so does one whose odd edges all lie in the mesh's floor plane (an
//!    open-bottomed building, a tree on the ground), closed there by a
//!    virtual cap that rays from above the floor never reach. Other
//!    components (open pipes, sheets) enclose nothing and give nothing.
//! 2. **Convex solids** (`convex.rs`) get hulls instead of cells: a closed component
//!    proven convex offers hulls of a few of its own
//!    vertices, shrunk a hair, each inside it because the body is convex
//!    (a sphere's boxes keep 55 % of its axis coverage, its 48-point hull 88 %).
//! 3. **Inside cells** (`cells.rs`). A grid of `resolution³` cells over the mesh's box.
//!    A cell is a *surface* cell when a solid's triangle touches it (the
//!    separating-axis test on the cell grown by a margin); a cell that is not
//!    is wholly inside or wholly outside each solid, and its centre's parity
//!    along a vertical ray says which. Orientation tests whose sign rounding
//!    could flip drop the whole column, so no cell is called inside by luck.
//! 4. **Boxes** (`boxes.rs`). Greedy by area per triangle: the box grown from seed cells
//!    through inside cells that adds the most uncovered surface area, an
//!    open part kept whole, or a convex part's next larger hull (paying the
//!    triangles it adds), until the triangle budget or the gains run out.
//!    The union of the picks is the stand-in (12 triangles a box),
//!    deterministic for a given mesh and configuration.
//!
//! **The guarantee.** A sample the stand-in covers is a ray from the eye
//! through a point `p` of a box or hull, inside some solid `V`. When the eye is
//! outside `V` the segment from eye to `p` crosses `V`'s surface at a point
//! no farther than `p`, on one of the original's triangles (never on a floor
//! cap, when the eye is above the floor): the original covers that sample
//! and is nearer. [`VirtualOccluder::usable`] checks the eye condition per
//! frame: the object's box wholly beyond the near plane (so the eye is
//! outside it and nothing of the original is clipped away) and, for capped
//! solids, the eye above the floor. Holes survive: a tunnel through a solid
//! is outside it, and a hole in an open sheet makes no solid at all.
//!
//! Drawing a stand-in, and the per-frame check that it may stand in, are
//! `draw.rs`; this file holds the configuration, the result and the greedy
//! bake that runs the four stages.

mod boxes;
mod cells;
mod convex;
mod draw;
mod solids;

#[cfg(test)]
pub(crate) use boxes::push_box;
pub(crate) use draw::draw_stand_in;

use boxes::{box_meshes, CellBox, PrefixSum};
use cells::Grid;
use solids::Parts;

use crate::geom::Aabb;
use crate::scene::{Mesh, SceneError};
use glam::Vec3;
use std::ops::Range;
use thiserror::Error;

/// How virtual occluders are baked.
#[derive(Clone, Debug, PartialEq)]
pub struct VirtualConfig {
    /// Grid cells per axis over the mesh's box.
    pub resolution: u32,
    /// Meshes with fewer triangles keep their originals: what a stand-in
    /// saves there is not worth the coverage it loses (terrain's 88-triangle
    /// houses: HOM efficiency 42.4 % with stand-ins, 43.2 % without).
    pub min_original: u32,
    /// At most this share of the original's triangles...
    pub max_share: f32,
    /// ...or this many, when that is more (never more than a quarter of the original's).
    pub min_triangles: u32,
    /// Stop when the next box or open part shows less area per triangle
    /// than this share of the first one's.
    pub min_gain: f32,
    /// Refuse a stand-in that keeps less than this share of the original's
    /// covered area along the three axes (estimated on a 64² grid a view):
    /// a round part that is not convex (so gets no hull) peeks out past any
    /// inscribed box.
    pub min_coverage: f32,
}

impl Default for VirtualConfig {
    /// Measured on the machine room and the city (`hom walk --occluders
    /// virtual --culler hom --frames 100 --no-cost-model --oracle`, HOM
    /// efficiency): a coverage floor of 0.7 / 0.8 / 0.9 gave 38.0 / 37.9 /
    /// 33.9 % and 87.8 / 87.8 / 82.2 %; none gave the spheres 35.5 % instead of
    /// 63.5 %. With convex hulls, 0.6 / 0.7 / 0.8 gave the machine room
    /// 35.7 / 35.7 / 40.3 % (the city, office, spheres, dynamic unchanged).
    /// A floor of 128 original triangles: city 87.8 -> 87.7 %, terrain
    /// 42.4 -> 43.2 %, machine room unchanged (256: 87.4, 43.2).
    fn default() -> Self {
        VirtualConfig {
            resolution: 32,
            min_original: 128,
            max_share: 0.05,
            min_triangles: 64,
            min_gain: 0.05,
            min_coverage: 0.8,
        }
    }
}

/// Why a mesh gets no virtual occluder.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum NoVirtual {
    /// No component of the mesh encloses a solid.
    #[error("no closed part: {open_edges} edges bound holes off the floor plane, so the mesh encloses no solid")]
    NoSolid {
        /// Edges with an odd number of triangles outside the floor plane.
        open_edges: usize,
    },
    /// The solids are thinner than the grid's cells.
    #[error("the closed parts are thinner than a grid cell ({resolution} per axis): no cell lies wholly inside")]
    TooThin {
        /// Cells per axis.
        resolution: u32,
    },
    /// The original is cheap enough to draw as it is.
    #[error("{triangles} triangles: below {min}, the original is drawn as it is")]
    TooFewTriangles {
        /// The original's triangle count.
        triangles: usize,
        /// The fewest triangles a mesh with a stand-in has.
        min: u32,
    },
    /// Unusable configuration.
    #[error("virtual occluder settings: {0}")]
    BadConfig(&'static str),
    /// The stand-in keeps too little of the original's coverage.
    #[error(
        "the stand-in keeps {kept:.0} % of the original's coverage along the axes (at least {needed:.0} % wanted)"
    )]
    TooLittleCoverage {
        /// Percentage kept.
        kept: f32,
        /// Percentage asked for.
        needed: f32,
    },
    /// The stand-in mesh was rejected (not expected for a validated mesh).
    #[error("stand-in mesh: {0}")]
    Mesh(#[from] SceneError),
}

/// A baked stand-in and the viewpoints it is valid from.
#[derive(Clone, Debug, PartialEq)]
pub struct VirtualOccluder {
    mesh: Mesh,
    /// Triangle ranges of `mesh` that each bound a convex solid (a box or a
    /// hull; kept open parts are not among them).
    convex_pieces: Vec<Range<u32>>,
    /// How many of `convex_pieces`, from the first, are boxes (8 corners,
    /// 12 triangles each): the pieces drawn as their silhouettes.
    boxes: usize,
    floor: Option<f32>,
    inside_share: f32,
    coverage: f32,
}

impl VirtualOccluder {
    /// The stand-in, in the original's (object) space.
    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    /// Triangle ranges of [`VirtualOccluder::mesh`] that each bound a convex
    /// solid inside the original's (a box or a hull), for object-space
    /// occlusion tests such as the PVS bake's. Kept open parts are sheets,
    /// not solids, and are in no range.
    pub fn convex_pieces(&self) -> &[Range<u32>] {
        &self.convex_pieces
    }

    /// The object-space floor height the eye must stay above, when a solid
    /// is closed by a floor cap.
    pub fn floor(&self) -> Option<f32> {
        self.floor
    }

    /// Share of the original's covered area it keeps along the three axes
    /// (orthographic, 64² samples a view over the original's box).
    pub fn coverage(&self) -> f32 {
        self.coverage
    }

    /// Share of the grid's inside cells the boxes cover.
    pub fn inside_share(&self) -> f32 {
        self.inside_share
    }
}

impl VirtualOccluder {
    /// Bakes the virtual occluder of `mesh` (in its own space).
    pub fn bake(mesh: &Mesh, config: &VirtualConfig) -> Result<VirtualOccluder, NoVirtual> {
        if !(config.max_share.is_finite() && config.max_share > 0.0) {
            return Err(NoVirtual::BadConfig("max_share must be positive and min_gain finite"));
        }
        let n = mesh.triangle_count();
        let budget = ((n as f32 * config.max_share) as usize)
            .max(config.min_triangles as usize)
            .min(n / 4);
        if budget < 12 || n < config.min_original as usize {
            return Err(NoVirtual::TooFewTriangles {
                triangles: n,
                min: config.min_original.max(48),
            });
        }
        Self::bake_within(mesh, config, budget)
    }

    /// Bakes inscribed solids for object-space tests, where a stand-in's
    /// triangle count costs nothing at run time: any mesh, at most `budget`
    /// triangles (boxes cost 12), `min_original` and `max_share` ignored.
    pub fn bake_solids(mesh: &Mesh, config: &VirtualConfig, budget: usize) -> Result<VirtualOccluder, NoVirtual> {
        Self::bake_within(mesh, config, budget)
    }

    fn bake_within(mesh: &Mesh, config: &VirtualConfig, budget: usize) -> Result<VirtualOccluder, NoVirtual> {
        if !(2..=256).contains(&config.resolution) {
            return Err(NoVirtual::BadConfig("resolution must be 2..=256 cells per axis"));
        }
        if !config.min_gain.is_finite() {
            return Err(NoVirtual::BadConfig("max_share must be positive and min_gain finite"));
        }
        let mut parts = Parts::find(mesh);
        let convex = parts.take_convex();
        let grid = Grid::new(mesh, config.resolution);
        let inside = match &grid {
            Some(g) if !parts.solid.is_empty() => g.inside_cells(mesh, &parts),
            _ => Vec::new(),
        };
        let total = inside.iter().filter(|&&c| c).count();
        // Greedy by area shown (along the three axes) per triangle: the next
        // box of inside cells, the next open part kept as it is, or a convex
        // part's next larger hull.
        let mut uncovered = inside.clone();
        let inside_sum = grid
            .as_ref()
            .filter(|_| total > 0)
            .map(|g| PrefixSum::new(g.dims, &inside));
        let (mut boxes, mut kept) = (Vec::new(), vec![false; parts.open.len()]);
        let mut hull_of: Vec<Option<usize>> = vec![None; convex.len()];
        let (mut left, mut first) = (budget, None);
        loop {
            let next_box = match (&grid, &inside_sum) {
                (Some(g), Some(sum)) if left >= 12 => {
                    g.best_box(sum, &uncovered).map(|(gain, b)| (gain / 12.0, Pick::Box(b)))
                }
                _ => None,
            };
            let next_part = (0..parts.open.len())
                .filter(|&i| !kept[i] && parts.open[i].triangles.len() <= left)
                .map(|i| {
                    (
                        parts.open[i].value / parts.open[i].triangles.len() as f32,
                        Pick::Open(i),
                    )
                });
            let next_hull = convex.iter().enumerate().flat_map(|(c, part)| {
                let (had, had_tris) = match hull_of[c] {
                    Some(l) => (part.hulls[l].value, part.hulls[l].triangles.len()),
                    None => (0.0, 0),
                };
                let from = hull_of[c].map_or(0, |l| l + 1);
                part.hulls.iter().enumerate().skip(from).filter_map(move |(l, h)| {
                    let more = h.triangles.len().saturating_sub(had_tris);
                    (more > 0 && more <= left).then(|| ((h.value - had) / more as f32, Pick::Hull(c, l)))
                })
            });
            // Ties go to the first candidate: boxes, then open parts, then hulls, each in order.
            let best = next_box
                .into_iter()
                .chain(next_part)
                .chain(next_hull)
                .reduce(|best, x| if x.0 > best.0 { x } else { best });
            let Some((per_triangle, pick)) = best else { break };
            let first = *first.get_or_insert(per_triangle);
            let gains = per_triangle > first * config.min_gain;
            if !gains {
                break;
            }
            match pick {
                Pick::Box(b) => {
                    grid.as_ref().expect("a box needs the grid").cover(&mut uncovered, &b);
                    boxes.push(b);
                    left -= 12;
                }
                Pick::Open(part) => {
                    kept[part] = true;
                    left -= parts.open[part].triangles.len();
                }
                Pick::Hull(c, l) => {
                    let had = hull_of[c].map_or(0, |h| convex[c].hulls[h].triangles.len());
                    left -= convex[c].hulls[l].triangles.len() - had;
                    hull_of[c] = Some(l);
                }
            }
        }
        if boxes.is_empty() && !kept.contains(&true) && hull_of.iter().all(Option::is_none) {
            return Err(if parts.solid.is_empty() && convex.is_empty() {
                NoVirtual::NoSolid {
                    open_edges: parts.open_edges,
                }
            } else {
                NoVirtual::TooThin {
                    resolution: config.resolution,
                }
            });
        }
        let (mut positions, mut triangles) = match &grid {
            Some(g) => box_meshes(g, &boxes),
            None => (Vec::new(), Vec::new()),
        };
        let mut convex_pieces: Vec<Range<u32>> = (0..boxes.len() as u32).map(|b| b * 12..b * 12 + 12).collect();
        let p = mesh.positions();
        let push = |positions: &mut Vec<Vec3>, triangles: &mut Vec<[u32; 3]>, corners: [Vec3; 3]| {
            let base = positions.len() as u32;
            positions.extend(corners);
            triangles.push([base, base + 1, base + 2]);
        };
        for (part, _) in parts.open.iter().zip(&kept).filter(|(_, &k)| k) {
            for &t in &part.triangles {
                push(
                    &mut positions,
                    &mut triangles,
                    mesh.triangles()[t as usize].map(|i| p[i as usize]),
                );
            }
        }
        for (part, level) in convex.iter().zip(&hull_of) {
            if let Some(l) = level {
                let start = triangles.len() as u32;
                for &t in &part.hulls[*l].triangles {
                    push(&mut positions, &mut triangles, t);
                }
                convex_pieces.push(start..triangles.len() as u32);
            }
        }
        let covered = inside.iter().zip(&uncovered).filter(|(&i, &u)| i && !u).count();
        let stand_in = Mesh::new(format!("{} (virtual)", mesh.name()), positions, triangles)?;
        let coverage = axis_coverage(&stand_in, mesh.bounds()) / axis_coverage(mesh, mesh.bounds()).max(1.0);
        if coverage < config.min_coverage {
            return Err(NoVirtual::TooLittleCoverage {
                kept: 100.0 * coverage,
                needed: 100.0 * config.min_coverage,
            });
        }
        Ok(VirtualOccluder {
            mesh: stand_in,
            convex_pieces,
            boxes: boxes.len(),
            coverage,
            floor: (parts.capped && !boxes.is_empty()).then_some(parts.floor),
            inside_share: if total == 0 { 0.0 } else { covered as f32 / total as f32 },
        })
    }
}

/// What the greedy bake takes next.
enum Pick {
    /// A box of inside cells.
    Box(CellBox),
    /// An open part, whole.
    Open(usize),
    /// Convex part `.0`'s hull `.1` (replacing a smaller one taken before).
    Hull(usize, usize),
}

/// Samples covered by `mesh` in three orthographic views along the axes,
/// 64² sample centres over `bounds` each.
fn axis_coverage(mesh: &Mesh, bounds: Aabb) -> f32 {
    const N: usize = 64;
    let p = mesh.positions();
    let (min, size) = (bounds.min, bounds.extent().max(Vec3::splat(1e-30)));
    let mut covered = 0;
    for axis in 0..3 {
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        let mut bits = vec![false; N * N];
        for t in mesh.triangles() {
            let q = t.map(|i| {
                let w = (p[i as usize] - min) / size * N as f32;
                (w[u], w[v])
            });
            let area = (q[1].0 - q[0].0) * (q[2].1 - q[0].1) - (q[1].1 - q[0].1) * (q[2].0 - q[0].0);
            if area == 0.0 {
                continue;
            }
            let lo = |k: usize| {
                (q.iter()
                    .map(|c| if k == 0 { c.0 } else { c.1 })
                    .fold(f32::MAX, f32::min)
                    - 0.5)
                    .ceil()
                    .max(0.0) as usize
            };
            let hi = |k: usize| {
                ((q.iter()
                    .map(|c| if k == 0 { c.0 } else { c.1 })
                    .fold(f32::MIN, f32::max)
                    - 0.5)
                    .floor()
                    .max(-1.0)
                    + 1.0)
                    .min(N as f32) as usize
            };
            for y in lo(1)..hi(1) {
                for x in lo(0)..hi(0) {
                    let (sx, sy) = (x as f32 + 0.5, y as f32 + 0.5);
                    let side = |a: (f32, f32), b: (f32, f32)| {
                        ((b.0 - a.0) * (sy - a.1) - (b.1 - a.1) * (sx - a.0)) * area.signum()
                    };
                    if side(q[0], q[1]) >= 0.0 && side(q[1], q[2]) >= 0.0 && side(q[2], q[0]) >= 0.0 {
                        bits[y * N + x] = true;
                    }
                }
            }
        }
        covered += bits.iter().filter(|&&b| b).count();
    }
    covered as f32
}

/// A unit UV sphere for tests: poles on ±y, `n - 1` rings of `2n` vertices,
/// wound outward.
#[cfg(test)]
pub(super) fn uv_sphere(n: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut p = vec![Vec3::Y];
    let mut t = Vec::new();
    for s in 1..n {
        let phi = s as f32 / n as f32 * std::f32::consts::PI;
        for i in 0..2 * n {
            let th = i as f32 / (2 * n) as f32 * std::f32::consts::TAU;
            p.push(Vec3::new(phi.sin() * th.cos(), phi.cos(), phi.sin() * th.sin()));
        }
    }
    p.push(-Vec3::Y);
    let ring = |s: u32, i: u32| 1 + (s - 1) * 2 * n + i % (2 * n);
    let south = p.len() as u32 - 1;
    for i in 0..2 * n {
        t.push([0, ring(1, i + 1), ring(1, i)]);
        t.push([south, ring(n - 1, i), ring(n - 1, i + 1)]);
        for s in 1..n - 1 {
            t.push([ring(s, i), ring(s, i + 1), ring(s + 1, i + 1)]);
            t.push([ring(s, i), ring(s + 1, i + 1), ring(s + 1, i)]);
        }
    }
    (p, t)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube_mesh(min: Vec3, max: Vec3, open_bottom: bool) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let (mut p, mut t) = (Vec::new(), Vec::new());
        push_box(&mut p, &mut t, min, max);
        if open_bottom {
            // Face 2 is -y (corners 0, 1, 5, 4).
            t.drain(4..6);
        }
        (p, t)
    }

    fn sphere(n: u32) -> Mesh {
        let (p, t) = uv_sphere(n);
        Mesh::new("sphere", p, t).unwrap()
    }

    /// Every corner of `v` on the centre's side of the plane of every face
    /// of `m` but those touching vertex `skip`.
    fn assert_inside_faces(m: &Mesh, v: &VirtualOccluder, skip: Option<u32>) {
        let q = m.positions();
        for p in v.mesh().positions() {
            for t in m.triangles().iter().filter(|t| skip.is_none_or(|s| !t.contains(&s))) {
                let [a, b, c] = t.map(|i| q[i as usize]);
                let n = (b - a).cross(c - a);
                if n.length() > 1e-6 {
                    assert_eq!((*p - a).dot(n) > 0.0, (-a).dot(n) > 0.0, "{p}");
                }
            }
        }
    }

    #[test]
    fn a_convex_sphere_gets_a_hull_that_keeps_its_coverage() {
        let m = sphere(24);
        let v = VirtualOccluder::bake(&m, &VirtualConfig::default()).unwrap();
        assert!(v.coverage() > 0.85, "{}", v.coverage());
        assert!(
            v.mesh().triangle_count() * 20 <= m.triangle_count(),
            "{}",
            v.mesh().triangle_count()
        );
        assert!(v.floor().is_none());
        // No grid cells: the hull is the whole stand-in.
        assert_eq!(v.inside_share(), 0.0);
        assert_inside_faces(&m, &v, None);
    }

    #[test]
    fn a_dented_sphere_gets_boxes_inside_it_but_they_keep_too_little_coverage() {
        // One vertex pushed halfway to the centre: no longer convex, so no hull.
        let m = sphere(24);
        let mut p = m.positions().to_vec();
        p[300] *= 0.5;
        let m = Mesh::new("dented sphere", p, m.triangles().to_vec()).unwrap();
        assert!(matches!(
            VirtualOccluder::bake(&m, &VirtualConfig::default()),
            Err(NoVirtual::TooLittleCoverage { .. })
        ));
        let any_coverage = VirtualConfig {
            min_coverage: 0.0,
            ..VirtualConfig::default()
        };
        let v = VirtualOccluder::bake(&m, &any_coverage).unwrap();
        assert!(v.coverage() > 0.4 && v.coverage() < 0.8, "{}", v.coverage());
        assert!(
            v.mesh().triangle_count() * 20 <= m.triangle_count(),
            "{}",
            v.mesh().triangle_count()
        );
        assert!(v.floor().is_none());
        assert!(v.inside_share() > 0.3, "{}", v.inside_share());
        // The boxes lie inside: on the centre's side of every face away from the dent.
        assert_inside_faces(&m, &v, Some(300));
    }

    /// `t` with an even number of copies of its first triangle added (edge
    /// parities unchanged) until it has `n` triangles or more.
    fn padded(mut t: Vec<[u32; 3]>, n: usize) -> Vec<[u32; 3]> {
        while t.len() < n {
            t.extend([t[0], t[0]]);
        }
        t
    }

    #[test]
    fn an_open_bottom_box_is_capped_by_its_floor_and_an_open_side_is_not() {
        let (p, mut t) = cube_mesh(Vec3::ZERO, Vec3::splat(2.0), false);
        let closed = Mesh::new("closed", p.clone(), padded(t.clone(), 400)).unwrap();
        assert_eq!(
            VirtualOccluder::bake(&closed, &VirtualConfig::default())
                .unwrap()
                .floor(),
            None
        );
        let (_, bottomless) = cube_mesh(Vec3::ZERO, Vec3::splat(2.0), true);
        let open_bottom = Mesh::new("open bottom", p.clone(), padded(bottomless, 400)).unwrap();
        let v = VirtualOccluder::bake(&open_bottom, &VirtualConfig::default()).unwrap();
        assert_eq!(v.floor(), Some(0.0));
        // Open on a side instead (face 0 is -z): no solid.
        t.drain(0..2);
        let open_side = Mesh::new("open side", p, padded(t, 400)).unwrap();
        assert!(matches!(
            VirtualOccluder::bake(&open_side, &VirtualConfig::default()),
            Err(NoVirtual::NoSolid { open_edges: 3 })
        ));
    }

    #[test]
    fn cheap_and_flat_meshes_are_refused_with_a_reason() {
        let (p, t) = cube_mesh(Vec3::ZERO, Vec3::ONE, false);
        let m = Mesh::new("cube", p, t).unwrap();
        assert!(matches!(
            VirtualOccluder::bake(&m, &VirtualConfig::default()),
            Err(NoVirtual::TooFewTriangles { triangles: 12, .. })
        ));
        let flat = Mesh::new("slivers", vec![Vec3::ZERO, Vec3::X, Vec3::Z], vec![[0, 1, 2]; 1000]).unwrap();
        assert!(VirtualOccluder::bake(&flat, &VirtualConfig::default()).is_err());
        let bad = VirtualConfig {
            resolution: 1,
            ..VirtualConfig::default()
        };
        assert!(matches!(
            VirtualOccluder::bake(&sphere(8), &bad),
            Err(NoVirtual::BadConfig(_))
        ));
    }

    #[test]
    fn prefix_sums_count_like_a_loop() {
        let n = 5;
        let cells: Vec<bool> = (0..n * n * n).map(|c| (c * 7919) % 3 == 0).collect();
        let s = PrefixSum::new([n; 3], &cells);
        let b = CellBox {
            lo: [1, 0, 2],
            hi: [4, 3, 5],
        };
        let mut brute = 0;
        for k in 2..5 {
            for j in 0..3 {
                for i in 1..4 {
                    brute += usize::from(cells[(k * n + j) * n + i]);
                }
            }
        }
        assert_eq!(s.count(&b), brute);
    }
}
