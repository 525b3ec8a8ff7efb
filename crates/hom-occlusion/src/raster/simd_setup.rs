//! Triangle setup four triangles at a time (structure of arrays), one
//! triangle per lane: from the clip-space corners, the outcodes, guard band
//! and projection ([`Vertex::new`]'s) in `f32` lanes, then, when none of the
//! four needs clipping, the screen setup in AVX2's four 64-bit lanes.
//! [`Vertex::new`] and [`setup_triangle_with`] are the scalar twin and define
//! the result; the kernel equals them bit for bit (property test):
//! - the projection is the same `f32` operations (`vdivps` for `1 / w`), and
//!   the snap the same truncation and correction;
//! - fixed-point coordinates fit `i32` (`|x| <= 2^28`), so the box, the
//!   differences and the top-left rule are `i32` lane arithmetic, and every
//!   edge-function product is `vpmuldq` (signed 32 × 32 → 64 bits, exact);
//! - the depth plane is the same `f64` operations in the same order
//!   (`vdivpd` for the one division; scaling by 1/256 is exact either way),
//!   rounded to `f32` as `as f32` does.
//!
//! Like [`super::simd`], a place for `unsafe` and `std::arch`.

use super::setup::{setup_triangle_with, SetupRule, Tri, Vertex, Viewport};
use super::simd::RasterBackend;
use glam::Vec4;

/// Triangles set up per call of the vector kernel.
pub(crate) const SETUP_LANES: usize = 4;

/// Sets up four triangles given by their clip-space corners (hom's
/// convention) under `rule`, pushing onto `out` in order what
/// [`setup_triangle_with`] would push for each, with `items[i]` and no
/// colour — when none of them needs clipping (some may be ones it drops
/// whole: unusable, or outside one plane) and `backend` and the CPU have
/// AVX2. Returns false, having pushed nothing, otherwise.
fn setup_clip4(
    backend: RasterBackend,
    corners: &[[Vec4; 3]; SETUP_LANES],
    vp: &Viewport,
    rule: SetupRule,
    items: [u32; SETUP_LANES],
    out: &mut Vec<Tri>,
) -> bool {
    match backend {
        #[cfg(target_arch = "x86_64")]
        RasterBackend::Avx2 | RasterBackend::Avx512 if std::arch::is_x86_feature_detected!("avx2") => {
            // SAFETY: AVX2 is available (checked above; the check is cached by std).
            unsafe { x86::setup_clip4_avx2(corners, vp, rule, items, out) }
        }
        _ => false,
    }
}

/// The triangles `indices` of the clip-space `vertices` (hom's convention)
/// set up by the exact rule, none culled, with `item`: onto `out` what
/// [`setup_triangle`](super::setup::setup_triangle) pushes for each in turn,
/// four at a time by `backend`'s kernel where it has one and none of the
/// four needs clipping. For a few small meshes a frame (the per-sample depth
/// check's objects), where the queue's chunks and batches cost more than
/// they save.
///
/// # Panics
/// If an index is out of `vertices`.
pub fn setup_triangles(
    backend: RasterBackend,
    vertices: &[Vec4],
    indices: &[[u32; 3]],
    vp: &Viewport,
    item: u32,
    out: &mut Vec<Tri>,
) {
    let rule = SetupRule::default();
    let corners_of = |t: &[u32; 3]| t.map(|i| vertices[i as usize]);
    let mut fours = indices.chunks_exact(SETUP_LANES);
    for four in &mut fours {
        let corners = std::array::from_fn(|l| corners_of(&four[l]));
        set_up_four(backend, &corners, vp, rule, [item; SETUP_LANES], out);
    }
    for t in fours.remainder() {
        set_up_one(corners_of(t), vp, rule, item, out);
    }
}

