//! The Z-pyramid of the hierarchical Z-buffer (Greene, Kass and Miller 1993),
//! row-major: the live pyramid of the hierarchical visibility culler
//! (hom's `HvCuller`, updated as it draws), and the reference the
//! HZB culler's tiled z-buffer ([`super::TiledZBuffer`]) is tested against.
//!
//! Level 0 is per-sample depth at output resolution, as the reference
//! renderer computes it (`f32::INFINITY` where nothing covers the sample). Each level above halves
//! both sides (rounding up) and holds, per texel, the *farthest* depth of its
//! 2×2 children; children outside the level below count as `f32::NEG_INFINITY`
//! (no sample exists there, so nothing drawn there can be seen and they never
//! prevent culling). The top level is 1×1.
//!
//! [`ZPyramid::is_behind`] tests a box's screen rectangle with its nearest
//! depth: it starts at the finest level where the rectangle touches at most
//! 2×2 texels and descends only into texels whose farthest depth is not
//! nearer than the box (by [`DEPTH_MARGIN`]). A box is behind when every
//! texel it ends on is; at level 0 a texel is one sample, so the test is
//! exact per sample up to the margin.

use crate::geom::ScreenRect;
use crate::DEPTH_MARGIN;

/// One level of a [`ZPyramid`].
#[derive(Clone, Debug, Default)]
pub struct ZLevel {
    /// Texels across.
    pub width: u32,
    /// Texels down.
    pub height: u32,
    texels: Vec<f32>,
}

impl ZLevel {
    /// Farthest depth under texel `(x, y)`.
    ///
    /// # Panics
    /// If `(x, y)` is outside the level.
    pub fn depth(&self, x: u32, y: u32) -> f32 {
        assert!(x < self.width && y < self.height);
        self.texels[(y * self.width + x) as usize]
    }

    /// The texels, row-major.
    pub fn texels(&self) -> &[f32] {
        &self.texels
    }
}

/// Work done by [`ZPyramid::is_behind`] calls.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ZTestStats {
    /// Texels read.
    pub texels: u64,
    /// Descents from a texel to its children.
    pub descents: u64,
}

/// A max-depth pyramid over the viewport; see the module docs.
#[derive(Clone, Debug, Default)]
pub struct ZPyramid {
    levels: Vec<ZLevel>,
}

impl ZPyramid {
    /// Rebuilds the pyramid from per-sample depth (`width` × `height`, row-major),
    /// reusing its storage.
    ///
    /// # Panics
    /// If `depth.len() != width * height` or a side is 0.
    pub fn build(&mut self, width: u32, height: u32, depth: &[f32]) {
        assert!(width > 0 && height > 0, "empty viewport");
        assert_eq!(depth.len(), width as usize * height as usize, "depth size");
        let mut n = 1;
        let (mut w, mut h) = (width, height);
        while w > 1 || h > 1 {
            w = w.div_ceil(2);
            h = h.div_ceil(2);
            n += 1;
        }
        self.levels.resize_with(n, ZLevel::default);
        let base = &mut self.levels[0];
        base.width = width;
        base.height = height;
        base.texels.clear();
        base.texels.extend_from_slice(depth);
        for k in 1..n {
            let (below, above) = self.levels.split_at_mut(k);
            let (src, dst) = (&below[k - 1], &mut above[0]);
            dst.width = src.width.div_ceil(2);
            dst.height = src.height.div_ceil(2);
            dst.texels.clear();
            dst.texels.reserve((dst.width * dst.height) as usize);
            let sw = src.width as usize;
            for y in 0..dst.height {
                let r0 = &src.texels[(2 * y) as usize * sw..][..sw];
                let r1 = if 2 * y + 1 < src.height {
                    &src.texels[(2 * y + 1) as usize * sw..][..sw]
                } else {
                    r0 // an edge row: max with itself is the row alone
                };
                for x in 0..dst.width as usize {
                    let mut m = r0[2 * x].max(r1[2 * x]);
                    if 2 * x + 1 < sw {
                        m = m.max(r0[2 * x + 1]).max(r1[2 * x + 1]);
                    }
                    dst.texels.push(m);
                }
            }
        }
    }

