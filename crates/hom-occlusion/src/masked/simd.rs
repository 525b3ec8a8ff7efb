//! Vector kernels of the masked rasterizer ([`super::raster`]): the eight
//! rows of a tile row stepped as eight `i32` lanes ([`TileRows`]), their
//! 32-column coverage masks, and the tile update with the eight subtiles as
//! eight `f32` lanes. Like [`crate::raster::simd`], a place for `unsafe` and
//! `std::arch`; [`TileRows::next_scalar`], [`LaneSpans::masks`] and
//! [`MaskTile::insert`] / [`MaskTile::insert_full`] define the results and
//! every kernel here equals them bit for bit (property tests): the same
//! `i32` sums and compares lane by lane, and the same `f32` operations,
//! every case of the update computed for every subtile, then selected.
//!
//! | backend | rows | masks | tile update |
//! |---|---|---|---|
//! | [`RasterBackend::Scalar`] | one at a time | one at a time | subtile by subtile |
//! | [`RasterBackend::Sse41`] | two vectors of four (`pmaxsd`, `pminsd`, `pblendvb` are SSE4.1) | one at a time (no per-lane shift before AVX2) | subtile by subtile |
//! | [`RasterBackend::Avx2`] | one vector of eight | `vpsllvd`: eight rows at once | one vector of eight subtiles |
//! | [`RasterBackend::Avx512`] | as AVX2 (a tile row is eight lanes) | as AVX2 | as AVX2 |

use super::group::{draw_group, GroupParts, MaskedStats, RowKernel, Scalar, SetUp};
use crate::masked::zbuffer::{MaskTile, SUBTILES};
use crate::raster::scanline::{LaneSpans, RowBounds, TileRows, LANES};
use crate::raster::simd::RasterBackend;

