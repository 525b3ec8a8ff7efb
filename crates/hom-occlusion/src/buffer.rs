//! The occlusion buffer trait and what every buffer shares: options,
//! errors, statistics, where a test lands before the image is consulted,
//! and the queue of triangles waiting to be drawn ([`Front`]).

use crate::geom::{project_points, Aabb, Footprint, Obb, ScreenRect, MAX_VIEWPORT_SIDE};
use crate::raster::queue::{QueueError, QueueSetup, TriangleQueue, MAX_QUEUED_TRIANGLES};
use crate::raster::setup::{Tri, Viewport};
use crate::raster::RasterBackend;
use crate::{ClipConvention, FaceCull};
use glam::{Mat4, Vec2, Vec3, Vec4};
use std::time::Instant;
use thiserror::Error;

/// The answer to a test.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Visibility {
    /// May be seen: draw it.
    Visible,
    /// Wholly outside the view frustum.
    ViewCulled,
    /// In the frustum, but no sample of the buffer sees any part of it.
    Occluded,
}

/// Which samples a triangle covers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Sampling {
    /// Only samples the true, unsnapped triangle covers, with depth no nearer
    /// than its own: conservative against any rasterizer drawing the final
    /// image at the buffer's resolution. The default.
    #[default]
    Conservative,
    /// Exactly the samples, and depths, of hom's reference renderer
    /// (`hom-render`: pixel centres, 8 sub-pixel bits, top-left rule — the
    /// Direct3D/Vulkan rules). For images drawn with that rule; slightly
    /// more culling along edges.
    Exact,
}

/// Where a buffer sets up and draws its triangles. Tests run where they are
/// called (and from many threads at once through [`OcclusionBuffer::share`]).
/// Both give the same buffer, bit for bit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Threads {
    /// On the rayon pool the call runs in: rayon's global pool, or an
    /// engine's own when it calls inside `pool.install(|| ..)`.
    #[default]
    Pool,
    /// On the calling thread alone: no thread pool is asked for anything,
    /// for an engine that runs the cull inside one of its own jobs.
    CallingThread,
}

/// Options shared by both buffers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BufferOptions {
    /// The clip convention of every matrix, clip-space vertex and depth passed in.
    pub clip: ClipConvention,
    /// Which samples a triangle covers.
    pub sampling: Sampling,
    /// The vector kernels to draw with; `None` picks [`RasterBackend::active`]
    /// (AVX2 where the CPU has it, else the widest it has; or `HOM_RASTER_BACKEND` / `HOM_FORCE_SCALAR`).
    /// Every backend gives the same answers.
    pub backend: Option<RasterBackend>,
    /// Where the buffer sets up and draws.
    pub threads: Threads,
}

/// Why a buffer refused a call.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum OcclusionError {
    /// Zero or absurd buffer size.
    #[error("occlusion buffer must be 1..={max} pixels a side, got {width}x{height}", max = MAX_VIEWPORT_SIDE)]
    Size {
        /// Width asked for.
        width: u32,
        /// Height asked for.
        height: u32,
    },
    /// A triangle names a vertex that was not passed.
    #[error("triangle {triangle} uses vertex {index}, but only {vertex_count} vertices were passed")]
    IndexOutOfRange {
        /// Triangle index in the call.
        triangle: usize,
        /// The bad vertex index.
        index: u32,
        /// Vertices passed.
        vertex_count: usize,
    },
    /// The matrix has a NaN or infinite entry.
    #[error("model-to-clip matrix has a NaN or infinite entry")]
    NonFiniteMatrix,
    /// More triangles in one frame than a buffer queues.
    #[error("{queued} triangles are queued and {adding} more would exceed {max}; clear the buffer each frame", max = MAX_QUEUED_TRIANGLES)]
    TooManyTriangles {
        /// Already queued.
        queued: usize,
        /// In this call.
        adding: usize,
    },
    /// `BufferOptions::backend` names vector kernels this CPU lacks.
    #[error("raster backend {0} is not supported by this CPU (supported: {1})")]
    UnsupportedBackend(&'static str, String),
}

