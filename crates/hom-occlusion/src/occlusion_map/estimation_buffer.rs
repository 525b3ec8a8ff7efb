//! The depth estimation buffer (Zhang et al. 1997, section 5.2.2).
//!
//! A coarse software buffer (default 64×64 cells over the viewport) holding,
//! per cell, the *farthest* depth (clip z / w) of the occluders over it. An
//! occludee is behind the occluders over its rectangle when its nearest depth
//! is farther than every cell the rectangle touches.
//!
//! Two ways to fill it, both conservative:
//! - [`DepthEstimationBuffer::insert_occluder`] (the paper's): each occluder's
//!   screen rectangle is written with the farthest depth of its box. A sample
//!   covered by an occluder lies in that occluder's rectangle, so its cell
//!   holds at least the box's farthest depth, which bounds the occluder's depth
//!   at the sample.
//! - [`DepthEstimationBuffer::cells_mut`] with [`crate::occlusion_map::CoverageRasterizer`]:
//!   while rasterizing coverage, each cell keeps at least the farthest depth
//!   the renderer's own depth formula gives at any sample first covered in
//!   it (a bound made once per run of rows from the samples themselves), and
//!   falls to the farthest depth of any occluder that covers the whole cell
//!   (every sample then lies at or before it); far tighter where occluder
//!   boxes are long in depth (a street facade), at no extra pass.

use crate::geom::ScreenRect;
use crate::DEPTH_MARGIN;

/// Farthest occluder depth per screen cell.
#[derive(Clone, Debug)]
pub struct DepthEstimationBuffer {
    cols: u32,
    rows: u32,
    cell_w: u32,
    cell_h: u32,
    /// `f32::INFINITY` = no occluder touches the cell (nothing is behind it).
    cells: Vec<f32>,
}

impl DepthEstimationBuffer {
    /// A cleared buffer of at most `cols` × `rows` cells over a `width` × `height` viewport.
    ///
    /// # Panics
    /// If any argument is 0.
    pub fn new(width: u32, height: u32, cols: u32, rows: u32) -> DepthEstimationBuffer {
        assert!(width > 0 && height > 0 && cols > 0 && rows > 0);
        let cell_w = width.div_ceil(cols);
        let cell_h = height.div_ceil(rows);
        let (cols, rows) = (width.div_ceil(cell_w), height.div_ceil(cell_h));
        DepthEstimationBuffer {
            cols,
            rows,
            cell_w,
            cell_h,
            cells: vec![f32::INFINITY; (cols * rows) as usize],
        }
    }

    /// Cells across and down.
    pub fn size(&self) -> (u32, u32) {
        (self.cols, self.rows)
    }

    /// Pixels per cell (width, height); the last row and column may be cut by the viewport.
    pub fn cell_size(&self) -> (u32, u32) {
        (self.cell_w, self.cell_h)
    }

    /// Forgets every occluder.
    pub fn clear(&mut self) {
        self.cells.fill(f32::INFINITY);
    }

    /// The cell range a pixel rectangle touches (half-open), or `None` if empty.
    fn cell_range(&self, r: &ScreenRect) -> Option<(u32, u32, u32, u32)> {
        if r.is_empty() {
            return None;
        }
        Some((
            r.x0 / self.cell_w,
            (r.x1 - 1) / self.cell_w + 1,
            r.y0 / self.cell_h,
            (r.y1 - 1) / self.cell_h + 1,
        ))
    }

    /// Records an occluder: every cell its rectangle touches keeps the farthest depth seen.
    /// Block-oriented: one row slice at a time.
    pub fn insert_occluder(&mut self, rect: &ScreenRect) {
        let Some((cx0, cx1, cy0, cy1)) = self.cell_range(rect) else {
            return;
        };
        let z = rect.z_far;
        for cy in cy0..cy1 {
            let row = &mut self.cells[(cy * self.cols) as usize..][cx0 as usize..cx1 as usize];
            for c in row {
                *c = if *c == f32::INFINITY { z } else { c.max(z) };
            }
        }
    }

    /// True when an occludee with this rectangle is behind every occluder over it
    /// (its nearest depth beyond the farthest occluder depth of each cell).
    pub fn is_behind(&self, rect: &ScreenRect) -> bool {
        let Some((cx0, cx1, cy0, cy1)) = self.cell_range(rect) else {
            return true;
        };
        let z = rect.z_near;
        for cy in cy0..cy1 {
            let row = &self.cells[(cy * self.cols) as usize..][cx0 as usize..cx1 as usize];
            if !row.iter().all(|&c| z > c + DEPTH_MARGIN) {
                return false;
            }
        }
        true
    }

    /// The cell values, row-major (for pictures and tests).
    pub fn cells(&self) -> &[f32] {
        &self.cells
    }

    /// The cells, row-major, for filling from a rasterizer: each must end up
    /// `f32::INFINITY` (no occluder) or, at every covered sample inside it,
    /// at least the depth of some occluder covering that sample.
    pub fn cells_mut(&mut self) -> &mut [f32] {
        &mut self.cells
    }
}

