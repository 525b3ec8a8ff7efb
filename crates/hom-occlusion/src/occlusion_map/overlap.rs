//! The hierarchical overlap test (Zhang et al. 1997, section 5.1) with
//! opacity and transparency thresholds (sections 5.1, 5.4).
//!
//! A screen rectangle is *covered* when every pyramid pixel it touches is
//! opaque. The test starts at the level whose pixel is about the rectangle's
//! size, accepts a pixel as soon as it is opaque at its level, descends only
//! where it is not, and gives up early where a pixel is at or below the
//! transparency threshold (nothing opaque enough can hide below it).

use super::pyramid::Pyramid;
use crate::geom::ScreenRect;

/// Per-level opacity and transparency thresholds, as sample counts.
#[derive(Clone, Debug, PartialEq)]
pub struct Thresholds {
    /// A level-`k` pixel is opaque when its count is at least `opaque_min[k]`.
    pub opaque_min: Vec<u32>,
    /// The test stops (not covered) at a level-`k` pixel whose count is at most `transparent_max[k]`.
    pub transparent_max: Vec<u32>,
}

impl Thresholds {
    /// Opacity threshold 1.0 at every level: a pixel is opaque only when every
    /// output sample under it is covered. Conservative: never hides a visible pixel.
    /// `transparency` (in `[0, 1)`) sets the early-termination bound.
    pub fn conservative(pyramid: &Pyramid, transparency: f32) -> Thresholds {
        Thresholds::per_level(pyramid, |_| 1.0, transparency)
    }

    /// Approximate culling from a base-level opacity threshold `o0` in `(0, 1]`,
    /// raised level by level as O(k+1) = (3 + O(k)) / 4, so a hole of the same
    /// number of output samples is ignored at every level (RTR, HOM excerpt).
    pub fn approximate(pyramid: &Pyramid, o0: f32, transparency: f32) -> Thresholds {
        Thresholds::per_level(
            pyramid,
            |k| {
                let mut o = o0;
                for _ in 0..k {
                    o = (3.0 + o) / 4.0;
                }
                o
            },
            transparency,
        )
    }

    /// Approximate culling that ignores holes of up to `samples` uncovered
    /// output samples in a base pixel: O(0) = 1 − samples / block².
    pub fn negligible_hole(pyramid: &Pyramid, samples: u32, transparency: f32) -> Thresholds {
        let m = (pyramid.block() * pyramid.block()) as f32;
        Thresholds::approximate(pyramid, (1.0 - samples as f32 / m).max(f32::MIN_POSITIVE), transparency)
    }

    fn per_level(pyramid: &Pyramid, opacity: impl Fn(usize) -> f32, transparency: f32) -> Thresholds {
        let t = transparency.clamp(0.0, 1.0);
        let mut opaque_min = Vec::new();
        let mut transparent_max = Vec::new();
        for (k, level) in pyramid.levels().iter().enumerate() {
            let full = level.samples_per_pixel;
            let o = opacity(k).clamp(0.0, 1.0) as f64;
            // ceil, and never 0: a pixel with nothing covered is never opaque.
            opaque_min.push(((o * full as f64).ceil() as u32).clamp(1, full));
            transparent_max.push(((t as f64 * full as f64).floor() as u32).min(full - 1));
        }
        Thresholds {
            opaque_min,
            transparent_max,
        }
    }

    /// True when every level's opacity threshold is 1.0 (the conservative mode).
    pub fn is_conservative(&self, pyramid: &Pyramid) -> bool {
        self.opaque_min
            .iter()
            .zip(pyramid.levels())
            .all(|(&m, l)| m == l.samples_per_pixel)
    }
}

/// What one overlap test did, for the walkthrough counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OverlapStats {
    /// Pyramid pixels examined.
    pub pixels: u64,
    /// Level visits (a descent into a level counts once per pixel descended from).
    pub levels: u64,
}

/// True when `rect` lies in the opaque area of the pyramid under `thresholds`.
/// An empty rectangle covers no sample centre, so it is covered.
pub fn rect_covered(pyramid: &Pyramid, thresholds: &Thresholds, rect: &ScreenRect, stats: &mut OverlapStats) -> bool {
    if rect.is_empty() {
        return true;
    }
    let levels = pyramid.levels();
    let block = pyramid.block();
    let side = rect.width().max(rect.height());
    // The level whose pixel is about the rectangle's size: at most 2×2 pixels to start.
    let mut k = 0usize;
    while k + 1 < levels.len() && (block << k) < side {
        k += 1;
    }
    let size = block << k;
    let (px0, px1) = (rect.x0 / size, (rect.x1 - 1) / size);
    let (py0, py1) = (rect.y0 / size, (rect.y1 - 1) / size);
    stats.levels += 1;
    for py in py0..=py1 {
        for px in px0..=px1 {
            if !pixel_covered(pyramid, thresholds, rect, k, px, py, stats) {
                return false;
            }
        }
    }
    true
}

