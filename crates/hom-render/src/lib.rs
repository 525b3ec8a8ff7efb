//! # hom-render — the reference software z-buffer renderer
//!
//! A multi-threaded rasterizer whose **item buffer** (the object id owning each
//! pixel) is the visibility oracle of the project: an object is visible from a
//! camera iff it owns at least one pixel ([`oracle_pixel_counts`]). It is also
//! what frame times are measured with, so it is built to be fast.
//!
//! ## Semantics (exact, and tested)
//! - **Conventions** are those of [`hom`]: world right-handed, +Y up; clip
//!   space from [`hom::geom::Camera::view_proj`] with clip z in `[0, w]`;
//!   pixel (0, 0) is the top-left; buffers are row-major, row 0 at the top.
//! - **Sampling**: one sample per pixel, at the pixel centre `(x + 0.5, y + 0.5)`.
//!   Vertices are snapped to fixed point with 8 sub-pixel bits and coverage is
//!   decided by exact integer edge functions with the **top-left fill rule**: a
//!   sample exactly on an edge is covered only if that edge is a top edge
//!   (horizontal, interior below) or a left edge (interior to its right). Two
//!   triangles sharing an edge therefore never both cover, and never both miss, a
//!   sample on it; a closed mesh is watertight.
//! - **Two-sided**: both windings are drawn; zero-area triangles (after
//!   snapping) draw nothing.
//! - **Clipping**: triangles are clipped against the near plane (clip `z >= 0`)
//!   in homogeneous space before the divide; a triangle wholly behind it, or
//!   wholly outside any frustum plane, is dropped. Against x and y a triangle is
//!   clipped only when it leaves a guard band of ±2^19 pixels, which keeps the
//!   fixed-point arithmetic exact (no overflow). A triangle with any NaN or
//!   infinite clip coordinate is skipped. Nothing panics on bad coordinates.
//! - **Depth**: the stored depth is clip `z / w` in `[0, 1]`. It is interpolated
//!   linearly in screen space (it is affine there) and evaluated at each pixel
//!   centre from the plane through the three snapped vertices (values below 0,
//!   from rounding at the near plane, are clamped to 0). The depth buffer is
//!   cleared to `1.0` and the test is **strictly less**, so fragments at or
//!   beyond the far plane (depth `>= 1`) never land, and on equal depth the
//!   earlier-drawn triangle keeps the pixel.
//! - **Draw order** (for determinism): objects in the order of the `ids` slice,
//!   each object's triangles in mesh order. Output (colour, depth, items) is
//!   bit-identical whatever the thread count.
//! - **Shading**: [`Shading::Flat`] gives each triangle a constant colour: object
//!   colour × `(0.25 + 0.75 · |n · v|)`, `n` the unit face normal and `v` the unit
//!   direction from the triangle's centroid to the eye (a two-sided headlight).
//!   [`Shading::ItemOnly`] writes depth and item only (the colour buffer is just
//!   cleared to the background); it is the fastest mode and what the oracle uses.
//!
//! ## Architecture
//! 1. **Setup** (parallel over chunks of 2048 triangles of the draw sequence):
//!    vertices are transformed to clip space, triangles trivially rejected,
//!    clipped, projected, snapped and turned into edge functions and a depth
//!    plane; each chunk bins its triangles into horizontal bands of 16 rows.
//! 2. **Raster** (parallel over bands): each band owns its rows of the
//!    framebuffer, clears them, then walks the chunks' bins in draw order and
//!    fills each triangle's covered spans (exact per-row spans from the edge
//!    functions), so no locks are needed and the result does not depend on
//!    scheduling. Scratch memory is kept inside the [`Renderer`] across frames.

#![forbid(unsafe_code)]

mod raster;
pub mod stand_in;

