//! Extreme Tux Racer (ETR) courses: an outdoor level made of a height field
//! and a map of trees and items, loaded from the course's `course.dim`.
//!
//! A course is a directory (Debian's `extremetuxracer-data` has them under
//! `/usr/share/games/etr/courses/{default,extras}/NAME/`) holding:
//!
//! - `course.dim`: the course's parameters, in ETR's "SP list" text: a line
//!   beginning `*` starts a record, the lines after it that do not begin
//!   with `*` continue it (empty lines and lines beginning `#` are skipped;
//!   the first line starts the first record whatever it begins with), and a value is the
//!   text after the first `[tag]` up to the next `[` or `#`, trimmed. The
//!   first record holds `[width]` and `[length]` (metres across and down the
//!   course), `[angle]` (the slope, degrees), `[scale]` (metres of relief
//!   from grey 0 to grey 255), and optionally `[play_width]`,
//!   `[play_length]` (the playable part: centred across, from the top down)
//!   and `[startx]`, `[starty]` (the start: its world `x`, and metres down
//!   from the top; the top-left corner seen facing downhill is `(0, 0)`).
//!   Anything else (author, description, environment, music) is ignored.
//! - `elev.png`: the height field, one sample per pixel (the first channel
//!   of the decoded colour: the grey of a grey image). `nx × ny` pixels make
//!   an `nx × ny` grid spanning the course.
//! - `trees.png`: the item map, the same size as `elev.png`; each pixel's
//!   colour names an item or nothing.
//! - `terrain.png` (surface types), `preview.png`, `items.lst` (ETR's cache of
//!   its conversion of `trees.png`, with the random sizes it drew): ignored.
//!
//! Where the semantics come from: Extreme Tux Racer's own source,
//! `src/course.cpp` (`CCourse::LoadElevMap`, `LoadAndConvertObjectMap` and its
//! colour table `GetObject`, `CalcRandomTrees`, `FindYCoord`,
//! `FindBarycentricCoords`, `LoadCourseList`), `src/course_render.cpp`
//! (`DrawTrees`), `src/spx.cpp` (`CSPList::Load`), `src/physics.cpp` (the play
//! area) and `data/objects/object_types.lst`. This module is our own code
//! written from that format.
//!
//! # Conventions
//!
//! ETR's world is OpenGL's: right-handed, +Y up, metres — hom's, so
//! coordinates are taken as they are. The course starts at `z = 0` and runs
//! down toward `z = −length`; `x` runs from 0 to `width`.
//!
//! - **Grid:** node `(i, j)`, `0 ≤ i < nx`, `0 ≤ j < ny`, is at
//!   `x = i / (nx − 1) · width`, `z = −j / (ny − 1) · length`. ETR flips the
//!   image both ways when it reads it, then mirrors x back, so node `(i, j)`
//!   holds PNG pixel `(nx − 1 − i, j)` (column from the left, row from the
//!   top): the top row of the image is the top of the course, and seen from
//!   above facing down the course (toward −z, +x to the right) the course is
//!   the image rotated 180°, not mirrored.
//! - **Elevation:** `y = (grey − 127) / 255 · scale − j / ny · length · tan(angle)`
//!   (ETR's `base_height_value` is 127; its slope term divides by `ny`, not
//!   `ny − 1`, and so does ours).
//! - **Terrain mesh:** two triangles per grid cell, split along the diagonal
//!   ETR uses for that cell (from `(i, j)` to `(i + 1, j + 1)` where `i + j` is
//!   even, the other diagonal where it is odd), counter-clockwise seen from
//!   above. The cells are cut into cluster-sized objects by [`crate::split`]
//!   (a cell is a piece: its two triangles stay together), named
//!   `terrain_K` in the cut's order, at most 64 triangles and
//!   [`TERRAIN_MAX_EXTENT`] (16 m) each: a height field's cells are all
//!   alike, so the triangle limit alone makes compact clusters, where the
//!   cut's default 3 m (set for a map's faces) made clusters of 6–12
//!   triangles and culling cost more than it saved (`docs/decisions/clusters.md`).
//!   Terrain objects are occluders.
//! - **Items:** pixel `(px, py)` of `trees.png` names an item by its colour,
//!   first match in this order (ETR's table; `±10` means strictly within 10):
//!
//!   | colour (r, g, b)                  | item        | drawn as |
//!   |-----------------------------------|-------------|----------|
//!   | r < 150, b > 200                  | herring     | flat billboard 1 × 1 m |
//!   | 194 ± 10, 40 ± 10, 40 ± 10        | flag        | flat billboard 1 × 1 m |
//!   | 128 ± 10, 128 ± 10, b < 10        | start       | flat billboard 9 m wide, 6 m high |
//!   | r > 220, g > 220, b < 20          | finish      | flat billboard 9 m wide, 6 m high |
//!   | r > 220, 128 ± 10, b > 220        | float       | not drawn: no object |
//!   | r > 220, g > 220, b > 220         | tree        | crossed billboards, base height 2.5 m |
//!   | r > 220, 96 ± 10, b < 40          | tree_barren | crossed billboards, base height 3 m |
//!   | r < 40, g > 220, b < 80           | shrub       | crossed billboards, base height 1.2 m |
//!
//!   Any other colour is no item. An item stands at
//!   `x = (nx − px) / (nx − 1) · width`, `z = −(py + 1) / (ny − 1) · length`
//!   (as ETR places them: one grid step further along +x and −z than the
//!   elevation sample of the same pixel), on the terrain surface there
//!   (the grid clamped at its edges, as ETR's `FindYCoord`).
//! - **Item sizes:** trees, barren trees and shrubs get ETR's random sizes at
//!   its default settings (tree size 3, variation 3): height uniform in
//!   `[base / 1.41, base · 1.41]`, diameter uniform in `[height / 1.4, height]`.
//!   ETR draws them with `rand()`; we draw them from a hash of the pixel
//!   position, so a course loads the same every time.
//! - **Billboards:** trees and shrubs are two crossed vertical quads (in the
//!   x–y and z–y planes through the item's position, `diameter` wide and
//!   `height` high, as ETR draws them); other items one quad in the x–y
//!   plane, facing a camera that comes down the course (ETR turns them to
//!   the viewer; start and finish it keeps facing +z). Each item is its own
//!   object, named `KIND_PX_PY` (`tree_12_340`), sharing one unit mesh per
//!   shape placed by its transform, and **never an occluder**: a billboard is
//!   a see-through texture.
//! - **Object ids:** the terrain objects, then the items in the map's row
//!   order (top row first, left to right).
//!
//! # The walkthrough
//!
//! [`EtrCourse::path`] runs down the course from the start toward the end of
//! the play area: per grid row it follows the cheapest line through the
//! course's valleys (a minimum-cost path over the rows: the cost of a node is
//! its relief above the slope, plus the course's `scale` where a tree,
//! barren tree or shrub stands, plus 0.1 per metre of sideways movement,
//! at most about 45° sideways per row, inside the play area), smoothed over
//! about ±10 m, sampled at [`EtrOptions::path_frames`] evenly spaced frames.
//! The eye is [`EtrOptions::eye_height`] above the terrain surface; each frame
//! looks [`EtrOptions::look_ahead`] metres ahead along the line, pitched to
//! the terrain there but never more than 60° down or 30° up (no frame looks
//! straight up or down). The far plane covers the whole course.
//!
//! # Hostile input
//!
//! Every problem is an [`EtrError`] naming the file ([`LoadError::Etr`]), never
//! a panic:
//!
//! - `course.dim` missing, unreadable, or over [`MAX_DIM_BYTES`] (an image
//!   over [`MAX_PNG_BYTES`]);
//! - a required parameter missing, or any parameter not a finite number;
//! - `[width]` or `[length]` not in (0, [`MAX_SIZE`]] metres, `[scale]` not in
//!   (0, [`MAX_SCALE`]] metres, `[angle]` not in (0°, [`MAX_ANGLE_DEG`]°), a
//!   play size not positive (one larger than the course is clamped to it);
//! - `elev.png` (or a present `trees.png`) missing, not a PNG, with a
//!   truncated header or truncated or corrupt data;
//! - an image whose header gives fewer than 2 × 2 or more than
//!   [`EtrOptions::max_samples`] samples (checked before decoding);
//! - a `trees.png` whose size is not `elev.png`'s: an error, not a rescale,
//!   since ETR reads the item map with `elev.png`'s size (every course of
//!   the Debian package has them equal).
//!
//! A missing `trees.png` is a course without items (ETR goes on without them
//! too); colours that name no item are ignored. A start outside the course
//! or the play area is clamped into it.