impl From<QueueError> for OcclusionError {
    fn from(e: QueueError) -> OcclusionError {
        match e {
            QueueError::Index {
                triangle,
                index,
                vertex_count,
            } => OcclusionError::IndexOutOfRange {
                triangle,
                index,
                vertex_count,
            },
            QueueError::Full { queued, adding } => OcclusionError::TooManyTriangles { queued, adding },
        }
    }
}

/// What a buffer did since its last [`OcclusionBuffer::clear`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BufferStats {
    /// Triangles passed to `render_*`.
    pub triangles_submitted: u64,
    /// Triangles drawn after clipping (a clipped triangle counts once per fan
    /// piece), face culling and dropping those that cover no sample.
    pub triangles_drawn: u64,
    /// [`HzBuffer`](crate::HzBuffer): 8×8 tiles whose samples were tested; [`MaskedBuffer`](crate::MaskedBuffer):
    /// 32×8 tiles a triangle reached. `tiles_rejected`: tiles and blocks
    /// skipped because everything there was nearer (or, masked, told nothing new).
    pub tiles_drawn: u64,
    /// See `tiles_drawn`.
    pub tiles_rejected: u64,
    /// Tests answered (`test_*`).
    pub tests: u64,
    /// Of those, answered [`Visibility::Occluded`].
    pub occluded: u64,
    /// Of those, answered [`Visibility::ViewCulled`].
    pub view_culled: u64,
    /// Time setting queued triangles up (clip, snap, edge functions), ms.
    pub setup_ms: f64,
    /// Time drawing them into the buffer, ms.
    pub raster_ms: f64,
}

/// What [`HzBuffer`](crate::HzBuffer) and [`HomBuffer`](crate::HomBuffer) share: draw occluders, test boxes.
///
/// Every test is conservative (see the module docs): `Occluded` only when no
/// sample of the buffer sees any part of the box or rectangle.
pub trait OcclusionBuffer {
    /// Width in pixels (samples).
    fn width(&self) -> u32;

    /// Height in pixels (samples).
    fn height(&self) -> u32;

    /// The options the buffer was made with.
    fn options(&self) -> &BufferOptions;

    /// Empties the buffer (nothing occludes) and its statistics. Cheap: call it every frame.
    fn clear(&mut self);

    /// Clears and changes the size.
    fn resize(&mut self, width: u32, height: u32) -> Result<(), OcclusionError>;

    /// Queues occluder triangles: `indices` into `positions`, which
    /// `model_to_clip` takes to clip space (`view_proj * model`, in the
    /// buffer's convention). Triangles with a non-finite vertex are skipped.
    fn render_triangles(
        &mut self,
        positions: &[Vec3],
        indices: &[[u32; 3]],
        model_to_clip: &Mat4,
        cull: FaceCull,
    ) -> Result<(), OcclusionError>;

    /// [`OcclusionBuffer::render_triangles`] for triangles that stand in for
    /// an occluder's own (a virtual occluder inside it): always sampled
    /// conservatively, whatever [`BufferOptions::sampling`] says. Exact
    /// sampling would snap the stand-in, and where its edge runs within the
    /// snapping error of the original's, the snapped stand-in can cover a
    /// sample the snapped original does not.
    fn render_stand_in_triangles(
        &mut self,
        positions: &[Vec3],
        indices: &[[u32; 3]],
        model_to_clip: &Mat4,
        cull: FaceCull,
    ) -> Result<(), OcclusionError>;

    /// [`OcclusionBuffer::render_stand_in_triangles`] for a stand-in that is
    /// one convex solid (a box or a convex hull; `indices`, its closed
    /// surface, use its corners only): drawn as its silhouette, the outline
    /// of its projection shrunk by more than the snapping error, as a fan of
    /// a few triangles (a box: 1–4 where its 12 would be set up) at or
    /// behind the solid's front, by the exact rule. Where it cannot be (a
    /// corner in front of the near plane, a projection too thin to shrink),
    /// the triangles are drawn as `render_stand_in_triangles` draws them.
    /// The fan is set up by the exact rule whatever [`BufferOptions::sampling`]
    /// says: it already covers only samples inside the solid's unsnapped
    /// outline (by a margin) and lies behind its front. Not for a solid
    /// that is not convex: its silhouette covers its hollows.
    fn render_convex_stand_in(
        &mut self,
        positions: &[Vec3],
        indices: &[[u32; 3]],
        model_to_clip: &Mat4,
    ) -> Result<(), OcclusionError> {
        self.render_stand_in_triangles(positions, indices, model_to_clip, FaceCull::None)
    }

