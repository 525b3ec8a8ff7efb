//! The `.pvs` format: a PVS as bytes (the library does no file I/O; the
//! binary reads and writes the bytes).
//!
//! Little-endian throughout:
//!
//! | field | bytes |
//! |---|---|
//! | magic `HOM-PVS\n` | 8 |
//! | version (1) | u32 |
//! | scene fingerprint ([`super::fingerprint`]) | u64 |
//! | object count | u32 |
//! | settings: cell size, levels, pad, margin, near, near clearance, min polygon area, solids, fusion spacing, side, radius | 7 × 4 + 1 + 3 × 4 |
//! | grid: origin x, origin z, blocks x, blocks z | 16 |
//! | shard index, shard count | 8 |
//! | cells: one bit per leaf (x fastest), then two `f32` heights per set bit | |
//! | moving objects, occluder objects: a count, then ids | |
//! | per node of the shard's blocks: a count, then ids | |
//! | portal cells: 0 (none) or 1, then a count of planes and per plane its normal and distance (4 × `f32`); a count of nodes and per node its plane, front and back child (varint, then two `i32`: a leaf `c` as `−(c + 1)`); a count of leaves and per leaf its cell + 1 (0: solid); a count of cells and per cell a count, then ids | |
//! | FNV-1a 64 of everything before it | u64 |
//!
//! Counts and ids are LEB128 varints, ids ascending and stored as the
//! difference from the previous one. Everything is deterministic, so shards
//! merged give the bytes a one-machine bake gives. A reader trusts nothing:
//! every count is bounded by the bytes left, every id by the object count,
//! every list checked ascending, the settings validated.

use super::{CellGrid, Fnv, PortalCells, Pvs, PvsConfig, Shard, MAX_NODES};
use glam::Vec2;
use thiserror::Error;

const MAGIC: &[u8; 8] = b"HOM-PVS\n";
/// 2: portal cells (version 1 had none).
const VERSION: u32 = 2;

/// Why bytes are not a PVS.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum PvsFileError {
    /// Not a `.pvs` file at all.
    #[error("not a hom PVS file (it does not start with the `HOM-PVS` magic)")]
    NotPvs,
    /// Written by another version of hom.
    #[error("PVS file version {found}, this hom reads version {VERSION}: bake it again")]
    Version {
        /// The version in the file.
        found: u32,
    },
    /// Damaged: the checksum does not match.
    #[error("the PVS file is damaged (checksum mismatch): bake it again")]
    Checksum,
    /// Cut short.
    #[error("the PVS file ends early, at byte {at} (reading {what})")]
    Truncated {
        /// Where the bytes ran out.
        at: usize,
        /// What was being read.
        what: &'static str,
    },
    /// A field holds an impossible value.
    #[error("the PVS file is malformed at byte {at}: {what}")]
    Malformed {
        /// Where.
        at: usize,
        /// What is wrong.
        what: &'static str,
    },
}

