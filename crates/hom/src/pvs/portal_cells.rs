//! Portal cells in a PVS: the objects hidden from each cell of a tree of
//! planes (a map's BSP tree, whose leaves are the cells
//! [`super::portals`] follows lines through), used beside the view cells.
//!
//! View cells and portal cells **combine**: a view cell's set holds what
//! occluders hide from its whole box; a portal cell's set what no line
//! through the portals reaches from it. At run time the eye's view cell and
//! its portal cell each give their set, and both are hidden. A portal cell
//! answers only when every point within [`super::PvsConfig::near_clearance`]
//! of the eye lies in open cells: the near plane clips nothing nearer, so no
//! line the renderer draws skips solid space (a camera in a wall, or so close
//! to one that the near plane cuts it, sees what the portals say it cannot).

use super::PvsError;
use glam::Vec3;

/// A tree of planes whose leaves are cells, open or solid, and per open
/// cell the sorted ids of the objects hidden from it.
#[derive(Clone, Debug, PartialEq)]
pub struct PortalCells {
    /// Planes: unit normal and distance; `n·p − d ≥ 0` is the front.
    pub(crate) planes: Vec<(Vec3, f32)>,
    /// Nodes: plane, front child, back child (negative: leaf `−(c + 1)`).
    pub(crate) nodes: Vec<(u32, i32, i32)>,
    /// Per leaf, its cell (an index into `hidden`), or `None` for solid space.
    pub(crate) leaf_cell: Vec<Option<u32>>,
    /// Per cell, the objects hidden from it (ascending).
    pub(crate) hidden: Vec<Vec<u32>>,
}

impl PortalCells {
    /// Checks and keeps a tree (node 0 is the root; a tree of no nodes is
    /// one leaf), its leaves' cells and the cells' hidden sets.
    pub fn new(
        planes: Vec<(Vec3, f32)>,
        nodes: Vec<(u32, i32, i32)>,
        leaf_cell: Vec<Option<u32>>,
        hidden: Vec<Vec<u32>>,
    ) -> Result<PortalCells, PvsError> {
        let bad = |what: &'static str| Err(PvsError::BadPortalCells(what));
        if planes
            .iter()
            .any(|(n, d)| !n.is_finite() || !d.is_finite() || n.length_squared() < 0.5)
        {
            return bad("a plane is not finite or its normal not of unit length");
        }
        for &(plane, front, back) in &nodes {
            if plane as usize >= planes.len() {
                return bad("a node's plane does not exist");
            }
            for child in [front, back] {
                let ok = if child >= 0 {
                    (child as usize) < nodes.len()
                } else {
                    ((-(child as i64) - 1) as usize) < leaf_cell.len()
                };
                if !ok {
                    return bad("a node's child does not exist");
                }
            }
        }
        if nodes.is_empty() && leaf_cell.is_empty() {
            return bad("a tree needs at least one leaf");
        }
        if leaf_cell.iter().flatten().any(|&c| c as usize >= hidden.len()) {
            return bad("a leaf's cell does not exist");
        }
        if hidden.iter().any(|h| h.windows(2).any(|w| w[0] >= w[1])) {
            return bad("a cell's hidden set is not strictly ascending");
        }
        Ok(PortalCells {
            planes,
            nodes,
            leaf_cell,
            hidden,
        })
    }

    /// How many cells.
    pub fn cell_count(&self) -> usize {
        self.hidden.len()
    }

    /// The objects hidden from cell `cell` (ascending).
    ///
    /// # Panics
    /// If `cell` is not a cell.
    pub fn hidden(&self, cell: u32) -> &[u32] {
        &self.hidden[cell as usize]
    }

