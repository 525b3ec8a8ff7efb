//! Triangles waiting for setup: what an occlusion buffer collects between
//! `clear` and its first test. Submission only transforms and copies; the
//! setup ([`super::setup`]: clip, snap, edge functions) of everything queued
//! runs at once, in parallel, in submission order.

use super::setup::{setup_triangle_with, FaceCull, SetupRule, Tri, Vertex, Viewport};
use super::simd::RasterBackend;
use super::simd_setup::{setup_clip4, SETUP_LANES};
use glam::{Mat4, Vec3, Vec4};
use rayon::prelude::*;

/// Triangles set up per parallel task: small enough that a culler's few
/// thousand occluder triangles still split evenly over the threads.
const SETUP_CHUNK: usize = 512;

/// Most triangles a queue holds (64 Mi): more in one frame is a runaway caller.
pub const MAX_QUEUED_TRIANGLES: usize = 1 << 26;

/// Why a submission was refused (the occlusion buffers turn these into their
/// public error type).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum QueueError {
    /// Triangle `triangle` names vertex `index` of `vertex_count`.
    Index {
        triangle: usize,
        index: u32,
        vertex_count: usize,
    },
    /// The queue would exceed [`MAX_QUEUED_TRIANGLES`] or `u32` vertex indices.
    Full { queued: usize, adding: usize },
}

/// One submission: its first triangle, which winding it drops, and whether
/// it is set up by the inner rule whatever the buffer's sampling.
#[derive(Clone, Copy, Debug)]
struct Batch {
    first: usize,
    cull: FaceCull,
    inner: bool,
}

/// Clip-space triangles in submission order, with their face culling; see the module docs.
#[derive(Clone, Debug, Default)]
pub(crate) struct TriangleQueue {
    /// Clip-space vertices, hom's convention (clip `0 <= z <= w`).
    verts: Vec<Vec4>,
    /// Indices into `verts`.
    tris: Vec<[u32; 3]>,
    batches: Vec<Batch>,
}

impl TriangleQueue {
    /// Forgets everything queued. Batch `k` of the next submissions sets up
    /// triangles with `item = k`.
    pub fn clear(&mut self) {
        self.verts.clear();
        self.tris.clear();
        self.batches.clear();
    }

    /// True when nothing is queued.
    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    fn check(&self, indices: &[[u32; 3]], vertex_count: usize) -> Result<(), QueueError> {
        if let Some((triangle, index)) = indices
            .iter()
            .enumerate()
            .find_map(|(i, t)| t.iter().find(|&&v| v as usize >= vertex_count).map(|&v| (i, v)))
        {
            return Err(QueueError::Index {
                triangle,
                index,
                vertex_count,
            });
        }
        let full = self.tris.len() + indices.len() > MAX_QUEUED_TRIANGLES
            || self.verts.len() + vertex_count > u32::MAX as usize;
        if full {
            return Err(QueueError::Full {
                queued: self.tris.len(),
                adding: indices.len(),
            });
        }
        Ok(())
    }

    fn push_indices(&mut self, base: usize, indices: &[[u32; 3]], cull: FaceCull, inner: bool) {
        self.batches.push(Batch {
            first: self.tris.len(),
            cull,
            inner,
        });
        let base = base as u32;
        self.tris.extend(indices.iter().map(|t| t.map(|i| base + i)));
    }

    /// Queues `indices` over `positions` transformed by `model_to_clip`
    /// (which must already produce hom's clip convention).
    #[cfg(test)]
    pub fn push_model(
        &mut self,
        positions: &[Vec3],
        indices: &[[u32; 3]],
        model_to_clip: &Mat4,
        cull: FaceCull,
    ) -> Result<(), QueueError> {
        self.push_model_with(positions, indices, model_to_clip, cull, false)
    }

    /// [`TriangleQueue::push_model`], set up by the inner rule when `inner`
    /// whatever the rule asked at setup.
    pub fn push_model_with(
        &mut self,
        positions: &[Vec3],
        indices: &[[u32; 3]],
        model_to_clip: &Mat4,
        cull: FaceCull,
        inner: bool,
    ) -> Result<(), QueueError> {
        self.check(indices, positions.len())?;
        let base = self.verts.len();
        self.verts
            .extend(positions.iter().map(|p| *model_to_clip * p.extend(1.0)));
        self.push_indices(base, indices, cull, inner);
        Ok(())
    }

    /// Queues `indices` over clip-space `vertices`, each mapped by `to_hom`
    /// into hom's clip convention.
    pub fn push_clip(
        &mut self,
        vertices: &[Vec4],
        indices: &[[u32; 3]],
        to_hom: impl Fn(Vec4) -> Vec4,
        cull: FaceCull,
    ) -> Result<(), QueueError> {
        self.check(indices, vertices.len())?;
        let base = self.verts.len();
        self.verts.extend(vertices.iter().map(|&v| to_hom(v)));
        self.push_indices(base, indices, cull, false);
        Ok(())
    }

