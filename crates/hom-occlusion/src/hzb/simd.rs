//! Vector kernels of the tiled depth rasterizer ([`super::raster`]): the depth
//! test and write of one 8×8 tile. Like [`crate::raster::simd`], this is a place for
//! `unsafe` and `std::arch`; the scalar kernel in `tile_band.rs` defines the
//! result and every kernel here equals it bit for bit (property tests): the
//! edge values are the same `i32` sums, the depth the same two `f32`
//! roundings (`zr + dz`), the clamp at 0 the same for every non-NaN depth.

use super::tile_band::{Band, BandParts, TileKernel, TiledStats};
use crate::raster::setup::Tri;
use crate::raster::simd::RasterBackend;

/// Fills one band with the kernel of `backend` (the scalar one where the CPU
/// lacks it). The vector entry points compile the whole band loop with their
/// target feature, so the kernel inlines into it.
pub(crate) fn render_band(backend: RasterBackend, band: &Band, bin: &[Tri], parts: BandParts) -> TiledStats {
    match backend {
        #[cfg(target_arch = "x86_64")]
        RasterBackend::Avx512 if std::arch::is_x86_feature_detected!("avx512f") => {
            // SAFETY: AVX-512F is available (checked above; the check is cached by std).
            unsafe { x86::band_avx512(band, bin, parts) }
        }
        #[cfg(target_arch = "x86_64")]
        RasterBackend::Avx2 if std::arch::is_x86_feature_detected!("avx2") => {
            // SAFETY: AVX2 is available (checked above).
            unsafe { x86::band_avx2(band, bin, parts) }
        }
        #[cfg(target_arch = "x86_64")]
        RasterBackend::Scalar => band.render(bin, parts, TileKernel::run_scalar),
        // SSE4.1 adds nothing this kernel uses: the SSE2 kernel serves it.
        #[cfg(target_arch = "x86_64")]
        _ => band.render(bin, parts, x86::run_sse2),
        #[cfg(not(target_arch = "x86_64"))]
        _ => band.render(bin, parts, TileKernel::run_scalar),
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{Band, BandParts, TileKernel, TiledStats, Tri};
    use std::arch::x86_64::*;

    /// The band loop compiled with AVX2, its kernel inlined.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn band_avx2(b: &Band, bin: &[Tri], parts: BandParts) -> TiledStats {
        // SAFETY: this function only runs where AVX2 is available.
        b.render(bin, parts, |k, tile| unsafe { run_avx2(k, tile) })
    }

    /// The band loop compiled with AVX-512F, its kernel inlined.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn band_avx512(b: &Band, bin: &[Tri], parts: BandParts) -> TiledStats {
        // SAFETY: this function only runs where AVX-512F is available.
        b.render(bin, parts, |k, tile| unsafe { run_avx512(k, tile) })
    }

    /// SSE2 (x86-64 baseline): a row is two vectors of four samples.
    #[inline(always)]
    pub(super) fn run_sse2(k: &TileKernel, tile: &mut [f32; 64]) -> Option<f32> {
        k.assert_in_tile();
        // SAFETY: SSE2 is part of x86-64; loads and stores are unaligned and
        // stay within the tile (8 lanes per row, rows <= 8: asserted above).
        unsafe {
            let lanes = [_mm_setr_epi32(0, 1, 2, 3), _mm_setr_epi32(4, 5, 6, 7)];
            let mut e = [[_mm_setzero_si128(); 2]; 3];
            let mut live = [_mm_setzero_si128(); 2];
            let mut dz = [_mm_setzero_ps(); 2];
            for h in 0..2 {
                for (eq, (&e0, &sx)) in e.iter_mut().zip(k.e.iter().zip(&k.step_x)) {
                    // SSE2 has no 32-bit multiply; the products are exact (see tiled.rs).
                    let m = [0, 1, 2, 3].map(|l| sx * (4 * h as i32 + l));
                    eq[h] = _mm_add_epi32(_mm_set1_epi32(e0), _mm_setr_epi32(m[0], m[1], m[2], m[3]));
                }
                live[h] = _mm_cmpgt_epi32(_mm_set1_epi32(k.cols), lanes[h]);
                let dx = _mm_add_epi32(_mm_set1_epi32(k.dx0), lanes[h]);
                dz[h] = _mm_mul_ps(_mm_set1_ps(k.dzdx), _mm_cvtepi32_ps(dx));
            }
            let sy = k.step_y.map(|s| _mm_set1_epi32(s));
            for (eq, &s) in e.iter_mut().zip(&k.step_y) {
                for v in eq.iter_mut() {
                    *v = _mm_add_epi32(*v, _mm_set1_epi32(s * k.row0 as i32));
                }
            }
            let zero = _mm_setzero_ps();
            let mut changed = 0;
            for j in k.row0..k.row1 {
                let zr = _mm_set1_ps(k.zr(j));
                for h in 0..2 {
                    let m = _mm_or_si128(_mm_or_si128(e[0][h], e[1][h]), e[2][h]);
                    let inside = _mm_and_si128(live[h], _mm_cmpgt_epi32(m, _mm_set1_epi32(-1)));
                    let z = _mm_max_ps(_mm_add_ps(zr, dz[h]), zero);
                    let p = tile.as_mut_ptr().add(j * 8 + 4 * h);
                    let d = _mm_loadu_ps(p);
                    let write = _mm_and_ps(_mm_castsi128_ps(inside), _mm_cmplt_ps(z, d));
                    _mm_storeu_ps(p, _mm_or_ps(_mm_and_ps(write, z), _mm_andnot_ps(write, d)));
                    changed |= _mm_movemask_ps(write);
                }
                for (eq, &s) in e.iter_mut().zip(&sy) {
                    for v in eq.iter_mut() {
                        *v = _mm_add_epi32(*v, s);
                    }
                }
            }
            (changed != 0).then(|| {
                // The farthest over every row inside the viewport, drawn or not.
                let mut far = _mm_set1_ps(f32::NEG_INFINITY);
                for j in 0..k.rows {
                    let p = tile.as_ptr().add(j * 8);
                    far = _mm_max_ps(far, _mm_max_ps(_mm_loadu_ps(p), _mm_loadu_ps(p.add(4))));
                }
                let m = _mm_max_ps(far, _mm_shuffle_ps::<0b01_00_11_10>(far, far));
                _mm_cvtss_f32(_mm_max_ps(m, _mm_shuffle_ps::<0b10_11_00_01>(m, m)))
            })
        }
    }

    /// AVX2: a row is one vector of eight samples.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn run_avx2(k: &TileKernel, tile: &mut [f32; 64]) -> Option<f32> {
        k.assert_in_tile();
        // SAFETY: loads and stores are unaligned, at rows < rows <= 8
        // (asserted above), so within the tile; the caller has AVX2.
        unsafe {
            let lanes = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
            // (Plain per-edge code, not array `map` closures: those do not inline
            // into a target-feature function and cost a call each.)
            let edge = |q: usize| {
                _mm256_add_epi32(
                    _mm256_set1_epi32(k.e[q] + k.step_y[q] * k.row0 as i32),
                    _mm256_mullo_epi32(_mm256_set1_epi32(k.step_x[q]), lanes),
                )
            };
            let mut e = [edge(0), edge(1), edge(2)];
            let live = _mm256_cmpgt_epi32(_mm256_set1_epi32(k.cols), lanes);
            let dx = _mm256_add_epi32(_mm256_set1_epi32(k.dx0), lanes);
            let dz = _mm256_mul_ps(_mm256_set1_ps(k.dzdx), _mm256_cvtepi32_ps(dx));
            let sy = k.step_y.map(|s| _mm256_set1_epi32(s));
            let zero = _mm256_setzero_ps();
            let mut changed = 0;
            for j in k.row0..k.row1 {
                let m = _mm256_or_si256(_mm256_or_si256(e[0], e[1]), e[2]);
                let inside = _mm256_and_si256(live, _mm256_cmpgt_epi32(m, _mm256_set1_epi32(-1)));
                let z = _mm256_max_ps(_mm256_add_ps(_mm256_set1_ps(k.zr(j)), dz), zero);
                let p = tile.as_mut_ptr().add(j * 8);
                let d = _mm256_loadu_ps(p);
                let write = _mm256_and_ps(_mm256_castsi256_ps(inside), _mm256_cmp_ps::<_CMP_LT_OQ>(z, d));
                // The nearer of the row and the triangle where it covers, stored whole:
                // a blend with the loaded row becomes a masked store, which AMD's
                // cores run microcoded (36 % of HZB's raster on an EPYC; min: z < d ? z : d).
                let covering = _mm256_blendv_ps(_mm256_set1_ps(f32::INFINITY), z, _mm256_castsi256_ps(inside));
                _mm256_storeu_ps(p, _mm256_min_ps(covering, d));
                changed |= _mm256_movemask_ps(write);
                for q in 0..3 {
                    e[q] = _mm256_add_epi32(e[q], sy[q]);
                }
            }
            (changed != 0).then(|| {
                let mut far = _mm256_set1_ps(f32::NEG_INFINITY);
                for j in 0..k.rows {
                    far = _mm256_max_ps(far, _mm256_loadu_ps(tile.as_ptr().add(j * 8)));
                }
                let m = _mm_max_ps(_mm256_castps256_ps128(far), _mm256_extractf128_ps::<1>(far));
                let m = _mm_max_ps(m, _mm_shuffle_ps::<0b01_00_11_10>(m, m));
                _mm_cvtss_f32(_mm_max_ps(m, _mm_shuffle_ps::<0b10_11_00_01>(m, m)))
            })
        }
    }

    /// AVX-512F: a vector is two rows of eight samples; masks in mask registers.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn run_avx512(k: &TileKernel, tile: &mut [f32; 64]) -> Option<f32> {
        k.assert_in_tile();
        // SAFETY: loads and stores are unaligned 16-float accesses at rows
        // 2p, 2p + 1 with 2p < rows <= 8 (asserted above), so within the
        // tile; the caller has AVX-512F.
        unsafe {
            let col = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 0, 1, 2, 3, 4, 5, 6, 7);
            let row = _mm512_setr_epi32(0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1);
            // Pairs of rows start at the even row at or above row0.
            let p0 = k.row0 & !1;
            let edge = |q: usize| {
                let x = _mm512_mullo_epi32(_mm512_set1_epi32(k.step_x[q]), col);
                let y = _mm512_mullo_epi32(_mm512_set1_epi32(k.step_y[q]), row);
                let base = k.e[q] + k.step_y[q] * p0 as i32;
                _mm512_add_epi32(_mm512_set1_epi32(base), _mm512_add_epi32(x, y))
            };
            let mut e = [edge(0), edge(1), edge(2)];
            let sy2 = [0, 1, 2].map(|q| _mm512_set1_epi32(2 * k.step_y[q]));
            let live = _mm512_cmpgt_epi32_mask(_mm512_set1_epi32(k.cols), col);
            let dx = _mm512_add_epi32(_mm512_set1_epi32(k.dx0), col);
            let dz = _mm512_mul_ps(_mm512_set1_ps(k.dzdx), _mm512_cvtepi32_ps(dx));
            let zero = _mm512_setzero_ps();
            let mut changed: __mmask16 = 0;
            for p in (p0..k.row1).step_by(2) {
                // The first row of the first pair may lie above row0, the second
                // of the last below row1 (or past the viewport).
                let rows: __mmask16 =
                    (if p >= k.row0 { 0x00ff } else { 0 }) | (if p + 1 < k.row1 { 0xff00 } else { 0 });
                let zr = _mm512_mask_blend_ps(
                    0xff00,
                    _mm512_set1_ps(k.zr(p)),
                    _mm512_set1_ps(if p + 1 < k.rows { k.zr(p + 1) } else { 0.0 }),
                );
                let m = _mm512_ternarylogic_epi32::<0xfe>(e[0], e[1], e[2]); // e0 | e1 | e2
                let inside = _mm512_mask_cmpge_epi32_mask(live & rows, m, _mm512_setzero_si512());
                let z = _mm512_max_ps(_mm512_add_ps(zr, dz), zero);
                let ptr = tile.as_mut_ptr().add(p * 8);
                let d = _mm512_loadu_ps(ptr);
                let write = _mm512_mask_cmp_ps_mask::<_CMP_LT_OQ>(inside, z, d);
                _mm512_mask_storeu_ps(ptr, write, z);
                changed |= write;
                for (v, s) in e.iter_mut().zip(&sy2) {
                    *v = _mm512_add_epi32(*v, *s);
                }
            }
            (changed != 0).then(|| {
                let mut far = _mm512_set1_ps(f32::NEG_INFINITY);
                for p in (0..k.rows).step_by(2) {
                    let m: __mmask16 = if p + 1 < k.rows { 0xffff } else { 0x00ff };
                    far = _mm512_mask_max_ps(far, m, far, _mm512_loadu_ps(tile.as_ptr().add(p * 8)));
                }
                _mm512_reduce_max_ps(far)
            })
        }
    }
}
