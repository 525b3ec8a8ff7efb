//! Quake 3 maps: IBSP version 46, loose (`.bsp`) or inside a `.pk3` (zip) archive.
//!
//! What is loaded:
//! - **Geometry** of the world model (model 0) only: polygon (type 1) and mesh
//!   (type 3) faces as triangle lists via their mesh vertex indices; Bezier
//!   patches (type 2) tessellated at [`BspOptions::tessellation`] segments per
//!   3 × 3 control-point quadratic patch; billboards (type 4) skipped.
//! - **Skipped surfaces:** shader surface flag `SURF_NODRAW` (0x80), the name
//!   `noshader`, and the editor's tool shaders under `common/` (caulk, nodraw,
//!   hint, skip, clip, trigger, portals…).
//! - **Sky** (surface flag `SURF_SKY` 0x4, or a shader name with `skies/`): an
//!   opaque wall, as the player sees it — the game paints the sky box there, and
//!   its `vis` takes sky as a wall — in objects of their own, after the rest
//!   ([`BspOptions::sky`]; [`SkyFaces::Open`] leaves them undrawn, so the renderer
//!   sees through the sky into the space around the level).
//! - **See-through surfaces** (content flags `CONTENTS_TRANSLUCENT` 0x20000000,
//!   water 0x20, lava 0x8, slime 0x10, fog 0x40, or a shader name with `glass`,
//!   `grate`, `fence`, `foliage`, `leaves`, `forcefield`, `water`, `fog`, `trans`…)
//!   are loaded in objects of their own, marked [`hom::scene::Object::occluder`] `= false`.
//! - **Units:** Quake's right-handed Z-up inches become hom's right-handed +Y-up
//!   metres: `(x, y, z) → (x, z, −y) × 0.0254` (a rotation, so handedness is kept).
//! - **Objects:** faces are never cut; they are grouped by [`crate::split`]:
//!   opaque faces first, then see-through ones, then sky, each in the splitter's
//!   documented order. Object ids are that order. Their parents
//!   ([`hom::scene::Object::parent`]) are what the map loads as with
//!   splitting off: `world_0`, then `see_through_K` and `sky_K` where the map has them.
//! - **Spawn points** (`info_player_*` but `info_player_intermission`,
//!   `team_CTF_*spawn`, `team_CTF_*player`) and a walkthrough through them.
//! - **The map's PVS:** [`BspMap::cluster_of`], [`BspMap::cluster_visible`] and
//!   the clusters of every object ([`BspMap::object_clusters`]).
//!
//! Lump offsets need not be 4-aligned (records are read byte by byte), but every
//! lump's length must be a whole number of its records. Every count, offset and index is checked against the file before use, and the
//! output is capped ([`BspOptions::max_triangles`], [`BspOptions::max_bytes`]), so a
//! hostile file gives a [`BspError`], never a panic or unbounded memory.

mod entities;
mod error;
mod pk3;
mod portals;
mod pvs;

pub use entities::Entity;
pub use error::BspError;
pub use pk3::{pk3_maps, read_pk3};
pub use portals::PortalPvs;

use pk3::{entry_map_name, read_capped, Capped};
use pvs::{read_pvs, Pvs};

use crate::camera_path::{CameraPath, PathFrame};
use crate::split::{group_pieces, Piece, SplitOptions};
use crate::LoadError;
use glam::{Mat4, Vec3};
use hom::geom::Aabb;
use hom::scene::{Mesh, Scene, SceneBuilder};
use std::path::Path;

/// The only BSP version read.
pub const VERSION: i32 = 46;
/// Metres per Quake unit (one inch).
pub const INCH: f32 = 0.0254;
/// Highest accepted [`BspOptions::tessellation`].
pub const MAX_TESSELLATION: u32 = 32;
/// Most spawn points [`BspMap::camera_path`] visits.
pub const MAX_PATH_SPAWNS: usize = 1024;
/// Most frames of [`BspMap::camera_path`] (a longer tour is walked faster).
pub const MAX_PATH_FRAMES: usize = 100_000;

/// Near plane of [`BspMap::camera_path`], metres.
pub const NEAR: f32 = 0.05;

/// Clearance the walk keeps in front of the eye, metres (see [`BspMap::camera_path`]).
pub const CLEARANCE: f32 = 0.1;
/// Quake 3's eye height above a player's origin (`DEFAULT_VIEWHEIGHT`, 26 units), metres.
pub const VIEW_HEIGHT: f32 = 26.0 * INCH;

const HEADER: usize = 8 + 17 * 8;
const LUMP_NAMES: [&str; 17] = [
    "entities",
    "textures",
    "planes",
    "nodes",
    "leafs",
    "leaffaces",
    "leafbrushes",
    "models",
    "brushes",
    "brushsides",
    "vertexes",
    "meshverts",
    "effects",
    "faces",
    "lightmaps",
    "lightvols",
    "visdata",
];
const ENTITIES: usize = 0;
const TEXTURES: usize = 1;
pub(super) const PLANES: usize = 2;
pub(super) const NODES: usize = 3;
pub(super) const LEAFS: usize = 4;
const LEAFFACES: usize = 5;
const LEAFBRUSHES: usize = 6;
const BRUSHES: usize = 8;
const BRUSHSIDES: usize = 9;
const MODELS: usize = 7;
const VERTEXES: usize = 10;
const MESHVERTS: usize = 11;
const FACES: usize = 13;
pub(super) const VISDATA: usize = 16;