/// Four triangles given by their clip-space corners onto `out`, with
/// `items[i]` and no colour, as [`setup_triangle_with`] sets each up in
/// turn: by `backend`'s kernel where it has one and none of the four needs
/// clipping, else one by one ([`set_up_one`]).
pub(crate) fn set_up_four(
    backend: RasterBackend,
    corners: &[[Vec4; 3]; SETUP_LANES],
    vp: &Viewport,
    rule: SetupRule,
    items: [u32; SETUP_LANES],
    out: &mut Vec<Tri>,
) {
    if !setup_clip4(backend, corners, vp, rule, items, out) {
        for (&c, item) in corners.iter().zip(items) {
            set_up_one(c, vp, rule, item, out);
        }
    }
}

/// One triangle given by its clip-space corners onto `out`, with `item` and
/// no colour, by the scalar setup ([`Vertex::new`], [`setup_triangle_with`]).
pub(crate) fn set_up_one(corners: [Vec4; 3], vp: &Viewport, rule: SetupRule, item: u32, out: &mut Vec<Tri>) {
    let [p, q, r] = corners.map(|v| Vertex::new(v, vp));
    setup_triangle_with([&p, &q, &r], vp, rule, item, [0; 4], out);
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{SetupRule, Tri, Vec4, Viewport, SETUP_LANES};
    use crate::raster::setup::{FaceCull, HALF, LIMIT_PX, ONE};
    use std::arch::x86_64::*;

    /// Four `i64` lanes as an array.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn lanes64(v: __m256i) -> [i64; 4] {
        let mut a = [0i64; 4];
        // SAFETY: an unaligned store of four `i64`.
        unsafe { _mm256_storeu_si256(a.as_mut_ptr().cast(), v) };
        a
    }

    /// Four `i32` lanes as an array.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn lanes32(v: __m128i) -> [i32; 4] {
        let mut a = [0i32; 4];
        // SAFETY: an unaligned store of four `i32`.
        unsafe { _mm_storeu_si128(a.as_mut_ptr().cast(), v) };
        a
    }

    /// Four `f32` lanes as an array.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn lanes_f32(v: __m128) -> [f32; 4] {
        let mut a = [0f32; 4];
        // SAFETY: an unaligned store of four `f32`.
        unsafe { _mm_storeu_ps(a.as_mut_ptr(), v) };
        a
    }

    /// `a · b` of `i32` lanes as exact `i64` lanes.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn mul64(a: __m128i, b: __m128i) -> __m256i {
        _mm256_mul_epi32(_mm256_cvtepi32_epi64(a), _mm256_cvtepi32_epi64(b))
    }

    /// The four triangles' corner `k`, projected and snapped as
    /// [`crate::raster::setup::Vertex::new`] does: `(x, y, z)`, whether it is
    /// unusable (non-finite, or finite and in the view's reach but not
    /// projectable), whether it needs clipping (near plane or guard band),
    /// and its frustum outcode bits 0..=5. Lanes not `direct` hold garbage
    /// coordinates.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn corner(corners: &[[Vec4; 3]; SETUP_LANES], k: usize, vp: &Viewport) -> Corner {
        let c = |f: fn(&Vec4) -> f32| {
            _mm_setr_ps(
                f(&corners[0][k]),
                f(&corners[1][k]),
                f(&corners[2][k]),
                f(&corners[3][k]),
            )
        };
        let (x, y, z, w) = (c(|v| v.x), c(|v| v.y), c(|v| v.z), c(|v| v.w));
        let zero = _mm_setzero_ps();
        // Finite iff v - v == 0 (NaN for NaN and infinities).
        let finite = |v: __m128| _mm_cmpeq_ps(_mm_sub_ps(v, v), zero);
        let fin = _mm_and_ps(_mm_and_ps(finite(x), finite(y)), _mm_and_ps(finite(z), finite(w)));
        let neg_w = _mm_sub_ps(zero, w);
        let bit = |m: __m128, b: i32| _mm_and_si128(_mm_castps_si128(m), _mm_set1_epi32(b));
        let code = _mm_or_si128(
            _mm_or_si128(
                _mm_or_si128(bit(_mm_cmplt_ps(x, neg_w), 1), bit(_mm_cmpgt_ps(x, w), 2)),
                _mm_or_si128(bit(_mm_cmplt_ps(y, neg_w), 4), bit(_mm_cmpgt_ps(y, w), 8)),
            ),
            _mm_or_si128(bit(_mm_cmplt_ps(z, zero), 16), bit(_mm_cmpgt_ps(z, w), 32)),
        );
        let abs = |v: __m128| _mm_andnot_ps(_mm_set1_ps(-0.0), v);
        let in_guard = _mm_and_ps(
            _mm_cmple_ps(abs(x), _mm_mul_ps(_mm_set1_ps(vp.gx), w)),
            _mm_cmple_ps(abs(y), _mm_mul_ps(_mm_set1_ps(vp.gy), w)),
        );
        let near = _mm_cmplt_ps(z, zero);
        let clipped = _mm_or_ps(near, _mm_xor_ps(in_guard, _mm_castsi128_ps(_mm_set1_epi32(-1))));
        // Projection: (x / w · 0.5 + 0.5) · width, (0.5 − y / w · 0.5) · height, z / w.
        let iw = _mm_div_ps(_mm_set1_ps(1.0), w);
        let half = _mm_set1_ps(0.5);
        let sx = _mm_mul_ps(
            _mm_add_ps(_mm_mul_ps(_mm_mul_ps(x, iw), half), half),
            _mm_set1_ps(vp.width as f32),
        );
        let sy = _mm_mul_ps(
            _mm_sub_ps(half, _mm_mul_ps(_mm_mul_ps(y, iw), half)),
            _mm_set1_ps(vp.height as f32),
        );
        let zw = _mm_mul_ps(z, iw);
        let limit = _mm_set1_ps(LIMIT_PX);
        let projected = _mm_and_ps(
            _mm_and_ps(_mm_cmpgt_ps(w, zero), finite(zw)),
            _mm_and_ps(_mm_cmple_ps(abs(sx), limit), _mm_cmple_ps(abs(sy), limit)),
        );
        // Unusable: not finite, or needing no clipping and not projectable.
        let bad = _mm_or_ps(
            _mm_xor_ps(fin, _mm_castsi128_ps(_mm_set1_epi32(-1))),
            _mm_andnot_ps(_mm_or_ps(clipped, projected), _mm_castsi128_ps(_mm_set1_epi32(-1))),
        );
        // snap(p) = floor(p · ONE + 0.5): truncate, then step down where that rounded up.
        let snap = |p: __m128| {
            let f = _mm_add_ps(_mm_mul_ps(p, _mm_set1_ps(ONE as f32)), half);
            let i = _mm_cvttps_epi32(f);
            _mm_add_epi32(i, _mm_castps_si128(_mm_cmpgt_ps(_mm_cvtepi32_ps(i), f)))
        };
        Corner {
            x: snap(sx),
            y: snap(sy),
            z: zw,
            bad: _mm_castps_si128(bad),
            clipped: _mm_castps_si128(clipped),
            code,
        }
    }

    /// One corner of four triangles; see [`corner`].
    #[derive(Clone, Copy)]
    struct Corner {
        x: __m128i,
        y: __m128i,
        z: __m128,
        bad: __m128i,
        clipped: __m128i,
        code: __m128i,
    }

    /// [`super::setup_clip4`] with AVX2; see the module docs.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn setup_clip4_avx2(
        corners: &[[Vec4; 3]; SETUP_LANES],
        vp: &Viewport,
        rule: SetupRule,
        items: [u32; SETUP_LANES],
        out: &mut Vec<Tri>,
    ) -> bool {
        let [c0, c1, c2] = [0, 1, 2].map(|k| corner(corners, k, vp));
        // Dropped whole before any clipping: an unusable corner, or all three outside one plane.
        let outside = _mm_cmpeq_epi32(
            _mm_and_si128(_mm_and_si128(c0.code, c1.code), c2.code),
            _mm_setzero_si128(),
        );
        let dropped = _mm_or_si128(
            _mm_or_si128(_mm_or_si128(c0.bad, c1.bad), c2.bad),
            _mm_xor_si128(outside, _mm_set1_epi32(-1)),
        );
        let clipped = _mm_or_si128(_mm_or_si128(c0.clipped, c1.clipped), c2.clipped);
        if _mm_testz_si128(_mm_andnot_si128(dropped, clipped), _mm_set1_epi32(-1)) == 0 {
            return false; // one of them is clipped: the scalar setup does all four
        }
        let live = _mm_xor_si128(dropped, _mm_set1_epi32(-1));
        let (x0, mut x1, mut x2) = (c0.x, c1.x, c2.x);
        let (y0, mut y1, mut y2) = (c0.y, c1.y, c2.y);
        let (z0, mut z1, mut z2) = (c0.z, c1.z, c2.z);
        let area = _mm256_sub_epi64(
            mul64(_mm_sub_epi32(x1, x0), _mm_sub_epi32(y2, y0)),
            mul64(_mm_sub_epi32(x2, x0), _mm_sub_epi32(y1, y0)),
        );
        let zero64 = _mm256_setzero_si256();
        let (positive, negative) = (_mm256_cmpgt_epi64(area, zero64), _mm256_cmpgt_epi64(zero64, area));
        // Lanes kept: a nonzero area of a winding the rule keeps.
        let kept = match rule.cull {
            FaceCull::None => _mm256_or_si256(positive, negative),
            FaceCull::Clockwise => negative,
            FaceCull::CounterClockwise => positive,
        };
        // The areas' signs as 32-bit lanes (the low half of each 64-bit mask).
        let pick_low = _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6);
        let swap = _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(negative, pick_low));
        let mut kept_lanes = _mm_and_si128(
            live,
            _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(kept, pick_low)),
        );
        // Two-sided: where the area is negative, v1 and v2 trade places.
        (x1, x2) = (_mm_blendv_epi8(x1, x2, swap), _mm_blendv_epi8(x2, x1, swap));
        (y1, y2) = (_mm_blendv_epi8(y1, y2, swap), _mm_blendv_epi8(y2, y1, swap));
        let swap_ps = _mm_castsi128_ps(swap);
        (z1, z2) = (_mm_blendv_ps(z1, z2, swap_ps), _mm_blendv_ps(z2, z1, swap_ps));
        // The pixel box (floor division by ONE is an arithmetic shift).
        let (min_x, max_x) = (
            _mm_min_epi32(_mm_min_epi32(x0, x1), x2),
            _mm_max_epi32(_mm_max_epi32(x0, x1), x2),
        );
        let (min_y, max_y) = (
            _mm_min_epi32(_mm_min_epi32(y0, y1), y2),
            _mm_max_epi32(_mm_max_epi32(y0, y1), y2),
        );
        let bits = ONE.trailing_zeros() as i32;
        let first = |m: __m128i| {
            _mm_max_epi32(
                _mm_sra_epi32(
                    _mm_add_epi32(m, _mm_set1_epi32((ONE - 1 - HALF) as i32)),
                    _mm_cvtsi32_si128(bits),
                ),
                _mm_setzero_si128(),
            )
        };
        let past = |m: __m128i, size: u32| {
            let last = _mm_sra_epi32(_mm_sub_epi32(m, _mm_set1_epi32(HALF as i32)), _mm_cvtsi32_si128(bits));
            _mm_min_epi32(_mm_add_epi32(last, _mm_set1_epi32(1)), _mm_set1_epi32(size as i32))
        };
        let (bx0, bx1) = (first(min_x), past(max_x, vp.width));
        let (by0, by1) = (first(min_y), past(max_y, vp.height));
        let boxed = _mm_and_si128(_mm_cmpgt_epi32(bx1, bx0), _mm_cmpgt_epi32(by1, by0));
        kept_lanes = _mm_and_si128(kept_lanes, boxed);
        let keep = _mm_movemask_ps(_mm_castsi128_ps(kept_lanes));
        if keep == 0 {
            return true;
        }
        // Inner rule bias, in i64: 3 (W + H) + 4.
        let bias = if rule.inner {
            let wh = _mm256_add_epi64(
                _mm256_cvtepi32_epi64(_mm_sub_epi32(max_x, min_x)),
                _mm256_cvtepi32_epi64(_mm_sub_epi32(max_y, min_y)),
            );
            _mm256_add_epi64(_mm256_add_epi64(wh, _mm256_add_epi64(wh, wh)), _mm256_set1_epi64x(4))
        } else {
            zero64
        };
        // Edges (v0, v1), (v1, v2), (v2, v0): E(s) = a s.x + b s.y + c.
        let verts = [(x0, y0), (x1, y1), (x2, y2)];
        let mut a = [[0i64; 4]; 3];
        let mut b = [[0i64; 4]; 3];
        let mut c = [[0i64; 4]; 3];
        for i in 0..3 {
            let ((px, py), (qx, _)) = (verts[i], verts[(i + 1) % 3]);
            let qy = verts[(i + 1) % 3].1;
            let ea = _mm_sub_epi32(py, qy);
            let eb = _mm_sub_epi32(qx, px);
            let zero = _mm_setzero_si128();
            let top_left = _mm_or_si128(
                _mm_cmpgt_epi32(ea, zero),
                _mm_and_si128(_mm_cmpeq_epi32(ea, zero), _mm_cmpgt_epi32(eb, zero)),
            );
            // -(ea px + eb py) - !top_left - bias; `top_left` is -1 or 0, so `!top_left` is `1 + top_left`.
            let dot = _mm256_add_epi64(mul64(ea, px), mul64(eb, py));
            let not_top_left = _mm256_add_epi64(_mm256_cvtepi32_epi64(top_left), _mm256_set1_epi64x(1));
            let ce = _mm256_sub_epi64(_mm256_sub_epi64(_mm256_sub_epi64(zero64, dot), not_top_left), bias);
            a[i] = lanes64(_mm256_cvtepi32_epi64(ea));
            b[i] = lanes64(_mm256_cvtepi32_epi64(eb));
            c[i] = lanes64(ce);
        }
        // The depth plane, in f64, in setup_screen's order of operations.
        let to_px = |v: __m128i| _mm256_mul_pd(_mm256_cvtepi32_pd(v), _mm256_set1_pd(1.0 / ONE as f64));
        let (x0f, y0f, z0d) = (to_px(x0), to_px(y0), _mm256_cvtps_pd(z0));
        let (dx1, dy1) = (_mm256_sub_pd(to_px(x1), x0f), _mm256_sub_pd(to_px(y1), y0f));
        let (dx2, dy2) = (_mm256_sub_pd(to_px(x2), x0f), _mm256_sub_pd(to_px(y2), y0f));
        let (dz1, dz2) = (
            _mm256_sub_pd(_mm256_cvtps_pd(z1), z0d),
            _mm256_sub_pd(_mm256_cvtps_pd(z2), z0d),
        );
        let det = _mm256_sub_pd(_mm256_mul_pd(dx1, dy2), _mm256_mul_pd(dx2, dy1));
        let inv_det = _mm256_div_pd(_mm256_set1_pd(1.0), det);
        let dzdx = _mm256_mul_pd(_mm256_sub_pd(_mm256_mul_pd(dz1, dy2), _mm256_mul_pd(dz2, dy1)), inv_det);
        let dzdy = _mm256_mul_pd(_mm256_sub_pd(_mm256_mul_pd(dz2, dx1), _mm256_mul_pd(dz1, dx2)), inv_det);
        let half = _mm256_set1_pd(0.5);
        let cx = _mm256_sub_pd(_mm256_add_pd(_mm256_cvtepi32_pd(bx0), half), x0f);
        let cy = _mm256_sub_pd(_mm256_add_pd(_mm256_cvtepi32_pd(by0), half), y0f);
        let mut zref = _mm256_add_pd(_mm256_add_pd(z0d, _mm256_mul_pd(dzdx, cx)), _mm256_mul_pd(dzdy, cy));
        if rule.inner {
            let abs = |v: __m256d| _mm256_andnot_pd(_mm256_set1_pd(-0.0), v);
            let plane = _mm256_mul_pd(_mm256_add_pd(abs(dzdx), abs(dzdy)), _mm256_set1_pd(4.0 / ONE as f64));
            let round = _mm256_mul_pd(
                _mm256_add_pd(
                    _mm256_mul_pd(abs(zref), _mm256_set1_pd(4.0)),
                    _mm256_set1_pd(crate::raster::setup::INNER_DEPTH_SLACK),
                ),
                _mm256_set1_pd(f64::from(f32::EPSILON)),
            );
            zref = _mm256_add_pd(zref, _mm256_add_pd(plane, round));
        }
        let (zref, dzdx, dzdy) = (
            lanes_f32(_mm256_cvtpd_ps(zref)),
            lanes_f32(_mm256_cvtpd_ps(dzdx)),
            lanes_f32(_mm256_cvtpd_ps(dzdy)),
        );
        let (bx0, bx1, by0, by1) = (lanes32(bx0), lanes32(bx1), lanes32(by0), lanes32(by1));
        for l in 0..SETUP_LANES {
            if keep >> l & 1 == 1 {
                out.push(Tri {
                    a: [a[0][l], a[1][l], a[2][l]],
                    b: [b[0][l], b[1][l], b[2][l]],
                    c: [c[0][l], c[1][l], c[2][l]],
                    x0: bx0[l] as u16,
                    y0: by0[l] as u16,
                    x1: bx1[l] as u16,
                    y1: by1[l] as u16,
                    zref: zref[l],
                    dzdx: dzdx[l],
                    dzdy: dzdy[l],
                    item: items[l],
                    colour: [0; 4],
                });
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::queue::{QueueSetup, TriangleQueue};
    use crate::raster::setup::FaceCull;
    use glam::Vec4;
    use hom_testkit::Rng;
    use proptest::prelude::*;

    proptest! {
        /// Random batches (each with a random face culling) of random
        /// triangles — tiny to screen-sized, some degenerate, some off screen
        /// or through the near plane, some with non-finite or tiny or
        /// negative `w` corners, vertices on pixel centres now and then
        /// (top-left ties): every backend sets up the same triangles as the
        /// scalar setup, bit for bit and in order.
        #[test]
        fn every_backend_sets_up_the_scalar_triangles(seed in any::<u64>(), w in 1u32..500, h in 1u32..300, inner in any::<bool>()) {
            let mut rng = Rng::new(seed);
            let mut q = TriangleQueue::default();
            for _ in 0..1 + rng.below(6) {
                let n = 1 + rng.below(40) as usize;
                let mut v = Vec::new();
                for _ in 0..3 * n {
                    let (x, y) = if rng.below(5) == 0 {
                        // A pixel centre.
                        let (px, py) = (rng.below(u64::from(w)) as f32 + 0.5, rng.below(u64::from(h)) as f32 + 0.5);
                        (px / w as f32 * 2.0 - 1.0, 1.0 - py / h as f32 * 2.0)
                    } else {
                        (rng.range(-1.2, 1.2), rng.range(-1.2, 1.2))
                    };
                    let wv = rng.range(0.5, 8.0);
                    let z = if rng.below(20) == 0 { -0.1 } else { rng.range(0.0, 1.3) };
                    v.push(Vec4::new(x * wv, y * wv, z * wv, wv));
                }
                // Some triangles small: pull their vertices towards the first.
                for t in 0..n {
                    if rng.below(2) == 0 {
                        let s = [0.001, 0.01, 0.05][rng.below(3) as usize];
                        let c = v[3 * t];
                        for k in 1..3 {
                            v[3 * t + k] = c + (v[3 * t + k] - c) * s;
                        }
                    }
                    if rng.below(15) == 0 {
                        v[3 * t + 2] = v[3 * t + 1]; // degenerate
                    }
                    if rng.below(40) == 0 {
                        v[3 * t + rng.below(3) as usize][rng.below(4) as usize] =
                            [f32::NAN, f32::INFINITY, -1.0e30][rng.below(3) as usize];
                    }
                    if rng.below(30) == 0 {
                        v[3 * t + rng.below(3) as usize].w = [0.0, -1.0, 1.0e-30][rng.below(3) as usize];
                    }
                }
                let idx: Vec<[u32; 3]> = (0..n as u32).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
                let cull = [FaceCull::None, FaceCull::Clockwise, FaceCull::CounterClockwise][rng.below(3) as usize];
                q.push_clip(&v, &idx, |v| v, cull).unwrap();
            }
            let vp = Viewport::new(w, h);
            let setup = |q: &mut TriangleQueue, backend| {
                let mut out = Vec::new();
                let setup = QueueSetup {
                    backend,
                    viewport: vp,
                    inner,
                    parallel: true,
                };
                q.set_up_with(&setup, &mut out);
                out.iter().map(|t| format!("{t:?}")).collect::<Vec<_>>()
            };
            let want = setup(&mut q, RasterBackend::Scalar);
            for backend in RasterBackend::supported() {
                prop_assert_eq!(&setup(&mut q, backend), &want, "{:?}", backend);
            }
        }
    }

    proptest! {
        /// A mesh's indexed triangles, some through the near plane or off
        /// screen, some with unusable corners: `setup_triangles` pushes with
        /// every backend what `setup_triangle` pushes for each in turn.
        #[test]
        fn setup_triangles_is_setup_triangle_in_turn(seed in any::<u64>(), n in 1usize..40, w in 1u32..400, h in 1u32..300) {
            let mut rng = Rng::new(seed);
            let v: Vec<Vec4> = (0..n + 2)
                .map(|_| {
                    let wv = rng.range(0.5, 8.0);
                    let z = if rng.below(10) == 0 { -0.2 } else { rng.range(0.0, 1.2) };
                    let mut c = Vec4::new(rng.range(-1.3, 1.3) * wv, rng.range(-1.3, 1.3) * wv, z * wv, wv);
                    if rng.below(40) == 0 {
                        c.w = [f32::NAN, 0.0, -1.0][rng.below(3) as usize];
                    }
                    c
                })
                .collect();
            let idx: Vec<[u32; 3]> = (0..n)
                .map(|_| std::array::from_fn(|_| rng.below(v.len() as u64) as u32))
                .collect();
            let vp = Viewport::new(w, h);
            let mut want = Vec::new();
            for t in &idx {
                let [p, q, r] = t.map(|i| Vertex::new(v[i as usize], &vp));
                setup_triangle_with([&p, &q, &r], &vp, SetupRule::default(), 7, [0; 4], &mut want);
            }
            let want: Vec<String> = want.iter().map(|t| format!("{t:?}")).collect();
            for backend in RasterBackend::supported() {
                let mut got = Vec::new();
                setup_triangles(backend, &v, &idx, &vp, 7, &mut got);
                let got: Vec<String> = got.iter().map(|t| format!("{t:?}")).collect();
                prop_assert_eq!(&got, &want, "{:?}", backend);
            }
        }
    }
}
