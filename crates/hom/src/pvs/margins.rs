//! The margins every PVS occlusion test keeps so the renderer agrees (Law &
//! Tan 1999, section 5.3, made conservative for hom's oracle; the argument is
//! in `region.rs`, "Margins, so the renderer agrees"): how far inside an
//! occluder a segment must cross, how far an occludee's box is grown, and
//! the box helpers both the region test and the planar unions use.

use crate::geom::Aabb;
use glam::{DVec3, Vec3};

/// How far inside its boundary a segment must cross an occluder
/// (`lateral`), and how far the occludee's box is grown (`gap`), in metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Margins {
    pub(crate) lateral: f64,
    pub(crate) gap: f64,
}

/// Lateral margin per metre of distance: 1e-4 rad is 1/256 pixel (the snap)
/// at a 60° field of view down to 45 rows, with room to spare at any real
/// viewport; so a sample ray through the pulled-in occluder stays covered
/// however hom's rule snaps its vertices.
const LATERAL_PER_METRE: f64 = 1e-4;
/// Depth resolution of `z / w` in `[0, 1]`: 4 `f32` ulps at 1.0. A world
/// distance `d` resolves to `DEPTH_ULPS * d² / near` metres.
const DEPTH_ULPS: f64 = 4.0 * f32::EPSILON as f64;

impl Margins {
    /// Margins for a cell and an occludee box: `base` metres (the bake's
    /// absolute margin) plus what the farthest distance between them needs
    /// at the nearest near plane `near` the PVS serves.
    pub(crate) fn for_pair(cell: &Aabb, x: &Aabb, base: f64, near: f64) -> Margins {
        let far = cell.union(*x).extent().as_dvec3().length();
        let lateral = base + LATERAL_PER_METRE * far;
        Margins {
            lateral,
            gap: lateral + DEPTH_ULPS * far * far / near,
        }
    }
}

/// The corners of `x` grown by `gap` on every side, in `f64` (the growth
/// exact, not rounded back to the box's `f32`).
pub(crate) fn grown_corners(x: &Aabb, gap: f64) -> [DVec3; 8] {
    let g = DVec3::splat(gap);
    let (lo, hi) = (x.min.as_dvec3() - g, x.max.as_dvec3() + g);
    std::array::from_fn(|i| DVec3::select(glam::BVec3::new(i & 1 != 0, i & 2 != 0, i & 4 != 0), hi, lo))
}

/// The smallest distance between two boxes (0 when they touch or overlap).
pub(crate) fn box_distance(a: &Aabb, b: &Aabb) -> f32 {
    let gap = (a.min - b.max).max(b.min - a.max).max(Vec3::ZERO);
    gap.length()
}