/// Surface flag: not drawn.
pub const SURF_NODRAW: i32 = 0x80;
/// Surface flag: sky.
pub const SURF_SKY: i32 = 0x4;
/// Content flags that make a surface see-through (translucent, lava, slime, water, fog).
pub const SEE_THROUGH_CONTENTS: i32 = 0x2000_0000 | 0x8 | 0x10 | 0x20 | 0x40;
/// Shader name parts (lower case) that mark a see-through surface.
pub const SEE_THROUGH_NAMES: &[&str] = &[
    "glass",
    "grate",
    "fence",
    "foliage",
    "leaves",
    "leaf",
    "forcefield",
    "water",
    "fog",
    "trans",
    "window",
    "mesh",
    "chain",
    "web",
    "flame",
    "beam",
    "liquid",
    "lava",
    "slime",
];
/// Tool shaders under `common/` that are never drawn (name prefixes after `common/`).
pub const TOOL_SHADERS: &[&str] = &[
    "caulk",
    "nodraw",
    "hint",
    "skip",
    "clip",
    "full_clip",
    "weapclip",
    "botclip",
    "playerclip",
    "trigger",
    "areaportal",
    "clusterportal",
    "donotenter",
    "origin",
    "nodrop",
    "invisible",
    "lightgrid",
    "antiportal",
    "monsterclip",
    "missileclip",
    "slick",
    "noimpact",
];

/// How to load a map.
#[derive(Clone, Debug, PartialEq)]
pub struct BspOptions {
    /// For a `.pk3`: the map to load (`NAME` for `maps/NAME.bsp`, case-insensitive).
    /// `None` takes the only map, and is an error listing them when there are several.
    pub map: Option<String>,
    /// Segments per side of each 3 × 3 Bezier patch (1..=[`MAX_TESSELLATION`]).
    pub tessellation: u32,
    /// How faces are grouped into objects.
    pub split: SplitOptions,
    /// Largest `.bsp` read, bytes (the whole file, or the pk3 entry uncompressed).
    pub max_bytes: u64,
    /// Most triangles (and leaf→face references) produced.
    pub max_triangles: usize,
    /// Eye height of the walkthrough above each spawn origin, metres.
    pub eye_height: f32,
    /// Walking speed of the walkthrough, metres per second (30 frames a second).
    pub speed: f32,
    /// What sky faces are.
    pub sky: SkyFaces,
}

/// What a map's sky faces (`SURF_SKY`) are in the scene.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SkyFaces {
    /// Opaque walls (the default): what the player sees, the sky box painted
    /// on them, and what the map's own `vis` assumes. They are occluders
    /// like any wall, in objects named `sky_ID`.
    #[default]
    Opaque,
    /// Not drawn: sight passes through them into the solid space around the
    /// level (and the other areas seen across it), as before 2026-12-07.
    Open,
}

impl Default for BspOptions {
    fn default() -> Self {
        BspOptions {
            map: None,
            tessellation: 5,
            split: SplitOptions::default(),
            max_bytes: 256 << 20,
            max_triangles: 8 << 20,
            eye_height: VIEW_HEIGHT,
            speed: 8.0,
            sky: SkyFaces::Opaque,
        }
    }
}

/// A player spawn point.
#[derive(Clone, Debug, PartialEq)]
pub struct SpawnPoint {
    /// Entity class (`info_player_deathmatch`, `team_CTF_redspawn`…).
    pub classname: String,
    /// Origin in hom's coordinates (metres, +Y up).
    pub origin: Vec3,
    /// Facing, degrees counter-clockwise about Quake's +Z from Quake's +X (the `angle` key; 0 if absent).
    pub angle_deg: f32,
}

impl SpawnPoint {
    /// The facing direction in hom's coordinates (horizontal, unit length).
    pub fn direction(&self) -> Vec3 {
        let a = self.angle_deg.to_radians();
        to_hom([a.cos(), a.sin(), 0.0]) / INCH
    }
}

/// A loaded map: the scene, its spawn points and its PVS.
#[derive(Clone, Debug)]
pub struct BspMap {
    /// The world as hom objects (see the module doc for ids and what is skipped).
    pub scene: Scene,
    /// Player spawn points, in entity order.
    pub spawns: Vec<SpawnPoint>,
    /// Every entity of the map, in file order.
    pub entities: Vec<Entity>,
    /// For each object (by id): the sorted clusters of the leaves holding its faces.
    /// Empty when no leaf with a cluster holds them.
    pub object_clusters: Vec<Vec<i32>>,
    /// For each object (by id): the sorted clustered leaves whose face lists
    /// hold its faces (the cells it lies in for [`BspMap::leaf_portals`]).
    pub object_leaves: Vec<Vec<u32>>,
    /// Eye height used by [`BspMap::camera_path`], metres above each spawn origin.
    pub eye_height: f32,
    /// Speed used by [`BspMap::camera_path`], metres per second.
    pub speed: f32,
    pvs: Pvs,
    /// For each object (by id): the leaves without a cluster whose face
    /// lists hold its faces (sight may reach some: see `portals.rs`).
    object_solid_leaves: Vec<Vec<u32>>,
    /// Per leaf: the brushes it lists that tell whether the compiler filled
    /// it for its `vis` alone (see `portals.rs`).
    leaf_brushes: Vec<LeafBrushes>,
    /// Per opaque brush (contents solid, not translucent): its sides'
    /// planes, indices into the tree's planes (normals pointing out).
    brush_planes: Vec<Vec<u32>>,
}

