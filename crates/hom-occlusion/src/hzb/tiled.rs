//! A z-buffer stored in 8×8-sample tiles, each with its farthest depth, and
//! a max-pyramid above the tiles: the hierarchical Z-buffer (Greene, Kass and
//! Miller 1993) laid out for a rasterizer that rejects whole tiles, and hom's
//! depth representation in `hom bench raster`.
//!
//! It holds the same information as a row-major depth image plus
//! [`super::ZPyramid`] (levels 0–2 live inside the tiles, level 3 is the tile
//! maxima, the levels above are stored), and [`TiledZBuffer::is_behind`]
//! answers exactly what [`super::ZPyramid::is_behind`] answers for the same
//! depths (tested). Depth is clip `z / w`, nearer is smaller;
//! `f32::INFINITY` marks a sample no occluder covers and samples past the
//! viewport's edge hold `f32::NEG_INFINITY` (nothing there can be seen).

use crate::geom::ScreenRect;
use crate::raster::scanline::all_tiles_of;
use crate::raster::setup::Tri;
use crate::DEPTH_MARGIN;

/// Tile side in samples.
pub const TILE: u32 = 8;
/// Samples per tile.
pub const TILE_SAMPLES: usize = (TILE * TILE) as usize;

/// A tiled z-buffer with per-tile farthest depth and a pyramid above; see the module docs.
#[derive(Clone, Debug, Default)]
pub struct TiledZBuffer {
    width: u32,
    height: u32,
    tiles_x: u32,
    tiles_y: u32,
    /// Tile-major: tile `(tx, ty)` holds samples `[(ty * tiles_x + tx) * 64..][..64]`,
    /// row-major inside; meaningful only for touched tiles.
    samples: Vec<f32>,
    /// Whether each tile's samples have been written since the last clear
    /// (an untouched tile is blank: clearing costs a flag, not 64 samples).
    touched: Vec<bool>,
    /// Farthest depth of each tile's samples, row-major over tiles.
    tile_max: Vec<f32>,
    /// Levels above the tiles: `upper[k]` has texels of `2^(k+1)` tiles a side.
    upper: Vec<(u32, u32, Vec<f32>)>,
}

impl TiledZBuffer {
    /// Clears to "nothing covered" at `width` × `height` (each side 1..=16384).
    ///
    /// # Panics
    /// If a side is 0 or above 16384.
    pub fn clear(&mut self, width: u32, height: u32) {
        assert!(
            (1..=16384).contains(&width) && (1..=16384).contains(&height),
            "viewport {width}x{height}"
        );
        self.width = width;
        self.height = height;
        self.tiles_x = width.div_ceil(TILE);
        self.tiles_y = height.div_ceil(TILE);
        let n = (self.tiles_x * self.tiles_y) as usize;
        // Stale samples stay: a tile is blanked when first drawn.
        self.samples.resize(n * TILE_SAMPLES, f32::INFINITY);
        self.touched.clear();
        self.touched.resize(n, false);
        self.tile_max.clear();
        self.tile_max.resize(n, f32::INFINITY);
        self.upper.clear();
    }

    /// Fills `tile` (the samples of tile `(tx, ty)`) with what a blank tile
    /// holds: `INFINITY` inside the viewport, `NEG_INFINITY` past its edges.
    pub(crate) fn blank(width: u32, height: u32, tx: u32, ty: u32, tile: &mut [f32]) {
        tile.fill(f32::INFINITY);
        let (cols, rows) = (width - tx * TILE, height - ty * TILE);
        if cols < TILE || rows < TILE {
            for (k, d) in tile.iter_mut().enumerate() {
                if k as u32 % TILE >= cols || k as u32 / TILE >= rows {
                    *d = f32::NEG_INFINITY;
                }
            }
        }
    }

    /// The sample at `(x, y)` (inside the viewport), blank where untouched.
    #[inline]
    fn sample(&self, x: u32, y: u32) -> f32 {
        if self.touched[(y / TILE * self.tiles_x + x / TILE) as usize] {
            self.samples[Self::index(self.tiles_x, x, y)]
        } else {
            f32::INFINITY
        }
    }