use hom::geom::{object_to_clip, Camera, MAX_VIEWPORT_SIDE};
use hom::occlusion::details::setup::{setup_triangle, Tri, Vertex, Viewport};
use hom::scene::Scene;
use raster::raster_tri;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Item-buffer value of a pixel no object covers (the one definition is
/// hom-occlusion's, which HV's z-buffer writes too).
pub use hom::occlusion::details::NO_OBJECT;

/// Triangles per setup chunk (fixed, so results never depend on thread count).
const CHUNK_TRIANGLES: u64 = 2048;
/// Rows per raster band.
const BAND_ROWS: u32 = 16;

/// Why rendering infrastructure failed. A variant with a `source` does not
/// repeat it in its message (print the chain to see it).
#[derive(thiserror::Error, Debug)]
pub enum RenderError {
    /// The rayon thread pool could not be built.
    #[error("could not start a renderer thread pool with {threads} threads: {cause}")]
    ThreadPool {
        /// Threads asked for (0 = all cores).
        threads: usize,
        /// The cause: in the message, not a `source`, since rayon's error both
        /// prints and returns its I/O error and the chain would say it twice.
        cause: rayon::ThreadPoolBuildError,
    },
    /// A PNG file could not be written.
    #[error("could not write PNG '{}'", path.display())]
    Png {
        /// The file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: image::ImageError,
    },
    /// A pixel buffer's length does not match its width × height.
    #[error("image buffer for '{}' has {len} pixels, but {width}x{height} needs {}", path.display(), (*width as u64) * (*height as u64))]
    BufferSize {
        /// The file that was to be written.
        path: PathBuf,
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
        /// Pixels supplied.
        len: usize,
    },
}

/// Colour, depth and item buffers of one image, row-major, row 0 at the top.
#[derive(Clone, Debug)]
pub struct Framebuffer {
    width: u32,
    height: u32,
    color: Vec<[u8; 4]>,
    depth: Vec<f32>,
    item: Vec<u32>,
}

impl Framebuffer {
    /// A `width` × `height` framebuffer: black opaque colour, depth 1.0, no objects.
    pub fn new(width: u32, height: u32) -> Framebuffer {
        let n = width as usize * height as usize;
        Framebuffer {
            width,
            height,
            color: vec![[0, 0, 0, 255]; n],
            depth: vec![1.0; n],
            item: vec![NO_OBJECT; n],
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// RGBA8 colour per pixel (alpha always 255).
    pub fn color(&self) -> &[[u8; 4]] {
        &self.color
    }

    /// Depth (clip z / w, in `[0, 1]`; 1.0 where nothing was drawn) per pixel.
    pub fn depth(&self) -> &[f32] {
        &self.depth
    }

    /// Object id per pixel; [`NO_OBJECT`] where nothing was drawn.
    pub fn items(&self) -> &[u32] {
        &self.item
    }

    /// The object id at pixel `(x, y)`.
    ///
    /// # Panics
    /// If the pixel is outside the framebuffer.
    pub fn item_at(&self, x: u32, y: u32) -> u32 {
        assert!(
            x < self.width && y < self.height,
            "pixel {x},{y} outside {}x{}",
            self.width,
            self.height
        );
        self.item[y as usize * self.width as usize + x as usize]
    }

    /// Pixels owned by each object id `0..object_count` (the visibility oracle:
    /// visible iff the count is non-zero). Ids at or beyond `object_count` are ignored.
    pub fn visible_pixel_counts(&self, object_count: usize) -> Vec<u32> {
        let mut counts = vec![0u32; object_count];
        for &id in &self.item {
            if let Some(c) = counts.get_mut(id as usize) {
                *c += 1;
            }
        }
        counts
    }

    /// Writes the colour buffer to a PNG file.
    pub fn save_png(&self, path: &Path) -> Result<(), RenderError> {
        write_png(path, self.width, self.height, &self.color)
    }

    /// Resizes (contents unspecified until cleared).
    fn resize(&mut self, width: u32, height: u32) {
        let n = width as usize * height as usize;
        self.width = width;
        self.height = height;
        self.color.resize(n, [0, 0, 0, 255]);
        self.depth.resize(n, 1.0);
        self.item.resize(n, NO_OBJECT);
    }

    /// Clears every pixel to `background`, depth 1.0, no object.
    fn clear(&mut self, background: [u8; 3]) {
        let bg = [background[0], background[1], background[2], 255];
        self.color.fill(bg);
        self.depth.fill(1.0);
        self.item.fill(NO_OBJECT);
    }
}

/// Writes an RGBA8 image (row-major, row 0 at the top) to a PNG file.
pub fn write_png(path: &Path, width: u32, height: u32, rgba: &[[u8; 4]]) -> Result<(), RenderError> {
    if rgba.len() as u64 != u64::from(width) * u64::from(height) {
        return Err(RenderError::BufferSize {
            path: path.to_path_buf(),
            width,
            height,
            len: rgba.len(),
        });
    }
    image::save_buffer(path, rgba.as_flattened(), width, height, image::ColorType::Rgba8).map_err(|source| {
        RenderError::Png {
            path: path.to_path_buf(),
            source,
        }
    })
}

/// How pixels are coloured.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Shading {
    /// Per-object colour × headlight Lambert on the face normal (two-sided,
    /// `|n · v|`) plus ambient: `colour × (0.25 + 0.75 · |n · v|)`, constant per triangle.
    #[default]
    Flat,
    /// Depth and item buffer only (colour is left at the background): the
    /// fastest mode, used by the oracle.
    ItemOnly,
}

/// Where an object's base colour comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Colouring<'a> {
    /// A stable, pleasant colour hashed from the object id ([`id_colour`]).
    #[default]
    ById,
    /// One colour per object, indexed by object id; ids past the end of the
    /// slice fall back to [`id_colour`].
    PerObject(&'a [[u8; 3]]),
    /// One colour per part of [`Renderer::render_parts`] (per id of
    /// [`Renderer::render`]), by its position in the list; parts past the end
    /// fall back to [`id_colour`] of their object.
    PerPart(&'a [[u8; 3]]),
}

impl Colouring<'_> {
    /// The colour of the `part`-th part drawn, of object `id`.
    fn colour(&self, part: usize, id: u32) -> [u8; 3] {
        match self {
            Colouring::ById => id_colour(id),
            Colouring::PerObject(c) => c.get(id as usize).copied().unwrap_or_else(|| id_colour(id)),
            Colouring::PerPart(c) => c.get(part).copied().unwrap_or_else(|| id_colour(id)),
        }
    }
}

/// The stable colour [`Colouring::ById`] gives object `id`: a hashed hue with
/// moderate saturation and high value.
pub fn id_colour(id: u32) -> [u8; 3] {
    // A 32-bit integer hash (lowbias32) decorrelates neighbouring ids.
    let mut h = id;
    h ^= h >> 16;
    h = h.wrapping_mul(0x7feb_352d);
    h ^= h >> 15;
    h = h.wrapping_mul(0x846c_a68b);
    h ^= h >> 16;
    let hue = (h & 0xffff) as f32 / 65536.0 * 6.0;
    let s = 0.40 + 0.25 * ((h >> 16) & 0xff) as f32 / 255.0;
    let v = 0.78 + 0.20 * (h >> 24) as f32 / 255.0;
    let sector = hue as u32;
    let f = hue - sector as f32;
    let (p, q, t) = (v * (1.0 - s), v * (1.0 - s * f), v * (1.0 - s * (1.0 - f)));
    let (r, g, b) = match sector {
        0 => (v, t, p),
        1 => (q, v, p),
        2 => (p, v, t),
        3 => (p, q, v),
        4 => (t, p, v),
        _ => (v, p, q),
    };
    [r, g, b].map(|c| (c * 255.0 + 0.5) as u8)
}

/// What to draw and how.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions<'a> {
    /// Shading mode.
    pub shading: Shading,
    /// Object base colours.
    pub colouring: Colouring<'a>,
    /// Colour of pixels no object covers.
    pub background: [u8; 3],
}

/// Default background: dark blue-grey.
pub const DEFAULT_BACKGROUND: [u8; 3] = [28, 32, 44];

impl Default for RenderOptions<'_> {
    /// Flat shading, colours by id, dark blue-grey background.
    fn default() -> Self {
        RenderOptions {
            shading: Shading::Flat,
            colouring: Colouring::ById,
            background: DEFAULT_BACKGROUND,
        }
    }
}

