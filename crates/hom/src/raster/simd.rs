//! Row-coverage kernels for the occluder rasterizer: the one place in the
//! crate for `unsafe` and `std::arch`.
//!
//! [`RasterBackend::Scalar`] defines the semantics: each row's covered span
//! comes from [`Tri::row_span`]. The vector backends compute, for triangles
//! whose bounding box is at most [`MASK_MAX`] samples wide, a bit mask per row
//! by evaluating the same exact integer edge functions at every sample of the
//! box, several samples per vector (`E_i = e_i + k * s_i`, stepped
//! incrementally; covered iff all three are `>= 0`, read as the sign bit of
//! `E_0 | E_1 | E_2`). The integers and the test are the scalar ones, so the
//! covered samples are bit-identical; wider boxes take the scalar span path.
//!
//! The backend is chosen once per process ([`RasterBackend::active`]): the
//! best the CPU supports, unless the environment variable `HOM_FORCE_SCALAR`
//! is set to anything but `0` or the empty string, which forces
//! [`RasterBackend::Scalar`].

use super::setup::{Tri, ONE};
use std::sync::OnceLock;

/// Triangles whose bounding box is at most this many samples wide get their
/// row masks from a vector kernel; wider ones use [`Tri::row_span`].
pub const MASK_MAX: u32 = 64;

/// The environment variable that forces [`RasterBackend::Scalar`] when set to
/// anything but `0` or the empty string (read once, by [`RasterBackend::active`]).
pub const FORCE_SCALAR_ENV: &str = "HOM_FORCE_SCALAR";

/// How the occluder rasterizer computes row coverage. Every backend covers
/// exactly the same samples; they differ only in speed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RasterBackend {
    /// Portable scalar code: one exact span per row ([`Tri::row_span`]). Defines the semantics.
    Scalar,
    /// x86-64 SSE2 (part of the x86-64 baseline): 2 samples per 128-bit vector.
    Sse2,
    /// x86-64 AVX2: 4 samples per 256-bit vector.
    Avx2,
}

impl RasterBackend {
    /// Every backend, slowest first.
    pub const ALL: [RasterBackend; 3] = [RasterBackend::Scalar, RasterBackend::Sse2, RasterBackend::Avx2];

