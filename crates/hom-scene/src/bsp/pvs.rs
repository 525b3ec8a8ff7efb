//! The map's own visibility: BSP nodes and planes down to leaf clusters, and
//! the cluster-to-cluster bit vectors of the visdata lump.

use super::{index, le_f32, le_i32, vec3, BspError, Lumps, LEAFS, NODES, PLANES, VISDATA};

/// The map's potentially visible sets: BSP tree, leaf clusters, cluster bit vectors.
#[derive(Clone, Debug, Default)]
pub(super) struct Pvs {
    /// Planes in Quake coordinates: normal, distance.
    pub(super) planes: Vec<([f32; 3], f32)>,
    /// Nodes: plane, front child, back child (negative: leaf −(c + 1)).
    pub(super) nodes: Vec<(u32, i32, i32)>,
    /// Cluster of each leaf (−1: solid or outside).
    pub(super) leaf_cluster: Vec<i32>,
    /// Clusters in the visdata (0 without visdata).
    pub(super) clusters: usize,
    /// Bytes per cluster row.
    pub(super) row: usize,
    /// `clusters × row` bits.
    pub(super) bits: Vec<u8>,
}

impl Pvs {
    /// The leaves whose regions the box `lo..hi` (Quake units) may touch,
    /// `hair` units wide, each once, ascending; `None` for a tree with a
    /// cycle.
    pub(super) fn leaves_touching(&self, lo: glam::DVec3, hi: glam::DVec3, hair: f64) -> Option<Vec<u32>> {
        let mut out = Vec::new();
        let mut stack = vec![if self.nodes.is_empty() { -1 } else { 0i32 }];
        let mut steps = 0usize;
        while let Some(child) = stack.pop() {
            steps += 1;
            if steps > 4 * self.nodes.len() + 8 {
                return None;
            }
            if child < 0 {
                out.push((-(child as i64) - 1) as u32);
                continue;
            }
            let (plane, front, back) = self.nodes[child as usize];
            let (n, d) = self.planes[plane as usize];
            let (mut smin, mut smax) = (-(d as f64), -(d as f64));
            for k in 0..3 {
                let (p, q) = (n[k] as f64 * lo[k], n[k] as f64 * hi[k]);
                smin += p.min(q);
                smax += p.max(q);
            }
            if smax >= -hair {
                stack.push(front);
            }
            if smin <= hair {
                stack.push(back);
            }
        }
        out.sort_unstable();
        out.dedup();
        Some(out)
    }
}

pub(super) fn read_pvs(lumps: &Lumps) -> Result<Pvs, BspError> {
    let mut planes = Vec::new();
    for (k, r) in lumps.records(PLANES, 16)?.enumerate() {
        let n = vec3(r, 0);
        let d = le_f32(r, 12);
        if !(n.iter().all(|c| c.is_finite()) && d.is_finite()) {
            return Err(BspError::NonFinite {
                what: "plane",
                record: k,
            });
        }
        planes.push((n, d));
    }
    let leaf_count = lumps.bytes(LEAFS).len() / 48;
    let node_bytes = lumps.records(NODES, 36)?;
    let node_count = node_bytes.len();
    let mut nodes = Vec::with_capacity(node_count);
    for (k, r) in node_bytes.enumerate() {
        let plane = index("node", k, "plane", le_i32(r, 0), planes.len())? as u32;
        let mut child = [0i32; 2];
        for (s, c) in child.iter_mut().enumerate() {
            let v = le_i32(r, 4 + 4 * s);
            if v >= 0 {
                index("node", k, "child node", v, node_count)?;
            } else {
                index(
                    "node",
                    k,
                    "child leaf",
                    (-(v as i64) - 1).min(i32::MAX as i64) as i32,
                    leaf_count,
                )?;
            }
            *c = v;
        }
        nodes.push((plane, child[0], child[1]));
    }

    let vis = lumps.bytes(VISDATA);
    let (clusters, row, bits) = if vis.is_empty() {
        (0, 0, Vec::new())
    } else {
        let bad = |message: String| BspError::BadVisdata { message };
        if vis.len() < 8 {
            return Err(bad(format!(
                "lump is {} bytes, shorter than its 8-byte header",
                vis.len()
            )));
        }
        let (n, sz) = (le_i32(vis, 0), le_i32(vis, 4));
        if n < 0 || sz < 0 {
            return Err(bad(format!("negative size: {n} clusters × {sz} bytes")));
        }
        let need = n as u64 * sz as u64;
        if need > (vis.len() - 8) as u64 {
            return Err(bad(format!(
                "{n} clusters × {sz} bytes need {need} bytes, but the lump holds {}",
                vis.len() - 8
            )));
        }
        if (sz as u64) * 8 < n as u64 {
            return Err(bad(format!("{sz} bytes per cluster cannot hold {n} cluster bits")));
        }
        (n as usize, sz as usize, vis[8..8 + need as usize].to_vec())
    };
    let mut leaf_cluster = Vec::with_capacity(leaf_count);
    for (leaf, r) in lumps.records(LEAFS, 48)?.enumerate() {
        let c = le_i32(r, 0);
        if c < -1 || (clusters > 0 && c >= 0 && c as usize >= clusters) {
            return Err(BspError::BadLeafCluster {
                leaf,
                cluster: c,
                clusters,
            });
        }
        leaf_cluster.push(c);
    }
    Ok(Pvs {
        planes,
        nodes,
        leaf_cluster,
        clusters,
        row,
        bits,
    })
}
