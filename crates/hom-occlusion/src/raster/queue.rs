//! Triangles waiting for setup: what an occlusion buffer collects between
//! `clear` and its first test. Submission only transforms and copies; the
//! setup ([`super::setup`]: clip, snap, edge functions) of everything queued
//! runs at once, in parallel, in submission order.

use super::setup::{FaceCull, SetupRule, Tri, Viewport};
use super::silhouette::{silhouette, Scratch};
use super::simd::RasterBackend;
use super::simd_setup::{set_up_four, set_up_one, SETUP_LANES};
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
/// it is set up by the inner rule whatever the buffer's sampling; for a
/// convex stand-in, its corners (`verts[first..first + count]`), drawn as
/// its silhouette where it can be ([`super::silhouette`]).
#[derive(Clone, Copy, Debug)]
struct Batch {
    first: usize,
    cull: FaceCull,
    inner: bool,
    corners: Option<(u32, u32)>,
}

/// How a queue is set up.
#[derive(Clone, Copy, Debug)]
pub(crate) struct QueueSetup {
    /// The vector backend of runs of four triangles that need no clipping
    /// (the same triangles as the scalar setup, bit for bit).
    pub backend: RasterBackend,
    /// The viewport set up for.
    pub viewport: Viewport,
    /// The inner rule for every triangle (conservative sampling), else
    /// for the batches that ask for it.
    pub inner: bool,
    /// Whether the work may go to the current rayon pool's threads (else
    /// all of it runs on the calling thread: [`crate::Threads`]).
    pub parallel: bool,
}

/// Clip-space triangles in submission order, with their face culling; see the module docs.
#[derive(Clone, Debug, Default)]
pub(crate) struct TriangleQueue {
    /// Clip-space vertices, hom's convention (clip `0 <= z <= w`).
    verts: Vec<Vec4>,
    /// Indices into `verts`.
    tris: Vec<[u32; 3]>,
    batches: Vec<Batch>,
    /// A convex stand-in's vertices, while it is queued.
    used: Vec<u32>,
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
            corners: None,
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

    /// Queues `indices` over `positions` transformed by `model_to_clip`
    /// (which must already produce hom's clip convention), set up by the
    /// inner rule when `inner` whatever the rule asked at setup.
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

    /// Queues the triangles `indices` of a convex solid inside an occluder
    /// (a stand-in), over `positions` transformed by `model_to_clip` (hom's
    /// clip convention): set up as the solid's shrunk silhouette where it
    /// can be, else as the triangles by the inner rule, two-sided. Only the
    /// vertices the triangles use are queued: they are the solid's corners.
    pub fn push_convex(
        &mut self,
        positions: &[Vec3],
        indices: &[[u32; 3]],
        model_to_clip: &Mat4,
    ) -> Result<(), QueueError> {
        self.check(indices, positions.len())?;
        let base = self.verts.len();
        let (lo, hi) = indices
            .iter()
            .flatten()
            .fold((u32::MAX, 0), |(lo, hi), &i| (lo.min(i), hi.max(i)));
        // Most solids use a short run of vertices, every one of them (a box's 8).
        let run = (hi.wrapping_sub(lo) < 64).then(|| {
            let mask = indices.iter().flatten().fold(0u64, |m, &i| m | 1 << (i - lo));
            mask.count_ones() == hi - lo + 1
        });
        let corners = if run == Some(true) {
            self.verts.extend(
                positions[lo as usize..=hi as usize]
                    .iter()
                    .map(|p| *model_to_clip * p.extend(1.0)),
            );
            self.tris
                .extend(indices.iter().map(|t| t.map(|i| base as u32 + i - lo)));
            hi - lo + 1
        } else {
            self.used.clear();
            self.used.extend(indices.iter().flatten());
            self.used.sort_unstable();
            self.used.dedup();
            let used = &self.used;
            self.verts
                .extend(used.iter().map(|&i| *model_to_clip * positions[i as usize].extend(1.0)));
            let new_index = |i: u32| (base + used.partition_point(|&u| u < i)) as u32;
            self.tris.extend(indices.iter().map(|t| t.map(new_index)));
            used.len() as u32
        };
        self.batches.push(Batch {
            first: self.tris.len() - indices.len(),
            cull: FaceCull::None,
            inner: true,
            corners: Some((base as u32, corners)),
        });
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
        let setup = QueueSetup {
            backend: RasterBackend::active(),
            viewport: *vp,
            inner,
            parallel: true,
        };
        self.set_up_with(&setup, out);
    }