/// What [`Renderer::render_parts`] draws: an object id and triangles of its
/// mesh (indices into its positions).
pub type Part<'a> = (u32, &'a [[u32; 3]]);

/// Counters of one [`Renderer::render`] call.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RenderStats {
    /// Triangles of the drawn objects (before any rejection).
    pub triangles_submitted: u64,
    /// Triangles that reached the rasterizer: after trivial rejection, clipping
    /// (a clipped triangle counts once per triangle of its clipped fan), and
    /// dropping those whose bounds hold no pixel centre or whose snapped area is zero.
    pub triangles_rasterized: u64,
    /// Fragments that passed the depth test and were written (always counted).
    pub fragments_written: u64,
}

/// Per-chunk setup output, kept across frames.
#[derive(Default)]
struct Chunk {
    tris: Vec<Tri>,
    /// Band `b`'s triangles are `bins[offsets[b]..offsets[b + 1]]` (indices into `tris`).
    offsets: Vec<u32>,
    bins: Vec<u32>,
    cursor: Vec<u32>,
    vertices: Vec<Vertex>,
    world: Vec<glam::Vec3>,
    submitted: u64,
}

#[derive(Default)]
struct Scratch {
    chunks: Vec<Chunk>,
    starts: Vec<u64>,
}

/// The renderer: a rayon thread pool and reusable scratch memory.
///
/// [`Renderer::render`] takes `&self`; concurrent calls on one renderer are
/// serialised (the scratch memory is behind a mutex).
pub struct Renderer {
    pool: rayon::ThreadPool,
    scratch: Mutex<Scratch>,
}