    /// Whether this CPU can run the backend.
    pub fn is_supported(self) -> bool {
        match self {
            RasterBackend::Scalar => true,
            #[cfg(target_arch = "x86_64")]
            RasterBackend::Sse2 => true,
            #[cfg(target_arch = "x86_64")]
            RasterBackend::Avx2 => std::arch::is_x86_feature_detected!("avx2"),
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// The backends this CPU supports, slowest first (always starts with `Scalar`).
    pub fn supported() -> Vec<RasterBackend> {
        RasterBackend::ALL.into_iter().filter(|b| b.is_supported()).collect()
    }

    /// The fastest backend this CPU supports (ignores `HOM_FORCE_SCALAR`);
    /// detected once and cached.
    pub fn detect() -> RasterBackend {
        static DETECTED: OnceLock<RasterBackend> = OnceLock::new();
        *DETECTED.get_or_init(|| {
            RasterBackend::supported()
                .last()
                .copied()
                .unwrap_or(RasterBackend::Scalar)
        })
    }

    /// The backend the rasterizer uses by default: [`RasterBackend::detect`],
    /// or `Scalar` when `HOM_FORCE_SCALAR` is set (to anything but `0` or
    /// empty). Decided once per process and cached.
    pub fn active() -> RasterBackend {
        static ACTIVE: OnceLock<RasterBackend> = OnceLock::new();
        *ACTIVE.get_or_init(|| {
            let forced = std::env::var_os(FORCE_SCALAR_ENV).is_some_and(|v| !v.is_empty() && v != "0");
            if forced {
                RasterBackend::Scalar
            } else {
                RasterBackend::detect()
            }
        })
    }

    /// A short lower-case name (`scalar`, `sse2`, `avx2`).
    pub fn name(self) -> &'static str {
        match self {
            RasterBackend::Scalar => "scalar",
            RasterBackend::Sse2 => "sse2",
            RasterBackend::Avx2 => "avx2",
        }
    }
}

impl Default for RasterBackend {
    /// [`RasterBackend::active`].
    fn default() -> RasterBackend {
        RasterBackend::active()
    }
}

/// Row masks of `t` for rows `py0..py0 + out.len()` (all within `t.y0..t.y1`):
/// bit `k` of `out[r]` is set iff the sample at column `t.x0 + k` of row
/// `py0 + r` is covered. Needs `t.x1 - t.x0 <= MASK_MAX`. An unsupported
/// backend computes the masks with the scalar loop.
pub(crate) fn row_masks(backend: RasterBackend, t: &Tri, py0: u32, out: &mut [u64]) {
    let n = u32::from(t.x1 - t.x0);
    debug_assert!((1..=MASK_MAX).contains(&n));
    debug_assert!(py0 >= u32::from(t.y0) && py0 + out.len() as u32 <= u32::from(t.y1));
    let e = t.edges_at_row(py0);
    let s = t.a.map(|a| a * ONE);
    let dy = t.b.map(|b| b * ONE);
    match backend {
        #[cfg(target_arch = "x86_64")]
        RasterBackend::Avx2 if std::arch::is_x86_feature_detected!("avx2") => {
            // SAFETY: the CPU supports AVX2 (checked just above), the only
            // requirement of this `target_feature` function.
            unsafe { x86::row_masks_avx2(e, s, dy, n, out) }
        }
        #[cfg(target_arch = "x86_64")]
        RasterBackend::Sse2 => x86::row_masks_sse2(e, s, dy, n, out),
        _ => row_masks_scalar(e, s, dy, n, out),
    }
}

/// The mask of the low `n` bits (`1 <= n <= 64`).
#[inline]
fn low_bits(n: u32) -> u64 {
    u64::MAX >> (64 - n)
}

/// Scalar row masks: the per-sample test, row after row.
fn row_masks_scalar(mut e: [i64; 3], s: [i64; 3], dy: [i64; 3], n: u32, out: &mut [u64]) {
    for m in out {
        let mut c = e;
        let mut bits = 0;
        for k in 0..n {
            bits |= u64::from((c[0] | c[1] | c[2]) >= 0) << k;
            for i in 0..3 {
                c[i] = c[i].wrapping_add(s[i]);
            }
        }
        *m = bits;
        e = [0, 1, 2].map(|i| e[i].wrapping_add(dy[i]));
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::low_bits;
    use std::arch::x86_64::*;

    /// Row masks, 4 samples per 256-bit vector of `i64` lanes (see [`super::row_masks`]).
    /// Lanes past the box may wrap; their bits are masked off.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    #[allow(unused_unsafe)] // intrinsics are safe here from Rust 1.87 on, unsafe before
    pub(super) unsafe fn row_masks_avx2(e: [i64; 3], s: [i64; 3], dy: [i64; 3], n: u32, out: &mut [u64]) {
        // SAFETY: this function is compiled with AVX2 and its caller guarantees
        // the CPU supports it; the intrinsics only touch registers.
        unsafe {
            let vectors = n.div_ceil(4);
            let valid = low_bits(n);
            let lane = |e: i64, s: i64| {
                _mm256_set_epi64x(
                    e.wrapping_add(s.wrapping_mul(3)),
                    e.wrapping_add(s.wrapping_mul(2)),
                    e.wrapping_add(s),
                    e,
                )
            };
            // Edge values at the row's first 4 samples, carried from row to row.
            let (mut r0, mut r1, mut r2) = (lane(e[0], s[0]), lane(e[1], s[1]), lane(e[2], s[2]));
            let (d0, d1, d2) = (
                _mm256_set1_epi64x(dy[0]),
                _mm256_set1_epi64x(dy[1]),
                _mm256_set1_epi64x(dy[2]),
            );
            let step = |s: i64| _mm256_set1_epi64x(s.wrapping_mul(4));
            let (s0, s1, s2) = (step(s[0]), step(s[1]), step(s[2]));
            let outside = |c0: __m256i, c1: __m256i, c2: __m256i| {
                // Sign bits: set where some edge is negative (sample outside).
                let any = _mm256_or_si256(_mm256_or_si256(c0, c1), c2);
                _mm256_movemask_pd(_mm256_castsi256_pd(any)) as u64
            };
            if vectors == 1 {
                // The common tall, thin box: one vector per row.
                for m in out {
                    *m = !outside(r0, r1, r2) & valid;
                    r0 = _mm256_add_epi64(r0, d0);
                    r1 = _mm256_add_epi64(r1, d1);
                    r2 = _mm256_add_epi64(r2, d2);
                }
                return;
            }
            for m in out {
                let (mut c0, mut c1, mut c2) = (r0, r1, r2);
                let mut out_bits = 0u64;
                for v in 0..vectors {
                    out_bits |= outside(c0, c1, c2) << (4 * v);
                    c0 = _mm256_add_epi64(c0, s0);
                    c1 = _mm256_add_epi64(c1, s1);
                    c2 = _mm256_add_epi64(c2, s2);
                }
                *m = !out_bits & valid;
                r0 = _mm256_add_epi64(r0, d0);
                r1 = _mm256_add_epi64(r1, d1);
                r2 = _mm256_add_epi64(r2, d2);
            }
        }
    }

    /// Row masks, 2 samples per 128-bit vector of `i64` lanes (SSE2, always
    /// available on x86-64; see [`super::row_masks`]).
    pub(super) fn row_masks_sse2(e: [i64; 3], s: [i64; 3], dy: [i64; 3], n: u32, out: &mut [u64]) {
        // SAFETY: SSE2 is part of the x86-64 baseline, so every x86-64 CPU
        // runs these intrinsics; they only touch registers.
        #[allow(unused_unsafe)] // intrinsics are safe here from Rust 1.87 on, unsafe before
        unsafe {
            let vectors = n.div_ceil(2);
            let valid = low_bits(n);
            let lane = |e: i64, s: i64| _mm_set_epi64x(e.wrapping_add(s), e);
            // Edge values at the row's first 2 samples, carried from row to row.
            let (mut r0, mut r1, mut r2) = (lane(e[0], s[0]), lane(e[1], s[1]), lane(e[2], s[2]));
            let (d0, d1, d2) = (_mm_set1_epi64x(dy[0]), _mm_set1_epi64x(dy[1]), _mm_set1_epi64x(dy[2]));
            let step = |s: i64| _mm_set1_epi64x(s.wrapping_mul(2));
            let (s0, s1, s2) = (step(s[0]), step(s[1]), step(s[2]));
            for m in out {
                let (mut c0, mut c1, mut c2) = (r0, r1, r2);
                let mut out_bits = 0u64;
                for v in 0..vectors {
                    // Sign bits: set where some edge is negative (sample outside).
                    let any = _mm_or_si128(_mm_or_si128(c0, c1), c2);
                    out_bits |= (_mm_movemask_pd(_mm_castsi128_pd(any)) as u64) << (2 * v);
                    c0 = _mm_add_epi64(c0, s0);
                    c1 = _mm_add_epi64(c1, s1);
                    c2 = _mm_add_epi64(c2, s2);
                }
                *m = !out_bits & valid;
                r0 = _mm_add_epi64(r0, d0);
                r1 = _mm_add_epi64(r1, d1);
                r2 = _mm_add_epi64(r2, d2);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Kernel masks equal `row_span` on every row of many random boxes.
    #[test]
    fn kernels_match_row_span() {
        use super::super::setup::{setup_triangle, Vertex, Viewport};
        use glam::Vec4;
        let mut seed = 0x2545_F491_4F6C_DD1Du64;
        let mut rnd = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f32 / (1u64 << 53) as f32
        };
        let (w, h) = (200u32, 150u32);
        let vp = Viewport::new(w, h);
        let mut tris = Vec::new();
        for _ in 0..4000 {
            let scale = [1.0, 3.0, 8.0, 30.0, 70.0, 400.0][(rnd() * 6.0) as usize % 6];
            let (cx, cy) = (rnd() * 220.0 - 10.0, rnd() * 170.0 - 10.0);
            let v = [0, 1, 2].map(|_| {
                let (x, y) = (cx + (rnd() - 0.5) * scale, cy + (rnd() - 0.5) * scale);
                Vertex::new(
                    Vec4::new(x / w as f32 * 2.0 - 1.0, 1.0 - y / h as f32 * 2.0, rnd(), 1.0),
                    &vp,
                )
            });
            setup_triangle([&v[0], &v[1], &v[2]], &vp, 0, [0; 4], &mut tris);
        }
        let mut checked = [0usize; 3];
        for t in tris.iter().filter(|t| u32::from(t.x1 - t.x0) <= MASK_MAX) {
            let rows = usize::from(t.y1 - t.y0);
            let expect: Vec<u64> = (u32::from(t.y0)..u32::from(t.y1))
                .map(|py| {
                    let span = t.row_span(py).map_or(0..0, |(lo, hi)| lo..hi);
                    span.fold(0, |m, x| m | 1 << (x - u32::from(t.x0)))
                })
                .collect();
            for (bi, b) in RasterBackend::ALL.into_iter().enumerate() {
                if !b.is_supported() {
                    continue;
                }
                let mut got = vec![0; rows];
                row_masks(b, t, u32::from(t.y0), &mut got);
                assert_eq!(got, expect, "{b:?} on {t:?}");
                checked[bi] += 1;
            }
        }
        assert!(checked[0] > 1000, "{checked:?}");
        eprintln!("row-mask kernels checked (scalar, sse2, avx2): {checked:?}");
    }

    #[test]
    fn active_is_supported() {
        assert!(RasterBackend::detect().is_supported());
        assert!(RasterBackend::active().is_supported());
        assert_eq!(RasterBackend::supported()[0], RasterBackend::Scalar);
    }
}