    /// Sets up every queued triangle as `setup` says into `out` (cleared
    /// first): the [`TriangleQueue::set_up_chunk`]s in order, set up in parallel.
    pub fn set_up_with(&self, setup: &QueueSetup, out: &mut Vec<Tri>) {
        out.clear();
        let chunk = |k| {
            let mut out = Vec::new();
            self.set_up_chunk(k, setup, &mut out);
            out
        };
        let chunks: Vec<Vec<Tri>> = if setup.parallel {
            (0..self.chunks()).into_par_iter().map(chunk).collect()
        } else {
            (0..self.chunks()).map(chunk).collect()
        };
        for c in chunks {
            out.extend(c);
        }
    }

    /// How many chunks [`TriangleQueue::set_up_chunk`] sets the queue up in.
    pub fn chunks(&self) -> usize {
        self.tris.len().div_ceil(SETUP_CHUNK)
    }

    /// Appends to `out` what chunk `k` (of [`TriangleQueue::chunks`]) sets
    /// up: the chunks' outputs in order are [`TriangleQueue::set_up_with`]'s.
    pub fn set_up_chunk(&self, k: usize, setup: &QueueSetup, out: &mut Vec<Tri>) {
        let QueueSetup {
            backend,
            viewport: ref vp,
            inner,
            ..
        } = *setup;
        let (verts, batches) = (&self.verts, &self.batches);
        let first = k * SETUP_CHUNK;
        let chunk = &self.tris[first..self.tris.len().min(first + SETUP_CHUNK)];
        // The batch holding the chunk's first triangle, then onwards.
        let mut b = batches.partition_point(|b| b.first <= first) - 1;
        out.reserve(chunk.len());
        let (mut scratch, mut tried) = (Scratch::default(), None);
        // Silhouette triangles of consecutive convex stand-ins, with their
        // batches, set up four at a time before anything queued after them.
        let mut fans: Vec<([Vec4; 3], u32)> = Vec::new();
        // By the exact rule in either sampling: a fan already keeps the inner
        // rule's guarantees (inside the unsnapped outline with a margin, behind
        // the solid), and the inner rule on its chords would open cracks.
        let fan_rule = SetupRule {
            cull: FaceCull::None,
            inner: false,
        };
        let mut i = 0;
        while i < chunk.len() {
            while b + 1 < batches.len() && batches[b + 1].first <= first + i {
                b += 1;
            }
            let batch_end = batches.get(b + 1).map_or(usize::MAX, |n| n.first);
            if let (Some((v, n)), true) = (batches[b].corners, tried != Some(b)) {
                // A convex stand-in: its silhouette, set up by the chunk it starts
                // in (a chunk it continues into asks again, for the answer only).
                tried = Some(b);
                let corners = &verts[v as usize..][..n as usize];
                if let Some(fan) = silhouette(corners, vp, &mut scratch) {
                    if batches[b].first == first + i {
                        fans.extend(fan.iter().map(|&t| (t, b as u32)));
                    }
                    i = (batch_end - first).min(chunk.len());
                    continue;
                }
            }
            set_up_fans(backend, &mut fans, vp, fan_rule, out);
            let rule = SetupRule {
                cull: batches[b].cull,
                inner: inner || batches[b].inner,
            };
            // Four of one batch at once; where one of them is clipped,
            // all four by the scalar setup (not tried again from the next).
            if i + SETUP_LANES <= chunk.len() && first + i + SETUP_LANES <= batch_end {
                let corners = std::array::from_fn(|l| chunk[i + l].map(|v| verts[v as usize]));
                set_up_four(backend, &corners, vp, rule, [b as u32; SETUP_LANES], out);
                i += SETUP_LANES;
            } else {
                set_up_one(chunk[i].map(|v| verts[v as usize]), vp, rule, b as u32, out);
                i += 1;
            }
        }
        set_up_fans(backend, &mut fans, vp, fan_rule, out);
    }
}

