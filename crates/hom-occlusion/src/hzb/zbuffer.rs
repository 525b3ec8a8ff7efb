//! The z-buffer rasterizer of hierarchical visibility (Greene, Kass and
//! Miller 1993; the Möller–Haines excerpt): one set-up triangle into a depth
//! and item buffer with the reference renderer's owner rule (nearest wins;
//! at equal depth the smaller object id, the renderer's draw order), its
//! bounding rectangle and then each of its 8×8-sample tiles first tested
//! against the live [`ZPyramid`] (one level of Greene's hierarchical
//! tiling). Coverage and depth are [`crate::raster::setup`]'s, so what is written is
//! exactly what the renderer writes.

use crate::geom::ScreenRect;
use crate::hzb::{ZPyramid, ZTestStats};
use crate::raster::setup::Tri;

/// Item-buffer value of a sample no object owns: the one definition, which
/// the reference renderer re-exports as `hom_render::NO_OBJECT`.
pub const NO_OBJECT: u32 = u32::MAX;

/// A half-open pixel rectangle of changed samples.
#[derive(Clone, Copy, Debug)]
pub struct Dirty {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl Dirty {
    /// No sample changed.
    pub const NONE: Dirty = Dirty {
        x0: u32::MAX,
        y0: u32::MAX,
        x1: 0,
        y1: 0,
    };

    /// Grows the rectangle to hold `x0..x1` × `y0..y1`.
    pub fn add(&mut self, x0: u32, y0: u32, x1: u32, y1: u32) {
        self.x0 = self.x0.min(x0);
        self.y0 = self.y0.min(y0);
        self.x1 = self.x1.max(x1);
        self.y1 = self.y1.max(y1);
    }
}

/// Pyramid level whose texels are the tiles of HV's triangle tiling (8×8 samples).
pub(crate) const TILE_LEVEL: usize = 3;

/// The smallest depth the renderer's formula ([`Tri::depth_at`])
/// gives on the samples `x0..x1` × `y0..y1` (non-empty, within `t`'s bounding
/// rectangle): the formula is monotone along rows and along columns (f32
/// rounding is monotone), so the minimum is at a corner. A lower bound of the
/// depth of every sample `t` covers there.
pub(crate) fn tri_min_depth(t: &Tri, x0: u32, y0: u32, x1: u32, y1: u32) -> f32 {
    let tx0 = u32::from(t.x0);
    let mut m = f32::INFINITY;
    for py in [y0, y1 - 1] {
        let zr = t.depth_row(py);
        for x in [x0, x1 - 1] {
            m = m.min(t.depth_in_row(zr, (x - tx0) as i32));
        }
    }
    m
}

/// What [`ZTarget::draw`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ZDrawStats {
    /// Triangles whose rectangle the pyramid proved hidden.
    pub triangles_occluded: u64,
    /// Triangles drawn sample by sample.
    pub triangles_rasterized: u64,
    /// Samples depth-tested.
    pub sample_tests: u64,
    /// Samples written (nearer, or a tie that changed the owner).
    pub samples_written: u64,
    /// Tiles tested against the pyramid.
    pub tile_tests: u64,
    /// Tiles the pyramid proved hidden.
    pub tiles_skipped: u64,
}

/// The buffers a triangle is drawn into, and what drawing did.
pub struct ZTarget<'a> {
    /// Level 0 is the depth buffer (one sample per pixel centre).
    pub pyramid: &'a mut ZPyramid,
    /// The owner of each sample, [`NO_OBJECT`] where none.
    pub items: &'a mut [u32],
    /// Scratch: the covered span of each row of a tile band.
    pub spans: &'a mut Vec<Option<(u32, u32)>>,
    /// Image width in samples.
    pub width: u32,
    /// Test the triangle's rectangle and tiles against the pyramid first.
    pub triangle_tests: bool,
    /// What drawing did.
    pub stats: ZDrawStats,
    /// The pyramid tests' counts.
    pub zstats: ZTestStats,
    /// Samples made nearer since the pyramid was last updated.
    pub dirty: Dirty,
}

