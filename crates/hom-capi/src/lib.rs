//! # hom-capi — hom's occlusion buffers from C
//!
//! A C ABI over the front door of `hom-occlusion`: create a buffer, clear it
//! each frame, draw occluder triangles (your positions with a stride, `uint32_t`
//! indices, a column-major `float[16]` matrix), test boxes and screen
//! rectangles, read its statistics, free it. The header is
//! `include/hom.h` (cbindgen's output, checked against this file by the
//! tests); `include/hom.hpp` wraps it in C++ RAII.
//!
//! Occluders that are one convex solid (a box inside a building) go in as
//! their outline ([`hom_buffer_render_convex_stand_in`]); a mesh that spans
//! the level is cut once into clusters to test and draw
//! ([`hom_cluster_triangles`]). `c/engine_loop.c` is hom-occlusion's
//! `engine_loop` example through this ABI.
//!
//! For a whole scene, `HomScene` holds meshes and objects (ids never
//! reused) and `HomCuller` culls it per frame with hom's occluder selection,
//! coherence and cost model: [`hom_culler_cull`] writes the visible object ids.
//!
//! ## The contract
//! - `HomBuffer` is any hom occlusion buffer: [`hom_buffer_new`] makes the
//!   hierarchical Z-buffer (what `engine_loop` uses), [`hom_buffer_new_kind`]
//!   any of the three.
//! - Functions that can fail return a negative code ([`HOM_ERROR_NULL`],
//!   [`HOM_ERROR_INVALID`], [`HOM_ERROR_INTERNAL`]) or `NULL`, and
//!   [`hom_last_error`] says why (per thread, until the next call on it).
//!   Success clears it.
//! - Every pointer is checked: `NULL` where data is needed, misaligned
//!   `float`/`uint32_t` pointers, a stride below 12 bytes or not a multiple
//!   of 4, counts whose byte size overflows, indices not a multiple of 3 or
//!   out of range, and non-finite matrices are errors, never a crash. Vertices
//!   that are not finite are skipped (their triangles draw nothing). A box
//!   with a NaN corner is `HOM_VISIBLE`, never `HOM_OCCLUDED`.
//! - No panic crosses the boundary: one is caught and becomes
//!   [`HOM_ERROR_INTERNAL`].
//! - A buffer is used by one thread at a time; different buffers, by any.
//!   One [`hom_buffer_test_aabbs`] call of many boxes (1,024 or more) tests
//!   them on all of hom's threads itself, as Rust's `SharedBuffer` lets an
//!   engine's jobs do.
//! - Triangles are two-sided, as hom's own default.
//!
//! This crate is the one place outside `hom-occlusion` where `unsafe` lives:
//! each function that takes a pointer reads it once, after the checks above,
//! into Rust values; nothing keeps a pointer past the call.

use hom_occlusion::clusters::{cluster_triangles, ClusterOptions};
use hom_occlusion::geom::Aabb;
use hom_occlusion::glam::{Mat4, Vec2, Vec3, Vec3A};
use hom_occlusion::{
    BufferOptions, ClipConvention, FaceCull, HomBuffer as MapBuffer, HzBuffer, MaskedBuffer, OcclusionBuffer, Threads,
    Visibility,
};
use rayon::prelude::*;
use std::cell::RefCell;
use std::ffi::{c_char, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};

/// Clip convention: z / w in [0, 1], 0 at the near plane (Vulkan, Direct3D, Metal, wgpu).
pub const HOM_CLIP_ZERO_TO_ONE: i32 = 0;
/// Clip convention: z / w in [-1, 1] (OpenGL).
pub const HOM_CLIP_NEG_ONE_TO_ONE: i32 = 1;
/// Clip convention: reversed Z, 1 at the near plane (finite or infinite far plane).
pub const HOM_CLIP_REVERSED_Z: i32 = 2;

/// A test's answer: some sample of the buffer may see it.
pub const HOM_VISIBLE: i32 = 0;
/// A test's answer: hidden behind what was drawn, at every sample.
pub const HOM_OCCLUDED: i32 = 1;
/// A test's answer: wholly outside the view.
pub const HOM_VIEW_CULLED: i32 = 2;

/// Buffer kind: the hierarchical Z-buffer (per-sample depth; the default).
pub const HOM_KIND_HZB: i32 = 0;
/// Buffer kind: hierarchical occlusion maps (coverage pyramid and depth cells).
pub const HOM_KIND_HOM: i32 = 1;
/// Buffer kind: masked occlusion culling (a coverage mask and two depth layers per tile).
pub const HOM_KIND_MASKED: i32 = 2;

// Written as differences so that cbindgen's `#define`s come out parenthesized,
// safe in any C expression (`x-HOM_ERROR_NULL`).
/// Error: a pointer that must not be `NULL` was.
pub const HOM_ERROR_NULL: i32 = 0 - 1;
/// Error: an argument out of range, misaligned, inconsistent or not finite.
pub const HOM_ERROR_INVALID: i32 = 0 - 2;
/// Error: hom failed inside (a panic, caught); the message says where.
pub const HOM_ERROR_INTERNAL: i32 = 0 - 3;

/// Most vertices or indices one call takes (indices are `uint32_t`).
const MAX_COUNT: usize = u32::MAX as usize;

/// An occlusion buffer (opaque to C).
pub struct HomBuffer {
    inner: Box<dyn OcclusionBuffer + Send>,
    /// Tests [`hom_buffer_test_aabbs`] answered on the pool since the last
    /// clear: the buffer's own statistics count only its `&mut` tests.
    shared_tests: SharedTests,
    /// The last draw's positions and triangles, kept for their capacity.
    mesh: (Vec<Vec3>, Vec<[u32; 3]>),
}

/// Counts of the tests answered through the shared buffer.
#[derive(Clone, Copy, Debug, Default)]
struct SharedTests {
    tests: u64,
    occluded: u64,
    view_culled: u64,
}