fn pixel_covered(
    pyramid: &Pyramid,
    th: &Thresholds,
    rect: &ScreenRect,
    k: usize,
    px: u32,
    py: u32,
    stats: &mut OverlapStats,
) -> bool {
    let level = &pyramid.levels()[k];
    stats.pixels += 1;
    let count = level.count(px, py);
    if count >= th.opaque_min[k] {
        return true;
    }
    if k == 0 || count <= th.transparent_max[k] {
        return false;
    }
    stats.levels += 1;
    let child = pyramid.block() << (k - 1);
    let lower = &pyramid.levels()[k - 1];
    for cy in 2 * py..2 * py + 2 {
        for cx in 2 * px..2 * px + 2 {
            // Children past the lower level's edge lie outside the viewport: covered.
            if cx >= lower.width || cy >= lower.height {
                continue;
            }
            let (x0, y0) = (cx * child, cy * child);
            let overlaps = x0 < rect.x1 && x0 + child > rect.x0 && y0 < rect.y1 && y0 + child > rect.y0;
            if overlaps && !pixel_covered(pyramid, th, rect, k - 1, cx, cy, stats) {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use hom_testkit::Rng;
    use proptest::prelude::*;

    fn pyramid_from(cov: &[Vec<bool>], width: u32, height: u32, block: u32) -> Pyramid {
        let wpr = (width as usize).div_ceil(64);
        let mut bits = vec![0u64; wpr * height as usize];
        for y in 0..height as usize {
            for x in 0..width as usize {
                if cov[y][x] {
                    bits[y * wpr + x / 64] |= 1 << (x % 64);
                }
            }
        }
        let mut p = Pyramid::new(width, height, block, 1);
        p.build_from_coverage(&bits, wpr);
        p
    }

    proptest! {
        /// Conservative mode equals brute force over every base pixel under the rectangle.
        #[test]
        fn overlap_test_equals_brute_force_over_base_pixels(
            width in 1u32..90, height in 1u32..90, block in 1u32..5, seed in any::<u64>(),
            hole_rate in 0.0f64..0.02, x0 in 0u32..90, y0 in 0u32..90, w in 1u32..90, h in 1u32..90,
            transparency in 0.0f32..0.9,
        ) {
            let mut rng = Rng::new(seed);
            let cov: Vec<Vec<bool>> = (0..height).map(|_| (0..width).map(|_| f64::from(rng.unit()) >= hole_rate).collect()).collect();
            let p = pyramid_from(&cov, width, height, block);
            let rect = ScreenRect { x0: x0.min(width), y0: y0.min(height), x1: (x0 + w).min(width), y1: (y0 + h).min(height), z_near: 1.0, z_far: 2.0 };
            // Brute force: every base pixel touching the rect is fully covered.
            let mut want = true;
            if !rect.is_empty() {
                for my in rect.y0 / block..=(rect.y1 - 1) / block {
                    for mx in rect.x0 / block..=(rect.x1 - 1) / block {
                        for sy in my * block..(my + 1) * block {
                            for sx in mx * block..(mx + 1) * block {
                                if sx < width && sy < height && !cov[sy as usize][sx as usize] { want = false; }
                            }
                        }
                    }
                }
            }
            let th = Thresholds::conservative(&p, transparency);
            let mut stats = OverlapStats::default();
            let got = rect_covered(&p, &th, &rect, &mut stats);
            // Early termination may only turn "covered" into "not covered".
            prop_assert!(!got || want);
            let exact = Thresholds::conservative(&p, 0.0);
            prop_assert_eq!(rect_covered(&p, &exact, &rect, &mut stats), want);
        }
    }

    #[test]
    fn approximate_thresholds_follow_the_recursion() {
        let p = Pyramid::new(1024, 1024, 8, 4);
        let th = Thresholds::negligible_hole(&p, 4, 0.0);
        // O0 = 1 - 4/64 = 0.9375; O1 = (3 + O0) / 4 = 0.984375.
        assert_eq!(th.opaque_min[0], 60);
        assert_eq!(th.opaque_min[1], (0.984375f64 * 256.0).ceil() as u32);
        assert!(Thresholds::conservative(&p, 0.0).is_conservative(&p));
        assert!(!th.is_conservative(&p));
    }

    #[test]
    fn a_one_sample_gap_is_not_covered_in_conservative_mode_but_is_in_approximate() {
        let (w, h) = (64u32, 64u32);
        let mut cov = vec![vec![true; w as usize]; h as usize];
        cov[30][30] = false;
        let p = pyramid_from(&cov, w, h, 4);
        let rect = ScreenRect {
            x0: 20,
            y0: 20,
            x1: 40,
            y1: 40,
            z_near: 1.0,
            z_far: 1.0,
        };
        let mut s = OverlapStats::default();
        assert!(!rect_covered(&p, &Thresholds::conservative(&p, 0.0), &rect, &mut s));
        assert!(rect_covered(
            &p,
            &Thresholds::negligible_hole(&p, 1, 0.0),
            &rect,
            &mut s
        ));
    }
}