impl Pvs {
    /// The `.pvs` bytes of this PVS (or shard).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut w = Vec::new();
        w.extend_from_slice(MAGIC);
        w.extend_from_slice(&VERSION.to_le_bytes());
        w.extend_from_slice(&self.fingerprint.to_le_bytes());
        w.extend_from_slice(&self.object_count.to_le_bytes());
        let c = &self.config;
        w.extend_from_slice(&c.cell_size.to_bits().to_le_bytes());
        w.extend_from_slice(&c.levels.to_le_bytes());
        for v in [c.pad, c.margin, c.near, c.near_clearance, c.min_polygon_area] {
            w.extend_from_slice(&v.to_bits().to_le_bytes());
        }
        w.push(c.solids as u8);
        w.extend_from_slice(&c.fusion_spacing.to_bits().to_le_bytes());
        w.extend_from_slice(&c.fusion_side.to_le_bytes());
        w.extend_from_slice(&c.fusion_radius.to_bits().to_le_bytes());
        let g = &self.grid;
        for v in [
            g.origin.x.to_bits(),
            g.origin.y.to_bits(),
            g.blocks[0],
            g.blocks[1],
            self.shard.index,
            self.shard.count,
        ] {
            w.extend_from_slice(&v.to_le_bytes());
        }
        let mut bits = vec![0u8; g.leaf_y.len().div_ceil(8)];
        for (i, y) in g.leaf_y.iter().enumerate() {
            if y.is_some() {
                bits[i / 8] |= 1 << (i % 8);
            }
        }
        w.extend_from_slice(&bits);
        for (a, b) in g.leaf_y.iter().flatten() {
            w.extend_from_slice(&a.to_bits().to_le_bytes());
            w.extend_from_slice(&b.to_bits().to_le_bytes());
        }
        write_ids(&mut w, &self.moving);
        write_ids(&mut w, &self.occluder_objects);
        for s in &self.sets {
            write_ids(&mut w, s);
        }
        match &self.portal_cells {
            None => w.push(0),
            Some(p) => {
                w.push(1);
                write_varint(&mut w, p.planes.len() as u32);
                for (n, d) in &p.planes {
                    for v in [n.x, n.y, n.z, *d] {
                        w.extend_from_slice(&v.to_bits().to_le_bytes());
                    }
                }
                write_varint(&mut w, p.nodes.len() as u32);
                for &(plane, front, back) in &p.nodes {
                    write_varint(&mut w, plane);
                    w.extend_from_slice(&front.to_le_bytes());
                    w.extend_from_slice(&back.to_le_bytes());
                }
                write_varint(&mut w, p.leaf_cell.len() as u32);
                for c in &p.leaf_cell {
                    write_varint(&mut w, c.map_or(0, |c| c + 1));
                }
                write_varint(&mut w, p.hidden.len() as u32);
                for set in &p.hidden {
                    write_ids(&mut w, set);
                }
            }
        }
        let mut h = Fnv::NEW;
        h.bytes(&w);
        w.extend_from_slice(&h.0.to_le_bytes());
        w
    }

    /// Reads `.pvs` bytes; any damage is an error, never a panic.
    pub fn from_bytes(bytes: &[u8]) -> Result<Pvs, PvsFileError> {
        if bytes.len() < 12 || &bytes[..8] != MAGIC {
            return Err(PvsFileError::NotPvs);
        }
        let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
        if version != VERSION {
            return Err(PvsFileError::Version { found: version });
        }
        if bytes.len() < 20 {
            return Err(PvsFileError::Truncated {
                at: bytes.len(),
                what: "the header",
            });
        }
        let (body, sum) = bytes.split_at(bytes.len() - 8);
        let mut h = Fnv::NEW;
        h.bytes(body);
        if h.0.to_le_bytes() != sum {
            return Err(PvsFileError::Checksum);
        }
        let mut r = Reader { bytes: body, at: 12 };
        let fingerprint = r.u64("the scene fingerprint")?;
        let object_count = r.u32("the object count")?;
        let cell_size = r.f32("the settings")?;
        let levels = r.u32("the settings")?;
        let mut f = || r.f32("the settings");
        let (pad, margin, near, near_clearance, min_polygon_area) = (f()?, f()?, f()?, f()?, f()?);
        let solids = match r.byte("the settings")? {
            0 => false,
            1 => true,
            _ => return Err(r.malformed("the solids flag is neither 0 nor 1")),
        };
        let fusion_spacing = r.f32("the settings")?;
        let fusion_side = r.u32("the settings")?;
        let fusion_radius = r.f32("the settings")?;
        let config = PvsConfig {
            cell_size,
            levels,
            pad,
            margin,
            near,
            near_clearance,
            min_polygon_area,
            solids,
            fusion_spacing,
            fusion_side,
            fusion_radius,
        };
        if config.validate().is_err() {
            return Err(r.malformed("the settings are out of range"));
        }
        let origin = Vec2::new(r.f32("the grid")?, r.f32("the grid")?);
        let blocks = [r.u32("the grid")?, r.u32("the grid")?];
        if !origin.is_finite() || blocks[0] == 0 || blocks[1] == 0 {
            return Err(r.malformed("the grid's origin or block counts"));
        }
        let per_block = ((1usize << (2 * (levels + 1))) - 1) / 3;
        let block_count = blocks[0] as usize * blocks[1] as usize;
        if block_count > MAX_NODES / per_block {
            return Err(r.malformed("more cell-hierarchy nodes than a PVS holds"));
        }
        let shard = Shard {
            index: r.u32("the shard")?,
            count: r.u32("the shard")?,
        };
        if shard.count == 0 || shard.index >= shard.count {
            return Err(r.malformed("the shard index is not below the shard count"));
        }
        let leaves = block_count << (2 * levels);
        let bits = r.take(leaves.div_ceil(8), "the cell bitmap")?.to_vec();
        let mut leaf_y = vec![None; leaves];
        for (i, y) in leaf_y.iter_mut().enumerate() {
            if bits[i / 8] & (1 << (i % 8)) != 0 {
                let (a, b) = (r.f32("a cell's heights")?, r.f32("a cell's heights")?);
                if !(a.is_finite() && b.is_finite() && a <= b) {
                    return Err(r.malformed("a cell's height span"));
                }
                *y = Some((a, b));
            }
        }
        let grid = CellGrid {
            origin,
            cell_size,
            levels,
            blocks,
            leaf_y,
        };
        let moving = r.ids(object_count)?;
        let occluder_objects = r.ids(object_count)?;
        let range = shard.blocks(block_count);
        let nodes = range.len() * per_block;
        let mut sets = Vec::with_capacity(nodes.min(r.left()));
        for _ in 0..nodes {
            sets.push(r.ids(object_count)?);
        }
        let portal_cells = match r.byte("the portal cells' flag")? {
            0 => None,
            1 => Some(r.portal_cells(object_count)?),
            _ => return Err(r.malformed("the portal cells' flag is neither 0 nor 1")),
        };
        if r.left() != 0 {
            return Err(r.malformed("bytes left after the last set"));
        }
        Ok(Pvs {
            grid,
            config,
            fingerprint,
            object_count,
            moving,
            occluder_objects,
            shard,
            sets,
            portal_cells,
        })
    }
}