/// [`hom_buffer_test_aabbs`] tests on the pool from this many boxes; fewer
/// are not worth the fork.
const PARALLEL_TESTS: usize = 1024;

/// A buffer's work since its last clear ([`hom_buffer_stats`]).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HomBufferStats {
    /// Triangles passed to `hom_buffer_render_triangles`.
    pub triangles_submitted: u64,
    /// Triangles drawn after clipping, face culling and dropping those that cover no sample.
    pub triangles_drawn: u64,
    /// Tests answered.
    pub tests: u64,
    /// Of those, answered `HOM_OCCLUDED`.
    pub occluded: u64,
    /// Of those, answered `HOM_VIEW_CULLED`.
    pub view_culled: u64,
    /// Milliseconds setting triangles up.
    pub setup_ms: f64,
    /// Milliseconds drawing them.
    pub raster_ms: f64,
}

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

/// Why a call failed: its code and message.
struct Fail {
    code: i32,
    message: String,
}

fn invalid(message: impl Into<String>) -> Fail {
    Fail {
        code: HOM_ERROR_INVALID,
        message: message.into(),
    }
}

fn null(what: &str) -> Fail {
    Fail {
        code: HOM_ERROR_NULL,
        message: format!("{what} is NULL"),
    }
}

fn set_error(message: &str) {
    let message = CString::new(message.replace('\0', " ")).unwrap_or_default();
    LAST_ERROR.with(|e| *e.borrow_mut() = message);
}

/// Empties the message after a call that succeeded, allocating nothing
/// when it is empty already (a test a call: this is the hot path).
fn clear_error() {
    LAST_ERROR.with(|e| {
        if !e.borrow().is_empty() {
            *e.borrow_mut() = CString::default();
        }
    });
}

/// Runs `f`: its value, or its error's code with the message kept for
/// [`hom_last_error`]; a panic becomes [`HOM_ERROR_INTERNAL`].
fn guard<T>(on_error: impl Fn(i32) -> T, f: impl FnOnce() -> Result<T, Fail>) -> T {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(v)) => {
            clear_error();
            v
        }
        Ok(Err(e)) => {
            set_error(&e.message);
            on_error(e.code)
        }
        Err(panic) => {
            let what = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown".into());
            set_error(&format!(
                "internal error in hom (a panic, caught at the C boundary): {what}"
            ));
            on_error(HOM_ERROR_INTERNAL)
        }
    }
}

fn clip_of(clip: i32) -> Result<ClipConvention, Fail> {
    match clip {
        HOM_CLIP_ZERO_TO_ONE => Ok(ClipConvention::ZeroToOne),
        HOM_CLIP_NEG_ONE_TO_ONE => Ok(ClipConvention::NegOneToOne),
        HOM_CLIP_REVERSED_Z => Ok(ClipConvention::ReversedZ),
        _ => Err(invalid(format!(
            "clip convention {clip} is not HOM_CLIP_ZERO_TO_ONE (0), HOM_CLIP_NEG_ONE_TO_ONE (1) or HOM_CLIP_REVERSED_Z (2)"
        ))),
    }
}

fn code_of(v: Visibility) -> i32 {
    match v {
        Visibility::Visible => HOM_VISIBLE,
        Visibility::Occluded => HOM_OCCLUDED,
        Visibility::ViewCulled => HOM_VIEW_CULLED,
    }
}

/// The answer for the box `min`..`max` placed by `m`: `HOM_VISIBLE` for a
/// NaN corner, never culled (`Aabb::new`'s min/max would drop the NaN).
fn test_box(buffer: &mut HomBuffer, min: Vec3, max: Vec3, m: &Mat4) -> i32 {
    match box_of(min.into(), max.into()) {
        Some(b) => code_of(buffer.inner.test_aabb(&b, m)),
        None => HOM_VISIBLE,
    }
}

/// The box with corners `a` and `b` in either order (as `Aabb::new`, in SSE
/// lanes: the pooled batch calls it for every box), or `None` for a NaN
/// corner, which every test answers `HOM_VISIBLE` before the buffer.
#[inline]
fn box_of(a: Vec3A, b: Vec3A) -> Option<Aabb> {
    (!a.is_nan() && !b.is_nan()).then(|| Aabb {
        min: a.min(b).into(),
        max: a.max(b).into(),
    })
}

/// `n` values of `T` at `p`, checked for `NULL` (when `n > 0`), alignment and size.
///
/// # Safety
/// When the checks pass, `p` must point at `n` readable values of `T`.
unsafe fn read_slice<'a, T>(p: *const T, n: usize, what: &str) -> Result<&'a [T], Fail> {
    if n == 0 {
        return Ok(&[]);
    }
    if p.is_null() {
        return Err(null(what));
    }
    if !p.is_aligned() {
        return Err(invalid(format!(
            "{what} is not aligned to {} bytes",
            std::mem::align_of::<T>()
        )));
    }
    if n.checked_mul(std::mem::size_of::<T>())
        .is_none_or(|b| b > isize::MAX as usize)
    {
        return Err(invalid(format!("{what}: {n} values do not fit in memory")));
    }
    // SAFETY: not NULL, aligned, the byte size fits isize, and the caller
    // promises `n` readable values; the slice lives only for this call.
    Ok(unsafe { std::slice::from_raw_parts(p, n) })
}

/// `n` writable values of `T` at `p`, checked for `NULL` (when `n > 0`),
/// alignment (always) and size: the output twin of [`read_slice`].
///
/// # Safety
/// When the checks pass, `p` must point at `n` writable values of `T` that
/// nothing else refers to during the call.
unsafe fn write_slice<'a, T>(p: *mut T, n: usize, what: &str) -> Result<&'a mut [T], Fail> {
    if n > 0 && p.is_null() {
        return Err(null(what));
    }
    if !p.is_aligned() {
        return Err(invalid(format!(
            "{what} is not aligned to {} bytes",
            std::mem::align_of::<T>()
        )));
    }
    if n == 0 {
        return Ok(&mut []);
    }
    if n.checked_mul(std::mem::size_of::<T>())
        .is_none_or(|b| b > isize::MAX as usize)
    {
        return Err(invalid(format!("{what}: {n} values do not fit in memory")));
    }
    // SAFETY: not NULL, aligned, the byte size fits isize, and the caller
    // promises `n` writable values no one else refers to; the slice lives
    // only for this call.
    Ok(unsafe { std::slice::from_raw_parts_mut(p, n) })
}

