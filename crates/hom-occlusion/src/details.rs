//! Building blocks behind the front door, public for the rest of the
//! workspace: hom's cullers (the rectangle test, the hole search, HV's live
//! Z-pyramid), the reference renderer (the triangle setup and sampling rule
//! it shares with every buffer: [`setup`]), the pictures (the pyramids and
//! z-buffers a culler's diagnostic accessors return) and the kernel benches.
//! An engine needs none of it; its shapes may change with the algorithms.

pub use crate::buffer::{RectTest, DEPTH_MARGIN};
pub use crate::closed_mesh::{faces_turned_away, height_field};
pub use crate::hzb::zbuffer::{Dirty, ZDrawStats, ZTarget, NO_OBJECT};
pub use crate::hzb::{TiledZBuffer, ZLevel, ZPyramid, ZTestStats};
pub use crate::masked::MaskedZBuffer;
pub use crate::occlusion_map::{
    find_worst_hole, rect_covered, worst_hole_of_coverage, CoverageBuffer, DepthEstimationBuffer, Hole, Level,
    OverlapStats, Pyramid, SingleZPlane, Thresholds,
};
pub use crate::raster::setup;
pub use crate::raster::setup_triangles;
pub use crate::sample_depth::{SampleDepthStats, SampleDepths};
pub use crate::weld::{number_welded, weld};

/// Bytes a vector holds on the heap (its capacity), for the memory counters.
pub fn vec_bytes<T>(v: &Vec<T>) -> usize {
    crate::vec_bytes(v)
}

/// What `buffer` covers, on a `width` × `height` grid over its viewport
/// (row-major, row 0 at the top): 255 where the middle half of a cell is
/// hidden at a depth just short of the far plane, else 0. For debug views:
/// hom-bevy's `OcclusionDebugView` and `hom view`'s inset.
pub fn coverage(buffer: &mut dyn crate::OcclusionBuffer, width: u32, height: u32) -> Vec<u8> {
    use glam::Vec2;
    let shared = buffer.share();
    let cell = Vec2::new(2.0 / width as f32, 2.0 / height as f32);
    let mut out = Vec::with_capacity(width as usize * height as usize);
    for y in 0..height {
        for x in 0..width {
            // The cell's centre in NDC (y up).
            let centre = Vec2::new(-1.0 + (x as f32 + 0.5) * cell.x, 1.0 - (y as f32 + 0.5) * cell.y);
            let hidden = shared.test_rect(centre - cell * 0.25, centre + cell * 0.25, 0.999_999);
            out.push(if hidden == crate::Visibility::Occluded { 255 } else { 0 });
        }
    }
    out
}