impl std::fmt::Debug for Renderer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Renderer").field("threads", &self.threads()).finish()
    }
}

/// What every setup chunk needs to know about the frame.
struct Frame<'a> {
    scene: &'a Scene,
    parts: &'a [Part<'a>],
    starts: &'a [u64],
    view_proj: glam::Mat4,
    eye: glam::Vec3,
    viewport: Viewport,
    options: &'a RenderOptions<'a>,
    bands: usize,
}

impl Renderer {
    /// A renderer with `threads` worker threads (0 = one per core).
    pub fn new(threads: usize) -> Result<Renderer, RenderError> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .thread_name(|i| format!("hom-render-{i}"))
            .build()
            .map_err(|cause| RenderError::ThreadPool { threads, cause })?;
        Ok(Renderer {
            pool,
            scratch: Mutex::new(Scratch::default()),
        })
    }

    /// Number of worker threads.
    pub fn threads(&self) -> usize {
        self.pool.current_num_threads()
    }

    /// Runs `f` inside the renderer's thread pool, so rayon work it starts
    /// (a culler's occluder rasterizer, say) shares the renderer's threads
    /// instead of a second pool competing with them for the cores.
    pub fn install<R: Send>(&self, f: impl FnOnce() -> R + Send) -> R {
        self.pool.install(f)
    }

    /// Clears `fb` (resizing it to `camera.width` × `camera.height`) to the
    /// background, then draws the objects `ids` of `scene` in that order, each
    /// with its current `transform`, as seen by `camera` (removed objects draw nothing).
    ///
    /// An invalid camera ([`Camera::validate`] fails) draws nothing; the
    /// framebuffer is still cleared (each side capped at
    /// [`MAX_VIEWPORT_SIDE`]).
    ///
    /// # Panics
    /// If an id in `ids` is not an object of `scene`.
    pub fn render(
        &self,
        scene: &Scene,
        ids: &[u32],
        camera: &Camera,
        options: &RenderOptions,
        fb: &mut Framebuffer,
    ) -> RenderStats {
        let parts: Vec<Part> = ids
            .iter()
            .map(|&id| {
                let o = scene.get(id).unwrap_or_else(|| {
                    panic!(
                        "render: object id {id} is not in scene '{}' ({} objects)",
                        scene.name(),
                        scene.objects().len()
                    )
                });
                (id, scene.mesh_of(o).triangles())
            })
            .collect();
        self.render_parts(scene, &parts, camera, options, fb)
    }

    /// As [`Renderer::render`], drawing for each `(id, triangles)` of `parts`
    /// those triangles (indices into object `id`'s mesh's positions, with its
    /// transform) instead of the whole mesh: a level-of-detail cut. An
    /// object may appear in several parts.
    ///
    /// # Panics
    /// If an id is not an object of `scene`, or a triangle's index is not a
    /// vertex of its mesh.
    pub fn render_parts(
        &self,
        scene: &Scene,
        parts: &[Part],
        camera: &Camera,
        options: &RenderOptions,
        fb: &mut Framebuffer,
    ) -> RenderStats {
        let (width, height) = (
            camera.width.min(MAX_VIEWPORT_SIDE),
            camera.height.min(MAX_VIEWPORT_SIDE),
        );
        fb.resize(width, height);
        let object_count = scene.objects().len();
        if let Some(&(bad, _)) = parts.iter().find(|p| p.0 as usize >= object_count) {
            panic!(
                "render: object id {bad} is not in scene '{}' ({object_count} objects)",
                scene.name()
            );
        }
        if camera.validate().is_err() {
            fb.clear(options.background);
            return RenderStats::default();
        }
        let mut guard = self.scratch.lock().unwrap_or_else(|e| e.into_inner());
        let scratch = &mut *guard;

        // Global triangle index of each object's first triangle in draw order.
        scratch.starts.clear();
        let mut total = 0u64;
        for &(id, triangles) in parts {
            scratch.starts.push(total);
            total += if scene.object(id).is_removed() {
                0
            } else {
                triangles.len() as u64
            };
        }
        scratch.starts.push(total);
        let chunk_count = total.div_ceil(CHUNK_TRIANGLES) as usize;
        if scratch.chunks.len() < chunk_count {
            scratch.chunks.resize_with(chunk_count, Chunk::default);
        }
        let bands = height.div_ceil(BAND_ROWS) as usize;
        let frame = Frame {
            scene,
            parts,
            starts: &scratch.starts,
            view_proj: camera.view_proj(),
            eye: camera.eye,
            viewport: Viewport::new(width, height),
            options,
            bands,
        };
        let chunks = &mut scratch.chunks[..chunk_count];
        self.pool.install(|| {
            chunks.par_iter_mut().enumerate().for_each(|(k, chunk)| {
                let g0 = k as u64 * CHUNK_TRIANGLES;
                chunk.setup(&frame, g0, (g0 + CHUNK_TRIANGLES).min(total));
            });
        });
        let chunks = &scratch.chunks[..chunk_count];
        let bg = options.background;
        let bg = [bg[0], bg[1], bg[2], 255];
        let w = width as usize;
        let band_px = w * BAND_ROWS as usize;
        let flat = options.shading == Shading::Flat;
        let fragments: u64 = self.pool.install(|| {
            fb.depth
                .par_chunks_mut(band_px)
                .zip(fb.item.par_chunks_mut(band_px))
                .zip(fb.color.par_chunks_mut(band_px))
                .enumerate()
                .map(|(b, ((depth, item), colour))| {
                    depth.fill(1.0);
                    item.fill(NO_OBJECT);
                    colour.fill(bg);
                    let y0 = b as u32 * BAND_ROWS;
                    let y1 = y0 + (depth.len() / w) as u32;
                    let mut written = 0;
                    for chunk in chunks {
                        let (s, e) = (chunk.offsets[b] as usize, chunk.offsets[b + 1] as usize);
                        for &i in &chunk.bins[s..e] {
                            let t = &chunk.tris[i as usize];
                            written += if flat {
                                raster_tri::<true>(t, y0, y1, w, depth, item, colour)
                            } else {
                                raster_tri::<false>(t, y0, y1, w, depth, item, colour)
                            };
                        }
                    }
                    written
                })
                .sum()
        });
        RenderStats {
            triangles_submitted: chunks.iter().map(|c| c.submitted).sum(),
            triangles_rasterized: chunks.iter().map(|c| c.tris.len() as u64).sum(),
            fragments_written: fragments,
        }
    }
}