/// Frees what `Box::into_raw` made of a handle; `NULL` is fine.
///
/// # Safety
/// `p` must be `NULL` or come from `Box::into_raw`, freed once.
unsafe fn free_box<T>(p: *mut T) {
    if !p.is_null() {
        // SAFETY: the caller's promise: made by `Box::into_raw`, not freed before.
        drop(unsafe { Box::from_raw(p) });
    }
}

/// The column-major matrix at `m`.
///
/// # Safety
/// When not `NULL` and aligned, `m` must point at 16 readable floats.
unsafe fn matrix(m: *const f32, what: &str) -> Result<Mat4, Fail> {
    if m.is_null() {
        return Err(null(what));
    }
    // SAFETY: the caller's promise, passed on.
    let cols = unsafe { read_slice(m, 16, what) }?;
    let m = Mat4::from_cols_slice(cols);
    if !m.is_finite() {
        return Err(invalid(format!("{what} is not finite")));
    }
    Ok(m)
}

/// The three floats at `p`.
///
/// # Safety
/// When not `NULL` and aligned, `p` must point at 3 readable floats.
unsafe fn vec3(p: *const f32, what: &str) -> Result<Vec3, Fail> {
    if p.is_null() {
        return Err(null(what));
    }
    // SAFETY: the caller's promise, passed on.
    Ok(Vec3::from_slice(unsafe { read_slice(p, 3, what) }?))
}

/// The buffer behind `buffer`.
///
/// # Safety
/// When not `NULL`, `buffer` must come from `hom_buffer_new*` and not be freed.
unsafe fn buffer_mut<'a>(buffer: *mut HomBuffer) -> Result<&'a mut HomBuffer, Fail> {
    // SAFETY: the caller's promise: a live buffer, used by this thread alone.
    unsafe { buffer.as_mut() }.ok_or_else(|| null("buffer"))
}

/// A new hierarchical Z-buffer of `width` × `height` samples (each 1..=16384)
/// for matrices in `clip` (a `HOM_CLIP_*`); `NULL` on error.
#[no_mangle]
pub extern "C" fn hom_buffer_new(width: u32, height: u32, clip: i32) -> *mut HomBuffer {
    hom_buffer_new_kind(HOM_KIND_HZB, width, height, clip)
}

/// A new buffer of `kind` (a `HOM_KIND_*`), as [`hom_buffer_new`]; `NULL` on error.
#[no_mangle]
pub extern "C" fn hom_buffer_new_kind(kind: i32, width: u32, height: u32, clip: i32) -> *mut HomBuffer {
    guard(
        |_| std::ptr::null_mut(),
        || {
            let options = BufferOptions {
                clip: clip_of(clip)?,
                ..BufferOptions::default()
            };
            let refused = |e: hom_occlusion::OcclusionError| invalid(e.to_string());
            let inner: Box<dyn OcclusionBuffer + Send> = match kind {
                HOM_KIND_HZB => Box::new(HzBuffer::new(width, height, options).map_err(refused)?),
                HOM_KIND_HOM => Box::new(MapBuffer::new(width, height, options).map_err(refused)?),
                HOM_KIND_MASKED => Box::new(MaskedBuffer::new(width, height, options).map_err(refused)?),
                _ => {
                    return Err(invalid(format!(
                        "buffer kind {kind} is not HOM_KIND_HZB (0), HOM_KIND_HOM (1) or HOM_KIND_MASKED (2)"
                    )))
                }
            };
            Ok(Box::into_raw(Box::new(HomBuffer {
                inner,
                shared_tests: SharedTests::default(),
                mesh: (Vec::new(), Vec::new()),
            })))
        },
    )
}

/// Frees `buffer`; `NULL` is fine.
///
/// # Safety
/// `buffer` must be `NULL` or come from `hom_buffer_new*`, freed once.
#[no_mangle]
pub unsafe extern "C" fn hom_buffer_free(buffer: *mut HomBuffer) {
    // SAFETY: the caller's promise, passed on.
    unsafe { free_box(buffer) }
}

/// Empties `buffer` for a new frame. Returns 0, or `HOM_ERROR_NULL`.
///
/// # Safety
/// `buffer` must be `NULL` or a live buffer.
#[no_mangle]
pub unsafe extern "C" fn hom_buffer_clear(buffer: *mut HomBuffer) -> i32 {
    guard(
        |code| code,
        || {
            // SAFETY: the caller's promise, passed on.
            let buffer = unsafe { buffer_mut(buffer) }?;
            buffer.inner.clear();
            buffer.shared_tests = SharedTests::default();
            Ok(0)
        },
    )
}

/// What the draw calls share: the checks, the mesh read into the
/// buffer's own vectors, then `render` (one of the buffer's draws).
///
/// # Safety
/// As [`hom_buffer_render_triangles`]'s pointers.
#[allow(clippy::too_many_arguments)] // the C call's arguments, passed on
unsafe fn draw(
    buffer: *mut HomBuffer,
    positions: *const f32,
    vertex_count: usize,
    stride_bytes: usize,
    indices: *const u32,
    index_count: usize,
    model_to_clip: *const f32,
    render: impl FnOnce(&mut dyn OcclusionBuffer, &[Vec3], &[[u32; 3]], &Mat4) -> Result<(), hom_occlusion::OcclusionError>,
) -> Result<i32, Fail> {
    // SAFETY: the caller's promise, passed on (each of the three below).
    let buffer = unsafe { buffer_mut(buffer) }?;
    // SAFETY: as above.
    let m = unsafe { matrix(model_to_clip, "model_to_clip") }?;
    let HomBuffer { inner, mesh, .. } = buffer;
    // SAFETY: as above.
    unsafe { mesh_data_into(mesh, positions, vertex_count, stride_bytes, indices, index_count) }?;
    render(inner.as_mut(), &mesh.0, &mesh.1, &m).map_err(|e| invalid(e.to_string()))?;
    Ok(0)
}

