//! The hierarchy of occlusion maps (Zhang et al. 1997, sections 4.1–4.2).
//!
//! Each pixel of level 0 stands for a `block × block` square of output
//! samples; each level above averages 2×2 pixels of the one below, down to a
//! minimum size. Opacity is kept as an exact *count of covered output samples*
//! (opacity = count / samples per pixel), not as a float: averaging floats can
//! round 0.99999994 up to 1.0 and make a pixel with a hole "opaque", while an
//! integer sum is opaque exactly when every sample below it is covered.
//!
//! Samples outside the viewport (the ragged right and bottom edges when the
//! viewport is not a multiple of the block, and the padding of odd-sized
//! levels) count as covered: nothing drawn there can ever be seen, so this
//! never hides a visible pixel, and it keeps objects at the screen edge cullable.

/// One level of the pyramid.
#[derive(Clone, Debug, Default)]
pub struct Level {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Output samples each pixel stands for (`block² · 4^level`).
    pub samples_per_pixel: u32,
    /// Covered output samples per pixel, row-major, row 0 at the top.
    pub counts: Vec<u32>,
}

impl Level {
    /// Covered samples of pixel `(x, y)`.
    ///
    /// # Panics
    /// If `(x, y)` is outside the level.
    #[inline]
    pub fn count(&self, x: u32, y: u32) -> u32 {
        self.counts[(y * self.width + x) as usize]
    }

    /// Opacity of pixel `(x, y)` in `[0, 1]`.
    pub fn opacity(&self, x: u32, y: u32) -> f32 {
        self.count(x, y) as f32 / self.samples_per_pixel as f32
    }
}

/// The occlusion map hierarchy; level 0 has the highest resolution.
#[derive(Clone, Debug, Default)]
pub struct Pyramid {
    block: u32,
    viewport: (u32, u32),
    levels: Vec<Level>,
}

impl Pyramid {
    /// An empty (all transparent) pyramid for a `width` × `height` viewport,
    /// with base pixels of `block` × `block` samples, reduced until both sides
    /// are at most `min_side` (or one pixel).
    ///
    /// # Panics
    /// If `block` is 0 or above 64, or the viewport is empty.
    pub fn new(width: u32, height: u32, block: u32, min_side: u32) -> Pyramid {
        assert!((1..=64).contains(&block), "block must be 1..=64, got {block}");
        assert!(width > 0 && height > 0, "viewport must not be empty");
        let levels = level_sides(width, height, block, min_side)
            .enumerate()
            .map(|(k, (w, h))| Level {
                width: w,
                height: h,
                samples_per_pixel: (block * block) << (2 * k),
                counts: vec![0; (w * h) as usize],
            })
            .collect();
        Pyramid {
            block,
            viewport: (width, height),
            levels,
        }
    }

    /// Output samples per base pixel side.
    pub fn block(&self) -> u32 {
        self.block
    }

    /// The output viewport (width, height) this pyramid covers.
    pub fn viewport(&self) -> (u32, u32) {
        self.viewport
    }

    /// The levels, base (highest resolution) first.
    pub fn levels(&self) -> &[Level] {
        &self.levels
    }

    /// Fills level 0 from a coverage bitmap at output resolution: `rows[y]`
    /// holds `words_per_row` 64-bit words, bit `x % 64` of word `x / 64` set
    /// when sample `(x, y)` is covered. Then builds the levels above.
    ///
    /// # Panics
    /// If `coverage` is shorter than `height * words_per_row`, or a row is too short for the width.
    pub fn build_from_coverage(&mut self, coverage: &[u64], words_per_row: usize) {
        let (width, height) = self.viewport;
        assert!(words_per_row * 64 >= width as usize, "coverage rows too short");
        assert!(coverage.len() >= height as usize * words_per_row, "coverage too short");
        let counter = self.base_counter();
        counter.count(&mut self.levels[0].counts, coverage, words_per_row, height);
        self.finish_base();
    }