    /// Sets every sample of a `width` × `height` viewport to `fill` (every
    /// level then holds `fill`), reusing storage: the start of an incremental
    /// pyramid ([`ZPyramid::base_mut`], [`ZPyramid::update_rect`]).
    ///
    /// # Panics
    /// If a side is 0.
    pub fn reset(&mut self, width: u32, height: u32, fill: f32) {
        assert!(width > 0 && height > 0, "empty viewport");
        let (mut w, mut h) = (width, height);
        let mut k = 0;
        loop {
            if self.levels.len() <= k {
                self.levels.push(ZLevel::default());
            }
            let l = &mut self.levels[k];
            l.width = w;
            l.height = h;
            l.texels.clear();
            l.texels.resize((w * h) as usize, fill);
            k += 1;
            if w == 1 && h == 1 {
                break;
            }
            w = w.div_ceil(2);
            h = h.div_ceil(2);
        }
        self.levels.truncate(k);
    }

    /// The per-sample depths (level 0, row-major), to write in place. After
    /// changing samples, call [`ZPyramid::update_rect`] over them before the
    /// next test: until then the levels above are stale.
    ///
    /// # Panics
    /// Before the first build or reset.
    pub fn base_mut(&mut self) -> &mut [f32] {
        &mut self.levels[0].texels
    }

    /// Level 0 to write in place (as [`ZPyramid::base_mut`]) together with
    /// level `k` to read; `None` for `k == 0` or a level that does not exist.
    /// Level `k` may be stale (too far) until [`ZPyramid::update_rect`] runs;
    /// since writes only bring samples nearer in a z-buffer, a stale texel is
    /// still an upper bound of its samples' depths.
    ///
    /// # Panics
    /// Before the first build or reset.
    pub fn base_and_level(&mut self, k: usize) -> (&mut [f32], Option<&ZLevel>) {
        let (base, above) = self.levels.split_at_mut(1);
        let level = if k == 0 { None } else { above.get(k - 1) };
        (&mut base[0].texels, level)
    }

    /// Recomputes every texel above level 0 whose samples meet the rectangle
    /// `x0..x1` × `y0..y1` of level 0 (half-open, clamped to the viewport), each
    /// as the farthest depth of its children: afterwards the pyramid equals
    /// [`ZPyramid::build`] of its level 0, provided only samples inside the
    /// rectangle changed since it last did. Returns the texels recomputed.
    pub fn update_rect(&mut self, x0: u32, y0: u32, x1: u32, y1: u32) -> u64 {
        let Some(base) = self.levels.first() else { return 0 };
        let (x1, y1) = (x1.min(base.width), y1.min(base.height));
        if x0 >= x1 || y0 >= y1 {
            return 0;
        }
        // Inclusive texel range at the current level.
        let (mut ax, mut ay, mut bx, mut by) = (x0, y0, x1 - 1, y1 - 1);
        let mut updated = 0u64;
        for k in 1..self.levels.len() {
            (ax, ay, bx, by) = (ax >> 1, ay >> 1, bx >> 1, by >> 1);
            let (below, above) = self.levels.split_at_mut(k);
            let (src, dst) = (&below[k - 1], &mut above[0]);
            let sw = src.width as usize;
            for ty in ay..=by {
                let (r0, r1) = (2 * ty as usize, (2 * ty as usize + 1).min(src.height as usize - 1));
                for tx in ax..=bx {
                    let c0 = 2 * tx as usize;
                    let c1 = (c0 + 1).min(sw - 1);
                    let m = src.texels[r0 * sw + c0]
                        .max(src.texels[r0 * sw + c1])
                        .max(src.texels[r1 * sw + c0])
                        .max(src.texels[r1 * sw + c1]);
                    dst.texels[ty as usize * dst.width as usize + tx as usize] = m;
                }
            }
            updated += u64::from(bx - ax + 1) * u64::from(by - ay + 1);
        }
        updated
    }

    /// The levels, finest (per sample) first; empty before the first build.
    pub fn levels(&self) -> &[ZLevel] {
        &self.levels
    }

