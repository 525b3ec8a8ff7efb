//! Row-coverage kernels for the occluder rasterizer: the one place in the
//! crate for `unsafe` and `std::arch`.
//!
//! [`RasterBackend::Scalar`] defines the semantics: each row's covered span
//! comes from [`Tri::row_span`]. The vector backends compute, for triangles
//! whose bounding box is at most [`MASK_MAX`] samples wide, a bit mask per row
//! by evaluating the same exact integer edge functions at every sample of the
//! box, several samples per vector of `i64` lanes (`E_i = e_i + k * s_i`,
//! stepped incrementally; covered iff all three are `>= 0`, i.e. the sign bit
//! of `E_0 | E_1 | E_2` is clear). The integers and the test are the scalar
//! ones, so the covered samples are bit-identical; wider boxes take the scalar
//! span path.
//!
//! All vector kernels share one structure (the `kernel!` macro below):
//! - a box at most half a vector wide packs several rows into one vector
//!   (`lanes / width` rows: a one-sample-wide box tests 8 rows per AVX-512
//!   compare), since most occluder boxes are tall and thin;
//! - a box at most one vector wide takes one vector per row;
//! - a wider box steps along the row vector by vector. (Stopping once past
//!   the covered samples, which are contiguous, was tried: its mispredicted
//!   branches made 5–64-wide boxes 1.1–1.7× slower.)
//!
//! | backend | lanes | covered bits of a vector |
//! |---|---|---|
//! | [`RasterBackend::Sse41`] | 2 | `por`, `movmskpd` (SSE2; SSE4.1 adds nothing this test needs) |
//! | [`RasterBackend::Avx2`] | 4 | `vpor`, `vmovmskpd` |
//! | [`RasterBackend::Avx512`] | 8 | `vpternlogq` (3-way OR), `vpcmpq` to a mask register (AVX-512F only) |
//!
//! The backend is chosen once per process ([`RasterBackend::active`]): the
//! best the CPU supports ([`RasterBackend::detect`]); the environment variable
//! [`BACKEND_ENV`] (`HOM_RASTER_BACKEND=scalar|sse41|avx2|avx512`) picks
//! another, and [`FORCE_SCALAR_ENV`] (`HOM_FORCE_SCALAR=1`) forces
//! [`RasterBackend::Scalar`] whatever `HOM_RASTER_BACKEND` says.

use super::setup::{Tri, ONE};
use std::ffi::OsStr;
use std::sync::OnceLock;

/// Triangles whose bounding box is at most this many samples wide get their
/// row masks from a vector kernel; wider ones use [`Tri::row_span`].
pub const MASK_MAX: u32 = 64;

/// The environment variable that forces [`RasterBackend::Scalar`] when set to
/// anything but `0` or the empty string (read once, by [`RasterBackend::active`]).
/// It wins over [`BACKEND_ENV`]; CI runs the raster tests with it set.
pub const FORCE_SCALAR_ENV: &str = "HOM_FORCE_SCALAR";

/// The environment variable that picks the raster backend by name
/// ([`RasterBackend::name`]: `scalar`, `sse41`, `avx2`, `avx512`; ASCII case
/// ignored), read once by [`RasterBackend::active`]. Unset or empty means
/// [`RasterBackend::detect`]. A name that is not a backend, or one this CPU
/// does not support, also falls back to `detect()` and prints one warning line
/// to stderr (once per process); it never aborts, so a script written for
/// another machine still runs. [`FORCE_SCALAR_ENV`] wins over it.
pub const BACKEND_ENV: &str = "HOM_RASTER_BACKEND";

/// How the occluder rasterizer computes row coverage. Every backend covers
/// exactly the same samples; they differ only in speed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RasterBackend {
    /// Portable scalar code: one exact span per row ([`Tri::row_span`]). Defines the semantics.
    Scalar,
    /// x86-64 SSE4.1: 2 samples per 128-bit vector.
    Sse41,
    /// x86-64 AVX2: 4 samples per 256-bit vector.
    Avx2,
    /// x86-64 AVX-512F: 8 samples per 512-bit vector, covered bits straight
    /// from a compare into a mask register.
    Avx512,
}

impl RasterBackend {
    /// Every backend, narrowest first.
    pub const ALL: [RasterBackend; 4] = [
        RasterBackend::Scalar,
        RasterBackend::Sse41,
        RasterBackend::Avx2,
        RasterBackend::Avx512,
    ];

