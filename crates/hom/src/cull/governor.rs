//! Occlusion culling that pays for itself, after M. Guthe, Á. Balázs and
//! R. Klein, "Near optimal hierarchical culling: performance driven use of
//! hardware occlusion queries" (EGSR 2006): spend a test only where its
//! expected saving exceeds its cost. Here the test is the whole frame's
//! occlusion work (occluder selection, raster, occlusion traversal), and the
//! alternative is frustum culling alone, which is never wrong.
//!
//! The governor learns from the frames the caller timed
//! ([`super::Culler::frame_done`]):
//! - the renderer's cost per triangle: the slope of render time against
//!   triangles drawn, a least-squares fit that forgets old frames (the frames
//!   of a walk draw very different counts, and resting frames draw more),
//!   kept within a quarter of the mean ratio and the mean ratio;
//! - the occlusion work's cost over frustum culling's, as moving averages;
//! - the triangles it culled as occluded in the last two full frames.
//!
//! Until the fit has seen [`WARM_UP`] frames, a triangle costs the mean ratio
//! of render time to triangles, the most the fit would price it.
//!
//! When the triangles culled, at the learnt cost, would have rendered in less
//! than half the time the occlusion work took, in two full frames running, it
//! rests: the next frames are frustum culled only. Then it probes with one full frame; a probe that still does
//! not pay doubles the rest (2 up to [`MAX_REST`] frames), one that pays
//! ends resting. Without frame times (an engine that does not report them)
//! it never rests. Resting draws more, never less: it cannot cull wrongly.

/// Longest rest between probes, in frames: occlusion that appears while
/// resting is found within this many frames.
pub(crate) const MAX_REST: u32 = 16;
/// First rest after occlusion stopped paying, in frames. Short, because
/// occlusion comes back quickly where a walk enters a room or turns a corner
/// (office walk, masked, 200 frames: speedup 1.42 with 4, 1.52 with 2; 1.49
/// without the cost model).
const MIN_REST: u32 = 2;
/// Timed frames before the fit's slope prices a triangle: it needs a spread
/// of triangle counts (before, the mean ratio does).
const WARM_UP: u32 = 8;
/// Weight of an old frame in the fit and the averages after one more frame.
const FORGET: f64 = 0.9;

/// What one frame did, recorded by the culler before its feedback.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct FrameFacts {
    /// Whether the occlusion work ran (not a resting frame).
    pub culled: bool,
    /// The culler's own time, ms.
    pub cull_ms: f64,
    /// Triangles drawn (visible objects).
    pub drawn: u64,
    /// Triangles culled as occluded.
    pub occluded: u64,
}

/// An exponentially forgetting mean.
#[derive(Clone, Copy, Debug, Default)]
struct Mean {
    weight: f64,
    sum: f64,
}

impl Mean {
    fn add(&mut self, x: f64) {
        self.weight = self.weight * FORGET + 1.0;
        self.sum = self.sum * FORGET + x;
    }

    fn get(&self) -> Option<f64> {
        (self.weight > 0.0).then(|| self.sum / self.weight)
    }
}

/// Weighted least squares of `y` on `x`, forgetting old points.
#[derive(Clone, Copy, Debug, Default)]
struct Fit {
    w: f64,
    x: f64,
    y: f64,
    xx: f64,
    xy: f64,
}

impl Fit {
    fn add(&mut self, x: f64, y: f64) {
        let k = FORGET;
        *self = Fit {
            w: self.w * k + 1.0,
            x: self.x * k + x,
            y: self.y * k + y,
            xx: self.xx * k + x * x,
            xy: self.xy * k + x * y,
        };
    }

    /// The mean ratio of `y` to `x`: the cost of one more `x` were there no
    /// fixed cost, an upper bound of [`Fit::marginal`].
    fn ratio(&self) -> Option<f64> {
        if self.w <= 0.0 || self.x <= 0.0 {
            return None;
        }
        Some((self.y / self.x).max(0.0))
    }

    /// Cost of one more `x`: the slope, within a quarter of the mean ratio
    /// and the mean ratio (which counts the fixed cost too, so bounds it
    /// above). The floor keeps a noisy slope over frames that draw much the
    /// same from calling triangles free: on the metropolis walk (render time
    /// ±20 % at ±8 % triangles) an unbounded slope fell to 0 and rested frames
    /// where culling saved 80 ms. The mean ratio when the points' spread is too
    /// small for a slope.
    fn marginal(&self) -> Option<f64> {
        let ratio = self.ratio()?;
        let (mx, my) = (self.x / self.w, self.y / self.w);
        let var = self.xx / self.w - mx * mx;
        if var <= (0.05 * mx).powi(2) {
            return Some(ratio);
        }
        let slope = (self.xy / self.w - mx * my) / var;
        Some(slope.clamp(0.25 * ratio, ratio))
    }
}