    /// Bytes held on the heap.
    pub fn heap_bytes(&self) -> usize {
        crate::vec_bytes(&self.samples)
            + crate::vec_bytes(&self.touched)
            + crate::vec_bytes(&self.tile_max)
            + self.upper.iter().map(|l| crate::vec_bytes(&l.2)).sum::<usize>()
    }

    /// Width in samples.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in samples.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Tiles across and down.
    pub fn tiles(&self) -> (u32, u32) {
        (self.tiles_x, self.tiles_y)
    }

    /// Depth at sample `(x, y)`.
    ///
    /// # Panics
    /// If `(x, y)` is outside the viewport.
    pub fn depth(&self, x: u32, y: u32) -> f32 {
        assert!(
            x < self.width && y < self.height,
            "sample {x},{y} outside {}x{}",
            self.width,
            self.height
        );
        self.sample(x, y)
    }

    #[inline]
    fn index(tiles_x: u32, x: u32, y: u32) -> usize {
        ((y / TILE * tiles_x + x / TILE) as usize) * TILE_SAMPLES + ((y % TILE) * TILE + x % TILE) as usize
    }

    /// The depth as a row-major `width` × `height` image.
    pub fn to_row_major(&self, out: &mut Vec<f32>) {
        out.clear();
        out.reserve((self.width * self.height) as usize);
        for y in 0..self.height {
            for x in 0..self.width {
                out.push(self.sample(x, y));
            }
        }
    }

    /// One bit per sample holding a finite depth (covered by something):
    /// bit `x % 64` of word `y * ceil(width / 64) + x / 64`, as
    /// [`crate::occlusion_map::CoverageBuffer`] lays its bits out. Reads only the
    /// tiles drawn since the last clear.
    pub fn coverage_bits(&self, bits: &mut Vec<u64>) {
        let wpr = (self.width as usize).div_ceil(64);
        bits.clear();
        bits.resize(wpr * self.height as usize, 0);
        for (t, _) in self.touched.iter().enumerate().filter(|(_, &touched)| touched) {
            let (tx, ty) = (t as u32 % self.tiles_x, t as u32 / self.tiles_x);
            let tile = &self.samples[t * TILE_SAMPLES..][..TILE_SAMPLES];
            // A finite farthest depth: every sample inside the viewport is covered
            // (past its edge samples hold NEG_INFINITY, uncovered ones INFINITY).
            let full = self.tile_max[t].is_finite();
            let inside = (1u64 << TILE.min(self.width - tx * TILE)) - 1;
            for j in 0..TILE.min(self.height - ty * TILE) {
                let row = if full {
                    inside
                } else {
                    (0..TILE).fold(0u64, |row, i| {
                        row | u64::from(tile[(j * TILE + i) as usize].is_finite()) << i
                    })
                };
                let (x, y) = (tx * TILE, (ty * TILE + j) as usize);
                // Tiles are 8 wide and 64 / 8 is whole: a tile row never straddles two words.
                bits[y * wpr + x as usize / 64] |= row << (x % 64);
            }
        }
    }

    /// Farthest depth of each tile, row-major over tiles.
    pub fn tile_max(&self) -> &[f32] {
        &self.tile_max
    }

    /// The samples (tile-major), tile maxima and touched flags, for the
    /// rasterizer; drops the levels above the tiles, which no longer match.
    pub(crate) fn parts_mut(&mut self) -> (&mut [f32], &mut [f32], &mut [bool]) {
        self.upper.clear();
        (&mut self.samples, &mut self.tile_max, &mut self.touched)
    }