    /// Queues occluder triangles whose vertices are already in clip space (the buffer's convention).
    fn render_clip_triangles(
        &mut self,
        vertices: &[Vec4],
        indices: &[[u32; 3]],
        cull: FaceCull,
    ) -> Result<(), OcclusionError>;

    /// Draws what is queued now instead of at the next test (for timing).
    fn flush(&mut self);

    /// Tests an axis-aligned box given in the space `model_to_clip` maps from.
    fn test_aabb(&mut self, aabb: &Aabb, model_to_clip: &Mat4) -> Visibility;

    /// Tests an oriented box given in the space `model_to_clip` maps from.
    fn test_obb(&mut self, obb: &Obb, model_to_clip: &Mat4) -> Visibility;

    /// Tests a screen rectangle in NDC (`min` bottom-left, `max` top-right)
    /// at `nearest_depth`, the nearest `z / w` of what it bounds in the
    /// buffer's convention. It covers every pixel it touches.
    fn test_rect(&mut self, min: Vec2, max: Vec2, nearest_depth: f32) -> Visibility;

    /// What the buffer did since the last clear.
    fn stats(&self) -> BufferStats;

    /// Draws what is queued, then lends the buffer for tests through `&self`:
    /// a [`SharedBuffer`] is `Copy`, `Send` and `Sync`, so an engine's job
    /// threads can test their objects at once (as Masked Occlusion Culling's
    /// `TestRect` allows). Its answers equal this buffer's `test_*` answers;
    /// they are not counted in [`OcclusionBuffer::stats`]. The borrow ends
    /// before the next draw.
    fn share(&mut self) -> SharedBuffer<'_>;
}

/// A drawn buffer lent for tests through `&self` ([`OcclusionBuffer::share`]).
///
/// ```
/// use hom_occlusion::{BufferOptions, FaceCull, MaskedBuffer, OcclusionBuffer, Sampling, Visibility};
/// use hom_occlusion::glam::{Mat4, Vec2, Vec3};
///
/// // Exact sampling: the wall's two triangles leave no sample between them.
/// let options = BufferOptions { sampling: Sampling::Exact, ..BufferOptions::default() };
/// let mut buffer = MaskedBuffer::new(64, 64, options)?;
/// // A wall across the whole view at depth 0.5 (clip space: the identity).
/// let wall = [Vec3::new(-2.0, -2.0, 0.5), Vec3::new(2.0, -2.0, 0.5), Vec3::new(2.0, 2.0, 0.5), Vec3::new(-2.0, 2.0, 0.5)];
/// buffer.render_triangles(&wall, &[[0, 1, 2], [0, 2, 3]], &Mat4::IDENTITY, FaceCull::None)?;
/// let shared = buffer.share();
/// let answers: Vec<Visibility> = std::thread::scope(|s| {
///     let jobs: Vec<_> = [0.3f32, 0.7]
///         .map(|z| s.spawn(move || shared.test_rect(Vec2::splat(-0.5), Vec2::splat(0.5), z)))
///         .into_iter()
///         .collect();
///     jobs.into_iter().map(|j| j.join().unwrap()).collect()
/// });
/// assert_eq!(answers, [Visibility::Visible, Visibility::Occluded]);
/// # Ok::<(), hom_occlusion::OcclusionError>(())
/// ```
#[derive(Clone, Copy)]
pub struct SharedBuffer<'a> {
    buffer: &'a (dyn SharedTest + Sync),
}

impl std::fmt::Debug for SharedBuffer<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let front = self.buffer.front();
        f.debug_struct("SharedBuffer")
            .field("width", &front.width)
            .field("height", &front.height)
            .finish()
    }
}