/// The per-frame decision between the occlusion work and frustum culling alone.
#[derive(Clone, Debug)]
pub(crate) struct Governor {
    enabled: bool,
    /// Render ms against triangles drawn.
    render: Fit,
    /// Full frames' cull ms.
    cull_ms: Mean,
    /// Resting frames' cull ms (frustum culling alone).
    rest_ms: Mean,
    /// The last full frame's occluded triangles.
    last_occluded: Option<u64>,
    timed: u32,
    facts: Option<FrameFacts>,
    /// Whether the last timed frame rested (the next full one is a probe).
    rested: bool,
    rest_left: u32,
    rest_len: u32,
}

impl Governor {
    /// A governor that rests when occlusion stops paying, or (`enabled` false) never.
    pub fn new(enabled: bool) -> Governor {
        Governor {
            enabled,
            render: Fit::default(),
            cull_ms: Mean::default(),
            rest_ms: Mean::default(),
            last_occluded: None,
            timed: 0,
            facts: None,
            rested: false,
            rest_left: 0,
            rest_len: MIN_REST,
        }
    }

    /// Whether the cost model runs.
    pub fn is_enabled(&self) -> bool {
        self.enabled
    }

    /// Whether this frame rests (frustum culling only); counts it down.
    pub fn rests(&mut self) -> bool {
        if self.rest_left == 0 {
            return false;
        }
        self.rest_left -= 1;
        true
    }

    /// Records what this frame did, for [`Governor::feedback`].
    pub fn record(&mut self, facts: FrameFacts) {
        self.facts = Some(facts);
    }

