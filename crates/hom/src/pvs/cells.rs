//! View cells: a controlled subdivision of the viewing region (Law & Tan
//! 1999, section 5.1: "quadtree for outdoor environments … if an urban
//! walkthrough restricts the viewer to the roads, cells should be associated
//! with the roads only").
//!
//! The ground (x, z) is cut into square **blocks**, each a complete quadtree
//! of `levels` levels over `2^levels × 2^levels` square **leaves** of
//! `cell_size` metres. A leaf is a cell only where the viewing region reaches
//! it (a camera path, with a pad), and then spans in height just the eyes
//! that reach it (so a terrain walk's cells follow the ground); a node spans
//! its cells. A viewpoint is in the PVS's region iff it lies in a cell's box;
//! elsewhere the PVS says nothing.
//!
//! Nodes are numbered block by block, each block's nodes in level order
//! (root, then its four children in z-major order, …): one block's nodes are
//! one contiguous range, which is what a bake shard takes.

use crate::geom::Aabb;
use glam::{Vec2, Vec3};

/// The cell hierarchy.
#[derive(Clone, Debug, PartialEq)]
pub struct CellGrid {
    /// World (x, z) of the first leaf's corner.
    pub(crate) origin: Vec2,
    /// Leaf edge in metres.
    pub(crate) cell_size: f32,
    /// Quadtree levels below a block (a block holds `4^levels` leaves).
    pub(crate) levels: u32,
    /// Blocks along x and z.
    pub(crate) blocks: [u32; 2],
    /// Per leaf (row-major over all leaves, x fastest): its height span, or
    /// `None` when it is no cell.
    pub(crate) leaf_y: Vec<Option<(f32, f32)>>,
}

impl CellGrid {
    /// Cells around the eye positions `eyes`, each eye reaching every leaf
    /// within `pad` metres (in x and z) and spanning `eye.y ± pad`. The eyes
    /// must be finite and `cell_size` positive (the caller checks).
    pub(crate) fn around(eyes: &[Vec3], cell_size: f32, levels: u32, pad: f32) -> CellGrid {
        let (origin, blocks) = Self::extent(eyes, cell_size, levels, pad);
        let side = 1usize << levels;
        let (lx, lz) = (blocks[0] as usize * side, blocks[1] as usize * side);
        let mut leaf_y: Vec<Option<(f32, f32)>> = vec![None; lx * lz];
        for e in eyes {
            let lo = ((Vec2::new(e.x, e.z) - pad - origin) / cell_size).floor();
            let hi = ((Vec2::new(e.x, e.z) + pad - origin) / cell_size).floor();
            let clamp = |v: f32, n: usize| (v.max(0.0) as usize).min(n - 1);
            for z in clamp(lo.y, lz)..=clamp(hi.y, lz) {
                for x in clamp(lo.x, lx)..=clamp(hi.x, lx) {
                    let y = &mut leaf_y[z * lx + x];
                    *y = Some(match *y {
                        Some((a, b)) => (a.min(e.y - pad), b.max(e.y + pad)),
                        None => (e.y - pad, e.y + pad),
                    });
                }
            }
        }
        CellGrid {
            origin,
            cell_size,
            levels,
            blocks,
            leaf_y,
        }
    }

    /// The first leaf's corner and the blocks along x and z that cells
    /// around `eyes` need (saturating, so a caller can refuse a huge region
    /// before anything is allocated).
    pub(crate) fn extent(eyes: &[Vec3], cell_size: f32, levels: u32, pad: f32) -> (Vec2, [u32; 2]) {
        let bounds = Aabb::from_points(eyes.iter().copied());
        let block = cell_size * (1u32 << levels) as f32;
        let origin = Vec2::new(bounds.min.x - pad, bounds.min.z - pad);
        let span = Vec2::new(bounds.max.x + pad, bounds.max.z + pad) - origin;
        let count = |s: f32| ((s / block).floor() as u32).saturating_add(1);
        (origin, [count(span.x), count(span.y)])
    }

    /// Nodes a grid of `blocks` with `levels` holds (saturating).
    pub(crate) fn nodes_for(blocks: [u32; 2], levels: u32) -> usize {
        let per = ((1usize << (2 * (levels + 1))) - 1) / 3;
        (blocks[0] as usize)
            .saturating_mul(blocks[1] as usize)
            .saturating_mul(per)
    }

    /// Leaves along x (over all blocks).
    fn leaves_x(&self) -> usize {
        self.blocks[0] as usize * (1 << self.levels)
    }

    /// Nodes in one block's quadtree.
    pub(crate) fn nodes_per_block(&self) -> usize {
        ((1usize << (2 * (self.levels + 1))) - 1) / 3
    }

    /// Blocks in all.
    pub(crate) fn block_count(&self) -> usize {
        self.blocks[0] as usize * self.blocks[1] as usize
    }

    /// Nodes in all.
    #[cfg(test)]
    pub(crate) fn node_count(&self) -> usize {
        self.block_count() * self.nodes_per_block()
    }

    /// Cells (leaves in the viewing region).
    pub fn cell_count(&self) -> usize {
        self.leaf_y.iter().filter(|y| y.is_some()).count()
    }

    /// The node id of `(level, x, z)` in block `block` (x, z within the level's grid of the block).
    pub(crate) fn node_id(&self, block: usize, level: u32, x: usize, z: usize) -> usize {
        let before = ((1usize << (2 * level)) - 1) / 3;
        block * self.nodes_per_block() + before + (z << level) + x
    }