mod error;

pub use error::EtrError;

use crate::builtin::rng::Rng;
use crate::camera_path::{CameraPath, PathFrame};
use crate::split::{group_pieces, Piece, SplitOptions};
use crate::LoadError;
use glam::{Mat4, Quat, Vec3};
use hom::geom::Aabb;
use hom::scene::{Mesh, Scene, SceneBuilder, SceneError};
use std::io::Read;
use std::path::Path;

/// Grey value at relief 0 (ETR's `base_height_value`).
pub const BASE_HEIGHT_VALUE: f32 = 127.0;
/// Largest extent of a terrain object, metres: 64 triangles of a course's
/// 1 × 2 m cells bind first (on 8 courses, HOM over frustum-only culling
/// 0.69–1.29 with 3 m clusters, 0.82–1.60 with 16 m, its cull 0.7–28 ms
/// against 1.0–5.5 ms).
pub const TERRAIN_MAX_EXTENT: f32 = 16.0;
/// Largest `[width]` and `[length]` accepted, metres (100 km).
pub const MAX_SIZE: f64 = 100_000.0;
/// Largest `[scale]` accepted, metres of relief (10 km).
pub const MAX_SCALE: f64 = 10_000.0;
/// `[angle]` must be below this, degrees (and above 0).
pub const MAX_ANGLE_DEG: f64 = 80.0;
/// Largest `course.dim` read, bytes.
pub const MAX_DIM_BYTES: u64 = 1 << 20;
/// Largest image file read, bytes (a PNG of 16 M 16-bit RGBA samples, stored
/// uncompressed, is 128 MiB).
pub const MAX_PNG_BYTES: u64 = 256 << 20;
/// Default [`EtrOptions::max_samples`]: 16 M samples per image.
pub const DEFAULT_MAX_SAMPLES: u64 = 16 << 20;

