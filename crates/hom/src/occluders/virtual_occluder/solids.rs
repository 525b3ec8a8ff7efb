//! Stage 1 of the virtual-occluder bake (Law & Tan 1999, section 4.2, the
//! stand-in inside the solid the original encloses): the solids. Vertices
//! are welded by position and the mesh split into connected components; a
//! component whose every edge has an even number of triangles bounds a
//! solid by parity, and so does one whose odd edges all lie in the mesh's
//! floor plane (closed there by a virtual cap). The rest are open parts,
//! kept whole or not at all.

use crate::occlusion::details::{number_welded, weld};
use crate::scene::Mesh;
use glam::Vec3;
use std::collections::HashMap;

/// An open component (it encloses nothing): kept whole or not at all.
pub(super) struct OpenPart {
    pub(super) triangles: Vec<u32>,
    /// Area shown along the three axes: Σ area · (|n.x| + |n.y| + |n.z|).
    pub(super) value: f32,
}

/// A mesh's connected components: the solid ones' triangles, and the open ones.
pub(super) struct Parts {
    /// `(triangle index, solid index)`.
    pub(super) solid: Vec<(u32, u32)>,
    pub(super) count: u32,
    pub(super) open: Vec<OpenPart>,
    /// Whether some solid is closed by a floor cap.
    pub(super) capped: bool,
    pub(super) floor: f32,
    /// Odd edges outside the floor plane, over all components.
    pub(super) open_edges: usize,
    /// Welded vertex positions, and every triangle over them.
    pub(super) welded_positions: Vec<Vec3>,
    pub(super) welded: Vec<[u32; 3]>,
}

impl Parts {
    pub(super) fn find(mesh: &Mesh) -> Parts {
        let p = mesh.positions();
        // Weld by position (-0.0 and 0.0 one point), numbered in order of first appearance.
        let (weld, welded_count) = number_welded(&weld(p));
        let tris: Vec<[u32; 3]> = mesh.triangles().iter().map(|t| t.map(|i| weld[i as usize])).collect();
        // Components over welded vertices.
        let mut parent: Vec<u32> = (0..welded_count as u32).collect();
        fn root(parent: &mut [u32], mut x: u32) -> u32 {
            while parent[x as usize] != x {
                parent[x as usize] = parent[parent[x as usize] as usize];
                x = parent[x as usize];
            }
            x
        }
        for t in &tris {
            let a = root(&mut parent, t[0]);
            for &v in &t[1..] {
                let b = root(&mut parent, v);
                if a != b {
                    parent[b as usize] = a;
                }
            }
        }
        let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
        for t in &tris {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                if a != b {
                    *edges.entry((a.min(b), a.max(b))).or_default() += 1;
                }
            }
        }
        let floor = mesh.bounds().min.y;
        let mut position = vec![Vec3::ZERO; welded_count];
        for (i, &w) in weld.iter().enumerate() {
            position[w as usize] = p[i];
        }
        // Per component root: does it have odd edges off the floor, or on it?
        let mut open: HashMap<u32, bool> = HashMap::new();
        let mut on_floor: HashMap<u32, bool> = HashMap::new();
        let mut open_edges = 0;
        for (&(a, b), &n) in &edges {
            if n % 2 == 1 {
                let r = root(&mut parent, a);
                if position[a as usize].y == floor && position[b as usize].y == floor {
                    on_floor.insert(r, true);
                } else {
                    open.insert(r, true);
                    open_edges += 1;
                }
            }
        }
        let mut solid_of: HashMap<u32, u32> = HashMap::new();
        let mut open_of: HashMap<u32, usize> = HashMap::new();
        let (mut solid, mut open_parts) = (Vec::new(), Vec::<OpenPart>::new());
        let mut capped = false;
        for (i, t) in tris.iter().enumerate() {
            let r = root(&mut parent, t[0]);
            if open.contains_key(&r) {
                let next = open_parts.len();
                let k = *open_of.entry(r).or_insert(next);
                if k == next {
                    open_parts.push(OpenPart {
                        triangles: Vec::new(),
                        value: 0.0,
                    });
                }
                let [a, b, c] = mesh.triangles()[i].map(|v| p[v as usize]);
                open_parts[k].triangles.push(i as u32);
                open_parts[k].value += (b - a).cross(c - a).abs().element_sum() * 0.5;
                continue;
            }
            capped |= on_floor.contains_key(&r);
            let next = solid_of.len() as u32;
            let s = *solid_of.entry(r).or_insert(next);
            solid.push((i as u32, s));
        }
        Parts {
            solid,
            count: solid_of.len() as u32,
            open: open_parts,
            capped,
            floor,
            open_edges,
            welded_positions: position,
            welded: tris,
        }
    }
}