/// Sets up and empties `fans` (clip-space triangles with their batches),
/// four at a time by `backend` where none of them needs clipping.
fn set_up_fans(
    backend: RasterBackend,
    fans: &mut Vec<([Vec4; 3], u32)>,
    vp: &Viewport,
    rule: SetupRule,
    out: &mut Vec<Tri>,
) {
    for group in fans.chunks(SETUP_LANES) {
        if let [a, b, c, d] = group {
            set_up_four(backend, &[a.0, b.0, c.0, d.0], vp, rule, [a.1, b.1, c.1, d.1], out);
        } else {
            for &(t, item) in group {
                set_up_one(t, vp, rule, item, out);
            }
        }
    }
    fans.clear();
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

    /// A convex stand-in is set up once, as its silhouette or (in front of
    /// the near plane) as its triangles, also when it straddles two chunks.
    #[test]
    fn convex_stand_ins_are_set_up_once_across_chunks() {
        let cube = hom_testkit::cube();
        let tri = [
            Vec4::new(-0.5, -0.5, 0.5, 1.0),
            Vec4::new(0.5, -0.5, 0.5, 1.0),
            Vec4::new(0.0, 0.5, 0.5, 1.0),
        ];
        let vp = Viewport::new(64, 64);
        // Boxes in view (w from 4 to 6) and through the near plane (z < 0 at some corner).
        let place = |k: usize| {
            let z = if k % 3 == 2 { -0.2 } else { 0.5 };
            Mat4::from_cols(
                Vec4::X,
                Vec4::Y,
                Vec4::new(0.0, 0.0, 0.4, 1.0),
                Vec4::new(0.0, 0.0, z, 4.0 + (k % 3) as f32),
            )
        };
        for lead in [SETUP_CHUNK - 12, SETUP_CHUNK - 7, SETUP_CHUNK - 1, SETUP_CHUNK] {
            let mut q = TriangleQueue::default();
            for _ in 0..lead {
                q.push_clip(&tri, &[[0, 1, 2]], |v| v, FaceCull::None).unwrap();
            }
            let boxes = 50;
            for k in 0..boxes {
                q.push_convex(cube.positions(), cube.triangles(), &place(k)).unwrap();
            }
            let mut out = Vec::new();
            q.set_up(&vp, false, &mut out);
            for k in 0..boxes {
                let item = (lead + k) as u32;
                let got: Vec<&Tri> = out.iter().filter(|t| t.item == item).collect();
                // What this box alone sets up.
                let mut alone = TriangleQueue::default();
                alone
                    .push_convex(cube.positions(), cube.triangles(), &place(k))
                    .unwrap();
                let mut want = Vec::new();
                alone.set_up(&vp, false, &mut want);
                assert!(!want.is_empty(), "box {k} covers something");
                assert_eq!(got.len(), want.len(), "lead {lead}, box {k}");
                for (g, w) in got.iter().zip(&want) {
                    assert_eq!((g.a, g.b, g.c, g.zref), (w.a, w.b, w.c, w.zref), "lead {lead}, box {k}");
                }
            }
            // Items rise: every box's triangles in submission order.
            assert!(out.windows(2).all(|w| w[0].item <= w[1].item));
        }
    }

    /// A convex stand-in whose corners are scattered among other vertices
    /// (the general path) sets up as one whose corners are a run (the fast
    /// path): as its silhouette, and as its triangles through the near plane.
    #[test]
    fn convex_corners_scattered_or_in_a_run_set_up_alike() {
        let cube = hom_testkit::cube();
        // Corner k at 3k + 1 among stray vertices, the last one more than 64 further.
        let at = |k: u32| 3 * k + 1 + if k == 7 { 150 } else { 0 };
        let mut scattered = vec![Vec3::splat(1e6); 200];
        for (k, &p) in cube.positions().iter().enumerate() {
            scattered[at(k as u32) as usize] = p;
        }
        let tris: Vec<[u32; 3]> = cube.triangles().iter().map(|t| t.map(at)).collect();
        let vp = Viewport::new(64, 64);
        let key = |t: &Tri| (t.a, t.b, t.c, t.zref);
        let set_up = |q: &mut TriangleQueue| {
            let mut out = Vec::new();
            q.set_up(&vp, false, &mut out);
            out.iter().map(key).collect::<Vec<_>>()
        };
        for (z, silhouette) in [(0.5, true), (-0.1, false)] {
            let m = Mat4::from_cols(
                Vec4::X,
                Vec4::Y,
                Vec4::new(0.0, 0.0, 0.4, 1.0),
                Vec4::new(0.1, 0.0, z, 4.0),
            );
            let (mut run, mut apart, mut triangles) = (
                TriangleQueue::default(),
                TriangleQueue::default(),
                TriangleQueue::default(),
            );
            run.push_convex(cube.positions(), cube.triangles(), &m).unwrap();
            apart.push_convex(&scattered, &tris, &m).unwrap();
            triangles
                .push_model_with(cube.positions(), cube.triangles(), &m, FaceCull::None, true)
                .unwrap();
            let want = set_up(&mut run);
            assert!(!want.is_empty());
            // Through the near plane: the triangles, two-sided by the inner rule.
            assert_eq!(want == set_up(&mut triangles), !silhouette);
            assert_eq!(set_up(&mut apart), want);
        }
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