/// Tree size factor at ETR's default tree size (3).
const TREE_SIZE_FACTOR: f32 = 1.0;
/// Tree size variation at ETR's default variation (3).
const TREE_VARIATION: f32 = 1.41;
/// A tree's diameter is at least its height divided by this.
const TREE_DIAMETER_FACTOR: f32 = 1.4;
/// Near plane of the walkthrough, metres.
const NEAR: f32 = 0.1;
/// Sideways cost of the walkthrough's line, per metre.
const LATERAL_COST: f64 = 0.1;
/// Half-width of the smoothing window of the walkthrough's line, metres.
const SMOOTHING: f32 = 10.0;
/// Steepest look down and up of the walkthrough, degrees.
const MAX_PITCH_DOWN_DEG: f32 = 60.0;
const MAX_PITCH_UP_DEG: f32 = 30.0;

/// How to load a course.
#[derive(Clone, Debug, PartialEq)]
pub struct EtrOptions {
    /// How the terrain is cut into objects (default: at most 64 triangles
    /// and [`TERRAIN_MAX_EXTENT`]).
    pub split: SplitOptions,
    /// Load the items of `trees.png` (trees, shrubs, herring, flags…)?
    pub items: bool,
    /// Most samples (width × height) an image may have; checked on its header.
    pub max_samples: u64,
    /// Eye height of the walkthrough above the terrain, metres.
    pub eye_height: f32,
    /// Frames of the walkthrough (at least 2).
    pub path_frames: usize,
    /// How far ahead along its line the walkthrough looks, metres.
    pub look_ahead: f32,
}

impl Default for EtrOptions {
    fn default() -> Self {
        EtrOptions {
            split: SplitOptions {
                max_extent: TERRAIN_MAX_EXTENT,
                ..SplitOptions::default()
            },
            items: true,
            max_samples: DEFAULT_MAX_SAMPLES,
            eye_height: 1.7,
            path_frames: 600,
            look_ahead: 20.0,
        }
    }
}

/// The parameters of `course.dim` that shape the course (metres, degrees).
#[derive(Clone, Debug, PartialEq)]
pub struct CourseDim {
    /// Across the course (x).
    pub width: f32,
    /// Down the course (−z).
    pub length: f32,
    /// Playable width, centred across (default: `width`; at most `width`).
    pub play_width: f32,
    /// Playable length from the top (default: `length`; at most `length`).
    pub play_length: f32,
    /// Start, metres from the left edge (default: the middle; clamped into the course).
    pub start_x: f32,
    /// Start, metres down from the top (default 0; clamped into the course).
    pub start_y: f32,
    /// Slope, degrees, in `(0, MAX_ANGLE_DEG)`.
    pub angle_deg: f32,
    /// Metres of relief from grey 0 to grey 255.
    pub scale: f32,
}

impl CourseDim {
    /// Parses the text of a `course.dim` (see the module docs).
    pub fn parse(text: &str) -> Result<CourseDim, EtrError> {
        let record = first_record(text);
        let required = |field: &'static str| -> Result<f64, EtrError> {
            number(&record, field)?.ok_or(EtrError::MissingField { field })
        };
        let range = |field: &'static str, v: f64, ok: bool, range: &'static str| {
            if ok {
                Ok(v)
            } else {
                Err(EtrError::OutOfRange { field, value: v, range })
            }
        };
        let width = required("width")?;
        range("width", width, width > 0.0 && width <= MAX_SIZE, "(0, 100000] m")?;
        let length = required("length")?;
        range("length", length, length > 0.0 && length <= MAX_SIZE, "(0, 100000] m")?;
        let angle = required("angle")?;
        range("angle", angle, angle > 0.0 && angle < MAX_ANGLE_DEG, "(0, 80) degrees")?;
        let scale = required("scale")?;
        range("scale", scale, scale > 0.0 && scale <= MAX_SCALE, "(0, 10000] m")?;
        let play_width = match number(&record, "play_width")? {
            Some(v) => range("play_width", v, v > 0.0, "(0, width] m")?.min(width),
            None => width,
        };
        let play_length = match number(&record, "play_length")? {
            Some(v) => range("play_length", v, v > 0.0, "(0, length] m")?.min(length),
            None => length,
        };
        let start_x = number(&record, "startx")?.unwrap_or(width / 2.0).clamp(0.0, width);
        let start_y = number(&record, "starty")?.unwrap_or(0.0).clamp(0.0, length);
        Ok(CourseDim {
            width: width as f32,
            length: length as f32,
            play_width: play_width as f32,
            play_length: play_length as f32,
            start_x: start_x as f32,
            start_y: start_y as f32,
            angle_deg: angle as f32,
            scale: scale as f32,
        })
    }
}