    /// Whether this CPU can run the backend.
    pub fn is_supported(self) -> bool {
        match self {
            RasterBackend::Scalar => true,
            #[cfg(target_arch = "x86_64")]
            RasterBackend::Sse41 => std::arch::is_x86_feature_detected!("sse4.1"),
            #[cfg(target_arch = "x86_64")]
            RasterBackend::Avx2 => std::arch::is_x86_feature_detected!("avx2"),
            #[cfg(target_arch = "x86_64")]
            RasterBackend::Avx512 => std::arch::is_x86_feature_detected!("avx512f"),
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// The backends this CPU supports, narrowest first (always starts with `Scalar`).
    pub fn supported() -> Vec<RasterBackend> {
        RasterBackend::ALL.into_iter().filter(|b| b.is_supported()).collect()
    }

    /// The backend to draw with on this CPU (ignores the environment): AVX2
    /// where the CPU has it, else the widest it supports; detected once and
    /// cached. AVX-512 stays one setting away ([`BACKEND_ENV`],
    /// [`crate::BufferOptions::backend`]), but on the AVX-512 host
    /// measured (a Xeon with AVX-512 FP16, 2026-12-05) AVX2 was faster on
    /// every input: the z path's setup + render 5–26 % less on all 18 MOC
    /// inputs, HOM's map up to 21 % and masked up to 16 % less, HOM's city
    /// raster 4–5 % less at one and two threads. The 512-bit kernels do more
    /// per instruction, but their share of the work is small and the rest of
    /// the raster runs slower beside them.
    pub fn detect() -> RasterBackend {
        static DETECTED: OnceLock<RasterBackend> = OnceLock::new();
        *DETECTED.get_or_init(|| {
            let supported = RasterBackend::supported();
            if supported.contains(&RasterBackend::Avx2) {
                RasterBackend::Avx2
            } else {
                supported.last().copied().unwrap_or(RasterBackend::Scalar)
            }
        })
    }

    /// The backend the rasterizer uses by default: `Scalar` when
    /// [`FORCE_SCALAR_ENV`] is set (to anything but `0` or empty), else the one
    /// [`BACKEND_ENV`] names if this CPU supports it, else
    /// [`RasterBackend::detect`] (with one warning line on stderr when
    /// `HOM_RASTER_BACKEND` named an unknown or unsupported backend). Decided
    /// once per process and cached.
    pub fn active() -> RasterBackend {
        static ACTIVE: OnceLock<RasterBackend> = OnceLock::new();
        *ACTIVE.get_or_init(|| {
            let force = std::env::var_os(FORCE_SCALAR_ENV);
            let name = std::env::var_os(BACKEND_ENV);
            let (backend, warning) = choose(
                force.as_deref(),
                name.as_deref(),
                RasterBackend::detect(),
                RasterBackend::is_supported,
            );
            if let Some(w) = warning {
                eprintln!("{w}");
            }
            backend
        })
    }

    /// A short lower-case name (`scalar`, `sse41`, `avx2`, `avx512`), as
    /// [`BACKEND_ENV`] takes it.
    pub fn name(self) -> &'static str {
        match self {
            RasterBackend::Scalar => "scalar",
            RasterBackend::Sse41 => "sse41",
            RasterBackend::Avx2 => "avx2",
            RasterBackend::Avx512 => "avx512",
        }
    }

    /// The backend called `name` ([`RasterBackend::name`], ASCII case
    /// ignored), supported by this CPU or not.
    pub fn from_name(name: &str) -> Option<RasterBackend> {
        RasterBackend::ALL
            .into_iter()
            .find(|b| b.name().eq_ignore_ascii_case(name))
    }
}

impl Default for RasterBackend {
    /// [`RasterBackend::active`].
    fn default() -> RasterBackend {
        RasterBackend::active()
    }
}

/// What [`RasterBackend::active`] decides from the values of
/// [`FORCE_SCALAR_ENV`] and [`BACKEND_ENV`], given the detected backend and
/// which backends the CPU supports: the backend, and a warning to print when
/// the name is unusable.
fn choose(
    force: Option<&OsStr>,
    name: Option<&OsStr>,
    detected: RasterBackend,
    supported: impl Fn(RasterBackend) -> bool,
) -> (RasterBackend, Option<String>) {
    if force.is_some_and(|v| !v.is_empty() && v != "0") {
        return (RasterBackend::Scalar, None);
    }
    let Some(name) = name.filter(|n| !n.is_empty()) else {
        return (detected, None);
    };
    let shown = name.to_string_lossy();
    let warning = match name.to_str().and_then(RasterBackend::from_name) {
        Some(b) if supported(b) => return (b, None),
        Some(_) => format!(
            "hom: {BACKEND_ENV}={shown}: this CPU does not support it; using {}",
            detected.name()
        ),
        None => {
            let names: Vec<&str> = RasterBackend::ALL.iter().map(|b| b.name()).collect();
            format!(
                "hom: {BACKEND_ENV}={shown} is not a raster backend ({}); using {}",
                names.join(", "),
                detected.name()
            )
        }
    };
    (detected, Some(warning))
}

/// Asks the CPU to bring `item` into cache ahead of its use (a hint: no
/// effect on results). For loops that read set-up triangles by index.
#[inline(always)]
pub(crate) fn prefetch<T>(item: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: SSE is part of the x86-64 baseline, and a prefetch reads no
    // memory the program can observe (any address is allowed; this one is valid).
    unsafe {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        _mm_prefetch::<_MM_HINT_T0>((item as *const T).cast::<i8>());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = item;
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
        RasterBackend::Avx512 if std::arch::is_x86_feature_detected!("avx512f") => {
            // SAFETY: the CPU supports AVX-512F (checked just above), the only
            // requirement of this `target_feature` function.
            unsafe { x86::row_masks_avx512(e, s, dy, n, out) }
        }
        #[cfg(target_arch = "x86_64")]
        RasterBackend::Avx2 if std::arch::is_x86_feature_detected!("avx2") => {
            // SAFETY: the CPU supports AVX2 (checked just above), the only
            // requirement of this `target_feature` function.
            unsafe { x86::row_masks_avx2(e, s, dy, n, out) }
        }
        #[cfg(target_arch = "x86_64")]
        RasterBackend::Sse41 if std::arch::is_x86_feature_detected!("sse4.1") => {
            // SAFETY: the CPU supports SSE4.1 (checked just above), the only
            // requirement of this `target_feature` function.
            unsafe { x86::row_masks_sse41(e, s, dy, n, out) }
        }
        _ => row_masks_scalar(e, s, dy, n, out),
    }
}

/// The mask of the low `n` bits (`1 <= n <= 64`).
#[inline]
fn low_bits(n: u32) -> u64 {
    u64::MAX >> (64 - n)
}

/// Scalar row masks: the per-sample test, row after row (the vector kernels'
/// reference in tests, and their fallback).
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

