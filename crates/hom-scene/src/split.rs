//! Objects from unstructured meshes: splitting one big mesh into spatially
//! coherent pieces (Zhang et al. 1997, section 6.2, build their hierarchy from
//! unstructured polygons too).
//!
//! Many real files are one big mesh (a Quake 3 world, an OBJ file with one
//! group). A culler works per object, so such a mesh is split into objects of a
//! bounded size: its *pieces* (triangles, or the faces of a BSP map) are cut
//! into clusters ([`hom::clusters`]: at the median of their centroids, at most
//! [`SplitOptions::max_triangles`] triangles and [`SplitOptions::max_extent`]
//! metres each, by default cluster-sized), and each cluster becomes an object.
//!
//! Files that have objects of their own (OBJ groups, glTF nodes) keep them,
//! but an object that spans the level — its box's longest side over
//! [`SplitOptions::whole_extent`] — is cut the same way ([`spans_level`]): a
//! ground, a road or a block of buildings is always partly visible, so
//! whole it is never culled and hides nothing behind it from the cullers'
//! boxes. Props and houses stay whole, where a closed mesh can be a virtual
//! occluder (`docs/decisions/clusters.md`).
//!
//! **Order (the object ids):** the clusters' order: depth-first over the cut,
//! the half with the smaller coordinates first; within a group the pieces
//! keep their input order. The result is a pure function of the input.

use hom::clusters::{self, ClusterOptions};
use hom::geom::Aabb;
use hom::scene::{Mesh, SceneError};

pub use hom::clusters::Piece;

/// How big the objects made from an unstructured mesh may be: clusters
/// ([`hom::clusters`]), whose defaults they share.
#[derive(Clone, Debug, PartialEq)]
pub struct SplitOptions {
    /// Split at all? When false, a mesh stays one object.
    pub enabled: bool,
    /// Most triangles in one object (a single piece with more stays whole). At least 1.
    pub max_triangles: usize,
    /// Largest spread of an object's piece centroids along any axis, metres (its
    /// box may be bigger by the size of its pieces). Infinity disables the size limit.
    pub max_extent: f32,
    /// An object of a file with objects of its own is cut only when its box's
    /// longest side exceeds this, metres (default 16: larger than props and
    /// houses, smaller than a ground, a road or a block of buildings).
    /// Infinity keeps every such object whole.
    pub whole_extent: f32,
}

impl Default for SplitOptions {
    fn default() -> Self {
        let c = ClusterOptions::default();
        SplitOptions {
            enabled: true,
            max_triangles: c.max_triangles as usize,
            max_extent: c.max_extent,
            whole_extent: 16.0,
        }
    }
}

/// Whether an object of a file with objects of its own is cut: splitting
/// enabled, more than [`SplitOptions::max_triangles`] triangles, and its
/// box (world space) longer than [`SplitOptions::whole_extent`] on some axis.
pub fn spans_level(bounds: &Aabb, triangles: usize, options: &SplitOptions) -> bool {
    options.enabled && triangles > options.max_triangles && bounds.extent().max_element() > options.whole_extent
}

/// Groups `pieces` into spatially coherent groups (indices into `pieces`) by
/// [`hom::clusters::group_pieces`], in its order. With splitting disabled,
/// or one piece, one group holds all. An empty input gives no groups.
pub fn group_pieces(pieces: &[Piece], options: &SplitOptions) -> Vec<Vec<u32>> {
    if !options.enabled {
        return if pieces.is_empty() {
            Vec::new()
        } else {
            vec![(0..pieces.len() as u32).collect()]
        };
    }
    clusters::group_pieces(pieces, &cluster_options(options))
}

/// Splits `mesh` into meshes of at most `options.max_triangles` triangles and
/// `options.max_extent` metres (each triangle is a piece), named `NAME_K`, each
/// holding only the vertices it uses ([`Mesh::cut`]). Disabled, or small
/// enough, it returns the mesh unchanged, alone.
pub fn split_mesh(mesh: &Mesh, options: &SplitOptions) -> Result<Vec<Mesh>, SceneError> {
    if !options.enabled {
        return Ok(vec![mesh.clone()]);
    }
    mesh.cut(&cluster_options(options))
}

/// The clusters' options `options` asks for.
fn cluster_options(options: &SplitOptions) -> ClusterOptions {
    ClusterOptions {
        max_triangles: u32::try_from(options.max_triangles).unwrap_or(u32::MAX),
        max_extent: options.max_extent,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// A row of `n` unit quads along +X (2 triangles each).
    fn strip(n: usize) -> Mesh {
        let mut p = Vec::new();
        let mut t = Vec::new();
        for i in 0..n {
            let x = i as f32;
            let b = p.len() as u32;
            p.extend([
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x + 1.0, 0.0, 0.0),
                Vec3::new(x + 1.0, 1.0, 0.0),
                Vec3::new(x, 1.0, 0.0),
            ]);
            t.extend([[b, b + 1, b + 2], [b, b + 2, b + 3]]);
        }
        Mesh::new("strip", p, t).unwrap()
    }

    #[test]
    fn splits_by_count_and_size_in_left_to_right_order() {
        let mesh = strip(100);
        let by_count = SplitOptions {
            max_triangles: 50,
            max_extent: f32::INFINITY,
            ..SplitOptions::default()
        };
        let parts = split_mesh(&mesh, &by_count).unwrap();
        assert!(parts.iter().all(|m| m.triangle_count() <= 50));
        assert_eq!(parts.iter().map(Mesh::triangle_count).sum::<usize>(), 200);
        // Left to right: each part's box starts where the previous one ends.
        for w in parts.windows(2) {
            assert!(w[0].bounds().max.x <= w[1].bounds().min.x + 1e-6);
        }
        let by_size = SplitOptions {
            max_triangles: 1000,
            max_extent: 10.0,
            ..SplitOptions::default()
        };
        let parts = split_mesh(&mesh, &by_size).unwrap();
        assert!(parts.len() >= 10);
        assert!(parts.iter().all(|m| m.bounds().extent().max_element() <= 11.0));
        // Deterministic.
        assert_eq!(parts, split_mesh(&mesh, &by_size).unwrap());
    }

    #[test]
    fn disabled_or_small_stays_whole() {
        let mesh = strip(3);
        assert_eq!(split_mesh(&mesh, &SplitOptions::default()).unwrap(), vec![mesh.clone()]);
        let off = SplitOptions {
            enabled: false,
            max_triangles: 1,
            ..SplitOptions::default()
        };
        assert_eq!(split_mesh(&mesh, &off).unwrap(), vec![mesh]);
        assert!(group_pieces(&[], &SplitOptions::default()).is_empty());
    }

    #[test]
    fn only_meshes_that_span_the_level_are_cut() {
        let options = SplitOptions::default();
        // 40 m of 80 triangles: spans; 10 m of 20 quads: a house's size, whole.
        let road = strip(40);
        assert!(spans_level(&road.bounds(), road.triangle_count(), &options));
        let house = strip(10);
        assert!(!spans_level(&house.bounds(), house.triangle_count(), &options));
        // Few triangles stay whole however long; disabled cuts nothing.
        let few = SplitOptions {
            max_triangles: 100,
            ..options.clone()
        };
        assert!(!spans_level(&road.bounds(), road.triangle_count(), &few));
        let off = SplitOptions {
            enabled: false,
            ..options
        };
        assert!(!spans_level(&road.bounds(), road.triangle_count(), &off));
    }
}