/// The first record of an SP list: its first valid line and the lines that
/// continue it (valid lines not starting with `*`).
fn first_record(text: &str) -> String {
    let mut record = String::new();
    let mut started = false;
    for line in text.lines() {
        let line = line.trim_end_matches('\r');
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        if started && line.starts_with('*') {
            break;
        }
        started = true;
        record.push_str(line);
    }
    record
}

/// The value of `[field]` in `record`: the text after the tag up to the next
/// `[` or `#`, trimmed; `None` when the tag is absent or its value empty.
fn value<'a>(record: &'a str, field: &str) -> Option<&'a str> {
    let tag = format!("[{field}]");
    let start = record.find(&tag)? + tag.len();
    let rest = &record[start..];
    let end = rest.find(['[', '#']).unwrap_or(rest.len());
    Some(rest[..end].trim()).filter(|v| !v.is_empty())
}

/// `[field]` as a finite number, `None` when absent.
fn number(record: &str, field: &'static str) -> Result<Option<f64>, EtrError> {
    let Some(text) = value(record, field) else {
        return Ok(None);
    };
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(Some(v)),
        _ => Err(EtrError::BadNumber {
            field,
            value: text.chars().take(64).collect(),
        }),
    }
}

/// An item of `trees.png`, by its colour (see the module docs' table).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ItemKind {
    /// A herring (collected).
    Herring,
    /// A flag.
    Flag,
    /// The start banner.
    Start,
    /// The finish banner.
    Finish,
    /// A reset point, not drawn.
    Float,
    /// A snowy tree.
    Tree,
    /// A barren tree.
    BarrenTree,
    /// A shrub.
    Shrub,
}

impl ItemKind {
    /// The item a pixel's colour names, `None` for any other colour (ETR's
    /// table, first match).
    pub fn from_rgb([r, g, b]: [u8; 3]) -> Option<ItemKind> {
        let (r, g, b) = (i32::from(r), i32::from(g), i32::from(b));
        let near = |v: i32, c: i32| (v - c).abs() < 10;
        Some(if r < 150 && b > 200 {
            ItemKind::Herring
        } else if near(r, 194) && near(g, 40) && near(b, 40) {
            ItemKind::Flag
        } else if near(r, 128) && near(g, 128) && b < 10 {
            ItemKind::Start
        } else if r > 220 && g > 220 && b < 20 {
            ItemKind::Finish
        } else if r > 220 && near(g, 128) && b > 220 {
            ItemKind::Float
        } else if r > 220 && g > 220 && b > 220 {
            ItemKind::Tree
        } else if r > 220 && near(g, 96) && b < 40 {
            ItemKind::BarrenTree
        } else if r < 40 && g > 220 && b < 80 {
            ItemKind::Shrub
        } else {
            return None;
        })
    }

    /// ETR's name of the item type (`object_types.lst`), used in object names.
    pub fn name(self) -> &'static str {
        match self {
            ItemKind::Herring => "herring",
            ItemKind::Flag => "flag",
            ItemKind::Start => "start",
            ItemKind::Finish => "finish",
            ItemKind::Float => "float",
            ItemKind::Tree => "tree",
            ItemKind::BarrenTree => "tree_barren",
            ItemKind::Shrub => "shrub",
        }
    }

    /// Is it drawn (does it become an object)? All but [`ItemKind::Float`].
    pub fn is_drawn(self) -> bool {
        self != ItemKind::Float
    }

    /// A tree, barren tree or shrub: drawn as crossed billboards, solid to the player.
    pub fn is_plant(self) -> bool {
        matches!(self, ItemKind::Tree | ItemKind::BarrenTree | ItemKind::Shrub)
    }

    /// Height and diameter, metres; plants from two unit random numbers.
    fn size(self, u_height: f32, u_diameter: f32) -> (f32, f32) {
        let base = match self {
            ItemKind::Tree => 2.5,
            ItemKind::BarrenTree => 3.0,
            ItemKind::Shrub => 1.2,
            ItemKind::Start | ItemKind::Finish => return (6.0, 9.0),
            _ => return (1.0, 1.0),
        };
        let mid = base * TREE_SIZE_FACTOR;
        let (lo, hi) = (mid / TREE_VARIATION, mid * TREE_VARIATION);
        let height = lo + u_height * (hi - lo);
        let diameter = height / TREE_DIAMETER_FACTOR + u_diameter * (height - height / TREE_DIAMETER_FACTOR);
        (height, diameter)
    }
}

/// One item of the course.
#[derive(Clone, Debug, PartialEq)]
pub struct Item {
    /// What it is.
    pub kind: ItemKind,
    /// Its pixel in `trees.png` (column from the left, row from the top).
    pub pixel: [u32; 2],
    /// The foot of the item, on the terrain.
    pub position: Vec3,
    /// Height, metres.
    pub height: f32,
    /// Width (diameter), metres.
    pub diameter: f32,
    /// Its object id; `None` for items not drawn.
    pub object: Option<u32>,
}

