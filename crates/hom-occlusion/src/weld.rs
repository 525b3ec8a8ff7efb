//! The one vertex weld of the workspace: vertices at the same position are
//! one vertex. The closed-mesh check ([`crate::ClosedMesh::of`]), hom's
//! virtual-occluder bake and its mesh simplifier all match vertices by it.

use glam::Vec3;

/// Canonical vertex per distinct position: returns, for each vertex index,
/// the smallest index holding the same position.
///
/// The rule: two positions are one when their f32 coordinates are bitwise
/// equal after `-0.0` is taken as `+0.0`. So `-0.0` and `+0.0` count as
/// equal (they are the same point, and mesh generators and mirrored
/// placements produce both on seams); positions a rounding step apart are
/// different; NaN coordinates are equal only with identical bits.
///
/// ```
/// use hom_occlusion::details::weld;
/// use hom_occlusion::glam::Vec3;
///
/// let p = [Vec3::X, Vec3::ZERO, Vec3::X, Vec3::new(-0.0, 0.0, -0.0)];
/// assert_eq!(weld(&p), vec![0, 1, 0, 1]);
/// ```
///
/// # Panics
/// If there are more than `u32::MAX + 1` positions (indices are `u32`).
pub fn weld(positions: &[Vec3]) -> Vec<u32> {
    let n = u32::try_from(positions.len()).ok().and_then(|n| n.checked_sub(1));
    assert!(positions.is_empty() || n.is_some(), "weld takes at most 2^32 positions");
    // Adding +0.0 turns -0.0 into +0.0 and leaves every other value alone.
    let key = |i: u32| {
        let p = positions[i as usize];
        [(p.x + 0.0).to_bits(), (p.y + 0.0).to_bits(), (p.z + 0.0).to_bits()]
    };
    // Sorting, not hashing: O(n log n), and the smallest index of a run comes first.
    let mut order: Vec<u32> = (0..positions.len()).map(|i| i as u32).collect();
    order.sort_unstable_by_key(|&i| (key(i), i));
    let mut canonical = vec![0; positions.len()];
    let mut run: Option<([u32; 3], u32)> = None;
    for &i in &order {
        let k = key(i);
        let first = match run {
            Some((run_key, first)) if run_key == k => first,
            _ => {
                run = Some((k, i));
                i
            }
        };
        canonical[i as usize] = first;
    }
    canonical
}

/// The welded vertices of [`weld`]'s `canonical` numbered densely, in the
/// order of their first vertex: returns, for each vertex, its welded
/// vertex's number in `0..count`, and `count`.
pub fn number_welded(canonical: &[u32]) -> (Vec<u32>, usize) {
    let mut number = vec![0; canonical.len()];
    let mut count = 0u32;
    for (i, &c) in canonical.iter().enumerate() {
        number[i] = if c as usize == i {
            count += 1;
            count - 1
        } else {
            // The canonical vertex is the smallest index: numbered already.
            number[c as usize]
        };
    }
    (number, count as usize)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weld_maps_each_position_to_its_first_index() {
        let positions = [
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(-0.0, 0.0, -0.0),
            Vec3::new(1.0, 2.0, 3.000_000_2),
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 2.0, 3.000_000_2),
            Vec3::new(f32::NAN, 0.0, 0.0),
            Vec3::new(f32::NAN, 0.0, 0.0),
        ];
        assert_eq!(weld(&positions), vec![0, 1, 0, 1, 4, 1, 4, 7, 7]);
        assert!(weld(&[]).is_empty());
    }

    #[test]
    fn welded_vertices_are_numbered_in_order_of_first_appearance() {
        let canonical = [0, 1, 0, 1, 4, 1, 4, 7, 7];
        assert_eq!(number_welded(&canonical), (vec![0, 1, 0, 1, 2, 1, 2, 3, 3], 4));
        assert_eq!(number_welded(&[]), (vec![], 0));
    }
}