/// Draws occluder triangles: `vertex_count` positions, three floats each,
/// `stride_bytes` apart (12 for packed `float[3]`), `index_count` indices
/// (three a triangle) into them, placed by the column-major
/// `model_to_clip` in the buffer's clip convention. Two-sided. 0 on
/// success, a negative code on error ([`hom_last_error`] says why).
///
/// # Safety
/// Each pointer must be `NULL` or point at what its count says:
/// `(vertex_count - 1) * stride_bytes + 12` bytes of positions,
/// `index_count` indices, 16 floats of matrix; `buffer` a live buffer.
#[no_mangle]
pub unsafe extern "C" fn hom_buffer_render_triangles(
    buffer: *mut HomBuffer,
    positions: *const f32,
    vertex_count: usize,
    stride_bytes: usize,
    indices: *const u32,
    index_count: usize,
    model_to_clip: *const f32,
) -> i32 {
    guard(
        |code| code,
        || {
            // SAFETY: the caller's promise, passed on.
            unsafe {
                draw(
                    buffer,
                    positions,
                    vertex_count,
                    stride_bytes,
                    indices,
                    index_count,
                    model_to_clip,
                    |b, p, t, m| b.render_triangles(p, t, m, FaceCull::None),
                )
            }
        },
    )
}

/// Draws an occluder that is one convex solid (a box, a convex hull), as
/// [`hom_buffer_render_triangles`] takes its mesh (`indices`: its closed
/// surface, using its corners only): as its outline shrunk by more than the
/// snapping error, a fan of a few triangles at or behind its front (a box:
/// 1–4 where its 12 would be drawn two-sided). Not for a solid that is not
/// convex: its outline covers its hollows. 0, or a negative code.
///
/// # Safety
/// As [`hom_buffer_render_triangles`].
#[no_mangle]
pub unsafe extern "C" fn hom_buffer_render_convex_stand_in(
    buffer: *mut HomBuffer,
    positions: *const f32,
    vertex_count: usize,
    stride_bytes: usize,
    indices: *const u32,
    index_count: usize,
    model_to_clip: *const f32,
) -> i32 {
    guard(
        |code| code,
        || {
            // SAFETY: the caller's promise, passed on.
            unsafe {
                draw(
                    buffer,
                    positions,
                    vertex_count,
                    stride_bytes,
                    indices,
                    index_count,
                    model_to_clip,
                    |b, p, t, m| b.render_convex_stand_in(p, t, m),
                )
            }
        },
    )
}

/// Tests the box `min`..`max` (three floats each, in the space
/// `model_to_clip` places): `HOM_VISIBLE`, `HOM_OCCLUDED` or
/// `HOM_VIEW_CULLED`, or a negative code on error. A box with a NaN corner
/// is `HOM_VISIBLE`.
///
/// # Safety
/// Each pointer must be `NULL` or point at its floats; `buffer` a live buffer.
#[no_mangle]
pub unsafe extern "C" fn hom_buffer_test_aabb(
    buffer: *mut HomBuffer,
    min: *const f32,
    max: *const f32,
    model_to_clip: *const f32,
) -> i32 {
    guard(
        |code| code,
        || {
            // SAFETY: the caller's promise, passed on (each of the four below).
            let buffer = unsafe { buffer_mut(buffer) }?;
            // SAFETY: as above.
            let (min, max) = (unsafe { vec3(min, "min") }?, unsafe { vec3(max, "max") }?);
            // SAFETY: as above.
            let m = unsafe { matrix(model_to_clip, "model_to_clip") }?;
            Ok(test_box(buffer, min, max, &m))
        },
    )
}

/// Tests `count` boxes at once, six floats each (`min_x, min_y, min_z,
/// max_x, max_y, max_z`) at `boxes`, all placed by `model_to_clip`, writing
/// each answer (`HOM_VISIBLE`, `HOM_OCCLUDED` or `HOM_VIEW_CULLED`) to
/// `results[i]`: [`hom_buffer_test_aabb`]'s answers, with the checks and the
/// call's overhead paid once. 0, or a negative code (then `results` is
/// unspecified).
///
/// # Safety
/// `boxes` must be `NULL` or point at `6 * count` floats, `results` at
/// `count` writable `int32_t`; `buffer` a live buffer.
#[no_mangle]
pub unsafe extern "C" fn hom_buffer_test_aabbs(
    buffer: *mut HomBuffer,
    boxes: *const f32,
    count: usize,
    model_to_clip: *const f32,
    results: *mut i32,
) -> i32 {
    guard(
        |code| code,
        || {
            // SAFETY: the caller's promise, passed on (each of the three below).
            let buffer = unsafe { buffer_mut(buffer) }?;
            // SAFETY: as above.
            let m = unsafe { matrix(model_to_clip, "model_to_clip") }?;
            if count > MAX_COUNT {
                return Err(invalid(format!("{count} boxes: at most {MAX_COUNT}")));
            }
            // SAFETY: as above.
            let boxes = unsafe { read_slice(boxes, 6 * count, "boxes") }?;
            // SAFETY: as above; `boxes` (floats) cannot be the same memory
            // without the caller breaking C's own aliasing rules.
            let results = unsafe { write_slice(results, count, "results") }?;
            if count < PARALLEL_TESTS || buffer.inner.options().threads == Threads::CallingThread {
                for (b, out) in boxes.chunks_exact(6).zip(results.iter_mut()) {
                    *out = test_box(buffer, Vec3::from_slice(&b[..3]), Vec3::from_slice(&b[3..]), &m);
                }
                return Ok(0);
            }
            // Many boxes: on the pool, through the drawn buffer lent for
            // tests from many threads (`share`), counted here since the
            // shared tests are not in the buffer's own statistics.
            let shared = buffer.inner.share();
            // Whole boxes as arrays: no bounds checks left in the loop.
            let (boxes, _) = boxes.as_chunks::<6>();
            let counts = results
                .par_iter_mut()
                .zip(boxes.par_iter())
                .map(|(out, b)| {
                    let Some(aabb) = box_of(Vec3A::new(b[0], b[1], b[2]), Vec3A::new(b[3], b[4], b[5])) else {
                        // As single tests: answered before the buffer, not counted.
                        *out = HOM_VISIBLE;
                        return [0, 0, 0];
                    };
                    *out = code_of(shared.test_aabb(&aabb, &m));
                    [1, u64::from(*out == HOM_OCCLUDED), u64::from(*out == HOM_VIEW_CULLED)]
                })
                .reduce(|| [0; 3], |a, b| [a[0] + b[0], a[1] + b[1], a[2] + b[2]]);
            let counted = &mut buffer.shared_tests;
            counted.tests += counts[0];
            counted.occluded += counts[1];
            counted.view_culled += counts[2];
            Ok(0)
        },
    )
}