    /// Builds the levels above the tiles (call after rendering, before [`TiledZBuffer::is_behind`]).
    pub fn build_pyramid(&mut self) {
        self.upper.clear();
        let (mut w, mut h) = (self.tiles_x, self.tiles_y);
        while w > 1 || h > 1 {
            let src = self.upper.last().map_or(&self.tile_max[..], |l| &l.2[..]);
            let (nw, nh) = (w.div_ceil(2), h.div_ceil(2));
            let mut dst = Vec::with_capacity((nw * nh) as usize);
            for y in 0..nh {
                for x in 0..nw {
                    let mut m = f32::NEG_INFINITY;
                    for (cx, cy) in [
                        (2 * x, 2 * y),
                        (2 * x + 1, 2 * y),
                        (2 * x, 2 * y + 1),
                        (2 * x + 1, 2 * y + 1),
                    ] {
                        if cx < w && cy < h {
                            m = m.max(src[(cy * w + cx) as usize]);
                        }
                    }
                    dst.push(m);
                }
            }
            self.upper.push((nw, nh, dst));
            (w, h) = (nw, nh);
        }
    }

    /// True when every sample of `r` holds an occluder nearer than `r.z_near`
    /// by more than [`DEPTH_MARGIN`]. Starts at the finest level (tiles or
    /// above) where the rectangle touches at most 2×2 texels and descends
    /// where a texel is not behind, down to the samples of a tile. An empty
    /// rectangle is behind. `r` must lie within the viewport.
    ///
    /// # Panics
    /// If the pyramid was not built since the last render ([`TiledZBuffer::build_pyramid`])
    /// and the rectangle spans more than 2×2 tiles.
    pub fn is_behind(&self, r: &ScreenRect) -> bool {
        if r.is_empty() {
            return true;
        }
        debug_assert!(r.x1 <= self.width && r.y1 <= self.height, "{r:?} outside the viewport");
        // Most visible rectangles are visible at their centre: one read.
        let (cx, cy) = ((r.x0 + r.x1 - 1) / 2, (r.y0 + r.y1 - 1) / 2);
        if r.z_near <= self.sample(cx, cy) + DEPTH_MARGIN {
            return false;
        }
        let (t0x, t0y, t1x, t1y) = (r.x0 / TILE, r.y0 / TILE, (r.x1 - 1) / TILE, (r.y1 - 1) / TILE);
        // Level 0 here is the tiles; level k + 1 is upper[k].
        let mut k = 0;
        while (t1x >> k) - (t0x >> k) > 1 || (t1y >> k) - (t0y >> k) > 1 {
            k += 1;
        }
        assert!(
            k == 0 || k <= self.upper.len(),
            "TiledZBuffer::build_pyramid was not called"
        );
        self.region_behind(k, r, [t0x, t0y, t1x, t1y])
    }

    /// Whether `tris` (set up for this viewport by the renderer's rule) lie
    /// behind the drawn depth at every sample they cover, by more than
    /// [`DEPTH_MARGIN`]: the per-sample question a box test cannot answer
    /// (`sample_depth.rs`). A triangle's box at its nearest depth is asked
    /// of the pyramid first (when built); a row's run within a tile is
    /// decided at once when its nearest depth lies behind the tile's
    /// farthest. Triangles that cover no sample are hidden.
    pub fn triangles_hidden(&self, tris: &[Tri]) -> bool {
        tris.iter().all(|t| self.triangle_hidden(t))
    }

    /// One triangle, a tile row (8 rows) at a time: each tile its rows reach
    /// is passed whole when the triangle's nearest depth over it lies behind
    /// the tile's farthest, else sample by sample.
    fn triangle_hidden(&self, t: &Tri) -> bool {
        let pyramid_built = !self.upper.is_empty() || (self.tiles_x <= 1 && self.tiles_y <= 1);
        all_tiles_of(
            t,
            (self.width, self.height),
            (TILE, TILE),
            |rect| pyramid_built && self.is_behind(rect),
            |row, spans, x, end| self.tile_hidden(t, row, spans, x, end),
        )
    }