impl ZTarget<'_> {
    /// Draws `t` (set up for this buffer's viewport; its `item` is the
    /// object id); true when it passed the depth test at some sample
    /// (wrote, or tied an owner).
    pub fn draw(&mut self, t: &Tri) -> bool {
        let (bx0, by0, bx1, by1) = (u32::from(t.x0), u32::from(t.y0), u32::from(t.x1), u32::from(t.y1));
        // A rectangle within one tile is left to the tile test below: testing it
        // twice costs more texel reads than it can save.
        if self.triangle_tests && (bx1 - bx0) * (by1 - by0) > 1 << (2 * TILE_LEVEL) {
            let z = tri_min_depth(t, bx0, by0, bx1, by1);
            let r = ScreenRect {
                x0: bx0,
                y0: by0,
                x1: bx1,
                y1: by1,
                z_near: z,
                z_far: z,
            };
            if z.is_finite() && self.pyramid.is_behind(&r, &mut self.zstats) {
                self.stats.triangles_occluded += 1;
                return false;
            }
        }
        self.stats.triangles_rasterized += 1;
        let w = self.width as usize;
        // Tiles of 8×8 samples, each tested against its pyramid texel (one
        // level of Greene's hierarchical tiling); one tile for all without tests.
        let k = if self.triangle_tests { TILE_LEVEL } else { 0 };
        let (base, tiles) = self.pyramid.base_and_level(k);
        let shift = if tiles.is_some() { TILE_LEVEL as u32 } else { 16 };
        let items = &mut *self.items;
        let spans = &mut *self.spans;
        let (x0, id) = (bx0, t.item);
        let (mut passed, mut tests, mut written, mut tile_tests, mut tiles_skipped) = (false, 0u64, 0u64, 0u64, 0u64);
        let mut dirty = Dirty::NONE;
        for band in (by0 >> shift)..=((by1 - 1) >> shift) {
            let (ry0, ry1) = (by0.max(band << shift), by1.min((band + 1) << shift));
            spans.clear();
            spans.extend((ry0..ry1).map(|py| t.row_span(py)));
            let (slo, shi) = spans
                .iter()
                .flatten()
                .fold((u32::MAX, 0), |(a, b), &(lo, hi)| (a.min(lo), b.max(hi)));
            if slo >= shi {
                continue;
            }
            for col in (slo >> shift)..=((shi - 1) >> shift) {
                let (rx0, rx1) = (slo.max(col << shift), shi.min((col + 1) << shift));
                let covered: u32 = spans
                    .iter()
                    .flatten()
                    .map(|&(lo, hi)| hi.min(rx1).saturating_sub(lo.max(rx0)))
                    .sum();
                if covered == 0 {
                    continue; // the triangle covers no sample of this tile
                }
                // A tile test costs one comparison: worth it from two samples on.
                if let Some(level) = tiles.filter(|_| covered > 1) {
                    // Every sample of the tile is nearer than its texel's farthest
                    // depth, and every depth of the triangle in the tile at least
                    // `z`: beyond it, no sample can be won or tied.
                    let z = tri_min_depth(t, rx0, ry0, rx1, ry1);
                    tile_tests += 1;
                    if z > level.depth(col, band) {
                        tiles_skipped += 1;
                        continue;
                    }
                }
                for (j, span) in spans.iter().enumerate() {
                    let Some((lo, hi)) = *span else { continue };
                    let (lo, hi) = (lo.max(rx0), hi.min(rx1));
                    if lo >= hi {
                        continue;
                    }
                    let py = ry0 + j as u32;
                    let zr = t.depth_row(py);
                    let row = py as usize * w;
                    tests += u64::from(hi - lo);
                    let mut nearer = false;
                    for x in lo..hi {
                        let z = t.depth_in_row(zr, (x - x0) as i32);
                        let i = row + x as usize;
                        let (d, owner) = (base[i], items[i]);
                        // The renderer's strict test, and ties to the smaller id (drawn first there).
                        if z < d {
                            base[i] = z;
                            items[i] = id;
                            nearer = true;
                            passed = true;
                            written += 1;
                        } else if z == d && owner != NO_OBJECT {
                            passed = true;
                            if id < owner {
                                items[i] = id;
                                written += 1;
                            }
                        }
                    }
                    if nearer {
                        dirty.add(lo, py, hi, py + 1);
                    }
                }
            }
        }
        self.dirty.add(dirty.x0, dirty.y0, dirty.x1, dirty.y1);
        self.stats.sample_tests += tests;
        self.stats.samples_written += written;
        self.stats.tile_tests += tile_tests;
        self.stats.tiles_skipped += tiles_skipped;
        self.zstats.texels += tile_tests;
        passed
    }
}