/// Tests the screen rectangle `min_x..max_x` × `min_y..max_y` (NDC, y up)
/// at `nearest_depth` (z / w in the buffer's clip convention): as
/// [`hom_buffer_test_aabb`].
///
/// # Safety
/// `buffer` must be `NULL` or a live buffer.
#[no_mangle]
pub unsafe extern "C" fn hom_buffer_test_rect(
    buffer: *mut HomBuffer,
    min_x: f32,
    min_y: f32,
    max_x: f32,
    max_y: f32,
    nearest_depth: f32,
) -> i32 {
    guard(
        |code| code,
        || {
            // SAFETY: the caller's promise, passed on.
            let buffer = unsafe { buffer_mut(buffer) }?;
            let (min, max) = (Vec2::new(min_x, min_y), Vec2::new(max_x, max_y));
            Ok(code_of(buffer.inner.test_rect(min, max, nearest_depth)))
        },
    )
}

/// The buffer's work since its last clear, into `out`. 0, or a negative code.
///
/// # Safety
/// `buffer` must be `NULL` or a live buffer; `out` `NULL` or writable.
#[no_mangle]
pub unsafe extern "C" fn hom_buffer_stats(buffer: *mut HomBuffer, out: *mut HomBufferStats) -> i32 {
    guard(
        |code| code,
        || {
            // SAFETY: the caller's promise, passed on.
            let buffer = unsafe { buffer_mut(buffer) }?;
            if out.is_null() {
                return Err(null("out"));
            }
            if !out.is_aligned() {
                return Err(invalid("out is not aligned to 8 bytes"));
            }
            let s = buffer.inner.stats();
            let stats = HomBufferStats {
                triangles_submitted: s.triangles_submitted,
                triangles_drawn: s.triangles_drawn,
                tests: s.tests + buffer.shared_tests.tests,
                occluded: s.occluded + buffer.shared_tests.occluded,
                view_culled: s.view_culled + buffer.shared_tests.view_culled,
                setup_ms: s.setup_ms,
                raster_ms: s.raster_ms,
            };
            // SAFETY: not NULL, aligned, and writable by the caller's promise.
            unsafe { out.write(stats) };
            Ok(0)
        },
    )
}

/// Why the last failing call on this thread failed; an empty string after
/// a call that succeeded. Valid until the next call on this thread.
#[no_mangle]
pub extern "C" fn hom_last_error() -> *const c_char {
    LAST_ERROR.with(|e| e.borrow().as_ptr())
}

/// Culler kind: frustum culling only.
pub const HOM_CULLER_FRUSTUM: i32 = 0;
/// Culler kind: hierarchical occlusion maps (hom's default).
pub const HOM_CULLER_HOM: i32 = 1;
/// Culler kind: the hierarchical Z-buffer.
pub const HOM_CULLER_HZB: i32 = 2;
/// Culler kind: masked occlusion culling.
pub const HOM_CULLER_MASKED: i32 = 3;

/// One cluster of a mesh cut by [`hom_cluster_triangles`]: its world box
/// and its range of the reordered triangles.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HomCluster {
    /// The box's smallest corner.
    pub min: [f32; 3],
    /// The box's largest corner.
    pub max: [f32; 3],
    /// Its first triangle in the order written to `order`.
    pub first_triangle: u32,
    /// How many triangles it has.
    pub triangle_count: u32,
}