/// The course's height field: the grid of the module docs.
#[derive(Clone, Debug, PartialEq)]
pub struct Heightfield {
    /// Nodes across (x), at least 2.
    pub nx: usize,
    /// Nodes down (−z), at least 2.
    pub ny: usize,
    /// Metres across.
    pub width: f32,
    /// Metres down.
    pub length: f32,
    /// Heights of node `(i, j)` at `i + nx · j`.
    pub heights: Vec<f32>,
}

impl Heightfield {
    /// Metres between nodes across.
    pub fn dx(&self) -> f32 {
        self.width / (self.nx - 1) as f32
    }

    /// Metres between nodes down.
    pub fn dz(&self) -> f32 {
        self.length / (self.ny - 1) as f32
    }

    /// Node `(i, j)` in the world.
    pub fn node(&self, i: usize, j: usize) -> Vec3 {
        Vec3::new(
            i as f32 * self.width / (self.nx - 1) as f32,
            self.heights[i + self.nx * j],
            -(j as f32) * self.length / (self.ny - 1) as f32,
        )
    }

    /// The height of the terrain surface (its triangles) at `(x, z)`; outside
    /// the course, at the nearest point of its edge.
    pub fn height_at(&self, x: f32, z: f32) -> f32 {
        let xi = (x / self.dx()).clamp(0.0, (self.nx - 1) as f32);
        let yi = (-z / self.dz()).clamp(0.0, (self.ny - 1) as f32);
        let i = (xi.floor() as usize).min(self.nx - 2);
        let j = (yi.floor() as usize).min(self.ny - 2);
        let (fx, fy) = (xi - i as f32, yi - j as f32);
        let h = |a: usize, b: usize| self.heights[a + self.nx * b];
        let (h00, h10, h01, h11) = (h(i, j), h(i + 1, j), h(i, j + 1), h(i + 1, j + 1));
        if (i + j).is_multiple_of(2) {
            // Diagonal from (i, j) to (i + 1, j + 1).
            if fy < fx {
                h00 + fx * (h10 - h00) + fy * (h11 - h10)
            } else {
                h00 + fy * (h01 - h00) + fx * (h11 - h01)
            }
        } else if fx + fy < 1.0 {
            // Diagonal from (i + 1, j) to (i, j + 1).
            h00 + fx * (h10 - h00) + fy * (h01 - h00)
        } else {
            h11 + (1.0 - fx) * (h01 - h11) + (1.0 - fy) * (h10 - h11)
        }
    }
}

/// A loaded course: the scene, what it was made from, and its walkthrough.
#[derive(Clone, Debug)]
pub struct EtrCourse {
    /// Terrain objects, then item objects (see the module docs).
    pub scene: Scene,
    /// The course's parameters.
    pub dim: CourseDim,
    /// The height field.
    pub terrain: Heightfield,
    /// Every item of `trees.png` (drawn or not), in the map's row order.
    pub items: Vec<Item>,
    /// Number of terrain objects (ids `0..terrain_objects`).
    pub terrain_objects: usize,
    /// The run down the course.
    pub path: CameraPath,
}

/// Loads the course whose `course.dim` is `path` (its images beside it).
pub fn load(path: &Path, options: &EtrOptions) -> Result<EtrCourse, LoadError> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let fail = |file: &Path| {
        let label = file.display().to_string();
        move |source| LoadError::Etr { path: label, source }
    };
    let dim = read_dim(path).map_err(fail(path))?;
    let elev_path = dir.join("elev.png");
    let (ew, eh, elev) = read_png(&elev_path, options.max_samples, None).map_err(fail(&elev_path))?;
    let terrain = heightfield(&dim, ew, eh, &elev);
    let trees_path = dir.join("trees.png");
    let items = if options.items && trees_path.exists() {
        let (_, _, map) = read_png(&trees_path, options.max_samples, Some((ew, eh))).map_err(fail(&trees_path))?;
        items(&terrain, &map)
    } else {
        Vec::new()
    };
    let name = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "etr".to_owned());
    build(name, dim, terrain, items, options).map_err(|source| LoadError::Etr {
        path: path.display().to_string(),
        source: EtrError::Geometry(source),
    })
}

/// Reads and parses `course.dim` (at most [`MAX_DIM_BYTES`]). Bytes that are
/// not UTF-8 are replaced: ETR's descriptions come in several encodings, and
/// only the ASCII parameters matter.
fn read_dim(path: &Path) -> Result<CourseDim, EtrError> {
    let bytes = read_capped(path, MAX_DIM_BYTES)?;
    CourseDim::parse(&String::from_utf8_lossy(&bytes))
}

/// The bytes of `path`, at most `max` of them.
fn read_capped(path: &Path, max: u64) -> Result<Vec<u8>, EtrError> {
    let file = std::fs::File::open(path).map_err(EtrError::Io)?;
    let mut bytes = Vec::new();
    file.take(max + 1).read_to_end(&mut bytes).map_err(EtrError::Io)?;
    if bytes.len() as u64 > max {
        return Err(EtrError::TooLarge { max });
    }
    Ok(bytes)
}