    /// Viewport (width, height) of the last build.
    pub fn viewport(&self) -> (u32, u32) {
        self.levels.first().map_or((0, 0), |l| (l.width, l.height))
    }

    /// True when every sample of `r` has an occluder nearer than the box's
    /// nearest depth by more than [`DEPTH_MARGIN`]: then nothing in the box
    /// can own a sample. An empty rectangle covers no sample and is behind.
    /// `r` must lie within the viewport (as [`crate::geom::project_points`]
    /// clamps it).
    pub fn is_behind(&self, r: &ScreenRect, stats: &mut ZTestStats) -> bool {
        if r.is_empty() {
            return true;
        }
        if self.levels.is_empty() {
            return false;
        }
        let (x1, y1) = (r.x1 - 1, r.y1 - 1); // inclusive
                                             // The finest level where the rectangle touches at most 2×2 texels.
        let mut k = 0;
        while k + 1 < self.levels.len() && ((x1 >> k) - (r.x0 >> k) > 1 || (y1 >> k) - (r.y0 >> k) > 1) {
            k += 1;
        }
        self.region_behind(k, r, r.z_near, stats)
    }

    /// Whether every texel of level `k` under `r` (sample coordinates) is behind `z`,
    /// descending where one is not.
    fn region_behind(&self, k: usize, r: &ScreenRect, z: f32, stats: &mut ZTestStats) -> bool {
        let l = &self.levels[k];
        let (x1, y1) = (r.x1 - 1, r.y1 - 1);
        for ty in r.y0 >> k..=y1 >> k {
            for tx in r.x0 >> k..=x1 >> k {
                stats.texels += 1;
                let d = l.texels[(ty * l.width + tx) as usize];
                if z > d + DEPTH_MARGIN {
                    continue;
                }
                if k == 0 {
                    return false;
                }
                // Descend into this texel's part of the rectangle.
                stats.descents += 1;
                let sub = ScreenRect {
                    x0: r.x0.max(tx << k),
                    y0: r.y0.max(ty << k),
                    x1: r.x1.min((tx + 1) << k),
                    y1: r.y1.min((ty + 1) << k),
                    ..*r
                };
                if !self.region_behind(k - 1, &sub, z, stats) {
                    return false;
                }
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hom_testkit::Rng;
    use proptest::prelude::*;

    /// Random depths in `[0, 1)`, one sample in 7 uncovered (infinite).
    fn depths(w: u32, h: u32, seed: u64) -> Vec<f32> {
        let mut rng = Rng::new(seed);
        (0..w * h)
            .map(|_| match rng.below(7) {
                0 => f32::INFINITY,
                _ => rng.unit(),
            })
            .collect()
    }

    proptest! {
        #[test]
        fn every_level_is_the_brute_force_max_reduction(w in 1u32..70, h in 1u32..70, seed in any::<u64>()) {
            let d = depths(w, h, seed);
            let mut p = ZPyramid::default();
            p.build(w, h, &d);
            prop_assert_eq!(p.levels().last().map(|l| (l.width, l.height)), Some((1, 1)));
            for (k, l) in p.levels().iter().enumerate() {
                prop_assert_eq!((l.width, l.height), (w.div_ceil(1 << k), h.div_ceil(1 << k)));
                for ty in 0..l.height {
                    for tx in 0..l.width {
                        let mut m = f32::NEG_INFINITY;
                        for y in (ty << k)..((ty + 1) << k).min(h) {
                            for x in (tx << k)..((tx + 1) << k).min(w) {
                                m = m.max(d[(y * w + x) as usize]);
                            }
                        }
                        prop_assert_eq!(l.depth(tx, ty), m, "level {} texel {},{}", k, tx, ty);
                    }
                }
            }
        }

        #[test]
        fn is_behind_equals_the_brute_force_depth_test(
            w in 1u32..60, h in 1u32..60, seed in any::<u64>(),
            a in (0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0), z in 0.0f32..1.2,
        ) {
            let d = depths(w, h, seed);
            let mut p = ZPyramid::default();
            p.build(w, h, &d);
            let (xa, xb) = ((a.0 * w as f32) as u32, (a.1 * w as f32) as u32);
            let (ya, yb) = ((a.2 * h as f32) as u32, (a.3 * h as f32) as u32);
            let r = ScreenRect { x0: xa.min(xb), x1: xa.max(xb) + 1, y0: ya.min(yb), y1: ya.max(yb) + 1, z_near: z, z_far: z };
            let r = ScreenRect { x1: r.x1.min(w), y1: r.y1.min(h), ..r };
            let brute = (r.y0..r.y1).all(|y| (r.x0..r.x1).all(|x| z > d[(y * w + x) as usize] + DEPTH_MARGIN));
            let hzb = p.is_behind(&r, &mut ZTestStats::default());
            // Never occluded where a sample is visible; and since level 0 is per
            // sample, the test is exact.
            prop_assert!(!hzb || brute, "hzb culls a visible rect {:?}", r);
            prop_assert_eq!(hzb, brute);
        }
    }

    proptest! {
        /// After any sequence of sample writes, each followed by
        /// `update_rect` over the written rectangle, every level equals the
        /// brute-force rebuild from level 0.
        #[test]
        fn incremental_updates_equal_a_rebuild(
            w in 1u32..50, h in 1u32..50, seed in any::<u64>(),
            writes in proptest::collection::vec((0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0), 1..30),
        ) {
            let mut p = ZPyramid::default();
            p.reset(w, h, 1.0);
            let d = depths(w, h, seed);
            p.base_mut().copy_from_slice(&d);
            p.update_rect(0, 0, w, h);
            for (a, b, c, e, z) in writes {
                let (xa, xb) = ((a * w as f32) as u32, (b * w as f32) as u32);
                let (ya, yb) = ((c * h as f32) as u32, (e * h as f32) as u32);
                let (x0, x1, y0, y1) = (xa.min(xb), xa.max(xb) + 1, ya.min(yb), ya.max(yb) + 1);
                let (x1, y1) = (x1.min(w), y1.min(h));
                // Any values, nearer or farther, inside the rectangle.
                for y in y0..y1 {
                    for x in x0..x1 {
                        let i = (y * w + x) as usize;
                        let old = p.levels()[0].texels()[i];
                        p.base_mut()[i] = if (x + y) % 3 == 0 { z } else { old.min(z * 0.5) };
                    }
                }
                p.update_rect(x0, y0, x1, y1);
            }
            let mut fresh = ZPyramid::default();
            fresh.build(w, h, p.levels()[0].texels());
            prop_assert_eq!(p.levels().len(), fresh.levels().len());
            for (k, (a, b)) in p.levels().iter().zip(fresh.levels()).enumerate() {
                prop_assert_eq!((a.width, a.height), (b.width, b.height));
                prop_assert!(a.texels() == b.texels(), "level {} differs", k);
            }
        }
    }

    #[test]
    fn reset_fills_every_level() {
        let mut p = ZPyramid::default();
        p.build(5, 3, &[0.5; 15]);
        p.reset(9, 4, 1.0);
        assert_eq!(p.viewport(), (9, 4));
        let sizes: Vec<(u32, u32)> = p.levels().iter().map(|l| (l.width, l.height)).collect();
        assert_eq!(sizes, vec![(9, 4), (5, 2), (3, 1), (2, 1), (1, 1)]);
        assert!(p.levels().iter().all(|l| l.texels().iter().all(|&t| t == 1.0)));
    }

    #[test]
    fn uncovered_samples_hide_nothing() {
        let mut d = vec![0.1; 16 * 16];
        d[5 * 16 + 7] = f32::INFINITY;
        let mut p = ZPyramid::default();
        p.build(16, 16, &d);
        let full = ScreenRect {
            x0: 0,
            y0: 0,
            x1: 16,
            y1: 16,
            z_near: 0.9,
            z_far: 1.0,
        };
        assert!(!p.is_behind(&full, &mut ZTestStats::default()));
        let left = ScreenRect { x1: 7, ..full };
        assert!(p.is_behind(&left, &mut ZTestStats::default()));
    }
}