/// The single Z plane (section 5.2.1): the farthest depth of all occluders.
/// Anything entirely beyond it is behind every occluder.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SingleZPlane {
    /// Farthest occluder depth; `f32::INFINITY` before any occluder.
    pub depth: f32,
}

impl Default for SingleZPlane {
    fn default() -> Self {
        SingleZPlane { depth: f32::INFINITY }
    }
}

impl SingleZPlane {
    /// Records an occluder's rectangle (its farthest depth).
    pub fn insert_occluder(&mut self, rect: &ScreenRect) {
        if !rect.is_empty() {
            self.depth = if self.depth == f32::INFINITY {
                rect.z_far
            } else {
                self.depth.max(rect.z_far)
            };
        }
    }

    /// True when an occludee with this rectangle lies beyond the plane.
    pub fn is_behind(&self, rect: &ScreenRect) -> bool {
        rect.is_empty() || rect.z_near > self.depth + DEPTH_MARGIN
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn rect(x0: u32, y0: u32, x1: u32, y1: u32, z_near: f32, z_far: f32) -> ScreenRect {
        ScreenRect {
            x0,
            y0,
            x1,
            y1,
            z_near,
            z_far,
        }
    }

    proptest! {
        /// Never nearer than brute force: a per-pixel buffer of the farthest
        /// occluder depth over each pixel's covering rectangles.
        #[test]
        fn estimation_is_never_nearer_than_brute_force(
            width in 1u32..120, height in 1u32..120, cols in 1u32..20, rows in 1u32..20,
            occluders in proptest::collection::vec((0u32..120, 0u32..120, 1u32..60, 1u32..60, 1.0f32..100.0), 0..12),
            probe in (0u32..120, 0u32..120, 1u32..60, 1u32..60, 1.0f32..120.0),
        ) {
            let mut deb = DepthEstimationBuffer::new(width, height, cols, rows);
            let mut brute = vec![f32::NEG_INFINITY; (width * height) as usize];
            let clampr = |(x, y, w, h, z): (u32, u32, u32, u32, f32), zn: f32| rect(x.min(width), y.min(height), (x + w).min(width), (y + h).min(height), zn, z);
            for &o in &occluders {
                let r = clampr(o, o.4 * 0.5);
                deb.insert_occluder(&r);
                for y in r.y0..r.y1 { for x in r.x0..r.x1 { let b = &mut brute[(y * width + x) as usize]; *b = b.max(r.z_far); } }
            }
            let p = clampr(probe, probe.4);
            let p = ScreenRect { z_near: probe.4, ..p };
            // Each cell is at least as far as every occluder over each of its pixels.
            let (cols, _) = deb.size();
            let (cw, ch) = deb.cell_size();
            for y in 0..height { for x in 0..width {
                let b = brute[(y * width + x) as usize];
                let cell = deb.cells()[((y / ch) * cols + x / cw) as usize];
                if b.is_finite() { prop_assert!(cell >= b, "pixel {},{}: cell {} < occluder {}", x, y, cell, b); }
            } }
            if deb.is_behind(&p) && !p.is_empty() {
                // Every occluder over the probe is nearer than the probe.
                for y in p.y0..p.y1 { for x in p.x0..p.x1 {
                    let b = brute[(y * width + x) as usize];
                    prop_assert!(b < p.z_near, "pixel {},{}: occluder depth {} probe {}", x, y, b, p.z_near);
                } }
            }
        }
    }

    #[test]
    fn occludee_at_exactly_the_occluder_depth_is_not_behind() {
        let mut deb = DepthEstimationBuffer::new(64, 64, 8, 8);
        deb.insert_occluder(&rect(0, 0, 64, 64, 5.0, 10.0));
        assert!(!deb.is_behind(&rect(10, 10, 20, 20, 10.0, 12.0)));
        assert!(deb.is_behind(&rect(10, 10, 20, 20, 10.5, 12.0)));
        let mut z = SingleZPlane::default();
        assert!(
            !z.is_behind(&rect(10, 10, 20, 20, 1e9, 1e9)),
            "no occluders: nothing is behind"
        );
        z.insert_occluder(&rect(0, 0, 1, 1, 5.0, 10.0));
        assert!(!z.is_behind(&rect(10, 10, 20, 20, 10.0, 12.0)));
        assert!(z.is_behind(&rect(10, 10, 20, 20, 10.5, 12.0)));
    }

    #[test]
    fn cells_without_occluders_hide_nothing() {
        let mut deb = DepthEstimationBuffer::new(100, 75, 64, 64);
        deb.insert_occluder(&rect(0, 0, 50, 75, 1.0, 2.0));
        assert!(deb.is_behind(&rect(0, 0, 40, 75, 3.0, 4.0)));
        assert!(!deb.is_behind(&rect(40, 0, 60, 10, 3.0, 4.0)));
    }
}
