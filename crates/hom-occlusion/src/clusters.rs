//! Clusters: a mesh's triangles cut into spatially coherent groups, each
//! culled on its own and drawn as a range of the mesh's index buffer — for
//! an engine that keeps its own meshes and culls parts of them through the
//! front door (a level's ground, a track, a block of buildings: meshes that
//! span the level are always partly visible, so whole they are never
//! culled). meshoptimizer's meshlets are the GPU analogue; these are sized
//! for CPU culling: tens of triangles and a few metres, so that a cluster's
//! box hugs its surface.
//!
//! The cut: the *pieces* (triangles here; a Quake 3 map's faces in
//! `hom-scene`) are split recursively at the median of their centroids
//! along the longest axis of the centroids' box, until a group holds at
//! most [`ClusterOptions::max_triangles`] triangles and its pieces'
//! centroids lie within [`ClusterOptions::max_extent`] on every axis (or it
//! is a single piece). Centroids, not the pieces' bounds, so that one long
//! triangle (a floor) does not shatter everything around it into single
//! pieces (Zhang et al. 1997, section 6.2, build their hierarchy from
//! unstructured polygons the same way).
//!
//! **Order:** groups come out in depth-first order of the split, the half
//! with the smaller coordinates first; within a group the pieces keep their
//! input order. The result is a pure function of the input.
//!
//! ```
//! use hom_occlusion::clusters::{cluster_triangles, ClusterOptions};
//! use hom_occlusion::glam::Vec3;
//!
//! // A strip of 100 unit quads along +x: 200 triangles, 100 m long.
//! let mut positions = Vec::new();
//! let mut triangles = Vec::new();
//! for i in 0..100u32 {
//!     let x = i as f32;
//!     positions.extend([Vec3::new(x, 0.0, 0.0), Vec3::new(x + 1.0, 0.0, 0.0),
//!                       Vec3::new(x + 1.0, 1.0, 0.0), Vec3::new(x, 1.0, 0.0)]);
//!     let b = 4 * i;
//!     triangles.extend([[b, b + 1, b + 2], [b, b + 2, b + 3]]);
//! }
//! let clusters = cluster_triangles(&positions, &triangles, &ClusterOptions::default())?;
//! // Draw cluster `k` as triangles `clusters.clusters[k].triangles` of this index buffer:
//! let index_buffer = clusters.reorder(&triangles);
//! assert_eq!(index_buffer.len(), 200);
//! // At most 3 m of centroids each, so at most 4 m with their 1 m triangles.
//! assert!(clusters.clusters.iter().all(|c| c.bounds.extent().x <= 4.0));
//! # Ok::<(), hom_occlusion::clusters::ClusterError>(())
//! ```

use crate::geom::Aabb;
use glam::Vec3;
use std::ops::Range;

/// How big a cluster may be.
#[derive(Clone, Debug, PartialEq)]
pub struct ClusterOptions {
    /// Most triangles in one cluster (a single piece with more stays whole).
    /// At least 1.
    pub max_triangles: u32,
    /// Largest spread of a cluster's piece centroids along any axis, in the
    /// mesh's units (its box may be bigger by the size of its pieces).
    /// Positive; infinity disables the size limit. The default, 3 m, suits
    /// level geometry of rooms and walls; on a dense mesh it makes clusters
    /// of a few triangles (a terrain grid of 2 m quads: 5 each), so there
    /// let the triangle count decide (`engine_loop`'s ground: 16 m).
    pub max_extent: f32,
}

/// 64 triangles and 3 m: on fifteen real levels, objects of that size gave
/// HOM 0.92–1.54× frustum-only culling (above 1 on twelve) where objects of
/// 512 triangles and 16 m gave 0.96–1.06×; 32 and 2 m were within ±0.1 of
/// it on ten of twelve maps with up to 1.5× the objects
/// (`docs/decisions/clusters.md`).
impl Default for ClusterOptions {
    fn default() -> Self {
        ClusterOptions {
            max_triangles: 64,
            max_extent: 3.0,
        }
    }
}

impl ClusterOptions {
    /// Checks the options: a clear error for zero triangles or a size that
    /// is not positive.
    pub fn validate(&self) -> Result<(), ClusterError> {
        if self.max_triangles == 0 {
            return Err(ClusterError::ZeroTriangles);
        }
        if self.max_extent.is_nan() || self.max_extent <= 0.0 {
            return Err(ClusterError::Extent(self.max_extent));
        }
        Ok(())
    }
}

