//! Occluder coverage at output resolution: the base of a conservative
//! occlusion map (Zhang et al. 1997, section 6.1, done in software).
//!
//! Each occluder triangle is clipped, snapped and set up by
//! [`super::setup`] — the same code the reference renderer draws with — so a
//! sample is covered here exactly when the renderer would cover it with that
//! triangle. Coverage is one bit per output sample; rows of the image are
//! split into bands filled in parallel (bits are OR-ed, so the result does not
//! depend on the thread count or order).

use super::setup::{setup_triangle, Tri, Vertex, Viewport};
use crate::depth::DepthEstimationBuffer;
use crate::geom::Camera;
use crate::occluders::OccluderDb;
use crate::scene::Scene;
use rayon::prelude::*;

/// One bit per output sample: bit `x % 64` of word `y * words_per_row + x / 64`.
#[derive(Clone, Debug, Default)]
pub struct CoverageBuffer {
    width: u32,
    height: u32,
    words_per_row: usize,
    bits: Vec<u64>,
}

impl CoverageBuffer {
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

/// Sets bits `lo..hi` of a row.
#[inline]
pub(crate) fn set_span(row: &mut [u64], lo: u32, hi: u32) {
    let mut x = lo;
    while x < hi {
        let bit = x % 64;
        let n = (64 - bit).min(hi - x);
        let mask = if n == 64 { u64::MAX } else { ((1u64 << n) - 1) << bit };
        row[(x / 64) as usize] |= mask;
        x += n;
    }
}

/// Sets bits `lo..hi` of a row and calls `fresh(base, bits)` for each word
/// where some were not set before (`bits` bit `i` is sample `base + i`).
#[inline]
fn set_span_reporting(row: &mut [u64], lo: u32, hi: u32, mut fresh: impl FnMut(u32, u64)) {
    let mut x = lo;
    while x < hi {
        let bit = x % 64;
        let n = (64 - bit).min(hi - x);
        let mask = if n == 64 { u64::MAX } else { ((1u64 << n) - 1) << bit };
        let word = &mut row[(x / 64) as usize];
        let new = mask & !*word;
        *word |= mask;
        if new != 0 {
            fresh(x - bit, new);
        }
        x += n;
    }
}

/// Rows per parallel band when no depth is gathered.
const BAND_ROWS: u32 = 16;

/// Rasterizes occluders' coverage; keeps its scratch between frames.
#[derive(Clone, Debug, Default)]
pub struct OccluderRasterizer {
    tris: Vec<Tri>,
    bins: Vec<Vec<u32>>,
}

impl OccluderRasterizer {
    /// Clears `coverage` to the camera's viewport and covers every sample the
    /// occluders `ids` cover (their stand-in meshes where they have one).
    ///
    /// With `depth`, also fills its cells with the farthest depth the renderer
    /// would compute at any covered sample in each cell (`f32::INFINITY` where
    /// nothing is covered); its cells must be laid over the same viewport.
    /// Returns the number of occluder triangles submitted.
    pub fn rasterize(
        &mut self,
        coverage: &mut CoverageBuffer,
        scene: &Scene,
        db: &OccluderDb,
        ids: &[u32],
        camera: &Camera,
        depth: Option<&mut DepthEstimationBuffer>,
    ) -> u64 {
        coverage.reset(camera.width, camera.height);
        let vp = Viewport::new(camera.width, camera.height);
        let view_proj = camera.view_proj();
        // Triangle setup, in parallel over occluders, concatenated nearest first.
        let mut order = ids.to_vec();
        let eye = camera.eye;
        let near = |id: &u32| scene.object(*id).aabb.distance_squared(eye);
        order.sort_by(|a, b| near(a).total_cmp(&near(b)).then(a.cmp(b)));
        let ids = &order[..];
        let stand_ins: Vec<Option<&crate::scene::Mesh>> = ids
            .iter()
            .map(|&id| {
                db.occluders()
                    .binary_search_by_key(&id, |o| o.object)
                    .ok()
                    .and_then(|i| db.occluders()[i].stand_in.as_deref())
            })
            .collect();
        let per_object: Vec<Vec<Tri>> = ids
            .par_iter()
            .zip(stand_ins.par_iter())
            .map(|(&id, stand_in)| {
                let o = scene.object(id);
                let mesh = stand_in.unwrap_or_else(|| scene.mesh_of(o));
                let mvp = view_proj * o.transform;
                let verts: Vec<Vertex> = mesh
                    .positions()
                    .iter()
                    .map(|p| Vertex::new(mvp * p.extend(1.0), &vp))
                    .collect();
                let mut out = Vec::with_capacity(mesh.triangle_count());
                for t in mesh.triangles() {
                    let [a, b, c] = t.map(|i| &verts[i as usize]);
                    setup_triangle([a, b, c], &vp, 0, [0; 4], &mut out);
                }
                out
            })
            .collect();
        let submitted = ids.iter().map(|&id| scene.object(id).triangles as u64).sum();
        self.tris.clear();
        for v in per_object {
            self.tris.extend(v);
        }

        // Bands of rows: one row of depth cells each when gathering depth, so
        // every band writes only its own cells.
        let (cols, band_rows, cell_w) = match depth.as_deref() {
            Some(d) => (d.size().0 as usize, d.cell_size().1, d.cell_size().0),
            None => (0, BAND_ROWS, 1),
        };
        let bands = camera.height.div_ceil(band_rows) as usize;
        self.bins.resize_with(bands, Vec::new);
        self.bins.truncate(bands);
        for bin in &mut self.bins {
            bin.clear();
        }
        for (i, t) in self.tris.iter().enumerate() {
            for band in u32::from(t.y0) / band_rows..=(u32::from(t.y1) - 1) / band_rows {
                self.bins[band as usize].push(i as u32);
            }
        }

        let (tris, bins) = (&self.tris, &self.bins);
        let wpr = coverage.words_per_row;
        // One row of depth cells per band (none when not gathering depth).
        let mut cell_rows: Vec<&mut [f32]> = match depth {
            Some(d) => d.cells_mut().chunks_mut(cols).collect(),
            None => (0..bands).map(|_| <&mut [f32]>::default()).collect(),
        };
        debug_assert_eq!(cell_rows.len(), bands, "depth cells and bands share rows");
        coverage
            .bits
            .par_chunks_mut(wpr * band_rows as usize)
            .zip(bins.par_iter())
            .zip(cell_rows.par_iter_mut())
            .enumerate()
            .for_each(|(band, ((words, bin), cells))| {
                let y0 = band as u32 * band_rows;
                let y1 = y0 + (words.len() / wpr) as u32;
                let gather = !cells.is_empty();
                cells.fill(f32::NEG_INFINITY);
                for &i in bin {
                    let t = &tris[i as usize];
                    let (ta, tb) = (u32::from(t.y0).max(y0), u32::from(t.y1).min(y1));
                    for py in ta..tb {
                        let Some((lo, hi)) = t.row_span(py) else { continue };
                        let row = &mut words[(py - y0) as usize * wpr..][..wpr];
                        if !gather {
                            set_span(row, lo, hi);
                            continue;
                        }
                        // Only samples this triangle covers first set depth: occluders
                        // come nearest first, so that is mostly the visible occluder, and
                        // in any order the first cover's depth bounds the nearest from above.
                        // The renderer's depth formula is monotone along the row, so the
                        // farthest of a cell's new samples is its first or last one.
                        let zr = t.depth_row(py);
                        let z = |x: u32| (zr + t.dzdx * (x - u32::from(t.x0)) as f32).max(0.0);
                        set_span_reporting(row, lo, hi, |base, fresh| {
                            let mut m = fresh;
                            while m != 0 {
                                let first = base + m.trailing_zeros();
                                let cell = first / cell_w;
                                let upto = ((cell + 1) * cell_w).min(base + 64) - base;
                                let in_cell = if upto == 64 { m } else { m & ((1u64 << upto) - 1) };
                                let last = base + 63 - in_cell.leading_zeros();
                                let c = &mut cells[cell as usize];
                                *c = c.max(z(first)).max(z(last));
                                m &= !in_cell;
                            }
                        });
                    }
                }
                for c in cells.iter_mut() {
                    if *c == f32::NEG_INFINITY {
                        *c = f32::INFINITY; // nothing covered: nothing is behind this cell
                    }
                }
            });
        submitted
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