impl SharedBuffer<'_> {
    /// [`OcclusionBuffer::test_aabb`] through `&self`.
    pub fn test_aabb(&self, aabb: &Aabb, model_to_clip: &Mat4) -> Visibility {
        self.decide(self.buffer.front().place_aabb(aabb, model_to_clip))
    }

    /// [`OcclusionBuffer::test_obb`] through `&self`.
    pub fn test_obb(&self, obb: &Obb, model_to_clip: &Mat4) -> Visibility {
        self.decide(self.buffer.front().place_obb(obb, model_to_clip))
    }

    /// [`OcclusionBuffer::test_rect`] through `&self`.
    pub fn test_rect(&self, min: Vec2, max: Vec2, nearest_depth: f32) -> Visibility {
        self.decide(self.buffer.front().place_rect(min, max, nearest_depth))
    }

    /// Whether every sample of `r` is hidden ([`RectTest::rect_is_occluded`] through `&self`).
    pub fn rect_is_occluded(&self, r: &ScreenRect) -> bool {
        r.is_empty() || self.buffer.is_behind_shared(r)
    }

    fn decide(&self, p: Placement) -> Visibility {
        p.answer(|r| self.rect_is_occluded(r))
    }
}

impl<'a> SharedBuffer<'a> {
    /// Lends `buffer`, drawn.
    pub(crate) fn new(buffer: &'a (dyn SharedTest + Sync)) -> SharedBuffer<'a> {
        SharedBuffer { buffer }
    }
}

/// What a drawn buffer lends a [`SharedBuffer`]: its placement and its
/// rectangle test through `&self` (the buffers' own `is_behind_shared`).
pub(crate) trait SharedTest {
    fn front(&self) -> &Front;
    fn is_behind_shared(&self, r: &ScreenRect) -> bool;
}

/// Depth margin (clip z / w): an occludee must be this much farther than the
/// buffer to count as behind. It absorbs float rounding between the box
/// projection here and the renderer's interpolated depths (a few ulps at 1.0;
/// about a metre at 300 m with a 0.1 m near plane).
pub const DEPTH_MARGIN: f32 = 1e-6;

/// The cullers' test: a rectangle of samples in hom's depth convention
/// (what the traversal projects boxes to), without the public placement.
pub trait RectTest {
    /// Whether every sample of `r` is hidden; draws what is queued first.
    /// An empty rectangle is hidden.
    fn rect_is_occluded(&mut self, r: &ScreenRect) -> bool;
}

/// Where a test lands before the image is consulted.
pub(crate) enum Placement {
    /// Wholly outside the frustum.
    ViewCulled,
    /// Reaches in front of the near plane, or not finite: visible.
    Visible,
    /// A rectangle of samples and the nearest depth (hom's convention).
    Rect(ScreenRect),
}

impl Placement {
    /// The answer: the image, asked through `occluded`, decides only rectangles.
    #[inline]
    pub(crate) fn answer(self, occluded: impl FnOnce(&ScreenRect) -> bool) -> Visibility {
        match self {
            Placement::ViewCulled => Visibility::ViewCulled,
            Placement::Visible => Visibility::Visible,
            Placement::Rect(r) if occluded(&r) => Visibility::Occluded,
            Placement::Rect(_) => Visibility::Visible,
        }
    }
}

/// The placement of a box's eight corners under `to_clip` (hom's convention).
pub(crate) fn place_corners(corners: &[Vec3; 8], to_clip: &Mat4, width: u32, height: u32) -> Placement {
    let mut all_out = 0x3fu32;
    for p in corners {
        let c = *to_clip * p.extend(1.0);
        let code = u32::from(c.x < -c.w)
            | u32::from(c.x > c.w) << 1
            | u32::from(c.y < -c.w) << 2
            | u32::from(c.y > c.w) << 3
            | u32::from(c.z < 0.0) << 4
            | u32::from(c.z > c.w) << 5;
        all_out &= code;
    }
    if all_out != 0 {
        return Placement::ViewCulled;
    }
    match project_points(corners, to_clip, width, height) {
        Footprint::Straddles => Placement::Visible,
        Footprint::Rect(r) => Placement::Rect(r),
    }
}

/// The placement of an NDC rectangle at a depth already in hom's convention:
/// every pixel it touches (columns `trunc((x + 1) / 2 · W)`, inclusive).
#[inline]
pub(crate) fn place_ndc_rect(min: Vec2, max: Vec2, depth: f32, width: u32, height: u32) -> Placement {
    if !(min.is_finite() && max.is_finite() && depth.is_finite()) || min.x > max.x || min.y > max.y || depth < 0.0 {
        return Placement::Visible;
    }
    if max.x < -1.0 || min.x > 1.0 || max.y < -1.0 || min.y > 1.0 || depth > 1.0 {
        return Placement::ViewCulled;
    }
    // Clamped before the (truncating) conversion, which then needs no range checks.
    let (w, h) = (width as f32, height as f32);
    let col = |x: f32| ((x + 1.0) * 0.5 * w).clamp(0.0, w - 1.0) as u32;
    let row = |y: f32| ((1.0 - y) * 0.5 * h).clamp(0.0, h - 1.0) as u32;
    Placement::Rect(ScreenRect {
        x0: col(min.x),
        x1: col(max.x) + 1,
        y0: row(max.y),
        y1: row(min.y) + 1,
        z_near: depth,
        z_far: depth,
    })
}

/// What both buffers keep besides their representation: size, options, the
/// queue of triangles not drawn yet, statistics.
#[derive(Clone, Debug)]
pub(crate) struct Front {
    pub(crate) width: u32,
    pub(crate) height: u32,
    pub(crate) options: BufferOptions,
    pub(crate) backend: RasterBackend,
    pub(crate) queue: TriangleQueue,
    /// Scratch: the queued triangles set up.
    pub(crate) tris: Vec<Tri>,
    pub(crate) stats: BufferStats,
}

impl Front {
    pub(crate) fn new(width: u32, height: u32, options: BufferOptions) -> Result<Front, OcclusionError> {
        check_size(width, height)?;
        let backend = match options.backend {
            None => RasterBackend::active(),
            Some(b) if b.is_supported() => b,
            Some(b) => {
                let names: Vec<&str> = RasterBackend::supported().iter().map(|b| b.name()).collect();
                return Err(OcclusionError::UnsupportedBackend(b.name(), names.join(", ")));
            }
        };
        Ok(Front {
            width,
            height,
            options,
            backend,
            queue: TriangleQueue::default(),
            tris: Vec::new(),
            stats: BufferStats::default(),
        })
    }