/// Why a mesh could not be cut into clusters.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ClusterError {
    /// A triangle names a vertex that was not passed.
    #[error("triangle {triangle} uses vertex {index}, but only {vertex_count} vertices were passed")]
    IndexOutOfRange {
        /// Triangle index.
        triangle: usize,
        /// The bad vertex index.
        index: u32,
        /// Vertices passed.
        vertex_count: usize,
    },
    /// A vertex a triangle uses is NaN or infinite.
    #[error("vertex {0} is NaN or infinite")]
    NonFiniteVertex(u32),
    /// `max_triangles` is 0.
    #[error("clusters must hold at least 1 triangle (max_triangles is 0)")]
    ZeroTriangles,
    /// `max_extent` is not positive.
    #[error("a cluster's largest extent must be positive, got {0}")]
    Extent(f32),
}

/// One unit the cut never divides: its bounds and how many triangles it holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Piece {
    /// Bounds of the piece's triangles.
    pub bounds: Aabb,
    /// Triangles in the piece.
    pub triangles: u32,
}

/// Groups `pieces` into spatially coherent groups (indices into `pieces`),
/// in the module's order; one piece or none gives one group or none. The
/// options are taken as they are (a `max_triangles` of 0 acts as 1); check
/// them with [`ClusterOptions::validate`].
pub fn group_pieces(pieces: &[Piece], options: &ClusterOptions) -> Vec<Vec<u32>> {
    if pieces.is_empty() {
        return Vec::new();
    }
    let centroid = |i: u32| pieces[i as usize].bounds.center();
    let mut out = Vec::new();
    // Explicit stack (right pushed first so the left half comes out first).
    let mut stack = vec![(0..pieces.len() as u32).collect::<Vec<u32>>()];
    while let Some(mut group) = stack.pop() {
        let triangles: u64 = group.iter().map(|&i| u64::from(pieces[i as usize].triangles)).sum();
        let e = Aabb::from_points(group.iter().map(|&i| centroid(i))).extent();
        let small = triangles <= u64::from(options.max_triangles.max(1)) && e.max_element() <= options.max_extent;
        if group.len() <= 1 || small {
            group.sort_unstable();
            out.push(group);
            continue;
        }
        let axis = if e.x >= e.y && e.x >= e.z {
            0
        } else if e.y >= e.z {
            1
        } else {
            2
        };
        let key = |i: u32| centroid(i)[axis];
        let mid = group.len() / 2;
        group.select_nth_unstable_by(mid, |&a, &b| key(a).total_cmp(&key(b)).then(a.cmp(&b)));
        let right = group.split_off(mid);
        stack.push(right);
        stack.push(group);
    }
    out
}

/// One cluster: a range of [`Clusters::order`] and the bounds of its triangles.
#[derive(Clone, Debug, PartialEq)]
pub struct Cluster {
    /// Its triangles: `order[triangles]` are indices into the input triangles.
    pub triangles: Range<u32>,
    /// The bounds of its triangles' vertices, in the mesh's space.
    pub bounds: Aabb,
}

/// A mesh cut into clusters ([`cluster_triangles`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Clusters {
    /// Every input triangle once, cluster by cluster: the order to lay the
    /// index buffer out in ([`Clusters::reorder`]).
    pub order: Vec<u32>,
    /// The clusters, their ranges back to back over `order`.
    pub clusters: Vec<Cluster>,
}

impl Clusters {
    /// `per_triangle` (one item per input triangle: the triangles
    /// themselves, their materials) laid out in cluster order, so that
    /// cluster `k` is `result[clusters[k].triangles]`.
    ///
    /// # Panics
    /// If `per_triangle` does not hold one item per input triangle.
    pub fn reorder<T: Copy>(&self, per_triangle: &[T]) -> Vec<T> {
        assert_eq!(
            per_triangle.len(),
            self.order.len(),
            "reorder: one item per triangle of the clustered mesh"
        );
        self.order.iter().map(|&i| per_triangle[i as usize]).collect()
    }
}