/// Draws a group of bands with the kernels of `backend` (the scalar ones
/// where the CPU lacks it). The vector entry points compile the whole group
/// loop with their target feature, so the kernels inline into it.
pub(crate) fn render_group(backend: RasterBackend, tris: &[SetUp], parts: GroupParts) -> MaskedStats {
    match backend {
        #[cfg(target_arch = "x86_64")]
        RasterBackend::Avx2 | RasterBackend::Avx512 if std::arch::is_x86_feature_detected!("avx2") => {
            // SAFETY: AVX2 is available (checked above; the check is cached by std).
            unsafe { x86::group_avx2(tris, parts) }
        }
        #[cfg(target_arch = "x86_64")]
        RasterBackend::Sse41 if std::arch::is_x86_feature_detected!("sse4.1") => {
            // SAFETY: SSE4.1 is available (checked above).
            unsafe { x86::group_sse41(tris, parts) }
        }
        _ => draw_group(Scalar, tris, parts),
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) mod x86 {
    use super::{
        draw_group, GroupParts, LaneSpans, MaskTile, MaskedStats, RowBounds, RowKernel, SetUp, TileRows, LANES,
        SUBTILES,
    };
    use crate::raster::scanline::EMPTY;
    use std::arch::x86_64::*;

    /// The AVX2 kernels. Only made where the CPU has AVX2 (its one field is private).
    #[derive(Clone, Copy, Debug)]
    pub(crate) struct Avx2(());

    impl Avx2 {
        /// The kernels, where this CPU has AVX2.
        #[cfg(test)]
        pub(crate) fn new() -> Option<Avx2> {
            std::arch::is_x86_feature_detected!("avx2").then_some(Avx2(()))
        }
    }

    /// The SSE4.1 kernels. Only made where the CPU has SSE4.1.
    #[derive(Clone, Copy, Debug)]
    pub(crate) struct Sse41(());

    impl Sse41 {
        /// The kernels, where this CPU has SSE4.1.
        #[cfg(test)]
        pub(crate) fn new() -> Option<Sse41> {
            std::arch::is_x86_feature_detected!("sse4.1").then_some(Sse41(()))
        }
    }

    /// The group loop compiled with AVX2, its kernels inlined.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn group_avx2(tris: &[SetUp], parts: GroupParts) -> MaskedStats {
        draw_group(Avx2(()), tris, parts)
    }

    /// The group loop compiled with SSE4.1, its kernels inlined.
    ///
    /// # Safety
    /// The CPU must support SSE4.1.
    #[target_feature(enable = "sse4.1")]
    pub(super) unsafe fn group_sse41(tris: &[SetUp], parts: GroupParts) -> MaskedStats {
        draw_group(Sse41(()), tris, parts)
    }

    impl RowKernel for Avx2 {
        #[inline(always)]
        fn next(self, rows: &mut TileRows, ja: u32, jb: u32) -> LaneSpans {
            // SAFETY: an `Avx2` exists only where the CPU has AVX2.
            unsafe { next_avx2(rows, ja, jb) }
        }

        #[inline(always)]
        fn next_direct(self, rows: &mut RowBounds, ja: u32, jb: u32) -> LaneSpans {
            // SAFETY: as above.
            unsafe { next_direct_avx2(rows, ja, jb) }
        }

        #[inline(always)]
        fn masks(self, spans: &LaneSpans, xt: i32) -> [u32; LANES] {
            // SAFETY: as above.
            unsafe { masks_avx2(spans, xt) }
        }

        #[inline(always)]
        fn nearer(self, tile: &MaskTile, zt: &[f32; SUBTILES]) -> bool {
            // SAFETY: as above.
            unsafe { nearer_avx2(tile, zt) }
        }

        #[inline(always)]
        fn insert(self, tile: &mut MaskTile, m: &[u32; 8], zt: &[f32; SUBTILES], outside: &[u32; 8]) -> bool {
            // SAFETY: as above.
            unsafe { insert_avx2(tile, m, zt, outside) }
        }

        #[inline(always)]
        fn insert_full(self, tile: &mut MaskTile, zt: &[f32; SUBTILES], outside: &[u32; 8]) -> bool {
            // SAFETY: as above.
            unsafe { insert_full_avx2(tile, zt, outside) }
        }
    }

    impl RowKernel for Sse41 {
        #[inline(always)]
        fn next(self, rows: &mut TileRows, ja: u32, jb: u32) -> LaneSpans {
            // SAFETY: an `Sse41` exists only where the CPU has SSE4.1.
            unsafe { next_sse41(rows, ja, jb) }
        }

        #[inline(always)]
        fn next_direct(self, rows: &mut RowBounds, ja: u32, jb: u32) -> LaneSpans {
            rows.next_scalar(ja, jb)
        }

        #[inline(always)]
        fn masks(self, spans: &LaneSpans, xt: i32) -> [u32; LANES] {
            spans.masks(xt)
        }

        #[inline(always)]
        fn nearer(self, tile: &MaskTile, zt: &[f32; SUBTILES]) -> bool {
            super::Scalar.nearer(tile, zt)
        }

        #[inline(always)]
        fn insert(self, tile: &mut MaskTile, m: &[u32; 8], zt: &[f32; SUBTILES], outside: &[u32; 8]) -> bool {
            tile.insert(m, zt, outside)
        }

        #[inline(always)]
        fn insert_full(self, tile: &mut MaskTile, zt: &[f32; SUBTILES], outside: &[u32; 8]) -> bool {
            tile.insert_full(zt, outside)
        }
    }

    /// The smallest and largest lane of `v`.
    #[inline]
    #[target_feature(enable = "sse4.1")]
    fn min_max_128(v: __m128i, w: __m128i) -> (i32, i32) {
        let (mut a, mut b) = (v, w);
        a = _mm_min_epi32(a, _mm_shuffle_epi32::<0b01_00_11_10>(a));
        a = _mm_min_epi32(a, _mm_shuffle_epi32::<0b10_11_00_01>(a));
        b = _mm_max_epi32(b, _mm_shuffle_epi32::<0b01_00_11_10>(b));
        b = _mm_max_epi32(b, _mm_shuffle_epi32::<0b10_11_00_01>(b));
        (_mm_cvtsi128_si32(a), _mm_cvtsi128_si32(b))
    }

    /// [`TileRows::next_scalar`] in one vector of eight lanes.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn next_avx2(rows: &mut TileRows, ja: u32, jb: u32) -> LaneSpans {
        // SAFETY: loads and stores are unaligned, of `[i32; 8]` arrays.
        unsafe {
            let ld = |a: &[i32; LANES]| _mm256_loadu_si256(a.as_ptr().cast());
            let zero = _mm256_setzero_si256();
            let (q, r) = (&rows.q, &rows.r);
            let left = |k: usize| _mm256_sub_epi32(ld(&q[k]), _mm256_cmpgt_epi32(ld(&r[k]), zero));
            let lo = _mm256_max_epi32(_mm256_max_epi32(left(0), left(1)), zero);
            let right = _mm256_min_epi32(_mm256_min_epi32(ld(&q[2]), ld(&q[3])), _mm256_set1_epi32(rows.last));
            let hi = _mm256_add_epi32(right, _mm256_set1_epi32(1));
            let out = spans_of(lo, hi, ja, jb);
            for k in 0..4 {
                let t = _mm256_add_epi32(ld(&rows.r[k]), _mm256_set1_epi32(rows.r8[k]));
                let carry = _mm256_cmpgt_epi32(t, _mm256_set1_epi32(rows.d[k] - 1));
                let q = _mm256_sub_epi32(_mm256_add_epi32(ld(&rows.q[k]), _mm256_set1_epi32(rows.q8[k])), carry);
                let r = _mm256_sub_epi32(t, _mm256_and_si256(carry, _mm256_set1_epi32(rows.d[k])));
                _mm256_storeu_si256(rows.q[k].as_mut_ptr().cast(), q);
                _mm256_storeu_si256(rows.r[k].as_mut_ptr().cast(), r);
            }
            rows.row += LANES as u32;
            out
        }
    }

    /// [`RowBounds::next_scalar`] in two vectors of four `f64` lanes per
    /// edge: the same products, sums, ceilings and corrections lane by lane
    /// (no fused multiply-add, as the scalar code has none).
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn next_direct_avx2(b: &mut RowBounds, ja: u32, jb: u32) -> LaneSpans {
        let (j_lo, j_hi) = (_mm256_setr_pd(0.0, 1.0, 2.0, 3.0), _mm256_setr_pd(4.0, 5.0, 6.0, 7.0));
        let one = _mm256_set1_pd(1.0);
        let (mut lo, mut neg_hi) = ([_mm256_setzero_pd(); 2], [_mm256_set1_pd(-b.last); 2]);
        for i in 0..3 {
            let (x0, s, d, inv) = (
                _mm256_set1_pd(b.x[i]),
                _mm256_set1_pd(b.s[i]),
                _mm256_set1_pd(b.d[i]),
                _mm256_set1_pd(b.inv[i]),
            );
            let ceil_div = |j: __m256d| {
                let x = _mm256_add_pd(x0, _mm256_mul_pd(s, j));
                let c = _mm256_round_pd::<{ _MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC }>(_mm256_mul_pd(x, inv));
                let r = _mm256_sub_pd(_mm256_mul_pd(c, d), x);
                let up = _mm256_and_pd(_mm256_cmp_pd::<_CMP_LT_OQ>(r, _mm256_setzero_pd()), one);
                let down = _mm256_and_pd(_mm256_cmp_pd::<_CMP_GE_OQ>(r, d), one);
                _mm256_sub_pd(_mm256_add_pd(c, up), down)
            };
            let c = [ceil_div(j_lo), ceil_div(j_hi)];
            let (to_left, to_right) = (_mm256_set1_pd(b.to_left[i]), _mm256_set1_pd(b.to_right[i]));
            for h in 0..2 {
                lo[h] = _mm256_max_pd(lo[h], _mm256_add_pd(c[h], to_left));
                neg_hi[h] = _mm256_max_pd(neg_hi[h], _mm256_add_pd(c[h], to_right));
            }
        }
        b.skip_tile_row();
        let (last1, zero) = (_mm256_set1_pd(b.last + 1.0), _mm256_setzero_pd());
        let to_i32 = |v: [__m256d; 2]| _mm256_set_m128i(_mm256_cvttpd_epi32(v[1]), _mm256_cvttpd_epi32(v[0]));
        let l = to_i32([_mm256_min_pd(lo[0], last1), _mm256_min_pd(lo[1], last1)]);
        let h = to_i32([
            _mm256_max_pd(_mm256_sub_pd(one, neg_hi[0]), zero),
            _mm256_max_pd(_mm256_sub_pd(one, neg_hi[1]), zero),
        ]);
        spans_of(l, h, ja, jb)
    }

    /// The spans with lanes `lo..hi` where the lane is a row `ja..jb` and
    /// not empty (else `(EMPTY, -EMPTY)`), with their `any` and `all`: the
    /// tail both kinds of row bounds share.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn spans_of(lo: __m256i, hi: __m256i, ja: u32, jb: u32) -> LaneSpans {
        let lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        let in_rows = _mm256_and_si256(
            _mm256_cmpgt_epi32(lane, _mm256_set1_epi32(ja as i32 - 1)),
            _mm256_cmpgt_epi32(_mm256_set1_epi32(jb as i32), lane),
        );
        let live = _mm256_and_si256(in_rows, _mm256_cmpgt_epi32(hi, lo));
        let lo = _mm256_blendv_epi8(_mm256_set1_epi32(EMPTY), lo, live);
        let hi = _mm256_blendv_epi8(_mm256_set1_epi32(-EMPTY), hi, live);
        let mut out = LaneSpans {
            lo: [0; LANES],
            hi: [0; LANES],
            any: (0, 0),
            all: (0, 0),
        };
        // SAFETY: unaligned stores of `[i32; 8]` arrays.
        unsafe {
            _mm256_storeu_si256(out.lo.as_mut_ptr().cast(), lo);
            _mm256_storeu_si256(out.hi.as_mut_ptr().cast(), hi);
        }
        let (lo_a, lo_b) = (_mm256_castsi256_si128(lo), _mm256_extracti128_si256::<1>(lo));
        let (hi_a, hi_b) = (_mm256_castsi256_si128(hi), _mm256_extracti128_si256::<1>(hi));
        let (min_lo, max_lo) = min_max_128(_mm_min_epi32(lo_a, lo_b), _mm_max_epi32(lo_a, lo_b));
        let (min_hi, max_hi) = min_max_128(_mm_min_epi32(hi_a, hi_b), _mm_max_epi32(hi_a, hi_b));
        out.any = (min_lo, max_hi);
        out.all = (max_lo, min_hi);
        out
    }

    /// [`LaneSpans::masks`] with `vpsllvd`, which shifts in zeros for counts of 32 or more.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn masks_avx2(spans: &LaneSpans, xt: i32) -> [u32; LANES] {
        // SAFETY: loads and stores are unaligned, of `[i32; 8]` / `[u32; 8]` arrays.
        unsafe {
            let zero = _mm256_setzero_si256();
            let (ones, xt) = (_mm256_set1_epi32(-1), _mm256_set1_epi32(xt));
            let a = _mm256_max_epi32(_mm256_sub_epi32(_mm256_loadu_si256(spans.lo.as_ptr().cast()), xt), zero);
            let b = _mm256_max_epi32(_mm256_sub_epi32(_mm256_loadu_si256(spans.hi.as_ptr().cast()), xt), zero);
            let m = _mm256_andnot_si256(_mm256_sllv_epi32(ones, b), _mm256_sllv_epi32(ones, a));
            let mut out = [0u32; LANES];
            _mm256_storeu_si256(out.as_mut_ptr().cast(), m);
            out
        }
    }

    /// Per subtile (lane `k`), whether its bytes of the rows of `v` (row
    /// `j` in lane `j`; subtile `k` is byte `k % 4` of rows `4·(k / 4)..`)
    /// are all ones once AND-ed (`all`), or not all zero once OR-ed (`!all`):
    /// -1 or 0 per lane.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn per_subtile(v: __m256i, all: bool) -> __m256i {
        // Fold the four rows of each half (rows 0..4, 4..8) into every lane of it.
        let fold = |a: __m256i, b: __m256i| {
            if all {
                _mm256_and_si256(a, b)
            } else {
                _mm256_or_si256(a, b)
            }
        };
        let v = fold(v, _mm256_shuffle_epi32::<0b01_00_11_10>(v));
        let v = fold(v, _mm256_shuffle_epi32::<0b10_11_00_01>(v));
        // Lanes 0 and 4 hold the bytes of subtiles 0..4 and 4..8: each byte to a lane.
        let bytes = _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(
            v,
            _mm256_setr_epi32(0, 4, 0, 4, 0, 4, 0, 4),
        ));
        let wide = _mm256_cvtepu8_epi32(bytes);
        if all {
            _mm256_cmpeq_epi32(wide, _mm256_set1_epi32(0xFF))
        } else {
            _mm256_xor_si256(_mm256_cmpeq_epi32(wide, _mm256_setzero_si256()), _mm256_set1_epi32(-1))
        }
    }

    /// The inverse of [`per_subtile`]: per row, the bytes of the subtiles
    /// whose lane of `sel` is -1.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn to_rows(sel: __m256i) -> __m256i {
        // Byte 0 of lanes 0..4 of each half into every lane of the half.
        let pick = _mm256_setr_epi8(
            0, 4, 8, 12, 0, 4, 8, 12, 0, 4, 8, 12, 0, 4, 8, 12, 0, 4, 8, 12, 0, 4, 8, 12, 0, 4, 8, 12, 0, 4, 8, 12,
        );
        _mm256_shuffle_epi8(sel, pick)
    }

    /// The largest of eight lanes.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn max8(v: __m256) -> f32 {
        let m = _mm_max_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps::<1>(v));
        let m = _mm_max_ps(m, _mm_shuffle_ps::<0b01_00_11_10>(m, m));
        _mm_cvtss_f32(_mm_max_ps(m, _mm_shuffle_ps::<0b10_11_00_01>(m, m)))
    }

    /// `Scalar::nearer` in one compare.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn nearer_avx2(tile: &MaskTile, zt: &[f32; SUBTILES]) -> bool {
        // SAFETY: unaligned loads of `[f32; 8]` arrays.
        unsafe {
            let lt = _mm256_cmp_ps::<_CMP_LT_OQ>(_mm256_loadu_ps(zt.as_ptr()), _mm256_loadu_ps(tile.z0.as_ptr()));
            _mm256_movemask_ps(lt) != 0
        }
    }

    /// [`MaskTile::insert`] with the eight subtiles as eight lanes: every
    /// case of the update computed for every subtile, then selected.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn insert_avx2(tile: &mut MaskTile, m: &[u32; 8], zt: &[f32; SUBTILES], outside: &[u32; 8]) -> bool {
        // SAFETY: unaligned loads and stores of `[u32; 8]` and `[f32; 8]` arrays.
        unsafe {
            let ldi = |a: &[u32; 8]| _mm256_loadu_si256(a.as_ptr().cast());
            let (m, o, mask) = (ldi(m), ldi(outside), ldi(&tile.mask));
            let (z, z0, z1) = (
                _mm256_loadu_ps(zt.as_ptr()),
                _mm256_loadu_ps(tile.z0.as_ptr()),
                _mm256_loadu_ps(tile.z1.as_ptr()),
            );
            let reach = per_subtile(m, false);
            let better = _mm256_and_si256(reach, _mm256_castps_si256(_mm256_cmp_ps::<_CMP_LT_OQ>(z, z0)));
            if _mm256_testz_si256(better, better) != 0 {
                return false;
            }
            let held = per_subtile(_mm256_xor_si256(mask, o), false);
            let alone = per_subtile(_mm256_or_si256(m, o), true);
            let merged = per_subtile(_mm256_or_si256(mask, m), true);
            // The four cases, as in `MaskTile::insert`.
            let a = _mm256_and_si256(better, alone);
            let rest = _mm256_andnot_si256(alone, better);
            let b = _mm256_and_si256(rest, merged);
            let rest = _mm256_andnot_si256(merged, rest);
            let much_nearer = _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_LT_OQ>(z, z1),
                _mm256_cmp_ps::<_CMP_GT_OQ>(
                    _mm256_sub_ps(z1, z),
                    _mm256_sub_ps(_mm256_min_ps(z0, _mm256_set1_ps(1.0)), z1),
                ),
            );
            let c = _mm256_and_si256(_mm256_and_si256(rest, held), _mm256_castps_si256(much_nearer));
            let d = _mm256_andnot_si256(c, rest);
            let far = _mm256_blendv_ps(z, _mm256_max_ps(z1, z), _mm256_castsi256_ps(held));
            let fz = |v: __m256i| _mm256_castsi256_ps(v);
            let new_z0 = _mm256_blendv_ps(_mm256_blendv_ps(z0, _mm256_min_ps(z0, far), fz(b)), z, fz(a));
            let clear_a = _mm256_and_si256(a, _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GE_OQ>(z1, z)));
            let clear = _mm256_or_si256(clear_a, b);
            let new_z1 = _mm256_blendv_ps(z1, far, fz(d));
            let new_z1 = _mm256_blendv_ps(new_z1, z, fz(c));
            let new_z1 = _mm256_blendv_ps(new_z1, _mm256_set1_ps(f32::NEG_INFINITY), fz(clear));
            let (clear, replace, merge) = (to_rows(clear), to_rows(c), to_rows(d));
            let kept = _mm256_andnot_si256(_mm256_or_si256(clear, replace), mask);
            let new_mask = _mm256_or_si256(
                _mm256_or_si256(kept, _mm256_and_si256(o, clear)),
                _mm256_or_si256(
                    _mm256_and_si256(_mm256_or_si256(m, o), replace),
                    _mm256_and_si256(m, merge),
                ),
            );
            _mm256_storeu_si256(tile.mask.as_mut_ptr().cast(), new_mask);
            _mm256_storeu_ps(tile.z0.as_mut_ptr(), new_z0);
            _mm256_storeu_ps(tile.z1.as_mut_ptr(), new_z1);
            tile.far = max8(new_z0);
            true
        }
    }

    /// [`MaskTile::insert_full`] with the eight subtiles as eight lanes.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn insert_full_avx2(tile: &mut MaskTile, zt: &[f32; SUBTILES], outside: &[u32; 8]) -> bool {
        // SAFETY: unaligned loads and stores of `[u32; 8]` and `[f32; 8]` arrays.
        unsafe {
            let (z, z0, z1) = (
                _mm256_loadu_ps(zt.as_ptr()),
                _mm256_loadu_ps(tile.z0.as_ptr()),
                _mm256_loadu_ps(tile.z1.as_ptr()),
            );
            let better = _mm256_cmp_ps::<_CMP_LT_OQ>(z, z0);
            if _mm256_movemask_ps(better) == 0 {
                return false;
            }
            let clear = _mm256_and_ps(better, _mm256_cmp_ps::<_CMP_GE_OQ>(z1, z));
            // Selects between a loaded value and another become masked stores,
            // microcoded on AMD's cores: a min of registers stores whole.
            // min(z, z0) is z where better (z < z0), else z0.
            let new_z0 = _mm256_min_ps(z, z0);
            let floor = _mm256_blendv_ps(_mm256_set1_ps(f32::INFINITY), _mm256_set1_ps(f32::NEG_INFINITY), clear);
            let new_z1 = _mm256_min_ps(floor, z1);
            let rows = to_rows(_mm256_castps_si256(clear));
            let mask = _mm256_loadu_si256(tile.mask.as_ptr().cast());
            let o = _mm256_loadu_si256(outside.as_ptr().cast());
            let new_mask = _mm256_or_si256(_mm256_andnot_si256(rows, mask), _mm256_and_si256(o, rows));
            _mm256_storeu_si256(tile.mask.as_mut_ptr().cast(), new_mask);
            _mm256_storeu_ps(tile.z0.as_mut_ptr(), new_z0);
            _mm256_storeu_ps(tile.z1.as_mut_ptr(), new_z1);
            tile.far = max8(new_z0);
            true
        }
    }

    /// [`TileRows::next_scalar`] in two vectors of four lanes.
    ///
    /// # Safety
    /// The CPU must support SSE4.1.
    #[inline]
    #[target_feature(enable = "sse4.1")]
    unsafe fn next_sse41(rows: &mut TileRows, ja: u32, jb: u32) -> LaneSpans {
        // SAFETY: loads and stores are unaligned, of halves of `[i32; 8]` arrays.
        unsafe {
            let ld = |a: &[i32; LANES], h: usize| _mm_loadu_si128(a.as_ptr().add(4 * h).cast());
            let zero = _mm_setzero_si128();
            let mut out = LaneSpans {
                lo: [0; LANES],
                hi: [0; LANES],
                any: (0, 0),
                all: (0, 0),
            };
            let (mut lo_min, mut lo_max) = (_mm_set1_epi32(EMPTY), _mm_set1_epi32(-EMPTY));
            let (mut hi_min, mut hi_max) = (_mm_set1_epi32(EMPTY), _mm_set1_epi32(-EMPTY));
            for h in 0..2 {
                let (q, r) = (&rows.q, &rows.r);
                let left = |k: usize| _mm_sub_epi32(ld(&q[k], h), _mm_cmpgt_epi32(ld(&r[k], h), zero));
                let lo = _mm_max_epi32(_mm_max_epi32(left(0), left(1)), zero);
                let right = _mm_min_epi32(_mm_min_epi32(ld(&q[2], h), ld(&q[3], h)), _mm_set1_epi32(rows.last));
                let hi = _mm_add_epi32(right, _mm_set1_epi32(1));
                let base = 4 * h as i32;
                let lane = _mm_setr_epi32(base, base + 1, base + 2, base + 3);
                let in_rows = _mm_and_si128(
                    _mm_cmpgt_epi32(lane, _mm_set1_epi32(ja as i32 - 1)),
                    _mm_cmpgt_epi32(_mm_set1_epi32(jb as i32), lane),
                );
                let live = _mm_and_si128(in_rows, _mm_cmpgt_epi32(hi, lo));
                let lo = _mm_blendv_epi8(_mm_set1_epi32(EMPTY), lo, live);
                let hi = _mm_blendv_epi8(_mm_set1_epi32(-EMPTY), hi, live);
                _mm_storeu_si128(out.lo.as_mut_ptr().add(4 * h).cast(), lo);
                _mm_storeu_si128(out.hi.as_mut_ptr().add(4 * h).cast(), hi);
                (lo_min, lo_max) = (_mm_min_epi32(lo_min, lo), _mm_max_epi32(lo_max, lo));
                (hi_min, hi_max) = (_mm_min_epi32(hi_min, hi), _mm_max_epi32(hi_max, hi));
            }
            let (min_lo, max_lo) = min_max_128(lo_min, lo_max);
            let (min_hi, max_hi) = min_max_128(hi_min, hi_max);
            out.any = (min_lo, max_hi);
            out.all = (max_lo, min_hi);
            for k in 0..4 {
                for h in 0..2 {
                    let t = _mm_add_epi32(ld(&rows.r[k], h), _mm_set1_epi32(rows.r8[k]));
                    let carry = _mm_cmpgt_epi32(t, _mm_set1_epi32(rows.d[k] - 1));
                    let q = _mm_sub_epi32(_mm_add_epi32(ld(&rows.q[k], h), _mm_set1_epi32(rows.q8[k])), carry);
                    let r = _mm_sub_epi32(t, _mm_and_si128(carry, _mm_set1_epi32(rows.d[k])));
                    _mm_storeu_si128(rows.q[k].as_mut_ptr().add(4 * h).cast(), q);
                    _mm_storeu_si128(rows.r[k].as_mut_ptr().add(4 * h).cast(), r);
                }
            }
            rows.row += LANES as u32;
            out
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::scanline::tests::soup;
    use crate::raster::scanline::ScanEdges;
    use proptest::prelude::*;

    /// A backend's name and its row kernels, as closures.
    type Kernels = (
        &'static str,
        Box<dyn Fn(&mut TileRows, u32, u32) -> LaneSpans>,
        Box<dyn Fn(&LaneSpans, i32) -> [u32; 8]>,
    );

    /// Every kernel this CPU has, with its name.
    fn kernels() -> Vec<Kernels> {
        let mut v: Vec<Kernels> = vec![(
            "scalar",
            Box::new(|r, a, b| Scalar.next(r, a, b)),
            Box::new(|s, x| Scalar.masks(s, x)),
        )];
        #[cfg(target_arch = "x86_64")]
        {
            if let Some(k) = x86::Sse41::new() {
                v.push((
                    "sse41",
                    Box::new(move |r, a, b| k.next(r, a, b)),
                    Box::new(move |s, x| k.masks(s, x)),
                ));
            }
            if let Some(k) = x86::Avx2::new() {
                v.push((
                    "avx2",
                    Box::new(move |r, a, b| k.next(r, a, b)),
                    Box::new(move |s, x| k.masks(s, x)),
                ));
            } else {
                eprintln!("masked::simd: this CPU has no AVX2; its kernels are untested here");
            }
        }
        v
    }

    proptest! {
        /// Each kernel's lanes are the exact row spans ([`Tri::row_span`]),
        /// tile row after tile row, with rows outside `ja..jb` empty; and its
        /// masks are the scalar ones at every tile of the row.
        #[test]
        fn kernels_step_the_exact_row_spans(seed in any::<u64>(), w in 1u32..400, h in 1u32..200, inner in any::<bool>()) {
            let kernels = kernels();
            for t in soup(seed, 30, w, h, inner) {
                let edges = ScanEdges::new(&t);
                let (ya, yb) = edges.rows;
                if ya >= yb {
                    continue;
                }
                let first = ya / 8 * 8;
                let Some(start) = TileRows::new(&t, &edges, first, yb) else {
                    continue;
                };
                let want_masks = |s: &LaneSpans, xt: i32| s.masks(xt);
                for (name, next, masks) in &kernels {
                    let mut rows = start;
                    let mut y = first;
                    while y < yb {
                        let (ja, jb) = (ya.max(y) - y, yb.min(y + 8) - y);
                        let got = next(&mut rows, ja, jb);
                        for j in 0..8 {
                            let py = y + j as u32;
                            let want = if (ja..jb).contains(&(j as u32)) { t.row_span(py).unwrap_or((0, 0)) } else { (0, 0) };
                            prop_assert_eq!(got.span(j, u32::from(t.x0)), want, "{} row {} of {:?}", name, py, t);
                        }
                        let spans: [(u32, u32); 8] = std::array::from_fn(|j| got.span(j, u32::from(t.x0)));
                        prop_assert_eq!(got, LaneSpans::from_spans(&spans, u32::from(t.x0)), "{} lanes at row {}", name, y);
                        for xt in (-40..i32::from(t.x1 - t.x0) + 8).step_by(13) {
                            prop_assert_eq!(masks(&got, xt), want_masks(&got, xt), "{} masks at {}", name, xt);
                        }
                        y += 8;
                    }
                }
            }
        }
    }

    /// A backend's name and its direct-bounds kernel, as a closure.
    type DirectKernel = (&'static str, Box<dyn Fn(&mut RowBounds, u32, u32) -> LaneSpans>);

    /// Every vector kernel of [`RowKernel::next_direct`] this CPU has.
    fn direct_kernels() -> Vec<DirectKernel> {
        let mut v: Vec<DirectKernel> = Vec::new();
        #[cfg(target_arch = "x86_64")]
        {
            if let Some(k) = x86::Sse41::new() {
                v.push(("sse41", Box::new(move |r, a, b| k.next_direct(r, a, b))));
            }
            if let Some(k) = x86::Avx2::new() {
                v.push(("avx2", Box::new(move |r, a, b| k.next_direct(r, a, b))));
            }
        }
        v
    }

    proptest! {
        /// Each kernel's direct bounds ([`RowKernel::next_direct`]) equal
        /// [`RowBounds::next_scalar`] lane for lane, and leave the bounds
        /// where it leaves them, tile row after tile row.
        #[test]
        fn direct_kernels_equal_the_scalar_bounds(seed in any::<u64>(), w in 1u32..400, h in 1u32..200, inner in any::<bool>()) {
            let kernels = direct_kernels();
            for t in soup(seed, 30, w, h, inner) {
                let (ya, yb) = crate::raster::scanline::row_limits(&t);
                if ya >= yb {
                    continue;
                }
                let first = ya / 8 * 8;
                let Some(start) = RowBounds::new(&t, first, yb) else {
                    continue;
                };
                for (name, next) in &kernels {
                    let (mut want_b, mut got_b) = (start, start);
                    for y in (first..yb).step_by(8) {
                        let (ja, jb) = (ya.max(y) - y, yb.min(y + 8) - y);
                        let (want, got) = (want_b.next_scalar(ja, jb), next(&mut got_b, ja, jb));
                        prop_assert_eq!(got, want, "{} at row {} of {:?}", name, y, t);
                        prop_assert_eq!(got_b.x.map(f64::to_bits), want_b.x.map(f64::to_bits), "{} bounds after row {}", name, y);
                    }
                }
            }
        }
    }

    /// Random inserts into random tiles (random masks, depths from a few
    /// values so ties happen, the edge of the viewport anywhere): every
    /// kernel leaves the tile exactly as the scalar `MaskTile` update does.
    #[test]
    fn kernels_update_tiles_as_the_scalar_code() {
        #[cfg(target_arch = "x86_64")]
        let avx2 = x86::Avx2::new();
        #[cfg(not(target_arch = "x86_64"))]
        let avx2: Option<Scalar> = None;
        let Some(avx2) = avx2 else {
            eprintln!("masked::simd: this CPU has no AVX2; its tile update is untested here");
            return;
        };
        let mut rng = hom_testkit::Rng::new(77);
        let depths = [0.1f32, 0.25, 0.4, 0.4, 0.7, 0.9, 1.0, 1.5];
        let pick = |rng: &mut hom_testkit::Rng| depths[rng.below(depths.len() as u64) as usize];
        let (mut inserts, mut told) = (0, 0);
        for _ in 0..300 {
            let mut zb = crate::masked::MaskedZBuffer::default();
            zb.clear(1 + rng.below(32) as u32, 1 + rng.below(8) as u32);
            let (tiles, outside, _) = zb.rows_mut();
            let (mut tile, outside) = (tiles[0], outside[0]);
            for _ in 0..40 {
                let m: [u32; 8] = std::array::from_fn(|_| match rng.below(4) {
                    0 => 0,
                    1 => u32::MAX,
                    _ => rng.below(1 << 32) as u32,
                });
                let m = m.map(|r| r & !outside[0]);
                let zt: [f32; 8] = std::array::from_fn(|_| pick(&mut rng));
                let full = rng.below(4) == 0;
                let (mut want, mut got) = (tile, tile);
                let (a, b) = if full {
                    (
                        want.insert_full(&zt, &outside),
                        avx2.insert_full(&mut got, &zt, &outside),
                    )
                } else {
                    (want.insert(&m, &zt, &outside), avx2.insert(&mut got, &m, &zt, &outside))
                };
                assert_eq!(a, b, "told, from {tile:?} with {m:x?} {zt:?} full {full}");
                assert_eq!(got, want, "from {tile:?} with {m:x?} {zt:?} full {full}");
                assert_eq!(got.far, want.far);
                assert_eq!(Scalar.nearer(&tile, &zt), avx2.nearer(&tile, &zt));
                inserts += 1;
                told += usize::from(a);
                tile = want;
            }
        }
        assert!(
            told > inserts / 4 && told < inserts,
            "{told} of {inserts} inserts told the tile something"
        );
    }

    #[test]
    fn masks_are_the_covered_columns() {
        let mut lo = [EMPTY_LO; 8];
        let mut hi = [-EMPTY_LO; 8];
        (lo[0], hi[0]) = (3, 10);
        (lo[1], hi[1]) = (0, 40);
        (lo[2], hi[2]) = (31, 32);
        let s = LaneSpans {
            lo,
            hi,
            any: (0, 40),
            all: (EMPTY_LO, -EMPTY_LO),
        };
        let m = s.masks(0);
        assert_eq!(m[0], 0b11_1111_1000);
        assert_eq!(m[1], u32::MAX);
        assert_eq!(m[2], 1 << 31);
        assert!(m[3..].iter().all(|&b| b == 0));
        assert_eq!(s.masks(8)[0], 0b11);
        assert_eq!(s.masks(-4)[0], 0b11_1111_1000_0000);
    }

    const EMPTY_LO: i32 = crate::raster::scanline::EMPTY;
}
