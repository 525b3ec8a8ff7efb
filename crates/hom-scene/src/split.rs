//! Objects from unstructured meshes: splitting one big mesh into spatially
//! coherent pieces (Zhang et al. 1997, section 6.2, build their hierarchy from
//! unstructured polygons too).
//!
//! Many real files are one big mesh (a Quake 3 world, an OBJ file with one
//! group). A culler works per object, so such a mesh is split into objects of a
//! bounded size: the *pieces* (triangles, or the faces of a BSP map) are split
//! recursively at the median of their centroids along the longest axis of the
//! centroids' bounding box until a group holds at most
//! [`SplitOptions::max_triangles`] triangles and its pieces' centroids lie within
//! [`SplitOptions::max_extent`] on every axis (or it is a single piece). The
//! centroids, not the pieces' full bounds, so that one long triangle (a floor)
//! does not shatter everything around it into single pieces.
//!
//! **Order (the object ids):** groups come out in depth-first order of the split
//! tree, the half with the smaller coordinates first; within a group the pieces
//! keep their input order. The result is a pure function of the input.

use glam::Vec3;
use hom::geom::Aabb;
use hom::scene::{Mesh, SceneError};

/// How big the objects made from an unstructured mesh may be.
#[derive(Clone, Debug, PartialEq)]
pub struct SplitOptions {
    /// Split at all? When false, a mesh stays one object.
    pub enabled: bool,
    /// Most triangles in one object (a single piece with more stays whole). At least 1.
    pub max_triangles: usize,
    /// Largest spread of an object's piece centroids along any axis, metres (its
    /// box may be bigger by the size of its pieces). Infinity disables the size limit.
    pub max_extent: f32,
}

impl Default for SplitOptions {
    fn default() -> Self {
        SplitOptions {
            enabled: true,
            max_triangles: 512,
            max_extent: 16.0,
        }
    }
}

/// One unit the splitter never cuts: its bounds and how many triangles it holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Piece {
    /// Bounds of the piece's triangles.
    pub bounds: Aabb,
    /// Triangles in the piece.
    pub triangles: usize,
}

/// Groups `pieces` into spatially coherent groups (indices into `pieces`), in
/// the documented order. With splitting disabled, or one piece, one group holds all.
/// An empty input gives no groups.
pub fn group_pieces(pieces: &[Piece], options: &SplitOptions) -> Vec<Vec<u32>> {
    if pieces.is_empty() {
        return Vec::new();
    }
    let all: Vec<u32> = (0..pieces.len() as u32).collect();
    if !options.enabled {
        return vec![all];
    }
    let centroid = |i: u32| pieces[i as usize].bounds.center();
    let mut out = Vec::new();
    // Explicit stack (right pushed first so the left half comes out first).
    let mut stack = vec![all];
    while let Some(mut group) = stack.pop() {
        let triangles: usize = group.iter().map(|&i| pieces[i as usize].triangles).sum();
        let cbounds = Aabb::from_points(group.iter().map(|&i| centroid(i)));
        let e = cbounds.extent();
        let small = triangles <= options.max_triangles.max(1) && e.max_element() <= options.max_extent;
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

/// Splits `mesh` into meshes of at most `options.max_triangles` triangles and
/// `options.max_extent` metres (each triangle is a piece), named `NAME_K`, each
/// holding only the vertices it uses. Disabled, or small enough, it returns the
/// mesh unchanged, alone.
pub fn split_mesh(mesh: &Mesh, options: &SplitOptions) -> Result<Vec<Mesh>, SceneError> {
    let p = mesh.positions();
    let pieces: Vec<Piece> = mesh
        .triangles()
        .iter()
        .map(|t| Piece {
            bounds: Aabb::from_points(t.iter().map(|&i| p[i as usize])),
            triangles: 1,
        })
        .collect();
    let groups = group_pieces(&pieces, options);
    if groups.len() <= 1 {
        return Ok(vec![mesh.clone()]);
    }
    groups
        .iter()
        .enumerate()
        .map(|(k, g)| {
            let tris: Vec<[u32; 3]> = g.iter().map(|&i| mesh.triangles()[i as usize]).collect();
            compact(format!("{}_{k}", mesh.name()), p, &tris)
        })
        .collect()
}

/// A mesh of `triangles` (indices into `positions`) holding only the vertices they use.
pub(crate) fn compact(name: String, positions: &[Vec3], triangles: &[[u32; 3]]) -> Result<Mesh, SceneError> {
    let mut remap = std::collections::HashMap::new();
    let mut local = Vec::new();
    let tris = triangles
        .iter()
        .map(|t| {
            t.map(|i| {
                *remap.entry(i).or_insert_with(|| {
                    local.push(positions[i as usize]);
                    (local.len() - 1) as u32
                })
            })
        })
        .collect();
    Mesh::new(name, local, tris)
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
