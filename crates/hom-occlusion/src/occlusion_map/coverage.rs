//! Occluder coverage at output resolution, the base of a conservative
//! occlusion map (Zhang et al. 1997, section 6.1, done in software): one bit
//! per output sample, and the span and mask writes that fill it (noting the
//! words a triangle covers first, for the depth cells).

/// One bit per output sample: bit `x % 64` of word `y * words_per_row + x / 64`.
#[derive(Clone, Debug, Default)]
pub struct CoverageBuffer {
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) words_per_row: usize,
    pub(super) bits: Vec<u64>,
}

impl CoverageBuffer {
    /// Sizes the buffer to `width` × `height`, keeping what it holds where
    /// the size is unchanged: for a draw that empties every row itself
    /// ([`CoverageRasterizer::set_up_and_rasterize`] with `empty_first`).
    pub(crate) fn set_size(&mut self, width: u32, height: u32) {
        if (width, height) != (self.width, self.height) {
            self.reset(width, height);
        }
    }

    /// Clears to "nothing covered" at `width` × `height`.
    pub fn reset(&mut self, width: u32, height: u32) {
        self.width = width;
        self.height = height;
        self.words_per_row = (width as usize).div_ceil(64);
        self.bits.clear();
        self.bits.resize(self.words_per_row * height as usize, 0);
    }

    /// Width in samples.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in samples.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Words per row.
    pub fn words_per_row(&self) -> usize {
        self.words_per_row
    }

    /// The bits, row-major.
    pub fn bits(&self) -> &[u64] {
        &self.bits
    }

    /// Whether sample `(x, y)` is covered.
    ///
    /// # Panics
    /// If `(x, y)` is outside the buffer.
    pub fn is_covered(&self, x: u32, y: u32) -> bool {
        assert!(x < self.width && y < self.height);
        self.bits[y as usize * self.words_per_row + x as usize / 64] >> (x % 64) & 1 == 1
    }

    /// Number of covered samples.
    pub fn covered(&self) -> u64 {
        self.bits.iter().map(|w| w.count_ones() as u64).sum()
    }
}

/// Calls `f(w, mask)` for each word `w` of a row that samples `lo..hi`
/// (`lo < hi`) touch, `mask` its bits among them: the first and last words
/// apart, the words between whole, with no per-word test (the per-word
/// tests were the coverage raster's costliest line).
#[inline(always)]
pub(super) fn for_span_words(lo: u32, hi: u32, mut f: impl FnMut(usize, u64)) {
    let (wa, wb) = ((lo / 64) as usize, ((hi - 1) / 64) as usize);
    let (first, last) = (u64::MAX << (lo % 64), u64::MAX >> (63 - (hi - 1) % 64));
    if wa == wb {
        f(wa, first & last);
    } else {
        f(wa, first);
        for w in wa + 1..wb {
            f(w, u64::MAX);
        }
        f(wb, last);
    }
}

/// Sets bits `lo..hi` of a row.
#[inline]
pub(crate) fn set_span(row: &mut [u64], lo: u32, hi: u32) {
    if lo < hi {
        for_span_words(lo, hi, |w, mask| row[w] |= mask);
    }
}

/// Sets bits `lo..hi` of row `py` and ORs the ones not set before into
/// `fresh` (a row's worth of words), widening `rows[w]` (first and last
/// row) to `py` for each word `w` that took any; whether there were any.
#[inline]
pub(super) fn set_span_fresh(
    row: &mut [u64],
    fresh: &mut [u64],
    rows: &mut [(u32, u32)],
    py: u32,
    lo: u32,
    hi: u32,
) -> bool {
    if lo >= hi {
        return false;
    }
    let mut any = 0;
    for_span_words(lo, hi, |w, mask| {
        let new = mask & !row[w];
        row[w] |= mask;
        if new != 0 {
            fresh[w] |= new;
            rows[w] = (rows[w].0.min(py), py);
        }
        any |= new;
    });
    any != 0
}

/// ORs `mask` (bit `k` is sample `x + k`) into a row.
#[inline]
pub(super) fn or_mask(row: &mut [u64], x: u32, mask: u64) {
    let (w, bit) = ((x / 64) as usize, x % 64);
    row[w] |= mask << bit;
    if bit != 0 {
        let high = mask >> (64 - bit);
        if high != 0 {
            row[w + 1] |= high;
        }
    }
}

/// [`or_mask`] into row `py`, keeping `fresh` and `rows` as
/// [`set_span_fresh`] does; whether any bit was not set before.
#[inline]
pub(super) fn or_mask_fresh(
    row: &mut [u64],
    fresh: &mut [u64],
    rows: &mut [(u32, u32)],
    py: u32,
    x: u32,
    mask: u64,
) -> bool {
    let (w, bit) = ((x / 64) as usize, x % 64);
    let low = mask << bit;
    let mut new = low & !row[w];
    row[w] |= low;
    if new != 0 {
        fresh[w] |= new;
        rows[w] = (rows[w].0.min(py), py);
    }
    if bit != 0 {
        let high = mask >> (64 - bit);
        if high != 0 {
            let n = high & !row[w + 1];
            row[w + 1] |= high;
            if n != 0 {
                fresh[w + 1] |= n;
                rows[w + 1] = (rows[w + 1].0.min(py), py);
            }
            new |= n;
        }
    }
    new != 0
}