    /// For a box `n` samples wide (`n` capped at `L`): lane `j`'s row `j / n`
    /// and sample `j % n` within the row, as `i64` lanes (entry 0 unused).
    const fn lane_index<const L: usize, const T: usize>() -> [([i64; L], [i64; L]); T] {
        let mut t = [([0; L], [0; L]); T];
        let mut n = 1;
        while n < T {
            let mut j = 0;
            while j < L {
                t[n].0[j] = (j / n) as i64;
                t[n].1[j] = (j % n) as i64;
                j += 1;
            }
            n += 1;
        }
        t
    }

    /// `(a * b) mod 2^64` per lane from 32×32 → 64-bit multiplies, for `a`'s
    /// lanes in `0..2^32`: `a * b_lo + ((a * b_hi) << 32)`.
    macro_rules! mul_small {
        ($mul_epu32:ident, $add:ident, $slli:ident, $srli:ident, $a:expr, $b:expr) => {{
            let (a, b) = ($a, $b);
            $add($mul_epu32(a, b), $slli::<32>($mul_epu32(a, $srli::<32>(b))))
        }};
    }

    /// The row-mask kernel every vector backend shares (see the module docs),
    /// expanded inside each backend's `target_feature` function so that its
    /// intrinsics inline. Arguments: the lane count `L`; `e`, `s`, `dy`, `n`,
    /// `out` as in [`super::row_masks`]; then closures `load(&[i64; L]) -> V`
    /// (lane 0 first), `splat(i64) -> V`, `add(V, V) -> V` (wrapping `i64`
    /// lanes), `mul(V, V) -> V` (wrapping `i64` product, first operand's lanes
    /// in `0..2^32`) and `covered(V, V, V) -> u64` (bit `j` set iff all three
    /// edge values of lane `j` are `>= 0`; no bits above the lanes). Expects a
    /// `LANE_INDEX: [([i64; L], [i64; L]); L + 1]` in scope ([`lane_index`]).
    ///
    /// Lanes outside the box or past the last row may wrap; their bits are
    /// never stored.
    macro_rules! kernel {
        ($lanes:expr, $e:expr, $s:expr, $dy:expr, $n:expr, $out:expr, $load:expr, $splat:expr, $add:expr, $mul:expr, $covered:expr) => {{
            const L: usize = $lanes;
            let (e, s, dy, n, out): ([i64; 3], [i64; 3], [i64; 3], u32, &mut [u64]) = ($e, $s, $dy, $n, $out);
            let (load, splat, add, mul, covered) = ($load, $splat, $add, $mul, $covered);
            let valid = low_bits(n);
            // Lane j starts at sample j % n of row j / n (a later row only when
            // rows are packed or the box is narrower than a vector): vector
            // arithmetic on constant lane indices, as exact (mod 2^64) as the
            // scalar wrapping loop, and far cheaper per call than 2 * L scalar
            // multiplies and L inserts per edge.
            let table = &LANE_INDEX[(n as usize).min(L)];
            let (rows, ks) = (load(&table.0), load(&table.1));
            let start = |i: usize| add(add(splat(e[i]), mul(rows, splat(dy[i]))), mul(ks, splat(s[i])));
            let (mut r0, mut r1, mut r2) = (start(0), start(1), start(2));
            if n as usize <= L {
                // At most one vector per row: `p` whole rows per vector.
                let p = L as u32 / n;
                let step = |i: usize| splat(dy[i].wrapping_mul(i64::from(p)));
                let (d0, d1, d2) = (step(0), step(1), step(2));
                if p == 1 {
                    for m in out.iter_mut() {
                        *m = covered(r0, r1, r2) & valid;
                        r0 = add(r0, d0);
                        r1 = add(r1, d1);
                        r2 = add(r2, d2);
                    }
                } else {
                    for rows in out.chunks_mut(p as usize) {
                        let bits = covered(r0, r1, r2);
                        for (i, m) in (0u32..).zip(rows.iter_mut()) {
                            *m = bits >> (i * n) & valid;
                        }
                        r0 = add(r0, d0);
                        r1 = add(r1, d1);
                        r2 = add(r2, d2);
                    }
                }
            } else {
                // Several vectors per row, left to right.
                let vectors = n.div_ceil(L as u32);
                let step = |i: usize| splat(s[i].wrapping_mul(L as i64));
                let (s0, s1, s2) = (step(0), step(1), step(2));
                let (d0, d1, d2) = (splat(dy[0]), splat(dy[1]), splat(dy[2]));
                for m in out.iter_mut() {
                    let (mut c0, mut c1, mut c2) = (r0, r1, r2);
                    let mut bits = 0u64;
                    let mut shift = 0;
                    for _ in 0..vectors {
                        bits |= covered(c0, c1, c2) << shift;
                        shift += L as u32;
                        c0 = add(c0, s0);
                        c1 = add(c1, s1);
                        c2 = add(c2, s2);
                    }
                    *m = bits & valid;
                    r0 = add(r0, d0);
                    r1 = add(r1, d1);
                    r2 = add(r2, d2);
                }
            }
        }};
    }

