//! Occluder coverage at output resolution: the base of a conservative
//! occlusion map (Zhang et al. 1997, section 6.1, done in software).
//!
//! Each occluder triangle is clipped, snapped and set up by
//! [`crate::raster::setup`] — the same code the reference renderer draws with — so a
//! sample is covered here exactly when the renderer would cover it with that
//! triangle. Coverage is one bit per output sample; rows of the image are
//! split into bands filled in parallel (bits are OR-ed, so the result does not
//! depend on the thread count or order).
//!
//! Rows are filled by one of the [`RasterBackend`]s: the scalar one (exact
//! spans, [`Tri::row_span`]'s, stepped row to row by [`crate::raster::scanline`])
//! defines the result, and the vector kernels of
//! [`crate::raster::simd`] produce bit-identical coverage and depth cells.

use super::coverage::{or_mask, or_mask_fresh, set_span, set_span_fresh, CoverageBuffer};
use super::depth_cells::{raise_fresh_cells, CellGrid, CellOf};
use crate::occlusion_map::DepthEstimationBuffer;
use crate::occlusion_map::{BandBuild, Pyramid};
#[cfg(test)]
use crate::raster::costliest_first;
use crate::raster::queue::{QueueSetup, TriangleQueue};
use crate::raster::scanline::{ScanEdges, Stepper};
use crate::raster::setup::Tri;
use crate::raster::simd::{prefetch, row_masks, RasterBackend, MASK_MAX};
use crate::raster::sort_costliest_first;
#[cfg(test)]
use rayon::iter::ParallelIterator;
use std::ops::Range;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, PoisonError, RwLock};
use std::time::Instant;

/// Where a triangle's rows come from: exact spans stepped row to row, or a
/// vector kernel's masks (into the band's scratch rows).
enum Rows {
    Spans(Stepper),
    Masks,
}

/// Rows per parallel band (whole rows of depth cells when gathering depth,
/// at least this many). Each band tests every triangle reaching it, so
/// taller bands test fewer: 32 against 16 cut the coverage raster by 3–11 %
/// on city, office and sculpture-park (one and two threads, 7 alternating
/// runs of `cull_time`, 2026-12-04); 64 was no better than 32.
const BAND_ROWS: u32 = 32;

/// Rows whose first covers share one depth evaluation per cell and word
/// (runs start at multiples of it, within a row of depth cells). Raising
/// cells once per run of a whole row of 16-row cells instead of once per row
/// took 3–24 % off HOM's cull on city, office and sculpture-park (one and two
/// threads, 7 alternating runs of `cull_time`) and changed no scene's
/// efficiency (each word's own first and last rows keep the bound tight;
/// the run's would lose 2.5 points on sculpture-park).
const RUN_ROWS: u32 = 16;

/// How many binned triangles ahead the band loop prefetches.
const PREFETCH_AHEAD: usize = 8;

/// Rows whose masks a vector kernel computes per call.
const MASK_ROWS: usize = 32;

/// Rasterizes set-up triangles' coverage (and depth cells); keeps its
/// scratch between frames (a clone starts with none).
#[derive(Debug)]
pub struct CoverageRasterizer {
    /// [`CoverageRasterizer::rasterize`]'s triangles per band.
    #[cfg(test)]
    bins: Vec<Vec<u32>>,
    /// The fused draw's chunks, kept between frames with their capacity.
    chunks: Vec<RwLock<SetUpChunk>>,
    /// How many of `chunks` the last fused draw set up.
    set_up: usize,
    backend: RasterBackend,
}

impl Clone for CoverageRasterizer {
    fn clone(&self) -> CoverageRasterizer {
        CoverageRasterizer::with_backend(self.backend)
    }
}

impl Default for CoverageRasterizer {
    /// A rasterizer using [`RasterBackend::active`].
    fn default() -> CoverageRasterizer {
        CoverageRasterizer::with_backend(RasterBackend::active())
    }
}

impl CoverageRasterizer {
    /// A rasterizer using `backend`; every backend covers the same samples.
    ///
    /// # Panics
    /// If the CPU does not support `backend` ([`RasterBackend::is_supported`]).
    pub fn with_backend(backend: RasterBackend) -> CoverageRasterizer {
        assert!(
            backend.is_supported(),
            "raster backend {backend:?} is not supported by this CPU"
        );
        CoverageRasterizer {
            #[cfg(test)]
            bins: Vec::new(),
            chunks: Vec::new(),
            set_up: 0,
            backend,
        }
    }

    /// Draws triangles already set up for `coverage`'s viewport, in order,
    /// as [`CoverageRasterizer::set_up_and_rasterize`] draws a queue's: the
    /// tests' way to draw chosen triangles.
    #[cfg(test)]
    pub fn rasterize(
        &mut self,
        coverage: &mut CoverageBuffer,
        tris: &[Tri],
        depth: Option<&mut DepthEstimationBuffer>,
        mut pyramid: Option<&mut Pyramid>,
    ) {
        let (draw, bands) = BandDraw::split(self.backend, coverage, depth, pyramid.as_deref_mut(), false);
        draw.bin(tris, &mut self.bins);
        let bins = &self.bins;
        costliest_first(bands, |band| bins[band].len()).for_each(|(band, rows)| {
            let tris: Vec<&Tri> = bins[band].iter().map(|&i| &tris[i as usize]).collect();
            draw.band(band, rows, &tris);
        });
        draw.finish(coverage, pyramid);
    }