    /// Splits the pyramid for a raster's bands of `band_rows` sample rows
    /// (from row 0; the last may be shorter): per band, its rows of the base
    /// and of each level above that lies within the band alone, which the
    /// band fills as soon as it is drawn ([`BandBuild::build`]); then
    /// [`Pyramid::finish_bands`] builds the levels above those. `None` when
    /// a band's rows are not whole rows of base pixels.
    pub(crate) fn split_bands(&mut self, band_rows: u32) -> Option<(BandBuild, Vec<Vec<&mut [u32]>>)> {
        let b = self.block;
        if !band_rows.is_multiple_of(b) {
            return None;
        }
        let base_rows = band_rows / b;
        // The base, and each level above while a band's rows halve evenly.
        let (mut levels, mut rows) = (1, base_rows);
        while levels < self.levels.len().min(MAX_BAND_LEVELS) && rows.is_multiple_of(2) {
            (levels, rows) = (levels + 1, rows / 2);
        }
        let mut build = BandBuild {
            counter: self.base_counter(),
            viewport: self.viewport,
            base_rows,
            levels,
            widths: [0; MAX_BAND_LEVELS],
            full: [0; MAX_BAND_LEVELS],
        };
        let bands = self.viewport.1.div_ceil(band_rows) as usize;
        let mut split: Vec<Vec<&mut [u32]>> = (0..bands).map(|_| Vec::with_capacity(levels)).collect();
        for (k, level) in self.levels[..levels].iter_mut().enumerate() {
            (build.widths[k], build.full[k]) = (level.width, level.samples_per_pixel);
            let pixels = ((base_rows >> k) * level.width) as usize;
            for (band, rows) in level.counts.chunks_mut(pixels).enumerate() {
                split[band].push(rows);
            }
        }
        debug_assert!(split.iter().all(|s| s.len() == levels), "every band holds every level");
        Some((build, split))
    }

    /// After every band built its levels ([`BandBuild::build`]): builds the levels above them.
    pub(crate) fn finish_bands(&mut self, build: &BandBuild) {
        self.build_levels_from(build.levels);
    }

    /// What counts the base level's pixels from coverage, a part of the
    /// rows at a time ([`BaseCounter::count`]).
    pub(crate) fn base_counter(&self) -> BaseCounter {
        BaseCounter {
            block: self.block,
            base_width: self.levels[0].width as usize,
            width: self.viewport.0,
        }
    }

    /// After every base pixel was counted from coverage: counts the samples
    /// past the viewport's edges as covered and builds the levels above.
    fn finish_base(&mut self) {
        let base = &mut self.levels[0];
        add_outside(&mut base.counts, 0, base.width, self.block, self.viewport);
        self.build_levels();
    }

    /// Rebuilds every level above the base from the base counts.
    pub fn build_levels(&mut self) {
        self.build_levels_from(1);
    }

    /// Rebuilds the levels from `first` up, each from the one below.
    fn build_levels_from(&mut self, first: usize) {
        for k in first..self.levels.len() {
            let (lower, upper) = self.levels.split_at_mut(k);
            let (lower, upper) = (&lower[k - 1], &mut upper[0]);
            reduce_rows(
                &lower.counts,
                lower.width,
                lower.samples_per_pixel,
                &mut upper.counts,
                upper.width,
            );
        }
    }

    /// Mutable base level, for callers that fill it themselves (then call [`Pyramid::build_levels`]).
    pub fn base_mut(&mut self) -> &mut Level {
        &mut self.levels[0]
    }
}

/// The sides of each level of [`Pyramid::new`]'s pyramid, from the base
/// (pixels of `block` × `block` samples) up: each halves the one below,
/// rounded up, until both sides are at most `min_side` (or one pixel).
pub(crate) fn level_sides(width: u32, height: u32, block: u32, min_side: u32) -> impl Iterator<Item = (u32, u32)> {
    let last = move |(w, h): (u32, u32)| (w <= min_side.max(1) && h <= min_side.max(1)) || (w == 1 && h == 1);
    let base = (width.div_ceil(block), height.div_ceil(block));
    std::iter::successors(Some(base), move |&s| {
        (!last(s)).then(|| (s.0.div_ceil(2), s.1.div_ceil(2)))
    })
}

/// Most levels (the base and those above it) a band builds on its own.
const MAX_BAND_LEVELS: usize = 8;

/// How a raster's bands build a pyramid's lower levels as each is drawn
/// ([`Pyramid::split_bands`]): the band counts its rows of the base, adds
/// the samples past the viewport's edges as covered, and reduces the rows
/// above while they lie within it, on its own thread and while its rows
/// are hot. (Built after the last band, levels 1 and up took the city's
/// frame 16 µs at two threads against 8 at one: half the base came from the
/// other core's cache.)
#[derive(Clone, Copy, Debug)]
pub(crate) struct BandBuild {
    counter: BaseCounter,
    viewport: (u32, u32),
    /// Base pixel rows of every band but the last.
    base_rows: u32,
    /// Levels a band holds: the base and `levels - 1` above it.
    levels: usize,
    /// Each held level's width and samples per pixel.
    widths: [u32; MAX_BAND_LEVELS],
    full: [u32; MAX_BAND_LEVELS],
}