    /// Row masks, 8 samples per 512-bit vector of `i64` lanes (see
    /// [`super::row_masks`]): `vpternlogq` ORs the three edge values, and a
    /// signed compare with zero writes the 8 covered bits to a mask register.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    #[allow(unused_unsafe)] // intrinsics are safe here from Rust 1.87 on
    pub(super) unsafe fn row_masks_avx512(e: [i64; 3], s: [i64; 3], dy: [i64; 3], n: u32, out: &mut [u64]) {
        // SAFETY: this function is compiled with AVX-512F and its caller
        // guarantees the CPU supports it; the intrinsics touch only registers,
        // but for the loads of the constant lane-index table commented below.
        unsafe {
            static LANE_INDEX: [([i64; 8], [i64; 8]); 9] = lane_index();
            let zero = _mm512_setzero_si512();
            kernel!(
                8,
                e,
                s,
                dy,
                n,
                out,
                // SAFETY: reads the 8 `i64` of a valid array reference (unaligned load).
                |v: &[i64; 8]| _mm512_loadu_si512(v.as_ptr().cast()),
                |x: i64| _mm512_set1_epi64(x),
                |a: __m512i, b: __m512i| _mm512_add_epi64(a, b),
                |a: __m512i, b: __m512i| mul_small!(
                    _mm512_mul_epu32,
                    _mm512_add_epi64,
                    _mm512_slli_epi64,
                    _mm512_srli_epi64,
                    a,
                    b
                ),
                |c0: __m512i, c1: __m512i, c2: __m512i| {
                    // 0xFE: a | b | c.
                    let any = _mm512_ternarylogic_epi64::<0xFE>(c0, c1, c2);
                    u64::from(_mm512_cmpge_epi64_mask(any, zero))
                }
            )
        }
    }