    pub(crate) fn clear(&mut self) {
        self.queue.clear();
        self.stats = BufferStats::default();
    }

    pub(crate) fn resize(&mut self, width: u32, height: u32) -> Result<(), OcclusionError> {
        check_size(width, height)?;
        (self.width, self.height) = (width, height);
        self.clear();
        Ok(())
    }

    pub(crate) fn render_triangles(
        &mut self,
        positions: &[Vec3],
        indices: &[[u32; 3]],
        model_to_clip: &Mat4,
        cull: FaceCull,
        inner: bool,
    ) -> Result<(), OcclusionError> {
        let m = self.to_hom(model_to_clip).ok_or(OcclusionError::NonFiniteMatrix)?;
        self.queue.push_model_with(positions, indices, &m, cull, inner)?;
        self.stats.triangles_submitted += indices.len() as u64;
        Ok(())
    }

    pub(crate) fn render_convex(
        &mut self,
        positions: &[Vec3],
        indices: &[[u32; 3]],
        model_to_clip: &Mat4,
    ) -> Result<(), OcclusionError> {
        let m = self.to_hom(model_to_clip).ok_or(OcclusionError::NonFiniteMatrix)?;
        self.queue.push_convex(positions, indices, &m)?;
        self.stats.triangles_submitted += indices.len() as u64;
        Ok(())
    }