impl BandBuild {
    /// Fills band `band`'s rows of the held levels (`levels`, as
    /// [`Pyramid::split_bands`] gave them) from its coverage: `rows` sample
    /// rows of `words_per_row` words (bits past the viewport zero).
    pub(crate) fn build(
        &self,
        band: usize,
        levels: &mut [&mut [u32]],
        coverage: &[u64],
        words_per_row: usize,
        rows: u32,
    ) {
        debug_assert_eq!(levels.len(), self.levels);
        self.counter.count(levels[0], coverage, words_per_row, rows);
        let first = band as u32 * self.base_rows;
        add_outside(levels[0], first, self.widths[0], self.counter.block, self.viewport);
        for k in 1..self.levels {
            let (lower, upper) = levels.split_at_mut(k);
            reduce_rows(
                lower[k - 1],
                self.widths[k - 1],
                self.full[k - 1],
                upper[0],
                self.widths[k],
            );
        }
    }
}

/// Counts base pixels (covered samples inside the viewport, without the
/// samples past its edges: [`add_outside`] adds those).
#[derive(Clone, Copy, Debug)]
pub(crate) struct BaseCounter {
    block: u32,
    base_width: usize,
    width: u32,
}

impl BaseCounter {
    /// Base pixels standing for `rows` sample rows from a multiple of the block.
    pub(crate) fn pixels_for_rows(self, rows: u32) -> usize {
        rows.div_ceil(self.block) as usize * self.base_width
    }

    /// Counts the base pixels of `out` (whole rows of the base, from a row
    /// of blocks whose first sample row is a multiple of the block) from
    /// `coverage`: the `rows` sample rows they stand for, `words_per_row`
    /// words each (bits past the viewport zero).
    pub(crate) fn count(self, out: &mut [u32], coverage: &[u64], words_per_row: usize, rows: u32) {
        let (b, bw) = (self.block, self.base_width);
        debug_assert_eq!(out.len(), self.pixels_for_rows(rows), "whole rows of blocks");
        match b {
            4 | 8 => count_blocks_swar(out, bw, coverage, words_per_row, b, rows),
            1 | 2 | 16 | 32 | 64 => count_blocks_aligned(out, bw, coverage, words_per_row, b, rows),
            _ => count_blocks_scalar(out, bw, coverage, words_per_row, b, rows, self.width),
        }
    }
}

/// Covered samples inside the viewport per base pixel, one pixel at a time:
/// the reference for [`count_blocks_swar`], and the path for unusual block sizes.
fn count_blocks_scalar(out: &mut [u32], bw: usize, coverage: &[u64], wpr: usize, b: u32, height: u32, width: u32) {
    for (my, out) in out.chunks_mut(bw).enumerate() {
        let y0 = my as u32 * b;
        let inside_h = b.min(height - y0);
        for (mx, count_out) in out.iter_mut().enumerate() {
            let mx = mx as u32;
            let x0 = mx * b;
            let inside_w = b.min(width - x0);
            let mut count = 0;
            for y in y0..y0 + inside_h {
                count += count_bits(&coverage[y as usize * wpr..][..wpr], x0, inside_w);
            }
            *count_out = count;
        }
    }
}