/// The PNG signature.
const PNG_SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n'];

/// Reads a PNG as 8-bit RGB after checking its header: the signature, a size
/// of at least 2 × 2 and at most `max_samples`, and (for the item map) the
/// size `expect`.
fn read_png(path: &Path, max_samples: u64, expect: Option<(u32, u32)>) -> Result<(u32, u32, Vec<u8>), EtrError> {
    let bytes = read_capped(path, MAX_PNG_BYTES)?;
    if bytes.len() < 8 || bytes[..8] != PNG_SIGNATURE {
        return Err(EtrError::NotPng);
    }
    // The first chunk must be IHDR: length 13, type, width, height.
    if bytes.len() < 33 || bytes[8..16] != [0, 0, 0, 13, b'I', b'H', b'D', b'R'] {
        return Err(EtrError::BadHeader);
    }
    let be = |at: usize| u32::from_be_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    let (width, height) = (be(16), be(20));
    if width < 2 || height < 2 || u64::from(width) * u64::from(height) > max_samples {
        return Err(EtrError::ImageSize {
            width,
            height,
            max_samples,
        });
    }
    if let Some((elev_width, elev_height)) = expect {
        if (width, height) != (elev_width, elev_height) {
            return Err(EtrError::MapSize {
                width,
                height,
                elev_width,
                elev_height,
            });
        }
    }
    let decoder = image::codecs::png::PngDecoder::with_limits(std::io::Cursor::new(&bytes), image::Limits::default())
        .map_err(EtrError::Image)?;
    let image = image::DynamicImage::from_decoder(decoder).map_err(EtrError::Image)?;
    if (image.width(), image.height()) != (width, height) {
        return Err(EtrError::BadHeader);
    }
    Ok((width, height, image.into_rgb8().into_raw()))
}

/// The height field of `elev` (`w × h` RGB) for `dim`.
fn heightfield(dim: &CourseDim, w: u32, h: u32, elev: &[u8]) -> Heightfield {
    let (nx, ny) = (w as usize, h as usize);
    let slope = (dim.angle_deg.to_radians()).tan();
    let mut heights = vec![0.0f32; nx * ny];
    for j in 0..ny {
        let drop = j as f32 / ny as f32 * dim.length * slope;
        for i in 0..nx {
            let px = nx - 1 - i;
            let grey = f32::from(elev[3 * (px + nx * j)]);
            heights[i + nx * j] = (grey - BASE_HEIGHT_VALUE) / 255.0 * dim.scale - drop;
        }
    }
    Heightfield {
        nx,
        ny,
        width: dim.width,
        length: dim.length,
        heights,
    }
}

/// A unit random number in `[0, 1)` from a pixel and a salt: the crate's
/// SplitMix64 hash of the pixel's position, one stream per salt.
fn unit_hash(px: u32, py: u32, salt: u64) -> f32 {
    let position = u64::from(px) | u64::from(py) << 32;
    Rng::from_state(position.wrapping_add(salt.wrapping_mul(0x9E37_79B9_7F4A_7C15))).f32()
}

/// The items of `map` (RGB, the height field's size), in row order.
fn items(terrain: &Heightfield, map: &[u8]) -> Vec<Item> {
    let (nx, ny) = (terrain.nx, terrain.ny);
    let mut out = Vec::new();
    for py in 0..ny {
        for px in 0..nx {
            let k = 3 * (px + nx * py);
            let Some(kind) = ItemKind::from_rgb([map[k], map[k + 1], map[k + 2]]) else {
                continue;
            };
            let (px, py) = (px as u32, py as u32);
            let x = (nx as f32 - px as f32) / (nx - 1) as f32 * terrain.width;
            let z = -(py as f32 + 1.0) / (ny - 1) as f32 * terrain.length;
            let (height, diameter) = kind.size(unit_hash(px, py, 1), unit_hash(px, py, 2));
            out.push(Item {
                kind,
                pixel: [px, py],
                position: Vec3::new(x, terrain.height_at(x, z), z),
                height,
                diameter,
                object: None,
            });
        }
    }
    out
}