/// Content flag: solid.
const CONTENTS_SOLID: i32 = 0x1;
/// Content flag: translucent (the compiler lets sight through such brushes).
const CONTENTS_TRANSLUCENT: i32 = 0x2000_0000;

/// Quake (Z-up inches) to hom (+Y-up metres).
pub fn to_hom(q: [f32; 3]) -> Vec3 {
    Vec3::new(q[0], q[2], -q[1]) * INCH
}

/// hom (+Y-up metres) to Quake (Z-up inches); the inverse of [`to_hom`].
pub fn to_quake(p: Vec3) -> [f32; 3] {
    let q = p / INCH;
    [q.x, -q.z, q.y]
}

impl BspMap {
    /// The cluster of the leaf holding `point` (hom coordinates), `None` in solid
    /// space or outside the map (cluster −1).
    pub fn cluster_of(&self, point: Vec3) -> Option<i32> {
        let leaf = self.leaf_of(point)?;
        self.pvs.leaf_cluster.get(leaf as usize).copied().filter(|&c| c >= 0)
    }

    /// The leaf of the map's BSP tree holding `point` (hom coordinates; a
    /// point on a node's plane lies in front of it); `None` for a point that
    /// is not finite.
    pub fn leaf_of(&self, point: Vec3) -> Option<u32> {
        let pvs = &self.pvs;
        if !point.is_finite() {
            return None;
        }
        let q = to_quake(point);
        let mut child: i32 = if pvs.nodes.is_empty() { -1 } else { 0 };
        // Indices are checked at load; the step bound stops a cyclic tree.
        for _ in 0..=pvs.nodes.len() {
            if child < 0 {
                return u32::try_from(-(child as i64) - 1).ok();
            }
            let (plane, front, back) = pvs.nodes[child as usize];
            let (n, d) = pvs.planes[plane as usize];
            let side = n[0] * q[0] + n[1] * q[1] + n[2] * q[2] - d;
            child = if side >= 0.0 { front } else { back };
        }
        None
    }

    /// Is `eye` (hom coordinates) at least `clearance` metres from every
    /// leaf without a cluster (solid space or the void)? The box of that
    /// half-size around it must reach no such leaf. A camera closer to (or
    /// inside) them may see through walls that are drawn from one side only
    /// of the solid, so PVS checks take their viewpoints where this holds.
    pub fn is_open(&self, eye: Vec3, clearance: f32) -> bool {
        if !eye.is_finite() || !clearance.is_finite() {
            return false;
        }
        let (a, b) = (to_quake(eye - clearance), to_quake(eye + clearance));
        let lo = glam::DVec3::from_array([0, 1, 2].map(|k| a[k].min(b[k]) as f64));
        let hi = glam::DVec3::from_array([0, 1, 2].map(|k| a[k].max(b[k]) as f64));
        // `cluster_of`'s rule (side ≥ 0 is the front), a hair wide; a cyclic
        // tree claims nothing.
        self.pvs.leaves_touching(lo, hi, 1e-2).is_some_and(|leaves| {
            leaves
                .iter()
                .all(|&l| self.pvs.leaf_cluster.get(l as usize).is_some_and(|&c| c >= 0))
        })
    }

    /// Clusters in the map's visibility data (0 when it has none).
    pub fn cluster_count(&self) -> usize {
        self.pvs.clusters
    }

    /// Does the map's PVS mark cluster `to` potentially visible from cluster `from`?
    /// Without visibility data everything is visible; a cluster outside the data is not.
    pub fn cluster_visible(&self, from: i32, to: i32) -> bool {
        let pvs = &self.pvs;
        if pvs.clusters == 0 {
            return true;
        }
        if from < 0 || to < 0 || from as usize >= pvs.clusters || to as usize >= pvs.clusters {
            return false;
        }
        let (from, to) = (from as usize, to as usize);
        pvs.bits[from * pvs.row + to / 8] & (1 << (to % 8)) != 0
    }

    /// Is object `id` potentially visible from cluster `from`: does any cluster
    /// holding its faces pass [`BspMap::cluster_visible`]? An object in no cluster
    /// counts as visible (the PVS says nothing about it).
    ///
    /// # Panics
    /// If `id` is not an object id of the scene.
    pub fn object_visible_from(&self, id: u32, from: i32) -> bool {
        let clusters = &self.object_clusters[id as usize];
        clusters.is_empty() || clusters.iter().any(|&c| self.cluster_visible(from, c))
    }

    /// The map's far plane in metres: the worldspawn key `_farplanedist` (Quake
    /// units), which q3map2 also uses to drop farther clusters from the PVS (the
    /// game hides them in fog). `None` when absent, not a number or not positive.
    pub fn far_plane(&self) -> Option<f32> {
        let world = self
            .entities
            .iter()
            .find(|e| entities::get(e, "classname") == Some("worldspawn"))?;
        let units: f32 = entities::get(world, "_farplanedist")?.trim().parse().ok()?;
        (units.is_finite() && units > 0.0).then_some(units * INCH)
    }

    /// Is the eye in a cluster, and the space just in front of it (a box of
    /// ±[`CLEARANCE`] around the near plane, out to 2.5 × [`CLEARANCE`] ahead) too?
    fn clear_ahead(&self, eye: Vec3, target: Vec3) -> bool {
        let d = (target - eye).normalize_or_zero();
        let r = d.cross(Vec3::Y).normalize_or_zero();
        let u = r.cross(d);
        let c = CLEARANCE;
        let probes = [
            eye,
            eye + d * (2.5 * c),
            eye + (d + r + u) * c,
            eye + (d + r - u) * c,
            eye + (d - r + u) * c,
            eye + (d - r - u) * c,
        ];
        probes.iter().all(|&p| self.cluster_of(p).is_some())
    }