impl Chunk {
    /// Sets up and bins the triangles `g0..g1` of the frame's draw sequence.
    fn setup(&mut self, f: &Frame, g0: u64, g1: u64) {
        self.tris.clear();
        self.submitted = g1 - g0;
        let flat = f.options.shading == Shading::Flat;
        // The draw-order position of the part holding triangle g0 (the last
        // of equal starts: empty parts hold nothing).
        let mut k = f.starts.partition_point(|&s| s <= g0) - 1;
        let mut g = g0;
        // The object whose vertices `vertices` and `world` hold.
        let mut cached_object = None;
        while g < g1 {
            let (id, part) = f.parts[k];
            let object = f.scene.object(id);
            let mesh = f.scene.mesh_of(object);
            let t0 = (g - f.starts[k]) as usize;
            let t1 = (g1.min(f.starts[k + 1]) - f.starts[k]) as usize;
            let positions = mesh.positions();
            let triangles = &part[t0..t1];
            let base = if flat {
                f.options.colouring.colour(k, id)
            } else {
                [0; 3]
            };
            // Transform and classify every vertex once when this chunk uses a
            // good share of the mesh (in this part and the object's parts that
            // follow, as a level-of-detail cut draws them); otherwise per
            // triangle. Both use the same arithmetic, so a vertex is
            // bit-identical either way.
            let vertex = |p: glam::Vec3| Vertex::new(object_to_clip(&f.view_proj, &object.transform, p), &f.viewport);
            if cached_object != Some(id) {
                let mut used = (t1 - t0) as u64;
                let mut j = k + 1;
                while j < f.parts.len() && f.parts[j].0 == id && f.starts[j] < g1 {
                    used += g1.min(f.starts[j + 1]) - f.starts[j];
                    j += 1;
                }
                cached_object = None;
                if used * 3 >= positions.len() as u64 {
                    self.vertices.clear();
                    self.vertices.extend(positions.iter().map(|&p| vertex(p)));
                    self.world.clear();
                    if flat {
                        self.world
                            .extend(positions.iter().map(|&p| object.transform.transform_point3(p)));
                    }
                    cached_object = Some(id);
                }
            }
            let cached = cached_object == Some(id);
            for tri in triangles {
                let n = if cached {
                    let v = &self.vertices;
                    let [i0, i1, i2] = tri.map(|i| i as usize);
                    setup_triangle(
                        [&v[i0], &v[i1], &v[i2]],
                        &f.viewport,
                        id,
                        [0, 0, 0, 255],
                        &mut self.tris,
                    )
                } else {
                    let v = tri.map(|i| vertex(positions[i as usize]));
                    setup_triangle([&v[0], &v[1], &v[2]], &f.viewport, id, [0, 0, 0, 255], &mut self.tris)
                };
                if n > 0 && flat {
                    let w = if cached {
                        tri.map(|i| self.world[i as usize])
                    } else {
                        tri.map(|i| object.transform.transform_point3(positions[i as usize]))
                    };
                    let colour = shade(base, w, f.eye);
                    let len = self.tris.len();
                    for t in &mut self.tris[len - n..] {
                        t.colour = colour;
                    }
                }
            }
            g = f.starts[k + 1].min(g1);
            k += 1;
        }
        self.bin(f.bands);
    }