    /// The box of node `(level, x, z)` of block `block`: its leaves' square,
    /// and the height span of its cells; `None` when it holds no cell.
    pub(crate) fn node_box(&self, block: usize, level: u32, x: usize, z: usize) -> Option<Aabb> {
        let side = 1usize << self.levels;
        let (bx, bz) = (block % self.blocks[0] as usize, block / self.blocks[0] as usize);
        let per = side >> level;
        let (x0, z0) = (bx * side + x * per, bz * side + z * per);
        let lx = self.leaves_x();
        let mut y: Option<(f32, f32)> = None;
        for zz in z0..z0 + per {
            for xx in x0..x0 + per {
                if let Some((a, b)) = self.leaf_y[zz * lx + xx] {
                    y = Some(y.map_or((a, b), |(c, d)| (a.min(c), b.max(d))));
                }
            }
        }
        let (y0, y1) = y?;
        let lo = self.origin + Vec2::new(x0 as f32, z0 as f32) * self.cell_size;
        let hi = lo + Vec2::splat(per as f32 * self.cell_size);
        Some(Aabb::new(Vec3::new(lo.x, y0, lo.y), Vec3::new(hi.x, y1, hi.y)))
    }

    /// The nodes from the root of its block down to the cell holding `eye`,
    /// or `None` when `eye` lies in no cell.
    pub fn path_to(&self, eye: Vec3) -> Option<Vec<usize>> {
        let cell = ((Vec2::new(eye.x, eye.z) - self.origin) / self.cell_size).floor();
        if !(cell.x >= 0.0 && cell.y >= 0.0) {
            return None;
        }
        let (x, z) = (cell.x as usize, cell.y as usize);
        let lx = self.leaves_x();
        if x >= lx || z >= self.leaf_y.len() / lx {
            return None;
        }
        let (y0, y1) = self.leaf_y[z * lx + x]?;
        if !(eye.y >= y0 && eye.y <= y1) {
            return None;
        }
        let side = 1usize << self.levels;
        let block = (z / side) * self.blocks[0] as usize + x / side;
        let (ix, iz) = (x % side, z % side);
        Some(
            (0..=self.levels)
                .map(|l| {
                    let shift = self.levels - l;
                    self.node_id(block, l, ix >> shift, iz >> shift)
                })
                .collect(),
        )
    }

    /// Every cell's box (for sampling viewpoints and pictures), with its leaf
    /// coordinates.
    pub fn cells(&self) -> impl Iterator<Item = ([usize; 2], Aabb)> + '_ {
        let lx = self.leaves_x();
        self.leaf_y.iter().enumerate().filter_map(move |(i, y)| {
            let (y0, y1) = (*y)?;
            let (x, z) = (i % lx, i / lx);
            let lo = self.origin + Vec2::new(x as f32, z as f32) * self.cell_size;
            let hi = lo + Vec2::splat(self.cell_size);
            Some(([x, z], Aabb::new(Vec3::new(lo.x, y0, lo.y), Vec3::new(hi.x, y1, hi.y))))
        })
    }

    /// The box around every cell.
    pub fn bounds(&self) -> Aabb {
        self.cells().fold(Aabb::EMPTY, |a, (_, b)| a.union(b))
    }

    /// Leaf edge in metres.
    pub fn cell_size(&self) -> f32 {
        self.cell_size
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_eye_finds_its_cell_and_the_path_ends_in_a_box_holding_it() {
        let eyes: Vec<Vec3> = (0..200)
            .map(|i| Vec3::new(i as f32 * 0.7, 1.5 + (i as f32 * 0.1).sin(), -(i as f32) * 0.3))
            .collect();
        let g = CellGrid::around(&eyes, 4.0, 3, 1.0);
        assert!(g.cell_count() > 10);
        for e in &eyes {
            let path = g.path_to(*e).expect("an eye of the region lies in a cell");
            assert_eq!(path.len(), 4);
            // The leaf node's box holds the eye, and so does every ancestor's.
            let side = 1usize << g.levels;
            let lx = g.leaves_x();
            let cell = ((Vec2::new(e.x, e.z) - g.origin) / g.cell_size).floor();
            let (x, z) = (cell.x as usize, cell.y as usize);
            let block = (z / side) * g.blocks[0] as usize + x / side;
            for l in 0..=g.levels {
                let s = g.levels - l;
                let b = g.node_box(block, l, (x % side) >> s, (z % side) >> s).unwrap();
                assert!(b.contains_point(*e), "level {l}: {b:?} misses {e}");
                assert_eq!(path[l as usize], g.node_id(block, l, (x % side) >> s, (z % side) >> s));
            }
            assert!(x < lx);
        }
        // Far from the path: no cell.
        assert!(g.path_to(Vec3::new(1e4, 0.0, 0.0)).is_none());
        assert!(g.path_to(Vec3::new(0.0, 100.0, 0.0)).is_none());
        assert!(g.path_to(Vec3::NAN).is_none());
        // Node ids are distinct and within range.
        let mut ids: Vec<usize> = (0..g.block_count())
            .flat_map(|b| (0..=g.levels).flat_map(move |l| (0..1usize << (2 * l)).map(move |i| (b, l, i))))
            .map(|(b, l, i)| g.node_id(b, l, i % (1 << l), i >> l))
            .collect();
        ids.sort_unstable();
        ids.dedup();
        assert_eq!(ids.len(), g.node_count());
        assert_eq!(*ids.last().unwrap(), g.node_count() - 1);
    }
}
