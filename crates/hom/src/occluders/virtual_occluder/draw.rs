//! Drawing a virtual occluder (Law & Tan 1999, section 4: a stand-in may
//! hide only what the original hides): its boxes as their silhouettes, the
//! rest as stand-in triangles by the inner rule, and the per-frame check of
//! section 4.1's condition (the eye outside the solids, above a floor cap).

use super::VirtualOccluder;
use crate::geom::{Aabb, Eye, Frustum};
use crate::occlusion::{FaceCull, OcclusionBuffer, OcclusionError};
use glam::{Mat4, Vec3};
use std::ops::Range;

impl VirtualOccluder {
    /// Queues the stand-in in `buffer` as the cullers draw it, placed by
    /// `model_to_clip` (the buffer's clip convention): its boxes as their
    /// shrunk silhouettes ([`OcclusionBuffer::render_convex_stand_in`]), the
    /// rest as stand-in triangles ([`OcclusionBuffer::render_stand_in_triangles`]).
    pub fn render(&self, buffer: &mut impl OcclusionBuffer, model_to_clip: &Mat4) -> Result<(), OcclusionError> {
        draw_stand_in(
            buffer,
            self.mesh.positions(),
            self.mesh.triangles(),
            self.box_pieces(),
            model_to_clip,
            true,
        )
    }

    /// The triangle ranges of [`VirtualOccluder::mesh`] that are boxes, in order.
    pub(crate) fn box_pieces(&self) -> &[Range<u32>] {
        &self.convex_pieces[..self.boxes]
    }

    /// Whether the stand-in may replace the original of an object placed by
    /// `transform` with world box `world_box`, seen from `eye` through
    /// `frustum`: the box wholly beyond the near plane (the eye is outside
    /// the solids and nothing of the original is clipped), and above the
    /// floor when there is one.
    pub fn usable(&self, transform: &Mat4, world_box: &Aabb, eye: &Eye, frustum: &Frustum) -> bool {
        if !frustum.beyond_near(world_box) {
            return false;
        }
        let Some(floor) = self.floor else {
            return true;
        };
        let inverse = transform.inverse();
        match eye {
            Eye::Point(p) => inverse.transform_point3(*p).y > floor,
            // Depth grows along `d`: rays come down onto the floor from above.
            Eye::Direction(d) => inverse.transform_vector3(*d).y < 0.0,
        }
    }
}

/// Queues a stand-in's triangles: each box among them (`boxes`, triangle
/// ranges in order) as its silhouette when the stand-in lies wholly beyond
/// the near plane ([`OcclusionBuffer::render_convex_stand_in`]: a box's 12
/// triangles become a fan of at most 6), the rest two-sided by the inner
/// rule, in as few submissions as the order allows. (`beyond_near` false
/// skips the boxes: every corner would be checked and refused.)
pub(crate) fn draw_stand_in(
    buffer: &mut impl OcclusionBuffer,
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    boxes: &[Range<u32>],
    model_to_clip: &Mat4,
    beyond_near: bool,
) -> Result<(), crate::occlusion::OcclusionError> {
    let two_sided = |buffer: &mut _, run: Range<usize>| -> Result<(), crate::occlusion::OcclusionError> {
        if run.is_empty() {
            return Ok(());
        }
        OcclusionBuffer::render_stand_in_triangles(buffer, positions, &triangles[run], model_to_clip, FaceCull::None)
    };
    // Triangles not yet queued start here.
    let mut next = 0;
    for piece in boxes.iter().filter(|_| beyond_near) {
        let piece = piece.start as usize..piece.end as usize;
        debug_assert!(piece.start >= next, "box pieces in order, apart");
        two_sided(buffer, next..piece.start)?;
        buffer.render_convex_stand_in(positions, &triangles[piece.clone()], model_to_clip)?;
        next = piece.end;
    }
    two_sided(buffer, next..triangles.len())
}