fn write_varint(w: &mut Vec<u8>, mut v: u32) {
    while v >= 0x80 {
        w.push((v as u8) | 0x80);
        v >>= 7;
    }
    w.push(v as u8);
}

fn write_ids(w: &mut Vec<u8>, ids: &[u32]) {
    write_varint(w, ids.len() as u32);
    let mut last = 0;
    for (i, &id) in ids.iter().enumerate() {
        write_varint(w, if i == 0 { id } else { id - last });
        last = id;
    }
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn left(&self) -> usize {
        self.bytes.len() - self.at
    }

    fn malformed(&self, what: &'static str) -> PvsFileError {
        PvsFileError::Malformed { at: self.at, what }
    }

    fn take(&mut self, n: usize, what: &'static str) -> Result<&[u8], PvsFileError> {
        if n > self.left() {
            return Err(PvsFileError::Truncated {
                at: self.bytes.len(),
                what,
            });
        }
        let s = &self.bytes[self.at..self.at + n];
        self.at += n;
        Ok(s)
    }

    fn byte(&mut self, what: &'static str) -> Result<u8, PvsFileError> {
        Ok(self.take(1, what)?[0])
    }

    fn u32(&mut self, what: &'static str) -> Result<u32, PvsFileError> {
        Ok(u32::from_le_bytes(self.take(4, what)?.try_into().expect("4 bytes")))
    }

    fn u64(&mut self, what: &'static str) -> Result<u64, PvsFileError> {
        Ok(u64::from_le_bytes(self.take(8, what)?.try_into().expect("8 bytes")))
    }

    fn f32(&mut self, what: &'static str) -> Result<f32, PvsFileError> {
        self.u32(what).map(f32::from_bits)
    }

    fn varint(&mut self) -> Result<u32, PvsFileError> {
        let mut v = 0u64;
        for shift in (0..35).step_by(7) {
            let b = self.byte("an id list")?;
            v |= ((b & 0x7f) as u64) << shift;
            if b & 0x80 == 0 {
                return u32::try_from(v).map_err(|_| self.malformed("a count or id beyond 32 bits"));
            }
        }
        Err(self.malformed("a count or id longer than five bytes"))
    }

    /// A count of items, each at least `size` bytes long: bounded by the bytes left.
    fn count(&mut self, size: usize, what: &'static str) -> Result<usize, PvsFileError> {
        let n = self.varint()? as usize;
        if n.saturating_mul(size) > self.left() {
            return Err(self.malformed(what));
        }
        Ok(n)
    }

    fn portal_cells(&mut self, object_count: u32) -> Result<PortalCells, PvsFileError> {
        let plane_count = self.count(16, "more portal planes than bytes")?;
        let mut planes = Vec::with_capacity(plane_count);
        for _ in 0..plane_count {
            let mut f = || self.f32("a portal plane");
            let (x, y, z, d) = (f()?, f()?, f()?, f()?);
            planes.push((glam::Vec3::new(x, y, z), d));
        }
        let node_count = self.count(9, "more portal nodes than bytes")?;
        let mut nodes = Vec::with_capacity(node_count);
        for _ in 0..node_count {
            let plane = self.varint()?;
            let front = self.u32("a portal node")? as i32;
            let back = self.u32("a portal node")? as i32;
            nodes.push((plane, front, back));
        }
        let leaf_count = self.count(1, "more portal leaves than bytes")?;
        let mut leaf_cell = Vec::with_capacity(leaf_count);
        for _ in 0..leaf_count {
            leaf_cell.push(self.varint()?.checked_sub(1));
        }
        let cell_count = self.count(1, "more portal cells than bytes")?;
        let mut hidden = Vec::with_capacity(cell_count);
        for _ in 0..cell_count {
            hidden.push(self.ids(object_count)?);
        }
        PortalCells::new(planes, nodes, leaf_cell, hidden)
            .map_err(|_| self.malformed("the portal cells do not make a tree"))
    }

    /// An ascending list of ids below `limit`.
    fn ids(&mut self, limit: u32) -> Result<Vec<u32>, PvsFileError> {
        let n = self.varint()? as usize;
        if n > self.left() || n > limit as usize {
            return Err(self.malformed("an id list longer than the file or the scene"));
        }
        let mut ids = Vec::with_capacity(n);
        let mut last = 0u32;
        for i in 0..n {
            let d = self.varint()?;
            let id = if i == 0 {
                d
            } else {
                if d == 0 {
                    return Err(self.malformed("an id list that is not strictly ascending"));
                }
                last.checked_add(d)
                    .ok_or_else(|| self.malformed("an id beyond 32 bits"))?
            };
            if id >= limit {
                return Err(self.malformed("an object id beyond the scene's objects"));
            }
            ids.push(id);
            last = id;
        }
        Ok(ids)
    }
}