/// [`count_blocks_scalar`] for blocks of 4 or 8 samples, 64 samples at a
/// time: per-group population counts in SIMD-within-a-register lanes, summed
/// over the block's rows, then read out. Bits past the viewport are zero in
/// coverage rows, so whole words can be counted.
fn count_blocks_swar(out: &mut [u32], bw: usize, coverage: &[u64], wpr: usize, b: u32, height: u32) {
    const M1: u64 = 0x5555_5555_5555_5555;
    const M2: u64 = 0x3333_3333_3333_3333;
    const M4: u64 = 0x0F0F_0F0F_0F0F_0F0F;
    let per_word = 64 / b as usize;
    for (my, out) in out.chunks_mut(bw).enumerate() {
        let y0 = my as u32 * b;
        let rows = b.min(height - y0);
        for word in 0..wpr {
            let first = word * per_word;
            let n = per_word.min(bw.saturating_sub(first));
            // Words that every row of the block row leaves empty, or covers
            // whole, count without the lanes (most of a walk's frame).
            let (mut all, mut any) = (u64::MAX, 0u64);
            for y in y0..y0 + rows {
                let w = coverage[y as usize * wpr + word];
                all &= w;
                any |= w;
            }
            if any == 0 || all == u64::MAX {
                let count = if any == 0 { 0 } else { rows * b };
                out[first..first + n].fill(count);
                continue;
            }
            // Byte lanes: for b = 4, `even`/`odd` hold the counts of the even/odd
            // nibbles (at most 16 per lane); for b = 8, `even` holds byte counts.
            let (mut even, mut odd) = (0u64, 0u64);
            for y in y0..y0 + rows {
                let w = coverage[y as usize * wpr + word];
                let x = w - ((w >> 1) & M1);
                let x = (x & M2) + ((x >> 2) & M2);
                if b == 4 {
                    even += x & M4;
                    odd += (x >> 4) & M4;
                } else {
                    even += (x + (x >> 4)) & M4;
                }
            }
            // Lane k of `even` (and of `odd` for b = 4) is pixel 2k (2k + 1); for b = 8, pixel k.
            let mut counts = [0u32; 16];
            for lane in 0..8 {
                let e = ((even >> (8 * lane)) & 0xFF) as u32;
                let o = ((odd >> (8 * lane)) & 0xFF) as u32;
                if b == 4 {
                    counts[2 * lane] = e;
                    counts[2 * lane + 1] = o;
                } else {
                    counts[lane] = e;
                }
            }
            // Whole words copy a fixed length: a length known only at run
            // time became a `memcpy` call per word (1.8 % of HOM's cull on city).
            match n {
                16 => out[first..first + 16].copy_from_slice(&counts),
                8 => out[first..first + 8].copy_from_slice(&counts[..8]),
                _ => out[first..first + n].copy_from_slice(&counts[..n]),
            }
        }
    }
}

/// [`count_blocks_scalar`] for blocks whose side divides 64 (1, 2, 16, 32,
/// 64 samples): a word holds whole blocks, so each block's row is one masked
/// population count. Small buffers take this path (a 256² buffer with the
/// default 256-pixel map has blocks of one sample): on MOC's recorded frames
/// at 256², HOM's map path fell from 1.0–2.6 to 0.8–1.6 ms against the
/// pixel-by-pixel count. Bits past the viewport are zero in coverage rows,
/// so whole words can be counted.
fn count_blocks_aligned(out: &mut [u32], bw: usize, coverage: &[u64], wpr: usize, b: u32, height: u32) {
    debug_assert!(64 % b == 0);
    let per_word = (64 / b) as usize;
    let mask = if b == 64 { u64::MAX } else { (1u64 << b) - 1 };
    for (my, out) in out.chunks_mut(bw).enumerate() {
        out.fill(0);
        let y0 = my as u32 * b;
        for y in y0..y0 + b.min(height - y0) {
            let row = &coverage[y as usize * wpr..][..wpr];
            for (word, &w) in row.iter().enumerate() {
                if w == 0 {
                    continue;
                }
                let first = word * per_word;
                for (g, count) in out[first..bw.min(first + per_word)].iter_mut().enumerate() {
                    *count += (w >> (g as u32 * b) & mask).count_ones();
                }
            }
        }
    }
}

/// Set bits among `n` bits starting at bit `x0` of a row of words.
#[inline]
fn count_bits(row: &[u64], x0: u32, n: u32) -> u32 {
    let mut count = 0;
    let (mut x, end) = (x0, x0 + n);
    while x < end {
        let word = row[(x / 64) as usize];
        let lo = x % 64;
        let take = (64 - lo).min(end - x);
        let mask = if take == 64 {
            u64::MAX
        } else {
            ((1u64 << take) - 1) << lo
        };
        count += (word & mask).count_ones();
        x += take;
    }
    count
}

/// Adds to base pixels `counts` (whole rows of `width` pixels, from row
/// `first_row`) the samples of each that lie past the viewport's right or
/// bottom edge, counted as covered.
fn add_outside(counts: &mut [u32], first_row: u32, width: u32, block: u32, (vw, vh): (u32, u32)) {
    let b = block;
    let last_row = vh.div_ceil(b) - 1;
    let inside = |mx: u32, my: u32| b.min(vw - mx * b) * b.min(vh - my * b);
    for (my, row) in (first_row..).zip(counts.chunks_mut(width as usize)) {
        // Only the last column, and the last row, reach past an edge.
        let xs = if my == last_row { 0..width } else { width - 1..width };
        for mx in xs {
            row[mx as usize] += b * b - inside(mx, my);
        }
    }
}