    /// A walkthrough from spawn point to spawn point at [`BspMap::eye_height`]:
    /// a nearest-neighbour tour starting at the first spawn (ties to the lower
    /// index), straight lines at [`BspMap::speed`] (30 frames a second), looking
    /// along the direction of travel; frames whose eye, or the space within
    /// [`CLEARANCE`] in front of it, is in solid space (no cluster: the line
    /// crosses a wall) are dropped, so the walk jumps through walls and never
    /// looks through one. The far plane is the map's [`BspMap::far_plane`] where
    /// it has one (at most 1.5 × the scene's diagonal, the default). With one spawn point, a turn on the spot
    /// starting along its `angle`. `None` without spawn points. Only the first [`MAX_PATH_SPAWNS`] spawn points
    /// are visited (the tour is quadratic in their number). A tour longer than [`MAX_PATH_FRAMES`] frames
    /// is walked faster; `None` also when the spawns are not finite.
    pub fn camera_path(&self) -> Option<CameraPath> {
        let up = Vec3::Y * self.eye_height;
        let mut eyes: Vec<Vec3> = Vec::new();
        for s in self.spawns.iter().take(MAX_PATH_SPAWNS) {
            let e = s.origin + up;
            if eyes.iter().all(|p| p.distance(e) > 0.01) {
                eyes.push(e);
            }
        }
        let bounds = self.scene.bounds();
        let diag = bounds.extent().length().max(10.0);
        let far = match self.far_plane() {
            Some(f) => f.clamp(1.0, diag * 1.5),
            None => diag * 1.5,
        };
        let lens = |frames| CameraPath {
            near: NEAR,
            far,
            ..CameraPath::new(frames)
        };
        match eyes.len() {
            0 => None,
            1 => {
                let start = self.spawns[0].direction();
                let frames = (0..120)
                    .map(|i| {
                        let rot = glam::Quat::from_rotation_y(i as f32 / 120.0 * std::f32::consts::TAU);
                        PathFrame {
                            eye: eyes[0].to_array(),
                            target: (eyes[0] + rot * start).to_array(),
                        }
                    })
                    .collect();
                Some(lens(frames))
            }
            _ => {
                let mut left: Vec<Vec3> = eyes[1..].to_vec();
                let mut tour = vec![eyes[0]];
                while !left.is_empty() {
                    let here = *tour.last().unwrap_or(&eyes[0]);
                    let (k, _) = left
                        .iter()
                        .enumerate()
                        .map(|(k, p)| (k, p.distance_squared(here)))
                        .fold((0, f32::INFINITY), |best, x| if x.1 < best.1 { x } else { best });
                    tour.push(left.remove(k));
                }
                // At most MAX_PATH_FRAMES frames, however far apart hostile spawns are.
                let length: f32 = tour.windows(2).map(|w| w[0].distance(w[1])).sum();
                if !length.is_finite() {
                    return None;
                }
                let step = (self.speed.max(0.01) / 30.0).max(length / MAX_PATH_FRAMES as f32);
                let mut frames = CameraPath::along(&tour, step, 2.0).frames;
                // Frames whose eye, or the space just in front of it, is in solid space
                // (the line crosses a wall) are dropped: a near plane inside a wall sees
                // through it, into rooms the PVS rightly hides.
                let inside = |f: &PathFrame| self.clear_ahead(Vec3::from(f.eye), Vec3::from(f.target));
                if frames.iter().any(inside) {
                    frames.retain(inside);
                }
                Some(lens(frames))
            }
        }
    }
}

/// Loads a map from a loose `.bsp`, or from a `.pk3` (chosen by extension, case-insensitive).
pub fn load(path: &Path, options: &BspOptions) -> Result<BspMap, LoadError> {
    let label = path.display().to_string();
    let wrap = |label: String| move |source| LoadError::Bsp { path: label, source };
    let is_pk3 = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("pk3"));
    if is_pk3 {
        let file = std::fs::File::open(path).map_err(|source| LoadError::Io {
            path: label.clone(),
            source,
        })?;
        let (entry, bytes) = read_pk3(std::io::BufReader::new(file), options).map_err(wrap(label.clone()))?;
        let name = entry_map_name(&entry);
        return parse(&bytes, &name, options).map_err(wrap(format!("{label}:{entry}")));
    }
    let file = std::fs::File::open(path).map_err(|source| LoadError::Io {
        path: label.clone(),
        source,
    })?;
    let bytes = read_capped(file, &label, options.max_bytes).map_err(|e| match e {
        Capped::Io(source) => LoadError::Io {
            path: label.clone(),
            source,
        },
        Capped::TooLarge(source) => wrap(label.clone())(source),
    })?;
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    parse(&bytes, &name, options).map_err(wrap(label))
}

pub(super) fn le_i32(b: &[u8], at: usize) -> i32 {
    i32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

pub(super) fn le_f32(b: &[u8], at: usize) -> f32 {
    f32::from_bits(le_i32(b, at) as u32)
}

pub(super) fn vec3(b: &[u8], at: usize) -> [f32; 3] {
    [le_f32(b, at), le_f32(b, at + 4), le_f32(b, at + 8)]
}

/// The lump directory of a checked header.
pub(super) struct Lumps<'a> {
    data: &'a [u8],
    dir: [(usize, usize); 17],
}