    /// Sets up the triangles queued in `queue` by `setup` (as
    /// [`TriangleQueue::set_up_with`], for `coverage`'s viewport) and covers,
    /// in `coverage` (which keeps what it holds, unless `empty_first`),
    /// every sample they cover, drawing them in order.
    ///
    /// With `depth` (laid over the same viewport), also raises each cell to
    /// at least the depth the renderer computes at every sample *first*
    /// covered in it by these triangles: per triangle, run of rows
    /// ([`RUN_ROWS`]) and 64-sample word, the depth at the cell's farthest
    /// first-covered column there, in the farther of the word's first and
    /// last rows with a first cover. Then each cell a triangle covers whole
    /// (every sample of it inside the viewport) falls to that triangle's
    /// farthest depth over it ([`Tri::depth_bounds`]) where that is nearer:
    /// a far occluder drawn first (the ground beyond a wall) no longer holds
    /// the cells a nearer one covers. A cell where nothing is covered holds
    /// `f32::INFINITY`. At every covered sample a cell is at least the depth
    /// of some occluder covering it, in any order of the triangles; no raise
    /// follows a whole cover (no sample is left to cover first), so the
    /// result is that of raising all, then lowering all.
    ///
    /// With `pyramid` (over the same viewport), also builds it from the
    /// coverage: each band counts its rows of the base and reduces its rows
    /// of the levels above while they lie within it, as soon as it is drawn,
    /// on its own thread, where a band's rows are whole rows of the
    /// pyramid's blocks (else after all, as [`Pyramid::build_from_coverage`]).
    /// Counted after the last band, the city's base took 32 µs a frame on
    /// one thread while the rest of the cull ran on two.
    ///
    /// One parallel region does both: the threads set up chunks of the
    /// queue, each binning its own triangles to bands, wait for the last
    /// chunk, then draw bands costliest first. Rayon wakes a sleeping thread
    /// 15–30 µs after a region starts, and a setup region then a raster
    /// region paid that twice a frame, besides binning serially and copying
    /// the set-up triangles into one list.
    ///
    /// With `empty_first`, each band first empties its rows of `coverage` and
    /// of `depth` (nothing covered) on its own thread, so that they need not
    /// be emptied before: the 144 KB of a 1024² frame are written once, by
    /// the thread that draws them, instead of by the caller alone.
    pub fn set_up_and_rasterize(
        &mut self,
        queue: &TriangleQueue,
        setup: QueueSetup,
        coverage: &mut CoverageBuffer,
        depth: Option<&mut DepthEstimationBuffer>,
        mut pyramid: Option<&mut Pyramid>,
        empty_first: bool,
    ) -> FusedStats {
        let start = Instant::now();
        let (draw, bands) = BandDraw::split(self.backend, coverage, depth, pyramid.as_deref_mut(), empty_first);
        let chunks = queue.chunks();
        self.chunks.resize_with(chunks.max(self.chunks.len()), Default::default);
        let region = Region {
            chunks: &self.chunks[..chunks],
            next_chunk: AtomicUsize::new(0),
            chunks_done: AtomicUsize::new(0),
            next_band: AtomicUsize::new(0),
            bands: bands.into_iter().map(|(_, rows)| Mutex::new(Some(rows))).collect(),
        };
        let set_up = |k: usize, out: &mut SetUpChunk| {
            out.tris.clear();
            queue.set_up_chunk(k, &setup, &mut out.tris);
            draw.bin(&out.tris, &mut out.bins);
        };
        let helpers = if setup.parallel {
            rayon::current_num_threads()
                .saturating_sub(1)
                .min(chunks.max(draw.bands))
        } else {
            0
        };
        let mut set_up_ms = 0.0;
        if helpers == 0 {
            // No scope: entering one from outside the pool would run it on a pool thread.
            set_up_ms = region.run(&set_up, &draw);
        } else {
            rayon::scope(|s| {
                for _ in 0..helpers {
                    s.spawn(|_| {
                        region.run(&set_up, &draw);
                    });
                }
                set_up_ms = region.run(&set_up, &draw);
            });
        }
        let triangles = self.chunks[..chunks]
            .iter()
            .map(|c| c.read().map_or(0, |c| c.tris.len()))
            .sum();
        draw.finish(coverage, pyramid);
        self.set_up = chunks;
        FusedStats {
            triangles,
            set_up_ms: set_up_ms.min(start.elapsed().as_secs_f64() * 1e3),
            total_ms: start.elapsed().as_secs_f64() * 1e3,
        }
    }

    /// The triangles the last [`CoverageRasterizer::set_up_and_rasterize`]
    /// set up, in order.
    pub fn set_up_triangles(&mut self) -> impl Iterator<Item = &Tri> {
        self.chunks[..self.set_up]
            .iter_mut()
            .flat_map(|c| &c.get_mut().unwrap_or_else(PoisonError::into_inner).tris)
    }
}

/// What [`CoverageRasterizer::set_up_and_rasterize`] did.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FusedStats {
    /// Triangles set up (and drawn).
    pub triangles: usize,
    /// Milliseconds until the calling thread saw the last chunk set up.
    pub set_up_ms: f64,
    /// Milliseconds in all.
    pub total_ms: f64,
}

/// One chunk of the queue set up: its triangles and, per band, which of them reach it.
#[derive(Debug, Default)]
struct SetUpChunk {
    tris: Vec<Tri>,
    bins: Vec<Vec<u32>>,
}

/// The work of one fused draw, shared by its threads: chunks to set up,
/// then bands to draw (each taken once).
struct Region<'a> {
    chunks: &'a [RwLock<SetUpChunk>],
    next_chunk: AtomicUsize,
    chunks_done: AtomicUsize,
    next_band: AtomicUsize,
    bands: Vec<Mutex<Option<BandRows<'a>>>>,
}

impl Region<'_> {
    /// Sets up chunks until none is left, waits for the others' last ones,
    /// then draws bands until none is left; returns the milliseconds until
    /// the wait ended. Never waits on work no thread has taken: a chunk is
    /// taken by a thread inside this function, which finishes it without
    /// waiting, so a thread that arrives late (or never) blocks no one. A
    /// chunk whose setup panics counts as done, so the others do not wait
    /// for it forever and the scope hands the panic on.
    fn run(&self, set_up: &(impl Fn(usize, &mut SetUpChunk) + Sync), draw: &BandDraw) -> f64 {
        /// Counts a chunk done when dropped, also while unwinding.
        struct Done<'a>(&'a AtomicUsize);
        impl Drop for Done<'_> {
            fn drop(&mut self) {
                self.0.fetch_add(1, Ordering::Release);
            }
        }
        let start = Instant::now();
        loop {
            let k = self.next_chunk.fetch_add(1, Ordering::Relaxed);
            let Some(chunk) = self.chunks.get(k) else { break };
            let _done = Done(&self.chunks_done);
            set_up(k, &mut chunk.write().unwrap_or_else(PoisonError::into_inner));
        }
        let mut spins = 0u32;
        while self.chunks_done.load(Ordering::Acquire) < self.chunks.len() {
            if spins < 1 << 12 {
                std::hint::spin_loop();
                spins += 1;
            } else {
                std::thread::yield_now();
            }
        }
        let set_up_ms = start.elapsed().as_secs_f64() * 1e3;
        let chunks: Vec<_> = self
            .chunks
            .iter()
            .map(|c| c.read().unwrap_or_else(PoisonError::into_inner))
            .collect();
        // Every thread finds the same order, and takes the next band in it.
        let mut order: Vec<(usize, usize)> = (0..self.bands.len())
            .map(|band| (band, chunks.iter().map(|c| c.bins[band].len()).sum()))
            .collect();
        let costs: Vec<usize> = order.iter().map(|&(_, cost)| cost).collect();
        sort_costliest_first(&mut order, |band| costs[band]);
        let mut tris: Vec<&Tri> = Vec::new();
        loop {
            let j = self.next_band.fetch_add(1, Ordering::Relaxed);
            let Some(&(band, cost)) = order.get(j) else { break };
            let Some(rows) = self.bands[band].lock().unwrap_or_else(PoisonError::into_inner).take() else {
                continue;
            };
            tris.clear();
            tris.reserve(cost);
            for c in &chunks {
                tris.extend(c.bins[band].iter().map(|&i| &c.tris[i as usize]));
            }
            draw.band(band, rows, &tris);
        }
        set_up_ms
    }
}