    /// The frame's total time (cull + render) when the caller measured it:
    /// learns, and after a full frame decides whether to rest.
    pub fn feedback(&mut self, frame_ms: Option<f64>) {
        let (Some(f), Some(ms)) = (self.facts.take(), frame_ms) else {
            return;
        };
        if !self.enabled || !ms.is_finite() {
            return;
        }
        self.timed += 1;
        self.render.add(f.drawn as f64, (ms - f.cull_ms).max(0.0));
        let probe = std::mem::replace(&mut self.rested, !f.culled);
        if !f.culled {
            self.rest_ms.add(f.cull_ms);
            return;
        }
        self.cull_ms.add(f.cull_ms);
        let last = self.last_occluded.replace(f.occluded);
        // Before the fit has its spread of triangle counts, a triangle is
        // priced at the mean ratio, the most the fit ever prices it: work
        // that does not pay even so is rested at once, not after the
        // warm-up (oa_ctf2old, 3,972 triangles: 16 full frames of 0.5 ms to
        // cull 150 triangles a frame, 7 % of a 100-frame walk's time).
        let price = if self.timed < WARM_UP {
            self.render.ratio()
        } else {
            self.render.marginal()
        };
        let (Some(per_triangle), Some(cull)) = (price, self.cull_ms.get()) else {
            return;
        };
        // A probe judges by what it found; a culling frame rests only when
        // neither it nor the frame before paid (one poor frame is not a trend).
        let occluded = match last {
            Some(last) if !probe => f.occluded.max(last),
            _ => f.occluded,
        } as f64;
        // Culling nothing never pays, even when the work costs no measurable
        // time. Rest only when the saving is under half the cost: the model
        // counts triangles, not the pixels and overdraw that occlusion saves
        // too, so near the break-even it keeps culling (six walks, speedup
        // where culling pays, without the model / with the rule at 1x / at
        // 0.5x the cost: city 1.66 / 1.67 / 1.65, office 1.63 / 1.58 / 1.63,
        // terrain 1.07 / 1.04 / 1.06; where it does not, spheres 0.94 / 1.04
        // / 1.05, machine-room 0.92 / 0.99 / 0.98).
        let cost = (cull - self.rest_ms.get().unwrap_or(0.0)).max(0.0);
        if per_triangle * occluded <= 0.5 * cost {
            self.rest_left = self.rest_len;
            self.rest_len = (self.rest_len * 2).min(MAX_REST);
        } else {
            self.rest_len = MIN_REST;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A renderer costing 1 ms plus 1 µs per triangle drawn; occlusion work
    /// costing `cull_ms` and culling `occluded` of 20,000 triangles in view.
    /// Returns which of `frames` frames rested.
    fn run(g: &mut Governor, frames: usize, cull_ms: f64, occluded: impl Fn(usize) -> u64) -> Vec<bool> {
        (0..frames)
            .map(|i| {
                let rest = g.rests();
                let (cull, occ) = if rest { (0.05, 0) } else { (cull_ms, occluded(i)) };
                let drawn = 20_000 - occ;
                g.record(FrameFacts {
                    culled: !rest,
                    cull_ms: cull,
                    drawn,
                    occluded: occ,
                });
                g.feedback(Some(cull + 1.0 + drawn as f64 * 1e-3));
                rest
            })
            .collect()
    }

    #[test]
    fn keeps_culling_while_it_pays() {
        let mut g = Governor::new(true);
        // Culls 5,000-10,000 triangles (5-10 ms) for 1 ms.
        let rested = run(&mut g, 200, 1.0, |i| 5_000 + (i as u64 * 37) % 5_000);
        assert!(!rested.contains(&true));
    }

    #[test]
    fn rests_when_culling_stops_paying_probes_and_comes_back() {
        let mut g = Governor::new(true);
        // Pays for 50 frames, culls nothing for 200, then pays again.
        let occluded = |i: usize| {
            if (50..250).contains(&i) {
                0
            } else {
                5_000 + (i as u64 * 37) % 5_000
            }
        };
        let rested = run(&mut g, 400, 1.0, occluded);
        assert!(!rested[..51].contains(&true), "no rest while it pays");
        let idle = rested[60..250].iter().filter(|&&r| r).count();
        assert!(
            idle as f64 > 0.9 * 190.0,
            "rests {idle} of 190 frames that cull nothing"
        );
        // Back within one longest rest and a probe, and stays.
        assert!(!rested[250 + MAX_REST as usize + 1..].contains(&true));
    }

    #[test]
    fn work_that_never_pays_rests_from_the_start() {
        let mut g = Governor::new(true);
        // Culls 100 triangles (0.1 ms at the most) for 1 ms from the first frame.
        let rested = run(&mut g, 40, 1.0, |_| 100);
        assert!(rested[2], "rests after two frames that did not pay: {rested:?}");
        let full = rested.iter().filter(|&&r| !r).count();
        assert!(full <= 7, "only probes after that: {full} full frames of 40");
    }

    #[test]
    fn noisy_render_times_over_similar_counts_do_not_make_triangles_free() {
        // Metropolis-like: 170-200k triangles drawn, 650k culled for 8 ms,
        // render 0.2 µs a triangle with ±20 % noise.
        let mut g = Governor::new(true);
        for i in 0..200u64 {
            assert!(!g.rests(), "frame {i} rested");
            let drawn = 170_000 + (i * 7919) % 30_000;
            let noise = 1.0 + 0.2 * (((i * 104_729) % 1000) as f64 / 500.0 - 1.0);
            g.record(FrameFacts {
                culled: true,
                cull_ms: 8.0,
                drawn,
                occluded: 650_000,
            });
            g.feedback(Some(8.0 + drawn as f64 * 2e-4 * noise));
        }
    }

    #[test]
    fn never_rests_without_frame_times_or_when_disabled() {
        let mut g = Governor::new(true);
        for _ in 0..100 {
            assert!(!g.rests());
            g.record(FrameFacts {
                culled: true,
                cull_ms: 5.0,
                drawn: 100,
                occluded: 0,
            });
            g.feedback(None);
        }
        let mut off = Governor::new(false);
        assert!(!run(&mut off, 100, 5.0, |_| 0).contains(&true));
    }

    #[test]
    fn the_fit_finds_the_marginal_cost_under_a_fixed_one() {
        let mut f = Fit::default();
        for i in 0..50 {
            let x = 1_000.0 + (i * 613 % 9_000) as f64;
            f.add(x, 2.0 + 0.001 * x);
        }
        let m = f.marginal().unwrap();
        assert!((m - 0.001).abs() < 1e-6, "{m}");
        let mut flat = Fit::default();
        for _ in 0..10 {
            flat.add(1_000.0, 3.0);
        }
        let m = flat.marginal().unwrap();
        assert!((m - 0.003).abs() < 1e-12, "no spread: the mean ratio, {m}");
    }
}