impl<'a> Lumps<'a> {
    fn new(data: &'a [u8]) -> Result<Lumps<'a>, BspError> {
        if data.len() < HEADER {
            if data.len() >= 4 && &data[..4] != b"IBSP" {
                return Err(BspError::BadMagic {
                    found: [data[0], data[1], data[2], data[3]],
                });
            }
            return Err(BspError::Truncated { len: data.len() });
        }
        if &data[..4] != b"IBSP" {
            return Err(BspError::BadMagic {
                found: [data[0], data[1], data[2], data[3]],
            });
        }
        let version = le_i32(data, 4);
        if version != VERSION {
            return Err(BspError::UnsupportedVersion { version });
        }
        let mut dir = [(0, 0); 17];
        for (k, d) in dir.iter_mut().enumerate() {
            let offset = le_i32(data, 8 + k * 8) as i64;
            let length = le_i32(data, 12 + k * 8) as i64;
            if offset < 0 || length < 0 || offset + length > data.len() as i64 {
                return Err(BspError::LumpOutOfBounds {
                    lump: LUMP_NAMES[k],
                    offset,
                    length,
                    file_len: data.len(),
                });
            }
            *d = (offset as usize, length as usize);
        }
        Ok(Lumps { data, dir })
    }

    pub(super) fn bytes(&self, lump: usize) -> &'a [u8] {
        let (o, l) = self.dir[lump];
        &self.data[o..o + l]
    }

    /// The lump as records of `size` bytes.
    pub(super) fn records(&self, lump: usize, size: usize) -> Result<std::slice::ChunksExact<'a, u8>, BspError> {
        let b = self.bytes(lump);
        if !b.len().is_multiple_of(size) {
            return Err(BspError::LumpSize {
                lump: LUMP_NAMES[lump],
                length: b.len(),
                record: size,
            });
        }
        Ok(b.chunks_exact(size))
    }
}

/// Checks that `first..first + count` lies in `0..len`.
pub(super) fn range(
    what: &'static str,
    record: usize,
    field: &'static str,
    first: i32,
    count: i32,
    len: usize,
) -> Result<std::ops::Range<usize>, BspError> {
    let (f, c) = (first as i64, count as i64);
    if f < 0 || c < 0 || f + c > len as i64 {
        return Err(BspError::RangeOutOfBounds {
            what,
            record,
            field,
            first: f,
            count: c,
            len,
        });
    }
    Ok(f as usize..(f + c) as usize)
}

/// Checks that `value` indexes `0..len`.
pub(super) fn index(
    what: &'static str,
    record: usize,
    field: &'static str,
    value: i32,
    len: usize,
) -> Result<usize, BspError> {
    if value < 0 || value as i64 >= len as i64 {
        return Err(BspError::IndexOutOfRange {
            what,
            record,
            field,
            value: value as i64,
            len,
        });
    }
    Ok(value as usize)
}

/// What a shader means for geometry.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Surface {
    Skip,
    Opaque,
    SeeThrough,
    Sky,
}

fn classify(name: &str, flags: i32, contents: i32, sky: SkyFaces) -> Surface {
    let lower = name.to_ascii_lowercase();
    let tool = lower
        .find("common/")
        .map(|i| &lower[i + "common/".len()..])
        .is_some_and(|rest| TOOL_SHADERS.iter().any(|t| rest.starts_with(t)));
    if flags & SURF_NODRAW != 0 || lower == "noshader" || tool {
        Surface::Skip
    } else if flags & SURF_SKY != 0 || lower.contains("skies/") {
        match sky {
            SkyFaces::Opaque => Surface::Sky,
            SkyFaces::Open => Surface::Skip,
        }
    } else if contents & SEE_THROUGH_CONTENTS != 0 || SEE_THROUGH_NAMES.iter().any(|n| lower.contains(n)) {
        Surface::SeeThrough
    } else {
        Surface::Opaque
    }
}

/// What a brush of the shader `name` with content flags `contents` is to sight.
fn brush_kind(name: &str, contents: i32) -> BrushKind {
    if name.to_ascii_lowercase().ends_with("common/antiportal") {
        BrushKind::AntiPortal
    } else if contents & (CONTENTS_SOLID | CONTENTS_TRANSLUCENT) == CONTENTS_SOLID {
        BrushKind::Opaque
    } else {
        BrushKind::Other
    }
}

/// Quadratic Bezier basis at `t`.
fn bezier(t: f32) -> [f32; 3] {
    let s = 1.0 - t;
    [s * s, 2.0 * s * t, t * t]
}

