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
//! 1. **Solids.** Vertices are welded by position and the mesh split into
//!    connected components. A component whose every edge has an even number
//!    of triangles is a closed surface (mod 2) and bounds a solid by parity;
//!    so does one whose odd edges all lie in the mesh's floor plane (an
//!    open-bottomed building, a tree on the ground), closed there by a
//!    virtual cap that rays from above the floor never reach. Other
//!    components (open pipes, sheets) enclose nothing and give nothing.
//! 2. **Convex solids** get hulls instead of cells: a closed component
//!    proven convex (`convex_part.rs`) offers hulls of a few of its own
//!    vertices, shrunk a hair, each inside it because the body is convex
//!    (a sphere's boxes keep 55 % of its axis coverage, its 48-point hull 88 %).
//! 3. **Inside cells.** A grid of `resolution³` cells over the mesh's box.
//!    A cell is a *surface* cell when a solid's triangle touches it (the
//!    separating-axis test on the cell grown by a margin); a cell that is not
//!    is wholly inside or wholly outside each solid, and its centre's parity
//!    along a vertical ray says which. Orientation tests whose sign rounding
//!    could flip drop the whole column, so no cell is called inside by luck.
//! 4. **Boxes.** Greedy by area per triangle: the box grown from seed cells
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

use super::convex_part::{convex_part, ConvexPart};
use super::draw::draw_stand_in;
use crate::geom::{Aabb, Eye, Frustum};
use crate::occlusion::details::{number_welded, weld};
use crate::occlusion::{OcclusionBuffer, OcclusionError};
use crate::scene::{Mesh, SceneError};
use glam::{Mat4, Vec3};
use std::collections::HashMap;
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
    /// Queues the stand-in in `buffer` as the cullers draw it, placed by
    /// `model_to_clip` (the buffer's clip convention): its boxes as their
    /// shrunk silhouettes ([`OcclusionBuffer::render_convex_stand_in`]), the
    /// rest as stand-in triangles ([`OcclusionBuffer::render_stand_in_triangles`]).
    pub fn render(&self, buffer: &mut impl OcclusionBuffer, model_to_clip: &Mat4) -> Result<(), OcclusionError> {
        draw_stand_in(
            buffer,
            self.mesh.positions(),
            self.mesh.triangles(),
            self.box_pieces(),
            model_to_clip,
            true,
        )
    }

    /// The triangle ranges of [`VirtualOccluder::mesh`] that are boxes, in order.
    pub(crate) fn box_pieces(&self) -> &[Range<u32>] {
        &self.convex_pieces[..self.boxes]
    }

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

    /// Whether the stand-in may replace the original of an object placed by
    /// `transform` with world box `world_box`, seen from `eye` through
    /// `frustum`: the box wholly beyond the near plane (the eye is outside
    /// the solids and nothing of the original is clipped), and above the
    /// floor when there is one.
    pub fn usable(&self, transform: &Mat4, world_box: &Aabb, eye: &Eye, frustum: &Frustum) -> bool {
        if !frustum.beyond_near(world_box) {
            return false;
        }
        let Some(floor) = self.floor else {
            return true;
        };
        let inverse = transform.inverse();
        match eye {
            Eye::Point(p) => inverse.transform_point3(*p).y > floor,
            // Depth grows along `d`: rays come down onto the floor from above.
            Eye::Direction(d) => inverse.transform_vector3(*d).y < 0.0,
        }
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

/// An open component (it encloses nothing): kept whole or not at all.
struct OpenPart {
    triangles: Vec<u32>,
    /// Area shown along the three axes: Σ area · (|n.x| + |n.y| + |n.z|).
    value: f32,
}

/// A mesh's connected components: the solid ones' triangles, and the open ones.
struct Parts {
    /// `(triangle index, solid index)`.
    solid: Vec<(u32, u32)>,
    count: u32,
    open: Vec<OpenPart>,
    /// Whether some solid is closed by a floor cap.
    capped: bool,
    floor: f32,
    /// Odd edges outside the floor plane, over all components.
    open_edges: usize,
    /// Welded vertex positions, and every triangle over them.
    welded_positions: Vec<Vec3>,
    welded: Vec<[u32; 3]>,
}

impl Parts {
    fn find(mesh: &Mesh) -> Parts {
        let p = mesh.positions();
        // Weld by position (-0.0 and 0.0 one point), numbered in order of first appearance.
        let (weld, welded_count) = number_welded(&weld(p));
        let tris: Vec<[u32; 3]> = mesh.triangles().iter().map(|t| t.map(|i| weld[i as usize])).collect();
        // Components over welded vertices.
        let mut parent: Vec<u32> = (0..welded_count as u32).collect();
        fn root(parent: &mut [u32], mut x: u32) -> u32 {
            while parent[x as usize] != x {
                parent[x as usize] = parent[parent[x as usize] as usize];
                x = parent[x as usize];
            }
            x
        }
        for t in &tris {
            let a = root(&mut parent, t[0]);
            for &v in &t[1..] {
                let b = root(&mut parent, v);
                if a != b {
                    parent[b as usize] = a;
                }
            }
        }
        let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
        for t in &tris {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                if a != b {
                    *edges.entry((a.min(b), a.max(b))).or_default() += 1;
                }
            }
        }
        let floor = mesh.bounds().min.y;
        let mut position = vec![Vec3::ZERO; welded_count];
        for (i, &w) in weld.iter().enumerate() {
            position[w as usize] = p[i];
        }
        // Per component root: does it have odd edges off the floor, or on it?
        let mut open: HashMap<u32, bool> = HashMap::new();
        let mut on_floor: HashMap<u32, bool> = HashMap::new();
        let mut open_edges = 0;
        for (&(a, b), &n) in &edges {
            if n % 2 == 1 {
                let r = root(&mut parent, a);
                if position[a as usize].y == floor && position[b as usize].y == floor {
                    on_floor.insert(r, true);
                } else {
                    open.insert(r, true);
                    open_edges += 1;
                }
            }
        }
        let mut solid_of: HashMap<u32, u32> = HashMap::new();
        let mut open_of: HashMap<u32, usize> = HashMap::new();
        let (mut solid, mut open_parts) = (Vec::new(), Vec::<OpenPart>::new());
        let mut capped = false;
        for (i, t) in tris.iter().enumerate() {
            let r = root(&mut parent, t[0]);
            if open.contains_key(&r) {
                let next = open_parts.len();
                let k = *open_of.entry(r).or_insert(next);
                if k == next {
                    open_parts.push(OpenPart {
                        triangles: Vec::new(),
                        value: 0.0,
                    });
                }
                let [a, b, c] = mesh.triangles()[i].map(|v| p[v as usize]);
                open_parts[k].triangles.push(i as u32);
                open_parts[k].value += (b - a).cross(c - a).abs().element_sum() * 0.5;
                continue;
            }
            capped |= on_floor.contains_key(&r);
            let next = solid_of.len() as u32;
            let s = *solid_of.entry(r).or_insert(next);
            solid.push((i as u32, s));
        }
        Parts {
            solid,
            count: solid_of.len() as u32,
            open: open_parts,
            capped,
            floor,
            open_edges,
            welded_positions: position,
            welded: tris,
        }
    }

    /// Takes the provably convex solids out of [`Parts::solid`] (the grid
    /// need not find their inside cells) and returns their hulls.
    fn take_convex(&mut self) -> Vec<ConvexPart> {
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

/// The cell grid over a mesh's box: rectilinear, with planes just either
/// side of the mesh's largest axis-aligned faces (so a thin CAD plate gets
/// cells wholly inside it) and the rest split evenly.
struct Grid {
    /// Cell boundaries per axis, ascending.
    planes: [Vec<f32>; 3],
    /// Cells per axis.
    dims: [usize; 3],
    /// How far a triangle may pass outside a cell and still touch it.
    margin: Vec3,
}

/// A box of cells, half-open index ranges.
#[derive(Clone, Copy, Debug, PartialEq)]
struct CellBox {
    lo: [usize; 3],
    hi: [usize; 3],
}

impl CellBox {
    fn cells(&self) -> usize {
        (0..3).map(|a| self.hi[a] - self.lo[a]).product()
    }
}

impl Grid {
    fn new(mesh: &Mesh, resolution: u32) -> Option<Grid> {
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

    fn index(&self, i: usize, j: usize, k: usize) -> usize {
        (k * self.dims[1] + j) * self.dims[0] + i
    }

    fn len(&self) -> usize {
        self.dims.iter().product()
    }

    /// Cells wholly inside some solid.
    fn inside_cells(&self, mesh: &Mesh, solids: &Parts) -> Vec<bool> {
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
    fn cell_bounds(&self, i: usize, j: usize, k: usize) -> (Vec3, Vec3) {
        let [x, y, z] = &self.planes;
        (Vec3::new(x[i], y[j], z[k]), Vec3::new(x[i + 1], y[j + 1], z[k + 1]))
    }

    fn centre(&self, i: usize, j: usize, k: usize) -> Vec3 {
        let (lo, hi) = self.cell_bounds(i, j, k);
        (lo + hi) * 0.5
    }

    /// The cell holding `p`, clamped to the grid.
    fn cell_of(&self, p: Vec3) -> [usize; 3] {
        std::array::from_fn(|a| {
            let i = self.planes[a].partition_point(|&b| b <= p[a]);
            i.saturating_sub(1).min(self.dims[a] - 1)
        })
    }

    /// The box of inside cells that adds the most uncovered area, grown
    /// from at most 128 uncovered seed cells spread evenly in index order
    /// (deterministic), with that area.
    fn best_box(&self, inside: &PrefixSum, uncovered: &[bool]) -> Option<(f32, CellBox)> {
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
    fn cover(&self, uncovered: &mut [bool], b: &CellBox) {
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
struct PrefixSum {
    dims: [usize; 3],
    sum: Vec<u32>,
}

impl PrefixSum {
    fn new(dims: [usize; 3], cells: &[bool]) -> PrefixSum {
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

    fn count(&self, b: &CellBox) -> usize {
        let (mx, my) = (self.dims[0] + 1, self.dims[1] + 1);
        let s = |i: usize, j: usize, k: usize| i64::from(self.sum[(k * my + j) * mx + i]);
        let ([x0, y0, z0], [x1, y1, z1]) = (b.lo, b.hi);
        (s(x1, y1, z1) - s(x0, y1, z1) - s(x1, y0, z1) - s(x1, y1, z0) + s(x0, y0, z1) + s(x0, y1, z0) + s(x1, y0, z0)
            - s(x0, y0, z0)) as usize
    }
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

/// Twelve triangles a box, at the cells' outer boundaries.
fn box_meshes(grid: &Grid, boxes: &[CellBox]) -> (Vec<Vec3>, Vec<[u32; 3]>) {
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