/// The scene and walkthrough of a course.
fn build(
    name: String,
    dim: CourseDim,
    terrain: Heightfield,
    mut items: Vec<Item>,
    options: &EtrOptions,
) -> Result<EtrCourse, SceneError> {
    let (nx, ny) = (terrain.nx, terrain.ny);
    let positions: Vec<Vec3> = (0..ny)
        .flat_map(|j| (0..nx).map(move |i| (i, j)))
        .map(|(i, j)| terrain.node(i, j))
        .collect();
    // Cells are the pieces: cell (i, j) has index i + (nx − 1) j.
    let cells = (nx - 1) * (ny - 1);
    let cell_triangles = |c: usize| -> [[u32; 3]; 2] {
        let (i, j) = (c % (nx - 1), c / (nx - 1));
        let v = |a: usize, b: usize| (a + nx * b) as u32;
        let (v00, v10, v01, v11) = (v(i, j), v(i + 1, j), v(i, j + 1), v(i + 1, j + 1));
        if (i + j).is_multiple_of(2) {
            [[v00, v10, v11], [v11, v01, v00]]
        } else {
            [[v00, v10, v01], [v11, v01, v10]]
        }
    };
    let pieces: Vec<Piece> = (0..cells)
        .map(|c| {
            let t = cell_triangles(c);
            Piece {
                bounds: Aabb::from_points(t.iter().flatten().map(|&k| positions[k as usize])),
                triangles: 2,
            }
        })
        .collect();
    let mut builder = SceneBuilder::new(name);
    let mut clusters = Vec::new();
    for (id, group) in group_pieces(&pieces, &options.split).into_iter().enumerate() {
        let object_name = format!("terrain_{id}");
        let tris: Vec<[u32; 3]> = group.iter().flat_map(|&c| cell_triangles(c as usize)).collect();
        clusters.push((
            object_name.clone(),
            builder.add_mesh(Mesh::compact(object_name, &positions, &tris)?),
        ));
    }
    builder.add_clusters("terrain_0", clusters, Mat4::IDENTITY)?;
    let terrain_objects = builder.object_count();

    // Unit billboards: crossed quads for plants, one quad for other items.
    let crossed = Mesh::new(
        "billboard_crossed",
        vec![
            Vec3::new(-0.5, 0.0, 0.0),
            Vec3::new(0.5, 0.0, 0.0),
            Vec3::new(0.5, 1.0, 0.0),
            Vec3::new(-0.5, 1.0, 0.0),
            Vec3::new(0.0, 0.0, 0.5),
            Vec3::new(0.0, 0.0, -0.5),
            Vec3::new(0.0, 1.0, -0.5),
            Vec3::new(0.0, 1.0, 0.5),
        ],
        vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]],
    )?;
    let flat = Mesh::new(
        "billboard_flat",
        vec![
            Vec3::new(-0.5, 0.0, 0.0),
            Vec3::new(0.5, 0.0, 0.0),
            Vec3::new(0.5, 1.0, 0.0),
            Vec3::new(-0.5, 1.0, 0.0),
        ],
        vec![[0, 1, 2], [0, 2, 3]],
    )?;
    let mut crossed_id = None;
    let mut flat_id = None;
    for item in items.iter_mut().filter(|it| it.kind.is_drawn()) {
        let mesh = if item.kind.is_plant() {
            *crossed_id.get_or_insert_with(|| builder.add_mesh(crossed.clone()))
        } else {
            *flat_id.get_or_insert_with(|| builder.add_mesh(flat.clone()))
        };
        let transform = Mat4::from_scale_rotation_translation(
            Vec3::new(item.diameter, item.height, item.diameter),
            Quat::IDENTITY,
            item.position,
        );
        let object_name = format!("{}_{}_{}", item.kind.name(), item.pixel[0], item.pixel[1]);
        let id = builder.add_object(object_name, mesh, transform)?;
        builder.set_occluder(id, false);
        item.object = Some(id);
    }
    let scene = builder.build()?;
    let path = walkthrough(&dim, &terrain, &items, &scene, options);
    Ok(EtrCourse {
        scene,
        dim,
        terrain,
        items,
        terrain_objects,
        path,
    })
}