/// Parses a map already in memory. `name` names the scene.
pub fn parse(data: &[u8], name: &str, options: &BspOptions) -> Result<BspMap, BspError> {
    if options.tessellation == 0 || options.tessellation > MAX_TESSELLATION {
        return Err(BspError::BadOptions {
            message: format!(
                "tessellation {} is outside 1..={MAX_TESSELLATION}",
                options.tessellation
            ),
        });
    }
    let lumps = Lumps::new(data)?;

    // Shaders: what a face of each is, and what a brush of each is.
    let (surfaces, brush_kinds): (Vec<Surface>, Vec<BrushKind>) = lumps
        .records(TEXTURES, 72)?
        .map(|r| {
            let end = r[..64].iter().position(|&b| b == 0).unwrap_or(64);
            let name = String::from_utf8_lossy(&r[..end]);
            let (flags, contents) = (le_i32(r, 64), le_i32(r, 68));
            (
                classify(&name, flags, contents, options.sky),
                brush_kind(&name, contents),
            )
        })
        .unzip();

    // Vertices, converted and checked.
    let mut positions: Vec<Vec3> = Vec::with_capacity(lumps.bytes(VERTEXES).len() / 44);
    for (k, r) in lumps.records(VERTEXES, 44)?.enumerate() {
        let p = to_hom(vec3(r, 0));
        if !p.is_finite() {
            return Err(BspError::NonFinite {
                what: "vertex",
                record: k,
            });
        }
        positions.push(p);
    }
    let vertex_count = positions.len();
    let meshverts: Vec<i32> = lumps.records(MESHVERTS, 4)?.map(|r| le_i32(r, 0)).collect();

    // The world model's faces.
    let mut models = lumps.records(MODELS, 40)?;
    let Some(world) = models.next() else {
        return Err(BspError::IndexOutOfRange {
            what: "map",
            record: 0,
            field: "world model (model 0)",
            value: 0,
            len: 0,
        });
    };
    let face_records: Vec<&[u8]> = lumps.records(FACES, 104)?.collect();
    let world_faces = range(
        "model",
        0,
        "faces",
        le_i32(world, 24),
        le_i32(world, 28),
        face_records.len(),
    )?;

    // Geometry per face: triangles appended to `triangles`, face ranges in `faces`.
    let budget = options.max_triangles;
    let too_big = || BspError::TooBig { limit: budget };
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    // (face index, what it is, triangle range)
    let mut faces: Vec<(usize, Surface, std::ops::Range<usize>)> = Vec::new();
    let level = options.tessellation as usize;
    for f in world_faces {
        let r = face_records[f];
        let texture = index("face", f, "shader", le_i32(r, 0), surfaces.len())?;
        let kind = le_i32(r, 8);
        let vertices = range("face", f, "vertices", le_i32(r, 12), le_i32(r, 16), vertex_count)?;
        let start = triangles.len();
        match kind {
            1 | 3 => {
                let n = le_i32(r, 24);
                let mv = range("face", f, "meshverts", le_i32(r, 20), n, meshverts.len())?;
                if n % 3 != 0 {
                    return Err(BspError::BadMeshverts { face: f, count: n });
                }
                if surfaces[texture] == Surface::Skip {
                    continue;
                }
                if triangles.len() + mv.len() / 3 > budget {
                    return Err(too_big());
                }
                for t in meshverts[mv].chunks_exact(3) {
                    let mut tri = [0u32; 3];
                    for (slot, &m) in tri.iter_mut().zip(t) {
                        let local = index("face", f, "meshvert (vertex offset)", m, vertices.len())?;
                        *slot = (vertices.start + local) as u32;
                    }
                    triangles.push(tri);
                }
            }
            2 => {
                let (w, h) = (le_i32(r, 96), le_i32(r, 100));
                let nv = vertices.len() as i64;
                if w < 3 || h < 3 || w % 2 == 0 || h % 2 == 0 || w as i64 * h as i64 != nv {
                    return Err(BspError::BadPatch {
                        face: f,
                        width: w,
                        height: h,
                        vertices: nv as i32,
                    });
                }
                if surfaces[texture] == Surface::Skip {
                    continue;
                }
                let (w, h) = (w as usize, h as usize);
                let patches = (w - 1) / 2 * ((h - 1) / 2);
                if triangles.len() + patches * 2 * level * level > budget
                    || positions.len() + patches * (level + 1) * (level + 1) > budget
                {
                    return Err(too_big());
                }
                let basis: Vec<[f32; 3]> = (0..=level).map(|i| bezier(i as f32 / level as f32)).collect();
                for py in 0..(h - 1) / 2 {
                    for px in 0..(w - 1) / 2 {
                        let mut control = [[Vec3::ZERO; 3]; 3];
                        for (row, line) in control.iter_mut().enumerate() {
                            for (col, c) in line.iter_mut().enumerate() {
                                *c = positions[vertices.start + (2 * py + row) * w + 2 * px + col];
                            }
                        }
                        let base = positions.len() as u32;
                        for bv in &basis {
                            for bu in &basis {
                                let mut p = Vec3::ZERO;
                                for (row, wv) in bv.iter().enumerate() {
                                    for (col, wu) in bu.iter().enumerate() {
                                        p += control[row][col] * (wv * wu);
                                    }
                                }
                                positions.push(p);
                            }
                        }
                        let side = (level + 1) as u32;
                        for y in 0..level as u32 {
                            for x in 0..level as u32 {
                                let a = base + y * side + x;
                                triangles.push([a, a + 1, a + side + 1]);
                                triangles.push([a, a + side + 1, a + side]);
                            }
                        }
                    }
                }
            }
            4 => continue,
            _ => return Err(BspError::BadFaceType { face: f, kind }),
        }
        if triangles.len() > start {
            faces.push((f, surfaces[texture], start..triangles.len()));
        }
    }

    let pvs = read_pvs(&lumps)?;
    // The leaves of every face, via the leaves' face lists.
    let leaffaces: Vec<i32> = lumps.records(LEAFFACES, 4)?.map(|r| le_i32(r, 0)).collect();
    let mut face_leaves: Vec<(u32, u32)> = Vec::new();
    for (leaf, r) in lumps.records(LEAFS, 48)?.enumerate() {
        let list = range("leaf", leaf, "leaffaces", le_i32(r, 32), le_i32(r, 36), leaffaces.len())?;
        if face_leaves.len() + list.len() > budget {
            return Err(too_big());
        }
        for &lf in &leaffaces[list] {
            let face = index("leafface of leaf", leaf, "face", lf, face_records.len())?;
            face_leaves.push((face as u32, leaf as u32));
        }
    }
    face_leaves.sort_unstable();
    face_leaves.dedup();
    let (leaf_brushes, brush_planes) = opaque_brushes(&lumps, &pvs, &brush_kinds, budget)?;

    // Entities and spawns.
    let entities = entities::parse(lumps.bytes(ENTITIES))?;
    let spawns = spawns(&entities)?;

    // Objects: opaque faces, then see-through faces, then sky, grouped spatially.
    let scene_err = |source| BspError::BadGeometry { source };
    let mut builder = SceneBuilder::new(name);
    let mut object_clusters = Vec::new();
    let mut object_leaves = Vec::new();
    let mut object_solid_leaves = Vec::new();
    for kind in [Surface::Opaque, Surface::SeeThrough, Surface::Sky] {
        let chosen: Vec<&(usize, Surface, std::ops::Range<usize>)> = faces.iter().filter(|x| x.1 == kind).collect();
        let pieces: Vec<Piece> = chosen
            .iter()
            .map(|(_, _, tr)| Piece {
                bounds: Aabb::from_points(triangles[tr.clone()].iter().flatten().map(|&i| positions[i as usize])),
                triangles: tr.len() as u32,
            })
            .collect();
        let label = match kind {
            Surface::SeeThrough => "see_through",
            Surface::Sky => "sky",
            _ => "world",
        };
        let mut parts = Vec::new();
        for group in group_pieces(&pieces, &options.split) {
            let id = builder.object_count() + parts.len();
            let object_name = format!("{label}_{id}");
            let tris: Vec<[u32; 3]> = group
                .iter()
                .flat_map(|&g| triangles[chosen[g as usize].2.clone()].iter().copied())
                .collect();
            let mut leaves: Vec<u32> = Vec::new();
            for &g in &group {
                let face = chosen[g as usize].0 as u32;
                let from = face_leaves.partition_point(|x| x.0 < face);
                leaves.extend(face_leaves[from..].iter().take_while(|x| x.0 == face).map(|x| x.1));
            }
            leaves.sort_unstable();
            leaves.dedup();
            let (clustered, unclustered): (Vec<u32>, Vec<u32>) =
                leaves.into_iter().partition(|&l| pvs.leaf_cluster[l as usize] >= 0);
            let mut clusters: Vec<i32> = clustered.iter().map(|&l| pvs.leaf_cluster[l as usize]).collect();
            clusters.sort_unstable();
            clusters.dedup();
            object_clusters.push(clusters);
            object_leaves.push(clustered);
            object_solid_leaves.push(unclustered);
            let mesh = Mesh::compact(object_name.clone(), &positions, &tris).map_err(scene_err)?;
            parts.push((object_name, builder.add_mesh(mesh)));
        }
        let name = format!("{label}_{}", builder.parent_count());
        let ids = builder.add_clusters(name, parts, Mat4::IDENTITY).map_err(scene_err)?;
        for id in ids {
            builder.set_occluder(id, kind != Surface::SeeThrough);
        }
    }
    if builder.object_count() == 0 {
        return Err(BspError::NoGeometry);
    }
    let scene = builder.build().map_err(scene_err)?;
    Ok(BspMap {
        scene,
        spawns,
        entities,
        object_clusters,
        object_leaves,
        object_solid_leaves,
        leaf_brushes,
        brush_planes,
        eye_height: options.eye_height,
        speed: options.speed,
        pvs,
    })
}

