//! Hole search for occluder selection's feedback (Zhang et al. 1997,
//! section 6.2): the worst hole of the last frame's coarsest occlusion map,
//! as a normalized-device rectangle the selection turns into a sub-frustum.

use super::{Level, Pyramid};

/// A hole region of the coarsest map: normalized device rectangle and its mean opacity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hole {
    /// NDC x range (left, right).
    pub x: (f32, f32),
    /// NDC y range (bottom, top).
    pub y: (f32, f32),
    /// Mean opacity over the region.
    pub opacity: f32,
}

/// The coarsest-level region of lowest opacity below `hole_opacity`, grown
/// greedily over neighbouring hole pixels, as an NDC rectangle.
pub fn find_worst_hole(p: &Pyramid, hole_opacity: f32) -> Option<Hole> {
    let top = p.levels().last()?;
    let size = p.block() << (p.levels().len() - 1);
    worst_hole_of_level(top, size, p.viewport(), hole_opacity)
}

/// [`find_worst_hole`] over a pyramid's coarsest level `top`, whose pixels
/// stand for `size` × `size` samples of a `viewport`.
pub(crate) fn worst_hole_of_level(top: &Level, size: u32, viewport: (u32, u32), hole_opacity: f32) -> Option<Hole> {
    let hole = |x: u32, y: u32| top.opacity(x, y) < hole_opacity;
    let (mut sx, mut sy, mut worst) = (0, 0, f32::MAX);
    for y in 0..top.height {
        for x in 0..top.width {
            let o = top.opacity(x, y);
            if hole(x, y) && o < worst {
                (sx, sy, worst) = (x, y, o);
            }
        }
    }
    if worst == f32::MAX {
        return None;
    }
    // Grow right, then down while every pixel of the new row is a hole.
    let mut x1 = sx + 1;
    while x1 < top.width && hole(x1, sy) {
        x1 += 1;
    }
    let mut x0 = sx;
    while x0 > 0 && hole(x0 - 1, sy) {
        x0 -= 1;
    }
    let mut y1 = sy + 1;
    while y1 < top.height && (x0..x1).all(|x| hole(x, y1)) {
        y1 += 1;
    }
    let mut y0 = sy;
    while y0 > 0 && (x0..x1).all(|x| hole(x, y0 - 1)) {
        y0 -= 1;
    }
    let mut sum = 0.0;
    for y in y0..y1 {
        for x in x0..x1 {
            sum += top.opacity(x, y);
        }
    }
    let n = ((x1 - x0) * (y1 - y0)) as f32;
    let size = size as f32;
    let (w, h) = (viewport.0 as f32, viewport.1 as f32);
    let ndc_x = |px: f32| (px * size / w).min(1.0) * 2.0 - 1.0;
    let ndc_y = |py: f32| 1.0 - (py * size / h).min(1.0) * 2.0;
    Some(Hole {
        x: (ndc_x(x0 as f32), ndc_x(x1 as f32)),
        y: (ndc_y(y1 as f32), ndc_y(y0 as f32)),
        opacity: sum / n,
    })
}

/// The worst hole of a per-sample coverage mask (bit `x % 64` of word
/// `y * ceil(width / 64) + x / 64`, as [`crate::occlusion_map::CoverageBuffer`]
/// lays it out): its opacity pyramid with `map`'s geometry, then
/// [`find_worst_hole`]. For representations that hold no opacity (the HZB's depth).
pub fn worst_hole_of_coverage(
    bits: &[u64],
    width: u32,
    height: u32,
    map: &crate::MapOptions,
    hole_opacity: f32,
) -> Option<Hole> {
    if width == 0 || height == 0 {
        return None;
    }
    let mut p = map.new_pyramid(width, height);
    p.build_from_coverage(bits, (width as usize).div_ceil(64));
    find_worst_hole(&p, hole_opacity)
}