    /// Row masks, 4 samples per 256-bit vector of `i64` lanes (see [`super::row_masks`]).
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    #[allow(unused_unsafe)] // intrinsics are safe here from Rust 1.87 on
    pub(super) unsafe fn row_masks_avx2(e: [i64; 3], s: [i64; 3], dy: [i64; 3], n: u32, out: &mut [u64]) {
        // SAFETY: this function is compiled with AVX2 and its caller guarantees
        // the CPU supports it; the intrinsics touch only registers,
        // but for the loads of the constant lane-index table commented below.
        unsafe {
            static LANE_INDEX: [([i64; 4], [i64; 4]); 5] = lane_index();
            kernel!(
                4,
                e,
                s,
                dy,
                n,
                out,
                // SAFETY: reads the 4 `i64` of a valid array reference (unaligned load).
                |v: &[i64; 4]| _mm256_loadu_si256(v.as_ptr().cast()),
                |x: i64| _mm256_set1_epi64x(x),
                |a: __m256i, b: __m256i| _mm256_add_epi64(a, b),
                |a: __m256i, b: __m256i| mul_small!(
                    _mm256_mul_epu32,
                    _mm256_add_epi64,
                    _mm256_slli_epi64,
                    _mm256_srli_epi64,
                    a,
                    b
                ),
                |c0: __m256i, c1: __m256i, c2: __m256i| {
                    // Sign bits: set where some edge is negative (sample outside).
                    let any = _mm256_or_si256(_mm256_or_si256(c0, c1), c2);
                    !(_mm256_movemask_pd(_mm256_castsi256_pd(any)) as u64) & 0xf
                }
            )
        }
    }