/// What a brush is to sight, by its shader.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum BrushKind {
    /// Contents solid, not translucent: its drawn faces hide what is inside.
    Opaque,
    /// q3map2's `common/antiportal`: no faces, nonsolid, but the compiler
    /// takes the leaves it fills as solid for its `vis` (and drops the faces
    /// of brushes that touch them only there).
    AntiPortal,
    /// Anything else (translucent, water, clip, hint, trigger…).
    Other,
}

/// What the leaves list: per leaf, the opaque brushes it lists (indices
/// into the second list; leaves without a cluster only) and whether it
/// lists an antiportal; per opaque brush, its sides' planes (see
/// [`BspMap::leaf_brushes`]). `kinds` is per shader; more than `budget`
/// leaf→brush references is [`BspError::TooBig`].
#[allow(clippy::type_complexity)]
fn opaque_brushes(
    lumps: &Lumps,
    pvs: &Pvs,
    kinds: &[BrushKind],
    budget: usize,
) -> Result<(Vec<LeafBrushes>, Vec<Vec<u32>>), BspError> {
    let sides: Vec<&[u8]> = lumps.records(BRUSHSIDES, 8)?.collect();
    let mut brush_planes = Vec::new();
    let mut brush_kind = Vec::new();
    for (b, r) in lumps.records(BRUSHES, 12)?.enumerate() {
        let shader = index("brush", b, "shader", le_i32(r, 8), kinds.len())?;
        let list = range("brush", b, "sides", le_i32(r, 0), le_i32(r, 4), sides.len())?;
        let mut planes = Vec::new();
        if kinds[shader] == BrushKind::Opaque {
            for side in &sides[list] {
                planes.push(index("brush side of brush", b, "plane", le_i32(side, 0), pvs.planes.len())? as u32);
            }
        }
        brush_planes.push(planes);
        brush_kind.push(kinds[shader]);
    }
    let leafbrushes: Vec<i32> = lumps.records(LEAFBRUSHES, 4)?.map(|r| le_i32(r, 0)).collect();
    let mut leaf_brushes = Vec::with_capacity(pvs.leaf_cluster.len());
    let mut references = 0usize;
    for (leaf, r) in lumps.records(LEAFS, 48)?.enumerate() {
        let mut listed = LeafBrushes::default();
        let list = range(
            "leaf",
            leaf,
            "leafbrushes",
            le_i32(r, 40),
            le_i32(r, 44),
            leafbrushes.len(),
        )?;
        // Leaves' lists may overlap: a hostile file must not make them quadratic.
        references += list.len();
        if references > budget {
            return Err(BspError::TooBig { limit: budget });
        }
        for &lb in &leafbrushes[list] {
            let brush = index("leafbrush of leaf", leaf, "brush", lb, brush_planes.len())?;
            match brush_kind[brush] {
                // Only a leaf without a cluster asks which brush fills it.
                BrushKind::Opaque if pvs.leaf_cluster[leaf] < 0 => listed.opaque.push(brush as u32),
                BrushKind::AntiPortal => listed.antiportal = true,
                _ => {}
            }
        }
        leaf_brushes.push(listed);
    }
    Ok((leaf_brushes, brush_planes))
}