    /// Whether `t`'s samples in columns `x..end` (one tile's) of rows
    /// `row..row + spans.len()` (one tile row's; `spans` their covered
    /// columns) all lie behind.
    #[inline]
    fn tile_hidden(&self, t: &Tri, row: u32, spans: &[(u32, u32)], x: u32, end: u32) -> bool {
        let tile = (row / TILE * self.tiles_x + x / TILE) as usize;
        let last_row = row + spans.len() as u32 - 1;
        if self.touched[tile] && t.depth_bounds(x, end - 1, row, last_row).0 > self.tile_max[tile] + DEPTH_MARGIN {
            return true;
        }
        for (py, &(lo, hi)) in (row..).zip(spans) {
            let (lo, hi) = (lo.max(x), hi.min(end));
            if lo >= hi {
                continue;
            }
            if !self.touched[tile] {
                return false; // no occluder there
            }
            let zr = t.depth_row(py);
            let i = Self::index(self.tiles_x, lo, py);
            let z = &self.samples[i..i + (hi - lo) as usize];
            let dx0 = lo as i32 - i32::from(t.x0);
            let seen = z.iter().zip(dx0..).fold(false, |seen, (&zo, dx)| {
                seen | (t.depth_in_row(zr, dx) <= zo + DEPTH_MARGIN)
            });
            if seen {
                return false;
            }
        }
        true
    }

    /// Whether every texel of level `k` (0 = tiles) over tile range `t` (inclusive) is behind `r`.
    fn region_behind(&self, k: usize, r: &ScreenRect, t: [u32; 4]) -> bool {
        let z = r.z_near;
        let (w, texels) = if k == 0 {
            (self.tiles_x, &self.tile_max[..])
        } else {
            let l = &self.upper[k - 1];
            (l.0, &l.2[..])
        };
        // At most 2×2 texels here (the start level is chosen so, and a
        // texel's children are 2×2). First the cheap verdict: a failing texel
        // wholly inside the rectangle has its farthest sample inside too.
        let side = TILE << k;
        let mut partial = [(0u32, 0u32); 4];
        let mut n = 0;
        for ty in t[1] >> k..=t[3] >> k {
            for tx in t[0] >> k..=t[2] >> k {
                if z > texels[(ty * w + tx) as usize] + DEPTH_MARGIN {
                    continue;
                }
                let inside = r.x0 <= tx * side
                    && r.y0 <= ty * side
                    && r.x1 >= ((tx + 1) * side).min(self.width)
                    && r.y1 >= ((ty + 1) * side).min(self.height);
                if inside {
                    return false;
                }
                partial[n] = (tx, ty);
                n += 1;
            }
        }
        // Then descend into the failing texels the rectangle only partly covers.
        partial[..n].iter().all(|&(tx, ty)| {
            if k == 0 {
                self.tile_behind(tx, ty, r)
            } else {
                // This texel's tiles, within the rectangle's.
                let sub = [
                    t[0].max(tx << k),
                    t[1].max(ty << k),
                    t[2].min(((tx + 1) << k) - 1),
                    t[3].min(((ty + 1) << k) - 1),
                ];
                self.region_behind(k - 1, r, sub)
            }
        })
    }