    pub(crate) fn render_clip_triangles(
        &mut self,
        vertices: &[Vec4],
        indices: &[[u32; 3]],
        cull: FaceCull,
    ) -> Result<(), OcclusionError> {
        let clip = self.options.clip;
        self.queue
            .push_clip(vertices, indices, |v| clip.vertex_to_zero_to_one(v), cull)?;
        self.stats.triangles_submitted += indices.len() as u64;
        Ok(())
    }

    /// Sets the queued triangles up into `self.tris` (timed); the buffer's
    /// flush empties the queue after drawing.
    #[inline(never)]
    pub(crate) fn set_up(&mut self) {
        let start = Instant::now();
        self.queue.set_up_with(&self.queue_setup(), &mut self.tris);
        self.stats.triangles_drawn += self.tris.len() as u64;
        self.stats.setup_ms += ms(start);
    }

    /// How the queue is set up: for the viewport, with the buffer's
    /// backend, by the inner rule in conservative sampling.
    pub(crate) fn queue_setup(&self) -> QueueSetup {
        QueueSetup {
            backend: self.backend,
            viewport: Viewport::new(self.width, self.height),
            inner: self.options.sampling == Sampling::Conservative,
            parallel: self.options.threads == Threads::Pool,
        }
    }

    /// Counts a test's answer.
    #[inline]
    pub(crate) fn answer(&mut self, v: Visibility) -> Visibility {
        self.stats.tests += 1;
        match v {
            Visibility::Occluded => self.stats.occluded += 1,
            Visibility::ViewCulled => self.stats.view_culled += 1,
            Visibility::Visible => {}
        }
        v
    }

    /// The matrix taking `model_to_clip`'s output to hom's convention; `None` when not finite.
    pub(crate) fn to_hom(&self, model_to_clip: &Mat4) -> Option<Mat4> {
        model_to_clip
            .is_finite()
            .then(|| self.options.clip.to_zero_to_one() * *model_to_clip)
    }

    pub(crate) fn place_aabb(&self, aabb: &Aabb, model_to_clip: &Mat4) -> Placement {
        match self.to_hom(model_to_clip) {
            Some(m) if aabb.is_finite() => place_corners(&aabb.corners(), &m, self.width, self.height),
            _ => Placement::Visible,
        }
    }

    pub(crate) fn place_obb(&self, obb: &Obb, model_to_clip: &Mat4) -> Placement {
        let corners = obb.corners();
        match self.to_hom(model_to_clip) {
            Some(m) if corners.iter().all(|c| c.is_finite()) => place_corners(&corners, &m, self.width, self.height),
            _ => Placement::Visible,
        }
    }