    /// Row masks, 2 samples per 128-bit vector of `i64` lanes (see [`super::row_masks`]).
    ///
    /// SSE4.1 adds nothing the sign-bit test needs (`ptest`, `pblendvb` and
    /// `pcmpeqq` do not beat SSE2's `por` + `movmskpd` here); it is the
    /// shared kernel with 2 lanes.
    ///
    /// # Safety
    /// The CPU must support SSE4.1.
    #[target_feature(enable = "sse4.1")]
    #[allow(unused_unsafe)] // intrinsics are safe here from Rust 1.87 on
    pub(super) unsafe fn row_masks_sse41(e: [i64; 3], s: [i64; 3], dy: [i64; 3], n: u32, out: &mut [u64]) {
        // SAFETY: this function is compiled with SSE4.1 and its caller
        // guarantees the CPU supports it; the intrinsics touch only registers,
        // but for the loads of the constant lane-index table commented below.
        unsafe {
            static LANE_INDEX: [([i64; 2], [i64; 2]); 3] = lane_index();
            kernel!(
                2,
                e,
                s,
                dy,
                n,
                out,
                // SAFETY: reads the 2 `i64` of a valid array reference (unaligned load).
                |v: &[i64; 2]| _mm_loadu_si128(v.as_ptr().cast()),
                |x: i64| _mm_set1_epi64x(x),
                |a: __m128i, b: __m128i| _mm_add_epi64(a, b),
                |a: __m128i, b: __m128i| mul_small!(_mm_mul_epu32, _mm_add_epi64, _mm_slli_epi64, _mm_srli_epi64, a, b),
                |c0: __m128i, c1: __m128i, c2: __m128i| {
                    // Sign bits: set where some edge is negative (sample outside).
                    let any = _mm_or_si128(_mm_or_si128(c0, c1), c2);
                    !(_mm_movemask_pd(_mm_castsi128_pd(any)) as u64) & 0b11
                }
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::setup::{setup_triangle, Vertex, Viewport};
    use super::*;
    use glam::Vec4;
    use hom_testkit::Rng;
    use proptest::prelude::*;

    /// The backends of [`RasterBackend::ALL`] this CPU cannot run, named on
    /// stderr so a run on an older CPU says what it did not test.
    fn report_untested(test: &str) {
        let untested: Vec<&str> = RasterBackend::ALL
            .into_iter()
            .filter(|b| !b.is_supported())
            .map(|b| b.name())
            .collect();
        if !untested.is_empty() {
            eprintln!("{test}: not tested (CPU lacks them): {}", untested.join(", "));
        }
    }

    /// Sets up the screen-space triangle `p` (pixel coordinates, y down) in a
    /// `w` × `h` viewport.
    fn setup_px(p: [(f32, f32); 3], w: u32, h: u32) -> Vec<Tri> {
        let vp = Viewport::new(w, h);
        let v = p.map(|(x, y)| {
            Vertex::new(
                Vec4::new(x / w as f32 * 2.0 - 1.0, 1.0 - y / h as f32 * 2.0, 0.5, 1.0),
                &vp,
            )
        });
        let mut tris = Vec::new();
        setup_triangle([&v[0], &v[1], &v[2]], &vp, 0, [0; 4], &mut tris);
        tris
    }

    /// The masks `row_span` gives for every row of `t`.
    fn span_masks(t: &Tri) -> Vec<u64> {
        (u32::from(t.y0)..u32::from(t.y1))
            .map(|py| {
                let span = t.row_span(py).map_or(0..0, |(lo, hi)| lo..hi);
                span.fold(0, |m, x| m | 1 << (x - u32::from(t.x0)))
            })
            .collect()
    }

    /// Every row of `t`'s box from `backend`, in calls of at most `chunk` rows
    /// starting at row `first` (then wrapping round to `t.y0`), as the rasterizer
    /// calls it.
    fn backend_masks(backend: RasterBackend, t: &Tri, first: u32, chunk: usize) -> Vec<u64> {
        let (y0, y1) = (u32::from(t.y0), u32::from(t.y1));
        let first = y0 + first % (y1 - y0);
        let mut got = vec![0; (y1 - y0) as usize];
        for (from, to) in [(first, y1), (y0, first)] {
            let mut py = from;
            while py < to {
                let rows = (to - py).min(chunk as u32);
                let at = (py - y0) as usize;
                row_masks(backend, t, py, &mut got[at..at + rows as usize]);
                py += rows;
            }
        }
        got
    }

    /// Kernel masks equal `row_span` on every row of many random boxes, for
    /// every backend this CPU supports.
    #[test]
    fn kernels_match_row_span() {
        let mut rng = Rng::new(0x2545_F491_4F6C_DD1D);
        let mut rnd = move || rng.unit();
        let (w, h) = (200u32, 150u32);
        let mut tris = Vec::new();
        for _ in 0..4000 {
            let scale = [1.0, 3.0, 8.0, 30.0, 70.0, 400.0][(rnd() * 6.0) as usize % 6];
            let (cx, cy) = (rnd() * 220.0 - 10.0, rnd() * 170.0 - 10.0);
            let p = [0, 1, 2].map(|_| (cx + (rnd() - 0.5) * scale, cy + (rnd() - 0.5) * scale));
            tris.extend(setup_px(p, w, h));
        }
        let mut checked = [0usize; RasterBackend::ALL.len()];
        let mut widths = [0usize; MASK_MAX as usize + 1];
        for (i, t) in tris
            .iter()
            .enumerate()
            .filter(|(_, t)| u32::from(t.x1 - t.x0) <= MASK_MAX)
        {
            widths[usize::from(t.x1 - t.x0)] += 1;
            let expect = span_masks(t);
            for (bi, b) in RasterBackend::ALL.into_iter().enumerate() {
                if !b.is_supported() {
                    continue;
                }
                let got = backend_masks(b, t, i as u32, 1 + i % 40);
                assert_eq!(got, expect, "{b:?} on {t:?}");
                checked[bi] += 1;
            }
        }
        assert!(checked[0] > 1000, "{checked:?}");
        assert!(widths.iter().filter(|&&c| c > 0).count() > 40, "box widths {widths:?}");
        let names: Vec<&str> = RasterBackend::ALL.iter().map(|b| b.name()).collect();
        eprintln!("row-mask kernels checked ({}): {checked:?}", names.join(", "));
        report_untested("kernels_match_row_span");
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]
        /// For random triangles — every box width up to and past `MASK_MAX`,
        /// tall and thin, slivers, degenerate, both windings, sub-pixel or
        /// pixel-centre vertices, across the viewport's edges — every supported
        /// backend's row masks equal the scalar ones bit for bit, whatever rows
        /// each call covers.
        #[test]
        fn backends_match_scalar_row_masks(
            w in 1u32..300, h in 1u32..300, kind in 0u8..5,
            c in (-0.2f32..1.2, -0.2f32..1.2), size in (0.0f32..1.0, 0.0f32..1.0),
            d in proptest::array::uniform6(-1.0f32..1.0),
            on_centres in any::<bool>(), flip in any::<bool>(), first in any::<u32>(), chunk in 1usize..40,
        ) {
            let (cx, cy) = (c.0 * w as f32, c.1 * h as f32);
            // Box extents in pixels: up to 90 wide (past MASK_MAX) and 300 tall;
            // kind 3 is at most 3 wide (facade edges), kind 4 at most 3 tall.
            let (sx, sy) = match kind {
                3 => (size.0 * 3.0, 1.0 + size.1 * 300.0),
                4 => (1.0 + size.0 * 90.0, size.1 * 3.0),
                _ => (size.0 * 90.0, size.1 * 300.0),
            };
            let mut p = [0, 1, 2].map(|k| (cx + d[2 * k] * sx * 0.5, cy + d[2 * k + 1] * sy * 0.5));
            match kind {
                // Sliver: the third vertex a hair off the line of the first two.
                1 => {
                    let t = d[4] * 0.5 + 0.5;
                    p[2] = (p[0].0 + (p[1].0 - p[0].0) * t + d[5] * 0.02, p[0].1 + (p[1].1 - p[0].1) * t);
                }
                // Degenerate: on the line of the first two (or a repeated vertex).
                2 => p[2] = if d[5] < 0.0 { p[0] } else { ((p[0].0 + p[1].0) * 0.5, (p[0].1 + p[1].1) * 0.5) },
                _ => {}
            }
            if on_centres {
                // Vertices (and so some edges) exactly on sample points.
                p = p.map(|(x, y)| (x.floor() + 0.5, y.floor() + 0.5));
            }
            if flip {
                p.swap(1, 2);
            }
            for t in setup_px(p, w, h) {
                prop_assert!(t.x1 <= w as u16 && t.y1 <= h as u16);
                if u32::from(t.x1 - t.x0) > MASK_MAX {
                    continue;
                }
                let mut want = vec![0; usize::from(t.y1 - t.y0)];
                row_masks_scalar(t.edges_at_row(u32::from(t.y0)), t.a.map(|a| a * ONE), t.b.map(|b| b * ONE),
                    u32::from(t.x1 - t.x0), &mut want);
                prop_assert_eq!(&want, &span_masks(&t), "scalar row masks vs row_span on {:?}", t);
                for b in RasterBackend::supported() {
                    let got = backend_masks(b, &t, first, chunk);
                    prop_assert_eq!(&got, &want, "{:?} on {:?}", b, t);
                }
            }
        }
    }

    /// Kernel-only timing (not a check; the criterion bench `kernels` times the
    /// whole rasterizer): median ns per row of `row_masks` over random boxes of
    /// three shapes, called per 16-row band, each backend in turn, runs
    /// interleaved.
    /// `cargo test -p hom kernel_timing -- --ignored --nocapture` (the test
    /// profile is optimized).
    #[test]
    #[ignore = "timing, not a check"]
    fn kernel_timing() {
        use std::time::Instant;
        let mut rng = Rng::new(0x9E37_79B9_7F4A_7C15);
        let mut rnd = move || rng.unit();
        let (w, h) = (1024u32, 1024u32);
        // (name, box width range, box height range)
        let shapes = [
            ("thin (1-4 wide)", 1.0, 4.0, 20.0, 200.0),
            ("mid (5-16 wide)", 5.0, 16.0, 5.0, 60.0),
            ("wide (17-64 wide)", 17.0, 64.0, 5.0, 60.0),
        ];
        for (name, w0, w1, h0, h1) in shapes {
            let mut tris = Vec::new();
            while tris.len() < 2000 {
                let (bw, bh) = (w0 + rnd() * (w1 - w0), h0 + rnd() * (h1 - h0));
                let (cx, cy) = (50.0 + rnd() * 900.0, 50.0 + rnd() * 900.0);
                let p = [0, 1, 2].map(|_| (cx + (rnd() - 0.5) * bw, cy + (rnd() - 0.5) * bh));
                let t = setup_px(p, w, h);
                tris.extend(t.into_iter().filter(|t| u32::from(t.x1 - t.x0) <= MASK_MAX));
            }
            let rows: usize = tris.iter().map(|t| usize::from(t.y1 - t.y0)).sum();
            let mut out = [0u64; 32];
            let mut times: Vec<Vec<f64>> = vec![Vec::new(); RasterBackend::ALL.len()];
            let mut sink = 0u64;
            for _ in 0..15 {
                for (bi, b) in RasterBackend::ALL
                    .into_iter()
                    .enumerate()
                    .filter(|(_, b)| b.is_supported())
                {
                    let start = Instant::now();
                    for t in &tris {
                        let (mut py, y1) = (u32::from(t.y0), u32::from(t.y1));
                        while py < y1 {
                            // Calls end at 16-row band edges, as in the rasterizer.
                            let n = (y1 - py).min(16 - py % 16) as usize;
                            row_masks(b, t, py, &mut out[..n]);
                            sink = sink.wrapping_add(out[0] ^ out[n - 1]);
                            py += n as u32;
                        }
                    }
                    times[bi].push(start.elapsed().as_secs_f64() * 1e9 / rows as f64);
                }
            }
            let line: Vec<String> = RasterBackend::ALL
                .into_iter()
                .zip(times.iter_mut())
                .filter(|(_, t)| !t.is_empty())
                .map(|(b, t)| {
                    t.sort_by(f64::total_cmp);
                    format!("{} {:.2}", b.name(), t[t.len() / 2])
                })
                .collect();
            eprintln!("{name}, {rows} rows: ns/row: {} (sink {})", line.join(", "), sink % 2);
        }
        report_untested("kernel_timing");
    }

    #[test]
    fn active_is_supported() {
        assert!(RasterBackend::detect().is_supported());
        assert!(RasterBackend::active().is_supported());
        let supported = RasterBackend::supported();
        assert_eq!(supported[0], RasterBackend::Scalar);
        let want = if supported.contains(&RasterBackend::Avx2) {
            RasterBackend::Avx2
        } else {
            *supported.last().unwrap()
        };
        assert_eq!(RasterBackend::detect(), want);
        #[cfg(target_arch = "x86_64")]
        for (b, feature) in [
            (RasterBackend::Sse41, is_x86_feature_detected!("sse4.1")),
            (RasterBackend::Avx2, is_x86_feature_detected!("avx2")),
            (RasterBackend::Avx512, is_x86_feature_detected!("avx512f")),
        ] {
            assert_eq!(supported.contains(&b), feature, "{b:?}");
        }
        eprintln!("raster backends supported: {supported:?}");
        report_untested("active_is_supported");
    }

    #[test]
    fn names_round_trip() {
        for b in RasterBackend::ALL {
            assert_eq!(RasterBackend::from_name(b.name()), Some(b));
            assert_eq!(RasterBackend::from_name(&b.name().to_uppercase()), Some(b));
        }
        assert_eq!(RasterBackend::from_name("sse2"), None);
        assert_eq!(RasterBackend::from_name(""), None);
    }

    /// `HOM_FORCE_SCALAR` wins; a supported name is used; an unknown or
    /// unsupported one falls back to the detected backend with a warning.
    #[test]
    fn environment_choice() {
        let os = |s: &'static str| Some(OsStr::new(s));
        // A CPU with everything, and one without AVX-512 (detects AVX2).
        let all = |_: RasterBackend| true;
        let no512 = |b: RasterBackend| b != RasterBackend::Avx512;
        let (top, avx2) = (RasterBackend::Avx512, RasterBackend::Avx2);
        assert_eq!(choose(None, None, top, all), (top, None));
        assert_eq!(choose(os(""), os(""), top, all), (top, None));
        assert_eq!(choose(os("0"), None, top, all), (top, None));
        assert_eq!(choose(os("1"), None, top, all), (RasterBackend::Scalar, None));
        assert_eq!(choose(os("yes"), os("avx2"), top, all), (RasterBackend::Scalar, None));
        assert_eq!(choose(os("0"), os("scalar"), top, all), (RasterBackend::Scalar, None));
        for b in RasterBackend::ALL {
            assert_eq!(choose(None, Some(OsStr::new(b.name())), top, all), (b, None));
        }
        assert_eq!(choose(None, os("Sse41"), avx2, no512), (RasterBackend::Sse41, None));
        let (got, warning) = choose(None, os("avx512"), avx2, no512);
        assert_eq!(got, avx2);
        let warning = warning.unwrap();
        assert!(
            warning.contains("does not support") && warning.ends_with("using avx2"),
            "{warning}"
        );
        let (got, warning) = choose(None, os("sse2"), top, all);
        assert_eq!(got, top);
        let warning = warning.unwrap();
        assert!(
            warning.contains("HOM_RASTER_BACKEND=sse2") && warning.contains("avx512"),
            "{warning}"
        );
        assert!(!warning.contains('\n'));
        // The real CPU: a supported name is taken as is.
        for b in RasterBackend::supported() {
            let got = choose(
                None,
                Some(OsStr::new(b.name())),
                RasterBackend::detect(),
                RasterBackend::is_supported,
            );
            assert_eq!(got, (b, None));
        }
    }
}