/// Cuts a mesh (as [`hom_buffer_render_triangles`] takes one) into clusters
/// of at most `max_triangles` triangles whose centroids spread at most
/// `max_extent` (hom's defaults: 64 and 3.0): a mesh that spans the level
/// (the ground, a track) is then tested and drawn cluster by cluster.
/// Writes up to `capacity` clusters to `clusters` and, when `order` is not
/// `NULL`, the original index of each triangle in cluster order
/// (`index_count / 3` of them: lay the index buffer out in it, and draw a
/// visible cluster's `triangle_count` triangles from `first_triangle`).
/// Returns how many clusters there are — more than `capacity` means the
/// list was cut: call again with room for all — or a negative code.
///
/// # Safety
/// As [`hom_buffer_render_triangles`]'s pointers; `clusters` must point at
/// `capacity` writable clusters (or be `NULL` with `capacity` 0), `order`
/// at `index_count / 3` writable `uint32_t` or be `NULL`.
#[no_mangle]
pub unsafe extern "C" fn hom_cluster_triangles(
    positions: *const f32,
    vertex_count: usize,
    stride_bytes: usize,
    indices: *const u32,
    index_count: usize,
    max_triangles: u32,
    max_extent: f32,
    clusters: *mut HomCluster,
    capacity: usize,
    order: *mut u32,
) -> i64 {
    guard(i64::from, || {
        // SAFETY: the caller's promise, passed on.
        let (points, triangles) = unsafe { mesh_data(positions, vertex_count, stride_bytes, indices, index_count) }?;
        if capacity > MAX_COUNT {
            return Err(invalid(format!("capacity {capacity}: at most {MAX_COUNT}")));
        }
        // SAFETY: the caller's promise: `capacity` writable clusters.
        let out = unsafe { write_slice(clusters, capacity, "clusters") }?;
        let options = ClusterOptions {
            max_triangles,
            max_extent,
        };
        let cut = cluster_triangles(&points, &triangles, &options).map_err(|e| invalid(e.to_string()))?;
        for (o, c) in out.iter_mut().zip(&cut.clusters) {
            *o = HomCluster {
                min: c.bounds.min.to_array(),
                max: c.bounds.max.to_array(),
                first_triangle: c.triangles.start,
                triangle_count: c.triangles.end - c.triangles.start,
            };
        }
        if !order.is_null() {
            // SAFETY: the caller's promise: room for one index a triangle.
            let order = unsafe { write_slice(order, cut.order.len(), "order") }?;
            order.copy_from_slice(&cut.order);
        }
        Ok(cut.clusters.len() as i64)
    })
}

/// A scene: meshes and the objects placing them (opaque to C).
pub struct HomScene {
    scene: hom::scene::Scene,
}

/// A culler built for one scene (opaque to C).
pub struct HomCuller {
    culler: Box<dyn hom::cull::Culler>,
    out: hom::cull::CullOutput,
}

/// The scene behind `scene`.
///
/// # Safety
/// When not `NULL`, `scene` must come from [`hom_scene_new`] and not be freed.
unsafe fn scene_mut<'a>(scene: *mut HomScene) -> Result<&'a mut HomScene, Fail> {
    // SAFETY: the caller's promise: a live scene, used by this thread alone.
    unsafe { scene.as_mut() }.ok_or_else(|| null("scene"))
}

/// The positions at `positions` (`vertex_count` of them, `stride_bytes`
/// apart) and the triangles of `index_count` indices at `indices`, after
/// the checks every call taking a mesh makes ([`hom_buffer_render_triangles`],
/// [`hom_scene_add_mesh`]): counts, stride, alignment, overflow.
///
/// # Safety
/// As [`hom_buffer_render_triangles`]'s pointers.
unsafe fn mesh_data(
    positions: *const f32,
    vertex_count: usize,
    stride_bytes: usize,
    indices: *const u32,
    index_count: usize,
) -> Result<(Vec<Vec3>, Vec<[u32; 3]>), Fail> {
    let mut mesh = (Vec::new(), Vec::new());
    // SAFETY: the caller's promise, passed on.
    unsafe { mesh_data_into(&mut mesh, positions, vertex_count, stride_bytes, indices, index_count) }?;
    Ok(mesh)
}

/// [`mesh_data`] into `mesh`'s vectors (emptied first): a buffer's draws
/// reuse its own, allocating nothing frame after frame.
///
/// # Safety
/// As [`hom_buffer_render_triangles`]'s pointers.
unsafe fn mesh_data_into(
    mesh: &mut (Vec<Vec3>, Vec<[u32; 3]>),
    positions: *const f32,
    vertex_count: usize,
    stride_bytes: usize,
    indices: *const u32,
    index_count: usize,
) -> Result<(), Fail> {
    if vertex_count > MAX_COUNT || index_count > MAX_COUNT {
        return Err(invalid(format!(
            "{vertex_count} vertices, {index_count} indices: at most {MAX_COUNT} each"
        )));
    }
    if !index_count.is_multiple_of(3) {
        return Err(invalid(format!(
            "index_count {index_count} is not a multiple of 3 (three indices a triangle)"
        )));
    }
    if stride_bytes < 12 || !stride_bytes.is_multiple_of(4) {
        return Err(invalid(format!(
            "stride_bytes {stride_bytes}: at least 12 (three floats) and a multiple of 4"
        )));
    }
    let floats = match vertex_count {
        0 => 0,
        n => (n - 1)
            .checked_mul(stride_bytes / 4)
            .and_then(|f| f.checked_add(3))
            .ok_or_else(|| invalid(format!("{vertex_count} vertices of {stride_bytes} bytes overflow")))?,
    };
    // SAFETY: the caller's promise: the positions span these floats.
    let raw = unsafe { read_slice(positions, floats, "positions") }?;
    let step = stride_bytes / 4;
    // SAFETY: the caller's promise, passed on.
    let flat = unsafe { read_slice(indices, index_count, "indices") }?;
    let (points, triangles) = mesh;
    points.clear();
    points.extend((0..vertex_count).map(|i| Vec3::from_slice(&raw[i * step..i * step + 3])));
    triangles.clear();
    triangles.extend(flat.chunks_exact(3).map(|t| [t[0], t[1], t[2]]));
    Ok(())
}

/// A new, empty scene; `NULL` only if hom fails inside.
#[no_mangle]
pub extern "C" fn hom_scene_new() -> *mut HomScene {
    guard(
        |_| std::ptr::null_mut(),
        || {
            Ok(Box::into_raw(Box::new(HomScene {
                scene: hom::scene::Scene::new("C scene"),
            })))
        },
    )
}

/// Frees `scene`; `NULL` is fine. Free its cullers first or after: they keep no pointer to it.
///
/// # Safety
/// `scene` must be `NULL` or come from [`hom_scene_new`], freed once.
#[no_mangle]
pub unsafe extern "C" fn hom_scene_free(scene: *mut HomScene) {
    // SAFETY: the caller's promise, passed on.
    unsafe { free_box(scene) }
}