    /// Builds the per-band lists (CSR) of this chunk's triangles.
    fn bin(&mut self, bands: usize) {
        let band_of = |y: u16| (u32::from(y) / BAND_ROWS) as usize;
        self.offsets.clear();
        self.offsets.resize(bands + 1, 0);
        for t in &self.tris {
            for b in band_of(t.y0)..=band_of(t.y1 - 1) {
                self.offsets[b + 1] += 1;
            }
        }
        for b in 0..bands {
            self.offsets[b + 1] += self.offsets[b];
        }
        self.cursor.clear();
        self.cursor.extend_from_slice(&self.offsets[..bands]);
        self.bins.clear();
        self.bins.resize(self.offsets[bands] as usize, 0);
        for (i, t) in self.tris.iter().enumerate() {
            for b in band_of(t.y0)..=band_of(t.y1 - 1) {
                self.bins[self.cursor[b] as usize] = i as u32;
                self.cursor[b] += 1;
            }
        }
    }
}

/// Flat headlight shading of a world-space triangle.
fn shade(base: [u8; 3], w: [glam::Vec3; 3], eye: glam::Vec3) -> [u8; 4] {
    let n = (w[1] - w[0]).cross(w[2] - w[0]);
    let v = eye - (w[0] + w[1] + w[2]) / 3.0;
    let lambert = n.dot(v).abs() / (n.length_squared() * v.length_squared()).sqrt();
    let k = if lambert.is_finite() {
        0.25 + 0.75 * lambert.min(1.0)
    } else {
        0.25
    };
    let [r, g, b] = base.map(|c| (f32::from(c) * k + 0.5) as u8);
    [r, g, b, 255]
}

/// Renders every live object of `scene` with [`Shading::ItemOnly`] and returns the
/// pixels each object id owns (index = object id): the visibility oracle.
pub fn oracle_pixel_counts(renderer: &Renderer, scene: &Scene, camera: &Camera, fb: &mut Framebuffer) -> Vec<u32> {
    let n = scene.objects().len();
    let ids: Vec<u32> = scene.live_objects().map(|(id, _)| id).collect();
    let options = RenderOptions {
        shading: Shading::ItemOnly,
        ..RenderOptions::default()
    };
    renderer.render(scene, &ids, camera, &options, fb);
    fb.visible_pixel_counts(n)
}