    /// Sets up every queued triangle for `vp` into `out` (cleared first), in
    /// submission order, each fan piece with `item` = its batch's index.
    /// Non-finite vertices, triangles outside the view and culled windings
    /// produce nothing. Uses the current rayon pool and
    /// [`RasterBackend::active`].
    #[cfg(test)]
    pub fn set_up(&mut self, vp: &Viewport, inner: bool, out: &mut Vec<Tri>) {
        self.set_up_with(RasterBackend::active(), vp, inner, out);
    }

    /// [`TriangleQueue::set_up`] with `backend`'s vector setup for runs of
    /// four triangles that need no clipping (the same triangles, bit for bit).
    pub fn set_up_with(&mut self, backend: RasterBackend, vp: &Viewport, inner: bool, out: &mut Vec<Tri>) {
        out.clear();
        let (verts, batches) = (&self.verts, &self.batches);
        let chunks: Vec<Vec<Tri>> = self
            .tris
            .par_chunks(SETUP_CHUNK)
            .enumerate()
            .map(|(k, chunk)| {
                let first = k * SETUP_CHUNK;
                // The batch holding the chunk's first triangle, then onwards.
                let mut b = batches.partition_point(|b| b.first <= first) - 1;
                let mut out = Vec::with_capacity(chunk.len());
                let mut i = 0;
                while i < chunk.len() {
                    while b + 1 < batches.len() && batches[b + 1].first <= first + i {
                        b += 1;
                    }
                    let rule = SetupRule {
                        cull: batches[b].cull,
                        inner: inner || batches[b].inner,
                    };
                    // Four of one batch at once; where one of them is clipped,
                    // all four by the scalar setup (not tried again from the next).
                    let batch_end = batches.get(b + 1).map_or(usize::MAX, |n| n.first);
                    let group = i + SETUP_LANES <= chunk.len() && first + i + SETUP_LANES <= batch_end;
                    let n = if group { SETUP_LANES } else { 1 };
                    if group {
                        let corners: [[Vec4; 3]; SETUP_LANES] =
                            std::array::from_fn(|l| chunk[i + l].map(|v| verts[v as usize]));
                        if setup_clip4(backend, &corners, vp, rule, [b as u32; SETUP_LANES], &mut out) {
                            i += n;
                            continue;
                        }
                    }
                    for t in &chunk[i..i + n] {
                        let [p, q, r] = t.map(|v| Vertex::new(verts[v as usize], vp));
                        setup_triangle_with([&p, &q, &r], vp, rule, b as u32, [0; 4], &mut out);
                    }
                    i += n;
                }
                out
            })
            .collect();
        for c in chunks {
            out.extend(c);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn batches_keep_their_rule_and_index_across_chunks() {
        // Many one-triangle batches alternating the culled winding, more than a chunk.
        let ccw = [
            Vec4::new(-0.5, -0.5, 0.5, 1.0),
            Vec4::new(0.5, -0.5, 0.5, 1.0),
            Vec4::new(0.0, 0.5, 0.5, 1.0),
        ];
        let mut q = TriangleQueue::default();
        let n = SETUP_CHUNK * 2 + 7;
        for k in 0..n {
            let cull = if k % 2 == 0 {
                FaceCull::Clockwise
            } else {
                FaceCull::CounterClockwise
            };
            q.push_clip(&ccw, &[[0, 1, 2]], |v| v, cull).unwrap();
        }
        let mut out = Vec::new();
        q.set_up(&Viewport::new(32, 32), false, &mut out);
        // The counter-clockwise triangle survives only where clockwise ones are dropped.
        let items: Vec<u32> = out.iter().map(|t| t.item).collect();
        let want: Vec<u32> = (0..n as u32).filter(|k| k % 2 == 0).collect();
        assert_eq!(items, want);
    }

    #[test]
    fn bad_indices_and_overflow_are_refused() {
        let mut q = TriangleQueue::default();
        let v = [Vec3::ZERO; 3];
        assert_eq!(
            q.push_model(&v, &[[0, 1, 2], [0, 3, 1]], &Mat4::IDENTITY, FaceCull::None),
            Err(QueueError::Index {
                triangle: 1,
                index: 3,
                vertex_count: 3
            })
        );
        assert!(q.is_empty(), "a refused submission queues nothing");
        q.push_model(&v, &[[0, 1, 2]], &Mat4::IDENTITY, FaceCull::None).unwrap();
        assert!(!q.is_empty());
    }
}