/// Adds a mesh (positions with a stride, three indices a triangle, as
/// [`hom_buffer_render_triangles`] takes them): its id (from 0), or a
/// negative code. A mesh with no triangles, a NaN vertex or an index out of
/// range is refused.
///
/// # Safety
/// As [`hom_buffer_render_triangles`]'s pointers; `scene` a live scene.
#[no_mangle]
pub unsafe extern "C" fn hom_scene_add_mesh(
    scene: *mut HomScene,
    positions: *const f32,
    vertex_count: usize,
    stride_bytes: usize,
    indices: *const u32,
    index_count: usize,
) -> i64 {
    guard(i64::from, || {
        // SAFETY: the caller's promise, passed on (both below).
        let scene = unsafe { scene_mut(scene) }?;
        // SAFETY: as above.
        let (points, triangles) = unsafe { mesh_data(positions, vertex_count, stride_bytes, indices, index_count) }?;
        let mesh = hom::scene::Mesh::new("mesh", points, triangles).map_err(|e| invalid(e.to_string()))?;
        Ok(i64::from(scene.scene.add_mesh(mesh)))
    })
}

/// Places mesh `mesh` by the column-major `transform`: the new object's id
/// (ids are never reused), or a negative code. `dynamic` non-zero: it will
/// move ([`hom_scene_set_transform`]); a static object may move too, and is
/// dynamic from then on.
///
/// # Safety
/// `transform` must be `NULL` or point at 16 floats; `scene` a live scene.
#[no_mangle]
pub unsafe extern "C" fn hom_scene_add_object(
    scene: *mut HomScene,
    mesh: u32,
    transform: *const f32,
    dynamic: i32,
) -> i64 {
    guard(i64::from, || {
        // SAFETY: the caller's promise, passed on (both below).
        let scene = unsafe { scene_mut(scene) }?;
        // SAFETY: as above.
        let m = unsafe { matrix(transform, "transform") }?;
        let s = &mut scene.scene;
        let id = if dynamic != 0 {
            s.add_dynamic_object("object", mesh, m)
        } else {
            s.add_object("object", mesh, m)
        };
        id.map(i64::from).map_err(|e| invalid(e.to_string()))
    })
}

/// Places mesh `mesh` by the column-major `transform` as one static object
/// cut into clusters ([`hom_cluster_triangles`]'s cut: at most
/// `max_triangles` triangles and `max_extent` of centroid spread each; a
/// ground, a track, a block of buildings). Each cluster is an object of its
/// own with consecutive ids, tested by the cullers and listed by
/// [`hom_culler_cull`]; [`hom_scene_parent_of`] maps them back to this one.
/// Returns the first cluster's id and writes how many there are to `count`
/// (when not `NULL`), or a negative code. A mesh that is one cluster is
/// placed whole. To move it, move each cluster.
///
/// # Safety
/// `transform` must be `NULL` or point at 16 floats; `count` `NULL` or one
/// writable `uint32_t`; `scene` a live scene.
#[no_mangle]
pub unsafe extern "C" fn hom_scene_add_clustered_object(
    scene: *mut HomScene,
    mesh: u32,
    transform: *const f32,
    max_triangles: u32,
    max_extent: f32,
    count: *mut u32,
) -> i64 {
    guard(i64::from, || {
        // SAFETY: the caller's promise, passed on (all three below).
        let scene = unsafe { scene_mut(scene) }?;
        // SAFETY: as above.
        let m = unsafe { matrix(transform, "transform") }?;
        let options = ClusterOptions {
            max_triangles,
            max_extent,
        };
        let ids = scene
            .scene
            .add_clustered_object("object", mesh, m, &options)
            .map_err(|e| invalid(e.to_string()))?;
        // SAFETY: as above: `count` is NULL or one writable u32.
        if let Some(count) = unsafe { count.as_mut() } {
            *count = ids.end - ids.start;
        }
        Ok(i64::from(ids.start))
    })
}

/// The object that object `object` is part of: the clusters of one
/// [`hom_scene_add_clustered_object`] share it, an object added whole has
/// its own. Objects are numbered from 0 in the order they were added (each
/// `hom_scene_add_object` or `hom_scene_add_clustered_object` call adds
/// one), so an engine maps an id [`hom_culler_cull`] lists back to its own
/// entity. Returns it, or a negative code.
///
/// # Safety
/// `scene` must be `NULL` or a live scene.
#[no_mangle]
pub unsafe extern "C" fn hom_scene_parent_of(scene: *const HomScene, object: u32) -> i64 {
    guard(i64::from, || {
        // SAFETY: the caller's promise: NULL or a live scene, not written meanwhile.
        let scene = unsafe { scene.as_ref() }.ok_or_else(|| null("scene"))?;
        let objects = scene.scene.objects();
        let o = objects.get(object as usize).ok_or_else(|| {
            invalid(format!(
                "no object {object}: the scene has {} object ids",
                objects.len()
            ))
        })?;
        Ok(i64::from(o.parent()))
    })
}

/// Moves object `object` to the column-major `transform`. 0, or a negative code.
///
/// # Safety
/// `transform` must be `NULL` or point at 16 floats; `scene` a live scene.
#[no_mangle]
pub unsafe extern "C" fn hom_scene_set_transform(scene: *mut HomScene, object: u32, transform: *const f32) -> i32 {
    guard(
        |code| code,
        || {
            // SAFETY: the caller's promise, passed on (both below).
            let scene = unsafe { scene_mut(scene) }?;
            // SAFETY: as above.
            let m = unsafe { matrix(transform, "transform") }?;
            scene
                .scene
                .set_transform(object, m)
                .map_err(|e| invalid(e.to_string()))?;
            Ok(0)
        },
    )
}