/// The brushes a leaf lists, as sight needs them.
#[derive(Clone, Debug, Default)]
pub(super) struct LeafBrushes {
    /// Its opaque brushes (indices into [`BspMap::brush_planes`]; for a
    /// leaf without a cluster).
    pub(super) opaque: Vec<u32>,
    /// Does it list an antiportal?
    pub(super) antiportal: bool,
}

fn is_spawn(classname: &str) -> bool {
    let c = classname.to_ascii_lowercase();
    (c.starts_with("info_player_") && c != "info_player_intermission")
        || (c.starts_with("team_ctf_") && (c.ends_with("spawn") || c.ends_with("player")))
}

fn spawns(entities: &[Entity]) -> Result<Vec<SpawnPoint>, BspError> {
    let mut out = Vec::new();
    for (k, e) in entities.iter().enumerate() {
        let Some(class) = entities::get(e, "classname").filter(|c| is_spawn(c)) else {
            continue;
        };
        let bad = |message: String| BspError::BadSpawn {
            entity: k,
            classname: class.to_owned(),
            message,
        };
        let origin = entities::get(e, "origin").ok_or_else(|| bad("has no origin".into()))?;
        let xyz: Vec<f32> = origin
            .split_ascii_whitespace()
            .map(|t| t.parse::<f32>())
            .collect::<Result<_, _>>()
            .map_err(|_| bad(format!("malformed origin '{origin}'")))?;
        if xyz.len() != 3 || !xyz.iter().all(|c| c.is_finite()) {
            return Err(bad(format!("origin '{origin}' is not three finite numbers")));
        }
        let angle = match entities::get(e, "angle") {
            None => 0.0,
            Some(a) => a
                .trim()
                .parse::<f32>()
                .ok()
                .filter(|a| a.is_finite())
                .ok_or_else(|| bad(format!("malformed angle '{a}'")))?,
        };
        out.push(SpawnPoint {
            classname: class.to_owned(),
            origin: to_hom([xyz[0], xyz[1], xyz[2]]),
            angle_deg: angle,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conversion_is_a_rotation_and_inverts() {
        let q = [10.0, 20.0, 30.0];
        let p = to_hom(q);
        assert_eq!(p, Vec3::new(10.0, 30.0, -20.0) * INCH);
        let back = to_quake(p);
        for i in 0..3 {
            assert!((back[i] - q[i]).abs() < 1e-4);
        }
        // Right-handed: X × Y = Z in Quake maps to X × Y = Z in hom.
        let (x, y, z) = (
            to_hom([1.0, 0.0, 0.0]) / INCH,
            to_hom([0.0, 1.0, 0.0]) / INCH,
            to_hom([0.0, 0.0, 1.0]) / INCH,
        );
        assert!((x.cross(y) - z).length() < 1e-6);
        assert_eq!(z.normalize(), Vec3::Y);
    }

    #[test]
    fn classifies_shaders() {
        let c = |name, flags, contents| classify(name, flags, contents, SkyFaces::Opaque);
        assert_eq!(c("textures/base_wall/concrete", 0, 1), Surface::Opaque);
        assert_eq!(c("textures/skies/blue", 0, 1), Surface::Sky);
        assert_eq!(c("textures/x/y", SURF_SKY, 1), Surface::Sky);
        assert_eq!(c("textures/x/y", SURF_NODRAW | SURF_SKY, 1), Surface::Skip);
        assert_eq!(c("textures/x/y", SURF_NODRAW, 1), Surface::Skip);
        assert_eq!(c("textures/common/caulk", 0, 1), Surface::Skip);
        assert_eq!(c("noshader", 0, 1), Surface::Skip);
        assert_eq!(c("textures/base/wall", 0, 0x20), Surface::SeeThrough);
        assert_eq!(c("textures/gothic/Grate1", 0, 1), Surface::SeeThrough);
        assert_eq!(c("textures/sfx/x", 0, 0x2000_0000), Surface::SeeThrough);
        // Open sky: not drawn.
        assert_eq!(classify("textures/skies/blue", 0, 1, SkyFaces::Open), Surface::Skip);
        assert_eq!(classify("textures/x/y", SURF_SKY, 1, SkyFaces::Open), Surface::Skip);
    }
}