/// One band's rows: its coverage words, its depth cells (none when not
/// gathering depth) and its rows of the pyramid's lower levels (none when
/// the pyramid is built after).
type BandRows<'a> = (&'a mut [u64], &'a mut [f32], Vec<&'a mut [u32]>);

/// What every band of one draw shares.
struct BandDraw {
    backend: RasterBackend,
    /// Coverage words per row.
    wpr: usize,
    /// The bits of the last word of a row that lie inside the viewport.
    last_word: u64,
    grid: CellGrid,
    /// Depth cells across (0 when not gathering depth).
    cols: usize,
    cell_h: u32,
    band_rows: u32,
    /// Bands of the viewport.
    bands: usize,
    /// The pyramid's lower levels are built band by band.
    pyramid_bands: Option<BandBuild>,
    /// Each band empties its rows first.
    empty_first: bool,
}

impl BandDraw {
    /// The draw's bands of rows, each with its coverage, depth cells and
    /// rows of the pyramid's lower levels: whole rows of depth cells when gathering depth, so
    /// every band writes only its own cells; at least `BAND_ROWS` rows.
    fn split<'a>(
        backend: RasterBackend,
        coverage: &'a mut CoverageBuffer,
        depth: Option<&'a mut DepthEstimationBuffer>,
        pyramid: Option<&'a mut Pyramid>,
        empty_first: bool,
    ) -> (BandDraw, Vec<(usize, BandRows<'a>)>) {
        let height = coverage.height;
        let (cols, cell_w, cell_h) = match depth.as_deref() {
            Some(d) => (d.size().0 as usize, d.cell_size().0, d.cell_size().1),
            None => (0, 1, BAND_ROWS),
        };
        let grid = CellGrid {
            col_of: CellOf::new(cell_w),
            row_of: CellOf::new(cell_h),
            width: coverage.width,
            cols: cols as u32,
        };
        let cell_rows_per_band = (BAND_ROWS / cell_h).max(1);
        let band_rows = cell_h * cell_rows_per_band;
        let bands = height.div_ceil(band_rows) as usize;
        let wpr = coverage.words_per_row;
        let last_word = match coverage.width % 64 {
            0 => u64::MAX,
            r => (1u64 << r) - 1,
        };
        let cell_rows: Vec<&mut [f32]> = match depth {
            Some(d) => d.cells_mut().chunks_mut(cols * cell_rows_per_band as usize).collect(),
            None => (0..bands).map(|_| <&mut [f32]>::default()).collect(),
        };
        debug_assert_eq!(cell_rows.len(), bands, "depth cells and bands share rows");
        let (pyramid_bands, levels) = match pyramid.and_then(|p| p.split_bands(band_rows)) {
            Some((build, levels)) => (Some(build), levels),
            None => (None, (0..bands).map(|_| Vec::new()).collect()),
        };
        debug_assert_eq!(levels.len(), bands, "the pyramid's levels and bands share rows");
        let rows = coverage
            .bits
            .chunks_mut(wpr * band_rows as usize)
            .zip(cell_rows)
            .zip(levels)
            .enumerate()
            .map(|(band, ((words, cells), levels))| (band, (words, cells, levels)))
            .collect();
        let draw = BandDraw {
            backend,
            wpr,
            last_word,
            grid,
            cols,
            cell_h,
            band_rows,
            bands,
            pyramid_bands,
            empty_first,
        };
        (draw, rows)
    }

    /// Lists in `bins`, per band, the indices of the triangles of `tris`
    /// reaching it, in order.
    fn bin(&self, tris: &[Tri], bins: &mut Vec<Vec<u32>>) {
        bins.resize_with(self.bands, Vec::new);
        bins.truncate(self.bands);
        for bin in bins.iter_mut() {
            bin.clear();
        }
        for (i, t) in tris.iter().enumerate() {
            let first = u32::from(t.y0) / self.band_rows;
            let last = (u32::from(t.y1) - 1) / self.band_rows;
            for bin in &mut bins[first as usize..=last as usize] {
                bin.push(i as u32);
            }
        }
    }

    /// After the bands: the pyramid's levels above the bands' (or all of
    /// it, where the bands' rows were not whole rows of its pixels).
    fn finish(&self, coverage: &CoverageBuffer, pyramid: Option<&mut Pyramid>) {
        match (pyramid, &self.pyramid_bands) {
            (Some(p), Some(build)) => p.finish_bands(build),
            (Some(p), None) => p.build_from_coverage(&coverage.bits, self.wpr),
            (None, _) => {}
        }
    }

    /// Draws `tris` (those reaching band `band`, in order) into its rows.
    fn band(&self, band: usize, (words, cells, mut levels): BandRows<'_>, tris: &[&Tri]) {
        let BandDraw {
            backend,
            wpr,
            last_word,
            grid,
            cols,
            cell_h,
            band_rows,
            pyramid_bands,
            empty_first,
            ..
        } = *self;
        let cell_of = grid.col_of;
        let y0 = band as u32 * band_rows;
        let y1 = y0 + (words.len() / wpr) as u32;
        let gather = !cells.is_empty();
        // Cells with nothing covered hold INFINITY; while drawing they hold
        // NEG_INFINITY so that `max` raises them (exact: a covered cell is finite).
        if empty_first {
            words.fill(0);
            cells.fill(f32::NEG_INFINITY);
        }
        for c in cells.iter_mut() {
            if *c == f32::INFINITY {
                *c = f32::NEG_INFINITY;
            }
        }
        // This triangle's first-covered samples in the current run, OR-ed over its rows.
        let mut fresh = if gather { vec![0u64; wpr] } else { Vec::new() };
        // Per word, the first and last rows of the run where it took new samples.
        let mut fresh_rows = if gather {
            vec![(u32::MAX, 0u32); wpr]
        } else {
            Vec::new()
        };
        // Per word column (64 samples): whether every row of the band covers
        // it wholly, and (made when asked, after the column was drawn in)
        // the samples every row covers. A triangle whose box lies in full
        // columns, or whose own columns in the band are covered by every
        // row, covers no sample first, so it changes neither coverage nor
        // depth cells and is skipped. (On layered occluders this is most of them.)
        let rows = words.len() / wpr;
        let column_full = |words: &[u64], c: usize| {
            let inside = if c + 1 == wpr { last_word } else { u64::MAX };
            (0..rows).all(|r| words[r * wpr + c] & inside == inside)
        };
        // The samples of word column `c` covered in every row of `rows` (of
        // the band), those right of the viewport counted as covered.
        let covered_in = |words: &[u64], c: usize, rows: Range<usize>| {
            let outside = if c + 1 == wpr { !last_word } else { 0 };
            rows.fold(u64::MAX, |m, r| m & words[r * wpr + c]) | outside
        };
        let mut full: Vec<bool> = (0..wpr).map(|c| column_full(words, c)).collect();
        let mut all_rows: Vec<Option<u64>> = vec![None; wpr];
        // A triangle's rows, a chunk at a time: spans or masks (one scratch for the band).
        let (mut spans, mut masks) = ([(0u32, 0u32); MASK_ROWS], [0u64; MASK_ROWS]);
        for (k, &t) in tris.iter().enumerate() {
            // Bins skip through the triangles: fetch a few ahead.
            if let Some(&next) = tris.get(k + PREFETCH_AHEAD) {
                prefetch(next);
            }
            let (ta, tb) = (u32::from(t.y0).max(y0), u32::from(t.y1).min(y1));
            let (wa, wb) = (usize::from(t.x0) / 64, (usize::from(t.x1) - 1) / 64);
            if full[wa..=wb].iter().all(|&f| f) {
                if gather {
                    grid.lower_whole(cells, t, (y0, y1), (ta, tb));
                }
                continue;
            }
            // A triangle wholly in the band spans its box's columns: only a
            // cut one needs `columns_in_rows`, whose three divisions were 7.7 %
            // of the dynamic walk's cull on one thread (its many small
            // triangles; raster at two threads 0.83-0.85 -> 0.78-0.80 ms).
            let (xa, xb) = if ta == u32::from(t.y0) && tb == u32::from(t.y1) {
                (u32::from(t.x0), u32::from(t.x1))
            } else {
                t.columns_in_rows(ta, tb)
            };
            if xa >= xb {
                continue;
            }
            let (wa, wb) = (xa as usize / 64, (xb as usize - 1) / 64);
            // The triangle's columns within word column `c`.
            let within = |c: usize| {
                let lo = (xa as usize).max(c * 64) - c * 64;
                let hi = (xb as usize).min(c * 64 + 64) - c * 64;
                (u64::MAX >> (64 - (hi - lo))) << lo
            };
            // Covered in every row of the band (kept per column until drawn
            // in), else, for a triangle with fewer rows, in every one of its
            // rows: 15 % of the city's triangle-band pairs left to draw
            // (186 of about 1,230 a frame) pass the second test only.
            let own_rows = (ta - y0) as usize..(tb - y0) as usize;
            let covered = (wa..=wb)
                .all(|c| *all_rows[c].get_or_insert_with(|| covered_in(words, c, 0..rows)) & within(c) == within(c))
                || (own_rows.len() < rows
                    && (wa..=wb).all(|c| {
                        // Row by row, to stop at the first that leaves a sample.
                        let m = within(c);
                        own_rows.clone().all(|r| words[r * wpr + c] & m == m)
                    }));
            if covered {
                if gather {
                    grid.lower_whole(cells, t, (y0, y1), (ta, tb));
                }
                continue;
            }
            let x0 = u32::from(t.x0);
            let wide = backend == RasterBackend::Scalar || u32::from(t.x1 - t.x0) > MASK_MAX;
            // Rows come from exact spans stepped row to row (`Tri::row_span`'s,
            // without its divisions) or from a vector kernel's bit masks.
            let (ta, tb, mut rows) = if wide {
                let edges = ScanEdges::new(t);
                let (ta, tb) = (ta.max(edges.rows.0), tb.min(edges.rows.1));
                if ta >= tb {
                    continue; // no covered row in this band: nothing to set up or mark full
                }
                (ta, tb, Rows::Spans(Stepper::new(t, &edges, ta)))
            } else {
                (ta, tb, Rows::Masks)
            };
            let mut py0 = ta;
            while py0 < tb {
                // A run: up to `RUN_ROWS` rows within one row of depth cells (the
                // whole band when not gathering).
                let run_end = if gather {
                    tb.min(y0 + ((py0 - y0) / cell_h + 1) * cell_h)
                        .min((py0 / RUN_ROWS + 1) * RUN_ROWS)
                } else {
                    tb
                };
                // Some row of the run covered a sample first (then its first row).
                let mut fa = u32::MAX;
                while py0 < run_end {
                    let n = ((run_end - py0) as usize).min(MASK_ROWS);
                    match &mut rows {
                        Rows::Spans(stepper) => {
                            stepper.rows(&mut spans[..n]);
                            for (py, &(lo, hi)) in (py0..).zip(&spans[..n]) {
                                let row = &mut words[(py - y0) as usize * wpr..][..wpr];
                                if lo >= hi {
                                    continue;
                                } else if !gather {
                                    set_span(row, lo, hi);
                                } else if set_span_fresh(row, &mut fresh, &mut fresh_rows, py, lo, hi) {
                                    fa = fa.min(py);
                                }
                            }
                        }
                        Rows::Masks => {
                            row_masks(backend, t, py0, &mut masks[..n]);
                            for (py, &m) in (py0..).zip(&masks[..n]) {
                                let row = &mut words[(py - y0) as usize * wpr..][..wpr];
                                if m == 0 {
                                    continue;
                                } else if !gather {
                                    or_mask(row, x0, m);
                                } else if or_mask_fresh(row, &mut fresh, &mut fresh_rows, py, x0, m) {
                                    fa = fa.min(py);
                                }
                            }
                        }
                    }
                    py0 += n as u32;
                }
                if fa != u32::MAX {
                    let cells = &mut cells[((fa - y0) / cell_h) as usize * cols..][..cols];
                    let words_of_tri = usize::from(t.x0) / 64..=(usize::from(t.x1) - 1) / 64;
                    raise_fresh_cells(
                        cells,
                        cell_of,
                        &mut fresh[words_of_tri.clone()],
                        &mut fresh_rows[words_of_tri],
                        x0 - x0 % 64,
                        t,
                    );
                }
            }
            if gather {
                grid.lower_whole(cells, t, (y0, y1), (ta, tb));
            }
            for c in wa..=wb {
                full[c] = full[c] || column_full(words, c);
                all_rows[c] = None;
            }
        }
        for c in cells.iter_mut() {
            if *c == f32::NEG_INFINITY {
                *c = f32::INFINITY; // nothing covered: nothing is behind this cell
            }
        }
        if let Some(p) = pyramid_bands {
            p.build(band, &mut levels, words, wpr, y1 - y0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::Camera;
    use crate::raster::setup::{FaceCull, Viewport};
    use glam::{Mat4, Quat, Vec3};
    use hom_testkit::Rng;
    use proptest::prelude::*;
    use std::collections::BTreeMap;

    /// One object of a test scene: its mesh and its model transform (hom's
    /// `Scene` lives above this crate).
    struct Object {
        positions: Vec<Vec3>,
        triangles: Vec<[u32; 3]>,
        transform: Mat4,
    }

    /// Random boxes of every size (slivers to huge), plus a soup of random
    /// triangles (tiny, sliver and huge) around the origin.
    fn random_scene(seed: u64, n: usize) -> Vec<Object> {
        let mut rng = Rng::new(seed);
        let mut rnd = move || rng.unit();
        let cube = hom_testkit::cube();
        let mut scene = Vec::new();
        for _ in 0..n {
            let pos = Vec3::new(rnd() * 20.0 - 10.0, rnd() * 6.0 - 3.0, rnd() * 20.0 - 10.0);
            let mut side = || [0.002, 0.05, 0.5, 1.0, 2.0, 6.0, 300.0][(rnd() * 7.0) as usize % 7] * (0.5 + rnd());
            let scale = Vec3::new(side(), side(), side());
            let rot = Quat::from_euler(glam::EulerRot::YXZ, rnd() * 3.0, rnd() * 3.0, rnd() * 3.0);
            scene.push(Object {
                positions: cube.positions().to_vec(),
                triangles: cube.triangles().to_vec(),
                transform: Mat4::from_scale_rotation_translation(scale, rot, pos),
            });
        }
        for _ in 0..n / 2 + 1 {
            let (mut p, mut tris) = (Vec::new(), Vec::new());
            let c = Vec3::new(rnd() * 30.0 - 15.0, rnd() * 10.0 - 5.0, rnd() * 30.0 - 15.0);
            for t in 0..4 {
                let size = [0.01, 0.1, 0.3, 1.0, 3.0, 10.0, 40.0, 2000.0][(rnd() * 8.0) as usize % 8];
                let sliver = rnd() < 0.3;
                for k in 0..3 {
                    let d = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * size;
                    // A sliver's third vertex lies almost on the line of the first two.
                    p.push(if sliver && k == 2 {
                        (p[p.len() - 1] + p[p.len() - 2]) * 0.5 + d * 1e-3
                    } else {
                        c + d
                    });
                }
                tris.push([3 * t, 3 * t + 1, 3 * t + 2]);
            }
            scene.push(Object {
                positions: p,
                triangles: tris,
                transform: Mat4::IDENTITY,
            });
        }
        scene
    }

    /// Every triangle of every object of `scene`, set up for `camera` in id order.
    fn scene_tris(scene: &[Object], camera: &Camera) -> Vec<Tri> {
        let mut q = TriangleQueue::default();
        for o in scene {
            let mvp = camera.view_proj() * o.transform;
            q.push_model(&o.positions, &o.triangles, &mvp, FaceCull::None).unwrap();
        }
        let mut tris = Vec::new();
        q.set_up(&Viewport::new(camera.width, camera.height), false, &mut tris);
        tris
    }

    /// Coverage and depth cells from `backend`.
    fn run(
        backend: RasterBackend,
        scene: &[Object],
        camera: &Camera,
        cells: Option<(u32, u32)>,
    ) -> (CoverageBuffer, Vec<u32>) {
        let mut cov = CoverageBuffer::default();
        cov.reset(camera.width, camera.height);
        let mut deb = cells.map(|(c, r)| DepthEstimationBuffer::new(camera.width, camera.height, c, r));
        CoverageRasterizer::with_backend(backend).rasterize(&mut cov, &scene_tris(scene, camera), deb.as_mut(), None);
        let cells = deb.map_or(Vec::new(), |d| d.cells().iter().map(|c| c.to_bits()).collect());
        (cov, cells)
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]
        /// Every backend the CPU supports gives bit-identical coverage and depth
        /// cells to the scalar path.
        #[test]
        fn backends_match_scalar(
            seed in any::<u64>(), n in 1usize..30,
            eye in (-12.0f32..12.0, -3.0f32..4.0, -12.0f32..12.0),
            look in (-1.0f32..1.0, -0.5f32..0.5, -1.0f32..1.0),
            viewport in 0usize..5, size in (1u32..300, 1u32..300), cells in proptest::option::of((1u32..70, 1u32..70)),
        ) {
            let scene = random_scene(seed, n);
            let (w, h) = [(1000, 750), (37, 29), (97, 61), (64, 1), size][viewport];
            let eye = Vec3::new(eye.0, eye.1, eye.2);
            let camera = Camera::new(eye, eye + Vec3::new(look.0, look.1, look.2 + 1e-3), Vec3::Y, 1.2, 0.1, 1000.0, w, h);
            prop_assume!(camera.validate().is_ok());
            let (want, want_cells) = run(RasterBackend::Scalar, &scene, &camera, cells);
            for backend in RasterBackend::supported() {
                let (got, got_cells) = run(backend, &scene, &camera, cells);
                prop_assert_eq!((got.width(), got.height()), (w, h));
                prop_assert!(got.bits() == want.bits(), "{:?}: coverage differs from scalar", backend);
                prop_assert!(got_cells == want_cells, "{:?}: depth cells differ from scalar", backend);
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]
        /// The pyramid each band counts as it is drawn is the one built from
        /// the whole coverage afterwards, for blocks that divide the bands'
        /// rows and blocks that do not, and over coverage drawn before.
        #[test]
        fn pyramid_counted_in_bands_is_built_after(
            seed in any::<u64>(), n in 1usize..30, size in (1u32..400, 1u32..400),
            block in 1u32..20, cells in proptest::option::of((1u32..70, 1u32..70)), threads in 1usize..4,
        ) {
            let scene = random_scene(seed, n);
            let (w, h) = size;
            let eye = Vec3::new(0.0, 1.5, -14.0);
            let camera = Camera::new(eye, Vec3::ZERO, Vec3::Y, 1.2, 0.1, 1000.0, w, h);
            prop_assume!(camera.validate().is_ok());
            let tris = scene_tris(&scene, &camera);
            let (half, rest) = tris.split_at(tris.len() / 2);
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let mut cov = CoverageBuffer::default();
            cov.reset(w, h);
            let mut deb = cells.map(|(c, r)| DepthEstimationBuffer::new(w, h, c, r));
            let mut pyramid = Pyramid::new(w, h, block, 1);
            let mut raster = CoverageRasterizer::default();
            pool.install(|| {
                raster.rasterize(&mut cov, half, deb.as_mut(), Some(&mut pyramid));
                raster.rasterize(&mut cov, rest, deb.as_mut(), Some(&mut pyramid));
            });
            let mut want = Pyramid::new(w, h, block, 1);
            want.build_from_coverage(cov.bits(), cov.words_per_row());
            for (k, (got, want)) in pyramid.levels().iter().zip(want.levels()).enumerate() {
                prop_assert!(got.counts == want.counts, "level {}", k);
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]
        /// Setting a queue up and drawing it in one parallel region draws
        /// what setting it up, then drawing the triangles, draws: coverage,
        /// depth cells and pyramid, bit for bit, on 1–3 threads, over several
        /// setup chunks (convex stand-ins among them), into buffers the first
        /// draw empties band by band, and over that first draw.
        #[test]
        fn set_up_and_rasterize_is_set_up_then_rasterize(
            seed in any::<u64>(), n in 1usize..90, size in (1u32..300, 1u32..300),
            block in 1u32..20, cells in proptest::option::of((1u32..70, 1u32..70)),
            threads in 1usize..4, inner in any::<bool>(),
        ) {
            let scene = random_scene(seed, n);
            let (w, h) = size;
            let eye = Vec3::new(0.0, 1.5, -14.0);
            let camera = Camera::new(eye, Vec3::ZERO, Vec3::Y, 1.2, 0.1, 1000.0, w, h);
            prop_assume!(camera.validate().is_ok());
            // Two queues (two draws): every third object a convex stand-in.
            let mut queues = [TriangleQueue::default(), TriangleQueue::default()];
            for (k, o) in scene.iter().enumerate() {
                let mvp = camera.view_proj() * o.transform;
                let q = &mut queues[usize::from(k >= scene.len() / 3)];
                if k % 3 == 0 {
                    q.push_convex(&o.positions, &o.triangles, &mvp).unwrap();
                } else {
                    q.push_model(&o.positions, &o.triangles, &mvp, FaceCull::None).unwrap();
                }
            }
            let setup = QueueSetup { backend: RasterBackend::active(), viewport: Viewport::new(w, h), inner, parallel: true };
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let draw = |fused: bool| {
                let mut cov = CoverageBuffer::default();
                cov.reset(w, h);
                let mut deb = cells.map(|(c, r)| DepthEstimationBuffer::new(w, h, c, r));
                let mut pyramid = Pyramid::new(w, h, block, 1);
                let mut raster = CoverageRasterizer::default();
                let mut drawn = 0;
                if fused {
                    // Left over from an earlier frame: the first draw empties it first.
                    cov.bits.fill(u64::MAX);
                    if let Some(d) = deb.as_mut() {
                        d.cells_mut().fill(0.5);
                    }
                }
                pool.install(|| {
                    for (k, q) in queues.iter().enumerate() {
                        if fused {
                            let s = raster.set_up_and_rasterize(q, setup, &mut cov, deb.as_mut(), Some(&mut pyramid), k == 0);
                            drawn += s.triangles;
                            assert!(raster.set_up_triangles().count() == s.triangles);
                        } else {
                            let mut tris = Vec::new();
                            q.set_up_with(&setup, &mut tris);
                            raster.rasterize(&mut cov, &tris, deb.as_mut(), Some(&mut pyramid));
                            drawn += tris.len();
                        }
                    }
                });
                let cells = deb.map_or(Vec::new(), |d| d.cells().iter().map(|c| c.to_bits()).collect::<Vec<_>>());
                (cov, cells, pyramid, drawn)
            };
            let (want, want_cells, want_pyramid, want_drawn) = draw(false);
            let (got, got_cells, got_pyramid, got_drawn) = draw(true);
            prop_assert_eq!(got_drawn, want_drawn);
            prop_assert!(got.bits() == want.bits(), "coverage differs");
            prop_assert!(got_cells == want_cells, "depth cells differ");
            for (k, (g, w)) in got_pyramid.levels().iter().zip(want_pyramid.levels()).enumerate() {
                prop_assert!(g.counts == w.counts, "pyramid level {}", k);
            }
        }
    }

    /// A chunk whose setup panics does not leave the other thread waiting
    /// for it: the region ends and hands the panic on (on 1–3 threads).
    #[test]
    fn a_panicking_setup_ends_the_region() {
        for threads in 1..=3 {
            let (tx, rx) = std::sync::mpsc::channel();
            std::thread::spawn(move || {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                let mut cov = CoverageBuffer::default();
                cov.reset(64, 64);
                let (draw, bands) = BandDraw::split(RasterBackend::Scalar, &mut cov, None, None, false);
                let chunks: Vec<RwLock<SetUpChunk>> = (0..6).map(|_| RwLock::default()).collect();
                let region = Region {
                    chunks: &chunks,
                    next_chunk: AtomicUsize::new(0),
                    chunks_done: AtomicUsize::new(0),
                    next_band: AtomicUsize::new(0),
                    bands: bands.into_iter().map(|(_, rows)| Mutex::new(Some(rows))).collect(),
                };
                let set_up = |k: usize, out: &mut SetUpChunk| {
                    assert!(k != 2, "chunk 2 fails");
                    draw.bin(&out.tris, &mut out.bins);
                };
                let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    pool.install(|| {
                        rayon::scope(|s| {
                            s.spawn(|_| {
                                region.run(&set_up, &draw);
                            });
                            region.run(&set_up, &draw);
                        })
                    })
                }));
                tx.send(result.is_err()).unwrap();
            });
            let panicked = rx.recv_timeout(std::time::Duration::from_secs(30));
            assert_eq!(
                panicked,
                Ok(true),
                "{threads} threads: the region must end with the panic"
            );
        }
    }

    /// Bands are handed to threads costliest first, in any order: the
    /// coverage and depth cells are those of one thread, on 2 and 3.
    #[test]
    fn thread_count_does_not_change_the_result() {
        let eye = Vec3::new(0.0, 1.5, -14.0);
        let camera = Camera::new(eye, Vec3::ZERO, Vec3::Y, 1.2, 0.1, 1000.0, 640, 480);
        let on = |threads: usize, seed: u64| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| {
                run(
                    RasterBackend::active(),
                    &random_scene(seed, 40),
                    &camera,
                    Some((40, 30)),
                )
            })
        };
        for seed in 0..4 {
            let (one, one_cells) = on(1, seed);
            assert!(one.covered() > 0 && one_cells.iter().any(|&c| f32::from_bits(c).is_finite()));
            for threads in [2, 3] {
                let (got, got_cells) = on(threads, seed);
                assert!(got.bits() == one.bits(), "seed {seed}, {threads} threads: coverage");
                assert!(got_cells == one_cells, "seed {seed}, {threads} threads: depth cells");
            }
        }
    }

    /// Layered screen-sized quads and small triangles, in random order, so
    /// that word columns fill up and later triangles are skipped: coverage
    /// is the union of the renderer's coverage, and each depth cell the
    /// farthest, over the triangles, runs of rows and 64-sample words, of
    /// the depth at the cell's farthest column covered first there, in the
    /// word's first and last rows with a first cover (brute force, sample
    /// by sample, in submission order).
    #[test]
    fn skipping_full_columns_changes_nothing() {
        use glam::Vec4;
        let mut rng = Rng::new(17);
        for case in 0..24 {
            let (w, h) = (1 + rng.below(300) as u32, 1 + rng.below(120) as u32);
            let (mut v, mut idx) = (Vec::new(), Vec::new());
            for _ in 0..(5 + rng.below(40)) {
                let b = v.len() as u32;
                let z = rng.range(0.05, 0.95);
                if rng.below(3) == 0 {
                    let (cx, cy, r) = (rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(0.01, 0.4));
                    v.extend([(cx - r, cy - r), (cx + r, cy), (cx, cy + r)].map(|(x, y)| Vec4::new(x, y, z, 1.0)));
                    idx.push([b, b + 1, b + 2]);
                } else {
                    let (x0, y0) = (rng.range(-1.3, 0.2), rng.range(-1.3, 0.2));
                    let (x1, y1) = (rng.range(0.5, 1.3), rng.range(0.5, 1.3));
                    let (tilt_x, tilt_y) = (rng.range(-0.3, 0.3), rng.range(-0.3, 0.3));
                    v.extend(
                        [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
                            .map(|(x, y)| Vec4::new(x, y, (z + tilt_x * x + tilt_y * y).clamp(0.0, 1.0), 1.0)),
                    );
                    idx.extend([[b, b + 1, b + 2], [b, b + 2, b + 3]]);
                }
            }
            let mut q = TriangleQueue::default();
            q.push_clip(&v, &idx, |v| v, FaceCull::None).unwrap();
            let mut tris = Vec::new();
            q.set_up(&Viewport::new(w, h), false, &mut tris);
            let (cols, rows) = (1 + rng.below(40) as u32, 1 + rng.below(20) as u32);
            for backend in RasterBackend::supported() {
                let mut cov = CoverageBuffer::default();
                cov.reset(w, h);
                let mut deb = DepthEstimationBuffer::new(w, h, cols, rows);
                CoverageRasterizer::with_backend(backend).rasterize(&mut cov, &tris, Some(&mut deb), None);
                let (cw, ch) = deb.cell_size();
                // Each sample's first cover, grouped by triangle, row of cells and run.
                let mut firsts: BTreeMap<(usize, u32, u32), Vec<(u32, u32)>> = BTreeMap::new();
                for y in 0..h {
                    for x in 0..w {
                        let first = tris.iter().position(|t| {
                            (u32::from(t.x0)..u32::from(t.x1)).contains(&x)
                                && (u32::from(t.y0)..u32::from(t.y1)).contains(&y)
                                && t.covers(x, y)
                        });
                        assert_eq!(
                            cov.is_covered(x, y),
                            first.is_some(),
                            "case {case} {backend:?}: sample {x},{y}"
                        );
                        if let Some(i) = first {
                            firsts.entry((i, y / ch, y / RUN_ROWS)).or_default().push((x, y));
                        }
                    }
                }
                // Per triangle in order: its first covers raise the cells (per row
                // of cells and run, `raise_twin`); then each cell the triangle
                // covers whole (every sample of it inside the viewport) falls to
                // the triangle's farthest depth over it.
                let mut want = vec![f32::NEG_INFINITY; deb.cells().len()];
                for (i, t) in tris.iter().enumerate() {
                    for ((_, cell_row, _), samples) in firsts.range((i, 0, 0)..(i + 1, 0, 0)) {
                        raise_twin(t, (w, deb.size().0, cw), *cell_row, samples, &mut want);
                    }
                    for (cy, cx) in (0..deb.size().1).flat_map(|cy| (0..deb.size().0).map(move |cx| (cy, cx))) {
                        let (xs, ys) = (cx * cw..((cx + 1) * cw).min(w), cy * ch..((cy + 1) * ch).min(h));
                        let whole = ys.clone().all(|y| {
                            xs.clone().all(|x| {
                                (u32::from(t.x0)..u32::from(t.x1)).contains(&x)
                                    && (u32::from(t.y0)..u32::from(t.y1)).contains(&y)
                                    && t.covers(x, y)
                            })
                        });
                        if whole {
                            let far = t.depth_bounds(xs.start, xs.end - 1, ys.start, ys.end - 1).1;
                            let c = &mut want[(cy * deb.size().0 + cx) as usize];
                            *c = c.min(far);
                        }
                    }
                }
                for c in &mut want {
                    if *c == f32::NEG_INFINITY {
                        *c = f32::INFINITY;
                    }
                }
                assert_eq!(deb.cells(), &want[..], "case {case} {backend:?}: depth cells");
            }
        }
    }

    /// The twin's raise: triangle `t`'s first covers `samples` in one row of
    /// cells and run, into `want`.
    fn raise_twin(t: &Tri, grid: (u32, u32, u32), cell_row: u32, samples: &[(u32, u32)], want: &mut [f32]) {
        // Per word: its first and last rows with a first cover; each cell's part
        // of the word rises to the depth at its farthest first-covered column
        // there, in the farther of the two rows.
        let (w, cols, cw) = grid;
        for word in 0..w.div_ceil(64) {
            let in_word = || samples.iter().filter(move |s| s.0 / 64 == word);
            let Some(fa) = in_word().map(|s| s.1).min() else {
                continue;
            };
            let fb = in_word().map(|s| s.1).max().unwrap();
            for cell in 0..cols {
                let xs = in_word().map(|s| s.0).filter(|x| x / cw == cell);
                let far = if t.dzdx >= 0.0 { xs.max() } else { xs.min() };
                if let Some(x) = far {
                    let c = &mut want[(cell_row * cols + cell) as usize];
                    *c = c.max(t.depth_at(x, fa)).max(t.depth_at(x, fb));
                }
            }
        }
    }

    /// Names the backends the proptest above compares (see `--nocapture`), and
    /// checks the detected one is among them.
    #[test]
    fn supported_backends_are_exercised() {
        let supported = RasterBackend::supported();
        eprintln!(
            "raster backends compared with scalar: {:?}; detected {:?}; active {:?}",
            supported,
            RasterBackend::detect(),
            RasterBackend::active()
        );
        assert!(supported.contains(&RasterBackend::detect()));
        let untested: Vec<&str> = RasterBackend::ALL
            .into_iter()
            .filter(|b| !supported.contains(b))
            .map(|b| b.name())
            .collect();
        if !untested.is_empty() {
            eprintln!("raster backends not tested (CPU lacks them): {}", untested.join(", "));
        }
        #[cfg(target_arch = "x86_64")]
        for (b, feature) in [
            (RasterBackend::Sse41, is_x86_feature_detected!("sse4.1")),
            (RasterBackend::Avx2, is_x86_feature_detected!("avx2")),
            (RasterBackend::Avx512, is_x86_feature_detected!("avx512f")),
        ] {
            assert_eq!(supported.contains(&b), feature, "{b:?}");
        }
        let scene = random_scene(7, 20);
        let camera = Camera::new(
            Vec3::new(0.5, 1.0, 15.0),
            Vec3::ZERO,
            Vec3::Y,
            1.1,
            0.1,
            100.0,
            1000,
            750,
        );
        let (want, want_cells) = run(RasterBackend::Scalar, &scene, &camera, Some((64, 64)));
        assert!(want.covered() > 0);
        for backend in supported {
            let (got, got_cells) = run(backend, &scene, &camera, Some((64, 64)));
            assert!(got.bits() == want.bits() && got_cells == want_cells, "{backend:?}");
        }
    }

    /// `or_mask_fresh` sets what `or_mask` sets, and `set_span_fresh` what
    /// `set_span` sets; both report exactly the bits that were clear before,
    /// and widen the rows of exactly the words that took some.
    #[test]
    fn fresh_bits_are_the_newly_set_ones() {
        let before = [0x0f0f_0000_0000_f0f0u64; 3];
        let rows0 = [(5, 6), (u32::MAX, 0), (9, 9)];
        for x in 0..130u32 {
            for n in 1..=64u32.min(192 - x) {
                for mask in [u64::MAX >> (64 - n), 1 | 1 << (n - 1), 0b1011 & (u64::MAX >> (64 - n))] {
                    let (mut a, mut fa, mut ra) = (before, [0u64; 3], rows0);
                    let any = or_mask_fresh(&mut a, &mut fa, &mut ra, 7, x, mask);
                    let mut c = before;
                    or_mask(&mut c, x, mask);
                    let (mut b, mut fb, mut rb) = (before, [0u64; 3], rows0);
                    for k in (0..n).filter(|k| mask >> k & 1 == 1) {
                        set_span_fresh(&mut b, &mut fb, &mut rb, 7, x + k, x + k + 1);
                    }
                    let new: [u64; 3] = std::array::from_fn(|w| c[w] & !before[w]);
                    let rows: [(u32, u32); 3] =
                        std::array::from_fn(|w| if new[w] != 0 { (rows0[w].0.min(7), 7) } else { rows0[w] });
                    assert_eq!((a, b), (c, c), "x {x} n {n} mask {mask:x}");
                    assert_eq!((fa, fb), (new, new), "x {x} n {n} mask {mask:x}");
                    assert_eq!((ra, rb), (rows, rows), "x {x} n {n} mask {mask:x}");
                    assert_eq!(any, new != [0; 3]);
                }
            }
        }
    }

    #[test]
    fn set_span_sets_exactly_the_range() {
        for lo in 0..130u32 {
            for hi in lo..=130u32.min(lo + 70) {
                let mut row = [0u64; 3];
                set_span(&mut row, lo, hi);
                for x in 0..192u32 {
                    let set = row[(x / 64) as usize] >> (x % 64) & 1 == 1;
                    assert_eq!(set, x >= lo && x < hi, "lo {lo} hi {hi} x {x}");
                }
            }
        }
    }
}