/// Cuts the mesh `triangles` (indices into `positions`) into clusters of at
/// most `options.max_triangles` triangles and `options.max_extent` of
/// centroid spread, each triangle a piece. An empty mesh has no clusters.
pub fn cluster_triangles(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    options: &ClusterOptions,
) -> Result<Clusters, ClusterError> {
    options.validate()?;
    let pieces = triangles
        .iter()
        .enumerate()
        .map(|(k, t)| {
            let mut corners = [Vec3::ZERO; 3];
            for (c, &i) in corners.iter_mut().zip(t) {
                *c = *positions.get(i as usize).ok_or(ClusterError::IndexOutOfRange {
                    triangle: k,
                    index: i,
                    vertex_count: positions.len(),
                })?;
                if !c.is_finite() {
                    return Err(ClusterError::NonFiniteVertex(i));
                }
            }
            Ok(Piece {
                bounds: Aabb::from_points(corners),
                triangles: 1,
            })
        })
        .collect::<Result<Vec<Piece>, ClusterError>>()?;
    let mut out = Clusters::default();
    for group in group_pieces(&pieces, options) {
        let start = out.order.len() as u32;
        let bounds = Aabb::from_points(group.iter().flat_map(|&i| {
            let b = pieces[i as usize].bounds;
            [b.min, b.max]
        }));
        out.order.extend(&group);
        out.clusters.push(Cluster {
            triangles: start..out.order.len() as u32,
            bounds,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use hom_testkit::Rng;

    /// Random triangles of up to `size` scattered over a `span` cube.
    fn soup(seed: u64, n: usize, span: f32, size: f32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let mut r = Rng::new(seed);
        let mut p = Vec::new();
        let mut t = Vec::new();
        for k in 0..n as u32 {
            let c = Vec3::new(r.unit(), r.unit(), r.unit()) * span;
            for _ in 0..3 {
                p.push(c + Vec3::new(r.unit(), r.unit(), r.unit()) * size);
            }
            t.push([3 * k, 3 * k + 1, 3 * k + 2]);
        }
        (p, t)
    }

    /// Clusters partition the triangles exactly, within their limits and
    /// bounds, whatever the mesh and the options.
    #[test]
    fn clusters_partition_the_mesh_within_limits() {
        for seed in 1..40u64 {
            let n = (seed as usize * 37) % 700;
            let (p, t) = soup(seed, n, 20.0, 1.0 + seed as f32 % 5.0);
            let options = ClusterOptions {
                max_triangles: 1 + (seed as u32 * 7) % 90,
                max_extent: 0.5 + (seed % 6) as f32,
            };
            let c = cluster_triangles(&p, &t, &options).unwrap();
            let mut seen = c.order.clone();
            seen.sort_unstable();
            assert_eq!(seen, (0..n as u32).collect::<Vec<u32>>(), "seed {seed}");
            let mut next = 0;
            for cl in &c.clusters {
                assert_eq!(cl.triangles.start, next);
                next = cl.triangles.end;
                let tris = &c.order[cl.triangles.start as usize..cl.triangles.end as usize];
                assert!(!tris.is_empty());
                let centroids = Aabb::from_points(tris.iter().map(|&i| {
                    let [a, b, d] = t[i as usize].map(|v| p[v as usize]);
                    Aabb::from_points([a, b, d]).center()
                }));
                let small = tris.len() as u32 <= options.max_triangles
                    && centroids.extent().max_element() <= options.max_extent;
                assert!(tris.len() == 1 || small, "seed {seed}: a cluster over its limits");
                for &i in tris {
                    for v in t[i as usize] {
                        let q = p[v as usize];
                        assert!(cl.bounds.min.cmple(q).all() && q.cmple(cl.bounds.max).all());
                    }
                }
            }
            assert_eq!(next as usize, n);
            // A pure function of the input.
            assert_eq!(c, cluster_triangles(&p, &t, &options).unwrap());
        }
    }

    #[test]
    fn a_small_mesh_is_one_cluster_and_an_empty_one_none() {
        let (p, t) = soup(3, 10, 1.0, 0.2);
        let c = cluster_triangles(&p, &t, &ClusterOptions::default()).unwrap();
        assert_eq!(c.clusters.len(), 1);
        assert_eq!(c.reorder(&t), t);
        assert!(cluster_triangles(&p, &[], &ClusterOptions::default())
            .unwrap()
            .clusters
            .is_empty());
    }

    #[test]
    fn bad_input_is_a_clear_error() {
        let (mut p, t) = soup(5, 4, 1.0, 0.2);
        let ok = ClusterOptions::default();
        let zero = ClusterOptions {
            max_triangles: 0,
            ..ok.clone()
        };
        assert_eq!(cluster_triangles(&p, &t, &zero), Err(ClusterError::ZeroTriangles));
        for extent in [0.0, -1.0, f32::NAN] {
            let bad = ClusterOptions {
                max_extent: extent,
                ..ok.clone()
            };
            assert!(matches!(cluster_triangles(&p, &t, &bad), Err(ClusterError::Extent(_))));
        }
        let err = cluster_triangles(&p, &[[0, 1, 99]], &ok).unwrap_err();
        assert_eq!(
            err.to_string(),
            "triangle 0 uses vertex 99, but only 12 vertices were passed"
        );
        p[4].y = f32::NAN;
        assert_eq!(cluster_triangles(&p, &t, &ok), Err(ClusterError::NonFiniteVertex(4)));
    }
}