/// 2×2 reduction of whole rows: `lower` (rows of `lw` pixels, each standing
/// for `full` samples) into `upper` (rows of `uw` pixels, half as many rows,
/// rounded up); children past the lower rows' right or bottom edge count as
/// fully covered.
fn reduce_rows(lower: &[u32], lw: u32, full: u32, upper: &mut [u32], uw: u32) {
    let lh = lower.len() as u32 / lw;
    let uh = upper.len() as u32 / uw;
    // Fast path: interior pixels whose four children all exist.
    let (inner_w, inner_h) = (lw / 2, lh / 2);
    for y in 0..inner_h {
        let r0 = &lower[(2 * y * lw) as usize..][..lw as usize];
        let r1 = &lower[((2 * y + 1) * lw) as usize..][..lw as usize];
        let out = &mut upper[(y * uw) as usize..][..inner_w as usize];
        for (x, o) in out.iter_mut().enumerate() {
            *o = r0[2 * x] + r0[2 * x + 1] + r1[2 * x] + r1[2 * x + 1];
        }
    }
    // Ragged right column and bottom row.
    let child = |x: u32, y: u32| {
        if x < lw && y < lh {
            lower[(y * lw + x) as usize]
        } else {
            full
        }
    };
    for y in 0..uh {
        let xs = if y < inner_h { inner_w..uw } else { 0..uw };
        for x in xs {
            upper[(y * uw + x) as usize] =
                child(2 * x, 2 * y) + child(2 * x + 1, 2 * y) + child(2 * x, 2 * y + 1) + child(2 * x + 1, 2 * y + 1);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hom_testkit::Rng;
    use proptest::prelude::*;

    /// Brute force: a level-k pixel's count is the number of covered samples in
    /// its square, with samples outside the viewport counted as covered.
    fn brute_count(cov: &[Vec<bool>], width: u32, height: u32, size: u32, x: u32, y: u32) -> u32 {
        let mut n = 0;
        for sy in y * size..(y + 1) * size {
            for sx in x * size..(x + 1) * size {
                if sx >= width || sy >= height || cov[sy as usize][sx as usize] {
                    n += 1;
                }
            }
        }
        n
    }

    proptest! {
        #[test]
        fn pyramid_equals_brute_force_averaging(
            width in 1u32..150, height in 1u32..70, block in prop_oneof![1u32..10, Just(16u32), Just(32), Just(64)],
            min_side in 1u32..5, seed in any::<u64>(), density in prop_oneof![0.0f64..1.0, Just(1.0f64), Just(0.0f64)]
        ) {
            let mut rng = Rng::new(seed);
            let cov: Vec<Vec<bool>> = (0..height).map(|_| (0..width).map(|_| f64::from(rng.unit()) < density).collect()).collect();
            let wpr = (width as usize).div_ceil(64);
            let mut bits = vec![0u64; wpr * height as usize];
            for y in 0..height as usize {
                for x in 0..width as usize {
                    if cov[y][x] { bits[y * wpr + x / 64] |= 1 << (x % 64); }
                }
            }
            let mut p = Pyramid::new(width, height, block, min_side);
            // Reused, as each frame reuses it: first the complement, then the coverage.
            let inside = |word: usize| if (word + 1) * 64 <= width as usize { u64::MAX } else { (1u64 << (width % 64)) - 1 };
            let other: Vec<u64> = bits.iter().enumerate().map(|(i, &w)| !w & inside(i % wpr)).collect();
            p.build_from_coverage(&other, wpr);
            p.build_from_coverage(&bits, wpr);
            for (k, level) in p.levels().iter().enumerate() {
                let size = block << k;
                prop_assert_eq!(level.samples_per_pixel, size * size);
                for y in 0..level.height {
                    for x in 0..level.width {
                        prop_assert_eq!(level.count(x, y), brute_count(&cov, width, height, size, x, y), "level {} pixel {},{}", k, x, y);
                    }
                }
            }
            let top = p.levels().last().unwrap();
            prop_assert!((top.width <= min_side && top.height <= min_side) || (top.width == 1 && top.height == 1));
        }
    }

    #[test]
    fn one_hole_keeps_every_ancestor_below_full() {
        let (w, h) = (256u32, 256u32);
        let wpr = 4;
        let mut bits = vec![u64::MAX; wpr * h as usize];
        bits[100 * wpr + 1] &= !(1 << 7); // sample (71, 100) uncovered
        let mut p = Pyramid::new(w, h, 4, 4);
        p.build_from_coverage(&bits, wpr);
        for (k, level) in p.levels().iter().enumerate() {
            let size = 4 << k;
            let (x, y) = (71 / size, 100 / size);
            assert_eq!(level.count(x, y), level.samples_per_pixel - 1, "level {k}");
        }
        assert_eq!(p.levels().len(), 5, "64, 32, 16, 8, 4");
    }
}