/// The run down the course (see the module docs).
fn walkthrough(dim: &CourseDim, t: &Heightfield, items: &[Item], scene: &Scene, options: &EtrOptions) -> CameraPath {
    let (nx, ny) = (t.nx, t.ny);
    let (dx, dz) = (t.dx(), t.dz());
    let slope = dim.angle_deg.to_radians().tan();
    // Play area columns, start and end rows.
    let margin = (dim.width - dim.play_width) / 2.0;
    let mut i_lo = ((margin / dx).ceil() as usize).min(nx - 1);
    let mut i_hi = (((dim.width - margin) / dx).floor() as usize).min(nx - 1);
    if i_lo > i_hi {
        let mid = ((dim.width / 2.0 / dx).round() as usize).min(nx - 1);
        (i_lo, i_hi) = (mid, mid);
    }
    let j_start = ((dim.start_y / dz).round() as usize).min(ny - 2);
    let end = if dim.play_length > dim.start_y {
        dim.play_length
    } else {
        dim.length
    };
    let j_end = ((end / dz).round() as usize).clamp(j_start + 1, ny - 1);
    let i_start = ((dim.start_x / dx).round() as usize).clamp(i_lo, i_hi);
    // Nodes near plants cost more.
    let mut blocked = vec![false; nx * ny];
    for it in items.iter().filter(|it| it.kind.is_plant()) {
        let r = it.diameter / 2.0 + 0.5;
        let (x0, x1) = ((it.position.x - r) / dx, (it.position.x + r) / dx);
        let (z0, z1) = ((-it.position.z - r) / dz, (-it.position.z + r) / dz);
        let (x0, x1) = (x0.ceil().max(0.0) as usize, (x1.floor().max(-1.0) + 1.0) as usize);
        let (z0, z1) = (z0.ceil().max(0.0) as usize, (z1.floor().max(-1.0) + 1.0) as usize);
        for j in z0..z1.min(ny) {
            for i in x0..x1.min(nx) {
                blocked[i + nx * j] = true;
            }
        }
    }
    let relief = |i: usize, j: usize| -> f64 {
        let h = f64::from(t.heights[i + nx * j]) + f64::from(j as f32 / ny as f32 * t.length * slope);
        h + if blocked[i + nx * j] { f64::from(dim.scale) } else { 0.0 }
    };
    // Minimum-cost line over rows j_start..=j_end, columns i_lo..=i_hi.
    let cols = i_hi - i_lo + 1;
    let reach = ((dz / dx).round() as usize).clamp(1, 64);
    let rows = j_end - j_start + 1;
    let mut cost = vec![f64::INFINITY; cols];
    cost[i_start - i_lo] = 0.0;
    let mut back = vec![0i8; rows * cols];
    let mut next = vec![0.0f64; cols];
    for r in 1..rows {
        let j = j_start + r;
        for c in 0..cols {
            let (mut best, mut from) = (f64::INFINITY, 0i8);
            let lo = c.saturating_sub(reach);
            for (k, &prev) in cost[lo..=(c + reach).min(cols - 1)].iter().enumerate() {
                let p = lo + k;
                let step = prev + LATERAL_COST * f64::from(dx) * c.abs_diff(p) as f64;
                if step < best {
                    (best, from) = (step, (p as isize - c as isize) as i8);
                }
            }
            next[c] = best + relief(i_lo + c, j);
            back[r * cols + c] = from;
        }
        std::mem::swap(&mut cost, &mut next);
    }
    let mut c = (0..cols).fold(0, |b, k| if cost[k] < cost[b] { k } else { b });
    let mut xs = vec![0.0f32; rows];
    for r in (0..rows).rev() {
        xs[r] = (i_lo + c) as f32 * dx;
        if r > 0 {
            c = (c as isize + isize::from(back[r * cols + c])) as usize;
        }
    }
    // Smoothed over about ±SMOOTHING metres.
    let half = ((SMOOTHING / dz).round() as usize).max(1);
    let mut prefix = vec![0.0f64; rows + 1];
    for r in 0..rows {
        prefix[r + 1] = prefix[r] + f64::from(xs[r]);
    }
    let smooth: Vec<f32> = (0..rows)
        .map(|r| {
            let (a, b) = (r.saturating_sub(half), (r + half).min(rows - 1));
            ((prefix[b + 1] - prefix[a]) / (b - a + 1) as f64) as f32
        })
        .collect();
    // The line at distance s metres down from the top (clamped to its rows).
    let z_top = j_start as f32 * dz;
    let z_end = j_end as f32 * dz;
    let line = |s: f32| -> Vec3 {
        let s = s.clamp(z_top, z_end);
        let r = ((s - z_top) / dz).clamp(0.0, (rows - 1) as f32);
        let r0 = (r.floor() as usize).min(rows - 1);
        let r1 = (r0 + 1).min(rows - 1);
        let x = smooth[r0] + (smooth[r1] - smooth[r0]) * (r - r0 as f32);
        Vec3::new(x, t.height_at(x, -s), -s)
    };
    let eye_height = if options.eye_height.is_finite() {
        options.eye_height
    } else {
        1.7
    };
    let look = if options.look_ahead.is_finite() && options.look_ahead > 0.5 {
        options.look_ahead
    } else {
        20.0
    };
    let n = options.path_frames.max(2);
    let (down, up) = (MAX_PITCH_DOWN_DEG.to_radians(), MAX_PITCH_UP_DEG.to_radians());
    let mut heading = Vec3::NEG_Z;
    let frames = (0..n)
        .map(|f| {
            let s = z_top + (z_end - z_top) * f as f32 / (n - 1) as f32;
            let eye = line(s) + Vec3::Y * eye_height;
            let mut ahead = line(s + look) + Vec3::Y * eye_height;
            if s + look > z_end {
                // Past the end: straight on along the slope.
                let beyond = s + look - z_end;
                ahead += Vec3::new(0.0, -beyond * slope, -beyond);
            }
            let d = ahead - eye;
            let flat = Vec3::new(d.x, 0.0, d.z);
            if flat.length() > 1e-3 {
                heading = flat.normalize();
            }
            let pitch = d.y.atan2(flat.length().max(1e-3)).clamp(-down, up);
            let dir = heading * pitch.cos() + Vec3::Y * pitch.sin();
            PathFrame {
                eye: eye.to_array(),
                target: (eye + dir * look).to_array(),
            }
        })
        .collect();
    let diag = scene.bounds().extent().length();
    CameraPath {
        near: NEAR,
        far: (diag * 1.1).max(100.0),
        ..CameraPath::new(frames)
    }
}

/// Is `path` an ETR course file: named `course.dim`, or ending `.dim`?
pub fn is_course_file(path: &Path) -> bool {
    path.file_name().is_some_and(|n| n.eq_ignore_ascii_case("course.dim"))
        || path.extension().is_some_and(|e| e.eq_ignore_ascii_case("dim"))
}