    /// The cell holding `eye` when every point of the cube of half-size
    /// `clearance` around it lies in open cells; `None` otherwise. A tree
    /// that is not one (a cycle) answers `None`.
    pub fn cell_for(&self, eye: Vec3, clearance: f32) -> Option<u32> {
        if !eye.is_finite() || !clearance.is_finite() {
            return None;
        }
        let (lo, hi) = (eye - clearance, eye + clearance);
        let root = if self.nodes.is_empty() { -1 } else { 0 };
        let mut stack = vec![root];
        let mut steps = 0usize;
        while let Some(child) = stack.pop() {
            steps += 1;
            if steps > 4 * self.nodes.len() + 8 {
                return None;
            }
            if child < 0 {
                self.leaf_cell[(-(child as i64) - 1) as usize]?;
                continue;
            }
            let (plane, front, back) = self.nodes[child as usize];
            let (n, d) = self.planes[plane as usize];
            let far = Vec3::select(n.cmpge(Vec3::ZERO), hi, lo);
            let near = Vec3::select(n.cmpge(Vec3::ZERO), lo, hi);
            // A hair wide both ways: rounding never keeps a solid leaf out.
            if n.dot(far) - d >= -1e-3 {
                stack.push(front);
            }
            if n.dot(near) - d <= 1e-3 {
                stack.push(back);
            }
        }
        let mut child = root;
        for _ in 0..=self.nodes.len() {
            if child < 0 {
                return self.leaf_cell[(-(child as i64) - 1) as usize];
            }
            let (plane, front, back) = self.nodes[child as usize];
            let (n, d) = self.planes[plane as usize];
            child = if n.dot(eye) - d >= 0.0 { front } else { back };
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// x < 0 is solid, 0 ≤ x < 10 cell 0, x ≥ 10 cell 1.
    fn cells() -> PortalCells {
        PortalCells::new(
            vec![(Vec3::X, 0.0), (Vec3::X, 10.0)],
            vec![(0, 1, -1), (1, -3, -2)],
            vec![None, Some(0), Some(1)],
            vec![vec![3, 7], vec![1]],
        )
        .unwrap()
    }

    #[test]
    fn the_eye_gets_its_cell_only_clear_of_solid_space() {
        let c = cells();
        assert_eq!(c.cell_for(Vec3::new(5.0, 0.0, 0.0), 0.4), Some(0));
        assert_eq!(c.cell_for(Vec3::new(12.0, 0.0, 0.0), 0.4), Some(1));
        assert_eq!(
            c.cell_for(Vec3::new(9.9, 0.0, 0.0), 0.4),
            Some(0),
            "near another open cell is fine"
        );
        assert_eq!(
            c.cell_for(Vec3::new(0.3, 0.0, 0.0), 0.4),
            None,
            "the near plane could cut the wall"
        );
        assert_eq!(c.cell_for(Vec3::new(-3.0, 0.0, 0.0), 0.4), None, "in the wall");
        assert_eq!(c.cell_for(Vec3::NAN, 0.4), None);
        assert_eq!(c.hidden(0), [3, 7]);
    }

    #[test]
    fn bad_trees_are_named() {
        let e = |p, n, l, h| PortalCells::new(p, n, l, h).unwrap_err().to_string();
        assert!(e(vec![(Vec3::ZERO, 0.0)], vec![], vec![None], vec![]).contains("unit length"));
        assert!(e(vec![(Vec3::X, 0.0)], vec![(1, -1, -1)], vec![None], vec![]).contains("plane does not exist"));
        assert!(e(vec![(Vec3::X, 0.0)], vec![(0, 5, -1)], vec![None], vec![]).contains("child does not exist"));
        assert!(e(vec![(Vec3::X, 0.0)], vec![(0, -1, -4)], vec![None], vec![]).contains("child does not exist"));
        assert!(e(vec![], vec![], vec![Some(2)], vec![vec![]]).contains("cell does not exist"));
        assert!(e(vec![], vec![], vec![Some(0)], vec![vec![2, 2]]).contains("ascending"));
        assert!(e(vec![], vec![], vec![], vec![]).contains("at least one leaf"));
        // A cycle answers nothing, never loops.
        let cyclic = PortalCells::new(vec![(Vec3::X, 0.0)], vec![(0, 0, 0)], vec![Some(0)], vec![vec![]]).unwrap();
        assert_eq!(cyclic.cell_for(Vec3::ONE, 0.1), None);
    }
}