    /// Whether every sample of tile `(tx, ty)` inside `r` is behind `r.z_near`.
    fn tile_behind(&self, tx: u32, ty: u32, r: &ScreenRect) -> bool {
        let t = (ty * self.tiles_x + tx) as usize;
        if !self.touched[t] {
            return false; // blank: every sample inside the viewport is uncovered
        }
        let tile = &self.samples[t * TILE_SAMPLES..][..TILE_SAMPLES];
        let (x0, x1) = (r.x0.max(tx * TILE) - tx * TILE, r.x1.min((tx + 1) * TILE) - tx * TILE);
        let (y0, y1) = (r.y0.max(ty * TILE) - ty * TILE, r.y1.min((ty + 1) * TILE) - ty * TILE);
        (y0..y1).all(|j| {
            tile[(j * TILE + x0) as usize..(j * TILE + x1) as usize]
                .iter()
                .all(|&d| r.z_near > d + DEPTH_MARGIN)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hzb::{ZPyramid, ZTestStats};
    use hom_testkit::Rng;
    use proptest::prelude::*;

    /// A tiled buffer holding the row-major `depth`, with each tile's max.
    fn tiled(w: u32, h: u32, depth: &[f32]) -> TiledZBuffer {
        let mut t = TiledZBuffer::default();
        t.clear(w, h);
        for ty in 0..t.tiles_y {
            for tx in 0..t.tiles_x {
                let k = (ty * t.tiles_x + tx) as usize;
                TiledZBuffer::blank(w, h, tx, ty, &mut t.samples[k * TILE_SAMPLES..][..TILE_SAMPLES]);
            }
        }
        for y in 0..h {
            for x in 0..w {
                t.samples[TiledZBuffer::index(t.tiles_x, x, y)] = depth[(y * w + x) as usize];
                t.touched[(y / TILE * t.tiles_x + x / TILE) as usize] = true;
            }
        }
        for (i, m) in t.tile_max.iter_mut().enumerate() {
            *m = t.samples[i * TILE_SAMPLES..][..TILE_SAMPLES]
                .iter()
                .fold(f32::NEG_INFINITY, |a, &b| a.max(b));
        }
        t.build_pyramid();
        t
    }

    proptest! {
        #[test]
        fn is_behind_equals_the_z_pyramid(
            w in 1u32..90, h in 1u32..90, seed in any::<u64>(),
            a in (0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0), z in 0.0f32..1.2,
        ) {
            let mut rng = Rng::new(seed);
            let d: Vec<f32> = (0..w * h).map(|_| {
                if rng.below(9) == 0 { f32::INFINITY } else { rng.range(0.0, 0.5) }
            }).collect();
            let t = tiled(w, h, &d);
            let mut back = Vec::new();
            t.to_row_major(&mut back);
            prop_assert_eq!(&back, &d);
            let mut p = ZPyramid::default();
            p.build(w, h, &d);
            let (xa, xb) = ((a.0 * w as f32) as u32, (a.1 * w as f32) as u32);
            let (ya, yb) = ((a.2 * h as f32) as u32, (a.3 * h as f32) as u32);
            let r = ScreenRect { x0: xa.min(xb), x1: (xa.max(xb) + 1).min(w), y0: ya.min(yb), y1: (ya.max(yb) + 1).min(h), z_near: z, z_far: z };
            prop_assert_eq!(t.is_behind(&r), p.is_behind(&r, &mut ZTestStats::default()), "{:?}", r);
        }
    }

    proptest! {
        #[test]
        fn coverage_bits_are_the_finite_samples(w in 1u32..150, h in 1u32..40, seed in any::<u64>(), holes in 0usize..4) {
            let mut rng = Rng::new(seed);
            // From dense holes to none: wholly covered tiles take the fast path.
            let one_in = [3, 60, 1000, u64::MAX][holes];
            let d: Vec<f32> = (0..w * h).map(|_| if rng.below(one_in) == 0 { f32::INFINITY } else { 0.5 }).collect();
            let t = tiled(w, h, &d);
            let mut bits = Vec::new();
            t.coverage_bits(&mut bits);
            let wpr = (w as usize).div_ceil(64);
            for y in 0..h as usize {
                for x in 0..w as usize {
                    let bit = bits[y * wpr + x / 64] >> (x % 64) & 1 == 1;
                    prop_assert_eq!(bit, d[y * w as usize + x].is_finite(), "sample {},{}", x, y);
                }
            }
        }
    }

    #[test]
    fn samples_past_the_edge_hide_nothing_and_block_nothing() {
        let mut t = TiledZBuffer::default();
        t.clear(10, 3);
        assert_eq!(t.tiles(), (2, 1));
        assert_eq!(t.depth(9, 2), f32::INFINITY);
        let r = ScreenRect {
            x0: 0,
            y0: 0,
            x1: 10,
            y1: 3,
            z_near: 0.5,
            z_far: 0.5,
        };
        t.build_pyramid();
        assert!(!t.is_behind(&r), "an empty buffer hides nothing");
    }
}