/// Removes object `object` (its id is not reused). 0, or a negative code.
///
/// # Safety
/// `scene` must be `NULL` or a live scene.
#[no_mangle]
pub unsafe extern "C" fn hom_scene_remove_object(scene: *mut HomScene, object: u32) -> i32 {
    guard(
        |code| code,
        || {
            // SAFETY: the caller's promise, passed on.
            let scene = unsafe { scene_mut(scene) }?;
            scene.scene.remove_object(object).map_err(|e| invalid(e.to_string()))?;
            Ok(0)
        },
    )
}

/// Whether object `object` may be chosen as an occluder (non-zero, the
/// default) or never (0: glass, foliage, grates). 0, or a negative code.
///
/// # Safety
/// `scene` must be `NULL` or a live scene.
#[no_mangle]
pub unsafe extern "C" fn hom_scene_set_occluder(scene: *mut HomScene, object: u32, occluder: i32) -> i32 {
    guard(
        |code| code,
        || {
            // SAFETY: the caller's promise, passed on.
            let scene = unsafe { scene_mut(scene) }?;
            scene
                .scene
                .set_occluder(object, occluder != 0)
                .map_err(|e| invalid(e.to_string()))?;
            Ok(0)
        },
    )
}

/// A culler of `kind` (a `HOM_CULLER_*`) for `scene`, with its defaults
/// for the scene (occluder budget, selection, coherence, cost model);
/// `NULL` on error. It follows the scene's changes by itself.
///
/// # Safety
/// `scene` must be `NULL` or a live scene.
#[no_mangle]
pub unsafe extern "C" fn hom_culler_new(scene: *const HomScene, kind: i32) -> *mut HomCuller {
    guard(
        |_| std::ptr::null_mut(),
        || {
            use hom::cull::{FrustumCuller, HomConfig, HomCuller as Hom, HzbCuller, MaskedCuller};
            // SAFETY: the caller's promise: a live scene.
            let scene = &unsafe { scene.as_ref() }.ok_or_else(|| null("scene"))?.scene;
            let config = HomConfig::for_scene(scene);
            let culler: Box<dyn hom::cull::Culler> = match kind {
                HOM_CULLER_FRUSTUM => Box::new(FrustumCuller::new(scene)),
                HOM_CULLER_HOM => Box::new(Hom::new(scene, config)),
                HOM_CULLER_HZB => Box::new(HzbCuller::new(scene, config.with_buffer(()))),
                HOM_CULLER_MASKED => Box::new(MaskedCuller::new(scene, config.with_buffer(()))),
                _ => {
                    return Err(invalid(format!(
                        "culler kind {kind} is not HOM_CULLER_FRUSTUM (0), HOM_CULLER_HOM (1), HOM_CULLER_HZB (2) or HOM_CULLER_MASKED (3)"
                    )))
                }
            };
            Ok(Box::into_raw(Box::new(HomCuller {
                culler,
                out: hom::cull::CullOutput::default(),
            })))
        },
    )
}

/// Frees `culler`; `NULL` is fine.
///
/// # Safety
/// `culler` must be `NULL` or come from [`hom_culler_new`], freed once.
#[no_mangle]
pub unsafe extern "C" fn hom_culler_free(culler: *mut HomCuller) {
    // SAFETY: the caller's promise, passed on.
    unsafe { free_box(culler) }
}

/// Culls `scene` (the one `culler` was made for) for a `width` × `height`
/// image seen through the column-major `view_proj` in `clip` (a
/// `HOM_CLIP_*`): writes the ids of the objects to draw, ascending, to
/// `visible` (at most `capacity` of them) and returns how many there are —
/// more than `capacity` means the list was cut: call again with room for
/// all. A negative code on error.
///
/// # Safety
/// `view_proj` must be `NULL` or point at 16 floats, `visible` at
/// `capacity` writable `uint32_t` (or be `NULL` with `capacity` 0);
/// `culler` and `scene` live.
#[no_mangle]
pub unsafe extern "C" fn hom_culler_cull(
    culler: *mut HomCuller,
    scene: *const HomScene,
    view_proj: *const f32,
    width: u32,
    height: u32,
    clip: i32,
    visible: *mut u32,
    capacity: usize,
) -> i64 {
    guard(i64::from, || {
        // SAFETY: the caller's promise: a live culler, used by this thread alone.
        let c = unsafe { culler.as_mut() }.ok_or_else(|| null("culler"))?;
        // SAFETY: the caller's promise: a live scene.
        let scene = &unsafe { scene.as_ref() }.ok_or_else(|| null("scene"))?.scene;
        // SAFETY: as above, for the matrix.
        let m = unsafe { matrix(view_proj, "view_proj") }?;
        // SAFETY: the caller's promise: `capacity` writable ids.
        let visible = unsafe { write_slice(visible, capacity, "visible") }?;
        if capacity > MAX_COUNT {
            return Err(invalid(format!("capacity {capacity}: at most {MAX_COUNT}")));
        }
        let view = hom::geom::View::new(m, width, height, clip_of(clip)?);
        c.culler
            .cull(scene, &view, &mut c.out)
            .map_err(|e| invalid(e.to_string()))?;
        let n = c.out.visible.len().min(capacity);
        visible[..n].copy_from_slice(&c.out.visible[..n]);
        Ok(c.out.visible.len() as i64)
    })
}

/// Tells `culler` the frame's time once drawn, in milliseconds (negative:
/// unknown): what its cost model learns whether occlusion culling pays from.
/// 0, or a negative code.
///
/// # Safety
/// `culler` must be `NULL` or a live culler.
#[no_mangle]
pub unsafe extern "C" fn hom_culler_frame_done(culler: *mut HomCuller, frame_ms: f64) -> i32 {
    guard(
        |code| code,
        || {
            // SAFETY: the caller's promise: a live culler.
            let c = unsafe { culler.as_mut() }.ok_or_else(|| null("culler"))?;
            c.culler
                .frame_done((frame_ms >= 0.0 && frame_ms.is_finite()).then_some(frame_ms));
            Ok(0)
        },
    )
}