    #[inline]
    pub(crate) fn place_rect(&self, min: Vec2, max: Vec2, depth: f32) -> Placement {
        let z = self.options.clip.depth_to_zero_to_one(depth);
        place_ndc_rect(min, max, z, self.width, self.height)
    }
}

fn check_size(width: u32, height: u32) -> Result<(), OcclusionError> {
    if (1..=MAX_VIEWPORT_SIDE).contains(&width) && (1..=MAX_VIEWPORT_SIDE).contains(&height) {
        Ok(())
    } else {
        Err(OcclusionError::Size { width, height })
    }
}

fn ms(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}

/// Implements [`OcclusionBuffer`] for a buffer with a `front: Front` and
/// inherent `draw(&mut self)` (draws `front.tris`), `reset(&mut self)`
/// (marks the representation cleared), `settle(&mut self)` (empties it if
/// it was cleared and not drawn since) and `is_behind(&ScreenRect) -> bool`.
///
/// `occlusion_buffer!(Buffer, draw_queue)` instead has the buffer draw the
/// queue itself with `draw_queue(&mut self)` (set up and drawn in one pass,
/// counting both in `front.stats`); the macro empties the queue after.
macro_rules! occlusion_buffer {
    ($buffer:ty) => {
        impl $buffer {
            /// Sets the queued triangles up, then draws them (timed).
            fn set_up_then_draw(&mut self) {
                self.front.set_up();
                let start = std::time::Instant::now();
                self.draw();
                self.front.stats.raster_ms += start.elapsed().as_secs_f64() * 1e3;
            }
        }
        $crate::occlusion_buffer!($buffer, set_up_then_draw);
    };
    ($buffer:ty, $draw_queue:ident) => {
        impl $crate::OcclusionBuffer for $buffer {
            fn width(&self) -> u32 {
                self.front.width
            }

            fn height(&self) -> u32 {
                self.front.height
            }

            fn options(&self) -> &$crate::BufferOptions {
                &self.front.options
            }

            fn clear(&mut self) {
                self.front.clear();
                self.reset();
            }

            fn resize(&mut self, width: u32, height: u32) -> Result<(), $crate::OcclusionError> {
                self.front.resize(width, height)?;
                self.reset();
                Ok(())
            }

            fn render_triangles(
                &mut self,
                positions: &[glam::Vec3],
                indices: &[[u32; 3]],
                model_to_clip: &glam::Mat4,
                cull: $crate::FaceCull,
            ) -> Result<(), $crate::OcclusionError> {
                self.front
                    .render_triangles(positions, indices, model_to_clip, cull, false)
            }

            fn render_stand_in_triangles(
                &mut self,
                positions: &[glam::Vec3],
                indices: &[[u32; 3]],
                model_to_clip: &glam::Mat4,
                cull: $crate::FaceCull,
            ) -> Result<(), $crate::OcclusionError> {
                self.front
                    .render_triangles(positions, indices, model_to_clip, cull, true)
            }

            fn render_convex_stand_in(
                &mut self,
                positions: &[glam::Vec3],
                indices: &[[u32; 3]],
                model_to_clip: &glam::Mat4,
            ) -> Result<(), $crate::OcclusionError> {
                self.front.render_convex(positions, indices, model_to_clip)
            }

            fn render_clip_triangles(
                &mut self,
                vertices: &[glam::Vec4],
                indices: &[[u32; 3]],
                cull: $crate::FaceCull,
            ) -> Result<(), $crate::OcclusionError> {
                self.front.render_clip_triangles(vertices, indices, cull)
            }

            #[inline]
            fn flush(&mut self) {
                if !self.front.queue.is_empty() {
                    self.$draw_queue();
                    self.front.queue.clear();
                }
                self.settle();
            }

            fn test_aabb(&mut self, aabb: &$crate::geom::Aabb, model_to_clip: &glam::Mat4) -> $crate::Visibility {
                let p = self.front.place_aabb(aabb, model_to_clip);
                self.decide(p)
            }

            fn test_obb(&mut self, obb: &$crate::geom::Obb, model_to_clip: &glam::Mat4) -> $crate::Visibility {
                let p = self.front.place_obb(obb, model_to_clip);
                self.decide(p)
            }

            fn test_rect(&mut self, min: glam::Vec2, max: glam::Vec2, nearest_depth: f32) -> $crate::Visibility {
                let p = self.front.place_rect(min, max, nearest_depth);
                self.decide(p)
            }

            fn stats(&self) -> $crate::BufferStats {
                self.front.stats
            }

            fn share(&mut self) -> $crate::SharedBuffer<'_> {
                <Self as $crate::OcclusionBuffer>::flush(self);
                $crate::SharedBuffer::new(self)
            }
        }

        impl $crate::buffer::SharedTest for $buffer {
            fn front(&self) -> &$crate::Front {
                &self.front
            }

            fn is_behind_shared(&self, r: &$crate::geom::ScreenRect) -> bool {
                <$buffer>::is_behind_shared(self, r)
            }
        }

        impl $buffer {
            /// Answers a placement: the image decides only rectangles.
            #[inline]
            fn decide(&mut self, p: $crate::Placement) -> $crate::Visibility {
                let v = p.answer(|r| <Self as $crate::RectTest>::rect_is_occluded(self, r));
                self.front.answer(v)
            }
        }

        impl $crate::RectTest for $buffer {
            #[inline]
            fn rect_is_occluded(&mut self, r: &$crate::geom::ScreenRect) -> bool {
                <Self as $crate::OcclusionBuffer>::flush(self);
                r.is_empty() || self.is_behind(r)
            }
        }
    };
}
pub(crate) use occlusion_buffer;
